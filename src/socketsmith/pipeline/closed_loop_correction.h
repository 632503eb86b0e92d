#pragma once
/// @file closed_loop_correction.h
/// The closed loop's wall correction (pipeline/closed_loop.h, step 2 and 3 of docs/design.md,
/// "Closed loop"): the excess of the delivered over the designed pressures becomes the skin's normal
/// displacement under it, moved onto the wall where each node touches it once donned.

#include <vector>

#include <Eigen/Core>

#include "socketsmith/contact/donning.h"
#include "socketsmith/design/design_solver.h"
#include "socketsmith/pipeline/closed_loop.h"

namespace socketsmith::pipeline {

/// Each skin node's position donned and stood, in the socket's frame (the socket's standing offset
/// along @p axis taken off).
std::vector<Eigen::Vector3d> donned_in_socket(const volume::SkinSurface& skin, const contact::DonningResult& d,
                                              const Eigen::Vector3d& axis);

/// The wall's correction at each skin node's vertex: the skin's normal displacement under the excess
/// of @p delivered over @p target (smoothed, ClosedLoopOptions::smoothing_passes), ω-relaxed, moved
/// to where each node touches the wall (@p donned, in the socket's frame; the wall is the designed
/// skin moved by @p offset along its normals). Only the nodes @p in_socket (compared, and donned
/// below the brim) correct the wall: a node that donning dragged above the brim touches at most the
/// brim's lip, which no correction shapes, and its deficit, moved onto the vertices above the brim,
/// only pulled the rim in from one correction to the next (seed 7, 3k: to the 5 mm clamp, raising
/// the 99th percentile of the ring below from 5.8 to 10 kPa). @p spacing: the skin nodes' mean
/// spacing [m] (the Gaussian's σ is half of it).
std::vector<double> wall_corrections(design::DesignSolver& solver, const design::DesignState& state,
                                     const std::vector<int>& in_socket, const std::vector<double>& delivered,
                                     const std::vector<double>& target, const std::vector<Eigen::Vector3d>& donned,
                                     const std::vector<double>& offset, double spacing,
                                     const ClosedLoopOptions& options);

}  // namespace socketsmith::pipeline
