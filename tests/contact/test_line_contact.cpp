// The all-angle beam contact (contact/line_contact.hpp): residual against finite differences of
// the potential, tangent against finite differences of the residual, at random configurations
// from parallel to crossing; the line part's quadrature and hand-over at knots; continuity as a
// yarn turns from crossing to parallel and as contact points pass knots.
#include "contact/line_contact.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <cstdio>
#include <memory>
#include <random>

namespace yarnsim::contact {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using Vec = Eigen::VectorXd;
using Mat = Eigen::MatrixXd;

// Scales of the study (formulation.md §1).
constexpr double kH = 1.1e-3; // control point spacing, m
constexpr double kRadius = 2.840909e-4;
constexpr double kEps = 1.5e6;
constexpr int kPoints = 6; // control points per curve: 4 segments, two interior ones

/// Two curves of kPoints control points (columns, metres): A and B.
struct Curves {
  Eigen::Matrix3Xd a = Eigen::Matrix3Xd::Zero(3, kPoints);
  Eigen::Matrix3Xd b = Eigen::Matrix3Xd::Zero(3, kPoints);
};

const SplineCurve& curve() {
  static const SplineCurve c(kPoints);
  return c;
}

/// A along x through the origin; B turned by `angle` about z, `shift` along its own axis, its
/// centre line `distance` above A's; both with random transverse perturbations of `wobble`
/// (metres) at the control points.
Curves make_curves(double angle, double distance, double shift, double wobble, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Curves c;
  const Vector3d axis(std::cos(angle), std::sin(angle), 0.0);
  for (int k = 0; k < kPoints; ++k) {
    const double s = (k - 0.5 * (kPoints - 1)) * kH;
    c.a.col(k) = Vector3d(s, 0, 0) + wobble * Vector3d(0.1 * u(rng), u(rng), u(rng));
    c.b.col(k) = (s + shift) * axis + Vector3d(0, 0, distance) +
                 wobble * Vector3d(0.1 * u(rng), u(rng), u(rng));
  }
  return c;
}

/// Sum over all segment pairs (A's i, B's j) of the all-angle contact: potential, gradient and
/// Hessian over the 2 kPoints control points (A's first), as the stage assembles them.
struct Total {
  double potential = 0.0;
  double force = 0.0;
  int line_points = 0;
  Vec residual = Vec::Zero(6 * kPoints);
  Mat tangent = Mat::Zero(6 * kPoints, 6 * kPoints);
};

/// With `velocity` (3 x 2 kPoints, m/s, A's control points first) and `law` damped, each pair
/// gets its control points' velocities and dv/dx = `vpd` (contact damping).
Total total(const Curves& c, const AllAngleOptions& opt, const SplineContactOptions& so = {},
            const InterfaceLaw* law = nullptr, const Eigen::Matrix3Xd* velocity = nullptr,
            double vpd = 0.0) {
  static const LinearPenalty linear(kEps);
  if (law == nullptr)
    law = &linear;
  Total t;
  SplineContactResult r;
  PairRates rates;
  for (int i = 0; i < curve().num_segments(); ++i)
    for (int j = 0; j < curve().num_segments(); ++j) {
      if (velocity != nullptr) {
        for (int k = 0; k < 3; ++k) {
          rates.velocity_A.col(k) = velocity->col(i + k);
          rates.velocity_B.col(k) = velocity->col(kPoints + j + k);
        }
        rates.velocity_per_displacement = vpd;
      }
      all_angle_contact(curve().control_points(c.a, i), curve().segment(i), kRadius,
                        curve().control_points(c.b, j), curve().segment(j), kRadius, {}, *law, opt,
                        r, so, nullptr, velocity != nullptr ? &rates : nullptr);
      EXPECT_NE(r.status, ProjectionStatus::NotConverged) << i << " " << j;
      if (!r.active)
        continue;
      t.potential += r.potential;
      t.force += r.force;
      t.line_points += r.line_points;
      int dofs[6] = {i, i + 1, i + 2, kPoints + j, kPoints + j + 1, kPoints + j + 2};
      for (int p = 0; p < 6; ++p) {
        t.residual.segment<3>(3 * dofs[p]) += r.residual.segment<3>(3 * p);
        for (int q = 0; q < 6; ++q)
          t.tangent.block<3, 3>(3 * dofs[p], 3 * dofs[q]) += r.tangent.block<3, 3>(3 * p, 3 * q);
      }
    }
  return t;
}

double& dof(Curves& c, int i) {
  const int point = i / 3, d = i % 3;
  return point < kPoints ? c.a(d, point) : c.b(d, point - kPoints);
}

/// Relative errors of the residual against central differences of the potential and of the
/// tangent against central differences of the residual.
std::pair<double, double> fd_errors(const Curves& c, const AllAngleOptions& opt) {
  const Total t0 = total(c, opt);
  const double step = 1e-9; // m, against penetrations of microns
  Vec fd_residual(6 * kPoints);
  Mat fd_tangent(6 * kPoints, 6 * kPoints);
  for (int i = 0; i < 6 * kPoints; ++i) {
    Curves p = c, m = c;
    dof(p, i) += step;
    dof(m, i) -= step;
    const Total tp = total(p, opt), tm = total(m, opt);
    fd_residual(i) = (tp.potential - tm.potential) / (2 * step);
    fd_tangent.col(i) = (tp.residual - tm.residual) / (2 * step);
  }
  const double er =
      (fd_residual - t0.residual).lpNorm<Eigen::Infinity>() / t0.residual.lpNorm<Eigen::Infinity>();
  const double et =
      (fd_tangent - t0.tangent).lpNorm<Eigen::Infinity>() / t0.tangent.lpNorm<Eigen::Infinity>();
  return {er, et};
}

TEST(PointShare, IsZeroBelowTheLineAngleOneAboveThePointAngleAndSmoothBetween) {
  const AllAngleOptions opt;
  const double lo = opt.line_sine * opt.line_sine, hi = opt.point_sine * opt.point_sine;
  EXPECT_EQ(point_share(0.0, opt), 0.0);
  EXPECT_EQ(point_share(lo, opt), 0.0);
  EXPECT_EQ(point_share(hi, opt), 1.0);
  EXPECT_EQ(point_share(1.0, opt), 1.0);
  EXPECT_NEAR(point_share(0.5 * (lo + hi), opt), 0.5, 1e-15);
  for (const double x : {lo + 0.1 * (hi - lo), lo + 0.7 * (hi - lo)}) {
    double ds = 0, d2s = 0;
    point_share(x, opt, &ds, &d2s);
    const double h = 1e-6 * (hi - lo);
    double dsp = 0, dsm = 0;
    EXPECT_NEAR(ds, (point_share(x + h, opt) - point_share(x - h, opt)) / (2 * h), 1e-6 * ds);
    point_share(x + h, opt, &dsp);
    point_share(x - h, opt, &dsm);
    EXPECT_NEAR(d2s, (dsp - dsm) / (2 * h), 1e-5 * std::abs(d2s));
  }
}

TEST(LineContact, StraightParallelYarnsCarryThePenaltyTimesTheLengthThroughEveryGaussRule) {
  // B longer than A on both sides: every Gauss point of A projects inside B, onto one segment.
  for (const int n : {1, 2, 3, 5, 10}) {
    AllAngleOptions opt;
    opt.gauss_points = n;
    opt.line_scale = 1.0 / (2 * kRadius);
    std::mt19937 rng(1);
    const double p = 1e-6;
    Curves c = make_curves(0.0, 2 * kRadius - p, 0.0, 0.0, rng);
    c.b.row(0) *= 1.5;
    const Total t = total(c, opt);
    const double length = c.a(0, kPoints - 1) - c.a(0, 0);
    EXPECT_NEAR(t.force, kEps * opt.line_scale * p * length, 1e-9 * t.force) << n;
    EXPECT_EQ(t.line_points, n * curve().num_segments()) << n;
    // The force on B is the force on A, opposite, and normal to the yarns (along z).
    Vector3d on_a = Vector3d::Zero(), on_b = Vector3d::Zero();
    for (int k = 0; k < kPoints; ++k) {
      on_a -= t.residual.segment<3>(3 * k);
      on_b -= t.residual.segment<3>(3 * (kPoints + k));
    }
    EXPECT_NEAR(on_a.z(), -t.force, 1e-9 * t.force);
    EXPECT_NEAR((on_a + on_b).norm(), 0.0, 1e-12 * t.force);
  }
}

TEST(LineContact, ParallelYarnsApartAreInactiveAndReportTheirGap) {
  // Parallel chords: the point contact is not evaluated, and the pair reports the smallest gap
  // of its Gauss points (the run's clearance report reads it).
  std::mt19937 rng(1);
  const Curves c = make_curves(0.0, 2 * kRadius + 3e-5, 0.0, 0.0, rng);
  static const LinearPenalty law(kEps);
  const SplineContactResult r = [&] {
    SplineContactResult out;
    all_angle_contact(curve().control_points(c.a, 1), curve().segment(1), kRadius,
                      curve().control_points(c.b, 1), curve().segment(1), kRadius, {}, law, {},
                      out);
    return out;
  }();
  EXPECT_FALSE(r.active);
  EXPECT_FALSE(r.point_evaluated);
  EXPECT_EQ(r.status, ProjectionStatus::Converged);
  EXPECT_NEAR(r.gap, 3e-5, 1e-15);
  EXPECT_EQ(r.line_points, 0);
}

TEST(LineContact, CentreLinesThatMeetLeaveNoNormalAndVetoTheStep) {
  // B on A's centre line: no normal at the Gauss points; the pair says NotConverged, as the
  // point contact does where the centre lines intersect, and the stage vetoes the step.
  std::mt19937 rng(1);
  const Curves c = make_curves(0.0, 0.0, 0.0, 0.0, rng);
  static const LinearPenalty law(kEps);
  SplineContactResult r;
  all_angle_contact(curve().control_points(c.a, 1), curve().segment(1), kRadius,
                    curve().control_points(c.b, 1), curve().segment(1), kRadius, {}, law, {}, r);
  EXPECT_EQ(r.status, ProjectionStatus::NotConverged);
  EXPECT_TRUE(r.residual.allFinite());
}

TEST(LineContact, ResidualAndTangentMatchFiniteDifferencesFromParallelToCrossing) {
  AllAngleOptions opt;
  opt.line_scale = 1.0 / (2 * kRadius);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  double worst_r = 0, worst_t = 0;
  // Parallel, nearly parallel (the old degenerate range), line only, blended, point only,
  // crossing; shifted so that contact points lie anywhere, knots included.
  for (const double angle : {0.0, 1e-3, 5e-3, 0.08, 0.15, 0.2, 0.26, 0.3, 0.34, 0.6, 1.5})
    for (int trial = 0; trial < 3; ++trial) {
      const double shift = (u(rng) - 0.5) * kH;
      const Curves c = make_curves(angle, 2 * kRadius - 1e-5, shift, 0.02 * kRadius, rng);
      const Total t = total(c, opt);
      ASSERT_GT(t.force, 0.0) << angle;
      const auto [er, et] = fd_errors(c, opt);
      std::printf("angle %.3f rad, shift %+.3f segments: %d line points, residual %.1e, tangent "
                  "%.1e\n",
                  angle, shift / kH, t.line_points, er, et);
      EXPECT_LT(er, 1e-5) << angle;
      EXPECT_LT(et, 1e-5) << angle;
      // The residual-only path (explicit dynamics: first-order jets) gives the same residual.
      SplineContactOptions residual_only;
      residual_only.compute_tangent = false;
      const Total f = total(c, opt, residual_only);
      EXPECT_LT((f.residual - t.residual).lpNorm<Eigen::Infinity>(),
                1e-12 * t.residual.lpNorm<Eigen::Infinity>())
          << angle;
      EXPECT_EQ(f.potential, t.potential) << angle;
      worst_r = std::max(worst_r, er);
      worst_t = std::max(worst_t, et);
    }
  std::printf("worst: residual %.1e, tangent %.1e\n", worst_r, worst_t);
}

TEST(LineContact, ARegularisedLawActsBeforeContactWithAConsistentTangent) {
  // The line part with contact::RegularisedPenalty (g0 = 2e-5 m): parallel yarns 1e-5 m apart
  // are in line contact with eps lambda (g0 - g)^2 / (2 g0) per unit length, and residual and
  // tangent match central differences from parallel into the blend, apart and pressed.
  AllAngleOptions opt;
  opt.line_scale = 1.0 / (2 * kRadius);
  const double g0 = 2e-5;
  const RegularisedPenalty law(kEps, g0);
  std::mt19937 rng(3);
  Curves c = make_curves(0.0, 2 * kRadius + 1e-5, 0.0, 0.0, rng);
  c.b.row(0) *= 1.5;
  const Total t = total(c, opt, {}, &law);
  const double length = c.a(0, kPoints - 1) - c.a(0, 0);
  EXPECT_NEAR(t.force, opt.line_scale * law.force(-1e-5) * length, 1e-9 * t.force);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (const double angle : {0.0, 0.05, 0.25})
    for (const double distance : {2 * kRadius + 1e-5, 2 * kRadius - 1e-5}) {
      const Curves d = make_curves(angle, distance, (u(rng) - 0.5) * kH, 0.02 * kRadius, rng);
      const Total t0 = total(d, opt, {}, &law);
      ASSERT_GT(t0.force, 0.0) << angle;
      const double step = 1e-9;
      Vec fd_residual(6 * kPoints);
      Mat fd_tangent(6 * kPoints, 6 * kPoints);
      for (int i = 0; i < 6 * kPoints; ++i) {
        Curves p = d, m = d;
        dof(p, i) += step;
        dof(m, i) -= step;
        const Total tp = total(p, opt, {}, &law), tm = total(m, opt, {}, &law);
        fd_residual(i) = (tp.potential - tm.potential) / (2 * step);
        fd_tangent.col(i) = (tp.residual - tm.residual) / (2 * step);
      }
      EXPECT_LT((fd_residual - t0.residual).lpNorm<Eigen::Infinity>() /
                    t0.residual.lpNorm<Eigen::Infinity>(),
                1e-5)
          << angle << " " << distance;
      EXPECT_LT((fd_tangent - t0.tangent).lpNorm<Eigen::Infinity>() /
                    t0.tangent.lpNorm<Eigen::Infinity>(),
                1e-5)
          << angle << " " << distance;
    }
}

/// The all-angle contact with a damped law on a dynamic step (PairRates): where the point
/// contact is blended with the line contact the blended force s f + U grad s holds the damped
/// point force, and its tangent the elastic gradient grad U; against central differences of the
/// residual in which every step moves the coordinate's velocity by dv/dx times the step, as in a
/// Newmark iteration.
TEST(LineContact, DampedPointContactIsBlendedWithItsConsistentTangent) {
  AllAngleOptions opt;
  opt.line_scale = 1.0 / (2 * kRadius);
  const DampedLaw law(std::make_shared<LinearPenalty>(kEps), 200.0);
  const double vpd = 0.5 / (0.3 * 1e-4); // Newmark gamma / (beta dt), dt = 1e-4 s
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  // Velocities of the 2 kPoints control points, up to 0.01 m/s.
  Eigen::Matrix3Xd v(3, 2 * kPoints);
  for (int k = 0; k < 2 * kPoints; ++k)
    for (int d = 0; d < 3; ++d)
      v(d, k) = 0.01 * u(rng);
  const auto damped_total = [&](const Curves& c, const Eigen::Matrix3Xd& vel) {
    return total(c, opt, {}, &law, &vel, vpd);
  };
  double worst = 0;
  for (const double angle : {0.2, 0.26, 0.3, 0.6})
    for (int trial = 0; trial < 2; ++trial) {
      const Curves c =
          make_curves(angle, 2 * kRadius - 1e-5, 0.3 * u(rng) * kH, 0.02 * kRadius, rng);
      const Total t0 = damped_total(c, v);
      ASSERT_GT(t0.force, 0.0) << angle;
      const double step = 1e-9;
      Mat fd(6 * kPoints, 6 * kPoints);
      for (int i = 0; i < 6 * kPoints; ++i) {
        Curves p = c, m = c;
        Eigen::Matrix3Xd vp = v, vm = v;
        dof(p, i) += step;
        dof(m, i) -= step;
        vp(i % 3, i / 3) += vpd * step;
        vm(i % 3, i / 3) -= vpd * step;
        fd.col(i) = (damped_total(p, vp).residual - damped_total(m, vm).residual) / (2 * step);
      }
      const double e =
          (fd - t0.tangent).lpNorm<Eigen::Infinity>() / t0.tangent.lpNorm<Eigen::Infinity>();
      std::printf("damped, angle %.2f rad: tangent %.1e\n", angle, e);
      EXPECT_LT(e, 1e-5) << angle;
      worst = std::max(worst, e);
      // The damping changes the force (the test sees it).
      EXPECT_GT(std::abs(t0.force - total(c, opt).force), 1e-6 * t0.force) << angle;
    }
  RecordProperty("worst_damped_tangent", std::to_string(worst));
}

/// Largest relative change of the total force and residual in one step of B's turn from 90 to
/// 0.3 degrees in `steps` steps uniform in log(angle); the angle where the force changes most.
struct Turn {
  double force = 0, residual = 0, angle = 0;
};

Turn turn(int steps) {
  AllAngleOptions opt;
  opt.line_scale = 1.0 / (2 * kRadius);
  const double from = std::log(0.5 * 3.141592653589793), to = std::log(0.005);
  Turn worst;
  double previous_force = -1;
  Vec previous_residual;
  for (int k = 0; k <= steps; ++k) {
    const double angle = std::exp(from + (to - from) * k / steps);
    std::mt19937 same(3);
    const Curves c = make_curves(angle, 2 * kRadius - 2e-6, 0.3 * kH, 0.0, same);
    const Total t = total(c, opt);
    EXPECT_GT(t.force, 0.0) << angle;
    if (previous_force > 0) {
      const double jump = std::abs(t.force - previous_force) / std::max(t.force, previous_force);
      if (jump > worst.force) {
        worst.force = jump;
        worst.angle = angle;
      }
      worst.residual =
          std::max(worst.residual, (t.residual - previous_residual).lpNorm<Eigen::Infinity>() /
                                       t.residual.lpNorm<Eigen::Infinity>());
    }
    previous_force = t.force;
    previous_residual = t.residual;
  }
  return worst;
}

TEST(LineContact, ForceIsContinuousAsAYarnTurnsFromCrossingToParallel) {
  // B turns about the vertical through the crossing at a fixed centre distance: the force,
  // which grows like 1 / angle as the line of contact lengthens, changes by about 1.4 % a step
  // of 400 where it is smooth and by up to 5 % in the blend. Halving the steps halves the
  // largest change: a jump (the old point contact's force switched by tens of per cent where its
  // degenerate path took over) would not shrink.
  const Turn coarse = turn(400), fine = turn(800);
  std::printf("turning 90 -> 0.3 degrees in 400 steps: largest change of the force in a step "
              "%.2f %% (at %.4f rad), of the residual %.2f %%; in 800 steps %.2f %% and %.2f %%\n",
              100 * coarse.force, coarse.angle, 100 * coarse.residual, 100 * fine.force,
              100 * fine.residual);
  EXPECT_LT(coarse.force, 0.08); // steepest in the blend (the smoothstep's slope: 15/8 its mean)
  EXPECT_LT(coarse.residual, 0.1);
  EXPECT_LT(fine.force, 0.6 * coarse.force);
  EXPECT_LT(fine.residual, 0.6 * coarse.residual);
}

TEST(LineContact, ForceIsContinuousAsContactPointsPassKnots) {
  // B slides along its axis over two segments, parallel and at 12 degrees (blended): the
  // potential's derivative along the slide equals the residual's component along it, at every
  // position (a jump in the potential, or a Gauss point counted twice or not at all near a
  // knot, would break it).
  AllAngleOptions opt;
  opt.line_scale = 1.0 / (2 * kRadius);
  for (const double angle : {0.0, 0.21}) {
    double worst = 0;
    for (int k = 0; k <= 200; ++k) {
      const double shift = -kH + 2 * kH * k / 200.0;
      const Vector3d axis(std::cos(angle), std::sin(angle), 0.0);
      auto at = [&](double s) {
        std::mt19937 same(5);
        return make_curves(angle, 2 * kRadius - 2e-6, s, 0.02 * kRadius, same);
      };
      const double h = 1e-9;
      const Total t = total(at(shift), opt);
      const double de =
          (total(at(shift + h), opt).potential - total(at(shift - h), opt).potential) / (2 * h);
      double along = 0;
      for (int p = 0; p < kPoints; ++p)
        along += t.residual.segment<3>(3 * (kPoints + p)).dot(axis);
      worst = std::max(worst, std::abs(de - along) / t.residual.lpNorm<Eigen::Infinity>());
    }
    std::printf("sliding at %.2f rad: worst |dE/ds - R.ds| / |R| = %.1e\n", angle, worst);
    EXPECT_LT(worst, 1e-5) << angle;
  }
}

} // namespace
} // namespace yarnsim::contact
