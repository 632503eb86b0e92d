// The socket's files of a design and its entry in design.json (design_socket_outputs.h says why
// this is apart from design_outputs.cpp).
#include "socketsmith/pipeline/design_socket_outputs.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "socketsmith/core/units.h"
#include "socketsmith/report/vtk_writer.h"

namespace socketsmith::pipeline {
namespace {

namespace fs = std::filesystem;
using geometry::Vec3;

nlohmann::json vec_json(const Vec3& v) { return {v.x(), v.y(), v.z()}; }

/// The socket's entry of design.json: file, wall thickness, volumes, levels, alignment, platform and
/// attachment.
nlohmann::json socket_json(const design::CaseFile& c, const design::SocketResult& sock, const report::ReportSocket& rs) {
  nlohmann::json levels = nlohmann::json::array();
  for (const auto& l : sock.levels) {
    levels.push_back({{"h_mm", l.h_m * 1e3},
                      {"socket_mm", l.inner_circumference_m * 1e3},
                      {"limb_mm", l.limb_circumference_m * 1e3},
                      {"reduction_percent", l.reduction_percent}});
  }
  nlohmann::json socket_json = {{"file", "socket.stl"},
                                {"triangles", sock.solid.num_triangles()},
                                {"thickness_mm", c.socket.thickness_m * 1e3},
                                {"min_thickness_mm", sock.min_thickness_m * 1e3},
                                {"median_thickness_mm", sock.median_thickness_m * 1e3},
                                {"max_thickness_mm", sock.max_thickness_m * 1e3},
                                {"min_thickness_ratio", sock.min_thickness_ratio},
                                {"thickness_map", "thickness_map.png"},
                                {"thickness_field", "socket.vtp"},
                                {"shell_volume_cm3", sock.shell_volume_m3 * 1e6},
                                {"cavity_volume_cm3", sock.cavity_volume_m3 * 1e6},
                                {"limb_volume_below_brim_cm3", rs.limb_volume_m3 * 1e6},
                                {"volume_reduction_percent",
                                 rs.limb_volume_m3 > 0 ? 100 * (1 - sock.cavity_volume_m3 / rs.limb_volume_m3) : 0.0},
                                {"levels", levels}};
  if (c.socket.distal_thickness_m > 0 || c.socket.brim_thickness_m > 0)
    socket_json["asked_thickness_mm"] = {
        {"distal", design::asked_thickness_m(c.socket, 0.0, 1.0) * 1e3},
        {"brim", design::asked_thickness_m(c.socket, 1.0, 1.0) * 1e3}};
  socket_json["alignment"] = {{"flexion_deg", c.socket.alignment.flexion_rad / units::deg},
                              {"adduction_deg", c.socket.alignment.adduction_rad / units::deg}};
  if (sock.platform.is_built) {
    const auto& pl = sock.platform;
    nlohmann::json holes = nlohmann::json::array();
    for (const auto& h : pl.hole_centres) holes.push_back(vec_json(h * 1e3));
    socket_json["platform"] = {{"centre_mm", vec_json(pl.centre * 1e3)},
                               {"normal", vec_json(pl.normal)},
                               {"diameter_mm", pl.diameter_m * 1e3},
                               {"height_mm", pl.max_height_m * 1e3}};
    if (c.socket.attachment.enabled)
      socket_json["attachment"] = {{"bolt", c.socket.attachment.bolt},
                                   {"hole_diameter_mm", pl.hole_diameter_m * 1e3},
                                   {"hole_spacing_mm", c.socket.attachment.hole_spacing_m * 1e3},
                                   {"hole_centres_mm", holes},
                                   {"min_hole_depth_mm", pl.min_hole_depth_m * 1e3},
                                   {"smallest_feature_mm", pl.smallest_feature_m * 1e3}};
  }
  return socket_json;
}

/// socket.vtp (the wall thickness per vertex, the face kinds) and thickness_map.png, into the
/// report's socket section too.
void write_wall_thickness(const design::CaseFile& c, const design::SocketResult& sock,
                          const report::SurfaceFrame& sframe, const fs::path& out, report::ReportSocket& rs) {
  // The wall thickness: a map of the outer surface, and the field per vertex for ParaView
  // (0 on the inner wall; the cell field face_kind: 0 inner, 1 outer, 2 lip, 3 platform, 4 hole).
  std::vector<double> t_mm(sock.solid.vertices.size()), t_field(sock.solid.vertices.size());
  for (size_t v = 0; v < t_mm.size(); ++v) {
    t_mm[v] = sock.vertex_thickness_m[v] * 1e3;
    t_field[v] = std::isnan(t_mm[v]) ? 0.0 : t_mm[v];
  }
  std::vector<double> kind(sock.face_kind.size());
  for (size_t f = 0; f < kind.size(); ++f) kind[f] = static_cast<double>(sock.face_kind[f]);
  report::write_vtp(out / "socket.vtp", sock.solid, {{"wall_thickness_mm", 1, t_field}}, {{"face_kind", 1, kind}});
  report::PressureMapData tm;
  tm.surface = &sock.solid;
  tm.values = std::move(t_mm);
  tm.value_label = "mm";
  tm.colormap = report::Colormap::Viridis;
  tm.title = "Wall thickness (distance to the inner wall)";
  tm.frame = sframe;
  tm.value_min = 0;
  tm.value_max = std::max(1.5 * c.socket.thickness_m, sock.max_thickness_m) * 1e3;
  report::write_pressure_map(out / "thickness_map.png", tm);
  rs.thickness_map = tm;
  rs.has_thickness_map = true;
  rs.min_thickness_m = sock.min_thickness_m;
  rs.median_thickness_m = sock.median_thickness_m;
  rs.max_thickness_m = sock.max_thickness_m;
}

/// The socket's lines of the report (ischial tuberosity, platform, attachment) and the ischial check
/// in design.json.
void add_socket_details(const DesignSetup& setup, const DesignResult& result, report::ReportSocket& rs,
                        nlohmann::json& socket_json) {
  const design::CaseFile& c = setup.case_file;
  const auto& sock = *result.socket;
  if (result.ischial_check && result.ischial_check->applies) {
    const auto& ic = *result.ischial_check;
    rs.details.push_back({"ischial tuberosity (3D)", ic.summary + (ic.met ? "" : " — NOT as the template means")});
    socket_json["ischial_check"] = {
        {"kind", ic.kind},
        {"met", ic.met},
        {"inside_cavity", ic.inside_cavity},
        {"cavity_margin_mm", ic.cavity_margin_m * 1e3},
        {"height_margin_mm", ic.height_margin_m * 1e3},
        {"tuberosity_mm", vec_json(ic.tuberosity * 1e3)},
        {"tuberosity_h_mm", ic.tuberosity_h_m * 1e3},
        {"tuberosity_theta_deg", ic.tuberosity_theta_rad / units::deg},
        {"tuberosity_estimated", setup.model.transfemoral && setup.model.transfemoral->estimated},
        {"brim_h_mm", ic.brim_h_m * 1e3},
        {"summary", ic.summary}};
  }
  if (sock.platform.is_built) {
    rs.details.push_back({"distal platform", fmt::format("{:.0f} mm across, normal to the pylon (flexion {:.1f}°, "
                                                         "adduction {:.1f}°)",
                                                         sock.platform.diameter_m * 1e3,
                                                         c.socket.alignment.flexion_rad / units::deg,
                                                         c.socket.alignment.adduction_rad / units::deg)});
    if (c.socket.attachment.enabled)
      rs.details.push_back({"attachment", fmt::format("4 × {:.1f} mm holes ({} bolts) on a {:.1f} mm square, at least "
                                                      "{:.1f} mm deep",
                                                      sock.platform.hole_diameter_m * 1e3, c.socket.attachment.bolt,
                                                      c.socket.attachment.hole_spacing_m * 1e3,
                                                      sock.platform.min_hole_depth_m * 1e3)});
  }
}

}  // namespace

nlohmann::json write_socket_outputs(const DesignSetup& setup, const DesignResult& result, const fs::path& out,
                                    const report::SurfaceFrame& sframe, report::ReportSocket& rs) {
  const design::CaseFile& c = setup.case_file;
  rs.thickness_m = c.socket.thickness_m;
  if (!result.socket) return {};
  const auto& sock = *result.socket;
  design::write_socket_stl(out / "socket.stl", sock);
  rs.has_socket = true;
  rs.socket_volume_m3 = sock.cavity_volume_m3;
  rs.stl_file = "socket.stl";
  rs.limb_volume_m3 = result.limb_volume_below_brim_m3;
  nlohmann::json j = socket_json(c, sock, rs);
  write_wall_thickness(c, sock, sframe, out, rs);
  add_socket_details(setup, result, rs, j);
  return j;
}

}  // namespace socketsmith::pipeline
