#include "socketsmith/design/pain_map.h"

#include <cmath>

#include "socketsmith/core/errors.h"

namespace socketsmith::design {

ThresholdTable default_thresholds(geometry::LimbType type) {
  if (type == geometry::LimbType::Transfemoral)
    return {{"IS", 95.0e3}, {"IR", 42.9e3}, {"GT", 45.85e3}, {"AL", 34.0e3}, {"ST", 60.86e3}, {"DF", 45.85e3}};
  return {{"MF", 53.7e3}, {"PT", 189.72e3}, {"FH", 45.85e3}, {"POP", 60.86e3}, {"AD", 98.77e3}};
}

std::vector<std::string> required_threshold_codes(geometry::LimbType type) {
  if (type == geometry::LimbType::Transfemoral) return {"IS", "IR", "GT", "AL", "ST", "DF"};
  return {"MF", "PT", "FH", "POP", "AD"};
}

void validate_thresholds(const ThresholdTable& table, const std::vector<volume::Landmark>& landmarks,
                         geometry::LimbType type) {
  const bool tf = type == geometry::LimbType::Transfemoral;
  for (const auto& code : required_threshold_codes(type)) {
    const auto defaults = default_thresholds(type);
    const auto d = defaults.find(code);
    require(table.count(code) > 0, "pain threshold missing for landmark {}: add \"{}\": <kPa> to patient.thresholds_kpa{}",
            code, code,
            d != defaults.end() ? fmt::format(" ({}: {:.2f} kPa)", tf ? "default, docs/design.md" : "thesis Table 7",
                                              d->second / 1e3)
                                : std::string());
  }
  for (const auto& [code, value] : table) {
    bool known = false;
    for (const auto& l : landmarks) known = known || l.code == code;
    require(known || !(tf && code == "AR"),
            "pain threshold given for 'AR': the transfemoral landmark AR (adductor / pubic ramus) is now two, IR (ischial "
            "ramus) and AL (adductor longus tendon); give those instead");
    require(known, "pain threshold given for '{}', which is not a landmark of this {} limb (check the code)", code,
            geometry::to_string(type));
    require(std::isfinite(value) && value > 0,
            "pain threshold of landmark {} is {} kPa: give a positive pressure in kPa (e.g. 50)", code, value / 1e3);
    require(value < 2e6, "pain threshold of landmark {} is {:.0f} kPa, far above any tissue's (wrong unit? the case file "
            "takes kPa)", code, value / 1e3);
  }
}

std::vector<double> threshold_map(const std::vector<Eigen::Vector3d>& points,
                                  const std::vector<volume::Landmark>& landmarks, const ThresholdTable& table,
                                  double power) {
  std::vector<std::pair<Eigen::Vector3d, double>> sources;
  for (const auto& l : landmarks) {
    const auto it = table.find(l.code);
    if (it != table.end()) sources.emplace_back(l.position, it->second);
  }
  require(!sources.empty(), "pain-threshold map: no landmark has a threshold");
  require(std::isfinite(power) && power > 0, "pain-threshold map: IDW power {} must be positive", power);
  std::vector<double> out(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    double sw = 0, swt = 0;
    bool exact = false;
    for (const auto& [p, t] : sources) {
      const double d = (points[i] - p).norm();
      if (d < 1e-9) {
        out[i] = t;
        exact = true;
        break;
      }
      const double w = std::pow(d, -power);
      sw += w;
      swt += w * t;
    }
    if (!exact) out[i] = swt / sw;
  }
  return out;
}

}  // namespace socketsmith::design
