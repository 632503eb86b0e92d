#include "socketsmith/geometry/mesh_report.h"

#include "socketsmith/core/units.h"
#include "socketsmith/geometry/mesh_checks.h"

namespace socketsmith::geometry {

nlohmann::json mesh_report_json(const std::string& file, const TriMesh& mesh, const MeshReadInfo& info) {
  MeshCheckOptions co;
  co.find_self_intersections = true;
  const auto rep = check_mesh(mesh, co);
  const auto box = bounding_box(mesh);
  nlohmann::json j{{"file", file},
                   {"format", info.format},
                   {"unit", units::to_string(info.unit)},
                   {"unit_guessed", info.unit_was_guessed},
                   {"vertices", rep.num_vertices},
                   {"triangles", rep.num_triangles},
                   {"bounding_box_m", {box.extent().x(), box.extent().y(), box.extent().z()}},
                   {"components", rep.connected_components},
                   {"boundary_loops", rep.boundary_loops},
                   {"boundary_edges", rep.boundary_edges},
                   {"non_manifold_edges", rep.non_manifold_edges},
                   {"inconsistently_oriented_edges", rep.inconsistently_oriented_edges},
                   {"degenerate_triangles", rep.degenerate_triangles},
                   {"self_intersecting_pairs", rep.self_intersecting_pairs},
                   {"closed", rep.is_closed()},
                   {"signed_volume_m3", rep.signed_volume_m3},
                   {"problems", rep.problems()}};
  if (!info.warning.empty()) j["warning"] = info.warning;
  if (!info.landmarks.empty()) {
    nlohmann::json lms = nlohmann::json::array();
    for (const auto& lm : info.landmarks) {
      nlohmann::json pts = nlohmann::json::array();
      for (const auto& p : lm.points) pts.push_back({p.x() * 1e3, p.y() * 1e3, p.z() * 1e3});
      lms.push_back({{"name", lm.name}, {"points_mm", pts}});
    }
    j["landmarks"] = lms;
  }
  return j;
}

}  // namespace socketsmith::geometry
