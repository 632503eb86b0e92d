#include "socketsmith/design/brim.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <numbers>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"

namespace socketsmith::design {
namespace {

using geometry::LimbType;
constexpr double kDeg = units::deg, kMm = units::mm;

struct NamedTemplate {
  BrimTemplate kind;
  const char* name;
};
constexpr std::array<NamedTemplate, 8> kNames{{{BrimTemplate::Ptb, "ptb"},
                                               {BrimTemplate::PtbSc, "ptb-sc"},
                                               {BrimTemplate::PtbScsp, "ptb-scsp"},
                                               {BrimTemplate::Kbm, "kbm"},
                                               {BrimTemplate::Tsb, "tsb"},
                                               {BrimTemplate::Quad, "quad"},
                                               {BrimTemplate::Ics, "ics"},
                                               {BrimTemplate::Custom, "custom"}}};

std::string names_of(LimbType type) {
  std::string out;
  for (const auto& n : kNames)
    if (n.kind != BrimTemplate::Custom && limb_type_of(n.kind) == type) out += (out.empty() ? "" : ", ") + std::string(n.name);
  return out;
}

geometry::PeriodicAkimaSpline build_spline(const std::vector<BrimKeyPoint>& points) {
  std::vector<double> th, h;
  for (const auto& p : points) {
    th.push_back(p.theta);
    h.push_back(p.h);
  }
  try {
    return geometry::PeriodicAkimaSpline(th, h);
  } catch (const InvalidInputError& e) {
    fail("brim line: {}", e.what());
  }
}

const volume::Landmark& landmark(const std::vector<volume::Landmark>& landmarks, const std::string& code,
                                 BrimTemplate kind) {
  for (const auto& l : landmarks)
    if (l.code == code) return l;
  fail("make_brim: template '{}' needs landmark {}, which the limb does not have; place it (\"landmarks\": "
       "{{\"{}\": [x, y, z]}} in a case file, --landmark {}=x,y,z on the command line)",
       to_string(kind), code, code, code);
}

/// Key point (θ in degrees, h in metres).
BrimKeyPoint kp(const char* label, double theta_deg, double h) { return {label, theta_deg * kDeg, h}; }

/// make_brim's preconditions: a real template of the limb's type, a cut height and options in range.
void check_brim_request(BrimTemplate kind, LimbType type, double cut_height_m, const BrimOptions& options) {
  require(kind != BrimTemplate::Custom,
          "make_brim: 'custom' is not a template; give the key points (brim_from_key_points) or pick one of {}",
          names_of(type));
  require(limb_type_of(kind) == type, "make_brim: brim '{}' is a {} template but the limb is {}; use one of {}",
          to_string(kind), geometry::to_string(limb_type_of(kind)), geometry::to_string(type), names_of(type));
  require(std::isfinite(cut_height_m) && cut_height_m > 0.0,
          "make_brim: cut height {} m is not positive (expected the limb's cut above its distal end)", cut_height_m);
  require(options.top_margin_m >= 0.0 && options.top_margin_m < 0.5 * cut_height_m,
          "make_brim: top_margin_m = {} m is out of range [0, half the cut height {} m]", options.top_margin_m,
          0.5 * cut_height_m);
  require(options.min_height_fraction >= 0.0 && options.min_height_fraction < 1.0,
          "make_brim: min_height_fraction = {} is out of range [0, 1)", options.min_height_fraction);
}

/// Where a transtibial key point's height is measured from.
enum class HeightFrom {
  Pt,        ///< the patellar tendon landmark (PT)
  KneeLine,  ///< the knee joint line, 10 mm above the popliteal crease (POP)
};

/// One key point of a transtibial template: its angle [deg, anterior 0, medial +] and its height
/// [mm] above PT or the knee joint line.
struct TranstibialKeyPoint {
  BrimTemplate kind;
  const char* label;
  double theta_deg;
  HeightFrom from;
  double above_mm;
};

// The transtibial templates, key point by key point (docs/socket_builder.md).
constexpr TranstibialKeyPoint kTranstibialKeyPoints[] = {
    {BrimTemplate::Ptb, "anterior (mid-patella)", 0, HeightFrom::Pt, 30},
    {BrimTemplate::Ptb, "antero-medial", 35, HeightFrom::Pt, 30},
    {BrimTemplate::Ptb, "medial wing (condyle)", 80, HeightFrom::KneeLine, 20},
    {BrimTemplate::Ptb, "postero-medial", 110, HeightFrom::KneeLine, 5},
    {BrimTemplate::Ptb, "medial hamstring relief", 145, HeightFrom::Pt, 0},
    {BrimTemplate::Ptb, "posterior (popliteal)", 180, HeightFrom::Pt, 10},
    {BrimTemplate::Ptb, "lateral hamstring relief", -145, HeightFrom::Pt, 5},
    {BrimTemplate::Ptb, "postero-lateral", -110, HeightFrom::KneeLine, 5},
    {BrimTemplate::Ptb, "lateral wing (condyle)", -80, HeightFrom::KneeLine, 20},
    {BrimTemplate::Ptb, "antero-lateral", -35, HeightFrom::Pt, 30},
    {BrimTemplate::PtbSc, "anterior (mid-patella)", 0, HeightFrom::Pt, 30},
    {BrimTemplate::PtbSc, "antero-medial", 35, HeightFrom::Pt, 35},
    {BrimTemplate::PtbSc, "medial wing (supracondylar)", 80, HeightFrom::KneeLine, 50},
    {BrimTemplate::PtbSc, "postero-medial", 110, HeightFrom::KneeLine, 15},
    {BrimTemplate::PtbSc, "medial hamstring relief", 145, HeightFrom::Pt, 0},
    {BrimTemplate::PtbSc, "posterior (popliteal)", 180, HeightFrom::Pt, 10},
    {BrimTemplate::PtbSc, "lateral hamstring relief", -145, HeightFrom::Pt, 5},
    {BrimTemplate::PtbSc, "postero-lateral", -110, HeightFrom::KneeLine, 15},
    {BrimTemplate::PtbSc, "lateral wing (supracondylar)", -80, HeightFrom::KneeLine, 50},
    {BrimTemplate::PtbSc, "antero-lateral", -35, HeightFrom::Pt, 35},
    {BrimTemplate::PtbScsp, "anterior (suprapatellar)", 0, HeightFrom::KneeLine, 55},
    {BrimTemplate::PtbScsp, "antero-medial", 35, HeightFrom::KneeLine, 50},
    {BrimTemplate::PtbScsp, "medial wing (supracondylar)", 80, HeightFrom::KneeLine, 55},
    {BrimTemplate::PtbScsp, "postero-medial", 115, HeightFrom::KneeLine, 15},
    {BrimTemplate::PtbScsp, "medial hamstring relief", 145, HeightFrom::Pt, 0},
    {BrimTemplate::PtbScsp, "posterior (popliteal)", 180, HeightFrom::Pt, 10},
    {BrimTemplate::PtbScsp, "lateral hamstring relief", -145, HeightFrom::Pt, 5},
    {BrimTemplate::PtbScsp, "postero-lateral", -115, HeightFrom::KneeLine, 15},
    {BrimTemplate::PtbScsp, "lateral wing (supracondylar)", -80, HeightFrom::KneeLine, 55},
    {BrimTemplate::PtbScsp, "antero-lateral", -35, HeightFrom::KneeLine, 50},
    {BrimTemplate::Kbm, "anterior (below the patella)", 0, HeightFrom::Pt, 10},
    {BrimTemplate::Kbm, "antero-medial", 30, HeightFrom::Pt, 15},
    {BrimTemplate::Kbm, "medial wing (over the condyle)", 80, HeightFrom::KneeLine, 50},
    {BrimTemplate::Kbm, "postero-medial", 110, HeightFrom::KneeLine, 20},
    {BrimTemplate::Kbm, "medial hamstring relief", 145, HeightFrom::Pt, 0},
    {BrimTemplate::Kbm, "posterior (popliteal)", 180, HeightFrom::Pt, 10},
    {BrimTemplate::Kbm, "lateral hamstring relief", -145, HeightFrom::Pt, 5},
    {BrimTemplate::Kbm, "postero-lateral", -110, HeightFrom::KneeLine, 20},
    {BrimTemplate::Kbm, "lateral wing (over the condyle)", -80, HeightFrom::KneeLine, 50},
    {BrimTemplate::Kbm, "antero-lateral", -30, HeightFrom::Pt, 15},
    {BrimTemplate::Tsb, "anterior", 0, HeightFrom::KneeLine, 25},
    {BrimTemplate::Tsb, "antero-medial", 40, HeightFrom::KneeLine, 25},
    {BrimTemplate::Tsb, "medial", 85, HeightFrom::KneeLine, 30},
    {BrimTemplate::Tsb, "postero-medial", 130, HeightFrom::KneeLine, 15},
    {BrimTemplate::Tsb, "posterior", 180, HeightFrom::KneeLine, 5},
    {BrimTemplate::Tsb, "postero-lateral", -130, HeightFrom::KneeLine, 15},
    {BrimTemplate::Tsb, "lateral", -85, HeightFrom::KneeLine, 30},
    {BrimTemplate::Tsb, "antero-lateral", -40, HeightFrom::KneeLine, 25},
};

/// A transtibial template's key points, heights from the patellar tendon (PT) and the knee joint
/// line (10 mm above the popliteal crease, POP).
std::vector<BrimKeyPoint> transtibial_key_points(BrimTemplate kind, const std::vector<volume::Landmark>& landmarks) {
  const double pt = landmark(landmarks, "PT", kind).cylindrical.h;
  const double knee_line = landmark(landmarks, "POP", kind).cylindrical.h + 10 * kMm;
  std::vector<BrimKeyPoint> points;
  for (const TranstibialKeyPoint& p : kTranstibialKeyPoints) {
    if (p.kind != kind) continue;
    const double base = p.from == HeightFrom::Pt ? pt : knee_line;
    points.push_back(kp(p.label, p.theta_deg, base + p.above_mm * kMm));
  }
  return points;
}

/// A transfemoral template's key points (quadrilateral or ischial containment).
std::vector<BrimKeyPoint> transfemoral_key_points(BrimTemplate kind, const std::vector<volume::Landmark>& landmarks) {
  // Placed from the bony landmarks: heights from the ischial tuberosity i and the greater
  // trochanter g, angles from the landmarks themselves (docs/socket_builder.md).
  const auto& L_is = landmark(landmarks, "IS", kind).cylindrical;
  const auto& L_gt = landmark(landmarks, "GT", kind).cylindrical;
  const auto& L_al = landmark(landmarks, "AL", kind).cylindrical;
  const auto& L_st = landmark(landmarks, "ST", kind).cylindrical;
  const double i = L_is.h, g = L_gt.h, mm = kMm;
  const double deg = kDeg;
  // Angles in degrees, kept apart so the spline's key points stay in order.
  const double t_st = std::clamp(L_st.theta / deg, 5.0, 40.0);
  const double t_al = std::clamp(L_al.theta / deg, t_st + 15.0, 80.0);
  const double t_is = std::clamp(L_is.theta / deg, t_al + 20.0, 150.0);
  const double t_ramus = 0.5 * (t_al + t_is);
  const double t_contain = std::min(t_is + 25.0, 165.0);
  const double t_gt = std::clamp(L_gt.theta / deg, -120.0, -60.0);
  if (kind == BrimTemplate::Quad)
    return {kp("anterior (Scarpa's bulge)", t_st, i + 65 * mm), kp("antero-medial (adductor channel)", t_al, i + 30 * mm),
            kp("medial wall", t_ramus, i), kp("ischial seat", t_contain, i), kp("posterior (seat)", 180, i),
            kp("postero-lateral", -135, i + 20 * mm), kp("lateral wall", t_gt, std::max(g + 10 * mm, i + 45 * mm)),
            kp("antero-lateral", -40, i + 65 * mm)};
  return {kp("anterior (Scarpa's triangle)", t_st, i + 25 * mm), kp("adductor longus relief", t_al, i + 5 * mm),
          kp("ramal containment (medial)", t_ramus, i + 35 * mm),
          kp("ischial containment (postero-medial)", t_contain, i + 50 * mm), kp("posterior (gluteal)", 180, i + 30 * mm),
          kp("postero-lateral", -135, i + 30 * mm),
          kp("lateral wall (over the trochanter)", t_gt, std::clamp(g + 15 * mm, i + 20 * mm, i + 45 * mm)),
          kp("antero-lateral", -40, i + 30 * mm)};
}

/// Clamps each key point's height into [lo_m, hi_m] (within the stump), with a note for each moved.
void clamp_key_points_to_stump(std::vector<BrimKeyPoint>& p, BrimTemplate kind, double lo_m, double hi_m,
                               double cut_height_m, std::vector<std::string>* notes) {
  for (auto& q : p) {
    const double h = std::clamp(q.h, lo_m, hi_m);
    if (notes && std::abs(h - q.h) > 1e-6)
      notes->push_back(fmt::format("brim '{}': key point '{}' clamped from {:.0f} to {:.0f} mm ({} the stump, which ends "
                                   "at {:.0f} mm)",
                                   to_string(kind), q.label, q.h / kMm, h / kMm, h < q.h ? "below the top of" : "within",
                                   cut_height_m / kMm));
    q.h = h;
  }
}

/// The brim through the key points, its heights scaled down about lo_m while the curve between
/// them rises above hi_m (transtibial only).
BrimLine fit_brim_below_top(BrimTemplate kind, LimbType type, std::vector<BrimKeyPoint> p, double lo_m, double hi_m,
                            double top_margin_m, std::vector<std::string>* notes) {
  const double lo = lo_m, hi = hi_m;  // the band the key points were clamped to
  // Key points within [lo, hi] do not keep the curve there: the periodic Akima spline rises between
  // two key points at the same height when steeper neighbours bend it (several clamped to hi on a
  // short transtibial stump: 5.5 mm above hi, and the socket could not be built). The spline is
  // affine in its values, so scaling the heights about lo by (hi − lo) / (max − lo) brings its top
  // to hi; a second pass covers the sampling of max_height. Transtibial templates only: a
  // transfemoral brim is placed from the ischial tuberosity, whose seat must stay where it is (on
  // the OpenLimbTF limb a 1.3 % scaling of the quadrilateral brim took its ischial share from 30 %
  // to 8 %), and its stump is continued 75 mm above the tuberosity, so no key point reaches hi.
  BrimLine line(kind, p);
  for (int pass = 0; type == LimbType::Transtibial && pass < 3 && line.max_height() > hi; ++pass) {
    const double top = line.max_height(), f = (hi - lo) / (top - lo);
    for (auto& q : p) q.h = lo + f * (q.h - lo);
    if (notes && pass == 0)
      notes->push_back(fmt::format("brim '{}': the curve between the key points rose to {:.1f} mm, above {:.1f} mm (the "
                                   "top of the stump less {:.0f} mm): its heights scaled by {:.3f} about {:.0f} mm",
                                   to_string(kind), top / kMm, hi / kMm, top_margin_m / kMm, f, lo / kMm));
    line = BrimLine(kind, p);
  }
  return line;
}

}  // namespace

std::string to_string(BrimTemplate kind) {
  for (const auto& n : kNames)
    if (n.kind == kind) return n.name;
  return "custom";
}

BrimTemplate parse_brim_template(const std::string& text) {
  std::string lower = text;
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
  for (const auto& n : kNames)
    if (lower == n.name) return n.kind;
  if (lower == "quadrilateral") return BrimTemplate::Quad;  // the socket's full name, as prosthetists write it
  fail("brim template '{}' is not known (valid: ptb, ptb-sc, ptb-scsp, kbm, tsb, quad, ics, custom; quadrilateral = quad)",
       text);
}

LimbType limb_type_of(BrimTemplate kind) {
  switch (kind) {
    case BrimTemplate::Quad:
    case BrimTemplate::Ics:
      return LimbType::Transfemoral;
    case BrimTemplate::Custom:
      fail("brim template 'custom' has no limb type (it is made of explicit key points)");
    default:
      return LimbType::Transtibial;
  }
}

BrimLine::BrimLine(BrimTemplate kind, std::vector<BrimKeyPoint> key_points)
    : kind_(kind), points_(std::move(key_points)), spline_(build_spline(points_)) {}

double BrimLine::min_height() const {
  double v = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 720; ++k) v = std::min(v, height(-std::numbers::pi + k * std::numbers::pi / 360));
  return v;
}

double BrimLine::max_height() const {
  double v = -std::numeric_limits<double>::infinity();
  for (int k = 0; k < 720; ++k) v = std::max(v, height(-std::numbers::pi + k * std::numbers::pi / 360));
  return v;
}

void BrimLine::move_key_point(int index, double theta, double h) {
  require(index >= 0 && index < static_cast<int>(points_.size()),
          "BrimLine::move_key_point: index {} is out of range (the brim has {} key points)", index, points_.size());
  std::vector<BrimKeyPoint> moved = points_;
  moved[index].theta = theta;
  moved[index].h = h;
  set_key_points(std::move(moved));
}

void BrimLine::set_key_points(std::vector<BrimKeyPoint> key_points) {
  geometry::PeriodicAkimaSpline s = build_spline(key_points);  // throws before anything changes
  points_ = std::move(key_points);
  spline_ = std::move(s);
  edited_ = true;
}

BrimLine make_brim(BrimTemplate kind, LimbType type, const std::vector<volume::Landmark>& landmarks,
                   double cut_height_m, const BrimOptions& options, std::vector<std::string>* notes) {
  check_brim_request(kind, type, cut_height_m, options);
  std::vector<BrimKeyPoint> p = type == LimbType::Transtibial ? transtibial_key_points(kind, landmarks)
                                                              : transfemoral_key_points(kind, landmarks);
  const double lo = options.min_height_fraction * cut_height_m, hi = cut_height_m - options.top_margin_m;
  clamp_key_points_to_stump(p, kind, lo, hi, cut_height_m, notes);
  return fit_brim_below_top(kind, type, std::move(p), lo, hi, options.top_margin_m, notes);
}

BrimLine make_brim(BrimTemplate kind, const volume::LimbModel& model, const BrimOptions& options,
                   std::vector<std::string>* notes) {
  return make_brim(kind, model.type, model.landmarks, model.cut_height_m, options, notes);
}

BrimTemplate default_brim(geometry::LimbType type) {
  return type == LimbType::Transfemoral ? BrimTemplate::Ics : BrimTemplate::Ptb;
}

BrimLine brim_from_key_points(std::vector<BrimKeyPoint> key_points, BrimTemplate kind) {
  return BrimLine(kind, std::move(key_points));
}

void validate_brim(const BrimLine& brim, const geometry::TriMesh& skin, const geometry::LimbFrame& frame,
                   const BrimValidationOptions& options) {
  require(!brim.spline().empty(), "validate_brim: the brim has no key points (pick a template or give key points)");
  require(!skin.empty(), "validate_brim: the skin has no triangles");
  require(options.min_enclosed_fraction > 0.0 && options.min_enclosed_fraction <= 1.0,
          "validate_brim: min_enclosed_fraction = {} is out of range (0, 1]", options.min_enclosed_fraction);
  std::vector<geometry::Cylindrical> c(skin.vertices.size());
  double top = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < c.size(); ++i) {
    c[i] = frame.to_cylindrical(skin.vertices[i]);
    top = std::max(top, c[i].h);
  }
  const auto& pts = brim.key_points();
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const auto& q = pts[i];
    const std::string label = q.label.empty() ? "" : " '" + q.label + "'";
    require(q.h <= top - options.top_margin_m,
            "validate_brim: brim key point {}{} at h = {:.1f} mm is above the top of the skin ({:.1f} mm); "
            "lower it below {:.1f} mm",
            i, label, q.h / kMm, top / kMm, (top - options.top_margin_m) / kMm);
    require(q.h > 0.0,
            "validate_brim: brim key point {}{} at h = {:.1f} mm is at or below the distal end of the limb; "
            "raise it (h is measured from the distal end)",
            i, label, q.h / kMm);
  }
  // Side area (the flat proximal cap, if any, is left out: it is never inside the socket).
  double side = 0.0, below = 0.0;
  const double cap_tol = 1e-6;
  for (int t = 0; t < skin.num_triangles(); ++t) {
    const auto& tri = skin.triangles[t];
    if (c[tri[0]].h >= top - cap_tol && c[tri[1]].h >= top - cap_tol && c[tri[2]].h >= top - cap_tol) continue;
    const double a = geometry::triangle_area(skin, t);
    side += a;
    const Eigen::Vector3d centroid = (skin.vertices[tri[0]] + skin.vertices[tri[1]] + skin.vertices[tri[2]]) / 3.0;
    if (!above_brim(brim, centroid, frame)) below += a;
  }
  const double fraction = side > 0 ? below / side : 0.0;
  require(fraction >= options.min_enclosed_fraction,
          "validate_brim: only {:.0f} % of the skin lies below the brim (at least {:.0f} % expected; lowest point "
          "h = {:.1f} mm); raise the brim's key points",
          100 * fraction, 100 * options.min_enclosed_fraction, brim.min_height() / kMm);
}

bool above_brim(const BrimLine& brim, const Eigen::Vector3d& p, const geometry::LimbFrame& frame) {
  const geometry::Cylindrical c = frame.to_cylindrical(p);
  return c.h > brim.height(c.theta);
}

double eased_lift(const std::vector<BrimLift>& lifts, double plateau_rad, double theta) {
  double lift = 0.0;
  for (const BrimLift& l : lifts) {
    if (l.lift_m <= 0.0) continue;
    const double d = std::abs(std::remainder(theta - l.theta, 2.0 * std::numbers::pi));
    if (d >= 2.0 * plateau_rad) continue;
    const double ease = d <= plateau_rad ? 1.0 : std::pow(std::cos(0.5 * std::numbers::pi * (d - plateau_rad) / plateau_rad), 2);
    lift = std::max(lift, ease * l.lift_m);
  }
  return lift;
}

BrimLine raise_brim(const BrimLine& brim, const std::vector<BrimLift>& lifts, double plateau_rad, double max_height_m) {
  require(std::isfinite(plateau_rad) && plateau_rad > 0.0 && plateau_rad <= 0.5 * std::numbers::pi,
          "raise_brim: the plateau {} rad is outside (0, pi/2]", plateau_rad);
  bool any = false;
  for (const BrimLift& l : lifts) {
    require(std::isfinite(l.theta) && std::isfinite(l.lift_m), "raise_brim: a lift is not finite ({} rad, {} m)",
            l.theta, l.lift_m);
    any = any || l.lift_m > 0.0;
  }
  if (!any) return brim;
  constexpr int kSamples = 144;
  std::vector<BrimKeyPoint> points;
  points.reserve(kSamples);
  for (int k = 0; k < kSamples; ++k) {
    const double theta = -std::numbers::pi + 2.0 * std::numbers::pi * k / kSamples;
    const double lift = eased_lift(lifts, plateau_rad, theta);
    const double h = brim.height(theta);
    points.push_back({"raised", theta, std::max(h, std::min(h + lift, max_height_m))});
  }
  return BrimLine(brim.kind(), std::move(points));
}

std::vector<char> points_above_brim(const BrimLine& brim, const std::vector<Eigen::Vector3d>& points,
                                    const geometry::LimbFrame& frame) {
  std::vector<char> out(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) out[i] = above_brim(brim, points[i], frame) ? 1 : 0;
  return out;
}

}  // namespace socketsmith::design
