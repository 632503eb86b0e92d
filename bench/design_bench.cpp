// Design benchmarks on a transtibial stump: the real OpenLimb limb (skin + 4 bones) when
// ../shared/data is present, else the generated sample limb (seed 1). 60 kg patient, E = 100 kPa,
// Table 7 pain thresholds, linearised stump model (the design solver's default), flat brim 15 mm
// above the patellar tendon.
//  - BM_DesignUpdate/N/M: one design update on an N-node stump (M = 1: the fe tissue model) — one spot amplitude changed by ±2 %,
//    then DesignSolver::solve (field, saturation, follower passes with back-substitutions, radar).
//    Set-up (meshing, model, K₀ factorisation, one optimisation) is outside the timed loop.
//    Counters: median_ms / max_ms of the per-update solve time, follower passes per update.
//  - BM_Optimise/N: a full optimise_design from the default layout. Timed: every amplitude fit
//    (SLSQP), the position search when needed, and the stump solves of every round. Not timed:
//    meshing, the MSS-CS model, the solver set-up and the K₀ factorisation (a warm-up solve before
//    the loop; the solver is reset() to rest before each run).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <vector>

#include "socketsmith/core/units.h"
#include "socketsmith/design/optimizer.h"
#include "socketsmith/design/pain_map.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/volume/hex_mesher.h"
#include "socketsmith/volume/limb_generator.h"
#include "socketsmith/volume/limb_model.h"

namespace {

using namespace socketsmith;

const std::filesystem::path kRealLimb =
    std::filesystem::path(SOCKETSMITH_SHARED_DATA_DIR) / "limbs/transtibial/openlimb_tt_mean_limb_with_bones_mm.stl";

/// The prepared limb: the real one when available, else the generated sample.
const volume::LimbModel& design_limb(bool* real = nullptr) {
  static const bool is_real = std::filesystem::exists(kRealLimb);
  static const volume::LimbModel model = [] {
    if (is_real) {
      geometry::MeshReadOptions ro;
      ro.unit = units::LengthUnit::Millimetre;
      return volume::prepare_limb(geometry::read_mesh(kRealLimb, ro), {}, {});
    }
    const auto g = volume::generate_limb(volume::default_params(geometry::LimbType::Transtibial, 1));
    return volume::prepare_limb(volume::merge_shells(g), {}, {});
  }();
  if (real) *real = is_real;
  return model;
}

const volume::HexMesh& design_mesh(int target_nodes) {
  static std::map<int, volume::HexMesh> meshes;
  auto it = meshes.find(target_nodes);
  if (it == meshes.end()) {
    volume::HexMesherOptions o;
    o.target_nodes = target_nodes;
    it = meshes.emplace(target_nodes, volume::mesh_limb(volume::mesher_input(design_limb()), o).mesh).first;
  }
  return it->second;
}

double brim_height(const volume::LimbModel& m) {
  for (const auto& l : m.landmarks)
    if (l.code == "PT") return l.cylindrical.h + 15 * units::mm;
  return 0.8 * m.length_m;
}

std::unique_ptr<design::DesignSolver> make_solver(int target_nodes, bool fe = false, bool neo_hookean = false) {
  const auto& m = design_limb();
  const auto& mesh = design_mesh(target_nodes);
  const auto skin = volume::extract_skin_surface(mesh);
  auto thr = design::threshold_map(skin.positions, m.landmarks, design::default_thresholds(m.type));
  tissue::TissueMaterial mat;
  mat.youngs_modulus_pa = 100e3;
  design::PatientLoad pl;
  pl.body_mass_kg = 60;
  tissue::MassSpringOptions mo;
  if (fe) mo.kind = tissue::TissueModelKind::StVenantKirchhoff;
  design::DesignSolverOptions so;
  if (neo_hookean) {
    mo.kind = tissue::TissueModelKind::NeoHookean;
    so.mode = design::DesignSolveMode::Nonlinear;
  }
  auto solver = std::make_unique<design::DesignSolver>(mesh, mat, mo, m.frame, std::move(thr),
                                                       pl, m.length_m, so);
  const double h = brim_height(m);
  solver->set_brim([h](double) { return h; });
  return solver;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void BM_DesignUpdate(benchmark::State& state) {
  bool real = false;
  const auto& m = design_limb(&real);
  const auto t0 = std::chrono::steady_clock::now();
  auto solver = make_solver(static_cast<int>(state.range(0)), state.range(1) != 0);
  const auto opt = design::optimise_design(*solver, design::default_spots(m.type, m.landmarks, m.length_m));
  const double setup_s = seconds_since(t0);
  auto spots = opt.spots;
  // The spot the designer drags: the patellar tendon's.
  size_t k = 0;
  for (size_t i = 0; i < spots.size(); ++i)
    if (spots[i].name == "PT") k = i;
  const double base = spots[k].amplitude_pa > 0 ? spots[k].amplitude_pa : 10e3;
  std::vector<double> seconds;
  long passes = 0, updates = 0;
  for (auto _ : state) {
    spots[k].amplitude_pa = base * (updates % 2 == 0 ? 1.02 : 0.98);
    const auto st = solver->solve(spots);
    benchmark::DoNotOptimize(st.radar);
    seconds.push_back(st.seconds);
    passes += st.follower_passes;
    ++updates;
  }
  std::sort(seconds.begin(), seconds.end());
  state.counters["nodes"] = solver->model().num_nodes();
  state.counters["skin_nodes"] = static_cast<double>(solver->skin().nodes.size());
  state.counters["real_limb"] = real ? 1 : 0;
  state.counters["setup_s"] = setup_s;
  state.counters["opt_met"] = opt.constraints_met ? 1 : 0;
  state.counters["passes"] = updates ? static_cast<double>(passes) / updates : 0;
  if (!seconds.empty()) {
    state.counters["median_ms"] = 1e3 * seconds[seconds.size() / 2];
    state.counters["max_ms"] = 1e3 * seconds.back();
  }
}

void BM_Optimise(benchmark::State& state) {
  bool real = false;
  const auto& m = design_limb(&real);
  auto solver = make_solver(static_cast<int>(state.range(0)));
  const auto spots = design::default_spots(m.type, m.landmarks, m.length_m);
  const auto t0 = std::chrono::steady_clock::now();
  solver->solve(spots);  // factorises K₀ (not timed)
  const double factor_s = seconds_since(t0);
  design::OptimizerResult res;
  for (auto _ : state) {
    state.PauseTiming();
    solver->reset();
    state.ResumeTiming();
    res = design::optimise_design(*solver, spots);
  }
  state.counters["nodes"] = solver->model().num_nodes();
  state.counters["real_limb"] = real ? 1 : 0;
  state.counters["first_solve_s"] = factor_s;
  state.counters["met"] = res.constraints_met ? 1 : 0;
  state.counters["rounds"] = res.rounds;
  state.counters["fits"] = res.evaluations;
  state.counters["peak_ratio"] = res.state.max_requested_ratio;
}

/// The GUI's drag on the nonlinear neo-Hookean stump: DesignSolver::preview (the tangent step from
/// the last equilibrium) per update, against the full nonlinear solve it stands in for.
/// Counters: full_solve_s (one nonlinear solve of the optimised layout), factor_s (the tangent's
/// factorisation, done once per equilibrium when the GUI is idle), median_ms / max_ms per preview.
void BM_DesignPreview(benchmark::State& state) {
  const auto& m = design_limb();
  auto solver = make_solver(static_cast<int>(state.range(0)), false, true);
  auto spots = design::default_spots(m.type, m.landmarks, m.length_m);
  auto t0 = std::chrono::steady_clock::now();
  solver->solve(spots);
  const double full_s = seconds_since(t0);
  t0 = std::chrono::steady_clock::now();
  solver->prepare_preview();
  const double factor_s = seconds_since(t0);
  size_t k = 0;
  for (size_t i = 0; i < spots.size(); ++i)
    if (spots[i].name == "PT") k = i;
  const double base = spots[k].amplitude_pa > 0 ? spots[k].amplitude_pa : 10e3;
  std::vector<double> seconds;
  long updates = 0;
  for (auto _ : state) {
    spots[k].amplitude_pa = base * (1.0 + 0.3 * std::sin(0.3 * static_cast<double>(updates)));
    const auto st = solver->preview(spots);
    benchmark::DoNotOptimize(st.radar);
    seconds.push_back(st.seconds);
    ++updates;
  }
  std::sort(seconds.begin(), seconds.end());
  state.counters["nodes"] = solver->model().num_nodes();
  state.counters["full_solve_s"] = full_s;
  state.counters["factor_s"] = factor_s;
  if (!seconds.empty()) {
    state.counters["median_ms"] = 1e3 * seconds[seconds.size() / 2];
    state.counters["max_ms"] = 1e3 * seconds.back();
  }
}

}  // namespace

// Second argument: 0 = MSS-CS (the default), 1 = the fe tissue model.
BENCHMARK(BM_DesignUpdate)->ArgsProduct({{8000, 20000}, {0, 1}})->Unit(benchmark::kMillisecond)->Iterations(30);
BENCHMARK(BM_Optimise)->Arg(8000)->Arg(20000)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_DesignPreview)->Arg(8000)->Arg(20000)->Unit(benchmark::kMillisecond)->Iterations(20);
