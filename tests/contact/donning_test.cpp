// Donning the socket the design made onto its own stump (the thesis's consistency check before
// FE, ch. 4.3): the path converges, no node goes deeper than 0.5 mm into the wall, the standing
// load is carried (force balance on the socket), and the contact pressures follow the designed
// ones below the brim.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "socketsmith/contact/donning.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"
#include "socketsmith/fe/comparison.h"
#include "socketsmith/pipeline/design_pipeline.h"

namespace socketsmith::contact {
namespace {
namespace fs = std::filesystem;

class Donning : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    c_ = pipeline::demo_case(1800);
    pipeline::run_design(c_, fs::path(SOCKETSMITH_BINARY_DIR) / "tests" / "donning_design", true, {}, &art_);
  }
  static design::CaseFile c_;
  static pipeline::DesignArtifacts art_;
};
design::CaseFile Donning::c_;
pipeline::DesignArtifacts Donning::art_;

TEST_F(Donning, the_designed_socket_reproduces_the_designed_pressures_on_its_own_stump) {
  const auto& c = c_;
  const auto& art = art_;
  ASSERT_TRUE(art.result.socket.has_value()) << "the demo design must meet its constraints";
  const auto& solver = *art.setup->solver;
  DonningOptions o;
  o.steps = 20;
  o.start_offset_m = 0.06;
  o.friction = c.patient.friction;
  o.stand_force_n = 0.5 * c.patient.body_mass_kg * units::kGravity;
  const auto r = simulate_donning(solver.model(), solver.skin().nodes, solver.skin().area_m2,
                                  art.result.socket->solid, art.setup->model.frame, o);
  ASSERT_TRUE(r.completed) << r.message;
  ASSERT_TRUE(r.stood) << r.message;
  ASSERT_EQ(r.series.size(), 21u);
  // The path: no contact at the start, contact grows, the socket carries the standing load.
  EXPECT_EQ(r.series.front().contact_nodes, 0);
  EXPECT_GT(r.series.back().contact_nodes, 50);
  EXPECT_NEAR(r.series.back().axial_force_n, o.stand_force_n, 2e-3 * o.stand_force_n);
  for (const auto& s : r.series) EXPECT_LE(s.max_penetration_m, 0.5e-3);
  // Newton's third law: the contact forces on the nodes sum to minus the force on the socket.
  Vec3 sum = Vec3::Zero();
  const Vec3 axis = art.setup->model.frame.axis;
  for (const auto& n : r.contacts)
    if (n.active) sum += n.normal_force_n * n.normal + n.tangential_n;
  EXPECT_LT((sum + r.force_on_socket_n).norm(), 1e-6 * r.force_on_socket_n.norm() + 1e-9)
      << "node forces " << sum.transpose() << " vs socket " << r.force_on_socket_n.transpose();
  EXPECT_GT(-r.force_on_socket_n.dot(axis), 0.0);
  // Agreement with the design below the brim.
  std::vector<double> pc;
  std::vector<char> below;
  for (size_t i = 0; i < r.contacts.size(); ++i) {
    pc.push_back(r.contacts[i].pressure_pa);
    below.push_back(solver.above_brim()[i] ? 0 : 1);
  }
  std::vector<int> subset;
  for (size_t i = 0; i < below.size(); ++i)
    if (below[i]) subset.push_back(static_cast<int>(i));
  const auto a = fe::compare_fields(pc, art.result.state.pressure_pa, subset);  // a: contact, b: designed
  EXPECT_GT(a.r, 0.6);
  EXPECT_LT(a.mae, 0.35 * a.mean_b);
  EXPECT_NEAR(a.mean_a, a.mean_b, 0.25 * a.mean_b);
}

TEST_F(Donning, rejects_a_socket_that_grips_at_the_start_and_bad_options) {
  const auto& art = art_;
  ASSERT_TRUE(art.result.socket.has_value());
  const auto& solver = *art.setup->solver;
  DonningOptions o;
  o.start_offset_m = 0.002;  // starts almost donned: the socket already grips
  EXPECT_THROW(simulate_donning(solver.model(), solver.skin().nodes, solver.skin().area_m2, art.result.socket->solid,
                                art.setup->model.frame, o),
               InvalidInputError);
  o.start_offset_m = -0.01;
  EXPECT_THROW(simulate_donning(solver.model(), solver.skin().nodes, solver.skin().area_m2, art.result.socket->solid,
                                art.setup->model.frame, o),
               InvalidInputError);
}

}  // namespace
}  // namespace socketsmith::contact
