// The Design panel's "Patient": masses, friction, tissue stiffness and pain thresholds; applied by
// rebuilding the stump model.

#include <imgui.h>

#include "app_impl.h"
#include "socketsmith/core/errors.h"

namespace socketsmith::gui {

void App::draw_patient_panel() {
  if (!session_.has_design() || !ImGui::CollapsingHeader("Patient")) return;
  const design::CaseFile& doc = session_.document();
  ImGui::TextWrapped("Changes here rebuild the stump model (a few seconds) when applied.");
  float mass = static_cast<float>(doc.patient.body_mass_kg);
  float pmass = static_cast<float>(doc.patient.prosthesis_mass_kg);
  float mu = static_cast<float>(doc.patient.friction);
  float e = static_cast<float>(doc.youngs_modulus_pa / 1e3);
  bool changed = false;
  changed |= ImGui::InputFloat("body mass [kg]", &mass, 1, 5, "%.1f");
  changed |= ImGui::InputFloat("prosthesis [kg]", &pmass, 0.1f, 1, "%.2f");
  changed |= ImGui::InputFloat("friction [-]", &mu, 0.05f, 0.1f, "%.2f");
  changed |= ImGui::InputFloat("tissue E [kPa]", &e, 5, 20, "%.0f");
  auto table = doc.thresholds.empty() ? design::default_thresholds(session_.setup()->model.type) : doc.thresholds;
  ImGui::Text("Pain thresholds [kPa]");
  bool thr_changed = false;
  for (auto& [code, v] : table) {
    float kpa = static_cast<float>(v / 1e3);
    if (ImGui::InputFloat(code.c_str(), &kpa, 1, 10, "%.1f")) {
      v = kpa * 1e3;
      thr_changed = true;
    }
  }
  if (changed || thr_changed) {
    design::PatientLoad p = doc.patient;
    p.body_mass_kg = mass;
    p.prosthesis_mass_kg = pmass;
    p.friction = mu;
    try {
      session_.set_patient(p, e * 1e3, thr_changed ? table : doc.thresholds);
    } catch (const Error& err) {
      session_.show_error(err.what());
    }
  }
  if (ImGui::Button("Apply (rebuild the stump model)")) session_.rebuild();
}

}  // namespace socketsmith::gui
