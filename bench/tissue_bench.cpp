// Benchmarks of the tissue engine on cube lattices of ~1k, ~8k and ~20k nodes (MSS-CS, E = 50 kPa,
// 2 kPa + 0.4 kPa shear on top): one implicit Euler step, one static solve from rest, and one
// warm-started re-solve after a 5 % load change (the design loop's case). Each benchmark runs with
// the cube-targets constants (the default) and with the recommended ones, named after the preset:
// BM_StaticSolveFromRest/cube_targets/1000, BM_StaticSolveFromRest/recommended/1000, ...
// BM_ForcesAndJacobian also runs with the fe tissue model (BM_ForcesAndJacobian/fe/N).
// Run: build/socketsmith_bench --benchmark_min_time=2 [--benchmark_filter=cube_targets]
#include <benchmark/benchmark.h>

#include <string>

#include "socketsmith/tissue/implicit_euler.h"
#include "socketsmith/tissue/static_solver.h"
#include "socketsmith/volume/box_mesher.h"

namespace {
using namespace socketsmith;
using namespace socketsmith::tissue;

struct Setup {
  Setup(int n, const char* constants)
      : mesh(make_mesh(n)), model(mesh, {50e3, 1060}, options(constants)), dofs(model.num_dofs(), constraints(n)) {
    f = VectorXd::Zero(model.num_dofs());
    // 2 kPa down and 0.4 kPa sideways on the top face (≈ 4 % nominal strain). At 5 kPa + 1 kPa the
    // recommended constants make Newton crawl (docs/PERFORMANCE.md).
    const double h = 0.05 / n;
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        const int node = volume::box_node_index({n, n, n}, i, j, n);
        f[dof(node, 2)] = -2e3 * h * h;
        f[dof(node, 0)] = 0.4e3 * h * h;
      }
  }
  static volume::HexMesh make_mesh(int n) {
    volume::BoxMeshOptions o;
    o.size = volume::Vec3::Constant(0.05);
    o.divisions = {n, n, n};
    return volume::mesh_box(o);
  }
  /// A preset of the MSS-CS constants, or "fe" / "neo-hookean": a finite-element tissue model (ν 0.45).
  static MassSpringOptions options(const char* constants) {
    MassSpringOptions o;
    if (std::string(constants) == "fe" || std::string(constants) == "neo-hookean") {
      o.kind = parse_tissue_model(constants);
      return o;
    }
    o.corrective = CorrectiveSpringConstants::preset(constants);
    return o;
  }
  static DofConstraints constraints(int n) {
    DofConstraints c;
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) c.fix_nodes({volume::box_node_index({n, n, n}, i, j, 0)});
    return c;
  }
  volume::HexMesh mesh;
  MassSpringModel model;
  DofMap dofs;
  VectorXd f;
};

int divisions_for(int64_t target_nodes) { return volume::cube_divisions_for_nodes(static_cast<int>(target_nodes)); }

void BM_ImplicitEulerStep(benchmark::State& state, const char* constants) {
  Setup s(divisions_for(state.range(0)), constants);
  // h = 1 ms, the thesis's time step.
  ImplicitEuler euler(s.model, s.dofs, {1e-3, 1e-6, 500});
  DynamicState st = rest_state(s.model);
  int cg = 0, steps = 0, redone = 0;
  for (auto _ : state) {
    const auto r = euler.step(st, s.f);
    cg += r.cg_iterations;
    redone += r.law_retried;
    ++steps;
    if (!r.ok) state.SkipWithError(r.message.c_str());
  }
  state.counters["nodes"] = s.model.num_nodes();
  state.counters["cg_iter"] = static_cast<double>(cg) / steps;
  state.counters["redone_per_step"] = static_cast<double>(redone) / steps;
}

/// range(1): untimed steps before timing (1: only the first factorisation; 80: the sudden load's
/// transient has passed, the lattice sways slowly).
void BM_ImplicitEulerStepFrozen(benchmark::State& state, const char* constants) {
  Setup s(divisions_for(state.range(0)), constants);
  ImplicitEulerOptions o{1e-3, 1e-6, 500};
  o.frozen_matrix = true;  // factorised once (in the untimed first step), one back-substitution per step
  ImplicitEuler euler(s.model, s.dofs, o);
  DynamicState st = rest_state(s.model);
  for (int64_t i = 0; i < state.range(1); ++i)
    if (!euler.step(st, s.f).ok) state.SkipWithError("a warm-up step diverged");
  int steps = 0, factorisations = 0;
  for (auto _ : state) {
    const auto r = euler.step(st, s.f);
    ++steps;
    factorisations += r.refactorised;
    if (!r.ok) state.SkipWithError(r.message.c_str());
  }
  state.counters["nodes"] = s.model.num_nodes();
  state.counters["refactorisations_per_step"] = static_cast<double>(factorisations) / std::max(steps, 1);
}

void BM_StaticSolveFromRest(benchmark::State& state, const char* constants) {
  Setup s(divisions_for(state.range(0)), constants);
  StaticResult last;
  for (auto _ : state) {
    StaticSolver solver(s.model, s.dofs);  // includes the symbolic analysis and factorisation
    VectorXd x = s.model.rest_positions();
    last = solver.solve(s.f, x);
    if (!last.converged) state.SkipWithError(last.message.c_str());
  }
  state.counters["nodes"] = s.model.num_nodes();
  state.counters["newton"] = last.iterations;
  state.counters["factorizations"] = last.factorizations;
  state.counters["load_steps"] = last.load_steps;
  state.counters["krylov"] = last.krylov_iterations;
}

void BM_StaticResolveWarm(benchmark::State& state, const char* constants) {
  Setup s(divisions_for(state.range(0)), constants);
  StaticSolver solver(s.model, s.dofs);
  VectorXd x = s.model.rest_positions();
  solver.solve(s.f, x);
  double scale = 1.0;
  StaticResult last;
  for (auto _ : state) {
    scale = scale == 1.0 ? 1.05 : 1.0;  // alternate loads: a slider moving
    last = solver.solve(scale * s.f, x);
    if (!last.converged) state.SkipWithError(last.message.c_str());
  }
  state.counters["nodes"] = s.model.num_nodes();
  state.counters["newton"] = last.iterations;
  state.counters["factorizations"] = last.factorizations;
}

void BM_ForcesAndJacobian(benchmark::State& state, const char* constants) {
  Setup s(divisions_for(state.range(0)), constants);
  SparseMatrix J;
  const VectorXd x = s.model.rest_positions() * 1.01;
  for (auto _ : state) {
    benchmark::DoNotOptimize(s.model.elastic_forces(x));
    s.model.jacobian(x, JacobianKind::Exact, J);
  }
  state.counters["nodes"] = s.model.num_nodes();
}

}  // namespace

// Each benchmark with both presets: BM_Name/cube_targets/ARGS and BM_Name/recommended/ARGS.
#define TISSUE_BENCHMARK(fn)                                   \
  BENCHMARK_CAPTURE(fn, cube_targets, "cube-targets")->Apply(args_##fn); \
  BENCHMARK_CAPTURE(fn, recommended, "recommended")->Apply(args_##fn)

void sizes(benchmark::internal::Benchmark* b) { b->Arg(1000)->Arg(8000)->Arg(20000)->Unit(benchmark::kMillisecond); }
void args_BM_ImplicitEulerStep(benchmark::internal::Benchmark* b) { sizes(b); }
// 40 steps from the sudden load (the average includes the refactorisations of the transient), and 40
// steps after 80 untimed ones.
void args_BM_ImplicitEulerStepFrozen(benchmark::internal::Benchmark* b) {
  b->ArgsProduct({{1000, 8000, 20000}, {1, 80}})->Unit(benchmark::kMillisecond)->Iterations(40);
}
void args_BM_StaticSolveFromRest(benchmark::internal::Benchmark* b) { sizes(b); b->Iterations(2); }
void args_BM_StaticResolveWarm(benchmark::internal::Benchmark* b) { sizes(b); }
void args_BM_ForcesAndJacobian(benchmark::internal::Benchmark* b) { sizes(b); }

TISSUE_BENCHMARK(BM_ImplicitEulerStep);
TISSUE_BENCHMARK(BM_ImplicitEulerStepFrozen);
TISSUE_BENCHMARK(BM_StaticSolveFromRest);
TISSUE_BENCHMARK(BM_StaticResolveWarm);
TISSUE_BENCHMARK(BM_ForcesAndJacobian);
// The finite-element tissue model (St Venant–Kirchhoff hexahedra, 8 Gauss points): assembly cost.
BENCHMARK_CAPTURE(BM_ForcesAndJacobian, fe, "fe")->Apply(args_BM_ForcesAndJacobian);
// The same elements with the neo-Hookean material (9×9 tangent per Gauss point).
BENCHMARK_CAPTURE(BM_ForcesAndJacobian, neo_hookean, "neo-hookean")->Apply(args_BM_ForcesAndJacobian);
BENCHMARK_MAIN();
