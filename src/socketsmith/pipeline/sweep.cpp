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

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace sweep_detail;

namespace {

constexpr const char* kManifest = "manifest.json";


std::string known_axes() {
  std::string s;
  for (const auto& a : kAxes) s += (s.empty() ? "" : ", ") + std::string(a.grid_key);
  return s;
}

/// The column an axis key names (grid or list spelling), or "".
std::string column_of(const std::string& key) {
  for (const auto& a : kAxes)
    if (key == a.grid_key || key == a.column) return a.column;
  return {};
}


/// Limb and bone files named relative to @p folder become absolute: the case files live elsewhere.
void absolute_limb_paths(json& limb, const fs::path& folder) {
  if (!limb.is_object()) return;
  const auto fix = [&](const char* key) {
    if (!limb.contains(key) || !limb[key].is_string()) return;
    const std::string v = limb[key].get<std::string>();
    if (v.empty() || v == "auto" || v == "estimate" || v == "none") return;
    const fs::path p(v);
    if (p.is_relative()) limb[key] = (folder / p).lexically_normal().string();
  };
  fix("file");
  fix("bones");
}

/// The value of one axis applied to a case document.
void apply_axis(json& c, const std::string& column, const json& v, const fs::path& folder) {
  if (column == "limb") {
    require(v.is_object(), "sweep file: each limb must be an object like the case file's \"limb\" ({{\"file\": "
                           "\"scan.stl\", \"units\": \"mm\"}} or {{\"type\": \"transtibial\"}}), not {}", v.dump());
    json limb = v;
    absolute_limb_paths(limb, folder);
    c["limb"] = limb;
  } else if (column == "body_mass_kg") {
    c["patient"]["body_mass_kg"] = v;
  } else if (column == "youngs_kpa") {
    c["tissue"]["youngs_kpa"] = v;
  } else if (column == "friction") {
    c["patient"]["friction"] = v;
  } else if (column == "brim") {
    c["brim"]["template"] = v;
  } else if (column == "seed") {
    if (!c["limb"].contains("file")) c["limb"]["generate_seed"] = v;
  } else if (column == "target_nodes") {
    c["mesh"]["target_nodes"] = v;
  }
}

std::string case_id(size_t k, size_t n) { return n > 10000 ? fmt::format("c{:06d}", k) : fmt::format("c{:04d}", k); }


json slurm_json(const SlurmResources& s) {
  return {{"partition", s.partition}, {"account", s.account},   {"time", s.time},
          {"cpus_per_task", s.cpus_per_task}, {"mem_mb", s.mem_mb}, {"max_parallel", s.max_parallel}};
}




}  // namespace

json sweep_detail::read_json_file(const fs::path& path, const std::string& what) {
  std::ifstream in(path);
  require<IoError>(in.good(), "cannot open {} '{}' (check the path)", what, path.string());
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_json_input(ss.str(), fmt::format("{} '{}'", what, path.string()));
}

SlurmResources sweep_detail::parse_slurm(const json& j) {
  SlurmResources s;
  require(j.is_object(), "sweep file: \"slurm\" must be an object (partition, account, time, cpus_per_task, mem_mb, "
                         "max_parallel)");
  for (const auto& [k, v] : j.items()) {
    if (k == "partition" || k == "account" || k == "time") {
      require(v.is_string(), "sweep file: slurm.{} must be a string", k);
      const std::string text = v.get<std::string>();
      require(text.find_first_of(" \n\r\t'\"\\$`") == std::string::npos,
              "sweep file: slurm.{} = '{}' has a blank, a quote or a '$': give a plain Slurm value", k, text);
      (k == "partition" ? s.partition : k == "account" ? s.account : s.time) = text;
    } else if (k == "cpus_per_task" || k == "mem_mb" || k == "max_parallel") {
      require(v.is_number_integer(), "sweep file: slurm.{} must be a whole number", k);
      const long long n = v.get<long long>();
      if (k == "cpus_per_task") {
        require(n >= 1 && n <= 256, "sweep file: slurm.cpus_per_task = {} is outside [1, 256]", n);
        s.cpus_per_task = static_cast<int>(n);
      } else if (k == "mem_mb") {
        require(n >= 100 && n <= 1000000, "sweep file: slurm.mem_mb = {} is outside [100, 1000000] MB", n);
        s.mem_mb = static_cast<int>(n);
      } else {
        require(n >= 0 && n <= 100000, "sweep file: slurm.max_parallel = {} is outside [0, 100000] (0: no limit)", n);
        s.max_parallel = static_cast<int>(n);
      }
    } else {
      fail("sweep file: unknown key '{}' in \"slurm\" (known: partition, account, time, cpus_per_task, mem_mb, "
           "max_parallel)",
           k);
    }
  }
  return s;
}

fs::path sweep_detail::case_dir(const fs::path& dir, const std::string& id) { return dir / "cases" / id; }

void sweep_detail::write_marker(const fs::path& dir, const SweepCaseStatus& s) {
  const json j{{"id", s.id}, {"status", s.status}, {"exit_code", s.exit_code}, {"message", s.message},
               {"seconds", s.seconds}};
  write_text_atomically(case_dir(dir, s.id) / "done.json", j.dump(2) + "\n");
}

bool sweep_detail::is_finished(const SweepCaseStatus& s, bool retry_failed) {
  return s.status == "ok" || (!retry_failed && (s.status == "failed" || s.status == "unmet"));
}

const std::vector<std::string>& sweep_axes() {
  static const std::vector<std::string> axes = [] {
    std::vector<std::string> v;
    for (const auto& a : kAxes) v.push_back(a.grid_key);
    return v;
  }();
  return axes;
}

namespace {

/// The base case: inline, or a case file (its relative paths are relative to it); its limb's paths
/// made absolute, or an empty limb (the generated one).
json read_base_case(const json& doc, const fs::path& folder) {
  json base = json::object();
  fs::path base_folder = folder;
  if (doc.contains("base_case")) {
    const json& b = doc["base_case"];
    if (b.is_string()) {
      const fs::path p = folder / b.get<std::string>();
      base = read_json_file(p, "base case file");
      base_folder = fs::absolute(p).parent_path();
    } else {
      require(b.is_object(), "sweep file: \"base_case\" must be a case (an object, docs/case_file.md) or the path of a "
                             "case file");
      base = b;
    }
  }
  require(base.is_object(), "sweep file: the base case must be a JSON object (docs/case_file.md)");
  if (base.contains("limb")) absolute_limb_paths(base["limb"], base_folder);
  else base["limb"] = json::object();
  return base;
}

void add_case(SweepSpec& spec, json parameters, json c) {
  SweepCase sc;
  sc.parameters = std::move(parameters);
  sc.case_doc = std::move(c);
  spec.cases.push_back(std::move(sc));
}

/// The grid @p g's cases: the product of its axes, outermost first in sweep_axes() order.
void add_grid_cases(const json& g, const json& base, const fs::path& folder, SweepSpec& spec) {
  require(g.is_object(), "sweep file: \"grid\" must be an object of axes ({})", known_axes());
  std::vector<std::pair<std::string, json>> axes;  // column, values
  for (const auto& [k, v] : g.items()) {
    require(!column_of(k).empty(), "sweep file: unknown axis '{}' in \"grid\" (known: {})", k, known_axes());
    require(v.is_array() && !v.empty(), "sweep file: grid.{} must be a non-empty list of values", k);
  }
  for (const auto& a : kAxes)
    for (const auto& [k, v] : g.items())
      if (column_of(k) == a.column) axes.emplace_back(a.column, v);
  require(!axes.empty(), "sweep file: \"grid\" has no axes (known: {})", known_axes());
  std::vector<size_t> index(axes.size(), 0);
  for (bool more = true; more;) {
    json c = base, p = json::object();
    bool duplicate = false;
    for (size_t a = 0; a < axes.size(); ++a) {
      const json& v = axes[a].second[index[a]];
      // A seed changes only a generated limb: a scanned limb runs once, with the first seed.
      if (axes[a].first == "seed" && c["limb"].contains("file")) {
        if (index[a] > 0) duplicate = true;
        continue;
      }
      apply_axis(c, axes[a].first, v, folder);
      p[axes[a].first] = v;
    }
    if (!duplicate) add_case(spec, p, c);
    // Next combination: the innermost axis turns fastest.
    more = false;
    for (size_t a = axes.size(); a-- > 0;) {
      if (++index[a] < axes[a].second.size()) {
        more = true;
        break;
      }
      index[a] = 0;
    }
  }
}

/// The list @p l's cases: each entry sets some axes of the base case.
void add_listed_cases(const json& l, const json& base, const fs::path& folder, SweepSpec& spec) {
  require(l.is_array(), "sweep file: \"cases\" must be a list of objects ({{\"body_mass_kg\": 70, \"seed\": 2}})");
  for (size_t k = 0; k < l.size(); ++k) {
    require(l[k].is_object(), "sweep file: cases[{}] must be an object of axis values ({})", k, known_axes());
    json c = base, p = json::object();
    for (const auto& a : kAxes)
      for (const auto& [key, v] : l[k].items())
        if (column_of(key) == a.column) {
          apply_axis(c, a.column, v, folder);
          p[a.column] = v;
        }
    for (const auto& [key, v] : l[k].items())
      require(!column_of(key).empty(), "sweep file: unknown axis '{}' in cases[{}] (known: {})", key, k, known_axes());
    add_case(spec, p, c);
  }
}

}  // namespace

SweepSpec parse_sweep(const json& doc, const fs::path& folder) {
  require(doc.is_object(), "sweep file: expected a JSON object with \"base_case\" and \"grid\" or \"cases\" "
                           "(docs/sweep.md)");
  for (const auto& [k, v] : doc.items())
    require(k == "socketsmith_sweep" || k == "name" || k == "base_case" || k == "grid" || k == "cases" || k == "slurm",
            "sweep file: unknown key '{}' (known: socketsmith_sweep, name, base_case, grid, cases, slurm)", k);
  SweepSpec spec;
  if (doc.contains("name")) {
    require(doc["name"].is_string(), "sweep file: \"name\" must be a string");
    spec.name = doc["name"].get<std::string>();
  }
  const json base = read_base_case(doc, folder);
  if (doc.contains("grid")) add_grid_cases(doc["grid"], base, folder, spec);
  if (doc.contains("cases")) add_listed_cases(doc["cases"], base, folder, spec);
  require(!spec.cases.empty(), "sweep file: no cases: give a \"grid\" of axes or a list of \"cases\" (docs/sweep.md)");
  for (size_t k = 0; k < spec.cases.size(); ++k) spec.cases[k].id = case_id(k, spec.cases.size());
  if (doc.contains("slurm")) spec.slurm = parse_slurm(doc["slurm"]);
  return spec;
}

SweepSpec read_sweep(const fs::path& path) {
  SweepSpec s = parse_sweep(read_json_file(path, "sweep file"), fs::absolute(path).parent_path());
  if (s.name.empty()) s.name = path.stem().string();
  return s;
}

void write_sweep(const SweepSpec& spec, const fs::path& dir) {
  json cases = json::array();
  for (const auto& c : spec.cases)
    cases.push_back({{"id", c.id}, {"parameters", c.parameters}, {"case", c.case_doc}});
  const json manifest{{"socketsmith_sweep_manifest", 1},
                      {"name", spec.name},
                      {"cases", cases},
                      {"slurm", slurm_json(spec.slurm)}};
  const fs::path mpath = dir / kManifest;
  if (fs::exists(mpath)) {
    const json old = read_json_file(mpath, "sweep manifest");
    require(old.contains("cases") && old["cases"] == cases,
            "sweep: '{}' holds another sweep ('{}', {} cases): give another --out or delete that folder", dir.string(),
            old.value("name", std::string()), old.contains("cases") ? old["cases"].size() : 0);
    if (old == manifest) return;  // a rerun: every case file is there, nothing to rewrite
  }
  ensure_directory(dir);
  for (const auto& c : spec.cases) {
    ensure_directory(case_dir(dir, c.id));
    const fs::path p = case_dir(dir, c.id) / "case.json";
    if (!fs::exists(p)) write_text_atomically(p, c.case_doc.dump(2) + "\n");
  }
  // The manifest last: a folder with a manifest has every case file.
  write_text_atomically(mpath, manifest.dump(2) + "\n");
}

json read_manifest(const fs::path& dir) {
  const fs::path p = dir / kManifest;
  require(fs::exists(p), "sweep: '{}' holds no sweep (no {}): run `socketsmith sweep SWEEP.json --out {}` first",
          dir.string(), kManifest, dir.string());
  json m = read_json_file(p, "sweep manifest");
  require(m.contains("cases") && m["cases"].is_array(), "sweep: '{}' is not a sweep manifest (no \"cases\"): "
                                                        "run `socketsmith sweep SWEEP.json --out DIR` again", p.string());
  return m;
}

SweepCaseStatus read_case_status(const fs::path& dir, const std::string& id) {
  SweepCaseStatus s;
  s.id = id;
  const fs::path p = case_dir(dir, id) / "done.json";
  if (!fs::exists(p)) return s;
  try {
    const json j = read_json_file(p, "done marker");
    s.status = j.at("status").get<std::string>();
    s.exit_code = j.at("exit_code").get<int>();
    s.message = j.at("message").get<std::string>();
    s.seconds = j.at("seconds").get<double>();
  } catch (const std::exception& e) {
    s.status = "missing";
    s.message = fmt::format("unreadable done marker {}: {}", p.string(), one_line(e.what()));
  }
  return s;
}

SweepCaseStatus run_sweep_case(const fs::path& dir, const std::string& id_or_index) {
  const json m = read_manifest(dir);
  const json& cases = m["cases"];
  std::string id;
  const bool is_index = !id_or_index.empty() && id_or_index.find_first_not_of("0123456789") == std::string::npos;
  if (is_index) {
    const unsigned long k = std::strtoul(id_or_index.c_str(), nullptr, 10);
    require(k < cases.size(), "sweep case: index {} is outside [0, {}] (the sweep in '{}' has {} cases)", id_or_index,
            cases.size() - 1, dir.string(), cases.size());
    id = cases[k]["id"].get<std::string>();
  } else {
    for (const auto& c : cases)
      if (c["id"] == id_or_index) id = id_or_index;
    require(!id.empty(), "sweep case: no case '{}' in '{}' (ids c0000 to {}, or an index)", id_or_index, dir.string(),
            cases.empty() ? std::string("none") : cases.back()["id"].get<std::string>());
  }
  const auto t0 = std::chrono::steady_clock::now();
  const fs::path cdir = case_dir(dir, id);
  const fs::path out = cdir / "out";
  std::error_code ec;
  fs::remove(cdir / "done.json", ec);
  fs::remove(out / "design.json", ec);  // a failed rerun must not leave an earlier run's numbers
  SweepCaseStatus s;
  s.id = id;
  try {
    const design::CaseFile c = design::read_case(cdir / "case.json");
    const json j = run_design(c, out, c.optimise);
    if (j["constraints_met"].get<bool>()) {
      s.status = "ok";
      s.exit_code = kExitSuccess;
    } else {
      const std::string why = j["optimiser_message"].get<std::string>();
      s.status = "unmet";
      s.exit_code = kExitBadInput;  // what `socketsmith design` exits with
      s.message = one_line(fmt::format("design: the constraints are not all met ({}): {}", j["failing"].get<std::string>(),
                                       why.empty() ? j["solver_message"].get<std::string>() : why));
    }
  } catch (...) {
    const ExitStatus st = exit_status(std::current_exception());
    s.status = "failed";
    s.exit_code = st.code;
    s.message = st.message;
  }
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  write_marker(dir, s);
  return s;
}

}  // namespace socketsmith::pipeline
