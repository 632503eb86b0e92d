// The closed loop's outputs: the delivered pressures' summary by region and landmark, the CSVs,
// the maps and path plots of the report, and the JSON of design.json's "closed_loop".
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/core/units.h"
#include "socketsmith/pipeline/closed_loop.h"
#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/report/csv.h"
#include "socketsmith/report/delivery_bar.h"

namespace socketsmith::pipeline {
namespace {

nlohmann::json stats_json(const report::ErrorStats& s) { return report::to_json(s, 1e-3, "_kpa"); }

report::ReportAgreement agreement_row(const std::string& region, const std::string& stage, const report::ErrorStats& s) {
  return {region, stage, s.count, s.mean_b, s.mean_a, s.mae, s.p99, s.max_error, s.r, s.sd_b};
}

/// delivered.csv (every skin node: designed, open- and closed-loop pressures, the wall's offset) and
/// delivered_iterations.csv (the pressures and offsets of every donning and refit).
void write_delivered_csvs(const design::DesignState& state, const ClosedLoopResult& loop,
                          const std::vector<double>& thresholds, const std::filesystem::path& out) {
  const size_t n = state.skin_positions.size();
  report::CsvTable t;
  t.header = {"x_m", "y_m", "z_m", "above_brim", "threshold_pa", "designed_pa", "open_loop_pa", "closed_loop_pa",
              "wall_offset_mm", "dragged_out"};
  for (size_t i = 0; i < n; ++i) {
    const auto& p = state.skin_positions[i];
    t.rows.push_back({p.x(), p.y(), p.z(), loop.below_brim[i] ? 0.0 : 1.0, thresholds[i], loop.target_pa[i],
                      loop.open_loop_pa[i], loop.closed_loop_pa[i], loop.wall_offset_m[i] * 1e3,
                      loop.dragged_out[i] ? 1.0 : 0.0});
  }
  report::write_csv(out / "delivered.csv", t.header, t.rows, 12);
  report::CsvTable h;
  h.header = {"above_brim", "designed_pa"};
  for (size_t k = 0; k < loop.delivered_by_iteration.size(); ++k) {
    h.header.push_back(fmt::format("donning{}_pa", k + 1));
    h.header.push_back(fmt::format("donning{}_wall_offset_mm", k + 1));
  }
  for (size_t i = 0; i < n; ++i) {
    std::vector<double> row{loop.below_brim[i] ? 0.0 : 1.0, loop.target_pa[i]};
    for (size_t k = 0; k < loop.delivered_by_iteration.size(); ++k) {
      row.push_back(loop.delivered_by_iteration[k][i]);
      row.push_back(loop.offset_by_iteration[k][i] * 1e3);
    }
    h.rows.push_back(std::move(row));
  }
  report::write_csv(out / "delivered_iterations.csv", h.header, h.rows, 9);
}

/// Each landmark's pressure / threshold, designed and delivered, as JSON and as report details.
nlohmann::json landmarks_json(const DeliverySummary& sum, report::ReportDelivery& delivery) {
  nlohmann::json landmarks = nlohmann::json::array();
  for (const auto& l : sum.landmarks) {
    landmarks.push_back({{"code", l.code},
                         {"nodes", l.nodes},
                         {"threshold_kpa", l.threshold_pa / 1e3},
                         {"designed_kpa", l.target_pa / 1e3},
                         {"open_loop_kpa", l.open_loop_pa / 1e3},
                         {"closed_loop_kpa", l.closed_loop_pa / 1e3},
                         {"designed_ratio", l.target_pa / l.threshold_pa},
                         {"open_loop_ratio", l.open_loop_pa / l.threshold_pa},
                         {"closed_loop_ratio", l.closed_loop_pa / l.threshold_pa}});
    delivery.details.push_back(
        {fmt::format("landmark {}: pressure / threshold", l.code),
         fmt::format("designed {:.3f}, open loop {:.3f}, closed loop {:.3f} ({} nodes)", l.target_pa / l.threshold_pa,
                     l.open_loop_pa / l.threshold_pa, l.closed_loop_pa / l.threshold_pa, l.nodes)});
  }
  return landmarks;
}

/// Every donning and refit of the loop, as JSON and as report details.
nlohmann::json iterations_json(const ClosedLoopResult& loop, report::ReportDelivery& delivery) {
  nlohmann::json iterations = nlohmann::json::array();
  for (size_t k = 0; k < loop.iterations.size(); ++k) {
    const auto& it = loop.iterations[k];
    iterations.push_back({{"refit", it.refit},
                          {"below_brim", stats_json(it.below_brim)},
                          {"in_socket", stats_json(it.in_socket)},
                          {"dragged_out_nodes", it.dragged_out},
                          {"dragged_out_max_designed_kpa", it.dragged_out_max_target_pa / 1e3},
                          {"dragged_out_height_mm", it.dragged_out_height_m * 1e3},
                          {"brim_raise_mm", it.brim_raise_m * 1e3},
                          {"max_wall_offset_mm", it.max_offset_m * 1e3},
                          {"mean_wall_offset_mm", it.mean_offset_m * 1e3},
                          {"wall_roughness_rms_mm", it.wall_roughness_rms_m * 1e3},
                          {"wall_roughness_p99_mm", it.wall_roughness_p99_m * 1e3},
                          {"wall_roughness_share", it.wall_roughness_share},
                          {"stood_at_mm", it.stood_offset_m * 1e3},
                          {"axial_friction_n", it.axial_friction_n},
                          {"friction_utilisation", it.friction_utilisation},
                          {"landmark_deviation", it.landmark_deviation},
                          {"landmark_furthest", it.landmark_furthest},
                          {"path_score", it.path_score},
                          {"path_furthest", it.path_furthest},
                          {"delivery_bar_met", it.bar_met},
                          {"factorizations", it.factorizations},
                          {"donning_seconds", it.donning_seconds},
                          {"socket_seconds", it.socket_seconds}});
    delivery.details.push_back({fmt::format("{} {}", it.refit ? "refit" : "donning", k + 1),
                                fmt::format("MAE {:.2f} kPa, 99th percentile {:.2f} kPa, R {:.3f}{}; wall moved up to "
                                            "{:.2f} mm, node-scale roughness {:.3f} mm RMS; stood {:+.2f} mm from the "
                                            "designed pose; friction mobilised {:.0f} %; {:.1f} s{}",
                                            it.below_brim.mae / 1e3, it.below_brim.p99 / 1e3, it.below_brim.r,
                                            landmark_note(it) + path_note(it),
                                            it.max_offset_m * 1e3, it.wall_roughness_rms_m * 1e3, it.stood_offset_m * 1e3,
                                            100 * it.friction_utilisation, it.donning_seconds,
                                            static_cast<int>(k) == loop.best ? " (kept)" : "")});
  }
  return iterations;
}

/// The maps on one scale (designed, open loop, closed loop) and the closed loop's error, into the
/// report and as delivered_map.png / delivered_error_map.png.
void add_delivery_maps(const DesignSetup& setup, const DesignResult& result, const ClosedLoopResult& loop,
                       const std::filesystem::path& out, report::ReportDelivery& delivery) {
  const size_t n = setup.solver->skin().nodes.size();
  const auto sframe = report::surface_frame(setup.model.frame);
  std::vector<report::MapLandmark> marks;
  for (const auto& l : setup.model.landmarks) marks.push_back({l.code, l.position, l.estimated});
  const double nan = std::numeric_limits<double>::quiet_NaN();
  double vmax = 0, emax = 0;
  std::vector<double> tk(n), ok(n), ck(n), ek(n);
  for (size_t i = 0; i < n; ++i) {
    const bool b = loop.below_brim[i];
    tk[i] = b ? loop.target_pa[i] / 1e3 : nan;
    ok[i] = b ? loop.open_loop_pa[i] / 1e3 : nan;
    ck[i] = b ? loop.closed_loop_pa[i] / 1e3 : nan;
    ek[i] = b ? ck[i] - tk[i] : nan;
    if (b) {
      vmax = std::max({vmax, tk[i], ok[i], ck[i]});
      emax = std::max(emax, std::abs(ek[i]));
    }
  }
  report::PressureMapData base;
  base.surface = &result.deformed_skin;  // lives as long as the result the report is written from
  base.value_label = "kPa";
  base.frame = sframe;
  base.landmarks = marks;
  emax = std::max(emax, 0.5);
  const struct {
    const std::vector<double>* values;
    const char* title;
    double lo, hi;
  } specs[] = {{&tk, "Designed pressure", 0, vmax},
               {&ok, "Delivered by the open-loop socket", 0, vmax},
               {&ck, "Delivered by the closed-loop socket (written)", 0, vmax},
               {&ek, "Closed loop: delivered minus designed", -emax, emax}};
  for (const auto& sp : specs) {
    report::PressureMapData m = base;
    m.values = *sp.values;
    m.title = sp.title;
    m.value_min = sp.lo;
    m.value_max = sp.hi;
    delivery.maps.push_back(std::move(m));
  }
  report::write_pressure_map(out / "delivered_map.png", delivery.maps[2]);
  report::write_pressure_map(out / "delivered_error_map.png", delivery.maps[3]);
}

/// Designed, open- and closed-loop pressures along the thesis's three paths, as report plots.
void add_delivery_plots(const DesignSetup& setup, const ClosedLoopResult& loop, report::ReportDelivery& delivery) {
  const auto& skin = setup.solver->skin();
  const auto sframe = report::surface_frame(setup.model.frame);
  for (const auto& path : design_paths(setup)) {
    const auto samples = report::sample_path(skin.positions, {}, sframe, path.spec);
    report::Plot p;
    p.title = "Delivered vs designed: " + path.name;
    p.x_label = path.spec.kind == report::PathKind::Vertical ? "height above the distal end [mm]" : "angle [deg]";
    p.y_label = "pressure [kPa]";
    const std::vector<std::pair<std::string, const std::vector<double>*>> curves{
        {"designed", &loop.target_pa}, {"open loop", &loop.open_loop_pa}, {"closed loop", &loop.closed_loop_pa}};
    for (const auto& [name, field] : curves) {
      report::PlotSeries s;
      s.name = name;
      s.dashed = name == "designed";
      for (const auto& smp : samples) {
        if (!loop.below_brim[smp.index]) continue;
        s.x.push_back(path.spec.kind == report::PathKind::Vertical ? smp.s * 1e3 : smp.s * 180.0 / std::numbers::pi);
        s.y.push_back((*field)[smp.index] / 1e3);
      }
      p.series.push_back(s);
    }
    p.y_min = 0.0;
    delivery.plots.push_back(p);
  }
}

}  // namespace

std::pair<report::DeliveryVerdict, report::DeliveryVerdict> delivery_verdicts(const DeliverySummary& sum) {
  std::vector<report::LandmarkRatio> open, kept;
  for (const auto& l : sum.landmarks) {
    open.push_back({l.code, l.target_pa / l.threshold_pa, l.open_loop_pa / l.threshold_pa});
    kept.push_back({l.code, l.target_pa / l.threshold_pa, l.closed_loop_pa / l.threshold_pa});
  }
  const RegionDelivery* below = nullptr;
  std::vector<report::PathDelivery> open_paths, kept_paths;
  for (const auto& r : sum.regions) {
    if (r.key == "below_brim") {
      below = &r;
      continue;
    }
    open_paths.push_back({r.name, r.open_loop});  // the thesis path's label
    kept_paths.push_back({r.name, r.closed_loop});
  }
  require(below != nullptr, "delivery_verdicts: the summary has no region below the brim");
  return {report::judge_delivery(below->open_loop, open, open_paths),
          report::judge_delivery(below->closed_loop, kept, kept_paths)};
}

std::vector<PathNodes> path_nodes_below_brim(const DesignSetup& setup, const std::vector<char>& below_brim) {
  const auto& skin = setup.solver->skin();
  const auto sframe = report::surface_frame(setup.model.frame);
  std::vector<PathNodes> out;
  for (const auto& path : design_paths(setup)) {
    std::vector<int> nodes;
    for (const auto& s : report::sample_path(skin.positions, {}, sframe, path.spec))
      if (below_brim[s.index]) nodes.push_back(s.index);
    if (nodes.size() >= 3) out.push_back({path.key, path.name, std::move(nodes)});
  }
  return out;
}

DeliverySummary summarise_delivery(const DesignSetup& setup, const ClosedLoopResult& loop) {
  const auto& skin = setup.solver->skin();
  const size_t n = skin.nodes.size();
  require(loop.target_pa.size() == n && loop.open_loop_pa.size() == n && loop.closed_loop_pa.size() == n,
          "summarise_delivery: the loop's fields do not match the stump's {} skin nodes", n);
  DeliverySummary d;
  std::vector<int> below;
  for (size_t i = 0; i < n; ++i)
    if (loop.below_brim[i]) below.push_back(static_cast<int>(i));
  const auto region = [&](const std::string& key, const std::string& name, const std::vector<int>& subset) {
    d.regions.push_back({key, name, report::compare_fields(loop.open_loop_pa, loop.target_pa, subset),
                         report::compare_fields(loop.closed_loop_pa, loop.target_pa, subset)});
  };
  region("below_brim", "below the brim", below);
  for (const auto& p : path_nodes_below_brim(setup, loop.below_brim)) region(p.key, p.name, p.nodes);
  for (const auto& z : landmark_zones(setup, loop.below_brim))
    d.landmarks.push_back({z.code, static_cast<int>(z.nodes.size()), z.mean(setup.thresholds, skin.area_m2),
                           z.mean(loop.target_pa, skin.area_m2), z.mean(loop.open_loop_pa, skin.area_m2),
                           z.mean(loop.closed_loop_pa, skin.area_m2)});
  return d;
}

double LandmarkZone::mean(const std::vector<double>& field, const std::vector<double>& area_m2_per_node) const {
  double s = 0;
  for (int i : nodes) s += area_m2_per_node[i] * field[i];
  return s / area_m2;
}

std::vector<LandmarkZone> landmark_zones(const DesignSetup& setup, const std::vector<char>& use) {
  const auto& skin = setup.solver->skin();
  require(use.size() == skin.nodes.size(), "landmark_zones: {} flags for {} skin nodes", use.size(), skin.nodes.size());
  std::vector<LandmarkZone> zones;
  for (const auto& l : setup.model.landmarks) {
    LandmarkZone z;
    z.code = l.code;
    const double radius = std::min(l.radius_m, 0.015);
    for (size_t i = 0; i < skin.nodes.size(); ++i)
      if (use[i] && (skin.positions[i] - l.position).norm() <= radius) {
        z.nodes.push_back(static_cast<int>(i));
        z.area_m2 += skin.area_m2[i];
      }
    if (!z.nodes.empty()) zones.push_back(std::move(z));
  }
  return zones;
}

namespace {
/// "MAE … kPa, 99th percentile … kPa" over the nodes of @p it still in the socket; "" when fewer
/// than 3 stayed in (their statistics were not computed).
std::string in_socket_figures(const ClosedLoopIteration& it) {
  if (it.in_socket.count == 0) return {};
  return fmt::format("MAE {:.2f} kPa, 99th percentile {:.2f} kPa", it.in_socket.mae / 1e3, it.in_socket.p99 / 1e3);
}
}  // namespace

std::string landmark_note(const ClosedLoopIteration& it) {
  if (it.landmark_furthest.empty()) return {};
  return fmt::format(", landmarks within {:.0f} % ({})", 100 * it.landmark_deviation, it.landmark_furthest);
}

std::string path_note(const ClosedLoopIteration& it) {
  if (it.path_furthest.empty() || it.path_score <= 1.0) return {};
  return fmt::format(", {}: MAE {:.2f} kPa, 99th percentile {:.2f} kPa", it.path_furthest, it.path_mae_pa / 1e3,
                     it.path_p99_pa / 1e3);
}

std::string dragged_out_note(const ClosedLoopIteration& it) {
  if (it.dragged_out == 0) return {};
  const std::string others = in_socket_figures(it);
  return fmt::format(" ({} nodes dragged above the brim by donning, up to {:.1f} mm, between {:.0f}° and {:.0f}° from "
                     "anterior towards medial, designed up to {:.1f} kPa{})",
                     it.dragged_out, it.dragged_out_height_m * 1e3, it.dragged_out_from_deg, it.dragged_out_to_deg,
                     it.dragged_out_max_target_pa / 1e3, others.empty() ? "" : "; the others: " + others);
}

std::string roughness_advice(const ClosedLoopIteration& kept, double cap_m) {
  const std::string level =
      fmt::format("{:.3f} mm RMS, {:.2f} of the correction's spread, 99th percentile {:.2f} mm (each node's "
                  "correction minus its neighbours' mean, below the brim{})",
                  kept.wall_roughness_rms_m * 1e3, kept.wall_roughness_share, kept.wall_roughness_p99_m * 1e3,
                  cap_m > 0 ? fmt::format("; capped at {:.2f} mm", cap_m * 1e3) : std::string());
  if (kept.wall_roughness_share <= kRoughWallShare) return level;
  return level + fmt::format(
                     ". Over {:.2f} of the spread the loop has fitted the wall to socketsmith's own sliding node by "
                     "node, and another solver may read those ripples as pressure: check the socket in CalculiX "
                     "(socketsmith validate design CASE --mode donning --stand, which runs CalculiX again with shorter "
                     "increments where its pressures alternate node by node, as over a bony crest).",
                     kRoughWallShare);
}

std::string dragged_out_advice(const ClosedLoopIteration& kept) {
  if (kept.dragged_out == 0) return {};
  const std::string without = in_socket_figures(kept);
  const std::string remedy =
      kept.brim_raise_m > 0
          ? fmt::format("The loop raised the socket's brim by up to {:.1f} mm (design.closed_loop_max_brim_raise_mm); "
                        "a brim higher still, or a liner (lower friction), keeps them in.",
                        kept.brim_raise_m * 1e3)
          : std::string("A brim higher there by that much (design.closed_loop_max_brim_raise_mm lets the closed loop "
                        "raise it), or a liner (lower friction), keeps them in.");
  return fmt::format("{} skin nodes below the brim (designed up to {:.1f} kPa) end above the socket's once donned and "
                     "stood on, up to {:.1f} mm, between {:.0f}° and {:.0f}° from anterior towards medial: friction "
                     "drags the skin proximally, and above the brim only the lip, which the loop does not shape, "
                     "presses them.{} {}",
                     kept.dragged_out, kept.dragged_out_max_target_pa / 1e3, kept.dragged_out_height_m * 1e3,
                     kept.dragged_out_from_deg, kept.dragged_out_to_deg,
                     without.empty() ? "" : " Without them: " + without + ".", remedy);
}

std::string drag_band_note(const DragBand& b) {
  const std::string what = fmt::format(
      "Donning dragged {} skin nodes below the brim, designed up to {:.1f} kPa, out of the first design's socket; the "
      "design was solved again asking no pressure up to {:.1f} mm below the brim there (design.closed_loop_drag_band)",
      b.node_ids.size(), b.max_designed_pa / 1e3, b.max_depth_m * 1e3);
  return b.kept ? what + fmt::format(", and its socket delivers it better: it is the design shown (the first design's "
                                     "socket missed the delivery bar, {:.2f} of it).",
                                     b.first_score)
                : what + ", and is not kept: " + b.why_not + ".";
}

namespace {

/// design.json's closed_loop.drag_band (null when it was not tried), and its report line.
nlohmann::json drag_band_json(const std::optional<DragBand>& band, report::ReportDelivery& delivery) {
  if (!band) return nullptr;
  const DragBand& b = *band;
  delivery.details.push_back({"the drag band", drag_band_note(b)});
  return {{"kept", b.kept},
          {"nodes", b.node_ids.size()},
          {"max_depth_mm", b.max_depth_m * 1e3},
          {"max_designed_kpa", b.max_designed_pa / 1e3},
          {"without_band_bar_score", b.first_score},
          {"why_not", b.why_not}};
}

}  // namespace

nlohmann::json write_closed_loop_outputs(const DesignSetup& setup, const DesignResult& result,
                                         const std::filesystem::path& out, report::ReportDelivery& delivery) {
  require(result.closed_loop.has_value(), "write_closed_loop_outputs: the design ran no closed loop");
  const ClosedLoopResult& loop = *result.closed_loop;
  write_delivered_csvs(result.state, loop, setup.thresholds, out);
  const DeliverySummary sum = summarise_delivery(setup, loop);
  delivery = {};
  delivery.has_delivery = true;
  delivery.summary = fmt::format(
      "The socket is donned from below with friction μ = {:.2f}, then pushed with half the body weight ({:.0f} N), "
      "as a standing patient loads it; the delivered contact pressures are compared with the designed ones. The "
      "closed loop corrected the wall: {}",
      setup.case_file.patient.friction, 0.5 * setup.case_file.patient.body_mass_kg * units::kGravity, loop.message);
  nlohmann::json regions = nlohmann::json::object();
  for (const auto& r : sum.regions) {
    delivery.rows.push_back(agreement_row(r.name, "open loop", r.open_loop));
    delivery.rows.push_back(agreement_row(r.name, "closed loop", r.closed_loop));
    regions[r.key] = {{"open_loop", stats_json(r.open_loop)}, {"closed_loop", stats_json(r.closed_loop)}};
  }
  const nlohmann::json landmarks = landmarks_json(sum, delivery);
  const auto [open_bar, kept_bar] = delivery_verdicts(sum);
  delivery.details.push_back({fmt::format("delivery bar ({})", report::describe()),
                              fmt::format("closed loop {}; open loop {}", kept_bar.summary(), open_bar.summary())});
  const nlohmann::json iterations = iterations_json(loop, delivery);
  add_delivery_maps(setup, result, loop, out, delivery);
  add_delivery_plots(setup, loop, delivery);
  const ClosedLoopIteration& kept = loop.iterations[loop.best];
  if (kept.dragged_out > 0) delivery.details.push_back({"dragged out of the socket", dragged_out_advice(kept)});
  const std::string rough = roughness_advice(kept, setup.case_file.closed_loop_max_roughness_m);
  delivery.details.push_back({"the wall's node-scale roughness", rough});
  if (kept.wall_roughness_share > kRoughWallShare) log::warn("closed loop: the wall's node-scale roughness: {}", rough);
  nlohmann::json socket_brim = nlohmann::json::array();
  if (kept.brim_raise_m > 0) {
    delivery.details.push_back(
        {"the socket's brim",
         fmt::format("up to {:.1f} mm above the design's, where donning and standing dragged skin designed below the "
                     "brim above it (the design, its pressures and the nodes compared stay the design's)",
                     kept.brim_raise_m * 1e3)});
    for (const auto& k : loop.socket_brim.key_points())
      socket_brim.push_back({{"theta_deg", k.theta / units::deg}, {"h_mm", k.h * 1e3}});
  }
  return {{"converged", loop.converged},
          {"message", loop.message},
          {"drag_band", drag_band_json(result.drag_band, delivery)},
          {"donnings", std::count_if(loop.iterations.begin(), loop.iterations.end(), [](const auto& it) { return !it.refit; })},
          {"refits", std::count_if(loop.iterations.begin(), loop.iterations.end(), [](const auto& it) { return it.refit; })},
          {"kept_donning", loop.kept_donning},
          {"retried_donnings", loop.retried_donnings},
          {"seconds", loop.seconds},
          {"friction", setup.case_file.patient.friction},
          {"body", loop.linear_body ? "linearised" : "nonlinear"},
          {"stand_force_n", 0.5 * setup.case_file.patient.body_mass_kg * units::kGravity},
          {"designed_friction_n", result.state.radar.stability_n},
          {"iterations", iterations},
          {"regions", regions},
          {"landmarks", landmarks},
          {"bar", report::to_json(kept_bar)},
          {"open_loop_bar", report::to_json(open_bar)},
          {"max_wall_offset_mm", kept.max_offset_m * 1e3},
          {"wall_roughness_rms_mm", kept.wall_roughness_rms_m * 1e3},
          {"wall_roughness_p99_mm", kept.wall_roughness_p99_m * 1e3},
          {"wall_roughness_share", kept.wall_roughness_share},
          {"dragged_out_nodes", kept.dragged_out},
          {"dragged_out_max_designed_kpa", kept.dragged_out_max_target_pa / 1e3},
          {"dragged_out_height_mm", kept.dragged_out_height_m * 1e3},
          {"dragged_out_arc_deg", {kept.dragged_out_from_deg, kept.dragged_out_to_deg}},
          {"brim_raise_mm", kept.brim_raise_m * 1e3},
          {"socket_brim_key_points", socket_brim},
          {"in_socket", stats_json(kept.in_socket)},
          {"outputs", {"delivered.csv", "delivered_iterations.csv", "delivered_map.png", "delivered_error_map.png"}}};
}

}  // namespace socketsmith::pipeline
