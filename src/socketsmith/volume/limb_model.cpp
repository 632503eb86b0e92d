#include "socketsmith/volume/limb_model.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/core/units.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/surface_query.h"

namespace socketsmith::volume {
namespace {

using geometry::LimbFrame;
using geometry::TriMesh;

struct Shell {
  TriMesh mesh;
  double area = 0.0;
  double h_min = 0.0, h_max = 0.0;
  double volume = 0.0;
  double outside_m = 0.0;  ///< how far the shell pokes out of the skin (tolerated up to 1 mm)
  Vec3 centroid = Vec3::Zero();
  std::string name;
};

void measure(Shell& s, const LimbFrame& frame) {
  s.h_min = std::numeric_limits<double>::infinity();
  s.h_max = -s.h_min;
  s.centroid.setZero();
  for (const auto& v : s.mesh.vertices) {
    const double h = frame.to_cylindrical(v).h;
    s.h_min = std::min(s.h_min, h);
    s.h_max = std::max(s.h_max, h);
    s.centroid += v;
  }
  if (!s.mesh.vertices.empty()) s.centroid /= static_cast<double>(s.mesh.vertices.size());
  s.volume = geometry::signed_volume(s.mesh);
}

/// Names bone shells by anatomy: transtibial — the most distal is the tibia, the next elongated
/// one reaching below mid-height the fibula, the most proximal the femur, a small compact one
/// near the knee the patella; transfemoral — the most distal is the femur.
void name_bones(std::vector<Shell>& bones, geometry::LimbType type, double cut) {
  std::vector<int> order(bones.size());
  for (size_t i = 0; i < bones.size(); ++i) order[i] = static_cast<int>(i);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return bones[a].h_min < bones[b].h_min; });
  for (auto& b : bones) b.name.clear();
  if (order.empty()) return;
  if (type == geometry::LimbType::Transfemoral) {
    bones[order[0]].name = "femur";
    for (size_t k = 1; k < order.size(); ++k) bones[order[k]].name = "bone " + std::to_string(k + 1);
    return;
  }
  bones[order[0]].name = "tibia";
  int femur = -1, patella = -1, fibula = -1;
  for (size_t k = 1; k < order.size(); ++k) {
    Shell& b = bones[order[k]];
    const double len = b.h_max - b.h_min;
    if (fibula < 0 && b.h_min < 0.5 * cut && len > 0.3 * (bones[order[0]].h_max - bones[order[0]].h_min)) {
      fibula = order[k];
      b.name = "fibula";
    }
  }
  for (size_t k = 1; k < order.size(); ++k) {
    const int i = order[k];
    if (i == fibula) continue;
    if (femur < 0 || bones[i].h_max > bones[femur].h_max) femur = i;
  }
  for (size_t k = 1; k < order.size(); ++k) {
    const int i = order[k];
    if (i == fibula || i == femur) continue;
    if (patella < 0 || bones[i].volume < bones[patella].volume) patella = i;
  }
  // A single remaining proximal shell could be the femur or the patella: the patella is small.
  if (femur >= 0 && patella < 0 && bones[femur].volume < 40e-6) {
    patella = femur;
    femur = -1;
  }
  if (femur >= 0) bones[femur].name = "femur";
  if (patella >= 0) bones[patella].name = "patella";
  int extra = 1;
  for (auto& b : bones)
    if (b.name.empty()) b.name = "bone " + std::to_string(extra++);
}

/// Trims and caps a shell; returns false when nothing of it lies below the cut.
bool trim(Shell& s, const LimbFrame& frame, double cut) {
  bool any_below = false;
  for (const auto& v : s.mesh.vertices) any_below = any_below || frame.to_cylindrical(v).h < cut - 1e-6;
  if (!any_below) return false;
  bool any_above = false;
  for (const auto& v : s.mesh.vertices) any_above = any_above || frame.to_cylindrical(v).h > cut;
  if (any_above) s.mesh = geometry::trim_and_cap(s.mesh, frame.on_axis(cut), frame.axis).mesh;
  return true;
}

}  // namespace

LimbModel prepare_limb(const TriMesh& limb, const TriMesh& extra_bones, const LimbInputOptions& opt) {
  LimbModel model;
  model.type = opt.type;
  require(!limb.empty(), "limb surface is empty (expected a scanned limb)");
  for (const auto& v : limb.vertices)
    require(v.allFinite(), "limb surface has a NaN or infinite vertex coordinate: re-export the scan");
  {
    const double diag = geometry::bounding_box(limb).extent().norm();
    require(diag > 0.08 && diag < 1.5,
            "limb is {:.3g} m across: not the size of a residual limb (0.08-1.5 m); wrong units? "
            "use --units mm or --units m (or --scale for normalised shapes)",
            diag);
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
  model.frame = geometry::estimate_limb_axis(skin.mesh);
  LimbFrame& frame = model.frame;

  // Cut plane.
  const double rim = geometry::lowest_open_boundary_height(skin.mesh, frame);
  double cut = opt.cut_height_m.value_or(rim - opt.cut_margin_m);
  require(cut > 0.3 * rim && cut <= rim + 1e-9,
          "cut height {:.0f} mm is outside the limb's closed part (0.3 x {:.0f} mm .. {:.0f} mm above the distal "
          "end); choose a cut below the open rim",
          cut * 1e3, rim * 1e3, rim * 1e3);
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
                           "software or cut lower (--cut-height-mm)",
                           chk.boundary_loops, chk.non_manifold_edges);
  }
  model.skin = std::move(trimmed.mesh);
  model.first_cap_triangle = trimmed.first_cap_triangle;
  model.cut_height_m = cut;
  model.length_m = cut;
  if (rim - cut > 0.02)
    model.notes.push_back(fmt::format("skin cut at {:.0f} mm above the distal end ({:.0f} mm below the open rim)",
                                      cut * 1e3, (rim - cut) * 1e3));

  // Bones: trimmed, inside the skin.
  const geometry::SurfaceQuery skin_query(model.skin);
  std::vector<Shell> bones;
  for (auto& s : shells) {
    geometry::repair_surface(s.mesh);
    if (geometry::signed_volume(s.mesh) < 0.0) geometry::flip_orientation(s.mesh);
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
    require(outside <= static_cast<int>(0.01 * tested),
            "a bone shell ({:.0f} cm^3) has {:.0f} % of its vertices outside the skin (up to {:.0f} mm): bones and "
            "skin must be in the same frame and units, bones inside the skin",
            s.volume * 1e6, 100.0 * outside / std::max(tested, 1), worst * 1e3);
    s.outside_m = worst;
    bones.push_back(std::move(s));
  }
  name_bones(bones, opt.type, cut);
  for (const auto& b : bones)
    if (b.outside_m > 0.0)
      model.notes.push_back(fmt::format("{} touches the skin (up to {:.1f} mm outside it)", b.name, b.outside_m * 1e3));

  // Anterior and side: user, then bones, then skin heuristic.
  auto find = [&](const std::string& name) -> const Shell* {
    for (const auto& b : bones)
      if (b.name == name) return &b;
    return nullptr;
  };
  const geometry::Slice mid = geometry::slice_surface(model.skin, frame.on_axis(0.6 * cut), frame.axis);
  const Vec3 skin_centre = mid.area > 0 ? mid.centroid : frame.on_axis(0.6 * cut);
  if (opt.anterior) {
    geometry::set_anterior(frame, *opt.anterior);
    frame.anterior_estimated = false;
  } else if (const Shell* patella = find("patella")) {
    geometry::set_anterior(frame, patella->centroid - frame.on_axis(frame.to_cylindrical(patella->centroid).h));
    frame.anterior_estimated = false;
    model.notes.push_back("anterior direction from the patella");
  } else if (const Shell* tibia = find(opt.type == geometry::LimbType::Transtibial ? "tibia" : "")) {
    geometry::set_anterior(frame, tibia->centroid - skin_centre);
    frame.anterior_estimated = false;
    model.notes.push_back("anterior direction from the tibia's offset in the limb");
  } else {
    if (opt.side) frame.side = *opt.side;  // the skin estimate depends on the side
    geometry::set_anterior(frame, geometry::estimate_anterior_from_skin(model.skin, frame));
    model.notes.push_back(fmt::format(
        "anterior direction ESTIMATED from the skin shape for a {} limb (calf skewness); check it and give "
        "--anterior x,y,z",
        geometry::to_string(frame.side)));
  }
  if (opt.side) {
    frame.side = *opt.side;
    frame.side_estimated = false;
  } else if (const Shell* fibula = find("fibula"); fibula && find("tibia")) {
    const double d = (fibula->centroid - find("tibia")->centroid).dot(frame.patient_right());
    frame.side = d > 0 ? geometry::Side::Right : geometry::Side::Left;
    frame.side_estimated = false;
    model.notes.push_back(fmt::format("{} limb (the fibula is lateral)", geometry::to_string(frame.side)));
  } else {
    frame.side = geometry::Side::Right;
    frame.side_estimated = true;
    model.notes.push_back("side unknown: assumed right (give --side left|right)");
  }

  for (auto& b : bones) model.bones.push_back({b.name, std::move(b.mesh)});
  if (model.bones.empty() && opt.estimate_bones) {
    model.bones = estimate_bones(model.skin, frame, opt.type);
    model.bones_estimated = true;
    model.notes.push_back("no bones given: bones ESTIMATED from the skin by an anatomical template");
  }
  model.landmarks = place_landmarks(model.skin, frame, opt.type, model.bones, cut);
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
