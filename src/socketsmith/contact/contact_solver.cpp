#include "socketsmith/contact/contact_solver.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "socketsmith/contact/contact_solver_impl.h"
#include "socketsmith/contact/contact_terms.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"

namespace socketsmith::contact {

std::vector<int> caught_nodes(const std::vector<double>& node_residual_n, const std::vector<double>& node_normal_force_n,
                              double rest_tol_n, int max_nodes) {
  require(node_residual_n.size() == node_normal_force_n.size(), "contact: {} node residuals for {} normal forces",
          node_residual_n.size(), node_normal_force_n.size());
  // The nodes by residual, largest first; the fewest of them (at most max_nodes) outside which the
  // residual is within rest_tol_n, each holding at most its own normal force.
  std::vector<int> order(node_residual_n.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  const size_t m_max = std::min(order.size(), static_cast<size_t>(std::max(max_nodes, 0)));
  std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(m_max), order.end(),
                    [&](int a, int b) { return node_residual_n[a] > node_residual_n[b]; });
  double rest2 = 0;
  for (const double q : node_residual_n) rest2 += q * q;
  for (size_t m = 0; m < m_max; ++m) {
    const auto i = static_cast<size_t>(order[m]);
    const double own = node_residual_n[i], force = node_normal_force_n[i];
    if (!(force > 0) || own > force + rest_tol_n) return {};
    rest2 -= own * own;
    if (std::sqrt(std::max(rest2, 0.0)) <= rest_tol_n) return {order.begin(), order.begin() + static_cast<std::ptrdiff_t>(m + 1)};
  }
  return {};
}

bool ContactSolver::Impl::caught(const VectorXd& r, double rs, const std::vector<NodeContact>& st,
                                 std::string& why) const {
  const double kink = kink_tolerance(st);
  if (rs >= kink) return false;  // the obstacle's own equilibrium is part of the rest
  const std::vector<double> res = node_residuals(r);
  std::vector<double> fn(res.size(), 0.0);
  for (size_t c = 0; c < nodes.size(); ++c)
    if (st[c].active)  // its contact forces, friction included (the lag's may exceed μ f_n)
      fn[static_cast<size_t>(nodes[c])] = st[c].normal_force_n + st[c].tangential_n.norm();
  const double tol = std::sqrt(kink * kink - rs * rs);
  const std::vector<int> held = caught_nodes(res, fn, tol, kMaxCaughtNodes);
  if (held.empty()) return false;
  std::string which;
  for (const int node : held)
    which += fmt::format("{}node {} ({:.3g} N of its {:.3g} N contact force unbalanced)", which.empty() ? "" : ", ", node,
                         res[static_cast<size_t>(node)], fn[static_cast<size_t>(node)]);
  why = fmt::format("{} caught on the socket's rim or a kink of its wall: {}, the rest within {:.3g} N",
                    held.size() == 1 ? "a node" : fmt::format("{} nodes", held.size()), which, tol);
  return true;
}

std::vector<double> ContactSolver::Impl::node_residuals(const VectorXd& r) const {
  const auto& ri = dofs.reduced_index();
  std::vector<double> res(ri.size() / 3, 0.0);
  for (size_t i = 0; i < res.size(); ++i) {
    double q = 0;
    for (int a = 0; a < 3; ++a)
      if (const auto d = ri[3 * i + a]; d >= 0) q += r[d] * r[d];
    res[i] = std::sqrt(q);
  }
  return res;
}

std::string ContactSolver::Impl::residual_holders(const VectorXd& xs, const VectorXd& r,
                                                  const std::vector<NodeContact>& st) const {
  const std::vector<double> res = node_residuals(r);
  std::vector<std::pair<double, size_t>> by;
  for (size_t c = 0; c < nodes.size(); ++c) by.emplace_back(res[static_cast<size_t>(nodes[c])], c);
  const size_t top = std::min<size_t>(3, by.size());
  std::partial_sort(by.begin(), by.begin() + static_cast<std::ptrdiff_t>(top), by.end(), std::greater<>());
  std::string out;
  for (size_t j = 0; j < top; ++j) {
    const size_t c = by[j].second;
    std::string touch;
    if (st[c].active) {
      touch = fmt::format("{:.0f} µm into the wall, f_n {:.3g} N", -st[c].gap_m * 1e6, st[c].normal_force_n);
    } else {  // where it is: short of the wall, or behind it where no face holds it (outside their cone)
      const Gap g = wall_gap(c, xs.segment<3>(3 * nodes[c]));
      touch = g.triangle < 0 ? std::string("not in contact, no wall near")
              : g.gap_m > 0  ? fmt::format("not in contact, {:.0f} µm from the wall", g.gap_m * 1e6)
                  : fmt::format("not in contact, {:.0f} µm behind the wall{}", -g.gap_m * 1e6,
                                g.valid ? "" : " where no face holds it");
    }
    out += fmt::format("{}node {} unbalanced by {:.3g} N ({}, friction {:.3g} N{}, lagged f_n {:.3g} N)", j ? "; " : "",
                       nodes[c], by[j].first, touch, st[c].tangential_n.norm(), st[c].sliding ? " sliding" : "",
                       lag_fn[c]);
  }
  return out;
}

std::string ContactSolver::Impl::model_breaker(const VectorXd& xs, const Vec3& t, const VectorXd& delta, double ds,
                                               double a, double scale_j) {
  VectorXd xa = xs;
  dofs.add_expanded(a * delta, xa);
  const Vec3 ta = t + a * ds * free_dir;
  struct Term {
    double energy = 0;
    Vec3 force = Vec3::Zero();
    Eigen::Matrix3d stiffness = Eigen::Matrix3d::Zero();
    double gap_m = 0;
  };
  // Every candidate's penalty and friction at (x, at), as evaluate() adds them.
  const auto terms = [&](const VectorXd& at_x, const Vec3& at) {
    obstacle.set_translation(at);
    std::vector<Term> out(nodes.size());
    for (size_t i = 0; i < nodes.size(); ++i) {
      const Vec3 p = at_x.segment<3>(3 * nodes[i]);
      const Gap g = wall_gap(i, p);
      const PenaltyTerm pen = penalty_term(g, k * areas[i], alm[i]);
      Term& tm = out[i];
      tm.gap_m = g.gap_m;
      tm.energy = pen.active ? pen.term.energy : 0.0;
      tm.force = pen.term.force;
      tm.stiffness = pen.term.stiffness;
      NodeContact st;
      Vec3 th;
      tm.energy += friction_term(i, p, at, st, th, tm.force, tm.stiffness);
    }
    return out;
  };
  const std::vector<Term> t0 = terms(xs, t), t1 = terms(xa, ta);
  obstacle.set_translation(t);
  double worst = 0;
  std::string out;
  for (size_t i = 0; i < nodes.size(); ++i) {
    if (t0[i].energy == 0 && t1[i].energy == 0) continue;
    const Vec3 d = xa.segment<3>(3 * nodes[i]) - xs.segment<3>(3 * nodes[i]) - (ta - t);  // relative to the wall
    const double err = (t1[i].energy - t0[i].energy) - (-t0[i].force.dot(d) + 0.5 * d.dot(t0[i].stiffness * d));
    if (std::abs(err) <= worst) continue;
    worst = std::abs(err);
    out = fmt::format("Newton's model broke most at node {}: its contact energy {:.3g} J off the model over a move of "
                      "{:.3g} µm, its gap {:.0f} → {:.0f} µm",
                      nodes[i], err, d.norm() * 1e6, t0[i].gap_m * 1e6, t1[i].gap_m * 1e6);
  }
  return worst > 0.01 * std::abs(scale_j) ? out : std::string();
}

double ContactSolver::Impl::free_residual(const std::vector<NodeContact>& st) const {
  if (!free_axis()) return 0.0;
  double on_nodes = 0;
  for (const auto& c : st) on_nodes += free_dir.dot(c.normal_force_n * c.normal + c.tangential_n);
  return free_force_n - on_nodes;
}

VectorXd ContactSolver::Impl::evaluate(const VectorXd& xs, const Vec3& t, std::vector<NodeContact>& st,
                                       std::vector<Vec3>& trial_hist, std::vector<Eigen::Matrix3d>* blocks,
                                       double* energy, const VectorXd* Ku, bool trial_point) {
  obstacle.set_translation(t);
  const bool conservative = opt.linear_body || model.has_energy();
  VectorXd f_full = VectorXd::Zero(xs.size());
  double pi = 0.0;
  if (!opt.linear_body) {
    // The body's forces and energy in one pass (the continuum models), the inversion check in it.
    if (!conservative) {
      if (trial_point && model.has_inverted_element(xs))
        return VectorXd::Constant(dofs.num_reduced(), std::numeric_limits<double>::quiet_NaN());
      f_full = model.elastic_forces(xs);
    } else if (!model.forces_and_energy(xs, f_full, pi)) {
      if (trial_point) return VectorXd::Constant(dofs.num_reduced(), std::numeric_limits<double>::quiet_NaN());
      // Not a trial point: the continuum models throw SolverError naming the inverted element;
      // the lattices are defined there and keep their forces and energy.
      f_full = model.elastic_forces(xs);
      pi = model.energy(xs);
    }
  }
  if (blocks) blocks->assign(nodes.size(), Eigen::Matrix3d::Zero());
  st.assign(nodes.size(), NodeContact{});
  trial_hist.assign(nodes.size(), Vec3::Zero());
  query_gaps(xs, t);
  for (size_t i = 0; i < nodes.size(); ++i) {
    const int nd = nodes[i];
    const Vec3 p = xs.segment<3>(3 * nd);
    const Gap& g = gaps[i];
    const PenaltyTerm pen = penalty_term(g, k * areas[i], alm[i]);
    Eigen::Matrix3d B = pen.term.stiffness;
    Vec3 f = pen.term.force;
    if (pen.active) {
      auto& s = st[i];
      s.active = true;
      s.gap_m = g.gap_m;
      s.normal = g.normal;
      s.normal_force_n = pen.normal_force_n;
      s.pressure_pa = s.normal_force_n / areas[i];
      pi += pen.term.energy;
    }
    pi += friction_term(i, p, t, st[i], trial_hist[i], f, B);
    if (f.squaredNorm() == 0.0 && B.isZero()) continue;
    f_full.segment<3>(3 * nd) += f;
    if (blocks) (*blocks)[i] = B;
  }
  VectorXd r = dofs.restrict_vector(f_full);
  if (opt.linear_body) {
    const VectorXd u = dofs.restrict_vector(xs - model.rest_positions());
    const VectorXd K0u = Ku ? *Ku : VectorXd(K0 * u);
    r -= K0u;
    pi += 0.5 * u.dot(K0u);
  }
  if (energy) *energy = conservative ? pi : std::numeric_limits<double>::quiet_NaN();
  return r;
}

void ContactSolver::Impl::query_gaps(const VectorXd& xs, const Vec3& t) {
  gaps.resize(nodes.size());
  const int n_nodes = static_cast<int>(nodes.size());
#pragma omp parallel for schedule(dynamic, 64)
  for (int i = 0; i < n_nodes; ++i) {
    const Vec3 p = xs.segment<3>(3 * nodes[i]);
    QueryCache& c = qcache[i];
    // (A node with a multiplier may press from a small gap: it is always queried.)
    if (alm[i] == 0 && c.clearance > 0 && c.clearance > (p - c.p).norm() + (t - c.t).norm()) {
      gaps[i] = Gap{};
      gaps[i].gap_m = c.clearance;  // a lower bound; the node is not in contact
      continue;
    }
    gaps[i] = wall_gap(i, p);
    c.p = p;
    c.t = t;
    // (The smoothed wall's gap is not an exact distance: its slope |∇gap| may exceed 1 a little.)
    // Only the facets' gap, a distance, bounds how far the node is from contact: the smoothed
    // wall's and the lip's (graded) are not distances and may switch between the wall's and the
    // lip's value where the lip's blend ends (a node cached at +0.6 mm was 57 µm deep a step
    // later, and Newton's reference potential had left its penalty out: seed 10's stalls).
    c.clearance = gaps[i].valid && !gaps[i].graded && gaps[i].gap_m > 0
                      ? gaps[i].gap_m / (1.5 * std::max(gaps[i].gradient_norm, 1.0))
                      : -1.0;
  }
}

double ContactSolver::Impl::friction_term(size_t i, const Vec3& p, const Vec3& t, NodeContact& s, Vec3& trial_hist,
                                          Vec3& f, Eigen::Matrix3d& B) const {
  FrictionInput in;
  in.stick_stiffness = opt.stick_stiffness_ratio * (k * areas[i]);
  in.limit_n = opt.friction * lag_fn[i];
  if (!(in.limit_n > 0)) return 0.0;
  in.lag_normal = lag_n[i];
  in.history_n = hist[i];
  in.displacement_m = (p - x_conv.segment<3>(3 * nodes[i])) - (t - t_conv);
  const FrictionTerm fr = contact::friction_term(in);
  s.sliding = fr.sliding;
  trial_hist = fr.spring_force_n;
  s.tangential_n = -trial_hist;
  f += fr.term.force;
  B += fr.term.stiffness;
  return fr.term.energy;
}

void ContactSolver::Impl::tangent(const VectorXd& xs, const std::vector<Eigen::Matrix3d>& blocks, SparseMatrix& K,
                                  bool psd_body) {
  if (opt.linear_body) {
    if (K.nonZeros() != K0c.nonZeros()) K = K0c;
    std::copy(K0c.valuePtr(), K0c.valuePtr() + K0c.nonZeros(), K.valuePtr());
    double* v = K.valuePtr();
    for (size_t i = 0; i < nodes.size(); ++i)
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
          if (block_at[9 * i + 3 * b + a] >= 0) v[block_at[9 * i + 3 * b + a]] += blocks[i](a, b);
    return;
  }
  // Nonlinear body: the body's tangent at xs plus every candidate node's block (explicit zeros
  // where it is not in contact), so the pattern stays the same from one Newton iteration to the
  // next and CHOLMOD analyses it once. `psd_body`: the body's tangent projected on its positive
  // part per element (when the exact one is not positive definite away from equilibrium).
  model.jacobian(xs, psd_body ? tissue::JacobianKind::SymmetricPsd : tissue::JacobianKind::Exact, J_body);
  dofs.reduce_matrix(J_body, K);  // the same pattern every time: DofMap maps the values
  double* v = K.valuePtr();
  for (Eigen::Index q = 0; q < K.nonZeros(); ++q) v[q] = -v[q];
  // Every candidate node's own 3×3 block lies in the body's pattern (the node is in an element).
  if (body_block_at.empty()) body_block_at = block_positions(K);
  add_node_blocks(blocks, K);
}

void ContactSolver::Impl::add_node_blocks(const std::vector<Eigen::Matrix3d>& blocks, SparseMatrix& K) const {
  double* v = K.valuePtr();
  for (size_t i = 0; i < nodes.size(); ++i)
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        if (body_block_at[9 * i + 3 * b + a] >= 0) v[body_block_at[9 * i + 3 * b + a]] += blocks[i](a, b);
}

std::vector<Eigen::Index> ContactSolver::Impl::block_positions(const SparseMatrix& K) const {
  const auto& ri = dofs.reduced_index();
  std::vector<Eigen::Index> at(9 * nodes.size(), -1);
  for (size_t i = 0; i < nodes.size(); ++i)
    for (int b = 0; b < 3; ++b) {
      const int col = ri[3 * nodes[i] + b];
      if (col < 0) continue;
      for (Eigen::Index q = K.outerIndexPtr()[col]; q < K.outerIndexPtr()[col + 1]; ++q)
        for (int a = 0; a < 3; ++a)
          if (ri[3 * nodes[i] + a] >= 0 && K.innerIndexPtr()[q] == ri[3 * nodes[i] + a]) at[9 * i + 3 * b + a] = q;
    }
  return at;
}

Gap ContactSolver::Impl::wall_gap(size_t i, const Vec3& p) const {
  Gap g = obstacle.gap(p);
  if (!g.valid && !g.graded && was_active[i] && g.gap_m < 0) {
    const Vec3 dd = p - g.point;
    g.valid = (dd - g.gap_m * g.normal).norm() <= 2.0 * std::abs(g.gap_m) + 1e-4;
  }
  return g;
}

bool ContactSolver::Impl::pcg(const SparseMatrix& K, const VectorXd& b, VectorXd& d) {
  const SerialParallelRegions serial;
  const double bn = b.norm();
  d = llt.solve(b);
  VectorXd res = b - K * d;
  if (res.norm() <= 1e-8 * bn) return true;
  VectorXd z = llt.solve(res);
  VectorXd p = z;
  double rz = res.dot(z);
  for (int it = 0; it < opt.max_reuse_cg; ++it) {
    ++cg_iterations;
    const VectorXd Kp = K * p;
    const double pKp = p.dot(Kp);
    if (!(pKp > 0)) return false;
    const double alpha = rz / pKp;
    d += alpha * p;
    res -= alpha * Kp;
    if (res.norm() <= 1e-8 * bn) return true;
    z = llt.solve(res);
    const double rz_new = res.dot(z);
    p = z + (rz_new / rz) * p;
    rz = rz_new;
  }
  return false;
}

double ContactSolver::Impl::force_sum(const std::vector<NodeContact>& st) {
  double fsum = 0;
  for (const auto& s : st) fsum += s.normal_force_n + s.tangential_n.norm();
  return fsum;
}

int ContactSolver::Impl::count_new_sticks(const std::vector<NodeContact>& st) const {
  int n = 0;
  for (size_t i = 0; i < st.size(); ++i)
    if (st[i].active && !st[i].sliding && st[i].tangential_n.squaredNorm() > 0 &&
        (!conv_state[i].active || conv_state[i].sliding))
      ++n;
  return n;
}

double ContactSolver::Impl::lag_change(const std::vector<NodeContact>& st) const {
  double change = 0, fmax = 0;
  for (size_t i = 0; i < st.size(); ++i) {
    change = std::max(change, std::abs(st[i].normal_force_n - lag_fn[i]));
    fmax = std::max(fmax, st[i].normal_force_n);
  }
  return fmax > 0 ? change / fmax : (change > 0 ? 1.0 : 0.0);
}

double ContactSolver::Impl::augmentation_change(const std::vector<NodeContact>& st) const {
  double change = 0, fmax = 0;
  for (size_t i = 0; i < st.size(); ++i) {
    if (st[i].active) change = std::max(change, k * areas[i] * std::abs(st[i].gap_m));
    else if (alm[i] > 0) change = std::max(change, alm[i]);  // a multiplier left on a node that let go
    fmax = std::max(fmax, st[i].normal_force_n);
  }
  return fmax > 0 ? change / fmax : (change > 0 ? 1.0 : 0.0);
}

void ContactSolver::Impl::update_augmentation(const std::vector<NodeContact>& st) {
  for (size_t i = 0; i < st.size(); ++i)
    alm[i] = st[i].active ? std::max(0.0, alm[i] - k * areas[i] * st[i].gap_m) : 0.0;
}

void ContactSolver::Impl::update_lag(const std::vector<NodeContact>& st) {
  const double change = lag_change(st);
  const double w = last_lag_change > 0 && change > 0.8 * last_lag_change ? 0.5 : 1.0;
  last_lag_change = change;
  for (size_t i = 0; i < st.size(); ++i) {
    lag_fn[i] += w * (st[i].normal_force_n - lag_fn[i]);
    if (st[i].active) lag_n[i] = st[i].normal;
  }
}

VectorXd ContactSolver::Impl::free_border(const std::vector<Eigen::Matrix3d>& B, double& h) const {
  VectorXd full = VectorXd::Zero(x.size());
  h = 0;
  for (size_t i = 0; i < nodes.size(); ++i) {
    full.segment<3>(3 * nodes[i]) -= B[i] * free_dir;
    h += free_dir.dot(B[i] * free_dir);
  }
  return dofs.restrict_vector(full);
}

bool ContactSolver::Impl::eliminate_free(const Eigen::MatrixXd& rhs, const Eigen::MatrixXd& sol, double h, double rs,
                                         VectorXd& delta, double& ds) {
  const double schur = h - rhs.col(1).dot(sol.col(1));
  if (!(schur > 1e-9 * h)) return false;
  ds = (rs - rhs.col(1).dot(sol.col(0))) / schur;
  const double scale = std::abs(ds) > kMaxFreeStep ? kMaxFreeStep / std::abs(ds) : 1.0;
  delta = scale * (sol.col(0) - ds * sol.col(1));
  ds *= scale;
  return delta.allFinite();
}

namespace {
/// The candidates' mean node spacing h: the mean √ of their nodal areas [m].
double mean_node_spacing_m(const std::vector<double>& areas) {
  double spacing = 0;
  for (double a : areas) {
    require(std::isfinite(a) && a > 0, "contact: a nodal area is not positive ({} m^2)", a);
    spacing += std::sqrt(a) / static_cast<double>(areas.size());
  }
  return spacing;
}
}  // namespace

ContactSolver::ContactSolver(const tissue::MassSpringModel& model, const tissue::DofMap& dofs, std::vector<int> nodes,
                             std::vector<double> areas, Obstacle& obstacle, const ContactOptions& options) {
  require(nodes.size() == areas.size() && !nodes.empty(), "contact: {} candidate nodes for {} areas", nodes.size(),
          areas.size());
  require(std::isfinite(options.friction) && options.friction >= 0, "contact: friction {} must be ≥ 0",
          options.friction);
  require(std::isfinite(options.penalty_factor) && options.penalty_factor > 0 && options.penalty_pa_per_m >= 0,
          "contact: penalty factor {} must be positive", options.penalty_factor);
  require(std::isfinite(options.stick_stiffness_ratio) && options.stick_stiffness_ratio > 0,
          "contact: stick stiffness ratio {} must be positive", options.stick_stiffness_ratio);
  require(std::isfinite(options.augmented_tol) && options.augmented_tol >= 0,
          "contact: augmented Lagrangian tolerance {} must be ≥ 0 (0: the penalty alone)", options.augmented_tol);
  require(std::isfinite(options.chord_ratio) && options.chord_ratio >= 0 && options.chord_ratio < 1,
          "contact: chord ratio {} must be in [0, 1) (0: a fresh tangent every Newton step)", options.chord_ratio);
  require(std::isfinite(options.predict_contact_m) && options.predict_contact_m >= 0 && options.predict_low_rank_max >= 0,
          "contact: predicted contacts' depth {} m and low-rank columns {} must be ≥ 0 (0: no prediction)",
          options.predict_contact_m, options.predict_low_rank_max);
  require(std::isfinite(options.residual_floor_ratio) && options.residual_floor_ratio >= 1,
          "contact: residual floor ratio {} must be ≥ 1 (the floor in E h²)", options.residual_floor_ratio);
  impl_ = std::make_unique<Impl>(model, dofs, std::move(nodes), std::move(areas), obstacle, options);
  auto& s = *impl_;
  const double spacing = mean_node_spacing_m(s.areas);
  s.k = contact_penalty_pa_per_m(options, model.material().youngs_modulus_pa, s.areas);
  s.x = s.x_conv = model.rest_positions();
  s.t_conv = obstacle.translation();
  s.hist.assign(s.nodes.size(), Vec3::Zero());
  s.was_active.assign(s.nodes.size(), 0);
  s.conv_fn.assign(s.nodes.size(), 0.0);
  s.alm.assign(s.nodes.size(), 0.0);
  s.conv_alm = s.alm;
  s.conv_n.assign(s.nodes.size(), Vec3::Zero());
  // Residual floor: the force that strains one element of the skin by one (E h²), times
  // ContactOptions::residual_floor_ratio — rel_tol of it is still far below anything a pressure
  // map shows (1e-4 · 30 E h² is 0.3 % of E on one node's area).
  s.tail_floor = model.material().youngs_modulus_pa * spacing * spacing;
  s.force_floor = options.residual_floor_ratio * s.tail_floor;
  s.state.assign(s.nodes.size(), NodeContact{});
  s.conv_state = s.state;
  s.qcache.assign(s.nodes.size(), Impl::QueryCache{});
  // One query before any parallel one (CGAL builds its distance-query structures lazily).
  (void)obstacle.gap(model.rest_positions().segment<3>(3 * s.nodes.front()));
  if (options.linear_body) {
    SparseMatrix J;
    model.jacobian(model.rest_positions(), tissue::JacobianKind::Exact, J);
    dofs.reduce_matrix(J, s.K0);
    s.K0 *= -1.0;
    s.K0 = 0.5 * (SparseMatrix(s.K0.transpose()) + s.K0);
    s.K0.makeCompressed();
    // The tangent's fixed pattern: K₀ plus every candidate node's 3×3 block.
    const auto& ri = dofs.reduced_index();
    std::vector<Eigen::Triplet<double>> trip;
    for (const int nd : s.nodes)
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
          if (ri[3 * nd + a] >= 0 && ri[3 * nd + b] >= 0) trip.emplace_back(ri[3 * nd + a], ri[3 * nd + b], 0.0);
    SparseMatrix Z(s.K0.rows(), s.K0.cols());
    Z.setFromTriplets(trip.begin(), trip.end());
    s.K0c = s.K0 + Z;
    s.K0c.makeCompressed();
    s.block_at = s.block_positions(s.K0c);
  }
}

ContactSolver::~ContactSolver() = default;

ContactStep ContactSolver::move_to(const Vec3& translation) { return impl_->solve_path(translation, true); }
ContactStep ContactSolver::try_move_to(const Vec3& translation, bool stop_on_new_stick) {
  impl_->stop_on_new_stick = stop_on_new_stick;
  ContactStep st = impl_->solve_path(translation, false);
  impl_->stop_on_new_stick = false;
  return st;
}
void ContactSolver::commit() { impl_->commit_last(); }
void ContactSolver::discard() {
  auto& s = *impl_;
  s.x = s.x_conv;
  s.state = s.conv_state;
  s.last_t = s.t_conv;
  s.last_hist = s.hist;
  s.alm = s.conv_alm;
  s.obstacle.set_translation(s.t_conv);
}

void ContactSolver::limit_newton(long iterations) {
  require(iterations >= 0, "contact: a Newton limit of {} iterations (expected ≥ 0; 0: no limit)", iterations);
  impl_->newton_limit = iterations > 0 ? impl_->newton_spent + iterations : 0;
}

long ContactSolver::newton_iterations_spent() const { return impl_->newton_spent; }

void ContactSolver::obstacle_changed() {
  auto& s = *impl_;
  s.qcache.assign(s.nodes.size(), Impl::QueryCache{});
  // One query before any parallel one (CGAL builds its distance-query structures lazily).
  (void)s.obstacle.gap(s.x.segment<3>(3 * s.nodes.front()));
}

bool ContactSolver::predict_wall_change() {
  auto& s = *impl_;
  if (!s.llt.valid() || s.conv_state.size() != s.nodes.size()) return false;
  const auto& ri = s.dofs.reduced_index();
  VectorXd f = VectorXd::Zero(s.dofs.num_reduced());
  int moved = 0;
  for (size_t i = 0; i < s.nodes.size(); ++i) {
    const NodeContact& c = s.conv_state[i];
    if (!c.active) continue;
    const Gap g = s.wall_gap(i, s.x_conv.segment<3>(3 * s.nodes[i]));
    if (!g.valid) continue;
    const Vec3 df = -s.k * s.areas[i] * (g.gap_m - c.gap_m) * c.normal;  // the contact force's change
    for (int a = 0; a < 3; ++a)
      if (const int r = ri[3 * s.nodes[i] + a]; r >= 0) f[r] += df[a];
    ++moved;
  }
  if (moved == 0) return false;
  VectorXd guess = s.x_conv;
  s.dofs.add_expanded(s.llt.solve(f), guess);
  const bool taken = s.warm_start(guess, s.obstacle.translation());
  log::debug("contact: the new wall's predicted start {} ({} nodes followed it)", taken ? "taken" : "not taken", moved);
  return taken;
}

const VectorXd& ContactSolver::positions() const { return impl_->x; }
const std::vector<NodeContact>& ContactSolver::contacts() const { return impl_->state; }
const std::vector<int>& ContactSolver::nodes() const { return impl_->nodes; }
double ContactSolver::penalty() const { return impl_->k; }

double contact_penalty_pa_per_m(const ContactOptions& options, double youngs_pa, const std::vector<double>& areas) {
  return options.penalty_pa_per_m > 0 ? options.penalty_pa_per_m
                                      : options.penalty_factor * youngs_pa / mean_node_spacing_m(areas);
}

}  // namespace socketsmith::contact
