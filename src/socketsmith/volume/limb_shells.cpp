// The shells of a limb file: measured, named, trimmed, and the transfemoral roles (limb_shells.h
// says why this is apart from limb_model.cpp).
#include "socketsmith/volume/limb_shells.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include <Eigen/Eigenvalues>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/mesh_repair.h"

namespace socketsmith::volume::limb_shells {

/// The midpoint of the first edge shared by more than two triangles, or nullopt.
std::optional<Vec3> first_non_manifold_edge(const TriMesh& mesh) {
  std::map<std::pair<int, int>, int> uses;
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      const int a = t[k], b = t[(k + 1) % 3];
      if (++uses[{std::min(a, b), std::max(a, b)}] == 3)
        return 0.5 * (mesh.vertices[a] + mesh.vertices[b]);
    }
  return std::nullopt;
}

void measure(Shell& s, const LimbFrame& frame) {
  s.h_min = std::numeric_limits<double>::infinity();
  s.h_max = -s.h_min;
  s.centroid.setZero();
  for (const auto& v : s.mesh.vertices) {
    const double h = frame.to_cylindrical(v).h;
    s.h_min = std::min(s.h_min, h);
    s.h_max = std::max(s.h_max, h);
    s.centroid += v;
  }
  if (!s.mesh.vertices.empty()) s.centroid /= static_cast<double>(s.mesh.vertices.size());
  s.volume = geometry::signed_volume(s.mesh);
}

/// Names bone shells by anatomy: transtibial — the most distal is the tibia, the next elongated
/// one reaching below mid-height the fibula, the most proximal the femur, a small compact one
/// near the knee the patella; transfemoral — the most distal is the femur.
void name_bones(std::vector<Shell>& bones, geometry::LimbType type, double cut) {
  std::vector<int> order(bones.size());
  for (size_t i = 0; i < bones.size(); ++i) order[i] = static_cast<int>(i);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return bones[a].h_min < bones[b].h_min; });
  for (auto& b : bones) b.name.clear();
  if (order.empty()) return;
  if (type == geometry::LimbType::Transfemoral) {
    bones[order[0]].name = "femur";
    for (size_t k = 1; k < order.size(); ++k) bones[order[k]].name = "bone " + std::to_string(k + 1);
    return;
  }
  bones[order[0]].name = "tibia";
  int femur = -1, patella = -1, fibula = -1;
  for (size_t k = 1; k < order.size(); ++k) {
    Shell& b = bones[order[k]];
    const double len = b.h_max - b.h_min;
    if (fibula < 0 && b.h_min < 0.5 * cut && len > 0.3 * (bones[order[0]].h_max - bones[order[0]].h_min)) {
      fibula = order[k];
      b.name = "fibula";
    }
  }
  for (size_t k = 1; k < order.size(); ++k) {
    const int i = order[k];
    if (i == fibula) continue;
    if (femur < 0 || bones[i].h_max > bones[femur].h_max) femur = i;
  }
  for (size_t k = 1; k < order.size(); ++k) {
    const int i = order[k];
    if (i == fibula || i == femur) continue;
    if (patella < 0 || bones[i].volume < bones[patella].volume) patella = i;
  }
  // A single remaining proximal shell could be the femur or the patella: the patella is small.
  if (femur >= 0 && patella < 0 && bones[femur].volume < 40e-6) {
    patella = femur;
    femur = -1;
  }
  if (femur >= 0) bones[femur].name = "femur";
  if (patella >= 0) bones[patella].name = "patella";
  int extra = 1;
  for (auto& b : bones)
    if (b.name.empty()) b.name = "bone " + std::to_string(extra++);
}

/// Trims and caps a shell; returns false when nothing of it lies below the cut.
bool trim(Shell& s, const LimbFrame& frame, double cut) {
  bool any_below = false;
  for (const auto& v : s.mesh.vertices) any_below = any_below || frame.to_cylindrical(v).h < cut - 1e-6;
  if (!any_below) return false;
  bool any_above = false;
  for (const auto& v : s.mesh.vertices) any_above = any_above || frame.to_cylindrical(v).h > cut;
  if (any_above) s.mesh = geometry::trim_and_cap(s.mesh, frame.on_axis(cut), frame.axis).mesh;
  return true;
}

/// Length along its principal direction over its largest width (a femur: 4–10; a hemipelvis: 1–2).
double elongation(const TriMesh& m) {
  Vec3 mean = Vec3::Zero();
  for (const auto& v : m.vertices) mean += v;
  mean /= static_cast<double>(std::max<std::size_t>(1, m.vertices.size()));
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& v : m.vertices) cov += (v - mean) * (v - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  const Vec3 d = eig.eigenvectors().col(2).normalized();
  double lo = std::numeric_limits<double>::infinity(), hi = -lo, width = 0.0;
  for (const auto& v : m.vertices) {
    const double h = (v - mean).dot(d);
    lo = std::min(lo, h);
    hi = std::max(hi, h);
    width = std::max(width, ((v - mean) - h * d).norm());
  }
  return width > 0.0 ? (hi - lo) / (2.0 * width) : 0.0;
}

/// Transfemoral roles of the bone shells (before the cut): the femur is the most elongated shell
/// (at least 2.5 × as long as wide), the hemipelvis the largest other shell of more than 20 cm³.
/// Returns their indices (-1 when absent).
std::pair<int, int> transfemoral_roles(const std::vector<Shell>& shells) {
  int femur = -1, pelvis = -1;
  double best = 2.5;
  for (std::size_t i = 0; i < shells.size(); ++i) {
    const double e = elongation(shells[i].mesh);
    if (e > best && std::abs(geometry::signed_volume(shells[i].mesh)) > 5e-6) {
      best = e;
      femur = static_cast<int>(i);
    }
  }
  double vmax = 20e-6;
  for (std::size_t i = 0; i < shells.size(); ++i) {
    if (static_cast<int>(i) == femur) continue;
    const double v = std::abs(geometry::signed_volume(shells[i].mesh));
    if (v > vmax) {
      vmax = v;
      pelvis = static_cast<int>(i);
    }
  }
  return {femur, pelvis};
}

}  // namespace socketsmith::volume::limb_shells
