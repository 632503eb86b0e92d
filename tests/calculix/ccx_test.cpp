// CalculiX for real: the cube against the analytic solution (a coarse lattice, a few seconds),
// and the runner's answers when ccx is missing or rejects a deck.
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/calculix/ccx_runner.h"
#include "socketsmith/calculix/cube_validation.h"
#include "socketsmith/calculix/design_check.h"
#include "socketsmith/calculix/socket_shell.h"
#include "socketsmith/volume/hex_element.h"
#include "socketsmith/volume/box_mesher.h"

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

/// A 20 × 20 × 40 mm box of 2 × 2 × 4 hexahedra as a designed stump: fixed at z = 0, its skin
/// undeformed and unloaded, all of it below the brim.
struct BoxStump {
  volume::HexMesh mesh;
  volume::SkinSurface skin;
  DesignedStump d;
  BoxStump() {
    volume::BoxMeshOptions bo;
    bo.size = Vec3(0.02, 0.02, 0.04);
    bo.divisions = {2, 2, 4};
    mesh = volume::mesh_box(bo);
    skin = volume::extract_skin_surface(mesh);
    d.mesh = &mesh;
    d.skin = &skin;
    for (int k = 0; k < mesh.num_nodes(); ++k)
      if (mesh.nodes[k].z() < 1e-9) d.fixed_nodes.push_back(k);
    d.designed_positions = mesh.nodes;
    d.pressure_pa.assign(skin.nodes.size(), 0.0);
    d.skin_normals = skin.normal;
    d.skin_areas_m2 = skin.area_m2;
    d.above_brim.assign(skin.nodes.size(), 0);
    d.stump_length_m = 0.04;
  }
  /// Mesh node → skin id, and the brim set at z = 35 mm (the top ring and face above it).
  std::vector<int> with_brim_at_35mm() {
    std::vector<int> skin_of(mesh.num_nodes(), -1);
    for (size_t i = 0; i < skin.nodes.size(); ++i) {
      skin_of[skin.nodes[i]] = static_cast<int>(i);
      d.above_brim[i] = mesh.nodes[skin.nodes[i]].z() > 0.035 ? 1 : 0;
    }
    return skin_of;
  }
  /// How far @p q is from the nearest face of the 20 × 20 × 40 mm box (0 on it).
  static double to_face(const Vec3& q) {
    return std::min({q.x(), 0.02 - q.x(), q.y(), 0.02 - q.y(), q.z(), 0.04 - q.z()});
  }
  BoxStump(const BoxStump&) = delete;  // d points into this object
  BoxStump& operator=(const BoxStump&) = delete;
};

/// A stand-in ccx in @p dir: a shell script of @p body (run as `ccx -i JOB`: the job is $2).
fs::path stand_in_ccx(const fs::path& dir, const std::string& body) {
  const fs::path exe = dir / "fake_ccx";
  write_text_atomically(exe, "#!/bin/sh\n" + body);
  fs::permissions(exe, fs::perms::owner_all);
  return exe;
}

/// A stand-in ccx that answers as ccx does when it stops inside step 1 after one increment (exit
/// 255, as its factorisation did on OpenLimb's transtibial donning), recording the *STATIC line of
/// every deck it is given.
fs::path ccx_stopping_in_step_one(const fs::path& dir) {
  return stand_in_ccx(dir, "grep -A1 '^\\*STATIC' \"$2.inp\" | sed -n 2p >> statics.txt\n"
                           "echo ' STEP 1'\necho ' increment 1 attempt 1'\necho ' actual step time=0.05'\n"
                           "echo ' convergence'\necho ' increment 2 attempt 1'\nexit 255\n");
}

// A donning that ccx gives up on its way is run once more with increments half as long, once;
// the stopped run's log is kept.
TEST(DesignCheck, a_first_step_stopped_on_its_way_runs_again_with_shorter_increments) {
  const auto dir = work_dir("step1_retry");
  BoxStump box;
  DesignedStump& d = box.d;
  DesignCheckOptions o;
  o.mode = DesignCheckMode::Donning;
  o.stand_force_n = 343.2;
  o.stand_travel_m = 0.002;
  o.ccx.executable = ccx_stopping_in_step_one(dir).string();
  EXPECT_THROW(check_design(d, o, dir, "box"), SolverError);  // no increment written at all
  std::ifstream in(dir / "statics.txt");
  std::string first, second, third;
  std::getline(in, first);
  std::getline(in, second);
  EXPECT_EQ(first, "0.05, 1., 1e-05, 0.1");
  EXPECT_EQ(second, "0.025, 1., 1e-05, 0.025");
  EXPECT_FALSE(std::getline(in, third)) << "a third run: " << third;
  // the stopped run's log kept beside the retry's, not overwritten by it
  EXPECT_TRUE(fs::exists(dir / "box.stopped.log"));
  EXPECT_TRUE(fs::exists(dir / "box.log"));
}

/// A stand-in ccx that finishes both steps of every deck it is given with the reference node's
/// reactions of validate donning --stand on the MSS-CS demo at 1.8k (2026-12-01): 229 N donned and
/// only 42 N more at the end of the push, whatever the push; each run's push recorded.
fs::path ccx_standing_short(const fs::path& dir) {
  std::string dat;
  for (const auto& [t, f, u] : {std::array<double, 3>{1.0, 228.7, 0.06}, {2.0, 270.8, 0.0628}}) {
    dat += fmt::format(" displacements (vx,vy,vz) for set REF and time  {:.7E}\n\n    900001  0  0  {:.7E}\n\n", t, u);
    dat += fmt::format(" forces (fx,fy,fz) for set REF and time  {:.7E}\n\n    900001  0  0  {:.7E}\n\n", t, f);
  }
  write_text_atomically(dir / "reactions.dat", dat);
  return stand_in_ccx(dir, "grep -c '^\\*STEP' \"$2.inp\" >> runs.txt\ncp reactions.dat \"$2.dat\"\n"
                           "echo ' STEP 1'\necho ' STEP 2'\necho ' Job finished'\n");
}

// A standing push that ends short of the load is run again from CalculiX's own reactions, twice at
// most (the demo's first push went the wrong way and its second, extrapolated from the unloading
// stiffness, fell short: 271 of 343 N).
TEST(DesignCheck, a_standing_push_short_of_the_load_is_run_again_twice_at_most) {
  const auto dir = work_dir("stand_retry");
  BoxStump box;
  DesignCheckOptions o;
  o.mode = DesignCheckMode::Donning;
  o.stand_force_n = 343.2;
  o.stand_travel_m = 0.002;
  o.ccx.executable = ccx_standing_short(dir).string();
  try {
    check_design(box.d, o, dir, "box");  // no .frd: the fields are not there to read
  } catch (const Error&) {
  }
  std::ifstream in(dir / "runs.txt");
  int runs = 0;
  for (std::string line; std::getline(in, line); ++runs) EXPECT_EQ(line, "2");  // donning and standing
  EXPECT_EQ(runs, 3);
}

/// The socket shell's inner nodes of a written donning deck (the first half of NSOCK).
std::vector<Vec3> inner_socket_nodes(const fs::path& deck) {
  std::ifstream in(deck);
  std::string line;
  std::vector<Vec3> nodes;
  bool in_socket = false;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] == '*') {
      in_socket = line.rfind("*NODE, NSET=NSOCK", 0) == 0;
      continue;
    }
    if (!in_socket) continue;
    Vec3 p;
    char comma;
    int id;
    std::istringstream row(line);
    row >> id >> comma >> p.x() >> comma >> p.y() >> comma >> p.z();
    nodes.push_back(p);
  }
  nodes.resize(nodes.size() / 2);
  return nodes;
}

// `validate design --shell-on-wall --shell-subdivision 2`: the donning deck's shell has each skin
// quad split 2 × 2 and every point laid where DesignedStump::wall_surface puts it (here a wall
// 1 mm beside the box in +x, to tell the two apart), then moved distally by the travel. Without
// the flags, the shell is the skin quads through the nodes, as before.
TEST(DesignCheck, the_donning_shell_is_subdivided_and_laid_on_socketsmiths_wall) {
  const auto dir = work_dir("shell_on_wall");
  BoxStump box;
  DesignedStump& d = box.d;
  const Vec3 beside(0.001, 0, 0);
  d.wall_surface = [&](const Vec3& p) { return std::optional<std::pair<Vec3, Vec3>>({p + beside, Vec3::UnitX()}); };
  DesignCheckOptions o;
  o.mode = DesignCheckMode::Donning;
  o.ccx.executable = ccx_stopping_in_step_one(dir).string();
  const Vec3 down(0, 0, -o.donning_travel_m);
  // The box's 40 skin quads: 42 corners; split 2 × 2, + 80 edge and 40 face points.
  EXPECT_THROW(check_design(d, o, dir, "box"), SolverError);
  auto inner = inner_socket_nodes(dir / "box.inp");
  ASSERT_EQ(inner.size(), 42u);
  for (const auto& p : inner) {
    const Vec3 q = p - down;
    EXPECT_NEAR(BoxStump::to_face(q), 0.0, 1e-9);  // on the box: the skin itself
  }
  o.shell_on_wall = true;
  o.shell_subdivision = 2;
  EXPECT_THROW(check_design(d, o, dir, "box"), SolverError);
  inner = inner_socket_nodes(dir / "box.inp");
  ASSERT_EQ(inner.size(), 162u);
  for (const auto& p : inner) {
    const Vec3 q = p - down - beside;
    EXPECT_NEAR(BoxStump::to_face(q), 0.0, 1e-9);
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(std::remainder(q[a], 0.005), 0.0, 1e-9);  // half a quad apart
  }
  // Points below the brim that do not face the wall (here the box's top) keep their place.
  d.wall_surface = [&](const Vec3& p) {
    return p.z() > 0.04 - 1e-9 ? std::nullopt : std::optional<std::pair<Vec3, Vec3>>({p + beside, Vec3::UnitX()});
  };
  EXPECT_THROW(check_design(d, o, dir, "box"), SolverError);
  inner = inner_socket_nodes(dir / "box.inp");
  ASSERT_EQ(inner.size(), 162u);
  int on_top = 0;
  for (const auto& p : inner) on_top += std::abs(p.z() - down.z() - 0.04) < 1e-9 && p.x() < 0.02 + 1e-9;
  EXPECT_EQ(on_top, 25);  // the top's 5 × 5 points, not moved beside the box
  // The refusals: the printed wall with a shell option, the wall or the lip without one given.
  o.printed_wall = true;
  EXPECT_THROW(check_design(d, o, dir, "box"), InvalidInputError);
  o.shell_on_wall = false;
  o.shell_subdivision = 1;
  o.shell_lip = true;  // the printed wall has its own lip: refused for that, not for its empty wall
  try {
    check_design(d, o, dir, "box");
    ADD_FAILURE() << "the printed wall with a lip was accepted";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("give a lip"), std::string::npos) << e.what();
  }
  o.printed_wall = false;
  o.shell_lip = false;
  o.shell_on_wall = true;
  d.wall_surface = nullptr;
  EXPECT_THROW(check_design(d, o, dir, "box"), InvalidInputError);
  o.shell_on_wall = false;
  o.shell_lip = true;
  EXPECT_THROW(check_design(d, o, dir, "box"), InvalidInputError);
}

// The lip alone: the shell below the brim stays on the quads through the skin nodes (its facets
// are the skin's), only the points of the quads across the brim that no quad below it shares are
// laid on socketsmith's wall — a rounded rim without moving the socket's body.
TEST(DesignCheck, the_lip_alone_moves_only_the_points_past_the_brim) {
  BoxStump box;
  DesignedStump& d = box.d;
  const std::vector<int> skin_of = box.with_brim_at_35mm();
  const Vec3 out(0.003, 0, 0);  // the wall: the box moved 3 mm along x
  d.wall_surface = [&](const Vec3& p) {
    return std::optional<std::pair<Vec3, Vec3>>({p + out, (p - Vec3(0.01, 0.01, 0.02)).normalized()});  // outward
  };
  DesignCheckOptions o;
  o.mode = DesignCheckMode::Donning;
  o.shell_lip = true;
  const auto below = socket_quads_below_brim(d, skin_of, false), across = socket_quads_below_brim(d, skin_of, true);
  ASSERT_EQ(across.size(), below.size() + 8);
  const RigidShell shell = donned_skin_shell(d, across, Vec3::Zero(), o);
  EXPECT_EQ(shell.hexahedra.size(), across.size());
  int moved = 0, kept = 0;
  for (const auto& h : shell.hexahedra)
    for (int a = 0; a < 4; ++a) {  // the inner face: the points the skin touches
      const Vec3& p = shell.nodes[h[a]];
      const bool past_brim = p.z() > 0.035;
      const Vec3 skin = past_brim ? p - out : p;
      EXPECT_NEAR(BoxStump::to_face(skin), 0.0, 1e-9) << p.transpose();
      (past_brim ? moved : kept) += 1;
    }
  EXPECT_GT(moved, 0);
  EXPECT_GT(kept, 0);
  // With the whole shell on the wall, every point moves.
  o.shell_on_wall = true;
  const RigidShell on_wall = donned_skin_shell(d, across, Vec3::Zero(), o);
  for (const auto& h : on_wall.hexahedra)
    for (int a = 0; a < 4; ++a) {
      const Vec3 skin = on_wall.nodes[h[a]] - out;
      EXPECT_NEAR(BoxStump::to_face(skin), 0.0, 1e-9);
    }
}

// A socket whose brim the closed loop raised: its own brim bounds the shell, the design's still
// says which nodes are compared (brim rings).
TEST(DesignCheck, a_raised_socket_brim_bounds_the_shell_and_not_the_designs) {
  BoxStump box;
  DesignedStump& d = box.d;
  const std::vector<int> skin_of = box.with_brim_at_35mm();
  const auto design_quads = socket_quads_below_brim(d, skin_of, false);
  EXPECT_EQ(&outside_socket(d), &d.above_brim);
  d.above_socket_brim.assign(d.above_brim.size(), 0);  // the socket's brim above the whole box
  EXPECT_EQ(&outside_socket(d), &d.above_socket_brim);
  const auto socket_quads = socket_quads_below_brim(d, skin_of, false);
  EXPECT_GT(socket_quads.size(), design_quads.size());
  EXPECT_EQ(socket_quads.size(), box.skin.quads.size());
  d.above_socket_brim.pop_back();
  EXPECT_THROW(outside_socket(d), InvalidInputError);
}

// A quad laid across the brim onto a lip that curves back on itself folds (OpenLimb TT 5.9k: ccx
// refused the deck, "nonpositive jacobian"): it is left out; the shell below the brim is whole.
TEST(DesignCheck, a_shell_quad_folded_over_the_lip_is_left_out) {
  BoxStump box;
  DesignedStump& d = box.d;
  const std::vector<int> skin_of = box.with_brim_at_35mm();
  // The wall: the box itself, but past z = 35 mm it turns back down (the top ring lands at 20 mm).
  d.wall_surface = [](const Vec3& p) {
    Vec3 q = p;
    if (q.z() > 0.0375) q.z() = 0.02;
    return std::optional<std::pair<Vec3, Vec3>>({q, (p - Vec3(0.01, 0.01, 0.02)).normalized()});  // outward
  };
  DesignCheckOptions o;
  o.mode = DesignCheckMode::Donning;
  o.shell_on_wall = true;
  o.shell_lip = true;
  o.shell_subdivision = 2;
  const auto below = socket_quads_below_brim(d, skin_of, false), across = socket_quads_below_brim(d, skin_of, true);
  ASSERT_EQ(across.size(), below.size() + 8);  // the 8 side quads between 30 and 40 mm
  const RigidShell shell = donned_skin_shell(d, across, Vec3::Zero(), o);
  // Each of the 8 splits 2 x 2: its lower half stays, its upper half (to the top ring) folds.
  EXPECT_EQ(shell.hexahedra.size(), 4 * below.size() + 8 * 2);
  for (const auto& h : shell.hexahedra) {
    volume::HexNodes x;
    for (int a = 0; a < 8; ++a) x[a] = shell.nodes[h[a]];
    EXPECT_GT(volume::min_corner_jacobian(x), 0.0);
  }
}

TEST(CcxRunner, ccx_runs_under_a_memory_cap_and_running_out_is_said_as_such) {
  const auto dir = work_dir("memory_cap");
  write_text_atomically(dir / "j.inp", "*HEADING\n");
  const auto fake = [&](const std::string& name, const std::string& body) {
    write_text_atomically(dir / name, "#!/bin/sh\n" + body);
    fs::permissions(dir / name, fs::perms::owner_all);
    CcxOptions o;
    o.executable = (dir / name).string();
    o.memory_fraction = 0.5;
    return run_ccx(dir, "j", o);
  };
  // The cap reaches ccx: its address-space limit [kB] is half the machine's memory.
  const CcxRun capped = fake("limit_ccx", "ulimit -v\necho 'Job finished'\n");
  EXPECT_TRUE(capped.converged) << capped.message;
  std::ifstream log(capped.log);
  double kb = 0;
  log >> kb;
  EXPECT_GT(capped.memory_limit_bytes, 0.0);
  EXPECT_NEAR(kb * 1024, capped.memory_limit_bytes, 1024.0);
  // ccx's own allocation failure under the cap, and the system's killer.
  for (const auto& [name, body] :
       {std::pair{"calloc_ccx", "echo ' STEP 1'\necho ' *ERROR in u_calloc: error allocating memory'\nexit 16\n"},
        std::pair{"killed_ccx", "echo ' STEP 1'\nkill -9 $$\n"}}) {
    const CcxRun run = fake(name, body);
    EXPECT_FALSE(run.converged) << name;
    EXPECT_TRUE(run.out_of_memory) << name;
    EXPECT_NE(run.message.find("ccx ran out of memory in step 1"), std::string::npos) << run.message;
    EXPECT_NE(run.message.find("50 % of this machine's"), std::string::npos) << run.message;
  }
  // Any other failure is not called a lack of memory.
  const CcxRun other = fake("failed_ccx", "echo ' STEP 1'\nexit 3\n");
  EXPECT_FALSE(other.out_of_memory) << other.message;
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

TEST(CubeFe, the_validation_writes_its_table_plots_and_a_summary_of_the_run) {
  if (!have_ccx()) GTEST_SKIP() << "ccx not installed (calculix-ccx)";
  CubeFeOptions o;
  o.divisions = 2;
  o.increments = 2;
  o.youngs_modulus_pa = 40e3;
  const fs::path out = fs::path(SOCKETSMITH_BINARY_DIR) / "fe_test_runs" / "cube_validation";
  fs::remove_all(out);
  const CubeFeValidation v = validate_cube_fe(o, out);
  for (const char* name : {"cube.inp", "cube_fe.csv", "cube_fe.svg", "cube_fe.png", "summary.json"})
    EXPECT_TRUE(fs::exists(out / name)) << name;
  const nlohmann::json& j = v.summary;
  std::ifstream in(out / "summary.json");
  EXPECT_EQ(j, nlohmann::json::parse(in));
  EXPECT_EQ(j["nodes"], 27);
  EXPECT_EQ(j["elements"], 8);
  EXPECT_EQ(j["element"], "C3D8");
  EXPECT_EQ(j["youngs_modulus_kpa"], 40.0);
  EXPECT_EQ(j["poisson_ratio"], 0.45);
  EXPECT_NEAR(j["max_force_n"].get<double>(), 8.0, 0.05);
  EXPECT_LT(j["max_displacement_rel_error"].get<double>(), 0.02);
  EXPECT_EQ(j["max_displacement_rel_error"], v.result.max_displacement_rel_error);
  EXPECT_TRUE(j["displacement"].contains("mae_mm"));
  EXPECT_TRUE(j["pressure"].contains("mae_kpa"));
  EXPECT_EQ(j["outputs"].size(), 8u);
  EXPECT_EQ(j["out"], out.string());
}

}  // namespace
}  // namespace socketsmith::calculix
