#pragma once
/// @file sweep.h
/// Parameter sweeps (`socketsmith sweep`, docs/sweep.md): a sweep file expands a grid or a list
/// of limbs × body masses × tissue moduli × friction × brim templates × seeds into case files and
/// a manifest in one folder; each case runs as `socketsmith sweep case DIR ID` — a subprocess of
/// a local worker pool, or one task of a Slurm job array — and leaves a done marker; collect
/// gathers every case into one CSV and a summary plot.
///
/// Why subprocesses: a case that crashes or is killed (memory, a bug) must not take the sweep with
/// it, and the same entry point then serves a local run and a cluster job.
/// Why done markers: a case is finished when cases/<id>/done.json exists (written atomically
/// after its outputs), so a rerun skips it and an interrupted run loses at most the cases in flight.

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "socketsmith/core/progress.h"

namespace socketsmith::pipeline {

/// Resources of one Slurm array task (the sweep file's "slurm" object).
struct SlurmResources {
  std::string partition;        ///< "" = the cluster's default
  std::string account;          ///< "" = the user's default
  std::string time = "01:00:00";  ///< wall-time limit per case (Slurm's [D-]HH:MM:SS)
  int cpus_per_task = 1;        ///< also OMP_NUM_THREADS of the case, 1–256
  int mem_mb = 4000;            ///< memory per case [MB], 100–1e6
  int max_parallel = 0;         ///< array throttle (`%N`); 0 = no limit
};

/// One case of a sweep.
struct SweepCase {
  std::string id;              ///< "c0000", … in expansion order
  nlohmann::json parameters;   ///< the swept values of this case ({"body_mass_kg": 70, …})
  nlohmann::json case_doc;     ///< the whole case document (file units, absolute paths)
};

/// A parsed sweep file.
struct SweepSpec {
  std::string name;                  ///< "" = the sweep file's stem
  std::vector<SweepCase> cases;
  SlurmResources slurm;
};

/// The axes a grid or a list entry may set, in the grid's expansion order (outermost first):
/// limbs (objects merged into the case's "limb"), body_mass_kg, youngs_kpa, friction, brim (the
/// template), seeds (limb.generate_seed of a generated limb), target_nodes.
const std::vector<std::string>& sweep_axes();

/// Parses a sweep document (docs/sweep.md); @p folder resolves relative paths (the base case
/// file, limb and bone files). Every expanded case is a JSON document; it is checked when it
/// runs, so a bad case becomes a failed row, not a failed sweep.
/// @throws InvalidInputError naming the key and the fix (unknown key or axis, an empty axis, a
///         value of the wrong type, no cases, bad Slurm resources).
SweepSpec parse_sweep(const nlohmann::json& doc, const std::filesystem::path& folder);

/// Reads and parses a sweep file. @throws IoError when it cannot be read; as parse_sweep.
SweepSpec read_sweep(const std::filesystem::path& path);

/// Writes the manifest (DIR/manifest.json) and DIR/cases/<id>/case.json, atomically. A folder
/// that already holds the same sweep is kept as it is (its finished cases stay finished).
/// @throws InvalidInputError when DIR holds a different sweep (naming it and the fix).
void write_sweep(const SweepSpec& spec, const std::filesystem::path& dir);

/// The manifest of DIR. @throws InvalidInputError when DIR holds none (run `socketsmith sweep
/// SWEEP.json --out DIR` first).
nlohmann::json read_manifest(const std::filesystem::path& dir);

/// What one case came to (its done marker, cases/<id>/done.json).
struct SweepCaseStatus {
  std::string id;
  std::string status = "missing";  ///< ok | unmet (constraints not all met) | failed | missing (no marker)
  int exit_code = -1;              ///< the CLI's exit code for it (README, "Exit codes")
  std::string message;             ///< one line; "" when ok
  double seconds = 0.0;            ///< wall time of the case [s]
};

/// The done marker of case @p id in DIR, or status "missing".
SweepCaseStatus read_case_status(const std::filesystem::path& dir, const std::string& id);

/// Runs case @p id_or_index (its id, or its index in the manifest) in this process:
/// pipeline::run_design into cases/<id>/out, then the done marker. The case's own failure (bad
/// case, bad limb, diverged solver, constraints not met) is recorded, not thrown.
/// @throws InvalidInputError when there is no such case; IoError when the marker cannot be written.
SweepCaseStatus run_sweep_case(const std::filesystem::path& dir, const std::string& id_or_index);

struct SweepRunOptions {
  int workers = 1;                ///< cases run at once, 1–256
  std::string executable;         ///< the socketsmith program that runs `sweep case` (required)
  bool retry_failed = false;      ///< run failed and unmet cases again (finished ones are skipped otherwise)
  ProgressCallback progress;      ///< after each finished case: "sweep: 3/8 cases done (1 failed)"
};

struct SweepRunResult {
  int cases = 0;    ///< in the manifest
  int skipped = 0;  ///< finished before this run
  int ran = 0;
  int ok = 0, unmet = 0, failed = 0;  ///< of those that ran
  double seconds = 0.0;
};

/// Runs every unfinished case of DIR in subprocesses (`EXECUTABLE sweep case DIR ID`, output in
/// cases/<id>/log.txt), @p workers at a time. A process that ends without writing its marker
/// (crash, signal) gets a failed marker naming its exit and its log. DIR/run.lock is held (flock)
/// for the run.
/// @throws InvalidInputError for bad options or when another local run holds DIR; IoError when a
///         process cannot be started.
SweepRunResult run_sweep_local(const std::filesystem::path& dir, const SweepRunOptions& options);

/// Writes DIR/slurm/sweep.sbatch: a job array with one task per unfinished case (the sweep's
/// resources; each task runs `EXECUTABLE sweep case DIR $SLURM_ARRAY_TASK_ID`). Returns its path
/// and, in @p pending, how many tasks it has (0: nothing left to run; the script is not written).
std::filesystem::path write_slurm_script(const std::filesystem::path& dir, const std::string& executable,
                                         bool retry_failed, int* pending);

struct SweepCollectResult {
  int rows = 0;
  int ok = 0, unmet = 0, failed = 0, missing = 0;
  /// Cases whose design.json judges a closed loop's kept socket against the delivery bar
  /// (report/delivery_bar.h), and of those, the ones that meet it.
  int delivery_judged = 0, delivery_met = 0;
  std::filesystem::path csv;   ///< DIR/results.csv
  std::filesystem::path png;   ///< DIR/summary.png
  std::filesystem::path svg;   ///< DIR/summary.svg
};

/// Gathers every case of DIR into results.csv (one row per case of the manifest: its parameters,
/// status and failure message, the radar, peak pressure ratio, volumes, timings), written
/// atomically, and summary.png / summary.svg (peak pressure ratio, cavity volume and time per case).
SweepCollectResult collect_sweep(const std::filesystem::path& dir);

}  // namespace socketsmith::pipeline
