// The checks of a scene before it is rendered: every layer's mesh, values and opacity and every
// marker, with one-line errors naming the caller (raster_detail.h says why this is apart).
#include <cmath>
#include <vector>

#include <Eigen/Core>

#include "socketsmith/core/errors.h"
#include "socketsmith/report/raster.h"
#include "socketsmith/report/raster_detail.h"

namespace socketsmith::report {

using Eigen::Vector3d;

void raster_detail::validate_scene(const char* fn, const std::vector<MeshLayer>& layers,
                                   const std::vector<Marker>& markers) {
  for (std::size_t l = 0; l < layers.size(); ++l) {
    const MeshLayer& layer = layers[l];
    require(layer.mesh != nullptr, "{}: layer {} has no mesh (the mesh pointer is null)", fn, l);
    const auto& mesh = *layer.mesh;
    const int nv = mesh.num_vertices();
    for (int v = 0; v < nv; ++v) {
      const Vector3d& x = mesh.vertices[v];
      require(x.allFinite(), "{}: layer {} vertex {} = ({}, {}, {}) is not finite", fn, l, v, x.x(),
              x.y(), x.z());
    }
    for (int t = 0; t < mesh.num_triangles(); ++t)
      for (int k : mesh.triangles[t])
        require(k >= 0 && k < nv, "{}: layer {} triangle {} refers to vertex {} (the mesh has {})",
                fn, l, t, k, nv);
    if (!layer.vertex_values.empty()) {
      require(layer.vertex_values.size() == std::size_t(nv),
              "{}: layer {} has {} vertex values for {} vertices (expected one per vertex or none)",
              fn, l, layer.vertex_values.size(), nv);
      require(std::isfinite(layer.value_min) && std::isfinite(layer.value_max) &&
                  layer.value_min < layer.value_max,
              "{}: layer {} value range [{}, {}] (expected finite value_min < value_max)", fn, l,
              layer.value_min, layer.value_max);
    }
    require(layer.opacity > 0 && layer.opacity <= 1,
            "{}: layer {} opacity {} (expected 0 < opacity <= 1)", fn, l, layer.opacity);
  }
  for (std::size_t m = 0; m < markers.size(); ++m) {
    const Vector3d& x = markers[m].position;
    require(x.allFinite(), "{}: marker {} '{}' position ({}, {}, {}) is not finite", fn, m,
            markers[m].label, x.x(), x.y(), x.z());
    require(markers[m].radius_px >= 1 && markers[m].radius_px <= 100,
            "{}: marker {} '{}' radius {} px (expected 1..100)", fn, m, markers[m].label,
            markers[m].radius_px);
  }
}

}  // namespace socketsmith::report
