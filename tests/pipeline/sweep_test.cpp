// The expansion of sweep files (pipeline/sweep.h): grid sizes and order, list entries, seeds of
// scanned limbs, relative paths, and one-line errors for bad sweep files. Running cases is tested
// end to end through the command line (tests/cli/sweep_test.py).
#include "socketsmith/pipeline/sweep.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <gtest/gtest.h>

#include "socketsmith/core/errors.h"

namespace socketsmith::pipeline {
namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;

std::string error_of(const json& doc) {
  try {
    parse_sweep(doc, "/data");
  } catch (const InvalidInputError& e) {
    return e.what();
  }
  return "";
}

TEST(Sweep, grid_of_the_issue_expands_to_200_distinct_cases_innermost_axis_fastest) {
  // 5 generated limbs × 2 masses × 2 E × 2 templates × 5 seeds (issue 25).
  const json doc = {{"base_case", {{"mesh", {{"target_nodes", 3000}}}}},
                    {"grid",
                     {{"limbs", json::array({{{"type", "transtibial"}, {"side", "right"}},
                                             {{"type", "transtibial"}, {"side", "left"}},
                                             {{"type", "transtibial"}, {"cut_height_mm", 130}},
                                             {{"type", "transtibial"}, {"cut_height_mm", 150}},
                                             {{"type", "transtibial"}, {"cut_height_mm", 170}}})},
                      {"body_mass_kg", {60, 90}},
                      {"youngs_kpa", {60, 120}},
                      {"brim", {"ptb", "kbm"}},
                      {"seeds", {1, 2, 3, 4, 5}}}}};
  const SweepSpec s = parse_sweep(doc, "/data");
  ASSERT_EQ(s.cases.size(), 200u);
  std::set<std::string> ids, docs;
  for (const auto& c : s.cases) {
    ids.insert(c.id);
    docs.insert(c.case_doc.dump());
    EXPECT_EQ(c.case_doc["mesh"]["target_nodes"], 3000);  // the base case is kept
  }
  EXPECT_EQ(ids.size(), 200u);
  EXPECT_EQ(docs.size(), 200u);
  EXPECT_EQ(s.cases.front().id, "c0000");
  EXPECT_EQ(s.cases.back().id, "c0199");
  // The seed turns fastest, then the brim, ... the limb slowest.
  EXPECT_EQ(s.cases[0].case_doc["limb"]["generate_seed"], 1);
  EXPECT_EQ(s.cases[1].case_doc["limb"]["generate_seed"], 2);
  EXPECT_EQ(s.cases[5].case_doc["brim"]["template"], "kbm");
  EXPECT_EQ(s.cases[40].case_doc["limb"]["side"], "left");
  EXPECT_EQ(s.cases[10].case_doc["tissue"]["youngs_kpa"], 120);
  EXPECT_EQ(s.cases[20].case_doc["patient"]["body_mass_kg"], 90);
  EXPECT_EQ(s.cases[199].parameters,
            json({{"limb", {{"type", "transtibial"}, {"cut_height_mm", 170}}}, {"body_mass_kg", 90},
                  {"youngs_kpa", 120}, {"brim", "kbm"}, {"seed", 5}}));
}

TEST(Sweep, a_scanned_limb_runs_once_whatever_the_seeds_and_its_path_becomes_absolute) {
  const json doc = {{"grid",
                     {{"limbs", json::array({{{"file", "scans/a.stl"}, {"units", "mm"}}, {{"type", "transtibial"}}})},
                      {"seeds", {1, 2, 3}}}}};
  const SweepSpec s = parse_sweep(doc, "/data/sweeps");
  ASSERT_EQ(s.cases.size(), 4u);  // 1 scan + 3 generated
  EXPECT_EQ(s.cases[0].case_doc["limb"]["file"], "/data/sweeps/scans/a.stl");
  EXPECT_FALSE(s.cases[0].case_doc["limb"].contains("generate_seed"));
  EXPECT_FALSE(s.cases[0].parameters.contains("seed"));
  EXPECT_EQ(s.cases[3].case_doc["limb"]["generate_seed"], 3);
}

TEST(Sweep, grid_and_list_together_and_slurm_resources) {
  const json doc = {{"name", "small"},
                    {"grid", {{"friction", {0.3, 0.6}}}},
                    {"cases", json::array({{{"body_mass_kg", 500}}, {{"brim", "tsb"}, {"seed", 4}}})},
                    {"slurm", {{"partition", "short"}, {"time", "00:10:00"}, {"cpus_per_task", 2}, {"mem_mb", 1500}}}};
  const SweepSpec s = parse_sweep(doc, "/data");
  ASSERT_EQ(s.cases.size(), 4u);
  EXPECT_EQ(s.cases[1].case_doc["patient"]["friction"], 0.6);
  // A value out of range is kept: the case fails when it runs, as a row of the results.
  EXPECT_EQ(s.cases[2].case_doc["patient"]["body_mass_kg"], 500);
  EXPECT_EQ(s.cases[3].case_doc["brim"]["template"], "tsb");
  EXPECT_EQ(s.cases[3].case_doc["limb"]["generate_seed"], 4);
  EXPECT_EQ(s.slurm.partition, "short");
  EXPECT_EQ(s.slurm.cpus_per_task, 2);
  EXPECT_EQ(s.slurm.mem_mb, 1500);
  EXPECT_EQ(s.name, "small");
}

TEST(Sweep, bad_sweep_files_get_one_line_naming_the_key_and_the_fix) {
  EXPECT_NE(error_of({{"grid", {{"mass", {70}}}}}).find("unknown axis 'mass' in \"grid\" (known: limbs, body_mass_kg"),
            std::string::npos);
  EXPECT_NE(error_of({{"grid", {{"friction", json::array()}}}}).find("grid.friction must be a non-empty list"),
            std::string::npos);
  EXPECT_NE(error_of({{"base_case", json::object()}}).find("no cases: give a \"grid\" of axes or a list of \"cases\""),
            std::string::npos);
  EXPECT_NE(error_of({{"grids", {}}}).find("unknown key 'grids'"), std::string::npos);
  EXPECT_NE(error_of({{"grid", {{"friction", {0.5}}}}, {"slurm", {{"cpus_per_task", 0}}}})
                .find("slurm.cpus_per_task = 0 is outside [1, 256]"),
            std::string::npos);
  EXPECT_NE(error_of({{"grid", {{"friction", {0.5}}}}, {"slurm", {{"partition", "a b"}}}}).find("slurm.partition"),
            std::string::npos);
  EXPECT_NE(error_of({{"grid", {{"limbs", json::array({"a.stl"})}}}}).find("each limb must be an object"), std::string::npos);
}

TEST(Sweep, a_folder_holding_another_sweep_is_refused_and_the_same_sweep_is_kept) {
  const fs::path dir = fs::temp_directory_path() / "socketsmith_sweep_test_folder";
  fs::remove_all(dir);
  const SweepSpec a = parse_sweep({{"grid", {{"friction", {0.3, 0.6}}}}}, "/data");
  write_sweep(a, dir);
  EXPECT_EQ(read_manifest(dir)["cases"].size(), 2u);
  EXPECT_NO_THROW(write_sweep(a, dir));
  const SweepSpec b = parse_sweep({{"grid", {{"friction", {0.3, 0.7}}}}}, "/data");
  try {
    write_sweep(b, dir);
    ADD_FAILURE() << "a different sweep was written over the first";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("holds another sweep"), std::string::npos) << e.what();
  }
  EXPECT_EQ(read_case_status(dir, "c0000").status, "missing");
  fs::remove_all(dir);
  EXPECT_THROW(read_manifest(dir), InvalidInputError);
}

TEST(Sweep, a_case_process_that_crashes_or_exits_without_a_marker_is_a_failed_case_and_the_others_run) {
  // A stand-in for the socketsmith program (`EXE sweep case DIR ID`): c0000 prints the CLI's error
  // line and exits 3, c0001 is killed by SIGKILL, c0002 writes its own marker like the real one.
  const fs::path dir = fs::temp_directory_path() / "socketsmith_sweep_test_crash";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path exe = dir / "fake_socketsmith.sh";
  {
    std::ofstream f(exe);
    f << "#!/bin/sh\n"
         "case \"$4\" in\n"
         "  c0000) echo 'error: the solver diverged (try a smaller load)' >&2; exit 3 ;;\n"
         "  c0001) kill -KILL $$ ;;\n"
         "  *) mkdir -p \"$3/cases/$4/out\"; printf '{\"closed_loop\": {\"donnings\": 2, \"retried_donnings\": 1, \"drag_band\": {\"kept\": true}, \"converged\": false, \"wall_roughness_rms_mm\": 0.117, "
         "\"wall_roughness_share\": 0.37, \"bar\": {\"met\": false, "
         "\"failing\": [\"back line: 99th percentile 4.62 kPa > 4\", \"AD +12 %%\"]}}}' > \"$3/cases/$4/out/design.json\"; "
         "printf '{\"id\": \"%s\", \"status\": \"ok\", \"exit_code\": 0, \"message\": \"\", \"seconds\": 1}' \"$4\" "
         "> \"$3/cases/$4/done.json\" ;;\n"
         "esac\n";
  }
  fs::permissions(exe, fs::perms::owner_all);
  write_sweep(parse_sweep({{"grid", {{"friction", {0.3, 0.5, 0.7}}}}}, "/data"), dir / "sweep");
  SweepRunOptions o;
  o.workers = 2;
  o.executable = exe.string();
  const SweepRunResult r = run_sweep_local(dir / "sweep", o);
  EXPECT_EQ(r.ran, 3);
  EXPECT_EQ(r.ok, 1);
  EXPECT_EQ(r.failed, 2);
  const auto a = read_case_status(dir / "sweep", "c0000");
  EXPECT_EQ(a.status, "failed");
  EXPECT_EQ(a.exit_code, 3);
  EXPECT_NE(a.message.find("exited with code 3 without a result (error: the solver diverged"), std::string::npos)
      << a.message;
  const auto b = read_case_status(dir / "sweep", "c0001");
  EXPECT_EQ(b.status, "failed");
  EXPECT_NE(b.message.find("killed by signal 9"), std::string::npos) << b.message;
  EXPECT_NE(b.message.find("log.txt"), std::string::npos) << b.message;
  // A second local run of the same folder while one holds it is refused.
  {
    const int fd = ::open((dir / "sweep" / "run.lock").c_str(), O_RDWR);
    ASSERT_GE(fd, 0);
    ASSERT_EQ(::flock(fd, LOCK_EX | LOCK_NB), 0);
    try {
      run_sweep_local(dir / "sweep", o);
      ADD_FAILURE() << "two local runs of one sweep at once";
    } catch (const InvalidInputError& e) {
      EXPECT_NE(std::string(e.what()).find("another `socketsmith sweep` is running the cases of"), std::string::npos)
          << e.what();
    }
    ::close(fd);
  }
  // A rerun skips all three; --retry-failed runs the two failed ones again.
  EXPECT_EQ(run_sweep_local(dir / "sweep", o).ran, 0);
  o.retry_failed = true;
  const SweepRunResult again = run_sweep_local(dir / "sweep", o);
  EXPECT_EQ(again.skipped, 1);
  EXPECT_EQ(again.ran, 2);
  // collect: a row per case, the failures with their messages.
  const SweepCollectResult c = collect_sweep(dir / "sweep");
  EXPECT_EQ(c.rows, 3);
  EXPECT_EQ(c.failed, 2);
  EXPECT_EQ(c.ok, 1);
  EXPECT_EQ(c.delivery_judged, 1);  // the ok case's closed loop, judged and missed
  EXPECT_EQ(c.delivery_met, 0);
  std::ifstream csv(c.csv);
  std::stringstream text;
  text << csv.rdbuf();
  EXPECT_NE(text.str().find("killed by signal 9"), std::string::npos);
  // The ok case's closed loop: short of its tolerances, its wall's roughness, its delivery bar
  // missed, and what it missed, in one cell.
  EXPECT_NE(text.str().find(",2,1,1,0,,,,,,0.117,0.37,0,back line: 99th percentile 4.62 kPa > 4; AD +12 %,"),
            std::string::npos)
      << text.str();
  fs::remove_all(dir);
}

}  // namespace
}  // namespace socketsmith::pipeline
