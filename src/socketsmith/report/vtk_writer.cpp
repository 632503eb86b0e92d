#include "socketsmith/report/vtk_writer.h"

#include <fmt/format.h>

#include <cmath>
#include <cstdint>
#include <iterator>
#include <ostream>
#include <set>
#include <string_view>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/report/svg_plot.h"  // xml_escape

namespace socketsmith::report {
namespace {

constexpr std::uint8_t kVtkTriangle = 5;
constexpr std::uint8_t kVtkHexahedron = 12;
constexpr std::string_view kNodeTagsName = "node_tags";

/// Streams "<DataArray ...>values</DataArray>" through a buffer flushed in chunks, so large
/// meshes do not need the whole file in memory. Numbers use the shortest representation that
/// reads back to the same double.
class ArrayWriter {
 public:
  ArrayWriter(std::ostream& out, std::string_view type, std::string_view name, int components,
              int per_line)
      : out_(out), per_line_(per_line) {
    fmt::format_to(std::back_inserter(buf_), R"(        <DataArray type="{}")", type);
    if (!name.empty()) fmt::format_to(std::back_inserter(buf_), R"( Name="{}")", xml_escape(name));
    if (components != 1)
      fmt::format_to(std::back_inserter(buf_), R"( NumberOfComponents="{}")", components);
    fmt::format_to(std::back_inserter(buf_), R"( format="ascii">)");
  }
  ArrayWriter(const ArrayWriter&) = delete;
  ArrayWriter& operator=(const ArrayWriter&) = delete;

  template <class T>
  void add(T value) {
    if (count_ % per_line_ == 0)
      buf_.append(std::string_view("\n          "));
    else
      buf_.push_back(' ');
    fmt::format_to(std::back_inserter(buf_), "{}", value);
    ++count_;
    if (buf_.size() > (1u << 16)) flush();
  }

  void finish() {
    buf_.append(std::string_view("\n        </DataArray>\n"));
    flush();
  }

 private:
  void flush() {
    out_.write(buf_.data(), static_cast<std::streamsize>(buf_.size()));
    buf_.clear();
  }

  std::ostream& out_;
  int per_line_;
  std::size_t count_ = 0;
  fmt::memory_buffer buf_;
};

void write_field(std::ostream& out, const VtkField& field) {
  const int per_line = field.components == 1 ? 6 : field.components;
  ArrayWriter w(out, "Float64", field.name, field.components, per_line);
  for (double v : field.values) w.add(v);
  w.finish();
}

void write_points(std::ostream& out, const std::vector<Eigen::Vector3d>& points) {
  out << "      <Points>\n";
  ArrayWriter w(out, "Float64", "Points", 3, 3);
  for (const auto& p : points) {
    w.add(p.x());
    w.add(p.y());
    w.add(p.z());
  }
  w.finish();
  out << "      </Points>\n";
}

/// Validates a set of fields for @p n points or cells. @p what is "point" or "cell".
void check_fields(std::string_view where, const std::filesystem::path& path,
                  const std::vector<VtkField>& fields, std::size_t n, std::string_view what,
                  bool reserve_node_tags) {
  std::set<std::string> names;
  for (std::size_t i = 0; i < fields.size(); ++i) {
    const VtkField& f = fields[i];
    require(!f.name.empty(), "{}: {} field {} for '{}' has an empty name (expected a unique name)",
            where, what, i, path.string());
    require(!reserve_node_tags || f.name != kNodeTagsName,
            "{}: point field '{}' for '{}' clashes with the node_tags field that is always "
            "written (choose another name)",
            where, f.name, path.string());
    require(names.insert(f.name).second,
            "{}: {} field name '{}' for '{}' is used twice (expected unique names)", where, what,
            f.name, path.string());
    require(f.components >= 1, "{}: {} field '{}' has components = {} (expected >= 1)", where, what,
            f.name, f.components);
    const std::size_t expected = n * static_cast<std::size_t>(f.components);
    require(f.values.size() == expected,
            "{}: {} field '{}' has {} values (expected {} = {} {}s × {} components)", where, what,
            f.name, f.values.size(), expected, n, what, f.components);
    for (std::size_t k = 0; k < f.values.size(); ++k)
      require(std::isfinite(f.values[k]),
              "{}: {} field '{}' has the non-finite value {} at {} {}, component {} (VTK ASCII "
              "readers cannot read it back; expected finite values)",
              where, what, f.name, f.values[k], what, k / static_cast<std::size_t>(f.components),
              k % static_cast<std::size_t>(f.components));
  }
}

void check_points(std::string_view where, const std::vector<Eigen::Vector3d>& points,
                  std::string_view what) {
  for (std::size_t i = 0; i < points.size(); ++i)
    require(points[i].allFinite(), "{}: {} {} has a non-finite coordinate ({}, {}, {})", where,
            what, i, points[i].x(), points[i].y(), points[i].z());
}

template <std::size_t N>
void check_cells(std::string_view where, const std::vector<std::array<int, N>>& cells,
                 std::size_t num_points, std::string_view what) {
  for (std::size_t c = 0; c < cells.size(); ++c)
    for (std::size_t k = 0; k < N; ++k)
      require(cells[c][k] >= 0 && static_cast<std::size_t>(cells[c][k]) < num_points,
              "{}: {} {} node {} has index {} (expected 0..{})", where, what, c, k, cells[c][k],
              static_cast<long long>(num_points) - 1);
}

template <std::size_t N>
void write_cell_arrays(std::ostream& out, const std::vector<std::array<int, N>>& cells,
                       bool with_types, std::uint8_t type) {
  {
    ArrayWriter w(out, "Int64", "connectivity", 1, static_cast<int>(N));
    for (const auto& cell : cells)
      for (int v : cell) w.add(v);
    w.finish();
  }
  {
    ArrayWriter w(out, "Int64", "offsets", 1, 8);
    for (std::size_t c = 0; c < cells.size(); ++c) w.add((c + 1) * N);
    w.finish();
  }
  if (with_types) {
    ArrayWriter w(out, "UInt8", "types", 1, 16);
    for (std::size_t c = 0; c < cells.size(); ++c) w.add(static_cast<int>(type));
    w.finish();
  }
}

void write_data_section(std::ostream& out, std::string_view tag,
                        const std::vector<VtkField>& fields, const std::vector<int>* node_tags,
                        std::size_t num_tags) {
  if (fields.empty() && node_tags == nullptr) return;
  out << "      <" << tag << ">\n";
  if (node_tags != nullptr) {
    ArrayWriter w(out, "Int32", kNodeTagsName, 1, 16);
    for (std::size_t i = 0; i < num_tags; ++i) w.add(node_tags->empty() ? 0 : (*node_tags)[i]);
    w.finish();
  }
  for (const auto& f : fields) write_field(out, f);
  out << "      </" << tag << ">\n";
}

void write_header(std::ostream& out, std::string_view type) {
  out << "<?xml version=\"1.0\"?>\n"
      << "<VTKFile type=\"" << type
      << R"(" version="1.0" byte_order="LittleEndian" header_type="UInt64">)" << '\n'
      << "  <" << type << ">\n";
}

void write_footer(std::ostream& out, std::string_view type) {
  out << "    </Piece>\n"
      << "  </" << type << ">\n"
      << "</VTKFile>\n";
}

}  // namespace

VtkField make_vector_field(std::string name, const std::vector<Eigen::Vector3d>& vectors) {
  VtkField f;
  f.name = std::move(name);
  f.components = 3;
  f.values.reserve(3 * vectors.size());
  for (const auto& v : vectors) f.values.insert(f.values.end(), {v.x(), v.y(), v.z()});
  return f;
}

void write_vtu(const std::filesystem::path& path, const volume::HexMesh& mesh,
               const std::vector<VtkField>& point_fields,
               const std::vector<VtkField>& cell_fields) {
  constexpr std::string_view where = "write_vtu";
  const std::size_t num_nodes = mesh.nodes.size();
  const std::size_t num_cells = mesh.hexahedra.size();
  require(mesh.node_tags.empty() || mesh.node_tags.size() == num_nodes,
          "{}: node_tags has {} entries for {} nodes (expected one per node, or none)", where,
          mesh.node_tags.size(), num_nodes);
  check_points(where, mesh.nodes, "node");
  check_cells(where, mesh.hexahedra, num_nodes, "hexahedron");
  check_fields(where, path, point_fields, num_nodes, "point", true);
  check_fields(where, path, cell_fields, num_cells, "cell", false);

  std::vector<int> tags(mesh.node_tags.begin(), mesh.node_tags.end());
  write_file_atomically(path, [&](std::ostream& out) {
    write_header(out, "UnstructuredGrid");
    out << "    <Piece NumberOfPoints=\"" << num_nodes << "\" NumberOfCells=\"" << num_cells
        << "\">\n";
    write_data_section(out, "PointData", point_fields, &tags, num_nodes);
    write_data_section(out, "CellData", cell_fields, nullptr, num_cells);
    write_points(out, mesh.nodes);
    out << "      <Cells>\n";
    write_cell_arrays(out, mesh.hexahedra, true, kVtkHexahedron);
    out << "      </Cells>\n";
    write_footer(out, "UnstructuredGrid");
  });
}

void write_vtp(const std::filesystem::path& path, const geometry::TriMesh& mesh,
               const std::vector<VtkField>& point_fields,
               const std::vector<VtkField>& cell_fields) {
  constexpr std::string_view where = "write_vtp";
  const std::size_t num_vertices = mesh.vertices.size();
  const std::size_t num_triangles = mesh.triangles.size();
  check_points(where, mesh.vertices, "vertex");
  check_cells(where, mesh.triangles, num_vertices, "triangle");
  check_fields(where, path, point_fields, num_vertices, "point", false);
  check_fields(where, path, cell_fields, num_triangles, "cell", false);

  write_file_atomically(path, [&](std::ostream& out) {
    write_header(out, "PolyData");
    out << "    <Piece NumberOfPoints=\"" << num_vertices
        << R"(" NumberOfVerts="0" NumberOfLines="0" NumberOfStrips="0" NumberOfPolys=")"
        << num_triangles << "\">\n";
    write_data_section(out, "PointData", point_fields, nullptr, num_vertices);
    write_data_section(out, "CellData", cell_fields, nullptr, num_triangles);
    write_points(out, mesh.vertices);
    out << "      <Polys>\n";
    write_cell_arrays(out, mesh.triangles, false, kVtkTriangle);
    out << "      </Polys>\n";
    write_footer(out, "PolyData");
  });
}

}  // namespace socketsmith::report
