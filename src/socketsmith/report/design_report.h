#pragma once
/// @file design_report.h
/// Pictures and the HTML report of the inverse socket design (thesis ch. 5, docs/method.md §3): the
/// radar chart of the seven constraint values, pressure maps on the stump, pressure profiles
/// along paths (anterior line, posterior line, a circumference), and one self-contained HTML
/// page a clinician can file or e-mail. Design results come in as plain data (this module does
/// not depend on `design`); every length is SI [m], pressure [Pa] unless a field says otherwise.

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/geometry/tri_mesh.h"
#include "socketsmith/report/plot.h"
#include "socketsmith/report/raster.h"
#include "socketsmith/report/slice_table.h"

namespace socketsmith::report {

// ------------------------------------------------------------------------------------------------
// Radar chart
// ------------------------------------------------------------------------------------------------

/// Colour of an axis (line, point, label) whose constraint holds.
inline constexpr Rgb kRadarOkColour{30, 150, 60};
/// Colour of an axis whose constraint does not hold.
inline constexpr Rgb kRadarFailColour{210, 40, 40};
/// Largest normalised radius drawn (the outer ring); values beyond are clamped to it and drawn
/// as a hollow point.
inline constexpr double kRadarMaxRadius = 2.0;

/// One axis of the radar chart: a constraint value with its target.
///
/// Normalisation: the point is drawn at radius r = 1 + (value − target) / scale, clamped to
/// [0, kRadarMaxRadius], so the target circle is r = 1 for every axis and a deviation moves the
/// point off it by deviation / scale. Dividing by the target itself would not work for the
/// zero-target values (F_x, F_y, T_x, T_y, T_z), hence a caller-given reference scale:
/// M g / 2 for the forces and the stability, M g / 2 × stump length for the torques
/// (seven_radar_axes()). With that choice F_z is drawn at r = F_z / (M g / 2) and a lateral
/// force of 10 % of half the body weight sits at r = 1.1 (or 0.9 when negative). The tolerance
/// band (target ± tolerance, or target..∞ for a lower bound) is marked by two ticks across the
/// axis.
struct RadarAxis {
  std::string name;       ///< "F_x" ... "stability" (ASCII is drawn as is; see to_ascii())
  std::string unit;       ///< "N", "N·m" (shown after the value)
  double value = 0;       ///< [unit], finite
  double target = 0;      ///< [unit], finite: 0, M g / 2 (F_z) or the stability minimum
  double tolerance = 0;   ///< [unit], ≥ 0: the constraint is |value − target| ≤ tolerance
  bool is_lower_bound = false;  ///< the constraint is value ≥ target (stability); tolerance unused
  double scale = 1;       ///< normalisation reference [unit], > 0, finite (see above)
  bool is_ok = false;     ///< whether the constraint holds: the caller's verdict, drawn as given
};

/// A radar chart: title, axes clockwise from the top.
struct RadarChart {
  std::string title = "Constraints";
  std::vector<RadarAxis> axes;  ///< 3..12 axes (7 for the design tool)
  int size_px = 300;            ///< radius of the outer ring (r = kRadarMaxRadius) [px], 80..2000
};

/// Inputs of the thesis's seven constraints (limb frame: x anterior, y medial, z axis proximal).
struct RadarInputs {
  Eigen::Vector3d force_n = Eigen::Vector3d::Zero();    ///< Σ nodal forces + friction in z [N]
  Eigen::Vector3d torque_nm = Eigen::Vector3d::Zero();  ///< Σ torques about C_I [N·m]
  double stability_n = 0;          ///< available friction Σ μ F_c cos θ [N]
  double body_mass_kg = 70;        ///< M [kg], > 0
  double prosthesis_mass_kg = 2;   ///< [kg], ≥ 0 (stability minimum = its weight)
  double stump_length_m = 0.15;    ///< [m], > 0 (torque scale = M g / 2 × length)
  double force_tolerance = 0.01;   ///< forces within this fraction of M g / 2, ≥ 0
  double torque_tolerance = 0.01;  ///< torques within this fraction of M g / 2 × length, ≥ 0
  double gravity = 9.81;           ///< g [m/s²], > 0
};

/// The seven axes F_x, F_y, F_z [N], T_x, T_y, T_z [N·m], stability [N] with the thesis's
/// targets (0, 0, M g / 2, 0, 0, 0, ≥ m_prosthesis g), tolerances, scales (M g / 2 for forces
/// and stability, M g / 2 × stump length for torques) and is_ok computed from them (the rule of
/// design/design_solver.h; a caller may overwrite is_ok with its own verdict).
/// @throws InvalidInputError when a mass, length, tolerance or g is out of range or not finite.
std::vector<RadarAxis> seven_radar_axes(const RadarInputs& inputs);

/// Number of axes whose is_ok is set.
int radar_axes_met(const std::vector<RadarAxis>& axes);

/// Renders @p chart on white: the title on top; grey rings at r = 0.5, 1.5, 2 and the target
/// circle r = 1 (dark blue, thicker); per axis a line from the centre to the outer ring, the
/// tolerance ticks, the value point and a two-line label "name / value unit", all in
/// kRadarOkColour or kRadarFailColour; the value polygon filled translucent blue; a legend
/// line at the bottom: "all constraints met" or "k of n met (failing: ...)".
/// @throws InvalidInputError when the axis count or size is out of range, or an axis has a
///         non-finite value/target, a negative tolerance or a scale that is not > 0.
Image render_radar_chart(const RadarChart& chart);

/// Pixel position (x, y) in render_radar_chart(@p chart)'s image of the point at normalised
/// radius @p r on axis @p axis (for tests and hit-testing in a GUI).
/// @throws InvalidInputError when axis is out of range, or as render_radar_chart.
Eigen::Vector2d radar_axis_pixel(const RadarChart& chart, int axis, double r);

/// Writes render_radar_chart(@p chart) as PNG, atomically.
void write_radar_chart(const std::filesystem::path& path, const RadarChart& chart);

// ------------------------------------------------------------------------------------------------
// Pressure maps
// ------------------------------------------------------------------------------------------------

/// The limb frame as plain vectors: the origin at the distal end on the axis, unit axis (distal
/// → proximal), unit anterior and medial directions (perpendicular to the axis and each other).
/// Cylindrical coordinates: h = (p − origin)·axis, θ = atan2((p − o)·medial, (p − o)·anterior)
/// (0 anterior, +90° medial, 180° posterior, −90° lateral), ρ = distance to the axis.
struct SurfaceFrame {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();    ///< [m]
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();      ///< unit
  Eigen::Vector3d anterior = Eigen::Vector3d::UnitX();  ///< unit, ⟂ axis
  Eigen::Vector3d medial = Eigen::Vector3d::UnitY();    ///< unit, ⟂ axis and anterior
};

/// The SurfaceFrame of a geometry::LimbFrame (its medial() depends on the side).
SurfaceFrame surface_frame(const geometry::LimbFrame& frame);

/// A landmark shown on a map.
struct MapLandmark {
  std::string code;  ///< "PT", "FH", ...
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< [m]
  bool is_estimated = false;  ///< placed automatically (drawn magenta; given ones white)
};

/// A value field on the stump surface, e.g. the applied pressure [kPa] (range 0..max), the
/// pressure / threshold ratio [-] (range 0..1.2) or the threshold map [kPa].
struct PressureMapData {
  const geometry::TriMesh* surface = nullptr;  ///< not owned; at least one triangle
  /// One value per vertex (#V) in the unit of value_label. NaN = no data (e.g. above the brim):
  /// triangles touching such a vertex are drawn in no_data_colour.
  std::vector<double> values;
  /// Colour range. value_max ≤ value_min (the default 0, 0) = automatic: from min(0, smallest
  /// finite value) to the largest finite value.
  double value_min = 0;
  double value_max = 0;
  std::string value_label = "kPa";   ///< unit above the colour bar
  Colormap colormap = Colormap::Pressure;
  Rgb no_data_colour{170, 170, 170};
  SurfaceFrame frame;
  std::vector<MapLandmark> landmarks;
  /// Brim line: closed polyline [m] drawn as a dark tube (hidden where the stump hides it);
  /// empty = none. Typically the points of the brim curve on the skin.
  std::vector<Eigen::Vector3d> brim;
  double brim_tube_radius_m = 1.5e-3;  ///< [m], > 0
  std::string title = "Applied pressure";
  int view_px = 320;  ///< side of each view [px], 64..2048
};

/// Four views of the field side by side, each view_px wide, in this order: anterior (seen from
/// the front), medial, posterior, lateral; axis up; one common scale; title on top, captions
/// below, the colour bar with value_label on the right (raster.h render_views()). Landmarks are
/// markers labelled with their code, drawn where the stump does not hide them.
/// @throws InvalidInputError when the surface is missing or has no triangle, the value count is
///         not #V, a fixed range is not finite, the frame is not orthonormal, or as render_views.
Image render_pressure_map(const PressureMapData& data);

/// Writes render_pressure_map(@p data) as PNG, atomically.
void write_pressure_map(const std::filesystem::path& path, const PressureMapData& data);

// ------------------------------------------------------------------------------------------------
// Paths and profiles
// ------------------------------------------------------------------------------------------------

/// Which path on the surface.
enum class PathKind {
  Vertical,         ///< the line θ = theta_rad, from distal to proximal (s = h [m])
  Circumferential,  ///< the circumference h = height_m, from θ = theta_rad towards medial
                    ///< (s = angle from theta_rad [rad], in [0, 2π))
};

/// A path on the stump surface in the limb's cylindrical frame.
struct PathSpec {
  PathKind kind = PathKind::Vertical;
  double theta_rad = 0;  ///< Vertical: the line's angle; Circumferential: where s = 0 [rad]
  double height_m = 0;   ///< Circumferential: h of the circumference [m]
  /// Half-width of the band [m], > 0: a point belongs to the path when its distance to it,
  /// |Δθ|·ρ (Vertical) or |Δh| (Circumferential), is ≤ band_m. Half a node spacing picks
  /// one row/column of surface nodes.
  double band_m = 2.5e-3;
  /// > 0: of the points in the band, keep one per bin of this length along the path (Δh for a
  /// vertical line, mean ρ × Δs for a circumference), the one nearest the path; bins are
  /// greedy (a bin starts at its first sample): use a bit less than the node spacing.
  /// 0 = keep all [m].
  double bin_m = 0;
};

/// One point of a path.
struct PathSample {
  double s = 0;       ///< path coordinate: h [m] (Vertical) or angle from theta_rad [rad]
  int index = -1;     ///< index of the point in the input
  double value = 0;   ///< the input value at that point (may be NaN)
  double distance_m = 0;  ///< distance to the path (|Δθ|·ρ or |Δh|) [m]
  double rho_m = 0, theta_rad = 0, h_m = 0;  ///< cylindrical coordinates of the point
};

/// The points of @p points within the band of @p path (optionally thinned to the nearest per
/// bin), sorted by s (ties by distance). A pure function: the same sampling serves the design
/// report and the comparison with CalculiX.
/// @param points surface nodes [m], #P
/// @param values one value per point (#P, any unit), or empty (then value = NaN)
/// @throws InvalidInputError when the value count is neither 0 nor #P, a point or the frame is
///         not finite, the frame is not orthonormal, band_m is not > 0, or bin_m < 0.
std::vector<PathSample> sample_path(const std::vector<Eigen::Vector3d>& points,
                                    const std::vector<double>& values, const SurfaceFrame& frame,
                                    const PathSpec& path);

/// One of the thesis's comparison paths.
struct NamedPath {
  std::string key;    ///< "front", "back", "mid"
  std::string label;  ///< "front line (through the patellar tendon)", "back line", "circumference at mid-stump"
  PathSpec spec;
};

/// The thesis's three paths (ch. 3.6, 5.5) on a stump: the front vertical line at
/// @p front_theta_rad (through the patellar tendon), the back line opposite it, the
/// circumference at @p mid_height_m (s from θ = 0); band 0.75 and bins 0.8 of the mean node
/// spacing (mean √area of @p node_areas_m2), so each path picks one row of nodes. The design
/// report and the CalculiX comparison sample the same nodes.
std::vector<NamedPath> thesis_paths(double front_theta_rad, double mid_height_m,
                                    const std::vector<double>& node_areas_m2);

/// Linear interpolation of the samples' values at path coordinate @p s (samples sorted by s,
/// as sample_path returns them); NaN outside [s_first, s_last] or when there are no samples.
double interpolate_path(const std::vector<PathSample>& samples, double s);

/// A pressure profile along a path, in display units.
struct PathProfile {
  std::string name;      ///< "anterior line", "posterior line", "circumference at mid-stump"
  std::string s_label;   ///< x-axis label, e.g. "height above the distal end [mm]"
  std::vector<double> s;             ///< path coordinate in display units
  std::vector<double> pressure_kpa;  ///< applied pressure [kPa], same size as s (NaN = gap)
  std::vector<double> threshold_kpa; ///< pain threshold [kPa], same size as s, or empty
  double s_min = 0;  ///< x-axis range in display units; s_max ≤ s_min = from the data
  double s_max = 0;
};

/// A profile from samples of sample_path(): s in mm (Vertical) or degrees (Circumferential,
/// x axis 0..360), pressure and threshold read at each sample's index from per-point fields in Pa.
/// @param threshold_pa per point (#P) or empty
/// @throws InvalidInputError when a sample's index is outside the fields.
PathProfile make_path_profile(const std::string& name, PathKind kind,
                              const std::vector<PathSample>& samples,
                              const std::vector<double>& pressure_pa,
                              const std::vector<double>& threshold_pa);

/// The profile as an svg_plot Plot: applied pressure (solid, with markers) and the threshold
/// (dashed red), y from 0 to a round value above 1.1 × the largest finite value.
/// @throws InvalidInputError when the sizes of s, pressure and threshold differ.
Plot path_profile_plot(const PathProfile& profile);

// ------------------------------------------------------------------------------------------------
// HTML report
// ------------------------------------------------------------------------------------------------

/// Patient data shown in the report.
struct ReportPatient {
  std::string id;                   ///< patient identifier or name ("" = omitted)
  double body_mass_kg = 70;         ///< M [kg]
  double prosthesis_mass_kg = 2;    ///< [kg]
  double tissue_youngs_modulus_pa = 60e3;  ///< E [Pa] (shown in kPa)
  double friction = 0.5;            ///< μ skin–socket [-]
  std::string note;                 ///< free text (escaped)
};

/// One pressure spot, SI units (shown in kPa, degrees and mm). Which fields are shown depends
/// on the type (thesis Table 6): "cos2": A, θ0, R_θ, h0, R_h; "sig2": A, θ1, θ2, λ_θ, h1, h2,
/// λ_h; "cos-sig": A, θ0, R_θ, h1, h2, λ_h; "grad": A, h1, h2; any other type: A only.
struct ReportSpot {
  std::string name;
  std::string type = "cos2";
  double amplitude_pa = 0;
  double theta0_rad = 0, r_theta_rad = 0;
  double h0_m = 0, r_h_m = 0;
  double theta1_rad = 0, theta2_rad = 0, lambda_theta_per_rad = 0;
  double h1_m = 0, h2_m = 0, lambda_h_per_m = 0;
  bool is_enabled = true;
};

/// A brim key point (θ, h) of the Akima-spline brim line.
struct ReportBrimPoint {
  double theta_rad = 0;
  double h_m = 0;
};

/// Circumference of the limb and the socket at one level.
struct ReportCircumference {
  double height_m = 0;           ///< h above the distal end [m]
  double limb_m = 0;             ///< undeformed limb [m]
  double socket_m = 0;           ///< socket inner surface [m]
};

/// Socket measurements.
struct ReportSocket {
  bool has_socket = false;        ///< false = section says "no socket built"
  double limb_volume_m3 = 0;      ///< below the brim, undeformed [m³]
  double socket_volume_m3 = 0;    ///< enclosed by the socket's inner surface [m³]
  double thickness_m = 0.005;     ///< wall [m]
  /// Measured wall: the distance from the outer surface to the inner wall [m] (0 = not measured).
  double min_thickness_m = 0;
  double median_thickness_m = 0;
  double max_thickness_m = 0;
  bool has_thickness_map = false;
  PressureMapData thickness_map;  ///< the wall thickness on the socket (its surface must outlive the report's writing)
  std::vector<std::pair<std::string, std::string>> details;  ///< extra (name, value) rows: platform, attachment
  std::vector<ReportCircumference> circumferences;
  std::string stl_file;           ///< socket STL file name ("" = omitted)
};

/// Summary of a run of the optimiser (or of a single design solve).
struct ReportRun {
  bool has_run = false;   ///< false = the section says "not run"
  bool converged = false;
  int iterations = 0;
  double residual = 0;    ///< final objective / residual (unit as the producer defines it)
  double seconds = 0;     ///< wall time [s]
  std::string message;
  std::vector<std::pair<std::string, std::string>> details;  ///< extra (name, value) rows
};

/// How well delivered pressures match the designed ones in one region, at one stage.
struct ReportAgreement {
  std::string region;            ///< "below the brim", "front line", ...
  std::string stage;             ///< "open loop", "closed loop"
  int count = 0;                 ///< skin nodes compared
  double target_mean_pa = 0;     ///< designed mean [Pa]
  double delivered_mean_pa = 0;  ///< delivered mean [Pa]
  double mae_pa = 0;             ///< mean |delivered − designed| [Pa]
  double p99_pa = 0;             ///< 99th percentile of |delivered − designed| [Pa]
  double max_error_pa = 0;       ///< largest |delivered − designed| [Pa]
  double r = 0;                  ///< Pearson R (NaN: a field is constant)
  double target_sd_pa = 0;       ///< spread of the designed field [Pa] (R of a flat field measures noise)
};

/// The pressures the socket delivers once donned and stood on, against the design (the closed loop).
struct ReportDelivery {
  bool has_delivery = false;     ///< false = section omitted
  std::string summary;           ///< how the loop ended, one line
  std::vector<ReportAgreement> rows;
  std::vector<PressureMapData> maps;  ///< designed, open-loop, closed-loop, difference
  std::vector<Plot> plots;            ///< designed vs delivered along the paths
  std::vector<std::pair<std::string, std::string>> details;  ///< extra (name, value) rows
};

/// The rectification at one landmark: how far the socket's inner wall lies from the limb's skin,
/// along the ray from the limb axis through the landmark (radially), or along the axis at the
/// distal end.
struct ReportRectificationPoint {
  std::string code;              ///< "PT", ...
  std::string name;              ///< "patellar tendon", ...
  double theta_rad = 0, h_m = 0; ///< where, in the limb frame
  double rectification_m = 0;    ///< socket − limb [m] (< 0: indentation); NaN above the brim (no wall)
  bool is_axial = false;         ///< measured along the axis (the distal end)
};

/// The rectification chart: socket minus limb, radially (along the axis at the distal end); < 0:
/// indentation, the socket presses the tissue in; > 0: relief.
struct ReportRectification {
  bool has_rectification = false;  ///< false = section omitted
  std::string source;              ///< what the socket wall is ("the socket's inner wall", ...)
  std::vector<ReportRectificationPoint> landmarks;
  double min_m = 0, max_m = 0, mean_m = 0;  ///< over the skin below the brim (mean area-weighted) [m]
  bool has_map = false;
  PressureMapData map;             ///< the rectification on the skin [mm], a diverging colour map
};

/// One level of the sock-ply study: the designed socket donned on the limb shrunk or grown.
struct ReportSockPlyLevel {
  double volume_change = 0;       ///< fraction of the limb's volume (−0.04 = shrunk by 4 %)
  double skin_offset_m = 0;       ///< the uniform normal offset of the skin that gives it [m]
  bool stood = false;             ///< the socket took half the body weight
  double stood_offset_m = 0;      ///< where it stood, relative to its designed pose along the axis [m]
  double sink_m = 0;              ///< how much deeper the limb sits than at its designed volume [m] (< 0: it rises)
  double peak_ratio = 0;          ///< max contact pressure / pain threshold below the brim
  double peak_pressure_pa = 0;    ///< [Pa]
  double distal_mean_pa = 0;      ///< area-weighted mean contact pressure over the distal end [Pa]
  double distal_peak_pa = 0;      ///< [Pa]
  int contact_nodes = 0;
  std::string constraints;        ///< "all hold" or the failing ones
  bool comfort_ok = false, stability_ok = false;
  std::string message;            ///< why it did not stand, when it did not
};

/// The sock-ply sensitivity study.
struct ReportSockPly {
  bool has_study = false;         ///< false = section omitted
  std::string summary;            ///< one line
  std::vector<ReportSockPlyLevel> levels;  ///< ascending volume change, the designed volume (0) included
  std::vector<PressureMapData> maps;       ///< contact pressure at chosen levels, one scale
  std::vector<Plot> plots;                 ///< sink and peak ratio against the volume change
};

/// Everything in the report. Pictures are rendered from this data when the report is written.
/// The axial load carried by one region of the skin (design/load_regions.h).
struct ReportRegionLoad {
  std::string name;            ///< "ischial / gluteal"
  double share = 0;            ///< of the socket's axial load F_z [-]
  double axial_n = 0;          ///< [N]: normal forces' axial part + available friction
  double friction_n = 0;       ///< of which the friction [N]
  double area_m2 = 0;          ///< loaded area [m²]
  double mean_pressure_pa = 0;
  double peak_pressure_pa = 0;
  bool is_highlighted = false; ///< the region the brim template is meant to load (shown first, bold)
};

struct DesignReportData {
  std::string title = "Socket design report";
  std::string generated;  ///< date / software version line ("" = omitted; no clock is read)
  ReportPatient patient;
  // Inputs
  std::string limb_file;
  std::string limb_type;  ///< "transtibial", "transfemoral"
  std::string side;       ///< "right", "left"
  int mesh_nodes = 0;
  std::string model;      ///< "MSS-CS", ...
  std::vector<ReportSpot> spots;
  std::string brim_template;  ///< "PTB", ...
  std::vector<ReportBrimPoint> brim_key_points;
  // Results
  RadarChart radar;  ///< rendered + tabulated; no axes = section omitted
  /// Maps (applied pressure, ratio, threshold...), rendered in this order. Each must be valid.
  std::vector<PressureMapData> maps;
  std::vector<PathProfile> profiles;
  double max_pressure_ratio = 0;   ///< max applied (or requested) pressure / threshold [-]
  bool has_max_ratio_position = false;
  Eigen::Vector3d max_ratio_position = Eigen::Vector3d::Zero();  ///< where [m]
  double max_pressure_pa = 0;      ///< largest applied pressure [Pa]
  std::vector<MapLandmark> landmarks;  ///< for "nearest landmark zone" (else maps[0]'s)
  std::vector<ReportRegionLoad> region_loads;  ///< "Axial load by region"; empty = section omitted
  std::string region_note;             ///< a line under that table (e.g. the template's floor)
  ReportSocket socket;
  ReportRectification rectification;
  SliceTable slices;               ///< limb against socket cavity; no rows = section omitted
  ReportDelivery delivery;
  ReportSockPly sock_ply;
  ReportRun optimiser;
  ReportRun solver;
  std::vector<std::string> warnings;  ///< "bones estimated", "anterior estimated", ...
};

/// The report as one self-contained HTML5 document (pictures embedded as base64 PNG / SVG data
/// URIs, inline CSS with a print stylesheet for A4, html.h): patient, inputs (limb, mesh, model,
/// spots in kPa/degrees/mm, brim), the radar chart and a table of the constraint values with
/// targets and pass/fail, the largest pressure/threshold ratio and the nearest landmark zone,
/// the axial load by region, pressure maps, path profiles, socket measurements (volume, circumferences with % reduction,
/// thickness), the rectification chart, the slice measurements, the delivered pressures against
/// the design (when the closed loop ran), the sock-ply study (when it ran), optimiser and solver
/// summaries, warnings. Every string is HTML-escaped.
/// @throws InvalidInputError as render_radar_chart / render_pressure_map / path_profile_plot.
std::string render_design_report_html(const DesignReportData& data);

/// Writes render_design_report_html(@p data) to @p path atomically: on any error nothing is
/// written and an earlier file is left as it was.
void write_design_report_html(const std::filesystem::path& path, const DesignReportData& data);

// ------------------------------------------------------------------------------------------------
// Small helpers (public for tests and other reports)
// ------------------------------------------------------------------------------------------------

/// Escapes &, <, >, " and ' for HTML text and attributes.
std::string html_escape(std::string_view text);

/// Standard base64 (RFC 4648, with '=' padding).
std::string base64_encode(std::string_view bytes);

}  // namespace socketsmith::report
