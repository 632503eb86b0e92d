#pragma once
/// @file pressure_load.h
/// Pressures on the skin of a limb mesh as nodal forces, and a static solve under them.

#include <vector>

#include "socketsmith/tissue/mass_spring_model.h"
#include "socketsmith/tissue/static_solver.h"
#include "socketsmith/volume/hex_mesher.h"

namespace socketsmith::tissue {

/// Nodal forces (3N) of per-surface-node pressures [Pa] acting inward: f_i = −p_i A_i n_i.
/// @throws InvalidInputError when the sizes differ or a pressure is not finite.
VectorXd pressure_forces(const volume::SkinSurface& skin, const std::vector<double>& pressure_pa, int num_nodes);

/// Deformed nodal areas and outward unit normals of the skin at positions @p x (3N): node k's
/// area A_k = Σ_q ¼|a_q| and normal n_k = Σ_q a_q / |Σ_q a_q| over its skin quads q, with the
/// quad's vector area a_q = ½ (c − a) × (d − b). Skin order (SkinSurface::nodes) [m², -].
void skin_areas_and_normals(const volume::SkinSurface& skin, const VectorXd& x, std::vector<double>& area_m2,
                            std::vector<Eigen::Vector3d>& normal);

/// Pressures that follow the deformed skin: f_k(x) = −p_k A_k(x) n_k(x) (skin_areas_and_normals),
/// the design's follower load, with its exact Jacobian for the static solver's Newton tangent.
/// Not conservative in general (non-uniform pressure): the Jacobian is not symmetric.
class FollowerPressure final : public PositionDependentLoad {
 public:
  /// @param pressure_pa per skin node (SkinSurface::nodes order), inward [Pa]; 0 where no load.
  /// @throws InvalidInputError when the sizes differ or a pressure is not finite.
  FollowerPressure(const volume::SkinSurface& skin, std::vector<double> pressure_pa, int num_nodes);
  VectorXd forces(const VectorXd& x) const override;
  void add_jacobian(const VectorXd& x, double scale, SparseMatrix& J) const override;

 private:
  const volume::SkinSurface& skin_;
  std::vector<double> pressure_pa_;
  int num_nodes_;
  std::vector<std::vector<int>> quads_of_;  // per skin node: the quads around it
};

/// Result of solve_uniform_pressure.
struct PressureLoadResult {
  StaticResult solve;
  VectorXd positions;                 ///< deformed positions (3N) [m]
  double max_displacement_m = 0.0;
  double mean_skin_displacement_m = 0.0;
  double total_force_n = 0.0;         ///< |Σ f_ext|: zero for a closed surface, not here (the cut is open)
  double applied_force_sum_n = 0.0;   ///< Σ |f_i|
  double volume_change = 0.0;         ///< V/V0 − 1 of the mesh
  double seconds_setup = 0.0;         ///< model + solver construction
  double seconds_solve = 0.0;
};

/// Static equilibrium of the limb model (nodes tagged kNodeFixed held) under a uniform inward
/// pressure on the skin surface nodes. @throws SolverError when the solve does not converge.
PressureLoadResult solve_uniform_pressure(const volume::HexMesh& mesh, double pressure_pa,
                                          const TissueMaterial& material, const MassSpringOptions& options,
                                          const StaticSolverOptions& solver_options = {});

}  // namespace socketsmith::tissue
