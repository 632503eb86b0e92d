// Issue 22 on designed stumps: the demo's deformed skin (pipeline::demo_case at a low resolution)
// with a four-hole attachment, checked by tests/design/socket_check.h's own distances — the wall at
// least 0.95 × the asked thickness everywhere but the brim band, the platform flat, its holes where
// the case puts them, watertight, no self-intersection; the outputs that report it; a design whose
// follower iteration cannot converge gets no socket. The slow-labelled build
// (SOCKETSMITH_REAL_LIMBS) runs every limb of ../shared/data.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "../design/socket_check.h"
#include "socketsmith/core/units.h"
#include "socketsmith/design/case_file.h"
#include "socketsmith/design/template_regions.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/volume/hex_mesher.h"
#include "socketsmith/volume/limb_model.h"

namespace socketsmith {
namespace {

namespace fs = std::filesystem;
constexpr double kMm = units::mm, kDeg = units::deg;

void print_measured(const std::string& name, const design::SocketResult& r, const wall_check::SocketCheck& check) {
  std::printf("[ measured ] %s: builder wall min %.3f / median %.3f / max %.3f mm (min ratio %.3f); independent %s\n",
              name.c_str(), r.min_thickness_m / kMm, r.median_thickness_m / kMm, r.max_thickness_m / kMm,
              r.min_thickness_ratio, check.text().c_str());
}

#ifndef SOCKETSMITH_REAL_LIMBS

TEST(DesignedSocket, the_demo_with_an_attachment_keeps_its_wall_and_is_drilled_where_the_case_says) {
  design::CaseFile c = pipeline::demo_case(1500);
  c.socket.alignment = {6 * kDeg, 2 * kDeg};
  c.socket.attachment.enabled = true;
  c.socket.attachment.rotation_rad = 20 * kDeg;
  c.socket.attachment.offset_anterior_m = 2 * kMm;
  c.socket.attachment.offset_medial_m = -1 * kMm;
  c.closed_loop = false;  // the designed socket's wall and drilling
  auto setup = pipeline::prepare_design(c);
  const pipeline::DesignResult res = pipeline::solve_design(*setup, true);
  ASSERT_TRUE(res.constraints_met) << res.state.message;
  ASSERT_TRUE(res.socket.has_value());
  const auto& sock = *res.socket;
  const auto check = wall_check::check_socket(sock, res.deformed_skin, setup->model.frame, setup->brim, c.socket);
  EXPECT_TRUE(check.failures.empty()) << check.text();
  print_measured("demo 1.5k, attachment", sock, check);

  // The outputs: design.json's wall and holes, the thickness map and field, the STL a solid.
  const fs::path out = fs::path(SOCKETSMITH_BINARY_DIR) / "tests" / "designed_socket_demo";
  fs::remove_all(out);
  const nlohmann::json j = pipeline::write_design_outputs(*setup, res, out, 0.0);
  const auto& js = j.at("socket");
  EXPECT_NEAR(js.at("min_thickness_mm").get<double>(), sock.min_thickness_m / kMm, 1e-9);
  EXPECT_NEAR(js.at("median_thickness_mm").get<double>(), sock.median_thickness_m / kMm, 1e-9);
  EXPECT_GE(js.at("min_thickness_mm").get<double>(), 0.95 * 5.0);
  EXPECT_GT(js.at("max_thickness_mm").get<double>(), 5.0 + 10.0);  // the platform
  ASSERT_TRUE(js.contains("attachment"));
  EXPECT_EQ(js.at("attachment").at("hole_centres_mm").size(), 4u);
  EXPECT_GE(js.at("attachment").at("min_hole_depth_mm").get<double>(), 10.0 - 1e-6);
  EXPECT_NEAR(js.at("alignment").at("flexion_deg").get<double>(), 6.0, 1e-9);
  for (const char* f : {"socket.stl", "socket.vtp", "thickness_map.png", "report.html"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  std::ifstream html(out / "report.html");
  const std::string page((std::istreambuf_iterator<char>(html)), std::istreambuf_iterator<char>());
  EXPECT_NE(page.find("measured wall (min / median / max)"), std::string::npos);
  EXPECT_NE(page.find("4 × 6.6 mm holes (M6 bolts)"), std::string::npos);
  geometry::MeshReadOptions ro;
  ro.unit = units::LengthUnit::Millimetre;
  const auto stl = geometry::read_mesh(out / "socket.stl", ro);
  const auto rep = geometry::check_mesh(stl);
  EXPECT_TRUE(rep.is_valid_closed_surface()) << (rep.problems().empty() ? "" : rep.problems().front());
  EXPECT_FALSE(geometry::has_self_intersections(stl));
}

TEST(DesignedSocket, a_design_whose_follower_iteration_cannot_converge_gets_no_socket) {
  // The follower iteration is the linear solve's (the nonlinear one has the follower load in its
  // Newton tangent): the demo's stump as the thesis's lattice, linearised, whose skin moves enough
  // under the design's pressures that one pass cannot settle it (the nearly incompressible
  // neo-Hookean stump moves less: one pass from rest meets the tolerance there).
  design::CaseFile c = pipeline::demo_case(1500);
  c.model = "mss-cs";
  c.solve_mode = design::DesignSolveMode::Linear;
  auto setup = pipeline::prepare_design(c);
  // The same stump with a follower iteration capped at one pass (from rest, no relaxation).
  design::DesignSolverOptions capped;
  capped.mode = c.solve_mode;
  capped.max_follower_passes = 1;
  capped.max_relaxed_passes = 0;
  setup->solver = std::make_unique<design::DesignSolver>(setup->mesh.mesh, setup->material, setup->model_options,
                                                         setup->model.frame, setup->thresholds, c.patient,
                                                         setup->model.length_m, capped);
  const auto& brim = setup->brim;
  setup->solver->set_brim([&brim](double theta) { return brim.height(theta); });
  const pipeline::DesignResult res = pipeline::solve_design(*setup, true);
  EXPECT_FALSE(res.constraints_met);
  EXPECT_FALSE(res.socket.has_value());
  EXPECT_TRUE(res.state.follower_capped);
  const fs::path out = fs::path(SOCKETSMITH_BINARY_DIR) / "tests" / "designed_socket_capped";
  fs::remove_all(out);
  const nlohmann::json j = pipeline::write_design_outputs(*setup, res, out, 0.0);
  EXPECT_FALSE(j.at("constraints_met").get<bool>());
  EXPECT_FALSE(j.at("follower_converged").get<bool>());
  EXPECT_NE(j.at("failing").get<std::string>().find("follower iteration"), std::string::npos) << j.at("failing");
  EXPECT_NE(j.at("optimiser_message").get<std::string>().find("follower iteration"), std::string::npos);
  EXPECT_FALSE(fs::exists(out / "socket.stl"));
}

#else

/// A real limb: designed (transtibial: the pipeline's optimiser on the limb, the socket on its
/// deformed skin) or, for the transfemoral limb that has no default thresholds, its rest skin.
struct RealLimb {
  const char* name;
  const char* file;
  const char* bones;
  bool transfemoral;
};

class RealLimbSocket : public ::testing::TestWithParam<RealLimb> {};

TEST_P(RealLimbSocket, keeps_its_wall_with_an_attachment) {
  const RealLimb l = GetParam();
  const fs::path file = fs::path(SOCKETSMITH_SHARED_DATA_DIR) / "limbs" / l.file;
  if (!fs::exists(file)) GTEST_SKIP() << "shared data absent: " << file;
  design::SocketOptions o;
  o.attachment.enabled = true;
  geometry::TriMesh skin;
  geometry::LimbFrame frame;
  design::BrimLine brim;
  std::string status;
  if (!l.transfemoral) {
    const design::CaseFile c = design::parse_case(nlohmann::json{
        {"limb", {{"file", file.string()}, {"units", "mm"}, {"bones", l.bones}}},
        {"mesh", {{"target_nodes", 8000}}},
        {"design", {{"closed_loop", false}}}});
    auto setup = pipeline::prepare_design(c);
    const pipeline::DesignResult res = pipeline::solve_design(*setup, true);
    status = res.constraints_met ? "design met" : "design not met: " + res.state.message;
    skin = res.deformed_skin;
    frame = setup->model.frame;
    brim = setup->brim;
  } else {
    geometry::MeshReadOptions ro;
    ro.unit = units::LengthUnit::Metre;
    ro.warn_on_implausible_size = false;
    geometry::TriMesh limb = geometry::read_mesh(file, ro);
    geometry::scale(limb, 0.45);  // normalised to the femur's length (../shared/data/README.md)
    volume::LimbInputOptions lo;
    lo.type = geometry::LimbType::Transfemoral;
    const auto model = volume::prepare_limb(limb, {}, lo);
    volume::HexMesherOptions mo;
    mo.target_nodes = 8000;
    skin = volume::extract_skin_surface(volume::mesh_limb(volume::mesher_input(model), mo).mesh).triangles();
    frame = model.frame;
    brim = design::make_brim(design::BrimTemplate::Quad, model);
    status = "rest skin";
  }
  const design::SocketResult r = design::build_socket(skin, frame, brim, o);
  const auto check = wall_check::check_socket(r, skin, frame, brim, o);
  EXPECT_TRUE(check.failures.empty()) << l.name << ": " << check.text();
  print_measured(std::string(l.name) + " (" + status + ")", r, check);
}

INSTANTIATE_TEST_SUITE_P(
    SharedData, RealLimbSocket,
    ::testing::Values(RealLimb{"openlimb_tt", "transtibial/openlimb_tt_mean_limb_with_bones_mm.stl", "auto", false},
                      RealLimb{"openlimb_tt_skin", "transtibial/openlimb_tt_mean_skin_mm.stl", "estimate", false},
                      RealLimb{"ampscan_tt", "transtibial/ampscan_limb_scan_mm.stl", "estimate", false},
                      RealLimb{"openlimb_tf", "transfemoral/openlimb_tf_mean_limb_normalised.stl", "auto", true}),
    [](const auto& param_info) { return std::string(param_info.param.name); });

/// A design of the default case at 3k nodes on a generated limb (seed, type) or a shared
/// transtibial file, with brim @p brim ("" = the type's default).
struct TemplateCase {
  std::string name;
  std::string file;  // under ../shared/data/limbs; empty: generated
  int seed = 1;
  bool transfemoral = false;
  std::string brim;
};

class EveryLimb : public ::testing::TestWithParam<TemplateCase> {};

// Issue 22's "done when" on every transtibial limb of ../shared/data and 10 generated limbs of
// both types: the designed socket keeps its wall (this file's own distances), and a PTB design
// means PTB (tolerant ≥ 1.5 × sensitive mean pressure, distal fifth ≤ 10 % of the axial load) and
// a TSB design bears evenly (CV below the brim ≤ 0.35) — recomputed here from the solved state.
TEST_P(EveryLimb, the_socket_keeps_its_wall_and_the_design_means_its_template) {
  const TemplateCase t = GetParam();
  nlohmann::json limb = {{"type", t.transfemoral ? "transfemoral" : "transtibial"}};
  if (t.file.empty()) {
    limb["generate_seed"] = t.seed;
  } else {
    const fs::path file = fs::path(SOCKETSMITH_SHARED_DATA_DIR) / "limbs" / t.file;
    if (!fs::exists(file)) GTEST_SKIP() << "shared data absent: " << file;
    limb["file"] = file.string();
    limb["units"] = "mm";
  }
  nlohmann::json doc = {{"limb", limb}, {"mesh", {{"target_nodes", 3000}}}, {"design", {{"closed_loop", false}}}};
  if (!t.brim.empty()) doc["brim"] = {{"template", t.brim}};
  const design::CaseFile c = design::parse_case(doc);
  auto setup = pipeline::prepare_design(c);
  const pipeline::DesignResult res = pipeline::solve_design(*setup, true);
  ASSERT_TRUE(res.constraints_met) << t.name << ": " << res.state.message;
  ASSERT_TRUE(res.socket.has_value());
  const auto check = wall_check::check_socket(*res.socket, res.deformed_skin, setup->model.frame, setup->brim, c.socket);
  EXPECT_TRUE(check.failures.empty()) << t.name << ": " << check.text();
  print_measured(t.name, *res.socket, check);
  if (t.transfemoral) return;
  // The template, from the state: pressures, deformed normals and areas, rest positions.
  const auto& st = res.state;
  const auto& solver = *setup->solver;
  const auto m = design::template_masks(setup->brim.kind(), setup->model.landmarks, solver.skin().positions,
                                        solver.above_brim(), setup->model.frame, setup->model.length_m);
  const Eigen::Vector3d ez = setup->model.frame.axis;
  double all = 0, distal = 0, tol_pa = 0, tol_a = 0, sen_pa = 0, sen_a = 0, a = 0, pa = 0, p2a = 0;
  for (size_t i = 0; i < st.pressure_pa.size(); ++i) {
    const double p = st.pressure_pa[i], ar = st.skin_areas[i], cz = st.skin_normals[i].dot(ez);
    const double axial = -p * ar * cz + c.patient.friction * p * ar * std::sqrt(std::max(0.0, 1 - cz * cz));
    all += axial;
    if (m.distal_fifth[i]) distal += axial;
    if (m.tolerant[i]) tol_pa += p * ar, tol_a += ar;
    if (m.sensitive[i]) sen_pa += p * ar, sen_a += ar;
    if (!solver.above_brim()[i]) a += ar, pa += p * ar, p2a += p * p * ar;
  }
  const double mean = pa / a, cv = std::sqrt(std::max(0.0, p2a / a - mean * mean)) / mean;
  if (t.brim == "tsb") {
    std::printf("[ measured ] %s: CV below the brim %.3f\n", t.name.c_str(), cv);
    EXPECT_LE(cv, 0.35) << t.name;
  } else {
    const double ratio = (tol_pa / tol_a) / (sen_pa / sen_a);
    std::printf("[ measured ] %s: tolerant / sensitive %.2f, distal fifth %.1f %%\n", t.name.c_str(), ratio,
                100 * distal / all);
    EXPECT_GE(ratio, 1.5) << t.name;
    EXPECT_LE(distal / all, 0.10) << t.name;
  }
}

std::vector<TemplateCase> every_limb() {
  std::vector<TemplateCase> v;
  for (const char* brim : {"ptb", "tsb"}) {
    for (int seed = 1; seed <= 10; ++seed)
      v.push_back({fmt::format("generated_tt_{}_{}", seed, brim), "", seed, false, brim});
    v.push_back({fmt::format("openlimb_tt_{}", brim), "transtibial/openlimb_tt_mean_limb_with_bones_mm.stl", 0, false, brim});
    v.push_back({fmt::format("openlimb_tt_skin_{}", brim), "transtibial/openlimb_tt_mean_skin_mm.stl", 0, false, brim});
    v.push_back({fmt::format("ampscan_tt_{}", brim), "transtibial/ampscan_limb_scan_mm.stl", 0, false, brim});
  }
  for (int seed = 1; seed <= 10; ++seed) v.push_back({fmt::format("generated_tf_{}", seed), "", seed, true, ""});
  return v;
}

INSTANTIATE_TEST_SUITE_P(SharedAndGenerated, EveryLimb, ::testing::ValuesIn(every_limb()),
                         [](const auto& param_info) { return param_info.param.name; });

#endif

}  // namespace
}  // namespace socketsmith
