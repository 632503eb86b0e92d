#pragma once
/// @file stump_mesh.h
/// A prepared limb meshed into the hexahedral stump as `socketsmith mesh` does it (docs/cli.md),
/// with its files: stump.vtu (each skin node's landmark zone, each hexahedron's smallest scaled
/// Jacobian, the displacement under the test pressure when there is one), skin_surface.vtp (nodal
/// areas and normals), skin.stl and the bones' STL, limb.png (the landmarks) and mesh.json. The
/// CLI reads the files and the user's landmarks into the limb (volume::prepare_limb) and prints
/// the summary.

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "socketsmith/core/progress.h"
#include "socketsmith/tissue/mass_spring_model.h"
#include "socketsmith/volume/hex_mesher.h"
#include "socketsmith/volume/limb_model.h"

namespace socketsmith::pipeline {

struct StumpMeshRequest {
  std::string limb_file;   ///< the limb's file as given: mesh.json's "limb", its name in the picture's title
  int target_nodes = 8000; ///< aimed-at node count (volume::HexMesherOptions)
  /// Also solve the stump under this uniform inward skin pressure [Pa], ≥ 0 (0: no test load).
  double test_pressure_pa = 0.0;
  tissue::MassSpringOptions model;    ///< the tissue model of the test load
  tissue::TissueMaterial material;
  ProgressCallback progress;          ///< the mesher's, then 0.9 the test load
};

struct StumpMesh {
  volume::HexMesherResult mesher;
  nlohmann::json summary;  ///< mesh.json
};

/// Meshes @p limb (volume::mesh_limb), solves the test load when asked and writes the files above
/// into @p out (created).
/// @throws as volume::mesh_limb; IoError when a file cannot be written.
StumpMesh run_stump_mesh(const volume::LimbModel& limb, const StumpMeshRequest& request,
                         const std::filesystem::path& out);

}  // namespace socketsmith::pipeline
