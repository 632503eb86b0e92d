#pragma once
/// Shared pieces of the socketsmith command-line tool.

#include <string>
#include <string_view>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "socketsmith/design/input_limits.h"
#include "socketsmith/tissue/mass_spring_model.h"

namespace socketsmith::cli {

/// Model flags shared by every command that builds a tissue model.
struct ModelFlags {
  std::string model = "mss-cs";
  std::string constants = "cube-targets";  // cube-targets | recommended | thesis | cube-fit
  double golec_a = -1, alpha = -1, c = -1, beta = -1, spring_ratio = -1, dead_zone = -1;  // < 0: from the preset
  std::string law;                                     // empty: from the preset
  double youngs_modulus_kpa = 50.0;
  double density = 1060.0;
  double cf_poisson = 0.49;
  double fe_poisson = 0.45;
};

/// A CLI11 check from the shared input limits (design/input_limits.h): a flag takes the same range
/// as its case-file key and says so in the same words ("--friction: 3 is outside [0, 2]: ...").
CLI::Validator within(const design::InputLimit& limit);

/// A finite number > 0 (CLI::PositiveNumber's message printed the 309 digits of DBL_MAX).
CLI::Validator positive();
/// A finite number ≥ 0.
CLI::Validator non_negative();

/// The names the case file allows for @p key ("tissue.model", design/case_parameters.h): a flag
/// that takes the same names checks them with these (CLI::IsMember) ...
std::vector<std::string> case_names(std::string_view key);
/// ... and lists them in its help: "transtibial | transfemoral".
std::string case_names_help(std::string_view key);

void add_model_flags(CLI::App& app, ModelFlags& flags);

/// A command made of subcommands (`check mesh`, `validate cube`), of which one must be given.
CLI::App* add_command_group(CLI::App& parent, const std::string& name, const std::string& description);
tissue::MassSpringOptions make_model_options(const ModelFlags& flags);
tissue::TissueMaterial make_material(const ModelFlags& flags);

/// Prints JSON to stdout (for --json).
void print_json(const nlohmann::json& j);

void register_simulate(CLI::App& app);
void register_calibrate(CLI::App& app);
void register_check(CLI::App& app);
void register_limb(CLI::App& app);  // cmd_limb.cpp: limb generate
void register_mesh(CLI::App& app);  // cmd_mesh.cpp: mesh
void register_design(CLI::App& app);  // cmd_design.cpp: design, run, demo
void register_contact(CLI::App& app);  // cmd_contact.cpp: simulate donning
void register_scan(CLI::App& app);  // cmd_scan.cpp: scan simulate, scan reconstruct
void register_validate(CLI::App& app);  // cmd_validate.cpp: validate cube, validate design
void register_compare(CLI::App& app);  // cmd_compare.cpp: compare A B
void register_sweep(CLI::App& app);  // cmd_sweep.cpp: sweep, sweep collect, sweep case

}  // namespace socketsmith::cli
