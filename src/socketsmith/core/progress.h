#pragma once
/// @file progress.h
/// Progress reporting for anything that takes more than a second. Libraries call a
/// ProgressCallback; the CLI prints it, the GUI shows a bar, tests ignore it.

#include <functional>
#include <string_view>

namespace socketsmith {

/// Called with a fraction in [0, 1] and a short label of the current stage.
/// Returning false asks the algorithm to stop early (cancel); it then returns a Result with
/// converged = false and message "cancelled".
using ProgressCallback = std::function<bool(double fraction, std::string_view stage)>;

/// Calls @p cb if set; returns true to continue.
bool report_progress(const ProgressCallback& cb, double fraction, std::string_view stage);

/// A callback that prints "stage: 42%" lines to stderr: at once when the stage changes, else at
/// most every @p min_interval_s seconds. A detail in parentheses at the end of the stage
/// ("design: optimising (fit, 37 evaluations)") is not a change of stage: it is printed with the
/// periodic lines, so a long step shows it moves without a line per evaluation.
ProgressCallback console_progress(double min_interval_s = 0.5);

}  // namespace socketsmith
