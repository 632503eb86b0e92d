// Stump model benchmarks on the real OpenLimb transtibial limb (skin + 4 bones): limb
// preparation, hexahedral meshing at 3k/8k/20k nodes, and a static MSS-CS solve under a uniform
// 3 kPa skin pressure. Skipped with a message when ../shared/data is absent.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <memory>

#include "socketsmith/core/units.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/tissue/pressure_load.h"
#include "socketsmith/volume/hex_mesher.h"
#include "socketsmith/volume/limb_model.h"

namespace {

using namespace socketsmith;

const std::filesystem::path kLimb =
    std::filesystem::path(SOCKETSMITH_SHARED_DATA_DIR) / "limbs/transtibial/openlimb_tt_mean_limb_with_bones_mm.stl";

const volume::LimbModel* limb_model() {
  static std::unique_ptr<volume::LimbModel> model;
  if (!model && std::filesystem::exists(kLimb)) {
    geometry::MeshReadOptions ro;
    ro.unit = units::LengthUnit::Millimetre;
    model = std::make_unique<volume::LimbModel>(volume::prepare_limb(geometry::read_mesh(kLimb, ro), {}, {}));
  }
  return model.get();
}

void BM_PrepareLimb(benchmark::State& state) {
  if (!std::filesystem::exists(kLimb)) return state.SkipWithError("shared data absent");
  geometry::MeshReadOptions ro;
  ro.unit = units::LengthUnit::Millimetre;
  const geometry::TriMesh limb = geometry::read_mesh(kLimb, ro);
  for (auto _ : state) benchmark::DoNotOptimize(volume::prepare_limb(limb, {}, {}));
}

void BM_MeshLimb(benchmark::State& state) {
  const auto* m = limb_model();
  if (!m) return state.SkipWithError("shared data absent");
  const auto in = volume::mesher_input(*m);
  volume::HexMesherOptions o;
  o.target_nodes = static_cast<int>(state.range(0));
  int nodes = 0;
  double min_sj = 0.0;
  for (auto _ : state) {
    const auto r = volume::mesh_limb(in, o);
    nodes = r.mesh.num_nodes();
    min_sj = r.quality.min_scaled_jacobian;
  }
  state.counters["nodes"] = nodes;
  state.counters["min_sj"] = min_sj;
}

void BM_PressureSolve(benchmark::State& state) {
  const auto* m = limb_model();
  if (!m) return state.SkipWithError("shared data absent");
  volume::HexMesherOptions o;
  o.target_nodes = static_cast<int>(state.range(0));
  const auto mesh = volume::mesh_limb(volume::mesher_input(*m), o).mesh;
  tissue::PressureLoadResult r;
  for (auto _ : state) r = tissue::solve_uniform_pressure(mesh, 3.0 * units::kPa, {}, {});
  state.counters["nodes"] = mesh.num_nodes();
  state.counters["newton"] = r.solve.iterations;
  state.counters["setup_s"] = r.seconds_setup;
  state.counters["solve_s"] = r.seconds_solve;
}

}  // namespace

BENCHMARK(BM_PrepareLimb)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_MeshLimb)->Arg(3000)->Arg(8000)->Arg(20000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PressureSolve)->Arg(3000)->Arg(8000)->Arg(20000)->Unit(benchmark::kMillisecond)->Iterations(1);
