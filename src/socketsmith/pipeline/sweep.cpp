#include "socketsmith/pipeline/sweep.h"

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
#include "socketsmith/report/plot_raster.h"
#include "socketsmith/report/svg_plot.h"

extern char** environ;

namespace socketsmith::pipeline {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

constexpr const char* kManifest = "manifest.json";
constexpr const char* kRunLock = "run.lock";  ///< held (flock) by a local run

// Axis names: the grid's (plural where it reads better) and the list's, and the column each fills.
struct Axis {
  const char* grid_key;
  const char* column;
};
constexpr Axis kAxes[] = {{"limbs", "limb"},       {"body_mass_kg", "body_mass_kg"}, {"youngs_kpa", "youngs_kpa"},
                          {"friction", "friction"}, {"brim", "brim"},                 {"seeds", "seed"},
                          {"target_nodes", "target_nodes"}};

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

json read_json_file(const fs::path& path, const std::string& what) {
  std::ifstream in(path);
  require<IoError>(in.good(), "cannot open {} '{}' (check the path)", what, path.string());
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_json_input(ss.str(), fmt::format("{} '{}'", what, path.string()));
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

SlurmResources parse_slurm(const json& j) {
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

json slurm_json(const SlurmResources& s) {
  return {{"partition", s.partition}, {"account", s.account},   {"time", s.time},
          {"cpus_per_task", s.cpus_per_task}, {"mem_mb", s.mem_mb}, {"max_parallel", s.max_parallel}};
}

fs::path case_dir(const fs::path& dir, const std::string& id) { return dir / "cases" / id; }

void write_marker(const fs::path& dir, const SweepCaseStatus& s) {
  const json j{{"id", s.id}, {"status", s.status}, {"exit_code", s.exit_code}, {"message", s.message},
               {"seconds", s.seconds}};
  write_text_atomically(case_dir(dir, s.id) / "done.json", j.dump(2) + "\n");
}

bool is_finished(const SweepCaseStatus& s, bool retry_failed) {
  return s.status == "ok" || (!retry_failed && (s.status == "failed" || s.status == "unmet"));
}

}  // namespace

const std::vector<std::string>& sweep_axes() {
  static const std::vector<std::string> axes = [] {
    std::vector<std::string> v;
    for (const auto& a : kAxes) v.push_back(a.grid_key);
    return v;
  }();
  return axes;
}

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
  // The base case: inline, or a case file (its relative paths are relative to it).
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

  const auto add_case = [&](json parameters, json c) {
    SweepCase sc;
    sc.parameters = std::move(parameters);
    sc.case_doc = std::move(c);
    spec.cases.push_back(std::move(sc));
  };
  // The grid: the product of its axes, outermost first in sweep_axes() order.
  if (doc.contains("grid")) {
    const json& g = doc["grid"];
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
      if (!duplicate) add_case(p, c);
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
  // The list: each entry sets some axes of the base case.
  if (doc.contains("cases")) {
    const json& l = doc["cases"];
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
      add_case(p, c);
    }
  }
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

}  // namespace

SweepRunResult run_sweep_local(const fs::path& dir, const SweepRunOptions& o) {
  require(o.workers >= 1 && o.workers <= 256, "sweep: --workers {} is outside [1, 256]", o.workers);
  require(!o.executable.empty(), "run_sweep_local: no executable given (the socketsmith program)");
  const auto t0 = std::chrono::steady_clock::now();
  const json m = read_manifest(dir);
  // One local run per folder: a second would start the same unfinished cases again.
  struct Lock {
    int fd = -1;
    ~Lock() {
      if (fd >= 0) ::close(fd);  // releases the flock
    }
  } lock;
  const fs::path lock_path = dir / kRunLock;
  lock.fd = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  require<IoError>(lock.fd >= 0, "sweep: cannot open '{}': {}", lock_path.string(), std::strerror(errno));
  require(::flock(lock.fd, LOCK_EX | LOCK_NB) == 0,
          "sweep: another `socketsmith sweep` is running the cases of '{}' ({} is locked): wait for it to end or stop it",
          dir.string(), lock_path.string());
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
      SweepCaseStatus s = read_case_status(dir, id);
      if (s.status == "missing") {
        // The process ended without its marker: a crash, a signal, a program that could not start.
        s.status = "failed";
        const std::string how = w < 0                ? "could not be waited for"
                                : WIFSIGNALED(status) ? fmt::format("was killed by signal {} ({})", WTERMSIG(status),
                                                                    strsignal(WTERMSIG(status)))
                                                      : fmt::format("exited with code {}", WEXITSTATUS(status));
        const std::string err = last_error_line(case_dir(dir, id) / "log.txt");
        s.exit_code = WIFEXITED(status) && WEXITSTATUS(status) != 0 ? WEXITSTATUS(status) : kExitInternal;
        s.message = fmt::format("the case's process {} without a result{}; see {}", how,
                                err.empty() ? std::string() : " (" + err + ")",
                                (case_dir(dir, id) / "log.txt").string());
        write_marker(dir, s);
      }
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
    array += (array.empty() ? "" : ",") + (a == b ? fmt::format("{}", todo[a]) : fmt::format("{}-{}", todo[a], todo[b]));
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

namespace {

std::string csv_cell(const std::string& t) {
  if (t.find_first_of(",\"\n\r") == std::string::npos && (t.empty() || (t.front() != ' ' && t.back() != ' '))) return t;
  std::string q = "\"";
  for (char c : t) q += c == '"' ? std::string("\"\"") : std::string(1, c == '\n' || c == '\r' ? ' ' : c);
  return q + "\"";
}

std::string number_cell(const json& v) {
  if (v.is_number()) {
    const double d = v.get<double>();
    return std::isfinite(d) ? fmt::format("{:.10g}", d) : std::string();
  }
  if (v.is_boolean()) return v.get<bool>() ? "1" : "0";
  return {};
}

/// A parameter's value as a cell: numbers and strings as they are, a limb as its file name or
/// "generated <type>".
std::string parameter_cell(const std::string& column, const json& v) {
  if (column == "limb" && v.is_object()) {
    if (v.contains("file") && v["file"].is_string()) return fs::path(v["file"].get<std::string>()).filename().string();
    // A generated limb: its type and whatever else the sweep set ("generated transtibial side=left").
    std::string label = "generated " + (v.contains("type") && v["type"].is_string() ? v["type"].get<std::string>()
                                                                                      : std::string("transtibial"));
    for (const auto& [k, x] : v.items())
      if (k != "type") label += " " + k + "=" + (x.is_string() ? x.get<std::string>() : x.dump());
    return label;
  }
  if (v.is_string()) return v.get<std::string>();
  if (v.is_number() || v.is_boolean()) return number_cell(v);
  return v.dump();
}

const json& at_path(const json& j, const std::vector<std::string>& keys) {
  static const json null;
  const json* p = &j;
  for (const auto& k : keys) {
    if (!p->is_object() || !p->contains(k)) return null;
    p = &(*p)[k];
  }
  return *p;
}

}  // namespace

SweepCollectResult collect_sweep(const fs::path& dir) {
  const json m = read_manifest(dir);
  // Parameter columns: the swept ones, in axis order.
  std::vector<std::string> params;
  for (const auto& a : kAxes)
    for (const auto& c : m["cases"])
      if (c["parameters"].contains(a.column)) {
        params.emplace_back(a.column);
        break;
      }
  // Result columns: name and where in design.json.
  struct Col {
    const char* name;
    std::vector<std::string> path;  ///< keys into design.json
  };
  const std::vector<Col> cols = {
      {"nodes", {"nodes"}},
      {"fx_n", {"radar", "fx_n"}},
      {"fy_n", {"radar", "fy_n"}},
      {"fz_n", {"radar", "fz_n"}},
      {"tx_nm", {"radar", "tx_nm"}},
      {"ty_nm", {"radar", "ty_nm"}},
      {"tz_nm", {"radar", "tz_nm"}},
      {"stability_n", {"radar", "stability_n"}},
      {"target_fz_n", {"targets", "fz_n"}},
      {"stability_min_n", {"targets", "stability_min_n"}},
      {"constraints_met", {"constraints_met"}},
      {"max_pressure_ratio", {"max_pressure_ratio"}},
      {"max_pressure_kpa", {"max_pressure_kpa"}},
      {"max_displacement_mm", {"max_displacement_mm"}},
      {"cavity_volume_cm3", {"socket", "cavity_volume_cm3"}},
      {"limb_volume_below_brim_cm3", {"socket", "limb_volume_below_brim_cm3"}},
      {"volume_reduction_percent", {"socket", "volume_reduction_percent"}},
      {"min_thickness_mm", {"socket", "min_thickness_mm"}},
      {"design_seconds", {"seconds"}},
      {"optimiser_seconds", {"optimiser_seconds"}},
  };
  std::string text = "id,status,exit_code,message";
  for (const auto& p : params) text += "," + p;
  text += ",failing";
  for (const auto& c : cols) text += std::string(",") + c.name;
  text += ",case_seconds\n";

  SweepCollectResult r;
  std::vector<double> x_ok, ratio_ok, x_unmet, ratio_unmet, x_failed, zero_failed, x_vol, vol, x_t, t;
  for (size_t k = 0; k < m["cases"].size(); ++k) {
    const json& c = m["cases"][k];
    const std::string id = c["id"].get<std::string>();
    const SweepCaseStatus s = read_case_status(dir, id);
    json d;  // design.json: the numbers of an ok or unmet case
    if (s.status == "ok" || s.status == "unmet") {
      const fs::path p = case_dir(dir, id) / "out" / "design.json";
      try {
        if (fs::exists(p)) d = read_json_file(p, "design summary");
      } catch (const Error&) {
        d = json();
      }
    }
    std::string row = csv_cell(id) + "," + s.status + "," + (s.status == "missing" ? "" : std::to_string(s.exit_code)) +
                      "," + csv_cell(s.status == "missing" && s.message.empty()
                                         ? "not run yet (or still running): run the sweep again to finish it"
                                         : s.message);
    for (const auto& p : params)
      row += "," + csv_cell(c["parameters"].contains(p) ? parameter_cell(p, c["parameters"][p]) : std::string());
    row += "," + csv_cell(d.is_object() ? d.value("failing", std::string()) : std::string());
    for (const auto& col : cols) row += "," + number_cell(at_path(d, col.path));
    row += "," + (s.status == "missing" ? std::string() : fmt::format("{:.3f}", s.seconds));
    text += row + "\n";
    ++r.rows;
    const double x = static_cast<double>(k);
    const json& ratio = at_path(d, {"max_pressure_ratio"});
    if (s.status == "ok") {
      ++r.ok;
      if (ratio.is_number()) x_ok.push_back(x), ratio_ok.push_back(ratio.get<double>());
      if (const json& v = at_path(d, {"socket", "cavity_volume_cm3"}); v.is_number()) x_vol.push_back(x), vol.push_back(v.get<double>());
    } else if (s.status == "unmet") {
      ++r.unmet;
      if (ratio.is_number()) x_unmet.push_back(x), ratio_unmet.push_back(ratio.get<double>());
    } else {
      s.status == "missing" ? ++r.missing : ++r.failed;
      x_failed.push_back(x), zero_failed.push_back(0.0);
    }
    if (s.status != "missing") x_t.push_back(x), t.push_back(s.seconds);
  }
  r.csv = dir / "results.csv";
  write_text_atomically(r.csv, text);

  // Summary figure: peak pressure ratio, cavity volume and time per case.
  const double n = static_cast<double>(std::max<size_t>(1, m["cases"].size()));
  const auto panel = [&](const std::string& title, const std::string& y_label) {
    report::Plot p;
    p.title = title;
    p.x_label = "case";
    p.y_label = y_label;
    p.x_min = -0.5;
    p.x_max = n - 0.5;
    p.width_px = 900;
    p.height_px = 300;
    return p;
  };
  const auto scatter = [](const std::string& name, std::vector<double> x, std::vector<double> y, const char* color) {
    report::PlotSeries s;
    s.name = name;
    s.x = std::move(x);
    s.y = std::move(y);
    s.color = color;
    s.markers = true;
    s.line_width = 0;
    return s;
  };
  std::vector<report::Plot> panels;
  {
    auto p = panel(fmt::format("{}: {} ok, {} constraints not met, {} failed, {} not run", m.value("name", std::string()),
                               r.ok, r.unmet, r.failed, r.missing),
                   "peak pressure / threshold");
    p.series.push_back(scatter("ok", x_ok, ratio_ok, "#0072B2"));
    p.series.push_back(scatter("constraints not met", x_unmet, ratio_unmet, "#E69F00"));
    p.series.push_back(scatter("failed or not run (at 0)", x_failed, zero_failed, "#D55E00"));
    p.y_min = 0.0;
    if (ratio_ok.empty() && ratio_unmet.empty()) p.y_max = 1.0;
    panels.push_back(p);
  }
  {
    auto p = panel("socket cavity", "volume [cm^3]");
    p.series.push_back(scatter("ok", x_vol, vol, "#0072B2"));
    if (vol.empty()) p.y_min = 0.0, p.y_max = 1.0;
    p.legend = report::LegendPosition::None;
    panels.push_back(p);
  }
  {
    auto p = panel("time per case", "wall time [s]");
    p.series.push_back(scatter("", x_t, t, "#009E73"));
    p.y_min = 0.0;
    if (t.empty()) p.y_max = 1.0;
    p.legend = report::LegendPosition::None;
    panels.push_back(p);
  }
  r.svg = dir / "summary.svg";
  r.png = dir / "summary.png";
  report::write_svg_grid(r.svg, panels, 1);
  report::write_plot_grid_png(r.png, panels, 1);
  return r;
}

}  // namespace socketsmith::pipeline
