#pragma once
/// @file test_shapes.h
/// Shapes built in code and small fixtures shared by the geometry tests.

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "socketsmith/core/log.h"
#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::geometry::test {

/// Axis-aligned cube [0, size]^3 with outward (counter-clockwise) triangles.
inline TriMesh make_cube(double size = 1.0, const Vec3& origin = Vec3::Zero()) {
  TriMesh m;
  for (int i = 0; i < 8; ++i)
    m.vertices.push_back(origin + size * Vec3((i & 1) ? 1 : 0, (i & 2) ? 1 : 0, (i & 4) ? 1 : 0));
  // Each face as a quad, counter-clockwise seen from outside.
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                           {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    m.triangles.push_back({q[0], q[1], q[2]});
    m.triangles.push_back({q[0], q[2], q[3]});
  }
  return m;
}

/// Icosphere of @p radius around @p center: an icosahedron subdivided @p levels times
/// (20 * 4^levels triangles), vertices projected onto the sphere, outward orientation.
inline TriMesh make_icosphere(double radius = 1.0, int levels = 3, const Vec3& center = Vec3::Zero()) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vec3> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                         {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (Vec3& p : v) p.normalize();
  std::vector<std::array<int, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                       {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                       {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                       {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back((v[a] + v[b]).normalized());
      const int id = static_cast<int>(v.size()) - 1;
      mid.emplace(key, id);
      return id;
    };
    std::vector<std::array<int, 3>> g;
    g.reserve(4 * f.size());
    for (const auto& tri : f) {
      const int ab = midpoint(tri[0], tri[1]), bc = midpoint(tri[1], tri[2]), ca = midpoint(tri[2], tri[0]);
      g.push_back({tri[0], ab, ca});
      g.push_back({tri[1], bc, ab});
      g.push_back({tri[2], ca, bc});
      g.push_back({ab, bc, ca});
    }
    f = std::move(g);
  }
  TriMesh m;
  for (const Vec3& p : v) m.vertices.push_back(center + radius * p);
  m.triangles = std::move(f);
  return m;
}

/// Open tube (cylinder without caps) along z: two boundary loops.
inline TriMesh make_open_tube(double radius, double height, int segments) {
  TriMesh m;
  for (int i = 0; i < segments; ++i) {
    const double a = 2.0 * M_PI * i / segments;
    m.vertices.emplace_back(radius * std::cos(a), radius * std::sin(a), 0.0);
    m.vertices.emplace_back(radius * std::cos(a), radius * std::sin(a), height);
  }
  for (int i = 0; i < segments; ++i) {
    const int j = (i + 1) % segments;
    m.triangles.push_back({2 * i, 2 * j, 2 * j + 1});
    m.triangles.push_back({2 * i, 2 * j + 1, 2 * i + 1});
  }
  return m;
}

/// Surface of revolution about z through the profile (r_k, z_k), k = 0..K-1, with @p segments
/// around, outward. A profile point with r = 0 at either end becomes a pole (closing that end);
/// otherwise that end is left open.
inline TriMesh make_lathe(const std::vector<std::pair<double, double>>& profile, int segments) {
  TriMesh m;
  const int k_count = static_cast<int>(profile.size());
  const bool bottom_pole = profile.front().first == 0.0, top_pole = profile.back().first == 0.0;
  const int first_ring = bottom_pole ? 1 : 0, last_ring = top_pole ? k_count - 2 : k_count - 1;
  std::vector<int> ring_start;
  for (int k = first_ring; k <= last_ring; ++k) {
    ring_start.push_back(m.num_vertices());
    for (int i = 0; i < segments; ++i) {
      const double a = 2.0 * M_PI * i / segments;
      m.vertices.emplace_back(profile[k].first * std::cos(a), profile[k].first * std::sin(a), profile[k].second);
    }
  }
  const auto at = [&](int ring, int i) { return ring_start[ring] + (i % segments); };
  for (int r = 0; r + 1 < static_cast<int>(ring_start.size()); ++r)
    for (int i = 0; i < segments; ++i) {
      m.triangles.push_back({at(r, i), at(r, i + 1), at(r + 1, i + 1)});
      m.triangles.push_back({at(r, i), at(r + 1, i + 1), at(r + 1, i)});
    }
  if (bottom_pole) {
    const int p = m.num_vertices();
    m.vertices.emplace_back(0.0, 0.0, profile.front().second);
    for (int i = 0; i < segments; ++i) m.triangles.push_back({p, at(0, i + 1), at(0, i)});
  }
  if (top_pole) {
    const int p = m.num_vertices();
    const int last = static_cast<int>(ring_start.size()) - 1;
    m.vertices.emplace_back(0.0, 0.0, profile.back().second);
    for (int i = 0; i < segments; ++i) m.triangles.push_back({p, at(last, i), at(last, i + 1)});
  }
  return m;
}

/// A capsule about z: hemispheres of @p radius around a cylinder of @p length, distal pole at z = 0,
/// @p rings per hemisphere; open at z = radius + length (a limb-like cup) when @p open_top.
inline TriMesh make_capsule(double radius, double length, int rings, int segments, bool open_top = false) {
  std::vector<std::pair<double, double>> profile;
  for (int k = 0; k <= rings; ++k) {
    const double phi = 0.5 * M_PI * k / rings;  // from the pole
    profile.emplace_back(radius * std::sin(phi), radius * (1 - std::cos(phi)));
  }
  if (open_top) {
    profile.emplace_back(radius, radius + length);
    return make_lathe(profile, segments);
  }
  for (int k = 0; k <= rings; ++k) {
    const double phi = 0.5 * M_PI * k / rings;
    profile.emplace_back(k == rings ? 0.0 : radius * std::cos(phi), radius + length + radius * std::sin(phi));
  }
  return make_lathe(profile, segments);
}

/// Appends @p b to @p a (indices shifted).
inline TriMesh merged(TriMesh a, const TriMesh& b) {
  const int off = a.num_vertices();
  a.vertices.insert(a.vertices.end(), b.vertices.begin(), b.vertices.end());
  for (auto t : b.triangles) a.triangles.push_back({t[0] + off, t[1] + off, t[2] + off});
  return a;
}

/// A random rigid motion (rotation + translation).
inline Eigen::Isometry3d random_rigid_motion(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Quaterniond q(u(rng), u(rng), u(rng), u(rng));
  q.normalize();
  Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
  m.linear() = q.toRotationMatrix();
  m.translation() = Vec3(u(rng), u(rng), u(rng)) * 10.0;
  return m;
}

inline TriMesh transformed(TriMesh m, const Eigen::Isometry3d& x) {
  for (Vec3& p : m.vertices) p = x * p;
  return m;
}

/// A fresh directory under the system temp folder, removed with everything in it at the end.
class TempDir {
 public:
  TempDir() {
    static std::atomic<int> counter{0};
    std::random_device rd;
    path_ = std::filesystem::temp_directory_path() /
            ("socketsmith_geometry_test_" + std::to_string(rd()) + "_" + std::to_string(counter++));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

inline void write_bytes(const std::filesystem::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

inline std::string read_bytes(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary | std::ios::ate);
  std::string bytes(static_cast<std::size_t>(std::max<std::streamoff>(0, in.tellg())), '\0');
  in.seekg(0);
  in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  return bytes;
}

/// Captures log messages for the lifetime of the object (and keeps test output quiet).
class LogCapture {
 public:
  LogCapture() {
    log::set_sink([this](log::Level l, std::string_view msg) { messages.emplace_back(l, std::string(msg)); });
  }
  ~LogCapture() { log::set_sink(nullptr); }
  LogCapture(const LogCapture&) = delete;
  LogCapture& operator=(const LogCapture&) = delete;

  bool contains(log::Level l, const std::string& needle) const {
    for (const auto& [level, msg] : messages)
      if (level == l && msg.find(needle) != std::string::npos) return true;
    return false;
  }
  int count(log::Level l) const {
    int n = 0;
    for (const auto& m : messages) n += m.first == l ? 1 : 0;
    return n;
  }
  std::vector<std::pair<log::Level, std::string>> messages;
};

/// Runs @p f, expects it to throw E, and returns the message.
template <class E, class F>
std::string error_message(F&& f) {
  try {
    f();
  } catch (const E& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "threw a different exception: " << e.what();
    return {};
  }
  ADD_FAILURE() << "did not throw";
  return {};
}

}  // namespace socketsmith::geometry::test
