#include "socketsmith/tissue/pressure_load.h"

#include <chrono>
#include <cmath>

#include "socketsmith/core/errors.h"
#include "socketsmith/volume/hex_mesh.h"

namespace socketsmith::tissue {

VectorXd pressure_forces(const volume::SkinSurface& skin, const std::vector<double>& pressure_pa, int num_nodes) {
  require(pressure_pa.size() == skin.nodes.size(), "pressure_forces: {} pressures for {} skin nodes",
          pressure_pa.size(), skin.nodes.size());
  VectorXd f = VectorXd::Zero(3 * static_cast<Eigen::Index>(num_nodes));
  for (size_t i = 0; i < skin.nodes.size(); ++i) {
    require(std::isfinite(pressure_pa[i]), "pressure_forces: pressure at skin node {} is not finite", i);
    f.segment<3>(3 * skin.nodes[i]) -= pressure_pa[i] * skin.area_m2[i] * skin.normal[i];
  }
  return f;
}

PressureLoadResult solve_uniform_pressure(const volume::HexMesh& mesh, double pressure_pa,
                                          const TissueMaterial& material, const MassSpringOptions& options,
                                          const StaticSolverOptions& solver_options) {
  require(std::isfinite(pressure_pa), "uniform pressure is not finite");
  const auto t0 = std::chrono::steady_clock::now();
  PressureLoadResult res;
  const MassSpringModel model(mesh, material, options);
  const DofMap dofs = fixed_node_dofs(mesh, "uniform pressure solve");
  StaticSolver solver(model, dofs, solver_options);
  const auto skin = volume::extract_skin_surface(mesh);
  const VectorXd f = pressure_forces(skin, std::vector<double>(skin.nodes.size(), pressure_pa), mesh.num_nodes());
  for (Eigen::Index i = 0; i < f.size() / 3; ++i) res.applied_force_sum_n += f.segment<3>(3 * i).norm();
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  for (Eigen::Index i = 0; i < f.size() / 3; ++i) total += f.segment<3>(3 * i);
  res.total_force_n = total.norm();
  const auto t1 = std::chrono::steady_clock::now();
  res.positions = model.rest_positions();
  res.solve = solver.solve(f, res.positions);
  const auto t2 = std::chrono::steady_clock::now();
  res.seconds_setup = std::chrono::duration<double>(t1 - t0).count();
  res.seconds_solve = std::chrono::duration<double>(t2 - t1).count();
  require<SolverError>(res.solve.converged, "static solve under {:.1f} kPa did not converge: {}", pressure_pa / 1e3,
                       res.solve.message);
  const VectorXd u = res.positions - model.rest_positions();
  for (Eigen::Index i = 0; i < u.size() / 3; ++i) res.max_displacement_m = std::max(res.max_displacement_m, u.segment<3>(3 * i).norm());
  for (int n : skin.nodes) res.mean_skin_displacement_m += u.segment<3>(3 * n).norm();
  if (!skin.nodes.empty()) res.mean_skin_displacement_m /= static_cast<double>(skin.nodes.size());
  volume::HexMesh deformed = mesh;
  for (int n = 0; n < mesh.num_nodes(); ++n) deformed.nodes[n] = res.positions.segment<3>(3 * n);
  res.volume_change = volume::total_volume(deformed) / volume::total_volume(mesh) - 1.0;
  return res;
}

}  // namespace socketsmith::tissue
