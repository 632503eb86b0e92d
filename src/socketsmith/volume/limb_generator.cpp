#include "socketsmith/volume/limb_generator.h"
#include "socketsmith/volume/shape_math.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/pchip_spline.h"
#include "socketsmith/geometry/ring_stack.h"
#include "socketsmith/geometry/surface_query.h"

namespace socketsmith::volume {

using geometry::LimbFrame;
using geometry::LimbType;
using geometry::TriMesh;
using geometry::Vec3;

namespace {

using shape::kPi;
constexpr double kDeg = kPi / 180.0;

using shape::clamp01;
using shape::gauss;
using shape::lerp;
using shape::smoothstep;
using shape::wrap_angle;
/// Smooth minimum (log-sum-exp with softness k), exact away from the crossing.
double smooth_min(double a, double b, double k) { return std::min(a, b) - k * std::log1p(std::exp(-std::abs(a - b) / k)); }

// ---------------------------------------------------------------------------------------------
// The analytic skin: r(theta, h) = cap(h) * section_h(theta), where section_h is a raw anatomical
// shape, translated so that its area centroid lies on the axis, and scaled so that its perimeter
// is 2 pi R(h) (R: the circumference profile).

class SkinModel {
 public:
  explicit SkinModel(const LimbShapeParams& p)
      : p_(p),
        tt_(p.type == LimbType::Transtibial),
        knee_(p.residual_length_m),
        top_(p.residual_length_m + p.proximal_extension_m),
        cap_h_(p.distal_cap_height_m),
        cap_k_(2.0 + p.bulbousness),
        profile_(make_profile(p)) {}

  double top() const { return top_; }
  double knee() const { return knee_; }
  double cap_height() const { return cap_h_; }

  /// Circumference / 2 pi at h, before the cap [m].
  double mean_radius(double h) const { return profile_(h); }
  /// Superelliptic distal cap: (1 - (1 - h/hc)^k)^(1/k) below hc, 1 above.
  double cap_factor(double h) const {
    if (h >= cap_h_) return 1.0;
    const double s = std::max(0.0, h) / cap_h_;
    return std::pow(1.0 - std::pow(1.0 - s, cap_k_), 1.0 / cap_k_);
  }

  /// A normalised cross-section at height h.
  class Section {
   public:
    Section(const SkinModel& m, double h) : m_(m), h_(h) {
      constexpr int n = 256;
      std::array<double, n> raw{}, c{}, s{};
      for (int i = 0; i < n; ++i) {
        const double t = 2.0 * kPi * i / n;
        raw[i] = m.raw(t, h);
        c[i] = std::cos(t);
        s[i] = std::sin(t);
      }
      // Move the area centroid onto the axis (first-order polar translation, iterated).
      for (int it = 0; it < 4; ++it) {
        double area = 0.0, cx = 0.0, cy = 0.0;
        for (int i = 0; i < n; ++i) {
          const double r = raw[i] - ca_ * c[i] - cm_ * s[i];
          area += 0.5 * r * r;
          cx += r * r * r * c[i] / 3.0;
          cy += r * r * r * s[i] / 3.0;
        }
        ca_ += cx / area;
        cm_ += cy / area;
      }
      double perimeter = 0.0;
      for (int i = 0; i < n; ++i) {
        const int j = (i + 1) % n;
        const double ri = raw[i] - ca_ * c[i] - cm_ * s[i], rj = raw[j] - ca_ * c[j] - cm_ * s[j];
        perimeter += std::hypot(rj * c[j] - ri * c[i], rj * s[j] - ri * s[i]);
      }
      scale_ = 2.0 * kPi * m.mean_radius(h) / perimeter;
    }
    /// Radius at angle theta, before the cap factor [m].
    double operator()(double theta) const {
      return scale_ * (m_.raw(theta, h_) - ca_ * std::cos(theta) - cm_ * std::sin(theta));
    }

   private:
    const SkinModel& m_;
    double h_;
    double ca_ = 0.0, cm_ = 0.0, scale_ = 1.0;
  };

  /// Skin radius at (theta, h) [m].
  double radius(double theta, double h) const { return cap_factor(h) * Section(*this, h)(theta); }

  /// Raw section shape (medio-lateral semi-axis 1) at angle theta and height h.
  double raw(double theta, double h) const {
    const double c = std::cos(theta);
    if (!tt_) {
      // Thigh: ellipse rounder distally, fuller posteriorly (hamstrings), slightly flatter
      // medially near the groin (adductors).
      const double q = lerp(p_.ap_ml_ratio, std::min(1.0, p_.ap_ml_ratio + 0.08), 1.0 - smoothstep(h / (0.5 * top_)));
      double r = ellipse(theta, q);
      if (c < 0.0) r *= 1.0 + p_.posterior_fullness * c * c;
      r *= 1.0 - 0.05 * gauss(wrap_angle(theta - 0.5 * kPi), 0.5) * smoothstep((h - (knee_ - 0.08)) / 0.08);
      return r;
    }
    const double H = knee_;
    // Shank ellipse rounding off to a circle at the knee (condyles, patella).
    const double q = lerp(p_.ap_ml_ratio, 1.0, smoothstep((h - (H - 0.03)) / 0.05));
    // Muscle relief (OpenLimb mean limb, about the section centroid): calf bulges postero-medial
    // (gastrocnemius, soleus) and postero-lateral, a flatter midline between them, tibialis
    // anterior antero-laterally; weaker distally and gone at the popliteal fossa.
    const double w_calf = lerp(0.5, 1.0, smoothstep((h - cap_h_) / std::max(1e-3, 0.4 * (H - cap_h_)))) *
                          (1.0 - 0.6 * smoothstep((h - (H - 0.03)) / 0.04));
    const double w_shank = smoothstep(h / (1.5 * cap_h_)) * (1.0 - smoothstep((h - (H - 0.065)) / 0.055));
    auto base = [&](double t) {
      double r = ellipse(t, q);
      r *= 1.0 + p_.posterior_fullness * w_calf *
                     (gauss(wrap_angle(t - 0.75 * kPi), 0.5) + 0.3 * gauss(wrap_angle(t + 0.75 * kPi), 0.5));
      r *= 1.0 - 0.07 * w_calf * gauss(wrap_angle(t - kPi), 0.35);
      r *= 1.0 + 0.04 * w_shank * gauss(wrap_angle(t + 0.6), 0.45);
      return r;
    };
    double r = base(theta);
    // The antero-medial face of the tibia (subcutaneous, flat) runs from the crest at theta = 0
    // medially: a line through the crest point whose normal is tilted by beta, cutting the
    // ellipse by `flat` along that normal (tan beta = q sqrt(1/(1-flat)^2 - 1)). Its corner with
    // the rounder lateral side is the tibial crest ridge (kept crisp); the medial border of the
    // face is rounded off by the soft tissue over it.
    const double flat = p_.anterior_flattening * w_shank;
    if (flat > 0.0) {
      const double beta = std::atan(q * std::sqrt(1.0 / ((1.0 - flat) * (1.0 - flat)) - 1.0));
      const double d = base(0.0) * std::cos(beta);
      const double cf = std::cos(theta - beta);
      const double softness = w_shank * (0.025 + 0.04 * smoothstep((theta - 0.5 * beta) / (1.2 * beta))) + 1e-9;
      if (cf > 0.05) r = smooth_min(r, d / cf, softness);
    }
    // Patella in front of the knee, popliteal hollow behind it.
    r += 0.11 * gauss(wrap_angle(theta), 0.5) * gauss(h - (H + 0.033), 0.02);
    r *= 1.0 - 0.04 * gauss(wrap_angle(theta - kPi), 0.5) * gauss(h - H, 0.02);
    return r;
  }

 private:
  static double ellipse(double theta, double q) {
    const double c = std::cos(theta) / q, s = std::sin(theta);
    return 1.0 / std::sqrt(c * c + s * s);
  }

  /// Relative circumference growth at dh above the knee joint line.
  static double above_knee_growth(double dh) { return 0.09 * (1.0 - std::exp(-dh / 0.025)) + 0.4 * dh; }
  /// Relative circumference growth at dh above the ischial tuberosity (buttock and hip: +4.5 % at 90 mm).
  static double above_ischium_growth(double dh) { return 0.5 * dh; }

  static geometry::PchipSpline make_profile(const LimbShapeParams& p) {
    const bool tt = p.type == LimbType::Transtibial;
    const double hc = p.distal_cap_height_m, L = p.residual_length_m;
    const double rd = p.distal_circumference_m / (2.0 * kPi), rp = p.proximal_circumference_m / (2.0 * kPi);
    const double b = p.bulbousness;
    std::vector<double> xs{hc}, ys{rd};
    for (const double s : {0.25, 0.5, 0.75}) {
      const double g = (1.0 - b) * s + b * (1.0 - std::pow(1.0 - s, 3.0));
      xs.push_back(lerp(hc, L, s));
      ys.push_back(lerp(rd, rp, g));
    }
    xs.push_back(L);
    ys.push_back(rp);
    if (p.proximal_extension_m > 0.005) {
      // Above the joint line the skin widens quickly over the patella and the condyles, then
      // slowly along the distal thigh (OpenLimb mean limb: +6 % at 22 mm, +10 % at 70 mm); above
      // the ischial tuberosity slowly over the buttock and the hip.
      for (const double s : {1.0 / 3.0, 2.0 / 3.0, 1.0}) {
        const double dh = s * p.proximal_extension_m;
        xs.push_back(L + dh);
        ys.push_back(rp * (1.0 + (tt ? above_knee_growth(dh) : above_ischium_growth(dh))));
      }
    }
    return geometry::PchipSpline(xs, ys);
  }

  LimbShapeParams p_;
  bool tt_;
  double knee_, top_, cap_h_, cap_k_;
  geometry::PchipSpline profile_;
};

// ---------------------------------------------------------------------------------------------

/// Bone sizes follow the knee (transtibial) or thigh (transfemoral) circumference.
double bone_size_factor(const LimbShapeParams& p) {
  const double nominal = p.type == LimbType::Transtibial ? 0.35 : 0.48;
  return std::clamp(p.proximal_circumference_m / nominal, 0.7, 1.3);
}

Vec3 world(const LimbFrame& f, double theta, double rho, double h) { return f.from_cylindrical({rho, theta, h}); }

Landmark make_landmark(const LimbFrame& frame, const geometry::SurfaceQuery& skin, const char* code, const char* name,
                       const Vec3& near, double radius_m) {
  Landmark l;
  l.code = code;
  l.name = name;
  l.position = skin.closest_point(near).point;
  l.cylindrical = frame.to_cylindrical(l.position);
  if (l.cylindrical.theta <= -kPi) l.cylindrical.theta += 2.0 * kPi;  // atan2(-0, -1): keep theta in (-pi, pi]
  l.radius_m = radius_m;
  l.estimated = false;
  return l;
}

const NamedMesh* find_bone(const std::vector<NamedMesh>& bones, const std::string& name) {
  for (const auto& b : bones)
    if (b.name == name) return &b;
  return nullptr;
}

/// The generated limb's frame: the axis along z from the origin, the front along y.
LimbFrame truth_frame(geometry::Side side) {
  LimbFrame frame;
  frame.origin = Vec3::Zero();
  frame.axis = Vec3::UnitZ();
  frame.anterior = Vec3::UnitY();
  frame.side = side;
  frame.anterior_estimated = false;
  frame.side_estimated = false;
  return frame;
}

/// The meridian of the mean radius, sampled finely: heights, arc length from the distal end, and
/// the largest radius [m].
struct Meridian {
  std::vector<double> h, arc;
  double r_max = 0.0;
};

Meridian sample_meridian(const SkinModel& skin_model, double bulbousness) {
  const double hc = skin_model.cap_height(), top = skin_model.top();
  const double k_cap = 2.0 + bulbousness;
  Meridian m;
  double prev_h = 0.0, prev_r = 0.0;
  auto add = [&](double h) {
    const double r = skin_model.mean_radius(h) * skin_model.cap_factor(h);
    m.r_max = std::max(m.r_max, r);
    m.arc.push_back(m.h.empty() ? 0.0 : m.arc.back() + std::hypot(h - prev_h, r - prev_r));
    m.h.push_back(h);
    prev_h = h;
    prev_r = r;
  };
  constexpr int n_cap = 600, n_body = 1200;
  for (int i = 0; i <= n_cap; ++i) {
    const double psi = 0.5 * kPi * i / n_cap;  // superellipse angle: 1 - h/hc = cos(psi)^(2/k)
    add(hc * (1.0 - std::pow(std::cos(psi), 2.0 / k_cap)));
  }
  for (int i = 1; i <= n_body; ++i) add(lerp(hc, top, static_cast<double>(i) / n_body));
  return m;
}

/// The skin's side: rings equally spaced along the meridian's arc length (about @p spacing apart),
/// up to the top; a ring of @p cols vertices, fewer on the distal cap.
geometry::RingStack side_rings(const SkinModel& skin_model, const LimbFrame& frame, const Meridian& m, int cols,
                               double spacing) {
  const double top = skin_model.top();
  const int rows = std::max(16, static_cast<int>(std::lround(m.arc.back() / spacing)));
  geometry::RingStack stack;
  stack.has_bottom_pole = true;
  stack.bottom_pole = frame.origin;
  std::size_t k = 0;
  for (int r = 1; r <= rows; ++r) {
    double h = top;
    if (r < rows) {
      const double target = m.arc.back() * r / rows;
      while (k + 1 < m.arc.size() && m.arc[k + 1] < target) ++k;
      const double t = (target - m.arc[k]) / (m.arc[k + 1] - m.arc[k]);
      h = lerp(m.h[k], m.h[k + 1], clamp01(t));
    }
    const double f = skin_model.cap_factor(h);
    const int n = std::clamp(static_cast<int>(std::ceil(cols * f)), 8, cols);
    const SkinModel::Section section(skin_model, h);
    std::vector<Vec3> ring;
    ring.reserve(static_cast<std::size_t>(n));
    for (int j = 0; j < n; ++j) {
      const double theta = 2.0 * kPi * j / n;
      ring.push_back(world(frame, theta, f * section(theta), h));
    }
    stack.rings.push_back(std::move(ring));
  }
  return stack;
}

/// Planar cap: @p n_cap_rings - 1 concentric rings shrinking from the top ring to the axis in the
/// cut plane at @p centre, closed by a pole there.
void add_planar_cap(geometry::RingStack& stack, const Vec3& centre, int n_cap_rings, int cols) {
  const std::vector<Vec3> top_ring = stack.rings.back();
  for (int i = 1; i < n_cap_rings; ++i) {
    const double lambda = 1.0 - static_cast<double>(i) / n_cap_rings;
    const int n = std::clamp(static_cast<int>(std::ceil(cols * lambda)), 8, cols);
    std::vector<Vec3> ring;
    for (int j = 0; j < n; ++j) {
      // Same angle as on the top ring, interpolated around it.
      const double u = static_cast<double>(j) * static_cast<double>(top_ring.size()) / n;
      const auto j0 = static_cast<std::size_t>(std::floor(u));
      const double t = u - static_cast<double>(j0);
      const Vec3 p = (1.0 - t) * top_ring[j0 % top_ring.size()] + t * top_ring[(j0 + 1) % top_ring.size()];
      ring.push_back(centre + lambda * (p - centre));
    }
    stack.rings.push_back(std::move(ring));
  }
  stack.has_top_pole = true;
  stack.top_pole = centre;
}

/// The skin meshed into @p limb (open or closed at the top, as the parameters ask). Returns the
/// closed skin, which the bones and the landmarks are placed in.
TriMesh mesh_skin(const LimbShapeParams& params, const SkinModel& skin_model, GeneratedLimb& limb) {
  const LimbFrame& frame = limb.frame;
  const double top = skin_model.top();
  const int cols = params.ring_vertices;
  const Meridian meridian = sample_meridian(skin_model, params.bulbousness);
  // Rings slightly closer than the vertices around them: near-equilateral triangles.
  const double spacing = 0.9 * 2.0 * kPi * meridian.r_max / cols;
  geometry::RingStack stack = side_rings(skin_model, frame, meridian, cols, spacing);
  const bool flip = frame.is_left_handed();
  const TriMesh open_skin = geometry::mesh_ring_stack(stack, flip);
  const std::size_t side_ring_count = stack.rings.size();
  const int n_cap_rings = std::max(2, static_cast<int>(std::lround(skin_model.mean_radius(top) / spacing)));
  add_planar_cap(stack, frame.on_axis(top), n_cap_rings, cols);
  std::vector<int> bands;
  TriMesh closed_skin = geometry::mesh_ring_stack(stack, flip, &bands);
  limb.skin_volume_m3 = geometry::signed_volume(closed_skin);
  if (params.open_proximal) {
    limb.skin = open_skin;
  } else {
    limb.skin = closed_skin;
    limb.first_cap_triangle = bands[side_ring_count - 1];
  }
  return closed_skin;
}

/// Bones: the shared template, measured on and fitted inside the closed skin (so that the open
/// and the closed limb of the same parameters have the same bones).
std::vector<NamedMesh> fit_bones(const LimbShapeParams& params, const SkinModel& skin_model, const TriMesh& closed_skin,
                                 const LimbFrame& frame) {
  const SkinRadii radii = measure_skin_radii(closed_skin, frame);
  BonePlacement placement;
  placement.type = params.type;
  placement.knee_height_m = skin_model.knee();
  if (params.type == LimbType::Transfemoral) placement.ischial_height_m = skin_model.knee();
  const BoneTemplateParams bones = scaled_bone_sizes(params.bones, bone_size_factor(params));
  BoneFitResult fit = fit_bone_template(closed_skin, radii, frame, bones, placement);
  return std::move(fit.bones);
}

/// Height of @p p along the frame's axis [m].
double height_in(const LimbFrame& frame, const Vec3& p) { return (p - frame.origin).dot(frame.axis); }

/// The lowest vertex of @p m along the frame's axis.
Vec3 lowest_vertex(const TriMesh& m, const LimbFrame& frame) {
  return *std::min_element(m.vertices.begin(), m.vertices.end(),
                           [&](const Vec3& a, const Vec3& b) { return height_in(frame, a) < height_in(frame, b); });
}

/// Most anterior vertex of a bone within a height band.
Vec3 most_anterior(const TriMesh& m, const LimbFrame& frame, double h0, double h1) {
  Vec3 best = m.vertices.front();
  double best_a = -std::numeric_limits<double>::infinity();
  for (const Vec3& v : m.vertices) {
    const double h = height_in(frame, v), a = (v - frame.origin).dot(frame.anterior);
    if (h >= h0 && h <= h1 && a > best_a) {
      best_a = a;
      best = v;
    }
  }
  return best;
}

/// Transtibial landmarks: anatomical points, from the skin model and the bones, projected onto
/// the skin.
void place_transtibial_landmarks(const SkinModel& skin_model, GeneratedLimb& limb) {
  const LimbFrame& frame = limb.frame;
  const double top = skin_model.top();
  auto on_skin = [&](double theta, double h) { return world(frame, theta, skin_model.radius(theta, h), h); };
  const geometry::SurfaceQuery skin_query(limb.skin);
  auto add = [&](const char* code, const char* name, const Vec3& near, double radius) {
    limb.landmarks.push_back(make_landmark(frame, skin_query, code, name, near, radius));
  };
  const double H = skin_model.knee();
  const NamedMesh* tibia = find_bone(limb.bones, "tibia");
  const NamedMesh* fibula = find_bone(limb.bones, "fibula");
  SOCKETSMITH_ASSERT(tibia != nullptr);
  add("PT", "patellar tendon", on_skin(0.0, H - 0.012), 0.015);
  add("MF", "medial tibial flare", on_skin(60.0 * kDeg, H - 0.03), 0.02);
  add("LF", "lateral tibial flare", on_skin(-55.0 * kDeg, H - 0.035), 0.015);
  if (fibula != nullptr) {
    // Centre of the fibular head: the top 20 mm of the fibula.
    double hmax = -std::numeric_limits<double>::infinity();
    for (const Vec3& v : fibula->mesh.vertices) hmax = std::max(hmax, height_in(frame, v));
    Vec3 c = Vec3::Zero();
    int n = 0;
    for (const Vec3& v : fibula->mesh.vertices)
      if (height_in(frame, v) > hmax - 0.02) {
        c += v;
        ++n;
      }
    const auto cyl = frame.to_cylindrical(c / n);
    add("FH", "fibular head", on_skin(cyl.theta, cyl.h), 0.012);
  }
  add("POP", "popliteal fossa", on_skin(kPi, std::min(H - 0.005, top - 0.005)), 0.025);
  const double tib_low = height_in(frame, lowest_vertex(tibia->mesh, frame));
  const Vec3 distal_crest = most_anterior(tibia->mesh, frame, tib_low, tib_low + 0.015);
  const auto cad = frame.to_cylindrical(distal_crest);
  add("AD", "anterior distal tibia", on_skin(cad.theta, cad.h), 0.015);
  const double h_mid = 0.5 * (tib_low + (H - 0.045));
  const auto ctc = frame.to_cylindrical(most_anterior(tibia->mesh, frame, h_mid - 0.004, h_mid + 0.004));
  add("TC", "tibial crest", on_skin(ctc.theta, h_mid), 0.015);
  add("DT", "distal tibia (end)", lowest_vertex(tibia->mesh, frame), 0.02);
}

/// Transfemoral: the bony points of the femur and the hemipelvis in the truth frame, and the
/// landmarks placed from them by the same rules as a limb model's (landmarks.h).
void place_transfemoral_points_and_landmarks(const TriMesh& closed_skin, double top, GeneratedLimb& limb) {
  const NamedMesh* femur = find_bone(limb.bones, "femur");
  const NamedMesh* pelvis = find_bone(limb.bones, "hemipelvis");
  SOCKETSMITH_ASSERT(femur != nullptr && pelvis != nullptr);
  Vec3 pc = Vec3::Zero();
  for (const auto& v : pelvis->mesh.vertices) pc += v;
  const FemurAxis axis = femur_shaft_axis(femur->mesh, pc / static_cast<double>(pelvis->mesh.vertices.size()));
  limb.transfemoral = transfemoral_points(femur->mesh, axis, pelvis->mesh, limb.frame);
  limb.landmarks = place_transfemoral_landmarks(closed_skin, limb.frame, *limb.transfemoral, top);
  for (auto& l : limb.landmarks) {
    // On the scan-like (open) skin too: the closed skin's side is the same surface below the top.
    l.estimated = false;
  }
}

// (+ 0.0 turns -0.0 into 0.0 for the reader.)

}  // namespace

// -------------------------------------------------------------------------------------------------

GeneratedLimb generate_limb(const LimbShapeParams& params) {
  validate(params);
  const SkinModel skin_model(params);
  GeneratedLimb limb;
  limb.params = params;
  limb.frame = truth_frame(params.side);
  const double top = skin_model.top();
  limb.cut_height_m = top;
  const TriMesh closed_skin = mesh_skin(params, skin_model, limb);
  limb.bones = fit_bones(params, skin_model, closed_skin, limb.frame);
  // Landmarks: anatomical points projected onto the skin.
  if (params.type == LimbType::Transtibial)
    place_transtibial_landmarks(skin_model, limb);
  else
    place_transfemoral_points_and_landmarks(closed_skin, top, limb);
  return limb;
}

TriMesh merge_shells(const GeneratedLimb& limb) {
  TriMesh out = limb.skin;
  for (const auto& b : limb.bones) {
    const int offset = out.num_vertices();
    out.vertices.insert(out.vertices.end(), b.mesh.vertices.begin(), b.mesh.vertices.end());
    for (const auto& t : b.mesh.triangles) out.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  }
  return out;
}

}  // namespace socketsmith::volume
