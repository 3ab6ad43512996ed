// Coulomb friction on the all-angle contact's line part (contact/line_friction.hpp): straight
// yarns side by side in stick (eps_t lambda L times the offset) and in slip (mu times the line's
// normal force); the tangent against central differences of the residual in stick and in slip,
// at random configurations from parallel into the blend, with Gauss points whose projections lie
// in any segment of the master and anchors in the neighbouring ones; the return mapping onto the
// cone; a rigid rotation of a stuck pair rotates its force.
#include "contact/line_friction.hpp"
#include "contact/torsional_friction.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <cstdio>
#include <random>

namespace yarnsim::contact {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using Vec = Eigen::VectorXd;
using Mat = Eigen::MatrixXd;

constexpr double kH = 1.1e-3; // control point spacing, m
constexpr double kRadius = 2.840909e-4;
constexpr double kEps = 1.5e6; // N/m
constexpr double kEpsT = 5e5;  // N/m
constexpr int kPoints = 6;     // control points per curve: 4 segments
constexpr int kSegments = kPoints - 2;

const SplineCurve& curve() {
  static const SplineCurve c(kPoints);
  return c;
}

struct Curves {
  Eigen::Matrix3Xd a = Eigen::Matrix3Xd::Zero(3, kPoints);
  Eigen::Matrix3Xd b = Eigen::Matrix3Xd::Zero(3, kPoints);
};

/// A along x; B turned by `angle` about z, shifted by `shift` along its axis, `distance` above
/// A; random transverse perturbations of `wobble` (m).
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

/// Histories of every Gauss point of A's segments (anchors on B, global parameters).
using Histories = std::array<std::array<LineFrictionHistory, kMaxGaussPoints>, kSegments>;

/// The friction of every segment pair, summed over the 2 kPoints control points (A's first), on
/// fixed `histories`; `anchored` (optional) receives, per A segment, the projections' global
/// parameters on B of the Gauss points in contact (the history of a first touch).
struct Total {
  double normal = 0.0; ///< sum of the evaluated points' N
  Vector3d on_a = Vector3d::Zero();
  int points = 0, slipping = 0;
  Vec residual = Vec::Zero(6 * kPoints);
  Mat tangent = Mat::Zero(6 * kPoints, 6 * kPoints);
};

Total total(const Curves& c, const AllAngleOptions& opt, const CoulombFriction& friction,
            const Histories& histories, Histories* anchored = nullptr) {
  static const LinearPenalty law(kEps);
  Total t;
  SplineContactResult r;
  LineFrictionResult f;
  const GaussRule& rule = gauss_rule(opt.gauss_points);
  for (int i = 0; i < kSegments; ++i)
    for (int j = 0; j < kSegments; ++j) {
      all_angle_contact(curve().control_points(c.a, i), curve().segment(i), kRadius,
                        curve().control_points(c.b, j), curve().segment(j), kRadius, {}, law, opt,
                        r);
      EXPECT_NE(r.status, ProjectionStatus::NotConverged) << i << " " << j;
      if (anchored != nullptr)
        for (int k = 0; k < rule.n; ++k)
          if (r.line_mask & (1u << k))
            (*anchored)[i][k] = {curve().segment(j).global(r.line_u[k]), true};
      line_friction(curve().control_points(c.a, i), curve().segment(i), kRadius,
                    curve().control_points(c.b, j), curve().segment(j), kRadius, law, opt, r,
                    0xffff, histories[i], friction, f);
      for (int k = 0; k < rule.n; ++k)
        if (f.mask & (1u << k)) {
          ++t.points;
          t.slipping += f.points[k].slipping;
          t.normal += f.points[k].normal_force;
          t.on_a += f.points[k].force;
        }
      const int dofs[6] = {i, i + 1, i + 2, kPoints + j, kPoints + j + 1, kPoints + j + 2};
      for (int p = 0; p < 6; ++p) {
        t.residual.segment<3>(3 * dofs[p]) += f.residual.segment<3>(3 * p);
        for (int q = 0; q < 6; ++q)
          t.tangent.block<3, 3>(3 * dofs[p], 3 * dofs[q]) += f.tangent.block<3, 3>(3 * p, 3 * q);
      }
    }
  return t;
}

double& dof(Curves& c, int i) {
  const int point = i / 3, d = i % 3;
  return point < kPoints ? c.a(d, point) : c.b(d, point - kPoints);
}

/// Histories anchored `offset` (segments of B) from where every Gauss point in contact touches
/// now, with the stick flag `stuck`.
Histories offset_histories(const Curves& c, const AllAngleOptions& opt, double offset, bool stuck) {
  const CoulombFriction none(0.0, 0.0, kEpsT);
  Histories h{}, now{};
  total(c, opt, none, h, &now);
  for (auto& segment : now)
    for (LineFrictionHistory& p : segment) {
      p.xi_B += offset * curve().segment(0).length();
      p.stuck = stuck;
    }
  return now;
}

AllAngleOptions options() {
  AllAngleOptions opt;
  opt.line_scale = 1.0 / (2 * kRadius);
  return opt;
}

TEST(LineFriction, StraightYarnsSideBySideStickThenSlipAtMuTimesTheLineLoad) {
  // A on B along x, pressed by p = 1 um; B three times as long, so every Gauss point of A touches
  // one of B's interior segments (C_B,u = 3 kH). Anchors `offset` segments ahead along B (+x):
  // g_t = C_B,u offset points +x, so does the force on A.
  const AllAngleOptions opt = options();
  std::mt19937 rng(1);
  const double p = 1e-6;
  Curves c = make_curves(0.0, 2 * kRadius - p, 0.0, 0.0, rng);
  c.b.row(0) *= 3.0;
  const double length = c.a(0, kPoints - 1) - c.a(0, 0);
  const double lambda = opt.line_scale;
  const double normal = kEps * lambda * p * length;
  const double mu = 0.3;
  const CoulombFriction friction(mu, mu, kEpsT);
  // Stick: 1e-4 segments of B = 3.3e-7 m, below mu f / eps_t = 9e-7 m.
  const double stick_offset = 1e-4;
  const Total stick = total(c, opt, friction, offset_histories(c, opt, stick_offset, true));
  EXPECT_EQ(stick.points, opt.gauss_points * kSegments);
  EXPECT_EQ(stick.slipping, 0);
  EXPECT_NEAR(stick.normal, normal, 1e-9 * normal);
  const double slide = stick_offset * 3.0 * kH;
  EXPECT_NEAR(stick.on_a.x(), kEpsT * lambda * length * slide, 1e-9 * stick.on_a.norm());
  EXPECT_NEAR(stick.on_a.y(), 0.0, 1e-12 * stick.on_a.norm());
  EXPECT_NEAR(stick.on_a.z(), 0.0, 1e-12 * stick.on_a.norm());
  // Slip: 1e-3 segments = 3.3e-6 m.
  const Total slip = total(c, opt, friction, offset_histories(c, opt, 1e-3, true));
  EXPECT_EQ(slip.slipping, slip.points);
  EXPECT_NEAR(slip.on_a.x(), mu * normal, 1e-9 * mu * normal);
  // The residual balances: the force on B is the opposite of the force on A.
  Vector3d on_a = Vector3d::Zero(), on_b = Vector3d::Zero();
  for (int k = 0; k < kPoints; ++k) {
    on_a -= slip.residual.segment<3>(3 * k);
    on_b -= slip.residual.segment<3>(3 * (kPoints + k));
  }
  EXPECT_NEAR((on_a - slip.on_a).norm(), 0.0, 1e-12 * mu * normal);
  EXPECT_NEAR((on_a + on_b).norm(), 0.0, 1e-12 * mu * normal);
  // With an elastic slip of 1 um the stick force is mu N slide / gamma (the stiffness mu N /
  // gamma), the slip force mu N again.
  const double gamma = 1e-6;
  const CoulombFriction elastic(mu, mu, 0.0, 0.0, gamma);
  const Total elastic_stick = total(c, opt, elastic, offset_histories(c, opt, stick_offset, true));
  EXPECT_EQ(elastic_stick.slipping, 0);
  EXPECT_NEAR(elastic_stick.on_a.x(), mu * normal * slide / gamma, 1e-9 * mu * normal);
  const Total elastic_slip = total(c, opt, elastic, offset_histories(c, opt, 1e-3, true));
  EXPECT_EQ(elastic_slip.slipping, elastic_slip.points);
  EXPECT_NEAR(elastic_slip.on_a.x(), mu * normal, 1e-9 * mu * normal);
}

/// Relative error of the tangent against central differences of the residual, histories fixed.
double tangent_error(const Curves& c, const AllAngleOptions& opt, const CoulombFriction& friction,
                     const Histories& h, Total& t0) {
  t0 = total(c, opt, friction, h);
  const double step = 1e-10; // m, against gaps of microns and anchors 1e-7 to 1e-5 m away
  Mat fd(6 * kPoints, 6 * kPoints);
  for (int i = 0; i < 6 * kPoints; ++i) {
    Curves p = c, m = c;
    dof(p, i) += step;
    dof(m, i) -= step;
    fd.col(i) =
        (total(p, opt, friction, h).residual - total(m, opt, friction, h).residual) / (2 * step);
  }
  return (fd - t0.tangent).lpNorm<Eigen::Infinity>() / t0.tangent.lpNorm<Eigen::Infinity>();
}

TEST(LineFriction, TangentMatchesCentralDifferencesInStickAndSlip) {
  const AllAngleOptions opt = options();
  // A constant tangential penalty, and an elastic slip of 6 um (the stiffness mu N / gamma, a
  // function of the positions through N).
  const CoulombFriction penalty(0.4, 0.3, kEpsT);
  const CoulombFriction elastic(0.4, 0.3, 0.0, 0.0, 6e-6);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  double worst = 0;
  // Parallel, nearly parallel, line only, and into the blend (10 to 20 degrees); contact points
  // anywhere on B (shift), anchors up to 0.6 segment away (in the neighbouring segment).
  for (const CoulombFriction* law : {&penalty, &elastic})
    for (const double angle : {0.0, 2e-3, 0.05, 0.15, 0.22, 0.3})
      for (const bool slipping : {false, true})
        for (int trial = 0; trial < 2; ++trial) {
          const CoulombFriction& friction = *law;
          const double shift = (u(rng) - 0.5) * kH;
          const Curves c = make_curves(angle, 2 * kRadius - 1e-5, shift, 0.02 * kRadius, rng);
          // Stick: 1e-5 segments (1.1e-8 m, inside the cone of about 6e-6 m); slip: 0.6 segment.
          const double offset = (slipping ? 0.6 : 1e-5) * (u(rng) < 0.5 ? -1 : 1);
          const Histories h = offset_histories(c, opt, offset, trial == 0);
          Total t;
          const double e = tangent_error(c, opt, friction, h, t);
          std::printf("%s, angle %.3f, %s: %d points (%d slipping), tangent %.1e\n",
                      law == &elastic ? "elastic slip" : "penalty", angle,
                      slipping ? "slip" : "stick", t.points, t.slipping, e);
          ASSERT_GT(t.points, 0) << angle;
          EXPECT_EQ(t.slipping, slipping ? t.points : 0) << angle;
          EXPECT_LT(e, 1e-6) << angle << (slipping ? " slip" : " stick");
          worst = std::max(worst, e);
        }
  std::printf("worst: %.1e\n", worst);
}

TEST(LineFriction, ReturnMappingPutsTheAnchorOnTheCone) {
  // A slipping point's returned history, evaluated at the same positions, gives the same force
  // on the cone; as a point that slipped it keeps slipping there (slips()).
  const AllAngleOptions opt = options();
  const CoulombFriction friction(0.3, 0.3, kEpsT);
  static const LinearPenalty law(kEps);
  std::mt19937 rng(3);
  const Curves c = make_curves(0.05, 2 * kRadius - 1e-5, 0.3 * kH, 0.02 * kRadius, rng);
  const Histories h = offset_histories(c, opt, 0.4, true);
  SplineContactResult r;
  LineFrictionResult first, again;
  const int i = 1, j = 1;
  all_angle_contact(curve().control_points(c.a, i), curve().segment(i), kRadius,
                    curve().control_points(c.b, j), curve().segment(j), kRadius, {}, law, opt, r);
  ASSERT_NE(r.line_mask, 0);
  line_friction(curve().control_points(c.a, i), curve().segment(i), kRadius,
                curve().control_points(c.b, j), curve().segment(j), kRadius, law, opt, r, 0xffff,
                h[i], friction, first);
  std::array<LineFrictionHistory, kMaxGaussPoints> returned{};
  for (int k = 0; k < kMaxGaussPoints; ++k)
    returned[k] = first.points[k].history;
  line_friction(curve().control_points(c.a, i), curve().segment(i), kRadius,
                curve().control_points(c.b, j), curve().segment(j), kRadius, law, opt, r, 0xffff,
                returned, friction, again);
  ASSERT_EQ(again.mask, first.mask);
  for (int k = 0; k < kMaxGaussPoints; ++k) {
    if (!(first.mask & (1u << k)))
      continue;
    const LineFrictionPoint &a = first.points[k], &b = again.points[k];
    EXPECT_TRUE(a.slipping);
    EXPECT_GT(a.slip_increment, 0.0);
    EXPECT_NEAR(a.dissipation, 0.3 * a.normal_force * a.slip_increment, 1e-15);
    EXPECT_NEAR(a.force.norm(), 0.3 * a.normal_force, 1e-12 * a.force.norm());
    EXPECT_TRUE(b.slipping);
    EXPECT_NEAR((b.force - a.force).norm(), 0.0, 1e-9 * a.force.norm());
    EXPECT_NEAR(b.slip_increment, 0.0, 1e-9 * a.slip_increment);
  }
}

TEST(LineFriction, RigidRotationOfAStuckPairRotatesItsForce) {
  // Up to 90 degrees about an axis across the yarns: the anchors are material (global
  // parameters), so the stuck force turns with the pair and keeps its magnitude.
  const AllAngleOptions opt = options();
  const CoulombFriction friction(0.3, 0.3, kEpsT);
  std::mt19937 rng(9);
  const Curves c = make_curves(0.03, 2 * kRadius - 1e-5, 0.2 * kH, 0.02 * kRadius, rng);
  const Histories h = offset_histories(c, opt, 1e-4, true);
  const Total before = total(c, opt, friction, h);
  ASSERT_GT(before.points, 0);
  ASSERT_EQ(before.slipping, 0);
  const Vector3d centre(0.3e-3, -0.1e-3, 0.2e-3);
  for (const double angle : {0.3, 1.0, std::acos(-1.0) / 2}) {
    const Matrix3d q = Eigen::AngleAxisd(angle, Vector3d(0.3, 1.0, -0.5).normalized()).matrix();
    Curves turned = c;
    for (int k = 0; k < kPoints; ++k) {
      turned.a.col(k) = centre + q * (c.a.col(k) - centre);
      turned.b.col(k) = centre + q * (c.b.col(k) - centre);
    }
    const Total after = total(turned, opt, friction, h);
    EXPECT_EQ(after.points, before.points);
    EXPECT_EQ(after.slipping, 0);
    EXPECT_NEAR((after.on_a - q * before.on_a).norm(), 0.0, 1e-9 * before.on_a.norm()) << angle;
  }
}

TEST(LineFriction, OnlyGaussPointsInContactWithAHistoryCarryFriction) {
  // The mask of points with a history selects them; points without contact carry none.
  const AllAngleOptions opt = options();
  const CoulombFriction friction(0.3, 0.3, kEpsT);
  static const LinearPenalty law(kEps);
  std::mt19937 rng(1);
  Curves c = make_curves(0.0, 2 * kRadius - 1e-6, 0.0, 0.0, rng);
  c.b.row(0) *= 1.5;
  const Histories h = offset_histories(c, opt, 1e-4, true);
  SplineContactResult r;
  LineFrictionResult f;
  all_angle_contact(curve().control_points(c.a, 1), curve().segment(1), kRadius,
                    curve().control_points(c.b, 1), curve().segment(1), kRadius, {}, law, opt, r);
  ASSERT_NE(r.line_mask, 0);
  line_friction(curve().control_points(c.a, 1), curve().segment(1), kRadius,
                curve().control_points(c.b, 1), curve().segment(1), kRadius, law, opt, r, 0, h[1],
                friction, f);
  EXPECT_EQ(f.mask, 0);
  EXPECT_EQ(f.residual.norm(), 0.0);
  const std::uint16_t some = r.line_mask & 0x5;
  line_friction(curve().control_points(c.a, 1), curve().segment(1), kRadius,
                curve().control_points(c.b, 1), curve().segment(1), kRadius, law, opt, r, 0x5, h[1],
                friction, f);
  EXPECT_EQ(f.mask, some);
  // Apart: no Gauss point in contact, no friction.
  const Curves apart = make_curves(0.0, 2 * kRadius + 1e-6, 0.0, 0.0, rng);
  all_angle_contact(curve().control_points(apart.a, 1), curve().segment(1), kRadius,
                    curve().control_points(apart.b, 1), curve().segment(1), kRadius, {}, law, opt,
                    r);
  EXPECT_EQ(r.line_mask, 0);
  line_friction(curve().control_points(apart.a, 1), curve().segment(1), kRadius,
                curve().control_points(apart.b, 1), curve().segment(1), kRadius, law, opt, r,
                0xffff, h[1], friction, f);
  EXPECT_EQ(f.mask, 0);
}

/// Point friction histories per segment pair (A's i, B's j) and whether the pair has one.
struct PointHistories {
  std::array<std::array<FrictionHistory, kSegments>, kSegments> history{};
  std::array<std::array<bool, kSegments>, kSegments> has{};
};

/// The point part's friction (friction.hpp with the all-angle contact's share) and its torsional
/// friction (torsional_friction.hpp) plus the line part's, over all segment pairs, on fixed
/// histories: residual, tangent, and the point parts' smallest share.
struct Blend {
  Vec residual = Vec::Zero(6 * kPoints);
  Mat tangent = Mat::Zero(6 * kPoints, 6 * kPoints);
  int point_frictions = 0, line_points = 0, twist_slipping = 0;
  double min_share = 1.0;
  Vector3d on_a = Vector3d::Zero();
};

Blend blend(const Curves& c, const AllAngleOptions& opt, const CoulombFriction& friction,
            const PointHistories& ph, const Histories& lh, PointHistories* touched = nullptr) {
  static const LinearPenalty law(kEps);
  Blend t;
  SplineContactResult r;
  SplineContactSensitivity sens;
  SplineFrictionResult pf;
  LineFrictionResult lf;
  for (int i = 0; i < kSegments; ++i)
    for (int j = 0; j < kSegments; ++j) {
      const Matrix3d A = curve().control_points(c.a, i), B = curve().control_points(c.b, j);
      const SegmentBasis &sa = curve().segment(i), &sb = curve().segment(j);
      all_angle_contact(A, sa, kRadius, B, sb, kRadius, {}, law, opt, r, {}, &sens);
      EXPECT_NE(r.status, ProjectionStatus::NotConverged) << i << " " << j;
      Eigen::Matrix<double, 18, 1> res = Eigen::Matrix<double, 18, 1>::Zero();
      Eigen::Matrix<double, 18, 18> tan = Eigen::Matrix<double, 18, 18>::Zero();
      if (sens.valid) {
        if (touched != nullptr) {
          touched->history[i][j] = first_touch(r);
          touched->history[i][j].twist = crossing_angle(A, sa, B, sb, r);
          touched->has[i][j] = true;
        }
        if (ph.has[i][j]) {
          spline_friction(A, sa, B, sb, r, &sens, ph.history[i][j], friction, pf);
          EXPECT_TRUE(pf.active);
          ++t.point_frictions;
          t.min_share = std::min(t.min_share, pf.share);
          t.on_a += pf.force;
          res += pf.residual;
          tan += pf.tangent;
          // Torsional friction at the crossing (rho from yarns 4 r wide).
          TorsionalFrictionResult tf;
          torsional_friction(A, sa, B, sb, r, &sens, ph.history[i][j],
                             torsional_law(friction.mu_s(), friction.mu_k(), friction.eps_t(), 0, 0,
                                           4 * kRadius, 4 * kRadius),
                             tf);
          EXPECT_TRUE(tf.active);
          t.twist_slipping += tf.slipping;
          res += tf.residual;
          tan += tf.tangent;
        }
      }
      line_friction(A, sa, kRadius, B, sb, kRadius, law, opt, r, 0xffff, lh[i], friction, lf);
      for (int k = 0; k < kMaxGaussPoints; ++k)
        if (lf.mask & (1u << k)) {
          ++t.line_points;
          t.on_a += lf.points[k].force;
        }
      res += lf.residual;
      tan += lf.tangent;
      const int dofs[6] = {i, i + 1, i + 2, kPoints + j, kPoints + j + 1, kPoints + j + 2};
      for (int p = 0; p < 6; ++p) {
        t.residual.segment<3>(3 * dofs[p]) += res.segment<3>(3 * p);
        for (int q = 0; q < 6; ++q)
          t.tangent.block<3, 3>(3 * dofs[p], 3 * dofs[q]) += tan.block<3, 3>(3 * p, 3 * q);
      }
    }
  return t;
}

TEST(LineFriction, BlendedPointFrictionHasItsShareAndAConsistentTangent) {
  // Crossing angles in the blend (10 to 20 degrees): the point part's friction and torsional
  // friction carry its share s (0 < s < 1) and the line part's Gauss points theirs; the sum's
  // tangent against central differences, in stick and in slip.
  const AllAngleOptions opt = options();
  const CoulombFriction friction(0.4, 0.3, kEpsT);
  static const LinearPenalty law(kEps);
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  double worst = 0, smallest_share = 1;
  for (const double angle : {0.2, 0.25, 0.3, 0.33})
    for (const bool slipping : {false, true}) {
      const Curves c =
          make_curves(angle, 2 * kRadius - 1e-5, (u(rng) - 0.5) * kH, 0.02 * kRadius, rng);
      // Point histories: anchors `offset` segments from the contact points on both curves.
      PointHistories now{}, ph{};
      blend(c, opt, friction, ph, {}, &now);
      const double offset = (slipping ? 0.3 : 1e-5) * curve().segment(0).length();
      ph = now;
      for (auto& row : ph.history)
        for (FrictionHistory& h : row) {
          h.xi_A -= offset;
          h.xi_B += offset;
          h.twist += slipping ? 0.3 : 1e-7; // rad
        }
      const Histories lh = offset_histories(c, opt, slipping ? 0.3 : 1e-5, true);
      const Blend t0 = blend(c, opt, friction, ph, lh);
      ASSERT_GT(t0.point_frictions, 0) << angle;
      EXPECT_EQ(t0.twist_slipping, slipping ? t0.point_frictions : 0) << angle;
      const double step = 1e-10;
      Mat fd(6 * kPoints, 6 * kPoints);
      for (int i = 0; i < 6 * kPoints; ++i) {
        Curves p = c, m = c;
        dof(p, i) += step;
        dof(m, i) -= step;
        fd.col(i) =
            (blend(p, opt, friction, ph, lh).residual - blend(m, opt, friction, ph, lh).residual) /
            (2 * step);
      }
      const double e =
          (fd - t0.tangent).lpNorm<Eigen::Infinity>() / t0.tangent.lpNorm<Eigen::Infinity>();
      std::printf("angle %.2f, %s: %d point frictions (smallest share %.3f), %d line points, "
                  "tangent %.1e\n",
                  angle, slipping ? "slip" : "stick", t0.point_frictions, t0.min_share,
                  t0.line_points, e);
      EXPECT_LT(e, 1e-6) << angle;
      worst = std::max(worst, e);
      smallest_share = std::min(smallest_share, t0.min_share);
    }
  EXPECT_LT(smallest_share, 0.9); // the blend was exercised
  std::printf("worst: %.1e\n", worst);
}

TEST(LineFriction, BlendedPointFrictionIsTheShareOfThePointFriction) {
  // The same pair with a share s < 1: force, dissipation and residual are s times those of the
  // point contact alone (line_contact = false) at the same positions and history.
  const AllAngleOptions opt = options();
  const CoulombFriction friction(0.3, 0.3, kEpsT);
  static const LinearPenalty law(kEps);
  std::mt19937 rng(17);
  const Curves c = make_curves(0.28, 2 * kRadius - 1e-5, 0.1 * kH, 0.0, rng);
  const int i = 1, j = 1;
  const Matrix3d A = curve().control_points(c.a, i), B = curve().control_points(c.b, j);
  const SegmentBasis &sa = curve().segment(i), &sb = curve().segment(j);
  SplineContactResult blended, alone;
  SplineContactSensitivity sb_sens, alone_sens;
  all_angle_contact(A, sa, kRadius, B, sb, kRadius, {}, law, opt, blended, {}, &sb_sens);
  spline_contact(A, sa, kRadius, B, sb, kRadius, {}, law, alone, {}, nullptr, &alone_sens);
  ASSERT_TRUE(sb_sens.valid);
  ASSERT_TRUE(alone_sens.valid);
  const double s = blended.point_share;
  ASSERT_GT(s, 0.05);
  ASSERT_LT(s, 0.95);
  EXPECT_NEAR(blended.point_force, alone.force, 1e-12 * alone.force);
  for (const double offset : {1e-5, 0.3}) {
    FrictionHistory h = first_touch(alone);
    h.xi_A -= offset * sa.length();
    h.xi_B += offset * sb.length();
    SplineFrictionResult fb, fa;
    spline_friction(A, sa, B, sb, blended, &sb_sens, h, friction, fb);
    spline_friction(A, sa, B, sb, alone, &alone_sens, h, friction, fa);
    EXPECT_EQ(fb.slipping, fa.slipping);
    EXPECT_EQ(fb.share, s);
    EXPECT_NEAR((fb.force - s * fa.force).norm(), 0.0, 1e-12 * fa.force.norm());
    EXPECT_NEAR((fb.residual - s * fa.residual).norm(), 0.0, 1e-12 * fa.residual.norm());
    EXPECT_NEAR(fb.dissipation, s * fa.dissipation, 1e-12 * fa.force.norm());
    EXPECT_EQ(fb.slip_increment, fa.slip_increment);
  }
}

} // namespace
} // namespace yarnsim::contact
