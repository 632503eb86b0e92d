#include "socketsmith/design/design_solver.h"

#include <algorithm>
#include <chrono>
#include <limits>
#include <cmath>


#include "socketsmith/core/enum_names.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"
#include "socketsmith/design/input_limits.h"
#include "socketsmith/tissue/dof_map.h"
#include "socketsmith/tissue/pressure_load.h"
#include "socketsmith/tissue/sparse_cholesky.h"

namespace socketsmith::design {

bool ConstraintStatus::all_ok() const {
  return force_ok[0] && force_ok[1] && force_ok[2] && torque_ok[0] && torque_ok[1] && torque_ok[2] && stability_ok &&
         comfort_ok && follower_converged;
}

std::string ConstraintStatus::failing() const {
  std::string out;
  const auto add = [&](bool ok, const char* name) {
    if (ok) return;
    if (!out.empty()) out += ", ";
    out += name;
  };
  add(force_ok[0], "F_x");
  add(force_ok[1], "F_y");
  add(force_ok[2], "F_z");
  add(torque_ok[0], "T_x");
  add(torque_ok[1], "T_y");
  add(torque_ok[2], "T_z");
  add(stability_ok, "stability");
  add(comfort_ok, "comfort");
  add(follower_converged, "follower iteration");
  return out;
}

RadarTargets radar_targets(const PatientLoad& patient, double stump_length_m) {
  check_patient(patient);
  RadarTargets t;
  t.fz_n = 0.5 * patient.body_mass_kg * units::kGravity;
  t.stability_min_n = patient.prosthesis_mass_kg * units::kGravity;
  t.force_tol_n = patient.force_tolerance * t.fz_n;
  t.torque_tol_nm = patient.torque_tolerance * t.fz_n * stump_length_m;
  return t;
}

RadarValues compute_radar(const std::vector<Vec3>& pos, const std::vector<Vec3>& normal,
                          const std::vector<double>& area, const std::vector<double>& p,
                          const geometry::LimbFrame& frame, const Vec3& centre, double friction) {
  require(pos.size() == normal.size() && pos.size() == area.size() && pos.size() == p.size(),
          "compute_radar: sizes differ ({} positions, {} normals, {} areas, {} pressures)", pos.size(), normal.size(),
          area.size(), p.size());
  const Vec3 ex = frame.anterior, ey = frame.medial(), ez = frame.axis;
  Vec3 f = Vec3::Zero(), t = Vec3::Zero();
  double fr = 0;
  for (size_t i = 0; i < pos.size(); ++i) {
    if (p[i] == 0.0) continue;
    const double mag = p[i] * area[i];
    const Vec3 fi = -mag * normal[i];
    f += fi;
    t += (pos[i] - centre).cross(fi);
    fr += axial_friction_n(p[i], area[i], normal[i], ez, friction);
  }
  RadarValues r;
  r.force_n = Vec3(f.dot(ex), f.dot(ey), f.dot(ez) + fr);
  r.torque_nm = Vec3(t.dot(ex), t.dot(ey), t.dot(ez));
  r.stability_n = fr;
  return r;
}

ConstraintStatus check_constraints(const RadarValues& r, const RadarTargets& t, double max_requested_ratio) {
  ConstraintStatus s;
  s.force_ok[0] = std::abs(r.force_n.x()) <= t.force_tol_n;
  s.force_ok[1] = std::abs(r.force_n.y()) <= t.force_tol_n;
  s.force_ok[2] = std::abs(r.force_n.z() - t.fz_n) <= t.force_tol_n;
  for (int a = 0; a < 3; ++a) s.torque_ok[a] = std::abs(r.torque_nm[a]) <= t.torque_tol_nm;
  s.stability_ok = r.stability_n >= t.stability_min_n;
  s.comfort_ok = max_requested_ratio <= 1.0 + 1e-9;
  return s;
}

constexpr EnumName<DesignSolveMode> kSolveModes[] = {
    {DesignSolveMode::Nonlinear, "nonlinear"}, {DesignSolveMode::Linear, "linear"}, {DesignSolveMode::Auto, "auto"}};

std::string to_string(DesignSolveMode mode) { return name_of(kSolveModes, mode); }

DesignSolveMode parse_design_solve_mode(const std::string& text) {
  return parse_named(kSolveModes, text, "design solve mode '{}' is not known (expected nonlinear, linear or auto)");
}

struct DesignSolver::Impl {
  tissue::MassSpringModel model;
  volume::SkinSurface skin;
  geometry::LimbFrame frame;
  std::vector<double> thresholds;
  PatientLoad patient;
  double length = 0;
  RadarTargets targets;
  DesignSolverOptions options;
  std::vector<geometry::Cylindrical> cyl;
  std::vector<char> above;
  double flare_m = 0;          // DesignSolver::set_brim_flare
  std::function<double(double)> band_m;  // DesignSolver::set_brim_band
  std::vector<double> weight;  // per skin node: the share of the spots' field applied (brim_weight)
  tissue::DofMap dofs;
  std::unique_ptr<tissue::StaticSolver> solver;
  tissue::VectorXd x;  // warm start
  Vec3 failure_point = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  bool fell_back = false;  // Auto mode: the nonlinear lattice lost stability once; linear since
  std::string fallback_reason;
  // Linearised model: K₀ = −Pᵀ J(x₀) P, factorised on first use.
  std::unique_ptr<tissue::SparseCholesky<>> k0;
  void factor_linear() {
    if (k0) return;
    tissue::SparseMatrix J, K;
    model.jacobian(model.rest_positions(), tissue::JacobianKind::Exact, J);
    dofs.reduce_matrix(J, K);
    K *= -1.0;
    tissue::SparseMatrix Ks = 0.5 * (tissue::SparseMatrix(K.transpose()) + K);
    k0 = std::make_unique<tissue::SparseCholesky<>>();
    require<SolverError>(k0->factorize(Ks),
                         "design solve: the stump's stiffness at rest is not positive definite (a free part of the "
                         "mesh? check the fixed bone nodes)");
  }
  // preview(): the tangent at the last nonlinear equilibrium (x_eq under p_eq), factorised lazily.
  bool has_equilibrium = false;
  tissue::VectorXd x_eq;
  std::vector<double> p_eq;
  std::unique_ptr<tissue::SparseCholesky<>> kt;  // its symmetric part; null: not factorised
  tissue::SparseMatrix kt_full;  // the reduced tangent, follower load included
  bool kt_failed = false;  // the tangent was not positive definite: previews solve in full
  void factor_tangent() {
    if (kt || kt_failed || !has_equilibrium) return;
    tissue::SparseMatrix J, K;
    model.jacobian(x_eq, tissue::JacobianKind::Exact, J);
    tissue::FollowerPressure(skin, p_eq, model.num_nodes()).add_jacobian(x_eq, 1.0, J);
    dofs.reduce_matrix(J, K);
    K *= -1.0;
    kt_full = K;
    const tissue::SparseMatrix Ks = 0.5 * (tissue::SparseMatrix(K.transpose()) + K);
    kt = std::make_unique<tissue::SparseCholesky<>>();
    if (!kt->factorize(Ks)) {
      kt.reset();
      kt_failed = true;
    }
  }
  /// K_T⁻¹ b: the symmetric part's factor, refined against the whole (non-symmetric: the follower
  /// load) tangent — u ← u + K_s⁻¹ (b − K_T u) while the residual is above
  /// options.preview_tolerance × |b| (at most 6 refinements, each a back-substitution).
  tissue::VectorXd tangent_solve(const tissue::VectorXd& b) const {
    tissue::VectorXd u = kt->solve(b);
    for (int k = 0; k < 6; ++k) {
      const tissue::VectorXd r = b - kt_full * u;
      if (r.norm() <= options.preview_tolerance * b.norm()) break;
      u += kt->solve(r);
    }
    return u;
  }
  tissue::VectorXd linear_solve(const tissue::VectorXd& f) {
    factor_linear();
    tissue::VectorXd positions = model.rest_positions();
    dofs.add_expanded(k0->solve(dofs.restrict_vector(f)), positions);
    return positions;
  }

  /// The nonlinear stump: one Newton solve with the pressure as a load that follows the skin, its
  /// load stiffness in the tangent. Passes of fixed forces do not carry it: a stump at a design
  /// load can be close to buckling under dead forces (the distal tissue swinging round the bone
  /// end; measured on ampscan, 80 kg, 100 kPa: softest eigenvalue 0.4 N/m, the second pass stalls
  /// at 0.8 % of its load) while the follower load, which turns with the skin, holds it. False when
  /// it found no equilibrium and Auto mode fell back to the linearised model (x back at rest).
  bool solve_nonlinear(DesignState& st, tissue::VectorXd& positions) {
    const tissue::FollowerPressure load(skin, st.pressure_pa, model.num_nodes());
    const auto res = solver->solve(load, positions);
    st.newton_iterations += res.iterations;
    st.follower_passes = 1;
    if (res.converged) return true;
    failure_point = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
    if (res.worst_element >= 0) {
      Vec3 c = Vec3::Zero();
      for (int nd : model.mesh().hexahedra[res.worst_element]) c += model.rest_positions().segment<3>(3 * nd) / 8.0;
      failure_point = c;
    }
    st.nonlinear_failure = res.message;
    if (options.mode != DesignSolveMode::Auto) {
      st.converged = false;
      st.message = res.message;
      fail<SolverError>("design solve: the stump found no equilibrium under these pressures (peak applied {:.1f} kPa): {}",
                        *std::max_element(st.pressure_pa.begin(), st.pressure_pa.end()) / 1e3, res.message);
    }
    // Auto: the model has no stable equilibrium here; take the linearised model from now on, say so.
    fell_back = true;
    fallback_reason = res.message;
    st.linearised = true;
    st.follower_passes = 0;
    positions = model.rest_positions();
    return false;
  }

  /// The linearised stump's follower iteration: x → forces f(x) on the geometry at x → y = K₀⁻¹ f,
  /// the stump solved under them → forces g at y. Converged when g and f differ by at most
  /// follower_tolerance (relative, largest nodal change): y is then the equilibrium under its own
  /// forces. The first passes take x = y (plain fixed point); after max_follower_passes, or as soon
  /// as the change grows (the iteration oscillates), x moves only part of the way, x += ω (y − x),
  /// with Aitken's dynamic relaxation factor ω (Irons & Tuck 1969; Küttler & Wall 2008) — for at
  /// most max_relaxed_passes more solves. A state that did not converge is flagged, and never counts
  /// as meeting its constraints (ConstraintStatus::follower_converged). x is @p positions (3N, the
  /// warm start in, the state out).
  void follow_linearised(const DesignSolver& self, DesignState& st, tissue::VectorXd& positions) {
    const size_t n = st.requested_pa.size();
    std::vector<Vec3> pos, normal;
    std::vector<double> area;
    auto forces_at = [&](const tissue::VectorXd& at) {
      self.skin_geometry(at, pos, normal, area);
      tissue::VectorXd f = tissue::VectorXd::Zero(model.num_dofs());
      for (size_t i = 0; i < n; ++i) f.segment<3>(3 * skin.nodes[i]) = -st.pressure_pa[i] * area[i] * normal[i];
      return f;
    };
    tissue::VectorXd f = forces_at(positions);
    tissue::VectorXd y = positions;  // the last solve's equilibrium
    tissue::VectorXd r_prev;
    double omega = 0.5, previous_change = std::numeric_limits<double>::infinity();
    bool relaxing = false;
    const int max_passes = options.max_follower_passes + std::max(0, options.max_relaxed_passes);
    for (;;) {
      if (st.follower_passes >= max_passes) {
        st.follower_capped = true;
        positions = y;
        break;
      }
      y = linear_solve(f);
      ++st.follower_passes;
      check_deformation_bounded(st, y);
      const tissue::VectorXd g = forces_at(y);
      const double change = relative_force_change(g, f, n);
      st.follower_change = change;
      if (change <= options.follower_tolerance) {
        positions = y;
        break;
      }
      if (!relaxing && (st.follower_passes >= options.max_follower_passes || change > previous_change)) {
        relaxing = true;
        st.follower_relaxed_from = st.follower_passes;
      }
      previous_change = change;
      if (!relaxing) {
        positions = y;
        f = g;
        continue;
      }
      relax_towards(y, positions, r_prev, omega);
      f = forces_at(positions);
    }
  }

  /// The follower iteration runs away when the tissue is too soft for the load (each pass's
  /// deformed skin carries larger forces): stop before NaN reaches the outputs.
  void check_deformation_bounded(const DesignState& st, const tissue::VectorXd& y) {
    double umax = 0;
    for (Eigen::Index k = 0; k < y.size() / 3; ++k)
      umax = std::max(umax, (y - model.rest_positions()).segment<3>(3 * k).norm());
    if (!y.allFinite() || !(umax <= 0.5 * length)) {
      failure_point = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
      fail<SolverError>("design solve: the stump's deformation runs away under these pressures (pass {}: {:.3g} mm, "
                        "more than half the {:.0f} mm stump): the tissue (E = {:.3g} kPa) is too soft for this load — "
                        "raise tissue.youngs_kpa or lower the pressures",
                        st.follower_passes, umax * 1e3, length * 1e3, model.material().youngs_modulus_pa / 1e3);
    }
  }

  /// The largest change of a skin node's force from b to a, relative to the largest force of a.
  double relative_force_change(const tissue::VectorXd& a, const tissue::VectorXd& b, size_t n) const {
    double fmax = 0, dmax = 0;
    for (size_t i = 0; i < n; ++i) {
      fmax = std::max(fmax, a.segment<3>(3 * skin.nodes[i]).norm());
      dmax = std::max(dmax, (a - b).segment<3>(3 * skin.nodes[i]).norm());
    }
    return fmax > 0 ? dmax / fmax : 0.0;
  }

  /// x += ω (y − x), ω updated by Aitken's rule from the previous step's residual r_prev.
  static void relax_towards(const tissue::VectorXd& y, tissue::VectorXd& x, tissue::VectorXd& r_prev, double& omega) {
    const tissue::VectorXd r = y - x;
    if (r_prev.size() == r.size()) {
      const tissue::VectorXd dr = r - r_prev;
      const double dd = dr.squaredNorm();
      if (dd > 0) omega = std::clamp(-omega * r_prev.dot(dr) / dd, 0.05, 1.5);
    }
    r_prev = r;
    x += omega * r;
  }

  Impl(const volume::HexMesh& mesh, const tissue::TissueMaterial& material, const tissue::MassSpringOptions& mo,
       const geometry::LimbFrame& f, std::vector<double> thr, const PatientLoad& pl, double len,
       const DesignSolverOptions& o)
      : model(mesh, material, mo),
        skin(volume::extract_skin_surface(mesh)),
        frame(f),
        thresholds(std::move(thr)),
        patient(pl),
        length(len),
        targets(radar_targets(pl, len)),
        options(o),
        dofs(tissue::fixed_node_dofs(mesh, "design solve")) {
    solver = std::make_unique<tissue::StaticSolver>(model, dofs, options.solver);
    x = model.rest_positions();
    cyl.reserve(skin.nodes.size());
    for (const auto& p : skin.positions) cyl.push_back(frame.to_cylindrical(p));
    above.assign(skin.nodes.size(), 0);
    weight.assign(skin.nodes.size(), 1.0);
  }
};

DesignSolver::DesignSolver(const volume::HexMesh& mesh, const tissue::TissueMaterial& material,
                           const tissue::MassSpringOptions& model_options, const geometry::LimbFrame& frame,
                           std::vector<double> thresholds_pa, const PatientLoad& patient, double stump_length_m,
                           const DesignSolverOptions& options) {
  require(std::isfinite(stump_length_m) && stump_length_m > 0, "stump length {} m must be positive", stump_length_m);
  require(options.max_follower_passes >= 1 && options.max_follower_passes <= 1000 && options.max_relaxed_passes >= 0 &&
              options.max_relaxed_passes <= 1000 && options.follower_tolerance > 0,
          "DesignSolver: follower passes {} + {} (relaxed) or tolerance {} out of range ([1, 1000], [0, 1000], > 0)",
          options.max_follower_passes, options.max_relaxed_passes, options.follower_tolerance);
  impl_ = std::make_unique<Impl>(mesh, material, model_options, frame, std::move(thresholds_pa), patient,
                                 stump_length_m, options);
  require(impl_->thresholds.size() == impl_->skin.nodes.size(), "DesignSolver: {} thresholds for {} skin nodes",
          impl_->thresholds.size(), impl_->skin.nodes.size());
  for (double t : impl_->thresholds)
    require(std::isfinite(t) && t > 0, "DesignSolver: a pain threshold is not a positive pressure ({} Pa)", t);
}

DesignSolver::~DesignSolver() = default;

const volume::SkinSurface& DesignSolver::skin() const { return impl_->skin; }
const std::vector<geometry::Cylindrical>& DesignSolver::skin_cylindrical() const { return impl_->cyl; }
const std::vector<double>& DesignSolver::thresholds() const { return impl_->thresholds; }
const geometry::LimbFrame& DesignSolver::frame() const { return impl_->frame; }
const PatientLoad& DesignSolver::patient() const { return impl_->patient; }
const RadarTargets& DesignSolver::targets() const { return impl_->targets; }
const tissue::MassSpringModel& DesignSolver::model() const { return impl_->model; }
double DesignSolver::stump_length_m() const { return impl_->length; }
const DesignSolverOptions& DesignSolver::options() const { return impl_->options; }
const std::vector<char>& DesignSolver::above_brim() const { return impl_->above; }
void DesignSolver::reset() {
  impl_->x = impl_->model.rest_positions();
  impl_->fell_back = false;
}
Vec3 DesignSolver::last_failure_point() const { return impl_->failure_point; }

std::vector<char> DesignSolver::above_brim_of(const std::function<double(double)>& brim_height_m) const {
  const auto& s = *impl_;
  std::vector<char> above(s.cyl.size(), 0);
  if (brim_height_m)
    for (size_t i = 0; i < s.cyl.size(); ++i) above[i] = s.cyl[i].h > brim_height_m(s.cyl[i].theta) ? 1 : 0;
  return above;
}

void DesignSolver::set_brim(const std::function<double(double)>& brim_height_m) {
  auto& s = *impl_;
  s.above = above_brim_of(brim_height_m);
  s.weight.assign(s.cyl.size(), 1.0);
  for (size_t i = 0; i < s.cyl.size(); ++i) {
    if (s.above[i]) {
      s.weight[i] = 0.0;
    } else if (brim_height_m && (s.flare_m > 0 || s.band_m)) {  // smoothstep over the flare below the band
      const double band = s.band_m ? std::max(0.0, s.band_m(s.cyl[i].theta)) : 0.0;
      const double depth = brim_height_m(s.cyl[i].theta) - s.cyl[i].h - band;
      const double t = s.flare_m > 0 ? std::clamp(depth / s.flare_m, 0.0, 1.0) : (depth > 0 ? 1.0 : 0.0);
      s.weight[i] = t * t * (3 - 2 * t);
    }
  }
}

void DesignSolver::set_brim_flare(double flare_m) {
  require(std::isfinite(flare_m) && flare_m >= 0, "design: the brim flare must be a length ≥ 0 (got {} m)", flare_m);
  impl_->flare_m = flare_m;
}

void DesignSolver::set_brim_band(std::function<double(double)> depth_m) { impl_->band_m = std::move(depth_m); }

const std::vector<double>& DesignSolver::brim_weight() const { return impl_->weight; }

std::vector<double> DesignSolver::requested_pressure(const std::vector<Spot>& spots) const {
  const auto& s = *impl_;
  std::vector<double> p(s.cyl.size(), 0.0);
  for (size_t i = 0; i < p.size(); ++i)
    if (!s.above[i]) p[i] = s.weight[i] * std::max(0.0, field_pressure(spots, s.cyl[i].theta, s.cyl[i].h));
  return p;
}

void DesignSolver::skin_geometry(const tissue::VectorXd& x, std::vector<Vec3>& pos, std::vector<Vec3>& normal,
                                 std::vector<double>& area) const {
  const auto& s = *impl_;
  pos.resize(s.skin.nodes.size());
  for (size_t i = 0; i < pos.size(); ++i) pos[i] = x.segment<3>(3 * s.skin.nodes[i]);
  tissue::skin_areas_and_normals(s.skin, x, area, normal);
}

std::vector<double> DesignSolver::normal_displacement(const std::vector<double>& pressure_pa, const DesignState& state) {
  auto& s = *impl_;
  const size_t n = s.skin.nodes.size();
  require(pressure_pa.size() == n && state.skin_normals.size() == n && state.skin_areas.size() == n,
          "normal_displacement: {} pressures and a state with {} normals for {} skin nodes", pressure_pa.size(),
          state.skin_normals.size(), n);
  tissue::VectorXd f = tissue::VectorXd::Zero(s.model.num_dofs());
  for (size_t i = 0; i < n; ++i) {
    require(std::isfinite(pressure_pa[i]), "normal_displacement: the pressure at skin node {} is not a number", i);
    f.segment<3>(3 * s.skin.nodes[i]) = -pressure_pa[i] * state.skin_areas[i] * state.skin_normals[i];
  }
  const tissue::VectorXd u = s.linear_solve(f) - s.model.rest_positions();
  std::vector<double> un(n);
  for (size_t i = 0; i < n; ++i) un[i] = u.segment<3>(3 * s.skin.nodes[i]).dot(state.skin_normals[i]);
  return un;
}

void DesignSolver::applied_pressure(const std::vector<Spot>& spots, DesignState& st) const {
  const auto& s = *impl_;
  st.requested_pa = requested_pressure(spots);
  const size_t n = st.requested_pa.size();
  st.pressure_pa.resize(n);
  for (size_t i = 0; i < n; ++i) {
    st.pressure_pa[i] = std::min(st.requested_pa[i], s.thresholds[i]);
    const double r = st.requested_pa[i] / s.thresholds[i];
    if (r > st.max_requested_ratio) {
      st.max_requested_ratio = r;
      st.max_ratio_node = static_cast<int>(i);
    }
    st.max_applied_ratio = std::max(st.max_applied_ratio, st.pressure_pa[i] / s.thresholds[i]);
    if (r > 1.0) ++st.saturated_nodes;
  }
}

DesignState DesignSolver::solve(const std::vector<Spot>& spots) {
  auto& s = *impl_;
  const auto t0 = std::chrono::steady_clock::now();
  DesignState st;
  applied_pressure(spots, st);
  bool linear = s.options.mode == DesignSolveMode::Linear || s.fell_back;
  if (s.fell_back) {
    st.linearised = true;
    st.nonlinear_failure = s.fallback_reason;
  }
  tissue::VectorXd x = s.x;  // warm start: the last equilibrium and its geometry
  if (!linear) linear = !s.solve_nonlinear(st, x);
  if (linear) s.follow_linearised(*this, st, x);
  s.x = x;  // warm start of the next solve
  if (!linear) {  // a new nonlinear equilibrium: the previews' tangent is to be refactorised
    s.has_equilibrium = true;
    s.x_eq = x;
    s.p_eq = st.pressure_pa;
    s.kt.reset();
    s.kt_failed = false;
  }
  finish_state(st, x, t0);
  if (st.follower_capped)
    st.message += fmt::format(" (the follower iteration did not converge: the forces still changed by {:.2g} after "
                              "{} passes, tolerance {:.2g})",
                              st.follower_change, st.follower_passes, s.options.follower_tolerance);
  if (st.linearised && s.options.mode == DesignSolveMode::Auto)
    st.message += " (shape from the linearised stump model: the nonlinear tissue model lost stability under this field)";
  return st;
}

void DesignSolver::prepare_preview() { impl_->factor_tangent(); }

DesignState DesignSolver::preview(const std::vector<Spot>& spots) {
  auto& s = *impl_;
  const bool linear = s.options.mode == DesignSolveMode::Linear || s.fell_back;
  if (linear || !s.has_equilibrium) return solve(spots);
  s.factor_tangent();
  if (!s.kt) return solve(spots);
  const auto t0 = std::chrono::steady_clock::now();
  DesignState st;
  applied_pressure(spots, st);
  const size_t n = st.pressure_pa.size();
  std::vector<Vec3> pos, normal;
  std::vector<double> area;
  skin_geometry(s.x_eq, pos, normal, area);
  tissue::VectorXd df = tissue::VectorXd::Zero(s.model.num_dofs());
  for (size_t i = 0; i < n; ++i)
    df.segment<3>(3 * s.skin.nodes[i]) = -(st.pressure_pa[i] - s.p_eq[i]) * area[i] * normal[i];
  tissue::VectorXd x = s.x_eq;
  s.dofs.add_expanded(s.tangent_solve(s.dofs.restrict_vector(df)), x);
  require<SolverError>(x.allFinite(), "design preview: the tangent step is not finite (solve in full)");
  st.is_preview = true;
  st.follower_passes = 0;
  finish_state(st, x, t0);
  st.message += " (preview: the tangent at the last equilibrium; the full solve follows)";
  return st;
}

void DesignSolver::finish_state(DesignState& st, const tissue::VectorXd& x,
                                std::chrono::steady_clock::time_point t0) const {
  const auto& s = *impl_;
  const size_t n = s.skin.nodes.size();
  std::vector<Vec3> pos, normal;
  std::vector<double> area;
  skin_geometry(x, pos, normal, area);
  st.converged = true;
  st.positions = x;
  st.skin_positions = pos;
  st.skin_normals = normal;
  st.skin_areas = area;
  st.displacement_m.resize(n);
  const tissue::VectorXd& x0 = s.model.rest_positions();
  for (size_t i = 0; i < n; ++i) st.displacement_m[i] = (pos[i] - x0.segment<3>(3 * s.skin.nodes[i])).norm();
  for (Eigen::Index k = 0; k < x.size() / 3; ++k)
    st.max_displacement_m = std::max(st.max_displacement_m, (x - x0).segment<3>(3 * k).norm());
  const auto& m = s.model.masses();
  Vec3 c = Vec3::Zero();
  double mt = 0;
  for (Eigen::Index k = 0; k < m.size(); ++k) {
    c += m[k] * x.segment<3>(3 * k);
    mt += m[k];
  }
  st.centre_of_inertia = c / mt;
  st.radar = compute_radar(pos, normal, area, st.pressure_pa, s.frame, st.centre_of_inertia, s.patient.friction);
  st.status = check_constraints(st.radar, s.targets, st.max_requested_ratio);
  st.status.follower_converged = !st.follower_capped;
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  st.message = st.status.all_ok() ? "all constraints met" : "not met: " + st.status.failing();
}

}  // namespace socketsmith::design
