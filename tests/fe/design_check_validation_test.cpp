// CalculiX on a designed socket (the embedded sample at ~3k nodes; ccx runs ~2 min per check on
// 2 cores): labelled `validation`. Both checks of docs/validation_fe.md, with the bars they meet.
#include <filesystem>

#include <gtest/gtest.h>

#include "socketsmith/fe/design_artifacts.h"

namespace socketsmith::fe {
namespace {

namespace fs = std::filesystem;

struct Designed {
  pipeline::DesignArtifacts art;
  DesignedStump stump;
  Designed() {
    const fs::path out = fs::path(SOCKETSMITH_BINARY_DIR) / "fe_test_runs" / "design_3k";
    pipeline::run_design(pipeline::demo_case(3000), out / "design", true, {}, &art);
    stump = designed_stump(art);
  }
};

Designed& designed() {
  static Designed d;
  return d;
}

fs::path run_dir(const std::string& name) {
  const fs::path d = fs::path(SOCKETSMITH_BINARY_DIR) / "fe_test_runs" / name;
  fs::remove_all(d);
  return d;
}

TEST(DesignCheckValidation, designed_loads_in_calculix_balance_and_deform_the_stump_alike) {
  auto& d = designed();
  DesignCheckOptions o;
  o.mode = DesignCheckMode::Load;
  o.material.youngs_modulus_pa = 100e3;
  o.material.poisson_ratio = 0.25;  // the MSS lattice's own Poisson ratio
  const auto r = check_design(d.stump, o, run_dir("design_3k_load"));
  ASSERT_TRUE(r.converged) << r.message;
  // Conservation: the bones carry exactly the designed load.
  EXPECT_NEAR(r.fe_force_n, r.designed_force_n, 0.01 * r.designed_force_n);
  // Shape: FE and socketsmith displacements correlate on the socket.
  EXPECT_GT(r.all.r, 0.8);
}

TEST(DesignCheckValidation, calculix_contact_pressure_in_the_designed_socket) {
  auto& d = designed();
  DesignCheckOptions o;
  o.material.youngs_modulus_pa = 100e3;
  o.material.poisson_ratio = 0.25;
  const auto r = check_design(d.stump, o, run_dir("design_3k_contact"));
  ASSERT_TRUE(r.converged) << r.message;
  EXPECT_GT(r.max_penetration_m, 0);
  EXPECT_LT(r.max_penetration_m, 0.5e-3);
  ASSERT_EQ(r.paths.size(), 3u);
  EXPECT_GT(r.paths[0].stats.count, 10);
  EXPECT_GT(r.paths[0].stats.r, 0.5);  // front line
}

}  // namespace
}  // namespace socketsmith::fe
