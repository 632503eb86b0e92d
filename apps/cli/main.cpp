// socketsmith — command-line entry point. Maps errors to one clear line and an exit code
// (core/exit_status.h): 1 bad input (also a bad command line), 2 IO, 3 solver/divergence,
// 4 topology, 70 internal.
#include <cstdio>
#include <exception>
#include <optional>

#include <CLI/CLI.hpp>

#include "cli_common.h"
#include "common/parse_command_line.h"
#include "socketsmith/core/exit_status.h"
#include "socketsmith/core/log.h"

int main(int argc, char** argv) {
  using namespace socketsmith;
  CLI::App app{"socketsmith — prosthetic socket design from a residual-limb scan"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "socketsmith 0.1.0");
  std::string log_level = "info";
  app.add_option("--log", log_level, "log level: debug|info|warn|error|off")
      ->check(CLI::IsMember({"debug", "info", "warn", "error", "off"}));
  app.parse_complete_callback([&] { log::set_level(log::parse_level(log_level)); });
  cli::register_simulate(app);
  cli::register_calibrate(app);
  cli::register_check(app);
  cli::register_limb(app);
  cli::register_mesh(app);
  cli::register_design(app);
  cli::register_scan(app);
  cli::register_contact(app);
  cli::register_validate(app);
  cli::register_compare(app);
  cli::register_sweep(app);
  try {
    if (const std::optional<int> code = apps::parse_command_line(app, argc, argv, "error")) return *code;
  } catch (...) {
    const ExitStatus status = exit_status(std::current_exception());
    std::fprintf(stderr, "%s\n", status.line().c_str());
    return status.code;
  }
  return 0;
}
