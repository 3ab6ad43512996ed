#include "contact/surface_contact.hpp"

#include "surface_pairs.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <random>
#include <utility>
#include <vector>

namespace yarnsim::contact {
namespace {

using namespace surface_test;

using Eigen::Matrix3d;
using Eigen::Vector2d;
using Eigen::Vector3d;
using Vec4 = Eigen::Vector4d;
using Vec24 = Eigen::Matrix<double, 24, 1>;
using Mat24 = Eigen::Matrix<double, 24, 24>;

/// Two element surfaces.
struct Pair {
  SurfaceNode a[2];
  SurfaceNode b[2];
  SuperEllipse sa{kA, kB};
  SuperEllipse sb{kA, kB};
  bool closes_a = false;
  bool closes_b = false;
  SuperEllipticalCylinder A() const { return {a[0], a[1], sa, closes_a}; }
  SuperEllipticalCylinder B() const { return {b[0], b[1], sb, closes_b}; }
};

/// DOF i of the pair in the kernel's order (eq. 2).
double& dof(Pair& p, int i) {
  SurfaceNode* n = i < 12 ? p.a : p.b;
  const int j = i % 12;
  return j < 6 ? n[j / 3].position(j % 3) : n[(j - 6) / 3].rotation_increment(j % 3);
}

SurfaceContactResult solve(const Pair& p, const InterfaceLaw& law,
                           const SurfaceProjectionStart& start = {},
                           const SurfaceContactOptions& options = {},
                           const SurfacePairRates* rates = nullptr) {
  return surface_contact(p.A(), p.B(), start, law, options, rates);
}

SurfaceProjectionStart warm_start(const SurfaceContactResult& r) {
  return {r.zeta_A, r.theta_A, r.zeta_B, r.theta_B, true};
}

void translate_b(Pair& p, const Vector3d& t) {
  p.b[0].position += t;
  p.b[1].position += t;
}

/// Moves B along the contact normal so that the signed gap becomes `gap`. A translation along
/// the normal keeps the contact points, so one move is exact; returns false if the projection
/// fails on the way.
bool place(Pair& p, double gap, const SurfaceContactOptions& options = {}) {
  const LinearPenalty law(kEps);
  for (int it = 0; it < 3; ++it) {
    const SurfaceContactResult r = solve(p, law, {}, options);
    if (r.status != ProjectionStatus::Converged) {
      return false;
    }
    if (std::abs(r.gap - gap) < 1e-15) {
      return true;
    }
    translate_b(p, (r.gap - gap) * r.normal);
  }
  return solve(p, law, {}, options).status == ProjectionStatus::Converged;
}

/// A random element of length about `length` centred at `centre` along `direction`, section
/// axis 1 turned by `twist` from `reference` about the axis; both nodes' positions and rotations
/// perturbed (a bent and twisted element), the rotations reached through random increments.
void random_element(std::mt19937& rng, SurfaceNode (&n)[2], const Vector3d& centre,
                    const Vector3d& direction, const Vector3d& reference, double twist,
                    double length, double bend) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Vector3d d = direction.normalized();
  const Vector3d e1 = Eigen::AngleAxisd(twist, d) * (reference - reference.dot(d) * d);
  const Matrix3d base = frame(e1, d);
  for (int k = 0; k < 2; ++k) {
    const Vector3d x =
        centre + (k - 0.5) * length * d + bend * length * Vector3d(u(rng), u(rng), u(rng));
    const Vector3d tilt = bend * Vector3d(u(rng), u(rng), u(rng));
    const Matrix3d q = Eigen::AngleAxisd(tilt.norm(), tilt.normalized()).toRotationMatrix() * base;
    const Vector3d alpha = 0.8 * Vector3d(u(rng), u(rng), u(rng));
    n[k] = node(x, q, alpha);
  }
}

/// A random crossing: A and B at an angle in [min_angle, 180 - min_angle] degrees, random
/// twists, bent elements, the whole turned by a random rotation; B's centre above A's by about
/// b_A + b_B. Section axis 1 (semi-axis a) lies in the fabric plane, turned about the element's
/// axis by up to `twist_a` (`twist_b`) radians. Gap not yet set (see place).
Pair random_crossing(std::mt19937& rng, double min_angle_deg = 20.0, double length = 1.0e-3,
                     double bend = 0.05, double twist_a = 0.4, double twist_b = 0.4) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Eigen::Quaterniond q = random_rotation(rng);
  const double span = 180.0 - 2.0 * min_angle_deg;
  const double angle = (min_angle_deg + span * (0.5 + 0.5 * u(rng))) * kPi / 180.0;
  Pair p;
  const Vector3d da = q * Vector3d::UnitX();
  const Vector3d db = q * Vector3d(std::cos(angle), std::sin(angle), 0.0);
  const Vector3d up = q * Vector3d::UnitZ();
  const Vector3d ca = 0.2 * length * (q * Vector3d(u(rng), u(rng), 0.0));
  const Vector3d cb = 0.2 * length * (q * Vector3d(u(rng), u(rng), 0.0)) + 2.0 * kB * up;
  random_element(rng, p.a, ca, da, da.cross(up), twist_a * u(rng), length, bend);
  random_element(rng, p.b, cb, db, db.cross(up), twist_b * u(rng), length, bend);
  return p;
}

/// DOF scales: metres for translations (the element length), 1 for Rodrigues parameters; the
/// finite-difference steps and the error norms use them so that both kinds of DOF count.
double dof_scale(int i) {
  return i % 12 < 6 ? 1e-3 : 1.0;
}

/// Max-norm relative error of the tangent against central differences of the residual, in
/// scaled DOFs, Richardson-extrapolated from steps h and h/2 (error O(h^4)): near the edge of a
/// node's window (SurfaceContactOptions::end_window) the share's polynomial S(t) ~ 10 t^3 leaves
/// a plain central difference an O(h^2 / t^2) error. The perturbed solves are warm-started from
/// the base solution, as in a Newton iteration.
double tangent_error(const Pair& base, const InterfaceLaw& law,
                     const SurfaceContactOptions& options = {},
                     const SurfacePairRates* rates = nullptr, double relative_step = 1e-6) {
  const SurfaceContactResult r0 = solve(base, law, {}, options, rates);
  EXPECT_EQ(r0.status, ProjectionStatus::Converged);
  EXPECT_TRUE(r0.active);
  const SurfaceProjectionStart warm = warm_start(r0);
  auto central = [&](int i, double h) {
    Vec24 res[2];
    for (int side = 0; side < 2; ++side) {
      const double step = side == 0 ? h : -h;
      Pair p = base;
      dof(p, i) += step;
      SurfacePairRates moved;
      if (rates != nullptr) {
        moved = *rates;
        moved.rate(i) += rates->velocity_per_displacement * step;
      }
      const SurfaceContactResult r =
          solve(p, law, warm, options, rates != nullptr ? &moved : nullptr);
      EXPECT_EQ(r.status, ProjectionStatus::Converged);
      EXPECT_EQ(r.degeneration, r0.degeneration);
      res[side] = r.residual;
    }
    return Vec24((res[0] - res[1]) / (2 * h));
  };
  Mat24 fd;
  for (int i = 0; i < 24; ++i) {
    const double h = relative_step * dof_scale(i);
    fd.col(i) = (4.0 * central(i, 0.5 * h) - central(i, h)) / 3.0;
  }
  Mat24 scaled_error;
  Mat24 scaled_tangent;
  for (int i = 0; i < 24; ++i) {
    for (int j = 0; j < 24; ++j) {
      const double s = dof_scale(i) * dof_scale(j);
      scaled_error(i, j) = s * (fd(i, j) - r0.tangent(i, j));
      scaled_tangent(i, j) = s * r0.tangent(i, j);
    }
  }
  return scaled_error.cwiseAbs().maxCoeff() / scaled_tangent.cwiseAbs().maxCoeff();
}

/// Max-norm relative error (scaled DOFs) of the residual against central differences of the
/// law's potential.
double residual_error(const Pair& base, const InterfaceLaw& law,
                      const SurfaceContactOptions& options = {}) {
  const SurfaceContactResult r0 = solve(base, law, {}, options);
  EXPECT_TRUE(r0.active);
  Vec24 error;
  Vec24 scaled;
  for (int i = 0; i < 24; ++i) {
    const double h = 1e-6 * dof_scale(i);
    Pair plus = base;
    Pair minus = base;
    dof(plus, i) += h;
    dof(minus, i) -= h;
    const double fd =
        (solve(plus, law, {}, options).potential - solve(minus, law, {}, options).potential) /
        (2 * h);
    error(i) = dof_scale(i) * (fd - r0.residual(i));
    scaled(i) = dof_scale(i) * r0.residual(i);
  }
  return error.cwiseAbs().maxCoeff() / scaled.cwiseAbs().maxCoeff();
}

// ---- Section -----------------------------------------------------------------------------------

TEST(SuperEllipse, DerivativesMatchCentralDifferences) {
  for (const double m : {2.0, 2.5, 4.0, 10.0}) {
    const SuperEllipse s(kA, kB, m);
    for (double theta = -3.0; theta < 3.2; theta += 0.37) {
      const double h = 1e-5;
      const SuperEllipse::Point p = s.point(theta);
      const SuperEllipse::Point pp = s.point(theta + h);
      const SuperEllipse::Point pm = s.point(theta - h);
      EXPECT_LT((p.first - (pp.value - pm.value) / (2 * h)).norm(), 1e-8 * kA) << m;
      EXPECT_LT((p.second - (pp.first - pm.first) / (2 * h)).norm(), 1e-7 * kA) << m;
      // On the curve |x/a|^m + |y/b|^m = 1.
      EXPECT_NEAR(std::pow(std::abs(p.value.x() / kA), m) + std::pow(std::abs(p.value.y() / kB), m),
                  1.0, 1e-13);
    }
  }
}

TEST(SuperEllipse, SupportPointHasTheGivenNormalAndMaximisesTheProjection) {
  for (const double m : {2.0, 3.0, 6.0}) {
    const SuperEllipse s(kA, kB, m);
    for (double angle = 0.05; angle < 6.3; angle += 0.4) {
      const Vector2d n(std::cos(angle), std::sin(angle));
      const double theta = s.normal_angle(n);
      const SuperEllipse::Point p = s.point(theta);
      // Outward normal of a counter-clockwise curve: the tangent turned clockwise.
      const Vector2d normal = Vector2d(p.first.y(), -p.first.x()).normalized();
      EXPECT_LT((normal - n).norm(), 1e-9) << "m " << m << " angle " << angle;
      EXPECT_NEAR(n.dot(p.value), s.support(n), 1e-15);
      double best = -1.0;
      for (int k = 0; k < 20000; ++k) {
        best = std::max(best, n.dot(s.point(k * 2 * kPi / 20000).value));
      }
      EXPECT_LE(best, s.support(n) + 1e-16);
      EXPECT_GT(best, s.support(n) - 1e-6 * kA); // sampling resolution
    }
  }
}

// ---- The broad phase's box ---------------------------------------------------------------------

// SuperEllipticalCylinder::bounding_box holds every surface point for zeta in the element and its
// end windows, whatever the two ends' rotations, and is tight: along each axis some surface point
// within the element reaches the end boxes' faces, and a flat section lying in the x-y plane gets
// a box of height 2 b, not 2 max(a, b).
TEST(SuperEllipticalCylinder, BoundingBoxHoldsTheSurfaceAndItsEndWindows) {
  std::mt19937 rng(20261203);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double window = 0.25;
  for (const double m : {2.0, 4.0}) {
    const SuperEllipse section(kA, kB, m);
    for (int trial = 0; trial < 40; ++trial) {
      const Vector3d xa(u(rng) * 1e-3, u(rng) * 1e-3, u(rng) * 1e-3);
      const Vector3d xb = xa + 1.2e-3 * Vector3d(u(rng), u(rng), u(rng)).normalized();
      const SuperEllipticalCylinder c(node(xa, random_rotation(rng).toRotationMatrix()),
                                      node(xb, random_rotation(rng).toRotationMatrix()), section);
      const Eigen::AlignedBox3d box = c.bounding_box(window);
      const Eigen::AlignedBox3d ends = c.bounding_box(0.0);
      Vector3d low = Vector3d::Constant(1e300), high = Vector3d::Constant(-1e300);
      for (int i = 0; i <= 40; ++i)
        for (int k = 0; k < 64; ++k) {
          const double zeta = -1.0 - window + i * (2.0 + 2.0 * window) / 40;
          const Vector3d x = c.point(zeta, k * 2 * kPi / 64);
          EXPECT_TRUE(box.exteriorDistance(x) == 0.0) << "m " << m << " trial " << trial;
          if (std::abs(zeta) <= 1.0) {
            low = low.cwiseMin(x);
            high = high.cwiseMax(x);
          }
        }
      // Tight on the element: the sampled surface reaches the end boxes' faces to within the
      // sampling's resolution (64 angles: 1 - cos(pi / 64) of a semi-axis).
      EXPECT_LT((low - ends.min()).cwiseAbs().maxCoeff(), 2e-3 * kA) << trial;
      EXPECT_LT((high - ends.max()).cwiseAbs().maxCoeff(), 2e-3 * kA) << trial;
    }
  }
  // A yarn along x, its section flat in the fabric plane (axis 1 along y): height 2 b.
  const Matrix3d q = frame(Vector3d::UnitY(), Vector3d::UnitX());
  const SuperEllipticalCylinder flat(node(Vector3d::Zero(), q), node(Vector3d(1e-3, 0, 0), q),
                                     SuperEllipse(kA, kB));
  const Eigen::AlignedBox3d box = flat.bounding_box(0.0);
  EXPECT_NEAR(box.sizes().z(), 2 * kB, 1e-15);
  EXPECT_NEAR(box.sizes().y(), 2 * kA, 1e-15);
  EXPECT_NEAR(box.sizes().x(), 1e-3, 1e-15);
  EXPECT_NEAR(flat.bounding_box(0.25).sizes().x(), 1.25e-3, 1e-15);
}

// ---- Crossing ellipses with closed-form answers -------------------------------------------------

/// A along x with semi-axis a along y (flat side up), B along y above it with semi-axis a
/// along x (flat side down), axes `distance` apart; A turned about its own axis by `psi`.
Pair right_angle_crossing(double distance, double psi = 0.0, double offset_x = 0.0,
                          double offset_y = 0.0) {
  const double length = 2e-3;
  Pair p;
  const Matrix3d qa =
      Eigen::AngleAxisd(psi, Vector3d::UnitX()) * frame(Vector3d::UnitY(), Vector3d::UnitX());
  const Matrix3d qb = frame(-Vector3d::UnitX(), Vector3d::UnitY());
  p.a[0] = node(Vector3d(-0.5 * length + offset_x, 0, 0), qa);
  p.a[1] = node(Vector3d(0.5 * length + offset_x, 0, 0), qa);
  p.b[0] = node(Vector3d(0, -0.5 * length + offset_y, distance), qb);
  p.b[1] = node(Vector3d(0, 0.5 * length + offset_y, distance), qb);
  return p;
}

TEST(SurfaceContact, CrossingEllipsesPressedTogetherGiveEpsTimesOverlap) {
  const LinearPenalty law(kEps);
  const double delta = 3e-6;
  const Pair p = right_angle_crossing(2 * kB - delta, 0.0, 0.2e-3, -0.3e-3);
  const SurfaceContactResult r = solve(p, law);
  ASSERT_EQ(r.status, ProjectionStatus::Converged);
  EXPECT_EQ(r.degeneration, SurfaceDegeneration::None);
  EXPECT_TRUE(r.active);
  // A's axis at x in [-0.8, 1.2] mm, B's at y in [-1.3, 0.7] mm: they cross at the origin.
  EXPECT_NEAR(r.zeta_A, -0.2, 1e-12);
  EXPECT_NEAR(r.zeta_B, 0.3, 1e-12);
  EXPECT_NEAR(r.theta_A, 0.5 * kPi, 1e-9); // A's top: +b along its axis 2 = z
  EXPECT_NEAR(r.theta_B, 1.5 * kPi, 1e-9); // B's bottom: -b along its axis 2 = z
  EXPECT_LT((r.point_A - Vector3d(0, 0, kB)).norm(), 1e-15);
  EXPECT_LT((r.point_B - Vector3d(0, 0, kB - delta)).norm(), 1e-15);
  EXPECT_NEAR(r.gap, -delta, 1e-17);
  EXPECT_NEAR(r.force, kEps * delta, 1e-9 * kEps * delta);
  EXPECT_NEAR(r.potential, 0.5 * kEps * delta * delta, 1e-12 * kEps * delta * delta);
  EXPECT_LT((r.normal - Vector3d(0, 0, -1)).norm(), 1e-12); // from B (above) towards A
  // Internal-force sign: A is pushed down, so its residual points up; B's the other way.
  const Vector3d on_a = r.residual.segment<3>(0) + r.residual.segment<3>(3);
  const Vector3d on_b = r.residual.segment<3>(12) + r.residual.segment<3>(15);
  EXPECT_LT((on_a - Vector3d(0, 0, kEps * delta)).norm(), 1e-9 * kEps * delta);
  EXPECT_LT((on_a + on_b).norm(), 1e-12 * kEps * delta);
  // zeta_A = -0.2: node A carries 60 %.
  EXPECT_NEAR(r.residual(2), 0.6 * kEps * delta, 1e-9 * kEps * delta);
  // The contact points lie on the section axes' planes: no moment about the beam axes, so the
  // Rodrigues parts vanish.
  for (int i : {6, 7, 8, 9, 10, 11, 18, 19, 20, 21, 22, 23}) {
    EXPECT_NEAR(r.residual(i), 0.0, 1e-12 * kEps * delta) << i;
  }
}

TEST(SurfaceContact, TurningACylinderChangesTheGapByItsSupportDistance) {
  const LinearPenalty law(kEps);
  const double distance = kB + kA * 0.8; // B's flat underside at kA * 0.8
  for (double psi = -1.5; psi <= 1.5; psi += 0.125) {
    const Pair p = right_angle_crossing(distance, psi);
    const SurfaceContactResult r = solve(p, law);
    ASSERT_EQ(r.status, ProjectionStatus::Converged) << psi;
    // Support of A's ellipse turned by psi in the direction z.
    const double h = std::sqrt(kA * kA * std::sin(psi) * std::sin(psi) +
                               kB * kB * std::cos(psi) * std::cos(psi));
    EXPECT_NEAR(r.gap, distance - kB - h, 1e-15) << "psi " << psi;
    EXPECT_LT((r.normal - Vector3d(0, 0, -1)).norm(), 1e-10) << psi;
    EXPECT_NEAR(r.point_B.z(), distance - kB, 1e-15);
    EXPECT_NEAR(r.point_A.z(), h, 1e-15);
    // The touching point of the turned ellipse lies off-centre: y = (a^2 - b^2) sin psi cos psi
    // / h. B's contact point follows it along B's axis.
    const double y = (kA * kA - kB * kB) * std::sin(psi) * std::cos(psi) / h;
    EXPECT_NEAR(r.point_A.y(), y, 1e-14) << psi;
    EXPECT_NEAR(r.point_B.y(), y, 1e-14) << psi;
  }
}

TEST(SurfaceContact, FirstTouchOfATurnedCylinderIsAtTheSupportDistance) {
  const LinearPenalty law(kEps);
  for (const double psi : {0.0, 0.3, 0.7, 1.2}) {
    const double h = std::sqrt(kA * kA * std::sin(psi) * std::sin(psi) +
                               kB * kB * std::cos(psi) * std::cos(psi));
    const double touch = kB + h; // centre distance at first touch
    const SurfaceContactResult before = solve(right_angle_crossing(touch * (1 + 1e-9), psi), law);
    const SurfaceContactResult after = solve(right_angle_crossing(touch * (1 - 1e-9), psi), law);
    EXPECT_FALSE(before.active) << psi;
    EXPECT_GT(before.gap, 0.0);
    EXPECT_TRUE(after.active) << psi;
    EXPECT_NEAR(after.penetration, 1e-9 * touch, 1e-18);
  }
}

TEST(SurfaceContact, SeparatedPairIsInactiveWithZeroResidual) {
  const LinearPenalty law(kEps);
  const SurfaceContactResult r = solve(right_angle_crossing(2 * kB + 1e-5), law);
  EXPECT_EQ(r.status, ProjectionStatus::Converged);
  EXPECT_FALSE(r.active);
  EXPECT_NEAR(r.gap, 1e-5, 1e-17);
  EXPECT_EQ(r.force, 0.0);
  EXPECT_EQ(r.residual.norm(), 0.0);
  EXPECT_EQ(r.tangent.norm(), 0.0);
}

TEST(SurfaceContact, ARegularisedLawActsBeforeContactWithAConsistentTangent) {
  // contact::RegularisedPenalty over g0 = 2e-5 m: the crossing 1e-5 m apart is active with
  // eps (g0 - g)^2 / (2 g0); the tangent matches central differences there; 3e-5 m apart it is
  // not.
  const double g0 = 2e-5;
  const RegularisedPenalty law(kEps, g0);
  const SurfaceContactResult r = solve(right_angle_crossing(2 * kB + 1e-5), law);
  ASSERT_TRUE(r.active);
  EXPECT_NEAR(r.force, kEps * 1e-10 / (2 * g0), 1e-9 * r.force);
  EXPECT_FALSE(solve(right_angle_crossing(2 * kB + 3e-5), law).active);
  std::mt19937 rng(5);
  int tested = 0;
  while (tested < 4) {
    Pair p = random_crossing(rng);
    if (!place(p, 0.5 * g0))
      continue;
    ++tested;
    ASSERT_TRUE(solve(p, law).active);
    EXPECT_LT(tangent_error(p, law, {}, nullptr, 1e-8), 1e-6);
  }
}

// ---- Residual and tangent against finite differences -------------------------------------------

TEST(SurfaceContact, ResidualIsTheGradientOfTheContactPotential) {
  std::mt19937 rng(3);
  const LinearPenalty law(kEps);
  int tested = 0;
  while (tested < 20) {
    // Sharp ownership: within a node's window the pair carries its share w of the force,
    // -w f grad g_n, which is not the gradient of w U.
    SurfaceContactOptions sharp;
    sharp.end_window = 0.0;
    Pair p = random_crossing(rng);
    if (!place(p, -4e-6, sharp)) {
      continue;
    }
    ++tested;
    const SurfaceContactResult r = solve(p, law, {}, sharp);
    EXPECT_NEAR(r.potential, 0.5 * kEps * r.penetration * r.penetration, 1e-20);
    EXPECT_LT(residual_error(p, law, sharp), 1e-6) << "configuration " << tested;
    const SurfaceContactResult shared = solve(p, law);
    EXPECT_NEAR(shared.potential, shared.share * r.potential, 1e-20);
    EXPECT_NEAR((shared.residual - shared.share * r.residual).norm(), 0.0,
                1e-12 * r.residual.norm());
  }
}

TEST(SurfaceContact, TangentMatchesCentralDifferencesAtRandomCrossings) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const LinearPenalty linear(kEps);
  const PowerLaw power(3e7, 1.5);
  int tested = 0;
  while (tested < 30) {
    Pair p = random_crossing(rng);
    if (!place(p, -(1e-6 + 1e-5 * u(rng)))) {
      continue;
    }
    ++tested;
    EXPECT_LT(tangent_error(p, linear), 1e-6) << "configuration " << tested;
    EXPECT_LT(tangent_error(p, power), 1e-6) << "configuration " << tested;
  }
}

TEST(SurfaceContact, TangentMatchesCentralDifferencesAtTinyAndDeepPenetrations) {
  std::mt19937 rng(8);
  const LinearPenalty law(kEps);
  for (const double depth : {1e-10, 1e-8, 1e-7, 5e-5, 2e-4}) {
    // Steps well below the depth, so that no perturbation opens the gap.
    const double step = std::min(1e-6, 1e-2 * depth / 1e-3);
    int tested = 0;
    while (tested < 4) {
      Pair p = random_crossing(rng);
      if (!place(p, -depth)) {
        continue;
      }
      ++tested;
      EXPECT_LT(tangent_error(p, law, {}, nullptr, step), 1e-6) << "depth " << depth;
      SurfaceContactOptions sharp; // the residual is a potential's gradient at share 1
      sharp.end_window = 0.0;
      if (depth >= 1e-7 && solve(p, law, {}, sharp).active) {
        EXPECT_LT(residual_error(p, law, sharp), 1e-6) << "depth " << depth;
      }
    }
  }
}

TEST(SurfaceContact, TangentMatchesCentralDifferencesNearElementEnds) {
  std::mt19937 rng(7);
  const LinearPenalty law(kEps);
  int tested = 0;
  while (tested < 12) {
    Pair p = random_crossing(rng);
    // Slide B along A's axis and A along B's until the contact sits near an end.
    const SurfaceContactResult r0 = solve(p, law);
    if (r0.status != ProjectionStatus::Converged) {
      continue;
    }
    const double target_a = (tested % 2 == 0 ? 0.98 : -0.98);
    const double target_b = (tested % 3 == 0 ? -0.97 : 0.3);
    const Vector3d along_a = 0.5 * (p.a[1].position - p.a[0].position);
    const Vector3d along_b = 0.5 * (p.b[1].position - p.b[0].position);
    translate_b(p, (target_a - r0.zeta_A) * along_a - (target_b - r0.zeta_B) * along_b);
    if (!place(p, -5e-6)) {
      continue;
    }
    const SurfaceContactResult r = solve(p, law);
    if (std::abs(r.zeta_A) < 0.9) {
      continue; // strongly bent pairs move the point elsewhere; not this test's case
    }
    ++tested;
    EXPECT_LT(tangent_error(p, law), 1e-6) << "zeta " << r.zeta_A << ", " << r.zeta_B;
  }
}

TEST(SurfaceContact, DampingTangentIncludesTheRateCoupling) {
  std::mt19937 rng(19);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const DampedLaw law(std::make_shared<LinearPenalty>(kEps), 20.0);
  int tested = 0;
  while (tested < 8) {
    Pair p = random_crossing(rng);
    if (!place(p, -5e-6)) {
      continue;
    }
    ++tested;
    SurfacePairRates rates;
    for (int i = 0; i < 24; ++i) {
      rates.rate(i) = (i % 12 < 6 ? 0.01 : 10.0) * u(rng);
    }
    rates.velocity_per_displacement = 0.5 / (0.3 * 1e-4); // Newmark gamma / (beta dt)
    const SurfaceContactResult r = solve(p, law, {}, {}, &rates);
    ASSERT_TRUE(r.active);
    if (!(r.force > 0.0)) {
      continue;
    }
    EXPECT_NEAR(r.force, r.share * (kEps * r.penetration + 20.0 * r.penetration_rate),
                1e-9 * r.force);
    EXPECT_LT(tangent_error(p, law, {}, &rates), 1e-6);
  }
}

TEST(SurfaceContact, RigidMotionsDoNoWork) {
  // A small rigid rotation of the whole pair about any point, carried by the Rodrigues
  // increments (alpha + Xi(alpha)^-1 dphi to first order) and the positions, changes neither
  // the gap nor the potential: residual . (rigid motion) = 0, and the forces on A and B cancel.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const LinearPenalty law(kEps);
  int tested = 0;
  while (tested < 10) {
    Pair p = random_crossing(rng);
    if (!place(p, -6e-6)) {
      continue;
    }
    ++tested;
    const SurfaceContactResult r = solve(p, law);
    const Vector3d dphi(u(rng), u(rng), u(rng));
    const Vector3d centre = 1e-3 * Vector3d(u(rng), u(rng), u(rng));
    Vec24 motion;
    for (int i = 0; i < 24; ++i) {
      // Through a pointer: bound as `(i < 12 ? p.a : p.b)[k]`, the reference read other data in
      // the sanitizer build (this test then failed there only).
      const SurfaceNode* surface = i < 12 ? p.a : p.b;
      const int j = i % 12;
      const SurfaceNode& n = surface[(j % 6) / 3];
      if (j < 6) {
        motion(i) = dphi.cross(n.position - centre)(j % 3);
      } else {
        motion(i) = (rodrigues_xi<double>(n.rotation_increment).inverse() * dphi)(j % 3);
      }
    }
    const double scale = r.residual.cwiseAbs().maxCoeff() * 1e-3;
    EXPECT_NEAR(r.residual.dot(motion), 0.0, 1e-10 * scale);
    Vector3d total = Vector3d::Zero();
    for (int k = 0; k < 4; ++k) {
      total += r.residual.segment<3>(k < 2 ? 3 * k : 12 + 3 * (k - 2));
    }
    EXPECT_LT(total.norm(), 1e-10 * r.force);
  }
}

// ---- Projection against brute force
// --------------------------------------------------------------

/// Independent evaluation of a surface for the brute-force reference: eq. 3 written out, the
/// section from phi with std::pow.
struct Reference {
  Vector3d x[2];
  Matrix3d q[2];
  double a, b, m;
  Reference(const SurfaceNode (&n)[2], const SuperEllipse& s) : a(s.a()), b(s.b()), m(s.m()) {
    for (int k = 0; k < 2; ++k) {
      x[k] = n[k].position;
      q[k] = rodrigues_rotation<double>(n[k].rotation_increment) * n[k].converged_rotation;
    }
  }
  Vector3d operator()(double zeta, double theta) const {
    const double c = std::cos(theta);
    const double s = std::sin(theta);
    const double phi = std::pow(std::pow(std::abs(c), m) + std::pow(std::abs(s), m), -1.0 / m);
    const Vector3d sec(a * phi * c, b * phi * s, 0.0);
    return 0.5 * (1 - zeta) * (x[0] + q[0] * sec) + 0.5 * (1 + zeta) * (x[1] + q[1] * sec);
  }
  /// dGamma/dzeta (exact: linear) and dGamma/dtheta (fourth-order central differences).
  Vector3d d_zeta(double /*zeta*/, double theta) const {
    return 0.5 * ((*this)(1.0, theta) - (*this)(-1.0, theta));
  }
  Vector3d d_theta(double zeta, double theta) const {
    const double h = 1e-3;
    return (-(*this)(zeta, theta + 2 * h) + 8.0 * (*this)(zeta, theta + h) -
            8.0 * (*this)(zeta, theta - h) + (*this)(zeta, theta - 2 * h)) /
           (12 * h);
  }
  Vector3d normal(double zeta, double theta) const {
    Vector3d n = d_theta(zeta, theta).cross(d_zeta(zeta, theta)).normalized();
    const Vector3d radial =
        (*this)(zeta, theta) - (0.5 * (1 - zeta) * x[0] + 0.5 * (1 + zeta) * x[1]);
    return n.dot(radial) < 0 ? -n : n;
  }
};

struct BruteForce {
  Vec4 c;
  Vector3d point_A;
  Vector3d point_B;
  double gap;
};

/// eq. 5 from the reference surfaces; fixed coordinates (mask) give r_i = 0.
Vec4 lcp_residual(const Reference& ra, const Reference& rb, const Vec4& c, const bool (&fixed)[4]) {
  const Vector3d g = ra(c(0), c(1)) - rb(c(2), c(3));
  Vec4 r;
  r << ra.d_zeta(c(0), c(1)).dot(g), ra.d_theta(c(0), c(1)).dot(g), -rb.d_zeta(c(2), c(3)).dot(g),
      -rb.d_theta(c(2), c(3)).dot(g);
  for (int i = 0; i < 4; ++i) {
    if (fixed[i]) {
      r(i) = 0.0;
    }
  }
  return r;
}

/// Newton's method on eq. 5 with a finite-difference Jacobian: polishes a sampled estimate to the
/// critical point next to it.
Vec4 polish(const Reference& ra, const Reference& rb, Vec4 c, const bool (&fixed)[4]) {
  for (int it = 0; it < 30; ++it) {
    const Vec4 r = lcp_residual(ra, rb, c, fixed);
    Eigen::Matrix4d j;
    for (int k = 0; k < 4; ++k) {
      if (fixed[k]) {
        j.col(k) = Vec4::Unit(k);
        continue;
      }
      Vec4 cp = c;
      Vec4 cm = c;
      cp(k) += 1e-6;
      cm(k) -= 1e-6;
      j.col(k) = (lcp_residual(ra, rb, cp, fixed) - lcp_residual(ra, rb, cm, fixed)) / 2e-6;
    }
    for (int k = 0; k < 4; ++k) {
      if (fixed[k]) {
        j.row(k) = Vec4::Unit(k).transpose();
      }
    }
    const Vec4 step = -j.partialPivLu().solve(r);
    c += step;
    if (step.cwiseAbs().maxCoeff() < 1e-14) {
      break;
    }
  }
  return c;
}

/// Samples of one surface over its range (zeta fixed if `fixed_zeta` is finite).
struct Samples {
  std::vector<Vector3d> x;
  std::vector<Eigen::Vector2d> c;
};

Samples sample(const Reference& r, double fixed_zeta) {
  Samples s;
  const int nz = std::isfinite(fixed_zeta) ? 1 : 41;
  const int nt = 120;
  for (int i = 0; i < nz; ++i) {
    const double zeta = std::isfinite(fixed_zeta) ? fixed_zeta : -1.0 + 2.0 * i / (nz - 1);
    for (int j = 0; j < nt; ++j) {
      const double theta = 2 * kPi * j / nt;
      s.x.push_back(r(zeta, theta));
      s.c.emplace_back(zeta, theta);
    }
  }
  return s;
}

/// Minimum of |Gamma_B(c_B) - p| over B by sampling, then zooming in.
double closest_on(const Reference& rb, const Samples& sb, const Vector3d& p, Eigen::Vector2d& arg) {
  double best = INFINITY;
  for (std::size_t k = 0; k < sb.x.size(); ++k) {
    const double d = (sb.x[k] - p).squaredNorm();
    if (d < best) {
      best = d;
      arg = sb.c[k];
    }
  }
  // Pattern search: stay at a width while the best point moves, halve it when it does not.
  double wz = 2.0 / 40;
  double wt = 2 * kPi / 120;
  for (int level = 0; level < 400 && wt > 1e-11; ++level) {
    const Eigen::Vector2d centre = arg;
    for (int i = -1; i <= 1; ++i) {
      for (int j = -1; j <= 1; ++j) {
        const Eigen::Vector2d c(std::clamp(centre(0) + wz * i, -1.0, 1.0), centre(1) + wt * j);
        const double d = (rb(c(0), c(1)) - p).squaredNorm();
        if (d < best) {
          best = d;
          arg = c;
        }
      }
    }
    if (arg == centre) {
      wz *= 0.5;
      wt *= 0.5;
    }
  }
  return std::sqrt(best);
}

/// Brute-force LCP solution. Separated: the minimum distance over both (sampled, zoomed)
/// surfaces. Overlapping: the point of A deepest inside B (the largest distance to B's surface
/// among A's points inside B) and its closest point on B. Both then polished on eq. 5.
/// A finite `fixed_zeta_a` restricts A to that section (the degenerate path's reduced problem).
BruteForce brute_force(const Pair& p, bool overlapping, double fixed_zeta_a = NAN) {
  const Reference ra(p.a, p.sa);
  const Reference rb(p.b, p.sb);
  const Samples sa = sample(ra, fixed_zeta_a);
  const Samples sb = sample(rb, NAN);
  const bool fix_a = std::isfinite(fixed_zeta_a);
  // Score of a point of A: minus its distance to B (separated), or its depth inside B.
  auto score = [&](const Eigen::Vector2d& ca, Eigen::Vector2d& cb) {
    const Vector3d x = ra(ca(0), ca(1));
    const double d = closest_on(rb, sb, x, cb);
    if (!overlapping) {
      return -d;
    }
    const bool inside = (x - rb(cb(0), cb(1))).dot(rb.normal(cb(0), cb(1))) < 0.0;
    return inside && std::abs(cb(0)) < 0.999 ? d : -INFINITY;
  };
  double best = -INFINITY;
  Eigen::Vector2d arg_a(0, 0);
  Eigen::Vector2d arg_b(0, 0);
  for (std::size_t k = 0; k < sa.x.size(); ++k) {
    // Coarse inner minimum by sampling only.
    double d2 = INFINITY;
    Eigen::Vector2d cb(0, 0);
    for (std::size_t l = 0; l < sb.x.size(); ++l) {
      const double e = (sb.x[l] - sa.x[k]).squaredNorm();
      if (e < d2) {
        d2 = e;
        cb = sb.c[l];
      }
    }
    double s = -std::sqrt(d2);
    if (overlapping) {
      const bool inside = (sa.x[k] - rb(cb(0), cb(1))).dot(rb.normal(cb(0), cb(1))) < 0.0;
      s = inside && std::abs(cb(0)) < 0.999 ? std::sqrt(d2) : -INFINITY;
    }
    if (s > best) {
      best = s;
      arg_a = sa.c[k];
      arg_b = cb;
    }
  }
  double wz = fix_a ? 0.0 : 2.0 / 40;
  double wt = 2 * kPi / 120;
  best = score(arg_a, arg_b);
  for (int level = 0; level < 400 && wt > 1e-9; ++level) {
    const Eigen::Vector2d centre = arg_a;
    for (int i = -1; i <= 1; ++i) {
      for (int j = -1; j <= 1; ++j) {
        const Eigen::Vector2d c(std::clamp(centre(0) + wz * i, -1.0, 1.0), centre(1) + wt * j);
        Eigen::Vector2d cb = arg_b;
        const double s = score(c, cb);
        if (s > best) {
          best = s;
          arg_a = c;
          arg_b = cb;
        }
      }
    }
    if (arg_a == centre) {
      wz *= 0.5;
      wt *= 0.5;
    }
  }
  const bool fixed[4] = {fix_a, false, false, false};
  const Vec4 c = polish(ra, rb, Vec4(arg_a(0), arg_a(1), arg_b(0), arg_b(1)), fixed);
  BruteForce out;
  out.c = c;
  out.point_A = ra(c(0), c(1));
  out.point_B = rb(c(2), c(3));
  out.gap = (overlapping ? -1.0 : 1.0) * (out.point_A - out.point_B).norm();
  return out;
}

/// Compares the kernel (cold start) with brute force on `count` pairs from `make`.
template <class Make>
void compare_with_brute_force(Make make, double gap, int count, SurfaceDegeneration expected) {
  const LinearPenalty law(kEps);
  int tested = 0;
  int attempts = 0;
  while (tested < count && attempts < 20 * count) {
    ++attempts;
    Pair p = make();
    if (!place(p, gap)) {
      continue;
    }
    const SurfaceContactResult r = solve(p, law);
    ASSERT_EQ(r.status, ProjectionStatus::Converged);
    ASSERT_EQ(r.degeneration, expected);
    if (std::abs(r.zeta_A) > 0.9 || std::abs(r.zeta_B) > 0.9) {
      continue; // keep the brute force's points inside both elements
    }
    ++tested;
    const BruteForce bf =
        brute_force(p, gap < 0.0, expected == SurfaceDegeneration::Parallel ? r.zeta_A : NAN);
    EXPECT_NEAR(r.gap, bf.gap, 1e-9 * std::abs(bf.gap)) << "pair " << tested;
    EXPECT_LT((r.point_A - bf.point_A).norm(), 1e-9 * kA) << "pair " << tested;
    EXPECT_LT((r.point_B - bf.point_B).norm(), 1e-9 * kA) << "pair " << tested;
  }
  EXPECT_EQ(tested, count);
}

TEST(SurfaceProjection, SeparatedCrossingsAgreeWithBruteForce) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  compare_with_brute_force([&] { return random_crossing(rng, 20.0, 3e-3, 0.03); },
                           2e-5 + 5e-5 * u(rng), 6, SurfaceDegeneration::None);
}

TEST(SurfaceProjection, OverlappingCrossingsAgreeWithBruteForce) {
  std::mt19937 rng(2);
  compare_with_brute_force([&] { return random_crossing(rng, 20.0, 3e-3, 0.03); }, -2e-5, 6,
                           SurfaceDegeneration::None);
}

TEST(SurfaceProjection, RightAngleCrossingsAgreeWithBruteForce) {
  std::mt19937 rng(4);
  for (const double gap : {3e-5, -3e-5}) {
    compare_with_brute_force([&] { return random_crossing(rng, 89.0, 3e-3, 0.03); }, gap, 3,
                             SurfaceDegeneration::None);
  }
}

/// B nearly parallel to A: A's axis turned by `angle` about the normal of the fabric, B beside
/// A (section axes a in the plane), both elements of length `length`, B shifted along A.
Pair near_parallel(std::mt19937& rng, double angle, double shift, double length,
                   double bend = 0.01) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Eigen::Quaterniond q = random_rotation(rng);
  const Vector3d up = q * Vector3d::UnitZ();
  const Vector3d da = q * Vector3d::UnitX();
  const Vector3d db = q * Vector3d(std::cos(angle), std::sin(angle), 0.0);
  Pair p;
  random_element(rng, p.a, Vector3d::Zero(), da, da.cross(up), 0.3 * u(rng), length, bend);
  // B stacked on A (flat sides facing), shifted along A.
  random_element(rng, p.b, shift * length * da + 2.0 * kB * up, db, db.cross(up), 0.3 * u(rng),
                 length, bend);
  return p;
}

TEST(SurfaceProjection, NearlyParallelCrossingsAgreeWithBruteForce) {
  std::mt19937 rng(6);
  for (const double gap : {2e-5, -2e-5}) {
    compare_with_brute_force([&] { return near_parallel(rng, 0.15, 0.1, 3e-3); }, gap, 3,
                             SurfaceDegeneration::None);
  }
}

TEST(SurfaceProjection, ParallelPathAgreesWithBruteForceOnTheReducedProblem) {
  std::mt19937 rng(9);
  for (const double gap : {2e-5, -2e-5}) {
    compare_with_brute_force([&] { return near_parallel(rng, 2e-3, 0.3, 3e-3, 1e-3); }, gap, 3,
                             SurfaceDegeneration::Parallel);
  }
}

// ---- Degenerate paths
// ------------------------------------------------------------------------------

TEST(SurfaceContact, ParallelElementsTouchAtTheOverlapMidpoint) {
  const LinearPenalty law(kEps);
  const double length = 2e-3;
  const double delta = 2e-6;
  Pair p;
  const Matrix3d q = frame(Vector3d::UnitY(), Vector3d::UnitX());
  p.a[0] = node(Vector3d(-0.5 * length, 0, 0), q);
  p.a[1] = node(Vector3d(0.5 * length, 0, 0), q);
  // B stacked on A, shifted by half an element: overlap [0, L/2], midpoint at x = L/4.
  p.b[0] = node(Vector3d(0, 0, 2 * kB - delta), q);
  p.b[1] = node(Vector3d(length, 0, 2 * kB - delta), q);
  const SurfaceContactResult r = solve(p, law);
  ASSERT_EQ(r.degeneration, SurfaceDegeneration::Parallel);
  ASSERT_EQ(r.status, ProjectionStatus::Converged);
  EXPECT_NEAR(r.zeta_A, 0.5, 1e-14);
  EXPECT_NEAR(r.zeta_B, -0.5, 1e-12);
  EXPECT_LT((r.point_A - Vector3d(0.25 * length, 0, kB)).norm(), 1e-15);
  EXPECT_LT((r.point_B - Vector3d(0.25 * length, 0, kB - delta)).norm(), 1e-15);
  EXPECT_NEAR(r.force, kEps * delta, 1e-9 * kEps * delta);
}

TEST(SurfaceContact, NearParallelElementsHaveAConsistentTangent) {
  std::mt19937 rng(11);
  const LinearPenalty law(kEps);
  const PowerLaw power(3e7, 1.5);
  int tested = 0;
  for (int trial = 0; trial < 60 && tested < 12; ++trial) {
    const double shift = std::array<double, 4>{0.12, 0.3, -0.25, 0.05}[trial % 4];
    const double angle = std::array<double, 3>{4e-3, -2e-3, 1e-5}[trial % 3];
    Pair p = near_parallel(rng, angle, shift, 1e-3, 1e-3);
    if (!place(p, -3e-6)) {
      continue;
    }
    const SurfaceContactResult r = solve(p, law);
    ASSERT_EQ(r.degeneration, SurfaceDegeneration::Parallel);
    ++tested;
    EXPECT_LT(tangent_error(p, law), 1e-6) << "trial " << trial;
    EXPECT_LT(tangent_error(p, power), 1e-6) << "trial " << trial;
    EXPECT_LT(residual_error(p, law), 1e-6) << "trial " << trial;
  }
  EXPECT_GE(tested, 10);
}

TEST(SurfaceContact, FlatFacedSectionsTouchWhereTheAxesCross) {
  const LinearPenalty law(kEps);
  const double delta = 4e-6;
  for (const double m : {4.0, 8.0}) {
    Pair p = right_angle_crossing(2 * kB - delta, 0.0, 0.3e-3, 0.1e-3);
    p.sa = SuperEllipse(kA, kB, m);
    p.sb = SuperEllipse(kA, kB, m);
    const SurfaceContactResult r = solve(p, law);
    ASSERT_EQ(r.status, ProjectionStatus::Converged) << m;
    EXPECT_EQ(r.degeneration, SurfaceDegeneration::FlatOnBoth);
    EXPECT_NEAR(r.zeta_A, -0.3, 1e-14);
    EXPECT_NEAR(r.zeta_B, -0.1, 1e-14);
    EXPECT_NEAR(r.gap, -delta, 1e-17);
    EXPECT_LT((r.point_A - Vector3d(0, 0, kB)).norm(), 1e-15);
    EXPECT_NEAR(r.force, kEps * delta, 1e-9 * kEps * delta);
  }
}

TEST(SurfaceContact, TurnedEllipseOnAFlatFaceTouchesAtItsSupportPoint) {
  // A (an ellipse turned by psi) under B's flat face (m = 6): B's face is straight along A's
  // axis, so zeta_A is fixed where the axes cross; the gap is still the support distance.
  const LinearPenalty law(kEps);
  const double psi = 0.6;
  const double h =
      std::sqrt(kA * kA * std::sin(psi) * std::sin(psi) + kB * kB * std::cos(psi) * std::cos(psi));
  Pair p = right_angle_crossing(kB + h - 3e-6, psi, 0.2e-3, 0.0);
  p.sb = SuperEllipse(kA, kB, 6.0);
  const SurfaceContactResult r = solve(p, law);
  ASSERT_EQ(r.status, ProjectionStatus::Converged);
  EXPECT_EQ(r.degeneration, SurfaceDegeneration::FlatOnB);
  EXPECT_NEAR(r.zeta_A, -0.2, 1e-14);
  EXPECT_NEAR(r.gap, -3e-6, 1e-15);
  EXPECT_NEAR(r.point_A.y(), (kA * kA - kB * kB) * std::sin(psi) * std::cos(psi) / h, 1e-14);
}

TEST(SurfaceContact, FlatPathsHaveAConsistentTangent) {
  std::mt19937 rng(13);
  const LinearPenalty law(kEps);
  const struct {
    double ma, mb, twist_a, twist_b;
    SurfaceDegeneration path;
  } cases[] = {{4.0, 6.0, 0.01, 0.01, SurfaceDegeneration::FlatOnBoth},
               {4.0, 2.0, 0.01, 0.4, SurfaceDegeneration::FlatOnA},
               {2.0, 8.0, 0.4, 0.01, SurfaceDegeneration::FlatOnB}};
  for (const auto& k : cases) {
    int tested = 0;
    int attempts = 0;
    while (tested < 5 && ++attempts < 200) {
      Pair p = random_crossing(rng, 40.0, 1e-3, 0.005, k.twist_a, k.twist_b);
      p.sa = SuperEllipse(kA, kB, k.ma);
      p.sb = SuperEllipse(kA, kB, k.mb);
      if (!place(p, -4e-6)) {
        continue;
      }
      const SurfaceContactResult r = solve(p, law);
      if (r.degeneration != k.path || std::abs(r.zeta_A) > 0.9 || std::abs(r.zeta_B) > 0.9) {
        continue; // the twist put the point elsewhere; not this case
      }
      ++tested;
      EXPECT_LT(tangent_error(p, law), 1e-6) << to_string(k.path) << " " << tested;
      EXPECT_LT(residual_error(p, law), 1e-6) << to_string(k.path) << " " << tested;
    }
    EXPECT_EQ(tested, 5) << to_string(k.path);
  }
}

// ---- Starts, statuses and ownership
// ---------------------------------------------------------------

TEST(SurfaceProjection, WarmStartConvergesInFewIterations) {
  std::mt19937 rng(23);
  const LinearPenalty law(kEps);
  int tested = 0;
  while (tested < 20) {
    Pair p = random_crossing(rng);
    if (!place(p, -3e-6)) {
      continue;
    }
    const SurfaceContactResult cold = solve(p, law);
    if (std::abs(cold.zeta_A) > 0.9 || std::abs(cold.zeta_B) > 0.9) {
      continue; // the small move could hand the contact to a neighbour
    }
    ++tested;
    Pair moved = p;
    translate_b(moved, Vector3d(1e-6, -2e-6, 1e-6));
    moved.b[0].rotation_increment += Vector3d(1e-3, 0, -1e-3);
    const SurfaceContactResult warm = solve(moved, law, warm_start(cold));
    EXPECT_EQ(warm.status, ProjectionStatus::Converged);
    EXPECT_LE(warm.iterations, 4);
  }
}

TEST(SurfaceProjection, StatusReportsOutOfRangeJumpAndFailure) {
  const LinearPenalty law(kEps);
  // B crosses A's axis beyond A's end: a neighbour's contact.
  const Pair beyond = right_angle_crossing(2 * kB - 1e-6, 0.0, 1.3e-3, 0.0);
  const SurfaceContactResult out = solve(beyond, law);
  EXPECT_EQ(out.status, ProjectionStatus::OutOfRange);
  EXPECT_FALSE(out.active);
  EXPECT_EQ(out.residual.norm(), 0.0);
  // A warm start far from the solution: the point jumped.
  const Pair p = right_angle_crossing(2 * kB - 1e-6);
  const SurfaceContactResult jumped = solve(p, law, {-0.8, 0.2, 0.9, 3.0, true});
  EXPECT_EQ(jumped.status, ProjectionStatus::Jumped);
  EXPECT_TRUE(jumped.active); // still owned: the engine decides whether to veto
  const SurfaceContactResult small = solve(p, law, {0.1, 0.5 * kPi + 0.1, -0.1, 1.5 * kPi, true});
  EXPECT_EQ(small.status, ProjectionStatus::Converged);
  // A collapsed element has no axis.
  Pair collapsed = p;
  collapsed.a[1].position = collapsed.a[0].position;
  EXPECT_EQ(solve(collapsed, law).status, ProjectionStatus::NotConverged);
  // Axes that cross (a penetration through the whole section) have no acceptable solution.
  EXPECT_EQ(solve(right_angle_crossing(0.0), law).status, ProjectionStatus::NotConverged);
}

TEST(SurfaceProjection, ContactSlidingAlongAStraightYarnIsHeldExactlyOnce) {
  // A contact sliding along a straight yarn passes from element to element; within a node's
  // window the two elements hold it together, their shares summing to one, and the force they
  // carry together is the law's, eps times the penetration, at every position.
  const LinearPenalty law(kEps);
  const int elements = 6;
  const double length = 0.9e-3;
  const Matrix3d qa = frame(Vector3d::UnitY(), Vector3d::UnitX());
  const Matrix3d qb = frame(-Vector3d::UnitX(), Vector3d::UnitY());
  const SuperEllipse section(kA, kB);
  std::vector<SurfaceNode> yarn;
  for (int i = 0; i <= elements; ++i) {
    yarn.push_back(node(Vector3d(i * length, 0, 0), qa, Vector3d(0.1, -0.2, 0.05)));
  }
  std::vector<int> holders_seen;
  int shared_positions = 0;
  for (int s = 0; s <= 997; ++s) {
    const double x = (1.1 + 3.8 * s / 997.0) * length;
    const SuperEllipticalCylinder b(node(Vector3d(x, -length, 2 * kB - 2e-6), qb),
                                    node(Vector3d(x, length, 2 * kB - 2e-6), qb), section);
    int active = 0;
    double shares = 0.0;
    double force = 0.0;
    for (int e = 0; e < elements; ++e) {
      const SuperEllipticalCylinder a(yarn[e], yarn[e + 1], section, e + 1 == elements,
                                      e > 0 ? &yarn[e - 1] : nullptr);
      const SurfaceContactResult r = surface_contact(a, b, {}, law);
      if (r.active) {
        ++active;
        shares += r.share;
        force += r.force;
        EXPECT_NEAR(r.penetration, 2e-6, 1e-15);
        if (std::find(holders_seen.begin(), holders_seen.end(), e) == holders_seen.end()) {
          holders_seen.push_back(e);
        }
      }
    }
    ASSERT_GE(active, 1) << "x = " << x / length << " elements";
    ASSERT_LE(active, 2) << "x = " << x / length << " elements";
    shared_positions += active == 2 ? 1 : 0;
    EXPECT_NEAR(shares, 1.0, 1e-12) << "x = " << x / length << " elements";
    EXPECT_NEAR(force, kEps * 2e-6, 1e-8 * kEps * 2e-6) << "x = " << x / length << " elements";
  }
  // x runs from 1.1 to 4.9 element lengths: elements 1 to 4, and 0 and 5 through the windows
  // of nodes 1 and 5 (half-width 0.25 in zeta, an eighth of an element on either side).
  EXPECT_EQ(holders_seen.size(), 6u);
  // Shared over a quarter element around nodes 2, 3 and 4, and the 0.025 elements of the
  // windows of nodes 1 and 5 that the range reaches.
  EXPECT_NEAR(shared_positions, (3 * 0.25 + 2 * 0.025) / 3.8 * 998, 3);
}

TEST(SurfaceProjection, ContactExactlyAboveANodeIsSharedEqually) {
  // A symmetric mesh puts a crossing exactly over a node: the two elements hold it half each,
  // whichever side rounding puts their solutions on.
  const LinearPenalty law(kEps);
  const SuperEllipse section(kA, kB);
  const Matrix3d qa = frame(Vector3d::UnitY(), Vector3d::UnitX());
  const Matrix3d qb = frame(-Vector3d::UnitX(), Vector3d::UnitY());
  for (const double length : {0.7e-3, 1.0e-3, 1.3e-3}) {
    std::vector<SurfaceNode> yarn;
    for (int i = 0; i <= 5; ++i) {
      yarn.push_back(node(Vector3d(i * length - 1.7e-3, 0, 0), qa, Vector3d(0.3, -0.1, 0.2)));
    }
    for (int k = 1; k < 5; ++k) {
      const double x = yarn[k].position.x();
      const SuperEllipticalCylinder b(node(Vector3d(x, -length, 2 * kB - 1e-6), qb),
                                      node(Vector3d(x, length, 2 * kB - 1e-6), qb), section);
      int active = 0;
      double force = 0.0;
      for (int e = 0; e < 5; ++e) {
        const SuperEllipticalCylinder a(yarn[e], yarn[e + 1], section, e == 4,
                                        e > 0 ? &yarn[e - 1] : nullptr);
        const SurfaceContactResult r = surface_contact(a, b, {}, law);
        if (r.active) {
          ++active;
          force += r.force;
          EXPECT_NEAR(r.share, 0.5, 1e-9) << "node " << k << ", element " << e;
        }
      }
      EXPECT_EQ(active, 2) << "node " << k << ", element length " << length;
      EXPECT_NEAR(force, kEps * 1e-6, 1e-8 * kEps * 1e-6) << "node " << k;
    }
  }
}

/// A yarn along x with a crest (a convex kink of half-angle `kink`) at node 2, nodes every
/// `length`, and a straight yarn B crossing it at right angles above the crest at x.
struct Kink {
  std::vector<SurfaceNode> yarn;
  SuperEllipse section{kA, kB};
  Kink(double kink, double length) {
    const Matrix3d q = frame(Vector3d::UnitY(), Vector3d::UnitX());
    for (int i = 0; i <= 4; ++i) {
      const double d = (i - 2) * length;
      yarn.push_back(node(Vector3d(d * std::cos(kink), 0, -std::abs(d) * std::sin(kink)), q,
                          Vector3d(0.05 * i, -0.1, 0.02)));
    }
  }
  SuperEllipticalCylinder element(int e, bool with_previous) const {
    return {yarn[e], yarn[e + 1], section, e == 3, with_previous && e > 0 ? &yarn[e - 1] : nullptr};
  }
};

SuperEllipticalCylinder crossing_yarn(double x, double z) {
  const Matrix3d qb = frame(-Vector3d::UnitX(), Vector3d::UnitY());
  return {node(Vector3d(x, -1e-3, z), qb), node(Vector3d(x, 1e-3, z), qb), SuperEllipse(kA, kB)};
}

TEST(SurfaceContact, ContactOverAConvexKinkIsHeldOnceAndContinuously) {
  // Over a crest node each element's own solution lies beyond the node, on the other element:
  // with sharp ownership neither reaches the contact, which sits on the ridge between them.
  // With the previous element known, the element after the node holds it (RidgeOnA); the
  // windows around the node pass it on continuously to the elements' own solutions.
  const LinearPenalty law(kEps);
  const Kink k(0.04, 0.5e-3);
  const double z = 2 * kB - 2e-6;
  SurfaceContactOptions sharp;
  sharp.end_window = 0.0;
  Eigen::Matrix<double, 3, 5> previous_force = Eigen::Matrix<double, 3, 5>::Zero();
  int ridge = 0;
  int missed_without_neighbour = 0;
  std::vector<double> held; // sum of the active pairs' shares at each position
  for (int s = -300; s <= 300; ++s) {
    const double x = s * 1e-6;
    const SuperEllipticalCylinder b = crossing_yarn(x, z);
    double shares = 0.0;
    int active_plain = 0;
    Eigen::Matrix<double, 3, 5> force = Eigen::Matrix<double, 3, 5>::Zero();
    for (int e = 0; e < 4; ++e) {
      const SurfaceContactResult r = surface_contact(k.element(e, true), b, {}, law);
      if (r.active) {
        shares += r.share;
        ridge += r.degeneration == SurfaceDegeneration::RidgeOnA ? 1 : 0;
        force.col(e) += r.residual.segment<3>(0);
        force.col(e + 1) += r.residual.segment<3>(3);
      }
      active_plain += surface_contact(k.element(e, false), b, {}, law, sharp).active ? 1 : 0;
    }
    held.push_back(shares);
    missed_without_neighbour += active_plain == 0 && shares > 0.0 ? 1 : 0;
    if (s > -300) {
      // No jump where the holder changes: B moves 1 micron between positions, changing the
      // penetration by about the slope (0.04) times that; a jump would be a good part of the
      // crest's force eps * 2 microns.
      EXPECT_LT((force - previous_force).norm(), kEps * 0.15e-6) << "x = " << x;
    }
    previous_force = force;
  }
  // The contact exists on one interval of positions around the crest, with no hole, held once:
  // the shares sum to one within 2 % (across the kink the two elements' solutions are not
  // exactly the same point) over the interval's middle, x within 0.12 mm of the crest (the
  // contact reaches to about 0.135 mm). Near its ends the extension of the element after the
  // crest, which lies above the element before it, still touches where the real surface no
  // longer does: there a share fading to zero over the window remains.
  const auto first = std::find_if(held.begin(), held.end(), [](double h) { return h > 0.0; });
  const auto last =
      std::find_if(held.rbegin(), held.rend(), [](double h) { return h > 0.0; }).base();
  ASSERT_TRUE(first < last);
  for (auto it = first; it != last; ++it) {
    const int s = static_cast<int>(it - held.begin()) - 300;
    EXPECT_GT(*it, 0.0) << "x = " << s << " microns";
    EXPECT_LT(*it, 1.02) << "x = " << s << " microns";
    if (std::abs(s) <= 120) {
      EXPECT_NEAR(*it, 1.0, 0.02) << "x = " << s << " microns";
    }
  }
  EXPECT_NEAR(held[300], 1.0, 1e-12); // over the crest: the ridge alone
  EXPECT_GT(ridge, 100);
  EXPECT_GT(missed_without_neighbour, 100); // what the ridge treatment repairs
}

TEST(SurfaceContact, RidgeContactsHaveAConsistentTangent) {
  const LinearPenalty law(kEps);
  const Kink k(0.05, 0.5e-3);
  for (const double x : {-40e-6, 0.0, 25e-6}) {
    const SuperEllipticalCylinder b = crossing_yarn(x, 2 * kB - 3e-6);
    // The ridge on A (the kinked yarn is A) and on B (the roles swapped).
    for (const bool swap : {false, true}) {
      Pair p;
      p.a[0] = k.yarn[2];
      p.a[1] = k.yarn[3];
      p.b[0] = b.node(0);
      p.b[1] = b.node(1);
      if (swap) {
        std::swap(p.a, p.b);
      }
      // Pair builds cylinders without neighbours; solve directly with the previous node.
      const SurfaceNode& prev = k.yarn[1];
      auto run = [&](const Pair& q, const SurfaceProjectionStart& start) {
        const SuperEllipticalCylinder ca(q.a[0], q.a[1], q.sa, false, swap ? nullptr : &prev);
        const SuperEllipticalCylinder cb(q.b[0], q.b[1], q.sb, false, swap ? &prev : nullptr);
        return surface_contact(ca, cb, start, law);
      };
      const SurfaceContactResult r0 = run(p, {});
      ASSERT_TRUE(r0.active) << x;
      ASSERT_EQ(r0.degeneration,
                swap ? SurfaceDegeneration::RidgeOnB : SurfaceDegeneration::RidgeOnA)
          << "x = " << x;
      Mat24 fd;
      for (int i = 0; i < 24; ++i) {
        const double h = 1e-6 * dof_scale(i);
        Pair plus = p;
        Pair minus = p;
        dof(plus, i) += h;
        dof(minus, i) -= h;
        fd.col(i) =
            (run(plus, warm_start(r0)).residual - run(minus, warm_start(r0)).residual) / (2 * h);
      }
      double err = 0.0;
      double ref = 0.0;
      for (int i = 0; i < 24; ++i) {
        for (int j = 0; j < 24; ++j) {
          const double sc = dof_scale(i) * dof_scale(j);
          err = std::max(err, sc * std::abs(fd(i, j) - r0.tangent(i, j)));
          ref = std::max(ref, sc * std::abs(r0.tangent(i, j)));
        }
      }
      EXPECT_LT(err / ref, 1e-6) << "x = " << x << (swap ? " (B)" : " (A)");
    }
  }
}

} // namespace
} // namespace yarnsim::contact
