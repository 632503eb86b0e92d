// The thesis's cube loaded through a rigid box by contact must match the constrained cube of the
// foundation issue (thesis Fig. 28): top pressure within 2 % of W/A, same displacements, no node
// deeper than 0.1 mm in the box.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <iostream>

#include "socketsmith/contact/contact_solver.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/tissue/cube_experiment.h"
#include "socketsmith/volume/box_mesher.h"

namespace socketsmith::contact {
namespace {

using tissue::dof;

struct ContactCube {
  static constexpr int n = 6;
  static constexpr double L = 0.05;
  volume::HexMesh mesh;
  std::vector<int> top;
  std::vector<double> top_area;
  tissue::DofConstraints cons;
  ContactCube() {
    volume::BoxMeshOptions o;
    o.size = volume::Vec3::Constant(L);
    o.divisions = {n, n, n};
    mesh = volume::mesh_box(o);
    const double h = L / n;
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        cons.fixed.push_back(dof(volume::box_node_index({n, n, n}, i, j, 0), 2));
        top.push_back(volume::box_node_index({n, n, n}, i, j, n));
        top_area.push_back(h * h * ((i == 0 || i == n) ? 0.5 : 1.0) * ((j == 0 || j == n) ? 0.5 : 1.0));
      }
    const int c0 = volume::box_node_index({n, n, n}, 0, 0, 0), c1 = volume::box_node_index({n, n, n}, n, 0, 0);
    cons.fixed.push_back(dof(c0, 0));
    cons.fixed.push_back(dof(c0, 1));
    cons.fixed.push_back(dof(c1, 1));
  }
};

// A stall accepted only when its residual is a few contact nodes' (caught on the rim or a kink):
// the AmpScan limb's 8k donning stalled with 1.0 N on a node holding 1.5 N and 0.03 N elsewhere,
// and with 7.2 and 4.7 N on two nodes holding 7.2 and 4.9 N.
TEST(CaughtNodes, are_the_few_contact_nodes_that_hold_the_residual_and_nothing_else) {
  using V = std::vector<int>;
  const std::vector<double> res = {0.01, 1.0, 0.02, 0.01}, fn = {0.5, 1.5, 0.0, 2.0};
  EXPECT_EQ(caught_nodes(res, fn, 0.27, 6), V{1});
  // the rest over the tolerance: not one node's
  EXPECT_EQ(caught_nodes({0.01, 1.0, 0.4, 0.01}, fn, 0.27, 1), V{});
  // two nodes sharing it: caught together, the larger first; not when one is allowed
  EXPECT_EQ(caught_nodes({0.01, 4.7, 7.2, 0.01}, {0.5, 4.9, 7.2, 2.0}, 0.27, 6), (V{2, 1}));
  EXPECT_EQ(caught_nodes({0.01, 4.7, 7.2, 0.01}, {0.5, 4.9, 7.2, 2.0}, 0.27, 1), V{});
  // a node not in contact: a body that does not balance, never accepted
  EXPECT_EQ(caught_nodes(res, {0.5, 0.0, 0.0, 2.0}, 0.27, 6), V{});
  EXPECT_EQ(caught_nodes({0.01, 4.7, 7.2, 0.01}, {0.5, 0.0, 7.2, 2.0}, 0.27, 6), V{});
  // more unbalanced than its whole contact force: a missing load, not a turning contact force
  EXPECT_EQ(caught_nodes({0.01, 3.0, 0.02, 0.01}, fn, 0.27, 6), V{});
  // the residual spread over more nodes than allowed
  EXPECT_EQ(caught_nodes({1.0, 1.0, 1.0, 1.0}, {2.0, 2.0, 2.0, 2.0}, 0.27, 3), V{});
  EXPECT_EQ(caught_nodes({1.0, 1.0, 1.0, 1.0}, {2.0, 2.0, 2.0, 2.0}, 0.27, 4).size(), 4u);
  EXPECT_EQ(caught_nodes({}, {}, 0.27, 6), V{});
  EXPECT_THROW(caught_nodes(res, {1.0}, 0.27, 6), Error);
}

// The penalty a solver uses is the one contact_penalty_pa_per_m gives (CalculiX's check takes it
// from there with --penalty 0): factor · E / h, h the mean √area (here the cube's top, 7 × 7 nodes
// of 1/4, 1/2 or 1 element face: mean √area = h (25 + 20/√2 + 4/2) / 49), or the value set.
TEST(ContactCube, the_penalty_is_factor_times_e_over_the_mean_node_spacing) {
  const ContactCube c;
  const tissue::TissueMaterial mat{50e3, 1060};
  const tissue::MassSpringModel model(c.mesh, mat, tissue::MassSpringOptions{});
  const tissue::DofMap dofs(model.num_dofs(), c.cons);
  PlaneObstacle box(Vec3(0, 0, ContactCube::L), Vec3(0, 0, -1));
  ContactOptions co;
  co.penalty_factor = 20;
  const double h = ContactCube::L / ContactCube::n, spacing = h * (25 + 20 / std::sqrt(2.0) + 2) / 49;
  EXPECT_NEAR(contact_penalty_pa_per_m(co, 50e3, c.top_area), 20 * 50e3 / spacing, 1e-6);
  EXPECT_DOUBLE_EQ(ContactSolver(model, dofs, c.top, c.top_area, box, co).penalty(),
                   contact_penalty_pa_per_m(co, 50e3, c.top_area));
  co.penalty_pa_per_m = 3e8;
  EXPECT_DOUBLE_EQ(contact_penalty_pa_per_m(co, 50e3, c.top_area), 3e8);
  EXPECT_THROW(contact_penalty_pa_per_m(ContactOptions{}, 50e3, {1e-4, 0.0}), InvalidInputError);
}

TEST(ContactCube, matches_the_constrained_cube_at_every_weight) {
  const ContactCube c;
  tissue::MassSpringOptions mo;  // MSS-CS, default (cube-targets) constants
  const tissue::TissueMaterial mat{50e3, 1060};
  const tissue::MassSpringModel model(c.mesh, mat, mo);
  const tissue::DofMap dofs(model.num_dofs(), c.cons);
  PlaneObstacle box(Vec3(0, 0, ContactCube::L), Vec3(0, 0, -1));  // the box's bottom face, cube below
  ContactOptions co;
  co.friction = 0.0;  // the thesis's box rests frictionlessly, like the constrained cube's tied top
  co.linear_body = false;
  ContactSolver solver(model, dofs, c.top, c.top_area, box, co);
  // The constrained reference: same mesh, same model.
  tissue::CubeExperimentOptions ref_opt;
  ref_opt.divisions = ContactCube::n;
  ref_opt.material = mat;
  ref_opt.model = mo;
  ref_opt.num_weights = 9;
  const auto ref = tissue::run_cube_experiment(ref_opt);
  ASSERT_TRUE(ref.converged) << ref.message;
  const double A = ContactCube::L * ContactCube::L;
  for (const auto& row : ref.rows) {
    if (row.weight_n == 0) continue;
    const auto st = solver.push_with_force(Vec3(0, 0, -1), row.weight_n, 1e-4, 0.004);
    ASSERT_TRUE(st.converged) << st.message;
    double sum = 0, top_z = 0;
    for (size_t i = 0; i < c.top.size(); ++i) {
      sum += solver.contacts()[i].normal_force_n;
      top_z += solver.positions()[dof(c.top[i], 2)] / static_cast<double>(c.top.size());
    }
    const double p = sum / A;
    EXPECT_NEAR(p, row.weight_n / A, 0.02 * row.weight_n / A) << "W = " << row.weight_n;
    EXPECT_NEAR(st.force_on_obstacle_n.z(), row.weight_n, 1e-3 * row.weight_n) << "third law: the cube pushes the box up";
    EXPECT_LE(st.max_penetration_m, 1e-4) << "W = " << row.weight_n;
    EXPECT_EQ(st.contact_nodes, static_cast<int>(c.top.size()));
    const double ratio = (ContactCube::L - top_z) / ContactCube::L;
    EXPECT_NEAR(ratio, row.displacement_ratio, 0.01 * row.displacement_ratio + 1e-4) << "W = " << row.weight_n;
    // Nodal pressures as even as the constrained cube's.
    double pmin = 1e30, pmax = 0;
    for (size_t i = 0; i < c.top.size(); ++i) {
      pmin = std::min(pmin, solver.contacts()[i].pressure_pa);
      pmax = std::max(pmax, solver.contacts()[i].pressure_pa);
    }
    EXPECT_LE((pmax - pmin) / p, 2 * row.nodal_pressure_spread + 0.02) << "W = " << row.weight_n;
  }
}

// The push solved in one Newton solve with the box's position as one more unknown (the default)
// reaches the force exactly, where the bracket of displacement-driven solves stops within its
// tolerance: asked for 5 %, the free push still lands within 1e-5 of the force. Without friction
// the equilibrium is unique: the same box height as the bracket asked for 1e-7 (within 0.5 µm,
// what Newton's residual tolerance leaves).
// With friction the state depends on the loading path — the bracket commits its steps below the
// force, the free push loads in one increment — and the heights differ by 5 µm of 14.5 mm.
TEST(ContactCube, the_push_solves_the_box_position_with_the_cube) {
  const ContactCube c;
  tissue::MassSpringOptions mo;
  mo.kind = tissue::TissueModelKind::NeoHookean;  // the design's default body
  const tissue::MassSpringModel model(c.mesh, {50e3, 1060}, mo);
  const tissue::DofMap dofs(model.num_dofs(), c.cons);
  const auto push = [&](double friction, bool free, double rel_tol, double& box_z) {
    PlaneObstacle box(Vec3(0, 0, ContactCube::L), Vec3(0, 0, -1));
    ContactOptions co;
    co.friction = friction;
    co.linear_body = false;
    co.free_push = free;
    ContactSolver solver(model, dofs, c.top, c.top_area, box, co);
    EXPECT_TRUE(solver.push_with_force(Vec3(0, 0, -1), 20.0, 1e-4, 0.004).converged);  // in contact
    const ContactStep st = solver.push_with_force(Vec3(0, 0, -1), 60.0, rel_tol, 0.004);
    EXPECT_TRUE(st.converged) << st.message;
    box_z = box.translation().z();
    return st.force_on_obstacle_n.z();
  };
  for (const double mu : {0.0, 0.5}) {
    double z_free = 0, z_bracket = 0;
    EXPECT_NEAR(push(mu, true, 0.05, z_free), 60.0, 6e-4) << "μ = " << mu;
    EXPECT_NEAR(push(mu, false, 1e-7, z_bracket), 60.0, 6e-4) << "μ = " << mu;
    EXPECT_LT(z_free, -1e-2) << "the box moved down onto the cube";
    EXPECT_NEAR(z_free, z_bracket, mu == 0 ? 5e-7 : 1e-5) << "μ = " << mu;
  }
}

/// The cube of neo-Hookean tissue (E 50 kPa) under the box's plane, nonlinear, μ 0.5.
struct NeoHookeanCube {
  const ContactCube c;
  const tissue::MassSpringModel model{c.mesh, {50e3, 1060}, [] {
                                        tissue::MassSpringOptions mo;
                                        mo.kind = tissue::TissueModelKind::NeoHookean;
                                        return mo;
                                      }()};
  const tissue::DofMap dofs{model.num_dofs(), c.cons};
  PlaneObstacle box{Vec3(0, 0, ContactCube::L), Vec3(0, 0, -1)};
  ContactOptions co = [] {
    ContactOptions o;
    o.friction = 0.5;
    o.linear_body = false;
    return o;
  }();
};

// push_free is the free solve alone: where it converges it lands on the force; where it cannot (a
// box that touches nothing has no stiffness along the push) it leaves the obstacle and the body
// exactly where they were — the refit's fall-back starts from the worn state, not from a
// half-pushed one.
TEST(ContactCube, a_free_push_that_fails_leaves_the_state_where_it_was) {
  NeoHookeanCube k;
  auto& [c, model, dofs, box, co] = k;
  ContactSolver solver(model, dofs, c.top, c.top_area, box, co);
  ASSERT_TRUE(solver.move_to(Vec3(0, 0, 0.003)).converged);  // 3 mm above the cube: no contact
  const tissue::VectorXd x0 = solver.positions();
  const ContactStep miss = solver.push_free(Vec3(0, 0, -1), 60.0);
  EXPECT_FALSE(miss.converged);
  EXPECT_EQ(box.translation(), Vec3(0, 0, 0.003));
  EXPECT_EQ(solver.positions(), x0);
  for (const auto& nc : solver.contacts()) EXPECT_FALSE(nc.active);
  ASSERT_TRUE(solver.move_to(Vec3(0, 0, -0.001)).converged);  // in contact: the free solve has a stiffness
  const ContactStep hit = solver.push_free(Vec3(0, 0, -1), 60.0, 1e-4);
  ASSERT_TRUE(hit.converged) << hit.message;
  EXPECT_NEAR(hit.force_on_obstacle_n.z(), 60.0, 6e-3);
  EXPECT_LT(box.translation().z(), -0.002);
  co.linear_body = true;
  ContactSolver linear(model, dofs, c.top, c.top_area, box, co);
  EXPECT_THROW(linear.push_free(Vec3(0, 0, -1), 60.0), InvalidInputError);
}

// limit_newton: every Newton iteration counts (failed solves too); a solve that reaches the limit
// stops unconverged without refining its path and leaves the state where it was.
TEST(ContactCube, a_solve_stops_at_its_newton_limit_and_leaves_the_state_where_it_was) {
  NeoHookeanCube k;
  auto& [c, model, dofs, box, co] = k;
  ContactSolver free_solver(model, dofs, c.top, c.top_area, box, co);
  const ContactStep ref = free_solver.move_to(Vec3(0, 0, -0.004));
  ASSERT_TRUE(ref.converged) << ref.message;
  ASSERT_GE(ref.newton_iterations, 3);
  EXPECT_EQ(free_solver.newton_iterations_spent(), ref.newton_iterations);

  box.set_translation(Vec3(0, 0, 0));
  ContactSolver solver(model, dofs, c.top, c.top_area, box, co);
  const tissue::VectorXd x0 = solver.positions();
  solver.limit_newton(2);
  const ContactStep cut = solver.move_to(Vec3(0, 0, -0.004));
  EXPECT_FALSE(cut.converged);
  EXPECT_TRUE(cut.out_of_budget);
  EXPECT_THAT(cut.message, ::testing::HasSubstr("Newton iterations in all (the limit"));
  EXPECT_EQ(solver.newton_iterations_spent(), 2);  // no sub-steps tried after the limit
  EXPECT_EQ(solver.positions(), x0);
  solver.limit_newton(0);  // no limit: the same solve converges to the reference
  const ContactStep again = solver.move_to(Vec3(0, 0, -0.004));
  ASSERT_TRUE(again.converged) << again.message;
  EXPECT_NEAR(again.force_on_obstacle_n.z(), ref.force_on_obstacle_n.z(), 1e-6 * std::abs(ref.force_on_obstacle_n.z()));
  EXPECT_THROW(solver.limit_newton(-1), InvalidInputError);
}

// A contact solve that fails says why in one line (the Newton loop's diagnosis, tissue::run_newton)
// (here: the iteration limit of each solve).
TEST(ContactCube, a_failed_solve_says_why_in_one_line) {
  NeoHookeanCube k;
  auto& [c, model, dofs, box, co] = k;
  co.max_newton = 1;  // one Newton step per solve: not enough for 4 mm into the cube, even in 64 sub-steps
  co.kink_rel_tol = co.rel_tol;  // no acceptance at a kink (a flat wall has none)
  ContactSolver solver(model, dofs, c.top, c.top_area, box, co);
  const ContactStep st = solver.move_to(Vec3(0, 0, -0.004));
  EXPECT_FALSE(st.converged);
  EXPECT_THAT(st.message, ::testing::HasSubstr("contact solve did not converge after"));
  EXPECT_THAT(st.message, ::testing::HasSubstr(": not converged after 1 iterations (residual"));
  EXPECT_EQ(st.message.find('\n'), std::string::npos);
}

// A plane over the cube's top, @p clear above it, whose gap is @p deeper smaller wherever
// @p where(q, gap) says (q the point in the wall's frame): a wall with a step in its gap, a
// distance or @p graded (not a distance, like the smoothed wall's and the lip's).
class SteppedWall : public Obstacle {
 public:
  SteppedWall(double clear, double deeper, std::function<bool(const Vec3&, double)> where, bool graded)
      : clear_(clear), deeper_(deeper), where_(std::move(where)), graded_(graded) {}
  Gap gap(const Vec3& p) const override {
    Gap g;
    g.valid = true;
    g.graded = graded_;
    g.normal = Vec3(0, 0, -1);
    const Vec3 q = p - translation();
    g.gap_m = ContactCube::L + clear_ - q.z();
    if (where_(q, g.gap_m)) g.gap_m -= deeper_;
    g.point = p - g.gap_m * g.normal;
    g.stiffness_shape = g.normal * g.normal.transpose();
    return g;
  }

 private:
  double clear_, deeper_;
  std::function<bool(const Vec3&, double)> where_;
  bool graded_;
};

// A wall whose gap jumps 40 µm deeper once a node is 2 µm in (a stand-in for the brim's lip,
// whose hand-back stalled seed 10 and AmpScan's scan). The box pressing the cube 4 mm down wants
// its top ~3 µm in: each node's energy rises by ½ k A ((g + J)² − g²) across the jump, and
// Newton's step past it is cut to slivers.
// A stall's message names the node whose contact energy departs most from Newton's quadratic model
// over the step the line search cut: the nodes that hold the residual need not be the ones that
// block the line search (on seed 10 and AmpScan's scan they were not).
TEST(ContactCube, a_stall_names_the_node_that_breaks_newtons_model) {
  NeoHookeanCube k;
  auto& [c, model, dofs, box, co] = k;
  co.friction = 0;
  co.kink_rel_tol = co.rel_tol;  // no acceptance at a kink
  SteppedWall wall(0, 4e-5, [](const Vec3&, double gap) { return gap < -2e-6; }, false);
  ContactSolver solver(model, dofs, c.top, c.top_area, wall, co);
  const ContactStep st = solver.move_to(Vec3(0, 0, -0.004));
  EXPECT_FALSE(st.converged);
  EXPECT_THAT(st.message, ::testing::HasSubstr("stalled: the line search cut the step"));
  EXPECT_THAT(st.message, ::testing::HasSubstr("Newton's model broke most at node "));
  EXPECT_THAT(st.message, ::testing::MatchesRegex(".*its gap -[0-9]+ → -[4-9][0-9] µm.*"));
  EXPECT_EQ(st.message.find('\n'), std::string::npos);
  std::cout << st.message << "\n";
}

// The gap queries' cache skips a node while it has moved less than its last gap allows; a graded
// gap is no such bound (the lip's blend switches from the lip's gap to the wall's), and a node it
// skipped was 57 µm deep at Newton's iterate, which left its penalty out (seed 10's stalls). Here
// the wall moves 0.6 mm sideways (less than the 1 mm clearance / 1.5 the cache allows), and the
// third column of the top, 1 mm clear of it before, is 1 mm into it after: every node the wall says
// is in it is in contact (with the cache on graded gaps: none of the 7). The wall: 1 mm above the
// top, its graded gap 2 mm deeper on a strip 2 mm wide from 0.05 mm past the third column.
TEST(ContactCube, a_node_whose_graded_gap_switches_is_queried_again) {
  NeoHookeanCube k;
  auto& [c, model, dofs, box, co] = k;
  co.friction = 0;
  const double line = 2 * ContactCube::L / ContactCube::n + 5e-5;
  SteppedWall wall(1e-3, 2e-3, [line](const Vec3& q, double) { return q.x() >= line && q.x() < line + 2e-3; }, true);
  ContactSolver solver(model, dofs, c.top, c.top_area, wall, co);
  ASSERT_TRUE(solver.move_to(Vec3(0, 0, 0)).converged);
  EXPECT_EQ(solver.move_to(Vec3(0, 0, 0)).contact_nodes, 0);
  const ContactStep st = solver.move_to(Vec3(-6e-4, 0, 0));
  ASSERT_TRUE(st.converged) << st.message;
  int inside = 0, missed = 0;
  for (size_t i = 0; i < c.top.size(); ++i) {
    const Gap g = wall.gap(solver.positions().segment<3>(3 * c.top[i]));
    if (g.gap_m >= 0) continue;
    ++inside;
    if (!solver.contacts()[i].active) ++missed;
  }
  EXPECT_EQ(inside, ContactCube::n + 1);  // the third column
  EXPECT_EQ(missed, 0);
  EXPECT_EQ(st.contact_nodes, ContactCube::n + 1);
}

// The contact's residual tolerance is rel_tol · max(Σ |f_contact|, residual_floor_ratio · E h²):
// forces above the floor are solved to rel_tol of themselves, a light touch (a few millinewtons)
// only to rel_tol of the floor, 30 E h² by default — without the floor Newton chased a fraction of a
// millinewton while the contact set flipped among a few nodes (transfemoral check donning: 5,200
// Newton iterations).
TEST(ContactCube, the_residual_tolerance_is_rel_tol_of_the_contact_forces_or_of_the_floor_when_they_are_below_it) {
  NeoHookeanCube k;
  auto& [c, model, dofs, box, co] = k;
  co.friction = 0;  // Σ |f_contact| is then |F_z| (every normal along the plane's)
  const auto solve = [&](double depth_m, double floor_ratio) {
    box.set_translation(Vec3(0, 0, 0));
    ContactOptions o = co;
    o.residual_floor_ratio = floor_ratio;
    ContactSolver solver(model, dofs, c.top, c.top_area, box, o);
    const ContactStep s = solver.move_to(Vec3(0, 0, -depth_m));
    EXPECT_TRUE(s.converged) << s.message;
    EXPECT_LE(s.residual_n, s.tolerance_n);
    return s;
  };
  // On this cube E h² is 2.45 N: a 4 mm press (10.9 N) is above it, under 30 E h².
  const ContactStep deep = solve(0.004, 30), deep_unfloored = solve(0.004, 1);
  EXPECT_NEAR(deep_unfloored.tolerance_n, co.rel_tol * std::abs(deep_unfloored.force_on_obstacle_n.z()),
              1e-9 * deep_unfloored.tolerance_n);
  const ContactStep light = solve(2e-7, 30), light_unfloored = solve(2e-7, 1);
  ASSERT_GT(light.contact_nodes, 0);
  std::printf("[ measured ] contact forces: deep %.3g N, light %.3g N; tolerance of the light touch %.3g N (%.3g N "
              "with the floor at E h²)\n",
              std::abs(deep.force_on_obstacle_n.z()), std::abs(light.force_on_obstacle_n.z()), light.tolerance_n,
              light_unfloored.tolerance_n);
  EXPECT_GT(light.tolerance_n, 10 * co.rel_tol * std::abs(light.force_on_obstacle_n.z()));
  EXPECT_NEAR(light.tolerance_n, 30 * light_unfloored.tolerance_n, 1e-9 * light.tolerance_n);
  EXPECT_NEAR(deep.tolerance_n, light.tolerance_n, 1e-9 * light.tolerance_n) << "the floor is above the deep press's forces";
  EXPECT_GT(deep.tolerance_n, 5 * deep_unfloored.tolerance_n);
}

// A new wall (a refit's corrected socket) is solved from the worn state. predict_wall_change starts
// Newton where every node in contact follows the wall's move, through the last factorised tangent:
// the same equilibrium in fewer Newton iterations (8k closed loop: a refit's 9–16 → 4–9).
TEST(ContactCube, the_predicted_start_on_a_moved_wall_reaches_the_same_state_in_fewer_newton_iterations) {
  const auto refit = [](bool predict, double friction) {
    NeoHookeanCube k;
    auto& [c, model, dofs, box, co] = k;
    co.friction = friction;
    ContactSolver solver(model, dofs, c.top, c.top_area, box, co);
    const Vec3 t(0, 0, -0.003);
    EXPECT_TRUE(solver.move_to(t).converged);
    box.set_point(Vec3(0, 0, ContactCube::L - 0.0008));  // the wall 0.8 mm further in
    solver.obstacle_changed();
    if (predict) {
      EXPECT_TRUE(solver.predict_wall_change());
    }
    const ContactStep st = solver.move_to(t);
    EXPECT_TRUE(st.converged) << st.message;
    return st;
  };
  for (const double mu : {0.0, 0.5}) {
    const ContactStep plain = refit(false, mu), predicted = refit(true, mu);
    std::printf("[ measured ] μ %.1f, the wall 0.8 mm further in: %d Newton iterations from the worn state, %d from "
                "the predicted start; force %.4f vs %.4f N\n",
                mu, plain.newton_iterations, predicted.newton_iterations, plain.force_on_obstacle_n.z(),
                predicted.force_on_obstacle_n.z());
    EXPECT_LT(predicted.newton_iterations, plain.newton_iterations) << "μ " << mu;
    EXPECT_NEAR(predicted.force_on_obstacle_n.z(), plain.force_on_obstacle_n.z(),
                1e-3 * std::abs(plain.force_on_obstacle_n.z())) << "μ " << mu;
  }
}

// A wall that reaches new nodes at every step: Newton's step, solved on the tangent of the nodes
// already touching, takes the others through the wall and the line search cuts it to a sliver (the
// 8k OpenLimb limb's donning: 7–10 % of Newton's step at the start of each step of the path).
// With the penalties of the nodes the step would take through the wall in its system, the same
// states are reached in fewer Newton iterations; the low-rank solve through the tangent's
// factorisation (Woodbury) gives the step a new factorisation gives.
// A Newton step whose system has the penalties of the free nodes it would take through the wall
// (ContactOptions::predict_contact_m): the low-rank solve through the tangent's factorisation
// (Woodbury) is the step a new factorisation of the tangent with those penalties gives. A tilted
// wall pressed 8 mm into the cube in two steps, its contact front crossing the top (the predicted
// contacts change the iterations: 61 against 66 without them, 2026-12-06). Without chord steps
// (which would use K's factorisation on one side and K''s on the other) the two ways take the same
// iterations to the same state; how much the prediction saves is the stump's: Donning.*.
TEST(ContactCube, the_low_rank_solve_of_predicted_contacts_is_the_refactorised_one) {
  const auto press = [](double predict_m, int low_rank_max, double chord_ratio) {
    NeoHookeanCube k;
    auto& [c, model, dofs, box, co] = k;
    PlaneObstacle plane(Vec3(0, 0, ContactCube::L + 0.001), Vec3(0.05, 0.03, -1));
    co.predict_contact_m = predict_m;
    co.predict_low_rank_max = low_rank_max;
    co.chord_ratio = chord_ratio;
    ContactSolver solver(model, dofs, c.top, c.top_area, plane, co);
    int iterations = 0;
    ContactStep st;
    for (const double depth : {0.004, 0.008}) {
      st = solver.move_to(Vec3(0, 0, -depth));
      EXPECT_TRUE(st.converged) << st.message;
      iterations += st.newton_iterations;
    }
    return std::make_pair(iterations, st);
  };
  const auto [plain_its, plain] = press(0.0, 0, 0.0);
  const auto [w_its, w] = press(2e-5, 96, 0.0);
  const auto [f_its, f] = press(2e-5, 0, 0.0);
  std::printf("[ measured ] %d Newton iterations without predicted contacts, %d with (low rank), %d (refactorised); "
              "force %.5f / %.5f / %.5f N\n",
              plain_its, w_its, f_its, plain.force_on_obstacle_n.norm(), w.force_on_obstacle_n.norm(),
              f.force_on_obstacle_n.norm());
  EXPECT_NE(w_its, plain_its) << "no contact was predicted: the test no longer tests it";
  EXPECT_EQ(w_its, f_its);
  EXPECT_NEAR(w.force_on_obstacle_n.norm(), f.force_on_obstacle_n.norm(), 1e-6 * f.force_on_obstacle_n.norm());
  EXPECT_NEAR(w.force_on_obstacle_n.norm(), plain.force_on_obstacle_n.norm(), 1e-3 * plain.force_on_obstacle_n.norm());
}

// The same with the obstacle free along its push (push_free: the standing push, a refit's one
// solve), where the added penalties also join the free obstacle's border column and its balance:
// the low-rank solve gives the step the refactorised one gives, and the push lands where it lands
// without the prediction, in fewer Newton iterations. The tilted wall pressed 3 mm into the cube's
// corner (0.9 N, 18 nodes), then pushed with 5 N, its contact front crossing the top (49 nodes):
// 45 Newton iterations without the prediction, 37 with it (2026-12-07).
TEST(ContactCube, a_free_pushs_predicted_contacts_solved_low_rank_are_the_refactorised_ones) {
  constexpr double kForce = 5.0, kRelTol = 0.02;  // the kink's residual at the cube's edges: ~0.03 N
  const auto push = [](double predict_m, int low_rank_max) {
    NeoHookeanCube k;
    auto& [c, model, dofs, box, co] = k;
    PlaneObstacle plane(Vec3(0, 0, ContactCube::L + 0.001), Vec3(0.05, 0.03, -1));
    co.predict_contact_m = predict_m;
    co.predict_low_rank_max = low_rank_max;
    co.chord_ratio = 0.0;
    ContactSolver solver(model, dofs, c.top, c.top_area, plane, co);
    EXPECT_TRUE(solver.move_to(Vec3(0, 0, -0.003)).converged);
    const ContactStep st = solver.push_free(Vec3(0, 0, -1), kForce, kRelTol);
    EXPECT_TRUE(st.converged) << st.message;
    return std::make_tuple(st, plane.translation().z(), solver.positions());
  };
  const auto [plain, plain_z, plain_x] = push(0.0, 0);
  const auto [w, w_z, w_x] = push(2e-5, 96);
  const auto [f, f_z, f_x] = push(2e-5, 0);
  std::printf("[ measured ] free push to %.0f N: %d Newton iterations without predicted contacts, %d with (low "
              "rank), %d (refactorised); %d / %d / %d nodes in contact; the wall at %.5f / %.5f / %.5f mm\n",
              kForce, plain.newton_iterations, w.newton_iterations, f.newton_iterations, plain.contact_nodes,
              w.contact_nodes, f.contact_nodes, plain_z * 1e3, w_z * 1e3, f_z * 1e3);
  EXPECT_GT(plain.contact_nodes, 40) << "the push no longer spreads the contact: the test no longer tests it";
  EXPECT_LT(w.newton_iterations, plain.newton_iterations) << "no contact was predicted: the test no longer tests it";
  EXPECT_EQ(w.newton_iterations, f.newton_iterations);
  EXPECT_NEAR(w_z, f_z, 1e-9);
  EXPECT_LT((w_x - f_x).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_NEAR(w.force_on_obstacle_n.z(), kForce, kRelTol * kForce);
  EXPECT_NEAR(w_z, plain_z, 5e-6);  // the same equilibrium within the kink's residual (1.1 µm apart)
  EXPECT_NEAR(w.force_on_obstacle_n.norm(), plain.force_on_obstacle_n.norm(), 0.01 * kForce);
}

TEST(ContactCube, friction_holds_a_sideways_push_below_mu_times_the_normal_force) {
  // A block glued to the ground, pressed by the plane and dragged sideways: stick below μ N, slip above.
  const ContactCube c;
  const tissue::MassSpringModel model(c.mesh, {50e3, 1060}, {});
  tissue::DofConstraints glued;
  for (int j = 0; j <= ContactCube::n; ++j)
    for (int i = 0; i <= ContactCube::n; ++i)
      glued.fix_nodes({volume::box_node_index({ContactCube::n, ContactCube::n, ContactCube::n}, i, j, 0)});
  const tissue::DofMap dofs(model.num_dofs(), glued);
  PlaneObstacle box(Vec3(0, 0, ContactCube::L), Vec3(0, 0, -1));
  ContactOptions co;
  co.friction = 0.3;
  ContactSolver solver(model, dofs, c.top, c.top_area, box, co);
  auto st = solver.move_to(Vec3(0, 0, -0.002));  // press 2 mm
  ASSERT_TRUE(st.converged) << st.message;
  const double N = st.force_on_obstacle_n.z();
  ASSERT_GT(N, 1.0);
  // Drag the plane by 0.1 mm sideways: the top sticks (elastic), friction below μ N.
  st = solver.move_to(Vec3(1e-4, 0, -0.002));
  ASSERT_TRUE(st.converged) << st.message;
  EXPECT_LT(std::abs(st.force_on_obstacle_n.x()), co.friction * N);
  EXPECT_GT(std::abs(st.force_on_obstacle_n.x()), 0.0);
  // Drag it far (20 mm): everything slides, the friction force is μ × the normal force.
  for (int k = 1; k <= 20; ++k) {
    st = solver.move_to(Vec3(1e-3 * k, 0, -0.002));
    ASSERT_TRUE(st.converged) << st.message;
  }
  const double N2 = st.force_on_obstacle_n.z();
  EXPECT_EQ(st.sliding_nodes, st.contact_nodes);
  EXPECT_NEAR(std::abs(st.force_on_obstacle_n.x()), co.friction * N2, 1e-3 * N2);
}

TEST(ContactCube, the_augmented_lagrangian_removes_the_penetration_and_presses_as_a_rigid_wall) {
  // The neo-Hookean cube with its top pushed 4 mm down by the box, frictionless. A soft penalty
  // (factor 1: k = E / h, 6 kPa/mm against the cube's ~1 kPa/mm) lets the top sink into the box and
  // carries less than a rigid box would; the augmented Lagrangian, same penalty, carries what a
  // penalty 1000× stiffer carries, with the top where the box is.
  NeoHookeanCube k;
  k.co.friction = 0.0;
  const auto press = [&](double factor, double augmented_tol, double& penetration) {
    PlaneObstacle box(Vec3(0, 0, ContactCube::L), Vec3(0, 0, -1));
    ContactOptions co = k.co;
    co.penalty_factor = factor;
    co.augmented_tol = augmented_tol;
    co.max_friction_passes = 20;
    ContactSolver solver(k.model, k.dofs, k.c.top, k.c.top_area, box, co);
    const ContactStep st = solver.move_to(Vec3(0, 0, -0.004));
    EXPECT_TRUE(st.converged) << st.message;
    penetration = st.max_penetration_m;
    return st.force_on_obstacle_n.z();
  };
  double d_penalty = 0, d_augmented = 0, d_stiff = 0;
  const double f_penalty = press(1.0, 0.0, d_penalty);
  const double f_augmented = press(1.0, 1e-3, d_augmented);
  const double f_stiff = press(1000.0, 0.0, d_stiff);
  std::printf("[ info ] penalty %.2f N (%.0f µm in), augmented %.2f N (%.1f µm), stiff penalty %.2f N (%.1f µm)\n", f_penalty,
              d_penalty * 1e6, f_augmented, d_augmented * 1e6, f_stiff, d_stiff * 1e6);
  EXPECT_GT(d_penalty, 3e-4);  // the soft penalty: a fraction of a millimetre
  EXPECT_LT(d_augmented, 0.01 * d_penalty);
  EXPECT_LT(f_penalty, 0.9 * f_stiff);  // the penetration is compliance in series with the cube
  EXPECT_NEAR(f_augmented, f_stiff, 0.01 * f_stiff);
}

TEST(ContactSolver, rejects_bad_input) {
  const ContactCube c;
  const tissue::MassSpringModel model(c.mesh, {50e3, 1060}, {});
  const tissue::DofMap dofs(model.num_dofs(), c.cons);
  PlaneObstacle box(Vec3(0, 0, ContactCube::L), Vec3(0, 0, -1));
  ContactOptions co;
  co.friction = -1;
  EXPECT_THROW(ContactSolver(model, dofs, c.top, c.top_area, box, co), InvalidInputError);
  EXPECT_THROW(ContactSolver(model, dofs, c.top, {}, box, {}), InvalidInputError);
  co = {};
  co.augmented_tol = -0.1;
  EXPECT_THROW(ContactSolver(model, dofs, c.top, c.top_area, box, co), InvalidInputError);
}

}  // namespace
}  // namespace socketsmith::contact
