#pragma once
/// @file ccx_runner.h
/// Runs CalculiX (`ccx`) on a deck in a job directory as a subprocess: progress from its output
/// (step, converged increments, step time), a wall-time limit, its log kept beside the deck, and a clear
/// outcome when it is missing, rejects the deck, or does not converge.

#include <filesystem>
#include <string>

#include "socketsmith/core/progress.h"

namespace socketsmith::calculix {

struct CcxOptions {
  std::string executable = "ccx";  ///< name on the PATH or a path
  int threads = 1;                 ///< OMP_NUM_THREADS / CCX_NPROC_EQUATION_SOLVER, ≥ 1
  double time_limit_s = 3600.0;    ///< wall-time limit [s], > 0; the process group is killed after it
  int num_steps = 1;               ///< steps in the deck (for the progress fraction), ≥ 1
  /// ccx's address space is capped at this fraction of the machine's physical memory, in (0, 1], so
  /// a run that runs away (contact can make ccx grow to all of it) fails with its own out-of-memory
  /// error instead of the system killing a process of its choosing.
  double memory_fraction = 0.75;
  ProgressCallback progress;       ///< fraction over all steps; returning false kills ccx
};

/// What happened.
struct CcxRun {
  bool converged = false;    ///< ccx finished ("Job finished") without an *ERROR line
  bool timed_out = false;
  bool cancelled = false;
  int exit_code = -1;
  double wall_s = 0.0;
  int last_step = 0;          ///< last step started
  int increments = 0;         ///< increments completed (all steps)
  double last_step_time = 0;  ///< step time of the last converged increment
  std::string error_line;     ///< ccx's first *ERROR line (or the reason it stopped)
  double memory_limit_bytes = 0;  ///< the cap on ccx's address space (CcxOptions::memory_fraction)
  bool out_of_memory = false;  ///< ccx could not allocate under the cap, or the system killed it
  std::string message;        ///< one line: what happened and the fix
  std::filesystem::path log;  ///< <job>.log: ccx's stdout and stderr
  std::filesystem::path frd, dat;  ///< <job>.frd, <job>.dat
};

/// Full path of the ccx executable. @throws InvalidInputError naming it and the fix
/// (install `calculix-ccx`, or give the path) when it is not found or not executable.
std::string find_ccx(const std::string& executable = "ccx");

/// Runs `ccx -i <job>` in @p job_dir on <job>.inp (already written).
/// @throws InvalidInputError when ccx is not found (find_ccx), IoError when the deck is missing
///         or the process cannot be started. A failure of ccx itself (deck rejected,
///         non-convergence, time limit) is returned with converged = false and a message.
CcxRun run_ccx(const std::filesystem::path& job_dir, const std::string& job, const CcxOptions& options = {});

}  // namespace socketsmith::calculix
