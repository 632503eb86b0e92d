#pragma once
/// The shells of a limb file (inside `volume` only; `limb_model.h` is the interface): each closed
/// surface measured in the limb frame, the bones named by where they lie, trimmed at the cut, and the
/// transfemoral roles (femur, hemipelvis). Why apart: `prepare_limb` (`limb_model.cpp`) decides what
/// the limb is; reading its shells is a step of its own.

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::volume::limb_shells {

using geometry::LimbFrame;
using geometry::TriMesh;
using geometry::Vec3;

/// One closed surface of the limb file, measured in the limb frame, and its name once a bone.
struct Shell {
  TriMesh mesh;
  double area = 0.0;
  double h_min = 0.0, h_max = 0.0;
  double volume = 0.0;
  double outside_m = 0.0;  ///< how far the shell pokes out of the skin (tolerated up to 1 mm)
  Vec3 centroid = Vec3::Zero();
  std::string name;
};

/// The midpoint of the first edge shared by more than two triangles, or nullopt.
std::optional<Vec3> first_non_manifold_edge(const TriMesh& mesh);

/// Height range, centroid and signed volume of @p s in @p frame.
void measure(Shell& s, const LimbFrame& frame);

/// Names bone shells by anatomy: transtibial — the most distal is the tibia, the next elongated
/// one reaching below mid-height the fibula, the most proximal the femur, a small compact one
/// near the knee the patella; transfemoral — the most distal is the femur.
void name_bones(std::vector<Shell>& bones, geometry::LimbType type, double cut);

/// Trims and caps a shell; returns false when nothing of it lies below the cut.
bool trim(Shell& s, const LimbFrame& frame, double cut);

/// Length along its principal direction over its largest width (a femur: 4–10; a hemipelvis: 1–2).
double elongation(const TriMesh& m);

/// Transfemoral roles of the bone shells (before the cut): the femur is the most elongated shell
/// (at least 2.5 × as long as wide), the hemipelvis the largest other shell of more than 20 cm³.
/// Returns their indices (-1 when absent).
std::pair<int, int> transfemoral_roles(const std::vector<Shell>& shells);

}  // namespace socketsmith::volume::limb_shells
