#pragma once
/// @file slice_table.h
/// Two shapes measured slice by slice along the limb axis — the limb and its socket's cavity, or
/// two scans of one limb: circumference, cross-section area and slab volume at each level, their
/// change in per cent, as a table (HTML and CSV) and a plot. Plain data in SI units.

#include <filesystem>
#include <string>
#include <vector>

#include "socketsmith/report/html.h"
#include "socketsmith/report/plot.h"

namespace socketsmith::report {

/// One shape at one level.
struct SliceValues {
  double circumference_m = 0.0;  ///< [m]; NaN = the shape is not closed at this level (above a brim)
  double area_m2 = 0.0;          ///< [m²]
  double slab_volume_m3 = 0.0;   ///< between the previous level (or the distal end) and this one [m³]
};

/// One level of the table.
struct SliceRow {
  double h_m = 0.0;  ///< height above the distal end [m]
  SliceValues a, b;
};

/// The table of two shapes.
struct SliceTable {
  std::string title = "Slice measurements";
  std::string a_label = "limb";    ///< first shape's name in headers and legends
  std::string b_label = "socket";  ///< second shape's
  double step_m = 0.01;            ///< level spacing [m]
  std::vector<SliceRow> rows;      ///< ascending h
  std::string csv_file;            ///< the CSV beside the report ("" = not mentioned)
  std::string note;                ///< a line under the table ("" = none)
};

/// 100 (b − a) / a; NaN when a is 0 or either is not finite.
double percent_change(double a, double b);

/// Circumferences of both shapes against h (mm) and the change in per cent on a second plot.
/// @throws InvalidInputError when the table has no rows.
std::vector<Plot> slice_plots(const SliceTable& table);

/// Writes the table as CSV: h_mm, then per shape circumference_mm, area_cm2, slab_volume_cm3,
/// then the changes in per cent (NaN where a shape is not closed), atomically.
void write_slice_csv(const std::filesystem::path& path, const SliceTable& table);

/// Appends the table (with totals) and its plots to an HTML page under a <h2> of its title.
void append_slice_section(HtmlWriter& html, const SliceTable& table);

}  // namespace socketsmith::report
