// Broad phase cost per segment on a woven-like layout: update with a full search, and update
// that only checks the motion and keeps the list.

#include "broadphase/candidate_search.hpp"

#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <chrono>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <vector>

namespace {

using yarnsim::broadphase::CandidateSearch;
using yarnsim::broadphase::CandidateSearchOptions;
using yarnsim::broadphase::SegmentInfo;

constexpr double spacing = 1.0e-3;    ///< metres between neighbouring yarns
constexpr double radius = 0.28e-3;    ///< metres, section radius
constexpr double amplitude = 0.28e-3; ///< metres, undulation: crossing yarns 2 * radius apart
constexpr int segments_per_cell = 4;  ///< segment length spacing / 4

/// An n x n plain weave: n warp yarns along x (group 0) and n weft yarns along y (group 1), each
/// crossing the fabric's width n * spacing, undulating in z with opposite phase at crossings.
struct Weave {
  std::vector<SegmentInfo> segments;
  std::vector<Eigen::AlignedBox3d> boxes; ///< from 3 points along each segment
  std::vector<double> radius;
};

Weave plain_weave(int n) {
  Weave w;
  const int per_yarn = n * segments_per_cell;
  const double ds = spacing / segments_per_cell;
  auto point = [&](int direction, int yarn, double s) {
    const double sign = (yarn % 2 == 0) ? 1.0 : -1.0;
    const double z =
        (direction == 0 ? 1.0 : -1.0) * sign * amplitude * std::cos(std::numbers::pi * s / spacing);
    const double across = yarn * spacing;
    return direction == 0 ? Eigen::Vector3d(s, across, z) : Eigen::Vector3d(across, s, z);
  };
  for (int direction = 0; direction < 2; ++direction) {
    for (int yarn = 0; yarn < n; ++yarn) {
      const int curve = direction * n + yarn;
      for (int i = 0; i < per_yarn; ++i) {
        Eigen::AlignedBox3d box(point(direction, yarn, i * ds));
        box.extend(point(direction, yarn, (i + 0.5) * ds));
        box.extend(point(direction, yarn, (i + 1) * ds));
        w.segments.push_back({curve, i, direction});
        w.boxes.push_back(box);
        w.radius.push_back(radius);
      }
    }
  }
  return w;
}

std::vector<Eigen::AlignedBox3d> shifted(const std::vector<Eigen::AlignedBox3d>& boxes,
                                         const Eigen::Vector3d& t) {
  std::vector<Eigen::AlignedBox3d> out(boxes);
  for (auto& b : out) {
    b = Eigen::AlignedBox3d(b.min() + t, b.max() + t);
  }
  return out;
}

const CandidateSearchOptions options{.margin = radius, .same_curve_skip = 1, .self_contact = false};

/// Args: approximate number of segments, threads.
void run(benchmark::State& state, bool search) {
  const int n = static_cast<int>(std::lround(std::sqrt(state.range(0) / 8.0)));
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, state.range(1));
  const Weave w = plain_weave(n);
  const auto count = static_cast<double>(w.segments.size());
  // Two configurations a small motion apart (a tenth of the refresh threshold).
  const double step = 0.1 * options.refresh_fraction * options.margin;
  const auto a = shifted(w.boxes, Eigen::Vector3d(step, -step, 0.5 * step));
  const auto& b = w.boxes;
  CandidateSearch cs(w.segments, {{0, 1}}, options);
  cs.update(b, w.radius);

  double seconds = 0.0;
  bool flip = false;
  for (auto _ : state) {
    flip = !flip;
    const auto start = std::chrono::steady_clock::now();
    const bool searched = cs.update(flip ? a : b, w.radius, /*force=*/search);
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (searched != search) {
      state.SkipWithError("unexpected search decision");
      break;
    }
    benchmark::DoNotOptimize(cs.candidates().data());
  }
  state.counters["segments"] = count;
  state.counters["pairs_per_seg"] = cs.candidates().size() / count;
  state.counters["ns_per_seg"] = 1e9 * seconds / (static_cast<double>(state.iterations()) * count);
}

void BM_UpdateAndSearch(benchmark::State& state) {
  run(state, true);
}
void BM_UpdateRefitOnly(benchmark::State& state) {
  run(state, false);
}

BENCHMARK(BM_UpdateAndSearch)
    ->ArgsProduct({{1000, 10000, 100000}, {1, 2}})
    ->ArgNames({"segments", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_UpdateRefitOnly)
    ->ArgsProduct({{1000, 10000, 100000}, {1, 2}})
    ->ArgNames({"segments", "threads"})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();

} // namespace

BENCHMARK_MAIN();
