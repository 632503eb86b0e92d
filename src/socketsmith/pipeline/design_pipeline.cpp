#include "socketsmith/pipeline/design_pipeline.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/core/units.h"
#include "socketsmith/design/template_regions.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/pipeline/prosthetist_checks.h"
#include "socketsmith/report/csv.h"
#include "socketsmith/report/design_report.h"
#include "socketsmith/report/vtk_writer.h"
#include "socketsmith/volume/limb_generator.h"

namespace socketsmith::pipeline {
namespace {

namespace fs = std::filesystem;
using geometry::Vec3;

nlohmann::json vec_json(const Vec3& v) { return {v.x(), v.y(), v.z()}; }

/// The limb surface (and extra bones) of a case, in metres.
std::pair<geometry::TriMesh, geometry::TriMesh> load_limb(const design::CaseFile& c, const fs::path& generated_stl,
                                                          std::string& label) {
  geometry::TriMesh limb, extra;
  if (c.limb.file.empty()) {
    auto p = volume::default_params(c.limb.type, c.limb.generate_seed);
    if (c.limb.side) p.side = *c.limb.side;
    const auto g = volume::generate_limb(p);
    limb = volume::merge_shells(g);
    if (!generated_stl.empty()) geometry::write_mesh(generated_stl, limb);
    label = fmt::format("generated {} {} limb (seed {})", geometry::to_string(p.side), geometry::to_string(c.limb.type),
                        c.limb.generate_seed);
    return {limb, extra};
  }
  geometry::MeshReadOptions ro;
  if (!c.limb.units.empty()) ro.unit = units::parse_length_unit(c.limb.units);
  // The size is checked against the limb type's anatomy once scaled (volume::check_limb_size).
  ro.warn_on_implausible_size = false;
  limb = geometry::read_mesh(design::resolve(c, c.limb.file), ro);
  if (c.limb.bones != "auto" && c.limb.bones != "estimate" && c.limb.bones != "none")
    extra = geometry::read_mesh(design::resolve(c, c.limb.bones), ro);
  if (c.limb.scale != 1.0) {
    geometry::scale(limb, c.limb.scale);
    if (!extra.empty()) geometry::scale(extra, c.limb.scale);
  }
  if (c.limb.bones == "estimate" || c.limb.bones == "none") {
    auto parts = geometry::split_components(limb);
    std::sort(parts.begin(), parts.end(),
              [](const auto& a, const auto& b) { return geometry::surface_area(a) > geometry::surface_area(b); });
    limb = parts.front();
  }
  label = c.limb.file;
  return {limb, extra};
}

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

}  // namespace

double ischial_share_floor(const DesignSetup& setup) {
  if (setup.model.type != geometry::LimbType::Transfemoral) return 0.0;
  return setup.case_file.ischial_share_min.value_or(design::default_ischial_share(setup.brim.kind()));
}

bool ischial_floor_holds(const DesignSetup& setup, const DesignResult& result) {
  const double floor = ischial_share_floor(setup);
  if (floor <= 0.0) return true;
  for (const auto& r : result.region_loads)
    if (r.key == "ischial_gluteal") return r.share >= floor - 1e-9;
  return false;
}

namespace {
constexpr double kIschialFloorMargin = 0.05;
}  // namespace

std::optional<design::OptimizerOptions::RegionShare> ischial_floor(const DesignSetup& setup) {
  const double share = ischial_share_floor(setup);
  if (share <= 0.0) return std::nullopt;
  const auto which = design::region_of(setup.regions, setup.solver->skin_cylindrical());
  int k = -1;
  for (std::size_t i = 0; i < setup.regions.size(); ++i)
    if (setup.regions[i].key == "ischial_gluteal") k = static_cast<int>(i);
  if (k < 0) return std::nullopt;
  design::OptimizerOptions::RegionShare f;
  f.name = setup.regions[static_cast<std::size_t>(k)].name;
  // Asked with the template constraints' 5 % margin: the last fit is on the geometry of the round
  // before it, the floor is read on the final state (without it the quadrilateral design of the
  // OpenLimbTF limb ended at 29.4 % for a 30 % floor).
  f.min_share = std::min(share * (1 + kIschialFloorMargin), 0.99);
  f.nodes.resize(which.size());
  for (std::size_t i = 0; i < which.size(); ++i) f.nodes[i] = which[i] == k ? 1 : 0;
  return f;
}

tissue::MassSpringOptions model_options(const design::CaseFile& c) {
  tissue::MassSpringOptions o;
  o.kind = tissue::parse_tissue_model(c.model);
  // MSS and MSS-CF use Golec's springs with the thesis's A.
  o.corrective = o.kind == tissue::TissueModelKind::MssCs ? tissue::CorrectiveSpringConstants::preset(c.constants)
                                                          : tissue::CorrectiveSpringConstants::thesis();
  if (c.poisson_ratio) {
    if (tissue::is_continuum(o.kind)) o.fe_poisson_ratio = *c.poisson_ratio;
    if (o.kind == tissue::TissueModelKind::MssCf) o.cf_poisson_ratio = *c.poisson_ratio;
  }
  return o;
}

namespace {

/// Each skin node above setup.brim — from the setup's brim, not the solver's flags (the GUI's
/// worker may be setting a new brim on its thread).
std::vector<char> above_brim(const DesignSetup& setup) {
  const design::BrimLine& brim = setup.brim;
  return setup.solver->above_brim_of([&brim](double theta) { return brim.height(theta); });
}

/// What the brim template means, as optimiser constraints (see optimizer_options).
void add_template_constraints(const DesignSetup& setup, const design::CaseFile& c, design::OptimizerOptions& options) {
  if (!c.follow_template || !setup.solver) return;
  const design::TemplateRegions t = design::template_regions(setup.brim.kind());
  if (t.uniform && options.objective == design::OptimizerOptions::Objective::Pressure)
    options.objective = design::OptimizerOptions::Objective::Uniform;
  if (t.tolerant.empty()) return;
  constexpr double kMargin = 0.05;
  const auto& solver = *setup.solver;
  auto m = design::template_masks(setup.brim.kind(), setup.model.landmarks, solver.skin().positions,
                                  above_brim(setup), setup.model.frame, setup.model.length_m);
  const auto any = [](const std::vector<char>& v) { return std::any_of(v.begin(), v.end(), [](char flag) { return flag != 0; }); };
  if (any(m.tolerant) && any(m.sensitive)) {
    design::OptimizerOptions::PressureRatio r;
    r.name = "tolerant / sensitive";
    r.bearing = std::move(m.tolerant);
    r.relieved = std::move(m.sensitive);
    r.min_ratio = design::kMinTolerantToSensitive * (1 + kMargin);
    options.pressure_ratios.push_back(std::move(r));
  }
  design::OptimizerOptions::RegionShare d;
  d.name = "distal fifth";
  d.nodes = std::move(m.distal_fifth);
  d.max_share = design::kMaxDistalFifthShare * (1 - kMargin);
  options.region_shares.push_back(std::move(d));
}

}  // namespace

design::OptimizerOptions optimizer_options(const DesignSetup& setup, const design::CaseFile& c) {
  design::OptimizerOptions oo;
  oo.objective = c.objective;
  oo.model_pressure_limit = c.model_pressure_limit;
  oo.time_limit_s = c.time_limit_s;
  if (const auto floor = ischial_floor(setup)) oo.region_shares.push_back(*floor);
  add_template_constraints(setup, c, oo);
  return oo;
}

tissue::TissueMaterial material(const design::CaseFile& c) { return {c.youngs_modulus_pa, c.density_kg_m3}; }

std::unique_ptr<DesignSetup> prepare_design(const design::CaseFile& c, const fs::path& generated_limb_stl,
                                            const ProgressCallback& progress) {
  auto s = std::make_unique<DesignSetup>();
  s->case_file = c;
  report_progress(progress, 0.0, "design: reading the limb");
  const auto [limb, extra] = load_limb(c, generated_limb_stl, s->limb_label);
  s->limb = limb;
  volume::LimbInputOptions lo;
  lo.type = c.limb.type;
  lo.anterior = c.limb.anterior;
  lo.axis = c.limb.axis;
  lo.side = c.limb.side;
  lo.cut_height_m = c.limb.cut_height_m;
  lo.estimate_bones = c.limb.bones != "none";
  lo.force_size = c.limb.force_size;
  s->model = volume::prepare_limb(limb, extra, lo);
  auto& model = s->model;
  for (const auto& [code, p] : c.landmarks) {
    volume::Landmark given;
    given.code = code;
    given.position = p;
    volume::override_landmark(model.landmarks, model.skin, model.frame, given);
    model.notes.push_back(fmt::format("landmark {} given in the case file", code));
  }
  for (const auto& n : model.notes) log::info("design: {}", n);
  // Checks that need the limb, before the expensive steps.
  s->table = c.thresholds.empty() ? design::default_thresholds(model.type) : c.thresholds;
  design::validate_thresholds(s->table, model.landmarks, model.type);
  const design::BrimTemplate kind = c.brim.value_or(design::default_brim(model.type));
  if (!c.brim) model.notes.push_back(fmt::format("brim: {} (the default of a {} limb)", design::to_string(kind),
                                                 geometry::to_string(model.type)));
  if (c.brim_key_points.empty()) {
    std::vector<std::string> clamped;
    s->brim = design::make_brim(kind, model, {}, &clamped);
    for (const auto& n : clamped) {
      log::warn("design: {}", n);
      model.notes.push_back(n);
      s->brim_notes.push_back(n);
    }
  } else {
    s->brim = design::brim_from_key_points(c.brim_key_points, kind);
  }
  design::validate_brim(s->brim, model.skin, model.frame);
  // A TSB brim bears on the whole skin: the background reaches the brim.
  const bool total_surface = design::template_regions(s->brim.kind()).uniform;
  s->spots =
      c.spots.empty() ? design::default_spots(model.type, model.landmarks, model.length_m, total_surface) : c.spots;
  for (const auto& sp : s->spots) design::validate_spot(sp, model.length_m);
  s->regions = design::load_regions(model.type, model.landmarks, model.length_m);

  report_progress(progress, 0.1, "design: meshing the stump");
  volume::HexMesherOptions mo;
  mo.target_nodes = c.target_nodes;
  mo.progress = [&](double f, std::string_view stage) { return report_progress(progress, 0.1 + 0.8 * f, stage); };
  s->mesh = volume::mesh_limb(volume::mesher_input(model), mo);

  s->model_options = model_options(c);
  s->material = material(c);
  const auto skin0 = volume::extract_skin_surface(s->mesh.mesh);
  s->thresholds = design::threshold_map(skin0.positions, model.landmarks, s->table);
  design::DesignSolverOptions so;
  so.mode = c.solve_mode;
  report_progress(progress, 0.92, "design: building the stump model");
  s->solver = std::make_unique<design::DesignSolver>(s->mesh.mesh, s->material, s->model_options, model.frame,
                                                     s->thresholds, c.patient, model.length_m, so);
  const auto& brim = s->brim;
  s->solver->set_brim([&brim](double theta) { return brim.height(theta); });
  report_progress(progress, 1.0, "design: stump model ready");
  return s;
}

design::SocketResult build_design_socket(const geometry::TriMesh& designed_skin, const geometry::TriMesh& rest_skin,
                                         const geometry::LimbFrame& frame, const design::BrimLine& brim,
                                         design::SocketOptions options) {
  options.undeformed_skin = &rest_skin;  // the circumference reductions against the limb at rest
  return design::build_socket(designed_skin, frame, brim, options);
}

DesignResult solve_design(DesignSetup& setup, bool optimise, const ProgressCallback& progress) {
  const design::CaseFile& c = setup.case_file;
  auto& solver = *setup.solver;
  DesignResult r;
  r.optimised = optimise;
  if (optimise) {
    design::OptimizerOptions oo = optimizer_options(setup, c);
    oo.progress = [&](double f, std::string_view stage) { return report_progress(progress, 0.9 * f, stage); };
    r.optimiser = design::optimise_design(solver, setup.spots, oo);
    r.spots = r.optimiser.spots;
    r.state = r.optimiser.state;
    for (const auto& l : r.optimiser.log) log::info("design: {}", l);
  } else {
    report_progress(progress, 0.1, "design: solving the stump under the spots");
    r.spots = setup.spots;
    r.state = solver.solve(r.spots);
  }
  r.constraints_met = r.state.status.all_ok();
  r.region_loads = design::region_loads(setup.regions, solver.skin_cylindrical(), solver.above_brim(), r.state,
                                        setup.model.frame, c.patient.friction);
  // Deformed and rest skin as triangles (local ids = skin order).
  r.rest_skin = solver.skin().triangles();
  r.deformed_skin = r.rest_skin;
  r.deformed_skin.vertices = r.state.skin_positions;
  if (r.constraints_met) {
    report_progress(progress, 0.92, "design: building the socket");
    r.socket = build_design_socket(r.deformed_skin, r.rest_skin, setup.model.frame, setup.brim, c.socket);
    for (const auto& n : r.socket->notes) log::info("design: socket: {}", n);
    // Limb volume below the brim: the same cavity measure on the undeformed skin.
    try {
      design::SocketOptions lopt = c.socket;
      lopt.undeformed_skin = nullptr;
      lopt.distal_pad = false;  // the cavity alone: no platform, no holes
      lopt.attachment.enabled = false;
      r.limb_volume_below_brim_m3 = design::build_socket(r.rest_skin, setup.model.frame, setup.brim, lopt).cavity_volume_m3;
    } catch (const Error&) {
      r.limb_volume_below_brim_m3 = 0;
    }
    if (c.closed_loop) {
      ClosedLoopOptions lo;
      lo.max_donnings = c.closed_loop_donnings;
      lo.progress = [&](double f, std::string_view stage) { return report_progress(progress, 0.93 + 0.07 * f, stage); };
      r.closed_loop = close_design_loop(setup, r, lo);
      log::info("design: closed loop: {}", r.closed_loop->message);
      r.socket = r.closed_loop->socket;
    }
    // Transfemoral: where the built socket holds the bony ischial tuberosity, in 3D.
    if (setup.model.transfemoral)
      r.ischial_check = design::check_ischial_tuberosity(setup.brim, setup.model.frame,
                                                         setup.model.transfemoral->ischial_tuberosity, *r.socket);
  }
  report_progress(progress, 1.0, "design: solved");
  return r;
}

Vec3 skin_point(const DesignSetup& setup, double theta, double h) {
  // The ray from the axis at (θ, h) — radius from the nearest skin node (rest coordinates).
  double best = 1e9, rho = 0;
  for (const auto& cy : setup.solver->skin_cylindrical()) {
    const double d = std::abs(design::wrap_angle(cy.theta - theta)) * cy.rho + std::abs(cy.h - h);
    if (d < best) {
      best = d;
      rho = cy.rho;
    }
  }
  return setup.model.frame.from_cylindrical({rho, theta, h});
}

std::vector<Vec3> brim_on_skin(const DesignSetup& setup, int samples) {
  std::vector<Vec3> poly;
  for (int k = 0; k < samples; ++k) {
    const double th = -std::numbers::pi + 2 * std::numbers::pi * k / samples;
    poly.push_back(skin_point(setup, th, setup.brim.height(th)));
  }
  return poly;
}

design::TemplateCheck template_check(const DesignSetup& setup, const design::DesignState& state) {
  const std::vector<char> above = above_brim(setup);
  design::SkinLoads loads;
  loads.rest_positions = &setup.solver->skin().positions;
  loads.normals = &state.skin_normals;
  loads.areas_m2 = &state.skin_areas;
  loads.pressures_pa = &state.pressure_pa;
  loads.above_brim = &above;
  return design::check_template(setup.brim.kind(), setup.model.landmarks, loads, setup.model.frame,
                                setup.model.length_m, setup.solver->patient().friction);
}

std::vector<report::RadarAxis> radar_axes(const DesignSetup& setup, const design::DesignState& state) {
  const design::CaseFile& c = setup.case_file;
  report::RadarInputs ri;
  ri.force_n = state.radar.force_n;
  ri.torque_nm = state.radar.torque_nm;
  ri.stability_n = state.radar.stability_n;
  ri.body_mass_kg = c.patient.body_mass_kg;
  ri.prosthesis_mass_kg = c.patient.prosthesis_mass_kg;
  ri.stump_length_m = setup.model.length_m;
  ri.force_tolerance = c.patient.force_tolerance;
  ri.torque_tolerance = c.patient.torque_tolerance;
  ri.gravity = units::kGravity;
  auto axes = report::seven_radar_axes(ri);
  const bool* oks[] = {&state.status.force_ok[0], &state.status.force_ok[1], &state.status.force_ok[2],
                       &state.status.torque_ok[0], &state.status.torque_ok[1], &state.status.torque_ok[2],
                       &state.status.stability_ok};
  for (size_t k = 0; k < axes.size() && k < 7; ++k) axes[k].is_ok = *oks[k];
  return axes;
}

std::vector<DesignPath> design_paths(const DesignSetup& setup) {
  double pt_theta = 0;
  for (const auto& l : setup.model.landmarks)
    if (l.code == "PT") pt_theta = l.cylindrical.theta;
  // The thesis's three paths, shared with the CalculiX comparison (report::thesis_paths).
  std::vector<DesignPath> out;
  for (auto& t : report::thesis_paths(pt_theta, 0.5 * setup.model.length_m, setup.solver->skin().area_m2)) {
    const std::string key = t.key == "front" ? "front_line" : t.key == "back" ? "back_line" : "mid_circumference";
    out.push_back(DesignPath{key, t.label, t.spec});
  }
  return out;
}

std::vector<report::PathProfile> pressure_profiles(const DesignSetup& setup, const design::DesignState& state) {
  const auto sframe = report::surface_frame(setup.model.frame);
  std::vector<report::PathProfile> profiles;
  for (const auto& p : design_paths(setup)) {
    const auto samples = report::sample_path(setup.solver->skin().positions, {}, sframe, p.spec);
    profiles.push_back(report::make_path_profile(p.name, p.spec.kind, samples, state.pressure_pa, setup.thresholds));
  }
  return profiles;
}

nlohmann::json write_design_outputs(const DesignSetup& setup, const DesignResult& result, const fs::path& out,
                                    double seconds) {
  ensure_directory(out);
  const design::CaseFile& c = setup.case_file;
  const auto& model = setup.model;
  const auto& mesh = setup.mesh;
  const auto& solver = *setup.solver;
  const auto& brim = setup.brim;
  const auto& thresholds = setup.thresholds;
  const auto& limb_label = setup.limb_label;
  const auto& state = result.state;
  const auto& opt = result.optimiser;
  const auto& spots = result.spots;
  const bool optimise = result.optimised;
  const bool met = result.constraints_met;
  // A socket of an earlier run would sit beside this run's report as if it were this design's.
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

  // Outputs: surface nodes, stump fields, pictures, socket, report, case replay.
  const auto& skin = solver.skin();
  const auto& above = solver.above_brim();
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
  const geometry::TriMesh& def_tri = result.deformed_skin;
  // Pictures.
  const auto sframe = report::surface_frame(model.frame);
  std::vector<report::MapLandmark> marks;
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
    report::PressureMapData m;
    m.surface = &def_tri;
    m.values = v;
    m.value_label = label;
    m.title = title;
    m.value_min = lo;
    m.value_max = hi;
    m.frame = sframe;
    m.landmarks = marks;
    m.brim = brim_poly;
    return m;
  };
  std::vector<report::PressureMapData> maps{
      make_map(p_kpa, "kPa", "Applied pressure (socket inner surface)", 0, 0),
      make_map(ratio, "p/T", "Pressure / pain threshold", 0, 1.2),
      make_map(thr_kpa, "kPa", "Pain-threshold map (IDW from the landmarks)", 0, 0),
      make_map(disp_mm, "mm", "Tissue displacement", 0, 0)};
  report::write_pressure_map(out / "pressure_map.png", maps[0]);
  report::write_pressure_map(out / "ratio_map.png", maps[1]);
  report::RadarChart radar;
  radar.title = met ? "Constraints: all met" : "Constraints: NOT all met";
  radar.axes = radar_axes(setup, state);
  report::write_radar_chart(out / "radar.png", radar);
  // Paths: front line through PT, back line, mid-stump circumference.
  const std::vector<report::PathProfile> profiles = pressure_profiles(setup, state);
  for (size_t k = 0; k < profiles.size(); ++k)
    report::write_svg(out / fmt::format("profile_{}.svg", k == 0 ? "front" : k == 1 ? "back" : "mid"),
                      report::path_profile_plot(profiles[k]));

  // Socket (only for a valid design: never a socket that violates the constraints).
  nlohmann::json socket_json;
  report::ReportSocket rs;
  rs.thickness_m = c.socket.thickness_m;
  if (result.socket) {
    const auto& sock = *result.socket;
    design::write_socket_stl(out / "socket.stl", sock);
    rs.has_socket = true;
    rs.socket_volume_m3 = sock.cavity_volume_m3;
    rs.stl_file = "socket.stl";
    rs.limb_volume_m3 = result.limb_volume_below_brim_m3;
    nlohmann::json levels = nlohmann::json::array();
    for (const auto& l : sock.levels) {
      levels.push_back({{"h_mm", l.h_m * 1e3},
                        {"socket_mm", l.inner_circumference_m * 1e3},
                        {"limb_mm", l.limb_circumference_m * 1e3},
                        {"reduction_percent", l.reduction_percent}});
    }
    socket_json = {{"file", "socket.stl"},
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
  // The design as a case file that replays it (spots fixed, no optimisation).
  design::CaseFile replay = c;
  replay.spots = spots;
  replay.optimise = false;
  replay.brim = brim.kind();
  if (!c.limb.file.empty()) replay.limb.file = fs::absolute(design::resolve(c, c.limb.file)).string();
  if (c.limb.bones != "auto" && c.limb.bones != "estimate" && c.limb.bones != "none")
    replay.limb.bones = fs::absolute(design::resolve(c, c.limb.bones)).string();
  replay.folder.clear();
  design::write_case(out / "design_case.json", replay);

  // Report.
  report::DesignReportData rd;
  rd.patient.id = c.patient_id;
  rd.patient.body_mass_kg = c.patient.body_mass_kg;
  rd.patient.prosthesis_mass_kg = c.patient.prosthesis_mass_kg;
  rd.patient.tissue_youngs_modulus_pa = c.youngs_modulus_pa;
  rd.patient.friction = c.patient.friction;
  rd.patient.note = c.patient_note;
  rd.generated = "socketsmith 0.1.0";
  rd.limb_file = limb_label;
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
  for (const auto& s : spots) rd.spots.push_back(report_spot(s));
  rd.brim_template = brim.name();
  for (const auto& k : brim.key_points()) rd.brim_key_points.push_back({k.theta, k.h});
  rd.radar = radar;
  rd.maps = maps;
  rd.profiles = profiles;
  rd.max_pressure_ratio = state.max_requested_ratio;
  if (state.max_ratio_node >= 0) {
    rd.has_max_ratio_position = true;
    rd.max_ratio_position = skin.positions[state.max_ratio_node];
  }
  rd.max_pressure_pa = *std::max_element(state.pressure_pa.begin(), state.pressure_pa.end());
  rd.landmarks = marks;
  for (const auto& r : result.region_loads)
    rd.region_loads.push_back({r.name, r.share, r.axial_n, r.friction_axial_n, r.area_m2, r.mean_pressure_pa,
                               r.peak_pressure_pa, r.key == "ischial_gluteal"});
  if (model.type == geometry::LimbType::Transfemoral && ischial_share_floor(setup) > 0)
    rd.region_note = fmt::format("The {} template asks the optimiser for at least {:.0f} % on the ischial / gluteal "
                                 "region{}.",
                                 brim.name(), 100 * ischial_share_floor(setup),
                                 ischial_floor_holds(setup, result) ? "" : " — the final design does not keep it");
  rd.socket = rs;
  // What a prosthetist checks: the rectification chart and the slice measurements.
  const nlohmann::json checks_json = write_prosthetist_checks(setup, result, prosthetist_checks(setup, result), out, rd);
  nlohmann::json closed_loop_json;
  if (result.closed_loop) closed_loop_json = write_closed_loop_outputs(setup, result, out, rd.delivery);
  nlohmann::json sock_ply_json;
  if (result.sock_ply) sock_ply_json = write_sock_ply_outputs(setup, result, out, rd.sock_ply);
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
  // The design read against its template (tolerant vs sensitive regions, the distal fifth's load).
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
  const nlohmann::json template_json = {{"template", tc.template_name},
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
  report::write_design_report_html(out / "report.html", rd);

  // Summary.
  const auto& T = solver.targets();
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
      {"radar",
       {{"fx_n", state.radar.force_n.x()},
        {"fy_n", state.radar.force_n.y()},
        {"fz_n", state.radar.force_n.z()},
        {"tx_nm", state.radar.torque_nm.x()},
        {"ty_nm", state.radar.torque_nm.y()},
        {"tz_nm", state.radar.torque_nm.z()},
        {"stability_n", state.radar.stability_n}}},
      {"targets",
       {{"fx_n", 0.0},
        {"fy_n", 0.0},
        {"fz_n", T.fz_n},
        {"tx_nm", 0.0},
        {"ty_nm", 0.0},
        {"tz_nm", 0.0},
        {"stability_min_n", T.stability_min_n},
        {"force_tolerance_n", T.force_tol_n},
        {"torque_tolerance_nm", T.torque_tol_nm}}},
      {"frame",
       {{"origin_m", vec_json(model.frame.origin)},
        {"axis", vec_json(model.frame.axis)},
        {"anterior", vec_json(model.frame.anterior)},
        {"medial", vec_json(model.frame.medial())}}},
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
      {"linearised", state.linearised || c.solve_mode == design::DesignSolveMode::Linear},
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
  if (!socket_json.is_null()) j["socket"] = socket_json;
  j["frame"]["axis_source"] = model.axis_source;
  j["frame"]["anterior_source"] = model.anterior_source;
  j["frame"]["side"] = geometry::to_string(model.frame.side);
  j["frame"]["side_estimated"] = model.frame.side_estimated;
  j["brim"]["key_points"] = nlohmann::json::array();
  for (const auto& k : brim.key_points())
    j["brim"]["key_points"].push_back({{"label", k.label}, {"theta_deg", k.theta / units::deg}, {"h_mm", k.h * 1e3}});
  j["brim"]["notes"] = setup.brim_notes;
  {
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
  j["skin_extension_mm"] = model.skin_extension_m * 1e3;
  j["skin_extension_area_percent"] = 100 * model.skin_extension_area_fraction;
  j["limb_notes"] = model.notes;
  {
    nlohmann::json lms = nlohmann::json::array();
    for (const auto& l : model.landmarks)
      lms.push_back({{"code", l.code},
                     {"name", l.name},
                     {"theta_deg", l.cylindrical.theta / units::deg},
                     {"h_mm", l.cylindrical.h * 1e3},
                     {"position_mm", vec_json(l.position * 1e3)},
                     {"estimated", l.estimated}});
    j["landmarks"] = lms;
  }
  j["rectification"] = checks_json["rectification"];
  j["slices"] = checks_json["slices"];
  for (const char* o : {"rectification_map.png", "rectification.csv", "slices.csv"}) j["outputs"].push_back(o);
  j["template_regions"] = template_json;
  if (!sock_ply_json.is_null()) {
    j["sock_ply"] = sock_ply_json;
    for (const auto& o : sock_ply_json["outputs"]) j["outputs"].push_back(o);
  }
  if (!closed_loop_json.is_null()) {
    j["closed_loop"] = closed_loop_json;
    for (const auto& o : closed_loop_json["outputs"]) j["outputs"].push_back(o);
  }
  write_text_atomically(out / "design.json", j.dump(2) + "\n");
  return j;
}

nlohmann::json run_design(const design::CaseFile& c, const fs::path& out, bool optimise,
                          const ProgressCallback& progress, DesignArtifacts* artifacts) {
  const auto t0 = std::chrono::steady_clock::now();
  ensure_directory(out);
  const auto stage = [&](double a, double b) {
    return [&progress, a, b](double f, std::string_view s) { return report_progress(progress, a + (b - a) * f, s); };
  };
  auto setup = prepare_design(c, c.limb.file.empty() ? out / "limb.stl" : fs::path(), stage(0.0, 0.45));
  DesignResult result = solve_design(*setup, optimise, stage(0.45, 0.9));
  report_progress(progress, 0.9, "design: writing the socket and the report");
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  nlohmann::json j = write_design_outputs(*setup, result, out, seconds);
  report_progress(progress, 1.0, "design: done");
  if (artifacts) {
    artifacts->setup = std::move(setup);
    artifacts->result = std::move(result);
  }
  return j;
}

design::CaseFile demo_case(int target_nodes) {
  design::CaseFile c;
  c.patient_id = "demo (generated limb)";
  c.patient.body_mass_kg = 70;
  c.youngs_modulus_pa = 100e3;
  c.target_nodes = target_nodes;
  c.socket.distal_pad = true;
  // The sample's coarse skin (1.8–3k nodes) leaves a pointed, coarsely faceted distal end; one
  // subdivision keeps the socket's facets fine enough there for the donning's smooth wall, which
  // fits quadrics over each vertex's edges (with the unsubdivided socket the 1.8k sample's donning
  // pressed 65 kPa at the tip, 0.32 mm into it; docs/contact.md). Until 2026-11-25 the distal pad's
  // self-intersection made every demo socket subdivide once anyway.
  c.socket.subdivisions = 1;
  return c;
}

}  // namespace socketsmith::pipeline
