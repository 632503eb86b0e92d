#pragma once
/// @file exit_status.h
/// The documented exit codes of the socketsmith programs and the one line that goes with each
/// exception, so the CLI, the GUI and the fuzz targets classify errors the same way.

#include <exception>
#include <string>
#include <string_view>

namespace socketsmith {

/// README, "Exit codes".
enum ExitCode : int {
  kExitSuccess = 0,
  kExitBadInput = 1,        ///< InvalidInputError, JSON that is not a valid input, a bad command line
  kExitFileError = 2,       ///< IoError, std::filesystem and stream failures
  kExitSolverDiverged = 3,  ///< SolverError
  kExitBadTopology = 4,     ///< TopologyError
  kExitInternal = 70,       ///< anything else: a bug (an assertion, an unexpected library exception)
};

/// An exit code and its message: one line, without the "error: " prefix.
struct ExitStatus {
  int code = kExitSuccess;
  std::string message;
  /// "error: <message>" or, for kExitInternal, "internal error: <message> (please report it)".
  std::string line() const;
};

/// Classifies @p error (e.g. std::current_exception() in a catch (...) block): every exception type
/// lands on a documented code.
ExitStatus exit_status(std::exception_ptr error);

/// @p text on one line: line breaks become "; ", trailing blanks go.
std::string one_line(std::string_view text);

}  // namespace socketsmith
