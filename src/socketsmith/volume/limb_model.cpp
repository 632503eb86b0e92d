#include "socketsmith/volume/limb_model.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include <Eigen/Eigenvalues>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/core/units.h"
#include "socketsmith/geometry/distal_dome.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/volume/limb_model_detail.h"
#include "socketsmith/volume/limb_shells.h"
#include "socketsmith/volume/transfemoral_anatomy.h"

namespace socketsmith::volume {
using namespace limb_shells;
using namespace limb_model_detail;
namespace {

using geometry::LimbFrame;
using geometry::TriMesh;

/// The highest a transfemoral stump is continued above the ischial tuberosity (the upper bound of
/// LimbInputOptions::containment_height_m) [m].
constexpr double kMaxContainmentHeight = 0.15;

/// The open boundary's vertices as (θ, h) in @p frame, sorted by θ.
std::vector<std::pair<double, double>> rim_profile(const TriMesh& skin, const LimbFrame& frame) {
  std::map<std::pair<int, int>, int> count;
  for (const auto& t : skin.triangles)
    for (int k = 0; k < 3; ++k) ++count[{std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])}];
  std::vector<char> on(skin.vertices.size(), 0);
  for (const auto& [e, c] : count)
    if (c == 1) on[e.first] = on[e.second] = 1;
  std::vector<std::pair<double, double>> out;
  for (std::size_t v = 0; v < on.size(); ++v)
    if (on[v]) {
      const auto c = frame.to_cylindrical(skin.vertices[v]);
      out.emplace_back(c.theta, c.h);
    }
  std::sort(out.begin(), out.end());
  return out;
}

/// Height of the rim at angle θ (linear between the nearest rim vertices, periodic).
double rim_height_at(const std::vector<std::pair<double, double>>& rim, double theta) {
  if (rim.empty()) return std::numeric_limits<double>::infinity();
  auto it = std::lower_bound(rim.begin(), rim.end(), std::pair{theta, -1e300});
  const auto& b = it == rim.end() ? rim.front() : *it;
  const auto& a = it == rim.begin() ? rim.back() : *(it - 1);
  double ta = a.first, tb = b.first;
  if (tb < ta) tb += 2.0 * std::numbers::pi;
  double t = theta;
  if (t < ta) t += 2.0 * std::numbers::pi;
  const double w = tb > ta ? std::clamp((t - ta) / (tb - ta), 0.0, 1.0) : 0.0;
  return a.second + w * (b.second - a.second);
}

/// The ischial tuberosity's height estimated from a transfemoral skin alone: 20 mm below the rim's
/// highest point when the rim is oblique (a scan reaching the hip laterally: OpenLimbTF mean limb,
/// truth 17 mm), else 60 mm below a level rim (an assumption: a level scan taken up to the groin).
double estimate_ischial_height(const std::vector<std::pair<double, double>>& rim, double top) {
  if (rim.empty()) return top - 0.06;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const auto& [t, h] : rim) {
    lo = std::min(lo, h);
    hi = std::max(hi, h);
  }
  return hi - lo >= 0.03 ? hi - 0.02 : lo - 0.06;
}

/// Refuses an empty limb, a non-finite coordinate, a containment height out of range and (unless
/// the size is forced) a limb far outside any limb's size.
void check_limb_input(const TriMesh& limb, const LimbInputOptions& opt) {
  require(!limb.empty(), "limb surface is empty (expected a scanned limb)");
  for (const auto& v : limb.vertices)
    require(v.allFinite(), "limb surface has a NaN or infinite vertex coordinate: re-export the scan");
  require(opt.containment_height_m >= 0.03 && opt.containment_height_m <= kMaxContainmentHeight,
          "prepare_limb: containment height {:.0f} mm is outside 30-150 mm above the ischial tuberosity",
          opt.containment_height_m * 1e3);
  if (!opt.force_size) {
    // Far outside any limb (the axis cannot even be found): the anatomical check comes later.
    const double diag = geometry::bounding_box(limb).extent().norm();
    require(diag > 0.02 && diag < 10.0, "limb is {:.3g} m across after units: not the size of a residual limb (0.08-1.5 m); wrong units? {}",
            diag, unit_mistake_hint(0.4 / std::max(diag, 1e-12)));
  }
}

/// Splits the file's shells: the skin (the largest area, repaired; a non-manifold edge refused)
/// and the others, repaired and outward; the transfemoral femur and hemipelvis named.
void read_shells(LimbPreparation& p, const TriMesh& limb, const TriMesh& extra_bones) {
  std::vector<Shell>& shells = p.shells;
  auto add_shells = [&](const TriMesh& mesh) {
    for (auto& c : geometry::split_components(mesh)) {
      Shell s;
      s.mesh = std::move(c);
      shells.push_back(std::move(s));
    }
  };
  add_shells(limb);
  if (!extra_bones.empty()) add_shells(extra_bones);
  for (auto& s : shells) s.area = geometry::surface_area(s.mesh);
  std::sort(shells.begin(), shells.end(), [](const Shell& a, const Shell& b) { return a.area > b.area; });
  p.skin = std::move(shells.front());
  shells.erase(shells.begin());
  const auto rep = geometry::repair_surface(p.skin.mesh);
  for (const auto& line : rep.changes()) p.model.notes.push_back("skin: " + line);
  // Open at both ends (an AAOP shape whose first slice is a ring, a scan that missed the tip):
  // closed at its distal end as O&P CAD programs do, and said, since the tip is now a guess.
  if (const auto dome = geometry::close_distal_opening(p.skin.mesh)) {
    log::warn("limb: {}", dome->describe());
    p.model.notes.push_back("skin: " + dome->describe());
  }
  // A fin or a sliver triangle stuck to the skin along an edge makes that edge non-manifold and
  // its free edges a second open rim: the axis, the rim and the cut would all be read from it
  // ("not a residual limb", a cut height nobody gave, a stump cut at the fin). Refused by name.
  if (const auto edge = first_non_manifold_edge(p.skin.mesh)) {
    const auto chk = geometry::check_mesh(p.skin.mesh);
    fail<TopologyError>("the skin has {} non-manifold edge(s) (edges of more than two triangles, the first at ({:.1f}, "
                        "{:.1f}, {:.1f}) mm): a fin or sliver triangle is stuck to the scan; delete it in the scanner "
                        "or mesh-editing software (socketsmith check mesh FILE counts them) and give the file again",
                        chk.non_manifold_edges, edge->x() * 1e3, edge->y() * 1e3, edge->z() * 1e3);
  }
  for (auto& s : shells) {
    geometry::repair_surface(s.mesh);
    if (geometry::signed_volume(s.mesh) < 0.0) geometry::flip_orientation(s.mesh);
  }
  std::tie(p.femur_i, p.pelvis_i) = p.tf ? transfemoral_roles(shells) : std::pair{-1, -1};
  if (p.femur_i >= 0) shells[p.femur_i].name = "femur";
  if (p.pelvis_i >= 0) shells[p.pelvis_i].name = "hemipelvis";
}

/// The femur's shaft axis, its proximal end told by the hemipelvis, else the skin's open rim, else
/// the skin's own axis; nullopt without a femur.
std::optional<FemurAxis> find_femur_axis(const LimbPreparation& p) {
  if (p.femur_i < 0) return std::nullopt;
  Vec3 hint;
  if (p.pelvis_i >= 0) {
    const TriMesh& pelvis = p.shells[p.pelvis_i].mesh;
    hint = Vec3::Zero();
    for (const auto& v : pelvis.vertices) hint += v;
    hint /= static_cast<double>(pelvis.vertices.size());
  } else if (const auto rim = geometry::open_rim_centroid(p.skin.mesh)) {
    hint = *rim;
  } else {
    const LimbFrame f = geometry::estimate_limb_axis(p.skin.mesh);
    hint = f.on_axis(10.0);
  }
  return femur_shaft_axis(p.shells[p.femur_i].mesh, hint);
}

/// The limb's axis (the user's, the femur's shaft, or the skin's), the size check along it, the
/// open rim's height and, with a femur and a hemipelvis, the pelvic directions.
void orient_limb(LimbPreparation& p) {
  const LimbInputOptions& opt = p.opt;
  LimbModel& model = p.model;
  const TriMesh& skin = p.skin.mesh;
  p.femur_axis = find_femur_axis(p);
  if (opt.axis) {
    model.frame = geometry::limb_frame_along(skin, *opt.axis);
    model.axis_source = "given";
  } else if (p.femur_axis) {
    model.frame = geometry::limb_frame_along(skin, p.femur_axis->direction);
    model.axis_source = "femur";
    model.notes.push_back("limb axis along the femur's shaft");
  } else {
    model.frame = geometry::estimate_limb_axis(skin);
    model.axis_source = "skin";
  }
  const LimbFrame& frame = model.frame;
  const LimbSize size = measure_limb_size(skin, frame);
  if (opt.force_size)
    model.notes.push_back(fmt::format("limb size {:.0f} x {:.0f} mm accepted without the anatomical range check (forced)",
                                      size.length_m * 1e3, size.width_m * 1e3));
  else
    check_limb_size(size, opt.type);

  // The open rim: where the closed part of the skin ends.
  p.rim = geometry::lowest_open_boundary_height(skin, frame);
  double skin_top = 0.0;
  for (const auto& v : skin.vertices) skin_top = std::max(skin_top, frame.to_cylindrical(v).h);
  require(p.rim >= 0.2 * skin_top,
          "the skin's open rim comes down to {:.0f} mm above the distal end along the limb axis, while the skin "
          "reaches {:.0f} mm: the limb axis ({} estimate) is probably wrong — give the limb's long axis "
          "(--axis x,y,z, or limb.axis in the case file)",
          p.rim * 1e3, skin_top * 1e3, model.axis_source == "given" ? "the given axis" : model.axis_source);

  if (p.femur_axis && p.pelvis_i >= 0)
    p.pelvic = pelvic_directions(*p.femur_axis, pelvis_points(p.shells[p.pelvis_i].mesh, *p.femur_axis), frame.axis);
}

/// The shell of @p named called @p name, or nullptr.
const Shell* find_shell(const std::vector<Shell>& named, const std::string& name) {
  for (const auto& b : named)
    if (b.name == name) return &b;
  return nullptr;
}

/// Sets the frame's front: the user's, then the hemipelvis, the patella or the tibia of @p named,
/// then the skin's shape. Returns whether the skin's estimate also found the side.
bool decide_anterior(LimbPreparation& p, const std::vector<Shell>& named, const TriMesh& skin_mesh, double top) {
  const LimbInputOptions& opt = p.opt;
  LimbModel& model = p.model;
  LimbFrame& frame = model.frame;
  const bool tf = p.tf;
  bool side_from_skin = false;
  const geometry::Slice mid = geometry::slice_surface(skin_mesh, frame.on_axis(0.6 * top), frame.axis);
  const Vec3 skin_centre = mid.area > 0 ? mid.centroid : frame.on_axis(0.6 * top);
  if (opt.anterior) {
    geometry::set_anterior(frame, *opt.anterior);
    frame.anterior_estimated = false;
    model.anterior_source = "given";
  } else if (p.pelvic) {
    geometry::set_anterior(frame, p.pelvic->anterior);
    frame.anterior_estimated = false;
    model.anterior_source = "hemipelvis";
    model.notes.push_back(fmt::format("anterior direction from the hemipelvis: its ischiopubic ramus turned back by the "
                                      "ischial ramus angle ({:.1f}°; the femur-centred estimate differs by {:.0f}°)",
                                      kIschialRamusAngle_rad / units::deg, p.pelvic->bisector_difference_deg));
  } else if (const Shell* patella = tf ? nullptr : find_shell(named, "patella")) {
    geometry::set_anterior(frame, patella->centroid - frame.on_axis(frame.to_cylindrical(patella->centroid).h));
    frame.anterior_estimated = false;
    model.anterior_source = "patella";
    model.notes.push_back("anterior direction from the patella");
  } else if (const Shell* tibia = tf ? nullptr : find_shell(named, "tibia")) {
    geometry::set_anterior(frame, tibia->centroid - skin_centre);
    frame.anterior_estimated = false;
    model.anterior_source = "tibia";
    model.notes.push_back("anterior direction from the tibia's offset in the limb");
  } else {
    if (opt.side) frame.side = *opt.side;  // the skin estimate depends on the side
    model.anterior_source = "skin";
    if (tf) {
      const auto est = geometry::estimate_anterior_from_thigh(skin_mesh, frame, opt.side.has_value());
      geometry::set_anterior(frame, est.anterior);
      if (est.side_found && !opt.side) {
        frame.side = est.side;
        side_from_skin = true;
      }
      model.notes.push_back(fmt::format("anterior direction ESTIMATED from the skin ({}); check it and give the "
                                        "front (limb.anterior in a case file, --anterior x,y,z on the command line)",
                                        est.how));
    } else {
      geometry::set_anterior(frame, geometry::estimate_anterior_from_skin(skin_mesh, frame));
      model.notes.push_back(fmt::format(
          "anterior direction ESTIMATED from the skin shape for a {} limb (calf skewness); check it and give the "
          "front (limb.anterior in a case file, --anterior x,y,z on the command line)",
          geometry::to_string(frame.side)));
    }
  }
  return side_from_skin;
}

/// Sets the frame's side: the user's, then the hemipelvis (medial) or the fibula (lateral) of
/// @p named, then what the skin's estimate found (@p side_from_skin), else right, assumed.
void decide_side(LimbPreparation& p, const std::vector<Shell>& named, bool side_from_skin) {
  LimbModel& model = p.model;
  LimbFrame& frame = model.frame;
  if (p.opt.side) {
    frame.side = *p.opt.side;
    frame.side_estimated = false;
  } else if (p.pelvic) {
    // The hemipelvis is medial (a given front keeps it so).
    frame.side = p.pelvic->medial.dot(frame.patient_right()) < 0 ? geometry::Side::Right : geometry::Side::Left;
    frame.side_estimated = false;
    model.notes.push_back(fmt::format("{} limb (the hemipelvis is medial)", geometry::to_string(frame.side)));
  } else if (const Shell* fibula = p.tf ? nullptr : find_shell(named, "fibula"); fibula && find_shell(named, "tibia")) {
    const double d = (fibula->centroid - find_shell(named, "tibia")->centroid).dot(frame.patient_right());
    frame.side = d > 0 ? geometry::Side::Right : geometry::Side::Left;
    frame.side_estimated = false;
    model.notes.push_back(fmt::format("{} limb (the fibula is lateral)", geometry::to_string(frame.side)));
  } else if (side_from_skin) {
    frame.side_estimated = true;
  } else {
    frame.side = geometry::Side::Right;
    frame.side_estimated = true;
    model.notes.push_back("side unknown: assumed right (give it: limb.side in a case file, --side left|right on the command line)");
  }
}

/// Transfemoral: the bony points on the whole bones (before the cut), or without a hemipelvis the
/// ischial tuberosity's height estimated from the skin's rim. They set the stump's top.
void find_ischial_height(LimbPreparation& p) {
  const LimbFrame& frame = p.model.frame;
  if (p.femur_axis && p.pelvis_i >= 0) {
    p.tf_points = transfemoral_points(p.shells[p.femur_i].mesh, *p.femur_axis, p.shells[p.pelvis_i].mesh, frame);
    p.ischial_h = frame.to_cylindrical(p.tf_points->ischial_tuberosity).h;
  } else {
    p.ischial_h = estimate_ischial_height(p.rim_h, p.rim);
    p.model.notes.push_back(fmt::format("no hemipelvis given: ischial tuberosity ESTIMATED at {:.0f} mm above the distal "
                                        "end (from the skin's rim)",
                                        p.ischial_h * 1e3));
  }
}

/// The cut plane's height, and the skin continued above the scan where a transfemoral containment
/// needs it.
void decide_cut(LimbPreparation& p) {
  const LimbInputOptions& opt = p.opt;
  const bool tf = p.tf;
  const double rim = p.rim, ischial_h = p.ischial_h;
  double cut = opt.cut_height_m.value_or(rim - opt.cut_margin_m);
  if (tf && !opt.cut_height_m && ischial_h > 0.0) cut = std::max(cut, ischial_h + opt.containment_height_m);
  const bool is_open = !p.rim_h.empty();
  // A given cut above the rim is reached by continuing the skin with assumed walls: only as far as
  // the highest containment needs (150 mm above the tuberosity). Beyond that the stump would be
  // mostly wall (a cut of 900 mm on the OpenLimbTF limb added 789 mm of it without a word).
  if (tf && is_open && opt.extend_skin && opt.cut_height_m && cut > rim && ischial_h > 0.0) {
    const double top = std::max(rim, ischial_h + kMaxContainmentHeight);
    require(cut <= top + 1e-9,
            "cut height {:.0f} mm is above what a transfemoral stump is continued to: the scan's rim ends at {:.0f} mm "
            "and the skin is continued above it only up to {:.0f} mm above the ischial tuberosity; give a cut at most "
            "{:.0f} mm above the distal end (limb.cut_height_mm in a case file, --cut-height-mm on the command line)",
            cut * 1e3, rim * 1e3, kMaxContainmentHeight * 1e3, top * 1e3);
  }
  if (tf && is_open && opt.extend_skin && cut > rim) {
    const SkinExtension ext = extend_skin_to_height(p.skin.mesh, p.model.frame, cut + opt.cut_margin_m);
    p.model.skin_extension_m = cut - rim;
    p.model.notes.push_back(fmt::format("skin CONTINUED above the scan by walls parallel to the axis, up to {:.0f} mm "
                                        "(the scan's rim ends {:.0f} mm lower at its lowest): the ischial containment "
                                        "needs the stump {:.0f} mm above the tuberosity; that part of the socket is "
                                        "designed on an assumed surface — scan up to the buttock and the groin",
                                        cut * 1e3, (cut - rim) * 1e3, opt.containment_height_m * 1e3));
    p.skin.mesh = ext.skin;
  }
  p.cut = cut;
}

/// The skin trimmed at the cut and capped, outward and closed, into the model.
void trim_skin(LimbPreparation& p) {
  LimbModel& model = p.model;
  const LimbFrame& frame = model.frame;
  const double cut = p.cut, rim = p.rim;
  TriMesh& skin = p.skin.mesh;
  const double rim_now = geometry::lowest_open_boundary_height(skin, frame);
  require(cut > 0.3 * rim_now && cut <= rim_now + 1e-9,
          "cut height {:.0f} mm is outside the limb's closed part: give a cut between {:.0f} and {:.0f} mm above the "
          "distal end (the lowest point of the open rim)",
          cut * 1e3, 0.3 * rim_now * 1e3, rim_now * 1e3);
  if (p.tf && p.ischial_h > 0.0 && cut < p.ischial_h + 0.05)
    model.notes.push_back(fmt::format("the stump ends {:.0f} mm above the ischial tuberosity: too low for an ischial "
                                      "containment (45-50 mm above it); transfemoral brims will be clamped below the cut",
                                      (cut - p.ischial_h) * 1e3));
  auto trimmed = geometry::trim_and_cap(skin, frame.on_axis(cut), frame.axis);
  if (geometry::signed_volume(trimmed.mesh) < 0.0) {
    geometry::flip_orientation(skin);
    trimmed = geometry::trim_and_cap(skin, frame.on_axis(cut), frame.axis);
    model.notes.push_back("skin: normals were inside-out; flipped");
  }
  {
    const auto chk = geometry::check_mesh(trimmed.mesh);
    require<TopologyError>(chk.is_closed() && chk.is_manifold() && chk.is_oriented(),
                           "skin is not closed below the cut ({} boundary loop(s), {} non-manifold edge(s)): "
                           "the scan has holes larger than the automatic repair fills; fill them in the scanner "
                           "software or cut lower (limb.cut_height_mm in a case file, --cut-height-mm on the command line)",
                           chk.boundary_loops, chk.non_manifold_edges);
  }
  model.skin = std::move(trimmed.mesh);
  model.first_cap_triangle = trimmed.first_cap_triangle;
  model.cut_height_m = cut;
  model.length_m = cut;
  if (rim - cut > 0.02)
    model.notes.push_back(fmt::format("skin cut at {:.0f} mm above the distal end ({:.0f} mm below the open rim)",
                                      cut * 1e3, (rim - cut) * 1e3));
}

/// Share of the trimmed skin's side area (the cap left out) above the scan's open rim @p rim_h [-].
double extension_area_fraction(const LimbModel& model, const std::vector<std::pair<double, double>>& rim_h) {
  double side = 0.0, added = 0.0;
  for (int t = 0; t < model.first_cap_triangle; ++t) {
    const auto& tri = model.skin.triangles[t];
    const auto c = model.frame.to_cylindrical((model.skin.vertices[tri[0]] + model.skin.vertices[tri[1]] +
                                               model.skin.vertices[tri[2]]) /
                                              3.0);
    const double a = geometry::triangle_area(model.skin, t);
    side += a;
    if (c.h > rim_height_at(rim_h, c.theta) + 1e-6) added += a;
  }
  return side > 0 ? added / side : 0.0;
}

}  // namespace

void limb_model_detail::decide_front(LimbPreparation& p, const std::vector<Shell>& named, const TriMesh& skin_mesh,
                                     double top) {
  const bool side_from_skin = decide_anterior(p, named, skin_mesh, top);
  decide_side(p, named, side_from_skin);
}

std::vector<std::string> apply_file_hints(LimbInputOptions& lo, const geometry::MeshReadInfo& info) {
  std::vector<std::string> notes;
  if (!lo.side && !info.side.empty()) {
    lo.side = geometry::parse_side(info.side);
    notes.push_back(fmt::format("{} limb (the limb file says so)", info.side));
  }
  return notes;
}

LimbModel prepare_limb(const TriMesh& limb, const TriMesh& extra_bones, const LimbInputOptions& opt) {
  LimbPreparation p(opt);
  check_limb_input(limb, opt);
  read_shells(p, limb, extra_bones);
  orient_limb(p);
  // Transfemoral: the front before the cut, which depends on the bones (transtibial: in place_bones).
  if (p.tf) decide_front(p, p.shells, p.skin.mesh, p.rim);
  p.rim_h = rim_profile(p.skin.mesh, p.model.frame);
  if (p.tf) find_ischial_height(p);
  decide_cut(p);
  trim_skin(p);
  if (p.model.skin_extension_m > 0.0) p.model.skin_extension_area_fraction = extension_area_fraction(p.model, p.rim_h);
  place_bones(p);
  LimbModel& model = p.model;
  model.landmarks =
      place_landmarks(model.skin, model.frame, opt.type, model.bones, p.cut, p.tf_points ? &*p.tf_points : nullptr);
  model.transfemoral = p.tf_points;
  return std::move(model);
}

HexMesherInput mesher_input(const LimbModel& model) {
  HexMesherInput in;
  in.skin = model.skin;
  in.first_cap_triangle = model.first_cap_triangle;
  in.frame = model.frame;
  in.cut_height_m = model.cut_height_m;
  for (const auto& b : model.bones) in.bones.push_back(b.mesh);
  return in;
}

}  // namespace socketsmith::volume
