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
  return {"IS", "AR", "GT", "DF"};
}

std::vector<Landmark> place_landmarks(const TriMesh& closed_skin, const LimbFrame& frame, geometry::LimbType type,
                                      const std::vector<NamedMesh>& bones, double cut_height_m) {
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
    const BoneInfo femur = bone_info(bones, frame, "femur");
    out.push_back(on_skin(skin, frame, "IS", "ischial seat", 150 * deg, top - 15 * mm, 25 * mm));
    out.push_back(on_skin(skin, frame, "AR", "adductor / pubic ramus", 90 * deg, top - 20 * mm, 25 * mm));
    out.push_back(on_skin(skin, frame, "GT", "greater trochanter", -90 * deg, top - 20 * mm, 30 * mm));
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
