#pragma once
// Signal analysis shared by the dynamic verification tests: the tip history of a free vibration
// and the frequency of a spectral peak.
#include "engine/solver/simulation.hpp"

#include <cmath>
#include <numbers>
#include <vector>

namespace yarnsim::test {

/// Records the y coordinate of one node at every reported increment.
struct TipRecorder : SimulationObserver {
  int node;
  std::vector<double> t, y;
  explicit TipRecorder(int n) : node(n) {}
  void on_increment(const Simulation& s, const IncrementReport& r) override {
    t.push_back(r.time);
    y.push_back(s.state().x_n(1, node));
  }
};

/// Frequency (rad/s) of the largest peak of the Hann-windowed spectrum of a uniformly sampled
/// signal within [lo, hi], refined by golden-section search on |X(omega)|.
inline double spectral_peak(const std::vector<double>& t, const std::vector<double>& y, double lo,
                            double hi) {
  const std::size_t n = y.size();
  double mean = 0;
  for (double v : y)
    mean += v / n;
  auto power = [&](double w) {
    double re = 0, im = 0;
    for (std::size_t k = 0; k < n; ++k) {
      const double hann = 0.5 - 0.5 * std::cos(2 * std::numbers::pi * k / (n - 1));
      re += hann * (y[k] - mean) * std::cos(w * t[k]);
      im += hann * (y[k] - mean) * std::sin(w * t[k]);
    }
    return re * re + im * im;
  };
  // Coarse scan, then golden section around the best sample.
  double best = lo, best_p = -1;
  const int samples = 400;
  for (int i = 0; i <= samples; ++i) {
    const double w = lo + (hi - lo) * i / samples;
    const double p = power(w);
    if (p > best_p) {
      best_p = p;
      best = w;
    }
  }
  double a = best - (hi - lo) / samples, b = best + (hi - lo) / samples;
  const double g = (std::sqrt(5.0) - 1) / 2;
  for (int it = 0; it < 60; ++it) {
    const double c = b - g * (b - a), d = a + g * (b - a);
    if (power(c) > power(d))
      b = d;
    else
      a = c;
  }
  return 0.5 * (a + b);
}

} // namespace yarnsim::test
