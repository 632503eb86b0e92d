#include "socketsmith/design/optimizer.h"

#include <algorithm>
#include <chrono>
#include <limits>
#include <cmath>
#include <numbers>
#include <optional>
#include <string>

#include <fmt/ranges.h>
#include <nlopt.hpp>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/design/amplitude_fit.h"

namespace socketsmith::design {
using namespace optimizer_detail;
namespace {

/// The region constraints as the log names them: "ischial / gluteal ≥ 15 %, distal fifth ≤ 9 %, tolerant / sensitive ≥ 1.55 ×".
std::string region_constraint_names(const OptimizerOptions& o) {
  std::string out;
  const auto add = [&out](const std::string& s) { out += (out.empty() ? "" : ", ") + s; };
  for (const auto& f : o.region_shares) {
    if (f.min_share > 0) add(fmt::format("{} ≥ {:.0f} %", f.name, 100 * f.min_share));
    if (f.max_share < 1) add(fmt::format("{} ≤ {:.0f} %", f.name, 100 * f.max_share));
  }
  for (const auto& r : o.pressure_ratios) add(fmt::format("{} ≥ {:.2f} ×", r.name, r.min_ratio));
  return out;
}

/// Position parameters of the spots that may move: (spot, kind) with kind 0 = θ, 1 = h.
struct PositionParam {
  int spot;
  int kind;
};

void shift_spot(Spot& s, int kind, double d) {
  if (kind == 0) {
    s.theta0 = wrap_angle(s.theta0 + d);
    s.theta1 = wrap_angle(s.theta1 + d);
    s.theta2 = wrap_angle(s.theta2 + d);
  } else {
    s.h0 += d;
    s.h1 += d;
    s.h2 += d;
  }
}

/// One-line errors for region constraints that do not fit the skin (one flag per skin node, sane shares).
void check_region_constraints(const OptimizerOptions& options, size_t n_skin) {
  for (const auto& f : options.region_shares)
    require(f.min_share >= 0.0 && f.min_share < 1.0 && f.max_share > f.min_share && f.max_share <= 1.0 &&
                f.nodes.size() == n_skin,
            "optimise_design: region '{}' asks {:.0f}–{:.0f} % of F_z on {} nodes of {} (expected 0 ≤ min < max ≤ 100 % "
            "and one flag per skin node)",
            f.name, 100 * f.min_share, 100 * f.max_share, f.nodes.size(), n_skin);
  for (const auto& r : options.pressure_ratios)
    require(std::isfinite(r.min_ratio) && r.min_ratio > 0 && r.bearing.size() == n_skin && r.relieved.size() == n_skin,
            "optimise_design: pressure ratio '{}' of {} asks {} and {} node flags of {} (expected a positive ratio and "
            "one flag per skin node)",
            r.name, r.min_ratio, r.bearing.size(), r.relieved.size(), n_skin);
}

/// The amplitude problem's options, its pressure caps and the geometry of the first fit: the stump at rest.
void set_up_problem(AmplitudeProblem& P, DesignSolver& solver, const OptimizerOptions& options) {
  P.q = options.softmax_power;
  P.by_ratio = options.objective == OptimizerOptions::Objective::Ratio;
  P.uniform = options.objective == OptimizerOptions::Objective::Uniform;
  double tmax = 0;
  for (double t : solver.thresholds()) tmax = std::max(tmax, t);
  P.a_max = options.max_amplitude_ratio * tmax;
  const double model_limit = options.model_pressure_limit * solver.model().material().youngs_modulus_pa;
  if (model_limit > 0) P.cap.assign(solver.thresholds().size(), model_limit);
  solver.skin_geometry(solver.model().rest_positions(), P.pos, P.normal, P.area);
  {
    const auto& m = solver.model().masses();
    const auto& x = solver.model().rest_positions();
    Vec3 c = Vec3::Zero();
    for (Eigen::Index k = 0; k < m.size(); ++k) c += m[k] * x.segment<3>(3 * k);
    P.centre = c / m.sum();
  }
}

/// Progress, cancel and the time limit of the fits, from @p t0.
FitControl fit_control(const OptimizerOptions& options, std::chrono::steady_clock::time_point t0) {
  FitControl control;
  control.progress = &options.progress;
  control.start = t0;
  require(std::isfinite(options.time_limit_s) && options.time_limit_s >= 0,
          "optimise_design: time limit {} s must be 0 (none) or positive", options.time_limit_s);
  if (options.time_limit_s > 0)
    control.deadline = t0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                std::chrono::duration<double>(options.time_limit_s));
  return control;
}

/// The amplitude fit of a round. The region constraints are the template's intent, not one of the seven
/// constraints: a fit that cannot keep them and the constraints together drops them (said in the log).
FitResult fit_keeping_regions(AmplitudeProblem& P, const std::vector<Spot>& spots, const RadarTargets& targets,
                              FitControl& control, bool has_regions, int round, OptimizerResult& out) {
  const OptimizerOptions& options = *P.options;
  P.use_regions = has_regions;
  FitResult fit = fit_amplitudes(P, spots, targets, control);
  if (!fit.ok && P.use_regions) {
    P.use_regions = false;
    const FitResult without = fit_amplitudes(P, spots, targets, control);
    if (without.ok) {
      out.log.push_back(fmt::format("round {}: the template's regions ({}) cannot be kept with the seven constraints: "
                                    "dropped for this fit",
                                    round + 1, region_constraint_names(options)));
      fit = without;
    } else {
      P.use_regions = true;
    }
  }
  return fit;
}

/// The position parameters of the spots that may move (a GRAD has no angle: its heights only).
std::vector<PositionParam> position_params(const std::vector<Spot>& spots) {
  std::vector<PositionParam> params;
  for (size_t k = 0; k < spots.size(); ++k) {
    if (!spots[k].enabled || !spots[k].optimise_position) continue;
    params.push_back({static_cast<int>(k), 0});
    if (spots[k].type != SpotType::Grad) params.push_back({static_cast<int>(k), 1});
    else params.back().kind = 1;  // a GRAD has no angle: move its heights only
  }
  return params;
}

/// The state of the position search (NLopt Sbplx) across its evaluations.
struct PositionSearch {
  AmplitudeProblem* P = nullptr;
  const std::vector<Spot>* base = nullptr;
  const std::vector<PositionParam>* params = nullptr;
  const RadarTargets* targets = nullptr;
  std::vector<Spot> work;
  int evaluations = 0;
  double length = 0;
  // Progress, cancel and the time limit: each evaluation (one amplitude fit) has its share
  // of the bar, and the fit inside reports within it.
  FitControl* control = nullptr;
  double fraction0 = 0, fraction_span = 0;
  int max_evaluations = 1;
  nlopt::opt* opt = nullptr;
  // The best evaluation: its shifts and its fit (kept, so no refit is needed after the search).
  double best_value = std::numeric_limits<double>::infinity();
  std::vector<double> best_shift;
  std::optional<FitResult> best_fit;
};

/// One evaluation of the position search: the spots shifted by @p d, their amplitudes fitted; the value is
/// J plus the constraints' violation (the best evaluation is kept).
double position_objective(unsigned nn, const double* d, double*, void* data) {
  auto& c = *static_cast<PositionSearch*>(data);
  auto& fc = *c.control;
  const double share = c.fraction_span / c.max_evaluations;
  fc.fraction0 = c.fraction0 + share * std::min(c.evaluations, c.max_evaluations);
  fc.fraction_span = c.evaluations < c.max_evaluations ? share : 0.0;
  if (!fc.report(0.0, fmt::format("fit {} of at most {}", c.evaluations + 1, c.max_evaluations))) {
    c.opt->force_stop();
    return std::numeric_limits<double>::max();
  }
  c.work = *c.base;
  for (unsigned i = 0; i < nn; ++i) shift_spot(c.work[(*c.params)[i].spot], (*c.params)[i].kind, d[i]);
  for (auto& s : c.work) {  // keep heights on the limb
    s.h0 = std::clamp(s.h0, 0.0, c.length);
  }
  c.P->build(c.work);
  const FitResult f = fit_amplitudes(*c.P, c.work, *c.targets, fc);
  ++c.evaluations;
  const double value = f.J + 10.0 * f.violation;
  if (value < c.best_value) {
    c.best_value = value;
    c.best_shift.assign(d, d + nn);
    c.best_fit = f;
  }
  if (fc.should_stop()) c.opt->force_stop();
  return value;
}

/// Amplitudes alone cannot meet the constraints: the spots are moved (Sbplx over their position parameters,
/// each evaluation an amplitude fit), @p spots and @p fit become the best found. False when cancelled.
bool search_positions(AmplitudeProblem& P, std::vector<Spot>& spots, const std::vector<PositionParam>& params,
                      const RadarTargets& targets, FitControl& control, int round, double round_share, FitResult& fit,
                      OptimizerResult& out) {
  const OptimizerOptions& options = *P.options;
  const std::vector<Spot> base = spots;
  PositionSearch ctx;
  ctx.P = &P;
  ctx.base = &base;
  ctx.params = &params;
  ctx.targets = &targets;
  ctx.work = base;
  ctx.length = P.solver->stump_length_m();
  const unsigned n = static_cast<unsigned>(params.size());
  nlopt::opt opt(nlopt::LN_SBPLX, n);
  ctx.control = &control;
  control.stage = fmt::format("design: optimising, round {}, moving spots", round + 1);
  ctx.fraction0 = control.fraction0 + round_share * 0.1;
  ctx.fraction_span = round_share * 0.7;
  ctx.max_evaluations = std::max(1, options.max_position_evaluations);
  ctx.opt = &opt;
  std::vector<double> lo(n), hi(n), step(n), x(n, 0.0);
  for (unsigned i = 0; i < n; ++i) {
    const double r = params[i].kind == 0 ? options.max_position_shift_rad : options.max_position_shift_m;
    lo[i] = -r;
    hi[i] = r;
    step[i] = 0.3 * r;
  }
  opt.set_lower_bounds(lo);
  opt.set_upper_bounds(hi);
  opt.set_initial_step(step);
  opt.set_maxeval(options.max_position_evaluations);
  opt.set_maxtime(options.max_position_seconds);
  opt.set_min_objective(position_objective, &ctx);
  opt.set_stopval(0.0);
  double best = 0;
  try {
    opt.optimize(x, best);
  } catch (const std::exception& e) {
    log::debug("optimise_design: position search stopped: {}", e.what());
  }
  control.stage = fmt::format("design: optimising, round {}", round + 1);
  if (control.is_cancelled) {
    out.evaluations += ctx.evaluations;
    return false;
  }
  if (ctx.best_fit) x = ctx.best_shift;
  for (unsigned i = 0; i < n; ++i) shift_spot(spots[params[i].spot], params[i].kind, x[i]);
  for (auto& s : spots) s.h0 = std::clamp(s.h0, 0.0, P.solver->stump_length_m());
  out.evaluations += ctx.evaluations;
  P.build(spots);
  // The best evaluation's fit is the fit at these positions (the same problem, the same start).
  if (ctx.best_fit) fit = *ctx.best_fit;
  else fit = fit_amplitudes(P, spots, targets, control);
  out.log.push_back(fmt::format("round {}: amplitudes alone could not meet the constraints; position search: {} fits, "
                                "J {:.3f}, violation {:.3g}",
                                round + 1, ctx.evaluations, fit.J, fit.violation));
  return true;
}

/// The stump model could not carry the fitted field (its lattice collapsed near @p c): the pressure is capped
/// around that point (a model limit, reported) for a fit again on the same geometry. Returns the log line.
std::string cap_near_collapse(AmplitudeProblem& P, const DesignSolver& solver, const std::vector<Spot>& spots,
                              const Vec3& c, const OptimizerOptions& options, int round) {
  const auto requested = solver.requested_pressure(spots);
  const auto& rest = solver.skin().positions;
  double mean_area = 0;
  for (double a : solver.skin().area_m2) mean_area += a / static_cast<double>(solver.skin().area_m2.size());
  const double radius = 3.0 * std::sqrt(mean_area);
  if (P.cap.empty()) P.cap.assign(rest.size(), std::numeric_limits<double>::infinity());
  double zone_peak = 0;
  int capped = 0;
  for (size_t i = 0; i < rest.size(); ++i)
    if ((rest[i] - c).norm() <= radius) zone_peak = std::max(zone_peak, std::min(requested[i], solver.thresholds()[i]));
  for (size_t i = 0; i < rest.size(); ++i)
    if ((rest[i] - c).norm() <= radius) {
      P.cap[i] = std::min(P.cap[i], options.model_cap_factor * zone_peak);
      ++capped;
    }
  const auto cyl = solver.frame().to_cylindrical(c);
  return fmt::format(
      "round {}: the stump model lost stability near θ = {:.0f}°, h = {:.0f} mm (peak {:.1f} "
      "kPa there); pressure capped at {:.1f} kPa on {} skin nodes and refitted",
      round + 1, cyl.theta * 180 / std::numbers::pi, cyl.h * 1e3, zone_peak / 1e3,
      options.model_cap_factor * zone_peak / 1e3, capped);
}

/// The log line of a solved round: the fit and the radar of the deformed stump.
std::string round_log(int round, const FitResult& fit, const DesignState& state) {
  return fmt::format(
      "round {}: fit J {:.3f} (violation {:.3g}), solved: F = ({:.1f}, {:.1f}, {:.1f}) N, "
      "T = ({:.2f}, {:.2f}, {:.2f}) N m, S = {:.1f} N, peak ratio {:.3f}, {}",
      round + 1, fit.J, fit.violation, state.radar.force_n.x(), state.radar.force_n.y(), state.radar.force_n.z(),
      state.radar.torque_nm.x(), state.radar.torque_nm.y(), state.radar.torque_nm.z(), state.radar.stability_n,
      state.max_requested_ratio, state.message);
}

/// Why the constraints are not met, and what would help: the follower iteration, comfort, stability, the
/// tissue model's limit, or the spot layout.
std::string failure_reason(const OptimizerResult& out, const DesignSolver& solver, const OptimizerOptions& options,
                           double model_limit) {
  const auto& targets = solver.targets();
  const auto& r = out.state.radar;
  const auto& st = out.state.status;
  if (!st.follower_converged)
    return fmt::format(
        "follower iteration: the stump's shape did not settle under its own pressures (the forces "
        "still changed by {:.2g} after {} passes, tolerance {:.2g}), so the socket it gives is not "
        "an equilibrium — stiffer tissue (tissue.youngs_kpa), a coarser or finer mesh, or lower "
        "pressures",
        out.state.follower_change, out.state.follower_passes, solver.options().follower_tolerance);
  if (!st.comfort_ok)
    return fmt::format(
        "comfort: the pressures needed peak at {:.0f} % of the pain threshold (skin node {}); the "
        "thresholds are too low for M g / 2 = {:.0f} N on this brim — raise the brim, add spots "
        "over tolerant areas, or review the thresholds",
        100 * out.state.max_requested_ratio, out.state.max_ratio_node, targets.fz_n);
  if (!st.stability_ok)
    return fmt::format(
        "stability: available friction {:.1f} N is below the prosthesis weight {:.1f} N — raise the "
        "friction coefficient or the wall pressures",
        r.stability_n, targets.stability_min_n);
  if (const double peak = out.state.pressure_pa.empty()
                              ? 0.0
                              : *std::max_element(out.state.pressure_pa.begin(), out.state.pressure_pa.end());
      model_limit > 0 && peak >= 0.95 * model_limit && r.force_n.z() < targets.fz_n - targets.force_tol_n)
    // The load is short because every pressure is held under the tissue model's range, not
    // because of where the spots are.
    return fmt::format(
        "{}: F_z = {:.1f} N of {:.1f} N with the pressures at the tissue model's limit, {:.2g} × E = "
        "{:.3g} kPa (design.model_pressure_limit): the tissue (E = {:.3g} kPa) is too soft for this "
        "load — raise tissue.youngs_kpa, or design.model_pressure_limit if larger strains are meant",
        st.failing(), r.force_n.z(), targets.fz_n, options.model_pressure_limit, model_limit / 1e3,
        solver.model().material().youngs_modulus_pa / 1e3);
  return fmt::format(
      "{}: F = ({:.1f}, {:.1f}, {:.1f}) N (target (0, 0, {:.1f}) ± {:.1f}), T = ({:.2f}, {:.2f}, "
      "{:.2f}) N m (± {:.2f}) — the spot layout cannot balance the load: add or move spots",
      st.failing(), r.force_n.x(), r.force_n.y(), r.force_n.z(), targets.fz_n, targets.force_tol_n, r.torque_nm.x(),
      r.torque_nm.y(), r.torque_nm.z(), targets.torque_tol_nm);
}

/// The optimiser's one-line outcome: met (rounds, fits, time, peak ratio), or why not, and the time limit.
std::string final_message(const OptimizerResult& out, const AmplitudeProblem& P, const DesignSolver& solver,
                          const OptimizerOptions& options, double model_limit) {
  std::string message;
  if (out.constraints_met) {
    message = fmt::format(
        "all constraints met after {} round(s) ({} amplitude fits, {:.1f} s); peak pressure "
        "{:.0f} % of the local pain threshold",
        out.rounds, out.evaluations, out.seconds, 100 * out.state.max_requested_ratio);
  } else {
    const std::string why = failure_reason(out, solver, options, model_limit);
    message = fmt::format("constraints not met after {} round(s): {}", out.rounds, why);
    if (P.free.size() < 6)
      message += fmt::format(
          " (only {} spot amplitude(s) may change, and balancing three forces and three "
          "torques needs at least 6: add spots or let the optimiser change more amplitudes)",
          P.free.size());
  }
  if (out.is_time_limited)
    message = fmt::format(
        "stopped by the time limit of {:.3g} s after {:.1f} s and {} round(s) — {} (a longer "
        "time limit, or fewer spots, lets it finish)",
        options.time_limit_s, out.seconds, out.rounds, message);
  return message;
}

/// The fitted amplitudes of a round, in the debug log.
void log_amplitudes(int round, const FitResult& fit, const std::vector<Spot>& spots) {
  std::string amps;
  for (const auto& sp : spots) amps += fmt::format(" {}={:.1f}", sp.name, sp.amplitude_pa / 1e3);
  log::debug("optimise_design: round {}: fit J {:.3f}, violation {:.3g}, amplitudes [kPa]:{}", round + 1, fit.J,
             fit.violation, amps);
}

/// The next round fits on the deformed geometry of the last solve.
void use_deformed_geometry(AmplitudeProblem& P, const DesignState& state) {
  P.pos = state.skin_positions;
  P.normal = state.skin_normals;
  P.area = state.skin_areas;
  P.centre = state.centre_of_inertia;
}

}  // namespace

OptimizerResult optimise_design(DesignSolver& solver, std::vector<Spot> spots, const OptimizerOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  OptimizerResult out;
  const auto& targets = solver.targets();
  for (const auto& s : spots) validate_spot(s, solver.stump_length_m());
  AmplitudeProblem P;
  P.solver = &solver;
  P.options = &options;
  const size_t n_skin = solver.skin_cylindrical().size();
  check_region_constraints(options, n_skin);
  const bool has_regions = !options.region_shares.empty() || !options.pressure_ratios.empty();
  set_up_problem(P, solver, options);
  const double model_limit = options.model_pressure_limit * solver.model().material().youngs_modulus_pa;
  const auto apply = [&](const FitResult& f, std::vector<Spot>& sp) {
    for (size_t j = 0; j < P.free.size(); ++j) sp[P.free[j]].amplitude_pa = kRef * f.z[static_cast<Eigen::Index>(j)];
  };
  bool positions_searched = false;
  int model_caps = 0;
  FitControl control = fit_control(options, t0);
  for (int round = 0; round < options.max_rounds; ++round) {
    // The bar: each round has 0.8 / max_rounds; its amplitude fit the first tenth of it, the
    // position search (when it runs) the next seven tenths.
    const double round_share = 0.8 / options.max_rounds;
    control.fraction0 = 0.1 + round_share * round;
    control.fraction_span = 0.1 * round_share;
    control.stage = fmt::format("design: optimising, round {}", round + 1);
    // Out of time after a solved round: stop; at the first round the fit stops at once and its
    // starting amplitudes are solved, so there is always a state to report.
    if (!control.report(0.0, "starting") && (control.is_cancelled || round > 0)) break;
    P.build(spots);
    FitResult fit = fit_keeping_regions(P, spots, targets, control, has_regions, round, out);
    out.region_constraints_met = P.use_regions || !has_regions;
    ++out.evaluations;
    out.slsqp_iterations += fit.evaluations;
    // Without friction no layout can hold the prosthesis: moving spots cannot help.
    const bool hopeless = solver.patient().friction == 0.0 && targets.stability_min_n > 0;
    if (!fit.ok && options.optimise_positions && !positions_searched && !hopeless && !control.should_stop()) {
      // Amplitudes alone cannot meet the constraints: move the spots.
      positions_searched = true;
      const std::vector<PositionParam> params = position_params(spots);
      if (!params.empty() &&
          !search_positions(P, spots, params, targets, control, round, round_share, fit, out))
        break;  // cancelled
    }
    if (control.is_cancelled) break;
    apply(fit, spots);
    log_amplitudes(round, fit, spots);
    out.objective = fit.J;
    out.rounds = round + 1;
    // Solve the stump under the fitted field and look at the radar of the deformed stump.
    try {
      out.state = solver.solve(spots);
    } catch (const SolverError& e) {
      // The lattice could not carry this field: cap the pressure around the element that collapsed
      // (a model limit, reported) and fit again on the same geometry.
      const Vec3 c = solver.last_failure_point();
      if (model_caps >= options.max_model_caps || !c.allFinite())
        fail<SolverError>("{} (optimiser round {}: {})", e.what(), round + 1, fmt::join(out.log, "; "));
      ++model_caps;
      out.log.push_back(cap_near_collapse(P, solver, spots, c, options, round));
      log::info("optimise_design: {}", out.log.back());
      ++out.model_caps;
      --round;  // the same round again, on the same geometry
      continue;
    }
    out.log.push_back(round_log(round, fit, out.state));
    if (out.state.status.all_ok()) break;
    if (control.should_stop()) break;  // out of time: the last solved state is the result
    if (!fit.ok && positions_searched && round > 0) break;  // infeasible: more rounds will not help
    use_deformed_geometry(P, out.state);  // next round
  }
  out.spots = spots;
  out.constraints_met = out.state.status.all_ok();
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.is_time_limited = control.is_timed_out && !control.is_cancelled;
  if (control.is_cancelled) out.message = "cancelled";
  if (out.message != "cancelled") out.message = final_message(out, P, solver, options, model_limit);
  report_progress(options.progress, 1.0, "design: optimised");
  return out;
}

}  // namespace socketsmith::design
