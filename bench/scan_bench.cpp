// Scan benchmarks: simulated 4-sensor Kinect v2 recordings (512×424, default errors) of a 16 cm ×
// 40 cm cylinder and of the generated transtibial limb; ray table, back-projection, simulation,
// and the whole reconstruction (4 frames → watertight mesh; target ≤ 3 s on the 2-core machine,
// thesis 12.8 s).
#include <benchmark/benchmark.h>

#include "socketsmith/scan/reconstruction.h"
#include "socketsmith/scan/simulated_sensor.h"
#include "socketsmith/volume/limb_generator.h"

namespace {

using namespace socketsmith;

const scan::Recording& cylinder_recording() {
  static const scan::Recording rec = scan::simulate_recording(scan::make_cylinder(0.16, 0.4), scan::default_rig(4));
  return rec;
}

const scan::Recording& limb_recording() {
  static const scan::Recording rec = [] {
    geometry::TriMesh skin =
        volume::generate_limb(volume::default_params(geometry::LimbType::Transtibial, 1)).skin;
    const geometry::Vec3 c = geometry::bounding_box(skin).center();
    for (auto& v : skin.vertices) v -= c;
    return scan::simulate_recording(skin, scan::default_rig(4));
  }();
  return rec;
}

void BM_ScanRayTable(benchmark::State& state) {
  const scan::CameraIntrinsics k = scan::kinect_v2_typical_intrinsics();
  for (auto _ : state) benchmark::DoNotOptimize(scan::make_ray_table(k, 1));
}

void BM_ScanBackProject4Frames(benchmark::State& state) {
  const scan::Recording& rec = cylinder_recording();
  for (auto _ : state) benchmark::DoNotOptimize(scan::recording_point_cloud(rec));
}

void BM_ScanSimulate4Sensors(benchmark::State& state) {
  const geometry::TriMesh cyl = scan::make_cylinder(0.16, 0.4);
  const auto rig = scan::default_rig(4);
  for (auto _ : state) benchmark::DoNotOptimize(scan::simulate_recording(cyl, rig));
}

void BM_ScanReconstruct4Frames(benchmark::State& state) {
  const scan::Recording& rec = cylinder_recording();
  for (auto _ : state) benchmark::DoNotOptimize(scan::reconstruct_recording(rec));
}

void BM_ScanReconstructLimb4Frames(benchmark::State& state) {
  const scan::Recording& rec = limb_recording();
  for (auto _ : state) benchmark::DoNotOptimize(scan::reconstruct_recording(rec));
}

}  // namespace

BENCHMARK(BM_ScanRayTable)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ScanBackProject4Frames)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ScanSimulate4Sensors)->Unit(benchmark::kMillisecond)->Iterations(2);
BENCHMARK(BM_ScanReconstruct4Frames)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(BM_ScanReconstructLimb4Frames)->Unit(benchmark::kMillisecond)->Iterations(3);
