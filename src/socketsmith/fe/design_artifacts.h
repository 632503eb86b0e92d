#pragma once
/// @file design_artifacts.h
/// The designed state of a pipeline run as the FE check's input.

#include "socketsmith/fe/design_check.h"
#include "socketsmith/pipeline/design_pipeline.h"

namespace socketsmith::fe {

/// The stump, its fixed (bone and cut) nodes, frame, designed positions, pressures, deformed
/// normals and areas, brim flags, front-line angle (PT landmark) and length of a design run.
/// The result refers to @p artifacts' mesh and skin: keep them alive.
/// @throws InvalidInputError when the artifacts hold no setup.
DesignedStump designed_stump(const pipeline::DesignArtifacts& artifacts);

}  // namespace socketsmith::fe
