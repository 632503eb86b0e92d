#include "socketsmith/core/progress.h"

#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

namespace socketsmith {

bool report_progress(const ProgressCallback& cb, double fraction, std::string_view stage) {
  return cb ? cb(fraction, stage) : true;
}

namespace {
/// The stage without its trailing detail: "design: optimising (fit, 37 evaluations)" → "design: optimising".
std::string_view major_stage(std::string_view stage) {
  if (stage.empty() || stage.back() != ')') return stage;
  const auto open = stage.rfind(" (");
  return open == std::string_view::npos ? stage : stage.substr(0, open);
}
}  // namespace

ProgressCallback console_progress(double min_interval_s) {
  using Clock = std::chrono::steady_clock;
  struct State {
    Clock::time_point last{};
    std::string last_stage;
  };
  auto state = std::make_shared<State>();
  return [state, min_interval_s](double fraction, std::string_view stage) {
    const auto now = Clock::now();
    const double dt = std::chrono::duration<double>(now - state->last).count();
    if (major_stage(stage) != major_stage(state->last_stage) || dt >= min_interval_s || fraction >= 1.0) {
      std::fprintf(stderr, "  %.*s: %3.0f%%\n", static_cast<int>(stage.size()), stage.data(),
                   100.0 * fraction);
      state->last = now;
      state->last_stage = std::string(stage);
    }
    return true;
  };
}

}  // namespace socketsmith
