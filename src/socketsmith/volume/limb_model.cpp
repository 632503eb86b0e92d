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
#include "socketsmith/volume/limb_shells.h"
#include "socketsmith/volume/transfemoral_anatomy.h"

namespace socketsmith::volume {
using namespace limb_shells;
namespace {

using geometry::LimbFrame;
using geometry::TriMesh;

/// Tissue kept between the skin and a clipped hemipelvis [m].
constexpr double kPelvisClearance_m = 0.005;
/// The highest a transfemoral stump is continued above the ischial tuberosity (the upper bound of
/// LimbInputOptions::containment_height_m) [m].
constexpr double kMaxContainmentHeight = 0.15;


/// A closed, star-shaped region @p clearance_m inside the skin: rings of the measured skin radii
/// less the clearance, from just above the distal end to the clearance below the top, closed by
/// fans to the axis.
TriMesh inset_region(const SkinRadii& r, const LimbFrame& frame, double clearance_m) {
  geometry::RingStack stack;
  const double h0 = r.h_lo_m + clearance_m, h1 = r.h_hi_m - clearance_m;
  const int rows = std::max(8, r.num_heights);
  for (int k = 0; k < rows; ++k) {
    const double h = h0 + (h1 - h0) * k / (rows - 1);
    std::vector<Vec3> ring;
    for (int j = 0; j < r.num_angles; ++j) {
      const double th = 2.0 * std::numbers::pi * j / r.num_angles;
      ring.push_back(frame.from_cylindrical({std::max(r.radius(th, h) - clearance_m, 1e-3), th, h}));
    }
    stack.rings.push_back(std::move(ring));
  }
  stack.has_bottom_pole = stack.has_top_pole = true;
  stack.bottom_pole = frame.on_axis(h0);
  stack.top_pole = frame.on_axis(h1);
  return geometry::mesh_ring_stack(stack, frame.is_left_handed());
}

/// The part of a hemipelvis that lies at least @p clearance_m inside the closed skin (exact
/// intersection), debris under 0.3 cm³ dropped; empty when nothing remains.
TriMesh clip_to_stump(const TriMesh& pelvis, const TriMesh& closed_skin, const LimbFrame& frame, double clearance_m) {
  const SkinRadii radii = measure_skin_radii(closed_skin, frame, 64, 72);
  const TriMesh region = inset_region(radii, frame, clearance_m);
  const TriMesh cut = geometry::mesh_boolean(pelvis, region, geometry::BooleanOperation::Intersection);
  TriMesh out;
  for (auto& c : geometry::split_components(cut)) {
    if (geometry::signed_volume(c) < 0.3e-6) continue;
    const int off = out.num_vertices();
    out.vertices.insert(out.vertices.end(), c.vertices.begin(), c.vertices.end());
    for (auto t : c.triangles) out.triangles.push_back({t[0] + off, t[1] + off, t[2] + off});
  }
  return out;
}

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

}  // namespace


LimbModel prepare_limb(const TriMesh& limb, const TriMesh& extra_bones, const LimbInputOptions& opt) {
  LimbModel model;
  model.type = opt.type;
  const bool tf = opt.type == geometry::LimbType::Transfemoral;
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

  // Shells: the skin has the largest area.
  std::vector<Shell> shells;
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
  Shell skin = std::move(shells.front());
  shells.erase(shells.begin());
  const auto rep = geometry::repair_surface(skin.mesh);
  for (const auto& line : rep.changes()) model.notes.push_back("skin: " + line);
  // A fin or a sliver triangle stuck to the skin along an edge makes that edge non-manifold and
  // its free edges a second open rim: the axis, the rim and the cut would all be read from it
  // ("not a residual limb", a cut height nobody gave, a stump cut at the fin). Refused by name.
  if (const auto edge = first_non_manifold_edge(skin.mesh)) {
    const auto chk = geometry::check_mesh(skin.mesh);
    fail<TopologyError>("the skin has {} non-manifold edge(s) (edges of more than two triangles, the first at ({:.1f}, "
                        "{:.1f}, {:.1f}) mm): a fin or sliver triangle is stuck to the scan; delete it in the scanner "
                        "or mesh-editing software (socketsmith check mesh FILE counts them) and give the file again",
                        chk.non_manifold_edges, edge->x() * 1e3, edge->y() * 1e3, edge->z() * 1e3);
  }
  for (auto& s : shells) {
    geometry::repair_surface(s.mesh);
    if (geometry::signed_volume(s.mesh) < 0.0) geometry::flip_orientation(s.mesh);
  }
  const auto [femur_i, pelvis_i] = tf ? transfemoral_roles(shells) : std::pair{-1, -1};
  if (femur_i >= 0) shells[femur_i].name = "femur";
  if (pelvis_i >= 0) shells[pelvis_i].name = "hemipelvis";

  // Axis: the user's, the femur's shaft, or the skin's.
  std::optional<FemurAxis> femur_axis;
  if (femur_i >= 0) {
    Vec3 hint;
    if (pelvis_i >= 0) {
      hint = Vec3::Zero();
      for (const auto& v : shells[pelvis_i].mesh.vertices) hint += v;
      hint /= static_cast<double>(shells[pelvis_i].mesh.vertices.size());
    } else if (const auto rim = geometry::open_rim_centroid(skin.mesh)) {
      hint = *rim;
    } else {
      const LimbFrame f = geometry::estimate_limb_axis(skin.mesh);
      hint = f.on_axis(10.0);
    }
    femur_axis = femur_shaft_axis(shells[femur_i].mesh, hint);
  }
  if (opt.axis) {
    model.frame = geometry::limb_frame_along(skin.mesh, *opt.axis);
    model.axis_source = "given";
  } else if (femur_axis) {
    model.frame = geometry::limb_frame_along(skin.mesh, femur_axis->direction);
    model.axis_source = "femur";
    model.notes.push_back("limb axis along the femur's shaft");
  } else {
    model.frame = geometry::estimate_limb_axis(skin.mesh);
    model.axis_source = "skin";
  }
  LimbFrame& frame = model.frame;
  const LimbSize size = measure_limb_size(skin.mesh, frame);
  if (opt.force_size)
    model.notes.push_back(fmt::format("limb size {:.0f} x {:.0f} mm accepted without the anatomical range check (forced)",
                                      size.length_m * 1e3, size.width_m * 1e3));
  else
    check_limb_size(size, opt.type);

  // The open rim: where the closed part of the skin ends.
  const double rim = geometry::lowest_open_boundary_height(skin.mesh, frame);
  double skin_top = 0.0;
  for (const auto& v : skin.mesh.vertices) skin_top = std::max(skin_top, frame.to_cylindrical(v).h);
  require(rim >= 0.2 * skin_top,
          "the skin's open rim comes down to {:.0f} mm above the distal end along the limb axis, while the skin "
          "reaches {:.0f} mm: the limb axis ({} estimate) is probably wrong — give the limb's long axis "
          "(--axis x,y,z, or limb.axis in the case file)",
          rim * 1e3, skin_top * 1e3, model.axis_source == "given" ? "the given axis" : model.axis_source);

  std::optional<PelvicDirections> pelvic;
  if (femur_axis && pelvis_i >= 0)
    pelvic = pelvic_directions(*femur_axis, pelvis_points(shells[pelvis_i].mesh, *femur_axis), frame.axis);
  // Front and side: the user's, then bones, then the skin — once the bones are named (transtibial:
  // after the cut, as their names depend on it; transfemoral: before, as the cut depends on them).
  bool side_from_skin = false;
  auto decide_front = [&](const std::vector<Shell>& named, const TriMesh& skin_mesh, double top) {
    auto find = [&](const std::string& name) -> const Shell* {
      for (const auto& b : named)
        if (b.name == name) return &b;
      return nullptr;
    };
    const geometry::Slice mid = geometry::slice_surface(skin_mesh, frame.on_axis(0.6 * top), frame.axis);
    const Vec3 skin_centre = mid.area > 0 ? mid.centroid : frame.on_axis(0.6 * top);
    if (opt.anterior) {
      geometry::set_anterior(frame, *opt.anterior);
      frame.anterior_estimated = false;
      model.anterior_source = "given";
    } else if (pelvic) {
      geometry::set_anterior(frame, pelvic->anterior);
      frame.anterior_estimated = false;
      model.anterior_source = "hemipelvis";
      model.notes.push_back(fmt::format("anterior direction from the hemipelvis: its ischiopubic ramus turned back by the "
                                        "ischial ramus angle ({:.1f}°; the femur-centred estimate differs by {:.0f}°)",
                                        kIschialRamusAngle_rad / units::deg, pelvic->bisector_difference_deg));
    } else if (const Shell* patella = tf ? nullptr : find("patella")) {
      geometry::set_anterior(frame, patella->centroid - frame.on_axis(frame.to_cylindrical(patella->centroid).h));
      frame.anterior_estimated = false;
      model.anterior_source = "patella";
      model.notes.push_back("anterior direction from the patella");
    } else if (const Shell* tibia = tf ? nullptr : find("tibia")) {
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
    if (opt.side) {
      frame.side = *opt.side;
      frame.side_estimated = false;
    } else if (pelvic) {
      // The hemipelvis is medial (a given front keeps it so).
      frame.side = pelvic->medial.dot(frame.patient_right()) < 0 ? geometry::Side::Right : geometry::Side::Left;
      frame.side_estimated = false;
      model.notes.push_back(fmt::format("{} limb (the hemipelvis is medial)", geometry::to_string(frame.side)));
    } else if (const Shell* fibula = tf ? nullptr : find("fibula"); fibula && find("tibia")) {
      const double d = (fibula->centroid - find("tibia")->centroid).dot(frame.patient_right());
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
  };
  if (tf) decide_front(shells, skin.mesh, rim);

  // Transfemoral bony points on the whole bones (before the cut): they set the stump's top.
  std::optional<TransfemoralPoints> tf_points;
  const auto rim_h = rim_profile(skin.mesh, frame);
  double ischial_h = -1.0;
  if (tf) {
    if (femur_axis && pelvis_i >= 0) {
      tf_points = transfemoral_points(shells[femur_i].mesh, *femur_axis, shells[pelvis_i].mesh, frame);
      ischial_h = frame.to_cylindrical(tf_points->ischial_tuberosity).h;
    } else {
      ischial_h = estimate_ischial_height(rim_h, rim);
      model.notes.push_back(fmt::format("no hemipelvis given: ischial tuberosity ESTIMATED at {:.0f} mm above the distal "
                                        "end (from the skin's rim)",
                                        ischial_h * 1e3));
    }
  }

  // Cut plane, and the skin continued above the scan where a transfemoral containment needs it.
  double cut = opt.cut_height_m.value_or(rim - opt.cut_margin_m);
  if (tf && !opt.cut_height_m && ischial_h > 0.0) cut = std::max(cut, ischial_h + opt.containment_height_m);
  const bool is_open = !rim_h.empty();
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
    const SkinExtension ext = extend_skin_to_height(skin.mesh, frame, cut + opt.cut_margin_m);
    model.skin_extension_m = cut - rim;
    model.notes.push_back(fmt::format("skin CONTINUED above the scan by walls parallel to the axis, up to {:.0f} mm "
                                      "(the scan's rim ends {:.0f} mm lower at its lowest): the ischial containment "
                                      "needs the stump {:.0f} mm above the tuberosity; that part of the socket is "
                                      "designed on an assumed surface — scan up to the buttock and the groin",
                                      cut * 1e3, (cut - rim) * 1e3, opt.containment_height_m * 1e3));
    skin.mesh = ext.skin;
  }
  const double rim_now = geometry::lowest_open_boundary_height(skin.mesh, frame);
  require(cut > 0.3 * rim_now && cut <= rim_now + 1e-9,
          "cut height {:.0f} mm is outside the limb's closed part: give a cut between {:.0f} and {:.0f} mm above the "
          "distal end (the lowest point of the open rim)",
          cut * 1e3, 0.3 * rim_now * 1e3, rim_now * 1e3);
  if (tf && ischial_h > 0.0 && cut < ischial_h + 0.05)
    model.notes.push_back(fmt::format("the stump ends {:.0f} mm above the ischial tuberosity: too low for an ischial "
                                      "containment (45-50 mm above it); transfemoral brims will be clamped below the cut",
                                      (cut - ischial_h) * 1e3));
  auto trimmed = geometry::trim_and_cap(skin.mesh, frame.on_axis(cut), frame.axis);
  if (geometry::signed_volume(trimmed.mesh) < 0.0) {
    geometry::flip_orientation(skin.mesh);
    trimmed = geometry::trim_and_cap(skin.mesh, frame.on_axis(cut), frame.axis);
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
  if (model.skin_extension_m > 0.0) {
    double side = 0.0, added = 0.0;
    for (int t = 0; t < model.first_cap_triangle; ++t) {
      const auto& tri = model.skin.triangles[t];
      const auto c = frame.to_cylindrical((model.skin.vertices[tri[0]] + model.skin.vertices[tri[1]] +
                                           model.skin.vertices[tri[2]]) /
                                          3.0);
      const double a = geometry::triangle_area(model.skin, t);
      side += a;
      if (c.h > rim_height_at(rim_h, c.theta) + 1e-6) added += a;
    }
    model.skin_extension_area_fraction = side > 0 ? added / side : 0.0;
  }

  // Bones: trimmed, inside the skin (the hemipelvis: clipped to the stump).
  const geometry::SurfaceQuery skin_query(model.skin);
  const double skin_volume = geometry::signed_volume(model.skin);
  std::vector<Shell> bones;
  for (auto& s : shells) {
    if (s.name == "hemipelvis") {
      try {
        TriMesh kept = clip_to_stump(s.mesh, model.skin, frame, kPelvisClearance_m);
        if (kept.empty()) {
          model.notes.push_back("the hemipelvis lies outside the stump: kept for the frame and the landmarks only");
          continue;
        }
        model.notes.push_back(fmt::format("hemipelvis clipped to the stump ({:.0f} of {:.0f} cm^3 lie {:.0f} mm inside the "
                                          "skin)",
                                          geometry::signed_volume(kept) * 1e6, geometry::signed_volume(s.mesh) * 1e6,
                                          kPelvisClearance_m * 1e3));
        s.mesh = std::move(kept);
        measure(s, frame);
        bones.push_back(std::move(s));
      } catch (const Error& e) {
        model.notes.push_back(fmt::format("the hemipelvis could not be clipped to the stump ({}): left out of the mesh, "
                                          "kept for the frame and the landmarks",
                                          e.what()));
      }
      continue;
    }
    if (!trim(s, frame, cut)) {
      model.notes.push_back(fmt::format("a shell of {:.0f} cm^2 lies above the cut: ignored", s.area * 1e4));
      continue;
    }
    measure(s, frame);
    if (s.volume < 0.1e-6) {
      model.notes.push_back(fmt::format("a tiny shell ({:.2f} cm^3) ignored as debris", s.volume * 1e6));
      continue;
    }
    // Vertices more than 1 mm outside the skin (the cap in the cut plane is not tested).
    int outside = 0, tested = 0;
    double worst = 0.0;
    for (const auto& v : s.mesh.vertices) {
      if (frame.to_cylindrical(v).h > cut - 1e-3) continue;
      ++tested;
      const double d = skin_query.signed_distance(v);
      worst = std::max(worst, d);
      outside += d > 1e-3 ? 1 : 0;
    }
    // A second surface about as large as the skin is not a bone: two overlapping skins (two scans
    // in one file, or a scan and its offset copy).
    require(outside <= static_cast<int>(0.01 * tested) || s.area < 0.5 * skin.area,
            "the file holds two skins: a second surface of {:.0f} cm^2 ({:.0f} % of the skin's area) has {:.0f} % of "
            "its vertices outside the skin (up to {:.0f} mm); keep one skin (and the bones inside it) in the file",
            s.area * 1e4, 100.0 * s.area / skin.area, 100.0 * outside / std::max(tested, 1), worst * 1e3);
    require(outside <= static_cast<int>(0.01 * tested),
            "a bone shell ({:.0f} cm^3) has {:.0f} % of its vertices outside the skin (up to {:.0f} mm): bones and "
            "skin must be in the same frame and units, bones inside the skin",
            s.volume * 1e6, 100.0 * outside / std::max(tested, 1), worst * 1e3);
    // Nor is a surface within a millimetre of the skin that holds most of its volume (a copy of the
    // skin slightly moved or shrunk): taken for the tibia, it left the mesher no tissue.
    require(s.volume < 0.5 * skin_volume,
            "the file holds two skins: a second surface of {:.0f} cm^2 ({:.0f} % of the skin's area) encloses {:.0f} % "
            "of the skin's volume, too much for a bone; keep one skin (and the bones inside it) in the file",
            s.area * 1e4, 100.0 * s.area / skin.area, 100.0 * s.volume / skin_volume);
    s.outside_m = worst;
    bones.push_back(std::move(s));
  }
  if (tf) {
    int extra = 1;
    for (auto& b : bones)
      if (b.name.empty()) b.name = "bone " + std::to_string(++extra);
  } else {
    name_bones(bones, opt.type, cut);
    decide_front(bones, model.skin, cut);
  }
  for (const auto& b : bones)
    if (b.outside_m > 0.0)
      model.notes.push_back(fmt::format("{} touches the skin (up to {:.1f} mm outside it)", b.name, b.outside_m * 1e3));
  for (auto& b : bones) model.bones.push_back({b.name, std::move(b.mesh)});

  // Estimated bones.
  if (!tf && model.bones.empty() && opt.estimate_bones) {
    model.bones = estimate_bones(model.skin, frame, opt.type);
    model.bones_estimated = true;
    model.notes.push_back("no bones given: bones ESTIMATED from the skin by an anatomical template");
  }
  if (tf && opt.estimate_bones && !tf_points) {
    const bool has_femur = femur_i >= 0;
    BoneEstimateOptions eo;
    eo.ischial_height_m = std::clamp(ischial_h, 0.05, cut - 0.01);
    std::vector<NamedMesh> est;
    if (has_femur) {
      const SkinRadii radii = measure_skin_radii(model.skin, frame);
      BonePlacement pl;
      pl.type = opt.type;
      pl.name_suffix = " (estimated)";
      pl.ischial_height_m = eo.ischial_height_m;
      est.push_back(build_hemipelvis_template(radii, frame, BoneTemplateParams{}, pl,
                                              femur_axis->at_height_of(frame.on_axis(eo.ischial_height_m))));
    } else {
      est = estimate_bones(model.skin, frame, opt.type, eo);
    }
    const NamedMesh* femur_mesh = has_femur ? nullptr : &est.front();
    const NamedMesh& pelvis_mesh = est.back();
    const TriMesh& femur_for_axis = has_femur ? shells[femur_i].mesh : femur_mesh->mesh;
    const FemurAxis fa = has_femur ? *femur_axis : femur_shaft_axis(femur_for_axis, frame.on_axis(cut));
    tf_points = transfemoral_points(femur_for_axis, fa, pelvis_mesh.mesh, frame);
    tf_points->estimated = true;
    for (auto& b : est) {
      if (b.name.rfind("hemipelvis", 0) == 0) {
        try {
          b.mesh = clip_to_stump(b.mesh, model.skin, frame, kPelvisClearance_m);
        } catch (const Error& e) {
          model.notes.push_back(fmt::format("the estimated hemipelvis could not be clipped ({}): left out", e.what()));
          continue;
        }
        if (b.mesh.empty()) continue;
      }
      model.bones.push_back(std::move(b));
    }
    model.bones_estimated = true;
    model.notes.push_back(has_femur ? "no hemipelvis given: hemipelvis ESTIMATED from the skin by an anatomical template"
                                    : "no bones given: femur and hemipelvis ESTIMATED from the skin by an anatomical "
                                      "template");
  }
  model.landmarks = place_landmarks(model.skin, frame, opt.type, model.bones, cut, tf_points ? &*tf_points : nullptr);
  model.transfemoral = tf_points;
  return model;
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
