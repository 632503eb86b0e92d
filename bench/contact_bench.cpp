// Contact benchmarks: one contact query pass (closest point on the socket's inner wall for every
// skin node, CGAL AABB tree) vs the stump's node count, a whole donning of the demo case's
// designed socket onto its stump (thesis: 69 s at 7,665 nodes; target ≤ 10 s), a refit of the worn
// socket, and the closed-loop design (issue 20's target: ≤ 30 s at 8k nodes).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <map>
#include <memory>

#include <sys/resource.h>

#include "socketsmith/contact/donning.h"
#include "socketsmith/contact/rigid_socket.h"
#include "socketsmith/core/units.h"
#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/tissue/dof_map.h"
#include "socketsmith/tissue/sparse_cholesky.h"

namespace {

using namespace socketsmith;

struct Designed {
  std::unique_ptr<pipeline::DesignSetup> setup;
  pipeline::DesignResult result;
};

/// The demo case designed at @p nodes (cached: set-up is not what is measured).
const Designed& designed(int nodes) {
  static std::map<int, Designed> cache;
  auto it = cache.find(nodes);
  if (it == cache.end()) {
    Designed d;
    design::CaseFile c = pipeline::demo_case(nodes);
    c.closed_loop = false;  // the designed socket: the benchmarks don it themselves
    d.setup = pipeline::prepare_design(c);
    d.result = pipeline::solve_design(*d.setup, true);
    it = cache.emplace(nodes, std::move(d)).first;
  }
  return it->second;
}

void BM_ContactQueryPass(benchmark::State& state) {
  const Designed& d = designed(static_cast<int>(state.range(0)));
  if (!d.result.socket) {
    state.SkipWithError("the demo design has no socket at this size");
    return;
  }
  contact::RigidSocket socket(d.result.socket->solid, d.setup->model.frame);
  const auto& pos = d.result.state.skin_positions;  // at the designed pose: every node near the wall
  int active = 0;
  for (auto _ : state) {
    active = 0;
    for (const auto& p : pos) active += socket.gap(p).gap_m < 0 ? 1 : 0;
    benchmark::DoNotOptimize(active);
  }
  state.counters["skin_nodes"] = static_cast<double>(pos.size());
  state.counters["ns_per_node"] = benchmark::Counter(static_cast<double>(pos.size()),
                                                     benchmark::Counter::kIsIterationInvariantRate |
                                                         benchmark::Counter::kInvert);
  state.counters["wall_triangles"] = socket.inner_triangles();
}

void BM_Donning(benchmark::State& state) {
  const Designed& d = designed(static_cast<int>(state.range(0)));
  if (!d.result.socket) {
    state.SkipWithError("the demo design has no socket at this size");
    return;
  }
  const auto& solver = *d.setup->solver;
  contact::DonningOptions o;
  o.friction = d.setup->case_file.patient.friction;
  o.stand_force_n = 0.5 * d.setup->case_file.patient.body_mass_kg * units::kGravity;
  // Second argument 1: the design's own (neo-Hookean) body, as the closed loop dons it; 0: the
  // stump linearised at rest.
  o.contact.linear_body = state.range(1) == 0;
  contact::DonningResult r;
  for (auto _ : state)
    r = contact::simulate_donning(solver.model(), solver.skin().nodes, solver.skin().area_m2,
                                  d.result.socket->solid, d.setup->model.frame, o);
  state.counters["nodes"] = d.setup->mesh.mesh.num_nodes();
  state.counters["steps"] = static_cast<double>(r.series.size());
  state.counters["newton"] = r.newton_iterations;
  state.counters["factorizations"] = r.series.empty() ? 0.0 : static_cast<double>(r.series.back().factorizations);
  state.counters["rejected_steps"] = r.rejected_steps;
  state.counters["completed"] = r.completed && r.stood ? 1 : 0;
}

/// The donning paths tests/contact/donning_test.cpp shows to give the same state, timed with the
/// Newton iterations and factorisations each needs (those counts are speed: measured here, not
/// pass/fail there). The 1.8k demo from 45 mm, standing. Arg: 0 the defaults (adaptive ≤ 6 mm,
/// smooth wall, soft stick); 1 the fast Newton path in 15 fixed steps; 2 the reference path
/// (halving, friction lag between solves, no bracket interpolation, no standing prediction) in the
/// same steps; 3 the facets instead of the smoothed wall; 4 1 mm steps with a stick as stiff as the
/// penalty.
void BM_DonningPath(benchmark::State& state) {
  const Designed& d = designed(1800);
  if (!d.result.socket) {
    state.SkipWithError("the demo design has no socket at this size");
    return;
  }
  const auto& solver = *d.setup->solver;
  contact::DonningOptions o;
  o.start_offset_m = 0.045;
  o.friction = d.setup->case_file.patient.friction;
  o.stand_force_n = 0.5 * d.setup->case_file.patient.body_mass_kg * units::kGravity;
  switch (state.range(0)) {
    case 1: o.steps = 15; break;
    case 2:
      o.steps = 15;
      o.contact.exact_line_search = false;
      o.contact.friction_in_newton = false;
      o.contact.interpolate_bracket = false;
      o.predict_stand_step = false;
      break;
    case 3:
      o.steps = 15;
      o.smooth_wall = false;
      break;
    case 4:
      o.step_m = 0.001;
      o.contact.stick_stiffness_ratio = 1.0;
      break;
    default: break;
  }
  contact::DonningResult r;
  for (auto _ : state)
    r = contact::simulate_donning(solver.model(), solver.skin().nodes, solver.skin().area_m2,
                                  d.result.socket->solid, d.setup->model.frame, o);
  state.counters["steps"] = static_cast<double>(r.series.size());
  state.counters["newton"] = r.newton_iterations;
  state.counters["factorizations"] = r.series.empty() ? 0.0 : static_cast<double>(r.series.back().factorizations);
  state.counters["completed"] = r.completed && r.stood ? 1 : 0;
}

/// A refit of the worn socket (the closed loop's inner step): the same socket, after a donning.
void BM_DonningRefit(benchmark::State& state) {
  const Designed& d = designed(static_cast<int>(state.range(0)));
  if (!d.result.socket) {
    state.SkipWithError("the demo design has no socket at this size");
    return;
  }
  const auto& solver = *d.setup->solver;
  contact::DonningOptions o;
  o.friction = d.setup->case_file.patient.friction;
  o.stand_force_n = 0.5 * d.setup->case_file.patient.body_mass_kg * units::kGravity;
  contact::DonningSimulation sim(solver.model(), solver.skin().nodes, solver.skin().area_m2, d.result.socket->solid,
                                 d.setup->model.frame, o);
  (void)sim.run();
  contact::DonningResult r;
  for (auto _ : state) r = sim.refit(d.result.socket->solid);
  state.counters["newton"] = r.newton_iterations;
  state.counters["completed"] = r.completed && r.stood ? 1 : 0;
}

/// The whole closed loop of the demo design with the loop's default options (ClosedLoopOptions).
void BM_ClosedLoop(benchmark::State& state) {
  auto& d = const_cast<Designed&>(designed(static_cast<int>(state.range(0))));
  if (!d.result.socket) {
    state.SkipWithError("the demo design has no socket at this size");
    return;
  }
  pipeline::ClosedLoopResult r;
  for (auto _ : state) r = pipeline::close_design_loop(*d.setup, d.result);
  const auto& b = r.iterations[r.best].below_brim;
  state.counters["nodes"] = d.setup->mesh.mesh.num_nodes();
  state.counters["donnings"] = static_cast<double>(std::count_if(r.iterations.begin(), r.iterations.end(),
                                                                 [](const auto& it) { return !it.refit; }));
  state.counters["refits"] = static_cast<double>(std::count_if(r.iterations.begin(), r.iterations.end(),
                                                               [](const auto& it) { return it.refit; }));
  state.counters["mae_kpa"] = b.mae / 1e3;
  state.counters["p99_kpa"] = b.p99 / 1e3;
  state.counters["r"] = b.r;
}

/// One Newton step's matrix work on the stump of the donning (the closed loop's dominant cost):
/// the neo-Hookean body's tangent at the designed state assembled (forces + exact tangent,
/// reduced to the free dofs) and factorised by CHOLMOD (the pattern analysed once, outside).
/// Arg 1: CHOLMOD's supernode relaxation (0 its defaults; k > 0: nrelax × k, zrelax × k up to
/// 0.95 — k = 2 is what tissue::SparseCholesky's constructor sets). CHOLMOD's lnz and fl count
/// the exact factor, not the relaxed one, so only the times compare the variants.
/// Arg 2: CHOLMOD's nmethods (0: AMD, then METIS when AMD fills much — the default; 9: every
/// ordering it has, the least fill kept; `method` is the one chosen).
/// f_user_ms / f_sys_ms / f_vcsw / f_ivcsw: the calling thread's CPU and its voluntary and forced
/// context switches per factorisation (getrusage): a factorisation that waits on a thread team
/// shows here (before SerialParallelRegions was made out of line, this benchmark, built without
/// OpenMP, made 1.8k voluntary switches and spent 178 ms a factorisation instead of 98).
/// Everything here runs on one thread (SerialParallelRegions), the assembly included.
void BM_StumpTangent(benchmark::State& state) {
  const Designed& d = designed(static_cast<int>(state.range(0)));
  const auto& model = d.setup->solver->model();
  const tissue::DofMap dofs = tissue::fixed_node_dofs(model.mesh(), "bench");
  const tissue::VectorXd& x = d.result.state.positions;
  tissue::SparseMatrix J, K;
  Eigen::CholmodSupernodalLLT<tissue::SparseMatrix, Eigen::Lower> llt;
  if (const int k = static_cast<int>(state.range(1)); k > 0) {
    auto& c = llt.cholmod();
    for (int i = 0; i < 3; ++i) {
      c.nrelax[i] *= static_cast<size_t>(k);
      c.zrelax[i] = std::min(0.95, c.zrelax[i] * k);
    }
  }
  llt.cholmod().nmethods = static_cast<int>(state.range(2));
  tissue::limit_solver_threads();
  const tissue::SerialParallelRegions serial;
  model.jacobian(x, tissue::JacobianKind::Exact, J);
  dofs.reduce_matrix(J, K);
  K *= -1.0;
  llt.analyzePattern(K);
  double assemble_s = 0, factorise_s = 0, cpu_s = 0, sys_s = 0;
  long vcsw = 0, ivcsw = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(model.elastic_forces(x));
    model.jacobian(x, tissue::JacobianKind::Exact, J);
    dofs.reduce_matrix(J, K);
    K *= -1.0;
    const auto t1 = std::chrono::steady_clock::now();
    rusage ru0{}, ru1{};
    getrusage(RUSAGE_THREAD, &ru0);
    llt.factorize(K);
    getrusage(RUSAGE_THREAD, &ru1);
    const auto seconds = [](const timeval& a, const timeval& b) {
      return static_cast<double>(b.tv_sec - a.tv_sec) + 1e-6 * static_cast<double>(b.tv_usec - a.tv_usec);
    };
    vcsw += ru1.ru_nvcsw - ru0.ru_nvcsw;
    ivcsw += ru1.ru_nivcsw - ru0.ru_nivcsw;
    cpu_s += seconds(ru0.ru_utime, ru1.ru_utime);
    sys_s += seconds(ru0.ru_stime, ru1.ru_stime);
    const auto t2 = std::chrono::steady_clock::now();
    assemble_s += std::chrono::duration<double>(t1 - t0).count();
    factorise_s += std::chrono::duration<double>(t2 - t1).count();
  }
  const auto n = static_cast<double>(state.iterations());
  state.counters["assemble_ms"] = 1e3 * assemble_s / n;
  state.counters["factorise_ms"] = 1e3 * factorise_s / n;
  state.counters["dofs"] = static_cast<double>(K.rows());
  state.counters["exact_factor_nnz_M"] = static_cast<double>(llt.cholmod().lnz) / 1e6;
  state.counters["exact_factor_gflop"] = llt.cholmod().fl / 1e9;
  state.counters["ok"] = llt.info() == Eigen::Success ? 1 : 0;
  state.counters["method"] = llt.cholmod().selected;
  state.counters["f_user_ms"] = 1e3 * cpu_s / n;
  state.counters["f_sys_ms"] = 1e3 * sys_s / n;
  state.counters["f_vcsw"] = vcsw / n;
  state.counters["f_ivcsw"] = ivcsw / n;
}

}  // namespace

BENCHMARK(BM_ContactQueryPass)->Arg(2000)->Arg(8000)->Arg(20000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Donning)
    ->Args({1800, 0})
    ->Args({7665, 0})
    ->Args({1800, 1})
    ->Args({7665, 1})
    ->Unit(benchmark::kSecond)
    ->Iterations(1);
BENCHMARK(BM_DonningPath)->DenseRange(0, 4)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_DonningRefit)->Arg(1800)->Arg(7665)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_StumpTangent)->ArgsProduct({{7665}, {0, 2, 3, 4}, {0, 9}})->Unit(benchmark::kMillisecond)->Iterations(10);
BENCHMARK(BM_ClosedLoop)->Arg(1800)->Arg(7665)->Unit(benchmark::kSecond)->Iterations(1);
