// CalculiX for real: the cube against the analytic solution (a coarse lattice, a few seconds),
// and the runner's answers when ccx is missing or rejects a deck.
#include <filesystem>

#include <gtest/gtest.h>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/calculix/ccx_runner.h"
#include "socketsmith/calculix/cube_validation.h"

namespace socketsmith::calculix {
namespace {

namespace fs = std::filesystem;

fs::path work_dir(const std::string& name) {
  const fs::path d = fs::path(SOCKETSMITH_BINARY_DIR) / "fe_test_runs" / name;
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

bool have_ccx() {
  try {
    find_ccx();
    return true;
  } catch (const InvalidInputError&) {
    return false;
  }
}

TEST(CcxRunner, missing_ccx_names_the_package) {
  try {
    find_ccx("ccx_that_does_not_exist");
    FAIL();
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("calculix-ccx"), std::string::npos) << e.what();
  }
  EXPECT_THROW(find_ccx("/nonexistent/ccx"), InvalidInputError);
}

// ccx runs in the job's folder: a relative --ccx path (typed against the user's folder) used to
// fail there as "could not be executed" (exit 127). A stand-in ccx (a shell script that answers as
// ccx does) found by a relative path must run and finish.
TEST(CcxRunner, a_relative_executable_path_runs_from_the_job_folder) {
  const auto base = work_dir("relative_exe");
  fs::create_directories(base / "bin");
  fs::create_directories(base / "job");
  write_text_atomically(base / "bin" / "fake_ccx", "#!/bin/sh\necho ' STEP 1'\necho 'Job finished'\n");
  fs::permissions(base / "bin" / "fake_ccx", fs::perms::owner_all);
  write_text_atomically(base / "job" / "j.inp", "*HEADING\n");
  const fs::path cwd = fs::current_path();
  fs::current_path(base);
  CcxOptions o;
  o.executable = "bin/fake_ccx";
  CcxRun run;
  std::string found;
  try {
    found = find_ccx(o.executable);
    run = run_ccx(base / "job", "j", o);
  } catch (...) {
    fs::current_path(cwd);
    throw;
  }
  fs::current_path(cwd);
  EXPECT_EQ(fs::path(found), (base / "bin" / "fake_ccx").lexically_normal());
  EXPECT_TRUE(run.converged) << run.message;
  EXPECT_EQ(run.exit_code, 0) << run.message;
}

TEST(CcxRunner, a_rejected_deck_is_reported_with_the_log_error_line) {
  if (!have_ccx()) GTEST_SKIP() << "ccx not installed (calculix-ccx)";
  const auto dir = work_dir("rejected");
  write_text_atomically(dir / "bad.inp", "*NODE\n1, 0, 0, 0\n*ELEMENT, TYPE=C3D8, ELSET=E\n1, 1, 2, 3\n*STEP\n*STATIC\n*END STEP\n");
  const auto run = run_ccx(dir, "bad");
  EXPECT_FALSE(run.converged);
  EXPECT_NE(run.message.find("ccx"), std::string::npos);
  EXPECT_FALSE(run.error_line.empty()) << run.message;
  EXPECT_TRUE(fs::exists(run.log));
}

TEST(CcxRunner, time_limit_kills_ccx) {
  if (!have_ccx()) GTEST_SKIP() << "ccx not installed (calculix-ccx)";
  CubeFeOptions o;
  o.divisions = 12;
  o.ccx.time_limit_s = 0.3;
  try {
    run_cube_fe(o, work_dir("timeout"));
    FAIL();
  } catch (const SolverError& e) {
    EXPECT_NE(std::string(e.what()).find("time limit"), std::string::npos) << e.what();
  }
}

TEST(CubeFe, calculix_matches_the_analytic_uniaxial_solution) {
  if (!have_ccx()) GTEST_SKIP() << "ccx not installed (calculix-ccx)";
  CubeFeOptions o;
  o.divisions = 3;
  o.increments = 4;
  const auto r = run_cube_fe(o, work_dir("cube"));
  ASSERT_EQ(r.force_n.size(), 4u);
  EXPECT_NEAR(r.force_n.back(), 8.0, 0.05);  // the plate travel is set for 8 N
  EXPECT_LT(r.max_displacement_rel_error, 0.01);
  EXPECT_LT(r.max_pressure_rel_error, 0.02);  // ccx's contact area vs (1 + ν ε)²: 1.4 %
  EXPECT_GT(r.pressure.r, 0.98);
  EXPECT_TRUE(fs::exists(r.deck));
}

}  // namespace
}  // namespace socketsmith::calculix
