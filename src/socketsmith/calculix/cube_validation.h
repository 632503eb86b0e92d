#pragma once
/// @file cube_validation.h
/// The thesis's cube (50 mm, E = 50 kPa) in CalculiX against the analytic solution: a rigid
/// plate (one layer of C3D8 tied to a reference node) pressed onto the top face by frictionless
/// penalty contact under displacement control, frictionless supports below and on two symmetry
/// planes (so the exact solution is uniaxial stress). Small-strain analysis: at every increment
/// the plate force F gives the analytic top displacement F L / (A E) and contact pressure
/// F / (A (1 + ν ε)²), ε = F / (A E) (ccx measures the contact area on the laterally expanded
/// top face even without NLGEOM), compared with ccx's nodal U and CPRESS on the top face.
/// Keep the strain small (the default 8 N is 6.4 %): at the thesis's 80 N (64 %) ccx's contact
/// area (3.70e-3 m² on the default cube) is neither A nor the linear theory's, and the nodal
/// pressures, uniform as they should be, are F over that area. It checks the deck writer, the runner and both
/// readers end to end on a problem whose answer is known. validate_cube_fe is the whole of
/// `socketsmith validate cube`: the run and its table, plots and summary.

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "socketsmith/calculix/calculix_deck.h"
#include "socketsmith/calculix/ccx_runner.h"
#include "socketsmith/report/field_comparison.h"

namespace socketsmith::calculix {

struct CubeFeOptions {
  double edge_m = 0.05;            ///< [m], > 0
  int divisions = 4;               ///< elements per edge, ≥ 1
  double youngs_modulus_pa = 50e3; ///< [Pa] (thesis ch. 3: 50 kPa)
  double poisson_ratio = 0.45;     ///< [-]
  double max_force_n = 8.0;        ///< plate force at the end [N] (6.4 % strain), > 0
  int increments = 8;              ///< equal increments (8: 1, 2, …, 8 N), ≥ 1
  ElementType element = ElementType::C3D8;
  double penalty_pa_per_m = 1e9;   ///< contact penalty [Pa/m]
  CcxOptions ccx;
};

struct CubeFeResult {
  std::vector<double> force_n;             ///< plate force per increment (from the .dat) [N]
  std::vector<double> fe_displacement_m;   ///< mean top-face U3 (downwards positive) [m]
  std::vector<double> analytic_displacement_m;  ///< F L / (A E)
  std::vector<double> fe_pressure_pa;      ///< mean top-face CPRESS [Pa]
  std::vector<double> analytic_pressure_pa;     ///< F / (A (1 + ν ε)²)
  report::ErrorStats displacement;   ///< FE vs analytic top displacement over the increments [m]
  report::ErrorStats pressure;       ///< nodal CPRESS vs F/A over all top nodes × increments [Pa]
  report::ErrorStats interior_pressure;  ///< the same without the top face's edge nodes [Pa]
  double max_displacement_rel_error = 0;  ///< max |FE − analytic| / analytic
  double max_pressure_rel_error = 0;      ///< of the mean top pressure
  int nodes = 0, elements = 0;
  CcxRun ccx;
  std::filesystem::path deck;
};

/// Writes <dir>/cube.inp, runs ccx in @p dir, reads the results.
/// @throws InvalidInputError for bad options or a missing ccx; SolverError (with ccx's message)
///         when ccx fails — the deck and log are kept in @p dir.
CubeFeResult run_cube_fe(const CubeFeOptions& options, const std::filesystem::path& dir);

/// A cube run with its outputs.
struct CubeFeValidation {
  CubeFeResult result;
  nlohmann::json summary;  ///< summary.json: sizes, material, errors, the agreement of displacement and pressure
};

/// Creates @p out, runs run_cube_fe there and writes cube_fe.csv (per increment: force [N],
/// CalculiX's and the analytic displacement [mm] and pressure [kPa]), cube_fe.svg and cube_fe.png
/// (displacement and pressure, CalculiX against analytic) and summary.json, each atomically.
/// @throws as run_cube_fe (nothing but the deck and ccx's files written then).
CubeFeValidation validate_cube_fe(const CubeFeOptions& options, const std::filesystem::path& out);

}  // namespace socketsmith::calculix
