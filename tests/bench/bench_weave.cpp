// Whole-model benchmarks on the paper's fabric and on n x n plain weaves of it:
//   BM_NewtonIterationWeave/<n>/<threads>/<solver>: wall time per Newton iteration and the time
//     of each stage per iteration, on the biaxial k = 1 test (dynamic, as the paper's) at the
//     start of the loading: one warm-up increment of 1 ms (the contact candidates, the matrix
//     pattern and its symbolic analysis settle), then kTimedIncrements increments of 1 ms are
//     timed (2-4 Newton iterations each). Every candidate pair of the weave is in the broad and
//     narrow phase from the first iteration, the pairs within reach in the pattern; the crossings
//     are still open there (spline clearance 0.099 mm), so the contact assembly adds few pairs.
//     Later in the toe, where the crossings close (t = 5 to 10 ms at n = 24), weaves of 16 x 16 and
//     more need many Newton iterations or smaller increments (docs/performance.md): a window there
//     would time the iterations of a struggling Newton, not the cost of one. Per iteration:
//       iteration_ms  wall time of the timed increments / their Newton iterations (each increment
//                     also assembles once more to confirm convergence; that is counted too);
//       broad_ms, narrow_ms, beam_assembly_ms, other_assembly_ms (zeroing, contact, inertia,
//       loads), assembly_ms (beam + other), factorisation_ms, solve_ms, check_ms (norms): stage
//       times summed over the iterations / the iterations. The narrow phase runs beside the beam
//       assembly, so on two threads the stages add up to more than the wall time;
//       graph_ms       wall time of the iteration's task graph (broad phase to contact assembly),
//                     the part that runs in parallel: its 1-over-2-thread ratio is the speed-up
//                     of assembly with contact.
//     scripts/bench fits the growth exponents against the DOF (scripts/bench_report.py).
//   BM_PaperCaseK1/<threads>/<solver>: wall time of the paper's k = 1 spline case to 1.5 % strain.
// <solver>: 0 the default ('auto', here SimplicialLDLT of the symmetric part), 1 CHOLMOD
// supernodal LL^T ('cholmod'), 2 UMFPACK LU ('lu').
#include "engine/solver/simulation.hpp"
#include "engine/textile/biaxial.hpp"
#include "engine/textile/weave.hpp"

#include <benchmark/benchmark.h>
#include <chrono>
#include <cstdint>
#include <tbb/global_control.h>

namespace yarnsim {
namespace {

constexpr double kWarmUpEnd = 1e-3; ///< s, end of the warm-up increment
constexpr double kTimedDt = 1e-3;   ///< s, each timed increment
constexpr int kTimedIncrements = 3;

SimulationOptions solver_option(std::int64_t code) {
  SimulationOptions o;
  o.linear_solver = code == 1   ? LinearSolverKind::Cholmod
                    : code == 2 ? LinearSolverKind::LU
                                : LinearSolverKind::Auto;
  return o;
}

Model weave(int n, double end_time) {
  textile::WeaveParameters p = textile::paper_fabric();
  p.n_warp = p.n_weft = n;
  // As the paper's fabric: the yarns run 1.5 spacings past the outer crossings on each side.
  p.length_warp = (n + 3) * p.spacing_weft;
  p.length_weft = (n + 3) * p.spacing_warp;
  textile::Fabric f = textile::build_weave(p);
  textile::BiaxialParameters b;
  b.monitors = false;
  textile::add_biaxial_test(f, b);
  f.model.steps.back().end_time = end_time;
  return f.model;
}

/// The weave with its biaxial step split into the warm-up increment and the timed window.
Model timed_weave(int n) {
  Model m = weave(n, 1.0);
  SolutionStep warm_up = m.steps.back(), timed = m.steps.back();
  warm_up.end_time = kWarmUpEnd;
  warm_up.dt_initial = warm_up.dt_max = kTimedDt;
  timed.end_time = kWarmUpEnd + kTimedIncrements * kTimedDt;
  timed.dt_initial = timed.dt_max = kTimedDt;
  m.steps = {warm_up, timed};
  return m;
}

void BM_NewtonIterationWeave(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, state.range(1));
  const Model m = timed_weave(n);
  using Clock = std::chrono::steady_clock;
  struct Mark : SimulationObserver {
    StageTimes times;
    int iterations = -1;
    Clock::time_point wall;
    void on_increment(const Simulation& s, const IncrementReport& r) override {
      if (r.step == 0 && r.time >= kWarmUpEnd * (1 - 1e-9)) {
        times = s.stage_times();
        iterations = s.total_iterations();
        wall = Clock::now();
      }
    }
  } mark;
  StageTimes t1;
  int it1 = 0;
  Clock::time_point end;
  for (auto _ : state) {
    Simulation sim(m, solver_option(state.range(2)));
    sim.run(&mark);
    end = Clock::now();
    t1 = sim.stage_times();
    it1 = sim.total_iterations();
    state.counters["dof"] = 6.0 * m.nodes.size();
    state.counters["equations"] = sim.assembler().n_equations();
    state.counters["nonzeros"] = static_cast<double>(sim.assembler().matrix().nonZeros());
    state.counters["candidates"] = sim.contact()->candidates();
    state.counters["active_contacts"] = sim.contact()->active();
  }
  const StageTimes& t0 = mark.times;
  const int iterations = it1 - mark.iterations;
  if (mark.iterations < 0 || iterations <= 0) {
    state.SkipWithError("the timed window has no Newton iteration");
    return;
  }
  const double k = 1e3 / iterations;
  state.counters["iterations"] = iterations;
  state.counters["iteration_ms"] = k * std::chrono::duration<double>(end - mark.wall).count();
  state.counters["broad_ms"] = k * (t1.broad_phase - t0.broad_phase);
  state.counters["narrow_ms"] = k * (t1.narrow_phase - t0.narrow_phase);
  state.counters["beam_assembly_ms"] = k * (t1.beam_assembly - t0.beam_assembly);
  state.counters["other_assembly_ms"] = k * (t1.other_assembly - t0.other_assembly);
  state.counters["assembly_ms"] =
      k * (t1.beam_assembly - t0.beam_assembly + t1.other_assembly - t0.other_assembly);
  state.counters["graph_ms"] = k * (t1.iteration_graph - t0.iteration_graph);
  state.counters["factorisation_ms"] = k * (t1.factorisation - t0.factorisation);
  state.counters["solve_ms"] = k * (t1.solve - t0.solve);
  state.counters["check_ms"] = k * (t1.convergence_check - t0.convergence_check);
}
BENCHMARK(BM_NewtonIterationWeave)
    ->ArgsProduct({{6, 12, 24, 48, 96}, {1, 2}, {0, 1, 2}})
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();

void BM_PaperCaseK1(benchmark::State& state) {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, state.range(0));
  const Model m = weave(6, 1.0);
  for (auto _ : state) {
    Simulation sim(m, solver_option(state.range(1)));
    sim.run();
    state.counters["increments"] = sim.state().increment;
    state.counters["iterations"] = sim.total_iterations();
  }
}
BENCHMARK(BM_PaperCaseK1)
    ->ArgsProduct({{1, 2}, {0, 1}})
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();

} // namespace
} // namespace yarnsim

BENCHMARK_MAIN();
