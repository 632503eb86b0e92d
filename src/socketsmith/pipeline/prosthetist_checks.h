#pragma once
/// @file prosthetist_checks.h
/// What a prosthetist checks on a rectified socket, computed from a design: the rectification
/// chart (socket minus limb, radially, at every skin point and at each landmark) and the slice
/// measurements (circumference, cross-section and volume of the limb and the socket's cavity every
/// 10 mm along the limb axis, with the % reduction). docs/prosthetist_checks.md.

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "socketsmith/design/brim.h"
#include "socketsmith/design/socket_builder.h"
#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/geometry/tri_mesh.h"
#include "socketsmith/report/design_report.h"
#include "socketsmith/report/slice_table.h"
#include "socketsmith/volume/landmarks.h"

namespace socketsmith::pipeline {

struct DesignSetup;
struct DesignResult;

/// Socket minus limb at one landmark.
struct LandmarkRectification {
  std::string code, name;
  double theta_rad = 0.0, h_m = 0.0;  ///< where (limb frame)
  double rectification_m = 0.0;       ///< socket − limb [m] (< 0: indentation); NaN above the brim
  bool is_axial = false;              ///< measured along the axis (the distal end), else radially
};

/// The rectification chart.
struct Rectification {
  /// Per vertex of the limb surface: socket − limb [m], radially where the skin faces sideways,
  /// along the axis where it faces down (the distal end); NaN above the brim or where no wall is met.
  std::vector<double> vertex_m;
  std::vector<LandmarkRectification> landmarks;
  double min_m = 0.0, max_m = 0.0;  ///< over the limb's vertices below the brim [m]
  double mean_m = 0.0;              ///< area-weighted [m]
};

/// Socket minus limb: for each vertex of @p limb below the brim, the distance from the limb's skin
/// to @p wall along the ray from the limb axis through the vertex (its radius on the wall less its
/// own) where the skin's normal is closer to radial than to the axis, and along the axis (how far
/// the wall lies below the skin) where it faces down, at the distal end — there a horizontal ray
/// grazes the skin and a radial difference is meaningless. The same at each landmark.
/// @param limb the limb's skin at rest [m] (the stump's rest skin)
/// @param wall the socket's inner wall, or the designed skin when no socket was built [m]
Rectification compute_rectification(const geometry::TriMesh& limb, const geometry::TriMesh& wall,
                                     const geometry::LimbFrame& frame, const design::BrimLine& brim,
                                     const std::vector<volume::Landmark>& landmarks);

/// "indentation" (< 0: the socket presses the tissue in), "relief" (≥ 0), or "above the brim" (NaN:
/// no wall) for a rectification @p socket_minus_limb_m.
const char* rectification_kind(double socket_minus_limb_m);

/// The half-range of the rectification's diverging colour bar [mm]: the larger of |min| and |max|
/// rounded up to a nice number (report::nice_ceil), at least 0.1 mm; the bar spans ± it.
double rectification_span_mm(const Rectification& rectification);

/// The surface a design's checks measure the socket by.
struct ChecksWall {
  geometry::TriMesh wall;          ///< oriented out of the cavity [m]
  std::string source;              ///< "the socket's inner wall", ... (as the report names it)
  double closed_below_m = 0.0;     ///< the cavity is a closed section below this h [m]
};

/// The socket's inner wall, turned to face out of the cavity, when @p socket is given (@p closed_loop:
/// it is the closed loop's corrected socket), else @p designed_skin (the skin at the designed shape).
ChecksWall checks_wall(const design::SocketResult* socket, bool closed_loop, const geometry::TriMesh& designed_skin,
                       const design::BrimLine& brim);

/// The wall of a solved but not yet written design (what the GUI measures after each design): the
/// socket solve_design builds (build_design_socket, before any closed loop) when @p constraints_met,
/// else @p designed_skin. Takes copies' references only, no DesignSetup, so it may run on a thread
/// of its own while the solver goes on. @throws as design::build_socket.
ChecksWall designed_wall(const geometry::TriMesh& rest_skin, const geometry::TriMesh& designed_skin,
                         bool constraints_met, const geometry::LimbFrame& frame, const design::BrimLine& brim,
                         const design::SocketOptions& socket);

/// The checks of a design.
struct ProsthetistChecks {
  std::string wall_source;        ///< "the socket's inner wall" or "the designed skin (no socket built)"
  geometry::TriMesh wall;          ///< that surface, oriented out of the cavity [m]
  Rectification rectification;
  report::SliceTable slices;       ///< limb (rest skin) against the socket's cavity, every 10 mm
  double socket_closed_below_m = 0.0;  ///< the cavity is a closed section below this h (the brim's lowest point) [m]
};

/// The checks of @p result: the wall is the socket's inner wall when a socket was built (the
/// closed loop's when it ran), else the designed skin; the limb is the stump's rest skin.
ProsthetistChecks prosthetist_checks(const DesignSetup& setup, const DesignResult& result);

/// Writes rectification_map.png, rectification.csv (per landmark) and slices.csv into @p out,
/// fills the report's sections (its map refers to result.rest_skin, which must outlive the report's
/// writing) and returns {"rectification": …, "slices": …} for design.json.
nlohmann::json write_prosthetist_checks(const DesignSetup& setup, const DesignResult& result,
                                        const ProsthetistChecks& checks, const std::filesystem::path& out,
                                        report::DesignReportData& report);

}  // namespace socketsmith::pipeline
