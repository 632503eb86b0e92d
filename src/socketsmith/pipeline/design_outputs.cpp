// The files of a design (docs/design.md) and its summary JSON: write_design_outputs and the pieces
// it writes one after the other — the node fields, the pictures, the socket and its measurements,
// the replay case, the HTML report with its prosthetist checks, and design.json. Why apart from
// design_pipeline.cpp: preparing and solving a design is one responsibility, writing what it gave
// is another, with its own formats.
#include <algorithm>
#include <cmath>
#include <limits>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/core/units.h"
#include "socketsmith/design/template_regions.h"
#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/pipeline/design_socket_outputs.h"
#include "socketsmith/pipeline/prosthetist_checks.h"
#include "socketsmith/report/csv.h"
#include "socketsmith/report/design_report.h"
#include "socketsmith/report/svg_plot.h"
#include "socketsmith/report/vtk_writer.h"

namespace socketsmith::pipeline {
namespace {

namespace fs = std::filesystem;
using geometry::Vec3;

nlohmann::json vec_json(const Vec3& v) { return {v.x(), v.y(), v.z()}; }

report::ReportSpot report_spot(const design::Spot& s) {
  report::ReportSpot r;
  r.name = s.name;
  r.type = design::to_string(s.type);
  r.amplitude_pa = s.amplitude_pa;
  r.theta0_rad = s.theta0;
  r.r_theta_rad = s.r_theta;
  r.h0_m = s.h0;
  r.r_h_m = s.r_h;
  r.theta1_rad = s.theta1;
  r.theta2_rad = s.theta2;
  r.lambda_theta_per_rad = s.lambda_theta;
  r.h1_m = s.h1;
  r.h2_m = s.h2;
  r.lambda_h_per_m = s.lambda_h;
  r.is_enabled = s.enabled;
  return r;
}

/// A socket of an earlier run would sit beside this run's report as if it were this design's: it is
/// removed when this design has none. Returns the files removed.
nlohmann::json remove_stale_socket(const DesignResult& result, const fs::path& out) {
  nlohmann::json removed = nlohmann::json::array();
  if (!result.socket) {
    std::error_code ec;
    if (fs::remove(out / "socket.stl", ec)) {
      removed.push_back("socket.stl");
      log::warn("design: removed the earlier socket.stl from {}: this design has no socket", out.string());
    } else if (ec) {
      fail<IoError>("design: cannot remove the earlier socket.stl from {} ({}): remove it by hand, it is not this "
                    "design's", out.string(), ec.message());
    }
  }
  return removed;
}

/// surface_nodes.csv (the skin nodes: position, normal, area, pressure, threshold) and stump.vtu
/// (displacement, pressure, threshold and their ratio on the stump's nodes).
void write_node_fields(const DesignSetup& setup, const design::DesignState& state, const fs::path& out) {
  const auto& mesh = setup.mesh;
  const auto& thresholds = setup.thresholds;
  const auto& skin = setup.solver->skin();
  const auto& above = setup.solver->above_brim();
  {
    report::CsvTable t;
    t.header = {"x_m", "y_m", "z_m", "nx", "ny", "nz", "area_m2", "pressure_pa", "threshold_pa", "above_brim"};
    for (size_t i = 0; i < skin.nodes.size(); ++i) {
      const auto& p = state.skin_positions[i];
      const auto& n = state.skin_normals[i];
      t.rows.push_back({p.x(), p.y(), p.z(), n.x(), n.y(), n.z(), state.skin_areas[i], state.pressure_pa[i],
                        thresholds[i], above[i] ? 1.0 : 0.0});
    }
    report::write_csv(out / "surface_nodes.csv", t.header, t.rows, 12);
  }
  {
    const int nn = mesh.mesh.num_nodes();
    std::vector<Vec3> u(nn);
    std::vector<double> pn(nn, 0.0), tn(nn, 0.0), rn(nn, 0.0);
    for (int k = 0; k < nn; ++k) u[k] = state.positions.segment<3>(3 * k) - mesh.mesh.nodes[k];
    for (size_t i = 0; i < skin.nodes.size(); ++i) {
      pn[skin.nodes[i]] = state.pressure_pa[i];
      tn[skin.nodes[i]] = thresholds[i];
      rn[skin.nodes[i]] = state.requested_pa[i] / thresholds[i];
    }
    report::write_vtu(out / "stump.vtu", mesh.mesh,
                      {report::make_vector_field("displacement_m", u), {"pressure_pa", 1, pn},
                       {"threshold_pa", 1, tn}, {"pressure_ratio", 1, rn}},
                      {});
  }
}

/// The pictures of a design, kept for its report.
struct DesignPictures {
  report::SurfaceFrame sframe;
  std::vector<report::MapLandmark> marks;
  std::vector<report::PressureMapData> maps;
  report::RadarChart radar;
  std::vector<report::PathProfile> profiles;
};

/// pressure_map.png, ratio_map.png, radar.png and the three path profiles (front line through PT,
/// back line, mid-stump circumference).
DesignPictures write_pictures(const DesignSetup& setup, const DesignResult& result, const fs::path& out) {
  const auto& model = setup.model;
  const auto& thresholds = setup.thresholds;
  const auto& state = result.state;
  const auto& skin = setup.solver->skin();
  const auto& above = setup.solver->above_brim();
  const geometry::TriMesh& def_tri = result.deformed_skin;
  const bool met = result.constraints_met;
  DesignPictures p;
  p.sframe = report::surface_frame(model.frame);
  const auto& sframe = p.sframe;
  std::vector<report::MapLandmark>& marks = p.marks;
  for (const auto& l : model.landmarks) marks.push_back({l.code, l.position, l.estimated});
  const std::vector<Vec3> brim_poly = brim_on_skin(setup, 180);
  std::vector<double> p_kpa(skin.nodes.size()), ratio(skin.nodes.size()), thr_kpa(skin.nodes.size()),
      disp_mm(skin.nodes.size());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (size_t i = 0; i < skin.nodes.size(); ++i) {
    p_kpa[i] = above[i] ? nan : state.pressure_pa[i] / 1e3;
    ratio[i] = above[i] ? nan : state.requested_pa[i] / thresholds[i];
    thr_kpa[i] = thresholds[i] / 1e3;
    disp_mm[i] = state.displacement_m[i] * 1e3;
  }
  const auto make_map = [&](const std::vector<double>& v, const std::string& label, const std::string& title, double lo,
                            double hi) {
    return report::PressureMapData{.surface = &def_tri,
                                   .values = v,
                                   .value_min = lo,
                                   .value_max = hi,
                                   .value_label = label,
                                   .frame = sframe,
                                   .landmarks = marks,
                                   .brim = brim_poly,
                                   .title = title};
  };
  p.maps = {
      make_map(p_kpa, "kPa", "Applied pressure (socket inner surface)", 0, 0),
      make_map(ratio, "p/T", "Pressure / pain threshold", 0, 1.2),
      make_map(thr_kpa, "kPa", "Pain-threshold map (IDW from the landmarks)", 0, 0),
      make_map(disp_mm, "mm", "Tissue displacement", 0, 0)};
  report::write_pressure_map(out / "pressure_map.png", p.maps[0]);
  report::write_pressure_map(out / "ratio_map.png", p.maps[1]);
  report::RadarChart& radar = p.radar;
  radar.title = met ? "Constraints: all met" : "Constraints: NOT all met";
  radar.axes = radar_axes(setup, state);
  report::write_radar_chart(out / "radar.png", radar);
  p.profiles = pressure_profiles(setup, state);
  const auto& profiles = p.profiles;
  for (size_t k = 0; k < profiles.size(); ++k)
    report::write_svg(out / fmt::format("profile_{}.svg", k == 0 ? "front" : k == 1 ? "back" : "mid"),
                      report::path_profile_plot(profiles[k]));
  return p;
}

/// design_case.json: the design as a case file that replays it (spots fixed, no optimisation).
void write_replay_case(const DesignSetup& setup, const DesignResult& result, const fs::path& out) {
  const design::CaseFile& c = setup.case_file;
  const auto& spots = result.spots;
  const auto& brim = setup.brim;
  design::CaseFile replay = c;
  replay.spots = spots;
  replay.optimise = false;
  replay.brim = brim.kind();
  if (!c.limb.file.empty()) replay.limb.file = fs::absolute(design::resolve(c, c.limb.file)).string();
  if (c.limb.bones != "auto" && c.limb.bones != "estimate" && c.limb.bones != "none")
    replay.limb.bones = fs::absolute(design::resolve(c, c.limb.bones)).string();
  replay.folder.clear();
  design::write_case(out / "design_case.json", replay);
}

/// The report's patient, limb, model, spots, brim, pictures, peaks and load shares.
report::DesignReportData report_data(const DesignSetup& setup, const DesignResult& result, const DesignPictures& p,
                                     const report::ReportSocket& rs) {
  const design::CaseFile& c = setup.case_file;
  const auto& model = setup.model;
  const auto& mesh = setup.mesh;
  const auto& brim = setup.brim;
  const auto& state = result.state;
  const auto& skin = setup.solver->skin();
  report::DesignReportData rd;
  rd.patient.id = c.patient_id;
  rd.patient.body_mass_kg = c.patient.body_mass_kg;
  rd.patient.prosthesis_mass_kg = c.patient.prosthesis_mass_kg;
  rd.patient.tissue_youngs_modulus_pa = c.youngs_modulus_pa;
  rd.patient.friction = c.patient.friction;
  rd.patient.note = c.patient_note;
  rd.generated = "socketsmith 0.1.0";
  rd.limb_file = setup.limb_label;
  rd.limb_type = geometry::to_string(model.type);
  rd.side = geometry::to_string(model.frame.side);
  rd.mesh_nodes = mesh.mesh.num_nodes();
  if (c.model == "fe" || c.model == "neo-hookean")
    rd.model = fmt::format("{} ({} hexahedra, E = {:.0f} kPa, nu = {:.2f}), {} design solve", c.model,
                           c.model == "fe" ? "St Venant-Kirchhoff" : "neo-Hookean", c.youngs_modulus_pa / 1e3,
                           model_options(c).fe_poisson_ratio, design::to_string(c.solve_mode));
  else
    rd.model = fmt::format("{} ({} constants, E = {:.0f} kPa), {} design solve", c.model, c.constants,
                           c.youngs_modulus_pa / 1e3, design::to_string(c.solve_mode));
  for (const auto& s : result.spots) rd.spots.push_back(report_spot(s));
  rd.brim_template = brim.name();
  for (const auto& k : brim.key_points()) rd.brim_key_points.push_back({k.theta, k.h});
  rd.radar = p.radar;
  rd.maps = p.maps;
  rd.profiles = p.profiles;
  rd.max_pressure_ratio = state.max_requested_ratio;
  if (state.max_ratio_node >= 0) {
    rd.has_max_ratio_position = true;
    rd.max_ratio_position = skin.positions[state.max_ratio_node];
  }
  rd.max_pressure_pa = *std::max_element(state.pressure_pa.begin(), state.pressure_pa.end());
  rd.landmarks = p.marks;
  for (const auto& r : result.region_loads)
    rd.region_loads.push_back({r.name, r.share, r.axial_n, r.friction_axial_n, r.area_m2, r.mean_pressure_pa,
                               r.peak_pressure_pa, r.key == "ischial_gluteal"});
  if (model.type == geometry::LimbType::Transfemoral && ischial_share_floor(setup) > 0)
    rd.region_note = fmt::format("The {} template asks the optimiser for at least {:.0f} % on the ischial / gluteal "
                                 "region{}.",
                                 brim.name(), 100 * ischial_share_floor(setup),
                                 ischial_floor_holds(setup, result) ? "" : " — the final design does not keep it");
  rd.socket = rs;
  return rd;
}

/// The optimiser's and the final solve's lines of the report.
void add_run_details(const DesignResult& result, report::DesignReportData& rd) {
  const auto& state = result.state;
  const auto& opt = result.optimiser;
  const bool optimise = result.optimised;
  rd.optimiser.has_run = optimise;
  rd.optimiser.converged = opt.constraints_met;
  rd.optimiser.iterations = opt.rounds;
  rd.optimiser.residual = opt.objective;
  rd.optimiser.seconds = opt.seconds;
  rd.optimiser.message = opt.message;
  rd.optimiser.details.push_back({"amplitude fits", std::to_string(opt.evaluations)});
  rd.optimiser.details.push_back({"SLSQP evaluations", std::to_string(opt.slsqp_iterations)});
  for (size_t k = 0; k < opt.log.size(); ++k) rd.optimiser.details.push_back({fmt::format("log {}", k + 1), opt.log[k]});
  rd.solver.has_run = true;
  rd.solver.converged = state.converged;
  rd.solver.iterations = state.follower_passes;
  rd.solver.seconds = state.seconds;
  rd.solver.message = state.message;
  rd.solver.details.push_back({"max displacement", fmt::format("{:.2f} mm", state.max_displacement_m * 1e3)});
  rd.solver.details.push_back({"follower passes", std::to_string(state.follower_passes)});
}

/// The design read against its template (tolerant vs sensitive regions, the distal fifth's load): its
/// lines of the report, and design.json's template_regions entry.
nlohmann::json template_regions_json(const DesignSetup& setup, const DesignResult& result,
                                     report::DesignReportData& rd) {
  const design::CaseFile& c = setup.case_file;
  const auto& state = result.state;
  const auto& opt = result.optimiser;
  const bool optimise = result.optimised;
  const design::TemplateCheck tc = template_check(setup, state);
  rd.solver.details.push_back({"template", tc.summary + (tc.applies ? (tc.met ? ": met" : ": NOT met") : "")});
  nlohmann::json regions_json = nlohmann::json::object();
  for (const design::ZoneLoad* r : {&tc.tolerant, &tc.sensitive, &tc.distal_fifth, &tc.below_brim}) {
    if (r->nodes == 0) continue;
    regions_json[r->key] = {{"landmarks", r->codes},          {"nodes", r->nodes},
                            {"mean_kpa", r->mean_pa / 1e3},   {"peak_kpa", r->peak_pa / 1e3},
                            {"axial_n", r->axial_force_n},    {"axial_share", r->axial_share}};
    std::string codes;
    for (const auto& code : r->codes) codes += (codes.empty() ? "" : ", ") + code;
    rd.solver.details.push_back({fmt::format("{} region", r->key),
                                 fmt::format("{}{} nodes, mean {:.1f} kPa, peak {:.1f} kPa, {:.0f} % of the axial load",
                                             codes.empty() ? "" : codes + "; ", r->nodes, r->mean_pa / 1e3,
                                             r->peak_pa / 1e3, 100 * r->axial_share)});
  }
  return {{"template", tc.template_name},
          {"applies", tc.applies},
          {"met", tc.met},
          {"summary", tc.summary},
          {"tolerant_to_sensitive", tc.tolerant_to_sensitive},
          {"cv_below_brim", tc.cv_below_brim},
          {"total_axial_n", tc.total_axial_n},
          {"regions", regions_json},
          // whether the optimiser aimed at the template, and kept it
          {"optimiser_follows", optimise && c.follow_template},
          {"optimiser_kept", optimise && c.follow_template && opt.region_constraints_met}};
}

/// What the report warns of: estimated frame or bones, a continued skin, a template or constraints
/// not kept, a linearised shape.
void add_warnings(const DesignSetup& setup, const DesignResult& result, report::DesignReportData& rd) {
  const design::CaseFile& c = setup.case_file;
  const auto& model = setup.model;
  const auto& brim = setup.brim;
  const auto& state = result.state;
  const auto& opt = result.optimiser;
  const bool optimise = result.optimised;
  const bool met = result.constraints_met;
  if (optimise && c.follow_template && !opt.region_constraints_met)
    rd.warnings.push_back(fmt::format("the {} template's regions could not be kept together with the seven constraints: "
                                      "the optimiser dropped them (see the optimiser's log)",
                                      brim.name()));
  if (model.bones_estimated) rd.warnings.push_back("bones ESTIMATED from the skin (no bone surfaces given)");
  if (model.frame.anterior_estimated) rd.warnings.push_back("anterior direction ESTIMATED from the skin: check it");
  if (model.frame.side_estimated) rd.warnings.push_back("side ESTIMATED: check it");
  if (model.skin_extension_m > 0)
    rd.warnings.push_back(fmt::format("skin CONTINUED {:.0f} mm above the scan ({:.0f} % of the socket's skin): the "
                                      "ischial containment lies on an assumed surface — scan up to the buttock and the "
                                      "groin",
                                      model.skin_extension_m * 1e3, 100 * model.skin_extension_area_fraction));
  for (const auto& n : setup.brim_notes) rd.warnings.push_back(n);
  if (result.ischial_check && result.ischial_check->applies && !result.ischial_check->met)
    rd.warnings.push_back(fmt::format("the {} socket does not hold the ischial tuberosity as the template means: {}",
                                      brim.name(), result.ischial_check->summary));
  if (state.linearised) rd.warnings.push_back("shape from the linearised stump model: " + state.nonlinear_failure);
  if (!met) rd.warnings.push_back("constraints not met: no socket written. " + (optimise ? opt.message : state.message));
}

nlohmann::json radar_json(const design::RadarValues& radar) {
  return {{"fx_n", radar.force_n.x()},
    {"fy_n", radar.force_n.y()},
    {"fz_n", radar.force_n.z()},
    {"tx_nm", radar.torque_nm.x()},
    {"ty_nm", radar.torque_nm.y()},
    {"tz_nm", radar.torque_nm.z()},
    {"stability_n", radar.stability_n}};
}

nlohmann::json targets_json(const design::RadarTargets& T) {
  return {{"fx_n", 0.0},
    {"fy_n", 0.0},
    {"fz_n", T.fz_n},
    {"tx_nm", 0.0},
    {"ty_nm", 0.0},
    {"tz_nm", 0.0},
    {"stability_min_n", T.stability_min_n},
    {"force_tolerance_n", T.force_tol_n},
    {"torque_tolerance_nm", T.torque_tol_nm}};
}

nlohmann::json frame_json(const geometry::LimbFrame& frame) {
  return {{"origin_m", vec_json(frame.origin)},
    {"axis", vec_json(frame.axis)},
    {"anterior", vec_json(frame.anterior)},
    {"medial", vec_json(frame.medial())}};
}

/// design.json's load shares of the regions (and the transfemoral ischial floor).
void add_load_shares(const DesignSetup& setup, const DesignResult& result, nlohmann::json& j) {
  const auto& model = setup.model;
  nlohmann::json shares = nlohmann::json::array();
  for (const auto& r : result.region_loads)
    shares.push_back({{"region", r.key},
                      {"name", r.name},
                      {"share", r.share},
                      {"axial_n", r.axial_n},
                      {"normal_axial_n", r.normal_axial_n},
                      {"friction_axial_n", r.friction_axial_n},
                      {"area_cm2", r.area_m2 * 1e4},
                      {"mean_kpa", r.mean_pressure_pa / 1e3},
                      {"peak_kpa", r.peak_pressure_pa / 1e3}});
  j["load_shares"] = shares;
  for (const auto& r : result.region_loads)
    if (r.key == "ischial_gluteal") j["ischial_gluteal_share"] = r.share;
  if (model.type == geometry::LimbType::Transfemoral) {
    j["ischial_share_min"] = ischial_share_floor(setup);
    j["ischial_share_floor_met"] = ischial_floor_holds(setup, result);
  }
}

nlohmann::json landmarks_json(const volume::LimbModel& model) {
  nlohmann::json lms = nlohmann::json::array();
  for (const auto& l : model.landmarks)
    lms.push_back({{"code", l.code},
                   {"name", l.name},
                   {"theta_deg", l.cylindrical.theta / units::deg},
                   {"h_mm", l.cylindrical.h * 1e3},
                   {"position_mm", vec_json(l.position * 1e3)},
                   {"estimated", l.estimated}});
  return lms;
}

/// design.json: the radar against its targets, the frame, the solves, the brim, the spots, the load
/// shares, the landmarks and the output files (the socket and the later outputs are added by the
/// caller).
nlohmann::json design_summary(const DesignSetup& setup, const DesignResult& result, const fs::path& out,
                              double seconds, const report::DesignReportData& rd, const nlohmann::json& removed) {
  const design::CaseFile& c = setup.case_file;
  const auto& model = setup.model;
  const auto& mesh = setup.mesh;
  const auto& solver = *setup.solver;
  const auto& brim = setup.brim;
  const auto& limb_label = setup.limb_label;
  const auto& state = result.state;
  const auto& opt = result.optimiser;
  const auto& spots = result.spots;
  const auto& skin = solver.skin();
  const bool optimise = result.optimised;
  const bool met = result.constraints_met;
  nlohmann::json outputs = {"surface_nodes.csv", "stump.vtu",      "pressure_map.png", "ratio_map.png",
                            "radar.png",         "report.html",    "design_case.json", "design.json",
                            "profile_front.svg", "profile_back.svg", "profile_mid.svg"};
  if (met) {
    outputs.push_back("socket.stl");
    outputs.push_back("socket.vtp");
    outputs.push_back("thickness_map.png");
  }
  if (c.limb.file.empty()) outputs.push_back("limb.stl");
  nlohmann::json spots_json = nlohmann::json::array();
  for (const auto& s : spots) spots_json.push_back(design::spot_to_json(s));
  nlohmann::json j{
      {"limb", limb_label},
      {"type", geometry::to_string(model.type)},
      {"nodes", mesh.mesh.num_nodes()},
      {"skin_nodes", skin.nodes.size()},
      {"radar", radar_json(state.radar)},
      {"targets", targets_json(solver.targets())},
      {"frame", frame_json(model.frame)},
      {"center_of_inertia_m", vec_json(state.centre_of_inertia)},
      {"friction", c.patient.friction},
      {"max_pressure_ratio", state.max_requested_ratio},
      {"max_pressure_kpa", rd.max_pressure_pa / 1e3},
      {"max_displacement_mm", state.max_displacement_m * 1e3},
      {"constraints_met", met},
      {"failing", state.status.failing()},
      {"optimised", optimise},
      {"iterations", opt.rounds},
      {"amplitude_fits", opt.evaluations},
      {"optimiser_message", opt.message},
      {"solver_message", state.message},
      {"follower_converged", !state.follower_capped},
      {"optimiser_seconds", opt.seconds},
      {"optimiser_time_limited", opt.is_time_limited},
      {"model_caps", opt.model_caps},
      {"linearised", design_body_linearised(state, c)},
      {"solve_mode", design::to_string(c.solve_mode)},
      {"final_solve",
       {{"newton_iterations", state.newton_iterations},
        {"follower_passes", state.follower_passes},
        {"seconds", state.seconds},
        {"nonlinear_failure", state.nonlinear_failure}}},
      {"brim", {{"template", brim.name()}, {"min_h_mm", brim.min_height() * 1e3}, {"max_h_mm", brim.max_height() * 1e3}}},
      {"spots", spots_json},
      {"bones_estimated", model.bones_estimated},
      {"anterior_estimated", model.frame.anterior_estimated},
      {"seconds", seconds},
      {"out", out.string()},
      {"outputs", outputs},
      {"removed", removed}};
  j["frame"]["axis_source"] = model.axis_source;
  j["frame"]["anterior_source"] = model.anterior_source;
  j["frame"]["side"] = geometry::to_string(model.frame.side);
  j["frame"]["side_estimated"] = model.frame.side_estimated;
  j["brim"]["key_points"] = nlohmann::json::array();
  for (const auto& k : brim.key_points())
    j["brim"]["key_points"].push_back({{"label", k.label}, {"theta_deg", k.theta / units::deg}, {"h_mm", k.h * 1e3}});
  j["brim"]["notes"] = setup.brim_notes;
  add_load_shares(setup, result, j);
  j["skin_extension_mm"] = model.skin_extension_m * 1e3;
  j["skin_extension_area_percent"] = 100 * model.skin_extension_area_fraction;
  j["limb_notes"] = model.notes;
  j["landmarks"] = landmarks_json(model);
  return j;
}

}  // namespace

nlohmann::json write_design_outputs(const DesignSetup& setup, const DesignResult& result, const fs::path& out,
                                    double seconds) {
  ensure_directory(out);
  const nlohmann::json removed = remove_stale_socket(result, out);
  write_node_fields(setup, result.state, out);
  const DesignPictures pictures = write_pictures(setup, result, out);
  report::ReportSocket rs;
  const nlohmann::json socket = write_socket_outputs(setup, result, out, pictures.sframe, rs);
  write_replay_case(setup, result, out);

  report::DesignReportData rd = report_data(setup, result, pictures, rs);
  // What a prosthetist checks: the rectification chart and the slice measurements.
  const nlohmann::json checks_json = write_prosthetist_checks(setup, result, prosthetist_checks(setup, result), out, rd);
  nlohmann::json closed_loop_json;
  if (result.closed_loop) closed_loop_json = write_closed_loop_outputs(setup, result, out, rd.delivery);
  nlohmann::json sock_ply_json;
  if (result.sock_ply) sock_ply_json = write_sock_ply_outputs(setup, result, out, rd.sock_ply);
  add_run_details(result, rd);
  const nlohmann::json template_json = template_regions_json(setup, result, rd);
  add_warnings(setup, result, rd);
  report::write_design_report_html(out / "report.html", rd);

  nlohmann::json j = design_summary(setup, result, out, seconds, rd, removed);
  if (!socket.is_null()) j["socket"] = socket;
  j["rectification"] = checks_json["rectification"];
  j["slices"] = checks_json["slices"];
  for (const char* o : {"rectification_map.png", "rectification.csv", "slices.csv"}) j["outputs"].push_back(o);
  j["template_regions"] = template_json;
  if (!sock_ply_json.is_null()) {
    j["sock_ply"] = sock_ply_json;
    for (const auto& o : sock_ply_json["outputs"]) j["outputs"].push_back(o);
  }
  if (!result.closed_loop_failed.empty()) j["closed_loop_failed"] = result.closed_loop_failed;
  if (!closed_loop_json.is_null()) {
    j["closed_loop"] = closed_loop_json;
    for (const auto& o : closed_loop_json["outputs"]) j["outputs"].push_back(o);
  }
  write_text_atomically(out / "design.json", j.dump(2) + "\n");
  return j;
}

}  // namespace socketsmith::pipeline
