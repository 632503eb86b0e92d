#include "socketsmith/volume/landmarks.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"
#include "socketsmith/geometry/surface_query.h"
#include "socketsmith/volume/hex_mesh.h"

namespace socketsmith::volume {
namespace {

using geometry::LimbFrame;
using geometry::TriMesh;

/// Extent and centroid of a bone in the limb frame.
struct BoneInfo {
  bool present = false;
  double h_min = 0.0, h_max = 0.0;
  Vec3 centroid = Vec3::Zero();
  Vec3 lowest = Vec3::Zero();   ///< most distal vertex
  Vec3 highest = Vec3::Zero();  ///< most proximal vertex
};

BoneInfo bone_info(const std::vector<NamedMesh>& bones, const LimbFrame& frame, const std::string& role) {
  BoneInfo info;
  for (const auto& b : bones) {
    if (b.name.find(role) == std::string::npos || b.mesh.vertices.empty()) continue;
    info.present = true;
    info.h_min = std::numeric_limits<double>::infinity();
    info.h_max = -info.h_min;
    for (const auto& v : b.mesh.vertices) {
      const double h = frame.to_cylindrical(v).h;
      if (h < info.h_min) {
        info.h_min = h;
        info.lowest = v;
      }
      if (h > info.h_max) {
        info.h_max = h;
        info.highest = v;
      }
      info.centroid += v;
    }
    info.centroid /= static_cast<double>(b.mesh.vertices.size());
    break;
  }
  return info;
}

/// Angle of the centroid of the vertices of @p bone between heights lo and hi.
std::optional<double> bone_theta(const std::vector<NamedMesh>& bones, const LimbFrame& frame,
                                 const std::string& role, double lo, double hi) {
  for (const auto& b : bones) {
    if (b.name.find(role) == std::string::npos) continue;
    Vec3 c = Vec3::Zero();
    int n = 0;
    for (const auto& v : b.mesh.vertices) {
      const double h = frame.to_cylindrical(v).h;
      if (h >= lo && h <= hi) {
        c += v;
        ++n;
      }
    }
    if (n == 0) return std::nullopt;
    return frame.to_cylindrical(c / n).theta;
  }
  return std::nullopt;
}

Landmark on_skin(const geometry::SurfaceQuery& skin, const LimbFrame& frame, std::string code, std::string name,
                 double theta, double h, double radius) {
  const Vec3 from = frame.on_axis(h);
  const auto hit = skin.first_hit(from, frame.radial(theta));
  require(hit.has_value(),
          "landmark {} ({}) : no skin found from the limb axis at h = {:.0f} mm, theta = {:.0f} deg; "
          "check the limb axis or give the landmark in the case file",
          code, name, h * 1e3, theta / units::deg);
  Landmark l;
  l.code = std::move(code);
  l.name = std::move(name);
  l.position = hit->point;
  l.cylindrical = frame.to_cylindrical(hit->point);
  l.radius_m = radius;
  l.estimated = true;
  return l;
}

Landmark nearest_on_skin(const geometry::SurfaceQuery& skin, const LimbFrame& frame, std::string code,
                         std::string name, const Vec3& p, double radius) {
  Landmark l;
  l.code = std::move(code);
  l.name = std::move(name);
  l.position = skin.closest_point(p).point;
  l.cylindrical = frame.to_cylindrical(l.position);
  l.radius_m = radius;
  return l;
}

}  // namespace

std::vector<std::string> landmark_codes(geometry::LimbType type) {
  if (type == geometry::LimbType::Transtibial) return {"PT", "MF", "LF", "FH", "POP", "AD", "TC", "DT"};
  return {"IS", "IR", "GT", "AL", "ST", "DF"};
}

std::vector<Landmark> place_transfemoral_landmarks(const TriMesh& closed_skin, const LimbFrame& frame,
                                                   const TransfemoralPoints& points, double cut_height_m) {
  const geometry::SurfaceQuery skin(closed_skin);
  const double deg = units::deg, mm = units::mm;
  const double top = cut_height_m - 10 * mm;
  const auto is = frame.to_cylindrical(points.ischial_tuberosity);
  const auto ir = frame.to_cylindrical(points.ischial_ramus);
  const auto sy = frame.to_cylindrical(points.symphysis);
  std::vector<Landmark> out;
  out.push_back(on_skin(skin, frame, "IS", "ischial tuberosity", is.theta, std::min(is.h, top), 25 * mm));
  out.push_back(on_skin(skin, frame, "IR", "ischial ramus", ir.theta, std::min(ir.h, top), 20 * mm));
  if (points.greater_trochanter) {
    const auto gt = frame.to_cylindrical(*points.greater_trochanter);
    out.push_back(on_skin(skin, frame, "GT", "greater trochanter", gt.theta, std::min(gt.h, top), 30 * mm));
  } else {
    out.push_back(on_skin(skin, frame, "GT", "greater trochanter", -90 * deg, std::min(is.h + 35 * mm, top), 30 * mm));
  }
  const double al = std::clamp(sy.theta, 30 * deg, 75 * deg);
  out.push_back(on_skin(skin, frame, "AL", "adductor longus tendon", al, std::min(is.h + 5 * mm, top), 20 * mm));
  out.push_back(on_skin(skin, frame, "ST", "Scarpa's triangle", 0.4 * al, std::min(is.h + 20 * mm, top), 30 * mm));
  out.push_back(nearest_on_skin(skin, frame, "DF", "distal end of the femur", points.femur_distal_end, 25 * mm));
  for (auto& l : out) l.estimated = true;
  return out;
}

std::vector<Landmark> place_landmarks(const TriMesh& closed_skin, const LimbFrame& frame, geometry::LimbType type,
                                      const std::vector<NamedMesh>& bones, double cut_height_m,
                                      const TransfemoralPoints* transfemoral) {
  if (type == geometry::LimbType::Transfemoral && transfemoral != nullptr)
    return place_transfemoral_landmarks(closed_skin, frame, *transfemoral, cut_height_m);
  const geometry::SurfaceQuery skin(closed_skin);
  const double deg = units::deg, mm = units::mm;
  const double top = cut_height_m;
  std::vector<Landmark> out;
  if (type == geometry::LimbType::Transtibial) {
    const BoneInfo tibia = bone_info(bones, frame, "tibia");
    const BoneInfo fibula = bone_info(bones, frame, "fibula");
    const BoneInfo patella = bone_info(bones, frame, "patella");
    // Knee joint line: top of the tibia (plateau); without a tibia, 75 % of the stump height.
    const double knee = tibia.present ? std::min(tibia.h_max, top - 5 * mm) : 0.75 * top;
    const double pt_h = std::min(patella.present ? patella.h_min - 15 * mm : knee - 25 * mm, top - 10 * mm);
    out.push_back(on_skin(skin, frame, "PT", "patellar tendon", 0.0, pt_h, 15 * mm));
    const double flare_h = std::min(knee - 30 * mm, top - 10 * mm);
    out.push_back(on_skin(skin, frame, "MF", "medial flare", 55 * deg, flare_h, 20 * mm));
    out.push_back(on_skin(skin, frame, "LF", "lateral flare", -55 * deg, flare_h, 20 * mm));
    double fh_theta = -115 * deg, fh_h = std::min(knee - 20 * mm, top - 10 * mm);
    if (fibula.present) {
      fh_h = std::min(fibula.h_max - 10 * mm, top - 10 * mm);
      fh_theta = bone_theta(bones, frame, "fibula", fibula.h_max - 30 * mm, fibula.h_max).value_or(fh_theta);
    }
    out.push_back(on_skin(skin, frame, "FH", "fibular head", fh_theta, fh_h, 15 * mm));
    out.push_back(on_skin(skin, frame, "POP", "popliteal area", 180 * deg, std::min(knee - 10 * mm, top - 10 * mm), 25 * mm));
    const double tib_lo = tibia.present ? tibia.h_min : 0.2 * top;
    const double ad_theta = tibia.present ? bone_theta(bones, frame, "tibia", tib_lo, tib_lo + 30 * mm).value_or(0.0) : 0.0;
    out.push_back(on_skin(skin, frame, "AD", "anterior distal tibia", ad_theta, tib_lo + 15 * mm, 20 * mm));
    const double mid = 0.5 * (tib_lo + knee);
    const double tc_theta = tibia.present ? bone_theta(bones, frame, "tibia", mid - 15 * mm, mid + 15 * mm).value_or(0.0) : 0.0;
    out.push_back(on_skin(skin, frame, "TC", "tibial crest", tc_theta, mid, 15 * mm));
    if (tibia.present)
      out.push_back(nearest_on_skin(skin, frame, "DT", "distal end of the tibia", tibia.lowest, 20 * mm));
    else
      out.push_back(on_skin(skin, frame, "DT", "distal end of the tibia", 0.0, 0.1 * top, 20 * mm));
  } else {
    // No hemipelvis: fixed places below the cut (the tuberosity 75 mm below it, as the limb model
    // cuts a transfemoral stump by default).
    const BoneInfo femur = bone_info(bones, frame, "femur");
    const double is_h = std::max(0.5 * top, top - 75 * mm);
    out.push_back(on_skin(skin, frame, "IS", "ischial tuberosity", 135 * deg, is_h, 25 * mm));
    out.push_back(on_skin(skin, frame, "IR", "ischial ramus", 100 * deg, is_h + 10 * mm, 20 * mm));
    out.push_back(on_skin(skin, frame, "GT", "greater trochanter", -100 * deg, is_h + 35 * mm, 30 * mm));
    out.push_back(on_skin(skin, frame, "AL", "adductor longus tendon", 55 * deg, is_h + 5 * mm, 20 * mm));
    out.push_back(on_skin(skin, frame, "ST", "Scarpa's triangle", 22 * deg, is_h + 20 * mm, 30 * mm));
    if (femur.present)
      out.push_back(nearest_on_skin(skin, frame, "DF", "distal end of the femur", femur.lowest, 25 * mm));
    else
      out.push_back(on_skin(skin, frame, "DF", "distal end of the femur", 0.0, 0.1 * top, 25 * mm));
  }
  return out;
}

void override_landmark(std::vector<Landmark>& landmarks, const TriMesh& closed_skin, const LimbFrame& frame,
                       const Landmark& given) {
  auto it = std::find_if(landmarks.begin(), landmarks.end(), [&](const Landmark& l) { return l.code == given.code; });
  require(it != landmarks.end(), "landmark code '{}' is not known for this limb type", given.code);
  const geometry::SurfaceQuery skin(closed_skin);
  const auto hit = skin.closest_point(given.position);
  require(hit.distance <= 20 * units::mm,
          "landmark {} is {:.0f} mm from the skin (at most 20 mm expected): a spot outside the limb? "
          "check its coordinates and units (mm in case files)",
          given.code, hit.distance / units::mm);
  Landmark l = given;
  if (l.name.empty()) l.name = it->name;
  l.position = hit.point;
  l.cylindrical = frame.to_cylindrical(hit.point);
  l.estimated = false;
  *it = l;
}

}  // namespace socketsmith::volume
