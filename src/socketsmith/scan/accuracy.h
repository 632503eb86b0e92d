#pragma once
/// @file accuracy.h
/// How close a reconstructed scan is to the surface that was scanned: area-weighted surface
/// samples of each mesh measured against the other (a symmetric surface distance), restricted to
/// the region a rig can measure — below the reconstruction's proximal cut, and, for the original,
/// the part at least one sensor sees. The limb-scan experiment (simulate a rig around a limb
/// mesh, reconstruct, measure) is built on it.

#include <cstdint>
#include <string>
#include <vector>

#include "socketsmith/core/progress.h"
#include "socketsmith/geometry/tri_mesh.h"
#include "socketsmith/scan/reconstruction.h"
#include "socketsmith/scan/simulated_sensor.h"

namespace socketsmith::scan {

/// Distances of a set of area-weighted samples to a surface.
struct Deviation {
  double rms_m = 0.0;   ///< area-weighted root mean square [m]
  double mean_m = 0.0;  ///< area-weighted mean of the unsigned distances [m]
  /// Area-weighted mean of the signed distances [m]: > 0 when the reconstruction lies outside the
  /// original (too large), < 0 inside (shrunk) — a depth bias shows here.
  double signed_mean_m = 0.0;
  double max_m = 0.0;   ///< largest distance [m]
  double p95_m = 0.0;   ///< 95th percentile (by area) [m]
  double area_m2 = 0.0; ///< area the samples stand for [m²]
  int samples = 0;
};

/// A point on a surface standing for @p weight of its area.
struct SurfaceSample {
  Vec3 point;
  Vec3 normal;    ///< unit normal of its triangle
  double weight;  ///< [m²]
  int triangle;
};

/// Samples every triangle of @p mesh (from @p first_triangle to @p end_triangle, −1: the end) on a
/// regular barycentric grid of L² sub-triangles, L = ⌈longest edge / spacing⌉, one sample at each
/// sub-triangle's centroid weighted by its area. @throws InvalidInputError for spacing ≤ 0.
std::vector<SurfaceSample> sample_surface(const geometry::TriMesh& mesh, double spacing_m, int first_triangle = 0,
                                          int end_triangle = -1);

/// Area-weighted deviation statistics of the signed distances @p d (see Deviation) with weights @p w.
Deviation deviation_stats(const std::vector<double>& d, const std::vector<double>& w);

/// True when a sensor measures @p p (outward unit normal @p n): it projects inside the image
/// onto a pixel with a valid ray, within @p max_view_angle_rad of facing the sensor, in the
/// sensor's range, and nothing of @p scene lies between them (a 1 mm tolerance).
bool sensor_sees(const SimulatedSensor& sensor, const RayTable& rays, const geometry::SurfaceQuery& scene,
                 const Vec3& p, const Vec3& n, double max_view_angle_rad, double min_range_m = 0.5,
                 double max_range_m = 4.5);

/// Settings of measure_scan_accuracy.
struct AccuracyOptions {
  double sample_spacing_m = 2e-3;     ///< sample spacing on both surfaces [m], > 0
  Vec3 up = Vec3::UnitZ();            ///< proximal direction, unit
  double region_top_m = 1e9;          ///< only samples with up·p ≤ this count (the proximal cut) [m]
  double max_view_angle_rad = 1.3;    ///< "seen": facing a sensor within this angle (the back-projection's limit)
};

/// Symmetric surface distance between a reconstruction and the original it was scanned from.
struct ScanAccuracy {
  /// Samples of the reconstruction below region_top (its cap excluded) → the original surface.
  Deviation reconstructed_to_original;
  /// Samples of the original below region_top that at least one sensor sees → the reconstruction.
  Deviation seen_original_to_reconstructed;
  /// Samples of the original below region_top that no sensor sees (filled in by Poisson).
  Deviation unseen_original_to_reconstructed;
  /// The two measured sets pooled (area-weighted): the headline number.
  Deviation symmetric;
  double seen_area_fraction = 0.0;  ///< of the original's area below region_top
};

/// Measures @p reconstructed (triangles from @p first_cap_triangle on are a cap and are not
/// sampled; −1: no cap) against @p original (any orientation, may be open) as seen by @p sensors.
/// @throws InvalidInputError for empty meshes or a region that holds no sample.
ScanAccuracy measure_scan_accuracy(const geometry::TriMesh& reconstructed, int first_cap_triangle,
                                   const geometry::TriMesh& original, const std::vector<SimulatedSensor>& sensors,
                                   const AccuracyOptions& options = {});

/// Settings of run_limb_scan_experiment.
struct LimbScanOptions {
  int sensors = 4;                         ///< on a horizontal ring around the limb
  double radius_m = 0.75;                  ///< ring radius (thesis 0.75 m)
  double height_m = 0.0;                   ///< sensor height above the limb's bounding-box centre [m]
  std::vector<CameraIntrinsics> intrinsics;  ///< 0, 1 or one per sensor (see default_rig)
  SimulationOptions simulation;            ///< error model, seed, frames
  ReconstructionOptions reconstruction;
  AccuracyOptions accuracy;                ///< region_top is set from the reconstruction's cut
  /// Learned error compensation of each unit (same seed and intrinsics as the calibration): empty,
  /// or one per sensor, applied by the back-projection.
  std::vector<ErrorCompensation> compensation;
};

/// One limb scan: the simulated recording, its reconstruction and the accuracy.
struct LimbScanResult {
  geometry::TriMesh original;     ///< the limb, moved so its bounding-box centre is at the rig's centre [m]
  Vec3 offset = Vec3::Zero();     ///< what was added to the input's vertices [m]
  std::vector<SimulatedSensor> rig;
  Recording recording;
  ReconstructionResult reconstruction;
  ScanAccuracy accuracy;
  double simulate_s = 0.0;        ///< wall time of the simulation [s]
};

/// Simulates a rig of options.sensors Kinect v2 around @p limb (metres, long axis along +z,
/// proximal end up, e.g. the generated limb's skin or openlimb_tt_mean_skin_mm.stl), reconstructs
/// the recording and measures the reconstruction against the limb below the proximal cut.
/// @throws InvalidInputError for an empty mesh or invalid options; whatever reconstruction throws.
LimbScanResult run_limb_scan_experiment(const geometry::TriMesh& limb, const LimbScanOptions& options = {},
                                        const ProgressCallback& progress = {});

}  // namespace socketsmith::scan
