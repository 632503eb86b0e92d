#include "socketsmith/calculix/ccx_runner.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "socketsmith/core/errors.h"

namespace socketsmith::calculix {
namespace fs = std::filesystem;

std::string find_ccx(const std::string& executable) {
  const auto is_exec = [](const fs::path& p) { return ::access(p.c_str(), X_OK) == 0 && fs::is_regular_file(p); };
  const std::string fix = "install CalculiX (sudo apt-get install calculix-ccx, or scripts/setup.sh) or pass --ccx PATH";
  // ccx runs in the job's folder (run_ccx changes into it), so a relative path is made absolute
  // here, against the folder the user typed it in.
  if (executable.find('/') != std::string::npos) {
    if (is_exec(executable)) return fs::absolute(executable).lexically_normal().string();
    fail("CalculiX executable '{}' is not found or not executable: {}", executable, fix);
  }
  const char* path = std::getenv("PATH");
  std::stringstream ss(path ? path : "/usr/bin:/bin");
  std::string dir;
  while (std::getline(ss, dir, ':')) {
    const fs::path p = fs::path(dir.empty() ? "." : dir) / executable;
    if (is_exec(p)) return fs::absolute(p).lexically_normal().string();
  }
  if (is_exec(executable))
    fail("CalculiX ('{}') is not on the PATH; to run the file in this folder, pass --ccx ./{}", executable, executable);
  fail("CalculiX ('{}') is not on the PATH: {}", executable, fix);
}

namespace {

/// Progress from ccx's output lines (" STEP 1", " increment 3 attempt 1", " actual step time=...").
struct OutputParser {
  CcxRun& run;
  const CcxOptions& options;
  bool job_finished = false;
  bool cancel = false;
  double attempted_time = 0;
  void line(const std::string& l) {
    const auto first = l.find_first_not_of(' ');
    if (first == std::string::npos) return;
    const std::string t = l.substr(first);
    if (t.starts_with("STEP ")) {
      run.last_step = std::atoi(t.c_str() + 5);
      run.last_step_time = 0;
    } else if (t.starts_with("actual step time=")) {
      attempted_time = std::atof(t.c_str() + 17);  // the increment being attempted
    } else if (t.starts_with("convergence")) {       // "convergence" / "convergence; the increment size ..."
      run.last_step_time = attempted_time;
      ++run.increments;
      const double f = (std::max(run.last_step, 1) - 1 + run.last_step_time) / std::max(options.num_steps, 1);
      if (!report_progress(options.progress, std::min(f, 1.0),
                           fmt::format("ccx: step {}, increment {} converged at step time {:.3f}", run.last_step,
                                       run.increments, run.last_step_time)))
        cancel = true;
    } else if (t.starts_with("*ERROR") && run.error_line.empty()) {
      run.error_line = t;
    } else if (t.starts_with("Job finished")) {
      job_finished = true;
    }
  }
};

/// Starts ccx on @p job in @p job_dir with @p threads threads and its address space capped at
/// @p memory_limit_bytes (0: not capped), in a process group of its own (what the time limit
/// kills), its stdout and stderr into the pipe's write end @p pipe_fds[1].
/// Returns its pid. @throws IoError when it cannot fork.
pid_t start_ccx(const std::string& exe, const fs::path& job_dir, const std::string& job, int threads,
                double memory_limit_bytes, const int pipe_fds[2]) {
  const rlim_t cap = static_cast<rlim_t>(memory_limit_bytes);
  const pid_t pid = ::fork();
  if (pid < 0) fail<IoError>("run_ccx: cannot start ccx: {}", std::strerror(errno));
  if (pid == 0) {
    ::setpgid(0, 0);
    ::dup2(pipe_fds[1], 1);
    ::dup2(pipe_fds[1], 2);
    ::close(pipe_fds[0]);
    ::close(pipe_fds[1]);
    if (::chdir(job_dir.c_str()) != 0) ::_exit(126);
    const rlimit as{cap, cap};
    if (cap > 0) ::setrlimit(RLIMIT_AS, &as);
    const std::string n = std::to_string(threads);
    ::setenv("OMP_NUM_THREADS", n.c_str(), 1);
    ::setenv("CCX_NPROC_EQUATION_SOLVER", n.c_str(), 1);
    ::setenv("CCX_NPROC_RESULTS", n.c_str(), 1);
    ::execl(exe.c_str(), exe.c_str(), "-i", job.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  ::setpgid(pid, pid);
  return pid;
}

/// Reads ccx's output from @p fd until it closes: into the log and, line by line, into @p parser.
/// Kills ccx's process group past the time limit or when the progress callback cancels (and says
/// which in the run). Returns whether it killed ccx.
bool follow_ccx_output(int fd, pid_t pid, std::chrono::steady_clock::time_point t0, const CcxOptions& options,
                       std::ofstream& log, OutputParser& parser) {
  std::string pending;
  char buf[4096];
  bool killed = false;
  for (;;) {
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!killed && (elapsed > options.time_limit_s || parser.cancel)) {
      parser.run.timed_out = !parser.cancel;
      parser.run.cancelled = parser.cancel;
      ::kill(-pid, SIGKILL);
      killed = true;
    }
    pollfd p{fd, POLLIN, 0};
    const int r = ::poll(&p, 1, 200);
    if (r < 0 && errno == EINTR) continue;
    if (r == 0) continue;
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n <= 0) break;
    log.write(buf, n);
    pending.append(buf, static_cast<size_t>(n));
    size_t nl;
    while ((nl = pending.find('\n')) != std::string::npos) {
      parser.line(pending.substr(0, nl));
      pending.erase(0, nl + 1);
    }
  }
  if (!pending.empty()) parser.line(pending);
  return killed;
}

/// The run's message (and its error line when ccx was stopped): how long it took, or why it failed
/// and what to do about it.
void describe_ccx_run(const std::string& exe, const CcxOptions& options, CcxRun& run) {
  const std::string where = fmt::format("(log: {})", run.log.string());
  if (run.converged) {
    run.message = fmt::format("ccx finished in {:.1f} s ({} increments)", run.wall_s, run.increments);
  } else if (run.timed_out) {
    run.error_line = fmt::format("time limit of {:.0f} s reached", options.time_limit_s);
    run.message = fmt::format("ccx stopped at the time limit of {:.0f} s in step {} at step time {:.3f} {}: raise "
                              "--ccx-time-limit or use a coarser mesh (--target-nodes)",
                              options.time_limit_s, run.last_step, run.last_step_time, where);
  } else if (run.cancelled) {
    run.error_line = "cancelled";
    run.message = "ccx cancelled";
  } else if (run.out_of_memory) {
    run.message = fmt::format("ccx ran out of memory in step {} after {} increments (capped at {:.1f} GB, {:.0f} % of "
                              "this machine's) {}: use a coarser mesh (--target-nodes) or close other programs",
                              run.last_step, run.increments, run.memory_limit_bytes / 1e9,
                              100.0 * options.memory_fraction, where);
  } else if (run.exit_code == 127) {
    run.message = fmt::format("ccx ('{}') could not be executed {}: reinstall calculix-ccx", exe, where);
  } else {
    const std::string err = run.error_line.empty() ? fmt::format("exit code {} without 'Job finished'", run.exit_code)
                                                   : run.error_line;
    const bool convergence = err.find("increment size smaller") != std::string::npos ||
                             err.find("too many cutbacks") != std::string::npos ||
                             err.find("too many iterations") != std::string::npos ||
                             err.find("divergence") != std::string::npos;
    const std::string fix = convergence
                                ? "ccx did not converge: try smaller increments, a softer contact penalty, a smaller "
                                  "donning travel or a coarser mesh; converged increments are kept in the .frd"
                                : run.increments == 0 ? "ccx rejected the deck: read the log's *ERROR line and the deck"
                                                      : "ccx stopped: read the log";
    run.message = fmt::format("ccx failed in step {} after {} increments: {} {}: {}", run.last_step, run.increments, err,
                              where, fix);
  }
}

}  // namespace

CcxRun run_ccx(const fs::path& job_dir, const std::string& job, const CcxOptions& options) {
  const std::string exe = find_ccx(options.executable);
  require(options.threads >= 1, "run_ccx: threads {} (expected ≥ 1)", options.threads);
  require(options.time_limit_s > 0, "run_ccx: time limit {} s (expected > 0)", options.time_limit_s);
  require(options.memory_fraction > 0 && options.memory_fraction <= 1, "run_ccx: memory fraction {} (expected in (0, 1])",
          options.memory_fraction);
  const fs::path inp = job_dir / (job + ".inp");
  if (!fs::exists(inp)) fail<IoError>("run_ccx: the deck '{}' does not exist", inp.string());
  CcxRun run;
  run.log = job_dir / (job + ".log");
  run.frd = job_dir / (job + ".frd");
  run.dat = job_dir / (job + ".dat");
  std::error_code ec;
  fs::remove(run.frd, ec);
  fs::remove(run.dat, ec);

  int fds[2];
  if (::pipe(fds) != 0) fail<IoError>("run_ccx: cannot create a pipe: {}", std::strerror(errno));
  const auto t0 = std::chrono::steady_clock::now();
  const double physical = static_cast<double>(::sysconf(_SC_PHYS_PAGES)) * static_cast<double>(::sysconf(_SC_PAGESIZE));
  run.memory_limit_bytes = physical > 0 ? options.memory_fraction * physical : 0.0;
  const pid_t pid = start_ccx(exe, job_dir, job, options.threads, run.memory_limit_bytes, fds);
  ::close(fds[1]);
  std::ofstream log(run.log, std::ios::binary);
  OutputParser parser{run, options};
  const bool killed = follow_ccx_output(fds[0], pid, t0, options, log, parser);
  ::close(fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  log.close();
  run.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
  run.converged = parser.job_finished && run.error_line.empty() && !killed && run.exit_code == 0;
  // Its own allocation failure under the cap, or the system's out-of-memory killer (SIGKILL not sent here).
  run.out_of_memory = !run.converged && (run.error_line.starts_with("*ERROR in u_calloc") ||
                                         (!killed && run.exit_code == 128 + SIGKILL));
  describe_ccx_run(exe, options, run);
  return run;
}

}  // namespace socketsmith::calculix
