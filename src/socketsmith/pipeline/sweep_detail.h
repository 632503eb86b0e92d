#pragma once
/// The sweep's shared pieces (inside `pipeline` only; `sweep.h` is the interface): reading a JSON
/// file with one-line errors, a case's folder and its done marker, the Slurm resources of a sweep
/// file. Used by the sweep's spec and cases (`sweep.cpp`), its runners — a local pool of
/// subprocesses and the Slurm job array (`sweep_runner.cpp`) — and its collection into one CSV and
/// a plot (`sweep_collect.cpp`). Why apart: each is a responsibility of its own.

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "socketsmith/pipeline/sweep.h"

namespace socketsmith::pipeline::sweep_detail {

namespace fs = std::filesystem;
using json = nlohmann::json;

// Axis names: the grid's (plural where it reads better) and the list's, and the column each fills.
struct Axis {
  const char* grid_key;
  const char* column;
};
inline constexpr Axis kAxes[] = {{"limbs", "limb"},       {"body_mass_kg", "body_mass_kg"}, {"youngs_kpa", "youngs_kpa"},
                          {"friction", "friction"}, {"brim", "brim"},                 {"seeds", "seed"},
                          {"target_nodes", "target_nodes"}};

inline constexpr const char* kRunLock = "run.lock";  ///< held (flock) by a local run

/// A JSON file read whole; one-line errors name @p what and the file.
json read_json_file(const fs::path& path, const std::string& what);
/// The sweep file's "slurm" object, checked.
SlurmResources parse_slurm(const json& j);
/// The folder of case @p id of the sweep in @p dir.
fs::path case_dir(const fs::path& dir, const std::string& id);
/// The case's done.json, written atomically: it is finished, with this status.
void write_marker(const fs::path& dir, const SweepCaseStatus& s);
/// Whether a run skips the case: done, or failed and not to be retried.
bool is_finished(const SweepCaseStatus& s, bool retry_failed);

}  // namespace socketsmith::pipeline::sweep_detail
