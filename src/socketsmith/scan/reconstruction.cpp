#include "socketsmith/scan/reconstruction.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <utility>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Eigen_solver_traits.h>
#include <CGAL/Implicit_surface_3.h>
#include <CGAL/Poisson_reconstruction_function.h>
#include <CGAL/Surface_mesh_default_triangulation_3.h>
#include <CGAL/IO/facets_in_complex_2_to_triangle_mesh.h>
#include <CGAL/Random.h>
#include <CGAL/make_surface_mesh.h>
#include <CGAL/property_map.h>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/geometry/mesh_repair.h"

namespace socketsmith::scan {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point3 = Kernel::Point_3;
using Vector3 = Kernel::Vector_3;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

/// CGAL's Poisson reconstruction (what poisson_surface_reconstruction_delaunay does), in two timed
/// steps: the implicit function (Delaunay refinement + sparse solve) and the surface mesher.
geometry::TriMesh poisson(const PointCloud& cloud, double spacing, const ReconstructionOptions& o, double& implicit_s,
                          double& mesher_s) {
  using PoissonFunction = CGAL::Poisson_reconstruction_function<Kernel>;
  using STr = CGAL::Surface_mesher::Surface_mesh_default_triangulation_3_generator<Kernel>::Type;
  using C2t3 = CGAL::Surface_mesh_complex_2_in_triangulation_3<STr>;
  using Surface3 = CGAL::Implicit_surface_3<Kernel, PoissonFunction>;
  using Pwn = std::pair<Point3, Vector3>;
  std::vector<Pwn> pwn;
  pwn.reserve(cloud.points.size());
  for (size_t i = 0; i < cloud.points.size(); ++i) {
    const Vec3& p = cloud.points[i];
    const Vec3& n = cloud.normals[i];
    pwn.emplace_back(Point3(p.x(), p.y(), p.z()), Vector3(n.x(), n.y(), n.z()));
  }
  const auto fail_poisson = [&] {
    fail("reconstruct_surface: Poisson reconstruction failed on {} points (the points do not enclose a volume: "
         "are the sensors around the limb and the normals facing the sensors?)",
         cloud.size());
  };
  // CGAL's default random generator (seeded from the clock) drives the spatial sort of the Poisson
  // function's Delaunay refinement and the surface mesher's initial points: both are seeded here, so
  // a reconstruction is repeatable from one run of the program to the next. (Two reconstructions in
  // one process can still differ within the bisection tolerance: CGAL orders cells and facets by
  // their heap addresses, and the heap is not in the same state the second time.)
  CGAL::get_default_random() = CGAL::Random(0);
  auto tp = Clock::now();
  PoissonFunction function(pwn.begin(), pwn.end(), CGAL::First_of_pair_property_map<Pwn>(),
                           CGAL::Second_of_pair_property_map<Pwn>());
  // Eigen's conjugate gradient defaults to a tolerance of machine epsilon; the level set moves by
  // far less than the sensor noise beyond a relative residual of ~1e-6.
  using Solver =
      CGAL::Eigen_solver_traits<Eigen::ConjugateGradient<CGAL::Eigen_sparse_symmetric_matrix<double>::EigenType>>;
  Solver solver;
  solver.solver().setTolerance(o.poisson_solver_tolerance);
  if (!function.compute_implicit_function(solver, false)) fail_poisson();
  implicit_s = seconds_since(tp);
  tp = Clock::now();
  const Point3 inner = function.get_inner_point();
  const double radius = std::sqrt(function.bounding_sphere().squared_radius());
  const double sphere_radius = 5.0 * radius;
  // Bisection along the mesher's segments down to this precision [m].
  const double dichotomy_error = o.poisson_distance * spacing * o.poisson_bisection_fraction;
  Surface3 surface(function, Kernel::Sphere_3(inner, sphere_radius * sphere_radius), dichotomy_error / sphere_radius);
  CGAL::Surface_mesh_default_criteria_3<STr> criteria(o.poisson_angle_deg, o.max_facet_m, o.poisson_distance * spacing);
  STr tr;
  C2t3 c2t3(tr);
  // The mesher's initial points: from the default generator, reseeded (see above).
  CGAL::get_default_random() = CGAL::Random(0);
  CGAL::make_surface_mesh(c2t3, surface, criteria, CGAL::Manifold_with_boundary_tag());
  // A mesher that found vertices but no facet (too few, too noisy points: 5 frames of the 100 mm
  // cylinder) leaves a complex that CGAL's conversion below dereferences past its end.
  if (tr.number_of_vertices() == 0 || c2t3.number_of_facets() == 0) fail_poisson();
  CGAL::Surface_mesh<Point3> sm;
  CGAL::facets_in_complex_2_to_triangle_mesh(c2t3, sm);
  mesher_s = seconds_since(tp);
  if (sm.number_of_faces() == 0) fail_poisson();
  geometry::TriMesh m;
  std::map<CGAL::Surface_mesh<Point3>::Vertex_index, int> id;
  for (auto v : sm.vertices()) {
    const Point3& p = sm.point(v);
    id[v] = m.num_vertices();
    m.vertices.emplace_back(p.x(), p.y(), p.z());
  }
  for (auto f : sm.faces()) {
    std::array<int, 3> t{};
    int k = 0;
    for (auto v : CGAL::vertices_around_face(sm.halfedge(f), sm)) {
      if (k < 3) t[static_cast<size_t>(k)] = id[v];
      ++k;
    }
    if (k == 3) m.triangles.push_back(t);
  }
  return m;
}

/// Keeps the triangles [0, end) and the vertices they use (renumbered).
geometry::TriMesh keep_triangles(const geometry::TriMesh& mesh, int end) {
  geometry::TriMesh out;
  std::vector<int> map(mesh.vertices.size(), -1);
  for (int t = 0; t < end; ++t) {
    std::array<int, 3> tri{};
    for (int c = 0; c < 3; ++c) {
      int& m = map[static_cast<size_t>(mesh.triangles[static_cast<size_t>(t)][static_cast<size_t>(c)])];
      if (m < 0) {
        m = out.num_vertices();
        out.vertices.push_back(mesh.vertices[static_cast<size_t>(mesh.triangles[static_cast<size_t>(t)][static_cast<size_t>(c)])]);
      }
      tri[static_cast<size_t>(c)] = m;
    }
    out.triangles.push_back(tri);
  }
  return out;
}

void validate(const ReconstructionOptions& o) {
  require(o.grid_cell_m >= 0.0 && o.grid_cell_m < 0.05,
          "reconstruct_surface: grid_cell_m = {} m is out of range (expected 0 to 0.05 m; 0 disables)", o.grid_cell_m);
  require(o.max_facet_m >= 1e-4 && o.max_facet_m <= 0.1,
          "reconstruct_surface: max_facet_m = {} m is out of range (expected 0.1 to 100 mm)", o.max_facet_m);
  require(o.poisson_distance > 0.0 && o.poisson_angle_deg > 0.0 &&
              o.poisson_angle_deg <= 30.0,
          "reconstruct_surface: Poisson mesher bounds must be positive (angle at most 30 deg)");
  require(std::abs(o.up.norm() - 1.0) < 1e-6, "reconstruct_surface: 'up' must be a unit vector");
  require(o.proximal_trim_m >= 0.0, "reconstruct_surface: proximal_trim_m = {} m must be >= 0", o.proximal_trim_m);
  require(o.smoothing_iterations >= 0 && o.smoothing_iterations <= 1000,
          "reconstruct_surface: smoothing_iterations = {} (expected 0 to 1000)", o.smoothing_iterations);
  require(o.min_overlap_fraction >= 0.0 && o.min_overlap_fraction <= 1.0 && o.overlap_radius_m > 0.0,
          "reconstruct_surface: overlap settings out of range");
}

}  // namespace

void taubin_smooth(geometry::TriMesh& mesh, int iterations) {
  if (iterations <= 0 || mesh.empty()) return;
  const size_t n = mesh.vertices.size();
  std::vector<std::vector<int>> nbr(n);
  std::map<std::pair<int, int>, int> edge_count;
  for (const auto& t : mesh.triangles)
    for (int c = 0; c < 3; ++c) {
      const int a = t[static_cast<size_t>(c)], b = t[static_cast<size_t>((c + 1) % 3)];
      nbr[static_cast<size_t>(a)].push_back(b);
      nbr[static_cast<size_t>(b)].push_back(a);
      ++edge_count[std::minmax(a, b)];
    }
  std::vector<char> fixed(n, 0);
  for (const auto& [e, count] : edge_count)
    if (count == 1) fixed[static_cast<size_t>(e.first)] = fixed[static_cast<size_t>(e.second)] = 1;
  for (auto& l : nbr) {
    std::sort(l.begin(), l.end());
    l.erase(std::unique(l.begin(), l.end()), l.end());
  }
  std::vector<Vec3> next(n);
  auto step = [&](double factor) {
    for (size_t i = 0; i < n; ++i) {
      next[i] = mesh.vertices[i];
      if (fixed[i] || nbr[i].empty()) continue;
      Vec3 c = Vec3::Zero();
      for (int j : nbr[i]) c += mesh.vertices[static_cast<size_t>(j)];
      c /= static_cast<double>(nbr[i].size());
      next[i] += factor * (c - mesh.vertices[i]);
    }
    mesh.vertices.swap(next);
  };
  for (int it = 0; it < iterations; ++it) {
    step(0.5);
    step(-0.53);
  }
}

ReconstructionResult reconstruct_surface(const PointCloud& input, const ReconstructionOptions& o,
                                         const ProgressCallback& progress) {
  validate(o);
  require(input.points.size() == input.normals.size() && input.points.size() == input.sensor.size(),
          "reconstruct_surface: points, normals and sensor ids differ in size");
  require(input.size() >= 100,
          "reconstruct_surface: only {} points (expected thousands; did the sensors see the limb?)", input.size());
  const auto t0 = Clock::now();
  ReconstructionResult r;
  r.input_points = input.size();
  PointCloud cloud = input;
  if (o.use_outlier_removal) {
    report_progress(progress, 0.05, "removing outliers");
    const auto to = Clock::now();
    r.outliers_removed = remove_statistical_outliers(cloud, o.outliers);
    r.outliers_s = seconds_since(to);
  }
  auto t = Clock::now();
  if (o.grid_cell_m > 0.0) cloud = grid_simplify(cloud, o.grid_cell_m);
  r.simplify_s = seconds_since(t);
  r.poisson_points = cloud.size();
  require(cloud.size() >= 100, "reconstruct_surface: only {} points left after filtering (expected thousands)",
          cloud.size());
  t = Clock::now();
  r.average_spacing_m = average_spacing(cloud, 6);
  r.spacing_s = seconds_since(t);
  if (!report_progress(progress, 0.2, "Poisson reconstruction")) {
    r.converged = false;
    r.message = "cancelled";
    return r;
  }
  const auto tp = Clock::now();
  geometry::TriMesh mesh = poisson(cloud, r.average_spacing_m, o, r.poisson_implicit_s, r.poisson_mesher_s);
  r.poisson_s = seconds_since(tp);
  report_progress(progress, 0.85, "cropping and capping");
  t = Clock::now();

  // Largest component, outward orientation.
  std::vector<geometry::TriMesh> parts = geometry::split_components(mesh);
  auto largest = std::max_element(parts.begin(), parts.end(),
                                  [](const auto& a, const auto& b) { return a.num_triangles() < b.num_triangles(); });
  mesh = std::move(*largest);
  // The surface mesher can leave a few tiny holes (a missing triangle or two where its
  // manifold-with-boundary criterion gave up): close those, never anything larger.
  geometry::RepairOptions ro;
  ro.max_hole_edges = 12;
  const geometry::RepairReport repaired = geometry::repair_surface(mesh, ro);
  if (geometry::signed_volume(mesh) < 0.0) geometry::flip_orientation(mesh);

  if (o.cut_proximal) {
    double top = -std::numeric_limits<double>::infinity();
    for (const Vec3& p : cloud.points) top = std::max(top, o.up.dot(p));
    const Vec3 plane_point = (top - o.proximal_trim_m) * o.up;
    const geometry::TrimResult cut = geometry::trim_and_cap(mesh, plane_point, o.up);
    mesh = o.open_proximal ? keep_triangles(cut.mesh, cut.first_cap_triangle) : cut.mesh;
    r.cut_height_m = top - o.proximal_trim_m;
    if (!o.open_proximal) r.first_cap_triangle = cut.first_cap_triangle;
  }
  r.cut_s = seconds_since(t);
  t = Clock::now();
  taubin_smooth(mesh, o.smoothing_iterations);
  r.smoothing_s = seconds_since(t);
  t = Clock::now();
  r.check = geometry::check_mesh(mesh);
  r.check_s = seconds_since(t);
  if (r.check.non_manifold_edges > 0 || r.check.non_finite_vertices > 0)
    fail<TopologyError>("reconstruct_surface: the reconstructed surface is not manifold ({}); try a larger grid_cell_m",
                        r.check.problems().empty() ? std::string("unknown") : r.check.problems().front());
  r.mesh = std::move(mesh);
  r.total_s = seconds_since(t0);
  r.message = fmt::format("{} triangles, {} boundary loop(s){}", r.check.num_triangles, r.check.boundary_loops,
                          repaired.filled_holes > 0
                              ? fmt::format(" ({} small hole(s) of the Poisson mesh closed)", repaired.filled_holes)
                              : std::string());
  report_progress(progress, 1.0, "reconstruction done");
  return r;
}

PointCloud recording_point_cloud(const Recording& rec, const BackProjectionOptions& options) {
  require(!rec.sensors.empty(), "reconstruct: the recording has no sensors");
  PointCloud all;
  for (size_t s = 0; s < rec.sensors.size(); ++s) {
    const SensorRecording& sr = rec.sensors[s];
    require(!sr.frames.empty(), "reconstruct: sensor '{}' has no depth frames", sr.name);
    const DepthImage frame = fuse_frames(sr.frames, options.fusion);
    const std::string file = sr.frame_files.empty() ? std::string("frame 0") : sr.frame_files.front();
    require(frame.count_valid() > 0,
            "reconstruct: sensor '{}': every pixel of {} is invalid (0) — the sensor saw nothing in range; check that "
            "it is aimed at the limb and 0.5-4.5 m away, or remove it from rig.json",
            sr.name, file);
    const RayTable rays = make_ray_table(sr.intrinsics, options.upsample);
    const PointCloud c = back_project(frame, sr.intrinsics, sr.world_from_sensor, options, static_cast<int>(s), &rays,
                                      sr.compensation ? &*sr.compensation : nullptr);
    require(c.size() > 0,
            "reconstruct: sensor '{}': no usable point in {} ({} valid pixels but none within {}-{} m with a surface "
            "normal); check the depth scale in rig.json",
            sr.name, file, frame.count_valid(), options.min_depth_m, options.max_depth_m);
    all.append(c);
  }
  return all;
}

ReconstructionResult reconstruct_recording(const Recording& rec, const ReconstructionOptions& o,
                                           const ProgressCallback& progress) {
  validate(o);
  const auto t0 = Clock::now();
  report_progress(progress, 0.0, "back-projecting depth frames");
  const PointCloud cloud = recording_point_cloud(rec, o.back_projection);
  const double bp_s = seconds_since(t0);
  const int n = static_cast<int>(rec.sensors.size());
  std::vector<int> counts(static_cast<size_t>(n), 0);
  for (int s : cloud.sensor) ++counts[static_cast<size_t>(s)];
  std::vector<double> overlap(static_cast<size_t>(n), 1.0);
  const auto t_overlap = Clock::now();
  if (n >= 2) {
    overlap = sensor_overlap_fractions(cloud, n, o.overlap_radius_m);
    for (int s = 0; s < n; ++s)
      require(overlap[static_cast<size_t>(s)] >= o.min_overlap_fraction,
              "reconstruct: sensor '{}' does not overlap the others ({:.1f} % of its points within {:.0f} mm of another "
              "sensor's, expected >= {:.1f} %): check its pose in rig.json and that all sensors look at the limb",
              rec.sensors[static_cast<size_t>(s)].name, 100.0 * overlap[static_cast<size_t>(s)],
              o.overlap_radius_m * 1e3, 100.0 * o.min_overlap_fraction);
  }
  const double overlap_s = seconds_since(t_overlap);
  ReconstructionResult r = reconstruct_surface(cloud, o, progress);
  r.overlap_s = overlap_s;
  r.points_per_sensor = counts;
  r.overlap_per_sensor = overlap;
  r.back_projection_s = bp_s;
  r.total_s = seconds_since(t0);
  return r;
}

}  // namespace socketsmith::scan
