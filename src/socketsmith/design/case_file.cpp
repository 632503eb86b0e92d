#include "socketsmith/design/case_file.h"

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/json_input.h"
#include "socketsmith/core/units.h"
#include "socketsmith/design/case_file_detail.h"
#include "socketsmith/design/case_parameters.h"
#include "socketsmith/design/input_limits.h"

namespace socketsmith::design {
namespace detail {
using nlohmann::json;

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
}  // namespace detail

namespace {
using nlohmann::json;
using detail::check_keys;
using detail::flag;
using detail::number;
using detail::text;
constexpr double kDeg = units::deg;

Eigen::Vector3d vec3(const json& j, const std::string& where) {
  require(j.is_array() && j.size() == 3 && j[0].is_number() && j[1].is_number() && j[2].is_number(),
          "case file: '{}' must be [x, y, z] (got {})", where, j.dump());
  Eigen::Vector3d v(j[0].get<double>(), j[1].get<double>(), j[2].get<double>());
  require(v.allFinite(), "case file: '{}' is not finite", where);
  return v;
}
}  // namespace

json spot_to_json(const Spot& s) {
  json j = json::object();
  write_text_parameters(j, "design.spots[]", s);
  write_parameters(j, "design.spots[]", s);
  return j;
}

Spot spot_from_json(const json& j, const std::string& where) {
  check_keys(j, where, section_keys("design.spots[]", {}));
  Spot s;
  s.name = where;  // a spot without a name
  read_text_parameters(j, "design.spots[]", where, s);
  require(j.contains("type"), "case file: '{}' has no 'type' ({})", where,
          listed_names(*find_spot_text_parameter("type")));
  s.amplitude_pa = 10e3;  // a spot without amplitude_kpa
  read_parameters(j, "design.spots[]", where, s);
  return s;
}

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

namespace {
void parse_limb(const json& j, CaseFile& c) {
  CaseLimb& limb = c.limb;
  check_keys(j, "limb", section_keys("limb", {"anterior", "axis", "generate_seed"}));
  read_text_parameters(j, "limb", "limb", c);
  read_parameters(j, "limb", "limb", c);
  if (j.contains("axis"))
    limb.axis = check_limb_direction(vec3(j.at("axis"), "limb.axis"), LimbDirection::Axis, "case file: 'limb.axis'");
  if (j.contains("anterior"))
    limb.anterior =
        check_limb_direction(vec3(j.at("anterior"), "limb.anterior"), LimbDirection::Anterior, "case file: 'limb.anterior'");
  if (j.contains("generate_seed")) {
    // A document built in code holds a positive int as a signed integer; a parsed file, unsigned.
    const auto& seed = j.at("generate_seed");
    require(seed.is_number_unsigned() || (seed.is_number_integer() && seed.get<long long>() >= 0),
            "case file: 'limb.generate_seed' must be a whole number ≥ 0");
    limb.generate_seed = seed.get<std::uint64_t>();
  }
}

void parse_patient(const json& j, CaseFile& c) {
  check_keys(j, "patient", section_keys("patient", {"thresholds_kpa"}));
  read_text_parameters(j, "patient", "patient", c);
  read_parameters(j, "patient", "patient", c);
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

void parse_tissue(const json& j, CaseFile& c) {
  check_keys(j, "tissue", section_keys("tissue", {"poisson"}));
  read_text_parameters(j, "tissue", "tissue", c);  // model, constants, solve
  // A model named without a solve gets its own; neither named keeps the default pair.
  if (j.contains("model") && !j.contains("solve")) c.solve_mode = default_solve_mode(c.model);
  if (j.contains("poisson")) {
    const bool continuum = c.model == "fe" || c.model == "neo-hookean";
    require(continuum || c.model == "mss-cf",
            "case file: tissue.poisson is given but tissue.model '{}' has no Poisson ratio of its own (the MSS lattice's "
            "is 1/4); use model fe, neo-hookean or mss-cf, or remove tissue.poisson",
            c.model);
    c.poisson_ratio = check_input(continuum ? limits::kFePoisson : limits::kCfPoisson,
                                  number(j, "poisson", "tissue", 0.45), "case file: tissue.poisson");
  }
  read_parameters(j, "tissue", "tissue", c);
  require(c.element == tissue::HexFormulation::Full || c.model == "neo-hookean",
          "case file: tissue.element 'fbar' is for the neo-hookean model (tissue.model is '{}'); use model "
          "neo-hookean or remove tissue.element",
          c.model);
}

void parse_design(const json& j, CaseFile& c) {
  check_keys(j, "design", section_keys("design", {"spots"}));
  read_parameters(j, "design", "design", c);
  read_text_parameters(j, "design", "design", c);
  if (!j.contains("spots")) return;
  const auto& s = j.at("spots");
  if (s.is_string()) {
    require(s == "default", "case file: design.spots must be a list of spots or \"default\"");
    return;
  }
  require(s.is_array(), "case file: design.spots must be a list of spots or \"default\"");
  require(!s.empty(),
          "case file: design.spots is an empty list: give at least one spot, or \"default\" for the limb type's "
          "layout");
  for (size_t i = 0; i < s.size(); ++i) c.spots.push_back(spot_from_json(s[i], fmt::format("design.spots[{}]", i)));
}

void parse_brim(const json& j, CaseFile& c) {
  check_keys(j, "brim", section_keys("brim", {"key_points"}));
  read_text_parameters(j, "brim", "brim", c);
  if (!j.contains("key_points")) return;
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

/// socket.attachment (issue 22): the distal platform and its four holes.
void parse_socket_attachment(const json& a, CaseFile& c) {
  const std::string w = "socket.attachment";
  check_keys(a, w, section_keys(w, {"enabled", "offset_mm"}));
  SocketAttachment& t = c.socket.attachment;
  t.enabled = flag(a, "enabled", w, true);
  read_text_parameters(a, w, w, c);
  t.bolt_diameter_m = bolt_diameter_m(t.bolt);
  t.hole_diameter_m = clearance_hole_diameter_m(t.bolt);  // unless hole_diameter_mm is given
  read_parameters(a, w, w, c);
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

void parse_socket(const json& j, CaseFile& c) {
  check_keys(j, "socket", section_keys("socket", {"alignment", "attachment"}));
  if (j.contains("alignment")) {
    check_keys(j.at("alignment"), "socket.alignment", section_keys("socket.alignment", {}));
    read_parameters(j.at("alignment"), "socket.alignment", "socket.alignment", c);
  }
  if (j.contains("attachment")) parse_socket_attachment(j.at("attachment"), c);
  read_parameters(j, "socket", "socket", c);  // after the nested objects, as before the table
}
}  // namespace

CaseFile parse_case(const json& doc, const std::filesystem::path& folder) {
  CaseFile c;
  c.folder = folder;
  check_keys(doc, "case", {"socketsmith_case", "limb", "patient", "tissue", "mesh", "landmarks", "design", "brim", "socket"});
  if (doc.contains("socketsmith_case"))
    require(doc.at("socketsmith_case") == 1, "case file: version {} is not supported (this socketsmith reads 1)",
            doc.at("socketsmith_case").dump());
  if (doc.contains("limb")) parse_limb(doc.at("limb"), c);
  if (doc.contains("patient")) parse_patient(doc.at("patient"), c);
  // Validate the patient now: the message names the field.
  check_patient(c.patient, "case file: ");
  if (doc.contains("tissue")) parse_tissue(doc.at("tissue"), c);
  if (doc.contains("mesh")) {
    check_keys(doc.at("mesh"), "mesh", section_keys("mesh", {}));
    read_parameters(doc.at("mesh"), "mesh", "mesh", c);
  }
  if (doc.contains("landmarks")) {
    const auto& j = doc.at("landmarks");
    require(j.is_object(), "case file: 'landmarks' must be an object {{\"PT\": [x, y, z] in mm, ...}}");
    for (const auto& [code, v] : j.items()) c.landmarks[code] = vec3(v, "landmarks." + code) * 1e-3;
  }
  if (doc.contains("design")) parse_design(doc.at("design"), c);
  if (doc.contains("brim")) parse_brim(doc.at("brim"), c);
  if (doc.contains("socket")) parse_socket(doc.at("socket"), c);
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

namespace {
json limb_json(const CaseFile& c) {
  json limb = json::object();
  write_text_parameters(limb, "limb", c);
  if (c.limb.file.empty()) limb["generate_seed"] = c.limb.generate_seed;
  if (c.limb.anterior) limb["anterior"] = {c.limb.anterior->x(), c.limb.anterior->y(), c.limb.anterior->z()};
  if (c.limb.axis) limb["axis"] = {c.limb.axis->x(), c.limb.axis->y(), c.limb.axis->z()};
  write_parameters(limb, "limb", c);
  return limb;
}

json patient_json(const CaseFile& c) {
  json patient = json::object();
  write_parameters(patient, "patient", c);
  write_text_parameters(patient, "patient", c);
  if (!c.thresholds.empty()) {
    json t = json::object();
    for (const auto& [code, v] : c.thresholds) t[code] = v / 1e3;
    patient["thresholds_kpa"] = t;
  }
  return patient;
}

json design_json(const CaseFile& c) {
  json design = json::object();
  write_parameters(design, "design", c);
  write_text_parameters(design, "design", c);
  if (c.spots.empty()) {
    design["spots"] = "default";
  } else {
    json spots = json::array();
    for (const auto& s : c.spots) spots.push_back(spot_to_json(s));
    design["spots"] = spots;
  }
  return design;
}

json brim_json(const CaseFile& c) {
  json brim = json::object();
  write_text_parameters(brim, "brim", c);
  if (!c.brim_key_points.empty()) {
    json k = json::array();
    for (const auto& p : c.brim_key_points) {
      json e{{"theta_deg", p.theta / kDeg}, {"h_mm", p.h / 1e-3}};
      if (!p.label.empty()) e["label"] = p.label;
      k.push_back(e);
    }
    brim["key_points"] = k;
  }
  return brim;
}

json socket_json(const CaseFile& c) {
  json socket = json::object(), alignment = json::object();
  write_parameters(socket, "socket", c);
  write_parameters(alignment, "socket.alignment", c);
  socket["alignment"] = alignment;
  const SocketAttachment& t = c.socket.attachment;
  if (t.enabled) {
    json a{{"offset_mm", {t.offset_anterior_m / units::mm, t.offset_medial_m / units::mm}}};
    write_text_parameters(a, "socket.attachment", c);
    write_parameters(a, "socket.attachment", c);
    socket["attachment"] = a;
  }
  return socket;
}
}  // namespace

json case_to_json(const CaseFile& c) {
  json tissue = json::object(), mesh = json::object();
  write_text_parameters(tissue, "tissue", c);  // the solve only when it is not the model's own
  write_parameters(tissue, "tissue", c);
  write_parameters(mesh, "mesh", c);
  if (c.poisson_ratio) tissue["poisson"] = *c.poisson_ratio;
  json doc{{"socketsmith_case", 1},  {"limb", limb_json(c)}, {"patient", patient_json(c)},
           {"tissue", tissue},        {"mesh", mesh},         {"design", design_json(c)},
           {"brim", brim_json(c)},    {"socket", socket_json(c)}};
  json lms = json::object();
  for (const auto& [code, p] : c.landmarks) lms[code] = {p.x() / 1e-3, p.y() / 1e-3, p.z() / 1e-3};
  if (!lms.empty()) doc["landmarks"] = lms;
  return doc;
}

void write_case(const std::filesystem::path& path, const CaseFile& c) {
  write_text_atomically(path, case_to_json(c).dump(2) + "\n");
}

std::filesystem::path resolve(const CaseFile& c, const std::string& file) {
  const std::filesystem::path p(file);
  return p.is_absolute() || c.folder.empty() ? p : c.folder / p;
}

bool closes_loop(const CaseFile& c) {
  return c.closed_loop.value_or(true);
}

double brim_flare_m(const CaseFile& c) {
  return c.brim_flare_m.value_or(c.limb.type == geometry::LimbType::Transtibial ? 0.005 : 0.0);
}

}  // namespace socketsmith::design
