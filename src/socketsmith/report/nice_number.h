#pragma once
/// @file nice_number.h
/// Round numbers for axes and colour ranges: the one routine behind the plots' tick steps
/// (plot_layout.h), the colour bars' ticks (raster.h) and the round tops of report axes and of
/// the GUI's colour ranges.

namespace socketsmith::report {

/// Which mantissas count as round.
enum class NiceMantissas {
  OneTwoFive,  ///< 1, 2, 5 × 10^k: tick steps
  Fine,        ///< 1, 1.2, 1.5, 2, 2.5, 3, 4, 5, 6, 8 × 10^k: the top of an axis or a colour range
};

/// The smallest round number m × 10^k that is ≥ @p v, m from @p mantissas. A value within 1e-9
/// (relative) above a round number is that number (it is round but for rounding errors).
/// @p v itself when it is not finite or not > 0 (nothing round to find).
double nice_ceil(double v, NiceMantissas mantissas = NiceMantissas::Fine);

}  // namespace socketsmith::report
