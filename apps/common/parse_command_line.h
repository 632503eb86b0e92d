// The command line of socketsmith and socketsmith-gui parsed the same way: --help and --version
// print and exit 0, a bad command line is one line on stderr and the bad-input exit code.
#pragma once

#include <cstdio>
#include <optional>

#include <CLI/CLI.hpp>

#include "socketsmith/core/exit_status.h"
#include "socketsmith/core/log.h"

namespace socketsmith::apps {

/// Parses @p argv into @p app (its callbacks run here, and what they throw goes through).
/// @return the exit code when the program should stop now (--help, --version: 0; a command line
///         CLI11 refuses: kExitBadInput after "PREFIX: what (see --help)"); std::nullopt otherwise.
inline std::optional<int> parse_command_line(CLI::App& app, int argc, char** argv, const char* prefix) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version are "errors" with exit code 0: CLI11 prints them.
    if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);
    std::fprintf(stderr, "%s: %s (see --help)\n", prefix, one_line(e.what()).c_str());
    return kExitBadInput;
  }
  return std::nullopt;
}

}  // namespace socketsmith::apps
