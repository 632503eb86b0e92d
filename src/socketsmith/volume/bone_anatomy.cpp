#include "socketsmith/volume/bone_anatomy.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>

#include <Eigen/Dense>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/pchip_spline.h"
#include "socketsmith/volume/shape_math.h"

namespace socketsmith::volume {

using Eigen::Vector2d;

namespace {

using shape::clamp01;
using shape::gauss;
using shape::kPi;
using shape::lerp;
using shape::smoothstep;
using shape::wrap_angle;
constexpr double kInf = std::numeric_limits<double>::infinity();

/// Polar radius of an ellipse with semi-axis @p semi_a along phi = 0 and @p semi_m along phi = pi/2.
double ellipse_radius(double phi, double semi_a, double semi_m) {
  const double c = std::cos(phi) / semi_a, s = std::sin(phi) / semi_m;
  return 1.0 / std::sqrt(c * c + s * s);
}

/// The documented range of every BoneTemplateParams field (bone_template.h), in the order they
/// are checked; bone sizes scale with the bone (scaled_bone_sizes), the rest stay.
struct ParamRange {
  const char* field;
  double BoneTemplateParams::*member;
  double lo, hi;
  bool is_size;
};

constexpr ParamRange kParamRanges[] = {
    {"tibia_plateau_width_m", &BoneTemplateParams::tibia_plateau_width_m, 0.05, 0.10, true},
    {"tibia_plateau_depth_m", &BoneTemplateParams::tibia_plateau_depth_m, 0.035, 0.07, true},
    {"tibia_shaft_radius_m", &BoneTemplateParams::tibia_shaft_radius_m, 0.012, 0.026, true},
    {"tibia_distal_radius_m", &BoneTemplateParams::tibia_distal_radius_m, 0.008, 0.02, true},
    {"tibia_end_height_m", &BoneTemplateParams::tibia_end_height_m, 0.012, 0.06, false},
    {"tibia_bevel", &BoneTemplateParams::tibia_bevel, 0.0, 0.8, false},
    {"crest_tissue_m", &BoneTemplateParams::crest_tissue_m, 0.005, 0.03, false},
    {"tibia_medial_shift_m", &BoneTemplateParams::tibia_medial_shift_m, -0.01, 0.01, false},
    {"fibula_head_radius_m", &BoneTemplateParams::fibula_head_radius_m, 0.007, 0.016, true},
    {"fibula_shaft_radius_m", &BoneTemplateParams::fibula_shaft_radius_m, 0.003, 0.01, true},
    {"fibula_shortening_m", &BoneTemplateParams::fibula_shortening_m, 0.01, 0.06, false},
    {"fibula_angle_rad", &BoneTemplateParams::fibula_angle_rad, -2.8, -1.6, false},
    {"femur_condyle_width_m", &BoneTemplateParams::femur_condyle_width_m, 0.055, 0.105, true},
    {"femur_condyle_depth_m", &BoneTemplateParams::femur_condyle_depth_m, 0.04, 0.075, true},
    {"patella_width_m", &BoneTemplateParams::patella_width_m, 0.03, 0.055, true},
    {"patella_height_m", &BoneTemplateParams::patella_height_m, 0.03, 0.055, true},
    {"patella_thickness_m", &BoneTemplateParams::patella_thickness_m, 0.014, 0.026, true},
    {"patella_tissue_m", &BoneTemplateParams::patella_tissue_m, 0.004, 0.02, false},
    {"femur_shaft_radius_m", &BoneTemplateParams::femur_shaft_radius_m, 0.009, 0.02, true},
    {"femur_end_height_m", &BoneTemplateParams::femur_end_height_m, 0.02, 0.09, false},
    {"femur_lateral_fraction", &BoneTemplateParams::femur_lateral_fraction, 0.0, 0.6, false},
    {"femur_anterior_fraction", &BoneTemplateParams::femur_anterior_fraction, -0.2, 0.35, false},
    {"trochanter_height_m", &BoneTemplateParams::trochanter_height_m, 0.0, 0.07, false},
    {"trochanter_prominence_m", &BoneTemplateParams::trochanter_prominence_m, 0.005, 0.03, true},
    {"ischium_radius_m", &BoneTemplateParams::ischium_radius_m, 0.008, 0.02, true},
    {"ischium_offset_m", &BoneTemplateParams::ischium_offset_m, 0.045, 0.1, true},
    {"ischium_angle_rad", &BoneTemplateParams::ischium_angle_rad, -0.8, 0.4, false},
    {"min_ischial_tissue_m", &BoneTemplateParams::min_ischial_tissue_m, 0.005, 0.04, false},
    {"pubic_ramus_length_m", &BoneTemplateParams::pubic_ramus_length_m, 0.06, 0.12, true},
    {"pubic_ramus_angle_rad", &BoneTemplateParams::pubic_ramus_angle_rad, 0.2, 1.0, false},
    {"pubic_ramus_rise_m", &BoneTemplateParams::pubic_ramus_rise_m, 0.015, 0.06, true},
};

}  // namespace

void validate(const BoneTemplateParams& p) {
  for (const ParamRange& r : kParamRanges) {
    const double value = p.*r.member;
    if (!std::isfinite(value) || value < r.lo || value > r.hi)
      fail("BoneTemplateParams: {} = {} is out of range (expected {} to {})", r.field, value, r.lo, r.hi);
  }
}

BoneTemplateParams scaled_bone_sizes(const BoneTemplateParams& params, double factor) {
  require(std::isfinite(factor) && factor > 0.0, "scaled_bone_sizes: factor = {} (expected > 0)", factor);
  BoneTemplateParams p = params;
  for (const ParamRange& r : kParamRanges)
    if (r.is_size) p.*r.member = std::clamp(p.*r.member * factor, r.lo, r.hi);
  return p;
}

namespace detail {
namespace {

// ---------------------------------------------------------------------------------------------
// A smooth centreline coordinate: least-squares polynomial (degree 1 or 2) in h over the control
// heights, continued linearly (value and slope at the ends) outside them.
class SmoothCurve {
 public:
  SmoothCurve() = default;
  SmoothCurve(const std::vector<double>& h, const std::vector<double>& y, int degree = 2) {
    SOCKETSMITH_ASSERT(h.size() == y.size() && h.size() >= 3);
    h0_ = *std::min_element(h.begin(), h.end());
    h1_ = *std::max_element(h.begin(), h.end());
    hm_ = 0.5 * (h0_ + h1_);
    Eigen::MatrixXd A(static_cast<Eigen::Index>(h.size()), 3);
    Eigen::VectorXd b(static_cast<Eigen::Index>(h.size()));
    for (std::size_t i = 0; i < h.size(); ++i) {
      const double x = h[i] - hm_;
      A.row(static_cast<Eigen::Index>(i)) << 1.0, x, degree >= 2 ? x * x : 0.0;
      b(static_cast<Eigen::Index>(i)) = y[i];
    }
    c_ = A.colPivHouseholderQr().solve(b);
    if (degree < 2) c_(2) = 0.0;
  }
  /// Moves the curve by dy.
  void shift(double dy) { c_(0) += dy; }
  double operator()(double h) const {
    const double hc = std::clamp(h, h0_, h1_);
    const double x = hc - hm_;
    const double v = c_(0) + c_(1) * x + c_(2) * x * x;
    const double slope = c_(1) + 2.0 * c_(2) * x;
    return v + slope * (h - hc);
  }

 private:
  double h0_ = 0, h1_ = 0, hm_ = 0;
  Eigen::Vector3d c_ = Eigen::Vector3d::Zero();
};

}  // namespace

std::string bone_name(const char* base, const BonePlacement& placement) { return std::string(base) + placement.name_suffix; }

namespace {

/// What every transtibial bone is placed from: the skin, the parameters and the placement, with
/// the heights of the joint line (H), the skin's ends (T, B) and the tibia's cut (h_end) [m].
struct KneeInputs {
  const SkinRadii& skin;
  const BoneTemplateParams& p;
  const BonePlacement& pl;
  double H, T, B, h_end;

  double S(double theta, double h) const { return skin.radius(theta, h); }
  /// The middle of the skin's medio-lateral width at h [m].
  double mid_ml(double h) const { return 0.5 * (S(0.5 * kPi, h) - S(-0.5 * kPi, h)); }
};

/// The heights of the template, checked: a knee inside the skin with room below it for a tibia.
KneeInputs knee_inputs(const SkinRadii& skin, const BoneTemplateParams& p, const BonePlacement& pl) {
  const double H = pl.knee_height_m, T = skin.top_m, B = skin.bottom_m;
  require(H > B + 0.05 && H <= T + 1e-9,
          "build_bone_template: knee height {:.1f} mm is outside the skin (expected {:.1f} to {:.1f} mm above the "
          "frame origin)",
          H * 1e3, (B + 0.05) * 1e3, T * 1e3);
  // Short stumps: the cut comes down to keep 40 mm of tibia, but stays 12 mm above the skin end.
  const double h_end = std::min(B + p.tibia_end_height_m, H - 0.04);
  require(h_end >= B + 0.012,
          "build_bone_template: the knee at {:.1f} mm leaves no room for 40 mm of tibia 12 mm above the distal end "
          "(expected a knee height of at least 52 mm)",
          (H - B) * 1e3);
  return {skin, p, pl, H, T, B, h_end};
}

/// The residual tibia: a trefoil shaft widening into the plateau, with the tuberosity's bump, on a
/// straight centreline kept the asked crest tissue behind the anterior skin.
BoneShape tibia_shape(const KneeInputs& in) {
  // Copies (the shape's functions outlive this call): a lambda [=] copies what a reference names.
  const BoneTemplateParams& p = in.p;
  const double H = in.H, h_end = in.h_end;
  const double W = p.tibia_plateau_width_m, D = p.tibia_plateau_depth_m;
  const double tib_top = std::min(H, in.T - 0.006);
  const double shaft_ref = H - 0.07;
  auto tibia_radius = [=](double phi, double h) {
    const double u = smoothstep((h - (H - 0.075)) / 0.062);
    const double ts = clamp01((h - h_end) / std::max(1e-3, shaft_ref - h_end));
    const double rs = lerp(p.tibia_distal_radius_m, p.tibia_shaft_radius_m, ts);
    const double shaft = rs * (1.0 + 0.13 * std::cos(3.0 * phi));
    const double plateau = ellipse_radius(phi, 0.5 * D, 0.5 * W) * (1.0 - 0.10 * gauss(wrap_angle(phi - kPi), 0.3));
    return lerp(shaft, plateau, u);
  };
  auto tuberosity = [=](double phi, double h) { return 0.0045 * gauss(wrap_angle(phi), 0.35) * gauss(h - (H - 0.03), 0.010); };
  const double crest_top = std::max(p.crest_tissue_m, 0.024);
  auto crest_tissue = [=](double h) { return lerp(p.crest_tissue_m, crest_top, smoothstep((h - (H - 0.045)) / 0.04)); };
  std::vector<double> hs, as, ms;
  for (int i = 0; i <= 6; ++i) {
    const double h = lerp(h_end + 0.015, tib_top - 0.005, i / 6.0);
    hs.push_back(h);
    as.push_back(in.S(0.0, h) - crest_tissue(h) - tibia_radius(0.0, h));
    ms.push_back(in.mid_ml(h) + p.tibia_medial_shift_m);
  }
  // A straight tibia: the least-squares line, moved back so that no control height has less
  // crest tissue than asked for.
  SmoothCurve tib_a(hs, as, 1);
  const SmoothCurve tib_m(hs, ms, 1);
  double excess = 0.0;
  for (std::size_t i = 0; i < hs.size(); ++i) excess = std::max(excess, tib_a(hs[i]) - as[i]);
  tib_a.shift(-excess);
  BoneShape tibia;
  tibia.name = bone_name("tibia", in.pl);
  tibia.h_bottom = h_end;
  tibia.h_top = tib_top;
  tibia.cap_bottom = 0.006;
  tibia.cap_top = 0.006;
  tibia.centre = [=](double h) { return Vector2d(tib_a(h), tib_m(h)); };
  tibia.radius = [=](double phi, double h) { return tibia_radius(phi, h) + tuberosity(phi, h); };
  tibia.bevel = p.tibia_bevel;
  tibia.columns = 48;
  tibia.rows = 44;
  return tibia;
}

/// The fibula's extent [m] and nominal radius: a shaft 15 % thinner distally, widening into the
/// head over its top 50 mm.
struct FibulaProfile {
  double f_end, f_top, rh, rf;

  double mean_radius(double h) const {
    return rf * lerp(0.85, 1.0, clamp01((h - f_end) / (f_top - f_end))) +
           (rh - rf) * smoothstep((h - (f_top - 0.05)) / 0.028);
  }
};

/// A plane section where the fibula is fitted: its height, the fibula's nominal outer radius, the
/// tibia's centre and its outline as a polygon.
constexpr int kFibulaSection = 72;
struct FibulaLevel {
  double h, rout;
  Vector2d ct;
  std::array<Vector2d, kFibulaSection> tibia;
};

/// Ten sections from just above the fibula's distal end to just below its head.
std::vector<FibulaLevel> fibula_levels(const FibulaProfile& f, const BoneShape& tibia) {
  std::vector<FibulaLevel> levels;
  for (int i = 0; i <= 9; ++i) {
    FibulaLevel l;
    l.h = lerp(f.f_end + 0.008, f.f_top - 0.006, i / 9.0);
    l.ct = tibia.centre(l.h);
    l.rout = 1.08 * f.mean_radius(l.h);
    for (int j = 0; j < kFibulaSection; ++j) {
      const double phi = 2.0 * kPi * j / kFibulaSection;
      l.tibia[static_cast<std::size_t>(j)] = l.ct + tibia.radius(phi, l.h) * Vector2d(std::cos(phi), std::sin(phi));
    }
    levels.push_back(l);
  }
  return levels;
}

/// Distance from q to the tibia's outline in section @p l [m].
double tibia_distance(const FibulaLevel& l, const Vector2d& q) {
  double best = kInf;
  for (int j = 0; j < kFibulaSection; ++j) {
    const Vector2d& a0 = l.tibia[static_cast<std::size_t>(j)];
    const Vector2d& a1 = l.tibia[static_cast<std::size_t>((j + 1) % kFibulaSection)];
    const Vector2d e = a1 - a0;
    const double t = std::clamp((q - a0).dot(e) / e.squaredNorm(), 0.0, 1.0);
    best = std::min(best, (a0 + t * e - q).norm());
  }
  return best;
}

/// The least radial tissue between a circle (centre q, radius r) and the skin at the section's height [m].
double skin_tissue(const SkinRadii& skin, const FibulaLevel& l, const Vector2d& q, double r) {
  double best = kInf;
  for (int j = 0; j < 24; ++j) {
    const double phi = 2.0 * kPi * j / 24;
    const Vector2d x = q + r * Vector2d(std::cos(phi), std::sin(phi));
    best = std::min(best, skin.radius(std::atan2(x.y(), x.x()), l.h) - x.norm());
  }
  return best;
}

/// The largest value in [lo, hi] where @p ok_below still holds (it holds below some value, not above).
double bisect(const std::function<bool(double)>& ok_below, double lo, double hi) {
  for (int it = 0; it < 40; ++it) {
    const double mid = 0.5 * (lo + hi);
    (ok_below(mid) ? lo : hi) = mid;
  }
  return lo;
}

/// The distances from the tibia centre along a direction where a fibula circle fits: at least 3 mm
/// from the tibia (d_min) and 6 mm inside the skin (d_max) [m]; it fits nowhere when d_max < d_min.
struct FibulaFit {
  double d_min, d_max;
};

/// Along a ray the tibia distance grows and the tissue shrinks with the distance d, so each bound is a bisection.
FibulaFit fit_along(const SkinRadii& skin, const FibulaLevel& l, const Vector2d& dir, double r) {
  return FibulaFit{bisect([&](double d) { return tibia_distance(l, l.ct + d * dir) < 0.003 + r; }, 0.0, 0.2),
                   bisect([&](double d) { return skin_tissue(skin, l, l.ct + d * dir, r) >= 0.006; }, 0.0, 0.2)};
}

/// The direction the fibula slides out along in every section: the one closest to @p phi_f
/// (within ±12°, by 4°) where the nominal fibula fits at every level, else the roomiest one.
Vector2d fibula_direction(const SkinRadii& skin, const std::vector<FibulaLevel>& levels, double phi_f) {
  auto direction = [&](int step) {
    const double phi = phi_f + step * 4.0 * kPi / 180.0;
    return Vector2d(std::cos(phi), std::sin(phi));
  };
  double best_slack = -kInf;
  Vector2d dir = direction(0);
  for (const int step : {0, 1, -1, 2, -2, 3, -3}) {
    double slack = kInf;
    for (const FibulaLevel& l : levels) {
      const FibulaFit f = fit_along(skin, l, direction(step), l.rout);
      slack = std::min(slack, f.d_max - f.d_min);
    }
    if (slack > best_slack) {
      best_slack = slack;
      dir = direction(step);
    }
    if (best_slack >= 0.0) break;
  }
  return dir;
}

/// The fibula's centreline (a, m) and radius factor k per section height h.
struct FibulaCentreline {
  std::vector<double> h, a, m, k;
};

/// In each section the fibula sits at the preferred (anatomical) gap from the tibia where the fit
/// allows it, narrowed where it does not fit (at most to half size; the clearance fit shrinks further).
FibulaCentreline fibula_centreline(const SkinRadii& skin, const std::vector<FibulaLevel>& levels, const Vector2d& dir,
                                   double f_top) {
  FibulaCentreline c;
  for (const FibulaLevel& l : levels) {
    double r = l.rout;
    FibulaFit f = fit_along(skin, l, dir, r);
    if (f.d_max < f.d_min) {
      r = bisect([&](double rr) { const FibulaFit g = fit_along(skin, l, dir, rr); return g.d_max >= g.d_min; },
                 0.5 * l.rout, l.rout);
      f = fit_along(skin, l, dir, r);
    }
    const double gap_pref = lerp(0.010, 0.003, smoothstep((l.h - (f_top - 0.06)) / 0.04));
    const double d_pref = bisect([&](double d) { return tibia_distance(l, l.ct + d * dir) < gap_pref + r; }, 0.0, 0.2);
    const double d = std::clamp(d_pref, f.d_min, std::max(f.d_min, f.d_max));
    c.h.push_back(l.h);
    c.a.push_back(l.ct.x() + d * dir.x());
    c.m.push_back(l.ct.y() + d * dir.y());
    c.k.push_back(r / l.rout);
  }
  return c;
}

/// Fibula: postero-lateral of the tibia, head just below the lateral condyle. In each plane
/// section its circle slides out from the tibia centre along one direction near
/// fibula_angle_rad; it must stay 3 mm from the tibia section (preferably the anatomical gap) and
/// 6 mm (radially) inside the skin section. None when the residual tibia is too short to keep 30 mm
/// of fibula (as surgeons do on very short stumps).
std::optional<BoneShape> fibula_shape(const KneeInputs& in, const BoneShape& tibia) {
  const FibulaProfile prof{in.h_end + in.p.fibula_shortening_m, std::min(in.H - 0.016, in.T - 0.01),
                           in.p.fibula_head_radius_m, in.p.fibula_shaft_radius_m};
  if (!(prof.f_top - prof.f_end >= 0.03)) return std::nullopt;
  const std::vector<FibulaLevel> levels = fibula_levels(prof, tibia);
  const Vector2d dir = fibula_direction(in.skin, levels, in.p.fibula_angle_rad);
  const FibulaCentreline c = fibula_centreline(in.skin, levels, dir, prof.f_top);
  const geometry::PchipSpline fib_a(c.h, c.a), fib_m(c.h, c.m), fib_k(c.h, c.k);
  BoneShape fibula;
  fibula.name = bone_name("fibula", in.pl);
  fibula.h_bottom = prof.f_end;
  fibula.h_top = prof.f_top;
  fibula.cap_bottom = 0.004;
  fibula.cap_top = std::min(0.009, 0.8 * prof.rh);
  fibula.centre = [=](double h) { return Vector2d(fib_a(h), fib_m(h)); };
  fibula.radius = [=](double phi, double h) {
    return std::clamp(fib_k(h), 0.5, 1.0) * prof.mean_radius(h) * (1.0 + 0.08 * std::cos(3.0 * phi));
  };
  fibula.columns = 28;
  fibula.rows = 48;
  return fibula;
}

/// Where the patella sits, when the skin extends far enough above the joint line: from 12 mm above
/// it up its height [m], its centre behind the skin's anterior tissue.
struct PatellaPlacement {
  bool present;
  double h_bottom, h_top;
  Vector2d centre;
};

PatellaPlacement place_patella(const KneeInputs& in) {
  const BoneTemplateParams& p = in.p;
  PatellaPlacement pp{in.T - in.H >= 0.012 + p.patella_height_m + 0.008, in.H + 0.012, 0.0, Vector2d(0.0, 0.0)};
  pp.h_top = pp.h_bottom + p.patella_height_m;
  if (pp.present) {
    const double hpc = 0.5 * (pp.h_bottom + pp.h_top);
    pp.centre = Vector2d(in.S(0.0, hpc) - p.patella_tissue_m - 0.5 * p.patella_thickness_m, in.mid_ml(hpc));
  }
  return pp;
}

/// The patella: an elliptical disc, pointed at its inferior pole.
BoneShape patella_shape(const KneeInputs& in, const PatellaPlacement& pp) {
  const BoneTemplateParams& p = in.p;
  const Vector2d patella_centre = pp.centre;
  BoneShape patella;
  patella.name = bone_name("patella", in.pl);
  patella.h_bottom = pp.h_bottom;
  patella.h_top = pp.h_top;
  patella.cap_bottom = 0.55 * p.patella_height_m;  // the inferior pole (apex) is the pointed end
  patella.cap_top = 0.45 * p.patella_height_m;
  patella.centre = [=](double) { return patella_centre; };
  patella.radius = [=](double phi, double) {
    return ellipse_radius(phi, 0.5 * p.patella_thickness_m, 0.5 * p.patella_width_m);
  };
  patella.columns = 44;
  patella.rows = 34;
  return patella;
}

/// The distal femur above the joint line: condyles (with their notch) narrowing into the shaft,
/// kept behind the tibia's front at the knee and 4 mm behind the patella.
BoneShape knee_femur_shape(const KneeInputs& in, const BoneShape& tibia, const PatellaPlacement& pp) {
  const BoneTemplateParams& p = in.p;
  const double H = in.H;
  const double fem_bottom = H + 0.004, fem_top = in.T - 0.008;
  const double Wf = p.femur_condyle_width_m, Df = p.femur_condyle_depth_m, rfs = p.femur_shaft_radius_m;
  auto femur_radius = [=](double phi, double h) {
    const double u = smoothstep((h - (H + 0.035)) / 0.045);
    const double condyles = ellipse_radius(phi, 0.5 * Df, 0.5 * Wf) * (1.0 - 0.22 * gauss(wrap_angle(phi - kPi), 0.25)) *
                            (1.0 - 0.06 * gauss(wrap_angle(phi), 0.3));
    const double shaft = rfs * (1.0 + 0.08 * gauss(wrap_angle(phi - kPi), 0.3));
    return lerp(condyles, shaft, u);
  };
  double a_f = tibia.centre(H).x() - 0.002;
  if (pp.present)
    for (int i = 0; i <= 8; ++i) {
      const double h = lerp(pp.h_bottom, pp.h_top, i / 8.0);
      a_f = std::min(a_f, pp.centre.x() - 0.5 * p.patella_thickness_m - 0.004 - femur_radius(0.0, h));
    }
  const Vector2d femur_centre(a_f, in.mid_ml(H + 0.03) + 0.002);
  BoneShape femur;
  femur.name = bone_name("femur", in.pl);
  femur.h_bottom = fem_bottom;
  femur.h_top = fem_top;
  femur.cap_bottom = std::min(0.014, 0.5 * (fem_top - fem_bottom));
  femur.cap_top = std::min(0.006, 0.25 * (fem_top - fem_bottom));
  femur.centre = [=](double) { return femur_centre; };
  femur.radius = femur_radius;
  femur.columns = 48;
  femur.rows = 32;
  return femur;
}

}  // namespace

std::vector<BoneShape> transtibial_bone_shapes(const SkinRadii& skin, const BoneTemplateParams& p, const BonePlacement& pl) {
  const KneeInputs in = knee_inputs(skin, p, pl);
  const BoneShape tibia = tibia_shape(in);
  std::vector<BoneShape> shapes{tibia};
  if (std::optional<BoneShape> fibula = fibula_shape(in, tibia)) shapes.push_back(*fibula);
  // Patella and distal femur, when the skin extends above the joint line.
  const PatellaPlacement patella = place_patella(in);
  if (patella.present) shapes.push_back(patella_shape(in, patella));
  if (in.T - in.H >= 0.035) shapes.push_back(knee_femur_shape(in, tibia, patella));
  return shapes;
}

std::vector<BoneShape> transfemoral_bone_shapes(const SkinRadii& skin, const BoneTemplateParams& p, const BonePlacement& pl) {
  const double T = skin.top_m, B = skin.bottom_m;
  auto S = [&](double theta, double h) { return skin.radius(theta, h); };
  // Short stumps: the cut comes down to keep 50 mm of femur, but stays 15 mm above the skin end.
  const double top = T - 0.008;
  const double h_end = std::min(B + p.femur_end_height_m, top - 0.05);
  require(h_end >= B + 0.015,
          "build_bone_template: the skin is {:.1f} mm long, too short for 50 mm of femur 15 mm above the distal end "
          "(expected at least 73 mm)",
          (T - B) * 1e3);
  const double rfs = p.femur_shaft_radius_m;
  // Widening towards the trochanters: at the top of the skin, or from the ischial tuberosity's
  // level up when it is known (the lesser trochanter lies about level with it).
  const double hi_t = pl.ischial_height_m;
  const bool has_trochanter = hi_t >= 0.0;
  const double widen_from = has_trochanter ? hi_t - 0.01 : T - 0.07;
  const double widen_over = has_trochanter ? 0.05 : 0.06;
  auto mean = [=](double h) { return rfs * (1.0 + 0.35 * smoothstep((h - widen_from) / widen_over)); };
  std::vector<double> hs, as, ms;
  for (int i = 0; i <= 6; ++i) {
    const double h = lerp(h_end + 0.01, top - 0.01, i / 6.0);
    const double lat = lerp(0.5 * p.femur_lateral_fraction, p.femur_lateral_fraction, clamp01((h - h_end) / (top - h_end)));
    hs.push_back(h);
    as.push_back(p.femur_anterior_fraction * S(0.0, h));
    ms.push_back(0.5 * (S(0.5 * kPi, h) - S(-0.5 * kPi, h)) - lat * S(-0.5 * kPi, h));
  }
  const SmoothCurve fa(hs, as), fm(hs, ms);
  BoneShape femur;
  femur.name = bone_name("femur", pl);
  femur.h_bottom = h_end;
  femur.h_top = top;
  femur.cap_bottom = 0.008;
  femur.cap_top = 0.008;
  femur.centre = [=](double h) { return Vector2d(fa(h), fm(h)); };
  const double h_gt = hi_t + p.trochanter_height_m, gt = has_trochanter ? p.trochanter_prominence_m : 0.0;
  // The greater trochanter stands out postero-laterally (phi = -90° - 17°).
  femur.radius = [=](double phi, double h) {
    return mean(h) * (1.0 + 0.10 * gauss(wrap_angle(phi - kPi), 0.25)) +
           gt * gauss(wrap_angle(phi + 0.5 * kPi + 0.3), 0.6) * gauss(h - h_gt, 0.014);
  };
  femur.columns = 40;
  femur.rows = 60;
  return {femur};
}

}  // namespace detail
}  // namespace socketsmith::volume
