// Explicit central-difference steps per second on n x n plain weaves of the paper's fabric
// (engine/solver/central_difference.cpp; docs/performance.md, "Explicit path"):
//   BM_ExplicitSteps/<n>/<threads>: the biaxial test on the explicit path with mass scaling to
//     5e-5 s, a bounded number of steps over which the fabric is pulled to 1.5 % (faster than
//     the 1 s test: a timing case, not a quasi-static one); n = 6 is the paper's k = 1 model (876
//     nodes, 432 elements, 36 crossings), n = 48 a 48 x 48 weave. The time reported is the stepping
//     alone (from the end of the first increment to the end of the last: stable-step estimate and
//     mass scaling at the start of the step are left out); counters give steps/s, ns per element
//     and step, and the CPU time of all threads per step (steadier than the wall time on a shared
//     machine).
#include "engine/solver/simulation.hpp"
#include "engine/textile/biaxial.hpp"
#include "engine/textile/weave.hpp"

#include <benchmark/benchmark.h>
#include <chrono>
#include <ctime>
#include <tbb/global_control.h>

namespace yarnsim {
namespace {

/// An n x n weave of the paper's fabric under the k = 1 biaxial test on the explicit path, pulled
/// to the full 1.5 % in `steps` increments of the mass-scaled step dt (s): the crossings close
/// within the first tenth, so most of the steps run with every contact active.
Model explicit_weave(int n, int steps, double dt) {
  textile::WeaveParameters p = textile::paper_fabric();
  p.n_warp = p.n_weft = n;
  // As the paper's fabric: the yarns run 1.5 spacings past the outer crossings on each side.
  p.length_warp = (n + 3) * p.spacing_weft;
  p.length_weft = (n + 3) * p.spacing_warp;
  textile::Fabric f = textile::build_weave(p);
  textile::BiaxialParameters b;
  b.monitors = false;
  b.type = StepType::Explicit;
  b.explicit_.mass_scaling_dt = dt;
  b.loading_time = steps * dt;
  textile::add_biaxial_test(f, b);
  f.model.steps.back().output_every = 1; // the stopwatch sees every increment
  return f.model;
}

void BM_ExplicitSteps(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, state.range(1));
  // Bounded so that each case takes seconds: 2000 steps on the paper's model, 100 on 48 x 48.
  const int steps = n <= 12 ? 2000 : 100;
  const Model m = explicit_weave(n, steps, 5e-5);
  using Clock = std::chrono::steady_clock;
  struct Stopwatch : SimulationObserver {
    Clock::time_point first, last;
    std::clock_t first_cpu = 0, last_cpu = 0; ///< CPU time of the process, all threads
    int first_increment = -1, last_increment = -1;
    void on_increment(const Simulation&, const IncrementReport& r) override {
      const Clock::time_point now = Clock::now();
      const std::clock_t cpu = std::clock();
      if (first_increment < 0) {
        first = now;
        first_cpu = cpu;
        first_increment = r.increment;
      }
      last = now;
      last_cpu = cpu;
      last_increment = r.increment;
    }
  };
  for (auto _ : state) {
    Simulation sim(m);
    Stopwatch watch;
    sim.run(&watch);
    const double seconds = std::chrono::duration<double>(watch.last - watch.first).count();
    const int stepped = watch.last_increment - watch.first_increment;
    state.SetIterationTime(seconds);
    state.counters["steps"] = stepped;
    state.counters["steps_per_s"] = stepped / seconds;
    state.counters["ns_per_element_step"] = 1e9 * seconds / stepped / m.elements.size();
    // CPU time of all threads per step: on a shared machine a steadier figure than the wall time.
    state.counters["cpu_ms_per_step"] =
        1e3 * static_cast<double>(watch.last_cpu - watch.first_cpu) / CLOCKS_PER_SEC / stepped;
    state.counters["elements"] = static_cast<double>(m.elements.size());
    state.counters["contact_candidates"] = sim.contact()->candidates();
    state.counters["active_contacts"] = sim.contact()->active();
  }
}
BENCHMARK(BM_ExplicitSteps)
    ->ArgsProduct({{6, 48}, {1, 2}})
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseManualTime();

} // namespace
} // namespace yarnsim

BENCHMARK_MAIN();
