// Design report: radar colours per axis, pressure map colours per view, path sampling on an
// analytic cylinder, the HTML page (values, escaping, embedded pictures, atomic write).
#include "socketsmith/report/design_report.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "socketsmith/core/errors.h"
#include "socketsmith/report/svg_plot.h"

namespace socketsmith::report {
namespace {

namespace fs = std::filesystem;
using Eigen::Vector3d;
constexpr double kPi = std::numbers::pi;
constexpr double kG = 9.81;

RadarInputs balanced_inputs() {
  RadarInputs in;
  in.body_mass_kg = 70;
  in.prosthesis_mass_kg = 2;
  in.stump_length_m = 0.15;
  in.force_n = {0.0, 0.0, 0.5 * 70 * kG};
  in.torque_nm = {0.0, 0.0, 0.0};
  in.stability_n = 60;
  return in;
}

Rgb pixel_at(const Image& img, const Eigen::Vector2d& p) {
  return img.at(static_cast<int>(std::floor(p.x())), static_cast<int>(std::floor(p.y())));
}

int count_colour(const Image& img, Rgb c) {
  int n = 0;
  for (const auto& p : img.pixels) n += p == c ? 1 : 0;
  return n;
}

TEST(RadarChart, seven_axes_have_the_thesis_targets_and_verdicts) {
  auto in = balanced_inputs();
  auto axes = seven_radar_axes(in);
  ASSERT_EQ(axes.size(), 7u);
  EXPECT_EQ(radar_axes_met(axes), 7);
  EXPECT_NEAR(axes[2].target, 0.5 * 70 * kG, 1e-9);
  EXPECT_NEAR(axes[2].scale, 0.5 * 70 * kG, 1e-9);
  EXPECT_NEAR(axes[3].scale, 0.5 * 70 * kG * 0.15, 1e-9);
  EXPECT_NEAR(axes[6].target, 2 * kG, 1e-9);
  EXPECT_TRUE(axes[6].is_lower_bound);
  in.force_n.y() = 0.02 * 0.5 * 70 * kG;  // 2 % > 1 % tolerance
  in.torque_nm.z() = 0.005 * 0.5 * 70 * kG * 0.15;  // 0.5 %: within
  in.stability_n = 10;                               // < 2 kg g
  axes = seven_radar_axes(in);
  EXPECT_FALSE(axes[1].is_ok);
  EXPECT_TRUE(axes[5].is_ok);
  EXPECT_FALSE(axes[6].is_ok);
  EXPECT_EQ(radar_axes_met(axes), 5);
  in.body_mass_kg = 0;
  EXPECT_THROW(seven_radar_axes(in), InvalidInputError);
}

TEST(RadarChart, failing_axis_is_drawn_red_and_the_others_green) {
  RadarChart met;
  met.axes = seven_radar_axes(balanced_inputs());
  met.size_px = 150;
  const Image ok_img = render_radar_chart(met);
  // Not blank.
  EXPECT_LT(count_colour(ok_img, Rgb{255, 255, 255}), static_cast<int>(ok_img.pixels.size() * 0.95));
  for (int k = 0; k < 7; ++k) EXPECT_EQ(pixel_at(ok_img, radar_axis_pixel(met, k, 1.7)), kRadarOkColour) << k;
  EXPECT_EQ(count_colour(ok_img, kRadarFailColour), 0);

  RadarChart one = met;
  auto in = balanced_inputs();
  in.force_n.x() = 0.3 * 0.5 * 70 * kG;  // F_x off by 30 % of M g / 2 → r = 1.3
  one.axes = seven_radar_axes(in);
  ASSERT_FALSE(one.axes[0].is_ok);
  const Image bad_img = render_radar_chart(one);
  EXPECT_EQ(pixel_at(bad_img, radar_axis_pixel(one, 0, 1.7)), kRadarFailColour);
  for (int k = 1; k < 7; ++k) EXPECT_EQ(pixel_at(bad_img, radar_axis_pixel(one, k, 1.7)), kRadarOkColour) << k;
  EXPECT_GT(count_colour(bad_img, kRadarFailColour), 100);  // axis, point, label, legend

  // The zero-target value is visible: its point (a dark-outlined disc) sits at r = 1.3, not 1.
  const Eigen::Vector2d c = radar_axis_pixel(one, 0, 0.0);
  const Eigen::Vector2d p13 = radar_axis_pixel(one, 0, 1.3);
  EXPECT_NEAR((p13 - c).norm(), 1.3 / kRadarMaxRadius * one.size_px, 1e-9);
  // 7 px from the point's centre along the axis normal is its dark outline in the failing
  // chart, plain axis-free background in the met chart.
  const Eigen::Vector2d side = p13 + Eigen::Vector2d(7.0, 0.0);
  EXPECT_NE(pixel_at(bad_img, side), pixel_at(ok_img, side));
}

TEST(RadarChart, bad_input_is_rejected) {
  RadarChart chart;
  chart.axes = seven_radar_axes(balanced_inputs());
  chart.axes[3].scale = 0;
  EXPECT_THROW(render_radar_chart(chart), InvalidInputError);
  chart.axes.resize(2);
  EXPECT_THROW(render_radar_chart(chart), InvalidInputError);
}

/// Open tube of radius r along +z from 0 to len, outward-oriented.
geometry::TriMesh cylinder(double r, double len, int n_around, int n_up) {
  geometry::TriMesh m;
  for (int j = 0; j <= n_up; ++j)
    for (int i = 0; i < n_around; ++i) {
      const double phi = 2 * kPi * i / n_around;
      m.vertices.emplace_back(r * std::cos(phi), r * std::sin(phi), len * j / n_up);
    }
  auto id = [&](int i, int j) { return j * n_around + (i % n_around); };
  for (int j = 0; j < n_up; ++j)
    for (int i = 0; i < n_around; ++i) {
      m.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return m;
}

bool is_red(Rgb c) { return c.r > 150 && c.g < 90 && c.b < 90; }

int count_in_view(const Image& img, int view, int view_px, bool (*pred)(Rgb)) {
  int n = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = view * view_px; x < (view + 1) * view_px; ++x) n += pred(img.at(x, y)) ? 1 : 0;
  return n;
}

TEST(PressureMap, hot_anterior_spot_is_red_in_the_anterior_view_only) {
  const auto mesh = cylinder(0.05, 0.2, 48, 20);
  PressureMapData data;
  data.surface = &mesh;
  data.frame = SurfaceFrame{};  // axis z, anterior x, medial y
  for (const auto& v : mesh.vertices) data.values.push_back(v.x() > 0.05 * std::cos(0.6) ? 100.0 : 10.0);
  data.value_min = 0;
  data.value_max = 100;
  data.view_px = 128;
  MapLandmark pt;
  pt.code = "PT";
  pt.position = {0.05, 0.0, 0.1};
  pt.is_estimated = true;
  data.landmarks = {pt};
  const Image img = render_pressure_map(data);
  ASSERT_GE(img.width, 4 * 128);
  EXPECT_GT(count_in_view(img, 0, 128, is_red), 300);  // anterior
  EXPECT_EQ(count_in_view(img, 2, 128, is_red), 0);    // posterior
  // The estimated landmark's magenta disc: in front, hidden from the back.
  auto magenta = [](Rgb c) { return c == Rgb{220, 60, 220}; };
  EXPECT_GT(count_in_view(img, 0, 128, +magenta), 10);
  EXPECT_EQ(count_in_view(img, 2, 128, +magenta), 0);

  // Above-brim part (NaN) is grey, with a brim polyline drawn dark.
  PressureMapData brim = data;
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
    if (mesh.vertices[i].z() > 0.15) brim.values[i] = std::numeric_limits<double>::quiet_NaN();
  for (int i = 0; i < 36; ++i) {
    const double phi = 2 * kPi * i / 36;
    brim.brim.emplace_back(0.0505 * std::cos(phi), 0.0505 * std::sin(phi), 0.15);
  }
  const Image grey_img = render_pressure_map(brim);
  auto greyish = [](Rgb c) { return c.r == c.g && c.g == c.b && c.r > 80 && c.r < 250; };
  EXPECT_GT(count_in_view(grey_img, 2, 128, +greyish), count_in_view(img, 2, 128, +greyish) + 300);
  auto dark = [](Rgb c) { return c.r < 30 && c.g < 30 && c.b < 30; };
  EXPECT_GT(count_in_view(grey_img, 1, 128, +dark), count_in_view(img, 1, 128, +dark) + 40);

  PressureMapData empty = data;
  const geometry::TriMesh none;
  empty.surface = &none;
  empty.values.clear();
  EXPECT_THROW(render_pressure_map(empty), InvalidInputError);
  PressureMapData wrong = data;
  wrong.values.pop_back();
  EXPECT_THROW(render_pressure_map(wrong), InvalidInputError);
}

/// Points on a cylinder ρ = 0.05, θ every 5°, h every 5 mm (0..200 mm), in a rotated frame.
struct CylinderPoints {
  std::vector<Vector3d> points;
  std::vector<double> values;
  SurfaceFrame frame;
};

CylinderPoints rotated_cylinder_points() {
  CylinderPoints c;
  const Eigen::Matrix3d rot =
      Eigen::AngleAxisd(0.7, Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  c.frame.origin = {0.1, -0.2, 0.3};
  c.frame.axis = rot * Vector3d::UnitZ();
  c.frame.anterior = rot * Vector3d::UnitX();
  c.frame.medial = rot * Vector3d::UnitY();
  for (int j = 0; j <= 40; ++j)
    for (int i = 0; i < 72; ++i) {
      const double th = 2 * kPi * i / 72, h = 0.005 * j;
      c.points.push_back(c.frame.origin + h * c.frame.axis +
                         0.05 * (std::cos(th) * c.frame.anterior + std::sin(th) * c.frame.medial));
      c.values.push_back(1000 * h + std::cos(th));
    }
  return c;
}

TEST(SamplePath, vertical_lines_and_circumference_on_an_analytic_cylinder) {
  const auto c = rotated_cylinder_points();
  PathSpec front;
  front.theta_rad = 0;
  front.band_m = 1e-3;  // neighbouring column is 4.4 mm away
  const auto a = sample_path(c.points, c.values, c.frame, front);
  ASSERT_EQ(a.size(), 41u);
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_NEAR(a[k].theta_rad, 0.0, 1e-9);
    EXPECT_NEAR(a[k].s, 0.005 * k, 1e-9);
    EXPECT_NEAR(a[k].h_m, a[k].s, 1e-12);
    EXPECT_NEAR(a[k].rho_m, 0.05, 1e-9);
    EXPECT_EQ(a[k].value, c.values[a[k].index]);
    if (k > 0) {
      EXPECT_LT(a[k - 1].s, a[k].s);
    }
  }
  PathSpec back = front;
  back.theta_rad = kPi;  // across the ±180° seam
  const auto b = sample_path(c.points, c.values, c.frame, back);
  ASSERT_EQ(b.size(), 41u);
  for (const auto& s : b) EXPECT_NEAR(std::abs(s.theta_rad), kPi, 1e-9);

  // A wider band catches three columns; one per 4 mm bin keeps the nearest (θ = 0).
  PathSpec wide = front;
  wide.band_m = 5e-3;
  EXPECT_EQ(sample_path(c.points, c.values, c.frame, wide).size(), 3u * 41u);
  wide.bin_m = 4e-3;
  const auto thin = sample_path(c.points, c.values, c.frame, wide);
  ASSERT_EQ(thin.size(), 41u);
  for (const auto& s : thin) EXPECT_NEAR(s.theta_rad, 0.0, 1e-9);

  PathSpec ring;
  ring.kind = PathKind::Circumferential;
  ring.height_m = 0.1;
  ring.band_m = 1e-3;
  const auto r = sample_path(c.points, c.values, c.frame, ring);
  ASSERT_EQ(r.size(), 72u);
  EXPECT_NEAR(r.front().s, 0.0, 1e-9);
  for (std::size_t k = 0; k < r.size(); ++k) {
    EXPECT_NEAR(r[k].h_m, 0.1, 1e-9);
    EXPECT_NEAR(r[k].s, 2 * kPi * k / 72, 1e-9);
    if (k > 0) {
      EXPECT_LT(r[k - 1].s, r[k].s);
    }
  }
  EXPECT_NEAR(r[18].theta_rad, kPi / 2, 1e-9);  // a quarter turn from anterior is medial
  // Interpolation along the front line: value = 1000 h + 1.
  EXPECT_NEAR(interpolate_path(a, 0.0125), 1000 * 0.0125 + 1, 1e-9);
  EXPECT_TRUE(std::isnan(interpolate_path(a, 0.3)));

  std::vector<double> short_values(3, 0.0);
  EXPECT_THROW(sample_path(c.points, short_values, c.frame, front), InvalidInputError);
  SurfaceFrame skew = c.frame;
  skew.medial = skew.anterior;
  EXPECT_THROW(sample_path(c.points, c.values, skew, front), InvalidInputError);
}

TEST(PathProfile, profile_in_clinical_units_and_plot_with_both_curves) {
  const auto c = rotated_cylinder_points();
  PathSpec front;
  front.band_m = 1e-3;
  const auto a = sample_path(c.points, {}, c.frame, front);
  std::vector<double> pressure(c.points.size(), 20e3), threshold(c.points.size(), 60e3);
  const auto prof = make_path_profile("anterior line", PathKind::Vertical, a, pressure, threshold);
  ASSERT_EQ(prof.s.size(), 41u);
  EXPECT_NEAR(prof.s.back(), 200.0, 1e-9);  // mm
  EXPECT_NEAR(prof.pressure_kpa[3], 20.0, 1e-12);
  EXPECT_NEAR(prof.threshold_kpa[3], 60.0, 1e-12);
  const Plot plot = path_profile_plot(prof);
  ASSERT_TRUE(plot.y_max.has_value());
  EXPECT_GE(*plot.y_max, 1.1 * 60.0);  // the threshold line is not on the frame
  EXPECT_LE(*plot.y_max, 1.5 * 60.0);
  const std::string svg = render_svg(plot);
  EXPECT_NE(svg.find("applied pressure"), std::string::npos);
  EXPECT_NE(svg.find("pain threshold"), std::string::npos);
  std::vector<double> too_short(2, 0.0);
  EXPECT_THROW(make_path_profile("x", PathKind::Vertical, a, too_short, {}), InvalidInputError);
}

TEST(ReportHelpers, base64_html_escape_and_ascii) {
  EXPECT_EQ(base64_encode(""), "");
  EXPECT_EQ(base64_encode("f"), "Zg==");
  EXPECT_EQ(base64_encode("fo"), "Zm8=");
  EXPECT_EQ(base64_encode("foo"), "Zm9v");
  EXPECT_EQ(base64_encode("foobar"), "Zm9vYmFy");
  EXPECT_EQ(base64_encode(std::string("\xff\x00\x10", 3)), "/wAQ");
  EXPECT_EQ(html_escape("a<b & \"c\" 'd'>"), "a&lt;b &amp; &quot;c&quot; &#39;d&#39;&gt;");
  EXPECT_EQ(to_ascii("N·m ≥ 2 μ θ"), "N.m >= 2 u theta");
  EXPECT_EQ(to_ascii("a☃b"), "a?b");
  const Image img(3, 2, Rgb{1, 2, 3});
  EXPECT_EQ(encode_png(img).substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
}

struct ReportFixture : ::testing::Test {
  fs::path dir;
  geometry::TriMesh mesh = cylinder(0.05, 0.2, 24, 10);
  void SetUp() override {
    dir = fs::temp_directory_path() / ("socketsmith_design_report_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }

  DesignReportData data() const {
    DesignReportData d;
    d.patient.id = "P-017";
    d.patient.body_mass_kg = 82.5;
    d.patient.prosthesis_mass_kg = 2.25;
    d.patient.tissue_youngs_modulus_pa = 60e3;
    d.patient.friction = 0.45;
    d.patient.note = "<script>alert(1)</script> & knee pain";
    d.limb_file = "limb_a.stl";
    d.limb_type = "transtibial";
    d.side = "right";
    d.mesh_nodes = 8123;
    d.model = "MSS-CS";
    ReportSpot spot;
    spot.name = "PT";
    spot.type = "cos2";
    spot.amplitude_pa = 40e3;
    spot.theta0_rad = kPi / 2;
    spot.r_theta_rad = kPi / 6;
    spot.h0_m = 0.125;
    spot.r_h_m = 0.02;
    d.spots = {spot};
    d.brim_template = "PTB";
    d.brim_key_points = {{0.0, 0.18}, {kPi, 0.15}};
    RadarInputs in = balanced_inputs();
    in.body_mass_kg = 82.5;
    in.force_n.z() = 0.5 * 82.5 * kG;
    in.torque_nm.x() = 3.0;  // far off
    d.radar.axes = seven_radar_axes(in);
    d.radar.size_px = 100;
    PressureMapData map;
    map.surface = &mesh;
    for (const auto& v : mesh.vertices) map.values.push_back(v.x() > 0 ? 50.0 : 5.0);
    map.view_px = 96;
    MapLandmark lm{"FH", {0.0, -0.05, 0.15}, false};
    map.landmarks = {lm, MapLandmark{"PT", {0.05, 0.0, 0.12}, true}};
    d.maps = {map};
    PathProfile prof;
    prof.name = "anterior line";
    prof.s_label = "h [mm]";
    prof.s = {0, 50, 100};
    prof.pressure_kpa = {10, 20, 15};
    prof.threshold_kpa = {60, 60, 60};
    d.profiles = {prof};
    d.max_pressure_ratio = 0.87;
    d.max_pressure_pa = 52.3e3;
    d.has_max_ratio_position = true;
    d.max_ratio_position = {0.049, 0.0, 0.125};
    d.socket.has_socket = true;
    d.socket.limb_volume_m3 = 1000e-6;
    d.socket.socket_volume_m3 = 950e-6;
    d.socket.circumferences = {{0.1, 0.3, 0.285}};
    d.optimiser.has_run = true;
    d.optimiser.iterations = 42;
    d.optimiser.converged = true;
    d.optimiser.message = "constraints met";
    d.warnings = {"bones estimated", "anterior estimated"};
    return d;
  }
};

std::string read_all(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

std::size_t count_substr(const std::string& s, const std::string& needle) {
  std::size_t n = 0;
  for (std::size_t pos = s.find(needle); pos != std::string::npos; pos = s.find(needle, pos + 1)) ++n;
  return n;
}

TEST_F(ReportFixture, html_has_the_values_escapes_text_and_embeds_pictures) {
  const fs::path path = dir / "report.html";
  write_design_report_html(path, data());
  const std::string html = read_all(path);
  ASSERT_FALSE(html.empty());
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_NE(html.find("</html>"), std::string::npos);
  // Patient and inputs in clinical units.
  EXPECT_NE(html.find("82.5 kg"), std::string::npos);
  EXPECT_NE(html.find("2.25 kg"), std::string::npos);
  EXPECT_NE(html.find("60 kPa"), std::string::npos);
  EXPECT_NE(html.find("0.45"), std::string::npos);
  EXPECT_NE(html.find("limb_a.stl"), std::string::npos);
  EXPECT_NE(html.find("8123"), std::string::npos);
  EXPECT_NE(html.find("<td>40</td>"), std::string::npos);         // A in kPa
  EXPECT_NE(html.find("θ0 90 ± 30"), std::string::npos);          // degrees
  EXPECT_NE(html.find("h0 125 ± 20"), std::string::npos);         // mm
  // Constraint table: T_x fails, the rest pass.
  EXPECT_NE(html.find("6 of 7 met"), std::string::npos);
  EXPECT_EQ(count_substr(html, "<td>FAIL</td>"), 1u);
  EXPECT_EQ(count_substr(html, "<td>pass</td>"), 6u);
  // Comfort: nearest landmark zone of the largest ratio.
  EXPECT_NE(html.find("0.87"), std::string::npos);
  EXPECT_NE(html.find("nearest landmark zone PT"), std::string::npos);
  // Socket: 5 % circumference reduction, 950 cm³.
  EXPECT_NE(html.find("<td>5</td>"), std::string::npos);
  EXPECT_NE(html.find("950 cm³"), std::string::npos);
  EXPECT_NE(html.find("bones estimated"), std::string::npos);
  EXPECT_NE(html.find("<td>42</td>"), std::string::npos);
  // Escaping.
  EXPECT_EQ(html.find("<script>"), std::string::npos);
  EXPECT_NE(html.find("&lt;script&gt;alert(1)&lt;/script&gt; &amp; knee pain"), std::string::npos);
  // Pictures: radar + map as PNG, the profile as SVG, all inline.
  EXPECT_EQ(count_substr(html, "src=\"data:image/png;base64,iVBORw0KGgo"), 2u);
  EXPECT_EQ(count_substr(html, "src=\"data:image/svg+xml;base64,"), 1u);
}

TEST_F(ReportFixture, round_off_is_shown_as_zero_in_clinical_units) {
  auto d = data();
  d.spots[0].theta0_rad = 1.0e-18;  // an optimised angle: 5.7e-17° printed as such before
  d.spots[0].amplitude_pa = 9.4e-14;
  const std::string html = render_design_report_html(d);
  EXPECT_NE(html.find("θ0 0 ± 30"), std::string::npos);
  EXPECT_NE(html.find("<td>0</td>"), std::string::npos);
  EXPECT_EQ(html.find("e-17"), std::string::npos);
  EXPECT_EQ(html.find("e-14"), std::string::npos);
}

TEST_F(ReportFixture, sock_ply_section_lists_every_level_with_its_verdict) {
  auto d = data();
  d.sock_ply.has_study = true;
  d.sock_ply.summary = "study summary line";
  for (double f : {-0.04, 0.0, 0.04}) {
    ReportSockPlyLevel l;
    l.volume_change = f;
    l.skin_offset_m = f * 0.02;
    l.stood = f < 0.03;
    l.stood_offset_m = -f * 0.1;
    l.sink_m = -f * 0.1;
    l.peak_ratio = 0.5 - f;
    l.peak_pressure_pa = 30e3;
    l.distal_mean_pa = 12.5e3;
    l.distal_peak_pa = 20e3;
    l.constraints = f == 0 ? "all hold" : "fail: F_x";
    l.message = "standing not reached";
    d.sock_ply.levels.push_back(l);
  }
  Plot p;
  p.title = "sink";
  PlotSeries sink;
  sink.x = {-4, 0};
  sink.y = {4, 0};
  p.series.push_back(sink);
  d.sock_ply.plots = {p};
  const std::string html = render_design_report_html(d);
  EXPECT_NE(html.find("Sock-ply sensitivity"), std::string::npos);
  EXPECT_NE(html.find("study summary line"), std::string::npos);
  EXPECT_NE(html.find("<td>-4 %</td>"), std::string::npos);
  EXPECT_NE(html.find("<td>as designed</td>"), std::string::npos);
  EXPECT_NE(html.find("<td>4</td>"), std::string::npos);        // sinks 4 mm at −4 %
  EXPECT_NE(html.find("<td>12.5</td>"), std::string::npos);     // distal mean [kPa]
  EXPECT_NE(html.find("standing not reached"), std::string::npos);  // +4 % did not stand
  EXPECT_EQ(count_substr(html, "src=\"data:image/svg+xml;base64,"), 2u);  // the profile and the study's plot
}

TEST_F(ReportFixture, an_error_leaves_no_file_and_keeps_the_previous_report) {
  const fs::path path = dir / "report.html";
  auto bad = data();
  const geometry::TriMesh empty;
  bad.maps[0].surface = &empty;
  bad.maps[0].values.clear();
  EXPECT_THROW(write_design_report_html(path, bad), InvalidInputError);
  EXPECT_FALSE(fs::exists(path));
  write_design_report_html(path, data());
  const std::string before = read_all(path);
  EXPECT_THROW(write_design_report_html(path, bad), InvalidInputError);
  EXPECT_EQ(read_all(path), before);
  int files = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    ++files;
    EXPECT_EQ(e.path().filename(), "report.html");  // no temporary left behind
  }
  EXPECT_EQ(files, 1);
}

}  // namespace
}  // namespace socketsmith::report
