// `socketsmith validate cube` and `socketsmith validate design CASE`: socketsmith against
// CalculiX (an independent FE solver) on the same mesh — the thesis's FE checks (ch. 3.6, 5.5).
#include <filesystem>

#include "cli_common.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/core/progress.h"
#include "socketsmith/calculix/cube_validation.h"
#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/pipeline/design_validation.h"

namespace socketsmith::cli {
namespace {

namespace fs = std::filesystem;

struct CcxFlags {
  std::string solver = "calculix";
  std::string ccx = "ccx";
  int threads = 1;
  double time_limit_s = 3600;
};

void add_ccx_flags(CLI::App& cmd, CcxFlags& f) {
  cmd.add_option("--fe", f.solver, "FE solver (only calculix)")->check(CLI::IsMember({"calculix"}));
  cmd.add_option("--ccx", f.ccx, "CalculiX executable (default: ccx on the PATH; package calculix-ccx)");
  cmd.add_option("--ccx-threads", f.threads, "threads for ccx (default 1)")->check(CLI::Range(1, 64));
  cmd.add_option("--ccx-time-limit", f.time_limit_s, "wall-time limit of ccx [s] (default 3600)")->check(positive());
}

calculix::CcxOptions ccx_options(const CcxFlags& f) {
  calculix::CcxOptions o;
  o.executable = f.ccx;
  o.threads = f.threads;
  o.time_limit_s = f.time_limit_s;
  o.progress = console_progress(2.0);
  return o;
}

struct CubeFlags {
  std::string out;
  bool json = false;
  int divisions = 4;
  double youngs_kpa = 50, poisson = 0.45, max_force = 8, edge_mm = 50;
  int increments = 8;
  std::string element = "c3d8";
  CcxFlags ccx;
};

void run_validate_cube(const CubeFlags& f) {
  const fs::path out(f.out);
  calculix::CubeFeOptions o;
  o.edge_m = f.edge_mm * 1e-3;
  o.divisions = f.divisions;
  o.youngs_modulus_pa = f.youngs_kpa * 1e3;
  o.poisson_ratio = f.poisson;
  o.max_force_n = f.max_force;
  o.increments = f.increments;
  o.element = calculix::parse_element_type(f.element);
  o.ccx = ccx_options(f.ccx);
  const calculix::CubeFeValidation v = calculix::validate_cube_fe(o, out);
  if (f.json) {
    print_json(v.summary);
    return;
  }
  const calculix::CubeFeResult& r = v.result;
  log::info("validate cube: {} nodes, {} elements ({}), ccx {:.1f} s", r.nodes, r.elements, calculix::to_string(o.element),
            r.ccx.wall_s);
  log::info("validate cube: top displacement max error {:.2f} % of analytic; contact pressure max error {:.2f} %, "
            "nodal R {:.4f}, MAE {:.3f} kPa",
            100 * r.max_displacement_rel_error, 100 * r.max_pressure_rel_error, r.pressure.r, r.pressure.mae / 1e3);
  log::info("validate cube: outputs in {}", out.string());
}

struct DesignFlags {
  std::string case_file;
  std::string out;
  bool json = false;
  bool demo = false;
  bool no_optimise = false;
  int target_nodes = 0;  // 0: the case's
  std::string mode = "contact";
  std::string element;  // empty: the tissue's twin (c3d8, or c3d8i for tissue.element fbar)
  double poisson = -1;  // < 0: the case's continuum model's ν, else 0.45 (the thesis's)
  double penalty = -1;  // < 0: the default (DesignValidationOptions::penalty_pa_per_m)
  double stick_slope = 5e7;
  double friction = -1;  // < 0: the case's μ
  double clearance_mm = 1.0;
  double travel_mm = 60.0;  // 30 mm started the demo's socket on the skin (README, validation_fe.md: 60)
  double initial_increment = 0.05;
  int alternation_rerun = 5;
  bool neo_hookean = false;
  bool small_strain = false;
  bool printed_wall = false;
  int shell_subdivision = 0;  // 0: the default (pipeline::calculix_shell)
  bool shell_on_wall = false;
  bool shell_lip = false;
  bool no_shell_lip = false;
  bool nonlinear_body = false;  // validate donning: socketsmith's donning with the nonlinear tissue model
  bool against_donning = false;
  std::string fe_pressure = "force";
  bool stand = false;  // validate donning: then half the body weight on the socket (thesis step 2)
  CcxFlags ccx;
};

/// The validation's options from the command line's flags.
pipeline::DesignValidationOptions validation_options(const DesignFlags& f) {
  pipeline::DesignValidationOptions o;
  o.mode = calculix::parse_design_check_mode(f.mode);
  o.against_donning = f.against_donning;
  o.stand = f.stand;
  o.nonlinear_body = f.nonlinear_body;
  o.optimise = !f.no_optimise;
  o.poisson_ratio = f.poisson;
  o.neo_hookean = f.neo_hookean;
  o.small_strain = f.small_strain;
  o.printed_wall = f.printed_wall;
  if (f.shell_subdivision > 0) o.shell_subdivision = f.shell_subdivision;
  o.shell_on_wall = f.shell_on_wall;
  if (f.shell_lip || f.no_shell_lip) o.shell_lip = f.shell_lip;
  if (!f.element.empty()) o.element = calculix::parse_element_type(f.element);
  if (f.penalty >= 0) o.penalty_pa_per_m = f.penalty;
  o.stick_slope_pa_per_m = f.stick_slope;
  o.friction = f.friction;
  o.clearance_m = f.clearance_mm * 1e-3;
  o.travel_m = f.travel_mm * 1e-3;
  o.initial_increment = f.initial_increment;
  o.alternation_rerun_nodes = f.alternation_rerun;
  o.fe_pressure = calculix::parse_fe_pressure(f.fe_pressure);
  o.ccx = ccx_options(f.ccx);
  o.progress = console_progress(1.0);
  o.case_label = f.demo ? std::string("demo") : f.case_file;
  o.write_case = f.demo;
  return o;
}

void run_validate_design(const DesignFlags& f) {
  const fs::path out(f.out);
  design::CaseFile c = f.demo ? pipeline::demo_case(f.target_nodes > 0 ? f.target_nodes : 3000)
                              : design::read_case(f.case_file);
  if (f.target_nodes > 0) c.target_nodes = f.target_nodes;
  const pipeline::DesignValidationOptions o = validation_options(f);
  const auto v = pipeline::validate_design(c, o, out);
  const auto& r = v.check;
  const auto& j = v.summary;
  if (f.json) print_json(j);
  else {
    const bool contact = r.mode != calculix::DesignCheckMode::Load;
    const auto [scale, unit, suffix, what] = pipeline::compared_quantity(r.mode);
    if (j.contains("socketsmith_delivered_vs_design")) {
      const auto& a = j["socketsmith_delivered_vs_design"];
      const auto& b = j["calculix_vs_socketsmith_delivered"];
      log::info("validate design: socketsmith delivered vs design: MAE {:.2f} {}, p99 {:.2f}, R {:.3f}; CalculiX vs "
                "socketsmith delivered: MAE {:.2f}, p99 {:.2f}, R {:.3f}",
                a["mae" + suffix].get<double>(), unit, a["p99" + suffix].get<double>(),
                a["r"].is_null() ? 0.0 : a["r"].get<double>(), b["mae" + suffix].get<double>(),
                b["p99" + suffix].get<double>(), b["r"].is_null() ? 0.0 : b["r"].get<double>());
    }
    const std::string ccx_time =
        r.ccx_runs > 1 ? fmt::format("{:.1f} s in {} runs (the last {:.1f} s)", r.ccx_total_wall_s, r.ccx_runs, r.ccx.wall_s)
                       : fmt::format("{:.1f} s", r.ccx.wall_s);
    log::info("validate design: {}{} — CalculiX {} vs socketsmith {:.1f} s (design solve {:.3f} s)",
              r.converged ? "" : "PARTIAL ", what, ccx_time, v.socketsmith_wall_s, v.artifacts.result.state.seconds);
    log::info("validate design: force designed {:.1f} N, CalculiX {:.1f} N; mean designed {:.2f}, CalculiX {:.2f}",
              r.designed_force_n, r.fe_force_n, r.all.mean_b * scale, r.all.mean_a * scale);
    if (v.stand_force_n > 0)
      log::info("validate design: CalculiX {} {:.0f} N {:+.2f} mm past the designed pose (socketsmith stood {:+.2f} mm "
                "past it; CalculiX's donned socket carried {:.0f} N; {} ccx run{})",
                r.stood ? "stood with" : "carried only", r.stand_reached_force_n, r.stand_offset_m * 1e3,
                v.socketsmith_stand_offset_m * 1e3, r.donned_force_n, r.ccx_runs, r.ccx_runs == 1 ? "" : "s");
    const auto line = [&](const std::string& name, const report::ErrorStats& st) {
      log::info("validate design: {:<26} n {:4d}  MAE {:.2f} ± {:.2f} {}  R {:.2f}  max {:.2f}", name, st.count,
                st.mae * scale, st.sd * scale, unit, st.r, st.max_error * scale);
    };
    if (contact) {
      log::info("validate design: CalculiX pressure compared: {}",
                r.fe_pressure == calculix::FePressure::SurfaceStress ? "-n.sigma.n of the stump's stress"
                : r.fe_pressure == calculix::FePressure::NodalForce  ? "the stump's nodal force over the nodal area"
                                                               : "nodal CPRESS");
      line("every node, nodal force", r.all_force);
      line("every node, -n.sigma.n", r.all_stress);
      line("every node, CPRESS", r.all_cpress);
    }
    line("every socket node", r.all);
    line("one ring from the brim", r.one_ring_away);
    line("away from the brim (≥ 4)", r.away_from_brim);
    for (const auto& pc : r.paths) line(pc.label.substr(0, 26), pc.stats);
    line("every node, one-ring mean", r.all_smoothed);
    line("away, one-ring mean", r.away_from_brim_smoothed);
    log::info("validate design: outputs in {}", out.string());
  }
  if (!r.converged)
    fail<SolverError>("validate design: {} (the partial comparison is in {}, labelled PARTIAL)", r.message,
                      (out / "summary.json").string());
}

/// Flags shared by `validate design` and `validate donning`.
void add_case_flags(CLI::App& cmd, DesignFlags& f) {
  cmd.add_option("case", f.case_file, "case file (JSON, docs/case_file.md)");
  cmd.add_flag("--demo", f.demo, "use the embedded sample case (generated limb, 3k nodes) instead of a case file");
  cmd.add_option("--out", f.out, "output folder (comparison.csv/.svg, profiles, stump_fe.vtu, summary.json, deck)")
      ->required();
  cmd.add_flag("--json", f.json, "print the summary as JSON on stdout");
  cmd.add_flag("--no-optimise", f.no_optimise, "solve the case's spots as given");
  cmd.add_option("--target-nodes", f.target_nodes, "stump size (default: the case's)")
      ->check(within(design::limits::kTargetNodes));
  cmd.add_option("--element", f.element,
                 "c3d8 | c3d8i | c3d8r (default: the tissue's twin, c3d8, or c3d8i for tissue.element fbar)");
  cmd.add_option("--poisson", f.poisson,
                 "tissue Poisson ratio in CalculiX (default: the case's fe or neo-hookean model's, else 0.45, the thesis's)")
      ->check(CLI::Range(0.0, 0.4999));
  cmd.add_flag("--neo-hookean", f.neo_hookean,
               "neo-Hookean tissue in CalculiX instead of linear elastic (automatic when the case's model is neo-hookean)");
  cmd.add_flag("--nonlinear-body", f.nonlinear_body,
               "validate donning: socketsmith's donning with the nonlinear tissue model instead of its linearisation at "
               "rest (slower; with the fe model, the large-displacement problem CalculiX solves under NLGEOM)");
  cmd.add_flag("--small-strain", f.small_strain,
               "CalculiX without NLGEOM: the problem of socketsmith's linear design solve (with --mode load and the fe "
               "tissue model, the two displacement fields agree to round-off)");
  cmd.add_flag("--printed-wall", f.printed_wall,
               "donning: CalculiX dons the printed socket's inner wall (brim and lip as built, C3D6 wedges; instead of a "
               "C3D8 shell on the skin below the brim; ccx stands the 1.8k demo's socket with it, not yet the 3k demo's or "
               "OpenLimb's limb, docs/VALIDATION.md)");
  cmd.add_option("--shell-subdivision", f.shell_subdivision,
                 "donning: each skin quad of CalculiX's socket shell split n x n (default 2 with the lip, else 1)")
      ->check(CLI::Range(1, 4));
  cmd.add_flag("--shell-on-wall", f.shell_on_wall,
               "donning: CalculiX's socket shell laid on the smoothed wall socketsmith's own donning touches, instead of "
               "bilinear quads through the wall at the skin nodes (with --shell-subdivision 2 it agrees better with "
               "socketsmith node by node; docs/VALIDATION.md)");
  auto* lip = cmd.add_flag("--shell-lip", f.shell_lip,
                           "donning: the shell also across the brim, its points past the rim on socketsmith's lip (a "
                           "rounded rim instead of the shell's sharp edge at the brim; without --shell-on-wall only the "
                           "lip's own points move; the default when the design wrote a socket, docs/VALIDATION.md)");
  cmd.add_flag("--no-shell-lip", f.no_shell_lip, "donning: CalculiX's shell ends at the brim in a sharp edge (no lip; the first ring below the brim then takes the largest errors, docs/VALIDATION.md)")
      ->excludes(lip);
  cmd.add_option("--penalty", f.penalty,
                 "CalculiX's contact penalty stiffness [Pa/m]; 0: socketsmith's own donning penalty on this stump, "
                 "20 E / h (default with --mode donning: the same contact law on both sides, docs/VALIDATION.md; "
                 "1e9 with --mode contact or a case whose closed loop dons on a rigid wall)")
      ->check(non_negative());
  cmd.add_option("--stick-slope", f.stick_slope,
                 "CalculiX's friction stick slope [Pa/m] (default 5e7, CALCULIX.md; socketsmith's stick is 0.2 x its penalty)")
      ->check(positive());
  cmd.add_option("--friction", f.friction, "friction coefficient (default: the case's μ)")
      ->check(within(design::limits::kFriction));
  cmd.add_option("--travel-mm", f.travel_mm, "donning: start this far distally [mm] (default 60)")
      ->check(positive());
  cmd.add_option("--initial-increment", f.initial_increment, "first ccx increment (fraction of the step, default 0.05)")
      ->check(CLI::Range(1e-4, 1.0));
  cmd.add_option("--alternation-rerun", f.alternation_rerun,
                 "rerun ccx once with increments half as long when its contact pressure alternates node by node at "
                 "this many skin nodes or more (default 5; 0: never)")
      ->check(non_negative());
  cmd.add_option("--fe-pressure", f.fe_pressure,
                 "CalculiX's contact pressure: force (the stump's nodal force from its integration-point stresses over "
                 "the nodal area, as a designed pressure; default) | stress (-n.sigma.n of the extrapolated nodal "
                 "stress at the skin) | cpress (nodal CPRESS, which depends on where a skin node sits on the socket's facets)")
      ->check(CLI::IsMember({"force", "stress", "cpress"}));
  add_ccx_flags(cmd, f.ccx);
}

}  // namespace

void register_validate(CLI::App& app) {
  auto* v = add_command_group(app, "validate", "compare socketsmith with CalculiX (ccx) on the same mesh");

  auto cf = std::make_shared<CubeFlags>();
  auto* cube = v->add_subcommand("cube", "the thesis's cube in CalculiX against the analytic solution (checks the FE chain)");
  cube->add_option("--out", cf->out, "output folder (cube.inp, cube_fe.csv, cube_fe.svg, cube_fe.png, summary.json)")->required();
  cube->add_flag("--json", cf->json, "print the summary as JSON on stdout");
  cube->add_option("--divisions", cf->divisions, "elements per edge (default 4)")->check(CLI::Range(1, 40));
  cube->add_option("--youngs-kpa", cf->youngs_kpa, "Young's modulus [kPa] (default 50)")
      ->check(within(design::limits::kYoungsModulus));
  cube->add_option("--poisson", cf->poisson, "Poisson ratio (default 0.45)");
  cube->add_option("--max-force", cf->max_force, "plate force at the end [N] (default 8: 6.4 % strain)");
  cube->add_option("--increments", cf->increments, "equal load increments (default 8)")->check(CLI::Range(1, 100));
  cube->add_option("--edge-mm", cf->edge_mm, "cube edge [mm] (default 50)");
  cube->add_option("--element", cf->element, "c3d8 | c3d8i | c3d8r (default c3d8)");
  add_ccx_flags(*cube, cf->ccx);
  cube->callback([cf] { run_validate_cube(*cf); });

  auto df = std::make_shared<DesignFlags>();
  auto* des = v->add_subcommand("design", "design a case's socket, then check its pressures with CalculiX (thesis ch. 5)");
  add_case_flags(*des, *df);
  des->add_option("--mode", df->mode, "contact (socket fitted, CPRESS vs designed pressure) | load (designed loads, "
                                       "displacements) | donning (rigid socket pushed up the axis)")
      ->check(CLI::IsMember({"contact", "load", "donning"}));
  des->add_option("--clearance-mm", df->clearance_mm, "where the socket fit starts outside the skin [mm] (default 1)")
      ->check(positive());
  des->add_flag("--stand", df->stand,
                "with --mode donning: then stand on the socket with half the body weight (the thesis's second step; "
                "CalculiX moves it up the axis and is compared where it carries the load), and compare socketsmith's "
                "own donned-and-stood pressures too (the closed loop's when the case runs one)");
  des->add_flag("--against-donning", df->against_donning,
                "with --mode donning: compare CalculiX's donning with socketsmith's own donning simulation "
                "(contact solver, same travel and μ) instead of with the designed pressures (thesis ch. 3)");
  des->callback([df] {
    if (df->case_file.empty() && !df->demo) fail("validate design: give a case file or --demo");
    run_validate_design(*df);
  });

  // The thesis's ch. 3 check as its own command: the same as design --mode donning --against-donning.
  auto dn = std::make_shared<DesignFlags>();
  auto* don = v->add_subcommand("donning", "design a case's socket, don it with socketsmith and with CalculiX, compare "
                                           "the contact pressures (thesis ch. 3)");
  add_case_flags(*don, *dn);
  don->add_flag("--stand", dn->stand,
                "then stand on the socket with half the body weight in both (the thesis's second step; CalculiX moves "
                "the socket up the axis and is compared where it carries the load)");
  don->callback([dn] {
    if (dn->case_file.empty() && !dn->demo) fail("validate donning: give a case file or --demo");
    dn->mode = "donning";
    dn->against_donning = true;
    run_validate_design(*dn);
  });
}

}  // namespace socketsmith::cli
