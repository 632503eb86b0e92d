#pragma once
/// @file anderson_mixing.h
/// Anderson acceleration (type II, Walker & Ni 2011) of a fixed point x ← x + f(x), as the closed
/// loop uses it for the socket wall's offsets (closed_loop.cpp).

#include <vector>

namespace socketsmith::pipeline {

/// Anderson acceleration of the fixed point δ ← δ + c(δ) (type II, Walker & Ni 2011): from the last
/// few iterates and their corrections it finds the combination whose correction is smallest, so a
/// correction whose scale is wrong in some mode (confined, nearly incompressible tissue at the
/// distal end answers 2–3× stiffer than the compliance says; the plain iteration then oscillated
/// there) is rescaled from what the iterations measured.
class AndersonMixing {
 public:
  explicit AndersonMixing(int depth) : depth_(depth) {}
  void clear() {
    x_.clear();
    f_.clear();
  }
  /// The next iterate from @p x and its correction @p f (the plain step is x + f).
  std::vector<double> next(const std::vector<double>& x, const std::vector<double>& f);

 private:
  int depth_;
  std::vector<std::vector<double>> x_, f_;
};

}  // namespace socketsmith::pipeline
