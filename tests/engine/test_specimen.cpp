// The bias extension specimen builder (engine/textile/specimen.hpp).

#include "engine/textile/specimen.hpp"

#include <Eigen/LU>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <gtest/gtest.h>
#include <iostream>
#include <numbers>
#include <set>
#include <stdexcept>
#include <string>

namespace yarnsim::textile {
namespace {

constexpr double kSpacing = 4.54545e-3; // m, the paper's fabric

/// A specimen of the paper's fabric, W x H in spacings.
BiasSpecimenParameters specimen(double width_spacings, double height_spacings,
                                double clamp_spacings = 0) {
  BiasSpecimenParameters p;
  p.weave = paper_fabric();
  p.width = width_spacings * kSpacing;
  p.height = height_spacings * kSpacing;
  p.clamp_length = clamp_spacings * kSpacing;
  return p;
}

/// Specimens of different kinds: the usual one, odd sizes, another angle with unequal spacings
/// and a twill, a basket.
std::vector<BiasSpecimenParameters> variety() {
  std::vector<BiasSpecimenParameters> out{specimen(20, 40, 3), specimen(10.37, 23.81, 2.5)};
  BiasSpecimenParameters p = specimen(9.6, 21.3, 1);
  p.angle = 30;
  p.weave.spacing_warp = 1.3 * kSpacing;
  p.weave.pattern = twill_pattern(2, 1);
  out.push_back(p);
  p = specimen(12.2, 25.1);
  p.weave.pattern = basket_pattern(2);
  p.weave.elements_per_spacing = 2;
  out.push_back(p);
  return out;
}

std::string describe(const BiasSpecimenParameters& p) {
  return "W = " + std::to_string(p.width / kSpacing) +
         " H = " + std::to_string(p.height / kSpacing) + " spacings, angle " +
         std::to_string(p.angle);
}

const Eigen::Vector3d& node(const Fabric& f, int n) {
  return f.model.nodes[static_cast<std::size_t>(n)];
}

const std::vector<int>& node_set(const Fabric& f, const std::string& name) {
  const int k = f.model.find_node_set(name);
  if (k < 0)
    throw std::runtime_error("no node set " + name);
  return f.model.node_sets[static_cast<std::size_t>(k)].nodes;
}

/// The spacing between the crossings along a yarn.
double spacing_along(const BiasSpecimenParameters& p, const Yarn& y) {
  return y.warp ? p.weave.spacing_weft : p.weave.spacing_warp;
}

/// Distance from an in-plane point inside the rectangle to its nearest side, m.
double to_boundary(const BiasSpecimenParameters& p, const Eigen::Vector3d& x) {
  return std::min(p.width / 2 - std::abs(x.x()), p.height / 2 - std::abs(x.y()));
}

/// The yarn ends (first and last node of every yarn).
std::set<int> yarn_ends(const Fabric& f) {
  std::set<int> out;
  for (const Yarn& y : f.yarns) {
    out.insert(y.nodes.front());
    out.insert(y.nodes.back());
  }
  return out;
}

/// Whether `points` (sorted by x) holds a point within `tol` of q (in-plane only when `planar`).
bool holds(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& q, double tol,
           bool planar) {
  auto it = std::lower_bound(points.begin(), points.end(), q.x() - tol,
                             [](const Eigen::Vector3d& a, double x) { return a.x() < x; });
  for (; it != points.end() && it->x() <= q.x() + tol; ++it)
    if (std::abs(it->y() - q.y()) <= tol && (planar || std::abs(it->z() - q.z()) <= tol))
      return true;
  return false;
}

TEST(BiasSpecimen, EveryNodeLiesInsideAndEveryYarnEndsOnTheBoundary) {
  for (const BiasSpecimenParameters& p : variety()) {
    SCOPED_TRACE(describe(p));
    const Fabric f = build_bias_specimen(p);
    const double hw = p.width / 2, hh = p.height / 2;
    const double tol = 1e-12 * std::max(p.width, p.height);
    for (const Eigen::Vector3d& x : f.model.nodes) {
      EXPECT_LE(std::abs(x.x()), hw + tol);
      EXPECT_LE(std::abs(x.y()), hh + tol);
    }
    int on_boundary = 0, at_crossing = 0;
    for (const Yarn& y : f.yarns)
      for (int n : {y.nodes.front(), y.nodes.back()}) {
        const double d = to_boundary(p, node(f, n));
        if (d <= tol) {
          ++on_boundary;
          // Exactly: the builder sets the boundary coordinate.
          const Eigen::Vector3d& x = node(f, n);
          EXPECT_TRUE(std::abs(x.x()) == hw || std::abs(x.y()) == hh)
              << yarn_name(y) << " ends at " << x.transpose();
          continue;
        }
        // Else the yarn ends at its outer crossing, less than the short-end fraction of a spacing
        // (along the yarn, so at most as much across) from the boundary.
        ++at_crossing;
        EXPECT_LT(d, kBiasShortEndFraction * spacing_along(p, y)) << yarn_name(y);
      }
    EXPECT_GT(on_boundary, 0);
    EXPECT_LE(at_crossing, on_boundary / 5); // the exception, not the rule
  }
}

TEST(BiasSpecimen, WarpAndWeftMeetAtEveryCrossingAtThePatternsHeights) {
  for (const BiasSpecimenParameters& p : variety()) {
    SCOPED_TRACE(describe(p));
    const Fabric f = build_bias_specimen(p);
    const double h = 2 * p.weave.b + p.weave.gap;
    const double s = std::min(p.weave.spacing_warp, p.weave.spacing_weft);
    const Eigen::MatrixXi& pattern = p.weave.pattern;
    int crossings = 0;
    for (const Yarn& warp : f.yarns) {
      if (!warp.warp)
        continue;
      const Eigen::Vector2d a0 = node(f, warp.nodes.front()).head<2>();
      const Eigen::Vector2d da = node(f, warp.nodes.back()).head<2>() - a0;
      for (const Yarn& weft : f.yarns) {
        if (weft.warp)
          continue;
        // Where the in-plane centre lines meet: a0 + t da = b0 + r db.
        const Eigen::Vector2d b0 = node(f, weft.nodes.front()).head<2>();
        const Eigen::Vector2d db = node(f, weft.nodes.back()).head<2>() - b0;
        Eigen::Matrix2d m;
        m << da, -db;
        const Eigen::Vector2d tr = m.inverse() * (b0 - a0);
        const Eigen::Vector2d c = a0 + tr(0) * da;
        if (std::abs(c.x()) > p.width / 2 - 1e-9 * s || std::abs(c.y()) > p.height / 2 - 1e-9 * s)
          continue; // outside, or on the boundary to round-off: left to the builder
        // Inside the rectangle, so within both yarns (a yarn ends at the boundary or at its outer
        // crossing).
        EXPECT_GE(tr(0), -1e-12);
        EXPECT_LE(tr(0), 1 + 1e-12);
        ++crossings;
        auto at = [&](const Yarn& y) {
          for (int n : y.nodes)
            if ((node(f, n).head<2>() - c).norm() < 1e-12 * s)
              return n;
          return -1;
        };
        const int na = at(warp), nb = at(weft);
        ASSERT_GE(na, 0) << yarn_name(warp) << " x " << yarn_name(weft);
        ASSERT_GE(nb, 0) << yarn_name(warp) << " x " << yarn_name(weft);
        // The same in-plane point bit for bit: both come from the same grid point.
        EXPECT_EQ(node(f, na).x(), node(f, nb).x());
        EXPECT_EQ(node(f, na).y(), node(f, nb).y());
        const bool on_top = pattern(warp.index % pattern.rows(), weft.index % pattern.cols()) == 1;
        EXPECT_EQ(node(f, na).z(), on_top ? h / 2 : -h / 2)
            << yarn_name(warp) << " x " << yarn_name(weft);
        EXPECT_EQ(node(f, nb).z(), -node(f, na).z());
      }
    }
    // Every crossing was found: the nodes of a warp and a weft yarn at one in-plane point.
    std::vector<Eigen::Vector3d> weft_nodes;
    for (const Yarn& y : f.yarns)
      if (!y.warp)
        for (int n : y.nodes)
          weft_nodes.push_back(node(f, n));
    std::sort(weft_nodes.begin(), weft_nodes.end(),
              [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return a.x() < b.x(); });
    int shared = 0;
    for (const Yarn& y : f.yarns)
      if (y.warp)
        for (int n : y.nodes)
          shared += holds(weft_nodes, node(f, n), 1e-12 * s, true);
    EXPECT_GT(crossings, 100);
    // Crossings on the boundary to round-off are counted by the nodes only.
    EXPECT_GE(shared, crossings);
    EXPECT_LE(shared, crossings + 4);
  }
}

TEST(BiasSpecimen, TheCentreIsACrossing) {
  const Fabric f = build_bias_specimen(specimen(20, 40));
  int at_centre = 0;
  for (const Eigen::Vector3d& x : f.model.nodes)
    at_centre += x.head<2>().norm() < 1e-15;
  EXPECT_EQ(at_centre, 2); // a warp node and a weft node
}

TEST(BiasSpecimen, YarnsRunAtPlusMinusTheAngle) {
  for (const BiasSpecimenParameters& p : variety()) {
    SCOPED_TRACE(describe(p));
    const Fabric f = build_bias_specimen(p);
    const double theta = p.angle * std::numbers::pi / 180;
    const Eigen::Vector2d warp(std::cos(theta), std::sin(theta));
    const Eigen::Vector2d weft(-std::sin(theta), std::cos(theta));
    for (const Yarn& y : f.yarns) {
      const Eigen::Vector2d a = node(f, y.nodes.front()).head<2>();
      const Eigen::Vector2d b = node(f, y.nodes.back()).head<2>();
      const Eigen::Vector2d d = (b - a).normalized();
      EXPECT_NEAR((d - (y.warp ? warp : weft)).norm(), 0, 1e-12) << yarn_name(y);
      // Every node on the straight in-plane line between the ends.
      for (int n : y.nodes) {
        const Eigen::Vector2d r = node(f, n).head<2>() - a;
        EXPECT_NEAR(d.x() * r.y() - d.y() * r.x(), 0, 1e-13 * p.height) << yarn_name(y);
      }
    }
  }
  // The bias specimen: +-45 degrees to the pull, the warp clockwise from y, the weft
  // counter-clockwise.
  const Fabric f = build_bias_specimen(specimen(20, 40));
  for (const Yarn& y : f.yarns) {
    const Eigen::Vector2d d =
        (node(f, y.nodes.back()) - node(f, y.nodes.front())).head<2>().normalized();
    EXPECT_NEAR(d.y(), std::sqrt(0.5), 1e-12);
    EXPECT_NEAR(d.x(), y.warp ? std::sqrt(0.5) : -std::sqrt(0.5), 1e-12);
  }
}

TEST(BiasSpecimen, PlainWeaveIsSymmetricAboutBothAxes) {
  for (const BiasSpecimenParameters& p : {specimen(20, 40), specimen(10.37, 23.81)}) {
    SCOPED_TRACE(describe(p));
    const Fabric f = build_bias_specimen(p);
    std::vector<Eigen::Vector3d> points = f.model.nodes;
    std::sort(points.begin(), points.end(),
              [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return a.x() < b.x(); });
    const double tol = 1e-12 * p.height;
    // The mirrors swap warp and weft: in-plane positions map onto themselves, and for the plain
    // weave the heights too when the mirror turns the fabric over (z -> -z); the half turn
    // about z keeps the heights.
    const std::vector<std::pair<std::string, Eigen::Vector3d>> maps{
        {"x -> -x, z -> -z", {-1, 1, -1}},
        {"y -> -y, z -> -z", {1, -1, -1}},
        {"half turn about z", {-1, -1, 1}}};
    for (const auto& [name, m] : maps) {
      int missing = 0;
      for (const Eigen::Vector3d& x : f.model.nodes)
        missing += !holds(points, x.cwiseProduct(m), tol, false);
      EXPECT_EQ(missing, 0) << name;
    }
    // In-plane only, x -> -x: the same holds without the turn over.
    int missing = 0;
    for (const Eigen::Vector3d& x : f.model.nodes)
      missing += !holds(points, Eigen::Vector3d(-x.x(), x.y(), x.z()), tol, true);
    EXPECT_EQ(missing, 0);
    // The heights alone do not map under the mirror: it is not a symmetry of the 3D fabric.
    int moved = 0;
    for (const Eigen::Vector3d& x : f.model.nodes)
      moved += !holds(points, Eigen::Vector3d(-x.x(), x.y(), x.z()), tol, false);
    EXPECT_GT(moved, 0);
    int warp = 0, weft = 0;
    for (const Yarn& y : f.yarns)
      (y.warp ? warp : weft) += 1;
    EXPECT_EQ(warp, weft);
  }
}

TEST(BiasSpecimen, ClampSetsHoldExactlyTheNodesOfTheClampedZones) {
  for (const BiasSpecimenParameters& p : variety()) {
    SCOPED_TRACE(describe(p));
    const Fabric f = build_bias_specimen(p);
    const double hh = p.height / 2, hw = p.width / 2, c = p.clamp_length;
    // The builder's tolerance (specimen.hpp): 1e-9 of the smaller spacing.
    const double tol = 1e-9 * std::min(p.weave.spacing_warp, p.weave.spacing_weft);
    const std::set<int> ends = yarn_ends(f);
    const double short_end =
        kBiasShortEndFraction * std::max(p.weave.spacing_warp, p.weave.spacing_weft);
    for (const auto& [name, sign] : {std::pair{"clamp.bottom", -1.0}, {"clamp.top", 1.0}}) {
      const std::vector<int>& set = node_set(f, name);
      const std::set<int> members(set.begin(), set.end());
      EXPECT_FALSE(set.empty()) << name;
      for (std::size_t n = 0; n < f.model.nodes.size(); ++n) {
        const double y =
            sign * f.model.nodes[n].y(); // distance beyond the centre, toward the clamp
        const int k = static_cast<int>(n);
        if (y >= hh - c - tol) {
          EXPECT_TRUE(members.contains(k)) << name << " misses node " << n << " at y " << y;
        } else if (members.contains(k)) {
          // Only a yarn end stopped at its outer crossing just short of the clamped edge.
          EXPECT_TRUE(ends.contains(k)) << name << " holds node " << n << " at y " << y;
          EXPECT_GT(y, hh - c - short_end) << name;
        }
      }
    }
    for (const auto& [name, sign] : {std::pair{"edge.left", -1.0}, {"edge.right", 1.0}}) {
      const std::vector<int>& set = node_set(f, name);
      EXPECT_FALSE(set.empty()) << name;
      for (int n : set) {
        EXPECT_TRUE(ends.contains(n)) << name;
        EXPECT_GT(sign * node(f, n).x(), hw - short_end) << name;
      }
      for (int n : ends)
        if (std::abs(sign * node(f, n).x() - hw) <= tol) {
          EXPECT_TRUE(std::binary_search(set.begin(), set.end(), n)) << name << " misses " << n;
        }
    }
    // Every yarn end is held by a clamp or lies on a free edge.
    for (int n : ends) {
      int in = 0;
      for (const char* name : {"clamp.bottom", "clamp.top", "edge.left", "edge.right"}) {
        const std::vector<int>& set = node_set(f, name);
        in += std::binary_search(set.begin(), set.end(), n);
      }
      EXPECT_GE(in, 1) << "yarn end " << n;
    }
  }
}

TEST(BiasSpecimen, WithoutAClampLengthTheClampsHoldTheYarnEndsOnTheClampedEdges) {
  const BiasSpecimenParameters p = specimen(20, 40, 0);
  const Fabric f = build_bias_specimen(p);
  const std::set<int> ends = yarn_ends(f);
  const double hh = p.height / 2;
  for (const auto& [name, sign] : {std::pair{"clamp.bottom", -1.0}, {"clamp.top", 1.0}}) {
    const std::vector<int>& set = node_set(f, name);
    EXPECT_FALSE(set.empty());
    for (int n : set) {
      EXPECT_TRUE(ends.contains(n)) << name;
      EXPECT_GT(sign * node(f, n).y(), hh - kBiasShortEndFraction * kSpacing) << name;
    }
    for (int n : ends)
      if (sign * node(f, n).y() == hh) {
        EXPECT_TRUE(std::binary_search(set.begin(), set.end(), n)) << name << " misses " << n;
      }
  }
  // A 20 x 40 spacing specimen at 45 degrees: the grid lines v = b spacing (warp) meet the left
  // edge x = -10 spacings for v in [-10, 30] / sqrt(2) spacings, b = -7 ... 21, less the corner
  // stub b = 21 (a chord of 0.42 spacing over the corner (-W/2, H/2)): 28 ends, and as many weft
  // ends. The bottom edge: v in [-30, -10] / sqrt(2), b = -21 ... -8 less the stub b = -21: 13
  // ends per direction.
  for (const char* name : {"edge.left", "edge.right"})
    EXPECT_EQ(node_set(f, name).size(), 2u * 28u) << name;
  for (const char* name : {"clamp.bottom", "clamp.top"})
    EXPECT_EQ(node_set(f, name).size(), 2u * 13u) << name;
}

TEST(BiasSpecimen, TwentyByFortySpacingsBuildsWithTheExpectedCounts) {
  // Tests do not depend on timing: the build time is printed (about 1 to 7 ms in Release), not
  // checked.
  const BiasSpecimenParameters p = specimen(20, 40, 2);
  const auto start = std::chrono::steady_clock::now();
  const Fabric f = build_bias_specimen(p);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cout << "[ specimen ] 20 x 40 spacings: " << f.yarns.size() << " yarns, "
            << f.model.elements.size() << " elements, " << f.model.nodes.size()
            << " nodes, built in " << seconds * 1e3 << " ms\n";

  // Yarn length per area: 1 / spacing per direction. Crossings per yarn direction: the area over
  // a spacing squared.
  const double area = p.width * p.height;
  double length = 0;
  int warp = 0, weft = 0;
  std::size_t nodes = 0, elements = 0;
  for (const Yarn& y : f.yarns) {
    (y.warp ? warp : weft) += 1;
    length += (node(f, y.nodes.back()) - node(f, y.nodes.front())).head<2>().norm();
    EXPECT_EQ(y.nodes.size(), 2 * y.elements.size() + 1);
    nodes += y.nodes.size();
    elements += y.elements.size();
  }
  EXPECT_EQ(nodes, f.model.nodes.size());
  EXPECT_EQ(elements, f.model.elements.size());
  EXPECT_NEAR(length, 2 * area / kSpacing, 0.01 * 2 * area / kSpacing);
  // 4 elements per spacing: elements ~ 4 length / spacing.
  EXPECT_NEAR(static_cast<double>(elements), 4 * length / kSpacing, 0.01 * 4 * length / kSpacing);
  std::cout << "[ specimen ] in-plane yarn length " << length / kSpacing << " spacings (2 W H / "
            << "spacing^2 = " << 2 * area / (kSpacing * kSpacing)
            << "), 4 length / spacing = " << 4 * length / kSpacing << " elements\n";
  // Yarns: the grid lines through the rectangle, |v| <= (W + H) / (2 sqrt(2)) = 21.2 spacings
  // (43 lines) per direction, less the two corner stubs (|b| = 21, chords of 0.42 spacing).
  EXPECT_EQ(warp, weft);
  EXPECT_EQ(warp, 41);
  // The count of this build, pinned. 4 length / spacing = 6395: on the regular grid every yarn
  // end at a side has the same leftover beyond its outer crossing (10 sqrt(2) and 20 sqrt(2)
  // spacings less whole ones: 0.14 spacing at the free edges, 0.28 at the clamped ones), each
  // one element, 0.57 and 1.13 elements' worth.
  EXPECT_EQ(elements, 6436u);

  // The fabric's own sets, splines, surfaces and contact come as with build_weave.
  EXPECT_EQ(f.model.splines.size(), f.yarns.size());
  EXPECT_EQ(f.model.surfaces.size(), f.yarns.size());
  ASSERT_EQ(f.model.spline_contacts.size(), 1u);
  EXPECT_EQ(f.model.spline_contacts[0].group_a.size(), static_cast<std::size_t>(warp));
  EXPECT_EQ(f.model.spline_contacts[0].group_b.size(), static_cast<std::size_t>(weft));
  for (const std::string name : {"warp0", "weft0.start", "warp.end", "weft"})
    EXPECT_GE(f.model.find_node_set(name), 0) << name;
  EXPECT_EQ(node_set(f, "warp.start").size(), static_cast<std::size_t>(warp));
  for (const BeamElement& e : f.model.elements) {
    EXPECT_EQ(e.reference_vector.z(), 0.0); // section axis 1 in the fabric plane
  }
}

TEST(BiasSpecimen, NoElementIsShorterThanTheShortEndFractionOfASpacing) {
  // Widths over a spacing in steps of 1/100: the leftover beyond the outer crossings sweeps
  // through (0, 1) spacing, the short-end rule included.
  int ended_at_crossing = 0, builds = 0;
  double shortest = 1;
  for (int k = 0; k <= 100; ++k) {
    const double w = 8 + k / 100.0;
    for (double angle : {45.0, 30.0}) {
      BiasSpecimenParameters p = specimen(w, 2 * w + 0.37);
      p.angle = angle;
      const Fabric f = build_bias_specimen(p);
      ++builds;
      for (const BeamElement& e : f.model.elements) {
        const double l = (node(f, e.nodes[2]) - node(f, e.nodes[0])).head<2>().norm();
        shortest = std::min(shortest, l / kSpacing);
        EXPECT_GE(l, kBiasShortEndFraction * kSpacing * (1 - 1e-12)) << "W " << w;
      }
      for (const Yarn& y : f.yarns)
        for (int n : {y.nodes.front(), y.nodes.back()})
          ended_at_crossing += to_boundary(p, node(f, n)) > 1e-12 * p.height;
    }
  }
  std::cout << "[ specimen ] " << builds << " builds: shortest element " << shortest << " spacing, "
            << ended_at_crossing << " yarn ends at their outer crossing\n";
  EXPECT_GT(ended_at_crossing, 0); // the rule was exercised
}

/// Expects build_bias_specimen(p) to throw std::invalid_argument whose message holds `expected`.
void expect_refused(const BiasSpecimenParameters& p, const std::string& expected) {
  try {
    build_bias_specimen(p);
    ADD_FAILURE() << "no exception; expected one about " << expected;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
  }
}

TEST(BiasSpecimen, BadParametersAreRefusedWithWhatWasExpected) {
  const BiasSpecimenParameters good = specimen(10, 20, 2);
  EXPECT_NO_THROW(build_bias_specimen(good));
  auto with = [&](const std::function<void(BiasSpecimenParameters&)>& change) {
    BiasSpecimenParameters p = good;
    change(p);
    return p;
  };
  expect_refused(with([](auto& p) { p.height = 0; }), "height H >= 2 spacings");
  expect_refused(with([](auto& p) { p.height = -1; }), "height");
  expect_refused(with([](auto& p) { p.width = 1.9 * kSpacing; }), "width W >= 2 spacings");
  expect_refused(with([](auto& p) { p.width = std::nan(""); }), "width");
  expect_refused(with([](auto& p) { p.angle = 0; }), "angle in (0, 90)");
  expect_refused(with([](auto& p) { p.angle = 90; }), "found 90");
  expect_refused(with([](auto& p) { p.angle = -45; }), "angle");
  expect_refused(with([](auto& p) { p.clamp_length = -1e-3; }), "clamp_length >= 0");
  expect_refused(with([](auto& p) { p.clamp_length = p.height / 2; }), "2 clamp_length < H");
  expect_refused(with([](auto& p) { p.weave.spacing_warp = 0; }), "spacing_warp > 0");
  expect_refused(with([](auto& p) { p.weave.pattern(0, 1) = 3; }), "pattern entries 0 or 1");
  expect_refused(with([](auto& p) { p.weave.b = 0; }), "b > 0");
  expect_refused(with([](auto& p) { p.weave.gap = -1e-5; }), "gap >= 0");
  expect_refused(with([](auto& p) { p.weave.elements_per_spacing = 0; }), "elements_per_spacing");
  expect_refused(with([](auto& p) { p.weave.material.young = 1e9; }), "exactly one of E");
  // The counts and lengths of the weave are not needed.
  EXPECT_NO_THROW(build_bias_specimen(with([](auto& p) {
    p.weave.n_warp = 0;
    p.weave.length_weft = -1;
  })));
}

} // namespace
} // namespace yarnsim::textile
