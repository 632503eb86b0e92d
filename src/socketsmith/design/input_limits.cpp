#include "socketsmith/design/input_limits.h"

#include <cmath>

#include <fmt/format.h>

#include "socketsmith/core/errors.h"
#include "socketsmith/design/design_solver.h"

namespace socketsmith::design {

const std::vector<InputLimit>& all_input_limits() {
  using namespace limits;
  static const std::vector<InputLimit> all{kBodyMass,      kProsthesisMass,     kFriction,      kForceTolerance,
                                           kTorqueTolerance, kPainThreshold,    kYoungsModulus, kDensity,
                                           kFePoisson,     kCfPoisson,          kTargetNodes,   kModelPressureLimit,
                                           kMaxAmplitude,  kTimeLimit,          kCutHeight,     kThickness,
                                           kDistalPadDiameter, kSubdivisions, kClosedLoopDonnings,
                                           kDistalThickness, kBrimThickness, kFlexion, kAdduction,
                                           kHoleDiameter, kHoleSpacing, kPlatformDiameter, kPlatformThickness,
                                           kAttachmentOffset, kAttachmentRotation, kScale, kIschialShareMin,
                                           kSpotAmplitude, kSpotTheta0, kSpotRTheta, kSpotH0, kSpotRH, kSpotTheta1,
                                           kSpotTheta2, kSpotLambdaTheta, kSpotH1, kSpotH2, kSpotLambdaH};
  return all;
}

std::string describe(const InputLimit& l) {
  std::string s = fmt::format("{}{}, {}{}", l.is_min_open ? "(" : "[", l.min, l.max, l.is_max_open ? ")" : "]");
  if (!l.unit.empty()) s += fmt::format(" {}", l.unit);
  if (l.is_integer) s += " (whole numbers)";
  return s;
}

std::string input_violation(const InputLimit& l, double value) {
  const std::string unit = l.unit.empty() ? std::string() : fmt::format(" {}", l.unit);
  if (!std::isfinite(value))
    return fmt::format("{} is not a finite number: give a value in {}: {}", value, describe(l), l.hint);
  const bool above_min = l.is_min_open ? value > l.min : value >= l.min;
  const bool below_max = l.is_max_open ? value < l.max : value <= l.max;
  if (!above_min || !below_max) return fmt::format("{}{} is outside {}: {}", value, unit, describe(l), l.hint);
  if (l.is_integer && value != std::floor(value))
    return fmt::format("{} is not a whole number: give one in {}: {}", value, describe(l), l.hint);
  return {};
}

double check_input(const InputLimit& l, double value, std::string_view name) {
  const std::string why = input_violation(l, value);
  require(why.empty(), "{} = {}", name, why);
  return value;
}

int check_input_count(const InputLimit& l, double value, std::string_view name) {
  require(l.is_integer && l.max <= 2e9, "check_input_count: limit '{}' is not a count", l.key);
  return static_cast<int>(check_input(l, value, name));
}

void check_patient(const PatientLoad& p, std::string_view prefix) {
  const auto name = [&](const InputLimit& l) { return fmt::format("{}{}", prefix, l.key); };
  check_input(limits::kBodyMass, p.body_mass_kg, name(limits::kBodyMass));
  check_input(limits::kProsthesisMass, p.prosthesis_mass_kg, name(limits::kProsthesisMass));
  require(p.prosthesis_mass_kg < p.body_mass_kg,
          "{}patient.prosthesis_mass_kg = {} kg is not below the body mass {} kg: give both in kg", prefix,
          p.prosthesis_mass_kg, p.body_mass_kg);
  check_input(limits::kFriction, p.friction, name(limits::kFriction));
  check_input(limits::kForceTolerance, p.force_tolerance, name(limits::kForceTolerance));
  check_input(limits::kTorqueTolerance, p.torque_tolerance, name(limits::kTorqueTolerance));
}

}  // namespace socketsmith::design
