// The generated limb's sidecar JSON (the truth a test or a user checks a reconstruction against:
// parameters, frame, landmarks, bones, volumes), apart from limb_generator.cpp because writing down
// a limb is not generating it.
#include <cmath>
#include <numbers>

#include <nlohmann/json.hpp>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/volume/limb_generator.h"

namespace socketsmith::volume {

using geometry::LimbFrame;
using geometry::LimbType;
using geometry::TriMesh;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

nlohmann::json vec_mm(const geometry::Vec3& v) { return {v.x() * 1e3 + 0.0, v.y() * 1e3 + 0.0, v.z() * 1e3 + 0.0}; }
nlohmann::json vec(const geometry::Vec3& v) { return {v.x() + 0.0, v.y() + 0.0, v.z() + 0.0}; }

nlohmann::json frame_json(const LimbFrame& f) {
  return {{"origin_mm", vec_mm(f.origin)},
          {"axis", vec(f.axis)},
          {"anterior", vec(f.anterior)},
          {"medial", vec(f.medial())},
          {"side", geometry::to_string(f.side)},
          {"anterior_estimated", f.anterior_estimated},
          {"side_estimated", f.side_estimated}};
}

/// A transfemoral limb's bony points [mm].
nlohmann::json bony_points_json(const TransfemoralPoints& t) {
  nlohmann::json pts = {{"ischial_tuberosity_mm", vec_mm(t.ischial_tuberosity)},
                        {"ischial_ramus_mm", vec_mm(t.ischial_ramus)},
                        {"pubic_symphysis_mm", vec_mm(t.symphysis)},
                        {"femur_distal_end_mm", vec_mm(t.femur_distal_end)}};
  if (t.greater_trochanter) pts["greater_trochanter_mm"] = vec_mm(*t.greater_trochanter);
  return pts;
}

nlohmann::json landmarks_json(const GeneratedLimb& limb) {
  nlohmann::json marks = nlohmann::json::array();
  for (const auto& l : limb.landmarks)
    marks.push_back({{"code", l.code},
                     {"name", l.name},
                     {"position_mm", vec_mm(l.position)},
                     {"rho_mm", l.cylindrical.rho * 1e3},
                     {"theta_deg", l.cylindrical.theta / kDeg},
                     {"h_mm", l.cylindrical.h * 1e3},
                     {"radius_mm", l.radius_m * 1e3},
                     {"estimated", l.estimated}});
  return marks;
}

/// The skin's and every bone's mesh sizes, closed or not, and the volume of the closed ones.
nlohmann::json shells_json(const GeneratedLimb& limb) {
  nlohmann::json shells = nlohmann::json::array();
  auto shell = [&](const std::string& name, const TriMesh& m, bool closed) {
    nlohmann::json s = {{"name", name}, {"vertices", m.num_vertices()}, {"triangles", m.num_triangles()}, {"closed", closed}};
    if (closed) s["volume_cm3"] = geometry::signed_volume(m) * 1e6;
    shells.push_back(s);
  };
  shell("skin", limb.skin, !limb.params.open_proximal);
  for (const auto& bone : limb.bones) shell(bone.name, bone.mesh, true);
  return shells;
}

}  // namespace

nlohmann::json limb_sidecar_json(const GeneratedLimb& limb) {
  const LimbShapeParams& p = limb.params;
  const BoneTemplateParams& b = p.bones;
  nlohmann::json j;
  j["generator"] = "socketsmith parametric residual limb";
  j["type"] = geometry::to_string(p.type);
  j["side"] = geometry::to_string(p.side);
  j["seed"] = p.seed;
  j["units"] = {{"positions", "mm"}, {"angles", "deg"}, {"params", "SI (m, rad)"}};
  j["params"] = {{"residual_length_m", p.residual_length_m},
                 {"proximal_extension_m", p.proximal_extension_m},
                 {"proximal_circumference_m", p.proximal_circumference_m},
                 {"distal_circumference_m", p.distal_circumference_m},
                 {"distal_cap_height_m", p.distal_cap_height_m},
                 {"bulbousness", p.bulbousness},
                 {"ap_ml_ratio", p.ap_ml_ratio},
                 {"anterior_flattening", p.anterior_flattening},
                 {"posterior_fullness", p.posterior_fullness},
                 {"open_proximal", p.open_proximal},
                 {"ring_vertices", p.ring_vertices},
                 {"bones",
                  {{"tibia_plateau_width_m", b.tibia_plateau_width_m},
                   {"tibia_plateau_depth_m", b.tibia_plateau_depth_m},
                   {"tibia_shaft_radius_m", b.tibia_shaft_radius_m},
                   {"tibia_distal_radius_m", b.tibia_distal_radius_m},
                   {"tibia_end_height_m", b.tibia_end_height_m},
                   {"tibia_bevel", b.tibia_bevel},
                   {"crest_tissue_m", b.crest_tissue_m},
                   {"tibia_medial_shift_m", b.tibia_medial_shift_m},
                   {"fibula_head_radius_m", b.fibula_head_radius_m},
                   {"fibula_shaft_radius_m", b.fibula_shaft_radius_m},
                   {"fibula_shortening_m", b.fibula_shortening_m},
                   {"fibula_angle_rad", b.fibula_angle_rad},
                   {"femur_condyle_width_m", b.femur_condyle_width_m},
                   {"femur_condyle_depth_m", b.femur_condyle_depth_m},
                   {"patella_width_m", b.patella_width_m},
                   {"patella_height_m", b.patella_height_m},
                   {"patella_thickness_m", b.patella_thickness_m},
                   {"patella_tissue_m", b.patella_tissue_m},
                   {"femur_shaft_radius_m", b.femur_shaft_radius_m},
                   {"femur_end_height_m", b.femur_end_height_m},
                   {"femur_lateral_fraction", b.femur_lateral_fraction},
                   {"femur_anterior_fraction", b.femur_anterior_fraction},
                   {"trochanter_height_m", b.trochanter_height_m},
                   {"trochanter_prominence_m", b.trochanter_prominence_m},
                   {"ischium_radius_m", b.ischium_radius_m},
                   {"ischium_offset_m", b.ischium_offset_m},
                   {"min_ischial_tissue_m", b.min_ischial_tissue_m},
                   {"ischium_angle_rad", b.ischium_angle_rad},
                   {"pubic_ramus_length_m", b.pubic_ramus_length_m},
                   {"pubic_ramus_angle_rad", b.pubic_ramus_angle_rad},
                   {"pubic_ramus_rise_m", b.pubic_ramus_rise_m}}}};
  j["frame"] = frame_json(limb.frame);
  if (p.type == LimbType::Transtibial) j["knee_joint_line_h_mm"] = p.residual_length_m * 1e3;
  if (limb.transfemoral) {
    j["ischial_tuberosity_h_mm"] = p.residual_length_m * 1e3;
    j["bony_points"] = bony_points_json(*limb.transfemoral);
  }
  j["cut_height_mm"] = limb.cut_height_m * 1e3;
  j["skin_open"] = p.open_proximal;
  j["skin_volume_cm3"] = limb.skin_volume_m3 * 1e6;
  j["landmarks"] = landmarks_json(limb);
  j["shells"] = shells_json(limb);
  nlohmann::json names = nlohmann::json::array();
  for (const auto& bone : limb.bones) names.push_back(bone.name);
  j["bones"] = names;
  return j;
}

void write_limb_sidecar(const std::filesystem::path& path, const GeneratedLimb& limb) {
  write_text_atomically(path, limb_sidecar_json(limb).dump(2) + "\n");
}

}  // namespace socketsmith::volume
