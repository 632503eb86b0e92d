#include "socketsmith/pipeline/validation_inputs.h"

#include <cmath>
#include <memory>

#include "socketsmith/core/errors.h"

namespace socketsmith::pipeline {
namespace {

using Vec3 = Eigen::Vector3d;

/// socketsmith's contact surface of the socket @p solid — the wall its donning touches, fitted to the
/// skin at rest @p rest (contact::donning_socket) — as the CalculiX check's projection
/// (RigidSocket::onto_wall: a point within 3 mm of the wall onto it, and the outward normal there).
/// The wall is built on the first call (only `--shell-on-wall` asks for it).
std::function<std::optional<std::pair<Vec3, Vec3>>(const Vec3&)> smoothed_wall_surface(const geometry::TriMesh& solid,
                                                                                       const geometry::LimbFrame& frame,
                                                                                       std::vector<Vec3> rest) {
  struct Wall {
    geometry::TriMesh solid;
    geometry::LimbFrame frame;
    std::vector<Vec3> rest;
    std::unique_ptr<contact::RigidSocket> socket;
  };
  auto wall = std::make_shared<Wall>(Wall{solid, frame, std::move(rest), nullptr});
  return [wall](const Vec3& p) {
    if (!wall->socket)
      wall->socket = std::make_unique<contact::RigidSocket>(contact::donning_socket(wall->solid, wall->frame, std::move(wall->rest)));
    return wall->socket->onto_wall(p);
  };
}

}  // namespace

calculix::FeMaterial fe_material(const design::CaseFile& c) {
  calculix::FeMaterial m;
  m.youngs_modulus_pa = c.youngs_modulus_pa;
  m.density_kg_m3 = c.density_kg_m3;
  const auto model = model_options(c);
  m.poisson_ratio = tissue::is_continuum(model.kind) ? model.fe_poisson_ratio : 0.45;
  m.is_neo_hookean = model.kind == tissue::TissueModelKind::NeoHookean;
  return m;
}

calculix::DesignedStump designed_stump(const DesignArtifacts& artifacts, bool printed_wall) {
  require(artifacts.setup != nullptr && artifacts.setup->solver != nullptr,
          "designed_stump: the design artifacts are empty (run pipeline::run_design with artifacts first)");
  const auto& setup = *artifacts.setup;
  const auto& mesh = setup.mesh.mesh;
  const auto& state = artifacts.result.state;
  require(state.positions.size() == 3 * mesh.num_nodes(), "designed_stump: the design state has {} coordinates for {} nodes",
          state.positions.size(), mesh.num_nodes());
  calculix::DesignedStump d;
  d.mesh = &mesh;
  d.skin = &setup.solver->skin();
  for (int n = 0; n < mesh.num_nodes(); ++n) {
    if (mesh.has_tag(n, volume::kNodeFixed)) d.fixed_nodes.push_back(n);
    d.designed_positions.push_back(state.positions.segment<3>(3 * n));
  }
  d.frame = setup.model.frame;
  d.pressure_pa = state.pressure_pa;
  d.skin_normals = state.skin_normals;
  d.skin_areas_m2 = state.skin_areas;
  d.above_brim = setup.solver->above_brim();
  for (const auto& l : setup.model.landmarks)
    if (l.code == "PT") d.front_theta_rad = l.cylindrical.theta;
  d.stump_length_m = setup.model.length_m;
  if (const auto& loop = artifacts.result.closed_loop) {
    // The closed loop's socket: the designed skin moved by its wall corrections.
    for (size_t i = 0; i < state.skin_positions.size(); ++i)
      d.wall_positions.push_back(state.skin_positions[i] + loop->wall_offset_m[i] * state.skin_normals[i]);
    // Its brim, where the loop raised it (ClosedLoopOptions::max_brim_raise_m), bounds the shell;
    // the nodes flagged as the design's are (the skin at rest against the brim).
    if (loop->iterations[loop->best].brim_raise_m > 0) {
      const design::BrimLine& brim = loop->socket_brim;
      d.above_socket_brim = setup.solver->above_brim_of([&brim](double theta) { return brim.height(theta); });
    }
  }
  // --printed-wall: the socket that is written (the closed loop's kept one, else the open-loop
  // socket), its inner wall, brim and lip as built, is what the donning check dons.
  const auto& loop = artifacts.result.closed_loop;
  const design::SocketResult* socket = loop ? &loop->socket : artifacts.result.socket ? &*artifacts.result.socket : nullptr;
  if (socket) {
    std::vector<Vec3> rest;
    for (const int n : d.skin->nodes) rest.push_back(mesh.nodes[n]);
    d.wall_surface = smoothed_wall_surface(socket->solid, setup.model.frame, std::move(rest));
  }
  if (socket && printed_wall) {
    geometry::TriMesh wall = contact::RigidSocket(socket->solid, setup.model.frame).inner_wall();
    // Only the faces that look towards the axis (or straight up: the distal cup): with the lip's
    // outer half, facing away from it, ccx stalled 1 mm before the demo's pose.
    const auto& f = setup.model.frame;
    const Eigen::Vector3d a = f.axis.normalized();
    std::vector<std::array<int, 3>> facing;
    for (const auto& t : wall.triangles) {
      const Eigen::Vector3d c = (wall.vertices[t[0]] + wall.vertices[t[1]] + wall.vertices[t[2]]) / 3.0 - f.origin;
      const Eigen::Vector3d n = (wall.vertices[t[1]] - wall.vertices[t[0]]).cross(wall.vertices[t[2]] - wall.vertices[t[0]]);
      if (n.dot(c - c.dot(a) * a) <= 0) facing.push_back(t);
    }
    wall.triangles = std::move(facing);
    d.socket_wall = std::move(wall);
  }
  return d;
}

contact::DonningResult don_designed_socket(const DesignArtifacts& artifacts,
                                           const contact::DonningOptions& options) {
  require(artifacts.setup != nullptr && artifacts.setup->solver != nullptr,
          "don_designed_socket: the design artifacts are empty (run pipeline::run_design with artifacts first)");
  require(artifacts.result.socket.has_value(),
          "validate design: the design does not meet its constraints, so it has no socket to don");
  const auto& setup = *artifacts.setup;
  const auto& solver = *setup.solver;
  contact::DonningOptions o = options;
  o.skin = &solver.skin();  // pressures per deformed area, as the design's
  auto r = contact::simulate_donning(solver.model(), solver.skin().nodes, solver.skin().area_m2,
                                     artifacts.result.socket->solid, setup.model.frame, o);
  require<SolverError>(r.completed, "validate design: {}", r.message);
  require<SolverError>(options.stand_force_n <= 0 || r.stood,
                       "validate design: socketsmith's donning could not stand the socket on the stump: {}; without "
                       "--stand the donned socket is compared",
                       r.message.empty() ? "the standing load was not reached" : r.message);
  return r;
}

void use_donning_pressures(const contact::DonningResult& donning, calculix::DesignedStump& stump) {
  require(donning.contacts.size() == stump.pressure_pa.size(),
          "use_donning_pressures: {} contact nodes for {} skin nodes", donning.contacts.size(), stump.pressure_pa.size());
  for (size_t i = 0; i < donning.contacts.size(); ++i) stump.pressure_pa[i] = donning.contacts[i].pressure_pa;
}

}  // namespace socketsmith::pipeline
