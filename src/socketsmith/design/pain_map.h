#pragma once
/// @file pain_map.h
/// The patient's pain-threshold map: the largest bearable pressure at landmark zones (thesis
/// Table 7), spread over the skin by inverse-distance weighting (thesis Fig. 56).

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/volume/landmarks.h"

namespace socketsmith::design {

/// Landmark code → bearable pressure [Pa].
using ThresholdTable = std::map<std::string, double>;

/// The thesis's Table 7 for a transtibial limb (PTB socket, standing; Safari et al.): MF 53.7,
/// PT 189.72, FH 45.85, POP 60.86, AD 98.77 kPa. Transfemoral (the thesis has none; sources and
/// which are assumed in docs/design.md, "Pain thresholds of a transfemoral limb"): IS ischial
/// tuberosity 95 (the walking maximum of ischial-bearing sockets, Lee et al. 1997), IR ischial
/// ramus 42.9 (the medial-proximal peak of comfortable ischial-ramal containment sockets, Kahle &
/// Highsmith 2013), GT greater trochanter 45.85 and DF distal femur 45.85 (bony prominences: the
/// fibular head's, assumed), AL adductor longus tendon 34 (the standing maximum, Lee et al. 1997,
/// for a known sore spot, assumed), ST Scarpa's triangle 60.86 (soft tissue over a neurovascular
/// bundle: the popliteal area's, assumed) kPa.
ThresholdTable default_thresholds(geometry::LimbType type);

/// The landmark codes a threshold table must cover for @p type (transtibial: Table 7's five
/// zones; transfemoral: IS, IR, GT, AL, ST, DF).
std::vector<std::string> required_threshold_codes(geometry::LimbType type);

/// Checks @p table against the limb's landmarks: every required code present, every value finite
/// and positive, every code a landmark of the limb. @throws InvalidInputError with one line naming
/// the landmark and the fix (e.g. "pain threshold missing for landmark FH").
void validate_thresholds(const ThresholdTable& table, const std::vector<volume::Landmark>& landmarks,
                         geometry::LimbType type);

/// Inverse-distance weighting: T(p) = Σ w_k T_k / Σ w_k, w_k = 1 / |p − L_k|^power, over the
/// landmarks with a threshold; exactly T_k at a landmark. Distances are straight-line [m].
/// @return one threshold [Pa] per point.
std::vector<double> threshold_map(const std::vector<Eigen::Vector3d>& points,
                                  const std::vector<volume::Landmark>& landmarks, const ThresholdTable& table,
                                  double power = 2.0);

}  // namespace socketsmith::design
