#include "engine/textile/specimen.hpp"

#include "engine/textile/weave_geometry.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

namespace yarnsim::textile {

namespace {

void check(const BiasSpecimenParameters& p) {
  auto fail = [](const std::string& message) {
    throw std::invalid_argument("bias specimen: " + message);
  };
  const WeaveParameters& w = p.weave;
  check_yarn_parameters(w, "bias specimen");
  const double spacing = std::max(w.spacing_warp, w.spacing_weft);
  if (!(p.height >= 2 * spacing) || !std::isfinite(p.height))
    fail(
        fmt::format("expected a height H >= 2 spacings = {} m, found {} m", 2 * spacing, p.height));
  if (!(p.width >= 2 * spacing) || !std::isfinite(p.width))
    fail(fmt::format("expected a width W >= 2 spacings = {} m, found {} m", 2 * spacing, p.width));
  if (!(p.angle > 0 && p.angle < 90))
    fail(fmt::format("expected an angle in (0, 90) degrees, found {}", p.angle));
  if (!(p.clamp_length >= 0) || !std::isfinite(p.clamp_length))
    fail(fmt::format("expected clamp_length >= 0, found {} m", p.clamp_length));
  if (!(2 * p.clamp_length < p.height))
    fail(fmt::format("expected 2 clamp_length < H = {} m (the clamps must leave a free length), "
                     "found clamp_length {} m",
                     p.height, p.clamp_length));
}

/// Sides of the rectangle, as bits: an end at a corner is on two.
enum Side : unsigned { kLeft = 1, kRight = 2, kBottom = 4, kTop = 8 };

/// Where a line leaves the rectangle |x| <= hw, |y| <= hh: the line is o + t d (d a unit vector
/// with both components non-zero); returns the parameters t_in <= t_out of entry and exit and the
/// sides of each (slab clipping). t_in > t_out when the line misses the rectangle.
struct Clip {
  double t_in = -std::numeric_limits<double>::infinity();
  double t_out = std::numeric_limits<double>::infinity();
  unsigned side_in = 0;
  unsigned side_out = 0;
};

Clip clip(const Eigen::Vector2d& o, const Eigen::Vector2d& d, double hw, double hh, double tol) {
  Clip c;
  const std::array<double, 2> half{hw, hh};
  const std::array<unsigned, 2> low{kLeft, kBottom};
  const std::array<unsigned, 2> high{kRight, kTop};
  std::array<double, 2> enter{}, leave{};
  std::array<unsigned, 2> enter_side{}, leave_side{};
  for (int k = 0; k < 2; ++k) {
    const double t_low = (-half[k] - o(k)) / d(k);
    const double t_high = (half[k] - o(k)) / d(k);
    enter[k] = std::min(t_low, t_high);
    leave[k] = std::max(t_low, t_high);
    enter_side[k] = d(k) > 0 ? low[k] : high[k];
    leave_side[k] = d(k) > 0 ? high[k] : low[k];
  }
  c.t_in = std::max(enter[0], enter[1]);
  c.t_out = std::min(leave[0], leave[1]);
  for (int k = 0; k < 2; ++k) {
    if (enter[k] >= c.t_in - tol)
      c.side_in |= enter_side[k];
    if (leave[k] <= c.t_out + tol)
      c.side_out |= leave_side[k];
  }
  return c;
}

} // namespace

Fabric build_bias_specimen(const BiasSpecimenParameters& p) {
  check(p);
  const WeaveParameters& w = p.weave;
  const double hw = p.width / 2;
  const double hh = p.height / 2;
  const double theta = p.angle * std::numbers::pi / 180;
  const Eigen::Vector2d eu(std::cos(theta), std::sin(theta));  // along the warp
  const Eigen::Vector2d ev(-std::sin(theta), std::cos(theta)); // along the weft
  const double tol = 1e-9 * std::min(w.spacing_warp, w.spacing_weft);
  // Crossings inside to round-off: a node may lie outside by this, 1e-13 of the specimen's size.
  const double tol_inside = 1e-13 * std::max(p.width, p.height);

  // In-plane position of the weave frame's point (u, v). Every node at a crossing comes from
  // point(u_of(a), v_of(b)), so a warp node and a weft node there agree bit for bit.
  auto u_of = [&](int a) { return a * w.spacing_weft; };
  auto v_of = [&](int b) { return b * w.spacing_warp; };
  auto point = [&](double u, double v) -> Eigen::Vector2d { return u * eu + v * ev; };
  auto inside = [&](int a, int b) {
    const Eigen::Vector2d x = point(u_of(a), v_of(b));
    return std::abs(x.x()) <= hw + tol_inside && std::abs(x.y()) <= hh + tol_inside;
  };

  // Grid lines that may cross the rectangle: |u| <= u_max, |v| <= v_max over its corners.
  const double u_max = hw * std::abs(eu.x()) + hh * std::abs(eu.y());
  const double v_max = hw * std::abs(ev.x()) + hh * std::abs(ev.y());
  const int na = static_cast<int>(std::floor(u_max / w.spacing_weft)) + 1;
  const int nb = static_cast<int>(std::floor(v_max / w.spacing_warp)) + 1;
  // Weft a in [-na, na] (index a + na), warp b in [-nb, nb].
  const int size_a = 2 * na + 1;
  const int size_b = 2 * nb + 1;
  std::vector<char> in(static_cast<std::size_t>(size_a * size_b));
  auto at = [&](int a, int b) { return static_cast<std::size_t>((a + na) * size_b + (b + nb)); };
  for (int a = -na; a <= na; ++a)
    for (int b = -nb; b <= nb; ++b)
      in[at(a, b)] = inside(a, b) ? 1 : 0;

  // Drop the yarns with fewer than 2 crossings with kept yarns, all at once per round (so the
  // result keeps the rectangle's symmetries), until none is left to drop.
  std::vector<char> keep_a(static_cast<std::size_t>(size_a), 1);
  std::vector<char> keep_b(static_cast<std::size_t>(size_b), 1);
  for (bool changed = true; changed;) {
    changed = false;
    std::vector<int> count_a(static_cast<std::size_t>(size_a), 0);
    std::vector<int> count_b(static_cast<std::size_t>(size_b), 0);
    for (int a = -na; a <= na; ++a)
      for (int b = -nb; b <= nb; ++b)
        if (in[at(a, b)] && keep_a[static_cast<std::size_t>(a + na)] &&
            keep_b[static_cast<std::size_t>(b + nb)]) {
          ++count_a[static_cast<std::size_t>(a + na)];
          ++count_b[static_cast<std::size_t>(b + nb)];
        }
    for (int k = 0; k < size_a; ++k)
      if (keep_a[static_cast<std::size_t>(k)] && count_a[static_cast<std::size_t>(k)] < 2) {
        keep_a[static_cast<std::size_t>(k)] = 0;
        changed = true;
      }
    for (int k = 0; k < size_b; ++k)
      if (keep_b[static_cast<std::size_t>(k)] && count_b[static_cast<std::size_t>(k)] < 2) {
        keep_b[static_cast<std::size_t>(k)] = 0;
        changed = true;
      }
  }
  std::vector<int> warp_b, weft_a; // the kept grid lines, in increasing v and u
  for (int b = -nb; b <= nb; ++b)
    if (keep_b[static_cast<std::size_t>(b + nb)])
      warp_b.push_back(b);
  for (int a = -na; a <= na; ++a)
    if (keep_a[static_cast<std::size_t>(a + na)])
      weft_a.push_back(a);
  if (warp_b.empty() || weft_a.empty())
    throw std::invalid_argument(fmt::format(
        "bias specimen: expected warp and weft yarns crossing at least twice in the {} x {} m "
        "rectangle, found {} warp and {} weft yarns",
        p.height, p.width, warp_b.size(), weft_a.size()));

  Fabric fabric;
  Model& model = fabric.model;
  model.title = fmt::format("bias extension specimen {} x {} mm, yarns at {} degrees, {} warp x {} "
                            "weft yarns",
                            p.height * 1e3, p.width * 1e3, p.angle, warp_b.size(), weft_a.size());
  add_yarn_section(model, w);
  const std::vector<Eigen::Vector3d> up{Eigen::Vector3d::UnitZ()};

  // The yarn ends and their sides, for the clamp and edge sets.
  std::vector<std::pair<int, unsigned>> ends;

  // One yarn along the grid line `line` (b for warp, a for weft); `others` are the kept lines
  // of the other direction.
  auto add_yarn = [&](bool warp, int rank, int line, const std::vector<int>& others) {
    const double spacing = warp ? w.spacing_weft : w.spacing_warp; // between its crossings
    std::vector<double> s, z;
    for (std::size_t k = 0; k < others.size(); ++k) {
      const int a = warp ? others[k] : line;
      const int b = warp ? line : others[k];
      if (!in[at(a, b)])
        continue;
      s.push_back(warp ? u_of(a) : v_of(b));
      const double zw =
          warp_height(w, warp ? rank : static_cast<int>(k), warp ? static_cast<int>(k) : rank);
      z.push_back(warp ? zw : -zw);
    }
    const double offset = warp ? v_of(line) : u_of(line);
    const Clip c =
        warp ? clip(point(0, offset), eu, hw, hh, tol) : clip(point(offset, 0), ev, hw, hh, tol);
    // End at the outer crossing when the boundary is less than the fraction of a spacing beyond.
    const double short_end = kBiasShortEndFraction * spacing;
    const double s_start = s.front() - c.t_in < short_end ? s.front() : c.t_in;
    const double s_end = c.t_out - s.back() < short_end ? s.back() : c.t_out;
    std::vector<Eigen::Vector3d> points;
    for (const ProfilePoint& q :
         crimped_profile(s_start, s_end, s, z, spacing, w.elements_per_spacing)) {
      const Eigen::Vector2d x = warp ? point(q.s, offset) : point(offset, q.s);
      points.emplace_back(x.x(), x.y(), q.z);
    }
    // The ends on the boundary: set the boundary coordinate.
    auto snap = [&](Eigen::Vector3d& x, unsigned side) {
      if (side & kLeft)
        x.x() = -hw;
      if (side & kRight)
        x.x() = hw;
      if (side & kBottom)
        x.y() = -hh;
      if (side & kTop)
        x.y() = hh;
    };
    if (s_start == c.t_in)
      snap(points.front(), c.side_in);
    if (s_end == c.t_out)
      snap(points.back(), c.side_out);
    const int y = append_yarn(fabric, warp, points, 0, up);
    const Yarn& yarn = fabric.yarns[static_cast<std::size_t>(y)];
    ends.emplace_back(yarn.nodes.front(), c.side_in);
    ends.emplace_back(yarn.nodes.back(), c.side_out);
  };
  for (std::size_t i = 0; i < warp_b.size(); ++i)
    add_yarn(true, static_cast<int>(i), warp_b[i], weft_a);
  for (std::size_t j = 0; j < weft_a.size(); ++j)
    add_yarn(false, static_cast<int>(j), weft_a[j], warp_b);

  const double r = w.contact_radius > 0 ? w.contact_radius : w.b;
  const std::vector<double> radii(fabric.yarns.size(), r);
  finish_fabric(fabric, radii, w.contact_law, w.contact);

  auto add_set = [&](std::string name, std::vector<int> nodes) {
    std::sort(nodes.begin(), nodes.end());
    nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
    model.node_sets.push_back({std::move(name), std::move(nodes)});
  };
  std::vector<int> bottom, top, left, right;
  for (std::size_t n = 0; n < model.nodes.size(); ++n) {
    const double y = model.nodes[n].y();
    if (y <= -hh + p.clamp_length + tol)
      bottom.push_back(static_cast<int>(n));
    if (y >= hh - p.clamp_length - tol)
      top.push_back(static_cast<int>(n));
  }
  for (const auto& [node, side] : ends) {
    if (side & kBottom)
      bottom.push_back(node);
    if (side & kTop)
      top.push_back(node);
    if (side & kLeft)
      left.push_back(node);
    if (side & kRight)
      right.push_back(node);
  }
  add_set("clamp.bottom", std::move(bottom));
  add_set("clamp.top", std::move(top));
  add_set("edge.left", std::move(left));
  add_set("edge.right", std::move(right));
  return fabric;
}

} // namespace yarnsim::textile
