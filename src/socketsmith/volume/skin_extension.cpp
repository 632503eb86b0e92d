// A skin open at its proximal rim continued upwards by walls parallel to the axis (limb_model.h:
// extend_skin_to_height); apart from limb_model.cpp because it is a surface operation the limb
// preparation asks for, not the preparation.
#include "socketsmith/volume/limb_model.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <optional>

#include <Eigen/Eigenvalues>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/core/units.h"
#include "socketsmith/geometry/mesh_boolean.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/ring_stack.h"
#include "socketsmith/geometry/surface_query.h"
#include "socketsmith/volume/transfemoral_anatomy.h"

namespace socketsmith::volume {

using geometry::LimbFrame;
using geometry::TriMesh;

SkinExtension extend_skin_to_height(const TriMesh& open_skin, const LimbFrame& frame, double top_h_m,
                                    double row_spacing_m) {
  require(row_spacing_m > 0.0, "extend_skin_to_height: row spacing {} m is not positive", row_spacing_m);
  // The boundary loop, in the direction its triangles traverse it.
  std::map<std::pair<int, int>, int> count;
  for (const auto& t : open_skin.triangles)
    for (int k = 0; k < 3; ++k) ++count[{std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])}];
  std::map<int, int> next;
  for (const auto& t : open_skin.triangles)
    for (int k = 0; k < 3; ++k) {
      const int a = t[k], b = t[(k + 1) % 3];
      if (count[{std::min(a, b), std::max(a, b)}] == 1) next[a] = b;
    }
  require(!next.empty(), "extend_skin_to_height: the skin has no open rim to continue (it is closed)");
  std::vector<int> loop{next.begin()->first};
  while (true) {
    const auto it = next.find(loop.back());
    require(it != next.end(), "extend_skin_to_height: the skin's rim is not a closed loop (non-manifold boundary)");
    if (it->second == loop.front()) break;
    loop.push_back(it->second);
    require(loop.size() <= next.size(), "extend_skin_to_height: the skin's rim is not a simple loop");
  }
  require(loop.size() == next.size(),
          "extend_skin_to_height: the skin has {} boundary vertices in more than one loop (holes besides the rim: "
          "fill them first)",
          next.size());
  std::vector<double> hv(loop.size());
  double hmin = std::numeric_limits<double>::infinity(), hmax = -hmin;
  for (std::size_t j = 0; j < loop.size(); ++j) {
    hv[j] = frame.to_cylindrical(open_skin.vertices[loop[j]]).h;
    hmin = std::min(hmin, hv[j]);
    hmax = std::max(hmax, hv[j]);
  }
  SkinExtension ext;
  ext.top_h_m = std::max(top_h_m, hmax + 0.001);
  ext.skin = open_skin;
  ext.first_added_triangle = open_skin.num_triangles();
  const int rows = std::max(1, static_cast<int>(std::ceil((ext.top_h_m - hmin) / row_spacing_m)));
  const int n = static_cast<int>(loop.size());
  std::vector<std::vector<int>> id(rows + 1, std::vector<int>(n));
  for (int j = 0; j < n; ++j) id[0][j] = loop[j];
  for (int k = 1; k <= rows; ++k)
    for (int j = 0; j < n; ++j) {
      const double h = hv[j] + (ext.top_h_m - hv[j]) * k / rows;
      id[k][j] = ext.skin.num_vertices();
      ext.skin.vertices.push_back(open_skin.vertices[loop[j]] + (h - hv[j]) * frame.axis);
    }
  // The rim edge a -> b belongs to a skin triangle; the wall triangle beside it runs b -> a.
  for (int k = 0; k < rows; ++k)
    for (int j = 0; j < n; ++j) {
      const int jn = (j + 1) % n;
      const int a = id[k][j], b = id[k][jn], au = id[k + 1][j], bu = id[k + 1][jn];
      ext.skin.triangles.push_back({b, a, au});
      ext.skin.triangles.push_back({b, au, bu});
    }
  for (int t = ext.first_added_triangle; t < ext.skin.num_triangles(); ++t)
    ext.added_area_m2 += geometry::triangle_area(ext.skin, t);
  return ext;
}

}  // namespace socketsmith::volume
