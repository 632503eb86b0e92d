#pragma once
/// @file shape_math.h
/// Small scalar helpers shared by the limb generator and the bone template (internal header).

#include <algorithm>
#include <cmath>
#include <numbers>

namespace socketsmith::volume::shape {

inline constexpr double kPi = std::numbers::pi;

inline double clamp01(double x) { return std::clamp(x, 0.0, 1.0); }
/// Hermite smooth step on [0, 1] (clamped).
inline double smoothstep(double x) {
  x = clamp01(x);
  return x * x * (3.0 - 2.0 * x);
}
inline double lerp(double a, double b, double t) { return a + (b - a) * t; }
/// Unnormalised Gaussian bump exp(-x²/2σ²).
inline double gauss(double x, double sigma) { return std::exp(-0.5 * (x / sigma) * (x / sigma)); }
/// Angle wrapped to [-pi, pi).
inline double wrap_angle(double a) {
  a = std::fmod(a + kPi, 2.0 * kPi);
  if (a < 0) a += 2.0 * kPi;
  return a - kPi;
}

}  // namespace socketsmith::volume::shape
