#pragma once
/// @file validation_inputs.h
/// The designed state of a pipeline run as the CalculiX check's input (calculix::DesignedStump,
/// calculix::FeMaterial), and socketsmith's own donning of its socket for the ch. 3 comparison. They
/// live in `pipeline`, above both the design run and the CalculiX bridge, so `calculix` needs neither
/// `pipeline` nor `contact`.

#include "socketsmith/contact/donning.h"
#include "socketsmith/calculix/design_check.h"
#include "socketsmith/pipeline/design_pipeline.h"

namespace socketsmith::pipeline {

/// The stump, its fixed (bone and cut) nodes, frame, designed positions, pressures, deformed
/// normals and areas, brim flags, front-line angle (PT landmark) and length of a design run, and
/// the socket's wall when the closed loop corrected it.
/// The result refers to @p artifacts' mesh and skin: keep them alive.
/// @throws InvalidInputError when the artifacts hold no setup.
/// @p printed_wall: also the written socket's inner wall (DesignedStump::socket_wall), for a
/// donning check of the printed socket (`validate design --printed-wall`).
calculix::DesignedStump designed_stump(const DesignArtifacts& artifacts, bool printed_wall = false);

/// CalculiX's twin of a case's tissue: E and ρ of the case; for the continuum models their own
/// ν and law (fe: *ELASTIC, St Venant–Kirchhoff under NLGEOM; neo-hookean: *HYPERELASTIC, NEO
/// HOOKE with the same C10 and D1), so both sides solve the same problem; for the MSS lattices,
/// which have no continuum twin, ν = 0.45 (the thesis's Abaqus check) and *ELASTIC.
calculix::FeMaterial fe_material(const design::CaseFile& c);

/// socketsmith's own donning of a design run's socket onto its stump (the thesis's ch. 3 check:
/// the side that CalculiX's donning is compared with): the contact solver on the run's linearised
/// stump, the socket started @p options.start_offset_m below its designed pose.
/// @throws InvalidInputError when the run has no socket (its constraints were not met);
///         SolverError when the donning does not complete, or when a standing load was asked
///         (options.stand_force_n > 0) and not reached.
contact::DonningResult don_designed_socket(const DesignArtifacts& artifacts,
                                           const contact::DonningOptions& options);

/// @p stump with its pressures replaced by @p donning's final contact pressures (same skin nodes).
/// @throws InvalidInputError when the sizes differ.
void use_donning_pressures(const contact::DonningResult& donning, calculix::DesignedStump& stump);

}  // namespace socketsmith::pipeline
