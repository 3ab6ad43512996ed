#include "engine/textile/weave.hpp"

#include "engine/textile/weave_geometry.hpp"

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
  check_yarn_parameters(p, "weave");
  if (p.n_warp < 1 || p.n_weft < 1)
    fail(fmt::format("expected at least one yarn per direction, found {} warp and {} weft",
                     p.n_warp, p.n_weft));
  for (auto [name, v] : {std::pair{"length_warp", p.length_warp}, {"length_weft", p.length_weft}})
    if (!(v > 0) || !std::isfinite(v))
      fail(fmt::format("expected {} > 0, found {}", name, v));
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
/// s_j = (j - (n - 1)/2) spacing with heights z_j, crimped_profile between them and straight
/// beyond (none when the yarn ends at its outer crossings). Returns (s, z) of the 2 m + 1 nodes.
std::vector<Eigen::Vector2d> yarn_profile(double length, double spacing,
                                          const std::vector<double>& z, int per_spacing) {
  const int n = static_cast<int>(z.size());
  // The same expression as the crossing yarn's coordinate, so both meet exactly.
  std::vector<double> crossings;
  for (int j = 0; j < n; ++j)
    crossings.push_back((j - (n - 1) / 2.0) * spacing);
  const double last = crossings.back();
  const double end = std::max(length / 2, last);
  const bool overhang = end - last > 1e-9 * spacing;
  if (n == 1 && !overhang) // a single crossing and no overhang: one straight element of one spacing
    return {{-spacing / 2, z.front()}, {0, z.front()}, {spacing / 2, z.front()}};
  std::vector<Eigen::Vector2d> out;
  for (const ProfilePoint& q :
       crimped_profile(overhang ? -end : crossings.front(), overhang ? end : last, crossings, z,
                       spacing, per_spacing))
    out.emplace_back(q.s, q.z);
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
  add_yarn_section(model, p);
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
