// Running a sweep's cases: a local pool of `socketsmith sweep case` subprocesses (each its own
// process, a lock against a second run, failures read from their logs) and the Slurm job-array
// script (sweep_detail.h says why this is apart).
#include "socketsmith/pipeline/sweep.h"
#include "socketsmith/pipeline/sweep_detail.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>

#include <fmt/format.h>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/exit_status.h"
#include "socketsmith/core/json_input.h"
#include "socketsmith/core/log.h"
#include "socketsmith/design/case_file.h"
#include "socketsmith/pipeline/design_pipeline.h"

extern char** environ;

namespace socketsmith::pipeline {
using namespace sweep_detail;

namespace {

/// Starts `argv` with stdout and stderr into @p log; OMP_NUM_THREADS set to @p omp_threads unless
/// the environment sets it.
pid_t spawn(const std::vector<std::string>& argv, const fs::path& log, int omp_threads) {
  // Everything the child needs is prepared before fork (only async-signal-safe calls after it).
  std::vector<std::string> env;
  bool has_omp = false;
  for (char** e = environ; e && *e; ++e) {
    env.emplace_back(*e);
    if (std::strncmp(*e, "OMP_NUM_THREADS=", 16) == 0) has_omp = true;
  }
  if (!has_omp) env.push_back(fmt::format("OMP_NUM_THREADS={}", omp_threads));
  std::vector<char*> envp, args;
  for (auto& e : env) envp.push_back(e.data());
  envp.push_back(nullptr);
  std::vector<std::string> argv_copy = argv;
  for (auto& a : argv_copy) args.push_back(a.data());
  args.push_back(nullptr);
  const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  require<IoError>(fd >= 0, "sweep: cannot write '{}': {}", log.string(), std::strerror(errno));
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    ::execve(args[0], args.data(), envp.data());
    static const char msg[] = "error: sweep: cannot run the socketsmith program (execve failed)\n";
    [[maybe_unused]] auto n = ::write(2, msg, sizeof(msg) - 1);
    ::_exit(127);
  }
  ::close(fd);
  require<IoError>(pid > 0, "sweep: cannot start a process for '{}': {}", argv[0], std::strerror(errno));
  return pid;
}

/// The last line of a log that starts with "error" (the CLI's one-line error), or "".
std::string last_error_line(const fs::path& log) {
  std::ifstream in(log);
  std::string line, found;
  while (std::getline(in, line))
    if (line.rfind("error:", 0) == 0 || line.rfind("internal error:", 0) == 0) found = line;
  return found;
}

/// One local run per folder: a second would start the same unfinished cases again. Held while
/// alive (an flock on the folder's lock file, released when the file is closed).
class SweepRunLock {
 public:
  /// @throws IoError when the lock file cannot be opened; InvalidInputError when another run holds it.
  explicit SweepRunLock(const fs::path& dir) {
    const fs::path lock_path = dir / kRunLock;
    fd_ = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    require<IoError>(fd_ >= 0, "sweep: cannot open '{}': {}", lock_path.string(), std::strerror(errno));
    if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      ::close(fd_);  // no destructor runs for a constructor that throws
      fail("sweep: another `socketsmith sweep` is running the cases of '{}' ({} is locked): wait for it to end or stop "
           "it",
           dir.string(), lock_path.string());
    }
  }
  ~SweepRunLock() {
    if (fd_ >= 0) ::close(fd_);  // releases the flock
  }
  SweepRunLock(const SweepRunLock&) = delete;
  SweepRunLock& operator=(const SweepRunLock&) = delete;

 private:
  int fd_ = -1;
};

/// Case @p id's status once its process ended (waitpid gave @p w and @p status): its marker, or,
/// when the process ended without one (a crash, a signal, a program that could not start), a
/// failure naming how it ended and the log's error line, written as its marker.
SweepCaseStatus ended_case_status(const fs::path& dir, const std::string& id, pid_t w, int status) {
  SweepCaseStatus s = read_case_status(dir, id);
  if (s.status != "missing") return s;
  s.status = "failed";
  const std::string how = w < 0                ? "could not be waited for"
                          : WIFSIGNALED(status) ? fmt::format("was killed by signal {} ({})", WTERMSIG(status),
                                                              strsignal(WTERMSIG(status)))
                                                : fmt::format("exited with code {}", WEXITSTATUS(status));
  const std::string err = last_error_line(case_dir(dir, id) / "log.txt");
  s.exit_code = WIFEXITED(status) && WEXITSTATUS(status) != 0 ? WEXITSTATUS(status) : kExitInternal;
  s.message = fmt::format("the case's process {} without a result{}; see {}", how,
                          err.empty() ? std::string() : " (" + err + ")", (case_dir(dir, id) / "log.txt").string());
  write_marker(dir, s);
  return s;
}

}  // namespace

SweepRunResult run_sweep_local(const fs::path& dir, const SweepRunOptions& o) {
  require(o.workers >= 1 && o.workers <= 256, "sweep: --workers {} is outside [1, 256]", o.workers);
  require(!o.executable.empty(), "run_sweep_local: no executable given (the socketsmith program)");
  const auto t0 = std::chrono::steady_clock::now();
  const json m = read_manifest(dir);
  const SweepRunLock lock(dir);
  SweepRunResult r;
  r.cases = static_cast<int>(m["cases"].size());
  std::vector<std::string> pending;
  for (const auto& c : m["cases"]) {
    const std::string id = c["id"].get<std::string>();
    if (is_finished(read_case_status(dir, id), o.retry_failed)) ++r.skipped;
    else pending.push_back(id);
  }
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  const int omp_threads = std::max(1, static_cast<int>(cores) / o.workers);
  const fs::path abs_dir = fs::absolute(dir);
  std::map<pid_t, std::string> running;
  size_t next = 0;
  int done = 0;
  const int to_run = static_cast<int>(pending.size());
  while (next < pending.size() || !running.empty()) {
    while (next < pending.size() && static_cast<int>(running.size()) < o.workers) {
      const std::string& id = pending[next++];
      ensure_directory(case_dir(dir, id));
      const pid_t pid = spawn({o.executable, "sweep", "case", abs_dir.string(), id}, case_dir(dir, id) / "log.txt",
                              omp_threads);
      running[pid] = id;
    }
    bool reaped = false;
    for (auto it = running.begin(); it != running.end();) {
      int status = 0;
      const pid_t w = ::waitpid(it->first, &status, WNOHANG);
      if (w == 0) {
        ++it;
        continue;
      }
      const std::string id = it->second;
      it = running.erase(it);
      reaped = true;
      const SweepCaseStatus s = ended_case_status(dir, id, w, status);
      ++r.ran;
      ++done;
      if (s.status == "ok") ++r.ok;
      else if (s.status == "unmet") ++r.unmet;
      else ++r.failed;
      report_progress(o.progress, to_run > 0 ? static_cast<double>(done) / to_run : 1.0,
                      fmt::format("sweep: {}/{} cases run ({} ok, {} constraints not met, {} failed)", done, to_run,
                                  r.ok, r.unmet, r.failed));
    }
    if (!reaped && !running.empty()) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

fs::path write_slurm_script(const fs::path& dir, const std::string& executable, bool retry_failed, int* pending) {
  const json m = read_manifest(dir);
  SlurmResources s;
  if (m.contains("slurm")) s = parse_slurm(m["slurm"]);
  std::vector<size_t> todo;
  for (size_t k = 0; k < m["cases"].size(); ++k)
    if (!is_finished(read_case_status(dir, m["cases"][k]["id"].get<std::string>()), retry_failed)) todo.push_back(k);
  if (pending) *pending = static_cast<int>(todo.size());
  const fs::path abs_dir = fs::absolute(dir);
  const fs::path script = abs_dir / "slurm" / "sweep.sbatch";
  if (todo.empty()) return script;
  // The array's indices: ranges of consecutive unfinished cases ("0-7,9,12-15").
  std::string array;
  for (size_t a = 0; a < todo.size();) {
    size_t b = a;
    while (b + 1 < todo.size() && todo[b + 1] == todo[b] + 1) ++b;
    if (!array.empty()) array += ',';
    array += a == b ? fmt::format("{}", todo[a]) : fmt::format("{}-{}", todo[a], todo[b]);
    a = b + 1;
  }
  if (s.max_parallel > 0) array += fmt::format("%{}", s.max_parallel);
  const auto quote = [](const std::string& t) {
    std::string q = "'";
    for (char c : t) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return q + "'";
  };
  std::string name = m.value("name", std::string("sweep"));
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
  std::string text = "#!/bin/bash\n";
  text += "# Written by `socketsmith sweep --slurm`: one array task per unfinished case of the sweep in\n";
  text += "# " + abs_dir.string() + " (docs/sweep.md). Each task writes cases/<id>/done.json;\n";
  text += "# `socketsmith sweep collect DIR` gathers them.\n";
  text += fmt::format("#SBATCH --job-name=socketsmith-{}\n", name);
  text += fmt::format("#SBATCH --array={}\n", array);
  text += fmt::format("#SBATCH --output={}/slurm/%A_%a.out\n", abs_dir.string());
  text += fmt::format("#SBATCH --cpus-per-task={}\n", s.cpus_per_task);
  text += fmt::format("#SBATCH --mem={}M\n", s.mem_mb);
  text += fmt::format("#SBATCH --time={}\n", s.time);
  if (!s.partition.empty()) text += fmt::format("#SBATCH --partition={}\n", s.partition);
  if (!s.account.empty()) text += fmt::format("#SBATCH --account={}\n", s.account);
  text += "export OMP_NUM_THREADS=${SLURM_CPUS_PER_TASK:-1}\n";
  text += fmt::format("exec {} sweep case {} \"$SLURM_ARRAY_TASK_ID\"\n", quote(executable), quote(abs_dir.string()));
  ensure_directory(abs_dir / "slurm");
  write_text_atomically(script, text);
  fs::permissions(script, fs::perms::owner_exec | fs::perms::group_exec | fs::perms::others_exec, fs::perm_options::add);
  return script;
}

}  // namespace socketsmith::pipeline
