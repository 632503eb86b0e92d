#pragma once
/// @file point_cloud.h
/// Oriented point clouds from depth frames: undistorted back-projection (thesis eq. 22) with
/// normals from the depth grid, world transform, statistical outlier removal (the thesis's "flying
/// pixel" filter, done there with PCL), voxel-grid simplification and a sensor-overlap measure.

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "socketsmith/scan/depth_image.h"
#include "socketsmith/scan/error_compensation.h"
#include "socketsmith/scan/intrinsics.h"

namespace socketsmith::scan {

using Vec3 = Eigen::Vector3d;

/// Points with unit normals (pointing towards the sensor that saw them, i.e. out of the object).
struct PointCloud {
  std::vector<Vec3> points;   ///< [m]
  std::vector<Vec3> normals;  ///< unit, same size as points
  std::vector<int> sensor;    ///< index of the sensor that saw each point (same size)

  int size() const { return static_cast<int>(points.size()); }
  void append(const PointCloud& other);
};

/// Settings of back_project.
struct BackProjectionOptions {
  int upsample = 1;                ///< bilinear up-sampling factor of the depth frame, 1 to 8
  double min_depth_m = 0.2;        ///< readings nearer than this are ignored [m]
  double max_depth_m = 4.5;        ///< readings farther than this are ignored [m] (Kinect v2: 4.5)
  int normal_step_px = 2;          ///< normals from neighbours ±step pixels away (sensor pixels), ≥ 1
  double max_depth_jump_m = 0.02;  ///< neighbours farther than this in depth are across an edge [m]
  /// Points whose normal makes more than this angle with the viewing ray are dropped (grazing
  /// measurements are the least reliable) [rad]; π/2 keeps all.
  double max_view_angle_rad = 1.3;
  /// How a sensor's several frames are fused per pixel before back-projection (recording_point_cloud).
  FrameFusion fusion = FrameFusion::Median;
};

/// Back-projects a depth frame (thesis eq. 22 with undistortion): P = (x d, y d, d) in the sensor
/// frame, (x, y) the undistorted normalised coordinates of the pixel, d = raw·scale + depth shift.
/// Invalid (0) pixels are skipped; points without two valid neighbours for a normal are dropped.
/// Points are mapped to the world by @p world_from_sensor (metres); normals face the sensor.
/// @param rays optional pre-computed make_ray_table(intrinsics, options.upsample) (else built here).
/// @param compensation optional learned error model: every sensor-frame point becomes
///        (I − ε(u, v, d)) P (thesis eq. 27; u, v the sensor pixel) before normals and the pose.
/// @throws InvalidInputError when the frame size differs from the intrinsics or options are invalid.
PointCloud back_project(const DepthImage& image, const CameraIntrinsics& intrinsics,
                        const Eigen::Isometry3d& world_from_sensor, const BackProjectionOptions& options = {},
                        int sensor_index = 0, const RayTable* rays = nullptr,
                        const ErrorCompensation* compensation = nullptr);

/// Settings of remove_statistical_outliers.
struct OutlierOptions {
  int neighbours = 8;   ///< k of the k-nearest-neighbour mean distance, ≥ 1
  double alpha = 2.0;   ///< a point is an outlier when its mean distance > μ + α σ, ≥ 0
};

/// Statistical outlier removal: the mean distance of each point to its k nearest neighbours
/// (k-d tree), then points with a mean distance above μ + α σ over the cloud are removed.
/// Returns the number of points removed.
int remove_statistical_outliers(PointCloud& cloud, const OutlierOptions& options = {});

/// Replaces the points in each cubic cell of @p cell_m by their centroid (normals averaged and
/// renormalised; the sensor of the first point is kept). Reduces noise and the reconstruction's
/// cost. @throws InvalidInputError for a non-positive cell.
PointCloud grid_simplify(const PointCloud& cloud, double cell_m);

/// Fraction of the points of sensor @p s within @p radius_m of a point of another sensor
/// (approximated by cells of that size). 0 when no other sensor saw anything near.
std::vector<double> sensor_overlap_fractions(const PointCloud& cloud, int num_sensors, double radius_m);

/// Mean distance of each point to its nearest other point [m] (k-d tree); 0 for < 2 points.
double average_spacing(const PointCloud& cloud, int neighbours = 6);

}  // namespace socketsmith::scan
