// `socketsmith simulate donning`: the designed (or a given) socket slides onto the stump with
// friction, then the patient stands; contact pressures against the designed ones.
// `socketsmith simulate sockply`: the designed socket donned on the limb shrunk and grown.
// The flags and the printing; the runs and their files are pipeline::run_donning and
// pipeline::run_sock_ply_case (pipeline/donning_run.h).
#include <cmath>
#include <filesystem>
#include <optional>

#include "cli_common.h"
#include "socketsmith/contact/donning.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/core/progress.h"
#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/pipeline/donning_run.h"

namespace socketsmith::cli {
namespace {

namespace fs = std::filesystem;

struct DonningFlags {
  std::string case_file, limb, socket, units, out;
  double offset_mm = 0;  // 0: automatic
  int steps = 0;         // 0: one per step_mm
  double step_mm = 0;    // 0: the case's design.closed_loop_step_mm (by default DonningOptions::step_m)
  double stick_stiffness = contact::DonningOptions{}.contact.stick_stiffness_ratio;
  int target_nodes = 0;
  double friction = -1;
  double penalty_factor = 20;
  int reuse_cg = -1;
  std::string wall;  // "" = the default (DonningOptions::smooth_wall)
  std::string body = "design";  // design | linearised | nonlinear
  bool no_stand = false;
  bool rigid_wall = false;
  bool json = false;
};

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

/// The request of the flags, in SI units.
pipeline::DonningRequest donning_request(const DonningFlags& f) {
  pipeline::DonningRequest q{.case_file = f.case_file, .limb = f.limb, .socket = f.socket, .units = f.units,
                             .target_nodes = f.target_nodes, .start_offset_m = f.offset_mm * 1e-3, .steps = f.steps,
                             .max_step_m = f.step_mm * 1e-3, .stick_stiffness_ratio = f.stick_stiffness,
                             .friction = f.friction, .penalty_factor = f.penalty_factor, .reuse_cg = f.reuse_cg,
                             .smooth_wall = f.wall.empty() ? std::nullopt : std::optional<bool>(f.wall == "smooth"),
                             .rigid_wall = f.rigid_wall,
                             .body = f.body == "linearised"  ? pipeline::DonnedBody::Linearised
                                     : f.body == "nonlinear" ? pipeline::DonnedBody::Nonlinear
                                                             : pipeline::DonnedBody::Design,
                             .stand = !f.no_stand, .progress = console_progress(1.0)};
  return q;
}

/// The outcome in one line, and with a design the agreement below the brim in another.
void log_donning_result(const contact::DonningResult& r, const nlohmann::json& agreement, bool has_design) {
  const contact::DonningSample last = pipeline::last_sample(r);
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
  const pipeline::DonningRun run = pipeline::run_donning(donning_request(f), out);
  const contact::DonningResult& r = run.donning;
  if (run.options.stand_force_n > 0 && !r.stood)
    log::warn("donning: {}; the results are those of the donned socket at its designed pose", r.message);
  if (f.json) {
    print_json(run.summary);
    return 0;
  }
  log_donning_result(r, run.agreement, run.has_design);
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
  pipeline::SockPlyRequest q;
  q.study.volume_changes.clear();
  for (double v : f.changes_pct) {
    require(std::isfinite(v) && std::abs(v) <= 20,
            "simulate sockply: volume change {} % is outside [-20, 20] % (e.g. --volume-changes-pct -4,-2,2,4)", v);
    q.study.volume_changes.push_back(v / 100);
  }
  q.case_file = f.case_file;
  q.demo = f.demo;
  q.target_nodes = f.target_nodes;
  q.progress = console_progress(1.0);
  const fs::path out(f.out);
  const pipeline::SockPlyRun run = pipeline::run_sock_ply_case(q, out);
  if (f.json) {
    print_json(run.summary["sock_ply"]);
    return 0;
  }
  for (const auto& l : run.result.sock_ply->levels)
    log::info("sockply: limb {:+5.1f} % (skin {:+.3f} mm): {}", 100 * l.volume_change, l.skin_offset_m * 1e3,
              l.stood ? fmt::format("socket at {:+.2f} mm, limb {} {:.2f} mm, peak p/T {:.3f} ({}), distal mean {:.1f} "
                                    "kPa, peak {:.1f} kPa; constraints {}",
                                    l.stood_offset_m * 1e3, l.sink_m >= 0 ? "sinks" : "rises", std::abs(l.sink_m) * 1e3,
                                    l.peak_ratio, l.peak_zone, l.distal_mean_pa / 1e3, l.distal_peak_pa / 1e3,
                                    l.status.all_ok() ? "all hold" : "fail: " + l.status.failing())
                      : "did not stand: " + l.message);
  log::info("sockply: done in {:.1f} s; outputs in {} (sockply.csv, design.json \"sock_ply\", sockply.png, report.html)",
            run.seconds, out.string());
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
                  fmt::format("longest adaptive step [mm] (default: the case's design.closed_loop_step_mm, {:g} without; down to {:g} mm "
                              "where a node starts sticking)",
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
  don->add_flag("--rigid-wall", f->rigid_wall,
                "no penetration of the socket wall (augmented Lagrangian contact: the penalty's ~60 µm at 15 kPa "
                "removed; ~1.5x the time; on when the case sets design.closed_loop_rigid_wall)");
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
