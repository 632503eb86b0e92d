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

/// What sets a .vtu of hexahedra apart from a .vtp of triangles.
struct GridKind {
  std::string_view where;        ///< the writer, for messages
  std::string_view vtk_type;     ///< "UnstructuredGrid" | "PolyData"
  std::string_view point_name;   ///< "node" | "vertex"
  std::string_view cell_name;    ///< "hexahedron" | "triangle"
  std::string_view zero_counts;  ///< the Piece's counts of kinds not written, each followed by a space
  std::string_view count_name;   ///< the Piece's count of the cells
  std::string_view cells_tag;    ///< "Cells" | "Polys"
  bool with_types;               ///< a types array (unstructured grids only)
  std::uint8_t cell_type;
};

/// Checks and writes one piece of @p kind; @p node_tags (with reserved name) only for the .vtu.
template <std::size_t N>
void write_grid(const std::filesystem::path& path, const GridKind& kind, const std::vector<Eigen::Vector3d>& points,
                const std::vector<std::array<int, N>>& cells, const std::vector<int>* node_tags,
                const std::vector<VtkField>& point_fields, const std::vector<VtkField>& cell_fields) {
  const std::size_t num_points = points.size();
  const std::size_t num_cells = cells.size();
  check_points(kind.where, points, kind.point_name);
  check_cells(kind.where, cells, num_points, kind.cell_name);
  check_fields(kind.where, path, point_fields, num_points, "point", node_tags != nullptr);
  check_fields(kind.where, path, cell_fields, num_cells, "cell", false);

  write_file_atomically(path, [&](std::ostream& out) {
    write_header(out, kind.vtk_type);
    out << "    <Piece NumberOfPoints=\"" << num_points << "\" " << kind.zero_counts << kind.count_name << "=\""
        << num_cells << "\">\n";
    write_data_section(out, "PointData", point_fields, node_tags, num_points);
    write_data_section(out, "CellData", cell_fields, nullptr, num_cells);
    write_points(out, points);
    out << "      <" << kind.cells_tag << ">\n";
    write_cell_arrays(out, cells, kind.with_types, kind.cell_type);
    out << "      </" << kind.cells_tag << ">\n";
    write_footer(out, kind.vtk_type);
  });
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
  constexpr GridKind kind{"write_vtu", "UnstructuredGrid", "node", "hexahedron", "", "NumberOfCells", "Cells",
                          true, kVtkHexahedron};
  require(mesh.node_tags.empty() || mesh.node_tags.size() == mesh.nodes.size(),
          "{}: node_tags has {} entries for {} nodes (expected one per node, or none)", kind.where,
          mesh.node_tags.size(), mesh.nodes.size());
  const std::vector<int> tags(mesh.node_tags.begin(), mesh.node_tags.end());
  write_grid(path, kind, mesh.nodes, mesh.hexahedra, &tags, point_fields, cell_fields);
}

void write_vtp(const std::filesystem::path& path, const geometry::TriMesh& mesh,
               const std::vector<VtkField>& point_fields,
               const std::vector<VtkField>& cell_fields) {
  constexpr GridKind kind{"write_vtp", "PolyData", "vertex", "triangle",
                          R"(NumberOfVerts="0" NumberOfLines="0" NumberOfStrips="0" )", "NumberOfPolys", "Polys",
                          false, kVtkTriangle};
  write_grid(path, kind, mesh.vertices, mesh.triangles, nullptr, point_fields, cell_fields);
}

}  // namespace socketsmith::report
