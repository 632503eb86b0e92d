// Designs that do not depend on where the limb lies or what units it is in, and the transfemoral
// brims judged in 3D on the built socket (issue 21):
// - the real transfemoral limb (OpenLimbTF mean limb) and a generated transtibial limb designed as
//   given and as a rigidly turned and shifted copy (written to an STL here): the frame turns with
//   the limb, the radar, the ischial share and the socket's volumes stay;
// - the same limb given in mm instead of (normalised) metres gives the same design;
// - a quadrilateral brim on the real limb seats the tuberosity ON the brim (an ICS wraps it);
// - generated transfemoral limbs, each turned by an arbitrary rotation and shifted, designed with
//   the default case: the "done when" on each (seven constraints, a watertight socket, the
//   front within 15 deg of the generator's truth, an ICS brim that rises >= 40 mm and is highest
//   postero-medially, the tuberosity inside the cavity, the ischial share in design.json and the
//   report). The unit build runs seeds 1 and 2, both sides; the slow-labelled build
//   (SOCKETSMITH_MANY_LIMBS) seeds 1-10, both sides, and nothing else.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>
#include <numbers>
#include <optional>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "socketsmith/design/case_file.h"
#include "socketsmith/design/brim.h"
#include "socketsmith/design/spots.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/volume/limb_generator.h"

namespace socketsmith {
namespace {
namespace fs = std::filesystem;
using Eigen::Vector3d;

constexpr int kNodes = 3000;

#ifndef SOCKETSMITH_MANY_LIMBS
fs::path tf_file() {
  return fs::path(SOCKETSMITH_SHARED_DATA_DIR) / "limbs/transfemoral/openlimb_tf_mean_limb_normalised.stl";
}
#endif

fs::path work_dir(const std::string& name) {
  const fs::path d = fs::path(SOCKETSMITH_BINARY_DIR) / "tests" / name;
  fs::create_directories(d);
  return d;
}

geometry::MeshReadOptions in_unit(units::LengthUnit u) {
  geometry::MeshReadOptions o;
  o.unit = u;
  o.warn_on_implausible_size = false;
  return o;
}

double angle_deg(const Vector3d& a, const Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180.0 / std::numbers::pi;
}

#ifndef SOCKETSMITH_MANY_LIMBS
/// What a design gives that must not depend on the limb's placement or units.
struct Outcome {
  Vector3d axis, anterior;       // world
  design::RadarValues radar;     // in the limb frame
  design::RadarTargets targets;
  bool met = false;
  double ischial_share = -1;     // transfemoral only
  double cavity_cm3 = 0, shell_cm3 = 0;
  std::optional<design::IschialCheck> ischial;
};

Outcome design_case(const design::CaseFile& c) {
  auto setup = pipeline::prepare_design(c);
  const pipeline::DesignResult r = pipeline::solve_design(*setup, true);
  Outcome o;
  o.axis = setup->model.frame.axis;
  o.anterior = setup->model.frame.anterior;
  o.radar = r.state.radar;
  o.targets = setup->solver->targets();
  o.met = r.constraints_met;
  for (const auto& l : r.region_loads)
    if (l.key == "ischial_gluteal") o.ischial_share = l.share;
  if (r.socket) {
    o.cavity_cm3 = r.socket->cavity_volume_m3 * 1e6;
    o.shell_cm3 = r.socket->shell_volume_m3 * 1e6;
  }
  o.ischial = r.ischial_check;
  return o;
}
#endif

design::CaseFile limb_case(const fs::path& file, const std::string& units, double scale, const std::string& type) {
  return design::parse_case(nlohmann::json{{"socketsmith_case", 1},
                                           {"limb", {{"file", file.string()}, {"units", units}, {"scale", scale},
                                                     {"type", type}}},
                                           {"mesh", {{"target_nodes", kNodes}}},
                                           // the designs compared, not their closed loops
                                           {"design", {{"closed_loop", false}}}});
}

/// @p m turned by @p R and shifted by @p t (both in the mesh's own unit).
geometry::TriMesh moved(geometry::TriMesh m, const Eigen::Matrix3d& R, const Vector3d& t) {
  for (auto& v : m.vertices) v = R * v + t;
  return m;
}

#ifndef SOCKETSMITH_MANY_LIMBS

/// 30° about a tilted axis.
Eigen::Matrix3d turn() { return Eigen::AngleAxisd(30.0 * std::numbers::pi / 180.0, Vector3d(0.3, -0.5, 0.8).normalized()).toRotationMatrix(); }
/// 100 mm along a diagonal [m].
Vector3d shift_m() { return 0.1 * Vector3d(1, -1, 1).normalized(); }

/// Two designs of one limb agree: the frame turned by @p R (2°), the radar (forces within 2 % of
/// M g / 2, torques within twice their tolerance, stability within 5 %), the ischial share within 3
/// points, the socket's cavity and shell volumes within 1 %.
void expect_same_design(const Outcome& a, const Outcome& b, const Eigen::Matrix3d& R, const std::string& what) {
  ASSERT_TRUE(a.met) << what << ": the first design does not meet its constraints";
  ASSERT_TRUE(b.met) << what << ": the second design does not meet its constraints";
  EXPECT_LT(angle_deg(R * a.axis, b.axis), 2.0) << what;
  EXPECT_LT(angle_deg(R * a.anterior, b.anterior), 2.0) << what;
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(a.radar.force_n[k], b.radar.force_n[k], 0.02 * a.targets.fz_n) << what << " force " << k;
    EXPECT_NEAR(a.radar.torque_nm[k], b.radar.torque_nm[k], 2 * a.targets.torque_tol_nm) << what << " torque " << k;
  }
  EXPECT_NEAR(a.radar.stability_n, b.radar.stability_n, 0.05 * a.radar.stability_n) << what;
  if (a.ischial_share >= 0) {
    EXPECT_NEAR(a.ischial_share, b.ischial_share, 0.03) << what;
  }
  EXPECT_NEAR(b.cavity_cm3, a.cavity_cm3, 0.01 * a.cavity_cm3) << what;
  EXPECT_NEAR(b.shell_cm3, a.shell_cm3, 0.01 * a.shell_cm3) << what;
  if (a.ischial) {
    ASSERT_TRUE(b.ischial.has_value()) << what;
    EXPECT_EQ(a.ischial->met, b.ischial->met) << what;
    EXPECT_NEAR(a.ischial->cavity_margin_m, b.ischial->cavity_margin_m, 0.002) << what;
  }
  double d_force = 0, d_torque = 0;
  for (int k = 0; k < 3; ++k) {
    d_force = std::max(d_force, std::abs(a.radar.force_n[k] - b.radar.force_n[k]));
    d_torque = std::max(d_torque, std::abs(a.radar.torque_nm[k] - b.radar.torque_nm[k]));
  }
  ::testing::Test::RecordProperty(
      what, fmt::format("cavity {:.2f} vs {:.2f} cm3 ({:.2g} %), shell {:.2f} vs {:.2f} cm3 ({:.2g} %), ischial share "
                        "{:.4f} vs {:.4f}, radar: forces within {:.2g} N, torques within {:.2g} N m, stability {:.2f} vs "
                        "{:.2f} N; frame: axis {:.3g} deg, anterior {:.3g} deg",
                        a.cavity_cm3, b.cavity_cm3, 100 * std::abs(b.cavity_cm3 / a.cavity_cm3 - 1), a.shell_cm3,
                        b.shell_cm3, 100 * std::abs(b.shell_cm3 / a.shell_cm3 - 1), a.ischial_share, b.ischial_share,
                        d_force, d_torque, a.radar.stability_n, b.radar.stability_n, angle_deg(R * a.axis, b.axis),
                        angle_deg(R * a.anterior, b.anterior)));
}

/// The real transfemoral limb as given (normalised, read as m, scale 0.45), designed once for the
/// tests that compare against it.
class RealTransfemoral : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!fs::exists(tf_file())) return;
    original_ = new Outcome(design_case(limb_case(tf_file(), "m", 0.45, "transfemoral")));
  }
  static void TearDownTestSuite() {
    delete original_;
    original_ = nullptr;
  }
  void SetUp() override {
    if (!fs::exists(tf_file())) GTEST_SKIP() << "shared data absent: " << tf_file();
  }
  static Outcome* original_;
};
Outcome* RealTransfemoral::original_ = nullptr;

TEST_F(RealTransfemoral, a_turned_and_shifted_copy_gets_the_same_design) {
  const Eigen::Matrix3d R = turn();
  // The copy in the file's own (normalised) unit: the 100 mm shift divided by the scale.
  const auto limb = geometry::read_mesh(tf_file(), in_unit(units::LengthUnit::Metre));
  const fs::path copy = work_dir("rigid_tf") / "tf_turned.stl";
  geometry::write_mesh(copy, moved(limb, R, shift_m() / 0.45), units::LengthUnit::Metre);
  const Outcome b = design_case(limb_case(copy, "m", 0.45, "transfemoral"));
  expect_same_design(*original_, b, R, "turned_tf");
  // Still an ischial containment that holds the tuberosity.
  ASSERT_TRUE(b.ischial && b.ischial->applies);
  EXPECT_TRUE(b.ischial->met) << b.ischial->summary;
}

// An odd frame: nearly upside down (160° about an oblique axis) and 250 mm away.
TEST_F(RealTransfemoral, an_upside_down_copy_far_away_gets_the_same_design) {
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(160.0 * std::numbers::pi / 180.0, Vector3d(1.0, 0.2, -0.4).normalized()).toRotationMatrix();
  const auto limb = geometry::read_mesh(tf_file(), in_unit(units::LengthUnit::Metre));
  const fs::path copy = work_dir("rigid_tf") / "tf_upside_down.stl";
  geometry::write_mesh(copy, moved(limb, R, Vector3d(-0.15, 0.2, 0.0) / 0.45), units::LengthUnit::Metre);
  const Outcome b = design_case(limb_case(copy, "m", 0.45, "transfemoral"));
  expect_same_design(*original_, b, R, "upside_down_tf");
}

TEST_F(RealTransfemoral, the_same_limb_in_mm_gets_the_same_design) {
  const auto limb = geometry::read_mesh(tf_file(), in_unit(units::LengthUnit::Metre));
  geometry::TriMesh in_m = limb;
  for (auto& v : in_m.vertices) v *= 0.45;  // metres; written in mm below
  const fs::path copy = work_dir("rigid_tf") / "tf_mm.stl";
  geometry::write_mesh(copy, in_m, units::LengthUnit::Millimetre);
  const Outcome b = design_case(limb_case(copy, "mm", 1.0, "transfemoral"));
  expect_same_design(*original_, b, Eigen::Matrix3d::Identity(), "mm_tf");
}

TEST(GeneratedTranstibial, a_turned_and_shifted_copy_gets_the_same_design) {
  const auto g = volume::generate_limb(volume::default_params(geometry::LimbType::Transtibial, 2));
  const geometry::TriMesh limb = volume::merge_shells(g);
  const fs::path dir = work_dir("rigid_tt");
  geometry::write_mesh(dir / "tt.stl", limb, units::LengthUnit::Millimetre);
  const Eigen::Matrix3d R = turn();
  geometry::write_mesh(dir / "tt_turned.stl", moved(limb, R, shift_m()), units::LengthUnit::Millimetre);
  const Outcome a = design_case(limb_case(dir / "tt.stl", "mm", 1.0, "transtibial"));
  const Outcome b = design_case(limb_case(dir / "tt_turned.stl", "mm", 1.0, "transtibial"));
  expect_same_design(a, b, R, "turned_tt");
  EXPECT_FALSE(a.ischial.has_value());  // a transtibial socket has no ischial check
}

/// A quadrilateral brim on the real limb: the tuberosity sits ON the brim (the seat at or just
/// below IS), where the ICS wraps it (its brim > 25 mm above IS); the seat carries at least its
/// floor of 30 % of the axial load; the seven constraints hold; the socket is a closed solid.
/// Checked on design.json and, independently of the ischial check, on the socket STL itself: its
/// highest point in the tuberosity's sector.
TEST_F(RealTransfemoral, a_quadrilateral_brim_seats_the_tuberosity_on_the_brim) {
  const fs::path dir = work_dir("tf_quad");
  const auto c = design::parse_case(nlohmann::json{{"socketsmith_case", 1},
                                        {"limb", {{"file", tf_file().string()}, {"units", "m"}, {"scale", 0.45},
                                                  {"type", "transfemoral"}}},
                                        {"mesh", {{"target_nodes", kNodes}}},
                                        {"brim", {{"template", "quadrilateral"}}},
                                        {"design", {{"closed_loop", false}}}});  // the brim, not the loop
  const nlohmann::json j = pipeline::run_design(c, dir / "out", true);
  ASSERT_TRUE(j["constraints_met"].get<bool>()) << j["failing"];
  EXPECT_EQ(j["brim"]["template"], "quad");
  // The ischial/gluteal region carries at least the quadrilateral's floor.
  EXPECT_DOUBLE_EQ(j["ischial_share_min"].get<double>(), 0.30);
  EXPECT_GE(j["ischial_gluteal_share"].get<double>(), 0.30 - 1e-3);
  // The seat: the brim at the IS landmark's angle lies at or just below IS.
  double is_h = 0, is_theta = 0;
  for (const auto& l : j["landmarks"])
    if (l["code"] == "IS") is_h = l["h_mm"].get<double>(), is_theta = l["theta_deg"].get<double>();
  std::vector<design::BrimKeyPoint> kps;
  for (const auto& k : j["brim"]["key_points"])
    kps.push_back({"", k["theta_deg"].get<double>() * std::numbers::pi / 180, k["h_mm"].get<double>()});
  const design::BrimLine brim = design::brim_from_key_points(kps);
  const double seat = brim.height(is_theta * std::numbers::pi / 180);
  EXPECT_LE(seat, is_h + 1.0);
  EXPECT_GE(seat, is_h - 10.0);
  // The built socket: its highest point within 15° of the tuberosity is the seat's edge (the lip
  // rounds a few mm over the rim), not a wall above it.
  const auto socket = geometry::read_mesh(dir / "out" / "socket.stl", in_unit(units::LengthUnit::Millimetre));
  const auto report = geometry::check_mesh(socket);
  EXPECT_TRUE(report.is_valid_closed_surface());
  geometry::LimbFrame frame;
  const auto vec = [](const nlohmann::json& a) { return Vector3d(a[0].get<double>(), a[1].get<double>(), a[2].get<double>()); };
  frame.origin = vec(j["frame"]["origin_m"]);
  frame.axis = vec(j["frame"]["axis"]);
  frame.anterior = vec(j["frame"]["anterior"]);
  frame.side = j["frame"]["side"] == "left" ? geometry::Side::Left : geometry::Side::Right;
  double top = -1e9;
  for (const auto& v : socket.vertices) {
    const auto q = frame.to_cylindrical(v);
    if (std::abs(design::wrap_angle(q.theta - is_theta * std::numbers::pi / 180)) < 15 * std::numbers::pi / 180)
      top = std::max(top, q.h * 1e3);
  }
  EXPECT_LT(top, is_h + 6.0) << "the socket rises above the tuberosity: not a seat";
  EXPECT_GT(top, is_h - 12.0);
  // The 3D check says the same: on the seat, not contained.
  const auto& ic = j["socket"]["ischial_check"];
  EXPECT_EQ(ic["kind"], "seat");
  EXPECT_TRUE(ic["met"].get<bool>()) << ic["summary"];
  EXPECT_GE(ic["height_margin_mm"].get<double>(), -2.0);
  EXPECT_LE(ic["height_margin_mm"].get<double>(), 15.0);
  // Where the ICS of the same limb wraps the tuberosity: its brim more than 25 mm above it.
  ASSERT_TRUE(original_->ischial.has_value());
  EXPECT_GT(original_->ischial->brim_h_m * 1e3, is_h + 25.0);
  EXPECT_GT(original_->ischial->brim_h_m * 1e3, seat + 25.0);
  RecordProperty("quad", fmt::format("seat {:.1f} mm, IS {:.1f} mm, socket top near IS {:.1f} mm, ischial share {:.3f}, "
                                     "3D: {}",
                                     seat, is_h, top, j["ischial_gluteal_share"].get<double>(),
                                     ic["summary"].get<std::string>()));
}

/// The ICS design of the same limb holds the tuberosity INSIDE the socket's cavity in 3D, with the
/// brim more than 25 mm above it.
TEST_F(RealTransfemoral, the_ics_socket_contains_the_tuberosity_in_3d) {
  ASSERT_TRUE(original_->ischial.has_value());
  const auto& ic = *original_->ischial;
  EXPECT_EQ(ic.kind, "containment");
  EXPECT_TRUE(ic.inside_cavity) << ic.summary;
  EXPECT_TRUE(ic.met) << ic.summary;
  EXPECT_GT(ic.cavity_margin_m, 0.0);
  EXPECT_GT(ic.height_margin_m, 0.025);
  RecordProperty("ics", ic.summary);
}

#endif  // SOCKETSMITH_MANY_LIMBS

/// A generated transfemoral limb turned by an arbitrary rotation and shifted: its seed and side.
struct TurnedLimb {
  int seed = 1;
  geometry::Side side = geometry::Side::Right;
};

class TurnedGeneratedTransfemoral : public ::testing::TestWithParam<TurnedLimb> {};

Vector3d vec3(const nlohmann::json& a) { return {a[0].get<double>(), a[1].get<double>(), a[2].get<double>()}; }

// Issue 21's "done when" on a generated limb in an arbitrary frame, through the pipeline the CLI
// runs (design.json, report.html, socket.stl), under the default tissue model.
TEST_P(TurnedGeneratedTransfemoral, gets_an_ischial_containment_a_prosthetist_would_fit) {
  const TurnedLimb t = GetParam();
  const std::string name = fmt::format("tf_{}_{}", t.seed, geometry::to_string(t.side));
  auto params = volume::default_params(geometry::LimbType::Transfemoral, t.seed);
  params.side = t.side;
  const volume::GeneratedLimb g = volume::generate_limb(params);
  // An arbitrary rotation (a different axis and angle for every seed and side) and a shift.
  const double s = t.seed + (t.side == geometry::Side::Left ? 0.5 : 0.0);
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(0.9 + 1.7 * s, Vector3d(std::cos(2.3 * s), std::sin(1.1 * s), 0.6 - 0.3 * s).normalized())
          .toRotationMatrix();
  const Vector3d shift_mm(40.0 * s - 200.0, 150.0 - 30.0 * s, 90.0);
  const fs::path dir = work_dir("turned_" + name);
  fs::remove_all(dir / "out");
  geometry::write_mesh(dir / "limb.stl", moved(volume::merge_shells(g), R, shift_mm), units::LengthUnit::Millimetre);
  const nlohmann::json j = pipeline::run_design(limb_case(dir / "limb.stl", "mm", 1.0, "transfemoral"), dir / "out", true);

  // The seven constraints, the template the limb type asks for.
  EXPECT_TRUE(j["constraints_met"].get<bool>()) << name << ": " << j["failing"];
  EXPECT_EQ(j["brim"]["template"], "ics") << name;
  // The frame: from the femur and the hemipelvis, the generator's truth turned by R.
  const double ant_err = angle_deg(vec3(j["frame"]["anterior"]), R * g.frame.anterior);
  EXPECT_LT(ant_err, 15.0) << name;
  EXPECT_LT(angle_deg(vec3(j["frame"]["axis"]), R * g.frame.axis), 5.0) << name;
  EXPECT_EQ(j["frame"]["side"], geometry::to_string(t.side)) << name;
  EXPECT_EQ(j["frame"]["anterior_source"], "hemipelvis") << name;

  // The brim is not flat: >= 40 mm of height around the limb, highest postero-medially (the limb
  // frame's theta runs from the front towards medial: 90-180 deg).
  std::vector<design::BrimKeyPoint> kps;
  for (const auto& k : j["brim"]["key_points"])
    kps.push_back({"", k["theta_deg"].get<double>() * std::numbers::pi / 180, k["h_mm"].get<double>()});
  const design::BrimLine brim = design::brim_from_key_points(kps);
  double lo = 1e9, hi = -1e9, top_theta = 0;
  for (int d = -180; d < 180; ++d) {
    const double h = brim.height(d * std::numbers::pi / 180);
    lo = std::min(lo, h);
    if (h > hi) hi = h, top_theta = d;
  }
  EXPECT_GE(hi - lo, 40.0) << name;
  EXPECT_GT(top_theta, 90.0) << name;
  EXPECT_LT(top_theta, 180.0) << name;

  // The socket: a watertight solid, its own highest point postero-medial too.
  const auto socket = geometry::read_mesh(dir / "out" / "socket.stl", in_unit(units::LengthUnit::Millimetre));
  const auto report = geometry::check_mesh(socket);
  EXPECT_TRUE(report.is_valid_closed_surface()) << name << ": "
                                                 << (report.problems().empty() ? "" : report.problems().front());
  EXPECT_EQ(report.connected_components, 1) << name;
  EXPECT_FALSE(geometry::has_self_intersections(socket)) << name;
  geometry::LimbFrame frame;
  frame.origin = vec3(j["frame"]["origin_m"]);
  frame.axis = vec3(j["frame"]["axis"]);
  frame.anterior = vec3(j["frame"]["anterior"]);
  frame.side = t.side;
  double socket_top = -1e9, socket_top_theta = 0;
  for (const auto& v : socket.vertices) {
    const auto q = frame.to_cylindrical(v);
    if (q.h > socket_top) socket_top = q.h, socket_top_theta = q.theta * 180 / std::numbers::pi;
  }
  EXPECT_GT(socket_top_theta, 90.0) << name;
  EXPECT_LT(socket_top_theta, 180.0) << name;

  // The brim's top 30 mm bears (issue 21 found 0.1-0.7 kPa there under a flat, clamped brim):
  // the area-weighted mean pressure of the skin nodes within 30 mm below the brim, from
  // surface_nodes.csv (x, y, z, nx, ny, nz, area, pressure, threshold, above_brim).
  double band_pa = 0, band_a = 0;
  {
    std::ifstream csv(dir / "out" / "surface_nodes.csv");
    std::string line;
    std::getline(csv, line);  // header
    while (std::getline(csv, line)) {
      std::vector<double> f;
      std::stringstream ss(line);
      for (std::string cell; std::getline(ss, cell, ',');) f.push_back(std::stod(cell));
      ASSERT_EQ(f.size(), 10u) << line;
      const auto q = frame.to_cylindrical(Vector3d(f[0], f[1], f[2]));
      const double h_mm = q.h * 1e3, brim_mm = brim.height(q.theta);
      if (f[9] == 0 && h_mm > brim_mm - 30.0) band_pa += f[7] * f[6], band_a += f[6];
    }
  }
  ASSERT_GT(band_a, 0.0) << name;
  const double band_kpa = band_pa / band_a * 1e-3;
  EXPECT_GT(band_kpa, 1.5) << name;

  // The bony tuberosity (the file's hemipelvis) inside the socket's cavity.
  const auto& ic = j["socket"]["ischial_check"];
  EXPECT_EQ(ic["kind"], "containment") << name;
  EXPECT_FALSE(ic["tuberosity_estimated"].get<bool>()) << name;
  EXPECT_TRUE(ic["inside_cavity"].get<bool>()) << name << ": " << ic["summary"];
  EXPECT_TRUE(ic["met"].get<bool>()) << name << ": " << ic["summary"];
  EXPECT_GT(ic["cavity_margin_mm"].get<double>(), 5.0) << name;

  // The ischial/gluteal share of the axial load: at least the floor, among shares that sum to 1,
  // in design.json and in the report.
  const double share = j["ischial_gluteal_share"].get<double>();
  EXPECT_GE(share, j["ischial_share_min"].get<double>() - 1e-3) << name;
  EXPECT_TRUE(j["ischial_share_floor_met"].get<bool>()) << name;
  double total = 0;
  for (const auto& r : j["load_shares"]) total += r["share"].get<double>();
  EXPECT_NEAR(total, 1.0, 1e-6) << name;
  std::ifstream html(dir / "out" / "report.html");
  const std::string page((std::istreambuf_iterator<char>(html)), std::istreambuf_iterator<char>());
  EXPECT_NE(page.find("Axial load by region"), std::string::npos) << name;
  EXPECT_NE(page.find("ischial / gluteal"), std::string::npos) << name;

  std::printf("[ measured ] %s turned: constraints %s, watertight %s, anterior %.1f deg off, brim %.1f mm high, "
              "highest at %.0f deg (socket %.0f deg), top 30 mm %.2f kPa, tuberosity %s (%.1f mm), ischial share %.1f %%\n",
              name.c_str(), j["constraints_met"].get<bool>() ? "met" : "NOT met",
              report.is_valid_closed_surface() ? "yes" : "NO", ant_err, hi - lo, top_theta, socket_top_theta, band_kpa,
              ic["inside_cavity"].get<bool>() ? "inside" : "NOT inside", ic["cavity_margin_mm"].get<double>(),
              100 * share);
}

std::vector<TurnedLimb> turned_limbs() {
#ifdef SOCKETSMITH_MANY_LIMBS
  const int seeds = 10;
#else
  const int seeds = 2;
#endif
  std::vector<TurnedLimb> v;
  for (int seed = 1; seed <= seeds; ++seed)
    for (const auto side : {geometry::Side::Right, geometry::Side::Left}) v.push_back({seed, side});
  return v;
}

INSTANTIATE_TEST_SUITE_P(Seeds, TurnedGeneratedTransfemoral, ::testing::ValuesIn(turned_limbs()),
                         [](const auto& param_info) {
                           return fmt::format("seed_{}_{}", param_info.param.seed,
                                              geometry::to_string(param_info.param.side));
                         });

}  // namespace
}  // namespace socketsmith
