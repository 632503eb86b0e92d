// DesignSession: edits given as headless script actions (docs/gui.md) and the journal that records
// every edit as such an action, so that a session replays to the same case and the same socket.
#include <algorithm>
#include <array>
#include <numbers>

#include "socketsmith/core/errors.h"
#include "socketsmith/pipeline/design_session.h"

namespace socketsmith::pipeline {

using nlohmann::json;

namespace {

constexpr std::array kEditActions{"add_spot",  "set",      "remove_spot", "optimise", "cancel", "patient",
                                  "rebuild",   "brim",     "brim_key_point", "thickness", "undo", "redo",
                                  "begin_edit", "end_edit", "save",        "export",   "compare"};

design::SpotType spot_type(const json& a) { return design::parse_spot_type(a.value("type", std::string("cos2"))); }

/// Two actions that set the same value (a slider's frames): the later one replaces the earlier one
/// in the journal while the drag lasts.
bool sets_the_same_value(const json& a, const json& b) {
  if (a.value("do", "") != b.value("do", "")) return false;
  const std::string what = a.value("do", "");
  if (what == "set") return a.value("spot", -1) == b.value("spot", -1) && a.value("field", "") == b.value("field", "");
  if (what == "brim_key_point") return a.value("index", -1) == b.value("index", -1);
  return what == "thickness";
}

}  // namespace

bool DesignSession::is_edit_action(const std::string& action) {
  return std::find(kEditActions.begin(), kEditActions.end(), action) != kEditActions.end();
}

void DesignSession::record(json action) {
  if (edit_start_ && !journal_.empty() && sets_the_same_value(journal_.back(), action)) {
    journal_.back() = std::move(action);
    return;
  }
  journal_.push_back(std::move(action));
}

void DesignSession::apply(const json& a) {
  const std::string what = a.value("do", "");
  const auto spot_of = [&](const json& s) {
    if (s.is_number_integer()) return s.get<int>();
    const int k = spot_index(s.get<std::string>());
    require(k >= 0, "no spot named '{}'", s.get<std::string>());
    return k;
  };
  constexpr double kDeg = std::numbers::pi / 180;
  if (what == "add_spot") {
    const double kpa = a.value("amplitude_kpa", 20.0);
    if (a.contains("landmark")) {
      add_spot_at_landmark(a["landmark"].get<std::string>(), spot_type(a), kpa * 1e3);
    } else {
      const auto p = a.at("point_mm").get<std::vector<double>>();
      require(p.size() == 3, "add_spot: point_mm needs 3 numbers");
      add_spot_at(Eigen::Vector3d(p[0], p[1], p[2]) * 1e-3, spot_type(a), kpa * 1e3);
    }
  } else if (what == "set") {
    set_spot_value(spot_of(a.at("spot")), a.at("field").get<std::string>(), a.at("value").get<double>());
  } else if (what == "remove_spot") {
    remove_spot(spot_of(a.at("spot")));
  } else if (what == "optimise") {
    optimise(a.value("time_limit_s", 0.0));
  } else if (what == "cancel") {
    cancel_optimise();
  } else if (what == "patient") {
    // The patient panel's fields, checked as the panel checks them.
    design::PatientLoad p = case_.patient;
    p.body_mass_kg = a.value("body_mass_kg", p.body_mass_kg);
    p.prosthesis_mass_kg = a.value("prosthesis_mass_kg", p.prosthesis_mass_kg);
    p.friction = a.value("friction", p.friction);
    const double e_kpa = a.value("youngs_kpa", case_.youngs_modulus_pa / 1e3);
    design::ThresholdTable thresholds = case_.thresholds;
    if (a.contains("thresholds_kpa")) {
      thresholds.clear();
      for (const auto& [code, kpa] : a["thresholds_kpa"].items()) thresholds[code] = kpa.get<double>() * 1e3;
    }
    set_patient(p, e_kpa * 1e3, thresholds);
  } else if (what == "rebuild") {
    rebuild();
  } else if (what == "brim") {
    set_brim_template(design::parse_brim_template(a.at("template").get<std::string>()));
  } else if (what == "brim_key_point") {
    move_brim_key_point(a.at("index").get<int>(), a.at("theta_deg").get<double>() * kDeg,
                        a.at("h_mm").get<double>() * 1e-3);
  } else if (what == "thickness") {
    set_thickness(a.at("mm").get<double>() * 1e-3);
  } else if (what == "undo") {
    undo();
  } else if (what == "redo") {
    redo();
  } else if (what == "begin_edit") {
    begin_edit();
  } else if (what == "end_edit") {
    end_edit();
  } else if (what == "save") {
    save_case(a.at("path").get<std::string>());
  } else if (what == "export") {
    export_design(a.at("dir").get<std::string>());
  } else if (what == "compare") {
    compare_with(a.at("file").get<std::string>());
  } else {
    fail("action '{}' is not an edit of the case (add_spot, set, remove_spot, optimise, cancel, patient, rebuild, "
         "brim, brim_key_point, thickness, undo, redo, begin_edit, end_edit, save, export, compare)",
         what);
  }
}

}  // namespace socketsmith::pipeline
