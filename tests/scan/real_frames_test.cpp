// Real depth frames (../shared/data/rgbd/open3d_sample, MIT: Open3D test data with Redwood and TUM
// frames): load, back-project and reconstruct without error; bad loose-frame input.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "scan_fixtures.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/scan/reconstruction.h"

namespace socketsmith::scan {
namespace {

namespace fs = std::filesystem;

fs::path sample() { return test::shared_data() / "rgbd" / "open3d_sample"; }

#define REQUIRE_SAMPLE()                                                                                \
  if (!fs::exists(sample() / "camera_primesense.json"))                                                 \
  GTEST_SKIP() << "../shared/data/rgbd/open3d_sample is absent (the real-frame tests need the shared data)"

TEST(RealFrames, open3d_redwood_frame_loads_back_projects_and_reconstructs) {
  REQUIRE_SAMPLE();
  const Recording rec = recording_from_frames({sample() / "RGBD" / "depth" / "00000.png"},
                                              sample() / "camera_primesense.json", 1e-3);
  ASSERT_EQ(rec.sensors.size(), 1u);
  EXPECT_EQ(rec.sensors[0].frames[0].width, 640);
  EXPECT_GT(rec.sensors[0].frames[0].count_valid(), 200000);
  // A room seen by one camera: scene-sized cells and facets, no proximal cut.
  ReconstructionOptions o;
  o.back_projection.max_depth_m = 2.5;
  o.grid_cell_m = 0.03;
  o.max_facet_m = 0.08;
  o.cut_proximal = false;
  const ReconstructionResult r = reconstruct_recording(rec, o);
  EXPECT_GT(r.input_points, 100000);
  EXPECT_GT(r.mesh.num_triangles(), 1000);
  EXPECT_EQ(r.check.non_manifold_edges, 0);
  EXPECT_EQ(r.check.non_finite_vertices, 0);
}

TEST(RealFrames, tum_frame_at_5000_units_per_metre_back_projects_to_room_depths) {
  REQUIRE_SAMPLE();
  const Recording rec = recording_from_frames({sample() / "RGBD" / "other_formats" / "TUM_depth.png"},
                                              sample() / "camera_primesense.json", 1.0 / 5000.0);
  const PointCloud c = recording_point_cloud(rec);
  ASSERT_GT(c.size(), 50000);
  std::vector<double> z;
  for (const Vec3& p : c.points) z.push_back(p.z());
  std::nth_element(z.begin(), z.begin() + static_cast<long>(z.size() / 2), z.end());
  const double median = z[z.size() / 2];
  // Read as mm the same raw values would be 5x farther: the scale is what makes them a room.
  EXPECT_GT(median, 0.5);
  EXPECT_LT(median, 4.0);
}

TEST(RealFrames, bad_loose_frame_input_gives_one_line_messages) {
  const auto dir = test::temp_dir("real_frames_bad");
  const auto message = [](auto&& fn) { return test::error_message(fn); };
  cv::imwrite((dir / "eight_bit.png").string(), cv::Mat(424, 512, CV_8UC1, cv::Scalar(100)));
  cv::imwrite((dir / "depth16.png").string(), cv::Mat(424, 512, CV_16UC1, cv::Scalar(800)));
  write_intrinsics_json(dir / "intrinsics.json", kinect_v2_typical_intrinsics());
  const std::string no_intrinsics = message([&] { recording_from_frames({dir / "depth16.png"}, {}); });
  EXPECT_NE(no_intrinsics.find("no intrinsics given"), std::string::npos) << no_intrinsics;
  const std::string missing = message([&] { recording_from_frames({dir / "depth16.png"}, dir / "nope.json"); });
  EXPECT_NE(missing.find("intrinsics '"), std::string::npos) << missing;
  EXPECT_NE(missing.find("not found"), std::string::npos) << missing;
  const std::string eight = message([&] { recording_from_frames({dir / "eight_bit.png"}, dir / "intrinsics.json"); });
  EXPECT_NE(eight.find("8-bit"), std::string::npos) << eight;
  const std::string scale = message([&] { recording_from_frames({dir / "depth16.png"}, dir / "intrinsics.json", 0.0); });
  EXPECT_NE(scale.find("depth scale"), std::string::npos) << scale;
  if (fs::exists(sample() / "camera_primesense.json")) {
    const std::string size =
        message([&] { recording_from_frames({dir / "depth16.png"}, sample() / "camera_primesense.json"); });
    EXPECT_NE(size.find("is 512x424 px but the intrinsics"), std::string::npos) << size;
  }
  // A frame where nothing is in range: all invalid.
  cv::imwrite((dir / "blank.png").string(), cv::Mat(424, 512, CV_16UC1, cv::Scalar(0)));
  const Recording blank = recording_from_frames({dir / "blank.png"}, dir / "intrinsics.json");
  const std::string invalid = message([&] { reconstruct_recording(blank); });
  EXPECT_NE(invalid.find("every pixel of blank.png is invalid"), std::string::npos) << invalid;
  for (const std::string& m : {no_intrinsics, missing, eight, scale, invalid})
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
}

}  // namespace
}  // namespace socketsmith::scan
