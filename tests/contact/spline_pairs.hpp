#pragma once
// Segment pairs shared by the spline contact and friction tests: the study's scales, random
// crossing configurations drawn from a test's own engine, placing B so that the pair touches at
// given local coordinates, and central differences over the pair's 18 coordinates.
#include "contact/spline_contact.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <random>

namespace yarnsim::contact::test {

using Vec18 = Eigen::Matrix<double, 18, 1>;
using Mat18 = Eigen::Matrix<double, 18, 18>;

// Scales of the study (formulation.md §1): control points ~1 mm apart, r = 0.284 mm,
// spline penalty 1.5e6 N/m, penetrations of microns.
constexpr double kL = 1.1e-3;
constexpr double kRadius = 2.840909e-4;
constexpr double kEps = 1.5e6;

/// One segment pair: control points of A and B (columns, metres) and their bases.
struct Pair {
  Eigen::Matrix3d xa;
  Eigen::Matrix3d xb;
  const SegmentBasis* ba;
  const SegmentBasis* bb;
  double ra = kRadius;
  double rb = kRadius;
};

inline const SplineCurve& curve5() {
  static const SplineCurve curve(5); // segments: first (double knot), interior, last
  return curve;
}

/// Coordinate i of the pair: A's control points for i < 9, then B's, each x, y, z.
inline double& dof(Pair& p, int i) {
  return i < 9 ? p.xa(i % 3, i / 3) : p.xb(i % 3, (i - 9) / 3);
}

/// The velocity of coordinate i (numbered as in dof()).
inline double& velocity(PairRates& rates, int i) {
  return i < 9 ? rates.velocity_A(i % 3, i / 3) : rates.velocity_B(i % 3, (i - 9) / 3);
}

/// Translates B so that the contact points sit at local coordinates (ua, ub) and the centre
/// distance is r_A + r_B - delta. Returns false if the projection fails on the way.
inline bool place(Pair& p, double ua, double ub, double delta) {
  SplineContactOptions wide;
  wide.max_extension = 10.0;
  for (int it = 0; it < 100; ++it) {
    const ProjectionResult pr = closest_point_projection(p.xa, *p.ba, p.xb, *p.bb, {}, wide);
    if (pr.status == ProjectionStatus::NotConverged) {
      return false;
    }
    const double ua0 = p.ba->local(pr.xi_A);
    const double ub0 = p.bb->local(pr.xi_B);
    const Eigen::Vector3d ca = p.xa * p.ba->values_local(ua0);
    const Eigen::Vector3d cb = p.xb * p.bb->values_local(ub0);
    if (std::abs(ua0 - ua) < 1e-13 && std::abs(ub0 - ub) < 1e-13) {
      const Eigen::Vector3d g = ca - cb;
      const double s = g.norm() - (p.ra + p.rb - delta);
      p.xb.colwise() += s * g.normalized();
      return true;
    }
    const Eigen::Vector3d move =
        (p.xa * p.ba->values_local(ua) - ca) - (p.xb * p.bb->values_local(ub) - cb);
    p.xb.colwise() += move;
  }
  return false;
}

/// place(), then checks that a cold start finds that point (strongly curved pairs can have
/// another minimum). Returns false if either fails.
inline bool place_checked(Pair& p, double ua, double ub, double delta) {
  if (!place(p, ua, ub, delta)) {
    return false;
  }
  const ProjectionResult pr = closest_point_projection(p.xa, *p.ba, p.xb, *p.bb, {});
  return pr.status == ProjectionStatus::Converged && std::abs(p.ba->local(pr.xi_A) - ua) < 1e-9 &&
         std::abs(p.bb->local(pr.xi_B) - ub) < 1e-9;
}

// Every random configuration is drawn from the test's own engine, one number per statement:
// Eigen's Quaterniond::UnitRandom() draws from std::rand(), whose state depends on which tests
// ran before (a --gtest_filter run saw other pairs than the full run), and the order in which
// the arguments of one call are evaluated is unspecified (GCC and Clang differ).

/// A vector with components uniform in [-1, 1], drawn x, y, z in that order.
inline Eigen::Vector3d random_vector(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Vector3d v;
  for (int i = 0; i < 3; ++i) {
    v(i) = u(rng);
  }
  return v;
}

/// A rotation uniform over SO(3): a unit quaternion of four independent normal deviates.
inline Eigen::Quaterniond random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Vector4d c;
  for (int i = 0; i < 4; ++i) {
    c(i) = n(rng);
  }
  return Eigen::Quaterniond(c.normalized());
}

/// A random curved pair crossing at an angle of at least 20 degrees, on segments `sa` and `sb`
/// of a 5-point spline.
inline Pair random_crossing(std::mt19937& rng, int sa, int sb) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Pair p;
  p.ba = &curve5().segment(sa);
  p.bb = &curve5().segment(sb);
  const Eigen::Quaterniond q = random_rotation(rng);
  const double angle = (20.0 + 140.0 * (0.5 + 0.5 * u(rng))) * M_PI / 180.0;
  const Eigen::Vector3d da = q * Eigen::Vector3d::UnitX();
  const Eigen::Vector3d db = q * Eigen::Vector3d(std::cos(angle), std::sin(angle), 0.0);
  for (int k = 0; k < 3; ++k) {
    p.xa.col(k) = (k - 1) * kL * da + 0.2 * kL * random_vector(rng);
    p.xb.col(k) = (k - 1) * kL * db + 0.2 * kL * random_vector(rng);
  }
  p.xb.colwise() += Eigen::Vector3d(kL, -kL, 2 * kL);
  return p;
}

/// As above on random segments: A's, then B's, each uniform over the spline's three.
inline Pair random_crossing(std::mt19937& rng) {
  std::uniform_int_distribution<int> seg(0, 2);
  const int sa = seg(rng);
  const int sb = seg(rng);
  return random_crossing(rng, sa, sb);
}

/// Random velocities of the control points (components up to 0.01 m/s, A's and B's point by
/// point) and the Newmark coupling gamma / (beta dt) with dt = 1e-4 s.
inline PairRates random_rates(std::mt19937& rng) {
  PairRates rates;
  for (int k = 0; k < 3; ++k) {
    rates.velocity_A.col(k) = 0.01 * random_vector(rng);
    rates.velocity_B.col(k) = 0.01 * random_vector(rng);
  }
  rates.velocity_per_displacement = 0.5 / (0.3 * 1e-4); // Newmark gamma / (beta dt)
  return rates;
}

/// Central differences, at h = 1e-6 kL, of `residual(pair, rates)` (a Vec18) with respect to the
/// 18 coordinates of `base`, column by column. With `rates`, each step moves the coordinate's
/// velocity too, by velocity_per_displacement times the step, as in a Newmark iteration; without,
/// `residual` gets nullptr.
template <class Residual>
Mat18 central_differences(const Pair& base, const PairRates* rates, const Residual& residual) {
  const double h = 1e-6 * kL;
  Mat18 fd;
  for (int i = 0; i < 18; ++i) {
    Vec18 res[2];
    for (int side = 0; side < 2; ++side) {
      const double step = side == 0 ? h : -h;
      Pair p = base;
      dof(p, i) += step;
      PairRates moved;
      if (rates != nullptr) {
        moved = *rates;
        velocity(moved, i) += rates->velocity_per_displacement * step;
      }
      res[side] = residual(p, rates != nullptr ? &moved : nullptr);
    }
    fd.col(i) = (res[0] - res[1]) / (2 * h);
  }
  return fd;
}

} // namespace yarnsim::contact::test
