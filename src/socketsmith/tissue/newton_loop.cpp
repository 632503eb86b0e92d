#include "socketsmith/tissue/newton_loop.h"

#include <cmath>
#include <vector>

#include <fmt/format.h>

#include "socketsmith/core/errors.h"

namespace socketsmith::tissue {

namespace {

std::string with_reason(std::string message, const std::string& reason) {
  return reason.empty() ? message : message + ": " + reason;
}

}  // namespace

NewtonOutcome run_newton(NewtonProblem& p, const NewtonLoopOptions& o) {
  require(o.max_iterations >= 0 && o.stall_iterations >= 0 && o.stall_reduction > 0 && o.stall_reduction < 1,
          "Newton: invalid options (max_iterations {} ≥ 0, stall_iterations {} ≥ 0, stall_reduction {} in (0, 1))",
          o.max_iterations, o.stall_iterations, o.stall_reduction);
  NewtonOutcome out;
  std::vector<double> history;  // ‖r‖ at the start of each iteration
  const auto finish = [&](NewtonStop stop, std::string message) {
    out.stop = stop;
    out.message = std::move(message);
    return out;
  };
  const auto accepted = [&] {
    return finish(NewtonStop::Accepted,
                  with_reason(fmt::format("accepted after {} iterations with residual {:.3g} N (tolerance {:.3g} N)",
                                          out.iterations, out.residual, out.tolerance),
                              p.stop_reason()));
  };
  const auto stopped = [&] {
    return finish(NewtonStop::Stopped,
                  with_reason(fmt::format("stopped after {} iterations", out.iterations), p.stop_reason()));
  };
  const auto short_of = [&](NewtonStop why, std::string message) {
    return p.accept_short(why) ? accepted() : finish(why, std::move(message));
  };
  for (;;) {
    out.residual = p.residual_norm();
    out.tolerance = p.tolerance();
    if (!std::isfinite(out.residual)) return finish(NewtonStop::NotFinite, "diverged: the residual is not finite");
    if (out.residual <= out.tolerance)
      return finish(NewtonStop::Converged, fmt::format("converged in {} iterations (residual {:.3g} N)", out.iterations,
                                                       out.residual));
    if (out.iterations >= o.max_iterations)
      return short_of(NewtonStop::IterationLimit,
                      fmt::format("not converged after {} iterations (residual {:.3g} N, tolerance {:.3g} N)",
                                  out.iterations, out.residual, out.tolerance));
    if (!p.proceed(out.iterations)) return stopped();
    history.push_back(out.residual);
    const auto k = static_cast<size_t>(o.stall_iterations);
    if (k > 0 && history.size() > k && out.residual > (1.0 - o.stall_reduction) * history[history.size() - 1 - k])
      return finish(NewtonStop::Stalled,
                    fmt::format("stalled: the residual fell from {:.3g} to {:.3g} N in the last {} iterations (by less "
                                "than {:.0f} %)",
                                history[history.size() - 1 - k], out.residual, k, 100 * o.stall_reduction));
    const auto dir = p.direction();
    if (dir == NewtonProblem::Result::RetryFresh) {
      history.pop_back();  // the same iterate again: neither an iteration nor a point of the stall test
      continue;
    }
    if (dir == NewtonProblem::Result::Failed)
      return finish(NewtonStop::NoDirection, with_reason("no Newton direction", p.stop_reason()));
    ++out.iterations;
    const auto searched = p.line_search();
    if (searched == NewtonProblem::Result::RetryFresh) {
      history.pop_back();
      --out.iterations;
      continue;
    }
    if (searched == NewtonProblem::Result::Failed) {
      out.residual = p.residual_norm();
      out.tolerance = p.tolerance();
      return short_of(NewtonStop::LineSearchFailed,
                      fmt::format("diverged: no step along the Newton direction was accepted by the line search "
                                  "(residual {:.3g} N, tolerance {:.3g} N)",
                                  out.residual, out.tolerance));
    }
    const auto next = p.after_step();
    if (next == NewtonProblem::Next::Continue) continue;
    out.residual = p.residual_norm();
    out.tolerance = p.tolerance();
    return next == NewtonProblem::Next::Accept ? accepted() : stopped();
  }
}

}  // namespace socketsmith::tissue
