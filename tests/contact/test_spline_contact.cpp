#include "contact/spline_contact.hpp"
#include "contact/spline_curve.hpp"

#include "spline_pairs.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <set>
#include <utility>
#include <vector>

namespace yarnsim::contact {
namespace {

using namespace test;

using Eigen::Matrix3d;
using Eigen::Vector3d;

SplineContactResult solve(const Pair& p, const InterfaceLaw& law, const ProjectionStart& start = {},
                          const SplineContactOptions& options = {},
                          const PairRates* rates = nullptr) {
  return spline_contact(p.xa, *p.ba, p.ra, p.xb, *p.bb, p.rb, start, law, options, rates);
}

/// Max-norm relative error of the tangent against central differences of the residual.
/// The perturbed solves are warm-started from the base solution, as in a Newton iteration.
double tangent_error(const Pair& base, const InterfaceLaw& law, const PairRates* rates = nullptr) {
  const SplineContactResult r0 = solve(base, law, {}, {}, rates);
  EXPECT_EQ(r0.status, ProjectionStatus::Converged);
  EXPECT_TRUE(r0.active);
  const ProjectionStart warm{r0.xi_A, r0.xi_B, true};
  const Mat18 fd = central_differences(base, rates, [&](const Pair& p, const PairRates* moved) {
    const SplineContactResult r = solve(p, law, warm, {}, moved);
    EXPECT_EQ(r.status, ProjectionStatus::Converged);
    EXPECT_EQ(r.degenerate, r0.degenerate);
    return r.residual;
  });
  return (fd - r0.tangent).cwiseAbs().maxCoeff() / r0.tangent.cwiseAbs().maxCoeff();
}

/// Max-norm relative error of the residual against central differences of the law's potential.
double residual_error(const Pair& base, const InterfaceLaw& law) {
  const SplineContactResult r0 = solve(base, law);
  EXPECT_TRUE(r0.active);
  const double h = 1e-6 * kL;
  Vec18 fd;
  for (int i = 0; i < 18; ++i) {
    Pair plus = base;
    Pair minus = base;
    dof(plus, i) += h;
    dof(minus, i) -= h;
    fd(i) = (solve(plus, law).potential - solve(minus, law).potential) / (2 * h);
  }
  return (fd - r0.residual).cwiseAbs().maxCoeff() / r0.residual.cwiseAbs().maxCoeff();
}

TEST(SplineContact, CrossingBeamsGiveEpsTimesOverlapAlongTheNormal) {
  const SplineCurve c3(3);
  const LinearPenalty law(kEps);
  const double delta = 2e-6;
  Pair p{Matrix3d::Zero(), Matrix3d::Zero(), &c3.segment(0), &c3.segment(0), 2e-4, 3e-4};
  const double d = p.ra + p.rb - delta;
  for (int k = 0; k < 3; ++k) {
    p.xa.col(k) = Vector3d((k - 1) * kL, 0.0, 0.0);
    p.xb.col(k) = Vector3d(0.0, (k - 1) * kL, d); // B above A, at right angles
  }
  const SplineContactResult r = solve(p, law);
  ASSERT_EQ(r.status, ProjectionStatus::Converged);
  EXPECT_TRUE(r.active);
  EXPECT_FALSE(r.degenerate);
  EXPECT_NEAR(r.xi_A, 0.5, 1e-14);
  EXPECT_NEAR(r.xi_B, 0.5, 1e-14);
  EXPECT_NEAR(r.penetration, delta, 1e-18);
  EXPECT_NEAR(r.force, kEps * delta, 1e-9 * kEps * delta);
  EXPECT_LT((r.normal - Vector3d(0, 0, -1)).norm(), 1e-15);
  Vector3d on_a = Vector3d::Zero();
  Vector3d on_b = Vector3d::Zero();
  for (int k = 0; k < 3; ++k) {
    on_a += r.residual.segment<3>(3 * k);
    on_b += r.residual.segment<3>(9 + 3 * k);
  }
  // Internal-force sign: A is pushed down (-z), so its residual points up.
  EXPECT_LT((on_a - Vector3d(0, 0, kEps * delta)).norm(), 1e-9 * kEps * delta);
  EXPECT_LT((on_b + on_a).norm(), 1e-12 * kEps * delta);
  // The mid control point of a 3-point spline carries half the load at xi = 1/2.
  EXPECT_NEAR(r.residual(5), 0.5 * kEps * delta, 1e-9 * kEps * delta);
}

TEST(SplineContact, CrossingStraightMultiSegmentYarns) {
  const SplineCurve c7(7);
  const LinearPenalty law(kEps);
  const double delta = 5e-6;
  Eigen::Matrix3Xd ya(3, 7);
  Eigen::Matrix3Xd yb(3, 7);
  for (int i = 0; i < 7; ++i) {
    ya.col(i) = Vector3d((i - 3.3) * kL, 0.0, 0.0);
    yb.col(i) = Vector3d(0.0, (i - 2.8) * kL, 2 * kRadius - delta);
  }
  int owners = 0;
  Vector3d total = Vector3d::Zero();
  for (int a = 0; a < c7.num_segments(); ++a) {
    for (int b = 0; b < c7.num_segments(); ++b) {
      const Pair p{c7.control_points(ya, a), c7.control_points(yb, b), &c7.segment(a),
                   &c7.segment(b)};
      const SplineContactResult r = solve(p, law);
      if (r.active) {
        ++owners;
        EXPECT_NEAR(r.force, kEps * delta, 1e-8 * kEps * delta);
        for (int k = 0; k < 3; ++k) {
          total += r.residual.segment<3>(3 * k);
        }
      }
    }
  }
  EXPECT_EQ(owners, 1);
  EXPECT_LT((total - Vector3d(0, 0, kEps * delta)).norm(), 1e-8 * kEps * delta);
}

TEST(SplineContact, TangentMatchesCentralDifferencesAtRandomCrossings) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(-0.4, 0.4);
  const LinearPenalty linear(kEps);
  const PowerLaw power(5e8, 1.5);
  int tested = 0;
  while (tested < 40) {
    Pair p = random_crossing(rng);
    const double ua = u(rng);
    const double ub = u(rng);
    const double delta = 1e-6 + 1e-5 * (0.5 + 0.5 * u(rng));
    if (!place(p, ua, ub, delta)) {
      continue;
    }
    ++tested;
    EXPECT_LT(tangent_error(p, linear), 1e-6) << "configuration " << tested;
    EXPECT_LT(tangent_error(p, power), 1e-6) << "configuration " << tested;
  }
}

TEST(SplineContact, ARegularisedLawActsBeforeContactWithAConsistentTangent) {
  // contact::RegularisedPenalty over g0 = 4 um: a pair 2 um apart is active with force
  // eps (g0 - g)^2 / (2 g0) along its normal, and the tangent matches central differences at
  // gaps and penetrations on both sides of contact; 5 um apart it is inactive.
  const double g0 = 4e-6;
  const RegularisedPenalty law(kEps, g0);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.4, 0.4);
  int tested = 0;
  while (tested < 20) {
    Pair p = random_crossing(rng);
    const double ua = u(rng), ub = u(rng);
    const double delta = (tested % 2 == 0 ? -1 : 1) * (0.1 + 0.8 * (0.5 + 0.5 * u(rng))) * g0;
    if (!place(p, ua, ub, delta))
      continue;
    ++tested;
    const SplineContactResult r = solve(p, law);
    ASSERT_TRUE(r.active) << "penetration " << delta;
    EXPECT_NEAR(r.force, law.force(delta), 1e-9 * law.force(delta));
    EXPECT_LT(tangent_error(p, law), 1e-6) << "penetration " << delta;
  }
  Pair apart = random_crossing(rng);
  while (!place(apart, 0.1, -0.1, -1.25 * g0))
    apart = random_crossing(rng);
  EXPECT_FALSE(solve(apart, law).active);
  EXPECT_TRUE(solve(apart, law).status == ProjectionStatus::Converged);
}

TEST(SplineContact, TangentMatchesCentralDifferencesNearSegmentEnds) {
  std::mt19937 rng(7);
  const LinearPenalty law(kEps);
  const std::pair<double, double> targets[] = {{0.499, 0.0},  {-0.499, 0.1},   {0.2, 0.499},
                                               {0.1, -0.499}, {0.499, -0.499}, {-0.499, 0.499}};
  for (const auto& [ua, ub] : targets) {
    int tested = 0;
    while (tested < 5) {
      Pair p = random_crossing(rng);
      if (!place(p, ua, ub, 4e-6)) {
        continue;
      }
      // Strongly curved random pairs can have a second minimum that a cold start finds first.
      const SplineContactResult r = solve(p, law);
      if (std::abs(p.ba->local(r.xi_A) - ua) > 1e-9 || std::abs(p.bb->local(r.xi_B) - ub) > 1e-9) {
        continue;
      }
      ++tested;
      EXPECT_LT(tangent_error(p, law), 1e-6) << "targets " << ua << ", " << ub;
    }
  }
}

TEST(SplineContact, ResidualIsTheGradientOfTheContactPotential) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.45, 0.45);
  const LinearPenalty law(kEps);
  int tested = 0;
  while (tested < 20) {
    Pair p = random_crossing(rng);
    const double ua = u(rng);
    const double ub = u(rng);
    if (!place(p, ua, ub, 3e-6)) {
      continue;
    }
    ++tested;
    const SplineContactResult r = solve(p, law);
    EXPECT_NEAR(r.potential, 0.5 * kEps * r.penetration * r.penetration, 1e-20);
    EXPECT_LT(residual_error(p, law), 1e-6);
  }
}

/// Near-parallel pairs: A's segment and a copy of it rotated by `angle` about an axis across it,
/// offset sideways to the contact distance and shifted along A by `shift` (in segments).
Pair parallel_pair(std::mt19937& rng, int segment, double angle, double shift, double delta) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Pair p;
  p.ba = &curve5().segment(segment);
  p.bb = p.ba;
  const Eigen::Quaterniond q = random_rotation(rng);
  for (int k = 0; k < 3; ++k) {
    const double y = 0.05 * kL * u(rng);
    const double z = 0.05 * kL * u(rng);
    p.xa.col(k) = q * Vector3d((k - 1) * kL, y, z);
  }
  const Vector3d chord = p.xa * (p.ba->values_local(0.5) - p.ba->values_local(-0.5));
  const Vector3d side = chord.unitOrthogonal();
  const Vector3d axis = chord.cross(side).normalized();
  const Eigen::AngleAxisd turn(angle, axis);
  const Vector3d centre = p.xa * p.ba->values_local(0.0);
  for (int k = 0; k < 3; ++k) {
    p.xb.col(k) =
        centre + turn * (p.xa.col(k) - centre) + shift * chord + (2 * kRadius - delta) * side;
  }
  return p;
}

TEST(SplineContact, NearParallelSegmentsTakeTheDegeneratePathWithAConsistentTangent) {
  std::mt19937 rng(11);
  const LinearPenalty law(kEps);
  const PowerLaw power(5e8, 2.0);
  int tested = 0;
  for (int trial = 0; trial < 200 && tested < 24; ++trial) {
    const int segment = trial % 3;
    // Partial overlaps, one end set by B and one by A; not exactly aligned ends, where the
    // overlap's end switches from one segment to the other (a kink of the midpoint).
    const double shift = std::array<double, 4>{0.12, 0.3, -0.25, 0.05}[trial % 4];
    const double angle = std::array<double, 3>{4e-3, -2e-3, 1e-5}[trial % 3];
    const Pair p = parallel_pair(rng, segment, angle, shift, 3e-6);
    const SplineContactResult r = solve(p, law);
    ASSERT_TRUE(r.degenerate);
    if (r.status != ProjectionStatus::Converged || r.penetration < 1e-6) {
      continue; // curvature moved the closest points apart; not this test's case
    }
    ++tested;
    EXPECT_LT(tangent_error(p, law), 1e-6) << "trial " << trial;
    EXPECT_LT(tangent_error(p, power), 1e-6) << "trial " << trial;
    EXPECT_LT(residual_error(p, law), 1e-6) << "trial " << trial;
  }
  EXPECT_GE(tested, 12);
}

TEST(SplineContact, ParallelStraightSegmentsTouchAtTheOverlapMidpoint) {
  const SplineCurve c3(3);
  const LinearPenalty law(kEps);
  const double delta = 2e-6;
  Pair p{Matrix3d::Zero(), Matrix3d::Zero(), &c3.segment(0), &c3.segment(0)};
  for (int k = 0; k < 3; ++k) {
    p.xa.col(k) = Vector3d((k - 1) * kL, 0.0, 0.0);
    p.xb.col(k) = Vector3d((k - 1) * kL + 0.5 * kL, 0.0, 2 * kRadius - delta); // overlap [0, 1]
  }
  const SplineContactResult r = solve(p, law);
  ASSERT_TRUE(r.degenerate);
  ASSERT_EQ(r.status, ProjectionStatus::Converged);
  // A spans [-L, L], B [-L/2, 3L/2]: overlap [-L/2, L], midpoint L/4 = xi_A 0.625.
  EXPECT_NEAR(r.xi_A, 0.625, 1e-14);
  EXPECT_NEAR(r.point_A.x(), 0.25 * kL, 1e-15);
  EXPECT_NEAR(r.point_B.x(), 0.25 * kL, 1e-15);
  EXPECT_NEAR(r.force, kEps * delta, 1e-9 * kEps * delta);
}

TEST(SplineContact, DampingTangentIncludesTheVelocityCoupling) {
  std::mt19937 rng(19);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const DampedLaw law(std::make_shared<LinearPenalty>(kEps), 20.0);
  int tested = 0;
  while (tested < 10) {
    Pair p = random_crossing(rng);
    const double ua = 0.3 * u(rng);
    const double ub = 0.3 * u(rng);
    if (!place(p, ua, ub, 5e-6)) {
      continue;
    }
    ++tested;
    const PairRates rates = random_rates(rng);
    const SplineContactResult r = solve(p, law, {}, {}, &rates);
    ASSERT_TRUE(r.active);
    ASSERT_GT(r.force, 0.0);
    EXPECT_NEAR(r.force, kEps * r.penetration + 20.0 * r.penetration_rate, 1e-9 * r.force);
    EXPECT_LT(tangent_error(p, law, &rates), 1e-6);
  }
}

/// Minimum of |g| over both ranges by dense sampling and zooming in.
std::pair<double, Eigen::Vector2d> brute_force(const Pair& p) {
  auto distance = [&](double ua, double ub) {
    return (p.xa * p.ba->values_local(ua) - p.xb * p.bb->values_local(ub)).norm();
  };
  double best = INFINITY;
  Eigen::Vector2d arg(0, 0);
  const int n = 200;
  for (int i = 0; i <= n; ++i) {
    for (int j = 0; j <= n; ++j) {
      const double ua = -0.5 + double(i) / n;
      const double ub = -0.5 + double(j) / n;
      if (distance(ua, ub) < best) {
        best = distance(ua, ub);
        arg << ua, ub;
      }
    }
  }
  double width = 2.0 / n;
  for (int level = 0; level < 40; ++level) {
    const Eigen::Vector2d centre = arg;
    for (int i = -10; i <= 10; ++i) {
      for (int j = -10; j <= 10; ++j) {
        const double ua = std::clamp(centre(0) + width * i / 10.0, -0.5, 0.5);
        const double ub = std::clamp(centre(1) + width * j / 10.0, -0.5, 0.5);
        if (distance(ua, ub) < best) {
          best = distance(ua, ub);
          arg << ua, ub;
        }
      }
    }
    width *= 0.3;
  }
  return {best, arg};
}

/// Every local minimum of |g| on the segments' extended polynomials with |u_A|, |u_B| <= 4:
/// Newton's method on r = [g_a.g, g_b.g] = 0 (two cubics in (u_A, u_B), so at most nine roots)
/// from a 41 x 41 grid of starts, keeping the roots where the Hessian is positive definite.
std::vector<Eigen::Vector2d> local_minima(const Pair& p) {
  const Vector3d gaa = p.xa * p.ba->second_local();
  const Vector3d gbb = -(p.xb * p.bb->second_local());
  auto derivatives = [&](const Eigen::Vector2d& c, Eigen::Vector2d& r, Eigen::Matrix2d& h) {
    const Vector3d g = p.xa * p.ba->values_local(c(0)) - p.xb * p.bb->values_local(c(1));
    const Vector3d ga = p.xa * p.ba->first_local(c(0));
    const Vector3d gb = -(p.xb * p.bb->first_local(c(1)));
    r << ga.dot(g), gb.dot(g);
    h << ga.squaredNorm() + gaa.dot(g), ga.dot(gb), ga.dot(gb), gb.squaredNorm() + gbb.dot(g);
  };
  const double reach = 4.0;
  const int n = 40;
  std::vector<Eigen::Vector2d> minima;
  for (int i = 0; i <= n; ++i) {
    for (int j = 0; j <= n; ++j) {
      Eigen::Vector2d c(reach * (2.0 * i / n - 1.0), reach * (2.0 * j / n - 1.0));
      Eigen::Vector2d r;
      Eigen::Matrix2d h;
      bool root = false;
      for (int it = 0; it < 60 && !root && c.cwiseAbs().maxCoeff() < 2 * reach; ++it) {
        derivatives(c, r, h);
        const Eigen::Vector2d step = -h.inverse() * r;
        if (!step.allFinite()) {
          break;
        }
        c += step;
        root = step.norm() < 1e-13;
      }
      if (!root || c.cwiseAbs().maxCoeff() > reach) {
        continue;
      }
      derivatives(c, r, h);
      if (!(h(0, 0) > 0.0 && h.determinant() > 0.0)) {
        continue;
      }
      bool known = false;
      for (const Eigen::Vector2d& m : minima) {
        known = known || (m - c).norm() < 1e-6;
      }
      if (!known) {
        minima.push_back(c);
      }
    }
  }
  return minima;
}

TEST(SplineContact, ProjectionAgreesWithBruteForceSampling) {
  std::mt19937 rng(5);
  int converged = 0;
  int out_of_range = 0;
  for (int trial = 0; trial < 150; ++trial) {
    Pair p = random_crossing(rng);
    std::uniform_real_distribution<double> u(-0.8, 0.8);
    const double ua = u(rng);
    const double ub = u(rng);
    if (!place(p, ua, ub, 1e-5)) {
      continue;
    }
    // The projection starts cold, at the midpoints, up to 0.8 segments from the placed minimum.
    const ProjectionResult pr = closest_point_projection(p.xa, *p.ba, p.xb, *p.bb, {});
    const Eigen::Vector2d found(p.ba->local(pr.xi_A), p.bb->local(pr.xi_B));
    const std::vector<Eigen::Vector2d> minima = local_minima(p);
    if (pr.status == ProjectionStatus::Converged) {
      double nearest = INFINITY;
      for (const Eigen::Vector2d& m : minima) {
        nearest = std::min(nearest, (m - found).norm());
      }
      EXPECT_LT(nearest, 1e-8) << "trial " << trial << ": not a local minimum";
    }
    // The projection is a local solver. Where the curved segments give the distance several
    // local minima (about half of these pairs, counting those out to 4 segments), which one it
    // reaches depends on its path, and the closest points over the ranges need not be that one:
    // on one pair of this loop it converged, in range, at the placed minimum 0.55818 mm apart,
    // while a range end was 0.55756 mm apart and the distance fell further beyond it. The
    // comparison with the closest points over the ranges holds where the minimum is unique.
    if (minima.size() != 1) {
      continue;
    }
    const auto [best, arg] = brute_force(p);
    if (pr.status == ProjectionStatus::Converged) {
      ++converged;
      const Vector3d g = p.xa * p.ba->values(pr.xi_A) - p.xb * p.bb->values(pr.xi_B);
      EXPECT_NEAR(g.norm(), best, 1e-12 * kL) << "trial " << trial;
      EXPECT_NEAR(found(0), arg(0), 1e-6) << "trial " << trial;
      EXPECT_NEAR(found(1), arg(1), 1e-6) << "trial " << trial;
    } else {
      ASSERT_EQ(pr.status, ProjectionStatus::OutOfRange) << "trial " << trial;
      ++out_of_range;
      // The minimum over the ranges then lies on a range end.
      EXPECT_NEAR(arg.cwiseAbs().maxCoeff(), 0.5, 1e-12)
          << "trial " << trial << ": closest over the ranges at (" << arg.transpose()
          << "), projection at (" << found.transpose() << ")";
    }
  }
  EXPECT_GT(converged, 10);
  EXPECT_GT(out_of_range, 10);
}

/// Segment 0 of curve5() for A and B with the given control points (columns, metres).
Pair pinned_pair(const Matrix3d& xa, const Matrix3d& xb) {
  Pair p;
  p.ba = &curve5().segment(0);
  p.bb = &curve5().segment(0);
  p.xa = xa;
  p.xb = xb;
  return p;
}

/// Expects the cold projection of `p` to converge at the closest points over the ranges, found
/// by sampling, and the contact there to be active.
void expect_cold_projection_finds_the_closest_points(const Pair& p) {
  const auto [best, arg] = brute_force(p);
  ASSERT_LT(arg.cwiseAbs().maxCoeff(), 0.5 - 1e-3); // the closest points are inside the ranges
  const SplineContactResult r = solve(p, LinearPenalty(kEps));
  EXPECT_EQ(r.status, ProjectionStatus::Converged)
      << to_string(r.status) << " at (" << p.ba->local(r.xi_A) << ", " << p.bb->local(r.xi_B)
      << ")";
  EXPECT_NEAR(p.ba->local(r.xi_A), arg(0), 1e-6);
  EXPECT_NEAR(p.bb->local(r.xi_B), arg(1), 1e-6);
  EXPECT_NEAR(r.distance, best, 1e-12 * kL);
  EXPECT_TRUE(r.active);
}

TEST(SplineContact, ColdStartAtAnIndefiniteHessianFindsTheNearbyMinimum) {
  // At the midpoints the Hessian has eigenvalues -2.6e-7 and 4.7e-6 m^2. The closest points over
  // the ranges, (-0.068, -0.186), are a minimum 0.2 segments away, 53 microns into each other.
  // A modified Newton step that lifted the negative eigenvalue to only 1e-3 of the positive one
  // was 7 segments long, almost along its eigenvector; capped to one segment it crossed to
  // another minimum at (0.740, -0.743), beyond both ranges: OutOfRange, the contact lost.
  Matrix3d xa;
  Matrix3d xb;
  xa << -0.00080509880912751875, 0.00018886819731701851, 0.00088465849994347309,
      -0.00062226424374232567, -0.00011870591275506934, 0.00091753852089815748,
      0.00037542337166802833, -2.0834582721955464e-05, -0.00015438563849772753;
  xb << 0.00056328365567013205, -6.3139855105829332e-05, -0.00054318526117331503,
      0.00011352508945347942, -0.00073744599870400706, -0.0015060100382825988,
      0.00045606331700780162, 0.00054000856548598716, 0.00025204480401586819;
  expect_cold_projection_finds_the_closest_points(pinned_pair(xa, xb));
}

TEST(SplineContact, CappedNewtonStepStopsAtTheFirstMinimumAlongIt) {
  // At the midpoints the Hessian is positive definite but nearly singular (eigenvalues 5.0e-8
  // and 4.3e-6 m^2) and the Newton step 7 segments long. Capped to one segment it points
  // at the closest points over the ranges, (0.315, -0.480), and overshoots them; the Armijo test
  // accepted the landing, on the far side of their valley, and the iteration settled at a
  // minimum beyond the ranges, (1.69, -0.80): OutOfRange, the contact lost.
  Matrix3d xa;
  Matrix3d xb;
  xa << -0.00042611241148375145, 0.00015108511580804623, 0.00081492148543167568,
      0.00031423125854372733, 8.1362866836135394e-05, -2.4566301833812726e-06,
      0.0010389407748874098, -9.9432419122441508e-06, -0.00080819424089916794;
  xb << 0.0008082909646402966, 6.4520889224141626e-05, -0.00027149078166150846,
      -5.8296355756665038e-05, -0.00050917485735558284, -0.0010987707255799802,
      6.2323212024942233e-05, 0.00083298827565480996, 0.0013109752465506812;
  expect_cold_projection_finds_the_closest_points(pinned_pair(xa, xb));
}

TEST(SplineContact, IllConditionedWrapConvergesAtTheRoundOffLevel) {
  // A yarn wound around a pin (the capstan of tests/engine/test_capstan.cpp, 4 pins): the yarn's
  // segment lies in the plane normal to the pin's axis, at nearly constant distance from it, so
  // Phi's Hessian has eigenvalues far apart (the distance varies little along the wrap), 5 cm
  // from the origin. The Newton step stalled at 2e-12 segments, above the 1e-12 tolerance and
  // the same at every iteration, until the 50 iterations were spent: NotConverged, a vetoed step
  // (with OpenBLAS's AVX-512 kernels the capstan's pull stopped there). Phi's gradient is at its
  // round-off level there: converged (out of this pair's range).
  Matrix3d xa;
  Matrix3d xb;
  Matrix3d ca;
  Matrix3d cb;
  xa << -0.019132118854400273, -0.019149465607939141, -0.019166799231176115, 0.046302965105051545,
      0.046295848045097385, 0.046288699065715214, 0, 0, 0;
  xb << -0.019133788934822121, -0.019133788934822121, -0.019133788934822121, 0.046193052746031825,
      0.046193052746031825, 0.046193052746031825, -0.00040000000000000002, -0.00020000000000000001,
      0;
  ca << 0.12500000000001066, -0.50000000000004263, 0.50000000000004263, 0.74999999999997868, 0,
      -1.0000000000000853, 0.12500000000001066, 0.50000000000004263, 0.50000000000004263;
  cb << 0.25, -1, 1, 0.625, 0.5, -1.5, 0.125, 0.5, 0.5;
  const SegmentBasis ba(0.61628664495114005, 0.6169381107491857, false, ca);
  const SegmentBasis bb(0, 0.33333333333333331, false, cb);
  const ProjectionResult r = closest_point_projection(xa, ba, xb, bb, {}, {});
  // The closest points lie beyond the pin segment's range: its neighbour holds them.
  EXPECT_EQ(r.status, ProjectionStatus::OutOfRange) << to_string(r.status);
  // They are a critical point of the distance (to 1e-6 of |g| |g_u|; a point off it is O(1)).
  const double ua = ba.local(r.xi_A), ub = bb.local(r.xi_B);
  const Eigen::Vector3d g = xa * ba.values_local(ua) - xb * bb.values_local(ub);
  const Eigen::Vector3d ga = xa * ba.first_local(ua), gb = xb * bb.first_local(ub);
  EXPECT_LT(std::abs(g.dot(ga)), 1e-6 * g.norm() * ga.norm());
  EXPECT_LT(std::abs(g.dot(gb)), 1e-6 * g.norm() * gb.norm());
}

TEST(SplineContact, AFlatValleyBetweenCrimpedYarnsIsCrossedInFewIterations) {
  // Two crimped yarns of the paper's picture frame pressed together at 63 degrees of shear (they
  // cross at 27 degrees; the segments are those of warp1 and weft4 where the run stopped): the
  // distance varies by 2e-10 m over a fifth of a segment along the valley between them, with
  // two minima and a saddle between (H's least eigenvalue 1e-10 against 6e-7). The modified
  // Newton steps, with the modified curvature instead of the valley's, crept along it: the warm
  // start from the saddle was NotConverged after 50 iterations (a vetoed step, and the frame
  // stopped), the cold start took 36. The ray search past a modified step's length finds the
  // nearest minimum on the ray.
  Matrix3d xa, xb;
  xa << 0.0096858183663775937, 0.010169166193941481, 0.010650664333454374, 0.0049046423716193549,
      0.0052063268532347873, 0.0055086379206308383, -0.00026462704165025234,
      -0.00028196016325310373, -0.00024071734002738241;
  xb << 0.0099115967822206059, 0.01021387584751628, 0.01051560183802086, 0.0047710013795912755,
      0.0052525394587886083, 0.005735829696768625, 0.00024799567127228964, 0.00028885902106227398,
      0.00027090341149893293;
  const SplineCurve curve(73);
  const SegmentBasis& ba = curve.segment(47);
  const SegmentBasis& bb = curve.segment(23);
  const ProjectionStart warm{0.66993285870716501, 0.32986602861478176, true};
  for (const ProjectionStart& start : {ProjectionStart{}, warm}) {
    SCOPED_TRACE(start.warm ? "warm start" : "cold start");
    const ProjectionResult r = closest_point_projection(xa, ba, xb, bb, start, {});
    EXPECT_EQ(r.status, ProjectionStatus::Converged) << to_string(r.status);
    EXPECT_LE(r.iterations, 8);
    // A strict local minimum: the gradient zero, the Hessian (central differences) definite.
    const auto phi = [&](double u, double v) {
      return 0.5 * (xa * ba.values_local(u) - xb * bb.values_local(v)).squaredNorm();
    };
    const double u = ba.local(r.xi_A), v = bb.local(r.xi_B), h = 1e-3;
    const Eigen::Vector3d g = xa * ba.values_local(u) - xb * bb.values_local(v);
    const Eigen::Vector3d ga = xa * ba.first_local(u), gb = xb * bb.first_local(v);
    EXPECT_LT(std::abs(g.dot(ga)), 1e-8 * g.norm() * ga.norm());
    EXPECT_LT(std::abs(g.dot(gb)), 1e-8 * g.norm() * gb.norm());
    const double huu = (phi(u + h, v) - 2 * phi(u, v) + phi(u - h, v)) / (h * h);
    const double hvv = (phi(u, v + h) - 2 * phi(u, v) + phi(u, v - h)) / (h * h);
    const double huv =
        (phi(u + h, v + h) - phi(u + h, v - h) - phi(u - h, v + h) + phi(u - h, v - h)) /
        (4 * h * h);
    EXPECT_GT(huu * hvv - huv * huv, 0.0);
    EXPECT_GT(huu, 0.0);
    // Either of the valley's two minima (distances 5.5436790e-4 and 5.5436808e-4 m).
    EXPECT_NEAR(g.norm(), 5.54368e-4, 2e-10);
  }
}

TEST(SplineContact, WarmStartConvergesInFewIterations) {
  std::mt19937 rng(23);
  const LinearPenalty law(kEps);
  int tested = 0;
  while (tested < 20) {
    Pair p = random_crossing(rng);
    if (!place(p, 0.1, -0.2, 3e-6)) {
      continue;
    }
    ++tested;
    const SplineContactResult cold = solve(p, law);
    Pair moved = p;
    moved.xb.colwise() += Vector3d(1e-3, -2e-3, 1e-3) * kL;
    const SplineContactResult warm = solve(moved, law, {cold.xi_A, cold.xi_B, true});
    EXPECT_EQ(warm.status, ProjectionStatus::Converged);
    EXPECT_LE(warm.iterations, 4); // three quadratic steps and the final check
  }
}

/// A wavy yarn along x (woven-like) and a straight yarn along y above it; returns every segment
/// pair's result.
struct Weave {
  SplineCurve ca{9};
  SplineCurve cb{5};
  Eigen::Matrix3Xd ya{3, 9};
  Eigen::Matrix3Xd yb{3, 5};
};

Weave make_weave(double x, double overlap) {
  Weave w;
  for (int i = 0; i < 9; ++i) {
    w.ya.col(i) = Vector3d(i * kL, 0.1 * kL * std::sin(1.3 * i), 0.15 * kL * ((i % 2) ? 1 : -1));
  }
  // Height of A below x: sample the curve finely (its x is monotone).
  double z = 0;
  double best = INFINITY;
  for (int s = 0; s <= 20000; ++s) {
    const Vector3d c = w.ca.point(w.ya, s / 20000.0);
    if (std::abs(c.x() - x) < best) {
      best = std::abs(c.x() - x);
      z = c.z();
    }
  }
  for (int j = 0; j < 5; ++j) {
    w.yb.col(j) = Vector3d(x, (j - 2.2) * kL, z + 2 * kRadius - overlap);
  }
  return w;
}

TEST(SplineContact, ContactSlidingOverKnotsIsOwnedByExactlyOnePair) {
  const LinearPenalty law(kEps);
  std::set<int> owners_seen;
  const int steps = 1500;
  for (int s = 0; s <= steps; ++s) {
    const double x = (1.2 + 3.6 * s / steps) * kL; // crosses segments 1..5 of A
    const Weave w = make_weave(x, 5e-6);
    int active = 0;
    for (int a = 0; a < w.ca.num_segments(); ++a) {
      for (int b = 0; b < w.cb.num_segments(); ++b) {
        const SplineContactResult r =
            spline_contact(w.ca.control_points(w.ya, a), w.ca.segment(a), kRadius,
                           w.cb.control_points(w.yb, b), w.cb.segment(b), kRadius, {}, law);
        if (r.active) {
          ++active;
          owners_seen.insert(a);
        }
      }
    }
    ASSERT_EQ(active, 1) << "x = " << x / kL << " L";
  }
  EXPECT_GE(owners_seen.size(), 4u);
}

/// Global contact force on A's nodes from all pairs.
Eigen::Matrix3Xd force_on_a(const Weave& w, const InterfaceLaw& law, int* owner) {
  Eigen::Matrix3Xd f = Eigen::Matrix3Xd::Zero(3, 9);
  for (int a = 0; a < w.ca.num_segments(); ++a) {
    for (int b = 0; b < w.cb.num_segments(); ++b) {
      const SplineContactResult r =
          spline_contact(w.ca.control_points(w.ya, a), w.ca.segment(a), kRadius,
                         w.cb.control_points(w.yb, b), w.cb.segment(b), kRadius, {}, law);
      if (r.active) {
        *owner = a;
        for (int k = 0; k < 3; ++k) {
          f.col(a + k) += r.residual.segment<3>(3 * k);
        }
      }
    }
  }
  return f;
}

TEST(SplineContact, ContactForceIsContinuousAcrossAKnot) {
  const LinearPenalty law(kEps);
  // Find a B position where the owner changes, by bisection on x.
  double lo = 1.7 * kL;
  double hi = 2.9 * kL;
  int owner_lo = -1;
  int owner_hi = -1;
  force_on_a(make_weave(lo, 5e-6), law, &owner_lo);
  force_on_a(make_weave(hi, 5e-6), law, &owner_hi);
  ASSERT_NE(owner_lo, owner_hi);
  for (int it = 0; it < 40; ++it) {
    const double mid = 0.5 * (lo + hi);
    int owner = -1;
    force_on_a(make_weave(mid, 5e-6), law, &owner);
    (owner == owner_lo ? lo : hi) = mid;
  }
  // make_weave places B at the curve's height sampled on a grid, identical on both sides here.
  const Weave left = make_weave(lo, 5e-6);
  Weave right = left;
  right.yb.row(0).array() += hi - lo;
  int a_left = -1;
  int a_right = -1;
  const Eigen::Matrix3Xd f_left = force_on_a(left, law, &a_left);
  const Eigen::Matrix3Xd f_right = force_on_a(right, law, &a_right);
  EXPECT_NE(a_left, a_right);
  EXPECT_LT((f_left - f_right).norm(), 1e-6 * f_left.norm());
}

TEST(SplineContact, ContactExactlyAtAKnotHasOneOwner) {
  const SplineCurve ca(6);
  const SplineCurve cb(4);
  const LinearPenalty law(kEps);
  Eigen::Matrix3Xd ya(3, 6);
  Eigen::Matrix3Xd yb(3, 4);
  for (int i = 0; i < 6; ++i) {
    ya.col(i) = Vector3d(i * kL, 0.0, 0.0);
  }
  for (int k = 1; k < ca.num_segments(); ++k) {
    // Knot k is the midpoint of control points k and k+1: B crosses exactly there.
    const double x = 0.5 * (ya(0, k) + ya(0, k + 1));
    for (const double angle : {0.0, 0.3, -0.7}) {
      for (int j = 0; j < 4; ++j) {
        yb.col(j) = Vector3d(x + std::sin(angle) * (j - 1.5) * kL, std::cos(angle) * (j - 1.5) * kL,
                             2 * kRadius - 1e-6);
      }
      int active = 0;
      for (int a = 0; a < ca.num_segments(); ++a) {
        for (int b = 0; b < cb.num_segments(); ++b) {
          const SplineContactResult r =
              spline_contact(ca.control_points(ya, a), ca.segment(a), kRadius,
                             cb.control_points(yb, b), cb.segment(b), kRadius, {}, law);
          active += r.active ? 1 : 0;
        }
      }
      EXPECT_EQ(active, 1) << "knot " << k << ", angle " << angle;
    }
  }
}

TEST(SplineContact, SeparatedPairIsInactiveWithZeroResidual) {
  std::mt19937 rng(2);
  const LinearPenalty law(kEps);
  // place() leaves a local minimum of the distance at (0, 0.1), 10 microns of gap, but a curved
  // pair can have others, and the projection from the midpoints need not reach this one: on one
  // pair it was shallow, the first (full, positive definite) Newton step already went below it
  // and the distance kept falling out of the range (OutOfRange at (2.06, -1.02), with the gap
  // of that point, -3.8e-4 m). Only a pair whose projection finds it tests the gap here.
  Pair p;
  SplineContactResult r;
  bool found = false;
  for (int attempt = 0; attempt < 100 && !found; ++attempt) {
    p = random_crossing(rng);
    if (!place(p, 0.0, 0.1, -1e-5)) {
      continue;
    }
    r = solve(p, law);
    found = std::abs(p.ba->local(r.xi_A)) < 1e-9 && std::abs(p.bb->local(r.xi_B) - 0.1) < 1e-9;
  }
  ASSERT_TRUE(found);
  EXPECT_EQ(r.status, ProjectionStatus::Converged);
  EXPECT_FALSE(r.active);
  EXPECT_NEAR(r.gap, 1e-5, 1e-15);
  EXPECT_EQ(r.force, 0.0);
  EXPECT_EQ(r.residual.norm(), 0.0);
  EXPECT_EQ(r.tangent.norm(), 0.0);
}

TEST(SplineContact, StatusReportsOutOfRangeSlideAndFailure) {
  std::mt19937 rng(9);
  const LinearPenalty law(kEps);
  Pair p;
  do {
    p = random_crossing(rng);
  } while (!place(p, 0.7, 0.0, 5e-6));
  const SplineContactResult out = solve(p, law);
  EXPECT_EQ(out.status, ProjectionStatus::OutOfRange);
  EXPECT_FALSE(out.active);
  EXPECT_EQ(out.residual.norm(), 0.0);
  EXPECT_NEAR(p.ba->local(out.xi_A), 0.7, 1e-9);

  do {
    p = random_crossing(rng);
  } while (!place(p, 0.4, 0.0, 5e-6));
  const double far_start = p.ba->global(-0.3);
  // A warm start 0.7 of a segment from the only contact point: the move exceeds jump_fraction,
  // but a cold start finds the same point, so it is the contact's own (a fast slide) and stands.
  const SplineContactResult slid = solve(p, law, {far_start, p.bb->global(0.0), true});
  EXPECT_EQ(slid.status, ProjectionStatus::Converged);
  EXPECT_TRUE(slid.active);
  EXPECT_NEAR(p.ba->local(slid.xi_A), 0.4, 1e-9);
  SplineContactOptions one;
  one.max_iterations = 1;
  const SplineContactResult failed = solve(p, law, {far_start, p.bb->global(-0.4), true}, one);
  EXPECT_EQ(failed.status, ProjectionStatus::NotConverged);
  EXPECT_FALSE(failed.active);
}

// A with its centre line a cup, z = H (2 u^2 - 1/2) over x = L u, and B a straight line along y
// above its bottom, a little to the left of it: the distance has two minima, u = -0.31 (the
// nearer, where a cold start goes) and u = +0.32. A warm start beyond the right one converges to
// it, more than jump_fraction from where it started, at a point a cold start does not find: the
// projection left the contact it followed (Jumped). The same pair from the left minimum's
// neighbourhood follows it.
TEST(SplineContact, WarmStartThatReachesAnotherCriticalPointJumps) {
  const LinearPenalty law(kEps);
  const double L = 1e-3, H = 1e-3, z0 = 4.5e-4 - H / 2, x0 = -2e-5;
  Pair p;
  p.ba = &curve5().segment(1);
  p.bb = &curve5().segment(1);
  p.xa << -L, 0, L, 0, 0, 0, H, -H, H;
  p.xb << x0, x0, x0, -L, 0, L, z0, z0, z0;
  const SplineContactResult cold = solve(p, law);
  ASSERT_EQ(cold.status, ProjectionStatus::Converged);
  EXPECT_NEAR(p.ba->local(cold.xi_A), -0.31, 0.02);
  const SplineContactResult far = solve(p, law, {p.ba->global(1.0), p.bb->global(0.0), true});
  EXPECT_NEAR(p.ba->local(far.xi_A), 0.32, 0.02);
  EXPECT_EQ(far.status, ProjectionStatus::Jumped);
  const SplineContactResult near = solve(p, law, {p.ba->global(-0.2), p.bb->global(0.0), true});
  EXPECT_EQ(near.status, ProjectionStatus::Converged);
  EXPECT_NEAR(p.ba->local(near.xi_A), p.ba->local(cold.xi_A), 1e-9);
}

TEST(SplineContact, ResidualOnlyOptionSkipsTheTangent) {
  std::mt19937 rng(4);
  const LinearPenalty law(kEps);
  Pair p;
  do {
    p = random_crossing(rng);
  } while (!place(p, 0.0, 0.0, 5e-6));
  SplineContactOptions options;
  options.compute_tangent = false;
  const SplineContactResult full = solve(p, law);
  const SplineContactResult lean = solve(p, law, {}, options);
  EXPECT_EQ((full.residual - lean.residual).norm(), 0.0);
  EXPECT_EQ(lean.tangent.norm(), 0.0);
}

TEST(SplineContact, KeptTangentIsLeftAloneOnlyWhereNotComputed) {
  // zero_unused_tangent = false (what the engine's contact set uses): the tangent of an open pair
  // keeps what the result held; an active pair's tangent is written whole, the same bits as with
  // the default.
  std::mt19937 rng(11);
  const LinearPenalty law(kEps);
  SplineContactOptions keep;
  keep.zero_unused_tangent = false;
  Pair closed, open;
  do {
    closed = random_crossing(rng);
  } while (!place(closed, 0.1, -0.2, 5e-6));
  do {
    open = random_crossing(rng);
  } while (!place(open, 0.0, 0.0, -5e-6));
  const SplineContactResult reference = solve(closed, law);
  ASSERT_TRUE(reference.active);

  SplineContactResult out;
  out.tangent.setConstant(7.0); // what an earlier evaluation of this result left
  spline_contact(open.xa, *open.ba, open.ra, open.xb, *open.bb, open.rb, {}, law, out, keep);
  EXPECT_FALSE(out.active);
  EXPECT_EQ(out.residual.norm(), 0.0);
  EXPECT_EQ((out.tangent.array() - 7.0).abs().maxCoeff(), 0.0);

  spline_contact(closed.xa, *closed.ba, closed.ra, closed.xb, *closed.bb, closed.rb, {}, law, out,
                 keep);
  EXPECT_TRUE(out.active);
  EXPECT_EQ((out.tangent - reference.tangent).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((out.residual - reference.residual).cwiseAbs().maxCoeff(), 0.0);

  // The default zeroes what it does not compute.
  spline_contact(open.xa, *open.ba, open.ra, open.xb, *open.bb, open.rb, {}, law, out, {});
  EXPECT_EQ(out.tangent.norm(), 0.0);
}

} // namespace
} // namespace yarnsim::contact
