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


/// The limb surface (and a separate bone file's shells) of a case, in metres; @p info receives
/// what the limb file says beside its surface (an AAOP file's side and landmarks).
std::pair<geometry::TriMesh, geometry::TriMesh> load_limb(const design::CaseFile& c, const fs::path& generated_stl,
                                                          std::string& label, geometry::MeshReadInfo& info) {
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
  limb = geometry::read_mesh(design::resolve(c, c.limb.file), ro, &info);
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
  if (tissue::is_continuum(o.kind)) o.hex_formulation = c.element;
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
  geometry::MeshReadInfo file;
  const auto [limb, extra] = load_limb(c, generated_limb_stl, s->limb_label, file);
  s->limb = limb;
  volume::LimbInputOptions lo{.type = c.limb.type, .axis = c.limb.axis, .anterior = c.limb.anterior,
                              .side = c.limb.side, .cut_height_m = c.limb.cut_height_m,
                              .estimate_bones = c.limb.bones != "none", .force_size = c.limb.force_size};
  const std::vector<std::string> from_file = volume::apply_file_hints(lo, file);
  s->model = volume::prepare_limb(limb, extra, lo);
  auto& model = s->model;
  model.notes.insert(model.notes.begin(), from_file.begin(), from_file.end());
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
  s->solver->set_brim_flare(design::brim_flare_m(c));
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

ClosedLoopOptions closed_loop_options(const design::CaseFile& c) {
  ClosedLoopOptions lo;
  lo.max_donnings = c.closed_loop_donnings;
  lo.max_brim_raise_m = c.closed_loop_max_brim_raise_m;
  lo.max_roughness_m = c.closed_loop_max_roughness_m;
  lo.donning.step_m = c.closed_loop_step_m;
  lo.donning.contact.augmented_tol = case_augmented_tol(c);
  return lo;
}

double case_augmented_tol(const design::CaseFile& c) {
  return c.closed_loop_rigid_wall ? contact::kRigidWallAugmentedTol : 0.0;
}

bool design_body_linearised(const design::DesignState& state, const design::CaseFile& c) {
  return state.linearised || c.solve_mode == design::DesignSolveMode::Linear;
}

namespace {

/// @p r's spots optimised from the setup's (@p optimise) or solved as the setup gives them, and the
/// stump under them: its state, the constraints, the loads by region and the skins.
void solve_spots(DesignSetup& setup, DesignResult& r, bool optimise, const ProgressCallback& progress) {
  const design::CaseFile& c = setup.case_file;
  auto& solver = *setup.solver;
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
}

/// @p r's socket, and the closed loop when the case asks for it (only when every constraint holds).
void build_socket_and_close_loop(DesignSetup& setup, DesignResult& r, const ProgressCallback& progress) {
  const design::CaseFile& c = setup.case_file;
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
  if (!design::closes_loop(c)) return;
  ClosedLoopOptions lo = closed_loop_options(c);
  lo.progress = [&](double f, std::string_view stage) { return report_progress(progress, 0.93 + 0.07 * f, stage); };
  try {
    r.closed_loop = close_design_loop(setup, r, lo);
    if (r.closed_loop->converged || lo.max_donnings == 1)  // 1: the open-loop socket measured only
      log::info("design: closed loop: {}", r.closed_loop->message);
    else  // the socket written is the loop's best, short of its tolerances: said where it is seen
      log::warn("design: closed loop: {}; the socket written is the best one it donned", r.closed_loop->message);
    r.socket = r.closed_loop->socket;
  } catch (const Error& e) {
    if (c.closed_loop.has_value()) throw;  // asked for by name: the design fails with the reason
    r.closed_loop_failed = e.what();
    log::warn("design: the closed loop failed ({}); the open-loop socket is written, which does not deliver its "
              "design as closely (set design.closed_loop to false to skip the loop, or true to make this an error)",
              r.closed_loop_failed);
  }
}

/// The closed loop's socket of @p r ranked as the loop ranks its own (kept_rank, then bar_score):
/// true when @p b's delivers its design better than @p a's.
bool delivers_better(const ClosedLoopResult& b, const ClosedLoopResult& a) {
  const ClosedLoopIteration &kb = b.iterations[b.best], &ka = a.iterations[a.best];
  return replaces_kept(b.converged, kb.bar_met, bar_score(kb), kept_rank(a.converged, ka.bar_met), bar_score(ka));
}

/// The design again with the drag band (DragBand): no pressure asked of the skin below the brim
/// that @p r's loop saw dragged out of the socket. Kept when its own loop delivers its design
/// better; otherwise @p r stays, the band is undone and DragBand says so.
void design_again_with_drag_band(DesignSetup& setup, DesignResult& r, const ProgressCallback& progress) {
  auto& solver = *setup.solver;
  const ClosedLoopResult& loop = *r.closed_loop;
  DragBand band = drag_band(solver, setup.brim, loop);
  // Nothing to gain, or the run was cancelled (the progress callback says so again).
  if (band.lifts.empty() || !report_progress(progress, 0.0, "design: the drag band")) return;
  const ProgressCallback again = [&progress](double f, std::string_view stage) {
    return report_progress(progress, f, fmt::format("{} (again, with the drag band)", stage));
  };
  const auto& brim = setup.brim;
  auto set_band = [&](bool on) {
    if (on)
      solver.set_brim_band([lifts = band.lifts](double theta) { return design::eased_lift(lifts, kDragBandPlateau, theta); });
    else
      solver.set_brim_band({});
    solver.set_brim([&brim](double theta) { return brim.height(theta); });
  };
  log::info("design: {} skin nodes below the brim, designed up to {:.1f} kPa, were dragged out of the socket by its "
            "donning; designing again with no pressure asked up to {:.1f} mm below the brim there",
            band.node_ids.size(), band.max_designed_pa / 1e3, band.max_depth_m * 1e3);
  band.first_score = bar_score(loop.iterations[loop.best]);
  set_band(true);
  DesignResult r2;
  solve_spots(setup, r2, r.optimised, again);
  if (r2.constraints_met) {
    try {
      build_socket_and_close_loop(setup, r2, again);
    } catch (const Error& e) {
      band.why_not = e.what();
    }
  } else {
    band.why_not = "the design with the band does not meet its constraints";
  }
  if (band.why_not.empty() && !r2.closed_loop)
    band.why_not = r2.closed_loop_failed.empty() ? "no closed loop" : r2.closed_loop_failed;
  // (The first missed the delivery bar, so a second that meets it is better: no better means missed too.)
  if (band.why_not.empty() && !delivers_better(*r2.closed_loop, loop))
    band.why_not = "its socket delivers its design no better (the delivery bar missed)";
  band.kept = band.why_not.empty();
  if (band.kept) {
    log::info("design: the design with the drag band is kept: {}", r2.closed_loop->message);
    r = std::move(r2);
  } else {
    log::info("design: the design with the drag band is not kept: {}", band.why_not);
    set_band(false);
  }
  r.drag_band = std::move(band);
}

}  // namespace

DesignResult solve_design(DesignSetup& setup, bool optimise, const ProgressCallback& progress) {
  const design::CaseFile& c = setup.case_file;
  DesignResult r;
  solve_spots(setup, r, optimise, progress);
  if (r.constraints_met) {
    build_socket_and_close_loop(setup, r, progress);
    // ... unless the loop only measures the open-loop socket (one donning).
    if (c.closed_loop_drag_band && c.closed_loop_donnings > 1 && r.closed_loop &&
        !r.closed_loop->iterations[r.closed_loop->best].bar_met)
      design_again_with_drag_band(setup, r, progress);
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
  const report::RadarInputs ri{.force_n = state.radar.force_n, .torque_nm = state.radar.torque_nm,
                               .stability_n = state.radar.stability_n, .body_mass_kg = c.patient.body_mass_kg,
                               .prosthesis_mass_kg = c.patient.prosthesis_mass_kg,
                               .stump_length_m = setup.model.length_m, .force_tolerance = c.patient.force_tolerance,
                               .torque_tolerance = c.patient.torque_tolerance, .gravity = units::kGravity};
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
  // pressed 65 kPa at the tip, 0.32 mm into it; docs/contact.md).
  c.socket.subdivisions = 1;
  return c;
}

}  // namespace socketsmith::pipeline
