#include "socketsmith/pipeline/stump_mesh.h"

#include <algorithm>
#include <vector>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/log.h"
#include "socketsmith/core/units.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/report/limb_views.h"
#include "socketsmith/report/vtk_writer.h"
#include "socketsmith/tissue/pressure_load.h"
#include "socketsmith/tissue/tissue_model_json.h"
#include "socketsmith/volume/hex_element.h"

namespace socketsmith::pipeline {
namespace {

using geometry::Vec3;

nlohmann::json landmark_json(const volume::Landmark& l) {
  return {{"code", l.code},
          {"name", l.name},
          {"position_mm", {l.position.x() * 1e3, l.position.y() * 1e3, l.position.z() * 1e3}},
          {"theta_deg", l.cylindrical.theta / units::deg},
          {"h_mm", l.cylindrical.h * 1e3},
          {"rho_mm", l.cylindrical.rho * 1e3},
          {"radius_mm", l.radius_m * 1e3},
          {"estimated", l.estimated}};
}

/// Landmark zone of each node: index of the nearest landmark within its radius, else -1.
std::vector<double> landmark_zones(const volume::HexMesh& mesh, const std::vector<volume::Landmark>& landmarks) {
  std::vector<double> zone(mesh.num_nodes(), -1.0);
  for (int n = 0; n < mesh.num_nodes(); ++n) {
    if (!mesh.has_tag(n, volume::kNodeSurface)) continue;
    double best = 1e30;
    for (size_t k = 0; k < landmarks.size(); ++k) {
      const double d = (mesh.nodes[n] - landmarks[k].position).norm();
      if (d <= landmarks[k].radius_m && d < best) {
        best = d;
        zone[n] = static_cast<double>(k);
      }
    }
  }
  return zone;
}

/// The smallest corner scaled Jacobian of each hexahedron.
std::vector<double> min_scaled_jacobians(const volume::HexMesh& mesh) {
  std::vector<double> sj(mesh.num_hexahedra());
  for (int e = 0; e < mesh.num_hexahedra(); ++e) {
    const auto c = volume::corner_scaled_jacobians(volume::gather(mesh.nodes, mesh.hexahedra[e]));
    sj[e] = *std::min_element(c.begin(), c.end());
  }
  return sj;
}

/// The stump solved under the test pressure: its displacement added to @p point_fields; returns
/// the summary's "load" entry.
nlohmann::json solve_test_load(const StumpMeshRequest& q, const volume::HexMesh& mesh,
                               std::vector<report::VtkField>& point_fields) {
  report_progress(q.progress, 0.9, "mesh: static solve under the test pressure");
  const auto pr = tissue::solve_uniform_pressure(mesh, q.test_pressure_pa, q.material, q.model);
  std::vector<Vec3> u(mesh.num_nodes());
  for (int n = 0; n < mesh.num_nodes(); ++n) u[n] = pr.positions.segment<3>(3 * n) - mesh.nodes[n];
  point_fields.push_back(report::make_vector_field("displacement_m", u));
  nlohmann::json load_json = {{"pressure_kpa", q.test_pressure_pa / units::kPa},
                              {"converged", pr.solve.converged},
                              {"newton_iterations", pr.solve.iterations},
                              {"load_steps", pr.solve.load_steps},
                              {"max_displacement_mm", pr.max_displacement_m * 1e3},
                              {"mean_skin_displacement_mm", pr.mean_skin_displacement_m * 1e3},
                              {"volume_change", pr.volume_change},
                              {"setup_s", pr.seconds_setup},
                              {"solve_s", pr.seconds_solve},
                              {"model", tissue::tissue_model_json(q.model, q.material)}};
  log::info("mesh: {:.1f} kPa inward: max displacement {:.2f} mm, volume change {:.2f} %, solved in {:.2f} s",
            q.test_pressure_pa / units::kPa, pr.max_displacement_m * 1e3, 100 * pr.volume_change, pr.seconds_solve);
  return load_json;
}

/// The limb's picture, its skin and bones as STL, and the mesh's skin surface with its nodal
/// areas and normals.
void write_limb_files(const std::filesystem::path& out, const StumpMeshRequest& q, const volume::LimbModel& model,
                      const volume::HexMesh& mesh) {
  namespace fs = std::filesystem;
  report::write_png(out / "limb.png",
                    report::render_limb_views(model.skin, model.bones, model.landmarks, model.frame,
                                              fs::path(q.limb_file).filename().string() + ": landmarks",
                                              model.bones_estimated));
  geometry::write_mesh(out / "skin.stl", model.skin);
  if (!model.bones.empty()) {
    geometry::TriMesh all;
    for (const auto& b : model.bones) {
      const int off = all.num_vertices();
      all.vertices.insert(all.vertices.end(), b.mesh.vertices.begin(), b.mesh.vertices.end());
      for (auto t : b.mesh.triangles) all.triangles.push_back({t[0] + off, t[1] + off, t[2] + off});
    }
    geometry::write_mesh(out / (model.bones_estimated ? "bones_estimated.stl" : "bones.stl"), all);
  }
  const auto surf = volume::extract_skin_surface(mesh);
  geometry::TriMesh tri = surf.triangles();
  std::vector<double> area(surf.area_m2), nodeid(surf.nodes.begin(), surf.nodes.end());
  report::write_vtp(out / "skin_surface.vtp", tri,
                    {{"nodal_area_m2", 1, area}, report::make_vector_field("normal", surf.normal), {"node", 1, nodeid}});
}

/// mesh.json: the mesh's counts and quality, the volumes, the limb's frame, landmarks and notes,
/// and the test load's result when there was one.
nlohmann::json mesh_summary(const StumpMeshRequest& q, const volume::LimbModel& model, const volume::HexMesherResult& r,
                            const nlohmann::json& load_json) {
  const double tissue_ref = r.skin_volume_m3 - r.bone_volume_m3;
  nlohmann::json lms = nlohmann::json::array();
  for (const auto& l : model.landmarks) lms.push_back(landmark_json(l));
  std::vector<std::string> bone_names;
  for (const auto& b : model.bones) bone_names.push_back(b.name);
  nlohmann::json j{
      {"limb", q.limb_file},
      {"type", geometry::to_string(model.type)},
      {"nodes", r.mesh.num_nodes()},
      {"hexahedra", r.mesh.num_hexahedra()},
      {"target_nodes", q.target_nodes},
      {"fixed_nodes", r.mesh.count_tag(volume::kNodeFixed)},
      {"bone_nodes", r.mesh.count_tag(volume::kNodeBone)},
      {"surface_nodes", r.mesh.count_tag(volume::kNodeSurface)},
      {"proximal_nodes", r.mesh.count_tag(volume::kNodeProximal)},
      {"cell_size_mm", r.cell_size_m * 1e3},
      {"min_scaled_jacobian", r.quality.min_scaled_jacobian},
      {"mean_scaled_jacobian", r.quality.mean_scaled_jacobian},
      {"max_aspect_ratio", r.quality.max_aspect_ratio},
      {"max_skin_distance_m", r.max_skin_distance_m},
      {"max_face_deviation_m", r.max_face_deviation_m},
      {"volume_m3", r.tissue_volume_m3},
      {"skin_volume_m3", r.skin_volume_m3},
      {"bone_volume_m3", r.bone_volume_m3},
      {"tissue_volume_error", tissue_ref > 0 ? r.tissue_volume_m3 / tissue_ref - 1.0 : 0.0},
      {"bones_estimated", model.bones_estimated},
      {"bones", bone_names},
      {"cut_height_mm", model.cut_height_m * 1e3},
      {"frame",
       {{"origin_mm", {model.frame.origin.x() * 1e3, model.frame.origin.y() * 1e3, model.frame.origin.z() * 1e3}},
        {"axis", {model.frame.axis.x(), model.frame.axis.y(), model.frame.axis.z()}},
        {"anterior", {model.frame.anterior.x(), model.frame.anterior.y(), model.frame.anterior.z()}},
        {"anterior_estimated", model.frame.anterior_estimated},
        {"side", geometry::to_string(model.frame.side)},
        {"side_estimated", model.frame.side_estimated}}},
      {"landmarks", lms},
      {"mesh_seconds", r.seconds},
      {"notes", model.notes},
      {"outputs", {"stump.vtu", "skin_surface.vtp", "skin.stl", "limb.png", "mesh.json"}}};
  for (const auto& n : r.notes) j["notes"].push_back(n);
  if (!load_json.is_null()) j["load"] = load_json;
  return j;
}

}  // namespace

StumpMesh run_stump_mesh(const volume::LimbModel& model, const StumpMeshRequest& q, const std::filesystem::path& out) {
  volume::HexMesherOptions mo;
  mo.target_nodes = q.target_nodes;
  mo.progress = q.progress;
  StumpMesh m;
  m.mesher = volume::mesh_limb(volume::mesher_input(model), mo);
  const volume::HexMesherResult& r = m.mesher;
  for (const auto& n : r.notes) log::info("mesh: {}", n);

  ensure_directory(out);
  const std::vector<double> zone = landmark_zones(r.mesh, model.landmarks);
  const std::vector<double> sj = min_scaled_jacobians(r.mesh);
  std::vector<report::VtkField> point_fields{{"landmark_zone", 1, zone}};
  const nlohmann::json load_json =
      q.test_pressure_pa > 0.0 ? solve_test_load(q, r.mesh, point_fields) : nlohmann::json();
  report::write_vtu(out / "stump.vtu", r.mesh, point_fields, {{"min_scaled_jacobian", 1, sj}});
  write_limb_files(out, q, model, r.mesh);
  m.summary = mesh_summary(q, model, r, load_json);
  write_text_atomically(out / "mesh.json", m.summary.dump(2) + "\n");
  return m;
}

}  // namespace socketsmith::pipeline
