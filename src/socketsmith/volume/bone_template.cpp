#include "socketsmith/volume/bone_template.h"
#include "socketsmith/volume/bone_anatomy.h"
#include "socketsmith/volume/shape_math.h"

#include <algorithm>
#include <numeric>
#include <tuple>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

#include <Eigen/Dense>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/mesh_boolean.h"
#include "socketsmith/geometry/pchip_spline.h"
#include "socketsmith/geometry/ring_stack.h"
#include "socketsmith/geometry/surface_query.h"

namespace socketsmith::volume {

using geometry::LimbFrame;
using geometry::TriMesh;
using geometry::Vec3;
using Eigen::Vector2d;

namespace {

using shape::kPi;
constexpr double kInf = std::numeric_limits<double>::infinity();

using shape::clamp01;
using shape::lerp;
using shape::smoothstep;
TriMesh mesh_bone(const detail::BoneShape& b, const LimbFrame& frame, double shrink) {
  const double s = shrink;
  const double body_nominal = std::max(0.0, (b.h_top - b.cap_top) - (b.h_bottom + b.cap_bottom));
  const double pull = (1.0 - s) * std::min(0.02, 0.25 * body_nominal);
  const double cb = s * b.cap_bottom, ct = s * b.cap_top;
  const double hb0 = b.h_bottom + b.cap_bottom + pull;
  const double ht0 = std::max(hb0, b.h_top - b.cap_top - pull);
  auto mean_radius = [&](double h) {
    double sum = 0.0;
    for (int j = 0; j < 16; ++j) sum += b.radius(2.0 * kPi * j / 16.0, h);
    return s * sum / 16.0;
  };
  // Global meridian parameter g: [0,1] distal cap (pole → rim), [1,2] body, [2,3] proximal cap.
  struct Eval {
    double h, hr, fr;
  };
  auto eval = [&](double g) -> Eval {
    if (g <= 1.0) {
      const double psi = g * 0.5 * kPi;
      return {hb0 - cb * std::cos(psi), hb0, std::sin(psi)};
    }
    if (g <= 2.0) {
      const double h = lerp(hb0, ht0, g - 1.0);
      return {h, h, 1.0};
    }
    const double psi = (3.0 - g) * 0.5 * kPi;
    return {ht0 + ct * std::cos(psi), ht0, std::sin(psi)};
  };
  // Arc length of the mean meridian, then rings equally spaced along it.
  const int fine = 600;
  std::vector<double> gs, arc;
  double r_prev = 0.0, h_prev = 0.0;
  for (int seg = 0; seg < 3; ++seg)
    for (int i = (seg == 0 ? 0 : 1); i <= fine; ++i) {
      const double g = seg + static_cast<double>(i) / fine;
      const Eval e = eval(g);
      const double r = mean_radius(e.hr) * e.fr;
      arc.push_back(gs.empty() ? 0.0 : arc.back() + std::hypot(e.h - h_prev, r - r_prev));
      gs.push_back(g);
      r_prev = r;
      h_prev = e.h;
    }
  const double total = arc.back();
  geometry::RingStack stack;
  const Vec3 medial = frame.medial();
  auto world = [&](double a, double m, double h) -> Vec3 {
    return frame.origin + h * frame.axis + a * frame.anterior + m * medial;
  };
  std::size_t k = 0;
  for (int r = 1; r <= b.rows; ++r) {
    const double target = total * r / (b.rows + 1.0);
    while (k + 1 < arc.size() && arc[k + 1] < target) ++k;
    const double t = (arc[k + 1] > arc[k]) ? (target - arc[k]) / (arc[k + 1] - arc[k]) : 0.0;
    const double g = lerp(gs[k], gs[k + 1], clamp01(t));
    const Eval e = eval(g);
    const int n = std::clamp(static_cast<int>(std::ceil(b.columns * e.fr)), 6, b.columns);
    const Vector2d c = b.centre(e.hr);
    std::vector<Vec3> ring;
    ring.reserve(static_cast<std::size_t>(n));
    for (int j = 0; j < n; ++j) {
      const double phi = 2.0 * kPi * j / n;
      const double rho = s * b.radius(phi, e.hr) * e.fr;
      const double a = c.x() + rho * std::cos(phi);
      const double m = c.y() + rho * std::sin(phi);
      double h = e.h;
      if (b.bevel != 0.0) h += b.bevel * (a - c.x()) * (1.0 - smoothstep((e.h - hb0) / b.bevel_fade_m));
      ring.push_back(world(a, m, h));
    }
    stack.rings.push_back(std::move(ring));
  }
  const Vector2d cb0 = b.centre(hb0), ct0 = b.centre(ht0);
  stack.bottom_pole = world(cb0.x(), cb0.y(), hb0 - cb);
  stack.top_pole = world(ct0.x(), ct0.y(), ht0 + ct);
  stack.has_bottom_pole = stack.has_top_pole = true;
  return geometry::mesh_ring_stack(stack, frame.is_left_handed());
}

// ---------------------------------------------------------------------------------------------
/// A surface's query index and its bounding box (the clearance loops skip vertices by the box).
struct IndexedSurface {
  explicit IndexedSurface(const TriMesh& mesh) : query(mesh), box(geometry::bounding_box(mesh)) {}
  geometry::SurfaceQuery query;
  geometry::Aabb box;
};

/// Clearances of each bone: to the skin (vertex–triangle both ways, plus inside tests) and to
/// the other bones, as the smallest values found, capped at the limits. Queries use each bone's
/// running minimum as their radius, so the exact minimum costs little more than a pass/fail check.
struct ClearanceReport {
  std::vector<double> skin;   ///< per bone: smallest skin distance (negative: a vertex outside the skin)
  std::vector<double> gap;    ///< per bone: smallest distance to another bone (negative: interpenetration)
  std::vector<double> skin_h; ///< per bone: height of the closest approach to the skin
  std::vector<int> partner;   ///< per bone: the bone it comes closest to (-1: none within the limit)
};

ClearanceReport measure_clearances(const TriMesh& skin, const geometry::SurfaceQuery& skin_query,
                                   const std::vector<NamedMesh>& bones, const LimbFrame& frame, double skin_limit,
                                   double gap_limit) {
  const std::size_t nb = bones.size();
  ClearanceReport rep{std::vector<double>(nb, skin_limit), std::vector<double>(nb, gap_limit), std::vector<double>(nb, 0.0),
                      std::vector<int>(nb, -1)};
  std::vector<IndexedSurface> indices;
  indices.reserve(nb);
  for (const auto& b : bones) indices.emplace_back(b.mesh);
  for (std::size_t i = 0; i < nb; ++i) {
    const TriMesh& m = bones[i].mesh;
    double& best = rep.skin[i];
    auto note = [&](double d, const Vec3& p) {
      if (d < best) {
        best = d;
        rep.skin_h[i] = (p - frame.origin).dot(frame.axis);
      }
    };
    // Both surfaces have edges shorter than twice the clearance, so a crossing would bring a
    // vertex within it; a sparse inside test then decides the side.
    for (std::size_t v = 0; v < m.vertices.size(); ++v) {
      const Vec3& p = m.vertices[v];
      // Rays across the axis: the skin may be open at its proximal cut.
      if (v % 16 == 0 && !skin_query.is_inside_across(p, frame.axis))
        note(-std::max(skin_query.distance_up_to(p, 0.05), 1e-9), p);
      if (best > 0.0) note(skin_query.distance_up_to(p, best), p);
    }
    const auto& box = indices[i].box;
    for (const Vec3& p : skin.vertices) {
      if (best <= 0.0) break;
      if ((p.array() < box.min.array() - best).any() || (p.array() > box.max.array() + best).any()) continue;
      note(indices[i].query.distance_up_to(p, best), p);
    }
    for (std::size_t j = 0; j < nb; ++j) {
      if (j == i) continue;
      const auto& bj = indices[j].box;
      double& gap = rep.gap[i];
      for (std::size_t v = 0; v < m.vertices.size(); ++v) {
        const Vec3& p = m.vertices[v];
        const double lim = std::max(gap, 0.0);
        if ((p.array() < bj.min.array() - lim).any() || (p.array() > bj.max.array() + lim).any()) continue;
        double d = gap > 0.0 ? indices[j].query.distance_up_to(p, gap) : gap;
        if (v % 8 == 0 && indices[j].query.is_inside_across(p, frame.axis))
          d = -std::max(indices[j].query.distance_up_to(p, 0.05), 1e-9);
        if (d < gap) {
          gap = d;
          rep.partner[i] = static_cast<int>(j);
        }
      }
    }
  }
  return rep;
}

/// The centreline point of a bone shape at height @p h (world) [m].
Vec3 femur_point_at(const detail::BoneShape& b, const LimbFrame& frame, double h) {
  const Vector2d c = b.centre(h);
  return frame.origin + h * frame.axis + c.x() * frame.anterior + c.y() * frame.medial();
}

std::vector<detail::BoneShape> template_shapes(const SkinRadii& skin, const BoneTemplateParams& params, const BonePlacement& placement) {
  validate(params);
  require(placement.shrink > 0.0 && placement.shrink <= 1.0,
          "build_bone_template: shrink = {} is out of range (expected (0, 1])", placement.shrink);
  require(skin.num_heights >= 2 && skin.num_angles >= 8 && skin.top_m > skin.bottom_m,
          "build_bone_template: the skin radii are empty (measure them with measure_skin_radii)");
  return placement.type == geometry::LimbType::Transtibial ? detail::transtibial_bone_shapes(skin, params, placement)
                                                           : detail::transfemoral_bone_shapes(skin, params, placement);
}

}  // namespace


NamedMesh build_hemipelvis_template(const SkinRadii& skin, const LimbFrame& frame, const BoneTemplateParams& p,
                                    const BonePlacement& pl, const Vec3& femur_axis_point) {
  validate(p);
  const double hT = pl.ischial_height_m;
  require(hT > skin.bottom_m + 0.03 && hT < skin.top_m - 0.005,
          "build_hemipelvis_template: ischial height {:.1f} mm is outside the skin ({:.1f} to {:.1f} mm along the "
          "axis)",
          hT * 1e3, (skin.bottom_m + 0.03) * 1e3, (skin.top_m - 0.005) * 1e3);
  const double s = pl.shrink;
  const double r = s * p.ischium_radius_m;
  // The pelvis's proportions follow the ramus.
  const double k = p.pubic_ramus_length_m / detail::kReferencePubicRamus_m;
  const Vec3 medial = frame.medial();
  const Vec3 fd = femur_axis_point - frame.on_axis((femur_axis_point - frame.origin).dot(frame.axis));
  const Vector2d f_am(fd.dot(frame.anterior), fd.dot(medial));
  // The tuberosity's centre: ischium_offset_m from the femur, 15° (by default) behind medial,
  // pulled back towards the femur while the skin over it would be thinner than allowed.
  const Vector2d dir(std::sin(p.ischium_angle_rad), std::cos(p.ischium_angle_rad));  // (anterior, medial)
  double off = p.ischium_offset_m;
  Vector2d t_am = f_am + off * dir;
  for (int it = 0; it < 40; ++it) {
    const double th = std::atan2(t_am.y(), t_am.x());
    if (t_am.norm() + r + p.min_ischial_tissue_m <= skin.radius(th, hT + r)) break;
    off *= 0.95;
    t_am = f_am + off * dir;
  }
  const Vector2d ramus(std::cos(p.pubic_ramus_angle_rad), std::sin(p.pubic_ramus_angle_rad));
  const Vector2d s_am = t_am + p.pubic_ramus_length_m * ramus;
  // The ischial body rises towards the acetabulum.
  const Vector2d a_am = t_am + k * Vector2d(detail::kAcetabulumAnterior_m, detail::kAcetabulumMedial_m);
  auto world = [&](const Vector2d& am, double h) -> Vec3 {
    return frame.origin + h * frame.axis + am.x() * frame.anterior + am.y() * medial;
  };
  const double hc = hT + r;
  const double h_acetabulum = hc + k * detail::kAcetabulumRise_m;
  const Vec3 T = world(t_am, hc), A = world(a_am, h_acetabulum);
  const Vec3 S = world(s_am, hc + p.pubic_ramus_rise_m);
  const Vec3 A_top = A + std::max(0.02, skin.top_m + 0.06 - h_acetabulum) * frame.axis;
  // Two nearly straight tubes joined at the tuberosity (their round ends make its round bottom):
  // the ramus to the symphysis, and the ischial body up past the acetabulum.
  const TriMesh ramus_tube = detail::sweep_tube({T, S}, {r, detail::kRamusRadiusFraction * r}, 24, 0.003);
  const double r_body = detail::kIschialBodyRadiusFraction * r;
  const TriMesh body_tube = detail::sweep_tube({T, A, A_top}, {r, r_body, r_body}, 24, 0.003);
  geometry::BooleanOptions bo;
  bo.check_operands = false;  // both tubes are valid by construction (straight or gently bent)
  TriMesh m = geometry::mesh_boolean(ramus_tube, body_tube, geometry::BooleanOperation::Union, bo);
  // The boolean's vertex and triangle order varies from run to run: sort both, so that the same
  // parameters give the same mesh (an open and a closed generated limb share their bones).
  {
    std::vector<int> order(m.vertices.size());
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](int a, int b) {
      const Vec3 &va = m.vertices[a], &vb = m.vertices[b];
      return std::tie(va.x(), va.y(), va.z()) < std::tie(vb.x(), vb.y(), vb.z());
    });
    std::vector<int> new_id(order.size());
    TriMesh sorted;
    sorted.vertices.reserve(order.size());
    for (std::size_t i = 0; i < order.size(); ++i) {
      new_id[order[i]] = static_cast<int>(i);
      sorted.vertices.push_back(m.vertices[order[i]]);
    }
    for (auto t : m.triangles) {
      for (int& v : t) v = new_id[v];
      // Start each triangle at its smallest index (same orientation).
      const auto first = std::min_element(t.begin(), t.end()) - t.begin();
      std::rotate(t.begin(), t.begin() + first, t.end());
      sorted.triangles.push_back(t);
    }
    std::sort(sorted.triangles.begin(), sorted.triangles.end());
    m = std::move(sorted);
  }
  // Put the lowest vertex at the tuberosity's height.
  double low_h = kInf;
  for (const auto& v : m.vertices) low_h = std::min(low_h, (v - frame.origin).dot(frame.axis));
  for (auto& v : m.vertices) v += (hT - low_h) * frame.axis;
  return {detail::bone_name("hemipelvis", pl), std::move(m)};
}

std::vector<NamedMesh> build_bone_template(const SkinRadii& skin, const LimbFrame& frame, const BoneTemplateParams& params,
                                           const BonePlacement& placement) {
  const auto shapes = template_shapes(skin, params, placement);
  std::vector<NamedMesh> bones;
  bones.reserve(shapes.size() + 1);
  for (const auto& s : shapes) bones.push_back({s.name, mesh_bone(s, frame, placement.shrink)});
  if (placement.type == geometry::LimbType::Transfemoral && placement.ischial_height_m >= 0.0)
    bones.push_back(build_hemipelvis_template(skin, frame, params, placement,
                                              femur_point_at(shapes.front(), frame, placement.ischial_height_m)));
  return bones;
}

namespace {
/// Appends the template hemipelvis to a fitted femur, shrunk (0.93 per step) until it keeps
/// kMinBoneGap_m from the other bones. It may leave the skin (it is clipped to the stump later).
void add_hemipelvis(BoneFitResult& fit, const TriMesh& skin, const SkinRadii& radii, const LimbFrame& frame,
                    const BoneTemplateParams& params, BonePlacement placement, const Vec3& femur_point) {
  const geometry::SurfaceQuery skin_query(skin);
  for (int iter = 0; iter < 12; ++iter) {
    fit.bones.push_back(build_hemipelvis_template(radii, frame, params, placement, femur_point));
    const ClearanceReport rep = measure_clearances(skin, skin_query, fit.bones, frame, 0.0, kMinBoneGap_m + 0.0005);
    if (rep.gap.back() >= kMinBoneGap_m + 0.0005 || placement.shrink < 0.3) {
      fit.shrink.push_back(placement.shrink);
      fit.min_bone_gap_m = std::min(fit.min_bone_gap_m, rep.gap.back());
      return;
    }
    fit.bones.pop_back();
    placement.shrink *= 0.93;
  }
  fail("fit_bone_template: the hemipelvis cannot be kept {:.1f} mm from the femur (the femur reaches the ischium: "
       "check the bone placement)",
       kMinBoneGap_m * 1e3);
}
}  // namespace

BoneFitResult fit_bone_template(const TriMesh& skin, const SkinRadii& radii, const LimbFrame& frame,
                                const BoneTemplateParams& params, const BonePlacement& placement, double min_clearance_m) {
  require(min_clearance_m >= 0.0 && min_clearance_m < 0.03,
          "fit_bone_template: min_clearance_m = {} is out of range (expected 0 to 0.03 m)", min_clearance_m);
  // Vertex–triangle distances miss edge–edge closest pairs by a fraction of a millimetre on these
  // smooth shells: keep a margin so that the true surface distances honour the clearances.
  const double need_skin = min_clearance_m + 0.0005, need_gap = kMinBoneGap_m + 0.0005;
  const geometry::SurfaceQuery skin_query(skin);
  const auto shapes = template_shapes(radii, params, placement);
  const std::size_t nb = shapes.size();
  std::vector<double> shrink(nb, placement.shrink);
  std::vector<NamedMesh> bones(nb);
  std::vector<bool> dirty(nb, true);
  std::vector<double> volume(nb, 0.0);
  ClearanceReport last;
  for (int iter = 0; iter < 40; ++iter) {
    for (std::size_t i = 0; i < nb; ++i)
      if (dirty[i]) {
        bones[i] = {shapes[i].name, mesh_bone(shapes[i], frame, shrink[i])};
        if (iter == 0) volume[i] = geometry::signed_volume(bones[i].mesh);
      }
    last = measure_clearances(skin, skin_query, bones, frame, need_skin, need_gap);
    // Too close to the skin: shrink that bone; too close to another bone: shrink the smaller one.
    std::fill(dirty.begin(), dirty.end(), false);
    for (std::size_t i = 0; i < nb; ++i) {
      if (last.skin[i] < need_skin) dirty[i] = true;
      if (last.gap[i] < need_gap) {
        const int j = last.partner[i];
        dirty[j >= 0 && volume[static_cast<std::size_t>(j)] < volume[i] ? static_cast<std::size_t>(j) : i] = true;
      }
    }
    bool ok = true, stuck = false;
    for (std::size_t i = 0; i < nb; ++i) {
      if (!dirty[i]) continue;
      ok = false;
      shrink[i] *= 0.93;
      stuck = stuck || shrink[i] < 0.25;
    }
    if (ok) {
      const ClearanceReport full = measure_clearances(skin, skin_query, bones, frame, 0.02, 0.02);
      BoneFitResult result;
      result.shrink = shrink;
      result.min_skin_clearance_m = *std::min_element(full.skin.begin(), full.skin.end());
      result.min_bone_gap_m = nb > 1 ? *std::min_element(full.gap.begin(), full.gap.end()) : kInf;
      result.bones = std::move(bones);
      if (placement.type == geometry::LimbType::Transfemoral && placement.ischial_height_m >= 0.0)
        add_hemipelvis(result, skin, radii, frame, params, placement,
                       femur_point_at(shapes.front(), frame, placement.ischial_height_m));
      return result;
    }
    if (stuck) break;
  }
  for (std::size_t i = 0; i < nb; ++i) {
    if (last.skin[i] < need_skin)
      fail("fit_bone_template: the {} does not fit inside the skin with {:.1f} mm of tissue even shrunk to {:.0f} % "
           "(closest at h = {:.0f} mm): the skin is too thin there, or the frame does not match it",
           shapes[i].name, min_clearance_m * 1e3, shrink[i] / 0.93 * 100.0, last.skin_h[i] * 1e3);
    if (last.gap[i] < need_gap)
      fail("fit_bone_template: the {} cannot be kept {:.1f} mm from the other bones even shrunk to {:.0f} % (the skin "
           "is too narrow for the template)",
           shapes[i].name, kMinBoneGap_m * 1e3, shrink[i] / 0.93 * 100.0);
  }
  fail<Error>("fit_bone_template: no shrink factor fits the bones (internal limit of 40 steps reached)");
}

double estimate_knee_height(const SkinRadii& skin) {
  const double length = skin.top_m - skin.bottom_m;
  return skin.top_m - std::clamp(0.32 * length, 0.03, 0.10);
}

std::vector<NamedMesh> estimate_bones(const TriMesh& closed_skin, const LimbFrame& frame, geometry::LimbType type,
                                      const BoneEstimateOptions& options) {
  require(std::abs(frame.axis.norm() - 1.0) < 1e-6 && std::abs(frame.anterior.norm() - 1.0) < 1e-6 &&
              std::abs(frame.axis.dot(frame.anterior)) < 1e-6,
          "estimate_bones: the limb frame is not orthonormal (|axis| = {}, |anterior| = {}, axis·anterior = {})",
          frame.axis.norm(), frame.anterior.norm(), frame.axis.dot(frame.anterior));
  const SkinRadii radii = measure_skin_radii(closed_skin, frame);
  const double length = radii.top_m - radii.bottom_m;
  BoneTemplateParams p;
  BonePlacement pl;
  pl.type = type;
  pl.name_suffix = " (estimated)";
  if (type == geometry::LimbType::Transtibial) {
    const double knee = options.knee_height_m > 0.0 ? options.knee_height_m : estimate_knee_height(radii);
    require(knee > radii.bottom_m + 0.05 && knee <= radii.top_m + 1e-9,
            "estimate_bones: knee height {:.1f} mm is outside the skin ({:.1f} to {:.1f} mm along the axis)", knee * 1e3,
            (radii.bottom_m + 0.05) * 1e3, radii.top_m * 1e3);
    pl.knee_height_m = knee;
    // Bone size follows the knee width (69 % of the skin's medio-lateral width at the joint line).
    p = scaled_bone_sizes(p, std::clamp(0.69 * radii.width_ml(knee), 0.055, 0.095) / p.tibia_plateau_width_m);
    p.tibia_end_height_m = std::clamp(0.17 * (knee - radii.bottom_m), 0.015, 0.04);
  } else {
    p.femur_end_height_m = std::clamp(0.16 * length, 0.025, 0.07);
    pl.ischial_height_m = options.ischial_height_m;
  }
  BoneFitResult fit = fit_bone_template(closed_skin, radii, frame, p, pl, options.min_clearance_m);
  return std::move(fit.bones);
}


}  // namespace socketsmith::volume
