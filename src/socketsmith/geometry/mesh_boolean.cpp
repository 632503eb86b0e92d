#include "socketsmith/geometry/mesh_boolean.h"

#include <string>
#include <vector>

#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/corefinement.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>

#include "socketsmith/core/errors.h"

namespace socketsmith::geometry {
namespace {

// Exact constructions: the intersection points of the corefinement are exact, so the result is
// a valid solid before it is rounded to double (CGAL's recommended kernel for Booleans).
using Kernel = CGAL::Exact_predicates_exact_constructions_kernel;
using Mesh = CGAL::Surface_mesh<Kernel::Point_3>;
namespace PMP = CGAL::Polygon_mesh_processing;

const char* name(BooleanOperation op) {
  switch (op) {
    case BooleanOperation::Union: return "union";
    case BooleanOperation::Difference: return "difference";
    case BooleanOperation::Intersection: return "intersection";
  }
  return "?";
}

Mesh to_cgal(const TriMesh& m, const char* which, BooleanOperation op, bool check) {
  require(!m.empty(), "mesh_boolean ({}): the {} operand has no triangles", name(op), which);
  Mesh out;
  std::vector<Mesh::Vertex_index> v;
  v.reserve(m.vertices.size());
  for (const auto& p : m.vertices) {
    require(p.allFinite(), "mesh_boolean ({}): the {} operand has a NaN/inf vertex", name(op), which);
    v.push_back(out.add_vertex(Kernel::Point_3(p.x(), p.y(), p.z())));
  }
  for (const auto& t : m.triangles) {
    for (int k = 0; k < 3; ++k)
      require(t[k] >= 0 && t[k] < static_cast<int>(v.size()), "mesh_boolean ({}): the {} operand has a vertex index "
              "out of range ({})", name(op), which, t[k]);
    if (out.add_face(v[t[0]], v[t[1]], v[t[2]]) == Mesh::null_face())
      fail<TopologyError>("mesh_boolean ({}): the {} operand is not a manifold surface (a face could not be added)",
                          name(op), which);
  }
  require<TopologyError>(CGAL::is_closed(out), "mesh_boolean ({}): the {} operand is not closed", name(op), which);
  if (!check) return out;
  require<TopologyError>(!PMP::does_self_intersect(out), "mesh_boolean ({}): the {} operand self-intersects", name(op),
                         which);
  require<TopologyError>(PMP::does_bound_a_volume(out),
                         "mesh_boolean ({}): the {} operand does not bound a volume (inside-out or nested wrongly)",
                         name(op), which);
  return out;
}

TriMesh from_cgal(const Mesh& m) {
  TriMesh out;
  std::vector<int> id(m.num_vertices() + m.number_of_removed_vertices(), -1);
  for (const auto v : m.vertices()) {
    id[v.idx()] = out.num_vertices();
    const auto& p = m.point(v);
    out.vertices.emplace_back(CGAL::to_double(p.x()), CGAL::to_double(p.y()), CGAL::to_double(p.z()));
  }
  for (const auto f : m.faces()) {
    std::array<int, 3> t{};
    int k = 0;
    for (const auto v : CGAL::vertices_around_face(m.halfedge(f), m)) {
      require<TopologyError>(k < 3, "mesh_boolean: internal: the result has a face with more than three vertices");
      t[k++] = id[v.idx()];
    }
    out.triangles.push_back(t);
  }
  return out;
}

}  // namespace

TriMesh mesh_boolean(const TriMesh& a, const TriMesh& b, BooleanOperation op, const BooleanOptions& options) {
  Mesh ma = to_cgal(a, "first", op, options.check_operands), mb = to_cgal(b, "second", op, options.check_operands), out;
  bool ok = false;
  switch (op) {
    case BooleanOperation::Union: ok = PMP::corefine_and_compute_union(ma, mb, out); break;
    case BooleanOperation::Difference: ok = PMP::corefine_and_compute_difference(ma, mb, out); break;
    case BooleanOperation::Intersection: ok = PMP::corefine_and_compute_intersection(ma, mb, out); break;
  }
  require<TopologyError>(ok, "mesh_boolean ({}): CGAL could not compute the result (the operands touch along a "
                         "non-manifold edge or vertex); move one of them slightly",
                         name(op));
  return from_cgal(out);
}

}  // namespace socketsmith::geometry
