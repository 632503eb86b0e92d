#include "cli_common.h"

#include <cmath>
#include <cstdlib>
#include <iostream>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "socketsmith/core/errors.h"
#include "socketsmith/design/case_parameters.h"

namespace socketsmith::cli {

CLI::Validator within(const design::InputLimit& limit) {
  return CLI::Validator(
      [limit](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        if (text.empty() || end != text.c_str() + text.size())
          return fmt::format("'{}' is not a number: give a value in {}", text, design::describe(limit));
        return design::input_violation(limit, v);
      },
      design::describe(limit));
}

namespace {
CLI::Validator sign_check(bool is_zero_allowed) {
  return CLI::Validator(
      [is_zero_allowed](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        if (text.empty() || end != text.c_str() + text.size()) return fmt::format("'{}' is not a number", text);
        if (!std::isfinite(v) || v < 0 || (v == 0 && !is_zero_allowed))
          return fmt::format("{} must be a {} number", text, is_zero_allowed ? "finite, zero or positive" : "finite, positive");
        return {};
      },
      is_zero_allowed ? "NONNEGATIVE" : "POSITIVE");
}
}  // namespace

CLI::Validator positive() { return sign_check(false); }
CLI::Validator non_negative() { return sign_check(true); }

std::vector<std::string> case_names(std::string_view key) {
  const design::CaseTextParameter* p = design::find_case_text_parameter(key);
  require(p != nullptr && !p->names.empty(), "case_names: '{}' is not a name of a kind in the case file", key);
  return {p->names.begin(), p->names.end()};
}

std::string case_names_help(std::string_view key) { return fmt::format("{}", fmt::join(case_names(key), " | ")); }

void add_model_flags(CLI::App& app, ModelFlags& f) {
  app.add_option("--model", f.model, "tissue model: mss-cs (thesis), mss-cf (Golec hybrid), mss (springs only), fe "
                 "(hexahedral finite elements, St Venant-Kirchhoff: CalculiX's C3D8 on the same mesh), neo-hookean (the "
                 "same elements, compressible neo-Hookean: CalculiX's *HYPERELASTIC, NEO HOOKE; large strains)")
      ->check(CLI::IsMember(case_names("tissue.model")));
  app.add_option("--constants", f.constants, "MSS-CS constants preset: cube-targets (default: meets the cube's 5 %/2 %, carries the "
                 "sheared cube), recommended (same linearisation, no dead zone: 6.4 %/2.6 %), thesis or cube-fit; see docs/VALIDATION.md")
      ->check(CLI::IsMember(case_names("tissue.constants")));
  app.add_option("--golec-a", f.golec_a, "override Golec's A (eq. 2), > 0");
  app.add_option("--alpha", f.alpha, "override the corrective rest-length ratio alpha (eq. 4), > 1");
  app.add_option("--c", f.c, "override the corrective stiffness constant C (eq. 8), >= 0");
  app.add_option("--beta", f.beta, "override the corrective exponent beta (eq. 8), > 0");
  app.add_option("--spring-ratio", f.spring_ratio, "override the MSS-CS spring modulus ratio E_s/E, > 0");
  app.add_option("--law", f.law, "override the corrective law: symmetric | compression-only");
  app.add_option("--dead-zone", f.dead_zone, "override the corrective dead zone d (volume fraction), in [0, 0.5)");
  app.add_option("--youngs-kpa", f.youngs_modulus_kpa, "tissue Young's modulus E [kPa]")
      ->check(within(design::limits::kYoungsModulus));
  app.add_option("--density", f.density, "tissue density rho [kg/m^3]")->check(within(design::limits::kDensity));
  app.add_option("--cf-poisson", f.cf_poisson, "MSS-CF target Poisson ratio, in [0.25, 0.5)");
  app.add_option("--fe-poisson", f.fe_poisson, "Poisson ratio of the fe and neo-hookean models, in [0, 0.5) (default 0.45)");
}

tissue::MassSpringOptions make_model_options(const ModelFlags& f) {
  tissue::MassSpringOptions o;
  o.kind = tissue::parse_tissue_model(f.model);
  o.corrective = tissue::CorrectiveSpringConstants::preset(f.constants);
  // MSS and MSS-CF use Golec's springs with the thesis's A unless told otherwise.
  if (o.kind != tissue::TissueModelKind::MssCs) o.corrective = tissue::CorrectiveSpringConstants::thesis();
  if (f.golec_a >= 0) o.corrective.golec_a = f.golec_a;
  if (f.alpha >= 0) o.corrective.alpha = f.alpha;
  if (f.c >= 0) o.corrective.c = f.c;
  if (f.beta >= 0) o.corrective.beta = f.beta;
  if (f.spring_ratio >= 0) o.corrective.spring_modulus_ratio = f.spring_ratio;
  if (f.dead_zone >= 0) o.corrective.dead_zone = f.dead_zone;
  if (!f.law.empty()) o.corrective.law = tissue::parse_corrective_law(f.law);
  o.cf_poisson_ratio = f.cf_poisson;
  o.fe_poisson_ratio = f.fe_poisson;
  return o;
}

tissue::TissueMaterial make_material(const ModelFlags& f) { return {f.youngs_modulus_kpa * 1e3, f.density}; }

void print_json(const nlohmann::json& j) { std::cout << j.dump(2) << std::endl; }

CLI::App* add_command_group(CLI::App& parent, const std::string& name, const std::string& description) {
  auto* group = parent.add_subcommand(name, description);
  group->require_subcommand(1);
  return group;
}

}  // namespace socketsmith::cli
