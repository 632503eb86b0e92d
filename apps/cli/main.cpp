// socketsmith — command-line entry point. Maps errors to one clear line and an exit code:
// 1 bad input, 2 IO, 3 solver/divergence, 4 topology, 70 internal.
#include <cstdio>
#include <exception>

#include <CLI/CLI.hpp>

#include "cli_common.h"
#include "socketsmith/core/errors.h"
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
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const InvalidInputError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  } catch (const IoError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const SolverError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 3;
  } catch (const TopologyError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 4;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "internal error: %s (please report it)\n", e.what());
    return 70;
  }
  return 0;
}
