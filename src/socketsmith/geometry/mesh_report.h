#pragma once
/// @file mesh_report.h
/// What a user must know about a surface file before using it — units, size, closed, manifold,
/// orientation, components, landmarks — as JSON: `socketsmith check mesh --json` and the Python
/// package's check_mesh print the same document from this one function.

#include <string>

#include <nlohmann/json.hpp>

#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::geometry {

/// The report of @p mesh as read from @p file with @p info: file, format, unit, unit_guessed,
/// vertices, triangles, bounding_box_m, components, boundary_loops, boundary_edges,
/// non_manifold_edges, inconsistently_oriented_edges, degenerate_triangles, closed,
/// signed_volume_m3, problems, and warning / landmarks (points_mm) when there are any.
nlohmann::json mesh_report_json(const std::string& file, const TriMesh& mesh, const MeshReadInfo& info);

}  // namespace socketsmith::geometry
