// The optimiser's amplitude problem and its SLSQP fit (amplitude_fit.h says what and why).
#include "socketsmith/design/amplitude_fit.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <nlopt.hpp>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"

namespace socketsmith::design::optimizer_detail {
namespace {

constexpr int kMaxFitEvaluations = 400;

/// Per region, summed over the skin below the brim: F_z per unit amplitude (shares) and Σ A p per
/// unit amplitude (ratios), with the fixed spots' parts in the last column; the ratios' areas.
struct RegionSums {
  Eigen::MatrixXd share_fz, bear_ap, relief_ap;
  Eigen::VectorXd bear_area, relief_area;

  RegionSums(size_t shares, size_t ratios, size_t free)
      : share_fz(Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(shares), static_cast<Eigen::Index>(free) + 1)),
        bear_ap(Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(ratios), static_cast<Eigen::Index>(free) + 1)),
        relief_ap(bear_ap),
        bear_area(Eigen::VectorXd::Zero(static_cast<Eigen::Index>(ratios))),
        relief_area(Eigen::VectorXd::Zero(static_cast<Eigen::Index>(ratios))) {}
};

/// Visits every skin node below the brim: the radar R, r_fixed and the region sums gain its part;
/// a node some spot reaches joins P.nodes with its row of φ / T (and the fixed spots' p / T) in
/// @p rows and @p fixed; the others count in P.area_unloaded.
void add_node_rows(AmplitudeProblem& P, const std::vector<Spot>& spots, RegionSums& sums, std::vector<double>& rows,
                   std::vector<double>& fixed) {
  const auto& cyl = P.solver->skin_cylindrical();
  const auto& above = P.solver->above_brim();
  const auto& weight = P.solver->brim_weight();  // the flare: the field eases in below the brim
  const auto& thr = P.solver->thresholds();
  const auto& fr = P.solver->frame();
  const double mu = P.solver->patient().friction;
  const auto& free = P.free;
  const auto& area = P.area;
  const auto& shares = P.options->region_shares;
  const auto& ratios = P.options->pressure_ratios;
  const size_t nf = free.size();
  const Eigen::Index nsh = static_cast<Eigen::Index>(shares.size()), nra = static_cast<Eigen::Index>(ratios.size());
  std::vector<double> row(nf);
  const auto add = [&](Eigen::MatrixXd& m, Eigen::Index r, double g, double pf) {
    for (size_t j = 0; j < nf; ++j) m(r, static_cast<Eigen::Index>(j)) += g * row[j];
    m(r, static_cast<Eigen::Index>(nf)) += g * pf;
  };
  for (size_t i = 0; i < cyl.size(); ++i) {
    if (above[i]) continue;
    double pf = 0;
    bool any = false;
    for (size_t j = 0; j < nf; ++j) {
      row[j] = weight[i] * spot_shape(spots[free[j]], cyl[i].theta, cyl[i].h);
      any = any || row[j] > 0;
    }
    for (size_t k = 0; k < spots.size(); ++k)
      if (spots[k].enabled && !spots[k].optimise_amplitude)
        pf += weight[i] * spot_pressure(spots[k], cyl[i].theta, cyl[i].h);
    // A ratio's means count every node of its regions, loaded or not.
    for (Eigen::Index r = 0; r < nra; ++r) {
      const auto& ra = ratios[static_cast<std::size_t>(r)];
      if (ra.bearing[i]) {
        sums.bear_area[r] += area[i];
        add(sums.bear_ap, r, area[i], pf);
      }
      if (ra.relieved[i]) {
        sums.relief_area[r] += area[i];
        add(sums.relief_ap, r, area[i], pf);
      }
    }
    if (!any && pf == 0) {
      P.area_unloaded += area[i];
      continue;
    }
    const auto g = P.unit_radar(i, fr, mu);
    for (size_t j = 0; j < nf; ++j) P.R.col(static_cast<Eigen::Index>(j)) += g * row[j];
    P.r_fixed += g * pf;
    for (Eigen::Index r = 0; r < nsh; ++r)
      if (shares[static_cast<std::size_t>(r)].nodes[i]) add(sums.share_fz, r, g[2], pf);
    P.nodes.push_back(static_cast<int>(i));
    const double te = P.cap.empty() ? thr[i] : std::min(thr[i], P.cap[i]);
    for (size_t j = 0; j < nf; ++j) rows.push_back(row[j] / te);
    fixed.push_back(pf / te);
  }
}

/// What the objective evens: φ / T (by ratio; not φ / cap) or φ / kRef, from φ / min(T, cap).
void weigh_objective_rows(AmplitudeProblem& P) {
  const auto& thr = P.solver->thresholds();
  const auto& nodes = P.nodes;
  const auto& cap = P.cap;
  P.phi_obj = P.phi;
  P.fixed_obj = P.fixed_ratio;
  for (size_t n = 0; n < nodes.size(); ++n) {
    const double te = cap.empty() ? thr[nodes[n]] : std::min(thr[nodes[n]], cap[nodes[n]]);
    const double s = P.by_ratio ? te / thr[nodes[n]] : te / kRef;  // J evens p / T, or p / kRef
    P.phi_obj.row(static_cast<Eigen::Index>(n)) *= s;
    P.fixed_obj[static_cast<Eigen::Index>(n)] *= s;
  }
}

/// The template's region rows G a + g0 ≤ 0: a floor −(F_region − min F_z) / F_z, a ceiling
/// (F_region − max F_z) / F_z, a ratio (k · mean_relieved − mean_bearing) / kRef; a region without
/// nodes below the brim gives none.
void build_region_rows(AmplitudeProblem& P, const RegionSums& sums, double fz_n) {
  const auto& shares = P.options->region_shares;
  const auto& ratios = P.options->pressure_ratios;
  const Eigen::Index nf = static_cast<Eigen::Index>(P.free.size());
  std::vector<Eigen::VectorXd> rows_g;  // |free| + 1 (the constant last)
  for (Eigen::Index r = 0; r < static_cast<Eigen::Index>(shares.size()); ++r) {
    const auto& sh = shares[static_cast<std::size_t>(r)];
    Eigen::VectorXd fz = sums.share_fz.row(r).transpose() / fz_n;
    if (sh.min_share > 0) {
      Eigen::VectorXd v = -fz;
      v[nf] += sh.min_share;
      rows_g.push_back(v);
    }
    if (sh.max_share < 1) {
      Eigen::VectorXd v = fz;
      v[nf] -= sh.max_share;
      rows_g.push_back(v);
    }
  }
  for (Eigen::Index r = 0; r < static_cast<Eigen::Index>(ratios.size()); ++r) {
    if (sums.bear_area[r] <= 0 || sums.relief_area[r] <= 0) continue;
    const double k = ratios[static_cast<std::size_t>(r)].min_ratio;
    rows_g.push_back(
        (k * sums.relief_ap.row(r) / sums.relief_area[r] - sums.bear_ap.row(r) / sums.bear_area[r]).transpose() / kRef);
  }
  P.G.resize(static_cast<Eigen::Index>(rows_g.size()), nf);
  P.g0.resize(static_cast<Eigen::Index>(rows_g.size()));
  for (size_t r = 0; r < rows_g.size(); ++r) {
    P.G.row(static_cast<Eigen::Index>(r)) = rows_g[r].head(nf).transpose();
    P.g0[static_cast<Eigen::Index>(r)] = rows_g[r][nf];
  }
}

/// The SLSQP variables' upper bounds: a_max, or a spot's own bound when lower (z = a / kRef).
std::vector<double> upper_bounds(const AmplitudeProblem& P, const std::vector<Spot>& spots) {
  const unsigned n = static_cast<unsigned>(P.free.size());
  std::vector<double> upper(n, P.a_max / kRef);
  for (unsigned j = 0; j < n; ++j)
    if (spots[P.free[j]].max_amplitude_pa > 0) upper[j] = std::min(upper[j], spots[P.free[j]].max_amplitude_pa / kRef);
  return upper;
}

/// What NLopt's callbacks see of a fit.
struct FitContext {
  AmplitudeProblem* P;
  FitControl* control;
  nlopt::opt* opt;
  bool least_squares;
  int first_evaluation;
};

/// The fit's objective (reporting progress, stopping when told) and its constraints.
void set_up_slsqp(nlopt::opt& opt, FitContext& eq) {
  const AmplitudeProblem& P = *eq.P;
  opt.set_min_objective(
      [](unsigned, const double* z, double* g, void* data) {
        auto& e = *static_cast<FitContext*>(data);
        const int k = e.P->evaluations - e.first_evaluation;
        if (!e.control->report(static_cast<double>(k) / kMaxFitEvaluations,
                               fmt::format("amplitude fit, {} evaluations", k)))
          e.opt->force_stop();
        return e.least_squares ? e.P->balance(z, g) : e.P->objective(z, g);
      },
      &eq);
  // Six equalities: the radar's forces and torques at their targets (normalised).
  if (!eq.least_squares)
    opt.add_equality_mconstraint(
      [](unsigned m, double* result, unsigned nn, const double* z, double* grad, void* data) {
        const auto& Q = *static_cast<FitContext*>(data)->P;
        const Eigen::VectorXd a = Q.amplitudes(z);
        const auto rv = Q.radar(a);
        for (unsigned k = 0; k < m; ++k) {
          result[k] = (rv[k] - Q.target[k]) / Q.scale[k];
          if (grad)
            for (unsigned j = 0; j < nn; ++j) grad[k * nn + j] = Q.R(k, j) * kRef / Q.scale[k];
        }
      },
      &eq, std::vector<double>(6, 1e-7));
  // Stability (available friction ≥ prosthesis weight, 2 % margin) and comfort at every node.
  opt.add_inequality_mconstraint(
      [](unsigned m, double* result, unsigned nn, const double* z, double* grad, void* data) {
        const auto& Q = *static_cast<FitContext*>(data)->P;
        const Eigen::VectorXd a = Q.amplitudes(z);
        const auto rv = Q.radar(a);
        result[0] = (1.02 * Q.stability_min - rv[6]) / Q.scale[6];
        if (grad)
          for (unsigned j = 0; j < nn; ++j) grad[j] = -Q.R(6, j) * kRef / Q.scale[6];
        const Eigen::VectorXd r = Q.phi * a + Q.fixed_ratio;
        for (unsigned i = 1; i < m; ++i) {
          result[i] = r[i - 1] - 1.0;
          if (grad)
            for (unsigned j = 0; j < nn; ++j) grad[i * nn + j] = Q.phi(i - 1, j) * kRef;
        }
      },
      &eq, std::vector<double>(1 + P.nodes.size(), 1e-9));
  if (P.use_regions && P.G.rows() > 0)
    opt.add_inequality_mconstraint(
        [](unsigned m, double* result, unsigned nn, const double* z, double* grad, void* data) {
          const auto& Q = *static_cast<FitContext*>(data)->P;
          const Eigen::VectorXd g = Q.region_excess(Q.amplitudes(z));
          for (unsigned f = 0; f < m; ++f) {
            result[f] = g[f];
            if (grad)
              for (unsigned j = 0; j < nn; ++j) grad[f * nn + j] = Q.G(f, j) * kRef;
          }
        },
        &eq, std::vector<double>(static_cast<std::size_t>(P.G.rows()), 1e-9));
  opt.set_xtol_rel(1e-8);
  opt.set_ftol_rel(1e-10);
  opt.set_maxeval(kMaxFitEvaluations);
}

}  // namespace

Eigen::Matrix<double, 7, 1> AmplitudeProblem::unit_radar(size_t i, const geometry::LimbFrame& fr, double mu) const {
  const Vec3 f = -area[i] * normal[i];
  const Vec3 t = (pos[i] - centre).cross(f);
  const double s = axial_friction_n(1.0, area[i], normal[i], fr.axis, mu);
  Eigen::Matrix<double, 7, 1> g;
  g << f.dot(fr.anterior), f.dot(fr.medial()), f.dot(fr.axis) + s, t.dot(fr.anterior), t.dot(fr.medial()),
      t.dot(fr.axis), s;
  return g;
}

void AmplitudeProblem::build(const std::vector<Spot>& spots) {
  free.clear();
  for (size_t k = 0; k < spots.size(); ++k)
    if (spots[k].enabled && spots[k].optimise_amplitude) free.push_back(static_cast<int>(k));
  nodes.clear();
  area_unloaded = 0;
  std::vector<double> rows;  // flattened φ
  std::vector<double> fixed;
  const size_t nf = free.size();
  R.setZero(7, static_cast<Eigen::Index>(nf));
  r_fixed.setZero();
  RegionSums sums(options->region_shares.size(), options->pressure_ratios.size(), nf);
  add_node_rows(*this, spots, sums, rows, fixed);
  phi = Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      rows.data(), static_cast<Eigen::Index>(nodes.size()), static_cast<Eigen::Index>(nf));
  fixed_ratio = Eigen::Map<Eigen::VectorXd>(fixed.data(), static_cast<Eigen::Index>(fixed.size()));
  weigh_objective_rows(*this);
  w.resize(static_cast<Eigen::Index>(nodes.size()));
  for (size_t n = 0; n < nodes.size(); ++n) w[static_cast<Eigen::Index>(n)] = area[nodes[n]];
  const auto& t = solver->targets();
  const double fs = t.fz_n, ts = t.fz_n * solver->stump_length_m();
  scale << fs, fs, fs, ts, ts, ts, fs;
  target << 0, 0, t.fz_n, 0, 0, 0;
  tolerance << t.force_tol_n, t.force_tol_n, t.force_tol_n, t.torque_tol_nm, t.torque_tol_nm, t.torque_tol_nm;
  stability_min = t.stability_min_n;
  build_region_rows(*this, sums, t.fz_n);
}

double AmplitudeProblem::balance(const double* z, double* grad) {
  ++evaluations;
  const Eigen::VectorXd a = amplitudes(z);
  const auto rv = radar(a);
  double f = 0;
  Eigen::Matrix<double, 6, 1> e;
  for (int k = 0; k < 6; ++k) {
    e[k] = (rv[k] - target[k]) / tolerance[k];
    f += 0.5 * e[k] * e[k];
  }
  if (grad)
    for (Eigen::Index j = 0; j < a.size(); ++j) {
      double g = 0;
      for (int k = 0; k < 6; ++k) g += e[k] * R(k, j) / tolerance[k];
      grad[j] = g * kRef;
    }
  return std::isfinite(f) ? f : 1e30;
}

Eigen::VectorXd AmplitudeProblem::amplitudes(const double* z) const {
  Eigen::VectorXd a(static_cast<Eigen::Index>(free.size()));
  for (Eigen::Index j = 0; j < a.size(); ++j) a[j] = kRef * z[j];
  return a;
}

double AmplitudeProblem::objective(const double* z, double* grad) {
  ++evaluations;
  const Eigen::VectorXd a = amplitudes(z);
  const Eigen::VectorXd r = phi_obj * a + fixed_obj;
  if (uniform) return squared_cv(r, a.size(), grad);
  const double W = w.sum();
  // Scaled by the largest ratio so that neither r^q nor J^(1−q) over- or underflows:
  // J = r_max (Σ w u^q / W)^(1/q), ∂J/∂a = (J / r_max)^(1−q) Σ w u^(q−1) φ / W, u = r / r_max.
  double rmax = 0;
  for (Eigen::Index i = 0; i < r.size(); ++i) rmax = std::max(rmax, r[i]);
  if (!std::isfinite(rmax)) {
    if (grad)
      for (Eigen::Index j = 0; j < a.size(); ++j) grad[j] = 0.0;
    return 1e10;
  }
  if (rmax <= 0) {  // no pressure at all: J = 0; a direction that raises it
    if (grad) {
      const Eigen::VectorXd g = phi_obj.transpose() * w / W;
      for (Eigen::Index j = 0; j < g.size(); ++j) grad[j] = g[j] * kRef;
    }
    return 0.0;
  }
  Eigen::VectorXd uq1(r.size());
  double sum = 0;
  for (Eigen::Index i = 0; i < r.size(); ++i) {
    const double u = std::max(r[i], 0.0) / rmax;
    uq1[i] = std::pow(u, q - 1);
    sum += w[i] * uq1[i] * u;
  }
  const double rel = std::pow(sum / W, 1.0 / q);  // J / r_max, in (0, 1]
  const double J = rmax * rel;
  if (grad) {
    const Eigen::VectorXd g = phi_obj.transpose() * (w.cwiseProduct(uq1));
    const double c = std::pow(rel, 1.0 - q) / W;
    for (Eigen::Index j = 0; j < g.size(); ++j) grad[j] = c * g[j] * kRef;
  }
  return J;
}

double AmplitudeProblem::squared_cv(const Eigen::VectorXd& r, Eigen::Index n, double* grad) const {
  const double W = w.sum() + area_unloaded;
  const Eigen::VectorXd wr = w.cwiseProduct(r);
  const double s1 = wr.sum(), s2 = wr.dot(r);
  if (!(s1 > 0) || !std::isfinite(s2)) {  // no pressure: a direction that raises it
    if (grad) {
      const Eigen::VectorXd g = -phi_obj.transpose() * w / W;
      for (Eigen::Index j = 0; j < n; ++j) grad[j] = g[j] * kRef;
    }
    return 1e3;
  }
  if (grad) {
    // ∂/∂r_i = 2 W w_i r_i / s1² − 2 W s2 w_i / s1³
    const Eigen::VectorXd d = (2 * W / (s1 * s1)) * wr - (2 * W * s2 / (s1 * s1 * s1)) * w;
    const Eigen::VectorXd g = phi_obj.transpose() * d;
    for (Eigen::Index j = 0; j < n; ++j) grad[j] = g[j] * kRef;
  }
  return W * s2 / (s1 * s1) - 1.0;
}

double AmplitudeProblem::violation(const double* z, const RadarTargets& t) const {
  const Eigen::VectorXd a = amplitudes(z);
  if (!a.allFinite()) return std::numeric_limits<double>::infinity();
  const auto rv = radar(a);
  double v = 0;
  for (int k = 0; k < 3; ++k) v = std::max(v, std::abs(rv[k] - target[k]) / t.force_tol_n - 1.0);
  for (int k = 3; k < 6; ++k) v = std::max(v, std::abs(rv[k]) / t.torque_tol_nm - 1.0);
  v = std::max(v, (t.stability_min_n - rv[6]) / t.force_tol_n);
  const Eigen::VectorXd r = phi * a + fixed_ratio;
  if (r.size() > 0) v = std::max(v, 100.0 * (r.maxCoeff() - 1.0));
  if (use_regions && G.rows() > 0) v = std::max(v, 100.0 * region_excess(a).maxCoeff());
  return std::max(v, 0.0);
}

FitResult fit_amplitudes(AmplitudeProblem& P, const std::vector<Spot>& spots, const RadarTargets& t,
                         FitControl& control) {
  const unsigned n = static_cast<unsigned>(P.free.size());
  FitResult fr;
  fr.z.resize(n);
  for (unsigned j = 0; j < n; ++j) fr.z[j] = std::clamp(spots[P.free[j]].amplitude_pa / kRef, 0.0, P.a_max / kRef);
  if (n == 0) {
    fr.violation = P.violation(fr.z.data(), t);
    fr.ok = fr.violation == 0;
    return fr;
  }
  nlopt::opt opt(nlopt::LD_SLSQP, n);
  opt.set_lower_bounds(std::vector<double>(n, 0.0));
  const std::vector<double> upper = upper_bounds(P, spots);
  for (unsigned j = 0; j < n; ++j) fr.z[j] = std::min(fr.z[j], upper[j]);
  opt.set_upper_bounds(upper);
  // Fewer free amplitudes than the six equalities (3 forces, 3 torques): no exact solution in
  // general, and NLopt refuses the problem — fit them in the least-squares sense instead (the
  // violation then says whether the tolerances hold).
  const bool least_squares = n < 6;
  FitContext eq{&P, &control, &opt, least_squares, P.evaluations};
  set_up_slsqp(opt, eq);
  std::vector<double> z(fr.z.data(), fr.z.data() + n);
  double J = 0;
  const int before = P.evaluations;
  try {
    opt.optimize(z, J);
  } catch (const std::exception& e) {
    log::debug("optimise_design: SLSQP stopped: {}", e.what());
  }
  bool finite = true;
  for (unsigned j = 0; j < n; ++j) finite = finite && std::isfinite(z[j]);
  if (finite)
    for (unsigned j = 0; j < n; ++j) fr.z[j] = std::clamp(z[j], 0.0, upper[j]);
  // else: keep the starting amplitudes (SLSQP broke down); the violation says how far they are.
  fr.J = P.objective(fr.z.data(), nullptr);
  fr.violation = P.violation(fr.z.data(), t);
  fr.evaluations = P.evaluations - before;
  fr.ok = fr.violation < 0.5;  // within the tolerances (the equalities are met far closer in practice)
  return fr;
}

}  // namespace socketsmith::design::optimizer_detail
