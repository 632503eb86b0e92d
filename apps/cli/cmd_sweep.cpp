// `socketsmith sweep SWEEP.json --out DIR [--workers N | --slurm]`, `socketsmith sweep collect DIR`
// and `socketsmith sweep case DIR ID` (one case: what a local worker or a Slurm array task runs).
// The sweep itself is pipeline/sweep.h; this file parses flags and prints.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <unistd.h>

#include "cli_common.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/exit_status.h"
#include "socketsmith/core/log.h"
#include "socketsmith/pipeline/sweep.h"

namespace socketsmith::cli {
namespace {

namespace fs = std::filesystem;

struct SweepFlags {
  std::string sweep_file;
  std::string out;
  int workers = 1;
  bool slurm = false;
  bool retry_failed = false;
  bool json = false;
  std::string dir;  // collect, case
  std::string id;   // case
};

/// This program's own path: the workers and array tasks run the same binary.
std::string self_executable() {
  std::error_code ec;
  const fs::path p = fs::read_symlink("/proc/self/exe", ec);
  require<IoError>(!ec, "sweep: cannot find this program's path (/proc/self/exe: {})", ec.message());
  return p.string();
}

/// The directory holding @p program on the PATH, or "".
std::string on_path(const std::string& program) {
  const char* path = std::getenv("PATH");
  std::string paths = path ? path : "";
  size_t start = 0;
  while (start <= paths.size()) {
    size_t end = paths.find(':', start);
    if (end == std::string::npos) end = paths.size();
    const fs::path candidate = fs::path(paths.substr(start, end - start)) / program;
    if (end > start && ::access(candidate.c_str(), X_OK) == 0) return candidate.string();
    start = end + 1;
  }
  return {};
}

void run_sweep(const SweepFlags& f) {
  const pipeline::SweepSpec spec = pipeline::read_sweep(f.sweep_file);
  pipeline::write_sweep(spec, f.out);
  log::info("sweep: {} cases of '{}' in {} (manifest.json, cases/<id>/case.json)", spec.cases.size(), spec.name, f.out);
  const std::string exe = self_executable();
  if (f.slurm) {
    int pending = 0;
    const fs::path script = pipeline::write_slurm_script(f.out, exe, f.retry_failed, &pending);
    if (pending == 0) {
      log::info("sweep: every case is finished; nothing to submit (socketsmith sweep collect {})", f.out);
      return;
    }
    log::info("sweep: wrote {} ({} array tasks)", script.string(), pending);
    const std::string sbatch = on_path("sbatch");
    if (sbatch.empty()) {
      log::info("sweep: sbatch not found: submit it on a Slurm cluster with `sbatch {}`, then `socketsmith sweep collect {}`",
                script.string(), f.out);
      return;
    }
    // --parsable: sbatch prints the job id alone ("123" or "123;cluster").
    const std::string cmd = "'" + sbatch + "' --parsable '" + script.string() + "'";
    FILE* p = ::popen(cmd.c_str(), "r");
    require<IoError>(p != nullptr, "sweep: cannot run {}", sbatch);
    std::string answer;
    char buf[256];
    while (std::fgets(buf, sizeof buf, p)) answer += buf;
    const int rc = ::pclose(p);
    require<IoError>(rc == 0, "sweep: sbatch failed (status {}) on {}: see its message above; is the cluster up "
                              "(sinfo)?", rc, script.string());
    const std::string job = one_line(answer.substr(0, answer.find(';')));
    log::info("sweep: submitted job array {} ({} tasks); when `squeue -j {}` is empty: socketsmith sweep collect {}", job,
              pending, job, f.out);
    if (f.json) print_json({{"job", job}, {"tasks", pending}, {"script", script.string()}, {"out", f.out}});
    return;
  }
  pipeline::SweepRunOptions o;
  o.workers = f.workers;
  o.executable = exe;
  o.retry_failed = f.retry_failed;
  o.progress = [](double, std::string_view stage) {
    log::info("{}", stage);
    return true;
  };
  const auto r = pipeline::run_sweep_local(f.out, o);
  log::info("sweep: {} cases: {} already finished, {} run ({} ok, {} constraints not met, {} failed) in {:.1f} s; "
            "results: socketsmith sweep collect {}",
            r.cases, r.skipped, r.ran, r.ok, r.unmet, r.failed, r.seconds, f.out);
  if (f.json)
    print_json({{"cases", r.cases}, {"skipped", r.skipped}, {"ran", r.ran}, {"ok", r.ok}, {"unmet", r.unmet},
                {"failed", r.failed}, {"seconds", r.seconds}, {"out", f.out}});
}

}  // namespace

void register_sweep(CLI::App& app) {
  auto f = std::make_shared<SweepFlags>();
  auto* cmd = app.add_subcommand("sweep", "parameter sweep: expand a sweep file into cases, run them (local workers or a "
                                          "Slurm job array), collect one CSV (docs/sweep.md)");
  cmd->require_subcommand(0, 1);
  cmd->add_option("sweep_file", f->sweep_file, "sweep file (JSON: base_case, grid or cases, slurm)");
  cmd->add_option("--out", f->out, "the sweep's folder (manifest, cases, results)");
  cmd->add_option("--workers", f->workers, "cases run at once on this machine (default 1)")->check(CLI::Range(1, 256));
  cmd->add_flag("--slurm", f->slurm, "write a Slurm job array (one task per unfinished case) and submit it with sbatch");
  cmd->add_flag("--retry-failed", f->retry_failed, "run failed cases again (finished cases are skipped otherwise)");
  cmd->add_flag("--json", f->json, "print the run's counts as JSON");

  auto* collect = cmd->add_subcommand("collect", "gather every case of a sweep into results.csv and summary.png/.svg");
  collect->add_option("dir", f->dir, "the sweep's folder")->required();
  collect->add_flag("--json", f->json, "print the counts as JSON");
  collect->callback([f] {
    const auto r = pipeline::collect_sweep(f->dir);
    log::info("sweep collect: {} rows ({} ok, {} constraints not met, {} failed, {} not run) -> {}, {}", r.rows, r.ok,
              r.unmet, r.failed, r.missing, r.csv.string(), r.png.string());
    if (r.delivery_judged > 0)
      log::info("sweep collect: the delivery bar (below the brim, each path, each landmark) met by {} of the {} closed "
                "loops (results.csv: delivery_bar_met, delivery_bar_missed)",
                r.delivery_met, r.delivery_judged);
    if (f->json)
      print_json({{"rows", r.rows}, {"ok", r.ok}, {"unmet", r.unmet}, {"failed", r.failed}, {"missing", r.missing},
                  {"delivery_judged", r.delivery_judged}, {"delivery_met", r.delivery_met},
                  {"csv", r.csv.string()}, {"png", r.png.string()}, {"svg", r.svg.string()}});
  });

  auto* one = cmd->add_subcommand("case", "run one case of a sweep in this process and write its done marker (what "
                                          "the workers and the Slurm array tasks run)");
  one->add_option("dir", f->dir, "the sweep's folder")->required();
  one->add_option("id", f->id, "the case's id (c0003) or index in the manifest (3)")->required();
  one->callback([f] {
    const auto s = pipeline::run_sweep_case(f->dir, f->id);
    if (s.status == "ok") {
      log::info("sweep case {}: ok in {:.1f} s", s.id, s.seconds);
      return;
    }
    // The case's failure is recorded in its marker; the exit code says it too (Slurm's accounting shows it).
    std::fprintf(stderr, "error: sweep case %s: %s\n", s.id.c_str(), s.message.c_str());
    std::fflush(stderr);
    std::exit(s.exit_code == kExitSuccess ? kExitBadInput : s.exit_code);
  });

  cmd->callback([f, cmd] {
    if (!cmd->get_subcommands().empty()) return;
    require(!f->sweep_file.empty() && !f->out.empty(),
            "sweep: give a sweep file and --out DIR (socketsmith sweep SWEEP.json --out DIR), or `sweep collect DIR`");
    run_sweep(*f);
  });
}

}  // namespace socketsmith::cli
