#include "engine/textile/shear_kinematics.hpp"

#include <cmath>
#include <fmt/format.h>
#include <numbers>
#include <stdexcept>

namespace yarnsim::textile {

namespace {
constexpr double kQuarterPi = std::numbers::pi / 4;
constexpr double kSqrt2 = std::numbers::sqrt2;
} // namespace

double picture_frame_angle(double d, double L) {
  if (!(L > 0) || !(d >= -kSqrt2 * L && d <= (2 - kSqrt2) * L))
    throw std::invalid_argument(fmt::format(
        "picture frame: expected L > 0 and -sqrt(2) L <= d <= (2 - sqrt(2)) L, found L = {} m, "
        "d = {} m",
        L, d));
  const double theta = std::acos((kSqrt2 * L + d) / (2 * L));
  return std::numbers::pi / 2 - 2 * theta;
}

double picture_frame_displacement(double gamma, double L) {
  return 2 * L * std::cos(kQuarterPi - gamma / 2) - kSqrt2 * L;
}

double picture_frame_shear_force(double F, double gamma) {
  return F / (2 * std::cos(kQuarterPi - gamma / 2));
}

double picture_frame_normalised_force(double F, double gamma, double L_frame, double L_fabric) {
  return picture_frame_shear_force(F, gamma) * L_frame / (L_fabric * L_fabric);
}

double bias_extension_angle(double d, double H, double W) {
  if (!(W > 0 && H > W) || !(d >= 0 && d <= (kSqrt2 - 1) * (H - W) * (1 + 1e-12)))
    throw std::invalid_argument(fmt::format(
        "bias extension: expected H > W > 0 and 0 <= d <= (sqrt(2) - 1) (H - W), found H = {} m, "
        "W = {} m, d = {} m",
        H, W, d));
  const double c = std::min(1.0, (H - W + d) / (kSqrt2 * (H - W)));
  return std::numbers::pi / 2 - 2 * std::acos(c);
}

double bias_extension_displacement(double gamma, double H, double W) {
  return kSqrt2 * (H - W) * std::cos(kQuarterPi - gamma / 2) - (H - W);
}

std::vector<double> bias_extension_normalised_force(std::span<const double> gamma,
                                                    std::span<const double> F, double H, double W) {
  if (!bias_extension_zones_fit(H, W) || gamma.size() != F.size())
    throw std::invalid_argument(fmt::format(
        "bias extension: expected H >= 2 W > 0 and as many forces as angles, found H = {} m, "
        "W = {} m, {} angles, {} forces",
        H, W, gamma.size(), F.size()));
  for (std::size_t i = 0; i < gamma.size(); ++i)
    if (!(gamma[i] >= 0) || (i > 0 && !(gamma[i] > gamma[i - 1])))
      throw std::invalid_argument(fmt::format(
          "bias extension: expected angles >= 0 and increasing, found {} rad at sample {}",
          gamma[i], i));
  std::vector<double> out(gamma.size());
  if (gamma.empty())
    return out;
  // March in gamma. F_sh(gamma_i / 2) is interpolated linearly in the values known: (0, F_sh(0))
  // with F_sh(0) = F(0) / (2 W) (the formula's fixed point), then the samples below. Where
  // gamma_i / 2 lies above the last known sample, the interpolation runs to the unknown
  // F_sh(gamma_i) itself, and the formula, linear in it, is solved for it.
  for (std::size_t i = 0; i < gamma.size(); ++i) {
    const double g = gamma[i];
    if (g == 0) {
      out[i] = F[i] / (2 * W);
      continue;
    }
    const double half = g / 2;
    double g0 = 0, v0 = F[0] / (2 * W);
    if (gamma[0] == 0)
      v0 = out[0];
    double t = -1; // the interpolation's weight on the unknown, or -1 when F_sh(g/2) is known
    double known = 0;
    std::size_t j = 0;
    while (j < i && gamma[j] <= half) {
      g0 = gamma[j];
      v0 = out[j];
      ++j;
    }
    if (j < i) {
      known = v0 + (half - g0) / (gamma[j] - g0) * (out[j] - v0);
    } else {
      t = (half - g0) / (g - g0);
    }
    const double a = (H / W - 1) * F[i] * (std::cos(g / 2) - std::sin(g / 2));
    const double b = (2 * H - 3 * W) * std::cos(g);
    const double c = W * std::cos(g / 2);
    out[i] = t < 0 ? (a - c * known) / b : (a - c * (1 - t) * v0) / (b + c * t);
  }
  return out;
}

double locking_angle(double w, double p) {
  if (!(w > 0 && w < p))
    throw std::invalid_argument(
        fmt::format("locking angle: expected 0 < w < p, found w = {} m, p = {} m", w, p));
  return std::acos(w / p);
}

} // namespace yarnsim::textile
