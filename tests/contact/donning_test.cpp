// Donning the socket the design made onto its own stump (the thesis's consistency check before
// FE, ch. 4.3): the path converges, no node goes deeper than 0.5 mm into the wall, the standing
// load is carried (force balance on the socket), and the contact pressures follow the designed
// ones below the brim.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <iostream>

#include "socketsmith/contact/donning.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"
#include "socketsmith/design/socket_builder.h"
#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/report/field_comparison.h"
#include "socketsmith/tissue/pressure_load.h"

namespace socketsmith::contact {
namespace {
namespace fs = std::filesystem;

class Donning : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    c_ = pipeline::demo_case(1800);
    // The socket these donning paths were tuned on (start offsets, step counts, the adaptive
    // step's rejection): the design with the seven constraints only.
    c_.follow_template = false;
    // ... on the thesis's lattice, linearised (the default model is neo-Hookean since its
    // end-to-end check; its donning is DonningNeoHookean's).
    c_.model = "mss-cs";
    c_.solve_mode = design::DesignSolveMode::Linear;
    c_.closed_loop = false;  // the designed (open-loop) socket: these tests don it themselves
    pipeline::run_design(c_, fs::path(SOCKETSMITH_BINARY_DIR) / "tests" / "donning_design", true, {}, &art_);
  }
  /// The designed socket from @p offset_m below in @p steps, then standing with M g / 2.
  static DonningOptions standing_path(int steps, double offset_m) {
    DonningOptions o;
    o.steps = steps;
    o.start_offset_m = offset_m;
    o.friction = c_.patient.friction;
    o.stand_force_n = 0.5 * c_.patient.body_mass_kg * units::kGravity;
    return o;
  }
  /// The default path with the sample's friction, then standing with M g / 2.
  static DonningOptions worn() {
    DonningOptions o;
    o.friction = c_.patient.friction;
    o.stand_force_n = 0.5 * c_.patient.body_mass_kg * units::kGravity;
    return o;
  }
  /// Nodal contact pressures of @p a against the reference @p b: largest and summed absolute
  /// difference, largest and summed reference pressure [Pa].
  struct PressureDifference {
    double pmax = 0, dmax = 0, dsum = 0, psum = 0;
  };
  static PressureDifference pressure_difference(const DonningResult& a, const DonningResult& b) {
    PressureDifference d;
    for (size_t i = 0; i < a.contacts.size(); ++i) {
      const double pa = a.contacts[i].pressure_pa, pb = b.contacts[i].pressure_pa;
      d.pmax = std::max(d.pmax, pb);
      d.psum += pb;
      d.dmax = std::max(d.dmax, std::abs(pa - pb));
      d.dsum += std::abs(pa - pb);
    }
    return d;
  }
  static DonningResult don(const DonningOptions& o) {
    const auto& solver = *art_.setup->solver;
    return simulate_donning(solver.model(), solver.skin().nodes, solver.skin().area_m2, art_.result.socket->solid,
                            art_.setup->model.frame, o);
  }
  static design::CaseFile c_;
  static pipeline::DesignArtifacts art_;
};
design::CaseFile Donning::c_;
pipeline::DesignArtifacts Donning::art_;

TEST_F(Donning, the_designed_socket_reproduces_the_designed_pressures_on_its_own_stump) {
  const auto& art = art_;
  ASSERT_TRUE(art.result.socket.has_value()) << "the demo design must meet its constraints";
  const auto& solver = *art.setup->solver;
  const DonningOptions o = standing_path(20, 0.06);
  const auto r = don(o);
  ASSERT_TRUE(r.completed) << r.message;
  ASSERT_TRUE(r.stood) << r.message;
  ASSERT_EQ(r.series.size(), 21u);
  // The path: no contact at the start, contact grows, the socket carries the standing load.
  EXPECT_EQ(r.series.front().contact_nodes, 0);
  EXPECT_GT(r.series.back().contact_nodes, 50);
  EXPECT_NEAR(r.series.back().axial_force_n, o.stand_force_n, 2e-3 * o.stand_force_n);
  for (const auto& s : r.series) EXPECT_LE(s.max_penetration_m, 0.5e-3);
  // Newton's third law: the contact forces on the nodes sum to minus the force on the socket.
  Vec3 sum = Vec3::Zero();
  const Vec3 axis = art.setup->model.frame.axis;
  for (const auto& n : r.contacts)
    if (n.active) sum += n.normal_force_n * n.normal + n.tangential_n;
  EXPECT_LT((sum + r.force_on_socket_n).norm(), 1e-6 * r.force_on_socket_n.norm() + 1e-9)
      << "node forces " << sum.transpose() << " vs socket " << r.force_on_socket_n.transpose();
  EXPECT_GT(-r.force_on_socket_n.dot(axis), 0.0);
  // Standing loads the socket once, upwards: the skin still slides along it the way donning did
  // (friction drags the nodes up). The earlier push committed a step past the load and came back,
  // which reversed the slip: then most nodes stuck (1.8k: 66 of 440 sliding, 7.5k: 197 of 1,471).
  double drag_up = 0;
  for (const auto& n : r.contacts) drag_up += n.tangential_n.dot(axis);
  EXPECT_GT(drag_up, 0.0);
  EXPECT_GT(r.series.back().sliding_nodes, r.series.back().contact_nodes / 2);
  // The push's first step is predicted from the reaction's slope over the last donning step: 28
  // factorisations for the standing instead of 86 with a full 3 mm first step (2026-11-24).
  const long stand_factorizations = r.series.back().factorizations - r.series[r.series.size() - 2].factorizations;
  EXPECT_LT(stand_factorizations, 50);
  // Agreement with the design below the brim.
  std::vector<double> pc;
  std::vector<char> below;
  for (size_t i = 0; i < r.contacts.size(); ++i) {
    pc.push_back(r.contacts[i].pressure_pa);
    below.push_back(solver.above_brim()[i] ? 0 : 1);
  }
  std::vector<int> subset;
  for (size_t i = 0; i < below.size(); ++i)
    if (below[i]) subset.push_back(static_cast<int>(i));
  const auto a = report::compare_fields(pc, art.result.state.pressure_pa, subset);  // a: contact, b: designed
  EXPECT_GT(a.r, 0.6);
  EXPECT_LT(a.mae, 0.35 * a.mean_b);
  EXPECT_NEAR(a.mean_a, a.mean_b, 0.25 * a.mean_b);
}

// The fast path (minimising line search, friction lag refreshed inside Newton, the standing push
// with a predicted first step and started from its bracket's interpolation) must land on the
// solution of the reference path (halving line search, lag refreshed only between Newton solves,
// a full first step, last solution as the start).
// The paths below start 45 mm down: at 32-33 mm the demo's socket (1.8k nodes) now grips 28 skin
// nodes at the start (the PTB-template design) and they could not run at all.
TEST_F(Donning, the_fast_newton_path_reaches_the_same_state_as_the_reference_path) {
  ASSERT_TRUE(art_.result.socket.has_value());
  const DonningOptions o = standing_path(15, 0.045);
  DonningOptions ref = o;
  ref.contact.exact_line_search = false;
  ref.contact.friction_in_newton = false;
  ref.contact.interpolate_bracket = false;
  ref.predict_stand_step = false;
  const auto a = don(o), b = don(ref);
  ASSERT_TRUE(a.completed && a.stood) << a.message;
  ASSERT_TRUE(b.completed && b.stood) << b.message;
  ASSERT_EQ(a.series.size(), b.series.size());
  for (size_t k = 0; k < a.series.size(); ++k) {
    // Within 0.5 % of the standing load at every step (early steps carry a few tens of N: at 60 N
    // the two paths' friction histories differ by 1.3 N).
    EXPECT_NEAR(a.series[k].axial_force_n, b.series[k].axial_force_n, 5e-3 * o.stand_force_n) << "step " << k;
    EXPECT_NEAR(a.series[k].contact_nodes, b.series[k].contact_nodes, 0.02 * b.series[k].contact_nodes + 1)
        << "step " << k;
  }
  EXPECT_NEAR(a.final_offset_m, b.final_offset_m, 1e-5);
  const PressureDifference d = pressure_difference(a, b);
  ASSERT_GT(d.pmax, 0.0);
  EXPECT_LT(d.dmax, 0.05 * d.pmax) << "largest nodal pressure difference";
  EXPECT_LT(d.dsum, 0.01 * d.psum) << "mean nodal pressure difference";
  // The point of the fast path is fewer Newton iterations for the same state: a speed, measured by
  // bench/contact_bench.cpp (BM_DonningPath), not a pass/fail count here.
  std::cout << "fast path: " << a.newton_iterations << " Newton iterations; reference: " << b.newton_iterations << "\n";
}

// The smoothed wall (the default) against the socket's facets: the same pressures within a fraction
// of what faceting itself changes (its Newton iterations: BM_DonningPath).
TEST_F(Donning, the_smoothed_wall_gives_the_facets_pressures) {
  ASSERT_TRUE(art_.result.socket.has_value());
  DonningOptions o = standing_path(15, 0.045);
  o.stand_force_n = 0;
  ASSERT_TRUE(o.smooth_wall);
  DonningOptions f = o;
  f.smooth_wall = false;
  const auto a = don(o), b = don(f);
  ASSERT_TRUE(a.completed) << a.message;
  ASSERT_TRUE(b.completed) << b.message;
  const double fa = a.series.back().axial_force_n, fb = b.series.back().axial_force_n;
  EXPECT_NEAR(fa, fb, 0.06 * fb);  // 319.6 vs 311.1 N
  EXPECT_NEAR(a.series.back().contact_nodes, b.series.back().contact_nodes, 0.03 * b.series.back().contact_nodes);
  // Nodal pressures: correlated, same mean.
  std::vector<double> pa, pb;
  for (size_t i = 0; i < a.contacts.size(); ++i) {
    pa.push_back(a.contacts[i].pressure_pa);
    pb.push_back(b.contacts[i].pressure_pa);
  }
  std::vector<int> all(pa.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  const auto c = report::compare_fields(pa, pb, all);
  EXPECT_GT(c.r, 0.9);
  EXPECT_NEAR(c.mean_a, c.mean_b, 0.06 * c.mean_b);
  for (const auto& sm : a.series) EXPECT_LE(sm.max_penetration_m, 0.5e-3);
  std::cout << "smooth: " << a.newton_iterations << " Newton iterations, " << fa << " N; facets: " << b.newton_iterations
            << ", " << fb << " N; nodal pressures r " << c.r << ", means " << c.mean_a << " / " << c.mean_b << " Pa\n";
}

// The donning's defaults — adaptive steps of at most 6 mm and a stick 5× softer than the penalty —
// against a fine path with the stiff stick (1 mm steps, stick as stiff as the penalty): the same
// standing state, the same pressures within a fraction of a percent on average (the factorisations
// each needs: BM_DonningPath).
TEST_F(Donning, the_default_path_gives_the_fine_stiff_stick_path_pressures) {
  ASSERT_TRUE(art_.result.socket.has_value());
  DonningOptions o = standing_path(0, 0.045);
  ASSERT_DOUBLE_EQ(o.step_m, 0.006);
  ASSERT_DOUBLE_EQ(o.contact.stick_stiffness_ratio, 0.2);

  DonningOptions fine = o;
  fine.step_m = 0.001;
  fine.contact.stick_stiffness_ratio = 1.0;
  const auto a = don(o), b = don(fine);
  ASSERT_TRUE(a.completed && a.stood) << a.message;
  ASSERT_TRUE(b.completed && b.stood) << b.message;
  EXPECT_EQ(b.series.size(), 46u);  // 45 steps + standing
  // Adaptive: 4 mm steps until a node starts sticking in one (the socket's bottom meets the stump's
  // end), then 2 mm. With 4 mm steps all the way a few distal nodes differed by 8 kPa.
  EXPECT_GE(a.rejected_steps, 1);
  EXPECT_LT(a.series.size(), 20u);
  EXPECT_NEAR(a.force_on_socket_n.norm(), b.force_on_socket_n.norm(), 2e-3 * b.force_on_socket_n.norm());
  const PressureDifference d = pressure_difference(a, b);
  ASSERT_GT(d.pmax, 0.0);
  EXPECT_LT(d.dmax, 0.05 * d.pmax) << "largest nodal pressure difference";
  EXPECT_LT(d.dsum, 0.01 * d.psum) << "mean nodal pressure difference";
  std::cout << "default: " << a.series.back().factorizations << " factorisations; fine, stiff stick: "
            << b.series.back().factorizations << "; largest nodal difference " << d.dmax << " Pa of " << d.pmax
            << ", mean " << d.dsum / a.contacts.size() << " Pa\n";
}

TEST_F(Donning, a_refit_keeps_the_worn_state_and_follows_a_looser_wall_as_a_donning_from_scratch_does) {
  const auto& setup = *art_.setup;
  const auto& solver = *setup.solver;
  DonningOptions o = worn();
  DonningSimulation sim(solver.model(), solver.skin().nodes, solver.skin().area_m2, art_.result.socket->solid,
                        setup.model.frame, o);
  const DonningResult worn = sim.run();
  ASSERT_TRUE(worn.completed && worn.stood) << worn.message;
  EXPECT_THROW(sim.run(), InvalidInputError);
  // The same socket again: nothing moves.
  const DonningResult same = sim.refit(art_.result.socket->solid);
  ASSERT_TRUE(same.completed && same.stood) << same.message;
  const auto ds = pressure_difference(same, worn);
  EXPECT_LT(ds.dmax, 0.01 * ds.pmax);
  EXPECT_NEAR(same.final_offset_m, worn.final_offset_m, 1e-5);
  // A socket 0.3 mm looser everywhere: it stands higher up the stump; the refit says how much and
  // with which pressures as a donning from scratch of that socket does.
  geometry::TriMesh inner = art_.result.deformed_skin;
  for (size_t i = 0; i < inner.vertices.size(); ++i) inner.vertices[i] += 0.3e-3 * art_.result.state.skin_normals[i];
  const auto looser = design::build_socket(inner, setup.model.frame, setup.brim, c_.socket);
  const DonningResult refit = sim.refit(looser.solid);
  ASSERT_TRUE(refit.completed && refit.stood) << refit.message;
  const DonningResult full = simulate_donning(solver.model(), solver.skin().nodes, solver.skin().area_m2, looser.solid,
                                              setup.model.frame, o);
  ASSERT_TRUE(full.completed && full.stood) << full.message;
  const double rise_full = full.final_offset_m - worn.final_offset_m, rise_refit = refit.final_offset_m - worn.final_offset_m;
  std::cout << "looser socket: stands " << rise_full * 1e3 << " mm higher (refit: " << rise_refit * 1e3 << " mm)\n";
  EXPECT_GT(rise_full, 0.3e-3);
  EXPECT_NEAR(rise_refit, rise_full, 0.25 * rise_full);
  const auto dr = pressure_difference(refit, full), dw = pressure_difference(worn, full);
  std::cout << "mean |refit - full| " << dr.dsum / refit.contacts.size() << " Pa, mean |worn - full| "
            << dw.dsum / refit.contacts.size() << " Pa\n";
  // Measured at 1.8k nodes: 1.47 vs 1.45 mm higher; mean |refit − full| 59 Pa, |worn − full| 800 Pa (1.39 mm and
  // 110 Pa before the refit predicted its push from the last standing stiffness).
  EXPECT_LT(dr.dsum, 0.25 * dw.dsum);  // the refit is much closer to the full donning than the old state was
}

TEST_F(Donning, a_rigid_wall_is_not_penetrated_stands_the_socket_sooner_and_its_refit_keeps_it_so) {
  // The augmented Lagrangian (DonningOptions::contact.augmented_tol): the same donning and standing
  // with the penetration removed — compliance in series with the tissue, so the socket pushed to
  // the standing load stops sooner; a refit of the same socket moves nothing and stays without
  // penetration.
  const auto& setup = *art_.setup;
  const auto& solver = *setup.solver;
  DonningOptions o = worn();
  const DonningResult penalty = don(o);
  ASSERT_TRUE(penalty.completed && penalty.stood) << penalty.message;
  o.contact.augmented_tol = kRigidWallAugmentedTol;
  DonningSimulation sim(solver.model(), solver.skin().nodes, solver.skin().area_m2, art_.result.socket->solid,
                        setup.model.frame, o);
  const DonningResult rigid = sim.run();
  ASSERT_TRUE(rigid.completed && rigid.stood) << rigid.message;
  const double pen_penalty = penalty.series.back().max_penetration_m, pen_rigid = rigid.series.back().max_penetration_m;
  double sum_penalty = 0, sum_rigid = 0;
  for (size_t i = 0; i < rigid.contacts.size(); ++i) {
    sum_penalty += penalty.contacts[i].pressure_pa;
    sum_rigid += rigid.contacts[i].pressure_pa;
  }
  std::printf("[ info ] penetration %.1f µm → %.2f µm; pressures summed %+.1f %%; stood %.2f → %.2f mm\n",
              pen_penalty * 1e6, pen_rigid * 1e6, 100 * (sum_rigid / sum_penalty - 1), penalty.final_offset_m * 1e3,
              rigid.final_offset_m * 1e3);
  EXPECT_GT(pen_penalty, 20e-6);
  EXPECT_LT(pen_rigid, 0.1 * pen_penalty);
  // Under the standing load the pressures carry the same weight: the stiffer wall shows in where it
  // stands (1.8k, MSS-CS linearised: 0.75 → 0.52 mm past the pose; summed pressures +0.7 %).
  EXPECT_LT(rigid.final_offset_m, penalty.final_offset_m - 0.1e-3);
  const DonningResult same = sim.refit(art_.result.socket->solid);
  ASSERT_TRUE(same.completed && same.stood) << same.message;
  const auto d = pressure_difference(same, rigid);
  EXPECT_LT(d.dmax, 0.01 * d.pmax);
  EXPECT_LT(same.series.back().max_penetration_m, 0.1 * pen_penalty);
}

TEST_F(Donning, a_distal_platform_leaves_the_cavity_that_the_stump_meets_as_it_is) {
  // The pad (or the attachment's platform) joins the outer wall below the cavity; the ledge where it
  // meets the wall faces the axis from within the distal wall's material. Taken for inner wall, it
  // stopped the distal skin 6 mm into the wall and doubled the donned distal pressure (CalculiX
  // donning check R 0.84 -> 0.36, 2026-11-26).
  const auto& setup = *art_.setup;
  design::SocketOptions plain = c_.socket;
  plain.distal_pad = false;
  plain.undeformed_skin = &art_.result.rest_skin;
  design::SocketOptions padded = plain;
  padded.distal_pad = true;
  const auto a = design::build_socket(art_.result.deformed_skin, setup.model.frame, setup.brim, padded);
  const auto b = design::build_socket(art_.result.deformed_skin, setup.model.frame, setup.brim, plain);
  ASSERT_TRUE(a.platform.is_built);
  const RigidSocket ra(a.solid, setup.model.frame, 1000.0), rb(b.solid, setup.model.frame, 1000.0);
  EXPECT_EQ(ra.inner_wall().num_triangles(), rb.inner_wall().num_triangles());
  const auto& skin = art_.result.state;
  int compared = 0;
  for (size_t i = 0; i < skin.skin_positions.size(); ++i)
    for (double depth : {0.0, 2e-3, 4e-3, 6e-3}) {
      const Vec3 p = skin.skin_positions[i] - depth * skin.skin_normals[i];
      const Gap ga = ra.gap(p), gb = rb.gap(p);
      if (!gb.valid) continue;
      ++compared;
      ASSERT_TRUE(ga.valid) << "skin node " << i << ", " << depth * 1e3 << " mm into the wall";
      ASSERT_NEAR(ga.gap_m, gb.gap_m, 1e-9) << "skin node " << i << ", " << depth * 1e3 << " mm into the wall";
    }
  EXPECT_GT(compared, 1000);
}

/// The 1.8k demo designed with the neo-Hookean model solved nonlinearly, written to @p folder.
pipeline::DesignArtifacts neo_hookean_design(const std::string& folder) {
  auto c = pipeline::demo_case(1800);
  c.model = "neo-hookean";
  c.solve_mode = design::DesignSolveMode::Nonlinear;
  c.closed_loop = false;  // the designed (open-loop) socket: these tests don it themselves
  pipeline::DesignArtifacts art;
  pipeline::run_design(c, fs::path(SOCKETSMITH_BINARY_DIR) / "tests" / folder, true, {}, &art);
  return art;
}

/// The neo-Hookean design's socket donned from 40 mm and stood on at 70 kg (μ 0.5, the nonlinear
/// body), its options changed by a test; two such donnings compared below the brim.
struct StoodNeoHookean {
  explicit StoodNeoHookean(const std::string& folder) : art(neo_hookean_design(folder)) {}
  DonningResult don(const std::function<void(DonningOptions&)>& change = {}) const {
    DonningOptions o;
    o.start_offset_m = 0.04;
    o.contact.linear_body = false;
    o.stand_force_n = 0.5 * 70.0 * units::kGravity;
    if (change) change(o);
    const auto& solver = *art.setup->solver;
    return simulate_donning(solver.model(), solver.skin().nodes, solver.skin().area_m2, art.result.socket->solid,
                            art.setup->model.frame, o);
  }
  /// @p a against @p b below the brim; @p peak_b: b's largest pressure there.
  report::ErrorStats compare(const DonningResult& a, const DonningResult& b, double& peak_b) const {
    std::vector<double> pa, pb;
    std::vector<int> subset;
    for (size_t i = 0; i < a.contacts.size(); ++i) {
      pa.push_back(a.contacts[i].pressure_pa);
      pb.push_back(b.contacts[i].pressure_pa);
      if (!art.setup->solver->above_brim()[i]) subset.push_back(static_cast<int>(i));
    }
    peak_b = *std::max_element(pb.begin(), pb.end());
    return report::compare_fields(pa, pb, subset);
  }
  pipeline::DesignArtifacts art;
};

TEST(DonningNeoHookean, predicted_contacts_reach_the_same_donned_and_stood_state_in_fewer_newton_steps) {
  // At the start of each step of the path the wall reaches new skin nodes; Newton's step on the
  // tangent of the nodes already touching takes them through it and the line search cuts it to a
  // sliver. With their penalties in the step's system (ContactOptions::predict_contact_m, the
  // default) the donning reaches the same donned and stood state in fewer Newton steps.
  const StoodNeoHookean nh("donning_design_nh_predict");
  ASSERT_TRUE(nh.art.result.socket.has_value());
  const DonningResult a = nh.don(), b = nh.don([](DonningOptions& o) { o.contact.predict_contact_m = 0.0; });
  ASSERT_TRUE(a.completed && a.stood) << a.message;
  ASSERT_TRUE(b.completed && b.stood) << b.message;
  double peak = 0;
  const auto d = nh.compare(a, b, peak);
  std::cout << "predicted contacts: " << a.newton_iterations << " Newton steps, " << a.series.back().factorizations
            << " factorisations; without: " << b.newton_iterations << ", " << b.series.back().factorizations
            << "; MAE " << d.mae << " Pa, max " << d.max_error << " Pa, R " << d.r << "\n";
  EXPECT_LT(a.newton_iterations, b.newton_iterations);
  EXPECT_NEAR(a.final_offset_m, b.final_offset_m, 2e-5);
  EXPECT_LT(d.mae, 0.005 * d.mean_b);
  EXPECT_LT(d.max_error, 0.05 * peak);
  EXPECT_GT(d.r, 0.999);
}

TEST(DonningNeoHookean, a_frictionless_donning_of_a_nonlinear_design_gives_back_its_state_with_the_nonlinear_body) {
  // The neo-Hookean design solved nonlinearly (follower pressures, large strain): donned without
  // friction and not stood on, its socket must put the stump back in the designed state — the wall
  // is the designed skin, the load is the designed pressures — when the donned body is the same
  // nonlinear model (CHOLMOD on the exact tangent, projected when it is not positive definite).
  const pipeline::DesignArtifacts art = neo_hookean_design("donning_design_nh");
  ASSERT_TRUE(art.result.socket.has_value()) << "the neo-Hookean demo design must meet its constraints";
  ASSERT_FALSE(art.result.state.linearised);
  const auto& solver = *art.setup->solver;
  DonningOptions o;
  o.friction = 0.0;
  o.start_offset_m = 0.04;
  o.contact.linear_body = false;
  const auto r = simulate_donning(solver.model(), solver.skin().nodes, solver.skin().area_m2,
                                  art.result.socket->solid, art.setup->model.frame, o);
  ASSERT_TRUE(r.completed) << r.message;
  std::vector<double> pc;
  std::vector<int> subset;
  for (size_t i = 0; i < r.contacts.size(); ++i) {
    pc.push_back(r.contacts[i].pressure_pa);
    if (!solver.above_brim()[i]) subset.push_back(static_cast<int>(i));
  }
  const auto a = report::compare_fields(pc, art.result.state.pressure_pa, subset);
  std::cout << "neo-Hookean, frictionless, nonlinear body: means " << a.mean_a << " / " << a.mean_b << " Pa, MAE "
            << a.mae << " Pa, p99 " << a.p99 << " Pa, R " << a.r << ", " << r.seconds << " s\n";
  EXPECT_NEAR(a.mean_a, a.mean_b, 0.05 * a.mean_b);
  // Measured 2026-11-26: means 10.45 / 10.41 kPa, MAE 0.42 kPa, p99 1.67 kPa, R 0.984, 1.3 s.
  EXPECT_LT(a.mae, 0.06 * a.mean_b);
  EXPECT_GT(a.r, 0.97);
  // The design's pressures are follower loads, force per deformed area: with the skin surface
  // given (DonningOptions::skin) the same donning reports each node's normal force over its
  // deformed nodal area. Without friction the skin is hardly stretched or bunched, so both measures
  // give the design back alike (2026-12-04: means 11.49 and 11.46 kPa against 11.87, MAE 0.64 and
  // 0.69 kPa); where friction drags the skin they part by up to 6 % (docs/contact.md).
  o.skin = &solver.skin();
  const auto rd = simulate_donning(solver.model(), solver.skin().nodes, solver.skin().area_m2,
                                   art.result.socket->solid, art.setup->model.frame, o);
  ASSERT_TRUE(rd.completed) << rd.message;
  std::vector<double> area;
  std::vector<Eigen::Vector3d> normal;
  tissue::skin_areas_and_normals(solver.skin(), rd.positions, area, normal);
  std::vector<double> pd;
  for (size_t i = 0; i < rd.contacts.size(); ++i) {
    const auto& c = rd.contacts[i];
    EXPECT_NEAR(c.normal_force_n, r.contacts[i].normal_force_n, 1e-9) << "skin node " << i << ": the same state";
    if (c.active) {
      EXPECT_NEAR(c.pressure_pa, c.normal_force_n / area[i], 1e-9 * c.pressure_pa) << "skin node " << i;
    }
    pd.push_back(c.pressure_pa);
  }
  const auto b = report::compare_fields(pd, art.result.state.pressure_pa, subset);
  std::cout << "... per deformed area: means " << b.mean_a << " / " << b.mean_b << " Pa, MAE " << b.mae << " Pa, p99 "
            << b.p99 << " Pa, R " << b.r << "\n";
  EXPECT_NEAR(b.mean_a, b.mean_b, 0.05 * b.mean_b);
  EXPECT_LT(b.mae, 0.07 * b.mean_b);
  EXPECT_GT(b.r, 0.97);
  // A surface that is not the donned skin's is refused.
  volume::SkinSurface other = solver.skin();
  other.nodes.pop_back();
  o.skin = &other;
  EXPECT_THROW(simulate_donning(solver.model(), solver.skin().nodes, solver.skin().area_m2, art.result.socket->solid,
                                art.setup->model.frame, o),
               InvalidInputError);
}

TEST(DonningNeoHookean, the_smoothed_wall_of_a_coarse_socket_presses_near_what_its_facets_press) {
  // The 1.8k demo's socket without its subdivision: facets of ~12 mm, whose corners are the skin's
  // nodes. Donned frictionless, the smoothed wall through the facets on average pressed 78 % above
  // the facets (net axial force 131.9 against 74.2 N, 2026-12-01); fitted to the skin's footprints
  // (RigidSocket::fit_smooth_wall_to) 27 % (94.2 N). The facets are what CalculiX dons and what is
  // printed. Bar: within 40 % (the fit's limit on facets this coarse; docs/contact.md).
  auto c = pipeline::demo_case(1800);
  c.socket.subdivisions = 0;
  c.closed_loop = false;
  pipeline::DesignArtifacts art;
  pipeline::run_design(c, fs::path(SOCKETSMITH_BINARY_DIR) / "tests" / "donning_design_coarse", true, {}, &art);
  ASSERT_TRUE(art.result.socket.has_value());
  const auto& solver = *art.setup->solver;
  DonningOptions o;
  o.friction = 0.0;
  o.contact.linear_body = false;
  DonningOptions f = o;
  f.smooth_wall = false;
  const auto don = [&](const DonningOptions& opt) {
    return simulate_donning(solver.model(), solver.skin().nodes, solver.skin().area_m2, art.result.socket->solid,
                            art.setup->model.frame, opt);
  };
  const auto a = don(o), b = don(f);
  ASSERT_TRUE(a.completed) << a.message;
  ASSERT_TRUE(b.completed) << b.message;
  const double fa = a.series.back().axial_force_n, fb = b.series.back().axial_force_n;
  std::cout << "coarse socket, frictionless: smoothed wall " << fa << " N, facets " << fb << " N\n";
  EXPECT_GT(fb, 10.0);
  EXPECT_NEAR(fa, fb, 0.4 * fb);
}

TEST(DonningNeoHookean, chord_steps_and_the_donnings_tolerances_reach_the_fresh_tangents_state) {
  // The donning's defaults (chord steps on the last factorisation in Newton's tail, ‖r‖ ≤ 1e-4 of
  // the contact forces, friction lag to 3 %) against a fresh tangent at every step and the tighter
  // 1e-5 / 1 %: the same donned and stood state, with friction, on the nonlinear body.
  const StoodNeoHookean nh("donning_design_nh_chord");
  ASSERT_TRUE(nh.art.result.socket.has_value());
  const DonningResult a = nh.don(), b = nh.don([](DonningOptions& o) {
    o.contact.chord_ratio = 0.0;
    o.contact.rel_tol = 1e-5;
    o.contact.friction_lag_tol = 0.01;
  });
  const DonningResult c = nh.don([](DonningOptions& o) { o.contact.chord_ratio = 0.0; });
  ASSERT_TRUE(a.completed && a.stood) << a.message;
  ASSERT_TRUE(b.completed && b.stood) << b.message;
  double peak = 0;
  const auto d = nh.compare(a, b, peak);
  const long fa = a.series.back().factorizations, fb = b.series.back().factorizations;
  std::cout << "defaults: " << a.newton_iterations << " Newton steps, " << fa << " factorisations; fresh tangents, "
            << "1e-5 / 1 %: " << b.newton_iterations << ", " << fb << "; no chord steps: "
            << c.series.back().factorizations << " factorisations; MAE " << d.mae << " Pa, max "
            << d.max_error << " Pa, R " << d.r << "\n";
  EXPECT_NEAR(a.final_offset_m, b.final_offset_m, 2e-5);
  // Measured 2026-11-30: MAE 15 Pa, max 0.74 kPa (a node switching stick/slip between the two
  // paths; the path tests above allow 5 % of the peak), R 0.99998; 63 factorisations, 76 without
  // chord steps, 104 with fresh tangents at 1e-5 / 1 %.
  EXPECT_LT(d.mae, 0.005 * d.mean_b);
  EXPECT_LT(d.max_error, 0.05 * peak);
  EXPECT_GT(d.r, 0.999);
  // Chord steps are taken (they never factorise), so the same tolerances without them factorise
  // more (how much more is speed: BM_Donning).
  ASSERT_TRUE(c.completed && c.stood) << c.message;
  EXPECT_LT(fa, c.series.back().factorizations);
}

TEST_F(Donning, a_stalled_path_says_where_the_wall_holds_the_skin_and_names_flags_only_where_the_user_has_them) {
  // Newton cut short (3 iterations, no residual accepted as a kink's): the path stalls at the
  // first step that needs more (18 mm below the pose at 1.8k nodes, the skin in contact).
  DonningOptions o = standing_path(15, 0.045);
  o.contact.max_newton = 3;
  o.contact.kink_rel_tol = 1e-12;
  const DonningResult r = don(o);
  ASSERT_FALSE(r.completed);
  EXPECT_THAT(r.message, ::testing::ContainsRegex("^donning stalled at [0-9.]+ mm below the designed pose"));
  EXPECT_THAT(r.message, ::testing::ContainsRegex(
                             "at [0-9.]+ mm ([0-9]+ skin nodes touch the wall, the hardest at -?[0-9]+ mm above the "
                             "distal end, (anterior|posterior|medial|lateral) \\(-?[0-9]+° from the front towards "
                             "medial\\), [0-9.]+ kPa)"));
  EXPECT_THAT(r.message, ::testing::HasSubstr("try more --steps or a smaller --offset-mm"));
  o.start_offset_name.clear();  // the closed-loop design: no donning flags to suggest
  const DonningResult q = don(o);
  ASSERT_FALSE(q.completed);
  EXPECT_THAT(q.message, ::testing::Not(::testing::HasSubstr("--")));
  std::cout << r.message << "\n";
}

// A path that grinds (the contact set flipping among a few nodes while Newton runs to its limit,
// step after step) must end with a message, not after minutes: the donning's Newton iterations
// are counted in all — failed solves and rejected steps too — and limited.
TEST_F(Donning, a_path_that_spends_its_newton_limit_ends_there_and_says_where_the_wall_holds_the_skin) {
  DonningOptions o = standing_path(0, 0.045);  // adaptive steps: rejected trial steps count too
  const DonningResult full = don(o);
  ASSERT_TRUE(full.completed) << full.message;
  EXPECT_GE(full.newton_spent, full.newton_iterations);
  EXPECT_LT(full.newton_spent, o.max_newton_iterations / 4) << "the default limit is far above a donning's need";
  o.max_newton_iterations = static_cast<int>(full.newton_spent / 2);
  const DonningResult cut = don(o);
  ASSERT_FALSE(cut.completed);
  EXPECT_LE(cut.newton_spent, o.max_newton_iterations);
  EXPECT_GE(cut.newton_spent, o.max_newton_iterations - 1);
  EXPECT_FALSE(cut.series.empty());  // the converged part of the path is kept
  EXPECT_LT(cut.final_offset_m, -1e-3);
  EXPECT_THAT(cut.message, ::testing::ContainsRegex("^donning stalled at [0-9.]+ mm below the designed pose"));
  EXPECT_THAT(cut.message, ::testing::HasSubstr("Newton iterations in all (the limit"));
  EXPECT_THAT(cut.message, ::testing::HasSubstr("does not settle"));
  EXPECT_THAT(cut.message, ::testing::HasSubstr("skin nodes touch the wall"));
  EXPECT_THAT(cut.message, ::testing::Not(::testing::HasSubstr("--steps")));  // more steps would not help
  std::cout << cut.message << "\n";
}

TEST_F(Donning, rejects_a_socket_that_grips_at_the_start_and_bad_options) {
  const auto& art = art_;
  ASSERT_TRUE(art.result.socket.has_value());
  const auto& solver = *art.setup->solver;
  const auto rejected = [&](const std::function<void(DonningOptions&)>& change) {
    DonningOptions o;
    o.start_offset_m = 0.06;
    change(o);
    EXPECT_THROW(simulate_donning(solver.model(), solver.skin().nodes, solver.skin().area_m2,
                                  art.result.socket->solid, art.setup->model.frame, o),
                 InvalidInputError);
  };
  rejected([](DonningOptions& o) { o.start_offset_m = 0.002; });  // starts almost donned: the socket grips
  rejected([](DonningOptions& o) { o.contact.stick_stiffness_ratio = 0.0; });
  rejected([](DonningOptions& o) { o.min_step_m = 0.0; });
  rejected([](DonningOptions& o) { o.start_offset_m = -0.01; });
  rejected([](DonningOptions& o) { o.contact.chord_ratio = 1.0; });
  rejected([](DonningOptions& o) { o.contact.chord_ratio = -0.1; });
  rejected([](DonningOptions& o) { o.max_newton_iterations = -1; });
  rejected([](DonningOptions& o) { o.contact.residual_floor_ratio = 0.5; });
}

}  // namespace
}  // namespace socketsmith::contact
