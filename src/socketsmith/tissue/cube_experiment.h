#pragma once
/// @file cube_experiment.h
/// The thesis's cube experiment (ch. 3.5–3.6, Figs. 26a, 28–30): an elastic cube of edge L
/// compressed by a rigid box of weight W resting frictionlessly on its top face; the bottom
/// rests on a frictionless support. Analytic reference (linear elasticity, uniaxial stress):
/// nominal top pressure W/A and displacement ratio δ/L = W/(A E), with A = L². For the continuum
/// models (fe, neo-hookean) also the exact uniaxial stress state of their own strain energy under
/// the nominal stress −W/A (uniaxial_stress_state, hyperelastic_hex.h): the state is homogeneous,
/// so the elements should reproduce it to the solver's tolerance.
///
/// Boundary conditions: every bottom node has z fixed; bottom corner (0,0,0) also x and y, and
/// bottom corner (L,0,0) also y (no rigid motion, free lateral expansion); the z DOFs of all
/// top nodes are tied (the rigid box moves down as one, nodes slide freely sideways) and carry
/// the weight. The cube's own weight is not applied (the analytic solution ignores it).

#include <limits>
#include <string>
#include <vector>

#include "socketsmith/core/progress.h"
#include "socketsmith/tissue/mass_spring_model.h"
#include "socketsmith/tissue/static_solver.h"

namespace socketsmith::tissue {

struct CubeExperimentOptions {
  double edge_m = 0.05;                  ///< cube edge L [m], > 0
  TissueMaterial material{50e3, 1060.0};  ///< thesis: E = 50 kPa, ρ = 1060 kg/m^3
  int divisions = 8;                     ///< elements per edge, ≥ 1
  double max_weight_n = 80.0;            ///< heaviest box [N], > 0
  int num_weights = 17;                  ///< weights 0..max, evenly spaced, ≥ 2
  int load_substeps = 4;                 ///< continuation steps between two weights, ≥ 1
  MassSpringOptions model;               ///< model variant and constants
  StaticSolverOptions solver;
  /// Compute the smallest real part of the eigenvalues of the reduced stiffness −J at every
  /// weight (dense; only when the reduced system has ≤ 1000 DOFs). A value ≤ 0 means the
  /// homogeneous equilibrium is unstable: the lattice buckles (shears sideways).
  bool check_stability = false;
};

struct CubeRow {
  double weight_n = 0;
  double top_pressure_analytic_pa = 0;    ///< W / A
  double top_pressure_pa = 0;             ///< Σ top-node reactions / A (nominal)
  double top_pressure_true_pa = 0;        ///< Σ top-node reactions / deformed top area
  double nodal_pressure_spread = 0;       ///< max |p_i − p̄| / p̄ over top nodes (p_i = R_i / a_i)
  double displacement_ratio_analytic = 0; ///< W / (A E)
  double displacement_ratio = 0;          ///< top displacement / L
  /// 1 − s of the uniaxial stress state of the model's own energy (continuum models; NaN for the
  /// lattices, which have no closed form, and past a limit point of the law)
  double displacement_ratio_reference = std::numeric_limits<double>::quiet_NaN();
  /// s t² of that state (NaN when there is none)
  double volume_ratio_reference = std::numeric_limits<double>::quiet_NaN();
  double volume_ratio = 1;                ///< V / V0
  double lateral_stretch = 1;             ///< width of the mid-height section / L
  int newton_iterations = 0;
  bool converged = false;
  double min_stiffness_eigenvalue = std::numeric_limits<double>::quiet_NaN();  ///< [N/m], NaN if not checked
};

struct CubeExperimentResult {
  std::vector<CubeRow> rows;
  bool converged = false;      ///< every weight converged
  std::string message;
  int num_nodes = 0;
  int num_elements = 0;
  double wall_s = 0;           ///< total wall time of the solves [s]
};

/// Runs the experiment for one model. Stops at the first weight that does not converge
/// (converged = false, message says which and why).
CubeExperimentResult run_cube_experiment(const CubeExperimentOptions& options,
                                         const ProgressCallback& progress = {});

/// Accuracy summary against the thesis's criteria.
struct CubeErrors {
  double max_displacement_error = 0;  ///< max relative error of the displacement ratio up to the strain limit
  double max_volume_error = 0;        ///< max |V/V0 − 1| up to the volume strain limit
  bool unstable = false;              ///< some checked row up to the displacement limit had eigenvalue ≤ 0
  /// Analytic strain W/(AE) of the first row whose stiffness had an eigenvalue ≤ 0 (+inf: none).
  double first_unstable_strain = std::numeric_limits<double>::infinity();
  double displacement_strain_limit = 0.6;
  double volume_strain_limit = 0.4;
  /// Against the analytic state of the model's own energy (continuum models), over every row with
  /// W > 0 that has one: max |δ − δ_ref| / δ_ref and max |V/V0 − (V/V0)_ref|. NaN without any.
  double max_displacement_error_reference = std::numeric_limits<double>::quiet_NaN();
  double max_volume_error_reference = std::numeric_limits<double>::quiet_NaN();
};

/// Errors over the rows whose analytic strain ≤ the limits (rows with W = 0 are skipped).
CubeErrors cube_errors(const CubeExperimentResult& result, double displacement_strain_limit = 0.6,
                       double volume_strain_limit = 0.4);

/// The sheared cube: a cube of edge L on a base held fixed, its top loaded by a uniform traction
/// of compression p_z and shear p_x (nodal forces from tributary areas), solved from rest. Unlike
/// the frictionless cube it exercises lattice shear with the base constrained (elements near the
/// base compressed in volume), where MSS-CS constants that fit the frictionless cube can lose
/// stability (docs/VALIDATION.md).
struct ShearedCubeOptions {
  double edge_m = 0.05;                   ///< L [m], > 0
  int divisions = 4;                      ///< elements per edge, ≥ 1
  TissueMaterial material{50e3, 1060.0};
  double compression_pa = 5e3;            ///< p_z, downward on the top [Pa], ≥ 0
  double shear_pa = 1e3;                  ///< p_x, along +x on the top [Pa], ≥ 0
  MassSpringOptions model;
  StaticSolverOptions solver;
};

struct ShearedCubeResult {
  bool converged = false;
  std::string message;          ///< the solver's message (why it stopped)
  int load_steps = 0;           ///< load-continuation steps (0: direct Newton converged)
  int newton_iterations = 0;
  double load_fraction = 0;     ///< fraction of the load the returned state balances [-]
  bool residual_within_tolerance = false;  ///< the returned state is an equilibrium (checked independently)
  double min_corner_jacobian = 1;  ///< smallest scaled corner Jacobian of the returned state (≤ 0: inverted)
  double top_sink_ratio = 0;    ///< mean downward displacement of the top / L [-]
  double top_shift_ratio = 0;   ///< mean +x displacement of the top / L [-]
};

/// Solves the sheared cube. Throws nothing for a model that cannot carry the load (converged = false).
ShearedCubeResult run_sheared_cube(const ShearedCubeOptions& options);

}  // namespace socketsmith::tissue
