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
