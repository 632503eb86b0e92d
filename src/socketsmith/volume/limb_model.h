#pragma once
/// @file limb_model.h
/// From a limb file (skin, maybe open, maybe with bone shells) to a prepared limb: closed skin
/// trimmed at a plane normal to the axis, named closed bones inside it (or estimated ones), the
/// limb frame, and the landmarks — everything the hexahedral mesher and the design need.

#include <optional>
#include <string>
#include <vector>

#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/geometry/mesh_repair.h"
#include "socketsmith/geometry/tri_mesh.h"
#include "socketsmith/volume/bone_template.h"
#include "socketsmith/volume/hex_mesh.h"
#include "socketsmith/volume/hex_mesher.h"
#include "socketsmith/volume/landmarks.h"

namespace socketsmith::volume {

/// How to read the limb. Every field may be left at its default.
struct LimbInputOptions {
  geometry::LimbType type = geometry::LimbType::Transtibial;
  std::optional<Vec3> anterior;               ///< world direction of the front (overrides estimates)
  std::optional<geometry::Side> side;         ///< overrides the side derived from bones
  std::optional<double> cut_height_m;         ///< proximal cut above the distal end [m]
  double cut_margin_m = 0.005;                ///< default cut: this far below the open rim's lowest point
  bool estimate_bones = true;                 ///< estimate bones when none are given
};

/// A limb ready for meshing.
struct LimbModel {
  geometry::LimbType type = geometry::LimbType::Transtibial;
  geometry::TriMesh skin;           ///< closed, outward, trimmed; cap triangles at the end
  int first_cap_triangle = -1;      ///< skin triangles from here on are the proximal cap
  std::vector<NamedMesh> bones;     ///< closed, trimmed at the cut, inside the skin
  bool bones_estimated = false;
  geometry::LimbFrame frame;
  double cut_height_m = 0.0;        ///< h of the proximal cut plane
  double length_m = 0.0;            ///< = cut_height_m (distal end at h = 0)
  std::vector<Landmark> landmarks;
  std::vector<std::string> notes;   ///< repairs and automatic decisions, one line each
};

/// Prepares a limb. @p limb may hold the skin and bone shells; @p extra_bones (may be empty) holds
/// bones from a separate file. Shells are told apart by size and containment (the skin is the
/// shell of largest area; bones must lie inside it).
/// @throws InvalidInputError / TopologyError with one line naming the problem and the fix: not
/// limb-like (sphere, box), holes that cannot be closed, bones outside the skin, a cut outside
/// the limb, a limb of implausible size (wrong units).
LimbModel prepare_limb(const geometry::TriMesh& limb, const geometry::TriMesh& extra_bones,
                       const LimbInputOptions& options = {});

/// The mesher's input for a prepared limb (closed skin with its cap, frame, cut, bone surfaces).
HexMesherInput mesher_input(const LimbModel& model);

}  // namespace socketsmith::volume
