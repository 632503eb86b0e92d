// The design session's solve worker (no window needed): requests made faster than the stump can be solved
// coalesce (latest wins) and the last result is that of the newest edit, equal to a direct
// solve; a cancelled optimisation leaves the spots alone; a failing solve comes back as an error.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "socketsmith/pipeline/design_worker.h"
#include "socketsmith/pipeline/design_pipeline.h"

namespace socketsmith::pipeline {
namespace {

pipeline::DesignSetup& stump() {
  static auto setup = pipeline::prepare_design(pipeline::demo_case(1500));
  return *setup;
}

std::vector<DesignOutcome> wait_all(DesignWorker& w) {
  std::vector<DesignOutcome> out;
  const auto t0 = std::chrono::steady_clock::now();
  do {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    for (auto& r : w.take_results()) out.push_back(std::move(r));
  } while (w.is_busy() && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(120));
  return out;
}

TEST(DesignWorker, requests_coalesce_and_the_newest_edit_is_solved_last) {
  auto& s = stump();
  std::vector<design::Spot> spots = s.spots;
  std::vector<design::Spot> last;
  std::vector<DesignOutcome> results;
  {
    DesignWorker w(*s.solver);
    for (int k = 1; k <= 40; ++k) {  // a slider dragged: one request per "frame", no waiting
      spots[0].amplitude_pa = 10e3 + 500.0 * k;
      w.solve({spots, std::nullopt, static_cast<std::uint64_t>(k)});
    }
    last = spots;
    results = wait_all(w);
    EXPECT_LT(w.solves_done(), 40);  // coalesced
    EXPECT_GE(w.solves_done(), 1);
  }
  ASSERT_FALSE(results.empty());
  const auto& r = results.back();
  EXPECT_EQ(r.generation, 40u);
  ASSERT_TRUE(r.state.has_value()) << r.error;
  EXPECT_DOUBLE_EQ(r.spots[0].amplitude_pa, last[0].amplitude_pa);
  // Generations arrive in order.
  for (size_t k = 1; k < results.size(); ++k) EXPECT_LT(results[k - 1].generation, results[k].generation);
  // The same as solving the newest spots directly.
  s.solver->reset();
  const auto direct = s.solver->solve(last);
  EXPECT_NEAR(r.state->radar.force_n.z(), direct.radar.force_n.z(), 1e-3 * std::abs(direct.radar.force_n.z()));
  EXPECT_NEAR(r.state->max_requested_ratio, direct.max_requested_ratio, 1e-6);
}

TEST(DesignWorker, a_drag_on_the_nonlinear_stump_is_served_by_previews_and_solved_in_full_on_release) {
  auto c = pipeline::demo_case(1500);
  c.model = "neo-hookean";
  c.solve_mode = design::DesignSolveMode::Nonlinear;
  auto setup = pipeline::prepare_design(c);
  std::vector<design::Spot> spots = setup->spots;
  std::vector<DesignOutcome> results;
  {
    DesignWorker w(*setup->solver);
    w.solve({spots, std::nullopt, 1});  // the case opened: a full solve
    for (auto& r : wait_all(w)) results.push_back(std::move(r));
    for (int k = 2; k <= 6; ++k) {  // the drag
      spots[0].amplitude_pa *= 1.05;
      DesignRequest r{spots, std::nullopt, static_cast<std::uint64_t>(k)};
      r.preview = true;
      w.solve(r);
      for (auto& o : wait_all(w)) results.push_back(std::move(o));
    }
    w.solve({spots, std::nullopt, 7});  // the release
    for (auto& r : wait_all(w)) results.push_back(std::move(r));
  }
  ASSERT_EQ(results.size(), 7u);
  for (const auto& r : results) ASSERT_TRUE(r.state.has_value()) << r.error;
  EXPECT_FALSE(results.front().state->is_preview);
  for (size_t k = 1; k + 1 < results.size(); ++k) EXPECT_TRUE(results[k].state->is_preview) << k;
  const auto& last = *results.back().state;
  EXPECT_FALSE(last.is_preview);
  EXPECT_GT(last.newton_iterations, 0);
  // The last preview and the full solve of the same spots are close (the tangent step's error is
  // first order in the change from the first equilibrium: 28 % here).
  const auto& pv = *results[results.size() - 2].state;
  const double step = (last.positions - results.front().state->positions).norm();
  EXPECT_LT((pv.positions - last.positions).norm(), 0.1 * step);
}

TEST(DesignWorker, a_cancelled_optimisation_returns_no_new_spots) {
  auto& s = stump();
  DesignWorker w(*s.solver);
  design::OptimizerOptions o;
  w.optimise({s.spots, std::nullopt, 1}, o);
  w.cancel();
  const auto results = wait_all(w);
  ASSERT_EQ(results.size(), 1u);
  EXPECT_EQ(results[0].kind, DesignOutcome::Kind::Optimise);
  EXPECT_TRUE(results[0].is_cancelled);
  EXPECT_FALSE(results[0].state.has_value());
  ASSERT_TRUE(results[0].optimiser.has_value());
  EXPECT_EQ(results[0].optimiser->message, "cancelled");
}

TEST(DesignWorker, a_bad_spot_comes_back_as_an_error_line) {
  auto& s = stump();
  DesignWorker w(*s.solver);
  auto spots = s.spots;
  spots[0].amplitude_pa = 10e3;
  w.optimise({spots, std::nullopt, 1}, {});  // validated by the optimiser
  spots[0].r_h = -1;                           // a negative half-height
  w.optimise({spots, std::nullopt, 2}, {});
  const auto results = wait_all(w);
  ASSERT_EQ(results.size(), 2u);
  EXPECT_TRUE(results[0].error.empty()) << results[0].error;
  EXPECT_FALSE(results[1].error.empty());
  EXPECT_FALSE(results[1].state.has_value());
}

}  // namespace
}  // namespace socketsmith::pipeline
