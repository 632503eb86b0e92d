#include "socketsmith/volume/hex_mesher.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iterator>
#include <map>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/geometry/surface_query.h"
#include "socketsmith/volume/hex_element.h"
#include "socketsmith/volume/hex_mesher_detail.h"

namespace socketsmith::volume {

using namespace hex_mesher_detail;

namespace {

/// The topology on the caller's cell size, or on the size whose mesh meets the node target (a few
/// builds, each size scaled by the cube root of the node ratio); @p h: in, the caller's size (0: from the
/// target); out, the size used.
Build build_for_node_target(const HexMesherInput& in, const HexMesherOptions& opt, const SkinParts& parts,
                            const SurfaceQuery& side_query, const std::vector<SurfaceQuery>& bone_queries,
                            double tissue_estimate, double& h) {
  Build b;
  if (h > 0.0) {
    b = build_topology(in, parts, side_query, h, opt.core_offset, opt.presmooth_iterations);
  } else {
    h = std::cbrt(tissue_estimate / opt.target_nodes);
    for (int it = 0; it < 6; ++it) {
      report_progress(opt.progress, 0.05 + 0.05 * it, "mesh: choosing the grid size");
      b = build_topology(in, parts, side_query, h, opt.core_offset, opt.presmooth_iterations);
      const int n = estimated_nodes(b, in.bones, bone_queries);
      const double ratio = static_cast<double>(n) / opt.target_nodes;
      log::debug("mesh_limb: h = {:.2f} mm -> {} nodes ({:.1f} % of target)", h * 1e3, n, 100 * ratio);
      if (std::abs(ratio - 1.0) < 0.04) break;
      h *= std::cbrt(ratio);
    }
  }
  return b;
}

/// How far the mesh's skin nodes and its skin quads' centres (the chordal deviation) lie from the skin.
void measure_skin_fit(const Build& b, const geometry::TriMesh& skin, HexMesherResult& res) {
  const SurfaceQuery skin_query(skin);
  for (int n = 0; n < b.mesh.num_nodes(); ++n)
    if (b.kind[n] == kSkinNode || b.kind[n] == kRimNode)
      res.max_skin_distance_m = std::max(res.max_skin_distance_m, skin_query.closest_point(b.mesh.nodes[n]).distance);
  // Chordal deviation: centres of the skin quads (not on the skin by construction) to the skin.
  {
    const SkinSurface surf = extract_skin_surface(b.mesh);
    for (const auto& q : surf.quads) {
      const Vec3 c = 0.25 * (b.mesh.nodes[q[0]] + b.mesh.nodes[q[1]] + b.mesh.nodes[q[2]] + b.mesh.nodes[q[3]]);
      res.max_face_deviation_m = std::max(res.max_face_deviation_m, skin_query.closest_point(c).distance);
    }
  }
}

/// The skin's and the bones' volumes into @p res; returns the tissue's (skin minus bones), which
/// the grid size is chosen from. @throws InvalidInputError for an inside-out skin or bones that
/// leave no tissue.
double tissue_volume_estimate(const HexMesherInput& in, HexMesherResult& res) {
  res.skin_volume_m3 = geometry::signed_volume(in.skin);
  for (const auto& bone : in.bones) res.bone_volume_m3 += geometry::signed_volume(bone);
  const double tissue_estimate = res.skin_volume_m3 - res.bone_volume_m3;
  require(res.skin_volume_m3 > 0.0, "mesh_limb: the skin encloses a volume of {:.3g} m^3 (inside-out?)",
          res.skin_volume_m3);
  // The grid size comes from the tissue's volume: bones that fill the skin would make it 0 or NaN.
  require(res.bone_volume_m3 < 0.9 * res.skin_volume_m3,
          "mesh_limb: the bones ({:.0f} % of the skin's volume) leave no tissue to mesh: bones must lie inside the "
          "skin and fill less than 90 % of it",
          100.0 * res.bone_volume_m3 / res.skin_volume_m3);
  return tissue_estimate;
}

/// Smoothing, bones and the quality check of @p b (built at @p h), into @p res's quality. At the
/// coarsest sizes (a few hundred nodes: a bone's tip a cell or two from the skin) one grid can keep a
/// few inverted elements where one 2 % finer or coarser does not, so a size chosen from
/// target_nodes is retried with the cell nudged by ±2 %, ±4 %, ±6 % before giving up; a cell size
/// the caller set is used as it is. @p h and @p b end as the last size tried and its mesh.
BoneReport smooth_and_place_bones(const HexMesherInput& in, const HexMesherOptions& opt, const SkinParts& parts,
                                  const SurfaceQuery& side_query, double& h, Build& b, HexMesherResult& res) {
  const double h_chosen = h;
  constexpr double kRetryScales[] = {1.0, 0.98, 1.02, 0.96, 1.04, 0.94, 1.06};
  const int attempts = opt.cell_size_m > 0.0 ? 1 : static_cast<int>(std::size(kRetryScales));
  BoneReport bone_report;
  for (int attempt = 0; attempt < attempts; ++attempt) {
    if (attempt > 0) {
      log::debug("mesh_limb: {} element(s) inverted at h = {:.2f} mm; retrying at {:.2f} mm", res.quality.inverted,
                 h * 1e3, h_chosen * kRetryScales[attempt] * 1e3);
      h = h_chosen * kRetryScales[attempt];
      b = build_topology(in, parts, side_query, h, opt.core_offset, opt.presmooth_iterations);
    }
    report_progress(opt.progress, 0.45, "mesh: smoothing and optimising");
    const Projector project{side_query, parts, b.grid, in.cut_height_m};
    smooth(b, project, opt.smoothing_iterations, opt.quality_goal);

    report_progress(opt.progress, 0.75, "mesh: bones");
    bone_report = apply_bones(b.mesh, in.bones, b.kind, project, b.grid.h, opt.bone_quality_goal);
    compact(b.mesh, b.kind);
    res.quality = hex_quality(b.mesh);
    if (res.quality.inverted == 0) {
      if (attempt > 0)
        res.notes.push_back(fmt::format("grid cell {:+.0f} % off the size for {} nodes: that size left inverted "
                                        "elements",
                                        100 * (kRetryScales[attempt] - 1.0), opt.target_nodes));
      break;
    }
  }
  return bone_report;
}

/// The build's counts and notes (grid cells changed, core parts dropped, what the bones did) into @p res.
void note_build(const Build& b, const BoneReport& bone_report, bool has_bones, HexMesherResult& res) {
  res.core_hexahedra = b.core_hexahedra;
  res.pillow_hexahedra = b.pillow_hexahedra;
  if (b.manifold_changes > 0)
    res.notes.push_back(fmt::format("{} grid cells added or removed to keep the core manifold", b.manifold_changes));
  if (b.components_dropped > 0)
    res.notes.push_back(fmt::format("{} small disconnected core part(s) dropped", b.components_dropped));
  res.removed_bone_hexahedra = bone_report.removed;
  if (has_bones)
    res.notes.push_back(fmt::format("bones: {} nodes snapped onto bone surfaces, {} held in place (quality), {} "
                                    "elements inside bones removed",
                                    bone_report.snapped, bone_report.held, bone_report.removed));
}

/// The node tags from the nodes' kinds: skin and rim nodes on the surface, rim and top-plane nodes
/// proximal (and fixed when @p fix_proximal).
void tag_nodes(Build& b, bool fix_proximal) {
  for (int n = 0; n < b.mesh.num_nodes(); ++n) {
    if (b.kind[n] == kSkinNode) b.mesh.node_tags[n] |= kNodeSurface;
    if (b.kind[n] == kRimNode) b.mesh.node_tags[n] |= kNodeSurface | kNodeProximal;
    if (b.kind[n] == kTopPlane) b.mesh.node_tags[n] |= kNodeProximal;
    if (fix_proximal && (b.kind[n] == kTopPlane || b.kind[n] == kRimNode)) b.mesh.node_tags[n] |= kNodeFixed;
  }
}

}  // namespace

HexMesherResult mesh_limb(const HexMesherInput& in, const HexMesherOptions& opt) {
  const auto t0 = std::chrono::steady_clock::now();
  require(opt.cell_size_m > 0.0 || opt.target_nodes >= 100,
          "mesh_limb: target of {} nodes is too small (expected at least 100)", opt.target_nodes);
  require(opt.core_offset >= 0.0 && opt.core_offset <= 2.0, "mesh_limb: core_offset {} outside [0, 2]",
          opt.core_offset);
  require(in.first_cap_triangle >= 0 && in.first_cap_triangle < in.skin.num_triangles(),
          "mesh_limb: the skin has no proximal cap (first_cap_triangle = {}); trim and cap it first",
          in.first_cap_triangle);
  const SkinParts parts = split_skin(in);
  require<TopologyError>(!parts.rim.empty(), "mesh_limb: the skin's cap does not meet its side");
  const SurfaceQuery side_query(parts.side);
  std::vector<SurfaceQuery> bone_queries;
  for (const auto& bone : in.bones) bone_queries.emplace_back(bone);

  HexMesherResult res;
  const double tissue_estimate = tissue_volume_estimate(in, res);
  // Grid size: from the target node count, refined by building the topology.
  double h = opt.cell_size_m;
  Build b = build_for_node_target(in, opt, parts, side_query, bone_queries, tissue_estimate, h);
  const BoneReport bone_report = smooth_and_place_bones(in, opt, parts, side_query, h, b, res);
  res.cell_size_m = h;
  note_build(b, bone_report, !in.bones.empty(), res);
  tag_nodes(b, opt.fix_proximal);

  // Report.
  require<TopologyError>(res.quality.inverted == 0,
                         "mesh_limb: {} element(s) remain inverted after optimisation (min scaled Jacobian "
                         "{:.3f}); try another stump size (mesh.target_nodes in a case file, --target-nodes on the "
                         "command line) or check the skin for folds",
                         res.quality.inverted, res.quality.min_scaled_jacobian);
  measure_skin_fit(b, in.skin, res);
  res.mesh_volume_m3 = total_volume(b.mesh);
  res.tissue_volume_m3 = res.mesh_volume_m3;
  res.mesh = std::move(b.mesh);
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  report_progress(opt.progress, 1.0, "mesh: done");
  return res;
}

geometry::TriMesh SkinSurface::triangles() const {
  geometry::TriMesh m;
  m.vertices = positions;
  std::map<int, int> local;
  for (size_t i = 0; i < nodes.size(); ++i) local[nodes[i]] = static_cast<int>(i);
  for (const auto& q : quads) {
    m.triangles.push_back({local.at(q[0]), local.at(q[1]), local.at(q[2])});
    m.triangles.push_back({local.at(q[0]), local.at(q[2]), local.at(q[3])});
  }
  return m;
}

std::vector<std::vector<int>> SkinSurface::neighbours() const {
  std::map<int, int> local;
  for (size_t i = 0; i < nodes.size(); ++i) local[nodes[i]] = static_cast<int>(i);
  auto nb = hex_mesher_detail::quad_edge_neighbours(quads, [&local](const std::array<int, 4>& q) {
    return std::array<int, 4>{local.at(q[0]), local.at(q[1]), local.at(q[2]), local.at(q[3])};
  });
  nb.resize(nodes.size());
  return nb;
}

SkinSurface extract_skin_surface(const HexMesh& mesh) {
  SkinSurface s;
  std::vector<int> local(mesh.nodes.size(), -1);
  for (const auto& bq : boundary_quads(mesh)) {
    bool skin = true;
    for (int n : bq.nodes) skin = skin && mesh.has_tag(n, kNodeSurface);
    if (!skin) continue;
    // A quad on the cut plane has only proximal nodes; skin quads have at least one non-rim node.
    bool all_proximal = true;
    for (int n : bq.nodes) all_proximal = all_proximal && mesh.has_tag(n, kNodeProximal);
    if (all_proximal) continue;
    s.quads.push_back(bq.nodes);
    const Vec3 a = mesh.nodes[bq.nodes[0]], b = mesh.nodes[bq.nodes[1]], c = mesh.nodes[bq.nodes[2]],
               d = mesh.nodes[bq.nodes[3]];
    const Vec3 an = 0.5 * (c - a).cross(d - b);  // area vector of the (possibly warped) quad
    for (int n : bq.nodes) {
      if (local[n] < 0) {
        local[n] = static_cast<int>(s.nodes.size());
        s.nodes.push_back(n);
        s.area_m2.push_back(0.0);
        s.normal.push_back(Vec3::Zero());
        s.positions.push_back(mesh.nodes[n]);
      }
      s.area_m2[local[n]] += 0.25 * an.norm();
      s.normal[local[n]] += an;
    }
  }
  for (auto& n : s.normal)
    if (n.squaredNorm() > 0) n.normalize();
  return s;
}

}  // namespace socketsmith::volume

