// The bones inside a prepared limb's stump: the file's bone shells trimmed at the cut, checked
// against the skin and named (the hemipelvis clipped to the stump), and the bones the file lacks
// estimated from the skin (limb_model_detail.h says why this is apart from the skin's steps).
#include <algorithm>
#include <numbers>
#include <string>
#include <vector>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/mesh_boolean.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/ring_stack.h"
#include "socketsmith/geometry/surface_query.h"
#include "socketsmith/volume/limb_model_detail.h"

namespace socketsmith::volume::limb_model_detail {
using namespace limb_shells;
namespace {

using geometry::LimbFrame;
using geometry::TriMesh;

/// Tissue kept between the skin and a clipped hemipelvis [m].
constexpr double kPelvisClearance_m = 0.005;

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

/// The hemipelvis @p s clipped to the stump and added to @p bones; when nothing of it lies inside
/// the stump, or the clip fails, it is left out of the mesh (a note says so).
void add_clipped_hemipelvis(Shell& s, LimbModel& model, std::vector<Shell>& bones) {
  const LimbFrame& frame = model.frame;
  try {
    TriMesh kept = clip_to_stump(s.mesh, model.skin, frame, kPelvisClearance_m);
    if (kept.empty()) {
      model.notes.push_back("the hemipelvis lies outside the stump: kept for the frame and the landmarks only");
      return;
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
}

/// Refuses a trimmed bone shell @p s that lies outside the skin (more than 1 % of its vertices
/// over 1 mm out) or is a second skin; records how far it pokes out.
void check_bone_in_skin(const LimbPreparation& p, const geometry::SurfaceQuery& skin_query, double skin_volume,
                        Shell& s) {
  const Shell& skin = p.skin;
  // Vertices more than 1 mm outside the skin (the cap in the cut plane is not tested).
  int outside = 0, tested = 0;
  double worst = 0.0;
  for (const auto& v : s.mesh.vertices) {
    if (p.model.frame.to_cylindrical(v).h > p.cut - 1e-3) continue;
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
}

/// Bones: trimmed, inside the skin (the hemipelvis: clipped to the stump); shells above the cut
/// and debris left out with a note.
std::vector<Shell> trim_bones(LimbPreparation& p) {
  LimbModel& model = p.model;
  const geometry::SurfaceQuery skin_query(model.skin);
  const double skin_volume = geometry::signed_volume(model.skin);
  std::vector<Shell> bones;
  for (auto& s : p.shells) {
    if (s.name == "hemipelvis") {
      add_clipped_hemipelvis(s, model, bones);
      continue;
    }
    if (!trim(s, model.frame, p.cut)) {
      model.notes.push_back(fmt::format("a shell of {:.0f} cm^2 lies above the cut: ignored", s.area * 1e4));
      continue;
    }
    measure(s, model.frame);
    if (s.volume < 0.1e-6) {
      model.notes.push_back(fmt::format("a tiny shell ({:.2f} cm^3) ignored as debris", s.volume * 1e6));
      continue;
    }
    check_bone_in_skin(p, skin_query, skin_volume, s);
    bones.push_back(std::move(s));
  }
  return bones;
}

/// Names the trimmed @p bones (transtibial: then decides the front and the side from them), notes
/// those touching the skin and moves them into the model.
void store_bones(LimbPreparation& p, std::vector<Shell> bones) {
  LimbModel& model = p.model;
  if (p.tf) {
    int extra = 1;
    for (auto& b : bones)
      if (b.name.empty()) b.name = "bone " + std::to_string(++extra);
  } else {
    name_bones(bones, p.opt.type, p.cut);
    decide_front(p, bones, model.skin, p.cut);
  }
  for (const auto& b : bones)
    if (b.outside_m > 0.0)
      model.notes.push_back(fmt::format("{} touches the skin (up to {:.1f} mm outside it)", b.name, b.outside_m * 1e3));
  for (auto& b : bones) model.bones.push_back({b.name, std::move(b.mesh)});
}

/// Transfemoral bones missing from the file, estimated from the skin by an anatomical template
/// (the hemipelvis alone when the file has a femur), the estimated hemipelvis clipped to the
/// stump; the bony points are placed on them.
void estimate_transfemoral_bones(LimbPreparation& p) {
  LimbModel& model = p.model;
  const LimbFrame& frame = model.frame;
  const bool has_femur = p.femur_i >= 0;
  BoneEstimateOptions eo;
  eo.ischial_height_m = std::clamp(p.ischial_h, 0.05, p.cut - 0.01);
  std::vector<NamedMesh> est;
  if (has_femur) {
    const SkinRadii radii = measure_skin_radii(model.skin, frame);
    BonePlacement pl;
    pl.type = p.opt.type;
    pl.name_suffix = " (estimated)";
    pl.ischial_height_m = eo.ischial_height_m;
    est.push_back(build_hemipelvis_template(radii, frame, BoneTemplateParams{}, pl,
                                            p.femur_axis->at_height_of(frame.on_axis(eo.ischial_height_m))));
  } else {
    est = estimate_bones(model.skin, frame, p.opt.type, eo);
  }
  const NamedMesh* femur_mesh = has_femur ? nullptr : &est.front();
  const NamedMesh& pelvis_mesh = est.back();
  const TriMesh& femur_for_axis = has_femur ? p.shells[p.femur_i].mesh : femur_mesh->mesh;
  const FemurAxis fa = has_femur ? *p.femur_axis : femur_shaft_axis(femur_for_axis, frame.on_axis(p.cut));
  p.tf_points = transfemoral_points(femur_for_axis, fa, pelvis_mesh.mesh, frame);
  p.tf_points->estimated = true;
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

/// Bones the file does not have, estimated from the skin when the options ask for it.
void estimate_missing_bones(LimbPreparation& p) {
  LimbModel& model = p.model;
  if (!p.tf && model.bones.empty() && p.opt.estimate_bones) {
    model.bones = estimate_bones(model.skin, model.frame, p.opt.type);
    model.bones_estimated = true;
    model.notes.push_back("no bones given: bones ESTIMATED from the skin by an anatomical template");
  }
  if (p.tf && p.opt.estimate_bones && !p.tf_points) estimate_transfemoral_bones(p);
}

}  // namespace

void place_bones(LimbPreparation& p) {
  store_bones(p, trim_bones(p));
  estimate_missing_bones(p);
}

}  // namespace socketsmith::volume::limb_model_detail
