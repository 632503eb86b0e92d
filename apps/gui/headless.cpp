#include "headless.h"
#include "fonts.h"
#include "plots.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <numbers>
#include <sstream>

#include <sys/resource.h>

#include <imgui.h>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/json_input.h"
#include "socketsmith/pipeline/closed_loop.h"
#include "socketsmith/report/delivery_bar.h"

namespace socketsmith::gui {

namespace fs = std::filesystem;
using nlohmann::json;

std::vector<json> read_script(const fs::path& path) {
  std::ifstream in(path);
  if (!in) fail<IoError>("socketsmith-gui: cannot open script '{}'", path.string());
  std::stringstream text;
  text << in.rdbuf();
  json doc = parse_json_input(text.str(), fmt::format("socketsmith-gui: script '{}'", path.string()));
  if (doc.is_object() && doc.contains("actions")) doc = doc["actions"];
  require(doc.is_array(), "socketsmith-gui: script '{}' must be a list of actions or {{\"actions\": [...]}}",
          path.string());
  std::vector<json> out;
  for (const auto& a : doc) {
    require(a.is_object() && a.contains("do") && a["do"].is_string(),
            "socketsmith-gui: script '{}': every action is an object with \"do\": \"<action>\" (got {})",
            path.string(), a.dump());
    out.push_back(a);
  }
  return out;
}

HeadlessRunner::HeadlessRunner(App& app, std::vector<json> actions, HeadlessOptions options)
    : app_(app), actions_(std::move(actions)), options_(std::move(options)) {}

void HeadlessRunner::fail_run(const std::string& message) {
  std::cerr << "socketsmith-gui: " << message << "\n";
  failed_ = true;
  finished_ = true;
}

namespace {

/// CPU time of the whole process (all threads: UI, solver, llvmpipe) [s].
double process_cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

/// The 1-minute load average of the machine (other processes compete for the cores).
double load_average() {
  std::ifstream in("/proc/loadavg");
  double l = -1;
  in >> l;
  return l;
}

/// The design as the window shows it, for write_state: radar, spots, template regions, the
/// compared shape's deviation, the colour field, the rectification chart and the delivery check.
json live_state(const App& app) {
  const pipeline::DesignSession& session = app.session();
  require(session.state().has_value(), "write_state: no design solved yet");
  const auto& st = *session.state();
  json spots = json::array();
  for (const auto& sp : session.document().spots) spots.push_back(design::spot_to_json(sp));
  json j{{"radar",
                {{"fx_n", st.radar.force_n.x()},
                 {"fy_n", st.radar.force_n.y()},
                 {"fz_n", st.radar.force_n.z()},
                 {"tx_nm", st.radar.torque_nm.x()},
                 {"ty_nm", st.radar.torque_nm.y()},
                 {"tz_nm", st.radar.torque_nm.z()},
                 {"stability_n", st.radar.stability_n}}},
               {"constraints_met", st.status.all_ok()},
               {"max_pressure_ratio", st.max_requested_ratio},
               {"max_displacement_mm", st.max_displacement_m * 1e3},
               {"spots", spots}};
  if (const auto& t = session.template_check())
    j["template_regions"] = {{"template", t->template_name},
                             {"met", t->met},
                             {"tolerant_to_sensitive", t->tolerant_to_sensitive},
                             {"distal_fifth_share", t->distal_fifth.axial_share},
                             {"cv_below_brim", t->cv_below_brim}};
  if (!session.deviation_m().empty()) {  // the compared shape's deviation on the skin [mm]
    json dev = json::array();
    for (double d : session.deviation_m()) dev.push_back(std::isfinite(d) ? json(d * 1e3) : json());
    j["deviation_mm"] = dev;
    j["comparison"] = session.comparison();
  }
  j["field"] = to_string(app.field());
  j["colour_range"] = {app.colour_range().first, app.colour_range().second};
  if (const pipeline::RectificationChart* c = session.rectification()) {  // the table as the window draws it
    json rows = json::array();
    for (const pipeline::RectificationRow& r : session.rectification_rows())
      rows.push_back({{"code", r.code},
                      {"name", r.name},
                      {"rectification_mm", std::isfinite(r.mm) ? json(r.mm) : json()},
                      {"shown", r.value},
                      {"kind", r.kind},
                      {"measured", r.measured}});
    j["rectification"] = {{"wall", c->wall_source},
                          {"min_mm", c->rectification.min_m * 1e3},
                          {"max_mm", c->rectification.max_m * 1e3},
                          {"mean_mm", c->rectification.mean_m * 1e3},
                          {"seconds", c->seconds},
                          {"landmarks", rows}};
  }
  j["font"] = {{"file", ImGui::GetIO().FontDefault ? json(window_font_file()) : json()},  // null: built-in
               {"missing_symbols", missing_symbols()},  // of the library's text (fonts.h)
               {"symbols_shown", shown_text(kLibrarySymbols)}};
  if (const pipeline::DeliveryCheck* d = session.delivery()) {  // the delivery check as the window shows it
    const report::DeliveryVerdict bar = pipeline::delivery_verdicts(d->summary).second;
    json regions = json::object(), landmarks = json::array();
    for (const pipeline::RegionDelivery& r : d->summary.regions)
      regions[r.key] = {{"open_loop", report::to_json(r.open_loop, 1e-3, "_kpa")},
                        {"closed_loop", report::to_json(r.closed_loop, 1e-3, "_kpa")}};
    for (const pipeline::LandmarkDelivery& l : d->summary.landmarks)
      landmarks.push_back({{"code", l.code},
                           {"threshold_kpa", l.threshold_pa / 1e3},
                           {"target_kpa", l.target_pa / 1e3},
                           {"open_loop_kpa", l.open_loop_pa / 1e3},
                           {"closed_loop_kpa", l.closed_loop_pa / 1e3}});
    j["delivery"] = {{"converged", d->converged},
                     {"message", d->message},
                     {"donnings", d->donnings},
                     {"refits", d->refits},
                     {"seconds", d->seconds},
                     {"of_shown_design", d->state == session.state_serial()},
                     {"regions", regions},
                     {"landmarks", landmarks},
                     {"bar", report::to_json(bar)},
                     {"bar_shown", shown_text(bar.summary())}};
  }
  return j;
}

}  // namespace

void HeadlessRunner::run_action(const json& a, int width, int height) {
  const std::string what = a["do"].get<std::string>();
  const pipeline::DesignSession& session = app_.session();
  if (pipeline::DesignSession::is_edit_action(what)) {  // the case's edits: the session's own actions
    app_.apply(a);
  } else if (what == "select_spot") {
    const json& s = a.at("spot");
    const int k = s.is_number_integer() ? s.get<int>() : session.spot_index(s.get<std::string>());
    if (!s.is_number_integer()) require(k >= 0, "no spot named '{}'", s.get<std::string>());
    app_.select_spot(k);
  } else if (what == "field") {
    app_.set_field(parse_field(a.at("value").get<std::string>()));
  } else if (what == "view") {
    auto& cam = app_.camera();
    if (a.contains("yaw_deg")) cam.yaw_rad = a["yaw_deg"].get<double>() * std::numbers::pi / 180;
    if (a.contains("pitch_deg")) cam.pitch_rad = a["pitch_deg"].get<double>() * std::numbers::pi / 180;
    if (a.contains("zoom")) cam.distance_m /= a["zoom"].get<double>();
    app_.set_view_toggles(a.value("bones", true), a.value("landmarks", true), a.value("socket", true),
                          static_cast<float>(a.value("stump_opacity", 1.0)));
  } else if (what == "screenshot") {
    require(!options_.screenshot_dir.empty(), "screenshot: give --screenshot-dir");
    app_.screenshot(options_.screenshot_dir / a.at("name").get<std::string>(), width, height);
  } else if (what == "write_state") {  // the live design as the window shows it (tests: compare with `design`)
    write_text_atomically(a.at("path").get<std::string>(), live_state(app_).dump(2) + "\n");
  } else if (what == "wait_frames") {
    settle_ = std::max(settle_, a.at("count").get<int>());
  } else {
    fail("action '{}' is not known (add_spot, set, remove_spot, select_spot, field, optimise, cancel, patient, rebuild, "
         "brim, brim_key_point, thickness, undo, redo, begin_edit, end_edit, save, export, compare, view, screenshot, "
         "write_state, wait_frames)",
         what);
  }
}

bool HeadlessRunner::after_frame(int width, int height) {
  if (finished_) return true;
  // An error shown by the application fails the run (the message is already on stderr).
  if (app_.session().errors().size() > errors_seen_) {
    errors_seen_ = app_.session().errors().size();
    failed_ = true;
  }
  if (settle_ > 0) {
    --settle_;
    return false;
  }
  if (bench_ == Bench::Warmup || bench_ == Bench::Running) return bench_frame();
  const bool waiting_for_optimise = next_ > 0 && actions_[next_ - 1]["do"] == "optimise" &&
                                    actions_[next_ - 1].value("wait", true) == false;
  if (!app_.is_idle() && !waiting_for_optimise) {
    if (std::chrono::steady_clock::now() - step_start_ > std::chrono::duration<double>(options_.timeout_seconds))
      fail_run(fmt::format("timed out after {:.0f} s waiting for the design", options_.timeout_seconds));
    return finished_;
  }
  if (!loaded_) {
    if (!app_.session().has_design() || !app_.session().state()) {
      if (app_.is_idle()) fail_run("the case could not be opened (the error is above)");
      return finished_;
    }
    loaded_ = true;
    settle_ = 2;
    return false;
  }
  if (next_ < actions_.size()) {
    const json& a = actions_[next_++];
    try {
      run_action(a, width, height);
    } catch (const std::exception& e) {
      fail_run(fmt::format("action {} ({}): {}", next_, a.dump(), e.what()));
      return true;
    }
    step_start_ = std::chrono::steady_clock::now();
    settle_ = 2;
    return false;
  }
  if (options_.bench_drag_seconds > 0 && bench_ != Bench::Done) return bench_frame();
  if (final_frames_ < options_.frames) {
    ++final_frames_;
    return false;
  }
  if (!options_.screenshot_dir.empty()) {
    try {
      app_.screenshot(options_.screenshot_dir / "final.png", width, height);
    } catch (const Error& e) {
      fail_run(e.what());
    }
  }
  finished_ = true;
  return true;
}

bool HeadlessRunner::bench_frame() {
  const auto now = std::chrono::steady_clock::now();
  if (bench_ == Bench::Off) {
    const auto& spots = app_.session().document().spots;
    for (size_t k = 0; k < spots.size(); ++k)
      if (spots[k].enabled && (options_.bench_spot.empty() || spots[k].name == options_.bench_spot)) {
        bench_spot_ = static_cast<int>(k);
        break;
      }
    if (bench_spot_ < 0) {
      fail_run(fmt::format("--bench-drag: no enabled spot named '{}'", options_.bench_spot));
      return true;
    }
    bench_base_kpa_ = std::max(5.0, spots[bench_spot_].amplitude_pa / 1e3);
    app_.select_spot(bench_spot_);
    app_.session().begin_edit();
    bench_ = Bench::Warmup;
    bench_t0_ = now;
    return false;
  }
  const double t = std::chrono::duration<double>(now - bench_t0_).count();
  if (bench_ == Bench::Warmup && t > 1.0) {
    bench_ = Bench::Running;
    bench_t0_ = now;
    bench_frames_ = 0;
    bench_solves0_ = app_.session().solves_done();
    bench_cpu0_ = process_cpu_seconds();
    bench_load0_ = load_average();
    frame_ms_.clear();
    last_frame_ = now;
    return false;
  }
  // The drag: the amplitude swings ±30 % around its value, a new value every frame (as a mouse
  // moving a slider), each one a solve request that the worker coalesces.
  app_.session().set_spot_value(bench_spot_, "amplitude_kpa",
                      bench_base_kpa_ * (1.0 + 0.3 * std::sin(2 * std::numbers::pi * t / 2.0)));
  if (bench_ == Bench::Warmup) return false;
  ++bench_frames_;
  frame_ms_.push_back(std::chrono::duration<double, std::milli>(now - last_frame_).count());
  last_frame_ = now;
  if (t < options_.bench_drag_seconds) return false;
  app_.session().end_edit();
  bench_ = Bench::Done;
  const long solves = app_.session().solves_done() - bench_solves0_;
  const double cpu = process_cpu_seconds() - bench_cpu0_;
  std::sort(frame_ms_.begin(), frame_ms_.end());
  const double p95 = frame_ms_.empty() ? 0 : frame_ms_[static_cast<size_t>(0.95 * (frame_ms_.size() - 1))];
  const json result{{"seconds", t},
                    {"frames", bench_frames_},
                    {"frames_per_s", bench_frames_ / t},
                    {"frame_ms_p95", p95},
                    {"solves", solves},
                    {"solves_per_s", solves / t},
                    {"cpu_ms_per_frame", 1e3 * cpu / std::max(1L, bench_frames_)},
                    {"cpu_cores_used", cpu / t},
                    {"load_average_1min", {bench_load0_, load_average()}},
                    {"skin_nodes", app_.session().state() ? app_.session().state()->pressure_pa.size() : 0},
                    {"nodes", app_.session().state() ? app_.session().state()->positions.size() / 3 : 0}};
  std::cout << result.dump() << std::endl;
  if (!options_.bench_json.empty()) write_text_atomically(options_.bench_json, result.dump(2) + "\n");
  return false;
}

}  // namespace socketsmith::gui
