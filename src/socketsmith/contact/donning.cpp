#include "socketsmith/contact/donning.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/tissue/pressure_load.h"

namespace socketsmith::contact {
namespace {

DonningSample sample(const ContactStep& st, const std::vector<NodeContact>& contacts, const Vec3& axis,
                     double offset_m) {
  DonningSample s;
  s.offset_m = offset_m;
  s.axial_force_n = -st.force_on_obstacle_n.dot(axis);
  s.lateral_force_n = (st.force_on_obstacle_n - st.force_on_obstacle_n.dot(axis) * axis).norm();
  s.contact_nodes = st.contact_nodes;
  s.sliding_nodes = st.sliding_nodes;
  s.max_penetration_m = st.max_penetration_m;
  s.newton_iterations = st.newton_iterations;
  s.factorizations = st.factorizations;
  s.friction_passes = st.friction_passes;
  s.seconds = st.seconds;
  double sum = 0;
  for (const auto& c : contacts) s.axial_friction_n += c.tangential_n.dot(axis);
  for (const auto& c : contacts) {
    if (!c.active) continue;
    s.max_pressure_pa = std::max(s.max_pressure_pa, c.pressure_pa);
    sum += c.pressure_pa;
  }
  s.mean_pressure_pa = s.contact_nodes > 0 ? sum / s.contact_nodes : 0.0;
  return s;
}

/// Where the wall grips the skin hardest in @p contacts: "the wall grips the skin hardest at 118 mm
/// above the distal end, posterior-lateral (152°), 45 kPa" — what a stalled path is stuck on.
std::string hardest_grip(const std::vector<NodeContact>& contacts, const std::vector<int>& nodes,
                         const tissue::VectorXd& x, const geometry::LimbFrame& frame) {
  size_t k = contacts.size();
  for (size_t i = 0; i < contacts.size(); ++i)
    if (contacts[i].active && (k == contacts.size() || contacts[i].pressure_pa > contacts[k].pressure_pa)) k = i;
  if (k == contacts.size()) return "no skin node touches the wall";
  const auto cy = frame.to_cylindrical(x.segment<3>(3 * nodes[k]));
  const double deg = cy.theta * 180.0 / std::numbers::pi;  // 0 anterior, +90 medial
  const char* side = std::abs(deg) <= 45 ? "anterior" : std::abs(deg) >= 135 ? "posterior" : deg > 0 ? "medial" : "lateral";
  int touching = 0;
  for (const auto& c : contacts) touching += c.active ? 1 : 0;
  return fmt::format("{} skin nodes touch the wall, the hardest at {:.0f} mm above the distal end, {} ({:.0f}° from "
                     "the front towards medial), {:.1f} kPa",
                     touching, cy.h * 1e3, side, deg, contacts[k].pressure_pa / 1e3);
}

/// The rest positions of @p model's nodes @p nodes.
std::vector<Vec3> rest_positions(const tissue::MassSpringModel& model, const std::vector<int>& nodes) {
  std::vector<Vec3> rest;
  rest.reserve(nodes.size());
  for (const int n : nodes) rest.push_back(model.mesh().nodes[n]);
  return rest;
}

}  // namespace

RigidSocket donning_socket(const geometry::TriMesh& solid, const geometry::LimbFrame& frame,
                           std::vector<Vec3> skin_at_rest, const DonningOptions& options) {
  RigidSocket socket(solid, frame, options.socket_density_kg_m3);
  socket.set_smooth_wall(options.smooth_wall);
  // Fitted to the facets where this skin touches them (rigid_socket.h).
  if (options.smooth_wall) socket.fit_smooth_wall_to(std::move(skin_at_rest));
  return socket;
}

struct DonningSimulation::Impl {
  const tissue::MassSpringModel& model;
  DonningOptions o;
  geometry::LimbFrame frame;
  Vec3 axis;
  RigidSocket socket;
  tissue::DofMap dofs;
  std::unique_ptr<ContactSolver> solver;
  std::vector<int> skin_nodes;
  bool completed = false, stood = false;
  double last_step = 0.0;
  long spent_at_begin = 0;  ///< the solver's Newton iterations when this run or refit began
  double stand_stiffness = 0.0;  ///< d(axial force)/d(position) over the last standing push [N/m]; 0 unknown
  // The guided path: the socket's offset across the axis is `shift` at `shift_from_m` along the
  // axis and fades linearly to 0 at the designed pose (no sidestep: shift_from_m = 0).
  Vec3 shift = Vec3::Zero();
  double shift_from_m = 0.0;

  Impl(const tissue::MassSpringModel& m, const std::vector<int>& nodes, const std::vector<double>& areas,
       const geometry::TriMesh& solid, const geometry::LimbFrame& limb_frame, const DonningOptions& options)
      : model(m), o(checked(options, m, nodes, solid, limb_frame)), frame(limb_frame), axis(limb_frame.axis.normalized()),
        socket(donning_socket(solid, limb_frame, rest_positions(m, nodes), o)),
        dofs(tissue::fixed_node_dofs(m.mesh(), "donning")), skin_nodes(nodes) {
    ContactOptions co = o.contact;
    co.friction = o.friction;
    socket.set_translation(-o.start_offset_m * axis);
    solver = std::make_unique<ContactSolver>(model, dofs, nodes, areas, socket, co);
  }

  /// The solver's contact state for a result: each node's pressure its normal force over its
  /// deformed nodal area when the skin surface is known (DonningOptions::skin), else as solved
  /// (over its rest area).
  std::vector<NodeContact> contacts() const {
    std::vector<NodeContact> c = solver->contacts();
    if (o.skin == nullptr) return c;
    std::vector<double> area;
    std::vector<Vec3> normal;
    tissue::skin_areas_and_normals(*o.skin, solver->positions(), area, normal);
    for (size_t i = 0; i < c.size(); ++i)
      if (c[i].active && area[i] > 0) c[i].pressure_pa = c[i].normal_force_n / area[i];
    return c;
  }

  /// The socket's translation at @p offset along the axis on the (guided) path.
  Vec3 at(double offset) const {
    if (shift_from_m >= 0) return offset * axis;
    return offset * axis + std::clamp(offset / shift_from_m, 0.0, 1.0) * shift;
  }

  /// The path stalled beyond @p offset (the last converged position): sidesteps the socket across
  /// the axis there, in the direction the skin pushes it (@p force_on_socket), by 2 mm, else 4 mm,
  /// within max_sidestep_m in all; true when a sidestep converged (the path then goes on from it).
  bool sidestep(double offset, const Vec3& force_on_socket, DonningResult& r) {
    const Vec3 lateral = force_on_socket - force_on_socket.dot(axis) * axis;
    if (o.max_sidestep_m <= 0 || lateral.norm() < 1e-3 * std::max(force_on_socket.norm(), 1.0)) return false;
    const Vec3 now = at(offset) - offset * axis;
    for (const double d : {0.002, 0.004}) {
      const Vec3 to = now + d * lateral.normalized();
      if (to.norm() > o.max_sidestep_m + 1e-9) break;
      const ContactStep st = solver->try_move_to(offset * axis + to);
      if (!st.converged) {
        solver->discard();
        continue;
      }
      solver->commit();
      shift = to;
      shift_from_m = offset;
      r.max_sidestep_m = std::max(r.max_sidestep_m, to.norm());
      log::info("donning: stalled above {:.1f} mm below the designed pose; the socket sidesteps {:.1f} mm across the "
                "axis (where the skin pushes it) and comes back to the axis by its pose",
                -offset * 1e3, to.norm() * 1e3);
      return true;
    }
    return false;
  }

  /// Why the path stopped at @p target, and where the socket holds the skin at @p offset (the last
  /// converged state: the solver went back to it).
  /// @p out_of_budget: the path ground (DonningOptions::max_newton_iterations spent), which more
  /// steps do not cure.
  std::string stalled_message(double target, double offset, const ContactStep& st, double sidestep_m,
                              bool out_of_budget = false) const {
    std::string m = fmt::format("donning stalled at {:.1f} mm below the designed pose (step of {:.2f} mm): {}; at {:.1f} "
                                "mm {}",
                                -target * 1e3, (target - offset) * 1e3, st.message, -offset * 1e3,
                                hardest_grip(solver->contacts(), skin_nodes, solver->positions(), frame));
    if (sidestep_m > 0) m += fmt::format(", after a sidestep of {:.0f} mm", sidestep_m * 1e3);
    if (out_of_budget)
      m += "; the contact there does not settle: ease the socket where it grips";
    else if (!o.start_offset_name.empty())
      m += fmt::format("; try more --steps or a smaller {}", o.start_offset_name);
    return m;
  }

  /// The options checked, with the automatic start offset resolved.
  static DonningOptions checked(DonningOptions o, const tissue::MassSpringModel& model, const std::vector<int>& skin_nodes,
                                const geometry::TriMesh& socket_solid, const geometry::LimbFrame& frame) {
    require(std::isfinite(o.start_offset_m) && o.start_offset_m >= 0,
            "donning: start offset {} mm must be positive (the socket starts below the stump)", o.start_offset_m * 1e3);
    require(o.steps >= 0 && std::isfinite(o.step_m) && o.step_m > 0, "donning: {} steps of {} mm: use positive values",
            o.steps, o.step_m * 1e3);
    require(std::isfinite(o.min_step_m) && o.min_step_m > 0, "donning: the shortest step {} mm must be positive",
            o.min_step_m * 1e3);
    o.min_step_m = std::min(o.min_step_m, o.step_m);
    require(o.skin == nullptr || o.skin->nodes == skin_nodes,
            "donning: the skin surface given for the pressures has {} nodes, not the {} skin nodes donned",
            o.skin ? o.skin->nodes.size() : 0, skin_nodes.size());
    require(o.max_newton_iterations >= 0, "donning: a limit of {} Newton iterations (expected ≥ 0; 0: no limit)",
            o.max_newton_iterations);
    require(std::isfinite(o.stand_force_n) && o.stand_force_n >= 0, "donning: standing force {} N must be ≥ 0",
            o.stand_force_n);
    require(std::isfinite(o.friction) && o.friction >= 0 && o.friction <= 2,
            "donning: friction coefficient {} must be in [0, 2] (skin on a socket: about 0.5)", o.friction);
    if (o.start_offset_m == 0) {
      // The socket's top 5 mm below the stump's lowest skin node: nothing touches at the start.
      double top = -1e30, bottom = 1e30;
      for (const auto& v : socket_solid.vertices) top = std::max(top, (v - frame.origin).dot(frame.axis));
      for (int n : skin_nodes)
        bottom = std::min(bottom, (model.rest_positions().segment<3>(3 * n) - frame.origin).dot(frame.axis));
      o.start_offset_m = std::max(top - bottom + 0.005, o.step_m);
    }
    return o;
  }

  /// Where the path starts, nothing may be gripped already: a node inside the wall at the start
  /// means the offset is too small for this socket (it would start half donned).
  void check_start() {
    const ContactStep st = solver->move_to(-o.start_offset_m * axis);
    require(st.contact_nodes == 0,
            "donning: {} skin nodes already touch the socket {:.0f} mm below its designed pose: start further "
            "down ({} larger than {:.0f})",
            st.contact_nodes, o.start_offset_m * 1e3,
            o.start_offset_name.empty() ? std::string("a start offset") : o.start_offset_name, o.start_offset_m * 1e3);
  }

  /// A result of run() or refit() begun: the skin nodes, the socket's mass, the path's start; the
  /// Newton iterations limited from now (DonningOptions::max_newton_iterations).
  DonningResult begin_result() {
    DonningResult r;
    r.start_offset_m = o.start_offset_m;
    r.nodes = skin_nodes;
    r.socket_mass_kg = socket.mass_kg();
    spent_at_begin = solver->newton_iterations_spent();
    solver->limit_newton(o.max_newton_iterations);
    return r;
  }
  /// … and ended: its Newton iterations in all and its time since @p t0.
  void end_result(DonningResult& r, std::chrono::steady_clock::time_point t0, const char* what) const {
    r.newton_spent = solver->newton_iterations_spent() - spent_at_begin;
    log::debug("donning: {}: {} Newton iterations in all, {} on the committed steps", what, r.newton_spent,
               r.newton_iterations);
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }

  /// The standing load reached by @p st, the push having started at @p start_at (along the axis)
  /// with the reaction @p pose_force (< 0: unknown, as in a refit's one solve): its sample and
  /// state into @p r, and the axial stiffness over the push for the next refit's prediction.
  void record_stand(DonningResult& r, const ContactStep& st, double pose_force, double start_at) {
    const double stood_at = socket.translation().dot(axis);
    log::debug("donning: stood {:.2f} mm from where the push started", (stood_at - start_at) * 1e3);
    if (pose_force >= 0 && std::abs(stood_at - start_at) > 1e-7) {
      const double k = (o.stand_force_n - pose_force) / (stood_at - start_at);
      if (k > 0) stand_stiffness = k;
    }
    r.series.push_back(sample(st, contacts(), axis, stood_at));
    r.newton_iterations += st.newton_iterations;
    r.force_on_socket_n = st.force_on_obstacle_n;
    r.final_offset_m = stood_at;
    r.stood = stood = true;
    r.contacts = contacts();
    r.positions = solver->positions();
  }

  /// Pushes the socket along the axis until its axial reaction is the standing force. The first
  /// step of the push from the reaction's slope over the last two samples (a little past the
  /// predicted position, so that it usually brackets the load at once); a 2 mm step overshot by
  /// 2–3× and its solve cost more than the bracket's.
  ///
  /// The push's free solve (ContactOptions::free_push) starts at the predicted position itself
  /// (3k demo: a corrected socket, 295 N at its pose, stood in 7 Newton iterations instead of 28;
  /// a donning from scratch 97 → 75 in all).
  ///
  /// A refit has one sample (the refitted socket where the worn one stood): its push is predicted
  /// from the axial stiffness the last standing measured — forwards as above, or, when the new
  /// socket already carries more than the load, backwards by the predicted distance instead of a
  /// whole donning step (the bracket's first end then lies next to the load).
  void stand(DonningResult& r) {
    try {
      double first = 0, max_step = last_step, free_start = 0;
      const size_t ns = r.series.size();
      const double pose_force = ns > 0 ? r.series.back().axial_force_n : 0.0;
      if (o.predict_stand_step && ns >= 2) {
        const auto &a = r.series[ns - 2], &b = r.series[ns - 1];
        const double slope = (b.axial_force_n - a.axial_force_n) / (b.offset_m - a.offset_m);
        if (slope > 0 && o.stand_force_n > b.axial_force_n) {
          free_start = std::min((o.stand_force_n - b.axial_force_n) / slope, last_step);
          first = 1.1 * (o.stand_force_n - b.axial_force_n) / slope;
        }
      } else if (o.predict_stand_step && ns == 1 && stand_stiffness > 0) {
        const double ds = (o.stand_force_n - pose_force) / stand_stiffness;
        if (ds > 0) {
          first = 1.1 * ds;
          max_step = std::max(max_step, first);
        } else {
          max_step = std::clamp(1.1 * -ds, 1e-5, std::max(last_step, 1e-5));
        }
      }
      const double start_at = socket.translation().dot(axis);
      const auto t0 = std::chrono::steady_clock::now();
      const ContactStep st = solver->push_with_force(axis, o.stand_force_n, 1e-3, max_step, first, free_start);
      log::debug("donning: standing push {:.0f} → {:.0f} N: {:.2f} s", pose_force, o.stand_force_n,
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      record_stand(r, st, ns > 0 ? pose_force : -1.0, start_at);
    } catch (const SolverError& e) {
      // What the caller keeps of the run (a donned socket's results, or nothing) is the caller's to say.
      r.message = fmt::format("standing with {:.0f} N not reached ({})", o.stand_force_n, e.what());
    }
    report_progress(o.progress, 1.0, "donning: standing");
  }
};

DonningSimulation::DonningSimulation(const tissue::MassSpringModel& model, const std::vector<int>& skin_nodes,
                                     const std::vector<double>& skin_areas, const geometry::TriMesh& socket_solid,
                                     const geometry::LimbFrame& frame, const DonningOptions& options)
    : impl_(std::make_unique<Impl>(model, skin_nodes, skin_areas, socket_solid, frame, options)) {}

DonningSimulation::~DonningSimulation() = default;

DonningResult DonningSimulation::run() {
  auto& s = *impl_;
  const DonningOptions& o = s.o;
  require(!s.completed, "donning: run() was already called on this simulation");
  auto& solver = *s.solver;
  const Vec3 axis = s.axis;
  const bool adaptive = o.steps == 0;
  const auto t0 = std::chrono::steady_clock::now();
  DonningResult r = s.begin_result();
  s.check_start();
  r.completed = true;
  // The path: fixed steps, or adaptive ones (DonningOptions::steps). A trial step is kept unless a
  // node that was sliding or free sticks in it; then it is tried again at the shortest step (and at
  // half the length when it does not converge).
  const double fixed_step = adaptive ? 0.0 : o.start_offset_m / o.steps;
  double offset = -o.start_offset_m, step = adaptive ? o.step_m : fixed_step;
  s.last_step = step;
  const double stand_share = o.stand_force_n > 0 ? 1.0 / (o.steps > 0 ? o.steps + 1 : 20) : 0.0;
  while (offset < -1e-12) {
    // No sliver of a last step: a target within a quarter of the shortest step of the pose is the pose.
    const auto target_of = [&](double length) {
      const double to = std::min(offset + length, 0.0);
      return adaptive && to > -0.25 * o.min_step_m ? 0.0 : to;
    };
    const double target = target_of(step);
    // Refinable: the shortest step goes somewhere else (the last step before the pose may already
    // end where the shortest one would; refining it would solve the same step twice).
    const bool refinable = adaptive && step > o.min_step_m * (1 + 1e-9) && target_of(o.min_step_m) != target;
    // A step that can be refined is tried and kept or refined; one that cannot is solved and
    // committed at once (move_to, whose sub-steps when it fails are committed: a path refinement).
    const ContactStep st = refinable ? solver.try_move_to(s.at(target), true) : solver.move_to(s.at(target));
    if (!st.converged) {
      solver.discard();
      if (st.out_of_budget) {
        r.completed = false;
        r.message = s.stalled_message(target, offset, st, r.max_sidestep_m, true);
        break;
      }
      if (refinable) {  // a node started sticking: the shortest step; no convergence: half the step
        if (st.stopped_on_new_stick) log::debug("donning: a node started sticking on the way to {:.2f} mm: refined", -target * 1e3);
        step = st.stopped_on_new_stick ? o.min_step_m : std::max(0.5 * step, o.min_step_m);
        ++r.rejected_steps;
        continue;
      }
      if (s.sidestep(offset, r.force_on_socket_n, r)) continue;
      r.completed = false;
      r.message = s.stalled_message(target, offset, st, r.max_sidestep_m);
      break;
    }
    const int new_sticks = st.new_sticks;
    if (new_sticks > 0 && refinable) {
      log::debug("donning: {} node(s) started sticking in the step to {:.2f} mm: refined", new_sticks, -target * 1e3);
      solver.discard();
      step = o.min_step_m;
      ++r.rejected_steps;
      continue;
    }
    if (refinable) solver.commit();
    s.last_step = target - offset;
    offset = target;
    ++r.steps;
    if (adaptive && new_sticks == 0) step = std::min(2.0 * step, o.step_m);
    r.series.push_back(sample(st, s.contacts(), axis, offset));
    r.newton_iterations += st.newton_iterations;
    r.force_on_socket_n = st.force_on_obstacle_n;
    r.final_offset_m = offset;
    if (!report_progress(o.progress, (1.0 - stand_share) * (1.0 + offset / o.start_offset_m), "donning")) {
      r.completed = false;
      r.message = fmt::format("donning cancelled at {:.1f} mm below the designed pose", -offset * 1e3);
      break;
    }
  }
  r.contacts = s.contacts();
  r.positions = solver.positions();
  s.completed = r.completed;
  if (r.completed && o.stand_force_n > 0) s.stand(r);
  s.end_result(r, t0, "run");
  return r;
}

DonningResult DonningSimulation::refit(const geometry::TriMesh& socket_solid) {
  auto& s = *impl_;
  require(s.completed, "donning: refit() needs a completed run() (the socket must be worn)");
  const auto t0 = std::chrono::steady_clock::now();
  s.socket.replace_solid(socket_solid);
  s.solver->obstacle_changed();
  s.solver->predict_wall_change();
  DonningResult r = s.begin_result();
  if (s.stood && s.o.stand_force_n > 0 && s.o.contact.free_push && !s.o.contact.linear_body) {
    // The new wall's equilibrium and the standing position in one solve (the socket free along the
    // axis under the standing load); when it fails, nothing has moved and the two steps below
    // start from the worn state.
    const double start_at = s.socket.translation().dot(s.axis);
    const ContactStep st = s.solver->push_free(s.axis, s.o.stand_force_n);
    if (st.converged) {
      s.record_stand(r, st, -1.0, start_at);
      r.completed = true;
      s.end_result(r, t0, "refit");
      return r;
    }
    log::debug("donning: the refit's one-solve standing did not converge ({}); the new wall first, then the load",
               st.message);
  }
  const Vec3 t = s.socket.translation();
  ContactStep st = s.solver->move_to(t);
  // The new wall in one step from the worn state can be too much for Newton (OpenLimb's limb: every
  // refit stalled at a residual of ~1.6 N). Then back the socket off along the axis, where the
  // tapered wall is looser, and bring it up again through the path continuation, the friction
  // history of the worn state kept.
  for (const double back_m : {0.005, 0.015}) {
    if (st.converged) break;
    s.solver->discard();
    const ContactStep down = s.solver->move_to(t - back_m * s.axis);
    if (!down.converged) continue;
    st = s.solver->move_to(t);
    if (st.converged) log::debug("donning: refit reached after backing the socket off {:.0f} mm", back_m * 1e3);
  }
  r.completed = st.converged;
  if (!st.converged) {
    r.message = fmt::format("the refitted socket found no equilibrium where the worn one stood: {}", st.message);
    s.completed = false;
  } else {
    r.series.push_back(sample(st, s.contacts(), s.axis, t.dot(s.axis)));
    r.newton_iterations = st.newton_iterations;
    r.force_on_socket_n = st.force_on_obstacle_n;
    r.final_offset_m = t.dot(s.axis);
    r.contacts = s.contacts();
    r.positions = s.solver->positions();
    if (s.stood && s.o.stand_force_n > 0) {
      s.stood = false;
      s.stand(r);
    }
  }
  s.end_result(r, t0, "refit");
  return r;
}

DonningResult simulate_donning(const tissue::MassSpringModel& model, const std::vector<int>& skin_nodes,
                               const std::vector<double>& skin_areas, const geometry::TriMesh& socket_solid,
                               const geometry::LimbFrame& frame, const DonningOptions& options) {
  DonningSimulation sim(model, skin_nodes, skin_areas, socket_solid, frame, options);
  return sim.run();
}

}  // namespace socketsmith::contact
