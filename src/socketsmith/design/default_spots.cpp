// The default spots of a limb type placed from its landmarks (Tables 5-6 of the thesis) and the
// total-contact background; apart from optimizer.cpp because where the spots start is not how the
// optimiser moves them.
#include <cmath>
#include <numbers>
#include <string>

#include "socketsmith/core/errors.h"
#include "socketsmith/design/amplitude_fit.h"
#include "socketsmith/design/optimizer.h"

namespace socketsmith::design {
namespace {
using optimizer_detail::kRef;  // the spots start at the fit's amplitude scale
constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kPi = std::numbers::pi;

const volume::Landmark* find_landmark(const std::vector<volume::Landmark>& lms, const std::string& code) {
  for (const auto& l : lms)
    if (l.code == code) return &l;
  return nullptr;
}

Spot cos2(const std::string& name, double theta, double h, double r_theta, double r_h) {
  return {.name = name, .type = SpotType::Cos2, .amplitude_pa = kRef, .theta0 = theta, .r_theta = r_theta, .h0 = h,
          .r_h = r_h};
}

Spot cos_sig(const std::string& name, double theta, double r_theta, double h1, double h2, double lambda_h) {
  return {.name = name, .type = SpotType::CosSig, .amplitude_pa = kRef, .theta0 = theta, .r_theta = r_theta,
          .h1 = h1, .h2 = h2, .lambda_h = lambda_h};
}
}  // namespace

std::vector<Spot> default_spots(geometry::LimbType type, const std::vector<volume::Landmark>& lms, double L,
                                bool total_surface) {
  const auto need = [&](const char* code) -> const volume::Landmark& {
    const auto* l = find_landmark(lms, code);
    require(l != nullptr, "default spot layout: landmark {} is missing (place it in the case file's landmarks)", code);
    return *l;
  };
  std::vector<Spot> s;
  const double lam = 8.0 / (0.05 * L);  // sigmoid edges over ~5 % of the length
  if (type == geometry::LimbType::Transtibial) {
    const auto& pt = need("PT");
    const auto& pop = need("POP");
    const auto& mf = need("MF");
    const auto& lf = need("LF");
    s.push_back(cos2("PT", pt.cylindrical.theta, pt.cylindrical.h, 25 * kDeg, 0.015));
    s.push_back(cos2("POP", pop.cylindrical.theta, std::min(pop.cylindrical.h, pt.cylindrical.h), 50 * kDeg, 0.025));
    s.push_back(cos2("MF", mf.cylindrical.theta, mf.cylindrical.h, 30 * kDeg, 0.025));
    s.push_back(cos2("LF", lf.cylindrical.theta, lf.cylindrical.h, 30 * kDeg, 0.025));
    s.push_back(cos_sig("medial tibia", 60 * kDeg, 30 * kDeg, 0.25 * L, 0.6 * L, lam));
    s.push_back(cos_sig("lateral tibia", -60 * kDeg, 30 * kDeg, 0.25 * L, 0.6 * L, lam));
    s.push_back(cos_sig("posterior calf", 180 * kDeg, 60 * kDeg, 0.2 * L, 0.6 * L, lam));
  } else {
    // Where a transfemoral socket bears (docs/design.md): the ischial seat and the gluteal mass
    // behind it, the lateral wall over the trochanter and along the femur (it holds the femur in
    // adduction), Scarpa's triangle as the anterior counter-support, the walls, a little ramus.
    const auto& is = need("IS").cylindrical;
    const auto& ir = need("IR").cylindrical;
    const auto& gt = need("GT").cylindrical;
    const auto& st = need("ST").cylindrical;
    s.push_back(cos2("ischial seat", is.theta, is.h, 35 * kDeg, 0.025));
    s.push_back(cos_sig("gluteal", wrap_angle(0.5 * (is.theta + kPi)), 50 * kDeg, is.h - 0.04, is.h + 0.04, lam));
    s.push_back(cos2("ischial ramus", ir.theta, ir.h, 20 * kDeg, 0.02));
    s.push_back(cos_sig("lateral wall", gt.theta, 45 * kDeg, 0.3 * L, gt.h + 0.01, lam));
    s.push_back(cos_sig("lateral femur", -90 * kDeg, 40 * kDeg, 0.3 * L, 0.7 * L, lam));
    s.push_back(cos2("Scarpa's triangle", st.theta, st.h, 30 * kDeg, 0.03));
    s.push_back(cos_sig("anterior wall", 0.0, 45 * kDeg, 0.3 * L, 0.75 * L, lam));
    s.push_back(cos_sig("posterior wall", 180 * kDeg, 45 * kDeg, 0.3 * L, 0.75 * L, lam));
    s.push_back(cos_sig("medial wall", 90 * kDeg, 40 * kDeg, 0.3 * L, 0.7 * L, lam));
  }
  // Total contact: a background of broad COS2 spots tiled below the brim (8 around × 3 heights),
  // so that the optimiser can spread the load where the landmark spots alone would peak; a fourth
  // row centred at 0.8 L reaches the brim for total surface bearing.
  for (int j = 0; j < (total_surface ? 4 : 3); ++j)
    for (int i = 0; i < 8; ++i) {
      Spot c = cos2(fmt::format("contact {}/{}", i + 1, j + 1), wrap_angle((-180 + 45 * i) * kDeg), (0.2 + 0.2 * j) * L,
                    45 * kDeg, 0.2 * L);
      c.amplitude_pa = 0.2 * kRef;
      c.optimise_position = false;
      s.push_back(c);
    }
  Spot g;
  g.name = "distal";
  g.type = SpotType::Grad;
  g.h1 = 0.08 * L;
  g.h2 = 0.3 * L;
  g.amplitude_pa = 0.5 * kRef;
  g.max_amplitude_pa = kRef;
  s.push_back(g);
  return s;
}

}  // namespace socketsmith::design
