// `socketsmith calibrate cube`: repeatable calibration of the MSS-CS constants.
#include <cmath>
#include <filesystem>

#include "cli_common.h"
#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/tissue/spring_calibration.h"

namespace socketsmith::cli {
namespace {

struct CalibrateFlags {
  std::string out;
  bool json = false;
  std::string law = "both";
  int evaluations = 400;
  int starts = 4;
  unsigned seed = 1;
  bool fixed_springs = false;
  int divisions = 2;
  double max_c = 0;
  double min_beta = 0;
  bool no_shear_check = false;
  std::string keep_linearisation;
  double shear_compression_kpa = 7.5;
  double shear_kpa = 1.5;
  double min_dead_zone = 0;
  double max_dead_zone = 0;
};

nlohmann::json candidate_json(const tissue::SpringCalibrationCandidate& c) {
  return {{"golec_a", c.constants.golec_a},
          {"alpha", c.constants.alpha},
          {"c", c.constants.c},
          {"beta", c.constants.beta},
          {"law", tissue::to_string(c.constants.law)},
          {"spring_modulus_ratio", c.constants.spring_modulus_ratio},
          {"dead_zone", c.constants.dead_zone},
          {"max_displacement_error_to_60pct", c.errors.max_displacement_error},
          {"max_volume_error_to_40pct", c.errors.max_volume_error},
          {"unstable_before_60pct", c.errors.unstable},
          {"first_unstable_strain", std::isinf(c.errors.first_unstable_strain) ? nlohmann::json() : nlohmann::json(c.errors.first_unstable_strain)},
          {"sheared_cube",
           c.shear_checked ? nlohmann::json{{"carried", c.sheared.converged},
                                            {"load_fraction", c.sheared.load_fraction},
                                            {"top_sink_ratio", c.sheared.top_sink_ratio},
                                            {"top_shift_ratio", c.sheared.top_shift_ratio},
                                            {"message", c.sheared.message}}
                           : nlohmann::json()},
          {"objective", c.objective}};
}

void run(const CalibrateFlags& f) {
  tissue::SpringCalibrationOptions o;
  o.cube.divisions = f.divisions;
  o.max_evaluations = f.evaluations;
  o.starts = f.starts;
  o.seed = f.seed;
  o.fit_spring_modulus_ratio = !f.fixed_springs;
  if (f.max_c > 0) o.max_c = f.max_c;
  if (f.min_beta > 0) o.min_beta = f.min_beta;
  o.shear_check = !f.no_shear_check;
  require(f.max_dead_zone == 0 || f.max_dead_zone >= f.min_dead_zone,
          "calibrate: --max-dead-zone {} is below --min-dead-zone {}", f.max_dead_zone, f.min_dead_zone);
  o.min_dead_zone = f.min_dead_zone;
  o.max_dead_zone = std::max(f.min_dead_zone, f.max_dead_zone);
  if (!f.keep_linearisation.empty()) {
    o.keep_linearisation_of = tissue::CorrectiveSpringConstants::preset(f.keep_linearisation);
    o.min_beta = std::max(o.min_beta, 1.05);
  }
  o.sheared.compression_pa = 1e3 * f.shear_compression_kpa;
  o.sheared.shear_pa = 1e3 * f.shear_kpa;
  if (f.law == "symmetric") o.laws = {tissue::CorrectiveLaw::Symmetric};
  if (f.law == "compression-only") o.laws = {tissue::CorrectiveLaw::CompressionOnly};
  log::info("calibrating MSS-CS constants on the cube ({}^3 elements, {} start(s) x {} evaluations per law)",
            f.divisions, f.starts, f.evaluations);
  const auto r = tissue::calibrate_corrective_springs(o, console_progress(1.0));
  nlohmann::json j;
  j["command"] = "socketsmith calibrate cube";
  j["seed"] = f.seed;
  j["evaluations"] = r.evaluations;
  j["targets"] = {{"displacement_error", o.target_displacement_error}, {"volume_error", o.target_volume_error}};
  j["sheared_cube"] = o.shear_check ? nlohmann::json{{"divisions", o.sheared.divisions},
                                                     {"compression_kpa", f.shear_compression_kpa},
                                                     {"shear_kpa", f.shear_kpa}}
                                    : nlohmann::json();
  j["thesis"] = candidate_json(r.thesis);
  j["best"] = candidate_json(r.best);
  for (const auto& c : r.per_law) j["per_law"].push_back(candidate_json(c));
  j["targets_met"] = r.targets_met;
  j["message"] = r.message;
  if (!f.out.empty()) {
    const std::filesystem::path out(f.out);
    ensure_directory(out);
    write_text_atomically(out / "calibration.json", j.dump(2) + "\n");
    log::info("wrote {}", (out / "calibration.json").string());
  }
  log::info("{}", r.message);
  if (f.json) print_json(j);
}

}  // namespace

void register_calibrate(CLI::App& app) {
  auto* cal = add_command_group(app, "calibrate", "calibrate model constants against an analytic experiment");
  auto flags = std::make_shared<CalibrateFlags>();
  auto* cube = cal->add_subcommand("cube", "fit the MSS-CS constants (A, alpha, C, beta) to the cube experiment");
  cube->add_option("--out", flags->out, "output folder for calibration.json");
  cube->add_flag("--json", flags->json, "print the result as JSON on stdout");
  cube->add_option("--law", flags->law, "corrective law to fit: symmetric | compression-only | both")
      ->check(CLI::IsMember({"symmetric", "compression-only", "both"}));
  cube->add_option("--evaluations", flags->evaluations, "objective evaluations per start")->check(CLI::Range(10, 100000));
  cube->add_option("--starts", flags->starts, "starting points per law: the thesis, recommended and cube-fit constants, then random ones")
      ->check(CLI::Range(1, 1000));
  cube->add_option("--seed", flags->seed, "random seed of the extra starting points");
  cube->add_flag("--thesis-springs", flags->fixed_springs, "keep the Golec springs at E (fit A, alpha, C, beta only)");
  cube->add_option("--divisions", flags->divisions, "elements per cube edge")->check(CLI::Range(1, 20));
  cube->add_option("--max-c", flags->max_c, "upper bound of the corrective constant C (default 2000)")
      ->check(positive());
  cube->add_option("--min-beta", flags->min_beta,
                   "lower bound of the corrective exponent beta (default 0.5; >= 2.5 keeps the corrective springs "
                   "negligible at small strain, where the linearised design model must hold)")
      ->check(CLI::Range(0.5, 4.0));
  cube->add_option("--keep-linearisation", flags->keep_linearisation,
                   "keep A and the spring modulus ratio of this preset (fit alpha, C, beta only): the linearised model, "
                   "and every linear design, stays the same")
      ->check(CLI::IsMember(case_names("tissue.constants")));
  cube->add_option("--min-dead-zone", flags->min_dead_zone,
                   "lower bound of the corrective dead zone d, a volume fraction (default 0; > 0 makes the nonlinear "
                   "model exactly its linearisation for volume changes up to d)")
      ->check(CLI::Range(0.0, 0.2));
  cube->add_option("--max-dead-zone", flags->max_dead_zone,
                   "upper bound of the dead zone d (fitted when above --min-dead-zone; default: held at --min-dead-zone)")
      ->check(CLI::Range(0.0, 0.2));
  cube->add_flag("--no-shear-check", flags->no_shear_check,
                 "do not require the constants to carry the sheared cube (base held, compression + shear on the top)");
  cube->add_option("--shear-compression-kpa", flags->shear_compression_kpa, "sheared cube: compression on the top [kPa]")
      ->check(non_negative());
  cube->add_option("--shear-kpa", flags->shear_kpa, "sheared cube: shear traction on the top [kPa]")
      ->check(non_negative());
  cube->callback([flags] { run(*flags); });
}

}  // namespace socketsmith::cli
