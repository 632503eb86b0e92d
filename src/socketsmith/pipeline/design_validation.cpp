#include "socketsmith/pipeline/design_validation.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/core/units.h"
#include "socketsmith/calculix/ccx_runner.h"
#include "socketsmith/pipeline/closed_loop.h"
#include "socketsmith/pipeline/validation_inputs.h"
#include "socketsmith/report/csv.h"
#include "socketsmith/report/delivery_bar.h"
#include "socketsmith/report/design_report.h"
#include "socketsmith/report/plot_raster.h"
#include "socketsmith/report/raster.h"
#include "socketsmith/report/svg_plot.h"
#include "socketsmith/report/vtk_writer.h"

namespace socketsmith::pipeline {
namespace {

namespace fs = std::filesystem;
using Vec3 = Eigen::Vector3d;

constexpr int kRingsListed = 12;  // ring_means: the deeper rings pooled in the last one

/// socketsmith's own donned-and-stood pressure per skin node [Pa]; empty without a standing step.
std::vector<double> stood_pressures_pa(const DesignValidation& v) {
  std::vector<double> p;
  if (!v.donning || v.stand_force_n <= 0) return p;
  for (const auto& c : v.donning->contacts) p.push_back(c.pressure_pa);
  return p;
}

/// socketsmith's own donning of the design (the closed loop's kept donning when the design ran
/// one with the same μ and body, else a donning here): what CalculiX's donning is compared with
/// (against_donning), or shown beside the design (stand: the delivered pressures three ways).
void run_own_donning(const design::CaseFile& c, const DesignValidationOptions& o, DesignValidation& v) {
  const double mu = o.friction >= 0 ? o.friction : c.patient.friction;
  const auto& loop = v.artifacts.result.closed_loop;
  if (loop && !o.nonlinear_body && o.stand && std::abs(mu - c.patient.friction) < 1e-12) {
    v.donning = loop->donning;
    v.donning_from_closed_loop = true;
    v.own_body_linear = loop->linear_body;
    log::info("validate design: socketsmith's donning and standing of the socket: the closed loop's (donning {})",
              loop->kept_donning);
    return;
  }
  contact::DonningOptions dopt;
  dopt.start_offset_m = o.travel_m;
  dopt.start_offset_name = "--travel-mm";
  dopt.friction = mu;
  dopt.stand_force_n = o.stand ? 0.5 * c.patient.body_mass_kg * units::kGravity : 0.0;
  dopt.progress = o.progress;
  // validate donning keeps the thesis's linearised body unless asked; the check of a design dons
  // the stump the design solved, as the closed loop and `simulate donning --case` do: a
  // neo-Hookean design's socket on the linearised stump is not the problem CalculiX's NLGEOM
  // neo-Hookean twin solves, and its standing travel sizes CalculiX's push.
  v.own_body_linear = o.against_donning ? !o.nonlinear_body : design_body_linearised(v.artifacts.result.state, c);
  dopt.contact.linear_body = v.own_body_linear;
  dopt.contact.augmented_tol = case_augmented_tol(c);
  dopt.step_m = c.closed_loop_step_m;
  log::info("validate design: socketsmith's donning ({:.0f} mm, μ = {:.2f}, {} body)", o.travel_m * 1e3, dopt.friction,
            v.own_body_linear ? "linearised" : "nonlinear");
  v.donning = don_designed_socket(v.artifacts, dopt);
  log::info("validate design: socketsmith donning done in {:.1f} s, {} nodes in contact", v.donning->seconds,
            v.donning->series.empty() ? 0 : v.donning->series.back().contact_nodes);
}

/// comparison.csv: per skin node, its position, rings from the brim, both values, the error, the
/// penetration, the one-ring means, CalculiX's three pressure measures and the node's skin area;
/// with a standing step, socketsmith's own donned-and-stood pressure and the designed one too (both
/// codes are judged against the design; `validate donning` compares CalculiX with socketsmith's
/// donning, so its socketsmith column is not the design).
void write_comparison_csv(const DesignValidation& v, const fs::path& out) {
  const auto& r = v.check;
  const auto& skin = *v.stump.skin;
  const auto [scale, unit, suffix, what] = compared_quantity(r.mode);
  const std::vector<double> delivered = stood_pressures_pa(v);
  std::vector<std::vector<double>> rows;
  for (size_t i = 0; i < skin.nodes.size(); ++i) {
    const auto& p = skin.positions[i];
    rows.push_back({static_cast<double>(i), static_cast<double>(skin.nodes[i] + 1), p.x(), p.y(), p.z(),
                    static_cast<double>(std::min(r.brim_ring[i], 999)), r.socketsmith_value[i] * scale,
                    r.fe_value[i] * scale, (r.fe_value[i] - r.socketsmith_value[i]) * scale,
                    r.fe_penetration_m[i] * 1e3, r.socketsmith_value_smoothed[i] * scale,
                    r.fe_value_smoothed[i] * scale,
                    r.fe_cpress_pa.empty() ? 0.0 : r.fe_cpress_pa[i] * scale,
                    r.fe_stress_pressure_pa.empty() ? 0.0 : r.fe_stress_pressure_pa[i] * scale,
                    r.fe_force_pressure_pa.empty() ? 0.0 : r.fe_force_pressure_pa[i] * scale, skin.area_m2[i],
                    r.fe_alternating.empty() ? 0.0 : static_cast<double>(r.fe_alternating[i])});
    if (!delivered.empty()) rows.back().insert(rows.back().end(), {delivered[i] * scale, v.designed_pa[i] * scale});
  }
  std::vector<std::string> header{"skin_index", "ccx_node", "x_m", "y_m", "z_m", "rings_from_brim", "socketsmith_" + unit,
                                  "calculix_" + unit, "error_" + unit, "penetration_mm",
                                  "socketsmith_one_ring_" + unit, "calculix_one_ring_" + unit, "calculix_cpress_" + unit,
                                  "calculix_stress_" + unit, "calculix_force_" + unit, "area_m2",
                                  "calculix_alternates"};
  if (!delivered.empty()) header.insert(header.end(), {"socketsmith_stood_" + unit, "designed_" + unit});
  report::write_csv(out / "comparison.csv", header, rows);
}

/// Area-weighted means of the designed pressure, CalculiX's and socketsmith's donned-and-stood ones
/// (in that order) on each ring of skin quads below the brim (ring kRingsListed holds every deeper
/// ring): where along the stump the two codes part at the same mean level (docs/VALIDATION.md, "Where
/// the codes part below the brim"). Empty without a standing step.
std::vector<report::BandMeans> ring_means(const DesignValidation& v) {
  const std::vector<double> delivered = stood_pressures_pa(v);
  if (delivered.empty()) return {};
  return report::band_means(v.check.brim_ring, v.stump.skin->area_m2, {v.designed_pa, v.check.fe_value, delivered},
                            kRingsListed);
}

/// ring_means as a plot: each code's delivered minus designed pressure, ring by ring (SVG, PNG).
void write_ring_plot(const std::vector<report::BandMeans>& rings, const fs::path& out) {
  report::Plot p;
  p.title = "Delivered minus designed, ring by ring below the brim";
  p.x_label = fmt::format("rings of skin quads below the brim (ring {}: every deeper one)", kRingsListed);
  p.y_label = "mean delivered - designed [kPa]";
  std::vector<double> x, fe, ours, zero;
  for (const auto& m : rings) {
    x.push_back(m.band);
    fe.push_back((m.mean[1] - m.mean[0]) / 1e3);
    ours.push_back((m.mean[2] - m.mean[0]) / 1e3);
    zero.push_back(0.0);
  }
  p.series = {{"CalculiX", x, fe, "#D55E00", false, true, 2},
              {"socketsmith", x, ours, "#0072B2", false, true, 2},
              {"", x, zero, "#999999", true, false, 1}};
  report::write_svg(out / "rings.svg", p);
  report::write_plot_png(out / "rings.png", p);
}

/// Each thesis path's profile (SVG, PNG), appended to @p panels; returns the paths' statistics.
nlohmann::json write_path_profiles(const calculix::DesignCheckResult& r, const fs::path& out,
                                   std::vector<report::Plot>& panels) {
  const auto [scale, unit, suffix, what] = compared_quantity(r.mode);
  nlohmann::json paths_json = nlohmann::json::object();
  for (const auto& pc : r.paths) {
    std::vector<double> a, b;
    for (int i : pc.skin_index) {
      a.push_back(r.socketsmith_value[i] * scale);
      b.push_back(r.fe_value[i] * scale);
    }
    report::Plot p;
    p.title = fmt::format("{}: MAE {:.2f} ± {:.2f} {}, R {:.2f}", pc.label, pc.stats.mae * scale, pc.stats.sd * scale,
                          unit, pc.stats.r);
    p.x_label = pc.is_vertical ? "height above the distal end [mm]" : "angle from the front line [deg]";
    p.y_label = fmt::format("{} [{}]", what, unit);
    p.series = {{"socketsmith (designed)", pc.s, a, "#0072B2", false, true, 2},
                {"CalculiX", pc.s, b, "#D55E00", false, true, 2}};
    report::write_svg(out / fmt::format("profile_{}.svg", pc.name), p);
    report::write_plot_png(out / fmt::format("profile_{}.png", pc.name), p);
    panels.push_back(p);
    auto pj = report::to_json(pc.stats, scale, suffix);
    pj["label"] = pc.label;
    pj["smoothed"] = report::to_json(pc.smoothed, scale, suffix);
    paths_json[pc.name] = pj;
  }
  return paths_json;
}

/// The scatter of CalculiX's values against socketsmith's on every socket node (SVG, PNG).
report::Plot write_scatter(const DesignValidation& v, const fs::path& out) {
  const auto& r = v.check;
  const auto& skin = *v.stump.skin;
  const auto [scale, unit, suffix, what] = compared_quantity(r.mode);
  std::vector<double> a, b;
  for (size_t i = 0; i < skin.nodes.size(); ++i)
    if (r.brim_ring[i] >= 1) {
      a.push_back(r.socketsmith_value[i] * scale);
      b.push_back(r.fe_value[i] * scale);
    }
  double hi = 0;
  for (double x : a) hi = std::max(hi, x);
  for (double x : b) hi = std::max(hi, x);
  report::Plot p;
  p.title = fmt::format("every socket node: R {:.2f}, MAE {:.2f} {}", r.all.r, r.all.mae * scale, unit);
  p.x_label = fmt::format("socketsmith {} [{}]", what, unit);
  p.y_label = fmt::format("CalculiX {} [{}]", what, unit);
  p.series = {{"nodes", a, b, "#0072B2", false, true, 0}, {"y = x", {0, hi}, {0, hi}, "#999999", true, false, 1}};
  report::write_svg(out / "scatter.svg", p);
  report::write_plot_png(out / "scatter.png", p);
  return p;
}

/// stump_fe.vtu: both displacement fields and both values with their error on the skin nodes.
void write_stump_vtu(const DesignValidation& v, const fs::path& out) {
  const auto& r = v.check;
  const auto& d = v.stump;
  const auto& mesh = *d.mesh;
  const auto& skin = *d.skin;
  const double scale = compared_quantity(r.mode).scale;
  const int nn = mesh.num_nodes();
  std::vector<Vec3> u_ss(nn);
  std::vector<double> v_ss(nn, 0.0), v_fe(nn, 0.0), err(nn, 0.0);
  for (int n = 0; n < nn; ++n) u_ss[n] = d.designed_positions[n] - mesh.nodes[n];
  for (size_t i = 0; i < skin.nodes.size(); ++i) {
    v_ss[skin.nodes[i]] = r.socketsmith_value[i] * scale;
    v_fe[skin.nodes[i]] = r.fe_value[i] * scale;
    err[skin.nodes[i]] = (r.fe_value[i] - r.socketsmith_value[i]) * scale;
  }
  const std::string tag = r.mode != calculix::DesignCheckMode::Load ? "pressure_kpa" : "displacement_mm";
  report::write_vtu(out / "stump_fe.vtu", mesh,
                    {report::make_vector_field("displacement_socketsmith_m", u_ss),
                     report::make_vector_field("displacement_calculix_m", r.fe_displacement_m),
                     {"socketsmith_" + tag, 1, v_ss}, {"calculix_" + tag, 1, v_fe}, {"error_" + tag, 1, err}});
}

/// comparison_map.png: colour maps on the designed skin, socketsmith and CalculiX on one scale, one
/// above the other, then the absolute error on its own scale (above the brim: no data).
void write_comparison_map(const DesignValidation& v, bool against_donning, const fs::path& out) {
  const auto& r = v.check;
  const auto& d = v.stump;
  const auto& skin = *d.skin;
  const auto [scale, unit, suffix, what] = compared_quantity(r.mode);
  geometry::TriMesh def_tri = skin.triangles();
  for (size_t i = 0; i < skin.nodes.size(); ++i) def_tri.vertices[i] = d.designed_positions[skin.nodes[i]];
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> v_ss(skin.nodes.size()), v_fe(skin.nodes.size()), v_err(skin.nodes.size());
  double vmax = 0, emax = 0;
  for (size_t i = 0; i < skin.nodes.size(); ++i) {
    const bool in = r.brim_ring[i] >= 1;
    v_ss[i] = in ? r.socketsmith_value[i] * scale : nan;
    v_fe[i] = in ? r.fe_value[i] * scale : nan;
    v_err[i] = in ? std::abs(r.fe_value[i] - r.socketsmith_value[i]) * scale : nan;
    if (in) {
      vmax = std::max({vmax, v_ss[i], v_fe[i]});
      emax = std::max(emax, v_err[i]);
    }
  }
  const auto map = [&](const std::vector<double>& values, const std::string& title, double hi) {
    report::PressureMapData m;
    m.surface = &def_tri;
    m.values = values;
    m.value_label = unit;
    m.title = title;
    m.value_min = 0;
    m.value_max = std::max(hi, 1e-6);
    m.frame = report::surface_frame(d.frame);
    return report::render_pressure_map(m);
  };
  const std::string ours_label = against_donning ? "socketsmith donning" : "socketsmith (designed)";
  report::write_png(out / "comparison_map.png",
                    report::stack_images({map(v_ss, ours_label + ": " + what, vmax), map(v_fe, "CalculiX: " + what, vmax),
                                          map(v_err, "|CalculiX - socketsmith|", emax)}));
}

/// Per-node CSV, path profiles and a scatter (SVG, PNG), the stump's VTU and colour maps on the
/// designed skin; returns the paths' statistics for the summary.
nlohmann::json write_comparison_files(const DesignValidation& v, bool against_donning, const fs::path& out) {
  write_comparison_csv(v, out);
  std::vector<report::Plot> panels;
  const nlohmann::json paths_json = write_path_profiles(v.check, out, panels);
  panels.push_back(write_scatter(v, out));
  report::write_svg_grid(out / "comparison.svg", panels, 2);
  report::write_plot_grid_png(out / "comparison.png", panels, 2);
  write_stump_vtu(v, out);
  write_comparison_map(v, against_donning, out);
  if (!v.rings.empty()) write_ring_plot(v.rings, out);
  return paths_json;
}

}  // namespace

double stand_offset_m(const contact::DonningResult& ours) {
  require(ours.stood && ours.series.size() >= 2, "validate: socketsmith's donning did not stand ({})", ours.message);
  return ours.series.back().offset_m - ours.series[ours.series.size() - 2].offset_m;
}

double calculix_stand_travel_m(const contact::DonningResult& ours) {
  const double s = 3.0 * stand_offset_m(ours);
  return std::abs(s) >= 0.5e-3 ? s : std::copysign(0.5e-3, s);
}

namespace {

/// CalculiX's check of @p v's socket as the flags @p o ask.
calculix::DesignCheckOptions check_options(const design::CaseFile& c, const DesignValidationOptions& o,
                                           const calculix::FeMaterial& material, const DesignValidation& v) {
  calculix::DesignCheckOptions co;
  co.mode = o.mode;
  co.material = material;
  co.element = o.element ? *o.element
                         : c.element == tissue::HexFormulation::FBar ? calculix::ElementType::C3D8I
                                                                      : calculix::ElementType::C3D8;
  const double ours = socketsmith_penalty_pa_per_m(v.artifacts);
  co.contact.penalty_pa_per_m = calculix_penalty_pa_per_m(c, o, ours);
  if (o.mode != calculix::DesignCheckMode::Load)
    log::info("validate design: CalculiX's contact penalty {:.3g} Pa/m (socketsmith's donning: {:.3g})",
              co.contact.penalty_pa_per_m, ours);
  co.contact.stick_slope_pa_per_m = o.stick_slope_pa_per_m;
  co.contact.friction = o.friction >= 0 ? o.friction : c.patient.friction;
  co.clearance_m = o.clearance_m;
  co.initial_increment = o.initial_increment;
  co.alternation_rerun_nodes = o.alternation_rerun_nodes;
  co.donning_travel_m = o.travel_m;
  co.stand_force_n = v.stand_force_n;
  if (v.stand_force_n > 0) co.stand_travel_m = calculix_stand_travel_m(*v.donning);
  co.max_increment = std::max(0.1, o.initial_increment);
  co.fe_pressure = o.fe_pressure;
  co.nonlinear_geometry = !o.small_strain;
  const auto& r = v.artifacts.result;
  calculix_shell(o, r.closed_loop.has_value() || r.socket.has_value(), co);
  co.ccx = o.ccx;
  return co;
}

/// Refuses the flag combinations that have no meaning: the donning options without --mode donning,
/// --nonlinear-body outside validate donning.
void check_validation_flags(const DesignValidationOptions& o) {
  require(!o.against_donning || o.mode == calculix::DesignCheckMode::Donning,
          "validate design: --against-donning needs --mode donning");
  const char* donning_flag = o.stand            ? "--stand"
                             : o.printed_wall   ? "--printed-wall"
                             : o.shell_on_wall  ? "--shell-on-wall"
                             : o.shell_lip.value_or(false) ? "--shell-lip"
                                                : nullptr;
  require(!donning_flag || o.mode == calculix::DesignCheckMode::Donning,
          "validate design: {} needs --mode donning (the socket is donned, then stood on)", donning_flag ? donning_flag : "");
  require(!o.printed_wall || (!o.shell_on_wall && !o.shell_lip.value_or(false) && o.shell_subdivision.value_or(1) == 1),
          "validate design: --printed-wall dons the written socket as built: drop --shell-on-wall, --shell-lip and --shell-subdivision");
  require(!o.penalty_pa_per_m || (std::isfinite(*o.penalty_pa_per_m) && *o.penalty_pa_per_m >= 0),
          "validate design: penalty {} Pa/m (expected ≥ 0; 0: socketsmith's own)", o.penalty_pa_per_m.value_or(0.0));
  require(!o.nonlinear_body || o.against_donning,
          "validate design: --nonlinear-body sets socketsmith's donning body: use it with validate donning");
}

/// CalculiX's material: the case's continuum model's own ν and law (same material on both sides),
/// else ν 0.45, the thesis's (the MSS lattices have none to give); the options override.
calculix::FeMaterial validation_material(const design::CaseFile& c, const DesignValidationOptions& o) {
  calculix::FeMaterial material = fe_material(c);
  if (o.poisson_ratio >= 0) material.poisson_ratio = o.poisson_ratio;
  if (o.neo_hookean) material.is_neo_hookean = true;
  require(!(material.is_neo_hookean && o.small_strain),
          "validate design: --small-strain with a neo-Hookean tissue: the hyperelastic law is a large-strain model, "
          "CalculiX runs it with NLGEOM (drop --small-strain, or use the fe model for a small-strain check)");
  return material;
}

/// socketsmith's side: the design into OUT/design, the stump CalculiX gets, and (when compared or
/// stood on) socketsmith's own donning with the standing load it gives CalculiX.
void design_and_don(const design::CaseFile& c, const DesignValidationOptions& o, const fs::path& out,
                    DesignValidation& v) {
  const auto t0 = std::chrono::steady_clock::now();
  log::info("validate design: designing the socket ({} nodes)", c.target_nodes);
  v.design_summary = run_design(c, out / "design", c.optimise && o.optimise, o.progress, &v.artifacts);
  v.socketsmith_wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  v.stump = designed_stump(v.artifacts, o.printed_wall);
  v.designed_pa = v.stump.pressure_pa;
  if (!o.against_donning && !o.stand) return;
  run_own_donning(c, o, v);
  if (o.stand && v.donning->series.size() >= 2) {
    v.stand_force_n = 0.5 * c.patient.body_mass_kg * units::kGravity;
    v.socketsmith_stand_offset_m = stand_offset_m(*v.donning);
  }
  if (o.against_donning) use_donning_pressures(*v.donning, v.stump);
}

/// summary.json's record of the run: the settings, CalculiX's outcome, the agreement in each
/// region, the paths' statistics, the timings and the outputs.
nlohmann::json validation_summary(const design::CaseFile& c, const DesignValidationOptions& o,
                                  const calculix::FeMaterial& material, const DesignValidation& v,
                                  const nlohmann::json& paths_json, const fs::path& out) {
  const auto& r = v.check;
  const calculix::DesignCheckOptions& co = v.check_options;
  const bool contact = co.mode != calculix::DesignCheckMode::Load;
  const auto [scale, unit, suffix, what] = compared_quantity(co.mode);
  const bool ours_linear = v.own_body_linear;
  nlohmann::json j{{"case", o.case_label},
                   {"mode", to_string(co.mode)},
                   {"compared", what + " [" + unit + "]"},
                   {"converged", r.converged},
                   {"message", r.message},
                   {"nodes", r.nodes},
                   {"elements", r.elements},
                   {"socket_elements", r.socket_elements},
                   {"fe_socket", fe_socket_description(co)},
                   {"element", to_string(co.element)},
                   {"poisson_ratio", material.poisson_ratio},
                   {"nlgeom", co.nonlinear_geometry},
                   {"youngs_modulus_kpa", c.youngs_modulus_pa / 1e3},
                   {"neo_hookean", material.is_neo_hookean},
                   {"penalty_pa_per_m", co.contact.penalty_pa_per_m},
                   {"stick_slope_pa_per_m", co.contact.stick_slope_pa_per_m},
                   {"friction", co.contact.friction},
                   {"against_donning", o.against_donning},
                   {"socketsmith_body", ours_linear ? "linearised" : "nonlinear"},
                   {"stand_force_n", v.stand_force_n},
                   {"fe_stood", r.stood},
                   {"fe_donned_force_n", r.donned_force_n},
                   {"fe_stand_travel_mm", r.stand_travel_m * 1e3},
                   {"fe_stand_offset_mm", r.stand_offset_m * 1e3},
                   {"fe_stand_force_reached_n", r.stand_reached_force_n},
                   {"socketsmith_stand_offset_mm", v.socketsmith_stand_offset_m * 1e3},
                   {"ccx_runs", r.ccx_runs},
                   {"calculix_alternating_nodes", r.fe_alternating_nodes},
                   {"calculix_alternating_nodes_first_try", r.fe_alternating_nodes_first_try},
                   {"designed_force_n", r.designed_force_n},
                   {"fe_force_n", r.fe_force_n},
                   {"fe_axial_force_n", r.fe_axial_force_n},
                   {"fe_axial_friction_n", r.fe_axial_friction_n},
                   {"mean_designed_kpa", r.mean_designed_pa / 1e3},
                   {"mean_fe_kpa", r.mean_fe_pa / 1e3},
                   {"fe_pressure", contact ? to_string(r.fe_pressure) : "none"},
                   {"mean_fe_cpress_kpa", r.all_cpress.mean_a / 1e3},
                   {"all_cpress", report::to_json(r.all_cpress, scale, suffix)},
                   {"all_stress", report::to_json(r.all_stress, scale, suffix)},
                   {"all_force", report::to_json(r.all_force, scale, suffix)},
                   {"max_penetration_mm", r.max_penetration_m * 1e3},
                   {"all", report::to_json(r.all, scale, suffix)},
                   {"one_ring_away", report::to_json(r.one_ring_away, scale, suffix)},
                   {"away_from_brim", report::to_json(r.away_from_brim, scale, suffix)},
                   {"all_smoothed", report::to_json(r.all_smoothed, scale, suffix)},
                   {"away_from_brim_smoothed", report::to_json(r.away_from_brim_smoothed, scale, suffix)},
                   {"paths", paths_json},
                   {"ccx_wall_s", r.ccx.wall_s},
                   {"ccx_total_wall_s", r.ccx_total_wall_s},
                   {"ccx_increments", r.ccx.increments},
                   {"socketsmith_wall_s", v.socketsmith_wall_s},
                   {"socketsmith_solve_s", v.artifacts.result.state.seconds},
                   {"deck", "design_fe.inp"},
                   {"outputs",
                    {"design_fe.inp", "design_fe.frd", "design_fe.dat", "design_fe.log", "comparison.csv", "comparison.svg",
                     "comparison.png", "profile_front.svg", "profile_back.svg", "profile_mid.svg", "profile_front.png",
                     "profile_back.png", "profile_mid.png", "scatter.svg", "scatter.png", "stump_fe.vtu", "comparison_map.png",
                     "summary.json", "design/"}},
                   {"out", out.string()}};
  return j;
}

/// Delivered three ways on the socket nodes: CalculiX and socketsmith against the design (the
/// design's pressures even when CalculiX was compared with socketsmith's donning), and against each other.
void add_delivered_comparison(const DesignValidation& v, nlohmann::json& j) {
  const auto& r = v.check;
  const auto [scale, unit, suffix, what] = compared_quantity(v.check_options.mode);
  const auto& skin = *v.stump.skin;
  std::vector<int> socket_nodes;
  std::vector<double> delivered(skin.nodes.size());
  for (size_t i = 0; i < skin.nodes.size(); ++i) {
    delivered[i] = v.donning->contacts[i].pressure_pa;
    if (r.brim_ring[i] >= 1) socket_nodes.push_back(static_cast<int>(i));
  }
  const std::vector<double>& designed_pa = v.designed_pa;
  const report::ErrorStats ours = report::compare_fields(delivered, designed_pa, socket_nodes);
  const report::ErrorStats theirs = report::compare_fields(r.fe_value, designed_pa, socket_nodes);
  j["socketsmith_delivered_vs_design"] = report::to_json(ours, scale, suffix);
  j["calculix_delivered_vs_design"] = report::to_json(theirs, scale, suffix);
  j["calculix_vs_socketsmith_delivered"] =
      report::to_json(report::compare_fields(r.fe_value, delivered, socket_nodes), scale, suffix);
  j["socketsmith_delivered_from"] = v.donning_from_closed_loop ? "the closed loop's kept donning" : "a donning in this run";
  // How each carries the socket's axial push: the design's friction assumption (eq. 42) is where a
  // difference in the normal pressures starts.
  if (!v.donning->series.empty()) {
    j["socketsmith_axial_force_n"] = v.donning->series.back().axial_force_n;
    j["socketsmith_axial_friction_n"] = v.donning->series.back().axial_friction_n;
  }
  // Each landmark's pressure / threshold over its zone (issue 20: within 10 % of the design's).
  const DesignSetup& setup = *v.artifacts.setup;
  std::vector<char> on_socket(skin.nodes.size(), 0);
  for (int i : socket_nodes) on_socket[i] = 1;
  nlohmann::json landmarks = nlohmann::json::array();
  std::vector<report::LandmarkRatio> fe_ratios, our_ratios;
  for (const auto& z : landmark_zones(setup, on_socket)) {
    const double threshold = z.mean(setup.thresholds, skin.area_m2);
    const double designed = z.mean(designed_pa, skin.area_m2) / threshold;
    fe_ratios.push_back({z.code, designed, z.mean(r.fe_value, skin.area_m2) / threshold});
    our_ratios.push_back({z.code, designed, z.mean(delivered, skin.area_m2) / threshold});
    landmarks.push_back({{"code", z.code},
                         {"nodes", z.nodes.size()},
                         {"threshold_kpa", threshold / 1e3},
                         {"designed_ratio", designed},
                         {"calculix_ratio", fe_ratios.back().delivered},
                         {"socketsmith_ratio", our_ratios.back().delivered},
                         {"calculix_deviation", report::landmark_deviation(designed, fe_ratios.back().delivered)},
                         {"socketsmith_deviation", report::landmark_deviation(designed, our_ratios.back().delivered)}});
  }
  j["landmarks"] = landmarks;
  // Ring by ring below the brim (ring_means): where along the stump each code parts from the design.
  nlohmann::json rings = nlohmann::json::object();
  for (const auto& m : v.rings)
    rings[std::to_string(m.band)] = {{"nodes", m.count},
                                     {"designed_kpa", m.mean[0] / 1e3},
                                     {"calculix_kpa", m.mean[1] / 1e3},
                                     {"socketsmith_kpa", m.mean[2] / 1e3},
                                     {"calculix_minus_design_kpa", (m.mean[1] - m.mean[0]) / 1e3},
                                     {"socketsmith_minus_design_kpa", (m.mean[2] - m.mean[0]) / 1e3}};
  j["rings_below_brim"] = rings;
  if (!v.rings.empty()) {
    j["outputs"].push_back("rings.svg");
    j["outputs"].push_back("rings.png");
  }
  // Each side's delivery against report::DeliveryBar (issue 20's bar), below the brim and on each
  // thesis path below it.
  std::vector<report::PathDelivery> fe_paths, our_paths;
  for (const auto& p : r.paths) {
    fe_paths.push_back({p.label, report::compare_fields(r.fe_value, designed_pa, p.skin_index)});
    our_paths.push_back({p.label, report::compare_fields(delivered, designed_pa, p.skin_index)});
  }
  const report::DeliveryVerdict fe_bar = report::judge_delivery(theirs, fe_ratios, fe_paths);
  const report::DeliveryVerdict our_bar = report::judge_delivery(ours, our_ratios, our_paths);
  j["bar"] = {{"calculix", report::to_json(fe_bar)}, {"socketsmith", report::to_json(our_bar)}};
  log::info("validate design: the delivery bar ({}) — CalculiX {}; socketsmith {}", report::describe(),
            fe_bar.summary(), our_bar.summary());
}

}  // namespace

std::string fe_socket_description(const calculix::DesignCheckOptions& o) {
  if (o.mode == calculix::DesignCheckMode::Load) return "none (designed loads)";
  if (o.mode == calculix::DesignCheckMode::Contact) return "skin quads below the brim, fitted onto the designed skin";
  if (o.printed_wall) return "the printed socket's inner wall (C3D6 wedges)";
  std::string d = "skin quads below the brim";
  if (o.shell_subdivision > 1) d += fmt::format(", each split {} x {}", o.shell_subdivision, o.shell_subdivision);
  d += o.shell_on_wall ? ", laid on socketsmith's smoothed wall" : ", through the wall at the skin nodes";
  if (o.shell_lip) d += ", across the brim onto its lip";
  return d;
}

ComparedQuantity compared_quantity(calculix::DesignCheckMode mode) {
  if (mode == calculix::DesignCheckMode::Load) return {1e3, "mm", "_mm", "displacement"};
  return {};
}

double socketsmith_penalty_pa_per_m(const DesignArtifacts& art) {
  require(art.setup != nullptr, "socketsmith_penalty_pa_per_m: the design run has no stump");
  const auto& solver = *art.setup->solver;
  return contact::contact_penalty_pa_per_m(contact::DonningOptions{}.contact,
                                           solver.model().material().youngs_modulus_pa, solver.skin().area_m2);
}

double calculix_penalty_pa_per_m(const design::CaseFile& c, const DesignValidationOptions& o, double ours) {
  if (o.penalty_pa_per_m) return *o.penalty_pa_per_m > 0 ? *o.penalty_pa_per_m : ours;
  const bool like_for_like = o.mode == calculix::DesignCheckMode::Donning && !c.closed_loop_rigid_wall;
  return like_for_like ? ours : calculix::DesignCheckOptions{}.contact.penalty_pa_per_m;
}

void calculix_shell(const DesignValidationOptions& o, bool has_socket, calculix::DesignCheckOptions& co) {
  const bool shell = o.mode == calculix::DesignCheckMode::Donning && !o.printed_wall;
  co.printed_wall = o.printed_wall;
  co.shell_on_wall = o.shell_on_wall;
  co.shell_lip = o.shell_lip.value_or(shell && has_socket);
  co.shell_subdivision = o.shell_subdivision.value_or(shell && co.shell_lip ? 2 : 1);
}

DesignValidation validate_design(const design::CaseFile& c, const DesignValidationOptions& o, const fs::path& out) {
  check_validation_flags(o);
  const calculix::FeMaterial material = validation_material(c, o);
  calculix::find_ccx(o.ccx.executable);  // before the design's minutes, not after
  ensure_directory(out);

  if (o.write_case) design::write_case(out / "case.json", c);

  DesignValidation v;
  design_and_don(c, o, out, v);
  const auto& mesh = v.artifacts.setup->mesh.mesh;
  v.check_options = check_options(c, o, material, v);
  const calculix::DesignCheckOptions& co = v.check_options;
  if (v.stand_force_n > 0)
    log::info("validate donning: CalculiX step 2 pushes the socket {:+.2f} mm past the designed pose and stands where "
              "it carries {:.1f} N (socketsmith stood {:+.2f} mm past it)", co.stand_travel_m * 1e3, v.stand_force_n,
              v.socketsmith_stand_offset_m * 1e3);
  log::info("validate design: CalculiX {} check ({} nodes, {} elements, {}, {}, ν {}, {})", to_string(co.mode),
            mesh.num_nodes(), mesh.num_hexahedra(), to_string(co.element),
            material.is_neo_hookean ? "neo-Hookean" : "linear elastic", material.poisson_ratio,
            co.nonlinear_geometry ? "NLGEOM" : "small strain");
  v.check = calculix::check_design(v.stump, co, out, "design_fe");
  v.rings = ring_means(v);

  const nlohmann::json paths_json = write_comparison_files(v, o.against_donning, out);
  nlohmann::json j = validation_summary(c, o, material, v, paths_json, out);
  if (v.donning && o.stand) add_delivered_comparison(v, j);
  write_text_atomically(out / "summary.json", j.dump(2) + "\n");
  v.summary = std::move(j);
  return v;
}

}  // namespace socketsmith::pipeline
