#pragma once
/// @file vtk_writer.h
/// ParaView-readable VTK XML files: hexahedral volumes (.vtu, UnstructuredGrid) and triangle
/// surfaces (.vtp, PolyData) with point and cell fields. ASCII, Float64 coordinates, written
/// atomically. Coordinates and values are written as given (SI units inside socketsmith).

#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

#include "socketsmith/geometry/tri_mesh.h"
#include "socketsmith/volume/hex_mesh.h"

namespace socketsmith::report {

/// A named field on points or cells. Tuple i occupies values[i*components .. i*components +
/// components - 1] (a vector field with 3 components is x0 y0 z0 x1 y1 z1 ...).
struct VtkField {
  std::string name;            ///< unique among the fields of one kind, not empty
  int components = 1;          ///< 1 = scalar, 3 = vector, 9 = tensor; >= 1
  std::vector<double> values;  ///< size = (#points or #cells) × components, finite
};

/// A 3-component field from one vector per point or cell (e.g. displacement_m).
VtkField make_vector_field(std::string name, const std::vector<Eigen::Vector3d>& vectors);

/// Writes @p mesh as a VTK XML UnstructuredGrid (.vtu) of VTK_HEXAHEDRON (type 12) cells.
/// The point field "node_tags" (Int32, the NodeTag bits of HexMesh::node_tags, 0 when
/// node_tags is empty) is always added.
/// @param point_fields one tuple per node
/// @param cell_fields  one tuple per hexahedron
/// @throws InvalidInputError naming the field when a field has the wrong size, a non-finite
///         value, an empty or duplicate name (or "node_tags" among the point fields), or
///         components < 1; naming the node/element when a coordinate is not finite, an index
///         is out of range, or node_tags has the wrong size. IoError when the file cannot be
///         written.
void write_vtu(const std::filesystem::path& path, const volume::HexMesh& mesh,
               const std::vector<VtkField>& point_fields = {},
               const std::vector<VtkField>& cell_fields = {});

/// Writes @p mesh as a VTK XML PolyData (.vtp) of triangles.
/// @param point_fields one tuple per vertex
/// @param cell_fields  one tuple per triangle
/// @throws as write_vtu (without the node_tags rules).
void write_vtp(const std::filesystem::path& path, const geometry::TriMesh& mesh,
               const std::vector<VtkField>& point_fields = {},
               const std::vector<VtkField>& cell_fields = {});

}  // namespace socketsmith::report
