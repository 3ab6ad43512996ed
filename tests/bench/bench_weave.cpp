// Whole-model benchmarks on the paper's fabric and on n x n plain weaves of it:
//   BM_NewtonIterationWeave/<n>/<threads>: time per Newton iteration split by stage (contact
//     search, beam assembly, other assembly, factorisation, solve), averaged over the increments
//     from 0.3 to 0.5 s of the k = 1 test, when the contacts are closed;
//   BM_PaperCaseK1/<threads>: wall time of the paper's k = 1 spline case to 1.5 % strain.
#include "engine/solver/simulation.hpp"
#include "engine/textile/biaxial.hpp"
#include "engine/textile/weave.hpp"

#include <benchmark/benchmark.h>
#include <chrono>
#include <tbb/global_control.h>

namespace yarnsim {
namespace {

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

void BM_NewtonIterationWeave(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, state.range(1));
  const Model m = weave(n, 0.5);
  StageTimes t0, t1;
  int it0 = 0, it1 = 0;
  for (auto _ : state) {
    Simulation sim(m);
    struct Mark : SimulationObserver {
      StageTimes* at;
      int* iterations;
      void on_increment(const Simulation& s, const IncrementReport& r) override {
        if (r.time >= 0.3 - 1e-9 && *iterations < 0) {
          *at = s.stage_times();
          *iterations = s.total_iterations();
        }
      }
    } mark;
    it0 = -1;
    mark.at = &t0;
    mark.iterations = &it0;
    sim.run(&mark);
    t1 = sim.stage_times();
    it1 = sim.total_iterations();
    state.counters["dof"] = 6.0 * m.nodes.size();
    state.counters["active_contacts"] = sim.contact()->active();
  }
  const double k = 1e3 / std::max(1, it1 - it0);
  state.counters["contact_ms"] = k * (t1.contact_search - t0.contact_search);
  state.counters["beam_assembly_ms"] = k * (t1.beam_assembly - t0.beam_assembly);
  state.counters["other_assembly_ms"] =
      k * (t1.other_assembly - t0.other_assembly + t1.convergence_check - t0.convergence_check);
  state.counters["factorisation_ms"] = k * (t1.factorisation - t0.factorisation);
  state.counters["solve_ms"] = k * (t1.solve - t0.solve);
  state.counters["iteration_ms"] =
      k * (t1.contact_search + t1.beam_assembly + t1.other_assembly + t1.convergence_check +
           t1.factorisation + t1.solve - t0.contact_search - t0.beam_assembly - t0.other_assembly -
           t0.convergence_check - t0.factorisation - t0.solve);
}
BENCHMARK(BM_NewtonIterationWeave)
    ->ArgsProduct({{6, 12, 24, 48}, {1, 2}})
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();

void BM_PaperCaseK1(benchmark::State& state) {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, state.range(0));
  const Model m = weave(6, 1.0);
  for (auto _ : state) {
    Simulation sim(m);
    sim.run();
    state.counters["increments"] = sim.state().increment;
    state.counters["iterations"] = sim.total_iterations();
  }
}
BENCHMARK(BM_PaperCaseK1)->Arg(1)->Arg(2)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

} // namespace
} // namespace yarnsim

BENCHMARK_MAIN();
