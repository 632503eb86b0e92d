#include "socketsmith/tissue/cube_experiment.h"

#include <chrono>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "socketsmith/core/errors.h"
#include "socketsmith/volume/box_mesher.h"

namespace socketsmith::tissue {

namespace {

void check_cube_options(const CubeExperimentOptions& o) {
  require(std::isfinite(o.edge_m) && o.edge_m > 0, "cube experiment: edge {} m (expected > 0)", o.edge_m);
  require(o.divisions >= 1, "cube experiment: divisions {} (expected ≥ 1)", o.divisions);
  require(std::isfinite(o.max_weight_n) && o.max_weight_n > 0, "cube experiment: max weight {} N (expected > 0)",
          o.max_weight_n);
  require(o.num_weights >= 2, "cube experiment: {} weights (expected ≥ 2)", o.num_weights);
  require(o.load_substeps >= 1, "cube experiment: {} load substeps (expected ≥ 1)", o.load_substeps);
}

/// The cube on the table: the bottom face slides on it (z fixed, rigid motion in the plane held at
/// two corners), the top face pushed down by a rigid box (its z tied).
struct CubeSupport {
  DofConstraints constraints;
  std::vector<int> top;            ///< the top face's nodes
  std::vector<double> top_area_m2;  ///< reference tributary area of each top node
};

CubeSupport cube_support(const std::array<int, 3>& divisions, double h_m) {
  const int n = divisions[2];
  const auto id = [&](int i, int j, int k) { return volume::box_node_index(divisions, i, j, k); };
  CubeSupport s;
  DofConstraints& c = s.constraints;
  std::vector<int> top_group;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      c.fixed.push_back(dof(id(i, j, 0), 2));
      s.top.push_back(id(i, j, n));
      top_group.push_back(dof(id(i, j, n), 2));
      s.top_area_m2.push_back(h_m * h_m * ((i == 0 || i == n) ? 0.5 : 1.0) * ((j == 0 || j == n) ? 0.5 : 1.0));
    }
  c.fixed.push_back(dof(id(0, 0, 0), 0));
  c.fixed.push_back(dof(id(0, 0, 0), 1));
  c.fixed.push_back(dof(id(n, 0, 0), 1));
  c.tied_groups.push_back(top_group);
  return s;
}

/// A weight's row before the solve: the analytic (linear) values and, for a continuum material,
/// the uniaxial stress state of its own energy.
CubeRow analytic_row(const MassSpringModel& model, const TissueMaterial& material, double weight_n, double area_m2) {
  CubeRow row;
  row.weight_n = weight_n;
  row.top_pressure_analytic_pa = weight_n / area_m2;
  row.displacement_ratio_analytic = weight_n / (area_m2 * material.youngs_modulus_pa);
  if (const auto* continuum = model.continuum_material()) {
    const UniaxialStressState ref = uniaxial_stress_state(*continuum, -weight_n / area_m2);
    if (ref.found) {
      row.displacement_ratio_reference = 1.0 - ref.axial_stretch;
      row.volume_ratio_reference = ref.axial_stretch * ref.lateral_stretch * ref.lateral_stretch;
    }
  }
  return row;
}

/// Raises the load on the top nodes from @p previous_n to @p weight_n in @p substeps solves; false
/// (with result.converged = false and the message) when one diverges.
bool load_to(StaticSolver& solver, const std::vector<int>& top, double previous_n, double weight_n, int substeps,
             VectorXd& f_ext, VectorXd& x, CubeRow& row, CubeExperimentResult& result, TissueModelKind kind) {
  for (int sub = 1; sub <= substeps; ++sub) {
    const double wi = previous_n + (weight_n - previous_n) * sub / substeps;
    for (int t : top) f_ext[dof(t, 2)] = -wi / static_cast<double>(top.size());
    const StaticResult r = solver.solve(f_ext, x);
    row.newton_iterations += r.iterations;
    if (!r.converged) {
      result.converged = false;
      result.message = fmt::format("{} diverged at W = {:.2f} N: {}", to_string(kind), wi, r.message);
      return false;
    }
  }
  return true;
}

/// The solved state's row: the box's reaction and its spread over the top nodes, the top's
/// displacement, the volume, the lateral stretch and (small meshes) the least stiffness eigenvalue.
void measure_row(CubeRow& row, const MassSpringModel& model, const DofMap& dofs, const VectorXd& x,
                 const CubeSupport& support, const std::array<int, 3>& divisions, const CubeExperimentOptions& o,
                 double v0_m3) {
  const int n = o.divisions;
  const double area = o.edge_m * o.edge_m;
  const std::vector<int>& top = support.top;
  const auto id = [&](int i, int j, int k) { return volume::box_node_index(divisions, i, j, k); };
  // Reactions at the top nodes: the box pushes with R_i = f_int,z(i) (upward internal force).
  const VectorXd f_int = model.elastic_forces(x);
  double total = 0.0, mean_p = 0.0;
  std::vector<double> p(top.size());
  for (size_t t = 0; t < top.size(); ++t) {
    total += f_int[dof(top[t], 2)];
    p[t] = f_int[dof(top[t], 2)] / support.top_area_m2[t];
    mean_p += p[t] / static_cast<double>(top.size());
  }
  row.top_pressure_pa = total / area;
  for (double pi : p)
    row.nodal_pressure_spread = std::max(row.nodal_pressure_spread, mean_p > 0 ? std::abs(pi - mean_p) / mean_p : 0.0);
  // Deformed top area from the top corner nodes' positions (the top face stays flat).
  const auto pos = [&](int node) { return volume::Vec3(x.segment<3>(3 * node)); };
  const volume::Vec3 a = pos(id(n, 0, n)) - pos(id(0, 0, n)), b = pos(id(0, n, n)) - pos(id(0, 0, n));
  const double top_area_now = a.cross(b).norm();
  row.top_pressure_true_pa = top_area_now > 0 ? total / top_area_now : 0.0;
  row.displacement_ratio = -(x[dof(id(0, 0, n), 2)] - o.edge_m) / o.edge_m + 0.0;  // no "-0"
  row.volume_ratio = model.total_volume(x) / v0_m3;
  const int mid = n / 2;
  row.lateral_stretch = (pos(id(n, 0, mid)) - pos(id(0, 0, mid))).norm() / o.edge_m;
  if (o.check_stability && dofs.num_reduced() <= 1000) {
    SparseMatrix J, J_red;
    model.jacobian(x, JacobianKind::Exact, J);
    dofs.reduce_matrix(J, J_red);
    const Eigen::MatrixXd K = -Eigen::MatrixXd(J_red);
    row.min_stiffness_eigenvalue = Eigen::EigenSolver<Eigen::MatrixXd>(K, false).eigenvalues().real().minCoeff();
  }
}

}  // namespace

CubeExperimentResult run_cube_experiment(const CubeExperimentOptions& o, const ProgressCallback& progress) {
  check_cube_options(o);
  volume::BoxMeshOptions box;
  box.size = volume::Vec3::Constant(o.edge_m);
  box.divisions = {o.divisions, o.divisions, o.divisions};
  const volume::HexMesh mesh = volume::mesh_box(box);
  const MassSpringModel model(mesh, o.material, o.model);
  const CubeSupport support = cube_support(box.divisions, o.edge_m / o.divisions);
  const DofMap dofs(model.num_dofs(), support.constraints);
  StaticSolver solver(model, dofs, o.solver);

  CubeExperimentResult result;
  result.num_nodes = model.num_nodes();
  result.num_elements = model.num_elements();
  const double area_m2 = o.edge_m * o.edge_m;
  const double v0 = model.total_volume(model.rest_positions());
  VectorXd x = model.rest_positions();
  VectorXd f_ext = VectorXd::Zero(model.num_dofs());
  const auto t0 = std::chrono::steady_clock::now();
  double previous_weight = 0.0;
  result.converged = true;
  for (int w = 0; w < o.num_weights; ++w) {
    const double weight = o.max_weight_n * w / (o.num_weights - 1);
    CubeRow row = analytic_row(model, o.material, weight, area_m2);
    const int substeps = w == 0 ? 1 : o.load_substeps;
    if (!load_to(solver, support.top, previous_weight, weight, substeps, f_ext, x, row, result, o.model.kind)) break;
    previous_weight = weight;
    row.converged = true;
    measure_row(row, model, dofs, x, support, box.divisions, o, v0);
    result.rows.push_back(row);
    if (!report_progress(progress, static_cast<double>(w + 1) / o.num_weights, "cube " + to_string(o.model.kind))) {
      result.converged = false;
      result.message = "cancelled";
      break;
    }
  }
  result.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (result.converged) result.message = fmt::format("{}: {} weights solved", to_string(o.model.kind), result.rows.size());
  return result;
}

CubeErrors cube_errors(const CubeExperimentResult& result, double disp_limit, double vol_limit) {
  CubeErrors e;
  e.displacement_strain_limit = disp_limit;
  e.volume_strain_limit = vol_limit;
  for (const auto& r : result.rows) {
    if (r.weight_n <= 0) continue;
    const double strain = r.displacement_ratio_analytic;
    if (r.min_stiffness_eigenvalue <= 0) e.first_unstable_strain = std::min(e.first_unstable_strain, strain);
    if (strain <= disp_limit + 1e-12 && r.min_stiffness_eigenvalue <= 0) e.unstable = true;
    if (strain <= disp_limit + 1e-12)
      e.max_displacement_error = std::max(e.max_displacement_error, std::abs(r.displacement_ratio - strain) / strain);
    if (strain <= vol_limit + 1e-12) e.max_volume_error = std::max(e.max_volume_error, std::abs(r.volume_ratio - 1.0));
    if (std::isfinite(r.displacement_ratio_reference) && r.displacement_ratio_reference > 0) {
      const double d = std::abs(r.displacement_ratio - r.displacement_ratio_reference) / r.displacement_ratio_reference;
      const double v = std::abs(r.volume_ratio - r.volume_ratio_reference);
      e.max_displacement_error_reference =
          std::isnan(e.max_displacement_error_reference) ? d : std::max(e.max_displacement_error_reference, d);
      e.max_volume_error_reference = std::isnan(e.max_volume_error_reference) ? v : std::max(e.max_volume_error_reference, v);
    }
  }
  return e;
}

ShearedCubeResult run_sheared_cube(const ShearedCubeOptions& o) {
  require(std::isfinite(o.edge_m) && o.edge_m > 0, "sheared cube: edge {} m (expected > 0)", o.edge_m);
  require(o.divisions >= 1, "sheared cube: divisions {} (expected ≥ 1)", o.divisions);
  require(std::isfinite(o.compression_pa) && o.compression_pa >= 0 && std::isfinite(o.shear_pa) && o.shear_pa >= 0,
          "sheared cube: tractions {} / {} Pa (expected finite, ≥ 0)", o.compression_pa, o.shear_pa);
  volume::BoxMeshOptions box;
  box.size = volume::Vec3::Constant(o.edge_m);
  box.divisions = {o.divisions, o.divisions, o.divisions};
  const MassSpringModel model(volume::mesh_box(box), o.material, o.model);
  const int n = o.divisions;
  const double h = o.edge_m / n;
  const auto id = [&](int i, int j, int k) { return volume::box_node_index(box.divisions, i, j, k); };
  DofConstraints c;
  VectorXd f = VectorXd::Zero(model.num_dofs());
  std::vector<int> top;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      c.fix_nodes({id(i, j, 0)});
      const int t = id(i, j, n);
      top.push_back(t);
      const double a = h * h * ((i == 0 || i == n) ? 0.5 : 1.0) * ((j == 0 || j == n) ? 0.5 : 1.0);
      f[dof(t, 2)] = -o.compression_pa * a;
      f[dof(t, 0)] = o.shear_pa * a;
    }
  const DofMap dofs(model.num_dofs(), c);
  StaticSolver solver(model, dofs, o.solver);
  VectorXd x = model.rest_positions();
  ShearedCubeResult out;
  StaticResult r;
  try {
    r = solver.solve(f, x);
  } catch (const Error& e) {
    out.message = e.what();
    return out;
  }
  out.converged = r.converged;
  out.message = r.message;
  out.load_steps = r.load_steps;
  out.newton_iterations = r.iterations;
  out.load_fraction = r.load_fraction;
  out.residual_within_tolerance = static_residual(model, dofs, f, x).norm() <= solver.options().rel_tol * r.reference_force_n + 1e-12;
  out.min_corner_jacobian = model.min_corner_jacobian(x);
  for (int t : top) {
    out.top_sink_ratio += (model.rest_positions()[dof(t, 2)] - x[dof(t, 2)]) / (o.edge_m * static_cast<double>(top.size()));
    out.top_shift_ratio += (x[dof(t, 0)] - model.rest_positions()[dof(t, 0)]) / (o.edge_m * static_cast<double>(top.size()));
  }
  return out;
}

}  // namespace socketsmith::tissue
