#include "socketsmith/contact/donning.h"

#include <chrono>
#include <cmath>
#include <limits>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"

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
  for (const auto& c : contacts) {
    if (!c.active) continue;
    s.max_pressure_pa = std::max(s.max_pressure_pa, c.pressure_pa);
    sum += c.pressure_pa;
  }
  s.mean_pressure_pa = s.contact_nodes > 0 ? sum / s.contact_nodes : 0.0;
  return s;
}

}  // namespace

DonningResult simulate_donning(const tissue::MassSpringModel& model, const std::vector<int>& skin_nodes,
                               const std::vector<double>& skin_areas, const geometry::TriMesh& socket_solid,
                               const geometry::LimbFrame& frame, const DonningOptions& options) {
  DonningOptions o = options;
  require(std::isfinite(o.start_offset_m) && o.start_offset_m >= 0,
          "donning: start offset {} mm must be positive (the socket starts below the stump)", o.start_offset_m * 1e3);
  require(o.steps >= 0 && std::isfinite(o.step_m) && o.step_m > 0, "donning: {} steps of {} mm: use positive values",
          o.steps, o.step_m * 1e3);
  require(std::isfinite(o.stand_force_n) && o.stand_force_n >= 0, "donning: standing force {} N must be ≥ 0",
          o.stand_force_n);
  if (o.start_offset_m == 0) {
    // The socket's top 5 mm below the stump's lowest skin node: nothing touches at the start.
    double top = -1e30, bottom = 1e30;
    for (const auto& v : socket_solid.vertices) top = std::max(top, (v - frame.origin).dot(frame.axis));
    for (int n : skin_nodes) bottom = std::min(bottom, (model.rest_positions().segment<3>(3 * n) - frame.origin).dot(frame.axis));
    o.start_offset_m = std::max(top - bottom + 0.005, o.step_m);
  }
  if (o.steps == 0) o.steps = static_cast<int>(std::ceil(o.start_offset_m / o.step_m - 1e-9));
  const auto t0 = std::chrono::steady_clock::now();
  const Vec3 axis = frame.axis.normalized();
  RigidSocket socket(socket_solid, frame, o.socket_density_kg_m3);
  socket.set_smooth_wall(o.smooth_wall);
  const tissue::DofMap dofs = tissue::fixed_node_dofs(model.mesh(), "donning");
  ContactOptions co = o.contact;
  co.friction = o.friction;
  socket.set_translation(-o.start_offset_m * axis);
  ContactSolver solver(model, dofs, skin_nodes, skin_areas, socket, co);

  DonningResult r;
  r.start_offset_m = o.start_offset_m;
  r.steps = o.steps;
  r.nodes = skin_nodes;
  r.socket_mass_kg = socket.mass_kg();
  // Where the path starts, nothing may be gripped already: a node inside the wall at the start
  // means the offset is too small for this socket (it would start half donned).
  {
    const ContactStep st = solver.move_to(-o.start_offset_m * axis);
    require(st.contact_nodes == 0,
            "donning: {} skin nodes already touch the socket {:.0f} mm below its designed pose: start further "
            "down (--offset-mm larger than {:.0f})",
            st.contact_nodes, o.start_offset_m * 1e3, o.start_offset_m * 1e3);
  }
  r.completed = true;
  for (int k = 1; k <= o.steps; ++k) {
    const double offset = -o.start_offset_m * (1.0 - static_cast<double>(k) / o.steps);
    const ContactStep st = solver.move_to(offset * axis);
    if (!st.converged) {
      r.completed = false;
      r.message = fmt::format("donning stalled at {:.1f} mm below the designed pose (step {} of {}): {}; try more "
                              "--steps or a smaller --offset-mm",
                              -offset * 1e3, k, o.steps, st.message);
      break;
    }
    r.series.push_back(sample(st, solver.contacts(), axis, offset));
    r.newton_iterations += st.newton_iterations;
    r.force_on_socket_n = st.force_on_obstacle_n;
    r.final_offset_m = offset;
    if (!report_progress(o.progress, static_cast<double>(k) / (o.steps + (o.stand_force_n > 0 ? 1 : 0)),
                         "donning")) {
      r.completed = false;
      r.message = fmt::format("donning cancelled at {:.1f} mm below the designed pose", -offset * 1e3);
      break;
    }
  }
  r.contacts = solver.contacts();
  r.positions = solver.positions();
  if (r.completed && o.stand_force_n > 0) {
    try {
      // The first step of the push from the reaction's slope over the last step (a little past the
      // predicted position, so that it usually brackets the load at once); a 2 mm step overshot
      // by 2–3× and its solve cost more than the bracket's.
      double first = 0;
      const size_t ns = r.series.size();
      if (o.predict_stand_step && ns >= 2) {
        const auto &a = r.series[ns - 2], &b = r.series[ns - 1];
        const double slope = (b.axial_force_n - a.axial_force_n) / (b.offset_m - a.offset_m);
        if (slope > 0 && o.stand_force_n > b.axial_force_n) first = 1.1 * (o.stand_force_n - b.axial_force_n) / slope;
      }
      const ContactStep st = solver.push_with_force(axis, o.stand_force_n, 1e-3, o.start_offset_m / o.steps, first);
      const double offset = socket.translation().dot(axis);
      r.series.push_back(sample(st, solver.contacts(), axis, offset));
      r.newton_iterations += st.newton_iterations;
      r.force_on_socket_n = st.force_on_obstacle_n;
      r.final_offset_m = offset;
      r.stood = true;
      r.contacts = solver.contacts();
      r.positions = solver.positions();
    } catch (const SolverError& e) {
      r.message = fmt::format("standing with {:.0f} N not reached ({}); the results are those of the donned socket at "
                              "its designed pose",
                              o.stand_force_n, e.what());
    }
    report_progress(o.progress, 1.0, "donning: standing");
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace socketsmith::contact
