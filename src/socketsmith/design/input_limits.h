#pragma once
/// @file input_limits.h
/// The range of every number a user gives socketsmith — in a case file, on the command line or in
/// the GUI — in one table, with one check, so the three say the same thing and nothing is
/// silently replaced by a default. The same ranges are listed in docs/case_file.md ("Ranges");
/// a unit test keeps the two in step.

#include <string>
#include <string_view>
#include <vector>

namespace socketsmith::design {

struct PatientLoad;

/// An interval of accepted values in the units the user types (kg, kPa, mm, -, s).
struct InputLimit {
  std::string_view key;     ///< case-file key, e.g. "patient.friction" (or the flag's meaning)
  std::string_view unit;    ///< "kg", "kPa", "mm", "" (dimensionless), "s"
  double min = 0.0;
  double max = 0.0;
  bool is_min_open = false; ///< true: value > min; false: value ≥ min
  bool is_max_open = false; ///< true: value < max; false: value ≤ max
  bool is_integer = false;  ///< whole numbers only
  std::string_view hint;    ///< what a typical value is, e.g. "skin on a socket: about 0.5"
};

namespace limits {
// Patient
inline constexpr InputLimit kBodyMass{"patient.body_mass_kg", "kg", 0, 400, true, true, false,
                                      "the body mass must be positive and in kg (e.g. 70)"};
inline constexpr InputLimit kProsthesisMass{"patient.prosthesis_mass_kg", "kg", 0, 50, false, false, false,
                                            "the prosthesis mass in kg (thesis: about 2)"};
inline constexpr InputLimit kFriction{"patient.friction", "", 0, 2, false, false, false,
                                      "the friction coefficient of skin on a socket, about 0.5"};
inline constexpr InputLimit kForceTolerance{"patient.force_tolerance", "", 0, 0.1, true, false, false,
                                            "a fraction of M g / 2 (0.01 = 1 %); above 10 % the radar would accept an "
                                            "unbalanced socket"};
inline constexpr InputLimit kTorqueTolerance{"patient.torque_tolerance", "", 0, 0.1, true, false, false,
                                             "a fraction of M g / 2 × stump length (0.01 = 1 %); above 10 % the radar "
                                             "would accept an unbalanced socket"};
inline constexpr InputLimit kPainThreshold{"patient.thresholds_kpa", "kPa", 0, 2000, true, true, false,
                                           "a pain threshold in kPa (thesis Table 7: 45–190)"};
// Tissue
inline constexpr InputLimit kYoungsModulus{"tissue.youngs_kpa", "kPa", 10, 10000, false, false, false,
                                           "the soft tissue's Young's modulus in kPa (typically 20–500)"};
inline constexpr InputLimit kDensity{"tissue.density_kg_m3", "kg/m^3", 100, 10000, false, false, false,
                                     "soft tissue: about 1060"};
inline constexpr InputLimit kFePoisson{"tissue.poisson", "", 0, 0.5, false, true, false,
                                       "the fe and neo-hookean models' Poisson ratio (soft tissue: 0.45-0.49)"};
inline constexpr InputLimit kCfPoisson{"tissue.poisson", "", 0.25, 0.5, false, true, false,
                                       "MSS-CF's target Poisson ratio (soft tissue: 0.45-0.49)"};
// Mesh, design, socket
inline constexpr InputLimit kTargetNodes{"mesh.target_nodes", "", 200, 200000, false, false, true,
                                         "e.g. 3000, 8000, 20000"};
inline constexpr InputLimit kModelPressureLimit{"design.model_pressure_limit", "", 0, 5, false, false, false,
                                                "a fraction of E; 0 = no limit (default 0.25)"};
inline constexpr InputLimit kMaxAmplitude{"design.spots[].max_amplitude_kpa", "kPa", 0, 5000, false, false, false,
                                          "the optimiser's bound on the spot's amplitude; 0 = none"};
inline constexpr InputLimit kClosedLoopDonnings{"design.closed_loop_donnings", "", 1, 20, false, false, true,
                                                "donnings at most, the open-loop socket's included (default 4)"};
inline constexpr InputLimit kClosedLoopBrimRaise{"design.closed_loop_max_brim_raise_mm", "mm", 0, 50, false, false, false,
                                                 "how far the closed loop may raise the socket's brim where donning "
                                                 "drags skin out of it, in mm (e.g. 10); 0 = never (the default)"};
inline constexpr InputLimit kClosedLoopRoughness{"design.closed_loop_max_roughness_mm", "mm", 0, 5, false, false, false,
                                                 "the closed loop's largest node-scale wall correction (a node's "
                                                 "minus its neighbours' mean), in mm (e.g. 0.2); 0 = no cap (the default)"};
inline constexpr InputLimit kClosedLoopStep{"design.closed_loop_step_mm", "mm", 2, 20, false, false, false,
                                            "the longest step of the closed loop's donning path, in mm (default 6; "
                                            "9 cuts the loop's Newton iterations by up to a quarter)"};
inline constexpr InputLimit kBrimFlare{"design.brim_flare_mm", "mm", 0, 50, false, false, false,
                                       "the designed pressure eases to nothing over this distance below the brim "
                                       "(a flared trim line), in mm; 0 = the spots' pressure up to the brim (default: 5 transtibial, 0 transfemoral)"};
inline constexpr InputLimit kTimeLimit{"design.time_limit_s", "s", 0, 86400, true, false, false,
                                       "the optimiser's wall-time bound in seconds (e.g. 60)"};
inline constexpr InputLimit kCutHeight{"limb.cut_height_mm", "mm", 0, 2000, true, false, false,
                                       "the proximal cut above the distal end, in mm (e.g. 180)"};
inline constexpr InputLimit kThickness{"socket.thickness_mm", "mm", 0, 50, true, false, false,
                                       "the wall must be thicker than 0 and at most 50 mm (typical 4–8)"};
inline constexpr InputLimit kDistalThickness{"socket.distal_thickness_mm", "mm", 1, 50, false, false, false,
                                             "a wall of 1-50 mm (leave it out for a uniform thickness_mm)"};
inline constexpr InputLimit kBrimThickness{"socket.brim_thickness_mm", "mm", 1, 50, false, false, false,
                                           "a wall of 1-50 mm (leave it out for a uniform thickness_mm)"};
inline constexpr InputLimit kFlexion{"socket.alignment.flexion_deg", "deg", -30, 30, false, false, false,
                                     "bench alignment: about 5 degrees of flexion"};
inline constexpr InputLimit kAdduction{"socket.alignment.adduction_deg", "deg", -30, 30, false, false, false,
                                       "bench alignment: a few degrees of adduction"};
inline constexpr InputLimit kHoleDiameter{"socket.attachment.hole_diameter_mm", "mm", 0, 150, true, false, false,
                                          "a clearance hole at least as wide as the bolt (leave it out for ISO 273 medium)"};
inline constexpr InputLimit kHoleSpacing{"socket.attachment.hole_spacing_mm", "mm", 0, 150, true, false, false,
                                         "the adapter's hole square, centre to centre"};
inline constexpr InputLimit kPlatformDiameter{"socket.attachment.platform_diameter_mm", "mm", 0, 150, true, false, false,
                                              "the distal platform's diameter"};
inline constexpr InputLimit kPlatformThickness{"socket.attachment.platform_thickness_mm", "mm", 0, 150, true, false,
                                               false, "the distal platform's thickness"};
inline constexpr InputLimit kAttachmentOffset{"socket.attachment.offset_mm", "mm", -20, 20, false, false, false,
                                              "each of [anterior, medial] within 20 mm of the axis; shift the rest with "
                                              "the adapter"};
inline constexpr InputLimit kDistalPadDiameter{"socket.distal_pad_diameter_mm", "mm", 0, 150, true, false, false,
                                               "the flat disc for the adapter (e.g. 40)"};
inline constexpr InputLimit kSubdivisions{"socket.subdivisions", "", 0, 3, false, false, true,
                                          "each quadruples the triangles"};
inline constexpr InputLimit kAttachmentRotation{"socket.attachment.rotation_deg", "deg", -360, 360, false, false,
                                                false, "the hole square's rotation about the pylon (e.g. 0 or 45)"};
// Limb and design
inline constexpr InputLimit kScale{"limb.scale", "", 0, 10000, true, false, false,
                                   "it multiplies the coordinates after the units; e.g. 0.45 with units m for a shape "
                                   "normalised to a 0.45 m femur"};
inline constexpr InputLimit kIschialShareMin{"design.ischial_share_min", "", 0, 0.9, false, false, false,
                                             "a fraction of the axial load, e.g. 0.2"};
// Spots (design.spots[]; the heights are checked against the limb's length when it is built)
inline constexpr InputLimit kSpotAmplitude{"design.spots[].amplitude_kpa", "kPa", 0, 5000, false, false, false,
                                           "the spot's peak pressure; a socket can only push, so never negative"};
inline constexpr InputLimit kSpotTheta0{"design.spots[].theta0_deg", "deg", -360, 360, false, false, false,
                                        "the centre's angle from anterior towards medial"};
inline constexpr InputLimit kSpotRTheta{"design.spots[].r_theta_deg", "deg", 0, 180, true, false, false,
                                        "the half-width around the limb"};
inline constexpr InputLimit kSpotH0{"design.spots[].h0_mm", "mm", -2000, 2000, false, false, false,
                                    "the centre's height above the distal end"};
inline constexpr InputLimit kSpotRH{"design.spots[].r_h_mm", "mm", 0, 2000, true, false, false,
                                    "the half-height along the limb"};
inline constexpr InputLimit kSpotTheta1{"design.spots[].theta1_deg", "deg", -360, 360, false, false, false,
                                        "where the sector starts, from anterior towards medial"};
inline constexpr InputLimit kSpotTheta2{"design.spots[].theta2_deg", "deg", -360, 360, false, false, false,
                                        "where the sector ends, from theta1 towards increasing angles"};
inline constexpr InputLimit kSpotLambdaTheta{"design.spots[].lambda_theta_per_deg", "1/deg", 0, 1000, true, false,
                                             false, "the sector's edge steepness (e.g. 0.35)"};
inline constexpr InputLimit kSpotH1{"design.spots[].h1_mm", "mm", -2000, 2000, false, false, false,
                                    "the band's lower height above the distal end"};
inline constexpr InputLimit kSpotH2{"design.spots[].h2_mm", "mm", -2000, 2000, false, false, false,
                                    "the band's upper height above the distal end"};
inline constexpr InputLimit kSpotLambdaH{"design.spots[].lambda_h_per_mm", "1/mm", 0, 1000, true, false, false,
                                         "the band's edge steepness (e.g. 0.4)"};
}  // namespace limits

/// Every limit above (for the documentation check and the fuzzers).
const std::vector<InputLimit>& all_input_limits();

/// The interval as text: "(0, 400) kg", "[0, 2]", "[200, 200000] (whole numbers)".
std::string describe(const InputLimit& limit);

/// What is wrong with @p value for @p limit ("3 is outside [0, 2]: the friction coefficient of
/// skin on a socket, about 0.5"), or "" when it is within.
std::string input_violation(const InputLimit& limit, double value);

/// Checks @p value against @p limit. @p name says where it came from, as the user wrote it:
/// "case file: patient.friction", "simulate donning: --friction", "patient panel: friction".
/// @returns value. @throws InvalidInputError, one line:
///   "case file: patient.friction = 3 is outside [0, 2]: the friction coefficient of skin on a socket, about 0.5"
double check_input(const InputLimit& limit, double value, std::string_view name);

/// check_input for whole numbers: @returns the value as int (only after the range check, so
/// 1e20 is reported as 1e+20, not as an overflowed int).
int check_input_count(const InputLimit& limit, double value, std::string_view name);

/// Every value of @p patient against its limit, and the prosthesis lighter than the body.
/// @p prefix starts each message ("case file: " → "case file: patient.friction = 3 is outside ...").
void check_patient(const PatientLoad& patient, std::string_view prefix = {});

}  // namespace socketsmith::design
