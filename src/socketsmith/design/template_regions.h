#pragma once
/// @file template_regions.h
/// What a brim template means, measured on a design: the pressure-tolerant and pressure-sensitive
/// regions each transtibial template names (from the landmarks), and per region the mean and peak
/// pressure and the share of the axial load it carries; the distal fifth's share; the pressure's
/// coefficient of variation below the brim. A prosthetist reads a "PTB" design by these numbers:
/// does it bear on the patellar tendon, the flares and the popliteal area, and relieve the fibular
/// head, the tibial crest and the distal tibia?
///
/// Regions (Radcliffe & Foort 1961, the PTB prosthesis; Fergason & Smith 1999, "Socket
/// considerations for the patient with a transtibial amputation", Clin Orthop Relat Res 361:
/// 76–84): tolerant — patellar tendon (PT), medial tibial flare (MF), lateral flare / pretibial
/// muscles (LF), popliteal area (POP, counter-pressure); sensitive — fibular head (FH), tibial crest
/// (TC), anterior distal tibia (AD), distal end of the tibia (DT). The supracondylar variants
/// (PTB-SC, PTB-SCSP, KBM) add suspension above the condyles, not new bearing regions, so they share
/// PTB's table. TSB (total surface bearing) means as uniform a pressure as the constraints allow.
///
/// First criteria (issue 22, until the literature gives better ones): PTB family — the tolerant
/// regions' mean pressure at least 1.5 × the sensitive ones', and the distal 20 % of the length
/// carrying at most 10 % of the axial load; TSB — coefficient of variation below the brim ≤ 0.35.
#include <string>
#include <vector>

#include <Eigen/Core>

#include "socketsmith/design/brim.h"
#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/volume/landmarks.h"

namespace socketsmith::design {

/// The regions a template names; empty lists for a template without a region table (the
/// transfemoral ones, custom).
struct TemplateRegions {
  std::vector<std::string> tolerant, sensitive;  ///< landmark codes
  bool uniform = false;                          ///< TSB: as uniform as the constraints allow
};
TemplateRegions template_regions(BrimTemplate kind);

/// One region's load on the designed skin. Axial load per skin node: the normal force's component
/// along the limb axis plus the friction the design counts on, μ p A |n × axis| — the same terms as
/// the radar's F_z, so the shares of all nodes sum to 1.
struct ZoneLoad {
  std::string key;                 ///< "tolerant", "sensitive", "distal_fifth", "below_brim"
  std::vector<std::string> codes;  ///< landmarks in it (empty for distal_fifth, below_brim)
  int nodes = 0;
  double mean_pa = 0.0;            ///< area-weighted mean pressure [Pa]
  double peak_pa = 0.0;            ///< largest nodal pressure [Pa]
  double axial_force_n = 0.0;      ///< its share of F_z [N]
  double axial_share = 0.0;        ///< axial_force_n / F_z of all nodes
};

/// The design read against its template.
struct TemplateCheck {
  std::string template_name;
  ZoneLoad tolerant, sensitive, distal_fifth, below_brim;
  double total_axial_n = 0.0;      ///< F_z of all nodes (the radar's) [N]
  double tolerant_to_sensitive = 0.0;  ///< tolerant.mean / sensitive.mean (0 when not defined)
  double cv_below_brim = 0.0;      ///< area-weighted SD / mean of the pressure below the brim
  bool applies = false;            ///< the template has criteria (PTB family, TSB)
  bool met = false;                ///< its first criteria hold
  std::string summary;             ///< one line, e.g. "PTB: tolerant 1.9 × sensitive, distal fifth 7 % of the load: met"
};

/// Skin node data of a design (one entry per skin node): rest positions (where the landmarks
/// are), deformed unit normals, areas, pressures, and whether each lies above the brim.
struct SkinLoads {
  const std::vector<Eigen::Vector3d>* rest_positions = nullptr;
  const std::vector<Eigen::Vector3d>* normals = nullptr;
  const std::vector<double>* areas_m2 = nullptr;
  const std::vector<double>* pressures_pa = nullptr;
  const std::vector<char>* above_brim = nullptr;
};

/// The issue-22 first criteria, shared by the check and the optimiser that aims at them.
inline constexpr double kMinTolerantToSensitive = 1.5;  ///< PTB family: tolerant mean ≥ this × sensitive mean
inline constexpr double kMaxDistalFifthShare = 0.10;    ///< PTB family: distal fifth's share of F_z at most
inline constexpr double kMaxCvBelowBrim = 0.35;         ///< TSB: pressure CV below the brim at most

/// The skin nodes of a template's regions (one flag per skin node): a landmark's region is the
/// nodes below the brim within the landmark's radius of it (rest positions); the distal fifth is
/// the nodes at heights up to 0.2 × the stump length (limb frame).
struct TemplateMasks {
  std::vector<char> tolerant, sensitive, distal_fifth, below_brim;
  std::vector<std::string> tolerant_codes, sensitive_codes;  ///< the landmarks found for each
};
TemplateMasks template_masks(BrimTemplate kind, const std::vector<volume::Landmark>& landmarks,
                             const std::vector<Eigen::Vector3d>& rest_positions, const std::vector<char>& above_brim,
                             const geometry::LimbFrame& frame, double stump_length_m);

/// Reads the design @p skin against @p kind: a node is in a landmark's region when it lies below
/// the brim within the landmark's radius of it (rest positions). @p stump_length_m sets the distal
/// fifth (heights below 0.2 × length in the limb frame), @p friction the friction term.
/// @throws InvalidInputError when the arrays are missing or differ in size.
TemplateCheck check_template(BrimTemplate kind, const std::vector<volume::Landmark>& landmarks, const SkinLoads& skin,
                             const geometry::LimbFrame& frame, double stump_length_m, double friction);

}  // namespace socketsmith::design
