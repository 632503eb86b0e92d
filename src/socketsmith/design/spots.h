#pragma once
/// @file spots.h
/// Parametric pressure spots of the inverse design (thesis Tables 5–6, docs/method.md §3), written in
/// the limb's cylindrical frame (θ from anterior towards medial, h above the distal end).
///
/// Key functions (Table 5):
///   COS(x; x0, R)     = ½ [1 + cos(π (x − x0) / R)] for |x − x0| ≤ R, else 0
///   SIG(x; x1, x2, λ) = 1/(1 + e^{−λ (x − x1)}) · 1/(1 + e^{λ (x − x2)})
///   RMP(x; x1, x2)    = 1 below x1, (x − x2)/(x1 − x2) between, 0 above x2
/// A spot's pressure is A · f_θ(θ) · f_h(h) (eq. 49, here a pressure [Pa], not a nodal force);
/// the field is the sum of the spots. In θ the functions are periodic: COS uses the wrapped
/// difference θ − θ0 in (−π, π]; SIG's interval runs from θ1 towards increasing θ to θ2 and may
/// cross ±180°.

#include <string>
#include <vector>

namespace socketsmith::design {

enum class SpotType { Cos2, Sig2, CosSig, Grad };

/// "cos2" | "sig2" | "cos-sig" | "grad"; parse throws InvalidInputError listing the valid names.
std::string to_string(SpotType type);
SpotType parse_spot_type(const std::string& text);

/// One pressure spot. Which fields are used depends on the type (Table 6):
/// COS2: A, θ0, R_θ, h0, R_h; SIG2: A, θ1, θ2, λ_θ, h1, h2, λ_h; COS-SIG: A, θ0, R_θ, h1, h2, λ_h;
/// GRAD: A, h1, h2 (full pressure below h1, none above h2).
struct Spot {
  std::string name;  ///< label, e.g. "PT" (a landmark zone) or "medial tibia"
  SpotType type = SpotType::Cos2;
  double amplitude_pa = 0.0;   ///< A [Pa], ≥ 0
  double theta0 = 0.0;         ///< centre angle [rad] (COS in θ)
  double r_theta = 0.5;        ///< half-width in θ [rad], in (0, π] (COS in θ)
  double h0 = 0.05;            ///< centre height [m] (COS in h)
  double r_h = 0.02;           ///< half-height [m], > 0 (COS in h)
  double theta1 = -0.5;        ///< start angle [rad] (SIG in θ)
  double theta2 = 0.5;         ///< end angle [rad] (SIG in θ)
  double lambda_theta = 20.0;  ///< steepness [1/rad], > 0 (SIG in θ)
  double h1 = 0.02;            ///< lower height [m] (SIG in h; GRAD: full pressure below)
  double h2 = 0.08;            ///< upper height [m] (SIG in h; GRAD: zero above), > h1
  double lambda_h = 400.0;     ///< steepness [1/m], > 0 (SIG in h)
  bool enabled = true;         ///< a disabled spot contributes nothing (kept in the case file)
  bool optimise_amplitude = true;  ///< the optimiser may change A
  bool optimise_position = true;   ///< the optimiser may move the centre (θ0/h0 or θ1,θ2/h1,h2)
  /// Upper bound of A for the optimiser [Pa] (0: the optimiser's default bound). The default
  /// layout bounds its distal GRAD at 10 kPa: a PTB socket keeps distal contact without end bearing.
  double max_amplitude_pa = 0.0;
};

double key_cos(double x, double x0, double r);
double key_sig(double x, double x1, double x2, double lambda);
double key_rmp(double x, double x1, double x2);

/// Wraps an angle to (−π, π].
double wrap_angle(double a);

/// f_θ(θ) · f_h(h) of @p spot, in [0, 1] (without the amplitude).
double spot_shape(const Spot& spot, double theta, double h);

/// A · f_θ(θ) · f_h(h) [Pa] (0 for a disabled spot).
inline double spot_pressure(const Spot& spot, double theta, double h) {
  return spot.enabled ? spot.amplitude_pa * spot_shape(spot, theta, h) : 0.0;
}

/// Σ of the spots' pressures at (θ, h) [Pa].
double field_pressure(const std::vector<Spot>& spots, double theta, double h);

/// Checks a spot against the limb (heights 0..limb_length_m): widths and steepness positive and
/// finite, amplitude ≥ 0, and its centre on the limb. @throws InvalidInputError with one line
/// naming the spot, the field and the fix (e.g. a spot centred above the limb's top).
void validate_spot(const Spot& spot, double limb_length_m);

/// Centre of a spot (θ, h) for reports and pictures: (θ0 or the middle of θ1..θ2 or 0, h0 or the
/// middle of h1..h2).
void spot_centre(const Spot& spot, double& theta, double& h);

}  // namespace socketsmith::design
