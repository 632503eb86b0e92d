#include "socketsmith/design/spots.h"

#include <cctype>
#include <cmath>
#include <numbers>

#include "socketsmith/core/enum_names.h"
#include "socketsmith/core/errors.h"

namespace socketsmith::design {
namespace {
constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

/// A logistic factor 1/(1 + e^z) without overflow.
double logistic_of(double z) { return z > 0 ? std::exp(-z) / (1.0 + std::exp(-z)) : 1.0 / (1.0 + std::exp(z)); }

/// Positive angular distance from a to b going towards increasing angles, in [0, 2π).
double ccw_span(double a, double b) {
  double d = std::fmod(b - a, 2 * kPi);
  if (d < 0) d += 2 * kPi;
  return d;
}

std::string upper(std::string_view name) {
  std::string u(name);
  for (char& c : u) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return u;
}
}  // namespace

constexpr EnumName<SpotType> kSpotTypes[] = {
    {SpotType::Cos2, "cos2"}, {SpotType::Sig2, "sig2"}, {SpotType::CosSig, "cos-sig"}, {SpotType::Grad, "grad"}};

std::string to_string(SpotType type) { return name_of(kSpotTypes, type); }

SpotType parse_spot_type(const std::string& text) {
  for (const auto& n : kSpotTypes)  // the name, or the name all in upper case as the thesis prints it
    if (text == n.name || text == upper(n.name)) return n.value;
  fail("spot type '{}' is not known (expected cos2, sig2, cos-sig or grad)", text);
}

double wrap_angle(double a) {
  double w = std::remainder(a, 2 * kPi);  // in [−π, π]
  if (w <= -kPi) w += 2 * kPi;
  return w;
}

double key_cos(double x, double x0, double r) {
  const double d = x - x0;
  if (std::abs(d) > r) return 0.0;
  return 0.5 * (1.0 + std::cos(kPi * d / r));
}

double key_sig(double x, double x1, double x2, double lambda) {
  return logistic_of(-lambda * (x - x1)) * logistic_of(lambda * (x - x2));
}

double key_rmp(double x, double x1, double x2) {
  if (x < x1) return 1.0;
  if (x > x2) return 0.0;
  return (x - x2) / (x1 - x2);
}

namespace {
double f_theta(const Spot& s, double theta) {
  switch (s.type) {
    case SpotType::Cos2:
    case SpotType::CosSig: return key_cos(wrap_angle(theta - s.theta0), 0.0, s.r_theta);
    case SpotType::Sig2: {
      const double width = ccw_span(s.theta1, s.theta2);
      const double mid = s.theta1 + 0.5 * width;
      return key_sig(wrap_angle(theta - mid), -0.5 * width, 0.5 * width, s.lambda_theta);
    }
    case SpotType::Grad: return 1.0;
  }
  return 0.0;
}
double f_h(const Spot& s, double h) {
  switch (s.type) {
    case SpotType::Cos2: return key_cos(h, s.h0, s.r_h);
    case SpotType::Sig2:
    case SpotType::CosSig: return key_sig(h, s.h1, s.h2, s.lambda_h);
    case SpotType::Grad: return key_rmp(h, s.h1, s.h2);
  }
  return 0.0;
}
}  // namespace

double spot_shape(const Spot& spot, double theta, double h) {
  const double a = f_h(spot, h);
  return a == 0.0 ? 0.0 : a * f_theta(spot, theta);
}

double field_pressure(const std::vector<Spot>& spots, double theta, double h) {
  double p = 0;
  for (const auto& s : spots) p += spot_pressure(s, theta, h);
  return p;
}

void spot_centre(const Spot& s, double& theta, double& h) {
  switch (s.type) {
    case SpotType::Cos2: theta = s.theta0; h = s.h0; return;
    case SpotType::CosSig: theta = s.theta0; h = 0.5 * (s.h1 + s.h2); return;
    case SpotType::Sig2: theta = wrap_angle(s.theta1 + 0.5 * ccw_span(s.theta1, s.theta2)); h = 0.5 * (s.h1 + s.h2); return;
    case SpotType::Grad: theta = 0.0; h = 0.5 * (s.h1 + s.h2); return;
  }
}

void validate_spot(const Spot& s, double limb_length_m) {
  const std::string& n = s.name.empty() ? std::string("(unnamed)") : s.name;
  const auto finite = [&](double v, const char* field) {
    require(std::isfinite(v), "spot {}: {} is not a finite number (fix the case file)", n, field);
  };
  finite(s.amplitude_pa, "amplitude_kpa");
  require(s.amplitude_pa >= 0, "spot {}: amplitude {:.3g} kPa is negative (a socket can only push: use 0 or more)", n,
          s.amplitude_pa / 1e3);
  const double lo = -0.1 * limb_length_m, hi = 1.1 * limb_length_m;
  const auto height_on_limb = [&](double h, const char* field) {
    finite(h, field);
    require(h >= lo && h <= hi,
            "spot {}: {} = {:.1f} mm is off the limb (heights 0–{:.1f} mm above the distal end): move the spot onto "
            "the limb",
            n, field, h * 1e3, limb_length_m * 1e3);
  };
  switch (s.type) {
    case SpotType::Cos2:
    case SpotType::CosSig:
      finite(s.theta0, "theta0_deg");
      require(std::isfinite(s.r_theta) && s.r_theta > 0 && s.r_theta <= kPi,
              "spot {}: r_theta {:.3g} deg must be in (0, 180]", n, s.r_theta / kDeg);
      break;
    case SpotType::Sig2:
      finite(s.theta1, "theta1_deg");
      finite(s.theta2, "theta2_deg");
      require(std::isfinite(s.lambda_theta) && s.lambda_theta > 0, "spot {}: lambda_theta must be positive", n);
      require(ccw_span(s.theta1, s.theta2) > 1e-6, "spot {}: theta1 and theta2 are equal (an empty sector)", n);
      break;
    case SpotType::Grad: break;
  }
  switch (s.type) {
    case SpotType::Cos2:
      height_on_limb(s.h0, "h0_mm");
      require(std::isfinite(s.r_h) && s.r_h > 0, "spot {}: r_h {:.3g} mm must be positive", n, s.r_h * 1e3);
      break;
    case SpotType::Sig2:
    case SpotType::CosSig:
      require(std::isfinite(s.lambda_h) && s.lambda_h > 0, "spot {}: lambda_h must be positive", n);
      [[fallthrough]];
    case SpotType::Grad:
      height_on_limb(s.h1, "h1_mm");
      height_on_limb(s.h2, "h2_mm");
      require(s.h2 > s.h1, "spot {}: h2 = {:.1f} mm must be above h1 = {:.1f} mm", n, s.h2 * 1e3, s.h1 * 1e3);
      break;
  }
}

}  // namespace socketsmith::design
