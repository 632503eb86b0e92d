// `socketsmith simulate donning`: the designed (or a given) socket slides onto the stump with
// friction, then the patient stands; contact pressures against the designed ones.
// `socketsmith simulate sockply`: the designed socket donned on the limb shrunk and grown.
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <numbers>

#include "cli_common.h"
#include "socketsmith/contact/donning.h"
#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/core/progress.h"
#include "socketsmith/core/units.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/pipeline/sock_ply.h"
#include "socketsmith/report/csv.h"
#include "socketsmith/report/design_report.h"
#include "socketsmith/report/field_comparison.h"
#include "socketsmith/report/svg_plot.h"
#include "socketsmith/report/vtk_writer.h"

namespace socketsmith::cli {
namespace {

namespace fs = std::filesystem;
using geometry::Vec3;

struct DonningFlags {
  std::string case_file, limb, socket, units, out;
  double offset_mm = 0;  // 0: automatic
  int steps = 0;         // 0: one per step_mm
  double step_mm = contact::DonningOptions{}.step_m * 1e3;
  double stick_stiffness = contact::DonningOptions{}.contact.stick_stiffness_ratio;
  int target_nodes = 0;
  double friction = -1;
  double penalty_factor = 20;
  int reuse_cg = -1;
  std::string wall;  // "" = the default (DonningOptions::smooth_wall)
  std::string body = "design";  // design | linearised | nonlinear
  bool no_stand = false;
  bool json = false;
};

/// Contact (a) against designed (b) pressure on the skin nodes where @p mask is set, in kPa.
nlohmann::json agreement_json(const std::vector<double>& contact_pa, const std::vector<double>& designed_pa,
                              const std::vector<char>& mask) {
  std::vector<int> subset;
  for (size_t i = 0; i < mask.size(); ++i)
    if (mask[i]) subset.push_back(static_cast<int>(i));
  return report::to_json(report::compare_fields(contact_pa, designed_pa, subset), 1e-3, "_kpa");
}

/// Refuses flags that do not name one stump and its socket, and a negative start offset.
void check_donning_flags(const DonningFlags& f) {
  require(f.case_file.empty() != f.limb.empty(),
          "simulate donning: give either --case CASE.json or --limb FILE --socket FILE, not both");
  require(!f.limb.empty() == !f.socket.empty() || !f.case_file.empty(),
          "simulate donning: --limb needs --socket (the socket to put on it)");
  require(std::isfinite(f.offset_mm) && f.offset_mm >= 0,
          "simulate donning: start offset {} mm must be positive (the socket starts that far below the stump)",
          f.offset_mm);
}

/// The stump and the socket to don: the case's own design (with its result), or a limb and a
/// given socket.
struct DonningInput {
  design::CaseFile c;
  std::unique_ptr<pipeline::DesignSetup> setup;
  std::optional<pipeline::DesignResult> designed;
  geometry::TriMesh socket_solid;
  std::string socket_label;  ///< the socket's file, as the log and donning.json name it
};

/// The case's design run into @p out / "design", and its socket; refused when the design has none.
DonningInput designed_socket(const DonningFlags& f, const fs::path& out, const ProgressCallback& progress) {
  DonningInput in;
  design::CaseFile& c = in.c;
  c = design::read_case(f.case_file);
  if (f.target_nodes > 0) c.target_nodes = f.target_nodes;
  pipeline::DesignArtifacts art;
  pipeline::run_design(c, out / "design", c.optimise, progress, &art);
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
DonningInput given_socket(const DonningFlags& f, const ProgressCallback& progress) {
  DonningInput in;
  // The socket first: a bad file is reported before the stump is meshed.
  geometry::MeshReadOptions ro;
  if (!f.units.empty()) ro.unit = units::parse_length_unit(f.units);
  in.socket_solid = geometry::read_mesh(f.socket, ro);
  const auto rep = geometry::check_mesh(in.socket_solid);
  require<TopologyError>(rep.is_closed(),
                         "simulate donning: the socket {} is not a closed surface ({} boundary edges): give the "
                         "socket as a solid (inner and outer wall joined at the brim)",
                         f.socket, rep.boundary_edges);
  in.socket_label = f.socket;
  in.c.limb.file = fs::absolute(f.limb).string();
  in.c.limb.units = f.units;
  if (f.target_nodes > 0) in.c.target_nodes = f.target_nodes;
  in.setup = pipeline::prepare_design(in.c, {}, progress);
  return in;
}

/// The donning's options from the flags, with friction @p mu.
contact::DonningOptions donning_options(const DonningFlags& f, const DonningInput& in, double mu,
                                        const ProgressCallback& progress) {
  const design::CaseFile& c = in.c;
  contact::DonningOptions o;
  o.start_offset_m = f.offset_mm * 1e-3;
  o.steps = f.steps;
  o.step_m = f.step_mm * 1e-3;
  o.friction = mu;
  o.stand_force_n = f.no_stand ? 0.0 : 0.5 * c.patient.body_mass_kg * units::kGravity;
  o.progress = progress;
  o.contact.penalty_factor = f.penalty_factor;
  o.contact.stick_stiffness_ratio = f.stick_stiffness;
  if (f.reuse_cg >= 0) o.contact.max_reuse_cg = f.reuse_cg;
  if (!f.wall.empty()) o.smooth_wall = f.wall == "smooth";
  // The donned stump: the design's (its tissue model as it was solved: the closed loop's rule), or
  // as asked. MSS-CS has no energy, so its "nonlinear" body is the lattice's own Newton.
  const bool design_linear =
      (in.designed && in.designed->state.linearised) || c.solve_mode == design::DesignSolveMode::Linear;
  o.contact.linear_body = f.body == "linearised" || (f.body == "design" && design_linear);
  return o;
}

/// One line: the socket, the stump, the start, the steps, μ and the standing load.
void log_donning_start(const DonningFlags& f, const DonningInput& in, const contact::DonningOptions& o) {
  log::info("donning: {} onto a {}-node {} stump ({} skin nodes), from {} in {}, μ = {:.2f}{}",
            in.socket_label, in.setup->mesh.mesh.num_nodes(),
            o.contact.linear_body ? "linearised" : fmt::format("nonlinear {}", in.c.model),
            in.setup->solver->skin().nodes.size(),
            f.offset_mm > 0 ? fmt::format("{:.0f} mm below", f.offset_mm) : std::string("below the stump"),
            f.steps > 0 ? fmt::format("{} steps", f.steps)
                        : fmt::format("adaptive steps of {:.1f} mm at most", f.step_mm),
            o.friction,
            o.stand_force_n > 0 ? fmt::format(", then standing ({:.0f} N)", o.stand_force_n) : "");
}

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
                       const std::optional<pipeline::DesignResult>& designed) {
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

/// contact.csv: the columns of surface_nodes.csv, pressure = contact pressure (+ the designed one).
void write_contact_csv(const fs::path& out, const DonnedSkin& d, const std::vector<double>& thresholds,
                       const contact::DonningResult& r) {
  report::CsvTable t;
  t.header = {"x_m",     "y_m",         "z_m",          "nx",          "ny",      "nz",      "area_m2",
              "pressure_pa", "threshold_pa", "above_brim", "designed_pressure_pa", "sliding", "gap_m"};
  for (size_t i = 0; i < d.pos.size(); ++i)
    t.rows.push_back({d.pos[i].x(), d.pos[i].y(), d.pos[i].z(), d.nrm[i].x(), d.nrm[i].y(), d.nrm[i].z(), d.area[i],
                      d.pc[i], thresholds[i], d.below[i] ? 0.0 : 1.0, d.pd[i], r.contacts[i].sliding ? 1.0 : 0.0,
                      r.contacts[i].gap_m});
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
void write_donning_maps(const fs::path& out, const pipeline::DesignSetup& setup, const report::SurfaceFrame& sframe,
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
nlohmann::json design_agreement(const pipeline::DesignSetup& setup, const report::SurfaceFrame& sframe,
                                const DonnedSkin& d) {
  nlohmann::json agreement;
  agreement["below_brim"] = agreement_json(d.pc, d.pd, d.below);
  for (const auto& path : pipeline::design_paths(setup)) {
    std::vector<char> m(d.pos.size(), 0);
    for (const auto& s : report::sample_path(setup.solver->skin().positions, {}, sframe, path.spec))
      if (d.below[s.index]) m[s.index] = 1;
    int count = 0;
    for (char v : m) count += v;
    if (count >= 3) agreement[path.key] = agreement_json(d.pc, d.pd, m);
  }
  return agreement;
}

/// The last accepted step (all zero when there was none).
contact::DonningSample last_sample(const contact::DonningResult& r) {
  return r.series.empty() ? contact::DonningSample{} : r.series.back();
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

/// The outcome in one line, and with a design the agreement below the brim in another.
void log_donning_result(const contact::DonningResult& r, const nlohmann::json& agreement, bool has_design) {
  const contact::DonningSample last = last_sample(r);
  log::info("donning: done in {:.1f} s ({} Newton iterations); socket at {:+.1f} mm, axial reaction {:.1f} N, {} nodes in "
            "contact, max pressure {:.1f} kPa, max penetration {:.3f} mm",
            r.seconds, r.newton_iterations, r.final_offset_m * 1e3, last.axial_force_n, last.contact_nodes,
            last.max_pressure_pa / 1e3, last.max_penetration_m * 1e3);
  if (has_design) {
    const auto& b = agreement["below_brim"];
    log::info("donning: below the brim, contact vs designed: MAE {:.2f} ± {:.2f} kPa, R {}, mean {:.2f} vs {:.2f} kPa",
              b["mae_kpa"].get<double>(), b["sd_kpa"].get<double>(),
              b["r"].is_null() ? "n/a" : fmt::format("{:.3f}", b["r"].get<double>()), b["mean_a_kpa"].get<double>(),
              b["mean_b_kpa"].get<double>());
  }
}

int run_donning(const DonningFlags& f) {
  check_donning_flags(f);
  const fs::path out(f.out);
  ensure_directory(out);
  const auto progress = console_progress(1.0);
  const auto stage = [&](double a, double b) {
    return [&progress, a, b](double x, std::string_view s) { return report_progress(progress, a + (b - a) * x, s); };
  };

  // The stump and the socket: the case's own design, or a limb and a given socket.
  const DonningInput in =
      f.case_file.empty() ? given_socket(f, stage(0.0, 0.3)) : designed_socket(f, out, stage(0.0, 0.3));
  const pipeline::DesignSetup& setup = *in.setup;
  const auto& solver = *setup.solver;
  const auto& skin = solver.skin();
  const double mu = f.friction >= 0 ? f.friction : in.c.patient.friction;
  const contact::DonningOptions o = donning_options(f, in, mu, stage(0.3, 0.95));
  log_donning_start(f, in, o);
  const contact::DonningResult r =
      contact::simulate_donning(solver.model(), skin.nodes, skin.area_m2, in.socket_solid, setup.model.frame, o);

  write_donning_series(out, r);
  const DonnedSkin d = donned_skin(solver, r, in.designed);
  write_contact_csv(out, d, setup.thresholds, r);
  write_donned_stump(out, setup.mesh.mesh, skin, r, d);
  const auto sframe = report::surface_frame(setup.model.frame);
  write_donning_maps(out, setup, sframe, d, in.designed.has_value());
  write_donning_force_plot(out, r);
  const nlohmann::json agreement = in.designed ? design_agreement(setup, sframe, d) : nlohmann::json();
  const nlohmann::json j = donning_summary(in, r, o, out, agreement);
  write_text_atomically(out / "donning.json", j.dump(2) + "\n");
  report_progress(progress, 1.0, "donning: done");
  if (!r.completed) fail<SolverError>("simulate donning: {} (the converged part is in {})", r.message, out.string());
  if (o.stand_force_n > 0 && !r.stood) log::warn("donning: {}", r.message);
  if (f.json) {
    print_json(j);
    return 0;
  }
  log_donning_result(r, agreement, in.designed.has_value());
  log::info("donning: outputs in {}", out.string());
  return 0;
}

struct SockPlyFlags {
  std::string case_file, out;
  bool demo = false;
  int target_nodes = 0;
  std::vector<double> changes_pct = {-4, -2, 2, 4};
  bool json = false;
};

int run_sock_ply(const SockPlyFlags& f) {
  require(f.case_file.empty() == f.demo,
          "simulate sockply: give a case file (--case CASE.json) or --demo, not {}", f.demo ? "both" : "neither");
  require(!f.changes_pct.empty(), "simulate sockply: --volume-changes-pct is empty (e.g. -4,-2,2,4)");
  pipeline::SockPlyOptions so;
  so.volume_changes.clear();
  for (double v : f.changes_pct) {
    require(std::isfinite(v) && std::abs(v) <= 20,
            "simulate sockply: volume change {} % is outside [-20, 20] % (e.g. --volume-changes-pct -4,-2,2,4)", v);
    so.volume_changes.push_back(v / 100);
  }
  const fs::path out(f.out);
  ensure_directory(out);
  const auto t0 = std::chrono::steady_clock::now();
  const auto progress = console_progress(1.0);
  const auto stage = [&](double a, double b) {
    return [&progress, a, b](double x, std::string_view s) { return report_progress(progress, a + (b - a) * x, s); };
  };
  design::CaseFile c = f.demo ? pipeline::demo_case() : design::read_case(f.case_file);
  if (f.target_nodes > 0) c.target_nodes = f.target_nodes;
  if (f.demo) design::write_case(out / "case.json", c);
  auto setup = pipeline::prepare_design(c, c.limb.file.empty() ? out / "limb.stl" : fs::path(), stage(0.0, 0.08));
  pipeline::DesignResult result = pipeline::solve_design(*setup, c.optimise, stage(0.08, 0.15));
  if (!result.socket) {
    pipeline::write_design_outputs(*setup, result, out, 0.0);
    fail("simulate sockply: the case's design does not meet its constraints, so it has no socket to don (see {}); "
         "fix the design first",
         (out / "report.html").string());
  }
  so.progress = stage(0.15, 0.98);
  result.sock_ply = pipeline::run_sock_ply_study(*setup, result, so);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const nlohmann::json j = pipeline::write_design_outputs(*setup, result, out, seconds);
  report_progress(progress, 1.0, "sock ply: done");
  if (f.json) {
    print_json(j["sock_ply"]);
    return 0;
  }
  for (const auto& l : result.sock_ply->levels)
    log::info("sockply: limb {:+5.1f} % (skin {:+.3f} mm): {}", 100 * l.volume_change, l.skin_offset_m * 1e3,
              l.stood ? fmt::format("socket at {:+.2f} mm, limb {} {:.2f} mm, peak p/T {:.3f} ({}), distal mean {:.1f} "
                                    "kPa, peak {:.1f} kPa; constraints {}",
                                    l.stood_offset_m * 1e3, l.sink_m >= 0 ? "sinks" : "rises", std::abs(l.sink_m) * 1e3,
                                    l.peak_ratio, l.peak_zone, l.distal_mean_pa / 1e3, l.distal_peak_pa / 1e3,
                                    l.status.all_ok() ? "all hold" : "fail: " + l.status.failing())
                      : "did not stand: " + l.message);
  log::info("sockply: done in {:.1f} s; outputs in {} (sockply.csv, design.json \"sock_ply\", sockply.png, report.html)",
            seconds, out.string());
  return 0;
}

}  // namespace

void register_contact(CLI::App& app) {
  auto* sim = app.get_subcommand("simulate");
  auto f = std::make_shared<DonningFlags>();
  auto* don = sim->add_subcommand("donning", "slide a socket onto the stump with friction, then stand; contact pressures");
  don->add_option("--case", f->case_file, "case file: design it, then don its own socket");
  don->add_option("--limb", f->limb, "limb scan (STL/OBJ/PLY/AOP) to mesh as the stump (with --socket)");
  don->add_option("--socket", f->socket, "closed socket solid (STL/OBJ/PLY/AOP) placed on the limb (with --limb)");
  don->add_option("--units", f->units, "units of --limb and --socket: mm | m (default: guessed from the size)");
  don->add_option("--offset-mm", f->offset_mm,
                  "start this far below the designed pose [mm] (default: the socket's top 5 mm below the stump)");
  don->add_option("--steps", f->steps, "this many equal displacement steps (default: adaptive, see --step-mm)")
      ->check(CLI::Range(1, 100000));
  don->add_option("--step-mm", f->step_mm,
                  fmt::format("longest adaptive step [mm] (default {:g}; down to {:g} mm where a node starts sticking)",
                              contact::DonningOptions{}.step_m * 1e3, contact::DonningOptions{}.min_step_m * 1e3))
      ->check(positive());
  don->add_option("--target-nodes", f->target_nodes, "stump size (default: the case's, 8000)")
      ->check(within(design::limits::kTargetNodes));
  don->add_option("--friction", f->friction, "Coulomb μ (default: the case's)")->check(within(design::limits::kFriction));
  don->add_option("--penalty-factor", f->penalty_factor,
                  "contact penalty k = factor · E / h (default 20: 15 kPa penetrates ~45 µm at E = 100 kPa, h = 6 mm)");
  don->add_option("--stick-stiffness", f->stick_stiffness,
                  "friction's elastic stick as a fraction of the contact penalty (default 0.2: ~75 µm of elastic slip "
                  "at 10 kPa; 1: as stiff as the penalty)")
      ->check(positive());
  don->add_option("--reuse-cg", f->reuse_cg,
                  "CG iterations on the last factorisation before refactorising (default 0: always factorise)")
      ->check(CLI::Range(0, 1000));
  don->add_option("--wall", f->wall, "socket wall for contact: smooth (default; a smooth surface fitted to its facets) | faceted")
      ->check(CLI::IsMember({"smooth", "faceted"}));
  don->add_option("--body", f->body,
                  "the donned stump: design (default: the tissue model as the design solved it — the neo-Hookean "
                  "default nonlinearly, a linear solve linearised at rest) | linearised | nonlinear")
      ->check(CLI::IsMember({"design", "linearised", "nonlinear"}));
  don->add_flag("--no-stand", f->no_stand, "stop at the designed pose (no half-body-weight load)");
  don->add_option("--out", f->out, "output directory")->required();
  don->add_flag("--json", f->json, "print the summary as JSON on stdout");
  don->callback([f] { run_donning(*f); });

  auto g = std::make_shared<SockPlyFlags>();
  auto* ply = sim->add_subcommand(
      "sockply", "sock-ply sensitivity: the designed socket donned and stood on with the limb shrunk and grown");
  ply->add_option("--case", g->case_file, "case file: design it, then don its socket on the changed limb");
  ply->add_flag("--demo", g->demo, "the embedded sample case (generated limb, 8k nodes) instead of a case file");
  ply->add_option("--target-nodes", g->target_nodes, "stump size (default: the case's)")
      ->check(within(design::limits::kTargetNodes));
  ply->add_option("--volume-changes-pct", g->changes_pct,
                  "limb volume changes to try [%], each in [-20, 20] (default -4,-2,2,4; the designed volume is added)")
      ->delimiter(',');
  ply->add_option("--out", g->out, "output directory (the design's outputs, sockply.csv, report.html)")->required();
  ply->add_flag("--json", g->json, "print the study as JSON on stdout");
  ply->callback([g] { run_sock_ply(*g); });
}

}  // namespace socketsmith::cli
