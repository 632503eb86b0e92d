#include "socketsmith/contact/rigid_socket.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <optional>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/socket_cavity.h"

namespace socketsmith::contact {

namespace {
constexpr double kSmoothBand = 0.003;  // [m] the smoothed wall's gap within this distance of the facets
constexpr double kBlendBand = 0.001;   // [m] beyond it, blended into the facets' distance over this width
// Support radius of a vertex / the mean length of its edges. In a 7.5k donning with standing
// (one measurement): 1.25 / 1.5 / 1.75 gave 214 / 234 / 250 factorisations, R against the design
// 0.718 / 0.717 / 0.715 (facets: 387, 0.720); below ~1.25 a point inside a long triangle can fall
// outside every vertex's support (then the facets' gap is used there: a seam), so 1.5.
constexpr double kSupport = 1.5;
// The smoothed wall counts a vertex fully when its normal is within ~60° of the wall's mean normal
// at the point (cos ≥ 0.5), not at all beyond ~78° (cos ≤ 0.2), smoothly in between.
constexpr double kAgreeLow = 0.2, kAgreeHigh = 0.5;
// Below this |Σ w_j n_j| / Σ w_j the mean normal is ill-defined (both sides of a thin cavity).
constexpr double kMeanNormalFloor = 0.3;
/// Barycentric coordinates of @p p (on the triangle's plane) in the triangle @p a, @p b, @p c; a
/// third each for a degenerate triangle.
std::array<double, 3> barycentric(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& p) {
  const Vec3 v0 = b - a, v1 = c - a, v2 = p - a;
  const double d00 = v0.dot(v0), d01 = v0.dot(v1), d11 = v1.dot(v1), d20 = v2.dot(v0), d21 = v2.dot(v1);
  const double den = d00 * d11 - d01 * d01;
  std::array<double, 3> bary = {1.0 / 3, 1.0 / 3, 1.0 / 3};
  if (den > 0) {
    bary[1] = (d11 * d20 - d01 * d21) / den;
    bary[2] = (d00 * d21 - d01 * d20) / den;
    bary[0] = 1.0 - bary[1] - bary[2];
  }
  return bary;
}

/// The smoothed gap @p s within kSmoothBand of the facets, the facets' distance @p g beyond
/// kSmoothBand + kBlendBand, blended smoothly in between (share: the smoothed gap's), so that the
/// gap is continuous where the band ends. @p d: q minus its closest point on the facets, |d| =
/// @p dist. Nothing where the blend's gradient vanishes (the facets' gap then stands).
std::optional<Gap> blended(const Gap& g, const Gap& s, const Vec3& d, double dist) {
  const double tb = std::clamp((dist - kSmoothBand) / kBlendBand, 0.0, 1.0);
  const double share = 1.0 - tb * tb * (3 - 2 * tb), db = -6 * tb * (1 - tb) / kBlendBand;
  const Vec3 grad_s = s.gradient_norm * s.normal, grad_f = g.normal;  // ∇ of the facets' gap: its normal
  // (db vanishes within kSmoothBand: a point on the facets, dist = 0, would make it 0 · NaN)
  const Vec3 fade = db != 0 ? Vec3((s.gap_m - g.gap_m) * db * (d / dist)) : Vec3::Zero();
  const Vec3 grad = share * grad_s + (1 - share) * grad_f + fade;
  Gap out = g;
  out.gap_m = share * s.gap_m + (1 - share) * g.gap_m;
  out.gradient_norm = grad.norm();
  if (!(out.gradient_norm > 1e-6)) return std::nullopt;
  out.normal = grad / out.gradient_norm;
  out.on_face = share == 1.0 || g.on_face;
  out.stiffness_shape = share * grad * grad.transpose() + (1 - share) * g.stiffness_shape;
  out.graded = true;
  out.valid = true;
  return out;
}

}  // namespace

RigidSocket::~RigidSocket() = default;
RigidSocket::RigidSocket(RigidSocket&&) noexcept = default;
RigidSocket& RigidSocket::operator=(RigidSocket&&) noexcept = default;

void RigidSocket::replace_solid(geometry::TriMesh solid) {
  RigidSocket fresh(std::move(solid), frame_, density_);
  fresh.set_translation(translation());
  fresh.smooth_ = smooth_;
  if (!fit_points_.empty()) fresh.fit_smooth_wall_to(std::move(fit_points_));
  *this = std::move(fresh);
}

RigidSocket::RigidSocket(geometry::TriMesh solid, const geometry::LimbFrame& frame, double density)
    : frame_(frame), density_(density), solid_(std::move(solid)) {
  require(std::isfinite(density) && density > 0, "socket density {} kg/m^3 must be positive", density);
  const auto rep = geometry::check_mesh(solid_);
  require(rep.non_finite_vertices == 0, "the socket has {} vertices with NaN/inf coordinates", rep.non_finite_vertices);
  require<TopologyError>(rep.is_closed(),
                         "the socket surface is not closed ({} boundary edges): contact needs a closed solid with "
                         "inner and outer walls (repair it, or give the wall a thickness)",
                         rep.boundary_edges);
  require<TopologyError>(rep.is_manifold() && rep.is_oriented(),
                         "the socket surface is not a manifold, consistently oriented solid ({} non-manifold, {} "
                         "misoriented edges): repair it",
                         rep.non_manifold_edges, rep.inconsistently_oriented_edges);
  mass_properties();
  const std::vector<int> cavity = find_inner_wall();
  wall_of_ = smooth_wall_vertices();
  const std::vector<int>& wall_of = wall_of_;
  fit_vertex_quadrics(wall_of);
  build_vertex_grid();
  centre_vertex_surfaces(wall_of);
  build_lip(wall_of, cavity);
}

void RigidSocket::mass_properties() {
  // Mass properties of the (outward) closed solid: signed tetrahedra from the origin.
  double vol = 0;
  Vec3 c = Vec3::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();  // ∫ x xᵀ dV
  for (const auto& t : solid_.triangles) {
    const Vec3 &a = solid_.vertices[t[0]], &b = solid_.vertices[t[1]], &d = solid_.vertices[t[2]];
    const double v = a.dot(b.cross(d)) / 6.0;
    vol += v;
    c += v * (a + b + d) / 4.0;
    // ∫ over the tetrahedron (0, a, b, d) of x xᵀ = v/20 (Σ p pᵀ + (Σ p)(Σ p)ᵀ) with p over the 4 vertices.
    const Vec3 s = a + b + d;
    second += v / 20.0 * (a * a.transpose() + b * b.transpose() + d * d.transpose() + s * s.transpose());
  }
  require<TopologyError>(vol > 0, "the socket solid is inside-out or empty (volume {:.3g} m^3): flip its triangles", vol);
  com_ = c / vol;
  mass_ = density_ * vol;
  const Eigen::Matrix3d cov = density_ * (second - vol * com_ * com_.transpose());
  inertia_ = cov.trace() * Eigen::Matrix3d::Identity() - cov;
}

std::vector<int> RigidSocket::find_inner_wall() {
  // The socket must surround the limb's axis: horizontal rays from the axis, at three heights of
  // the socket, hit a wall that faces them in (nearly) every direction.
  int facing = 0;
  require(geometry::surrounds_axis(solid_, frame_, &facing),
          "the socket does not surround the limb: from the limb's axis at 30-70 % of the socket's height only {} of 8 "
          "directions meet its inner wall (place it around the stump, check its units and the limb frame)",
          facing);
  const std::vector<int> cavity = geometry::cavity_triangles(solid_, frame_);  // inner wall: seen from the axis
  for (int i : cavity) {
    inner_.triangles.push_back(solid_.triangles[i]);
    inner_normals_.push_back(geometry::triangle_normal(solid_, i));
  }
  inner_.vertices = solid_.vertices;
  require(inner_.num_triangles() > 0,
          "the socket does not surround the limb: no part of it is seen from the limb's axis (place it around the "
          "stump, check its units)");
  query_ = std::make_unique<geometry::SurfaceQuery>(inner_);
  return cavity;
}

std::vector<int> RigidSocket::smooth_wall_vertices() {
  // The smoothed wall's data: per used vertex an angle-weighted normal and the mean length of its
  // edges; a uniform grid over the vertices. The angle-weighted normals and each edge's two faces'
  // mean normal are also the facets' pseudo-normals (the gap's side).
  const int nv = static_cast<int>(inner_.vertices.size());
  std::vector<Vec3> vn(nv, Vec3::Zero());
  std::vector<double> elen(nv, 0.0);
  std::vector<int> ecount(nv, 0);
  std::map<std::pair<int, int>, Vec3> edge_sum;  // each edge's faces' normals summed
  for (int i = 0; i < inner_.num_triangles(); ++i) {
    const auto& t = inner_.triangles[i];
    for (int k = 0; k < 3; ++k) {
      const Vec3& a = inner_.vertices[t[k]];
      const Vec3 e1 = inner_.vertices[t[(k + 1) % 3]] - a, e2 = inner_.vertices[t[(k + 2) % 3]] - a;
      const double l1 = e1.norm(), l2 = e2.norm();
      if (l1 <= 0 || l2 <= 0) continue;
      const double angle = std::acos(std::clamp(e1.dot(e2) / (l1 * l2), -1.0, 1.0));
      vn[t[k]] += angle * inner_normals_[i];
      elen[t[k]] += l1 + l2;
      ecount[t[k]] += 2;
      const auto key = std::minmax(t[(k + 1) % 3], t[(k + 2) % 3]);
      // (try_emplace from zero: operator[] would leave an Eigen vector uninitialised)
      edge_sum.try_emplace({key.first, key.second}, Vec3::Zero()).first->second += inner_normals_[i];
    }
  }
  // Per triangle, the pseudo-normal of the edge opposite each corner (its face's normal on a knife
  // edge, where the two faces' normals cancel).
  tri_edge_normals_.resize(inner_.num_triangles());
  for (int i = 0; i < inner_.num_triangles(); ++i) {
    const auto& t = inner_.triangles[i];
    for (int k = 0; k < 3; ++k) {
      const auto key = std::minmax(t[(k + 1) % 3], t[(k + 2) % 3]);
      const Vec3& sum = edge_sum.at({key.first, key.second});
      tri_edge_normals_[i][k] = sum.norm() > 1e-12 ? Vec3(sum.normalized()) : inner_normals_[i];
    }
  }
  double rho_max = 0;
  std::vector<int> wall_of(nv, -1);
  for (int v = 0; v < nv; ++v) {
    if (ecount[v] == 0 || vn[v].norm() <= 0) continue;
    wall_of[v] = static_cast<int>(wall_v_.size());
    const double rho = kSupport * elen[v] / ecount[v];
    wall_v_.push_back(inner_.vertices[v]);
    wall_n_.push_back(vn[v].normalized());
    wall_rho2_.push_back(rho * rho);
    rho_max = std::max(rho_max, rho);
  }
  cell_ = std::max(rho_max, 1e-6);
  return wall_of;
}

void RigidSocket::fit_vertex_quadrics(const std::vector<int>& wall_of) {
  // Each vertex's local surface is a quadric h = ½ dᵀ H d over its tangent plane, H fitted (least
  // squares) to the heights of its neighbours: the blend of planes alone lay up to ~1 mm off the
  // facets where the wall curves strongly (its error grows with the square of the support).
  std::vector<std::vector<int>> ring(wall_v_.size());
  for (const auto& t : inner_.triangles)
    for (int k = 0; k < 3; ++k) {
      const int a = wall_of[t[k]], b = wall_of[t[(k + 1) % 3]];
      if (a < 0 || b < 0) continue;
      ring[a].push_back(b);
      ring[b].push_back(a);
    }
  wall_h_.assign(wall_v_.size(), Eigen::Matrix3d::Zero());
  for (size_t j = 0; j < wall_v_.size(); ++j) {
    auto& nb = ring[j];
    std::sort(nb.begin(), nb.end());
    nb.erase(std::unique(nb.begin(), nb.end()), nb.end());
    if (nb.size() < 4) continue;  // a rim or a sliver: the plane alone
    const Vec3& n = wall_n_[j];
    const Vec3 t1 = (std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).cross(n).normalized();
    const Vec3 t2 = n.cross(t1);
    Eigen::MatrixXd A(nb.size(), 3);
    Eigen::VectorXd h(nb.size());
    for (size_t k = 0; k < nb.size(); ++k) {
      const Vec3 d = wall_v_[nb[k]] - wall_v_[j];
      const double x = d.dot(t1), y = d.dot(t2);
      A.row(k) << 0.5 * x * x, x * y, 0.5 * y * y;
      h[k] = d.dot(n);
    }
    const Eigen::Vector3d abc = A.colPivHouseholderQr().solve(h);
    if (!abc.allFinite()) continue;
    wall_h_[j] = abc[0] * t1 * t1.transpose() + abc[1] * (t1 * t2.transpose() + t2 * t1.transpose()) +
                 abc[2] * t2 * t2.transpose();
  }
}

void RigidSocket::build_vertex_grid() {
  Vec3 lo = Vec3::Constant(1e30), hi = Vec3::Constant(-1e30);
  for (const auto& v : wall_v_) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  grid_lo_ = lo;
  for (int a = 0; a < 3; ++a) grid_dim_[a] = static_cast<int>(std::floor((hi[a] - lo[a]) / cell_)) + 1;
  const auto cell_of = [&](const Vec3& v) {
    Eigen::Vector3i ci;
    for (int a = 0; a < 3; ++a) ci[a] = std::clamp(static_cast<int>(std::floor((v[a] - lo[a]) / cell_)), 0, grid_dim_[a] - 1);
    return (ci[2] * grid_dim_[1] + ci[1]) * grid_dim_[0] + ci[0];
  };
  cell_start_.assign(static_cast<size_t>(grid_dim_.prod()) + 1, 0);
  for (const auto& v : wall_v_) ++cell_start_[cell_of(v) + 1];
  for (size_t k = 1; k < cell_start_.size(); ++k) cell_start_[k] += cell_start_[k - 1];
  cell_items_.resize(wall_v_.size());
  std::vector<int> fill(cell_start_.begin(), cell_start_.end() - 1);
  for (int j = 0; j < static_cast<int>(wall_v_.size()); ++j) cell_items_[fill[cell_of(wall_v_[j])]++] = j;
}

void RigidSocket::centre_vertex_surfaces(const std::vector<int>& wall_of) {
  // A surface through the vertices lies outside the facets where the wall curves (the facets are
  // its chords): shift each vertex's surface by the mean smooth gap at the midpoints of its
  // triangles' edges (the midpoint rule integrates a quadratic deviation over a triangle
  // exactly), so that the smoothed wall passes through the facets on average (two Jacobi sweeps).
  wall_c_.assign(wall_v_.size(), 0.0);
  for (int sweep = 0; sweep < 2; ++sweep) {
    std::vector<double> sum(wall_v_.size(), 0.0);
    std::vector<int> cnt(wall_v_.size(), 0);
    for (int i = 0; i < inner_.num_triangles(); ++i)
      for (int k = 0; k < 3; ++k) {
        const auto& t = inner_.triangles[i];
        const int j0 = wall_of[t[k]], j1 = wall_of[t[(k + 1) % 3]];
        if (j0 < 0 || j1 < 0) continue;
        Gap on;
        on.triangle = i;
        const std::optional<Gap> gs = smooth_gap(0.5 * (inner_.vertices[t[k]] + inner_.vertices[t[(k + 1) % 3]]), on);
        if (!gs) continue;
        for (const int j : {j0, j1}) {
          sum[j] += gs->gap_m;
          ++cnt[j];
        }
      }
    for (size_t j = 0; j < wall_c_.size(); ++j)
      if (cnt[j] > 0) wall_c_[j] += sum[j] / cnt[j];
  }
  wall_c_facets_ = wall_c_;
}

std::optional<Gap> RigidSocket::smooth_gap(const Vec3& q, Gap g) const {
  // Σ W_j, Σ W_j a_j with a_j = d·n_j − ½ dᵀ H_j d − c_j (d = q − v_j: the height over vertex j's
  // quadric), and their gradients, over the vertices whose support contains q. W_j = w_j s_j: the
  // support weight w_j = (1 − |d|²/ρ_j²)⁴ times a smooth ramp s_j of how far n_j agrees with the
  // wall's mean normal n̄ at q (n̄ = Σ w_j n_j normalised), so that vertices across a crease or the
  // cavity do not count. n̄ and the ramp are smooth in q, so the gap is too: a choice of vertices by
  // the closest facet's normal changed with the facet, and the gap jumped by up to 0.1 mm where the
  // closest facet switched on a strongly curved wall (Newton's line search then stalled there). The
  // gradient is exact (the ramp's and n̄'s derivatives included); the stiffness is ∇g ∇gᵀ (the term
  // g ∇²g is of the order of the penetration over the wall's radius of curvature: negligible).
  const auto for_support = [&](auto&& visit) { for_vertex_support(q, visit); };
  // The mean normal n̄ and its gradient ∂n̄/∂q = (I − n̄n̄ᵀ) Σ n_j ∇w_jᵀ / |m|.
  Vec3 m = Vec3::Zero();
  Eigen::Matrix3d dm = Eigen::Matrix3d::Zero();
  double wsum = 0;
  for_support([&](int j, const Vec3& d, double u) {
    const double u3 = u * u * u;
    m += u3 * u * wall_n_[j];
    dm += wall_n_[j] * ((-8.0 * u3 / wall_rho2_[j]) * d).transpose();
    wsum += u3 * u;
  });
  Vec3 ref;
  Eigen::Matrix3d dref = Eigen::Matrix3d::Zero();
  if (m.norm() >= kMeanNormalFloor * wsum && m.norm() > 0) {
    ref = m.normalized();
    dref = (Eigen::Matrix3d::Identity() - ref * ref.transpose()) * dm / m.norm();
  } else if (g.triangle >= 0) {
    ref = inner_normals_[g.triangle];  // both sides of a thin cavity in the support: the facet decides
  } else {
    return std::nullopt;
  }
  double S = 0, N = 0;
  Vec3 dS = Vec3::Zero(), dN = Vec3::Zero();
  for_support([&](int j, const Vec3& d, double u) {
    const double t = std::clamp((wall_n_[j].dot(ref) - kAgreeLow) / (kAgreeHigh - kAgreeLow), 0.0, 1.0);
    if (t <= 0) return;
    const double s = t * t * (3 - 2 * t), ds = 6 * t * (1 - t) / (kAgreeHigh - kAgreeLow);
    const double u3 = u * u * u, w = u3 * u;
    const Vec3 dw = (-8.0 * u3 / wall_rho2_[j]) * d;
    const Vec3 Hd = wall_h_[j] * d;
    const double a = d.dot(wall_n_[j]) - 0.5 * d.dot(Hd) - wall_c_[j];
    const Vec3 dW = s * dw + (w * ds) * (dref.transpose() * wall_n_[j]);
    S += w * s;
    N += w * s * a;
    dS += dW;
    dN += dW * a + (w * s) * (wall_n_[j] - Hd);
  });
  if (S <= 1e-12) return std::nullopt;  // too far from any vertex
  const double gap = N / S;
  const Vec3 grad = (dN - gap * dS) / S;
  const double gn = grad.norm();
  if (!(gn > 1e-6)) return std::nullopt;
  g.gap_m = gap;
  g.normal = grad / gn;
  g.gradient_norm = gn;
  g.on_face = true;
  g.stiffness_shape = grad * grad.transpose();
  return g;
}

Gap RigidSocket::gap(const Vec3& p) const {
  Gap g;
  const Vec3 q = p - translation_;  // in the solid's coordinates
  const auto hit = query_->closest_point(q);
  if (hit.triangle < 0) return g;
  const Vec3 d = q - hit.point;
  g.point = hit.point + translation_;
  g.triangle = hit.triangle;
  // Where on the triangle is the closest point: barycentric coordinates ≈ 0 mark edges/vertices.
  const auto& tri = inner_.triangles[hit.triangle];
  const std::array<double, 3> bary =
      barycentric(inner_.vertices[tri[0]], inner_.vertices[tri[1]], inner_.vertices[tri[2]], hit.point);
  int zeros = 0, zero_at = -1, kept_at = -1;
  for (int k = 0; k < 3; ++k)
    if (bary[k] < 1e-9) {
      ++zeros;
      zero_at = k;
    } else {
      kept_at = k;
    }
  // The side from the closest feature's pseudo-normal (Bærentzen and Aanæs): the face's, its two
  // faces' mean on an edge, the angle-weighted one at a vertex. With the face the query returned,
  // a point level with a ridge where the wall turns over by more than 90° (a rim folded out and
  // down) is equally close to both faces and in the cavity by one, behind the wall by the other:
  // its gap flipped between +d and −d for moves of 1e-15 m.
  const int vertex_at = zeros >= 2 ? wall_of_[tri[kept_at < 0 ? 0 : kept_at]] : -1;
  const Vec3& n = zeros == 0   ? inner_normals_[hit.triangle]
                  : zeros == 1 ? tri_edge_normals_[hit.triangle][zero_at]
                  : vertex_at >= 0 ? wall_n_[vertex_at]
                                   : inner_normals_[hit.triangle];
  const double along_signed = d.dot(n);
  // Valid when the offset is (nearly) along that normal: the projection falls on the wall, not
  // past its rim (a node above the brim is not in contact with the lip's edge).
  const double along = std::abs(along_signed), across = (d - along_signed * n).norm();
  g.valid = across <= 0.5 * along + 1e-5;
  // Gap and normal from the distance function (|d|, d/|d|), signed by that side: continuous when
  // the closest point moves across an edge between two faces (face normals would jump there and
  // Newton would stall).
  const double dist = d.norm();
  g.on_face = zeros == 0 || dist < 1e-15;
  if (g.on_face) {
    g.stiffness_shape = n * n.transpose();
  } else if (zeros == 1) {
    const Vec3 e = (inner_.vertices[tri[(zero_at + 2) % 3]] - inner_.vertices[tri[(zero_at + 1) % 3]]).normalized();
    g.stiffness_shape = Eigen::Matrix3d::Identity() - e * e.transpose();
  } else {
    g.stiffness_shape = Eigen::Matrix3d::Identity();
  }
  if (dist > 1e-12) {
    const double sign = along_signed >= 0 ? 1.0 : -1.0;
    g.gap_m = sign * dist;
    g.normal = sign * d / dist;
  } else {
    g.gap_m = 0.0;
    g.normal = n;
  }
  if (!smooth_) return g;
  // Beyond the blend and inside the cavity the gap is the facets' and no contact can act: no
  // smoothed wall (most queries of a donning are such points, for nodes not yet near the wall).
  if (dist >= kSmoothBand + kBlendBand && along_signed >= 0) return g;
  // The closest point lies on the rim (an edge or a vertex of the wall's boundary): q is past it.
  bool on_rim = false;
  if (!g.on_face && !rim_vertex_.empty()) {
    on_rim = true;
    for (int k = 0; k < 3; ++k)
      if (bary[k] >= 1e-9 && !rim_vertex_[tri[k]]) on_rim = false;
  }
  const std::optional<Gap> smoothed = smooth_gap(q, g);
  if (!smoothed) return with_lip(q, g, on_rim);  // no vertex's support covers q: the facets' gap and validity
  const Gap& s = *smoothed;
  const std::optional<Gap> out = blended(g, s, d, dist);
  return out ? with_lip(q, *out, on_rim) : g;
}

}  // namespace socketsmith::contact
