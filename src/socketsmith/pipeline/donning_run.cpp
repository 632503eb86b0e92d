// A donning run (`simulate donning`) and its outputs — the series, the contact on the donned skin,
// the stump for ParaView, the maps, the force plot, the agreement with the design and donning.json —
// and the sock-ply study of a case (`simulate sockply`). Why apart from sock_ply.cpp and
// closed_loop.cpp: those are the solvers' loops; this is a run of a request into files.
#include <chrono>
#include <cmath>
#include <filesystem>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/core/units.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/pipeline/donning_run.h"
#include "socketsmith/report/csv.h"
#include "socketsmith/report/design_report.h"
#include "socketsmith/report/field_comparison.h"
#include "socketsmith/report/svg_plot.h"
#include "socketsmith/report/vtk_writer.h"

namespace socketsmith::pipeline {
namespace {

namespace fs = std::filesystem;
using geometry::Vec3;

/// Contact (a) against designed (b) pressure on the skin nodes where @p mask is set, in kPa.
nlohmann::json agreement_json(const std::vector<double>& contact_pa, const std::vector<double>& designed_pa,
                              const std::vector<char>& mask) {
  std::vector<int> subset;
  for (size_t i = 0; i < mask.size(); ++i)
    if (mask[i]) subset.push_back(static_cast<int>(i));
  return report::to_json(report::compare_fields(contact_pa, designed_pa, subset), 1e-3, "_kpa");
}

/// The stump and the socket to don: the case's own design (with its result), or a limb and a
/// given socket.
struct DonningInput {
  design::CaseFile c;
  std::unique_ptr<DesignSetup> setup;
  std::optional<DesignResult> designed;
  geometry::TriMesh socket_solid;
  std::string socket_label;  ///< the socket's file, as the log and donning.json name it
};

/// donning.csv: one row per accepted step.
void write_donning_series(const fs::path& out, const contact::DonningResult& r) {
  report::CsvTable t;
  t.header = {"time",         "socket_position_mm", "reaction_force_n",   "lateral_force_n",   "contact_nodes",
              "sliding_nodes", "max_pressure_kpa",   "mean_pressure_kpa", "max_penetration_mm", "newton_iterations",
              "friction_passes", "factorizations", "seconds"};
  for (size_t k = 0; k < r.series.size(); ++k) {
    const auto& s = r.series[k];
    t.rows.push_back({static_cast<double>(k + 1), s.offset_m * 1e3, s.axial_force_n, s.lateral_force_n,
                      static_cast<double>(s.contact_nodes), static_cast<double>(s.sliding_nodes),
                      s.max_pressure_pa / 1e3, s.mean_pressure_pa / 1e3, s.max_penetration_m * 1e3,
                      static_cast<double>(s.newton_iterations), static_cast<double>(s.friction_passes),
                      static_cast<double>(s.factorizations), s.seconds});
  }
  report::write_csv(out / "donning.csv", t.header, t.rows, 9);
}

/// Per skin node after donning: the deformed position, normal and area, the contact pressure, the
/// designed pressure (0 without a design) [Pa], and whether the node lies below the brim.
struct DonnedSkin {
  std::vector<Vec3> pos, nrm;
  std::vector<double> area, pc, pd;
  std::vector<char> below;
};

DonnedSkin donned_skin(const design::DesignSolver& solver, const contact::DonningResult& r,
                       const std::optional<DesignResult>& designed) {
  const volume::SkinSurface& s0 = solver.skin();
  const size_t ns = s0.nodes.size();
  DonnedSkin d;
  d.pos.resize(ns);
  d.pc.resize(ns);
  d.pd.assign(ns, 0.0);
  d.below.assign(ns, 1);
  for (size_t i = 0; i < ns; ++i) {
    d.pos[i] = r.positions.segment<3>(3 * s0.nodes[i]);
    d.pc[i] = r.contacts[i].pressure_pa;
  }
  // Deformed normals and areas from the final positions.
  tissue::VectorXd x = r.positions;
  std::vector<Vec3> p2;
  solver.skin_geometry(x, p2, d.nrm, d.area);
  const auto& above = solver.above_brim();
  for (size_t i = 0; i < ns; ++i) d.below[i] = above[i] ? 0 : 1;
  if (designed) d.pd = designed->state.pressure_pa;
  return d;
}

/// contact.csv: the columns of surface_nodes.csv, pressure = contact pressure (+ the designed one),
/// then the socket wall's normal where the node touches it and the friction's shear traction on the
/// skin [Pa] (friction force over the same nodal area as the pressure; zeros off contact).
void write_contact_csv(const fs::path& out, const DonnedSkin& d, const std::vector<double>& thresholds,
                       const contact::DonningResult& r) {
  report::CsvTable t;
  t.header = {"x_m",     "y_m",         "z_m",          "nx",          "ny",      "nz",      "area_m2",
              "pressure_pa", "threshold_pa", "above_brim", "designed_pressure_pa", "sliding", "gap_m",
              "wall_nx", "wall_ny", "wall_nz", "shear_x_pa", "shear_y_pa", "shear_z_pa"};
  for (size_t i = 0; i < d.pos.size(); ++i) {
    const contact::NodeContact& c = r.contacts[i];
    const Vec3 shear = c.normal_force_n > 0 ? Vec3(c.tangential_n * (c.pressure_pa / c.normal_force_n)) : Vec3::Zero();
    t.rows.push_back({d.pos[i].x(), d.pos[i].y(), d.pos[i].z(), d.nrm[i].x(), d.nrm[i].y(), d.nrm[i].z(), d.area[i],
                      d.pc[i], thresholds[i], d.below[i] ? 0.0 : 1.0, d.pd[i], c.sliding ? 1.0 : 0.0, c.gap_m,
                      c.normal.x(), c.normal.y(), c.normal.z(), shear.x(), shear.y(), shear.z()});
  }
  report::write_csv(out / "contact.csv", t.header, t.rows, 12);
}

/// stump.vtu, for ParaView: the displacement and the contact and designed pressures on the nodes.
void write_donned_stump(const fs::path& out, const volume::HexMesh& mesh, const volume::SkinSurface& skin,
                        const contact::DonningResult& r, const DonnedSkin& d) {
  const int nn = mesh.num_nodes();
  std::vector<Vec3> u(nn);
  std::vector<double> pcn(nn, 0.0), pdn(nn, 0.0);
  for (int k = 0; k < nn; ++k) u[k] = r.positions.segment<3>(3 * k) - mesh.nodes[k];
  for (size_t i = 0; i < skin.nodes.size(); ++i) {
    pcn[skin.nodes[i]] = d.pc[i];
    pdn[skin.nodes[i]] = d.pd[i];
  }
  report::write_vtu(out / "stump.vtu", mesh,
                    {report::make_vector_field("displacement_m", u), {"contact_pressure_pa", 1, pcn},
                     {"designed_pressure_pa", 1, pdn}},
                    {});
}

/// Pressure maps on the deformed skin: the contact's, and the designed one beside it on the same
/// scale when there is a design.
void write_donning_maps(const fs::path& out, const DesignSetup& setup, const report::SurfaceFrame& sframe,
                        const DonnedSkin& d, bool has_design) {
  geometry::TriMesh def_tri = setup.solver->skin().triangles();
  def_tri.vertices = d.pos;
  std::vector<report::MapLandmark> marks;
  for (const auto& l : setup.model.landmarks) marks.push_back({l.code, l.position, l.estimated});
  double vmax = 0;
  for (size_t i = 0; i < d.pos.size(); ++i) vmax = std::max({vmax, d.pc[i] / 1e3, d.pd[i] / 1e3});
  const auto map = [&](const std::vector<double>& p, const std::string& title) {
    report::PressureMapData m;
    m.surface = &def_tri;
    for (double v : p) m.values.push_back(v / 1e3);
    m.value_label = "kPa";
    m.title = title;
    m.value_min = 0;
    m.value_max = std::max(vmax, 1e-3);
    m.frame = sframe;
    m.landmarks = marks;
    return m;
  };
  report::write_pressure_map(out / "contact_map.png", map(d.pc, "Contact pressure after donning"));
  if (has_design) report::write_pressure_map(out / "designed_map.png", map(d.pd, "Designed pressure (same scale)"));
}

/// donning_force.svg: the axial force along the socket's path.
void write_donning_force_plot(const fs::path& out, const contact::DonningResult& r) {
  report::Plot p;
  p.title = "Donning: reaction of the stump on the socket";
  p.x_label = "socket position relative to the designed pose [mm]";
  p.y_label = "axial force [N]";
  report::PlotSeries s;
  s.name = "axial force";
  for (const auto& d : r.series) {
    s.x.push_back(d.offset_m * 1e3);
    s.y.push_back(d.axial_force_n);
  }
  s.markers = true;
  p.series.push_back(s);
  report::write_svg(out / "donning_force.svg", p);
}

/// Agreement of the contact pressure with the design's: below the brim, and along the front line,
/// back line and mid circumference where at least 3 of their nodes lie below the brim.
nlohmann::json design_agreement(const DesignSetup& setup, const report::SurfaceFrame& sframe,
                                const DonnedSkin& d) {
  nlohmann::json agreement;
  agreement["below_brim"] = agreement_json(d.pc, d.pd, d.below);
  for (const auto& path : design_paths(setup)) {
    std::vector<char> m(d.pos.size(), 0);
    for (const auto& s : report::sample_path(setup.solver->skin().positions, {}, sframe, path.spec))
      if (d.below[s.index]) m[s.index] = 1;
    int count = 0;
    for (char v : m) count += v;
    if (count >= 3) agreement[path.key] = agreement_json(d.pc, d.pd, m);
  }
  return agreement;
}

/// donning.json: the run's settings, its outcome, the final step and (with a design) the agreement.
nlohmann::json donning_summary(const DonningInput& in, const contact::DonningResult& r,
                               const contact::DonningOptions& o, const fs::path& out, const nlohmann::json& agreement) {
  const contact::DonningSample last = last_sample(r);
  nlohmann::json j{{"socket", in.socket_label},
                   {"completed", r.completed},
                   {"stood", r.stood},
                   {"message", r.message},
                   {"nodes", in.setup->mesh.mesh.num_nodes()},
                   {"skin_nodes", in.setup->solver->skin().nodes.size()},
                   {"steps", r.series.size()},
                   {"rejected_steps", r.rejected_steps}, {"max_sidestep_mm", r.max_sidestep_m * 1e3},
                   {"max_step_mm", o.step_m * 1e3},
                   {"stick_stiffness_ratio", o.contact.stick_stiffness_ratio},
                   {"start_offset_mm", r.start_offset_m * 1e3},
                   {"friction", o.friction},
                   {"body", o.contact.linear_body ? "linearised" : "nonlinear"},
                   {"stand_force_n", o.stand_force_n},
                   {"final_offset_mm", r.final_offset_m * 1e3},
                   {"force_on_socket_n", {r.force_on_socket_n.x(), r.force_on_socket_n.y(), r.force_on_socket_n.z()}},
                   {"axial_force_n", last.axial_force_n},
                   {"contact_nodes", last.contact_nodes},
                   {"sliding_nodes", last.sliding_nodes},
                   {"max_pressure_kpa", last.max_pressure_pa / 1e3},
                   {"max_penetration_mm", last.max_penetration_m * 1e3},
                   {"socket_mass_kg", r.socket_mass_kg},
                   {"newton_iterations", r.newton_iterations},
                   {"factorizations", r.series.empty() ? 0L : r.series.back().factorizations},
                   {"donning_seconds", r.seconds},
                   {"out", out.string()},
                   {"outputs", {"donning.csv", "contact.csv", "stump.vtu", "contact_map.png", "donning_force.svg",
                                "donning.json"}}};
  if (in.designed) {
    j["agreement"] = agreement;
    j["outputs"].push_back("designed_map.png");
    j["outputs"].push_back("design/");
  }
  return j;
}

/// Refuses a request that does not name one stump and its socket, and a negative start offset.
void check_request(const DonningRequest& q) {
  require(q.case_file.empty() != q.limb.empty(), "run_donning: give either a case file or a limb and a socket");
  require(q.limb.empty() == q.socket.empty() || !q.case_file.empty(), "run_donning: a limb needs a socket");
  require(std::isfinite(q.start_offset_m) && q.start_offset_m >= 0,
          "run_donning: start offset {} m must be positive (the socket starts that far below the stump)",
          q.start_offset_m);
}

/// The case's design run into @p out / "design", and its socket; refused when the design has none.
DonningInput designed_socket(const DonningRequest& q, const fs::path& out, const ProgressCallback& progress) {
  DonningInput in;
  design::CaseFile& c = in.c;
  c = design::read_case(q.case_file);
  if (q.target_nodes > 0) c.target_nodes = q.target_nodes;
  DesignArtifacts art;
  run_design(c, out / "design", c.optimise, progress, &art);
  require(art.result.socket.has_value(),
          "simulate donning: the case's design does not meet its constraints, so it has no socket to don (see {}); "
          "fix the design first",
          (out / "design" / "report.html").string());
  in.setup = std::move(art.setup);
  in.designed = std::move(art.result);
  in.socket_solid = in.designed->socket->solid;
  in.socket_label = (out / "design" / "socket.stl").string();
  return in;
}

/// The given socket (refused unless closed), then the limb prepared as a case with default settings.
DonningInput given_socket(const DonningRequest& q, const ProgressCallback& progress) {
  DonningInput in;
  // The socket first: a bad file is reported before the stump is meshed.
  geometry::MeshReadOptions ro;
  if (!q.units.empty()) ro.unit = units::parse_length_unit(q.units);
  in.socket_solid = geometry::read_mesh(q.socket, ro);
  const auto rep = geometry::check_mesh(in.socket_solid);
  require<TopologyError>(rep.is_closed(),
                         "simulate donning: the socket {} is not a closed surface ({} boundary edges): give the "
                         "socket as a solid (inner and outer wall joined at the brim)",
                         q.socket.string(), rep.boundary_edges);
  in.socket_label = q.socket.string();
  in.c.limb.file = fs::absolute(q.limb).string();
  in.c.limb.units = q.units;
  if (q.target_nodes > 0) in.c.target_nodes = q.target_nodes;
  in.setup = prepare_design(in.c, {}, progress);
  return in;
}

/// The donning's options from the request, with friction @p mu.
contact::DonningOptions donning_options(const DonningRequest& q, const DonningInput& in, double mu,
                                        const ProgressCallback& progress) {
  const design::CaseFile& c = in.c;
  contact::DonningOptions o;
  o.start_offset_m = q.start_offset_m;
  o.steps = q.steps;
  o.step_m = q.max_step_m > 0 ? q.max_step_m : c.closed_loop_step_m;
  o.friction = mu;
  o.stand_force_n = q.stand ? 0.5 * c.patient.body_mass_kg * units::kGravity : 0.0;
  o.progress = progress;
  o.contact.penalty_factor = q.penalty_factor;
  o.contact.stick_stiffness_ratio = q.stick_stiffness_ratio;
  if (q.reuse_cg >= 0) o.contact.max_reuse_cg = q.reuse_cg;
  if (q.smooth_wall) o.smooth_wall = *q.smooth_wall;
  o.contact.augmented_tol = q.rigid_wall ? contact::kRigidWallAugmentedTol : case_augmented_tol(c);
  // The donned stump: the design's (its tissue model as it was solved: the closed loop's rule), or
  // as asked. MSS-CS has no energy, so its "nonlinear" body is the lattice's own Newton.
  const bool design_linear = in.designed ? design_body_linearised(in.designed->state, c)
                                         : c.solve_mode == design::DesignSolveMode::Linear;
  o.contact.linear_body = q.body == DonnedBody::Linearised || (q.body == DonnedBody::Design && design_linear);
  return o;
}

/// One line: the socket, the stump, the start, the steps, μ and the standing load.
void log_donning_start(const DonningRequest& q, const DonningInput& in, const contact::DonningOptions& o) {
  log::info("donning: {} onto a {}-node {} stump ({} skin nodes), from {} in {}, μ = {:.2f}{}",
            in.socket_label, in.setup->mesh.mesh.num_nodes(),
            o.contact.linear_body ? "linearised" : fmt::format("nonlinear {}", in.c.model),
            in.setup->solver->skin().nodes.size(),
            q.start_offset_m > 0 ? fmt::format("{:.0f} mm below", q.start_offset_m * 1e3)
                                 : std::string("below the stump"),
            q.steps > 0 ? fmt::format("{} steps", q.steps)
                        : fmt::format("adaptive steps of {:.1f} mm at most", o.step_m * 1e3),
            o.friction,
            o.stand_force_n > 0 ? fmt::format(", then standing ({:.0f} N)", o.stand_force_n) : "");
}

/// The part [a, b] of @p progress.
ProgressCallback stage(const ProgressCallback& progress, double a, double b) {
  return [progress, a, b](double x, std::string_view s) { return report_progress(progress, a + (b - a) * x, s); };
}

}  // namespace

contact::DonningSample last_sample(const contact::DonningResult& r) {
  return r.series.empty() ? contact::DonningSample{} : r.series.back();
}

DonningRun run_donning(const DonningRequest& q, const fs::path& out) {
  check_request(q);
  ensure_directory(out);
  // The stump and the socket: the case's own design, or a limb and a given socket.
  const DonningInput in = q.case_file.empty() ? given_socket(q, stage(q.progress, 0.0, 0.3))
                                              : designed_socket(q, out, stage(q.progress, 0.0, 0.3));
  const DesignSetup& setup = *in.setup;
  const auto& solver = *setup.solver;
  const auto& skin = solver.skin();
  DonningRun run;
  run.has_design = in.designed.has_value();
  const double mu = q.friction >= 0 ? q.friction : in.c.patient.friction;
  run.options = donning_options(q, in, mu, stage(q.progress, 0.3, 0.95));
  run.options.skin = &skin;  // pressures per deformed area, as the design's
  log_donning_start(q, in, run.options);
  run.donning = contact::simulate_donning(solver.model(), skin.nodes, skin.area_m2, in.socket_solid,
                                          setup.model.frame, run.options);
  const contact::DonningResult& r = run.donning;

  write_donning_series(out, r);
  const DonnedSkin d = donned_skin(solver, r, in.designed);
  write_contact_csv(out, d, setup.thresholds, r);
  write_donned_stump(out, setup.mesh.mesh, skin, r, d);
  const auto sframe = report::surface_frame(setup.model.frame);
  write_donning_maps(out, setup, sframe, d, run.has_design);
  write_donning_force_plot(out, r);
  if (run.has_design) run.agreement = design_agreement(setup, sframe, d);
  run.summary = donning_summary(in, r, run.options, out, run.agreement);
  write_text_atomically(out / "donning.json", run.summary.dump(2) + "\n");
  report_progress(q.progress, 1.0, "donning: done");
  if (!r.completed) fail<SolverError>("simulate donning: {} (the converged part is in {})", r.message, out.string());
  return run;
}

SockPlyRun run_sock_ply_case(const SockPlyRequest& q, const fs::path& out) {
  ensure_directory(out);
  const auto t0 = std::chrono::steady_clock::now();
  design::CaseFile c = q.demo ? demo_case() : design::read_case(q.case_file);
  if (q.target_nodes > 0) c.target_nodes = q.target_nodes;
  if (q.demo) design::write_case(out / "case.json", c);
  SockPlyRun run;
  run.setup = prepare_design(c, c.limb.file.empty() ? out / "limb.stl" : fs::path(), stage(q.progress, 0.0, 0.08));
  run.result = solve_design(*run.setup, c.optimise, stage(q.progress, 0.08, 0.15));
  if (!run.result.socket) {
    write_design_outputs(*run.setup, run.result, out, 0.0);
    fail("simulate sockply: the case's design does not meet its constraints, so it has no socket to don (see {}); "
         "fix the design first",
         (out / "report.html").string());
  }
  SockPlyOptions so = q.study;
  so.progress = stage(q.progress, 0.15, 0.98);
  run.result.sock_ply = run_sock_ply_study(*run.setup, run.result, so);
  run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  run.summary = write_design_outputs(*run.setup, run.result, out, run.seconds);
  report_progress(q.progress, 1.0, "sock ply: done");
  return run;
}

}  // namespace socketsmith::pipeline
