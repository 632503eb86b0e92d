#pragma once
/// @file compare_report.h
/// The page of `socketsmith compare`: two shapes of one limb aligned and compared — the alignment
/// (seed, residual, the rigid motion found), the deviation map with its colour bar, its statistics,
/// the volumes below the crop and the slice-by-slice changes. One self-contained HTML page with
/// the same stylesheet (and print layout) as the design report. Plain data, SI units.

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "socketsmith/report/design_report.h"
#include "socketsmith/report/slice_table.h"

namespace socketsmith::report {

struct CompareReportData {
  std::string title = "Shape comparison";
  std::string generated;                 ///< software line ("" = omitted)
  std::string a_file, b_file;            ///< the two shapes as given
  std::vector<std::pair<std::string, std::string>> alignment;  ///< (name, value) rows: seed, residual, motion
  std::vector<std::pair<std::string, std::string>> deviation;  ///< (name, value) rows: mean, SD, range, coverage
  std::vector<std::pair<std::string, std::string>> volumes;    ///< (name, value) rows below the crop
  PressureMapData map;                   ///< the deviation on A [mm]; its surface must outlive the writing
  std::string map_caption;
  SliceTable slices;                     ///< A against B
  std::vector<std::string> notes;        ///< decisions taken automatically, one line each
};

/// The page (html.h's stylesheet; the map rendered by render_pressure_map).
/// @throws InvalidInputError as render_pressure_map, or when the slice table has no rows.
std::string render_compare_html(const CompareReportData& data);

/// Writes render_compare_html(@p data) to @p path atomically (nothing written on error).
void write_compare_html(const std::filesystem::path& path, const CompareReportData& data);

}  // namespace socketsmith::report
