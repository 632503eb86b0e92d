// The socket's lip: the rounded edge along the inner wall's rims (a tube of half the wall's
// thickness), the closest point on it, and the wall's gap handed over to the lip's past the rim
// (RigidSocket, rigid_socket.h).
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <set>

#include <Eigen/Eigenvalues>

#include "socketsmith/contact/rigid_socket.h"

namespace socketsmith::contact {
namespace {
// The brim's lip: a half-round of half the wall's thickness (clamped), and how far from its centre
// line a point is looked at. Past the rim, the inner wall's energy hands over to the lip's
// over kLipBlendAngle about the lip's centre line.
constexpr double kLipRadiusMin = 0.001, kLipRadiusMax = 0.005;
constexpr double kLipReach = 0.02;
constexpr double kLipBlendAngle = 0.26;  // [rad] ~15°: 0.65 mm past the rim on a 2.5 mm lip
/// [rad] ~6°: below the rim behind the centre line, the lip's energy hands back to the wall's over
/// this angle (RigidSocket::with_lip); under a folded rim's levelled lip the wall's nodes lie
/// atan(r / depth) ≥ 14° from the rim's level at depths ≤ 10 mm.
constexpr double kLipHandBackAngle = 0.1;

/// Past the rim is out of the socket, never down into it: where the wall's last ring folds out and
/// down (a steep trim line, a curled brim) the direction past the rim @p b tilts below the level,
/// and "past" — the half-space through the lip's centre line along it — took in points well below
/// the rim: a node pressed 1 mm into the wall 13 mm below it counted as behind the lip, its gap
/// +12 mm, no force (the clinical AAOP example: a node left 1-4 mm deep in the wall at no pressure
/// while the closed loop pushed the wall in). The frame (@p n, @p b) is turned about the rim's
/// tangent until @p b is level with the @p axis. @p b is first made a unit vector across @p n.
void level_lip_frame(Vec3& n, Vec3& b, const Vec3& axis) {
  b = (b - b.dot(n) * n).normalized();
  const Vec3 t = n.cross(b);
  const Vec3 up = axis - axis.dot(t) * t;  // the axis in the plane of n and b
  if (up.norm() < 0.1 || b.dot(up) >= 0) return;
  const Vec3 u = up.normalized();
  const Vec3 level = b - b.dot(u) * u;
  if (level.norm() < 0.1) return;  // b straight down: no level direction to take
  b = level.normalized();
  n = (n - n.dot(b) * b).normalized();
}
/// The lip's share β of the contact energy at a point (a, s) in the frame (n, b) of its nearest
/// point on the lip's centre line (a along the wall's normal n, s past the rim along b), D from it
/// along the unit vector e, and ∇β; the wall's share is 1 − β.
struct LipShare {
  double beta = 0.0;
  Vec3 dbeta = Vec3::Zero();
};
LipShare lip_share(double a, double s, const Vec3& n, const Vec3& b, double D, const Vec3& e, double radius,
                   bool on_rim) {
  const bool behind = a < 0, behind_below = behind && s <= 0;
  const double rr = a * a + s * s;
  // φ: the angle about the centre line from the rim's level, on the cavity's side in front of the
  // centre line, on the outer side behind it (then in (0, π/2) past the rim, and below it by the
  // hand-back's angle).
  const double phi = !behind ? std::atan2(s, a) : behind_below ? std::atan2(-s, -a) : std::atan2(s, -a);
  const double angle = behind_below ? kLipHandBackAngle : kLipBlendAngle;
  const double tb = std::min(phi / angle, 1.0);
  const double smooth = tb * tb * (3 - 2 * tb);
  const double dsmooth = tb < 1 ? 6 * tb * (1 - tb) / angle : 0.0;
  // ∇φ: (a b − s n)/rr in front of the centre line; behind it, φ grows away from the rim's level.
  const Vec3 dphi = ((behind_below || !behind ? 1.0 : -1.0) / rr) * (a * b - s * n);
  // Behind the centre line the lip counts near the lip only (D within 1.5 r, fading out by 2.5 r);
  // further away the wall's gap stands at the rim's level, on both sides of it. Under a folded
  // rim's levelled lip the wall holds nodes far below the centre line in a narrow cone about it
  // (the test of a folded rim: 16 mm below, 1 mm across). Past the rim the lip alone counted
  // behind the centre line however far away: a node 1.7 mm into the wall beside a steep trim line,
  // level with its nearest rim point but 8.9 mm behind that point's centre line, went from the
  // wall's −1.6 mm to the lip's +6.6 mm as it crossed the rim's level (the AAOP example at 8k
  // nodes: "Newton's model broke most at node 6772 … its gap 6637 → −1634 µm" over 0.1 µm; the
  // corrected socket's refit stalled). Now the wall's share past the rim is (1 − near)(1 − smooth):
  // the same as just below at the level, handed over to the lip by kLipBlendAngle above it. Where
  // q's closest point on the facets is not on the rim, the wall's gap is the wall's own, not its
  // extension past the rim, and the wall keeps 1 − near however far above the level: the lip's
  // nearest point jumps across the rim's medial axis (inside a notch of the trim line), and with
  // it the side — a node 0.7 mm into the wall there, 9.3 mm from the lip, went from the lip's
  // +9.3 mm to the wall's −0.7 mm for a move of 0.1 µm.
  const double tf = std::clamp((2.5 * radius - D) / radius, 0.0, 1.0);
  const double near = tf * tf * (3 - 2 * tf);
  const Vec3 dnear = tf > 0 && tf < 1 ? Vec3((-6 * tf * (1 - tf) / radius) * e) : Vec3::Zero();  // ∇D = e
  if (!behind) return {smooth, dsmooth * dphi};
  if (behind_below) return {near * (1 - smooth), (1 - smooth) * dnear - near * dsmooth * dphi};
  if (!on_rim) return {near, dnear};
  return {1 - (1 - near) * (1 - smooth), (1 - smooth) * dnear + (1 - near) * dsmooth * dphi};
}
}  // namespace

void RigidSocket::build_lip(const std::vector<int>& wall_of, const std::vector<int>& cavity) {
  // The inner wall's boundary edges (a directed edge whose twin is not in the wall): the brim's
  // rim, and the rims of any holes. Beyond an edge a → b lies the direction (b − a) × n, n the
  // wall's normal into the cavity (the triangle is counter-clockwise seen from the cavity).
  std::set<std::pair<int, int>> directed;
  for (const auto& t : inner_.triangles)
    for (int k = 0; k < 3; ++k) directed.insert({t[k], t[(k + 1) % 3]});
  std::map<int, int> lip_of;  // mesh vertex → index into lip_o_
  std::vector<std::pair<int, int>> edges;
  for (const auto& e : directed) {
    if (directed.count({e.second, e.first}) > 0) continue;
    edges.push_back(e);
    for (const int v : {e.first, e.second})
      if (!lip_of.count(v) && wall_of[v] >= 0) {
        lip_of[v] = static_cast<int>(lip_o_.size());
        lip_o_.push_back(inner_.vertices[v]);
        lip_n_.push_back(wall_n_[wall_of[v]]);
        lip_b_.push_back(Vec3::Zero());
      }
  }
  if (edges.empty()) return;
  rim_vertex_.assign(inner_.vertices.size(), 0);
  for (const auto& [a, b] : edges) rim_vertex_[a] = rim_vertex_[b] = 1;
  for (const auto& [a, b] : edges) {
    if (!lip_of.count(a) || !lip_of.count(b)) continue;
    const int ia = lip_of[a], ib = lip_of[b];
    const Vec3 beyond = (inner_.vertices[b] - inner_.vertices[a]).cross(0.5 * (lip_n_[ia] + lip_n_[ib]));
    lip_b_[ia] += beyond;
    lip_b_[ib] += beyond;
    lip_seg_.push_back({ia, ib});
  }
  // The lip's radius: half the wall's thickness, measured from the inner wall's vertices along
  // their normals (outwards, into the wall) to the rest of the solid; its median, 1–5 mm.
  geometry::TriMesh rest;
  rest.vertices = solid_.vertices;
  std::vector<char> in_wall(solid_.triangles.size(), 0);
  for (int i : cavity) in_wall[i] = 1;
  for (size_t i = 0; i < solid_.triangles.size(); ++i)
    if (!in_wall[i]) rest.triangles.push_back(solid_.triangles[i]);
  std::vector<double> thickness;
  if (!rest.triangles.empty()) {
    const geometry::SurfaceQuery outer(rest);
    const size_t stride = std::max<size_t>(1, wall_v_.size() / 500);
    for (size_t j = 0; j < wall_v_.size(); j += stride)
      if (const auto hit = outer.first_hit(wall_v_[j] - 1e-7 * wall_n_[j], -wall_n_[j]))
        thickness.push_back(hit->distance);
  }
  double t = 0.004;
  if (!thickness.empty()) {
    std::nth_element(thickness.begin(), thickness.begin() + thickness.size() / 2, thickness.end());
    t = thickness[thickness.size() / 2];
  }
  lip_radius_ = std::clamp(0.5 * t, kLipRadiusMin, kLipRadiusMax);
  for (size_t k = 0; k < lip_o_.size(); ++k) {
    level_lip_frame(lip_n_[k], lip_b_[k], frame_.axis.normalized());
    lip_o_[k] -= lip_radius_ * lip_n_[k];
  }
  // The rim's chains (where a vertex has one incoming and one outgoing segment) and the unit
  // tangent at each vertex along its chain, from its neighbours.
  std::vector<int> seg_in(lip_o_.size(), -1), seg_out(lip_o_.size(), -1);
  for (int k = 0; k < static_cast<int>(lip_seg_.size()); ++k) {
    const auto& [a, b] = lip_seg_[k];
    seg_out[a] = seg_out[a] == -1 ? k : -2;  // −2: more than one (a pinched rim): no neighbour
    seg_in[b] = seg_in[b] == -1 ? k : -2;
  }
  lip_t_.assign(lip_o_.size(), Vec3::Zero());
  for (size_t v = 0; v < lip_o_.size(); ++v) {
    const Vec3 from = seg_in[v] >= 0 ? lip_o_[lip_seg_[seg_in[v]].first] : lip_o_[v];
    const Vec3 to = seg_out[v] >= 0 ? lip_o_[lip_seg_[seg_out[v]].second] : lip_o_[v];
    const Vec3 along = to - from;
    lip_t_[v] = along.norm() > 0 ? Vec3(along.normalized()) : Vec3::Zero();
  }
}

void RigidSocket::lip_curve(int k, double t, Vec3& c, Vec3& dc, Vec3& ddc) const {
  // Cubic Hermite from o_a to o_b with tangents L t_a, L t_b (L its chord, t the unit tangents at
  // the vertices): the centre line turns smoothly through every vertex.
  const auto& [a, b] = lip_seg_[k];
  const double L = (lip_o_[b] - lip_o_[a]).norm();
  const Vec3 m0 = L * lip_t_[a], m1 = L * lip_t_[b];
  const double t2 = t * t, t3 = t2 * t;
  c = (2 * t3 - 3 * t2 + 1) * lip_o_[a] + (t3 - 2 * t2 + t) * m0 + (-2 * t3 + 3 * t2) * lip_o_[b] + (t3 - t2) * m1;
  dc = (6 * t2 - 6 * t) * lip_o_[a] + (3 * t2 - 4 * t + 1) * m0 + (-6 * t2 + 6 * t) * lip_o_[b] + (3 * t2 - 2 * t) * m1;
  ddc = (12 * t - 6) * lip_o_[a] + (6 * t - 4) * m0 + (-12 * t + 6) * lip_o_[b] + (6 * t - 2) * m1;
}

double RigidSocket::closest_on_lip_segment(int k, const Vec3& q, double t0) const {
  Vec3 c, dc, ddc;
  double t = t0, best = std::numeric_limits<double>::infinity();
  for (const double ts : {t0, 0.0, 0.25, 0.5, 0.75, 1.0}) {
    lip_curve(k, ts, c, dc, ddc);
    const double d2 = (c - q).squaredNorm();
    if (d2 < best) {
      best = d2;
      t = ts;
    }
  }
  for (int it = 0; it < 20; ++it) {
    lip_curve(k, t, c, dc, ddc);
    const double f = (c - q).dot(dc);
    double df = dc.squaredNorm() + (c - q).dot(ddc);
    if (!(df > 0.1 * dc.squaredNorm())) df = dc.squaredNorm();
    if (!(df > 0)) break;
    const double t_new = std::clamp(t - f / df, 0.0, 1.0);
    const double moved = std::abs(t_new - t);
    t = t_new;
    if (moved < 1e-12) break;
  }
  return t;
}

std::optional<RigidSocket::LipHit> RigidSocket::lip_hit(const Vec3& q) const {
  // The closest point on the smooth centre line (lip_curve), the global one: the distance to the
  // polyline has a kink where two segments are equally close (inside every corner of the rim), so
  // Newton runs on the curve's parameter, on every segment that can hold the closest point — its
  // chord no further than the nearest chord plus how far two segments can bow off their chords
  // (kBow L each). Newton hopping from the nearest chord's segment to its neighbours stopped at a
  // local closest point where a rising and falling, flared rim's centre line turns tightly: a
  // point on the wall just below such a rim was 1.9 or 3.2 mm from the centre line for a move of
  // 5 µm, its gap −0.61 or +0.76 mm (tests/contact/rigid_socket_test.cpp). Brute force over the
  // segments: a brim has a few hundred and only points near the wall ask.
  constexpr double kBow = 0.6;  // a Hermite segment with unit end tangents lies within 0.6 L of its chord
  const auto chord = [&](int k, double* t_out) {
    const auto& [a, b] = lip_seg_[k];
    const Vec3 e = lip_o_[b] - lip_o_[a];
    const double ee = e.squaredNorm();
    const double t = ee > 0 ? std::clamp((q - lip_o_[a]).dot(e) / ee, 0.0, 1.0) : 0.0;
    if (t_out) *t_out = t;
    return (q - lip_o_[a] - t * e).norm();
  };
  const auto length = [&](int k) { return (lip_o_[lip_seg_[k].second] - lip_o_[lip_seg_[k].first]).norm(); };
  const int n_seg = static_cast<int>(lip_seg_.size());
  double nearest = kLipReach, nearest_bow = 0;
  for (int k = 0; k < n_seg; ++k) {
    const double d = chord(k, nullptr);
    if (d >= nearest) continue;
    nearest = d;
    nearest_bow = kBow * length(k);
  }
  if (nearest >= kLipReach) return std::nullopt;
  Vec3 c, dc, ddc;
  int seg = -1;
  double tau = 0, best = std::numeric_limits<double>::infinity();
  for (int k = 0; k < n_seg; ++k) {
    double t = 0;
    if (chord(k, &t) - kBow * length(k) > nearest + nearest_bow) continue;
    t = closest_on_lip_segment(k, q, t);
    lip_curve(k, t, c, dc, ddc);
    const double d2 = (c - q).squaredNorm();
    if (d2 < best) {
      best = d2;
      seg = k;
      tau = t;
    }
  }
  if (seg < 0) return std::nullopt;
  lip_curve(seg, tau, c, dc, ddc);
  const auto& [a, b] = lip_seg_[seg];
  LipHit h;
  h.centre = c;
  h.normal = ((1 - tau) * lip_n_[a] + tau * lip_n_[b]).normalized();
  h.beyond = ((1 - tau) * lip_b_[a] + tau * lip_b_[b]).normalized();
  const Vec3 d = q - c;
  const double D = d.norm();
  h.direction = D > 1e-12 ? Vec3(d / D) : h.normal;
  h.gap_m = D - lip_radius_;
  h.past_m = d.dot(h.beyond);
  return h;
}

Gap RigidSocket::with_lip(const Vec3& q, Gap wall, bool on_rim) const {
  // Past the rim the wall ends in its lip, a half-round a node can press on or slide over. The
  // inner wall's energy ½ k A gap² hands over to the lip's smoothly, by the angle φ of q about the
  // lip's centre line (0 level with the rim on the cavity's side, 90° straight past it) from 0 to
  // kLipBlendAngle: the two agree where the lip's tube touches the wall, so the handover costs
  // little. Behind the centre line near the lip (a node hanging over the outer side of the lip)
  // only the lip counts past the rim: the wall's extension would hold it millimetres deep (further
  // away: lip_share). A fade of the wall's contact to nothing past the rim made nodes pressed on
  // the rim feel the wall's extension hard, and Newton crawled (AmpScan's limb: docs/contact.md).
  // Below the rim behind the centre line the mirror image: the lip's energy hands back to the
  // wall's from the rim's level by the same kind of blend, so that a node on the lip's outer side
  // that moves below the rim's level meets no jump (the wall's gap there is ≈ 2|a| deeper than the
  // lip's: the generated transfemoral limb of seed 10 stalled on a node under the levelled lip of
  // its brim, 2.4 mm behind the centre line, whose gap went from −0.10 to −3.85 mm for a step of
  // 3 nm). Over a narrower angle than past the rim
  // (kLipHandBackAngle): where a folded rim's frame was levelled (level_lip_frame), "below the
  // rim" is the wall under the fold, which must hold a node pressed into it.
  const std::optional<LipHit> lip = lip_hit(q);
  const Vec3 d = lip ? Vec3(q - lip->centre) : Vec3::Zero();
  const double a = lip ? d.dot(lip->normal) : 0.0, s = lip ? lip->past_m : 0.0;
  if (!lip || (s <= 0 && a >= 0)) {
    if (!lip && on_rim) wall.valid = false;  // far past the rim: nothing to touch
    return wall;
  }
  // (D: q's whole distance, not √(a² + s²): at an end of the centre line q lies off its plane.)
  const LipShare share =
      lip_share(a, s, lip->normal, lip->beyond, lip->gap_m + lip_radius_, lip->direction, lip_radius_, on_rim);
  const double beta = share.beta;
  const Vec3& dbeta = share.dbeta;
  if (beta <= 0) return wall;
  Gap out = wall;
  out.valid = true;
  out.graded = true;
  const double pw = std::min(wall.gap_m, 0.0), pr = std::min(lip->gap_m, 0.0);
  const Vec3 grad_w = wall.gradient_norm * wall.normal, grad_r = lip->direction;
  const double G = (1 - beta) * pw * pw + beta * pr * pr;  // energy / (½ k A)
  if (beta >= 1.0 || G <= 0) {
    // The lip alone, or no contact: the gap of the nearer surface (a lower bound for the cache).
    if (beta < 1.0 && wall.gap_m < lip->gap_m) return out;
    out.gap_m = lip->gap_m;
    out.normal = grad_r;
    out.gradient_norm = 1.0;
    out.point = lip->centre + lip_radius_ * lip->direction + translation_;
    out.on_face = true;
    out.stiffness_shape = grad_r * grad_r.transpose();
    return out;
  }
  // Blend of the energies: gap = −√G, ∇gap = ∇G / (2 gap); the stiffness is ∇²(G/2) without the
  // surfaces' curvatures, the blend's cross terms included, projected on its positive part.
  const Vec3 jump = pr * grad_r - pw * grad_w;
  const Vec3 dG = 2 * (1 - beta) * pw * grad_w + 2 * beta * pr * grad_r + (pr * pr - pw * pw) * dbeta;
  out.gap_m = -std::sqrt(G);
  const Vec3 grad = dG / (2 * out.gap_m);
  out.gradient_norm = grad.norm();
  if (!(out.gradient_norm > 1e-9)) return wall;
  out.normal = grad / out.gradient_norm;
  const Eigen::Matrix3d H = (pw < 0 ? (1 - beta) : 0.0) * grad_w * grad_w.transpose() +
                            (pr < 0 ? beta : 0.0) * grad_r * grad_r.transpose() + dbeta * jump.transpose() +
                            jump * dbeta.transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(H);
  out.stiffness_shape = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() * eig.eigenvectors().transpose();
  return out;
}

}  // namespace socketsmith::contact
