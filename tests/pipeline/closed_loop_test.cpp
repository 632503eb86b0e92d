// The closed-loop design: the stump's skin compliance (reciprocity, direction), and the loop on the
// embedded sample at 1.8k nodes — the corrected socket delivers the design better than the open-loop
// one, the numbers reported are those of the socket written (re-donned here independently), and the
// outputs carry them.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <tuple>

#include <nlohmann/json.hpp>

#include "socketsmith/contact/donning.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"
#include "socketsmith/pipeline/closed_loop.h"
#include "socketsmith/pipeline/closed_loop_correction.h"
#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/pipeline/validation_inputs.h"
#include "socketsmith/report/csv.h"

namespace socketsmith::pipeline {
namespace {
namespace fs = std::filesystem;

/// MAE, 99th percentile (nearest rank) and R of a against b over the nodes where use is 1, written
/// out here independently of report::compare_fields.
struct Agreement {
  double mae = 0, p99 = 0, r = 0, mean_a = 0, mean_b = 0;
};
Agreement agreement(const std::vector<double>& a, const std::vector<double>& b, const std::vector<char>& use) {
  std::vector<double> e;
  double sa = 0, sb = 0;
  for (size_t i = 0; i < a.size(); ++i)
    if (use[i]) {
      e.push_back(std::abs(a[i] - b[i]));
      sa += a[i];
      sb += b[i];
    }
  const double n = static_cast<double>(e.size());
  Agreement g;
  for (double v : e) g.mae += v / n;
  std::sort(e.begin(), e.end());
  g.p99 = e[static_cast<size_t>(std::ceil(0.99 * n)) - 1];
  double cab = 0, caa = 0, cbb = 0;
  for (size_t i = 0; i < a.size(); ++i)
    if (use[i]) {
      const double da = a[i] - sa / n, db = b[i] - sb / n;
      cab += da * db;
      caa += da * da;
      cbb += db * db;
    }
  g.r = cab / std::sqrt(caa * cbb);
  g.mean_a = sa / n;
  g.mean_b = sb / n;
  return g;
}

/// run_design of @p c in a folder of this process's named @p name, removed after; @p art filled.
nlohmann::json run_design_scratch(const design::CaseFile& c, const std::string& name, bool optimise,
                                  DesignArtifacts& art) {
  const fs::path out = fs::path(SOCKETSMITH_BINARY_DIR) / "tests" / (name + "_" + std::to_string(::getpid()));
  nlohmann::json j = run_design(c, out, optimise, {}, &art);
  fs::remove_all(out);
  return j;
}

class ClosedLoopRun : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // One folder per process: CTest runs each test of the suite as its own process, in parallel,
    // and one process's remove_all emptied the folder another was checking.
    out_ = fs::path(SOCKETSMITH_BINARY_DIR) / "tests" / ("closed_loop_" + std::to_string(::getpid()));
    fs::remove_all(out_);
    design::CaseFile c = demo_case(1800);
    c.closed_loop = true;
    c.closed_loop_donnings = 3;
    c.closed_loop_max_brim_raise_m = 0.010;  // the loop may raise the socket's brim (off by default)
    art_ = new DesignArtifacts;
    summary_ = new nlohmann::json(run_design(c, out_, true, {}, art_));
  }
  static void TearDownTestSuite() {
    delete art_;
    delete summary_;
    fs::remove_all(out_);
  }
  static fs::path out_;
  static DesignArtifacts* art_;
  static nlohmann::json* summary_;
};
fs::path ClosedLoopRun::out_;
DesignArtifacts* ClosedLoopRun::art_ = nullptr;
nlohmann::json* ClosedLoopRun::summary_ = nullptr;

TEST_F(ClosedLoopRun, skin_compliance_is_reciprocal_and_pressure_pushes_the_skin_in) {
  auto& solver = *art_->setup->solver;
  const auto& state = art_->result.state;
  const auto& skin = solver.skin();
  const size_t n = skin.nodes.size();
  // Two different fields: a distal one and a band on the anterior side.
  std::vector<double> p1(n, 0.0), p2(n, 0.0), uniform(n, 1e3);
  for (size_t i = 0; i < n; ++i) {
    const auto& cy = solver.skin_cylindrical()[i];
    p1[i] = cy.h < 0.05 ? 5e3 : 0.0;
    p2[i] = std::abs(cy.theta) < 0.6 ? 8e3 * (1 + cy.h) : 0.0;
  }
  const auto u1 = solver.normal_displacement(p1, state), u2 = solver.normal_displacement(p2, state);
  // Maxwell–Betti: the work of load 1 through displacement 2 equals that of load 2 through 1
  // (f_i = −p_i A_i n_i, so f·u = −Σ p A u_n).
  double w12 = 0, w21 = 0, scale = 0;
  for (size_t i = 0; i < n; ++i) {
    w12 += p1[i] * state.skin_areas[i] * u2[i];
    w21 += p2[i] * state.skin_areas[i] * u1[i];
    scale += std::abs(p1[i] * state.skin_areas[i] * u1[i]);
  }
  EXPECT_NEAR(w12, w21, 1e-9 * scale);
  // A uniform pressure squeezes the stump: the skin moves in (its area-weighted mean normal
  // displacement is negative) and the response is linear.
  const auto uu = solver.normal_displacement(uniform, state);
  double mean = 0, area = 0;
  for (size_t i = 0; i < n; ++i) {
    mean += state.skin_areas[i] * uu[i];
    area += state.skin_areas[i];
  }
  EXPECT_LT(mean / area, 0.0);
  std::vector<double> twice(n, 2e3);
  const auto u2x = solver.normal_displacement(twice, state);
  for (size_t i = 0; i < n; i += 37) EXPECT_NEAR(u2x[i], 2 * uu[i], 1e-12 + 1e-9 * std::abs(uu[i]));
  std::vector<double> bad(n, 0.0);
  bad[3] = std::nan("");
  EXPECT_THROW(solver.normal_displacement(bad, state), InvalidInputError);
  EXPECT_THROW(solver.normal_displacement(std::vector<double>(n - 1, 0.0), state), InvalidInputError);
}

TEST_F(ClosedLoopRun, the_corrected_socket_delivers_the_design_better_than_the_open_loop_one) {
  ASSERT_TRUE(art_->result.closed_loop.has_value());
  const ClosedLoopResult& loop = *art_->result.closed_loop;
  ASSERT_GE(loop.iterations.size(), 2u) << loop.message;
  const Agreement open = agreement(loop.open_loop_pa, loop.target_pa, loop.below_brim);
  const Agreement closed = agreement(loop.closed_loop_pa, loop.target_pa, loop.below_brim);
  // The figures reported are these (an independent computation of the same statistics).
  EXPECT_NEAR(loop.iterations[0].below_brim.mae, open.mae, 1e-6);
  EXPECT_NEAR(loop.iterations[loop.best].below_brim.mae, closed.mae, 1e-6);
  EXPECT_NEAR(loop.iterations[loop.best].below_brim.p99, closed.p99, 1e-6);
  // Measured at 1.8k nodes (the default neo-Hookean stump, nonlinear; pressures per deformed area;
  // converged after 3 donnings + 12 refits, the socket's brim raised up to 9.9 mm where donning
  // dragged skin above it, none left out, 2026-12-05): MAE 3.47 → 0.33 kPa, 99th percentile 13.98 →
  // 3.41 kPa, R 0.827 → 0.994. Bars: issue 20's MAE (1.5 kPa) and R (0.95) with a margin below them,
  // and a 99th percentile with a margin over its 4 kPa (4.29 per rest area, 2026-12-02). (With the
  // design's brim, 3 nodes dragged above it: MAE 0.67, p99 6.4, R 0.962; when those nodes still
  // corrected the wall: MAE 0.95, p99 9.5.)
  EXPECT_LT(closed.mae, 0.5 * open.mae) << "open " << open.mae << " Pa, closed " << closed.mae << " Pa";
  EXPECT_LT(closed.mae, 1.2e3);
  EXPECT_LT(closed.p99, 5e3);
  EXPECT_GT(closed.r, open.r);
  EXPECT_GT(closed.r, 0.94);
  EXPECT_NEAR(closed.mean_a, closed.mean_b, 0.05 * closed.mean_b);  // the level: no gap left
  // The socket kept is the socket written, and it delivers what the loop reported: don it again.
  ASSERT_TRUE(art_->result.socket.has_value());
  EXPECT_EQ(art_->result.socket->solid.num_triangles(), loop.socket.solid.num_triangles());
  const auto& setup = *art_->setup;
  contact::DonningOptions o;
  o.friction = setup.case_file.patient.friction;
  o.stand_force_n = 0.5 * setup.case_file.patient.body_mass_kg * units::kGravity;
  o.contact.linear_body = loop.linear_body;  // the body the loop donned (the design's)
  const auto& skin = setup.solver->skin();
  o.skin = &skin;  // pressures per deformed area, as the loop's
  const auto d = contact::simulate_donning(setup.solver->model(), skin.nodes, skin.area_m2, art_->result.socket->solid,
                                           setup.model.frame, o);
  ASSERT_TRUE(d.completed && d.stood) << d.message;
  for (size_t i = 0; i < skin.nodes.size(); ++i)
    EXPECT_NEAR(d.contacts[i].pressure_pa, loop.closed_loop_pa[i], 1.0) << "skin node " << i;
  // The nodes flagged as dragged out of the socket are those this donning leaves above the socket's
  // brim (height above brim(θ) in the socket's frame, from the cylindrical coordinates here), and
  // the in-socket figures are over the others.
  const auto& frame = setup.model.frame;
  const design::BrimLine& brim = loop.socket_brim;
  const Eigen::Vector3d stood = d.final_offset_m * frame.axis.normalized();
  std::vector<char> in_socket(skin.nodes.size(), 0);
  int dragged = 0;
  double highest = 0;
  const auto& kept = loop.iterations[loop.best];
  for (size_t i = 0; i < skin.nodes.size(); ++i) {
    if (!loop.below_brim[i]) continue;
    const auto cy = frame.to_cylindrical(d.positions.segment<3>(3 * skin.nodes[i]) - stood);
    const bool above = cy.h > brim.height(cy.theta);
    EXPECT_EQ(loop.dragged_out[i] != 0, above) << "skin node " << i;
    dragged += above ? 1 : 0;
    in_socket[i] = above ? 0 : 1;
    if (!above) continue;
    highest = std::max(highest, cy.h - brim.height(cy.theta));
    // Inside the arc reported (degrees from anterior towards medial, through increasing angles).
    const double deg = std::fmod(cy.theta * 180 / M_PI + 360, 360);
    const double span = std::fmod(kept.dragged_out_to_deg - kept.dragged_out_from_deg + 360, 360);
    EXPECT_LE(std::fmod(deg - kept.dragged_out_from_deg + 360, 360), span + 1e-9) << "skin node " << i;
  }
  EXPECT_EQ(dragged, kept.dragged_out);
  EXPECT_NEAR(kept.dragged_out_height_m, highest, 1e-12);
  // Friction drags the ring below the design's brim up by about a node spacing (4.7 mm at 1.8k):
  // the socket's brim rose there (ClosedLoopOptions::max_brim_raise_m), never fell, and keeps them in.
  EXPECT_EQ(dragged, 0);
  double raised = 0;
  for (int k = 0; k < 720; ++k) {
    const double theta = -M_PI + k * M_PI / 360;
    const double up = brim.height(theta) - setup.brim.height(theta);
    EXPECT_GT(up, -1e-4) << theta;
    raised = std::max(raised, up);
  }
  EXPECT_NEAR(raised, kept.brim_raise_m, 1e-9);
  EXPECT_GT(raised, 3e-3);
  EXPECT_LE(raised, 0.010 + 1e-4);
  // CalculiX's check gets the socket's brim for its shell (the skin at rest against it, as the
  // design's flags are), and the design's brim still picks the nodes compared.
  const calculix::DesignedStump stump = designed_stump(*art_);
  ASSERT_EQ(stump.above_socket_brim.size(), skin.nodes.size());
  int in_band = 0;
  for (size_t i = 0; i < skin.nodes.size(); ++i) {
    const auto rest = frame.to_cylindrical(skin.positions[i]);
    EXPECT_EQ(stump.above_socket_brim[i] != 0, rest.h > brim.height(rest.theta)) << "skin node " << i;
    EXPECT_EQ(stump.above_brim[i] != 0, !loop.below_brim[i]) << "skin node " << i;
    if (stump.above_brim[i] && !stump.above_socket_brim[i]) ++in_band;
    EXPECT_FALSE(!stump.above_brim[i] && stump.above_socket_brim[i]) << "skin node " << i;
  }
  EXPECT_GT(in_band, 0);  // skin between the design's brim and the socket's: in the shell, not compared
  const Agreement kept_in = agreement(loop.closed_loop_pa, loop.target_pa, in_socket);
  EXPECT_NEAR(loop.iterations[loop.best].in_socket.p99, kept_in.p99, 1e-6);
  EXPECT_NEAR(loop.iterations[loop.best].in_socket.mae, kept_in.mae, 1e-6);
  // A node dragged above the socket's brim corrects no wall: its deficit does not pull the rim in.
  // (When it did, each correction moved the wall vertices above the brim further in, to the 5 mm
  // clamp on generated limbs. What was left, −2.3 mm here on 2026-12-02 and the clamp again per
  // deformed area, was the corrections of the nodes just below the raised brim carried whole onto
  // vertices only they reached, millimetres above them; faded by their weight (corrections_on_wall in
  // closed_loop_correction.cpp), −0.27 mm, 2026-12-05.)
  double rim_in = 0;
  for (size_t i = 0; i < skin.nodes.size(); ++i)
    if (design::above_brim(brim, art_->result.state.skin_positions[i], frame))
      rim_in = std::min(rim_in, loop.wall_offset_m[i]);
  EXPECT_GT(rim_in, -1.5e-3);
  // Where the loop moved the wall: within its bound, and not nowhere.
  double max_offset = 0;
  for (double v : loop.wall_offset_m) max_offset = std::max(max_offset, std::abs(v));
  EXPECT_GT(max_offset, 1e-4);
  EXPECT_LE(max_offset, ClosedLoopOptions{}.max_offset_m + 1e-12);
  // Its node-scale roughness, reported per donning: none on the open-loop socket; the kept socket's
  // is its wall's, and a share of how far the wall moved.
  EXPECT_EQ(loop.iterations[0].wall_roughness_rms_m, 0.0);
  const WallRoughness rough = wall_roughness(skin.neighbours(), skin.area_m2, loop.below_brim, loop.wall_offset_m);
  const ClosedLoopIteration& kept_it = loop.iterations[loop.best];
  EXPECT_NEAR(kept_it.wall_roughness_rms_m, rough.rms_m, 1e-12);
  EXPECT_NEAR(kept_it.wall_roughness_p99_m, rough.p99_m, 1e-12);
  EXPECT_NEAR(kept_it.wall_roughness_share, rough.share(), 1e-12);
  if (loop.best > 0) {
    EXPECT_GT(rough.rms_m, 1e-6);
  }
  EXPECT_LT(rough.p99_m, max_offset);
}

TEST_F(ClosedLoopRun, outputs_carry_the_designed_open_and_closed_loop_pressures) {
  const auto& j = (*summary_)["closed_loop"];
  ASSERT_TRUE(j.is_object());
  const ClosedLoopResult& loop = *art_->result.closed_loop;
  const auto full = std::count_if(loop.iterations.begin(), loop.iterations.end(), [](const auto& it) { return !it.refit; });
  EXPECT_EQ(j["donnings"].get<long>(), full);
  EXPECT_EQ(j["donnings"].get<long>() + j["refits"].get<long>(), static_cast<long>(loop.iterations.size()));
  EXPECT_FALSE(loop.iterations[loop.best].refit);  // the socket kept was donned from scratch
  EXPECT_NEAR(j["wall_roughness_rms_mm"].get<double>(), loop.iterations[loop.best].wall_roughness_rms_m * 1e3, 1e-9);
  EXPECT_NEAR(j["iterations"].back()["wall_roughness_p99_mm"].get<double>(),
              loop.iterations.back().wall_roughness_p99_m * 1e3, 1e-9);
  // Converged means every tolerance, the landmarks' too (ClosedLoopOptions::landmark_tolerance).
  if (loop.converged) {
    EXPECT_LE(loop.iterations[loop.best].landmark_deviation, ClosedLoopOptions{}.landmark_tolerance);
  }
  EXPECT_GE(j["kept_donning"].get<int>(), 1);
  EXPECT_NEAR(j["regions"]["below_brim"]["closed_loop"]["mae_kpa"].get<double>(),
              loop.iterations[loop.best].below_brim.mae / 1e3, 1e-9);
  EXPECT_TRUE(j["regions"].contains("front_line"));
  EXPECT_FALSE(j["landmarks"].empty());
  // Each donning's landmark deviation: the landmark whose zone's pressure / threshold is furthest
  // from the design's, relative to the design's (to 0.1 below it) — recomputed from the landmarks
  // written for the kept socket.
  double furthest = 0;
  std::string code;
  for (const auto& l : j["landmarks"]) {
    const double designed = l["designed_ratio"].get<double>();
    const double dev = std::abs(l["closed_loop_ratio"].get<double>() - designed) / std::max(designed, 0.1);
    if (dev >= furthest) std::tie(furthest, code) = std::tie(dev, l["code"].get_ref<const std::string&>());
  }
  const auto& kept_json = j["iterations"][loop.best];
  EXPECT_NEAR(kept_json["landmark_deviation"].get<double>(), furthest, 1e-9);
  EXPECT_EQ(kept_json["landmark_furthest"].get<std::string>(), code);
  EXPECT_GT(j["iterations"][0]["landmark_deviation"].get<double>(), furthest);  // the open-loop socket's, further
  // The delivery bar of the kept socket: the same worst landmark, and each item as its figure says.
  const auto& bar = j["bar"];
  const auto& below = j["regions"]["below_brim"]["closed_loop"];
  EXPECT_NEAR(bar["worst_landmark_deviation"].get<double>(), furthest, 1e-9);
  EXPECT_EQ(bar["mae_met"].get<bool>(), below["mae_kpa"].get<double>() <= 1.5);
  EXPECT_EQ(bar["p99_met"].get<bool>(), below["p99_kpa"].get<double>() <= 4.0);
  EXPECT_EQ(bar["landmarks_met"].get<bool>(), furthest <= 0.1);
  bool paths_within = true;  // each thesis path below the brim, held to the same bar
  for (const auto& [key, region] : j["regions"].items()) {
    if (key == "below_brim") continue;
    const auto& s = region["closed_loop"];
    paths_within = paths_within && s["mae_kpa"].get<double>() <= 1.5 && s["p99_kpa"].get<double>() <= 4.0 &&
                   (s["sd_b_kpa"].get<double>() < 2.0 || s["r"].get<double>() >= 0.95);
  }
  EXPECT_EQ(j["regions"].size(), 4u);
  EXPECT_EQ(bar["paths_met"].get<bool>(), paths_within);
  // The loop's own path score of the kept socket is the bar's MAE and p99 over these paths, and it
  // stops on it: converged means every path within them.
  double path_score = 0;
  for (const auto& [key, region] : j["regions"].items())
    if (key != "below_brim")
      path_score = std::max({path_score, region["closed_loop"]["mae_kpa"].get<double>() / 1.5,
                             region["closed_loop"]["p99_kpa"].get<double>() / 4.0});
  EXPECT_NEAR(kept_json["path_score"].get<double>(), path_score, 1e-9);
  if (loop.converged) {
    EXPECT_LE(path_score, 1.0) << loop.message;
  }
  EXPECT_EQ(bar["met"].get<bool>(), bar["failing"].empty());
  EXPECT_FALSE(j["open_loop_bar"]["met"].get<bool>());  // the open-loop socket misses it
  const auto t = report::read_csv(out_ / "delivered.csv");
  const auto designed = t.column("designed_pa"), closed = t.column("closed_loop_pa"), open = t.column("open_loop_pa");
  const auto dragged = t.column("dragged_out");
  ASSERT_EQ(designed.size(), loop.target_pa.size());
  EXPECT_EQ(std::count(dragged.begin(), dragged.end(), 1.0), j["dragged_out_nodes"].get<long>());
  EXPECT_EQ(j["dragged_out_nodes"].get<int>(), loop.iterations[loop.best].dragged_out);
  for (size_t i = 0; i < designed.size(); i += 11) {
    EXPECT_EQ(dragged[i] != 0, loop.dragged_out[i] != 0);
    EXPECT_NEAR(designed[i], loop.target_pa[i], 1e-6 * (1 + loop.target_pa[i]));
    EXPECT_NEAR(closed[i], loop.closed_loop_pa[i], 1e-6 * (1 + loop.closed_loop_pa[i]));
    EXPECT_NEAR(open[i], loop.open_loop_pa[i], 1e-6 * (1 + loop.open_loop_pa[i]));
  }
  EXPECT_TRUE(fs::exists(out_ / "delivered_map.png"));
  EXPECT_TRUE(fs::exists(out_ / "delivered_error_map.png"));
  std::ifstream in(out_ / "report.html");
  const std::string html((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(html.find("Delivered pressures"), std::string::npos);
  EXPECT_NE(html.find("closed loop"), std::string::npos);
}

TEST(ClosedLoop, the_dragged_out_lines_give_in_socket_figures_only_when_nodes_stayed_in) {
  ClosedLoopIteration it;
  EXPECT_EQ(dragged_out_note(it), "");
  EXPECT_EQ(dragged_out_advice(it), "");
  it.dragged_out = 12;
  it.dragged_out_height_m = 0.0034;
  it.dragged_out_max_target_pa = 15700;
  it.dragged_out_from_deg = 78;
  it.dragged_out_to_deg = 316;
  // Fewer than 3 nodes stayed in the socket: their statistics were not computed (count 0) and
  // must not be printed as zeros.
  for (const std::string& line : {dragged_out_note(it), dragged_out_advice(it)}) {
    EXPECT_THAT(line, ::testing::HasSubstr("12 "));
    EXPECT_THAT(line, ::testing::HasSubstr("3.4 mm"));
    EXPECT_THAT(line, ::testing::HasSubstr("between 78° and 316°"));
    EXPECT_THAT(line, ::testing::Not(::testing::HasSubstr("MAE")));
  }
  it.in_socket.count = 700;
  it.in_socket.mae = 360;
  it.in_socket.p99 = 2160;
  EXPECT_THAT(dragged_out_note(it), ::testing::HasSubstr("the others: MAE 0.36 kPa, 99th percentile 2.16 kPa"));
  EXPECT_THAT(dragged_out_advice(it), ::testing::HasSubstr("Without them: MAE 0.36 kPa, 99th percentile 2.16 kPa."));
}

TEST(ClosedLoop, a_rough_wall_is_reported_with_the_advice_to_check_it_in_calculix) {
  ClosedLoopIteration it;
  it.wall_roughness_rms_m = 0.066e-3;  // the demo at 8k
  it.wall_roughness_p99_m = 0.23e-3;
  it.wall_roughness_share = 0.14;
  EXPECT_EQ(roughness_advice(it, 0.0), "0.066 mm RMS, 0.14 of the correction's spread, 99th percentile 0.23 mm (each "
                                       "node's correction minus its neighbours' mean, below the brim)");
  // A coarser mesh's rougher RMS alone is no alarm (the 12 sweep limbs at 3k: 0.091–0.122 mm, shares 0.18–0.27).
  it.wall_roughness_rms_m = 0.122e-3;
  it.wall_roughness_share = 0.27;
  EXPECT_THAT(roughness_advice(it, 0.0), ::testing::Not(::testing::HasSubstr("validate design")));
  it.wall_roughness_rms_m = 0.167e-3;  // the AAOP example at 3k
  it.wall_roughness_p99_m = 0.60e-3;
  it.wall_roughness_share = 0.50;
  const std::string rough = roughness_advice(it, 0.0);
  EXPECT_THAT(rough, ::testing::HasSubstr("0.167 mm RMS, 0.50 of the correction's spread"));
  EXPECT_THAT(rough, ::testing::HasSubstr("validate design"));
  // The cap is not advised: its gain on the AAOP example was CalculiX's increment path (docs/design.md, "Limits").
  EXPECT_THAT(rough, ::testing::HasSubstr("again with shorter increments where its pressures alternate"));
  EXPECT_THAT(rough, ::testing::Not(::testing::HasSubstr("design.closed_loop_max_roughness_mm")));
  EXPECT_THAT(roughness_advice(it, 0.15e-3), ::testing::HasSubstr("capped at 0.15 mm"));
}

TEST(ClosedLoop, the_socket_kept_meets_the_tolerances_then_the_delivery_bar_then_is_the_closest) {
  // The first donned socket is kept whatever it is.
  EXPECT_TRUE(replaces_kept(false, false, 9.0, -1, std::numeric_limits<double>::infinity()));
  // Generated limb, seed 4 before 2026-12-03: donning 2 at MAE 0.48 kPa (score 0.96) with AD off the
  // bar; a donning at MAE 0.59 (score 1.18) that meets the bar is kept before it...
  EXPECT_TRUE(replaces_kept(false, true, 1.18, kept_rank(false, false), 0.96));
  // ... and not the other way round, however close to the tolerances.
  EXPECT_FALSE(replaces_kept(false, false, 0.50, kept_rank(false, true), 1.18));
  // Within every tolerance beats the bar alone; within a tier the smaller score wins, a tie keeps.
  EXPECT_TRUE(replaces_kept(true, true, 0.95, kept_rank(false, true), 0.60));
  EXPECT_FALSE(replaces_kept(false, true, 0.40, kept_rank(true, true), 0.95));
  EXPECT_TRUE(replaces_kept(false, true, 0.70, kept_rank(false, true), 0.80));
  EXPECT_FALSE(replaces_kept(false, true, 0.80, kept_rank(false, true), 0.80));
  EXPECT_EQ(kept_rank(true, false), 2);
}

TEST(ClosedLoop, of_the_sockets_that_miss_the_delivery_bar_the_one_closest_to_it_is_kept) {
  // Transfemoral seed 4 at 8k (2026-12-06): donning 2 at MAE 0.28 / p99 1.26 kPa with the greater
  // trochanter 39 % over its design; donning 3 at 0.23 / 1.37 with it 116 % over. By the MAE and p99
  // (scores 0.56 and 0.46) the third was kept; by how far each misses the bar, the second.
  ClosedLoopIteration d2, d3;
  d2.below_brim.mae = 280;
  d2.below_brim.p99 = 1260;
  d2.landmark_deviation = 0.39;
  d2.path_score = 0.3;
  d3.below_brim.mae = 230;
  d3.below_brim.p99 = 1370;
  d3.landmark_deviation = 1.16;
  d3.path_score = 0.3;
  EXPECT_NEAR(bar_score(d2), 3.9, 1e-12);
  EXPECT_NEAR(bar_score(d3), 11.6, 1e-12);
  EXPECT_FALSE(replaces_kept(false, false, bar_score(d3), kept_rank(false, false), bar_score(d2)));
  // Below the brim and on the paths: the largest miss counts.
  d3.landmark_deviation = 0.05;
  d3.below_brim.p99 = 6000;
  EXPECT_NEAR(bar_score(d3), 1.5, 1e-12);
  d3.path_score = 2.0;
  EXPECT_NEAR(bar_score(d3), 2.0, 1e-12);
}

TEST(ClosedLoop, a_default_loop_that_fails_keeps_the_open_loop_socket_and_a_loop_asked_for_fails_the_design) {
  design::CaseFile c = demo_case(1800);
  c.closed_loop_donnings = 0;  // refused by the loop (a case file cannot say it; code can)
  ASSERT_FALSE(c.closed_loop.has_value());
  auto setup = prepare_design(c);
  const DesignResult r = solve_design(*setup, true);
  ASSERT_TRUE(r.constraints_met);
  EXPECT_FALSE(r.closed_loop.has_value());
  ASSERT_TRUE(r.socket.has_value());  // the open-loop socket, written with a warning
  EXPECT_THAT(r.closed_loop_failed, ::testing::HasSubstr("0 donnings"));
  setup->case_file.closed_loop = true;
  EXPECT_THROW(solve_design(*setup, true), InvalidInputError);
}

TEST(ClosedLoop, the_rigid_wall_and_step_keys_reach_the_loops_donnings_and_survive_a_round_trip) {
  // design.closed_loop_rigid_wall: the loop's donnings (closed_loop_options) and the others of the
  // case's socket (case_augmented_tol) get the augmented Lagrangian; without it, the penalty alone.
  const design::CaseFile plain = design::parse_case(nlohmann::json::object());
  EXPECT_EQ(case_augmented_tol(plain), 0.0);
  EXPECT_EQ(closed_loop_options(plain).donning.contact.augmented_tol, 0.0);
  const design::CaseFile rigid =
      design::parse_case(nlohmann::json::parse(R"({"design": {"closed_loop_rigid_wall": true}})"));
  EXPECT_TRUE(rigid.closed_loop_rigid_wall);
  EXPECT_EQ(case_augmented_tol(rigid), contact::kRigidWallAugmentedTol);
  EXPECT_EQ(closed_loop_options(rigid).donning.contact.augmented_tol, contact::kRigidWallAugmentedTol);
  EXPECT_TRUE(design::parse_case(design::case_to_json(rigid)).closed_loop_rigid_wall);
  // design.closed_loop_max_roughness_mm: in mm in the file, reaches the loop in metres; 0 (no cap)
  // by default; out of range is refused.
  EXPECT_EQ(closed_loop_options(plain).max_roughness_m, 0.0);
  const design::CaseFile capped =
      design::parse_case(nlohmann::json::parse(R"({"design": {"closed_loop_max_roughness_mm": 0.15}})"));
  EXPECT_NEAR(closed_loop_options(capped).max_roughness_m, 0.15e-3, 1e-15);
  EXPECT_NEAR(design::parse_case(design::case_to_json(capped)).closed_loop_max_roughness_m, 0.15e-3, 1e-15);
  EXPECT_THROW(design::parse_case(nlohmann::json::parse(R"({"design": {"closed_loop_max_roughness_mm": -1}})")),
               InvalidInputError);
  // design.closed_loop_step_mm: by default the donning's own step; in mm in the file, in metres in
  // the loop's donning; a step under the donning's shortest (2 mm) is refused.
  EXPECT_EQ(plain.closed_loop_step_m, contact::DonningOptions{}.step_m);
  EXPECT_EQ(closed_loop_options(plain).donning.step_m, contact::DonningOptions{}.step_m);
  const design::CaseFile longer = design::parse_case(nlohmann::json::parse(R"({"design": {"closed_loop_step_mm": 9}})"));
  EXPECT_NEAR(closed_loop_options(longer).donning.step_m, 9e-3, 1e-15);
  EXPECT_NEAR(design::parse_case(design::case_to_json(longer)).closed_loop_step_m, 9e-3, 1e-15);
  EXPECT_FALSE(design::case_to_json(plain)["design"].contains("closed_loop_step_mm"));
  EXPECT_THROW(design::parse_case(nlohmann::json::parse(R"({"design": {"closed_loop_step_mm": 1}})")),
               InvalidInputError);
}

TEST(ClosedLoop, refuses_bad_options_and_a_design_without_a_socket) {
  design::CaseFile c = demo_case(1800);
  c.closed_loop = false;  // the loops below are called by hand
  auto setup = prepare_design(c);
  DesignResult none;
  EXPECT_THROW(close_design_loop(*setup, none), InvalidInputError);
  DesignResult r = solve_design(*setup, true);
  ASSERT_TRUE(r.socket.has_value());
  ClosedLoopOptions o;
  o.max_donnings = 0;
  EXPECT_THROW(close_design_loop(*setup, r, o), InvalidInputError);
  o = {};
  o.relaxation = std::nan("");
  EXPECT_THROW(close_design_loop(*setup, r, o), InvalidInputError);
  o = {};
  o.max_offset_m = -1;
  EXPECT_THROW(close_design_loop(*setup, r, o), InvalidInputError);
  o = {};
  o.check_newton_ratio = 0;
  EXPECT_THROW(close_design_loop(*setup, r, o), InvalidInputError);
  o = {};
  o.max_brim_raise_m = -1e-3;
  EXPECT_THROW(close_design_loop(*setup, r, o), InvalidInputError);
  o = {};
  o.landmark_tolerance = 0;
  EXPECT_THROW(close_design_loop(*setup, r, o), InvalidInputError);
  o = {};
  o.max_roughness_m = -1e-4;
  EXPECT_THROW(close_design_loop(*setup, r, o), InvalidInputError);
}

// design.closed_loop_max_brim_raise_mm 0, the default (the brim stays where the prosthetist drew
// it): the socket keeps the design's brim, and the skin donning drags above it stays out (the lip
// alone presses it), as the report says.
TEST(ClosedLoop, a_brim_the_case_does_not_let_rise_stays_the_designs_and_the_dragged_out_nodes_are_said) {
  design::CaseFile c = demo_case(1800);
  c.closed_loop = true;
  c.closed_loop_donnings = 2;
  c.closed_loop_drag_band = false;  // the design as asked, its dragged-out skin and all
  EXPECT_EQ(c.closed_loop_max_brim_raise_m, 0.0);
  const fs::path out = fs::path(SOCKETSMITH_BINARY_DIR) / "tests" / ("closed_loop_fixed_brim_" + std::to_string(::getpid()));
  DesignArtifacts art;
  run_design(c, out, true, {}, &art);
  fs::remove_all(out);
  ASSERT_TRUE(art.result.closed_loop.has_value());
  const ClosedLoopResult& loop = *art.result.closed_loop;
  const auto& brim = art.setup->brim;
  for (int k = 0; k < 720; ++k) {
    const double theta = -M_PI + k * M_PI / 360;
    EXPECT_NEAR(loop.socket_brim.height(theta), brim.height(theta), 1e-12) << theta;
  }
  for (const auto& it : loop.iterations) EXPECT_EQ(it.brim_raise_m, 0.0);
  const ClosedLoopIteration& kept = loop.iterations[loop.best];
  EXPECT_GT(kept.dragged_out, 0);  // 3 at 1.8k (2026-12-01), up to 4.7 mm above the brim
  EXPECT_THAT(dragged_out_advice(kept), ::testing::HasSubstr("lets the closed loop raise it"));
}

// design.closed_loop_drag_band (on by default): a loop whose socket misses the delivery bar with
// skin designed to bear pressure dragged out over the brim has the design solved again asking
// nothing of that skin, and the design whose socket delivers it better is kept; design.json says
// which (the demo at 1.8k with 2 donnings: 2026-12-07, 3 nodes; kept).
TEST(ClosedLoop, skin_dragged_out_over_the_brim_is_designed_again_without_pressure_and_the_better_design_kept) {
  design::CaseFile c = demo_case(1800);
  c.closed_loop = true;
  c.closed_loop_donnings = 2;
  DesignArtifacts art;
  const nlohmann::json j = run_design_scratch(c, "closed_loop_drag_band", true, art);
  ASSERT_TRUE(art.result.drag_band.has_value());
  const DragBand& b = *art.result.drag_band;
  ASSERT_GT(b.node_ids.size(), 0u);
  ASSERT_EQ(b.lifts.size(), b.node_ids.size());
  const auto& cyl = art.setup->solver->skin_cylindrical();
  for (size_t k = 0; k < b.node_ids.size(); ++k) {  // each reaches past its node's depth below the brim
    const auto& cy = cyl[b.node_ids[k]];
    EXPECT_EQ(b.lifts[k].theta, cy.theta);
    EXPECT_GT(b.lifts[k].lift_m, art.setup->brim.height(cy.theta) - cy.h);
    EXPECT_LE(b.lifts[k].lift_m, b.max_depth_m);
  }
  EXPECT_GT(b.max_designed_pa, kDragBandMinPa);
  const ClosedLoopResult& loop = *art.result.closed_loop;
  if (b.kept) {  // the design written asks nothing of them
    for (int i : b.node_ids) EXPECT_EQ(art.result.state.pressure_pa[i], 0.0) << i;
    EXPECT_LT(bar_score(loop.iterations[loop.best]), b.first_score);
  } else {
    EXPECT_FALSE(b.why_not.empty());
  }
  const auto& jb = j["closed_loop"]["drag_band"];
  EXPECT_EQ(jb["kept"].get<bool>(), b.kept);
  EXPECT_EQ(jb["nodes"].get<size_t>(), b.node_ids.size());
  EXPECT_NEAR(jb["without_band_bar_score"].get<double>(), b.first_score, 1e-12);
  EXPECT_GT(b.first_score, 1.0);  // the first design's p99 6.28 kPa against the bar's 4
  EXPECT_NEAR(jb["max_depth_mm"].get<double>(), b.max_depth_m * 1e3, 1e-9);
}

// The drag band's design is not kept when it does not hold: here the spots are fixed (not optimised
// again), so asking nothing of the band leaves the axial load short and its constraints unmet. The
// first design stays — its state, its socket — and so do the design solver's brim weights.
TEST(ClosedLoop, a_drag_band_design_that_misses_its_constraints_leaves_the_first_design_and_weights) {
  design::CaseFile c = demo_case(1800);
  c.closed_loop = false;
  auto spots_setup = prepare_design(c);
  c.spots = solve_design(*spots_setup, true).spots;  // the optimised layout, then solved as given
  c.optimise = false;
  c.closed_loop = true;
  c.closed_loop_donnings = 2;
  DesignArtifacts art;
  const nlohmann::json j = run_design_scratch(c, "closed_loop_band_not_kept", false, art);
  ASSERT_TRUE(art.result.drag_band.has_value());
  const DragBand& b = *art.result.drag_band;
  EXPECT_FALSE(b.kept);
  EXPECT_THAT(b.why_not, ::testing::HasSubstr("constraints"));
  EXPECT_FALSE(j["closed_loop"]["drag_band"]["kept"].get<bool>());
  EXPECT_TRUE(art.result.constraints_met);
  double asked = 0;  // the first design still asks the banded nodes for their pressure
  for (int i : b.node_ids) asked = std::max(asked, art.result.state.pressure_pa[i]);
  EXPECT_NEAR(asked, b.max_designed_pa, 1e-9);
  const auto& solver = *art.setup->solver;
  const auto& cyl = solver.skin_cylindrical();
  const double flare = design::brim_flare_m(c);
  for (size_t i = 0; i < cyl.size(); ++i) {  // the flare from the brim again, no band
    const double t = std::clamp((art.setup->brim.height(cyl[i].theta) - cyl[i].h) / flare, 0.0, 1.0);
    EXPECT_NEAR(solver.brim_weight()[i], solver.above_brim()[i] ? 0.0 : t * t * (3 - 2 * t), 1e-12) << i;
  }
}

// A corrected socket's donning may spend only a multiple of the open-loop donning's Newton
// iterations (ClosedLoopOptions::check_newton_ratio): one that outspends it ends as a stalled
// donning, and the loop stops there with the best socket so far and the reason — instead of
// grinding for minutes.
TEST(ClosedLoop, a_corrected_socket_whose_donning_outspends_its_newton_limit_stops_the_loop_with_the_best_socket) {
  design::CaseFile c = demo_case(1800);
  c.closed_loop = false;  // the loop is called by hand
  auto setup = prepare_design(c);
  const DesignResult r = solve_design(*setup, true);
  ASSERT_TRUE(r.socket.has_value());
  ClosedLoopOptions o;
  o.refits_per_donning = 0;  // the first correction is donned from scratch
  o.check_newton_ratio = 0.2;
  o.check_newton_min = 0;
  const ClosedLoopResult loop = close_design_loop(*setup, r, o);
  EXPECT_FALSE(loop.converged);
  ASSERT_EQ(loop.iterations.size(), 1u) << loop.message;  // the open-loop donning only
  EXPECT_EQ(loop.best, 0);
  EXPECT_THAT(loop.message, ::testing::HasSubstr("stopped after 2 donnings: the corrected socket could not be donned"));
  EXPECT_THAT(loop.message, ::testing::HasSubstr("Newton iterations in all (the limit"));
  EXPECT_EQ(loop.retried_donnings, 1);  // donned again on a finer path, within the same limit: no better
  EXPECT_EQ(loop.closed_loop_pa, loop.open_loop_pa);  // the open-loop socket is kept
}

}  // namespace
}  // namespace socketsmith::pipeline
