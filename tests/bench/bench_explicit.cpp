// Explicit central-difference steps per second on n x n plain weaves of the paper's fabric
// (engine/solver/central_difference.cpp; docs/performance.md, "Explicit path"):
//   BM_ExplicitSteps/<n>/<threads>: the biaxial test on the explicit path with mass scaling to
//     5e-5 s (the default of examples/biaxial-k1-explicit.toml), a bounded number of steps from
//     the start of loading; n = 6 is the paper's k = 1 model (876 nodes, 432 elements, 36
//     crossings), n = 48 a 48 x 48 weave. The time reported is the stepping alone (from the end of
//     the first increment to the end of the last: stable-step estimate and mass scaling at the
//     start of the step are left out); counters give steps/s and ns per element and step.
#include "engine/solver/simulation.hpp"
#include "engine/textile/biaxial.hpp"
#include "engine/textile/weave.hpp"

#include <benchmark/benchmark.h>
#include <chrono>
#include <tbb/global_control.h>

namespace yarnsim {
namespace {

/// An n x n weave of the paper's fabric under the k = 1 biaxial test on the explicit path,
/// stopped after `steps` increments of the mass-scaled step dt (s).
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
  textile::add_biaxial_test(f, b);
  f.model.steps.back().end_time = steps * dt;
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
    int first_increment = -1, last_increment = -1;
    void on_increment(const Simulation&, const IncrementReport& r) override {
      const Clock::time_point now = Clock::now();
      if (first_increment < 0) {
        first = now;
        first_increment = r.increment;
      }
      last = now;
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
    state.counters["elements"] = static_cast<double>(m.elements.size());
    state.counters["contact_candidates"] = sim.spline_contact()->candidates();
    state.counters["active_contacts"] = sim.spline_contact()->active();
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
