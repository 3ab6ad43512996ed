// Narrow phase of the spline contact: time per segment pair, cold against warm-started.
#include "contact/spline_contact.hpp"

#include <benchmark/benchmark.h>

#include <Eigen/Geometry>

#include <cmath>
#include <ctime>
#include <random>
#include <vector>

namespace {

using namespace yarnsim::contact;
using Eigen::Matrix3d;
using Eigen::Vector3d;

constexpr double kL = 1.1e-3;           // control point spacing, m
constexpr double kRadius = 2.840909e-4; // m

struct Pair {
  Matrix3d xa;
  Matrix3d xb;
  const SegmentBasis* ba;
  const SegmentBasis* bb;
  ProjectionStart warm; // solution one small step earlier
};

/// Crossing, curved segment pairs in contact (about 90 % penetrate), as after a broad phase,
/// with the warm start taken from the same pair one step earlier (B moved by 1e-3 L).
std::vector<Pair> make_pairs(int count) {
  static const SplineCurve curve(5);
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Pair> pairs;
  while (static_cast<int>(pairs.size()) < count) {
    Pair p;
    p.ba = &curve.segment(static_cast<int>(pairs.size()) % 3);
    p.bb = &curve.segment(static_cast<int>(pairs.size() / 3) % 3);
    const Eigen::Quaterniond q = Eigen::Quaterniond::UnitRandom();
    const double angle = (40.0 + 100.0 * (0.5 + 0.5 * u(rng))) * M_PI / 180.0;
    for (int k = 0; k < 3; ++k) {
      p.xa.col(k) = q * Vector3d((k - 1) * kL, 0.1 * kL * u(rng), 0.1 * kL * u(rng));
      p.xb.col(k) = q * (Vector3d(std::cos(angle), std::sin(angle), 0.0) * (k - 1) * kL +
                         Vector3d(0.1 * kL * u(rng), 0.1 * kL * u(rng), 0.1 * kL * u(rng)));
    }
    p.xb.colwise() += q * Vector3d(0.3 * kL * u(rng), 0.3 * kL * u(rng), 0.0);
    const ProjectionResult first = closest_point_projection(p.xa, *p.ba, p.xb, *p.bb, {});
    if (first.status != ProjectionStatus::Converged) {
      continue;
    }
    const Vector3d g = p.ba->point(p.xa, first.xi_A) - p.bb->point(p.xb, first.xi_B);
    const double overlap = 1e-5 * (0.5 + 0.5 * u(rng)) - 1e-6;
    p.xb.colwise() += (g.norm() - (2 * kRadius - overlap)) * g.normalized();
    Pair before = p;
    before.xb.colwise() += 1e-3 * kL * Vector3d(u(rng), u(rng), u(rng));
    const ProjectionResult previous =
        closest_point_projection(before.xa, *before.ba, before.xb, *before.bb, {});
    if (previous.status != ProjectionStatus::Converged) {
      continue;
    }
    p.warm = {previous.xi_A, previous.xi_B, true};
    pairs.push_back(p);
  }
  return pairs;
}

const std::vector<Pair>& pairs() {
  static const std::vector<Pair> all = make_pairs(1024);
  return all;
}

/// CPU time of this thread, s: unlike wall time, not inflated by other work on a shared machine.
double thread_seconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

/// Runs `body` over all pairs per iteration and reports the mean CPU time per pair, ns.
template <class Body>
void per_pair(benchmark::State& state, Body body) {
  const auto& ps = pairs();
  double seconds = 0.0;
  for (auto _ : state) {
    const double begin = thread_seconds();
    for (const Pair& p : ps) {
      body(p);
    }
    seconds += thread_seconds() - begin;
  }
  state.counters["ns_per_pair"] =
      1e9 * seconds / (static_cast<double>(state.iterations()) * static_cast<double>(ps.size()));
}

void BM_ProjectionCold(benchmark::State& state) {
  per_pair(state, [](const Pair& p) {
    benchmark::DoNotOptimize(closest_point_projection(p.xa, *p.ba, p.xb, *p.bb, {}));
  });
}

void BM_ProjectionWarm(benchmark::State& state) {
  per_pair(state, [](const Pair& p) {
    benchmark::DoNotOptimize(closest_point_projection(p.xa, *p.ba, p.xb, *p.bb, p.warm));
  });
}

/// The full kernel: projection, gap, law, residual and (argument 1) the 18 x 18 tangent.
void contact(benchmark::State& state, bool warm) {
  const LinearPenalty law(1.5e6);
  SplineContactOptions options;
  options.compute_tangent = state.range(0) == 1;
  SplineContactResult out;
  per_pair(state, [&](const Pair& p) {
    spline_contact(p.xa, *p.ba, kRadius, p.xb, *p.bb, kRadius, warm ? p.warm : ProjectionStart{},
                   law, out, options);
    benchmark::DoNotOptimize(out.tangent.data());
    benchmark::ClobberMemory();
  });
}

void BM_ContactCold(benchmark::State& state) {
  contact(state, false);
}
void BM_ContactWarm(benchmark::State& state) {
  contact(state, true);
}

BENCHMARK(BM_ProjectionCold);
BENCHMARK(BM_ProjectionWarm);
BENCHMARK(BM_ContactCold)->ArgName("tangent")->Arg(0)->Arg(1);
BENCHMARK(BM_ContactWarm)->ArgName("tangent")->Arg(0)->Arg(1);

} // namespace

BENCHMARK_MAIN();
