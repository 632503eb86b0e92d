#pragma once
/// @file hex_mesher.h
/// Hexahedral mesher of a residual limb: an axis-aligned grid core inside the skin, a pillow
/// layer of hexahedra whose outer nodes lie on the skin (not a voxel staircase), smoothing and
/// quality optimisation, bone nodes fixed, elements wholly inside bones removed.
///
/// Method (grid-based "core + pillow", as in Schneiders 1996 and Zhang's meshers):
/// 1. a grid of cell size h aligned with the limb frame, its top plane on the proximal cut;
/// 2. grid nodes classified inside/outside the skin by scan-line parity, with their distance to
///    the skin; core = cells whose 8 corners are inside and at least `core_offset`·h from it;
///    largest component kept, cavities filled, non-manifold edges/vertices of the core boundary
///    repaired by adding or removing cells;
/// 3. every core boundary quad (except those on the cut plane) is extruded into one hexahedron
///    whose outer face lies on the skin (nodes cast along the averaged quad normal, rim nodes on
///    the cut loop);
/// 4. surface nodes smoothed tangentially and re-projected, then a quality pass moves nodes of
///    elements whose scaled Jacobian is low;
/// 5. nodes inside bones tagged fixed + bone; elements with all 8 nodes in bone removed.

#include <string>
#include <vector>

#include "socketsmith/core/progress.h"
#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/geometry/tri_mesh.h"
#include "socketsmith/volume/hex_mesh.h"

namespace socketsmith::volume {

/// The domain to mesh.
struct HexMesherInput {
  geometry::TriMesh skin;            ///< closed, outward; the proximal cap lies in the cut plane
  int first_cap_triangle = -1;       ///< skin triangles from here on are the planar cap (-1: none)
  geometry::LimbFrame frame;         ///< grid axes follow the frame; cut plane is h = cut_height_m
  double cut_height_m = 0.0;         ///< height of the proximal cut plane above the distal end
  std::vector<geometry::TriMesh> bones;  ///< closed bone surfaces (capped at the cut when crossing it)
};

struct HexMesherOptions {
  int target_nodes = 8000;      ///< aimed-at node count of the final mesh (±15 %; ±25 % at a few hundred nodes)
  double cell_size_m = 0.0;     ///< > 0: use this grid size and ignore target_nodes
  double core_offset = 0.5;     ///< core corners at least this many cells from the skin
  int presmooth_iterations = 8;  ///< rounding of the core staircase before the pillow
  int smoothing_iterations = 8;
  double quality_goal = 0.35;   ///< the optimiser works on elements below this scaled Jacobian
  double bone_quality_goal = 0.3;  ///< snapping nodes onto bones never spoils an element below this
  bool fix_proximal = true;     ///< fix the nodes of the proximal cut plane (tissue held by the thigh)
  ProgressCallback progress;
};

/// Meshing result and its quality report.
struct HexMesherResult {
  HexMesh mesh;                    ///< tags: kNodeSurface (skin), kNodeProximal, kNodeBone, kNodeFixed
  double cell_size_m = 0.0;
  HexQuality quality;
  double max_skin_distance_m = 0.0;   ///< max distance of a skin-surface node to the skin
  double max_face_deviation_m = 0.0;  ///< max distance of a skin-quad centre to the skin (chord error)
  double skin_volume_m3 = 0.0;        ///< enclosed by the closed skin
  double bone_volume_m3 = 0.0;        ///< enclosed by the bones (inside the skin, below the cut)
  double mesh_volume_m3 = 0.0;        ///< sum of the element volumes (soft tissue + bone-crossing)
  double tissue_volume_m3 = 0.0;      ///< volume of the mesh once all-bone elements are removed and
                                      ///< the bone interface is snapped (compare: skin − bone)
  int core_hexahedra = 0;
  int pillow_hexahedra = 0;
  int removed_bone_hexahedra = 0;
  double seconds = 0.0;
  std::vector<std::string> notes;
};

/// Meshes the soft tissue. @throws InvalidInputError on bad options (target_nodes < 100),
/// TopologyError when the core is empty (limb too thin for the requested size) or an element
/// stays inverted after optimisation.
HexMesherResult mesh_limb(const HexMesherInput& input, const HexMesherOptions& options = {});

/// Outer skin surface of a limb mesh, ready for pressures: the boundary quads that are not on a
/// bone interface nor on the proximal cut, as triangles, with per-node area and outward normal.
struct SkinSurface {
  std::vector<int> nodes;              ///< mesh node ids of the skin surface
  std::vector<double> area_m2;         ///< nodal area (a quarter of each incident quad)
  std::vector<Vec3> normal;            ///< outward unit normal (area-weighted over the quads)
  std::vector<std::array<int, 4>> quads;  ///< outward quads, mesh node ids
  geometry::TriMesh triangles() const;     ///< quads split in two; vertices = local surface ids
  /// Each surface node's neighbours along the quads' edges, as local surface ids, sorted.
  std::vector<std::vector<int>> neighbours() const;
  std::vector<Vec3> positions;         ///< copy of the node positions (for triangles())
};
SkinSurface extract_skin_surface(const HexMesh& mesh);

}  // namespace socketsmith::volume
