#pragma once
/// @file ischial_check.h
/// Where a transfemoral socket holds the ischial tuberosity, checked in 3D on the built socket.
///
/// The bony tuberosity (volume::TransfemoralPoints, from the hemipelvis or its template) is tested
/// against the socket's cavity: the built socket's inner wall closed over its rim by the brim's own
/// surface — every point (r, θ, h = rim height at θ) inside the rim, a ruled cap from each rim
/// vertex to the axis at its height — so "inside" means below the brim AND within the wall:
/// - ICS (ischial containment): the tuberosity must lie INSIDE the cavity; the margin is its
///   distance to the cavity's surface (positive inside: the nearer of the wall and the brim's cap).
/// - quadrilateral: the tuberosity sits ON the seat: the brim at the tuberosity's angle lies at or
///   just below its height (0 to seat_tolerance_m below), so the bone rests on the seat's edge and
///   is not inside the cavity by more than seat_above_tolerance_m.
/// A height-only test (the brim above IS) cannot tell a wall that passes medially or laterally of
/// the bone from one that wraps it; this one can.

#include <string>

#include <Eigen/Core>

#include "socketsmith/design/brim.h"
#include "socketsmith/design/socket_builder.h"
#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::design {

/// The socket's cavity as a closed surface [m], outward of the cavity: the inner wall
/// (SocketFace::Inner triangles of @p socket.solid, flipped: the solid's inner wall faces into the
/// cavity); the rim (its highest boundary loop) closed by the brim's cap — for each rim edge (a, b)
/// the triangles (b, a, A_a) and (b, A_a, A_b), A_x the point of @p frame's axis at x's height;
/// any other boundary loop (an attachment hole) by a fan to its centroid. The cap's triangles at the
/// axis are degenerate (zero area) where the rim is level; geometry::SurfaceQuery leaves them out.
/// @throws InvalidInputError when the socket has no inner wall or its face kinds do not match it.
geometry::TriMesh socket_cavity_surface(const SocketResult& socket, const geometry::LimbFrame& frame);

/// Limits of check_ischial_tuberosity.
struct IschialCheckOptions {
  /// Quadrilateral: the seat may lie this far below the tuberosity and still carry it [m], > 0.
  double seat_tolerance_m = 0.015;
  /// Quadrilateral: the seat may lie this far above the tuberosity (meshing of the brim) [m], ≥ 0.
  double seat_above_tolerance_m = 0.002;
};

/// What check_ischial_tuberosity found.
struct IschialCheck {
  bool applies = false;           ///< an ICS or quadrilateral brim with a built socket
  std::string kind;               ///< "containment" (ics), "seat" (quad), "" when it does not apply
  Eigen::Vector3d tuberosity = Eigen::Vector3d::Zero();  ///< the bony point tested [m]
  double tuberosity_theta_rad = 0.0;  ///< its angle in the limb frame
  double tuberosity_h_m = 0.0;        ///< its height above the distal end [m]
  double brim_h_m = 0.0;              ///< the brim at that angle [m]
  bool inside_cavity = false;         ///< 3D: inside the closed cavity surface
  double cavity_margin_m = 0.0;       ///< distance to the cavity surface, positive inside [m]
  /// ICS: brim − tuberosity height (positive: the brim is above it); quad: tuberosity − seat height
  /// (0…seat_tolerance_m: on the seat) [m].
  double height_margin_m = 0.0;
  bool met = false;               ///< ICS: inside the cavity; quad: on the seat and not inside the cavity
  std::string summary;            ///< one line, for the report
};

/// Checks the bony ischial tuberosity @p tuberosity [m] against the built @p socket with @p brim in
/// @p frame (see the file comment). Templates other than ICS and quad: applies = false.
IschialCheck check_ischial_tuberosity(const BrimLine& brim, const geometry::LimbFrame& frame,
                                      const Eigen::Vector3d& tuberosity, const SocketResult& socket,
                                      const IschialCheckOptions& options = {});

}  // namespace socketsmith::design
