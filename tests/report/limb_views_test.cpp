// Limb pictures: both rows drawn, landmarks coloured, the image not blank.
#include <gtest/gtest.h>

#include "socketsmith/report/limb_views.h"

namespace socketsmith::report {
namespace {

geometry::TriMesh box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  geometry::TriMesh m;
  for (int i = 0; i < 8; ++i)
    m.vertices.push_back({(i & 1) ? hi.x() : lo.x(), (i & 2) ? hi.y() : lo.y(), (i & 4) ? hi.z() : lo.z()});
  const int q[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : q) {
    m.triangles.push_back({f[0], f[1], f[2]});
    m.triangles.push_back({f[0], f[2], f[3]});
  }
  return m;
}

int count(const Image& img, Rgb c) {
  int n = 0;
  for (const auto& p : img.pixels) n += (p == c) ? 1 : 0;
  return n;
}

TEST(LimbViews, TwoRowsWithLandmarksFacingTheCamera) {
  const auto skin = box({-0.05, -0.05, 0.0}, {0.05, 0.05, 0.25});
  std::vector<volume::NamedMesh> bones{{"tibia", box({-0.01, -0.01, 0.05}, {0.01, 0.01, 0.24})}};
  volume::Landmark front;
  front.code = "PT";
  front.position = {0.0, 0.05, 0.15};  // on the anterior face (+y)
  front.estimated = true;
  geometry::LimbFrame frame;  // axis +z, anterior +y
  const Image img = render_limb_views(skin, bones, {front}, frame, "box", false, 200);
  EXPECT_GT(img.height, 400);
  EXPECT_GE(img.width, 4 * 200);
  // The marker's red fill appears (anterior and side views), and most of the image is not white.
  EXPECT_GT(count(img, Rgb{200, 40, 40}), 10);
  EXPECT_LT(count(img, Rgb{255, 255, 255}), static_cast<int>(img.pixels.size() * 0.9));
}

}  // namespace
}  // namespace socketsmith::report
