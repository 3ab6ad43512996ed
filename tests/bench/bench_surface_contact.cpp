// Narrow phase of the surface contact: time per element pair, cold against warm-started.
#include "contact/surface_contact.hpp"

#include "engine/math/rotation.hpp"

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

constexpr double kLength = 1.0e-3; // element length, m
constexpr double kA = 1.136364e-3; // semi-axes of the study, m
constexpr double kB = 2.840909e-4;

struct Pair {
  SuperEllipticalCylinder a;
  SuperEllipticalCylinder b;
  SurfaceProjectionStart warm; // solution one small step earlier
};

Matrix3d frame(const Vector3d& e1, const Vector3d& e3) {
  Matrix3d q;
  q.col(0) = e1.normalized();
  q.col(2) = e3.normalized();
  q.col(1) = q.col(2).cross(q.col(0));
  return q;
}

/// A bent, twisted element along `d` centred at `c`, its rotations reached through random
/// Rodrigues increments.
void element(std::mt19937& rng, SurfaceNode (&n)[2], const Vector3d& c, const Vector3d& d,
             const Vector3d& up) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Matrix3d base = Eigen::AngleAxisd(0.1 * u(rng), d) * frame(d.cross(up), d);
  for (int k = 0; k < 2; ++k) {
    const Vector3d tilt = 0.05 * Vector3d(u(rng), u(rng), u(rng));
    const Matrix3d q = Eigen::AngleAxisd(tilt.norm(), tilt.normalized()).toRotationMatrix() * base;
    const Vector3d alpha = 0.3 * Vector3d(u(rng), u(rng), u(rng));
    n[k].position = c + (k - 0.5) * kLength * d + 0.03 * kLength * Vector3d(u(rng), u(rng), u(rng));
    n[k].rotation_increment = alpha;
    n[k].converged_rotation = yarnsim::rodrigues_rotation<double>(alpha).transpose() * q;
  }
}

/// Crossing element pairs (40 to 140 degrees) of elliptical sections, about 90 % of them
/// penetrating by up to 10 microns, as after a broad phase; the warm start is the same pair's
/// solution one step earlier (B moved by 1 micron). With `beyond`, B is then moved along A's
/// axis by one to two elements: the contact belongs to a neighbour (OutOfRange), the common
/// case among a broad phase's candidates.
std::vector<Pair> make_pairs(int count, bool beyond) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const SuperEllipse section(kA, kB);
  const LinearPenalty law(3.5e5);
  std::vector<Pair> pairs;
  while (static_cast<int>(pairs.size()) < count) {
    std::normal_distribution<double> n(0.0, 1.0);
    const Eigen::Quaterniond q = Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized();
    const double angle = (40.0 + 100.0 * (0.5 + 0.5 * u(rng))) * M_PI / 180.0;
    const Vector3d up = q * Vector3d::UnitZ();
    SurfaceNode na[2];
    SurfaceNode nb[2];
    element(rng, na, 0.2 * kLength * (q * Vector3d(u(rng), u(rng), 0)), q * Vector3d::UnitX(), up);
    element(rng, nb, 0.2 * kLength * (q * Vector3d(u(rng), u(rng), 0)) + 2 * kB * up,
            q * Vector3d(std::cos(angle), std::sin(angle), 0.0), up);
    const SuperEllipticalCylinder a(na[0], na[1], section);
    const SurfaceContactResult first = surface_contact(a, {nb[0], nb[1], section}, {}, law);
    if (first.status != ProjectionStatus::Converged) {
      continue;
    }
    const double gap = 1e-6 - 1e-5 * (0.5 + 0.5 * u(rng));
    for (auto& n : nb) {
      n.position += (first.gap - gap) * first.normal;
    }
    SurfaceNode before[2] = {nb[0], nb[1]};
    const Vector3d move = 1e-6 * Vector3d(u(rng), u(rng), u(rng));
    for (auto& n : before) {
      n.position += move;
    }
    const SurfaceContactResult previous =
        surface_contact(a, {before[0], before[1], section}, {}, law);
    if (beyond) {
      const Vector3d shift = (1.0 + 0.5 * (1.0 + u(rng))) * (na[1].position - na[0].position);
      for (auto& n : nb) {
        n.position += shift;
      }
    }
    const SuperEllipticalCylinder b(nb[0], nb[1], section);
    const ProjectionStatus expected =
        beyond ? ProjectionStatus::OutOfRange : ProjectionStatus::Converged;
    if (previous.status != ProjectionStatus::Converged ||
        surface_contact(a, b, {}, law).status != expected) {
      continue;
    }
    pairs.push_back(
        {a, b, {previous.zeta_A, previous.theta_A, previous.zeta_B, previous.theta_B, true}});
  }
  return pairs;
}

const std::vector<Pair>& pairs(bool beyond = false) {
  static const std::vector<Pair> in_range = make_pairs(1024, false);
  static const std::vector<Pair> out_of_range = make_pairs(1024, true);
  return beyond ? out_of_range : in_range;
}

/// CPU time of this thread, s: unlike wall time, not inflated by other work on a shared machine.
double thread_seconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

/// Runs `body` over all pairs per iteration and reports the mean CPU time per pair, ns.
template <class Body>
void per_pair(benchmark::State& state, Body body, bool beyond = false) {
  const auto& ps = pairs(beyond);
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

/// Building the two surfaces from node data (two Rodrigues rotations each).
void BM_BuildSurfaces(benchmark::State& state) {
  per_pair(state, [](const Pair& p) {
    const SuperEllipticalCylinder a(p.a.node(0), p.a.node(1), p.a.section());
    const SuperEllipticalCylinder b(p.b.node(0), p.b.node(1), p.b.section());
    benchmark::DoNotOptimize(&a);
    benchmark::DoNotOptimize(&b);
  });
}

void BM_ProjectionCold(benchmark::State& state) {
  per_pair(state,
           [](const Pair& p) { benchmark::DoNotOptimize(surface_projection(p.a, p.b, {})); });
}

/// A neighbour's contact: the solution lies beyond A's end (OutOfRange), cold start.
void BM_ProjectionColdOutOfRange(benchmark::State& state) {
  per_pair(
      state, [](const Pair& p) { benchmark::DoNotOptimize(surface_projection(p.a, p.b, {})); },
      true);
}

void BM_ProjectionWarm(benchmark::State& state) {
  per_pair(state,
           [](const Pair& p) { benchmark::DoNotOptimize(surface_projection(p.a, p.b, p.warm)); });
}

/// The full kernel: projection, gap, law, residual and (argument 1) the 24 x 24 tangent.
void contact(benchmark::State& state, bool warm) {
  const LinearPenalty law(3.5e5);
  SurfaceContactOptions options;
  options.compute_tangent = state.range(0) == 1;
  SurfaceContactResult out;
  per_pair(state, [&](const Pair& p) {
    surface_contact(p.a, p.b, warm ? p.warm : SurfaceProjectionStart{}, law, out, options);
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

BENCHMARK(BM_BuildSurfaces);
BENCHMARK(BM_ProjectionCold);
BENCHMARK(BM_ProjectionColdOutOfRange);
BENCHMARK(BM_ProjectionWarm);
BENCHMARK(BM_ContactCold)->ArgName("tangent")->Arg(0)->Arg(1);
BENCHMARK(BM_ContactWarm)->ArgName("tangent")->Arg(0)->Arg(1);

} // namespace

BENCHMARK_MAIN();
