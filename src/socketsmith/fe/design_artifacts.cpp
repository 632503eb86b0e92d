#include "socketsmith/fe/design_artifacts.h"

#include "socketsmith/core/errors.h"

namespace socketsmith::fe {

DesignedStump designed_stump(const pipeline::DesignArtifacts& artifacts) {
  require(artifacts.setup != nullptr && artifacts.setup->solver != nullptr,
          "designed_stump: the design artifacts are empty (run pipeline::run_design with artifacts first)");
  const auto& setup = *artifacts.setup;
  const auto& mesh = setup.mesh.mesh;
  const auto& state = artifacts.result.state;
  require(state.positions.size() == 3 * mesh.num_nodes(), "designed_stump: the design state has {} coordinates for {} nodes",
          state.positions.size(), mesh.num_nodes());
  DesignedStump d;
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
  return d;
}

}  // namespace socketsmith::fe
