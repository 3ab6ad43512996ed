#include "engine/textile/weave_geometry.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <numbers>
#include <stdexcept>
#include <string>

namespace yarnsim::textile {

void check_yarn_parameters(const WeaveParameters& p, std::string_view what) {
  auto fail = [&](const std::string& message) {
    throw std::invalid_argument(fmt::format("{}: {}", what, message));
  };
  if (p.pattern.size() == 0)
    fail("expected a non-empty pattern");
  for (Eigen::Index i = 0; i < p.pattern.rows(); ++i)
    for (Eigen::Index j = 0; j < p.pattern.cols(); ++j)
      if (p.pattern(i, j) != 0 && p.pattern(i, j) != 1)
        fail(fmt::format("expected pattern entries 0 or 1, found {} at ({}, {})", p.pattern(i, j),
                         i, j));
  for (auto [name, v] : {std::pair{"spacing_warp", p.spacing_warp},
                         {"spacing_weft", p.spacing_weft},
                         {"a", p.a},
                         {"b", p.b}})
    if (!(v > 0) || !std::isfinite(v))
      fail(fmt::format("expected {} > 0, found {}", name, v));
  if (!(p.gap >= 0) || !std::isfinite(p.gap))
    fail(fmt::format("expected gap >= 0, found {}", p.gap));
  if (!(p.contact_radius >= 0) || !std::isfinite(p.contact_radius))
    fail(fmt::format("expected contact_radius >= 0, found {}", p.contact_radius));
  if (p.elements_per_spacing < 1)
    fail(fmt::format("expected elements_per_spacing >= 1, found {}", p.elements_per_spacing));
}

void add_yarn_section(Model& model, const WeaveParameters& p) {
  model.materials.push_back(p.material.resolve(std::numbers::pi * p.a * p.b, "yarn"));
  model.sections.push_back(ellipse_yarn_section("yarn", p.a, p.b, p.material,
                                                p.reduce_lower_inertia, p.shear_factor,
                                                p.reduce_upper_inertia));
}

std::vector<ProfilePoint> crimped_profile(double s_start, double s_end,
                                          const std::vector<double>& crossings,
                                          const std::vector<double>& z, double spacing,
                                          int per_spacing) {
  std::vector<ProfilePoint> out;
  // A straight part of `elements` elements from s0 to s1 (the point at s1 placed exactly).
  auto straight = [&](double s0, double s1, double height, bool include_first) {
    const int elements =
        std::max(1, static_cast<int>(std::lround((s1 - s0) / spacing * per_spacing)));
    for (int k = include_first ? 0 : 1; k <= 2 * elements; ++k) {
      const double t = static_cast<double>(k) / (2 * elements);
      out.push_back({k == 2 * elements ? s1 : (1 - t) * s0 + t * s1, height});
    }
  };
  if (s_start < crossings.front())
    straight(s_start, crossings.front(), z.front(), true);
  else
    out.push_back({crossings.front(), z.front()});
  for (std::size_t k = 0; k + 1 < crossings.size(); ++k) {
    const double s0 = crossings[k];
    const double s1 = crossings[k + 1];
    // Neighbouring crossings are one spacing apart (wider intervals get as many elements per
    // spacing): points at s0 + t k spacing, which for one spacing is s0 + t spacing exactly.
    const int spacings = std::max(1, static_cast<int>(std::lround((s1 - s0) / spacing)));
    const int elements = per_spacing * spacings;
    const double span = spacings * spacing;
    for (int i = 1; i <= 2 * elements; ++i) {
      const double t = static_cast<double>(i) / (2 * elements);
      const double w = t * t * (3 - 2 * t); // cubic Hermite, zero slope at both crossings
      out.push_back(i == 2 * elements ? ProfilePoint{s1, z[k + 1]}
                                      : ProfilePoint{s0 + t * span, z[k] + (z[k + 1] - z[k]) * w});
    }
  }
  if (s_end > crossings.back())
    straight(crossings.back(), s_end, z.back(), false);
  return out;
}

} // namespace yarnsim::textile
