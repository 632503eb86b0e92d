#pragma once
/// @file headless.h
/// The headless mode of socketsmith-gui (tests, screenshots, the drag benchmark): after the case
/// is loaded, applies a scripted list of actions (docs/gui.md), each once the previous one has
/// been solved, renders frames, saves PNG screenshots and finishes with an exit status.

#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "app.h"

namespace socketsmith::gui {

struct HeadlessOptions {
  std::filesystem::path screenshot_dir;  ///< where screenshots go ("" = none); final.png at the end
  int frames = 3;                        ///< frames rendered after the last action
  double bench_drag_seconds = 0;         ///< > 0: drag a spot's amplitude for this long and measure
  std::string bench_spot;                ///< the spot dragged ("" = the first enabled one)
  std::filesystem::path bench_json;      ///< where the measurement goes ("" = stdout only)
  double timeout_seconds = 900;          ///< a step waiting longer fails the run
};

/// Reads a script: {"actions": [...]} or a bare array. @throws IoError, InvalidInputError.
std::vector<nlohmann::json> read_script(const std::filesystem::path& path);

class HeadlessRunner {
 public:
  HeadlessRunner(App& app, std::vector<nlohmann::json> actions, HeadlessOptions options);
  /// Call after each rendered frame, before the buffers are swapped (screenshots read the back
  /// buffer). Returns true when the run is over.
  bool after_frame(int width, int height);
  /// 0 when every action succeeded and no error was shown, 1 otherwise.
  int exit_status() const { return failed_ ? 1 : 0; }

 private:
  /// Runs one action; false when it must wait (e.g. a screenshot before the view settled).
  void run_action(const nlohmann::json& action, int width, int height);
  void fail_run(const std::string& message);
  bool bench_frame();

  App& app_;
  std::vector<nlohmann::json> actions_;
  HeadlessOptions options_;
  size_t next_ = 0;
  int settle_ = 2;            // frames to render before the next step
  int final_frames_ = 0;
  bool loaded_ = false;
  bool failed_ = false;
  bool finished_ = false;
  size_t errors_seen_ = 0;
  std::chrono::steady_clock::time_point step_start_ = std::chrono::steady_clock::now();
  // Drag benchmark
  enum class Bench { Off, Warmup, Running, Done } bench_ = Bench::Off;
  int bench_spot_ = -1;
  double bench_base_kpa_ = 0;
  long bench_frames_ = 0, bench_solves0_ = 0;
  double bench_cpu0_ = 0, bench_load0_ = 0;
  std::chrono::steady_clock::time_point bench_t0_;
  std::vector<double> frame_ms_;
  std::chrono::steady_clock::time_point last_frame_;
};

}  // namespace socketsmith::gui
