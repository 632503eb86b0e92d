// The anatomical size of a limb after units: its ranges per limb type, the measure, the check and the
// hint at the likely unit mistake (limb_model.h); apart from limb_model.cpp because checking a size
// is not preparing a limb.
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

std::string unit_mistake_hint(double factor) {
  if (factor > 300 && factor < 3000) return "about 1000 x too small: the file is probably in m read as mm; give units m";
  if (factor < 1.0 / 300 && factor > 1.0 / 3000)
    return "about 1000 x too large: the file is probably in mm read as m; give units mm";
  if (factor < 1.0 / 30 && factor >= 1.0 / 300)
    return "about 100 x too large: in cm read as m? give units mm and limb.scale 10 (--scale 10), or units m and "
           "limb.scale 0.01";
  // A scan exported in cm and read as mm (the guess from its size says mm): 10 x too small, give
  // or take the limb's proportions (OpenLimb's skin in cm: 7.8).
  if (factor >= 5 && factor < 20)
    return fmt::format("about {:.2g} x too small: in cm read as mm? give units mm and limb.scale 10 (--scale 10); a "
                       "normalised shape? give its limb.scale, e.g. the intact femur length in m (0.45 with units m)",
                       factor);
  if (factor > 0.05 && factor < 5)
    return fmt::format("about {:.2g} x off: a normalised shape? give limb.scale (--scale), e.g. the intact femur length "
                       "in m for an OpenLimbTF shape (0.45)",
                       factor);
  return "check the units and limb.scale (--units, --scale)";
}

LimbSizeRange limb_size_range(geometry::LimbType type) {
  return type == geometry::LimbType::Transtibial ? LimbSizeRange{0.06, 0.45, 0.05, 0.20}
                                                 : LimbSizeRange{0.05, 0.60, 0.07, 0.25};
}

LimbSize measure_limb_size(const TriMesh& skin, const LimbFrame& frame) {
  LimbSize s;
  for (const auto& v : skin.vertices) s.length_m = std::max(s.length_m, frame.to_cylindrical(v).h);
  const double closed = geometry::lowest_open_boundary_height(skin, frame);
  const geometry::Slice mid = geometry::slice_surface(skin, frame.on_axis(0.5 * closed), frame.axis);
  s.width_m = 2.0 * std::sqrt(std::abs(mid.area) / std::numbers::pi);
  return s;
}

void check_limb_size(const LimbSize& size, geometry::LimbType type) {
  const LimbSizeRange r = limb_size_range(type);
  const bool ok = size.length_m >= r.min_length_m && size.length_m <= r.max_length_m && size.width_m >= r.min_width_m &&
                  size.width_m <= r.max_width_m;
  if (ok) return;
  // What factor would bring both into the range, and which unit mistake that is.
  const double mid_l = std::sqrt(r.min_length_m * r.max_length_m), mid_w = std::sqrt(r.min_width_m * r.max_width_m);
  const double factor = std::sqrt((mid_l / std::max(size.length_m, 1e-12)) * (mid_w / std::max(size.width_m, 1e-12)));
  const std::string hint = unit_mistake_hint(factor);
  fail("limb is {:.0f} mm long and {:.0f} mm wide at mid-length after units: outside {:.0f}-{:.0f} mm x {:.0f}-{:.0f} mm for "
       "a {} limb — {} (or set limb.force_size / --force-size if it really is this size)",
       size.length_m * 1e3, size.width_m * 1e3, r.min_length_m * 1e3, r.max_length_m * 1e3, r.min_width_m * 1e3,
       r.max_width_m * 1e3, geometry::to_string(type), hint);
}

}  // namespace socketsmith::volume
