#include "engine/textile/weave.hpp"

#include <cmath>
#include <fmt/format.h>
#include <numbers>
#include <stdexcept>

namespace yarnsim::textile {

Eigen::MatrixXi plain_pattern() {
  Eigen::MatrixXi p(2, 2);
  p << 1, 0, 0, 1;
  return p;
}

Eigen::MatrixXi twill_pattern(int over, int under) {
  if (over < 1 || under < 1)
    throw std::invalid_argument(
        fmt::format("twill: expected over >= 1 and under >= 1, found {} and {}", over, under));
  const int n = over + under;
  Eigen::MatrixXi p(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      p(i, j) = ((j - i) % n + n) % n < over ? 1 : 0;
  return p;
}

Eigen::MatrixXi basket_pattern(int n) {
  if (n < 1)
    throw std::invalid_argument(fmt::format("basket: expected a group size >= 1, found {}", n));
  Eigen::MatrixXi p(2 * n, 2 * n);
  for (int i = 0; i < 2 * n; ++i)
    for (int j = 0; j < 2 * n; ++j)
      p(i, j) = (i / n + j / n) % 2 == 0 ? 1 : 0;
  return p;
}

WeaveParameters paper_fabric() {
  WeaveParameters p;
  p.pattern = plain_pattern();
  p.n_warp = p.n_weft = 6;
  p.spacing_warp = p.spacing_weft = 4.54545e-3;
  p.length_warp = p.length_weft = 40.90909e-3;
  p.gap = 0.11364e-3;
  p.a = 1.136364e-3;
  p.b = 0.2840909e-3;
  p.contact_radius = 0.2840909e-3;
  p.material.EA = 38000;
  p.material.poisson = 0.2;
  p.material.density = 2540;
  p.reduce_lower_inertia = 0.1;
  p.elements_per_spacing = 4;
  p.contact_law = {1.5e6, 1.0, 0.0};
  return p;
}

namespace {

void check(const WeaveParameters& p) {
  auto fail = [](const std::string& message) { throw std::invalid_argument("weave: " + message); };
  if (p.pattern.size() == 0)
    fail("expected a non-empty pattern");
  for (Eigen::Index i = 0; i < p.pattern.rows(); ++i)
    for (Eigen::Index j = 0; j < p.pattern.cols(); ++j)
      if (p.pattern(i, j) != 0 && p.pattern(i, j) != 1)
        fail(fmt::format("expected pattern entries 0 or 1, found {} at ({}, {})", p.pattern(i, j),
                         i, j));
  if (p.n_warp < 1 || p.n_weft < 1)
    fail(fmt::format("expected at least one yarn per direction, found {} warp and {} weft",
                     p.n_warp, p.n_weft));
  for (auto [name, v] : {std::pair{"spacing_warp", p.spacing_warp},
                         {"spacing_weft", p.spacing_weft},
                         {"length_warp", p.length_warp},
                         {"length_weft", p.length_weft},
                         {"a", p.a},
                         {"b", p.b}})
    if (!(v > 0) || !std::isfinite(v))
      fail(fmt::format("expected {} > 0, found {}", name, v));
  if (!(p.gap >= 0) || !std::isfinite(p.gap))
    fail(fmt::format("expected gap >= 0, found {}", p.gap));
  if (!(p.contact_radius >= 0))
    fail(fmt::format("expected contact_radius >= 0, found {}", p.contact_radius));
  if (p.elements_per_spacing < 1)
    fail(fmt::format("expected elements_per_spacing >= 1, found {}", p.elements_per_spacing));
  const double tol = 1e-9;
  if (p.length_warp < (p.n_weft - 1) * p.spacing_weft * (1 - tol))
    fail(fmt::format("expected length_warp >= (n_weft - 1) spacing_weft = {} (a warp yarn must "
                     "reach its outer crossings), found {}",
                     (p.n_weft - 1) * p.spacing_weft, p.length_warp));
  if (p.length_weft < (p.n_warp - 1) * p.spacing_warp * (1 - tol))
    fail(fmt::format("expected length_weft >= (n_warp - 1) spacing_warp = {}, found {}",
                     (p.n_warp - 1) * p.spacing_warp, p.length_weft));
}

/// Points along one yarn: in-plane coordinate s from -length/2 to length/2, crossings at
/// s_j = (j - (n - 1)/2) spacing with heights z_j, Hermite between crossings, straight beyond.
/// Returns (s, z) of the 2 m + 1 nodes.
std::vector<Eigen::Vector2d> yarn_profile(double length, double spacing,
                                          const std::vector<double>& z, int per_spacing) {
  const int n = static_cast<int>(z.size());
  // The same expression as the crossing yarn's coordinate, so both meet exactly.
  auto crossing = [&](int j) { return (j - (n - 1) / 2.0) * spacing; };
  const double first = crossing(0);
  const double last = crossing(n - 1);
  const double end = std::max(length / 2, last);
  const double overhang = end - last;
  // Elements of a straight end: as many per spacing as between crossings, at least one, none when
  // the yarn ends at its outer crossing.
  const int end_elements =
      overhang <= 1e-9 * spacing
          ? 0
          : std::max(1, static_cast<int>(std::lround(overhang / spacing * per_spacing)));

  std::vector<Eigen::Vector2d> out;
  auto straight = [&](double s0, double s1, double height, bool include_first) {
    for (int k = include_first ? 0 : 1; k <= 2 * end_elements; ++k) {
      const double t = static_cast<double>(k) / (2 * end_elements);
      out.emplace_back((1 - t) * s0 + t * s1, height);
    }
  };
  if (end_elements > 0)
    straight(-end, first, z.front(), true);
  else
    out.emplace_back(first, z.front());
  for (int j = 0; j + 1 < n; ++j) {
    const double s0 = crossing(j);
    for (int k = 1; k <= 2 * per_spacing; ++k) {
      const double t = static_cast<double>(k) / (2 * per_spacing);
      const double w = t * t * (3 - 2 * t); // cubic Hermite, zero slope at both crossings
      // The last point of an interval is the next crossing itself: place it exactly.
      const double s = k == 2 * per_spacing ? crossing(j + 1) : s0 + t * spacing;
      out.emplace_back(
          s, k == 2 * per_spacing
                 ? z[static_cast<std::size_t>(j + 1)]
                 : z[static_cast<std::size_t>(j)] +
                       (z[static_cast<std::size_t>(j + 1)] - z[static_cast<std::size_t>(j)]) * w);
    }
  }
  if (end_elements > 0)
    straight(last, end, z.back(), false);
  if (out.size() < 3) // a single crossing and no overhang: one straight element of one spacing
    out = {{-spacing / 2, z.front()}, {0, z.front()}, {spacing / 2, z.front()}};
  return out;
}

} // namespace

double warp_height(const WeaveParameters& p, int i, int j) {
  const double h = 2 * p.b + p.gap;
  const int on_top = p.pattern(i % p.pattern.rows(), j % p.pattern.cols());
  return on_top != 0 ? h / 2 : -h / 2;
}

Fabric build_weave(const WeaveParameters& p) {
  check(p);
  Fabric fabric;
  Model& model = fabric.model;
  model.title = fmt::format("woven fabric, {} warp x {} weft yarns", p.n_warp, p.n_weft);
  const Section section =
      ellipse_yarn_section("yarn", p.a, p.b, p.material, p.reduce_lower_inertia, p.shear_factor);
  model.materials.push_back(p.material.resolve(std::numbers::pi * p.a * p.b, "yarn"));
  model.sections.push_back(section);
  const std::vector<Eigen::Vector3d> up{Eigen::Vector3d::UnitZ()};

  for (int i = 0; i < p.n_warp; ++i) {
    const double y = (i - (p.n_warp - 1) / 2.0) * p.spacing_warp;
    std::vector<double> z;
    for (int j = 0; j < p.n_weft; ++j)
      z.push_back(warp_height(p, i, j));
    std::vector<Eigen::Vector3d> points;
    for (const auto& sz : yarn_profile(p.length_warp, p.spacing_weft, z, p.elements_per_spacing))
      points.emplace_back(sz.x(), y, sz.y());
    append_yarn(fabric, true, points, 0, up);
  }
  for (int j = 0; j < p.n_weft; ++j) {
    const double x = (j - (p.n_weft - 1) / 2.0) * p.spacing_weft;
    std::vector<double> z;
    for (int i = 0; i < p.n_warp; ++i)
      z.push_back(-warp_height(p, i, j));
    std::vector<Eigen::Vector3d> points;
    for (const auto& sz : yarn_profile(p.length_weft, p.spacing_warp, z, p.elements_per_spacing))
      points.emplace_back(x, sz.x(), sz.y());
    append_yarn(fabric, false, points, 0, up);
  }
  const double r = p.contact_radius > 0 ? p.contact_radius : p.b;
  const std::vector<double> radii(fabric.yarns.size(), r);
  finish_fabric(fabric, radii, p.contact_law, p.contact);
  return fabric;
}

} // namespace yarnsim::textile
