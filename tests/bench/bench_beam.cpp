// Beam element and Newton-iteration benchmarks (issue "A runnable engine"):
//   BM_BeamResidualTangent, BM_BeamResidual: ns per element on one core;
//   BM_NewtonIteration/<threads>/<solver>: one Newton iteration (assembly, factorisation, solve) on
//   a 10 000-element model: 100 parallel clamped-clamped beams of 100 elements, sagging under load.
#include "engine/assembly/assembler.hpp"
#include "engine/beam/beam_element.hpp"
#include "engine/math/rotation.hpp"
#include "engine/model/model.hpp"
#include "engine/solver/linear_solver.hpp"

#include <benchmark/benchmark.h>
#include <chrono>
#include <random>
#include <tbb/global_control.h>

namespace yarnsim {
namespace {

Section bench_section() {
  Section s;
  s.EA = 3.8e4;
  s.GA1 = s.GA2 = 1.3e4;
  s.EI1 = 7.7e-5;
  s.EI2 = 1.2e-2;
  s.GJ = 1.2e-3;
  s.rhoA = 2.6e-3;
  return s;
}

/// n random deformed elements with history, as the assembly sees them.
struct ElementSet {
  std::vector<BeamReference> ref;
  std::vector<std::array<GaussState, 2>> hist;
  std::vector<BeamNodalValues> val;
  explicit ElementSet(int n) {
    std::mt19937 rng(1);
    std::uniform_real_distribution<double> u(-1, 1);
    for (int e = 0; e < n; ++e) {
      Eigen::Matrix3d X;
      X << 0, 0.5e-3, 1e-3, 0, 0.02e-3 * u(rng), 0, 0, 0, 0.01e-3 * u(rng);
      ref.push_back(make_beam_reference(X, Eigen::Vector3d::UnitY(), bench_section()));
      std::array<GaussState, 2> h;
      for (int g = 0; g < 2; ++g)
        h[g] = {rotation_matrix(Eigen::Vector3d(u(rng), u(rng), u(rng))) * ref.back().Q0[g],
                Eigen::Vector3d(u(rng), u(rng), u(rng))};
      hist.push_back(h);
      BeamNodalValues v;
      v.x = X + 1e-5 * Eigen::Matrix3d::Random();
      v.alpha = 0.05 * Eigen::Matrix3d::Random();
      val.push_back(v);
    }
  }
};

void BM_BeamResidualTangent(benchmark::State& state) {
  const ElementSet set(1000);
  ElementVector f;
  ElementMatrix K;
  for (auto _ : state) {
    for (int e = 0; e < 1000; ++e) {
      beam_internal_force(set.ref[e], set.hist[e], set.val[e], f, &K);
      benchmark::DoNotOptimize(K.data());
    }
  }
  // Rate inverted: seconds per (1e-9 x 1000 elements) = ns per element.
  state.counters["ns_per_element"] = benchmark::Counter(
      1e-6, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_BeamResidualTangent)->Unit(benchmark::kMicrosecond);

void BM_BeamResidual(benchmark::State& state) {
  const ElementSet set(1000);
  ElementVector f;
  for (auto _ : state) {
    for (int e = 0; e < 1000; ++e) {
      beam_internal_force(set.ref[e], set.hist[e], set.val[e], f, nullptr);
      benchmark::DoNotOptimize(f.data());
    }
  }
  // Rate inverted: seconds per (1e-9 x 1000 elements) = ns per element.
  state.counters["ns_per_element"] = benchmark::Counter(
      1e-6, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_BeamResidual)->Unit(benchmark::kMicrosecond);

/// 100 parallel beams, 100 elements each, clamped at both ends.
Model grid_model() {
  Model m;
  m.sections.push_back(bench_section());
  const int beams = 100, per = 100;
  const double L = 0.1;
  NodeSet ends{"ends", {}};
  for (int b = 0; b < beams; ++b) {
    const int first = static_cast<int>(m.nodes.size());
    for (int i = 0; i <= 2 * per; ++i)
      m.nodes.emplace_back(L * i / (2 * per), 2e-3 * b, 0.0);
    for (int e = 0; e < per; ++e)
      m.elements.push_back(
          {{first + 2 * e, first + 2 * e + 1, first + 2 * e + 2}, 0, Eigen::Vector3d::UnitY()});
    ends.nodes.push_back(first);
    ends.nodes.push_back(first + 2 * per);
  }
  m.node_sets.push_back(ends);
  return m;
}

void BM_NewtonIteration(benchmark::State& state) {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, state.range(0));
  const Model m = grid_model();
  const int n = static_cast<int>(m.nodes.size());
  std::vector<char> constrained(6 * n, 0);
  for (int node : m.node_sets[0].nodes)
    for (int d = 0; d < 6; ++d)
      constrained[6 * node + d] = 1;
  Assembler as(m, constrained);
  State s;
  s.x.resize(3, n);
  for (int i = 0; i < n; ++i)
    s.x.col(i) = m.nodes[i] + Eigen::Vector3d(0, 0, 1e-4 * std::sin(37.0 * i));
  s.alpha = 0.01 * Eigen::Matrix3Xd::Random(3, n);
  s.gauss.resize(m.elements.size());
  for (std::size_t e = 0; e < m.elements.size(); ++e)
    for (int g = 0; g < 2; ++g)
      s.gauss[e][g] = {as.references()[e].Q0[g], Eigen::Vector3d::Zero()};
  // range(1): 0 = LDLT of the symmetric part (what 'auto' picks here), 1 = UMFPACK LU.
  auto solver = make_linear_solver(state.range(1) == 0 ? LinearSolverKind::LDLTSymmetric
                                                       : LinearSolverKind::LU);
  Eigen::VectorXd r(6 * n), rhs(as.n_equations());
  solver->analyze(as.matrix());
  double t_asm = 0, t_fact = 0, t_solve = 0;
  using C = std::chrono::steady_clock;
  for (auto _ : state) {
    const auto t0 = C::now();
    r.setZero();
    as.zero_matrix();
    as.add_beams(s, r, true, {});
    for (int d = 0; d < 6 * n; ++d)
      if (as.equation(d) >= 0)
        rhs(as.equation(d)) = -r(d);
    const auto t1 = C::now();
    solver->factorize(as.matrix());
    const auto t2 = C::now();
    const Eigen::VectorXd dx = solver->solve(rhs);
    benchmark::DoNotOptimize(dx.data());
    const auto t3 = C::now();
    t_asm += std::chrono::duration<double>(t1 - t0).count();
    t_fact += std::chrono::duration<double>(t2 - t1).count();
    t_solve += std::chrono::duration<double>(t3 - t2).count();
  }
  const double it = static_cast<double>(state.iterations());
  state.counters["assembly_ms"] = 1e3 * t_asm / it;
  state.counters["factorisation_ms"] = 1e3 * t_fact / it;
  state.counters["solve_ms"] = 1e3 * t_solve / it;
  state.counters["dof"] = as.n_equations();
}
BENCHMARK(BM_NewtonIteration)
    ->ArgsProduct({{1, 2}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

} // namespace
} // namespace yarnsim

BENCHMARK_MAIN();
