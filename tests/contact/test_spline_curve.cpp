#include "contact/spline_curve.hpp"

#include <gtest/gtest.h>

#include <random>
#include <stdexcept>

namespace yarnsim::contact {
namespace {

Eigen::Matrix3Xd random_polygon(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Matrix3Xd x(3, n);
  for (int i = 0; i < n; ++i) {
    x.col(i) << i + 0.3 * u(rng), 0.5 * u(rng), 0.5 * u(rng);
  }
  return x;
}

TEST(SplineCurve, OpenUniformKnotVector) {
  const SplineCurve curve(6);
  const std::vector<double> expected = {0, 0, 0, 0.25, 0.5, 0.75, 1, 1, 1};
  ASSERT_EQ(curve.knots().size(), expected.size());
  for (std::size_t k = 0; k < expected.size(); ++k) {
    EXPECT_DOUBLE_EQ(curve.knots()[k], expected[k]);
  }
  ASSERT_EQ(curve.num_segments(), 4);
  for (int i = 0; i < 4; ++i) {
    EXPECT_DOUBLE_EQ(curve.segment(i).begin(), curve.knots()[i + 2]);
    EXPECT_DOUBLE_EQ(curve.segment(i).end(), curve.knots()[i + 3]);
  }
}

TEST(SplineCurve, ThreePointsGiveTheBernsteinQuadratic) {
  const SplineCurve curve(3);
  const SegmentBasis& b = curve.segment(0);
  for (const double xi : {0.0, 0.1, 0.37, 0.5, 0.9, 1.0}) {
    const Eigen::Vector3d n = b.values(xi);
    EXPECT_NEAR(n(0), (1 - xi) * (1 - xi), 1e-15);
    EXPECT_NEAR(n(1), 2 * xi * (1 - xi), 1e-15);
    EXPECT_NEAR(n(2), xi * xi, 1e-15);
    const Eigen::Vector3d d = b.first(xi);
    EXPECT_NEAR(d(0), -2 * (1 - xi), 1e-14);
    EXPECT_NEAR(d(1), 2 - 4 * xi, 1e-14);
    EXPECT_NEAR(d(2), 2 * xi, 1e-14);
    EXPECT_NEAR(b.second(xi)(1), -4.0, 1e-13);
  }
}

TEST(SplineCurve, BasisIsAPartitionOfUnityWithMatchingDerivatives) {
  const SplineCurve curve(9);
  for (int i = 0; i < curve.num_segments(); ++i) {
    const SegmentBasis& b = curve.segment(i);
    for (int s = 0; s <= 10; ++s) {
      const double xi = b.begin() + 0.1 * s * b.length();
      EXPECT_NEAR(b.values(xi).sum(), 1.0, 1e-14);
      EXPECT_GE(b.values(xi).minCoeff(), -1e-15);
      EXPECT_NEAR(b.first(xi).sum(), 0.0, 1e-12);
      const double h = 1e-6 * b.length();
      const Eigen::Vector3d fd = (b.values(xi + h) - b.values(xi - h)) / (2 * h);
      EXPECT_LT((fd - b.first(xi)).norm(), 1e-7 * b.first(xi).norm());
      const Eigen::Vector3d fd2 = (b.first(xi + h) - b.first(xi - h)) / (2 * h);
      EXPECT_LT((fd2 - b.second(xi)).norm(), 1e-6 * b.second(xi).norm());
    }
  }
}

TEST(SplineCurve, InterpolatesOnlyTheEndPoints) {
  const SplineCurve curve(7);
  const Eigen::Matrix3Xd x = random_polygon(7, 3);
  EXPECT_LT((curve.point(x, 0.0) - x.col(0)).norm(), 1e-14);
  EXPECT_LT((curve.point(x, 1.0) - x.col(6)).norm(), 1e-14);
  // Interior knots sit at midpoints of consecutive control points, not on the nodes.
  for (int i = 1; i < curve.num_segments(); ++i) {
    const double k = curve.segment(i).begin();
    EXPECT_LT((curve.point(x, k) - 0.5 * (x.col(i) + x.col(i + 1))).norm(), 1e-14);
  }
}

TEST(SplineCurve, IsC1AcrossEveryInteriorKnot) {
  for (const int n : {4, 5, 12}) {
    const SplineCurve curve(n);
    const Eigen::Matrix3Xd x = random_polygon(n, 11 + n);
    for (int i = 0; i + 1 < curve.num_segments(); ++i) {
      const SegmentBasis& left = curve.segment(i);
      const SegmentBasis& right = curve.segment(i + 1);
      const double k = left.end();
      ASSERT_EQ(k, right.begin());
      const Eigen::Matrix3d xl = curve.control_points(x, i);
      const Eigen::Matrix3d xr = curve.control_points(x, i + 1);
      EXPECT_LT((left.point(xl, k) - right.point(xr, k)).norm(), 1e-13);
      EXPECT_LT((left.first_derivative(xl, k) - right.first_derivative(xr, k)).norm(),
                1e-12 * left.first_derivative(xl, k).norm());
      // Only C1: the second derivative jumps for a generic polygon.
      EXPECT_GT((left.second_derivative(xl, k) - right.second_derivative(xr, k)).norm(), 1e-3);
    }
  }
}

TEST(SplineCurve, EveryParameterHasExactlyOneOwner) {
  const SplineCurve curve(8);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> samples = curve.knots();
  for (int s = 0; s < 2000; ++s) {
    samples.push_back(u(rng));
  }
  for (const double xi : samples) {
    int owners = 0;
    for (int i = 0; i < curve.num_segments(); ++i) {
      owners += curve.segment(i).owns(xi) ? 1 : 0;
    }
    EXPECT_EQ(owners, 1) << "xi = " << xi;
    const int i = curve.segment_of(xi);
    ASSERT_GE(i, 0);
    EXPECT_TRUE(curve.segment(i).owns(xi));
  }
  EXPECT_EQ(curve.segment_of(curve.segment(2).begin()), 2); // half-open: a knot starts a segment
  EXPECT_EQ(curve.segment_of(1.0), curve.num_segments() - 1);
  EXPECT_EQ(curve.segment_of(-1e-12), -1);
  EXPECT_EQ(curve.segment_of(1.0 + 1e-12), -1);
  EXPECT_EQ(curve.segment_of(NAN), -1);
}

TEST(SplineCurve, SegmentBoxHoldsTheSegment) {
  const SplineCurve curve(6);
  const Eigen::Matrix3Xd x = random_polygon(6, 21);
  for (int i = 0; i < curve.num_segments(); ++i) {
    const Aabb box = curve.box(x, i);
    const Eigen::Matrix3d xi = curve.control_points(x, i);
    for (int s = 0; s <= 50; ++s) {
      const double t = curve.segment(i).begin() + s / 50.0 * curve.segment(i).length();
      const Eigen::Vector3d p = curve.segment(i).point(xi, t);
      EXPECT_TRUE(((p - box.min).array() >= -1e-15).all() &&
                  ((box.max - p).array() >= -1e-15).all());
    }
    const Aabb grown = curve.box(x, i, 0.1);
    EXPECT_LT((grown.min - (box.min.array() - 0.1).matrix()).norm(), 1e-15);
  }
}

TEST(SplineCurve, RejectsBadInput) {
  EXPECT_THROW(SplineCurve(2), std::invalid_argument);
  const SplineCurve curve(4);
  const Eigen::Matrix3Xd x = random_polygon(4, 1);
  EXPECT_THROW(curve.point(x, 1.5), std::invalid_argument);
  EXPECT_THROW(curve.point(random_polygon(5, 1), 0.5), std::invalid_argument);
}

} // namespace
} // namespace yarnsim::contact
