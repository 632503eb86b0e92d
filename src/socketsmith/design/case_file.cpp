#include "socketsmith/design/case_file.h"

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>
#include <tuple>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/json_input.h"
#include "socketsmith/core/units.h"
#include "socketsmith/design/input_limits.h"

namespace socketsmith::design {
namespace {
using nlohmann::json;
constexpr double kDeg = units::deg;

void check_keys(const json& j, const std::string& where, const std::set<std::string>& known) {
  require(j.is_object(), "case file: '{}' must be a JSON object", where);
  for (const auto& [k, v] : j.items()) {
    if (known.count(k)) continue;
    std::string list;
    for (const auto& n : known) list += (list.empty() ? "" : ", ") + n;
    fail("case file: unknown key '{}' in '{}' (known: {})", k, where, list);
  }
}

double number(const json& j, const std::string& key, const std::string& where, double fallback) {
  if (!j.contains(key)) return fallback;
  const auto& v = j.at(key);
  require(v.is_number(), "case file: '{}.{}' must be a number (got {})", where, key, v.dump());
  const double d = v.get<double>();
  require(std::isfinite(d), "case file: '{}.{}' is not finite", where, key);
  return d;
}

/// A number of @p j checked against its limit (the name in messages is the case-file key).
double limited(const json& j, const std::string& key, const std::string& where, double fallback,
               const InputLimit& limit) {
  if (!j.contains(key)) return fallback;
  return check_input(limit, number(j, key, where, fallback), fmt::format("case file: {}.{}", where, key));
}

/// A whole number of @p j checked against its limit before it becomes an int.
int count(const json& j, const std::string& key, const std::string& where, int fallback, const InputLimit& limit) {
  if (!j.contains(key)) return fallback;
  return check_input_count(limit, number(j, key, where, fallback), fmt::format("case file: {}.{}", where, key));
}

std::string text(const json& j, const std::string& key, const std::string& where, const std::string& fallback) {
  if (!j.contains(key)) return fallback;
  require(j.at(key).is_string(), "case file: '{}.{}' must be a string (got {})", where, key, j.at(key).dump());
  return j.at(key).get<std::string>();
}

bool flag(const json& j, const std::string& key, const std::string& where, bool fallback) {
  if (!j.contains(key)) return fallback;
  require(j.at(key).is_boolean(), "case file: '{}.{}' must be true or false (got {})", where, key, j.at(key).dump());
  return j.at(key).get<bool>();
}

Eigen::Vector3d vec3(const json& j, const std::string& where) {
  require(j.is_array() && j.size() == 3 && j[0].is_number() && j[1].is_number() && j[2].is_number(),
          "case file: '{}' must be [x, y, z] (got {})", where, j.dump());
  Eigen::Vector3d v(j[0].get<double>(), j[1].get<double>(), j[2].get<double>());
  require(v.allFinite(), "case file: '{}' is not finite", where);
  return v;
}

std::string objective_name(OptimizerOptions::Objective o) {
  switch (o) {
    case OptimizerOptions::Objective::Ratio: return "ratio";
    case OptimizerOptions::Objective::Uniform: return "uniform";
    default: return "pressure";
  }
}
}  // namespace

json spot_to_json(const Spot& s) {
  json j{{"name", s.name}, {"type", to_string(s.type)}, {"amplitude_kpa", s.amplitude_pa / 1e3}};
  switch (s.type) {
    case SpotType::Cos2:
      j["theta0_deg"] = s.theta0 / kDeg;
      j["r_theta_deg"] = s.r_theta / kDeg;
      j["h0_mm"] = s.h0 * 1e3;
      j["r_h_mm"] = s.r_h * 1e3;
      break;
    case SpotType::Sig2:
      j["theta1_deg"] = s.theta1 / kDeg;
      j["theta2_deg"] = s.theta2 / kDeg;
      j["lambda_theta_per_deg"] = s.lambda_theta * kDeg;
      j["h1_mm"] = s.h1 * 1e3;
      j["h2_mm"] = s.h2 * 1e3;
      j["lambda_h_per_mm"] = s.lambda_h * 1e-3;
      break;
    case SpotType::CosSig:
      j["theta0_deg"] = s.theta0 / kDeg;
      j["r_theta_deg"] = s.r_theta / kDeg;
      j["h1_mm"] = s.h1 * 1e3;
      j["h2_mm"] = s.h2 * 1e3;
      j["lambda_h_per_mm"] = s.lambda_h * 1e-3;
      break;
    case SpotType::Grad:
      j["h1_mm"] = s.h1 * 1e3;
      j["h2_mm"] = s.h2 * 1e3;
      break;
  }
  if (!s.enabled) j["enabled"] = false;
  if (!s.optimise_amplitude) j["optimise_amplitude"] = false;
  if (!s.optimise_position) j["optimise_position"] = false;
  if (s.max_amplitude_pa > 0) j["max_amplitude_kpa"] = s.max_amplitude_pa / 1e3;
  return j;
}

Spot spot_from_json(const json& j, const std::string& where) {
  check_keys(j, where,
             {"name", "type", "amplitude_kpa", "theta0_deg", "r_theta_deg", "h0_mm", "r_h_mm", "theta1_deg", "theta2_deg",
              "lambda_theta_per_deg", "h1_mm", "h2_mm", "lambda_h_per_mm", "enabled", "optimise_amplitude",
              "optimise_position", "max_amplitude_kpa"});
  Spot s;
  s.name = text(j, "name", where, where);
  require(j.contains("type"), "case file: '{}' has no 'type' (cos2, sig2, cos-sig or grad)", where);
  s.type = parse_spot_type(text(j, "type", where, ""));
  s.amplitude_pa = number(j, "amplitude_kpa", where, 10.0) * 1e3;
  s.theta0 = number(j, "theta0_deg", where, s.theta0 / kDeg) * kDeg;
  s.r_theta = number(j, "r_theta_deg", where, s.r_theta / kDeg) * kDeg;
  s.h0 = number(j, "h0_mm", where, s.h0 * 1e3) * 1e-3;
  s.r_h = number(j, "r_h_mm", where, s.r_h * 1e3) * 1e-3;
  s.theta1 = number(j, "theta1_deg", where, s.theta1 / kDeg) * kDeg;
  s.theta2 = number(j, "theta2_deg", where, s.theta2 / kDeg) * kDeg;
  s.lambda_theta = number(j, "lambda_theta_per_deg", where, s.lambda_theta * kDeg) / kDeg;
  s.h1 = number(j, "h1_mm", where, s.h1 * 1e3) * 1e-3;
  s.h2 = number(j, "h2_mm", where, s.h2 * 1e3) * 1e-3;
  s.lambda_h = number(j, "lambda_h_per_mm", where, s.lambda_h * 1e-3) * 1e3;
  s.enabled = flag(j, "enabled", where, true);
  s.optimise_amplitude = flag(j, "optimise_amplitude", where, true);
  s.optimise_position = flag(j, "optimise_position", where, true);
  s.max_amplitude_pa = limited(j, "max_amplitude_kpa", where, 0.0, limits::kMaxAmplitude) * 1e3;
  require(s.amplitude_pa >= 0, "case file: '{}.amplitude_kpa' is negative (a socket can only push: use 0 or more)",
          where);
  return s;
}

namespace {
/// socket.alignment and socket.attachment (issue 22): the distal platform and its four holes.
void parse_socket_attachment(const json& j, SocketOptions& s) {
  if (j.contains("alignment")) {
    const auto& a = j.at("alignment");
    check_keys(a, "socket.alignment", {"flexion_deg", "adduction_deg"});
    s.alignment.flexion_rad = limited(a, "flexion_deg", "socket.alignment", s.alignment.flexion_rad / kDeg,
                                      limits::kFlexion) * kDeg;
    s.alignment.adduction_rad = limited(a, "adduction_deg", "socket.alignment", s.alignment.adduction_rad / kDeg,
                                        limits::kAdduction) * kDeg;
  }
  if (!j.contains("attachment")) return;
  const auto& a = j.at("attachment");
  const std::string w = "socket.attachment";
  check_keys(a, w, {"enabled", "bolt", "hole_diameter_mm", "hole_spacing_mm", "platform_diameter_mm",
                    "platform_thickness_mm", "rotation_deg", "offset_mm"});
  SocketAttachment& t = s.attachment;
  t.enabled = flag(a, "enabled", w, true);
  t.bolt = text(a, "bolt", w, t.bolt);
  t.bolt_diameter_m = bolt_diameter_m(t.bolt);
  t.hole_diameter_m = limited(a, "hole_diameter_mm", w, clearance_hole_diameter_m(t.bolt) / units::mm,
                              limits::kHoleDiameter) * units::mm;
  t.hole_spacing_m = limited(a, "hole_spacing_mm", w, t.hole_spacing_m / units::mm, limits::kHoleSpacing) * units::mm;
  t.platform_diameter_m =
      limited(a, "platform_diameter_mm", w, t.platform_diameter_m / units::mm, limits::kPlatformDiameter) * units::mm;
  t.platform_thickness_m =
      limited(a, "platform_thickness_mm", w, t.platform_thickness_m / units::mm, limits::kPlatformThickness) * units::mm;
  t.rotation_rad = number(a, "rotation_deg", w, t.rotation_rad / kDeg) * kDeg;
  if (a.contains("offset_mm")) {
    const auto& o = a.at("offset_mm");
    require(o.is_array() && o.size() == 2 && o[0].is_number() && o[1].is_number(),
            "case file: socket.attachment.offset_mm must be [anterior, medial] in mm (got {})", o.dump());
    t.offset_anterior_m =
        check_input(limits::kAttachmentOffset, o[0].get<double>(), "case file: socket.attachment.offset_mm[0] (anterior)") *
        units::mm;
    t.offset_medial_m =
        check_input(limits::kAttachmentOffset, o[1].get<double>(), "case file: socket.attachment.offset_mm[1] (medial)") *
        units::mm;
  }
  require(t.hole_diameter_m >= t.bolt_diameter_m,
          "case file: socket.attachment.hole_diameter_mm = {:.1f} is narrower than the {} bolt; give a clearance hole "
          "(ISO 273 medium: {:.1f} mm) or leave it out",
          t.hole_diameter_m / units::mm, t.bolt, clearance_hole_diameter_m(t.bolt) / units::mm);
}

json socket_attachment_json(const SocketOptions& s) {
  json out{{"alignment", {{"flexion_deg", s.alignment.flexion_rad / kDeg}, {"adduction_deg", s.alignment.adduction_rad / kDeg}}}};
  if (s.distal_thickness_m > 0) out["distal_thickness_mm"] = s.distal_thickness_m / units::mm;
  if (s.brim_thickness_m > 0) out["brim_thickness_mm"] = s.brim_thickness_m / units::mm;
  if (s.attachment.enabled) {
    const auto& t = s.attachment;
    out["attachment"] = {{"bolt", t.bolt},
                         {"hole_diameter_mm", t.hole_diameter_m / units::mm},
                         {"hole_spacing_mm", t.hole_spacing_m / units::mm},
                         {"platform_diameter_mm", t.platform_diameter_m / units::mm},
                         {"platform_thickness_mm", t.platform_thickness_m / units::mm},
                         {"rotation_deg", t.rotation_rad / kDeg},
                         {"offset_mm", {t.offset_anterior_m / units::mm, t.offset_medial_m / units::mm}}};
  }
  return out;
}
}  // namespace

namespace {
const char* direction_hint(LimbDirection which) {
  return which == LimbDirection::Axis ? "the long axis, distal to proximal, e.g. 0,0,1"
                                      : "the front of the limb, e.g. 0,1,0";
}
}  // namespace

Eigen::Vector3d check_limb_direction(const Eigen::Vector3d& v, LimbDirection which, const std::string& where) {
  require(v.allFinite(), "{} is not finite (give {})", where, direction_hint(which));
  require(v.norm() > 0.0, "{} is the zero vector (give {})", where, direction_hint(which));
  return v;
}

Eigen::Vector3d parse_limb_direction(const std::string& text, LimbDirection which, const std::string& flag) {
  Eigen::Vector3d v;
  char c1 = 0, c2 = 0;
  std::istringstream in(text);
  in >> v.x() >> c1 >> v.y() >> c2 >> v.z();
  const bool complete = in && c1 == ',' && c2 == ',' && (in >> std::ws).eof();
  require(complete, "{} '{}' is not a direction x,y,z ({})", flag, text, direction_hint(which));
  return check_limb_direction(v, which, fmt::format("{} '{}'", flag, text));
}

DesignSolveMode default_solve_mode(const std::string& model) {
  return model == "neo-hookean" ? DesignSolveMode::Nonlinear : DesignSolveMode::Linear;
}

CaseFile parse_case(const json& doc, const std::filesystem::path& folder) {
  CaseFile c;
  c.folder = folder;
  check_keys(doc, "case", {"socketsmith_case", "limb", "patient", "tissue", "mesh", "landmarks", "design", "brim", "socket"});
  if (doc.contains("socketsmith_case"))
    require(doc.at("socketsmith_case") == 1, "case file: version {} is not supported (this socketsmith reads 1)",
            doc.at("socketsmith_case").dump());
  if (doc.contains("limb")) {
    const auto& j = doc.at("limb");
    check_keys(j, "limb", {"file", "bones", "units", "scale", "type", "side", "anterior", "axis", "cut_height_mm",
                           "force_size", "generate_seed"});
    c.limb.file = text(j, "file", "limb", "");
    require(!j.contains("file") || !c.limb.file.empty(),
            "case file: limb.file is empty: give the scan's path (STL/OBJ/PLY), or remove 'file' to use the generated "
            "sample limb");
    c.limb.bones = text(j, "bones", "limb", "auto");
    require(!c.limb.bones.empty(),
            "case file: limb.bones is empty: give auto, estimate, none or the path of a bone file");
    c.limb.units = text(j, "units", "limb", "");
    if (!c.limb.units.empty()) (void)units::parse_length_unit(c.limb.units);
    c.limb.scale = number(j, "scale", "limb", 1.0);
    require(c.limb.scale > 0.0 && c.limb.scale <= 1e4,
            "case file: limb.scale = {} must be positive (it multiplies the coordinates after the units; e.g. 0.45 "
            "with units m for a shape normalised to a 0.45 m femur)",
            c.limb.scale);
    c.limb.force_size = flag(j, "force_size", "limb", false);
    if (j.contains("axis"))
      c.limb.axis = check_limb_direction(vec3(j.at("axis"), "limb.axis"), LimbDirection::Axis, "case file: 'limb.axis'");
    c.limb.type = geometry::parse_limb_type(text(j, "type", "limb", "transtibial"));
    if (j.contains("side")) c.limb.side = geometry::parse_side(text(j, "side", "limb", ""));
    if (j.contains("anterior"))
      c.limb.anterior =
          check_limb_direction(vec3(j.at("anterior"), "limb.anterior"), LimbDirection::Anterior, "case file: 'limb.anterior'");
    if (j.contains("cut_height_mm")) c.limb.cut_height_m = limited(j, "cut_height_mm", "limb", 0, limits::kCutHeight) * 1e-3;
    if (j.contains("generate_seed")) {
      // A document built in code holds a positive int as a signed integer; a parsed file, unsigned.
      const auto& seed = j.at("generate_seed");
      require(seed.is_number_unsigned() || (seed.is_number_integer() && seed.get<long long>() >= 0),
              "case file: 'limb.generate_seed' must be a whole number ≥ 0");
      c.limb.generate_seed = j.at("generate_seed").get<std::uint64_t>();
    }
  }
  if (doc.contains("patient")) {
    const auto& j = doc.at("patient");
    check_keys(j, "patient", {"id", "note", "body_mass_kg", "prosthesis_mass_kg", "friction", "thresholds_kpa",
                              "force_tolerance", "torque_tolerance"});
    c.patient_id = text(j, "id", "patient", "");
    c.patient_note = text(j, "note", "patient", "");
    c.patient.body_mass_kg = number(j, "body_mass_kg", "patient", c.patient.body_mass_kg);
    c.patient.prosthesis_mass_kg = number(j, "prosthesis_mass_kg", "patient", c.patient.prosthesis_mass_kg);
    c.patient.friction = number(j, "friction", "patient", c.patient.friction);
    c.patient.force_tolerance = number(j, "force_tolerance", "patient", c.patient.force_tolerance);
    c.patient.torque_tolerance = number(j, "torque_tolerance", "patient", c.patient.torque_tolerance);
    if (j.contains("thresholds_kpa")) {
      const auto& t = j.at("thresholds_kpa");
      require(t.is_object(), "case file: 'patient.thresholds_kpa' must be an object {{\"PT\": 189.72, ...}}");
      for (const auto& [code, v] : t.items()) {
        require(v.is_number(), "case file: pain threshold of landmark {} must be a number in kPa (got {})", code,
                v.dump());
        c.thresholds[code] =
            check_input(limits::kPainThreshold, v.get<double>(), "case file: patient.thresholds_kpa." + code) * 1e3;
      }
    }
  }
  // Validate the patient now: the message names the field.
  check_patient(c.patient, "case file: ");
  if (doc.contains("tissue")) {
    const auto& j = doc.at("tissue");
    check_keys(j, "tissue", {"model", "constants", "youngs_kpa", "density_kg_m3", "poisson", "solve"});
    c.model = text(j, "model", "tissue", c.model);
    require(c.model == "mss-cs" || c.model == "mss-cf" || c.model == "mss" || c.model == "fe" || c.model == "neo-hookean",
            "case file: tissue.model '{}' is not known (mss-cs, mss-cf, mss, fe or neo-hookean)", c.model);
    if (j.contains("poisson")) {
      const bool continuum = c.model == "fe" || c.model == "neo-hookean";
      require(continuum || c.model == "mss-cf",
              "case file: tissue.poisson is given but tissue.model '{}' has no Poisson ratio of its own (the MSS lattice's "
              "is 1/4); use model fe, neo-hookean or mss-cf, or remove tissue.poisson",
              c.model);
      c.poisson_ratio =
          limited(j, "poisson", "tissue", 0.45, continuum ? limits::kFePoisson : limits::kCfPoisson);
    }
    c.constants = text(j, "constants", "tissue", c.constants);
    require(c.constants == "recommended" || c.constants == "thesis" || c.constants == "cube-fit" ||
                c.constants == "cube-targets",
            "case file: tissue.constants '{}' is not known (cube-targets, recommended, thesis or cube-fit)", c.constants);
    c.youngs_modulus_pa = limited(j, "youngs_kpa", "tissue", c.youngs_modulus_pa / 1e3, limits::kYoungsModulus) * 1e3;
    c.density_kg_m3 = limited(j, "density_kg_m3", "tissue", c.density_kg_m3, limits::kDensity);
    // A model named without a solve gets its own; neither named keeps the default pair.
    const DesignSolveMode fallback = j.contains("model") ? default_solve_mode(c.model) : c.solve_mode;
    c.solve_mode = parse_design_solve_mode(text(j, "solve", "tissue", to_string(fallback)));
  }
  if (doc.contains("mesh")) {
    const auto& j = doc.at("mesh");
    check_keys(j, "mesh", {"target_nodes"});
    c.target_nodes = count(j, "target_nodes", "mesh", c.target_nodes, limits::kTargetNodes);
  }
  if (doc.contains("landmarks")) {
    const auto& j = doc.at("landmarks");
    require(j.is_object(), "case file: 'landmarks' must be an object {{\"PT\": [x, y, z] in mm, ...}}");
    for (const auto& [code, v] : j.items()) c.landmarks[code] = vec3(v, "landmarks." + code) * 1e-3;
  }
  if (doc.contains("design")) {
    const auto& j = doc.at("design");
    check_keys(j, "design", {"spots", "optimise", "objective", "model_pressure_limit", "time_limit_s", "closed_loop",
                             "closed_loop_donnings", "ischial_share_min", "follow_template"});
    if (j.contains("ischial_share_min")) {
      const double v = number(j, "ischial_share_min", "design", 0.0);
      require(v >= 0.0 && v <= 0.9,
              "case file: design.ischial_share_min = {} is outside [0, 0.9] (a fraction of the axial load, e.g. 0.2)", v);
      c.ischial_share_min = v;
    }
    c.optimise = flag(j, "optimise", "design", true);
    c.follow_template = flag(j, "follow_template", "design", c.follow_template);
    const std::string obj = text(j, "objective", "design", "pressure");
    require(obj == "pressure" || obj == "ratio" || obj == "uniform",
            "case file: design.objective '{}' is not known (pressure, ratio or uniform)", obj);
    c.objective = obj == "ratio"     ? OptimizerOptions::Objective::Ratio
                  : obj == "uniform" ? OptimizerOptions::Objective::Uniform
                                     : OptimizerOptions::Objective::Pressure;
    c.model_pressure_limit =
        limited(j, "model_pressure_limit", "design", c.model_pressure_limit, limits::kModelPressureLimit);
    c.time_limit_s = limited(j, "time_limit_s", "design", c.time_limit_s, limits::kTimeLimit);
    c.closed_loop = flag(j, "closed_loop", "design", c.closed_loop);
    c.closed_loop_donnings =
        count(j, "closed_loop_donnings", "design", c.closed_loop_donnings, limits::kClosedLoopDonnings);
    if (j.contains("spots")) {
      const auto& s = j.at("spots");
      if (s.is_string()) {
        require(s == "default", "case file: design.spots must be a list of spots or \"default\"");
      } else {
        require(s.is_array(), "case file: design.spots must be a list of spots or \"default\"");
        require(!s.empty(),
                "case file: design.spots is an empty list: give at least one spot, or \"default\" for the limb type's "
                "layout");
        for (size_t i = 0; i < s.size(); ++i) c.spots.push_back(spot_from_json(s[i], fmt::format("design.spots[{}]", i)));
      }
    }
  }
  if (doc.contains("brim")) {
    const auto& j = doc.at("brim");
    check_keys(j, "brim", {"template", "key_points"});
    if (j.contains("template")) c.brim = parse_brim_template(text(j, "template", "brim", ""));
    if (j.contains("key_points")) {
      const auto& k = j.at("key_points");
      require(k.is_array(), "case file: brim.key_points must be a list of {{\"theta_deg\", \"h_mm\"}}");
      for (size_t i = 0; i < k.size(); ++i) {
        const std::string w = fmt::format("brim.key_points[{}]", i);
        check_keys(k[i], w, {"theta_deg", "h_mm", "label"});
        require(k[i].contains("theta_deg") && k[i].contains("h_mm"), "case file: '{}' needs theta_deg and h_mm", w);
        c.brim_key_points.push_back(
            {text(k[i], "label", w, ""), number(k[i], "theta_deg", w, 0) * kDeg, number(k[i], "h_mm", w, 0) * 1e-3});
      }
    }
  }
  if (doc.contains("socket")) {
    const auto& j = doc.at("socket");
    check_keys(j, "socket", {"thickness_mm", "distal_pad", "distal_pad_diameter_mm", "round_brim", "subdivisions",
                             "distal_thickness_mm", "brim_thickness_mm", "alignment", "attachment"});
    c.socket.thickness_m = limited(j, "thickness_mm", "socket", c.socket.thickness_m * 1e3, limits::kThickness) * 1e-3;
    // 0 (or left out): the uniform thickness_mm.
    for (auto [key, limit, value] : {std::tuple{"distal_thickness_mm", limits::kDistalThickness, &c.socket.distal_thickness_m},
                                     std::tuple{"brim_thickness_mm", limits::kBrimThickness, &c.socket.brim_thickness_m}}) {
      const double mm = number(j, key, "socket", 0.0);
      *value = (mm == 0.0 ? 0.0 : check_input(limit, mm, fmt::format("case file: socket.{}", key))) * 1e-3;
    }
    parse_socket_attachment(j, c.socket);
    c.socket.distal_pad = flag(j, "distal_pad", "socket", c.socket.distal_pad);
    c.socket.distal_pad_diameter_m =
        limited(j, "distal_pad_diameter_mm", "socket", c.socket.distal_pad_diameter_m * 1e3,
                limits::kDistalPadDiameter) * 1e-3;
    c.socket.round_brim = flag(j, "round_brim", "socket", c.socket.round_brim);
    c.socket.subdivisions = count(j, "subdivisions", "socket", c.socket.subdivisions, limits::kSubdivisions);
  }
  return c;
}

CaseFile read_case(const std::filesystem::path& path) {
  std::ifstream in(path);
  require<IoError>(in.good(), "cannot open case file '{}' (check the path)", path.string());
  std::stringstream ss;
  ss << in.rdbuf();
  require<IoError>(!in.bad(), "cannot read case file '{}' (check the path)", path.string());
  const json doc = parse_json_input(ss.str(), fmt::format("case file '{}'", path.string()));
  return parse_case(doc, std::filesystem::absolute(path).parent_path());
}

json case_to_json(const CaseFile& c) {
  json limb{{"bones", c.limb.bones}, {"type", geometry::to_string(c.limb.type)}};
  if (!c.limb.file.empty()) limb["file"] = c.limb.file;
  else limb["generate_seed"] = c.limb.generate_seed;
  if (!c.limb.units.empty()) limb["units"] = c.limb.units;
  if (c.limb.side) limb["side"] = geometry::to_string(*c.limb.side);
  if (c.limb.anterior) limb["anterior"] = {c.limb.anterior->x(), c.limb.anterior->y(), c.limb.anterior->z()};
  if (c.limb.axis) limb["axis"] = {c.limb.axis->x(), c.limb.axis->y(), c.limb.axis->z()};
  if (c.limb.scale != 1.0) limb["scale"] = c.limb.scale;
  if (c.limb.force_size) limb["force_size"] = true;
  if (c.limb.cut_height_m) limb["cut_height_mm"] = *c.limb.cut_height_m * 1e3;
  json patient{{"body_mass_kg", c.patient.body_mass_kg},
               {"prosthesis_mass_kg", c.patient.prosthesis_mass_kg},
               {"friction", c.patient.friction},
               {"force_tolerance", c.patient.force_tolerance},
               {"torque_tolerance", c.patient.torque_tolerance}};
  if (!c.patient_id.empty()) patient["id"] = c.patient_id;
  if (!c.patient_note.empty()) patient["note"] = c.patient_note;
  if (!c.thresholds.empty()) {
    json t = json::object();
    for (const auto& [code, v] : c.thresholds) t[code] = v / 1e3;
    patient["thresholds_kpa"] = t;
  }
  json spots = json::array();
  for (const auto& s : c.spots) spots.push_back(spot_to_json(s));
  json design{{"optimise", c.optimise}, {"objective", objective_name(c.objective)},
              {"model_pressure_limit", c.model_pressure_limit}, {"closed_loop", c.closed_loop},
              {"closed_loop_donnings", c.closed_loop_donnings}, {"follow_template", c.follow_template}};
  if (c.ischial_share_min) design["ischial_share_min"] = *c.ischial_share_min;
  if (c.time_limit_s > 0) design["time_limit_s"] = c.time_limit_s;
  if (c.spots.empty()) design["spots"] = "default";
  else design["spots"] = spots;
  json brim = json::object();
  if (c.brim) brim["template"] = to_string(*c.brim);
  if (!c.brim_key_points.empty()) {
    json k = json::array();
    for (const auto& p : c.brim_key_points) {
      json e{{"theta_deg", p.theta / kDeg}, {"h_mm", p.h * 1e3}};
      if (!p.label.empty()) e["label"] = p.label;
      k.push_back(e);
    }
    brim["key_points"] = k;
  }
  json lms = json::object();
  for (const auto& [code, p] : c.landmarks) lms[code] = {p.x() * 1e3, p.y() * 1e3, p.z() * 1e3};
  json doc{{"socketsmith_case", 1},
           {"limb", limb},
           {"patient", patient},
           {"tissue",
            {{"model", c.model},
             {"constants", c.constants},
             {"youngs_kpa", c.youngs_modulus_pa / 1e3},
             {"density_kg_m3", c.density_kg_m3}}},
           {"mesh", {{"target_nodes", c.target_nodes}}},
           {"design", design},
           {"brim", brim},
           {"socket",
            {{"thickness_mm", c.socket.thickness_m * 1e3},
             {"distal_pad", c.socket.distal_pad},
             {"distal_pad_diameter_mm", c.socket.distal_pad_diameter_m * 1e3},
             {"round_brim", c.socket.round_brim},
             {"subdivisions", c.socket.subdivisions}}}};
  doc["socket"].update(socket_attachment_json(c.socket));
  if (!lms.empty()) doc["landmarks"] = lms;
  if (c.poisson_ratio) doc["tissue"]["poisson"] = *c.poisson_ratio;
  // The solve is written only when it is not the model's own, so that a document whose model is
  // edited (a replay case, a Python dict) gets the new model's solve, as a hand-written one does.
  if (c.solve_mode != default_solve_mode(c.model)) doc["tissue"]["solve"] = to_string(c.solve_mode);
  return doc;
}

void write_case(const std::filesystem::path& path, const CaseFile& c) {
  write_text_atomically(path, case_to_json(c).dump(2) + "\n");
}

std::filesystem::path resolve(const CaseFile& c, const std::string& file) {
  const std::filesystem::path p(file);
  return p.is_absolute() || c.folder.empty() ? p : c.folder / p;
}

}  // namespace socketsmith::design
