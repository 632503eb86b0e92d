#pragma once
/// The optimiser's amplitude fit (inside `design` only; `optimizer.h` is the interface): the linear
/// problem of the spot amplitudes on one skin geometry and one set of spot positions — radar rows
/// per unit amplitude, pressure/threshold per node, the template's region rows — and its SLSQP fit
/// with progress, cancel and the time limit. Why apart: `optimise_design` (`optimizer.cpp`) runs
/// rounds of fits, moves the spots and solves the stump; the fit itself is one problem with its
/// own algebra.

#include <chrono>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "socketsmith/core/progress.h"
#include "socketsmith/design/optimizer.h"

namespace socketsmith::design::optimizer_detail {

inline constexpr double kRef = 10e3;  // amplitude scale of the SLSQP variables [Pa]

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
  Eigen::Matrix<double, 7, 1> unit_radar(size_t i, const geometry::LimbFrame& fr, double mu) const;

  void build(const std::vector<Spot>& spots);

  /// The region constraints at amplitudes a (≤ 0: held; 0.01 = 1 % of F_z or of kRef short).
  Eigen::VectorXd region_excess(const Eigen::VectorXd& a) const { return G * a + g0; }

  /// ½ Σ_k (e_k / tol_k)², e = the six radar residuals: the objective of a least-squares fit
  /// when fewer than six amplitudes are free (six equalities cannot all hold exactly).
  double balance(const double* z, double* grad);

  Eigen::VectorXd amplitudes(const double* z) const;

  double objective(const double* z, double* grad);

  /// J of Objective::Uniform: CV² = W Σ w r² / (Σ w r)² − 1 over the skin below the brim (W its
  /// area, the unloaded part included), r = p / kRef; its gradient in z.
  double squared_cv(const Eigen::VectorXd& r, Eigen::Index n, double* grad) const;

  /// Normalised radar residuals (6 equalities) and stability shortfall at amplitudes a.
  Eigen::Matrix<double, 7, 1> radar(const Eigen::VectorXd& a) const { return R * a + r_fixed; }

  /// Worst normalised violation of the constraints at z (0 when all hold within tolerances).
  double violation(const double* z, const RadarTargets& t) const;
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

struct FitResult {
  Eigen::VectorXd z;
  double J = 0;
  double violation = 0;
  int evaluations = 0;
  bool ok = false;
};

/// The amplitudes of the free spots that meet the seven constraints (and the template's regions
/// when P.use_regions) with the most even pressure/threshold (SLSQP; least squares with fewer than
/// six free amplitudes).
FitResult fit_amplitudes(AmplitudeProblem& P, const std::vector<Spot>& spots, const RadarTargets& t,
                         FitControl& control);

}  // namespace socketsmith::design::optimizer_detail
