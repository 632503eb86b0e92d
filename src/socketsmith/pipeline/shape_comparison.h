#pragma once
/// @file shape_comparison.h
/// `socketsmith compare A B` as a library call: reads two shapes (limb scans, or a scan and a
/// socket), aligns and compares them (geometry::compare_shapes) and writes the deviation map (PNG
/// and VTK), the slice table (CSV), B aligned onto A (STL), the summary (compare.json) and one
/// HTML page (compare.html). docs/prosthetist_checks.md.

#include <filesystem>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "socketsmith/core/units.h"
#include "socketsmith/geometry/shape_compare.h"
#include "socketsmith/report/compare_report.h"

namespace socketsmith::pipeline {

struct CompareRunOptions {
  geometry::ShapeCompareOptions compare;          ///< kind of B, seed, crop, slice step, ICP
  std::optional<units::LengthUnit> units;         ///< of both files; empty = guessed from their size
  double scale = 1.0;                             ///< both shapes multiplied by this after reading, > 0
  /// The deviation map's colour range is ±range_m; 0 = automatic (1.25 × the larger of the 5th and
  /// 95th percentiles of |deviation|, rounded up to a round number) [m], ≥ 0.
  double range_m = 0.0;
  std::filesystem::path landmarks_a, landmarks_b;  ///< JSON {"PT": [x, y, z], …} in the files' unit (the landmark seed)
};

/// The comparison's report data from its result (the map refers to result.a, which must outlive
/// the page's writing). @p range_m as CompareRunOptions::range_m.
report::CompareReportData compare_report_data(const geometry::ShapeComparison& result, const std::string& a_label,
                                              const std::string& b_label, double range_m);

/// Reads @p a and @p b, compares them and writes every output into @p out (created). Returns the
/// summary, also written as compare.json.
/// @throws IoError for unreadable files; InvalidInputError (one line: the problem and the fix) for
///         bad options or shapes that cannot be compared (compare_shapes).
nlohmann::json run_compare(const std::filesystem::path& a, const std::filesystem::path& b,
                           const std::filesystem::path& out, const CompareRunOptions& options = {});

/// Named points from a JSON object {"CODE": [x, y, z], …} in @p unit, returned in metres × @p scale.
/// @throws IoError when the file cannot be read; InvalidInputError when it is not such an object.
std::vector<geometry::NamedPoint> read_landmark_file(const std::filesystem::path& path, units::LengthUnit unit,
                                                     double scale);

}  // namespace socketsmith::pipeline
