#include "contact/friction.hpp"

#include "spline_pairs.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <limits>
#include <memory>
#include <random>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace yarnsim::contact {
namespace {

using namespace test;

using Eigen::Matrix3d;
using Eigen::Vector3d;

/// Normal contact (with its sensitivity) and friction of one evaluation.
struct Evaluation {
  SplineContactResult contact;
  SplineContactSensitivity sensitivity;
  SplineFrictionResult friction;
};

/// spline_contact then spline_friction at fixed `history`, with the default options (the force
/// conjugate to the gap residual only: it has no tangent). Unlike the
/// normal force, which is stationary in the parameters, the friction force depends on them at
/// first order, so the projection's accuracy enters the finite differences below directly (a
/// parameter error of 1e-13 would show as 1e-13 kL / h ~ 1e-7): the projection's last step is a
/// full Newton step past one below the tolerance, which leaves round-off (checked: a tolerance of
/// 1e-15 instead of 1e-12 changes the measured errors by less than 10 %).
Evaluation evaluate(const Pair& p, const InterfaceLaw& law, const CoulombFriction& friction,
                    const FrictionHistory& history, const ProjectionStart& start = {},
                    const PairRates* rates = nullptr,
                    FrictionForce force = FrictionForce::AtContactPoints) {
  const SplineContactOptions options;
  Evaluation e;
  spline_contact(p.xa, *p.ba, kRadius, p.xb, *p.bb, kRadius, start, law, e.contact, options, rates,
                 &e.sensitivity);
  FrictionOptions friction_options;
  friction_options.force = force;
  friction_options.compute_tangent = force == FrictionForce::AtContactPoints;
  spline_friction(p.xa, *p.ba, p.xb, *p.bb, e.contact, &e.sensitivity, history, friction,
                  e.friction, friction_options, rates);
  return e;
}

/// A random anchor at local offsets (da, db) from the contact point (in segments; may lie in
/// the neighbouring segment), and a tangential penalty that puts the trial force at `ratio`
/// times the cone's radius mu f_n.
struct Anchored {
  FrictionHistory history;
  double eps_t = 0.0;
};

Anchored anchored(const Pair& p, const SplineContactResult& c, double da, double db, bool stuck,
                  double mu, double ratio) {
  Anchored s;
  s.history = {c.xi_A - da * p.ba->length(), c.xi_B - db * p.bb->length(), stuck};
  const Vector3d g_t = da * (p.xa * p.ba->first_local(p.ba->local(c.xi_A))) -
                       db * (p.xb * p.bb->first_local(p.bb->local(c.xi_B)));
  s.eps_t = ratio * mu * c.force / g_t.norm();
  return s;
}

/// Max-norm relative error of the friction tangent against central differences of the friction
/// residual, at fixed history; the perturbed projections are warm-started from the base one,
/// as in a Newton iteration. Also checks that the state (stick or slip) does not switch.
double tangent_error(const Pair& base, const InterfaceLaw& law, const CoulombFriction& friction,
                     const FrictionHistory& history, const PairRates* rates = nullptr) {
  const Evaluation e0 = evaluate(base, law, friction, history, {}, rates);
  EXPECT_EQ(e0.contact.status, ProjectionStatus::Converged);
  EXPECT_TRUE(e0.friction.active);
  const ProjectionStart warm{e0.contact.xi_A, e0.contact.xi_B, true};
  const Mat18 fd = central_differences(base, rates, [&](const Pair& p, const PairRates* moved) {
    const Evaluation e = evaluate(p, law, friction, history, warm, moved);
    EXPECT_EQ(e.contact.status, ProjectionStatus::Converged);
    EXPECT_EQ(e.friction.slipping, e0.friction.slipping);
    return e.friction.residual;
  });
  return (fd - e0.friction.tangent).cwiseAbs().maxCoeff() /
         e0.friction.tangent.cwiseAbs().maxCoeff();
}

TEST(SplineFriction, LawRejectsBadCoefficients) {
  EXPECT_NO_THROW(CoulombFriction(0.3, 0.2, 1e5, 1.0));
  EXPECT_NO_THROW(CoulombFriction(0.0, 0.0, 1e5));
  EXPECT_THROW(CoulombFriction(0.2, 0.3, 1e5), std::invalid_argument); // mu_k > mu_s
  EXPECT_THROW(CoulombFriction(0.3, -0.1, 1e5), std::invalid_argument);
  EXPECT_THROW(CoulombFriction(0.3, 0.2, 0.0), std::invalid_argument);
  EXPECT_THROW(CoulombFriction(0.3, 0.2, 1e5, -1.0), std::invalid_argument);
  EXPECT_THROW(CoulombFriction(std::numeric_limits<double>::quiet_NaN(), 0.2, 1e5),
               std::invalid_argument);
  EXPECT_THROW(CoulombFriction(0.3, 0.2, INFINITY), std::invalid_argument);
  // An elastic slip in place of the penalty; neither, or a negative one, is an error.
  EXPECT_NO_THROW(CoulombFriction(0.3, 0.2, 0.0, 0.0, 1e-5));
  EXPECT_THROW(CoulombFriction(0.3, 0.2, 0.0, 0.0, 0.0), std::invalid_argument);
  EXPECT_THROW(CoulombFriction(0.3, 0.2, 1e5, 0.0, -1e-5), std::invalid_argument);
  EXPECT_THROW(CoulombFriction(0.3, 0.2, 1e5, 0.0, INFINITY), std::invalid_argument);
}

TEST(SplineFriction, SensitivityMatchesCentralDifferencesAndLeavesTheContactAlone) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.4, 0.4);
  std::uniform_int_distribution<int> seg(0, 2);
  const DampedLaw law(std::make_shared<LinearPenalty>(kEps), 20.0);
  double worst = 0.0;
  int tested = 0;
  while (tested < 20) {
    const int sa = seg(rng);
    const int sb = seg(rng);
    Pair p = random_crossing(rng, sa, sb);
    const double ua = u(rng);
    const double ub = u(rng);
    if (!place_checked(p, ua, ub, 4e-6)) {
      continue;
    }
    ++tested;
    const PairRates rates = random_rates(rng);
    const SplineContactOptions options;
    const SplineContactResult plain =
        spline_contact(p.xa, *p.ba, kRadius, p.xb, *p.bb, kRadius, {}, law, options, &rates);
    SplineContactSensitivity s;
    const SplineContactResult r =
        spline_contact(p.xa, *p.ba, kRadius, p.xb, *p.bb, kRadius, {}, law, options, &rates, &s);
    ASSERT_TRUE(r.active);
    ASSERT_TRUE(s.valid);
    EXPECT_EQ(r.xi_A, plain.xi_A);
    EXPECT_EQ(r.force, plain.force);
    EXPECT_EQ(r.residual, plain.residual);
    EXPECT_EQ(r.tangent, plain.tangent);
    const ProjectionStart warm{r.xi_A, r.xi_B, true};
    const double h = 1e-6 * kL;
    Eigen::Matrix<double, 2, 18> fd_xi;
    Vec18 fd_force;
    for (int i = 0; i < 18; ++i) {
      double xi_a[2], xi_b[2], force[2];
      for (int side = 0; side < 2; ++side) {
        const double step = side == 0 ? h : -h;
        Pair q = p;
        dof(q, i) += step;
        PairRates moved = rates;
        velocity(moved, i) += rates.velocity_per_displacement * step;
        const SplineContactResult rq =
            spline_contact(q.xa, *q.ba, kRadius, q.xb, *q.bb, kRadius, warm, law, options, &moved);
        xi_a[side] = rq.xi_A;
        xi_b[side] = rq.xi_B;
        force[side] = rq.force;
      }
      fd_xi(0, i) = (xi_a[0] - xi_a[1]) / (2 * h);
      fd_xi(1, i) = (xi_b[0] - xi_b[1]) / (2 * h);
      fd_force(i) = (force[0] - force[1]) / (2 * h);
    }
    const double xi_error =
        (fd_xi - s.parameters).cwiseAbs().maxCoeff() / s.parameters.cwiseAbs().maxCoeff();
    const double force_error =
        (fd_force - s.force).cwiseAbs().maxCoeff() / s.force.cwiseAbs().maxCoeff();
    EXPECT_LT(xi_error, 1e-6);
    EXPECT_LT(force_error, 1e-6);
    worst = std::max({worst, xi_error, force_error});
  }
  std::ostringstream value;
  value << std::scientific << std::setprecision(2) << worst;
  RecordProperty("worst_error", value.str());
}

/// Test 1: the tangent against central differences of the residual in stick and slip, with
/// mu_s = mu_k and mu_s > mu_k, stuck and slipping histories, anchors in the contact's segment
/// and across a knot in the neighbouring one, with and without damping. Tolerance 1e-6 of the
/// largest entry, as for the normal contact's tangent: central differences at h = 1e-6 kL have a
/// truncation error ~(h / kL)^2 ~ 1e-12, and rounding (of the residual and of the re-solved
/// projection) measured below 2e-9 over these configurations (the worst per state is recorded
/// as a test property). Dropping any one term of the tangent (du/dx in the weights, C'' in
/// dg_t/dx, df_n/dx in slip, dn/dx in the damping) gives errors of 1e-4 to 60.
TEST(SplineFriction, TangentMatchesCentralDifferencesInStickAndSlip) {
  std::mt19937 rng(2027);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<int> seg(0, 2);
  const LinearPenalty linear(kEps);
  const PowerLaw power(5e8, 1.5);
  const DampedLaw damped(std::make_shared<LinearPenalty>(kEps), 20.0);
  int count[2][2] = {{0, 0}, {0, 0}}; // [slip][anchor across a knot]
  int dampened = 0;
  int elastic_count[2] = {0, 0};                 // [slip], with an elastic slip
  double worst[2][2] = {{0.0, 0.0}, {0.0, 0.0}}; // [slip][damped]
  int tested = 0;
  // The last 32 configurations set the stick stiffness by an elastic slip (mu f_n / gamma, its
  // dependence on f_n in the stick tangent) instead of a constant penalty.
  while (tested < 96) {
    const bool elastic = tested >= 64;
    const int sa = seg(rng);
    const int sb = seg(rng);
    Pair p = random_crossing(rng, sa, sb);
    const bool across = tested % 2 == 1;
    const bool slip = (tested / 2) % 2 == 1;
    const bool unequal = (tested / 4) % 2 == 1; // mu_s > mu_k
    const bool stuck = (tested / 8) % 2 == 1;
    const bool with_damping = tested % 16 >= 12;
    // Contact point: near the end of A's segment that has a neighbour when the anchor is to lie
    // across a knot, else anywhere inside.
    const double side_a = sa == 0 ? 1.0 : sa == 2 ? -1.0 : (unit(rng) < 0.5 ? -1.0 : 1.0);
    const double side_b = sb == 0 ? 1.0 : sb == 2 ? -1.0 : (unit(rng) < 0.5 ? -1.0 : 1.0);
    const double ua = across ? side_a * (0.5 - 0.02 * unit(rng)) : 0.8 * unit(rng) - 0.4;
    const double ub = across ? side_b * (0.5 - 0.02 * unit(rng)) : 0.8 * unit(rng) - 0.4;
    const double delta = 1e-6 + 1e-5 * unit(rng);
    if (!place_checked(p, ua, ub, delta)) {
      continue;
    }
    // Anchor offsets (segments): across the knot, 0.03 to 0.1 beyond the contact point.
    const double da = across ? -side_a * (0.03 + 0.07 * unit(rng)) : 0.1 * (2 * unit(rng) - 1);
    const double db = across ? -side_b * (0.03 + 0.07 * unit(rng)) : 0.1 * (2 * unit(rng) - 1);
    const double mu_s = unequal ? 0.4 : 0.3;
    const double mu_k = 0.3;
    const double ratio = slip ? 1.1 + 4.0 * unit(rng) : 0.2 + 0.7 * unit(rng);
    const PairRates rates = random_rates(rng);
    const PairRates* r = with_damping ? &rates : nullptr;
    const InterfaceLaw& law = with_damping      ? static_cast<const InterfaceLaw&>(damped)
                              : tested % 3 == 0 ? static_cast<const InterfaceLaw&>(power)
                                                : static_cast<const InterfaceLaw&>(linear);
    const SplineContactResult c =
        spline_contact(p.xa, *p.ba, kRadius, p.xb, *p.bb, kRadius, {}, law, {}, r);
    ASSERT_TRUE(c.active);
    const Anchored s = anchored(p, c, da, db, stuck, stuck ? mu_s : mu_k, ratio);
    // The same trial ratio by an elastic slip: gamma = mu f_n / eps_t = |g_t| / ratio.
    const double gamma = elastic ? (stuck ? mu_s : mu_k) * c.force / s.eps_t : 0.0;
    const CoulombFriction friction(mu_s, mu_k, elastic ? 0.0 : s.eps_t, with_damping ? 0.05 : 0.0,
                                   gamma);
    const Evaluation e = evaluate(p, law, friction, s.history, {}, r);
    ASSERT_TRUE(e.friction.active);
    ASSERT_EQ(e.friction.slipping, slip);
    EXPECT_NEAR(e.friction.stiffness, s.eps_t, 1e-12 * s.eps_t);
    elastic_count[slip] += elastic ? 1 : 0;
    if (across) {
      // The anchor lies in the neighbouring segment of both curves.
      EXPECT_FALSE(p.ba->owns(s.history.xi_A));
      EXPECT_FALSE(p.bb->owns(s.history.xi_B));
    }
    if (with_damping) {
      ASSERT_GT(e.friction.sliding_velocity.norm(), 0.0);
      ++dampened;
    }
    ++count[slip][across];
    ++tested;
    const double error = tangent_error(p, law, friction, s.history, r);
    worst[slip][with_damping] = std::max(worst[slip][with_damping], error);
    EXPECT_LT(error, 1e-6) << "configuration " << tested << (slip ? " slip" : " stick")
                           << (across ? ", anchor across a knot" : "");
  }
  for (const auto& row : count) {
    for (const int n : row) {
      EXPECT_GE(n, 12);
    }
  }
  EXPECT_GE(dampened, 12);
  EXPECT_GE(elastic_count[0], 12);
  EXPECT_GE(elastic_count[1], 12);
  for (const int slip : {0, 1}) {
    for (const int damping : {0, 1}) {
      std::ostringstream name;
      std::ostringstream value;
      name << "worst_error_" << (slip ? "slip" : "stick") << (damping ? "_damped" : "");
      value << std::scientific << std::setprecision(2) << worst[slip][damping];
      RecordProperty(name.str(), value.str());
    }
  }
}

/// Straight beams crossing at right angles, A along x below B along y, penetration 2 microns.
Pair straight_crossing(const SplineCurve& c3, double delta) {
  Pair p{Matrix3d::Zero(), Matrix3d::Zero(), &c3.segment(0), &c3.segment(0)};
  for (int k = 0; k < 3; ++k) {
    p.xa.col(k) = Vector3d((k - 1) * kL, 0.0, 0.0);
    p.xb.col(k) = Vector3d(0.0, (k - 1) * kL, 2 * kRadius - delta);
  }
  return p;
}

/// Sum of the residual's blocks over A's control points: the internal force on A, N.
Vector3d on_a(const Vec18& residual) {
  return residual.segment<3>(0) + residual.segment<3>(3) + residual.segment<3>(6);
}
Vector3d on_b(const Vec18& residual) {
  return residual.segment<3>(9) + residual.segment<3>(12) + residual.segment<3>(15);
}

/// Drags A along +x by u = 3 cone i / n (i = 1 ... n, those within 1e-3 of the cone left out:
/// either state within round-off) from first touch, the history held, pressed by delta (m); `cone`
/// is the radius of the friction's cone in displacement (m: mu f_n / eps_t, or the elastic slip).
/// Checks that the point sticks with the force mu f_n u / cone inside it and slides at mu f_n
/// outside it, on A along -x (opposing the sliding), the internal forces balanced, the slip
/// increment u - cone and the stick stiffness mu f_n / cone. Returns {stuck, slipping}.
std::pair<int, int> drag_from_first_touch(const CoulombFriction& friction, double delta,
                                          double cone, int n) {
  const SplineCurve c3(3);
  const LinearPenalty law(kEps);
  const double f_n = kEps * delta;
  const double mu = friction.mu_s();
  const Pair p0 = straight_crossing(c3, delta);
  const FrictionHistory history = first_touch(evaluate(p0, law, friction, {}).contact);
  const Evaluation e0 = evaluate(p0, law, friction, history);
  EXPECT_TRUE(e0.friction.active);
  EXPECT_EQ(e0.friction.force.norm(), 0.0);
  int stuck = 0;
  int slipping = 0;
  for (int i = 1; i <= n; ++i) {
    const double u = 3.0 * cone * i / n;
    if (std::abs(u - cone) < 1e-3 * cone)
      continue;
    Pair p = p0;
    p.xa.row(0).array() += u;
    const Evaluation e = evaluate(p, law, friction, history);
    EXPECT_TRUE(e.friction.active);
    EXPECT_NEAR(e.contact.force, f_n, 1e-12 * f_n);
    const double expected = mu * f_n * std::min(u / cone, 1.0);
    EXPECT_EQ(e.friction.slipping, u > cone) << "u = " << u << ", f_n = " << f_n;
    (e.friction.slipping ? slipping : stuck)++;
    EXPECT_NEAR(e.friction.force.norm(), expected, 1e-12 * expected) << "u = " << u;
    // Opposes the sliding of A (+x): the force on A points -x; the internal forces are its
    // opposite on A and the force itself on B.
    EXPECT_LT((e.friction.force + expected * Vector3d::UnitX()).norm(), 1e-12 * expected);
    EXPECT_LT((on_a(e.friction.residual) - expected * Vector3d::UnitX()).norm(), 1e-12 * expected);
    EXPECT_LT((on_b(e.friction.residual) + on_a(e.friction.residual)).norm(), 1e-14 * expected);
    EXPECT_NEAR(e.friction.stiffness, mu * f_n / cone, 1e-12 * mu * f_n / cone);
    EXPECT_NEAR(e.friction.slip_increment, std::max(u - cone, 0.0), 1e-12 * u);
  }
  return {stuck, slipping};
}

/// Test 2, one coefficient: dragging A along +x by u from first touch (history held), the force
/// on A points -x with magnitude eps_t u inside the cone and mu f_n outside it.
TEST(SplineFriction, StraightBeamsStickThenSlipAtMuTimesTheNormalForce) {
  const double delta = 2e-6, eps_t = 1e5, mu = 0.3;
  const double f_n = kEps * delta; // 3 N
  const auto [stuck, slipping] =
      drag_from_first_touch(CoulombFriction(mu, mu, eps_t), delta, mu * f_n / eps_t, 40); // 9 um
  EXPECT_GT(stuck, 5);
  EXPECT_GT(slipping, 5);
}

/// With an elastic slip gamma the stick stiffness is mu f_n / gamma: dragging A from first touch,
/// the point sticks up to a displacement of gamma at every normal force (the force mu f_n u /
/// gamma), then slides at mu f_n, and the slip increment is u - gamma.
TEST(SplineFriction, WithAnElasticSlipEveryNormalForceSticksOverTheSameDisplacement) {
  const double gamma = 4e-6; // m
  const CoulombFriction friction(0.3, 0.3, 0.0, 0.0, gamma);
  for (const double delta : {2e-8, 2e-7, 2e-6}) { // 0.03 to 3 N
    const auto [stuck, slipping] = drag_from_first_touch(friction, delta, gamma, 30);
    EXPECT_EQ(stuck, 9);
    EXPECT_EQ(slipping, 20);
  }
}

/// Test 2, mu_s > mu_k: dragging A by steps with the history committed after each, a stuck
/// point holds up to mu_s f_n, the step that breaks it loose carries mu_s f_n (the coefficient
/// is the committed state's), and the steps after it slide at mu_k f_n.
TEST(SplineFriction, StuckPointHoldsUpToStaticAndSlidesAtKineticFriction) {
  const SplineCurve c3(3);
  const LinearPenalty law(kEps);
  const double delta = 2e-6;
  const double f_n = kEps * delta;
  const double eps_t = 1e5;
  const double mu_s = 0.4;
  const double mu_k = 0.25;
  const CoulombFriction friction(mu_s, mu_k, eps_t);
  Pair p = straight_crossing(c3, delta);
  FrictionHistory history = first_touch(evaluate(p, law, friction, {}).contact);
  const double step = 0.093 * mu_s * f_n / eps_t; // no step ends on the cone
  double u = 0.0;
  int phase = 0; // 0 stuck, 1 the step that broke loose, 2 sliding
  int held_above_kinetic = 0;
  int sliding = 0;
  for (int i = 1; i <= 30; ++i) {
    p.xa.row(0).array() += step;
    u += step;
    const Evaluation e = evaluate(p, law, friction, history);
    ASSERT_TRUE(e.friction.active);
    const double magnitude = e.friction.force.norm();
    EXPECT_LT((e.friction.force / magnitude + Vector3d::UnitX()).norm(), 1e-12);
    if (phase == 0 && !e.friction.slipping) {
      EXPECT_EQ(e.friction.mu, mu_s);
      EXPECT_NEAR(magnitude, eps_t * u, 1e-12 * eps_t * u);
      EXPECT_LE(magnitude, mu_s * f_n);
      held_above_kinetic += magnitude > mu_k * f_n ? 1 : 0;
    } else if (phase == 0) {
      phase = 1;
      EXPECT_GT(eps_t * u, mu_s * f_n);
      EXPECT_EQ(e.friction.mu, mu_s);
      EXPECT_NEAR(magnitude, mu_s * f_n, 1e-12 * mu_s * f_n);
    } else {
      phase = 2;
      ++sliding;
      EXPECT_TRUE(e.friction.slipping);
      EXPECT_EQ(e.friction.mu, mu_k);
      EXPECT_NEAR(magnitude, mu_k * f_n, 1e-12 * mu_k * f_n);
    }
    history = e.friction.history; // commit the converged increment
    EXPECT_EQ(history.stuck, !e.friction.slipping);
  }
  EXPECT_GE(held_above_kinetic, 3); // stuck between mu_k f_n and mu_s f_n
  EXPECT_GE(sliding, 10);
}

/// Test 3: a rigid motion (rotation up to 90 degrees about an arbitrary axis through an
/// arbitrary point, plus a translation) of a stuck configuration, the anchors' parameters
/// unchanged, leaves |f| unchanged and rotates the force and the residual's blocks. The
/// projection is solved again in the moved configuration, so its round-off (~1e-16 in xi)
/// enters g_t relative to |g_t| >= 1e-3 segments: a tolerance of 1e-10 holds it with margin,
/// while a non-objective gap (e.g. the anchor as a fixed point in space) would be off by O(1).
TEST(SplineFriction, RigidMotionOfAStuckPairRotatesTheForce) {
  std::mt19937 rng(99);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<int> seg(0, 2);
  const LinearPenalty law(kEps);
  int tested = 0;
  while (tested < 20) {
    const int sa = seg(rng);
    const int sb = seg(rng);
    Pair p = random_crossing(rng, sa, sb);
    const double ua = 0.8 * unit(rng) - 0.4;
    const double ub = 0.8 * unit(rng) - 0.4;
    if (!place_checked(p, ua, ub, 5e-6)) {
      continue;
    }
    const SplineContactResult c =
        spline_contact(p.xa, *p.ba, kRadius, p.xb, *p.bb, kRadius, {}, law);
    const double da = 0.05 * (2 * unit(rng) - 1);
    const double db = 0.05 * (2 * unit(rng) - 1);
    if (std::abs(da) < 1e-3 || std::abs(db) < 1e-3) {
      continue;
    }
    const bool slip = tested % 4 == 3; // mostly stuck; the slip cone must rotate along as well
    const Anchored s = anchored(p, c, da, db, true, 0.4, slip ? 2.0 : 0.5 + 0.4 * unit(rng));
    const CoulombFriction friction(0.4, 0.3, s.eps_t);
    const Evaluation e0 = evaluate(p, law, friction, s.history);
    ASSERT_TRUE(e0.friction.active);
    ASSERT_EQ(e0.friction.slipping, slip);
    ++tested;
    for (int k = 0; k < 4; ++k) {
      const Vector3d axis = random_vector(rng).normalized();
      const double angle = 0.5 * M_PI * (k == 0 ? 1.0 : unit(rng)); // 90 degrees, then random
      const Matrix3d rot = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
      const Vector3d centre = 1e-3 * random_vector(rng);
      const Vector3d shift = 1e-3 * random_vector(rng);
      Pair q = p;
      for (int j = 0; j < 3; ++j) {
        q.xa.col(j) = rot * (p.xa.col(j) - centre) + centre + shift;
        q.xb.col(j) = rot * (p.xb.col(j) - centre) + centre + shift;
      }
      const Evaluation e =
          evaluate(q, law, friction, s.history, {e0.contact.xi_A, e0.contact.xi_B, true});
      ASSERT_TRUE(e.friction.active);
      EXPECT_EQ(e.friction.slipping, slip);
      const double f = e0.friction.force.norm();
      EXPECT_NEAR(e.friction.force.norm(), f, 1e-10 * f);
      EXPECT_LT((e.friction.force - rot * e0.friction.force).norm(), 1e-10 * f);
      for (int b = 0; b < 6; ++b) {
        EXPECT_LT(
            (e.friction.residual.segment<3>(3 * b) - rot * e0.friction.residual.segment<3>(3 * b))
                .norm(),
            1e-10 * f);
      }
      // The elastic gap stays orthogonal to the normal.
      EXPECT_LT(std::abs(e.friction.elastic_gap.dot(e.contact.normal)),
                1e-10 * e.friction.elastic_gap.norm());
    }
  }
}

/// Test 4: after a slip, evaluating again with the returned anchor (and the same coefficient)
/// puts the trial force on the cone, phi = 0, with the same force; the anchor moved along both
/// curves by the same factor, and the gap shrank by the slip increment. Round-off: the anchor
/// is stored as a global parameter (~1), whose rounding (1.1e-16) is at most ~1e-13 of the
/// parameter differences (>= 1e-3 segments here); a tolerance of 1e-12 of mu f_n holds it.
TEST(SplineFriction, ReturnMappingPutsTheAnchorOnTheCone) {
  std::mt19937 rng(314);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<int> seg(0, 2);
  const LinearPenalty law(kEps);
  int tested = 0;
  while (tested < 30) {
    const int sa = seg(rng);
    const int sb = seg(rng);
    Pair p = random_crossing(rng, sa, sb);
    const double ua = 0.8 * unit(rng) - 0.4;
    const double ub = 0.8 * unit(rng) - 0.4;
    if (!place_checked(p, ua, ub, 1e-6 + 1e-5 * unit(rng))) {
      continue;
    }
    const SplineContactResult c =
        spline_contact(p.xa, *p.ba, kRadius, p.xb, *p.bb, kRadius, {}, law);
    const double da = 0.1 * (2 * unit(rng) - 1);
    const double db = 0.1 * (2 * unit(rng) - 1);
    const double ratio = 1.1 + 9.0 * unit(rng);
    if (std::abs(da) < 1e-2 * ratio || std::abs(db) < 1e-2 * ratio) {
      continue; // keep the returned differences above 1e-3 segments
    }
    const bool unequal = tested % 2 == 1;
    const bool stuck = tested % 3 == 0;
    const double mu_s = unequal ? 0.5 : 0.3;
    const double mu_k = 0.3;
    const double mu = stuck ? mu_s : mu_k;
    const Anchored s = anchored(p, c, da, db, stuck, mu, ratio);
    const CoulombFriction friction(mu_s, mu_k, s.eps_t);
    const Evaluation e = evaluate(p, law, friction, s.history);
    ASSERT_TRUE(e.friction.slipping);
    ++tested;
    const double cone = mu * e.contact.force;
    EXPECT_NEAR(e.friction.slip_function, (ratio - 1.0) * cone, 1e-9 * ratio * cone);
    EXPECT_FALSE(e.friction.history.stuck);
    // Both differences scaled by one factor, in [0, 1).
    const double scale_a =
        (e.contact.xi_A - e.friction.history.xi_A) / (e.contact.xi_A - s.history.xi_A);
    const double scale_b =
        (e.contact.xi_B - e.friction.history.xi_B) / (e.contact.xi_B - s.history.xi_B);
    EXPECT_NEAR(scale_a, 1.0 / ratio, 1e-9 / ratio);
    EXPECT_NEAR(scale_b, scale_a, 1e-12);
    // Re-evaluation with the returned anchor, the same coefficient: on the cone.
    FrictionHistory returned = e.friction.history;
    returned.stuck = stuck;
    const Evaluation again = evaluate(p, law, friction, returned);
    EXPECT_NEAR(again.friction.slip_function, 0.0, 1e-12 * cone);
    EXPECT_LT((again.friction.force - e.friction.force).norm(), 1e-12 * cone);
    EXPECT_NEAR(e.friction.elastic_gap.norm() - again.friction.elastic_gap.norm(),
                e.friction.slip_increment, 1e-12 * e.friction.elastic_gap.norm());
    EXPECT_LT(again.friction.slip_increment, 1e-12 * e.friction.elastic_gap.norm());
  }
}

/// A point returned onto the cone in the committed state is evaluated next at positions that
/// have not moved (the converged state's tangent, the first correction of an increment): its
/// trial lies on the cone to the projection's round-off, and it keeps slipping, with the slip
/// tangent, until its trial falls inside by kOnCone of the radius. A stuck point is not moved.
TEST(SplineFriction, APointThatSlippedKeepsSlippingOnTheCone) {
  const SplineCurve c3(3);
  const LinearPenalty law(kEps);
  const double delta = 2e-6;
  const double f_n = kEps * delta;
  const double eps_t = 1e5;
  const double mu = 0.3;
  const CoulombFriction friction(mu, mu, eps_t);
  const Pair p0 = straight_crossing(c3, delta);
  const double u_star = mu * f_n / eps_t;
  const auto at = [&](double u, bool stuck) {
    FrictionHistory history = first_touch(evaluate(p0, law, friction, {}).contact);
    history.stuck = stuck;
    Pair p = p0;
    p.xa.row(0).array() += u;
    return evaluate(p, law, friction, history).friction;
  };
  const SplineFrictionResult beyond = at((1 + 1e-4) * u_star, false); // slipping, the reference
  const SplineFrictionResult inside = at((1 - 1e-3) * u_star, false); // stuck, the reference
  ASSERT_TRUE(beyond.slipping);
  ASSERT_FALSE(inside.slipping);
  const double tangent_gap = (beyond.tangent - inside.tangent).norm();
  ASSERT_GT(tangent_gap, 1e-2 * inside.tangent.norm()); // the two tangents differ
  for (const double below : {1e-12, 1e-9, 1e-7}) {
    const SplineFrictionResult on = at((1 - below) * u_star, false);
    EXPECT_TRUE(on.slipping) << below;
    EXPECT_FALSE(on.history.stuck) << below;
    EXPECT_NEAR(on.force.norm(), mu * f_n, 1e-12 * mu * f_n) << below;
    EXPECT_EQ(on.slip_increment, 0.0) << below;
    EXPECT_EQ(on.dissipation, 0.0) << below;
    EXPECT_LT((on.tangent - beyond.tangent).norm(), 1e-3 * tangent_gap) << below;
    // The same point stuck in the committed state stays stuck: mu_s holds it.
    const SplineFrictionResult held = at((1 - below) * u_star, true);
    EXPECT_FALSE(held.slipping) << below;
    EXPECT_LT((held.tangent - inside.tangent).norm(), 1e-3 * tangent_gap) << below;
  }
  EXPECT_FALSE(at((1 - 10 * kOnCone) * u_star, false).slipping);
}

TEST(SplineFriction, NoFrictionWithoutARegularActiveContact) {
  const SplineCurve c3(3);
  const LinearPenalty law(kEps);
  const CoulombFriction friction(0.3, 0.3, 1e5);
  // Separated.
  Pair p = straight_crossing(c3, -1e-6);
  Evaluation e = evaluate(p, law, friction, {0.4, 0.6, true});
  EXPECT_FALSE(e.contact.active);
  EXPECT_FALSE(e.sensitivity.valid);
  EXPECT_FALSE(e.friction.active);
  EXPECT_EQ(e.friction.residual, Vec18::Zero());
  EXPECT_EQ(e.friction.tangent, Mat18::Zero());
  EXPECT_EQ(e.friction.history.xi_A, 0.4);
  // Parallel (degenerate path): out of scope, no friction.
  for (int k = 0; k < 3; ++k) {
    p.xb.col(k) = Vector3d((k - 1) * kL + 0.3 * kL, 0.0, 2 * kRadius - 2e-6);
  }
  e = evaluate(p, law, friction, {0.4, 0.6, true});
  EXPECT_TRUE(e.contact.active);
  EXPECT_TRUE(e.contact.degenerate);
  EXPECT_FALSE(e.sensitivity.valid);
  EXPECT_FALSE(e.friction.active);
  EXPECT_EQ(e.friction.residual, Vec18::Zero());
}

TEST(SplineFriction, TangentAndConjugateForceNeedTheNormalContactSensitivity) {
  const SplineCurve c3(3);
  const LinearPenalty law(kEps);
  const CoulombFriction friction(0.3, 0.3, 1e5);
  Pair p = straight_crossing(c3, 2e-6);
  p.xa.row(0).array() += 1e-6;
  SplineContactSensitivity sensitivity;
  const SplineContactResult c = spline_contact(p.xa, *p.ba, kRadius, p.xb, *p.bb, kRadius, {}, law,
                                               {}, nullptr, &sensitivity);
  const FrictionHistory history{0.5, 0.5, true};
  SplineFrictionResult out;
  FrictionOptions residual_only;
  residual_only.compute_tangent = false;
  FrictionOptions conjugate_residual = residual_only;
  conjugate_residual.force = FrictionForce::ConjugateToTheGap;
  // The conjugate force has no tangent (the explicit path's).
  FrictionOptions conjugate_tangent;
  conjugate_tangent.force = FrictionForce::ConjugateToTheGap;
  EXPECT_THROW(spline_friction(p.xa, *p.ba, p.xb, *p.bb, c, &sensitivity, history, friction, out,
                               conjugate_tangent),
               std::invalid_argument);
  for (const FrictionOptions& options : {FrictionOptions{}, conjugate_residual}) {
    EXPECT_THROW(
        spline_friction(p.xa, *p.ba, p.xb, *p.bb, c, nullptr, history, friction, out, options),
        std::invalid_argument);
    const SplineContactSensitivity stale; // valid = false
    EXPECT_THROW(
        spline_friction(p.xa, *p.ba, p.xb, *p.bb, c, &stale, history, friction, out, options),
        std::invalid_argument);
  }
  // The point forces' residual alone needs none, and its tangent is zero.
  spline_friction(p.xa, *p.ba, p.xb, *p.bb, c, nullptr, history, friction, out, residual_only);
  EXPECT_TRUE(out.active);
  EXPECT_NEAR(out.force.x(), -1e5 * 1e-6, 1e-12);
  EXPECT_EQ(out.tangent, Mat18::Zero());
  const Vec18 points = out.residual;
  // The force conjugate to the gap: on each yarn the same resultant as the point forces; the
  // difference is the couple (C_A - C_B) x f that the point forces leave, here taken by A's
  // bending (B, along y, would take it as torsion, which its translations cannot carry).
  spline_friction(p.xa, *p.ba, p.xb, *p.bb, c, &sensitivity, history, friction, out,
                  conjugate_residual);
  EXPECT_LT((on_a(out.residual) - on_a(points)).norm(), 1e-9 * out.force.norm());
  EXPECT_LT((on_b(out.residual) - on_b(points)).norm(), 1e-9 * out.force.norm());
  Vector3d moment = Vector3d::Zero();
  for (int k = 0; k < 6; ++k) {
    const Vector3d x = k < 3 ? Vector3d(p.xa.col(k)) : Vector3d(p.xb.col(k - 3));
    moment += x.cross(out.residual.segment<3>(3 * k) - points.segment<3>(3 * k));
  }
  const Vector3d couple = c.distance * c.normal.cross(out.force);
  EXPECT_LT((moment - couple).norm(), 1e-6 * couple.norm()) << moment.transpose();
  EXPECT_EQ(out.tangent, Mat18::Zero());
}

/// Random curved crossings with an anchor 0.02 to 0.1 segments from the contact point, in stick
/// or slip, constant penalty, no damping, the force carried as `force` says: calls `check` with
/// the pair, the law, the history and the evaluation, 24 times.
template <class Check>
void for_anchored_crossings(unsigned seed, bool slip, FrictionForce force, const Check& check) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<int> seg(0, 2);
  const LinearPenalty law(kEps);
  int tested = 0;
  while (tested < 24) {
    Pair p = random_crossing(rng, seg(rng), seg(rng));
    if (!place_checked(p, 0.8 * unit(rng) - 0.4, 0.8 * unit(rng) - 0.4, 1e-6 + 1e-5 * unit(rng)))
      continue;
    const SplineContactResult c =
        spline_contact(p.xa, *p.ba, kRadius, p.xb, *p.bb, kRadius, {}, law);
    ASSERT_TRUE(c.active);
    const double sign_a = unit(rng) < 0.5 ? -1.0 : 1.0, sign_b = unit(rng) < 0.5 ? -1.0 : 1.0;
    const Anchored s =
        anchored(p, c, sign_a * (0.02 + 0.08 * unit(rng)), sign_b * (0.02 + 0.08 * unit(rng)), true,
                 0.3, slip ? 1.5 + 2.0 * unit(rng) : 0.2 + 0.7 * unit(rng));
    const CoulombFriction friction(0.3, 0.3, s.eps_t);
    const Evaluation e = evaluate(p, law, friction, s.history, {}, nullptr, force);
    ASSERT_TRUE(e.friction.active);
    ASSERT_EQ(e.friction.slipping, slip);
    check(p, law, friction, s.history, e);
    ++tested;
  }
}

// In stick with a constant penalty the force conjugate to the gap is the gradient of the stored
// energy eps_t |g_t|^2 / 2 at the held anchor: it does work on the gap it is computed from, so
// the work of the loads is the stored energy plus the dissipation (formulation.md, "Friction on
// the explicit path"). Point forces f at C_A and -f at C_B miss the part through the turning of
// the normal, a relative error of order one on these curved crossings (0.87 measured).
TEST(SplineFriction, StickForceConjugateToTheGapIsTheGradientOfTheStoredEnergy) {
  double worst = 0.0;
  for_anchored_crossings(
      31, false, FrictionForce::ConjugateToTheGap,
      [&](const Pair& base, const InterfaceLaw& law, const CoulombFriction& friction,
          const FrictionHistory& history, const Evaluation& e0) {
        const ProjectionStart warm{e0.contact.xi_A, e0.contact.xi_B, true};
        Vec18 gradient;
        const double h = 1e-6 * kL;
        for (int i = 0; i < 18; ++i) {
          double energy[2];
          for (int side = 0; side < 2; ++side) {
            Pair p = base;
            dof(p, i) += side == 0 ? h : -h;
            const Evaluation e = evaluate(p, law, friction, history, warm, nullptr,
                                          FrictionForce::ConjugateToTheGap);
            EXPECT_FALSE(e.friction.slipping);
            energy[side] = 0.5 * friction.eps_t() * e.friction.elastic_gap.squaredNorm();
          }
          gradient(i) = (energy[0] - energy[1]) / (2 * h);
        }
        const double error = (gradient - e0.friction.residual).cwiseAbs().maxCoeff() /
                             e0.friction.residual.cwiseAbs().maxCoeff();
        worst = std::max(worst, error);
      });
  std::printf("stick force conjugate to the gap against the energy's central differences: worst "
              "%.2e relative\n",
              worst);
  EXPECT_LT(worst, 1e-8); // measured 6.1e-10; the point forces: 0.87
}

// The friction forces conjugate to the gap are internal to the pair: they sum to zero, and so do
// their moments, in stick and in slip (the force along g_t, which is objective). Point forces f
// at C_A and -f at C_B sum to zero too but leave the couple (C_A - C_B) x f, of magnitude
// |g| |f| (f is normal to the normal).
TEST(SplineFriction, ForcesConjugateToTheGapHaveNoResultantAndNoMoment) {
  for (const FrictionForce force :
       {FrictionForce::ConjugateToTheGap, FrictionForce::AtContactPoints}) {
    const bool conjugate = force == FrictionForce::ConjugateToTheGap;
    for (const bool slip : {false, true}) {
      double worst_force = 0.0, worst_moment = 0.0;
      for_anchored_crossings(
          47, slip, force,
          [&](const Pair& p, const InterfaceLaw&, const CoulombFriction&, const FrictionHistory&,
              const Evaluation& e) {
            Vector3d resultant = Vector3d::Zero(), moment = Vector3d::Zero();
            for (int k = 0; k < 6; ++k) {
              const Vector3d x = k < 3 ? Vector3d(p.xa.col(k)) : Vector3d(p.xb.col(k - 3));
              const Vector3d r = e.friction.residual.segment<3>(3 * k);
              resultant += r;
              moment += x.cross(r);
            }
            // Scales: the force, and the force times the pair's size.
            const double f = e.friction.force.norm();
            const double size = (p.xa.col(2) - p.xa.col(0)).norm();
            const double couple = e.contact.distance * f;
            worst_force = std::max(worst_force, resultant.norm() / f);
            if (conjugate)
              worst_moment = std::max(worst_moment, moment.norm() / (f * size));
            else
              worst_moment = std::max(worst_moment, std::abs(moment.norm() - couple) / couple);
          });
      const char* what = conjugate ? (slip ? "conjugate, slip" : "conjugate, stick")
                                   : (slip ? "point forces, slip" : "point forces, stick");
      EXPECT_LT(worst_force, 1e-9) << what;
      EXPECT_LT(worst_moment, 1e-9) << what;
    }
  }
}

} // namespace
} // namespace yarnsim::contact
