// `socketsmith demo` end to end: the radar reported in design.json is recomputed from
// surface_nodes.csv with the thesis's formulas (eqs. 42–47, written out here independently of
// design::compute_radar), and the socket STL is a closed manifold solid of the requested wall.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "socketsmith/design/case_file.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/pipeline/prosthetist_checks.h"
#include "socketsmith/pipeline/design_validation.h"
#include "socketsmith/pipeline/validation_inputs.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/geometry/surface_query.h"
#include "socketsmith/report/csv.h"

namespace socketsmith {
namespace {
namespace fs = std::filesystem;

class DemoRun : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    out_ = fs::path(SOCKETSMITH_BINARY_DIR) / "tests" / "pipeline_demo";
    fs::remove_all(out_);
    const std::string cmd = std::string(SOCKETSMITH_BINARY_DIR) + "/socketsmith demo --target-nodes 3000 --out " +
                            out_.string() + " > " + (out_.string() + ".log") + " 2>&1";
    rc_ = std::system(cmd.c_str());
  }
  static fs::path out_;
  static int rc_;
};
fs::path DemoRun::out_;
int DemoRun::rc_ = -1;

Eigen::Vector3d vec(const nlohmann::json& j) { return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()}; }

TEST_F(DemoRun, RadarRecomputedFromSurfaceNodesEqualsTheReportAndTheSocketIsASolid) {
  ASSERT_EQ(rc_, 0) << "see " << out_.string() << ".log";
  std::ifstream in(out_ / "design.json");
  const auto j = nlohmann::json::parse(in);
  ASSERT_TRUE(j["constraints_met"].get<bool>());
  const auto t = report::read_csv(out_ / "surface_nodes.csv");
  const Eigen::Vector3d C = vec(j["center_of_inertia_m"]), ex = vec(j["frame"]["anterior"]),
                        ey = vec(j["frame"]["medial"]), ez = vec(j["frame"]["axis"]);
  const double mu = j["friction"].get<double>();
  Eigen::Vector3d F = Eigen::Vector3d::Zero(), T = Eigen::Vector3d::Zero();
  double S = 0;
  const auto col = [&](const char* name) { return t.column(name); };
  const auto x = col("x_m"), y = col("y_m"), z = col("z_m"), nx = col("nx"), ny = col("ny"), nz = col("nz"),
             a = col("area_m2"), p = col("pressure_pa"), thr = col("threshold_pa"), above = col("above_brim");
  ASSERT_GT(x.size(), 500u);
  for (size_t i = 0; i < x.size(); ++i) {
    if (above[i] > 0.5) {
      EXPECT_EQ(p[i], 0.0) << "pressure above the brim at row " << i;
    }
    EXPECT_LE(p[i], thr[i] * (1 + 1e-9)) << "pressure above the threshold at row " << i;
    const Eigen::Vector3d n(nx[i], ny[i], nz[i]);
    const Eigen::Vector3d fi = -p[i] * a[i] * n;  // socket on stump: along the inward normal
    F += fi;
    T += (Eigen::Vector3d(x[i], y[i], z[i]) - C).cross(fi);
    const double cos_t = std::sqrt(std::max(0.0, 1.0 - std::pow(n.dot(ez), 2)));  // angle vertical–tangent
    S += mu * p[i] * a[i] * cos_t;
  }
  const auto& r = j["radar"];
  const double fz_target = j["targets"]["fz_n"].get<double>();
  EXPECT_NEAR(F.dot(ex), r["fx_n"].get<double>(), 1e-6 * fz_target);
  EXPECT_NEAR(F.dot(ey), r["fy_n"].get<double>(), 1e-6 * fz_target);
  EXPECT_NEAR(F.dot(ez) + S, r["fz_n"].get<double>(), 1e-6 * fz_target);
  EXPECT_NEAR(T.dot(ex), r["tx_nm"].get<double>(), 1e-6 * fz_target * 0.2);
  EXPECT_NEAR(T.dot(ey), r["ty_nm"].get<double>(), 1e-6 * fz_target * 0.2);
  EXPECT_NEAR(T.dot(ez), r["tz_nm"].get<double>(), 1e-6 * fz_target * 0.2);
  EXPECT_NEAR(S, r["stability_n"].get<double>(), 1e-6 * fz_target);
  // And they meet the targets: forces within 1 % of M g / 2, stability above the prosthesis weight.
  EXPECT_NEAR(F.dot(ez) + S, fz_target, 0.01 * fz_target);
  EXPECT_LT(std::abs(F.dot(ex)), 0.01 * fz_target);
  EXPECT_LT(std::abs(F.dot(ey)), 0.01 * fz_target);
  EXPECT_LE(T.norm(), std::sqrt(3.0) * j["targets"]["torque_tolerance_nm"].get<double>());
  EXPECT_GE(S, j["targets"]["stability_min_n"].get<double>());
  // The template reading's axial loads are the same terms: they sum to F_z; the regions' shares
  // are parts of it.
  const auto& tr = j["template_regions"];
  EXPECT_NEAR(tr["total_axial_n"].get<double>(), F.dot(ez) + S, 1e-6 * fz_target);
  EXPECT_EQ(tr["template"].get<std::string>(), "ptb");
  for (const char* key : {"tolerant", "sensitive", "distal_fifth"}) {
    ASSERT_TRUE(tr["regions"].contains(key)) << key;
    EXPECT_GT(tr["regions"][key]["nodes"].get<int>(), 0) << key;
    EXPECT_GT(tr["regions"][key]["axial_share"].get<double>(), 0.0) << key;
    EXPECT_LT(tr["regions"][key]["axial_share"].get<double>(), 1.0) << key;
  }
  // The optimiser followed the PTB template (issue 22): the tolerant regions bear at least 1.5 ×
  // the sensitive ones on average, and the distal fifth carries at most 10 % of the axial load
  // (optimizer_test recomputes both from the solved state; without the template's constraints the
  // same stump reads 0.8 × and 32 %).
  EXPECT_TRUE(tr["optimiser_follows"].get<bool>());
  EXPECT_TRUE(tr["optimiser_kept"].get<bool>());
  EXPECT_TRUE(tr["met"].get<bool>()) << tr["summary"].get<std::string>();
  EXPECT_GE(tr["regions"]["tolerant"]["mean_kpa"].get<double>(),
            1.5 * tr["regions"]["sensitive"]["mean_kpa"].get<double>());
  EXPECT_LE(tr["regions"]["distal_fifth"]["axial_share"].get<double>(), 0.10);

  // The socket: a closed manifold solid of the requested thickness.
  geometry::MeshReadOptions ro;
  ro.unit = units::LengthUnit::Millimetre;
  const auto socket = geometry::read_mesh(out_ / "socket.stl", ro);
  const auto rep = geometry::check_mesh(socket);
  EXPECT_TRUE(rep.is_valid_closed_surface()) << (rep.problems().empty() ? "" : rep.problems().front());
  EXPECT_EQ(rep.connected_components, 1);
  EXPECT_GT(rep.signed_volume_m3, 0.0);
  // Wall: measured along each stump node's outward normal — from the node (the inner wall lies on
  // the deformed skin) to the first socket surface more than 1 mm out, the outer wall. Nodes 15 mm
  // from any node above the brim (the rounded lip) and the lowest 20 mm (the pad, built outward)
  // are left out. The demo asks for 5 mm (README: at least 4.75 mm everywhere but the brim edge);
  // the median must be within 3 % of it and the 2nd percentile above 4.5 mm — a wall of 4 or 6 mm
  // fails (it used to pass anything from about 4 to 11 mm).
  const geometry::SurfaceQuery socket_q(socket);
  std::vector<Eigen::Vector3d> above_brim;
  double lowest = 1e9;
  for (size_t i = 0; i < x.size(); ++i) {
    lowest = std::min(lowest, Eigen::Vector3d(x[i], y[i], z[i]).dot(ez));
    if (above[i] > 0.5) above_brim.emplace_back(x[i], y[i], z[i]);
  }
  ASSERT_FALSE(above_brim.empty());
  // The demo closes the loop (a transtibial limb's default): the socket's inner wall is the designed
  // skin moved by the closed loop's offset along each node's normal (delivered.csv, same rows).
  ASSERT_TRUE(j.contains("closed_loop")) << "the demo's design closes the loop";
  const auto delivered = report::read_csv(out_ / "delivered.csv");
  const auto offset_mm = delivered.column("wall_offset_mm");
  ASSERT_EQ(offset_mm.size(), x.size());
  std::vector<double> wall;
  for (size_t i = 0; i < x.size(); ++i) {
    const Eigen::Vector3d n(nx[i], ny[i], nz[i]);
    const Eigen::Vector3d q = Eigen::Vector3d(x[i], y[i], z[i]) + offset_mm[i] * 1e-3 * n;
    if (above[i] > 0.5 || q.dot(ez) < lowest + 0.02) continue;
    double near_brim = 1e9;
    for (const auto& b : above_brim) near_brim = std::min(near_brim, (b - q).norm());
    if (near_brim < 0.015) continue;
    const auto hit = socket_q.first_hit(q + 1e-3 * n, n);
    if (hit) wall.push_back(hit->distance + 1e-3);
  }
  ASSERT_GT(wall.size(), 300u);
  std::sort(wall.begin(), wall.end());
  const double median = wall[wall.size() / 2], p2 = wall[wall.size() / 50];
  std::printf("[ info ] wall along the skin normals at %zu nodes: 2nd percentile %.3f mm, median %.3f mm, max %.3f mm\n",
              wall.size(), p2 * 1e3, median * 1e3, wall.back() * 1e3);
  const double asked = j["socket"]["thickness_mm"].get<double>() * 1e-3;
  EXPECT_DOUBLE_EQ(asked, 0.005);
  EXPECT_NEAR(median, asked, 0.03 * asked);
  EXPECT_GT(p2, 0.9 * asked);
}

// The real transfemoral limb (OpenLimbTF mean limb, scaled by a 0.45 m femur via limb.scale), a
// case without a brim: the transfemoral default (ICS) is placed from the bony landmarks, the
// ischial/gluteal region carries its share of the axial load, the socket is a closed solid.
TEST(TransfemoralCase, RealLimbWithoutABrimGetsAnIschialContainment) {
  const fs::path stl = fs::path(SOCKETSMITH_SHARED_DATA_DIR) / "limbs/transfemoral/openlimb_tf_mean_limb_normalised.stl";
  if (!fs::exists(stl)) GTEST_SKIP() << "shared data absent: " << stl;
  const fs::path dir = fs::path(SOCKETSMITH_BINARY_DIR) / "tests" / "pipeline_tf";
  fs::remove_all(dir);
  fs::create_directories(dir);
  {
    std::ofstream c(dir / "tf.json");
    c << nlohmann::json{{"socketsmith_case", 1},
                        {"limb", {{"file", stl.string()}, {"units", "m"}, {"scale", 0.45}, {"type", "transfemoral"}}},
                        {"mesh", {{"target_nodes", 3000}}}}
             .dump();
  }
  const std::string cmd = std::string(SOCKETSMITH_BINARY_DIR) + "/socketsmith design " + (dir / "tf.json").string() +
                          " --out " + (dir / "out").string() + " > " + (dir / "log.txt").string() + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << "see " << (dir / "log.txt").string();
  std::ifstream in(dir / "out" / "design.json");
  const auto j = nlohmann::json::parse(in);
  EXPECT_TRUE(j["constraints_met"].get<bool>());
  EXPECT_EQ(j["brim"]["template"], "ics");
  EXPECT_EQ(j["frame"]["axis_source"], "femur");
  EXPECT_EQ(j["frame"]["anterior_source"], "hemipelvis");
  // The brim is not flat, and highest postero-medially where it wraps the tuberosity.
  const double hmin = j["brim"]["min_h_mm"].get<double>(), hmax = j["brim"]["max_h_mm"].get<double>();
  EXPECT_GE(hmax - hmin, 40.0);
  double top_theta = 0, top_h = -1;
  for (const auto& k : j["brim"]["key_points"])
    if (k["h_mm"].get<double>() > top_h) top_h = k["h_mm"].get<double>(), top_theta = k["theta_deg"].get<double>();
  EXPECT_GT(top_theta, 90.0);
  EXPECT_LT(top_theta, 180.0);
  // The tuberosity lies inside the containment: the brim above it by more than 25 mm.
  double is_h = -1;
  for (const auto& l : j["landmarks"])
    if (l["code"] == "IS") is_h = l["h_mm"].get<double>();
  ASSERT_GT(is_h, 0.0);
  EXPECT_GT(top_h, is_h + 25.0);
  // And in 3D (design.json, socket.ischial_check): the bony tuberosity lies inside the socket's
  // cavity — below the brim and within the inner wall.
  const auto& ic = j["socket"]["ischial_check"];
  EXPECT_EQ(ic["kind"], "containment");
  EXPECT_TRUE(ic["inside_cavity"].get<bool>()) << ic["summary"];
  EXPECT_TRUE(ic["met"].get<bool>());
  EXPECT_GT(ic["cavity_margin_mm"].get<double>(), 5.0);
  EXPECT_GT(ic["height_margin_mm"].get<double>(), 25.0);
  EXPECT_FALSE(ic["tuberosity_estimated"].get<bool>());  // from the file's hemipelvis
  // The ischial/gluteal region carries at least the template's share, reported.
  EXPECT_GE(j["ischial_gluteal_share"].get<double>(), j["ischial_share_min"].get<double>() - 1e-3);
  EXPECT_GT(j["ischial_share_min"].get<double>(), 0.0);
  double total = 0;
  for (const auto& r : j["load_shares"]) total += r["share"].get<double>();
  EXPECT_NEAR(total, 1.0, 0.05);
  // The report shows the table; the socket is a closed solid.
  std::ifstream html(dir / "out" / "report.html");
  const std::string report((std::istreambuf_iterator<char>(html)), std::istreambuf_iterator<char>());
  EXPECT_NE(report.find("Axial load by region"), std::string::npos);
  // The transfemoral default closes the loop too: the socket written delivers its design better
  // than the open-loop one did (measured at 3k: MAE 2.44 → 0.60 kPa, 99th percentile 8.35 → 2.77
  // kPa, R 0.60 → 0.92; the bars leave room for the path's noise).
  ASSERT_TRUE(j.contains("closed_loop")) << "a transfemoral design closes the loop by default";
  const auto& below = j["closed_loop"]["regions"]["below_brim"];
  const double open_mae = below["open_loop"]["mae_kpa"].get<double>(), mae = below["closed_loop"]["mae_kpa"].get<double>();
  EXPECT_LT(mae, 0.5 * open_mae);
  EXPECT_LT(mae, 1.0);
  EXPECT_LT(below["closed_loop"]["p99_kpa"].get<double>(), 4.0);
  EXPECT_GT(below["closed_loop"]["r"].get<double>(), 0.85);
  EXPECT_NE(report.find("ischial tuberosity INSIDE the socket"), std::string::npos);
  const auto socket = geometry::read_mesh(dir / "out" / "socket.stl", {});
  EXPECT_TRUE(geometry::check_mesh(socket).is_valid_closed_surface());
}

// `design --axis --anterior` override the case file's limb.axis / limb.anterior: the design's frame
// is the flags' (normalised), said to be given, and the replay case holds the flags' directions.
TEST(DesignFlags, axis_and_anterior_flags_override_the_case_file) {
  const fs::path dir = fs::path(SOCKETSMITH_BINARY_DIR) / "tests" / "pipeline_flags";
  fs::remove_all(dir);
  fs::create_directories(dir);
  {
    std::ofstream c(dir / "case.json");
    c << nlohmann::json{{"socketsmith_case", 1},
                        {"limb", {{"generate_seed", 1}, {"axis", {0.3, 0.0, 1.0}}, {"anterior", {1.0, 0.0, 0.0}}}},
                        {"mesh", {{"target_nodes", 1500}}},
                        {"design", {{"closed_loop", false}}}}
             .dump();
  }
  const std::string cmd = std::string(SOCKETSMITH_BINARY_DIR) + "/socketsmith design " + (dir / "case.json").string() +
                          " --axis 0,0,2 --anterior 0,3,0.5 --out " + (dir / "out").string() + " > " +
                          (dir / "log.txt").string() + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << "see " << (dir / "log.txt").string();
  std::ifstream in(dir / "out" / "design.json");
  const auto j = nlohmann::json::parse(in);
  EXPECT_EQ(j["frame"]["axis_source"], "given");
  EXPECT_EQ(j["frame"]["anterior_source"], "given");
  EXPECT_LT((vec(j["frame"]["axis"]) - Eigen::Vector3d(0, 0, 1)).norm(), 1e-9);
  // The front: the flag's direction made perpendicular to the axis.
  EXPECT_LT((vec(j["frame"]["anterior"]) - Eigen::Vector3d(0, 1, 0)).norm(), 1e-9);
  std::ifstream rc(dir / "out" / "design_case.json");
  const auto replay = nlohmann::json::parse(rc);
  EXPECT_LT((vec(replay["limb"]["axis"]) - Eigen::Vector3d(0, 0, 2)).norm(), 1e-12);
  EXPECT_LT((vec(replay["limb"]["anterior"]) - Eigen::Vector3d(0, 3, 0.5)).norm(), 1e-12);
}

// A TSB brim means total surface bearing: the optimiser evens the pressure out over the whole skin
// below the brim (objective "uniform", a contact row up to the brim). The coefficient of variation
// is recomputed here from surface_nodes.csv.
TEST(TsbCase, a_tsb_design_bears_on_the_whole_skin_below_the_brim) {
  const fs::path dir = fs::path(SOCKETSMITH_BINARY_DIR) / "tests" / "pipeline_tsb";
  fs::remove_all(dir);
  fs::create_directories(dir);
  {
    std::ofstream c(dir / "tsb.json");
    c << nlohmann::json{{"socketsmith_case", 1},
                        {"limb", {{"type", "transtibial"}, {"generate_seed", 3}}},
                        {"brim", {{"template", "tsb"}}},
                        {"mesh", {{"target_nodes", 3000}}},
                        {"design", {{"closed_loop", false}}}}
             .dump();
  }
  const std::string cmd = std::string(SOCKETSMITH_BINARY_DIR) + "/socketsmith design " + (dir / "tsb.json").string() +
                          " --out " + (dir / "out").string() + " > " + (dir / "log.txt").string() + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << "see " << (dir / "log.txt").string();
  std::ifstream in(dir / "out" / "design.json");
  const auto j = nlohmann::json::parse(in);
  EXPECT_TRUE(j["constraints_met"].get<bool>());
  const auto t = report::read_csv(dir / "out" / "surface_nodes.csv");
  const auto a = t.column("area_m2"), p = t.column("pressure_pa"), above = t.column("above_brim");
  double area = 0, pa = 0, p2a = 0;
  for (size_t i = 0; i < a.size(); ++i)
    if (above[i] < 0.5) area += a[i], pa += p[i] * a[i], p2a += p[i] * p[i] * a[i];
  const double mean = pa / area, cv = std::sqrt(std::max(0.0, p2a / area - mean * mean)) / mean;
  EXPECT_LE(cv, 0.35);
  EXPECT_NEAR(cv, j["template_regions"]["cv_below_brim"].get<double>(), 1e-6);
  EXPECT_TRUE(j["template_regions"]["met"].get<bool>());
}

TEST(ModelOptions, a_case_files_tissue_model_and_poisson_ratio_reach_the_model) {
  auto c = design::parse_case(nlohmann::json::parse(R"({"tissue": {"model": "fe", "poisson": 0.48}})"));
  auto o = pipeline::model_options(c);
  EXPECT_EQ(o.kind, tissue::TissueModelKind::StVenantKirchhoff);
  EXPECT_DOUBLE_EQ(o.fe_poisson_ratio, 0.48);
  c = design::parse_case(nlohmann::json::parse(R"({"tissue": {"model": "fe"}})"));
  EXPECT_DOUBLE_EQ(pipeline::model_options(c).fe_poisson_ratio, 0.45);
  c = design::parse_case(nlohmann::json::parse(R"({"tissue": {"model": "mss-cf", "poisson": 0.3}})"));
  EXPECT_DOUBLE_EQ(pipeline::model_options(c).cf_poisson_ratio, 0.3);
  // The neo-Hookean model takes the same ν as the fe model.
  c = design::parse_case(nlohmann::json::parse(R"({"tissue": {"model": "neo-hookean", "poisson": 0.45, "solve": "nonlinear"}})"));
  o = pipeline::model_options(c);
  EXPECT_EQ(o.kind, tissue::TissueModelKind::NeoHookean);
  EXPECT_DOUBLE_EQ(o.fe_poisson_ratio, 0.45);
  EXPECT_EQ(c.solve_mode, design::DesignSolveMode::Nonlinear);
}

/// The optimised demo at 1.5k nodes designed into the tests' folder @p name (emptied first).
void design_demo_1500(const std::string& name, pipeline::DesignArtifacts& art) {
  const fs::path dir = fs::path(SOCKETSMITH_BINARY_DIR) / "tests" / name;
  fs::remove_all(dir);
  design::CaseFile c = pipeline::demo_case(1500);
  c.closed_loop = false;  // the designed socket (the CalculiX checks below don it themselves)
  pipeline::run_design(c, dir, true, {}, &art);
}

// `validate design --printed-wall`: CalculiX dons the written socket's inner wall, only its faces
// that look towards the limb's axis (the lip's outer half caught the demo's skin in ccx). Without
// the flag nothing is built.
TEST(DesignedStump, the_printed_wall_is_the_written_sockets_cavity_facing_the_axis) {
  pipeline::DesignArtifacts art;
  design_demo_1500("pipeline_printed_wall", art);
  ASSERT_TRUE(art.result.socket.has_value());
  EXPECT_TRUE(pipeline::designed_stump(art).socket_wall.empty());
  const geometry::TriMesh wall = pipeline::designed_stump(art, true).socket_wall;
  ASSERT_GT(wall.num_triangles(), 500);
  const auto& f = art.setup->model.frame;
  const Eigen::Vector3d a = f.axis.normalized();
  double solid_top = -1e30, solid_bottom = 1e30, wall_top = -1e30, wall_bottom = 1e30;
  for (const auto& v : art.result.socket->solid.vertices) {
    solid_top = std::max(solid_top, (v - f.origin).dot(a));
    solid_bottom = std::min(solid_bottom, (v - f.origin).dot(a));
  }
  for (const auto& t : wall.triangles) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int v : t) {
      c += wall.vertices[v] / 3.0;
      wall_top = std::max(wall_top, (wall.vertices[v] - f.origin).dot(a));
      wall_bottom = std::min(wall_bottom, (wall.vertices[v] - f.origin).dot(a));
    }
    const Eigen::Vector3d n = (wall.vertices[t[1]] - wall.vertices[t[0]]).cross(wall.vertices[t[2]] - wall.vertices[t[0]]);
    const Eigen::Vector3d r = (c - f.origin) - (c - f.origin).dot(a) * a;
    EXPECT_LE(n.dot(r), 0.0) << "a face looking away from the axis";
  }
  // The cavity from its floor to the brim: inside the solid, reaching within a wall's thickness of its top.
  EXPECT_LE(wall_top, solid_top + 1e-9);
  EXPECT_GT(wall_top, solid_top - 0.008);
  EXPECT_GE(wall_bottom, solid_bottom - 1e-9);
}

// The donning check's shell is laid on the wall socketsmith's own donning touches (the smoothed
// wall fitted to the rest skin): DesignedStump::wall_surface projects a point near the wall onto
// it. On the 1.5k demo's socket: the designed skin below the brim lies within a millimetre of it
// (the socket is the designed skin), the projection is idempotent, a point 2 mm inside the cavity
// lands where the skin node itself does, the normal points out of the cavity, and a point far
// from the wall is refused.
TEST(DesignedStump, the_shell_is_laid_on_socketsmiths_smoothed_wall) {
  pipeline::DesignArtifacts art;
  design_demo_1500("pipeline_wall_surface", art);
  ASSERT_TRUE(art.result.socket.has_value());
  const auto d = pipeline::designed_stump(art);
  ASSERT_TRUE(static_cast<bool>(d.wall_surface));
  const auto& skin = *d.skin;
  int checked = 0;
  double worst = 0, worst_inside = 0;
  for (size_t i = 0; i < skin.nodes.size(); ++i) {
    if (d.above_brim[i]) continue;
    const Eigen::Vector3d p = d.designed_positions[skin.nodes[i]], n = d.skin_normals[i].normalized();
    const auto on = d.wall_surface(p);
    if (!on) continue;  // the distal cup's pad, the brim's rim: not every node faces the smoothed wall
    ++checked;
    worst = std::max(worst, (on->first - p).norm());
    EXPECT_NEAR(on->second.norm(), 1.0, 1e-9);
    EXPECT_GT(on->second.dot(n), 0.5) << "skin node " << i;
    const auto again = d.wall_surface(on->first);
    ASSERT_TRUE(again.has_value());
    EXPECT_LT((again->first - on->first).norm(), 1e-7);
    const auto from_inside = d.wall_surface(on->first - 0.0005 * on->second);
    ASSERT_TRUE(from_inside.has_value());
    worst_inside = std::max(worst_inside, (from_inside->first - on->first).norm());
  }
  int below = 0;
  for (char a : d.above_brim) below += !a;
  EXPECT_GT(checked, below * 9 / 10);
  EXPECT_LT(worst, 1e-3);
  // Newton follows the smoothed gap's gradient, not a straight normal: 0.1–0.4 mm along the wall on
  // this socket (measured 2026-12-01), a shift along the surface, not off it.
  EXPECT_LT(worst_inside, 0.5e-3);
  EXPECT_FALSE(d.wall_surface(d.frame.origin + 0.5 * d.stump_length_m * d.frame.axis.normalized()).has_value());  // on the axis, far from the wall
}

// summary.json's "fe_socket" says which socket CalculiX checked, for every combination of the flags.
TEST(DesignValidation, the_summary_names_the_socket_calculix_checked) {
  calculix::DesignCheckOptions o;
  EXPECT_EQ(pipeline::fe_socket_description(o), "skin quads below the brim, fitted onto the designed skin");
  o.mode = calculix::DesignCheckMode::Load;
  EXPECT_EQ(pipeline::fe_socket_description(o), "none (designed loads)");
  o.mode = calculix::DesignCheckMode::Donning;
  EXPECT_EQ(pipeline::fe_socket_description(o), "skin quads below the brim, through the wall at the skin nodes");
  o.shell_subdivision = 2;
  o.shell_on_wall = true;
  o.shell_lip = true;
  EXPECT_EQ(pipeline::fe_socket_description(o),
            "skin quads below the brim, each split 2 x 2, laid on socketsmith's smoothed wall, across the brim onto its lip");
  o = {};
  o.mode = calculix::DesignCheckMode::Donning;
  o.printed_wall = true;
  EXPECT_EQ(pipeline::fe_socket_description(o), "the printed socket's inner wall (C3D6 wedges)");
}

// CalculiX's contact penalty: a donning presses with socketsmith's own (the same contact law on both
// sides) unless told otherwise; a fitted socket, or a loop donned on a rigid wall, with the deck's 1e9.
TEST(DesignValidation, a_donning_is_checked_with_socketsmiths_own_contact_penalty) {
  design::CaseFile c;
  pipeline::DesignValidationOptions o;
  const double ours = 2.5e8, deck = calculix::DesignCheckOptions{}.contact.penalty_pa_per_m;
  ASSERT_DOUBLE_EQ(deck, 1e9);
  o.mode = calculix::DesignCheckMode::Contact;
  EXPECT_DOUBLE_EQ(pipeline::calculix_penalty_pa_per_m(c, o, ours), deck);
  o.mode = calculix::DesignCheckMode::Donning;
  EXPECT_DOUBLE_EQ(pipeline::calculix_penalty_pa_per_m(c, o, ours), ours);
  o.penalty_pa_per_m = 4e8;
  EXPECT_DOUBLE_EQ(pipeline::calculix_penalty_pa_per_m(c, o, ours), 4e8);
  o.penalty_pa_per_m = 0.0;  // `--penalty 0`: socketsmith's, whatever the mode
  o.mode = calculix::DesignCheckMode::Contact;
  EXPECT_DOUBLE_EQ(pipeline::calculix_penalty_pa_per_m(c, o, ours), ours);
  o.penalty_pa_per_m.reset();
  o.mode = calculix::DesignCheckMode::Donning;
  c.closed_loop_rigid_wall = true;
  EXPECT_DOUBLE_EQ(pipeline::calculix_penalty_pa_per_m(c, o, ours), deck);
}

// CalculiX's socket: a donned socket is the shell split 2 x 2 with the written socket's lip across
// the brim unless told otherwise; no lip without a written socket, for the printed wall or a fitted
// socket; an explicit subdivision or --no-shell-lip is kept.
TEST(DesignValidation, a_donned_socket_is_checked_with_its_lip_by_default) {
  pipeline::DesignValidationOptions o;
  calculix::DesignCheckOptions co;
  o.mode = calculix::DesignCheckMode::Donning;
  pipeline::calculix_shell(o, true, co);
  EXPECT_TRUE(co.shell_lip);
  EXPECT_EQ(co.shell_subdivision, 2);
  EXPECT_FALSE(co.shell_on_wall);
  pipeline::calculix_shell(o, false, co);  // no socket written: nothing to take the lip from
  EXPECT_FALSE(co.shell_lip);
  EXPECT_EQ(co.shell_subdivision, 1);
  o.printed_wall = true;
  pipeline::calculix_shell(o, true, co);
  EXPECT_TRUE(co.printed_wall);
  EXPECT_FALSE(co.shell_lip);
  EXPECT_EQ(co.shell_subdivision, 1);
  o.printed_wall = false;
  o.shell_lip = false;  // --no-shell-lip
  pipeline::calculix_shell(o, true, co);
  EXPECT_FALSE(co.shell_lip);
  EXPECT_EQ(co.shell_subdivision, 1);
  o.shell_subdivision = 3;
  pipeline::calculix_shell(o, true, co);
  EXPECT_EQ(co.shell_subdivision, 3);
  o = {};
  o.mode = calculix::DesignCheckMode::Contact;
  pipeline::calculix_shell(o, true, co);
  EXPECT_FALSE(co.shell_lip);
  EXPECT_EQ(co.shell_subdivision, 1);
}

// The GUI's rectification chart (issue 23) is computed from a solved state before anything is
// written: pipeline::designed_wall builds the socket as solve_design does and picks its wall as the
// report does. On the optimised 1.5k demo (every constraint met, no closed loop) it must give the
// report's chart to the last bit; a state that misses a constraint is measured on its designed skin.
TEST(DesignedWall, the_chart_of_a_solved_state_is_the_reports) {
  pipeline::DesignArtifacts art;
  design_demo_1500("pipeline_designed_wall", art);
  ASSERT_TRUE(art.result.socket.has_value());
  ASSERT_FALSE(art.result.closed_loop.has_value());
  const pipeline::DesignSetup& setup = *art.setup;
  const pipeline::ProsthetistChecks report = pipeline::prosthetist_checks(setup, art.result);
  const pipeline::ChecksWall wall =
      pipeline::designed_wall(art.result.rest_skin, art.result.deformed_skin, art.result.state.status.all_ok(),
                              setup.model.frame, setup.brim, setup.case_file.socket);
  EXPECT_EQ(wall.source, "the socket's inner wall");
  EXPECT_EQ(wall.source, report.wall_source);
  EXPECT_EQ(wall.closed_below_m, report.socket_closed_below_m);
  ASSERT_EQ(wall.wall.vertices.size(), report.wall.vertices.size());
  const pipeline::Rectification gui = pipeline::compute_rectification(art.result.rest_skin, wall.wall,
                                                                        setup.model.frame, setup.brim,
                                                                        setup.model.landmarks);
  const pipeline::Rectification& lib = report.rectification;
  ASSERT_EQ(gui.vertex_m.size(), lib.vertex_m.size());
  int below_brim = 0;
  for (size_t k = 0; k < lib.vertex_m.size(); ++k) {
    ASSERT_EQ(std::isfinite(gui.vertex_m[k]), std::isfinite(lib.vertex_m[k])) << k;
    if (!std::isfinite(lib.vertex_m[k])) continue;
    ++below_brim;
    EXPECT_EQ(gui.vertex_m[k], lib.vertex_m[k]) << k;
  }
  EXPECT_GT(below_brim, 300);
  ASSERT_EQ(gui.landmarks.size(), lib.landmarks.size());
  for (size_t k = 0; k < lib.landmarks.size(); ++k) {
    EXPECT_EQ(gui.landmarks[k].code, lib.landmarks[k].code);
    EXPECT_EQ(pipeline::rectification_kind(gui.landmarks[k].rectification_m),
              pipeline::rectification_kind(lib.landmarks[k].rectification_m));
  }
  // The demo's socket indents: a negative mean, and its colour bar (± the span) holds the range.
  EXPECT_LT(lib.mean_m, -0.5e-3);
  const double span_mm = pipeline::rectification_span_mm(lib);
  EXPECT_GE(span_mm, std::max(-lib.min_m, lib.max_m) * 1e3);
  // Not met: no socket; the designed skin itself is the wall.
  const pipeline::ChecksWall skin = pipeline::designed_wall(art.result.rest_skin, art.result.deformed_skin, false,
                                                            setup.model.frame, setup.brim, setup.case_file.socket);
  EXPECT_EQ(skin.source, "the designed skin (no socket was built)");
  EXPECT_EQ(skin.wall.vertices, art.result.deformed_skin.vertices);
  EXPECT_STREQ(pipeline::rectification_kind(-1e-3), "indentation");
  EXPECT_STREQ(pipeline::rectification_kind(0.0), "relief");
  EXPECT_STREQ(pipeline::rectification_kind(std::nan("")), "above the brim");
}

}  // namespace
}  // namespace socketsmith
