#pragma once
/// The design report's shared pieces (inside `report` only; `design_report.h` is the interface):
/// number formatting, the frame check, angle wrapping and the radar radius, used by the pictures
/// (`design_report.cpp`: radar chart, pressure maps), the paths (`design_report_paths.cpp`: sampling
/// and profiles) and the page (`design_report_html.cpp`). Why apart: each of the three is a
/// responsibility of its own; these few helpers are what they share.

#include <numbers>
#include <string>

#include "socketsmith/report/design_report.h"
#include "socketsmith/report/html.h"

namespace socketsmith::report::design_report_detail {

inline constexpr double kPi = std::numbers::pi;

/// A number as the report prints it (format_number, 3 significant digits by default).
inline std::string num(double v, int digits = 3) { return format_number(v, digits); }
/// One-line error unless the frame is finite and orthonormal (@p fn names the caller).
void validate_frame(const SurfaceFrame& f, const char* fn);
/// An angle wrapped into (−π, π].
double wrap_pi(double a);
/// The radar radius of an axis: 1 + (value − target) / scale (the target circle is r = 1).
double radar_radius(const RadarAxis& a);

}  // namespace socketsmith::report::design_report_detail
