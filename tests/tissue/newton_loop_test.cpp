#include "socketsmith/tissue/newton_loop.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "socketsmith/core/errors.h"

namespace socketsmith::tissue {
namespace {
using namespace testing;

/// The cubic spring x³ + x = b: residual r = b − x³ − x, Newton's step r / (3x² + 1), a
/// backtracking line search on |r|. Its knobs make each way the loop can end happen.
class CubicSpring : public NewtonProblem {
 public:
  explicit CubicSpring(double b, double x0 = 0.0) : b_(b), x_(x0) {}
  double residual_norm() const override { return std::abs(r()); }
  double tolerance() const override { return tol; }
  bool proceed(int it) override { return it < budget; }
  Result direction() override {
    ++direction_calls;
    if (stale_factor && !fresh_) {  // every iterate's first direction is on an aged factorisation
      fresh_ = true;
      return Result::RetryFresh;
    }
    if (singular) return Result::Failed;
    delta_ = step_scale * r() / (3 * x_ * x_ + 1);
    return Result::Done;
  }
  Result line_search() override {
    ++line_searches;
    if (refuse_steps) return Result::Failed;
    for (double t = 1.0; t > 1e-4; t *= 0.5) {
      const double x = x_ + t * delta_;
      if (std::abs(b_ - x * x * x - x) < std::abs(r())) {
        x_ = x;
        fresh_ = false;
        return Result::Done;
      }
    }
    return Result::Failed;
  }
  bool accept_short(NewtonStop why) override { return accept && why != NewtonStop::Stalled; }
  std::string stop_reason() const override { return reason; }

  double x() const { return x_; }
  double r() const { return b_ - x_ * x_ * x_ - x_; }

  double tol = 1e-10;
  int budget = 1000;
  bool stale_factor = false, singular = false, refuse_steps = false, accept = false;
  double step_scale = 1.0;  ///< < 1: a damped Newton that converges only linearly
  std::string reason;
  int direction_calls = 0, line_searches = 0;

 private:
  double b_, x_;
  double delta_ = 0;
  bool fresh_ = false;
};

TEST(NewtonLoop, solves_a_cubic_spring_quadratically) {
  CubicSpring p(10.0);  // x³ + x = 10: x = 2
  const NewtonOutcome out = run_newton(p, {});
  EXPECT_EQ(out.stop, NewtonStop::Converged) << out.message;
  EXPECT_TRUE(out.ok());
  EXPECT_NEAR(p.x(), 2.0, 1e-11);
  EXPECT_LE(out.residual, out.tolerance);
  EXPECT_LE(out.iterations, 8);  // quadratic: from x = 0 about 6 steps to 1e-10
  EXPECT_EQ(out.iterations, p.line_searches);
  EXPECT_EQ(out.message.rfind("converged in", 0), 0u) << out.message;
}

TEST(NewtonLoop, a_retry_with_a_fresh_factorisation_is_not_an_iteration) {
  CubicSpring plain(10.0), retried(10.0);
  retried.stale_factor = true;
  NewtonLoopOptions o;
  o.stall_iterations = 2;  // a retry is no point of the stall test either
  const NewtonOutcome a = run_newton(plain, o), b = run_newton(retried, o);
  ASSERT_TRUE(a.ok() && b.ok()) << a.message << " / " << b.message;
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(retried.direction_calls, 2 * b.iterations);
  EXPECT_DOUBLE_EQ(plain.x(), retried.x());
}

TEST(NewtonLoop, stops_a_crawl_with_the_stall_test_and_says_so) {
  CubicSpring p(10.0);
  p.step_scale = 0.05;  // each step removes ~5 % of the residual
  NewtonLoopOptions o;
  o.stall_iterations = 4;
  o.stall_reduction = 1.0 / 3;
  const NewtonOutcome out = run_newton(p, o);
  EXPECT_EQ(out.stop, NewtonStop::Stalled);
  EXPECT_FALSE(out.ok());
  EXPECT_EQ(out.iterations, 4);  // the residual is tested against 4 iterations back from the fifth
  EXPECT_NE(out.message.find("stalled: the residual fell from"), std::string::npos) << out.message;
  EXPECT_NE(out.message.find("in the last 4 iterations"), std::string::npos) << out.message;
  // Without the test the same crawl runs into the iteration limit.
  CubicSpring q(10.0);
  q.step_scale = 0.05;
  NewtonLoopOptions limit;
  limit.max_iterations = 10;
  const NewtonOutcome cap = run_newton(q, limit);
  EXPECT_EQ(cap.stop, NewtonStop::IterationLimit);
  EXPECT_EQ(cap.iterations, 10);
  EXPECT_NE(cap.message.find("not converged after 10 iterations"), std::string::npos) << cap.message;
}

TEST(NewtonLoop, the_problem_may_accept_an_iterate_short_of_the_tolerance) {
  CubicSpring p(10.0);
  p.step_scale = 0.05;
  p.accept = true;
  p.reason = "a node on a kink";
  NewtonLoopOptions o;
  o.max_iterations = 3;
  const NewtonOutcome out = run_newton(p, o);
  EXPECT_EQ(out.stop, NewtonStop::Accepted);
  EXPECT_TRUE(out.ok());
  EXPECT_GT(out.residual, out.tolerance);
  EXPECT_NE(out.message.find("accepted after 3 iterations"), std::string::npos) << out.message;
  EXPECT_NE(out.message.find("a node on a kink"), std::string::npos) << out.message;
}

TEST(NewtonLoop, names_each_failure_in_one_line) {
  {
    CubicSpring p(10.0);
    p.singular = true;
    p.reason = "the tangent is singular";
    const NewtonOutcome out = run_newton(p, {});
    EXPECT_EQ(out.stop, NewtonStop::NoDirection);
    EXPECT_EQ(out.iterations, 0);
    EXPECT_EQ(out.message, "no Newton direction: the tangent is singular");
  }
  {
    CubicSpring p(10.0);
    p.refuse_steps = true;
    const NewtonOutcome out = run_newton(p, {});
    EXPECT_EQ(out.stop, NewtonStop::LineSearchFailed);
    EXPECT_EQ(out.iterations, 1);  // the direction was taken
    EXPECT_NE(out.message.find("no step along the Newton direction was accepted"), std::string::npos) << out.message;
  }
  {
    CubicSpring p(std::numeric_limits<double>::quiet_NaN());
    const NewtonOutcome out = run_newton(p, {});
    EXPECT_EQ(out.stop, NewtonStop::NotFinite);
    EXPECT_EQ(out.message, "diverged: the residual is not finite");
  }
  {
    CubicSpring p(10.0);
    p.budget = 2;
    p.reason = "the budget is spent";
    const NewtonOutcome out = run_newton(p, {});
    EXPECT_EQ(out.stop, NewtonStop::Stopped);
    EXPECT_EQ(out.iterations, 2);
    EXPECT_EQ(out.message, "stopped after 2 iterations: the budget is spent");
  }
}

TEST(NewtonLoop, rejects_options_that_cannot_work) {
  CubicSpring p(10.0);
  NewtonLoopOptions o;
  o.stall_reduction = 1.5;
  EXPECT_THROW(run_newton(p, o), InvalidInputError);
  o = {};
  o.max_iterations = -1;
  EXPECT_THROW(run_newton(p, o), InvalidInputError);
}

}  // namespace
}  // namespace socketsmith::tissue
