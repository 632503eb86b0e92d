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

namespace socketsmith::design {
namespace {
constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kPi = std::numbers::pi;
constexpr double kRef = 10e3;  // amplitude scale of the SLSQP variables [Pa]

const volume::Landmark* find_landmark(const std::vector<volume::Landmark>& lms, const std::string& code) {
  for (const auto& l : lms)
    if (l.code == code) return &l;
  return nullptr;
}

Spot cos2(const std::string& name, double theta, double h, double r_theta, double r_h) {
  Spot s;
  s.name = name;
  s.type = SpotType::Cos2;
  s.theta0 = theta;
  s.h0 = h;
  s.r_theta = r_theta;
  s.r_h = r_h;
  s.amplitude_pa = kRef;
  return s;
}

Spot cos_sig(const std::string& name, double theta, double r_theta, double h1, double h2, double lambda_h) {
  Spot s;
  s.name = name;
  s.type = SpotType::CosSig;
  s.theta0 = theta;
  s.r_theta = r_theta;
  s.h1 = h1;
  s.h2 = h2;
  s.lambda_h = lambda_h;
  s.amplitude_pa = kRef;
  return s;
}
}  // namespace

std::vector<Spot> default_spots(geometry::LimbType type, const std::vector<volume::Landmark>& lms, double L,
                                bool total_surface) {
  const auto need = [&](const char* code) -> const volume::Landmark& {
    const auto* l = find_landmark(lms, code);
    require(l != nullptr, "default spot layout: landmark {} is missing (place it in the case file's landmarks)", code);
    return *l;
  };
  std::vector<Spot> s;
  const double lam = 8.0 / (0.05 * L);  // sigmoid edges over ~5 % of the length
  if (type == geometry::LimbType::Transtibial) {
    const auto& pt = need("PT");
    const auto& pop = need("POP");
    const auto& mf = need("MF");
    const auto& lf = need("LF");
    s.push_back(cos2("PT", pt.cylindrical.theta, pt.cylindrical.h, 25 * kDeg, 0.015));
    s.push_back(cos2("POP", pop.cylindrical.theta, std::min(pop.cylindrical.h, pt.cylindrical.h), 50 * kDeg, 0.025));
    s.push_back(cos2("MF", mf.cylindrical.theta, mf.cylindrical.h, 30 * kDeg, 0.025));
    s.push_back(cos2("LF", lf.cylindrical.theta, lf.cylindrical.h, 30 * kDeg, 0.025));
    s.push_back(cos_sig("medial tibia", 60 * kDeg, 30 * kDeg, 0.25 * L, 0.6 * L, lam));
    s.push_back(cos_sig("lateral tibia", -60 * kDeg, 30 * kDeg, 0.25 * L, 0.6 * L, lam));
    s.push_back(cos_sig("posterior calf", 180 * kDeg, 60 * kDeg, 0.2 * L, 0.6 * L, lam));
  } else {
    // Where a transfemoral socket bears (docs/design.md): the ischial seat and the gluteal mass
    // behind it, the lateral wall over the trochanter and along the femur (it holds the femur in
    // adduction), Scarpa's triangle as the anterior counter-support, the walls, a little ramus.
    const auto& is = need("IS").cylindrical;
    const auto& ir = need("IR").cylindrical;
    const auto& gt = need("GT").cylindrical;
    const auto& st = need("ST").cylindrical;
    s.push_back(cos2("ischial seat", is.theta, is.h, 35 * kDeg, 0.025));
    s.push_back(cos_sig("gluteal", wrap_angle(0.5 * (is.theta + kPi)), 50 * kDeg, is.h - 0.04, is.h + 0.04, lam));
    s.push_back(cos2("ischial ramus", ir.theta, ir.h, 20 * kDeg, 0.02));
    s.push_back(cos_sig("lateral wall", gt.theta, 45 * kDeg, 0.3 * L, gt.h + 0.01, lam));
    s.push_back(cos_sig("lateral femur", -90 * kDeg, 40 * kDeg, 0.3 * L, 0.7 * L, lam));
    s.push_back(cos2("Scarpa's triangle", st.theta, st.h, 30 * kDeg, 0.03));
    s.push_back(cos_sig("anterior wall", 0.0, 45 * kDeg, 0.3 * L, 0.75 * L, lam));
    s.push_back(cos_sig("posterior wall", 180 * kDeg, 45 * kDeg, 0.3 * L, 0.75 * L, lam));
    s.push_back(cos_sig("medial wall", 90 * kDeg, 40 * kDeg, 0.3 * L, 0.7 * L, lam));
  }
  // Total contact: a background of broad COS2 spots tiled below the brim (8 around × 3 heights),
  // so that the optimiser can spread the load where the landmark spots alone would peak; a fourth
  // row centred at 0.8 L reaches the brim for total surface bearing.
  for (int j = 0; j < (total_surface ? 4 : 3); ++j)
    for (int i = 0; i < 8; ++i) {
      Spot c = cos2(fmt::format("contact {}/{}", i + 1, j + 1), wrap_angle((-180 + 45 * i) * kDeg), (0.2 + 0.2 * j) * L,
                    45 * kDeg, 0.2 * L);
      c.amplitude_pa = 0.2 * kRef;
      c.optimise_position = false;
      s.push_back(c);
    }
  Spot g;
  g.name = "distal";
  g.type = SpotType::Grad;
  g.h1 = 0.08 * L;
  g.h2 = 0.3 * L;
  g.amplitude_pa = 0.5 * kRef;
  g.max_amplitude_pa = kRef;
  s.push_back(g);
  return s;
}

namespace {

/// The linear amplitude problem on one skin geometry and one set of spot positions.
struct AmplitudeProblem {
  // Inputs
  const DesignSolver* solver = nullptr;
  std::vector<Vec3> pos, normal;
  std::vector<double> area;
  Vec3 centre = Vec3::Zero();
  double q = 8;
  double a_max = 0;
  std::vector<double> cap;  // per skin node: pressure the stump model was found unable to carry [Pa]
  // Built by build()
  std::vector<int> free;              // indices of spots with optimised amplitude
  std::vector<int> nodes;             // skin nodes reached by some spot (below the brim)
  Eigen::MatrixXd phi;                // |nodes| × |free|, φ_k(i) / T_i
  Eigen::MatrixXd phi_obj;            // what J evens: φ_k(i) / T_i or φ_k(i) / kRef
  Eigen::VectorXd fixed_obj;
  bool by_ratio = false;
  bool uniform = false;               // Objective::Uniform
  double area_unloaded = 0;           // skin area below the brim no spot reaches (p = 0 there)
  Eigen::VectorXd fixed_ratio;        // |nodes|, pressure/threshold of the fixed-amplitude spots
  Eigen::VectorXd w;                  // |nodes|, area weights
  Eigen::MatrixXd R;                  // 7 × |free| radar per unit amplitude (Pa)
  Eigen::Matrix<double, 7, 1> r_fixed;
  Eigen::Matrix<double, 7, 1> scale;  // normalisers of the radar rows
  Eigen::Matrix<double, 6, 1> target;
  Eigen::Matrix<double, 6, 1> tolerance;  // of the six equalities [N, N m]
  double stability_min = 0;
  int evaluations = 0;
  // The template's region constraints (OptimizerOptions::region_shares, pressure_ratios) as rows
  // g(a) = G a + g0 ≤ 0, each normalised (a share by F_z, a ratio by kRef) so 0.01 is 1 %.
  const OptimizerOptions* options = nullptr;
  bool use_regions = true;
  Eigen::MatrixXd G;                  // |rows| × |free|
  Eigen::VectorXd g0;                 // |rows|

  /// Radar contributions of unit pressure at skin node i: (F_x, F_y, F_z + friction, T, S).
  Eigen::Matrix<double, 7, 1> unit_radar(size_t i, const geometry::LimbFrame& fr, double mu) const {
    const Vec3 f = -area[i] * normal[i];
    const Vec3 t = (pos[i] - centre).cross(f);
    const double s = axial_friction_n(1.0, area[i], normal[i], fr.axis, mu);
    Eigen::Matrix<double, 7, 1> g;
    g << f.dot(fr.anterior), f.dot(fr.medial()), f.dot(fr.axis) + s, t.dot(fr.anterior), t.dot(fr.medial()),
        t.dot(fr.axis), s;
    return g;
  }

  void build(const std::vector<Spot>& spots) {
    const auto& cyl = solver->skin_cylindrical();
    const auto& above = solver->above_brim();
    const auto& thr = solver->thresholds();
    const auto& fr = solver->frame();
    const double mu = solver->patient().friction;
    free.clear();
    for (size_t k = 0; k < spots.size(); ++k)
      if (spots[k].enabled && spots[k].optimise_amplitude) free.push_back(static_cast<int>(k));
    nodes.clear();
    area_unloaded = 0;
    std::vector<double> rows;  // flattened φ
    std::vector<double> fixed;
    const size_t nf = free.size();
    std::vector<double> row(nf);
    R.setZero(7, static_cast<Eigen::Index>(nf));
    r_fixed.setZero();
    // Per region: F_z per unit amplitude (shares) and Σ A p per unit amplitude (ratios), with the
    // fixed spots' parts in the last column.
    const auto& shares = options->region_shares;
    const auto& ratios = options->pressure_ratios;
    const Eigen::Index nsh = static_cast<Eigen::Index>(shares.size()), nra = static_cast<Eigen::Index>(ratios.size());
    Eigen::MatrixXd share_fz = Eigen::MatrixXd::Zero(nsh, static_cast<Eigen::Index>(nf) + 1);
    Eigen::MatrixXd bear_ap = Eigen::MatrixXd::Zero(nra, static_cast<Eigen::Index>(nf) + 1), relief_ap = bear_ap;
    Eigen::VectorXd bear_area = Eigen::VectorXd::Zero(nra), relief_area = Eigen::VectorXd::Zero(nra);
    const auto add = [&](Eigen::MatrixXd& m, Eigen::Index r, double g, double pf) {
      for (size_t j = 0; j < nf; ++j) m(r, static_cast<Eigen::Index>(j)) += g * row[j];
      m(r, static_cast<Eigen::Index>(nf)) += g * pf;
    };
    for (size_t i = 0; i < cyl.size(); ++i) {
      if (above[i]) continue;
      double pf = 0;
      bool any = false;
      for (size_t j = 0; j < nf; ++j) {
        row[j] = spot_shape(spots[free[j]], cyl[i].theta, cyl[i].h);
        any = any || row[j] > 0;
      }
      for (size_t k = 0; k < spots.size(); ++k)
        if (spots[k].enabled && !spots[k].optimise_amplitude) pf += spot_pressure(spots[k], cyl[i].theta, cyl[i].h);
      // A ratio's means count every node of its regions, loaded or not.
      for (Eigen::Index r = 0; r < nra; ++r) {
        const auto& ra = ratios[static_cast<std::size_t>(r)];
        if (ra.bearing[i]) {
          bear_area[r] += area[i];
          add(bear_ap, r, area[i], pf);
        }
        if (ra.relieved[i]) {
          relief_area[r] += area[i];
          add(relief_ap, r, area[i], pf);
        }
      }
      if (!any && pf == 0) {
        area_unloaded += area[i];
        continue;
      }
      const auto g = unit_radar(i, fr, mu);
      for (size_t j = 0; j < nf; ++j) R.col(static_cast<Eigen::Index>(j)) += g * row[j];
      r_fixed += g * pf;
      for (Eigen::Index r = 0; r < nsh; ++r)
        if (shares[static_cast<std::size_t>(r)].nodes[i]) add(share_fz, r, g[2], pf);
      nodes.push_back(static_cast<int>(i));
      const double te = cap.empty() ? thr[i] : std::min(thr[i], cap[i]);
      for (size_t j = 0; j < nf; ++j) rows.push_back(row[j] / te);
      fixed.push_back(pf / te);
    }
    phi = Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
        rows.data(), static_cast<Eigen::Index>(nodes.size()), static_cast<Eigen::Index>(nf));
    fixed_ratio = Eigen::Map<Eigen::VectorXd>(fixed.data(), static_cast<Eigen::Index>(fixed.size()));
    if (by_ratio) {
      phi_obj = phi;
      fixed_obj = fixed_ratio;
      for (size_t n = 0; n < nodes.size(); ++n) {  // J evens p / T (not p / cap)
        const double te = cap.empty() ? thr[nodes[n]] : std::min(thr[nodes[n]], cap[nodes[n]]);
        const double s = te / thr[nodes[n]];
        phi_obj.row(static_cast<Eigen::Index>(n)) *= s;
        fixed_obj[static_cast<Eigen::Index>(n)] *= s;
      }
    } else {
      phi_obj = phi;
      fixed_obj = fixed_ratio;
      for (size_t n = 0; n < nodes.size(); ++n) {
        const double te = cap.empty() ? thr[nodes[n]] : std::min(thr[nodes[n]], cap[nodes[n]]);
        const double s = te / kRef;
        phi_obj.row(static_cast<Eigen::Index>(n)) *= s;
        fixed_obj[static_cast<Eigen::Index>(n)] *= s;
      }
    }
    w.resize(static_cast<Eigen::Index>(nodes.size()));
    for (size_t n = 0; n < nodes.size(); ++n) w[static_cast<Eigen::Index>(n)] = area[nodes[n]];
    const auto& t = solver->targets();
    const double fs = t.fz_n, ts = t.fz_n * solver->stump_length_m();
    scale << fs, fs, fs, ts, ts, ts, fs;
    target << 0, 0, t.fz_n, 0, 0, 0;
    tolerance << t.force_tol_n, t.force_tol_n, t.force_tol_n, t.torque_tol_nm, t.torque_tol_nm, t.torque_tol_nm;
    stability_min = t.stability_min_n;
    // The rows: a floor −(F_region − min F_z) / F_z, a ceiling (F_region − max F_z) / F_z, a ratio
    // (k · mean_relieved − mean_bearing) / kRef; a region without nodes below the brim gives none.
    std::vector<Eigen::VectorXd> rows_g;  // |free| + 1 (the constant last)
    for (Eigen::Index r = 0; r < nsh; ++r) {
      const auto& sh = shares[static_cast<std::size_t>(r)];
      Eigen::VectorXd fz = share_fz.row(r).transpose() / t.fz_n;
      if (sh.min_share > 0) {
        Eigen::VectorXd v = -fz;
        v[static_cast<Eigen::Index>(nf)] += sh.min_share;
        rows_g.push_back(v);
      }
      if (sh.max_share < 1) {
        Eigen::VectorXd v = fz;
        v[static_cast<Eigen::Index>(nf)] -= sh.max_share;
        rows_g.push_back(v);
      }
    }
    for (Eigen::Index r = 0; r < nra; ++r) {
      if (bear_area[r] <= 0 || relief_area[r] <= 0) continue;
      const double k = ratios[static_cast<std::size_t>(r)].min_ratio;
      rows_g.push_back((k * relief_ap.row(r) / relief_area[r] - bear_ap.row(r) / bear_area[r]).transpose() / kRef);
    }
    G.resize(static_cast<Eigen::Index>(rows_g.size()), static_cast<Eigen::Index>(nf));
    g0.resize(static_cast<Eigen::Index>(rows_g.size()));
    for (size_t r = 0; r < rows_g.size(); ++r) {
      G.row(static_cast<Eigen::Index>(r)) = rows_g[r].head(static_cast<Eigen::Index>(nf)).transpose();
      g0[static_cast<Eigen::Index>(r)] = rows_g[r][static_cast<Eigen::Index>(nf)];
    }
  }

  /// The region constraints at amplitudes a (≤ 0: held; 0.01 = 1 % of F_z or of kRef short).
  Eigen::VectorXd region_excess(const Eigen::VectorXd& a) const { return G * a + g0; }

  /// ½ Σ_k (e_k / tol_k)², e = the six radar residuals: the objective of a least-squares fit
  /// when fewer than six amplitudes are free (six equalities cannot all hold exactly).
  double balance(const double* z, double* grad) {
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

  Eigen::VectorXd amplitudes(const double* z) const {
    Eigen::VectorXd a(static_cast<Eigen::Index>(free.size()));
    for (Eigen::Index j = 0; j < a.size(); ++j) a[j] = kRef * z[j];
    return a;
  }

  double objective(const double* z, double* grad) {
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

  /// J of Objective::Uniform: CV² = W Σ w r² / (Σ w r)² − 1 over the skin below the brim (W its
  /// area, the unloaded part included), r = p / kRef; its gradient in z.
  double squared_cv(const Eigen::VectorXd& r, Eigen::Index n, double* grad) const {
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

  /// Normalised radar residuals (6 equalities) and stability shortfall at amplitudes a.
  Eigen::Matrix<double, 7, 1> radar(const Eigen::VectorXd& a) const { return R * a + r_fixed; }

  /// Worst normalised violation of the constraints at z (0 when all hold within tolerances).
  double violation(const double* z, const RadarTargets& t) const {
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
};

/// Progress, cancel and the time limit of the SLSQP fits: every objective evaluation reports
/// (the bar moves while a large fit runs) and stops the fit when asked or past the deadline.
struct FitControl {
  const ProgressCallback* progress = nullptr;
  std::string stage = "design: optimising";
  double fraction0 = 0, fraction_span = 0;  // the bar's share of the current fit
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
  std::optional<std::chrono::steady_clock::time_point> deadline;
  bool is_cancelled = false;
  bool is_timed_out = false;

  bool should_stop() const { return is_cancelled || is_timed_out; }
  bool past_deadline() const { return deadline && std::chrono::steady_clock::now() >= *deadline; }
  double seconds() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); }
  /// Reports @p done ∈ [0, 1] of the current share; false = stop (cancelled or out of time).
  bool report(double done, const std::string& detail) {
    if (past_deadline()) is_timed_out = true;
    const double f = fraction0 + fraction_span * std::clamp(done, 0.0, 1.0);
    if (progress && !report_progress(*progress, f, fmt::format("{} ({}, {:.0f} s)", stage, detail, seconds())))
      is_cancelled = true;
    return !should_stop();
  }
};

constexpr int kMaxFitEvaluations = 400;

struct FitResult {
  Eigen::VectorXd z;
  double J = 0;
  double violation = 0;
  int evaluations = 0;
  bool ok = false;
};

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
  std::vector<double> upper(n, P.a_max / kRef);
  for (unsigned j = 0; j < n; ++j)
    if (spots[P.free[j]].max_amplitude_pa > 0) upper[j] = std::min(upper[j], spots[P.free[j]].max_amplitude_pa / kRef);
  for (unsigned j = 0; j < n; ++j) fr.z[j] = std::min(fr.z[j], upper[j]);
  opt.set_upper_bounds(upper);
  // Fewer free amplitudes than the six equalities (3 forces, 3 torques): no exact solution in
  // general, and NLopt refuses the problem — fit them in the least-squares sense instead (the
  // violation then says whether the tolerances hold).
  const bool least_squares = n < 6;
  struct Eq {
    AmplitudeProblem* P;
    FitControl* control;
    nlopt::opt* opt;
    bool least_squares;
    int first_evaluation;
  } eq{&P, &control, &opt, least_squares, P.evaluations};
  opt.set_min_objective(
      [](unsigned, const double* z, double* g, void* data) {
        auto& e = *static_cast<Eq*>(data);
        const int k = e.P->evaluations - e.first_evaluation;
        if (!e.control->report(static_cast<double>(k) / kMaxFitEvaluations,
                               fmt::format("amplitude fit, {} evaluations", k)))
          e.opt->force_stop();
        return e.least_squares ? e.P->balance(z, g) : e.P->objective(z, g);
      },
      &eq);
  // Six equalities: the radar's forces and torques at their targets (normalised).
  if (!least_squares)
    opt.add_equality_mconstraint(
      [](unsigned m, double* result, unsigned nn, const double* z, double* grad, void* data) {
        const auto& Q = *static_cast<Eq*>(data)->P;
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
        const auto& Q = *static_cast<Eq*>(data)->P;
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
          const auto& Q = *static_cast<Eq*>(data)->P;
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
  const bool has_regions = !options.region_shares.empty() || !options.pressure_ratios.empty();
  P.q = options.softmax_power;
  P.by_ratio = options.objective == OptimizerOptions::Objective::Ratio;
  P.uniform = options.objective == OptimizerOptions::Objective::Uniform;
  double tmax = 0;
  for (double t : solver.thresholds()) tmax = std::max(tmax, t);
  P.a_max = options.max_amplitude_ratio * tmax;
  const double model_limit = options.model_pressure_limit * solver.model().material().youngs_modulus_pa;
  if (model_limit > 0) P.cap.assign(solver.thresholds().size(), model_limit);
  // Geometry of the first fit: the stump at rest.
  solver.skin_geometry(solver.model().rest_positions(), P.pos, P.normal, P.area);
  {
    const auto& m = solver.model().masses();
    const auto& x = solver.model().rest_positions();
    Vec3 c = Vec3::Zero();
    for (Eigen::Index k = 0; k < m.size(); ++k) c += m[k] * x.segment<3>(3 * k);
    P.centre = c / m.sum();
  }
  const auto apply = [&](const FitResult& f, std::vector<Spot>& sp) {
    for (size_t j = 0; j < P.free.size(); ++j) sp[P.free[j]].amplitude_pa = kRef * f.z[static_cast<Eigen::Index>(j)];
  };
  bool positions_searched = false;
  int model_caps = 0;
  FitControl control;
  control.progress = &options.progress;
  control.start = t0;
  require(std::isfinite(options.time_limit_s) && options.time_limit_s >= 0,
          "optimise_design: time limit {} s must be 0 (none) or positive", options.time_limit_s);
  if (options.time_limit_s > 0)
    control.deadline = t0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                std::chrono::duration<double>(options.time_limit_s));
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
    // The region constraints are the template's intent, not one of the seven constraints: a fit
    // that cannot keep them and the constraints together drops them (said in the log).
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
    out.region_constraints_met = P.use_regions || !has_regions;
    ++out.evaluations;
    out.slsqp_iterations += fit.evaluations;
    // Without friction no layout can hold the prosthesis: moving spots cannot help.
    const bool hopeless = solver.patient().friction == 0.0 && targets.stability_min_n > 0;
    if (!fit.ok && options.optimise_positions && !positions_searched && !hopeless && !control.should_stop()) {
      // Amplitudes alone cannot meet the constraints: move the spots.
      positions_searched = true;
      std::vector<PositionParam> params;
      for (size_t k = 0; k < spots.size(); ++k) {
        if (!spots[k].enabled || !spots[k].optimise_position) continue;
        params.push_back({static_cast<int>(k), 0});
        if (spots[k].type != SpotType::Grad) params.push_back({static_cast<int>(k), 1});
        else params.back().kind = 1;  // a GRAD has no angle: move its heights only
      }
      if (!params.empty()) {
        const std::vector<Spot> base = spots;
        struct Ctx {
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
        Ctx ctx;
        ctx.P = &P;
        ctx.base = &base;
        ctx.params = &params;
        ctx.targets = &targets;
        ctx.work = base;
        ctx.length = solver.stump_length_m();
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
        opt.set_min_objective(
            [](unsigned nn, const double* d, double*, void* data) {
              auto& c = *static_cast<Ctx*>(data);
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
            },
            &ctx);
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
          break;
        }
        if (ctx.best_fit) x = ctx.best_shift;
        for (unsigned i = 0; i < n; ++i) shift_spot(spots[params[i].spot], params[i].kind, x[i]);
        for (auto& s : spots) s.h0 = std::clamp(s.h0, 0.0, solver.stump_length_m());
        out.evaluations += ctx.evaluations;
        P.build(spots);
        // The best evaluation's fit is the fit at these positions (the same problem, the same start).
        if (ctx.best_fit) fit = *ctx.best_fit;
        else fit = fit_amplitudes(P, spots, targets, control);
        out.log.push_back(fmt::format("round {}: amplitudes alone could not meet the constraints; position search: {} fits, "
                                      "J {:.3f}, violation {:.3g}",
                                      round + 1, ctx.evaluations, fit.J, fit.violation));
      }
    }
    if (control.is_cancelled) break;
    apply(fit, spots);
    {
      std::string amps;
      for (const auto& sp : spots) amps += fmt::format(" {}={:.1f}", sp.name, sp.amplitude_pa / 1e3);
      log::debug("optimise_design: round {}: fit J {:.3f}, violation {:.3g}, amplitudes [kPa]:{}", round + 1, fit.J,
                 fit.violation, amps);
    }
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
      out.log.push_back(fmt::format("round {}: the stump model lost stability near θ = {:.0f}°, h = {:.0f} mm (peak {:.1f} "
                                    "kPa there); pressure capped at {:.1f} kPa on {} skin nodes and refitted",
                                    round + 1, cyl.theta * 180 / std::numbers::pi, cyl.h * 1e3, zone_peak / 1e3,
                                    options.model_cap_factor * zone_peak / 1e3, capped));
      log::info("optimise_design: {}", out.log.back());
      ++out.model_caps;
      --round;  // the same round again, on the same geometry
      continue;
    }
    out.log.push_back(fmt::format("round {}: fit J {:.3f} (violation {:.3g}), solved: F = ({:.1f}, {:.1f}, {:.1f}) N, "
                                  "T = ({:.2f}, {:.2f}, {:.2f}) N m, S = {:.1f} N, peak ratio {:.3f}, {}",
                                  round + 1, fit.J, fit.violation, out.state.radar.force_n.x(),
                                  out.state.radar.force_n.y(), out.state.radar.force_n.z(),
                                  out.state.radar.torque_nm.x(), out.state.radar.torque_nm.y(),
                                  out.state.radar.torque_nm.z(), out.state.radar.stability_n,
                                  out.state.max_requested_ratio, out.state.message));
    if (out.state.status.all_ok()) break;
    if (control.should_stop()) break;  // out of time: the last solved state is the result
    if (!fit.ok && positions_searched && round > 0) break;  // infeasible: more rounds will not help
    // Next round: the deformed geometry.
    P.pos = out.state.skin_positions;
    P.normal = out.state.skin_normals;
    P.area = out.state.skin_areas;
    P.centre = out.state.centre_of_inertia;
  }
  out.spots = spots;
  out.constraints_met = out.state.status.all_ok();
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.is_time_limited = control.is_timed_out && !control.is_cancelled;
  if (control.is_cancelled) out.message = "cancelled";
  if (out.message != "cancelled") {
    if (out.constraints_met) {
      out.message = fmt::format("all constraints met after {} round(s) ({} amplitude fits, {:.1f} s); peak pressure "
                                "{:.0f} % of the local pain threshold",
                                out.rounds, out.evaluations, out.seconds, 100 * out.state.max_requested_ratio);
    } else {
      const auto& r = out.state.radar;
      std::string why;
      const auto& st = out.state.status;
      if (!st.follower_converged)
        why = fmt::format("follower iteration: the stump's shape did not settle under its own pressures (the forces "
                          "still changed by {:.2g} after {} passes, tolerance {:.2g}), so the socket it gives is not "
                          "an equilibrium — stiffer tissue (tissue.youngs_kpa), a coarser or finer mesh, or lower "
                          "pressures",
                          out.state.follower_change, out.state.follower_passes,
                          solver.options().follower_tolerance);
      else if (!st.comfort_ok)
        why = fmt::format("comfort: the pressures needed peak at {:.0f} % of the pain threshold (skin node {}); the "
                          "thresholds are too low for M g / 2 = {:.0f} N on this brim — raise the brim, add spots "
                          "over tolerant areas, or review the thresholds",
                          100 * out.state.max_requested_ratio, out.state.max_ratio_node, targets.fz_n);
      else if (!st.stability_ok)
        why = fmt::format("stability: available friction {:.1f} N is below the prosthesis weight {:.1f} N — raise the "
                          "friction coefficient or the wall pressures",
                          r.stability_n, targets.stability_min_n);
      else if (const double peak = out.state.pressure_pa.empty()
                                       ? 0.0
                                       : *std::max_element(out.state.pressure_pa.begin(), out.state.pressure_pa.end());
               model_limit > 0 && peak >= 0.95 * model_limit && r.force_n.z() < targets.fz_n - targets.force_tol_n)
        // The load is short because every pressure is held under the tissue model's range, not
        // because of where the spots are.
        why = fmt::format("{}: F_z = {:.1f} N of {:.1f} N with the pressures at the tissue model's limit, {:.2g} × E = "
                          "{:.3g} kPa (design.model_pressure_limit): the tissue (E = {:.3g} kPa) is too soft for this "
                          "load — raise tissue.youngs_kpa, or design.model_pressure_limit if larger strains are meant",
                          st.failing(), r.force_n.z(), targets.fz_n, options.model_pressure_limit, model_limit / 1e3,
                          solver.model().material().youngs_modulus_pa / 1e3);
      else
        why = fmt::format("{}: F = ({:.1f}, {:.1f}, {:.1f}) N (target (0, 0, {:.1f}) ± {:.1f}), T = ({:.2f}, {:.2f}, "
                          "{:.2f}) N m (± {:.2f}) — the spot layout cannot balance the load: add or move spots",
                          st.failing(), r.force_n.x(), r.force_n.y(), r.force_n.z(), targets.fz_n,
                          targets.force_tol_n, r.torque_nm.x(), r.torque_nm.y(), r.torque_nm.z(),
                          targets.torque_tol_nm);
      out.message = fmt::format("constraints not met after {} round(s): {}", out.rounds, why);
      if (P.free.size() < 6)
        out.message += fmt::format(" (only {} spot amplitude(s) may change, and balancing three forces and three "
                                   "torques needs at least 6: add spots or let the optimiser change more amplitudes)",
                                   P.free.size());
    }
    if (out.is_time_limited)
      out.message = fmt::format("stopped by the time limit of {:.3g} s after {:.1f} s and {} round(s) — {} (a longer "
                                "time limit, or fewer spots, lets it finish)",
                                options.time_limit_s, out.seconds, out.rounds, out.message);
  }
  report_progress(options.progress, 1.0, "design: optimised");
  return out;
}

}  // namespace socketsmith::design
