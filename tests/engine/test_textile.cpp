// The textile builder and the biaxial test (engine/textile/weave.hpp, biaxial.hpp).

#include "contact/spline_curve.hpp"
#include "engine/textile/biaxial.hpp"
#include "engine/textile/weave.hpp"

#include <cmath>
#include <gtest/gtest.h>
#include <iostream>
#include <limits>
#include <numbers>

namespace yarnsim::textile {
namespace {

const Yarn& yarn(const Fabric& f, bool warp, int index) {
  for (const Yarn& y : f.yarns)
    if (y.warp == warp && y.index == index)
      return y;
  throw std::runtime_error("no such yarn");
}

/// The node of a yarn at in-plane coordinate s along it (x for warp, y for weft), or -1.
int node_at(const Fabric& f, const Yarn& y, double s) {
  for (int n : y.nodes) {
    const Eigen::Vector3d& x = f.model.nodes[static_cast<std::size_t>(n)];
    if (std::abs((y.warp ? x.x() : x.y()) - s) < 1e-15)
      return n;
  }
  return -1;
}

Eigen::Matrix3Xd positions(const Fabric& f, const Yarn& y) {
  Eigen::Matrix3Xd p(3, static_cast<Eigen::Index>(y.nodes.size()));
  for (std::size_t k = 0; k < y.nodes.size(); ++k)
    p.col(static_cast<Eigen::Index>(k)) = f.model.nodes[static_cast<std::size_t>(y.nodes[k])];
  return p;
}

/// Minimum distance between two splines near a point `near`: coarse sampling, then alternating
/// golden-section projections (the curves cross at nearly a right angle).
double spline_distance(const Eigen::Matrix3Xd& pa, const Eigen::Matrix3Xd& pb,
                       const Eigen::Vector3d& near, double window) {
  const contact::SplineCurve ca(static_cast<int>(pa.cols()));
  const contact::SplineCurve cb(static_cast<int>(pb.cols()));
  constexpr int kSamples = 4000;
  auto candidates = [&](const contact::SplineCurve& c, const Eigen::Matrix3Xd& p) {
    std::vector<double> xi;
    for (int k = 0; k <= kSamples; ++k) {
      const double t = static_cast<double>(k) / kSamples;
      if ((c.point(p, t) - near).head<2>().norm() < window)
        xi.push_back(t);
    }
    return xi;
  };
  const std::vector<double> xa = candidates(ca, pa);
  const std::vector<double> xb = candidates(cb, pb);
  EXPECT_FALSE(xa.empty());
  EXPECT_FALSE(xb.empty());
  double best = std::numeric_limits<double>::infinity(), ta = 0, tb = 0;
  for (double a : xa)
    for (double b : xb) {
      const double d = (ca.point(pa, a) - cb.point(pb, b)).norm();
      if (d < best) {
        best = d;
        ta = a;
        tb = b;
      }
    }
  // Golden-section search of the distance to a fixed point over one parameter.
  auto project = [](const contact::SplineCurve& c, const Eigen::Matrix3Xd& p,
                    const Eigen::Vector3d& q, double lo, double hi) {
    lo = std::max(lo, 0.0);
    hi = std::min(hi, 1.0);
    const double g = (std::sqrt(5.0) - 1) / 2;
    for (int it = 0; it < 200; ++it) {
      const double m1 = hi - g * (hi - lo);
      const double m2 = lo + g * (hi - lo);
      if ((c.point(p, m1) - q).norm() < (c.point(p, m2) - q).norm())
        hi = m2;
      else
        lo = m1;
    }
    return (lo + hi) / 2;
  };
  const double h = 2.0 / kSamples;
  for (int round = 0; round < 50; ++round) {
    ta = project(ca, pa, cb.point(pb, tb), ta - h, ta + h);
    tb = project(cb, pb, ca.point(pa, ta), tb - h, tb + h);
  }
  return std::min(best, (ca.point(pa, ta) - cb.point(pb, tb)).norm());
}

TEST(Weave, PaperFabricHasTheStudysCounts) {
  const WeaveParameters p = paper_fabric();
  const Fabric f = build_weave(p);
  ASSERT_EQ(f.yarns.size(), 12u);
  EXPECT_EQ(f.model.elements.size(), 12u * 36u);
  EXPECT_EQ(f.model.nodes.size(), 12u * 73u);
  for (const Yarn& y : f.yarns)
    EXPECT_EQ(y.nodes.size(), 73u);
  for (const char* name : {"warp0", "warp5.start", "weft3.end", "warp", "weft", "warp.start",
                           "warp.end", "weft.start", "weft.end"})
    EXPECT_GE(f.model.find_node_set(name), 0) << name;
  EXPECT_EQ(
      f.model.node_sets[static_cast<std::size_t>(f.model.find_node_set("warp.end"))].nodes.size(),
      6u);
  ASSERT_EQ(f.model.splines.size(), 12u);
  for (const Spline& s : f.model.splines) {
    EXPECT_EQ(s.nodes.size(), 73u);
    EXPECT_DOUBLE_EQ(s.radius, p.b);
  }
  ASSERT_EQ(f.model.spline_contacts.size(), 1u);
  const SplineContactDefinition& c = f.model.spline_contacts[0];
  EXPECT_EQ(c.name, "warp-weft");
  EXPECT_EQ(c.group_a.size(), 6u);
  EXPECT_EQ(c.group_b.size(), 6u);
  EXPECT_FALSE(c.self_contact);
  EXPECT_DOUBLE_EQ(c.law.penalty, 1.5e6);
  EXPECT_DOUBLE_EQ(c.law.exponent, 1.0);
  EXPECT_DOUBLE_EQ(c.margin, p.b);
}

TEST(Weave, CentreLinesAreTwoBPlusGapApartAtEveryCrossing) {
  const WeaveParameters p = paper_fabric();
  const Fabric f = build_weave(p);
  const double h = 2 * p.b + p.gap;
  for (int i = 0; i < p.n_warp; ++i) {
    for (int j = 0; j < p.n_weft; ++j) {
      const double xj = (j - (p.n_weft - 1) / 2.0) * p.spacing_weft;
      const double yi = (i - (p.n_warp - 1) / 2.0) * p.spacing_warp;
      const int a = node_at(f, yarn(f, true, i), xj);
      const int b = node_at(f, yarn(f, false, j), yi);
      ASSERT_GE(a, 0);
      ASSERT_GE(b, 0);
      const Eigen::Vector3d& xa = f.model.nodes[static_cast<std::size_t>(a)];
      const Eigen::Vector3d& xb = f.model.nodes[static_cast<std::size_t>(b)];
      EXPECT_NEAR((xa - xb).norm(), h, 1e-12 * h) << "warp " << i << " weft " << j;
      // The surfaces (semi-axis b normal to the fabric) are `gap` apart.
      EXPECT_NEAR((xa - xb).norm() - 2 * p.b, p.gap, 1e-12 * h);
      // Over or under as the pattern says.
      EXPECT_EQ(xa.z() > xb.z(), p.pattern(i % 2, j % 2) == 1) << "warp " << i << " weft " << j;
    }
  }
}

TEST(Weave, SplinesOfCrossingYarnsStartApart) {
  const WeaveParameters p = paper_fabric();
  const Fabric f = build_weave(p);
  const double r = p.contact_radius;
  double smallest = std::numeric_limits<double>::infinity();
  for (int i = 0; i < p.n_warp; ++i)
    for (int j = 0; j < p.n_weft; ++j) {
      const Eigen::Vector3d crossing((j - (p.n_weft - 1) / 2.0) * p.spacing_weft,
                                     (i - (p.n_warp - 1) / 2.0) * p.spacing_warp, 0);
      const double d = spline_distance(positions(f, yarn(f, true, i)),
                                       positions(f, yarn(f, false, j)), crossing, p.spacing_weft);
      EXPECT_GE(d, 2 * r) << "warp " << i << " weft " << j;
      smallest = std::min(smallest, d - 2 * r);
    }
  // The spline passes through no interior node: at a crossing it stays inside the centre line's
  // crest, so the clearance the spline contact sees is below the nominal gap. The surface
  // contact (beam axis through the nodes, section semi-axis b) sees the nominal gap.
  std::cout << "[ spline ] paper fabric: nominal surface gap " << p.gap * 1e3
            << " mm; spline clearance at a crossing (|C_warp - C_weft| - 2 r) " << smallest * 1e3
            << " mm (" << smallest / p.gap * 100 << " % of the nominal gap)\n";
  ::testing::Test::RecordProperty("spline_clearance_mm", std::to_string(smallest * 1e3));
  EXPECT_LT(smallest, p.gap);
  EXPECT_GT(smallest, 0.5 * p.gap);
}

TEST(Weave, YarnsHaveTheirLengthAndSpacingAndRunStraightPastTheOuterCrossings) {
  const WeaveParameters p = paper_fabric();
  const Fabric f = build_weave(p);
  for (const Yarn& y : f.yarns) {
    const Eigen::Vector3d a = f.model.nodes[static_cast<std::size_t>(y.nodes.front())];
    const Eigen::Vector3d b = f.model.nodes[static_cast<std::size_t>(y.nodes.back())];
    const double length = y.warp ? p.length_warp : p.length_weft;
    EXPECT_NEAR((b - a).head<2>().norm(), length, 1e-12 * length);
    EXPECT_GT(y.warp ? b.x() : b.y(), y.warp ? a.x() : a.y()); // start at the minimum
    // Straight beyond the outer crossing: 2 spacings of 4 elements = 16 nodes at each end.
    const double outer = (p.n_weft - 1) / 2.0 * p.spacing_weft;
    for (int n : y.nodes) {
      const Eigen::Vector3d& x = f.model.nodes[static_cast<std::size_t>(n)];
      const double s = y.warp ? x.x() : x.y();
      if (s <= -outer) {
        EXPECT_EQ(x.z(), a.z());
      }
      if (s >= outer) {
        EXPECT_EQ(x.z(), b.z());
      }
    }
  }
  for (int i = 1; i < p.n_warp; ++i) {
    const double y0 = f.model.nodes[static_cast<std::size_t>(yarn(f, true, i - 1).nodes[0])].y();
    const double y1 = f.model.nodes[static_cast<std::size_t>(yarn(f, true, i).nodes[0])].y();
    EXPECT_NEAR(y1 - y0, p.spacing_warp, 1e-12 * p.spacing_warp);
  }
  for (int j = 1; j < p.n_weft; ++j) {
    const double x0 = f.model.nodes[static_cast<std::size_t>(yarn(f, false, j - 1).nodes[0])].x();
    const double x1 = f.model.nodes[static_cast<std::size_t>(yarn(f, false, j).nodes[0])].x();
    EXPECT_NEAR(x1 - x0, p.spacing_weft, 1e-12 * p.spacing_weft);
  }
}

TEST(Weave, MidNodesLieOnTheCentreLineAndTheCurveIsSmoothAtCrossings) {
  const WeaveParameters p = paper_fabric();
  const Fabric f = build_weave(p);
  const double h = 2 * p.b + p.gap;
  const Yarn& y = yarn(f, true, 0);
  for (int j = 0; j + 1 < p.n_weft; ++j) {
    const double x0 = (j - (p.n_weft - 1) / 2.0) * p.spacing_weft;
    const double z0 = warp_height(p, 0, j);
    const double z1 = warp_height(p, 0, j + 1);
    EXPECT_NEAR(std::abs(z1 - z0), h, 1e-15); // plain weave: over, then under
    for (int n : y.nodes) {
      const Eigen::Vector3d& x = f.model.nodes[static_cast<std::size_t>(n)];
      const double t = (x.x() - x0) / p.spacing_weft;
      if (t < -1e-12 || t > 1 + 1e-12)
        continue;
      EXPECT_NEAR(x.z(), z0 + (z1 - z0) * t * t * (3 - 2 * t), 1e-15);
    }
  }
}

TEST(Weave, SectionHasTheStudysStiffnessesWithAxisOneInThePlane) {
  const WeaveParameters p = paper_fabric();
  const Fabric f = build_weave(p);
  ASSERT_EQ(f.model.sections.size(), 1u);
  const Section& s = f.model.sections[0];
  EXPECT_NEAR(s.EA, 38000, 1e-9);
  EXPECT_NEAR(s.EI1, 7.67e-5, 0.01e-5); // lower inertia x 0.1
  EXPECT_NEAR(s.EI2, 1.23e-2, 0.01e-2);
  EXPECT_NEAR(s.GJ, 1.20e-3, 0.01e-3);
  EXPECT_NEAR(s.rhoA, 2.576e-3, 0.001e-3);
  EXPECT_EQ(s.shape, SectionShape::Ellipse);
  EXPECT_DOUBLE_EQ(s.a, p.a);
  EXPECT_DOUBLE_EQ(s.b, p.b);
  for (const BeamElement& e : f.model.elements) {
    const Eigen::Vector3d axis = f.model.nodes[static_cast<std::size_t>(e.nodes[2])] -
                                 f.model.nodes[static_cast<std::size_t>(e.nodes[0])];
    EXPECT_EQ(e.reference_vector.z(), 0.0);
    EXPECT_NEAR(e.reference_vector.dot(axis), 0.0, 1e-15);
    EXPECT_NEAR(e.reference_vector.norm(), 1.0, 1e-15);
  }
}

TEST(Weave, TwillAndBasketPatternsGiveTheirOverUnderMatrix) {
  Eigen::MatrixXi twill(4, 4);
  twill << 1, 1, 0, 0, //
      0, 1, 1, 0,      //
      0, 0, 1, 1,      //
      1, 0, 0, 1;
  EXPECT_EQ(twill_pattern(2, 2), twill);
  Eigen::MatrixXi basket(4, 4);
  basket << 1, 1, 0, 0, //
      1, 1, 0, 0,       //
      0, 0, 1, 1,       //
      0, 0, 1, 1;
  EXPECT_EQ(basket_pattern(2), basket);
  EXPECT_EQ(plain_pattern(), basket_pattern(1));

  for (const Eigen::MatrixXi& pattern : {twill, basket}) {
    WeaveParameters p = paper_fabric();
    p.pattern = pattern;
    const Fabric f = build_weave(p);
    for (int i = 0; i < p.n_warp; ++i)
      for (int j = 0; j < p.n_weft; ++j) {
        const double xj = (j - (p.n_weft - 1) / 2.0) * p.spacing_weft;
        const double yi = (i - (p.n_warp - 1) / 2.0) * p.spacing_warp;
        const double za =
            f.model.nodes[static_cast<std::size_t>(node_at(f, yarn(f, true, i), xj))].z();
        const double zb =
            f.model.nodes[static_cast<std::size_t>(node_at(f, yarn(f, false, j), yi))].z();
        EXPECT_EQ(za > zb, pattern(i % 4, j % 4) == 1) << "warp " << i << " weft " << j;
        EXPECT_NEAR(za - zb, pattern(i % 4, j % 4) == 1 ? 2 * p.b + p.gap : -(2 * p.b + p.gap),
                    1e-15);
      }
  }
}

TEST(Weave, InconsistentParametersAreRefused) {
  WeaveParameters p = paper_fabric();
  p.length_warp = 4 * p.spacing_weft; // shorter than the 5 spacings between outer crossings
  EXPECT_THROW(build_weave(p), std::invalid_argument);
  p = paper_fabric();
  p.pattern(0, 0) = 2;
  EXPECT_THROW(build_weave(p), std::invalid_argument);
  p = paper_fabric();
  p.material.young = 1e9; // and EA
  EXPECT_THROW(build_weave(p), std::invalid_argument);
  // A yarn that ends exactly at its outer crossings has no straight part.
  p = paper_fabric();
  p.length_warp = 5 * p.spacing_weft;
  const Fabric f = build_weave(p);
  EXPECT_EQ(yarn(f, true, 0).nodes.size(), 5u * 8u + 1u);
}

/// In-plane end-to-end strain of yarn `y` at time t from the prescribed end displacements.
double end_strain(const Fabric& f, const Yarn& y, double t) {
  auto displaced = [&](int node_set, int node) {
    Eigen::Vector3d x = f.model.nodes[static_cast<std::size_t>(node)];
    for (const PrescribedMotion& m : f.model.prescribed)
      if (m.node_set == node_set)
        for (int c = 0; c < 3; ++c)
          x(c) += m.displacement[static_cast<std::size_t>(c)]->at(t);
    return x;
  };
  const std::string name = yarn_name(y);
  const Eigen::Vector3d a0 = f.model.nodes[static_cast<std::size_t>(y.nodes.front())];
  const Eigen::Vector3d b0 = f.model.nodes[static_cast<std::size_t>(y.nodes.back())];
  const Eigen::Vector3d a = displaced(f.model.find_node_set(name + ".start"), y.nodes.front());
  const Eigen::Vector3d b = displaced(f.model.find_node_set(name + ".end"), y.nodes.back());
  const double L0 = (b0 - a0).head<2>().norm();
  return ((b - a).head<2>().norm() - L0) / L0;
}

TEST(Biaxial, EndDisplacementsHonourTheStrainRatio) {
  for (double k : {1.0, 2.0, 0.5}) {
    Fabric f = build_weave(paper_fabric());
    BiaxialParameters b;
    b.strain_ratio = k;
    add_biaxial_test(f, b);
    const auto [eps_warp, eps_weft] = biaxial_strains(k, 0.015);
    EXPECT_DOUBLE_EQ(std::max(eps_warp, eps_weft), 0.015);
    for (const Yarn& y : f.yarns) {
      EXPECT_NEAR(end_strain(f, y, 1.0), y.warp ? eps_warp : eps_weft, 1e-12);
      EXPECT_NEAR(end_strain(f, y, 0.5), (y.warp ? eps_warp : eps_weft) / 2, 1e-12);
      EXPECT_EQ(end_strain(f, y, 0.0), 0.0);
    }
    const double ratio = end_strain(f, f.yarns.front(), 1.0) / end_strain(f, f.yarns.back(), 1.0);
    EXPECT_NEAR(ratio, k, 1e-12 * k) << "k = " << k;
    // Only the component along the yarn moves; rotations stay free.
    EXPECT_EQ(f.model.prescribed.size(), 24u);
    for (const PrescribedMotion& m : f.model.prescribed) {
      EXPECT_FALSE(m.rotation.has_value());
      int moving = 0;
      for (int c = 0; c < 3; ++c) {
        ASSERT_TRUE(m.displacement[static_cast<std::size_t>(c)].has_value());
        moving += m.displacement[static_cast<std::size_t>(c)]->at(1.0) != 0;
      }
      EXPECT_EQ(moving, 1);
      EXPECT_EQ(m.displacement[2]->at(1.0), 0.0);
    }
    ASSERT_TRUE(f.model.biaxial.has_value());
    const BiaxialTest& t = *f.model.biaxial;
    EXPECT_EQ(t.strain_ratio, k);
    EXPECT_EQ(t.warp_start.size(), 6u);
    EXPECT_EQ(t.weft_end.size(), 6u);
    EXPECT_NEAR(t.length_warp, 40.90909e-3, 1e-15);
    EXPECT_EQ(f.model.node_sets[static_cast<std::size_t>(t.warp_end[2])].name, "warp2.end");
    ASSERT_EQ(f.model.steps.size(), 1u);
    const SolutionStep& s = f.model.steps[0];
    EXPECT_EQ(s.type, StepType::Dynamic);
    EXPECT_EQ(s.newmark_beta, 0.3);
    EXPECT_EQ(s.newmark_gamma, 0.5);
    EXPECT_DOUBLE_EQ(s.dt_initial, 0.01);
    EXPECT_DOUBLE_EQ(s.dt_max, 0.02);
    EXPECT_DOUBLE_EQ(s.dt_min, 1e-6);
    EXPECT_EQ(s.tol_force, 1e-4);
    ASSERT_EQ(f.model.monitors.size(), 2u);
    EXPECT_EQ(f.model.monitors[0].name, "warp_ends");
    EXPECT_EQ(f.model.node_sets[static_cast<std::size_t>(f.model.monitors[1].target)].name,
              "weft.end");
  }
}

TEST(Biaxial, BadParametersAreRefused) {
  EXPECT_THROW(biaxial_strains(0, 0.01), std::invalid_argument);
  EXPECT_THROW(biaxial_strains(1, 1.5), std::invalid_argument);
  Fabric f = build_weave(paper_fabric());
  BiaxialParameters b;
  b.dt = 2; // longer than the loading
  EXPECT_THROW(add_biaxial_test(f, b), std::invalid_argument);
}

} // namespace
} // namespace yarnsim::textile
