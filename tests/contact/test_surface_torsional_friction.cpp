// Torsional friction of the surface contact (contact/surface_torsional_friction.hpp): the
// section's third derivative the jets need, the stick residual against central differences of
// the stored energy, the tangent against central differences of the residual in stick and in
// slip (crossings at 90 degrees, near it, oblique, random; elliptical and super-elliptical
// sections; contacts inside an end window, share < 1), the return mapping onto mu f_n rho, the
// residual-only path, and the crossing angle's objectivity (rigid motions leave it, a rotation
// of one yarn about the normal changes it by that angle).
#include "contact/surface_torsional_friction.hpp"

#include "surface_pairs.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>

namespace yarnsim::contact {
namespace {

using namespace surface_test;

using Eigen::Matrix3d;
using Eigen::Vector3d;
using Vec24 = Eigen::Matrix<double, 24, 1>;
using Mat24 = Eigen::Matrix<double, 24, 24>;

std::string scientific(double v) {
  std::ostringstream s;
  s << std::scientific << std::setprecision(2) << v;
  return s.str();
}

/// Two element surfaces (as in test_surface_friction.cpp).
struct Pair {
  SurfaceNode a[2];
  SurfaceNode b[2];
  SuperEllipse sa{kA, kB};
  SuperEllipse sb{kA, kB};
  SuperEllipticalCylinder A() const { return {a[0], a[1], sa}; }
  SuperEllipticalCylinder B() const { return {b[0], b[1], sb}; }
};

/// DOF i of the pair in the kernel's order (eq. 2).
double& dof(Pair& p, int i) {
  SurfaceNode* n = i < 12 ? p.a : p.b;
  const int j = i % 12;
  return j < 6 ? n[j / 3].position(j % 3) : n[(j - 6) / 3].rotation_increment(j % 3);
}

/// DOF scales: metres for translations (the element length), 1 for Rodrigues parameters.
double dof_scale(int i) {
  return i % 12 < 6 ? 1e-3 : 1.0;
}

SurfaceContactResult solve(const Pair& p, const InterfaceLaw& law,
                           const SurfaceProjectionStart& start = {},
                           SurfaceContactSensitivity* sensitivity = nullptr) {
  return surface_contact(p.A(), p.B(), start, law, {}, nullptr, sensitivity);
}

SurfaceProjectionStart warm_start(const SurfaceContactResult& r) {
  return {r.zeta_A, r.theta_A, r.zeta_B, r.theta_B, true};
}

/// Moves B along the contact normal to the signed gap `gap`; false unless the projection ends
/// active on the regular path.
bool place(Pair& p, double gap) {
  const LinearPenalty law(kEps);
  for (int it = 0; it < 3; ++it) {
    const SurfaceContactResult r = solve(p, law);
    if (r.status != ProjectionStatus::Converged) {
      return false;
    }
    if (std::abs(r.gap - gap) < 1e-15) {
      break;
    }
    for (SurfaceNode& n : p.b) {
      n.position += (r.gap - gap) * r.normal;
    }
  }
  const SurfaceContactResult r = solve(p, law);
  return r.status == ProjectionStatus::Converged && r.active &&
         r.degeneration == SurfaceDegeneration::None;
}

/// A random bent and twisted element (as in test_surface_friction.cpp).
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

/// A crossing at `degrees` between the axes, turned by a random rotation, bent, twisted, with
/// random Rodrigues increments at all four nodes, and B's centre moved along A by `shift`
/// element lengths; gap not yet set (place). `m`: both sections' exponent.
Pair crossing(std::mt19937& rng, double degrees, double m = 2.0, double shift = 0.0) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double length = 1e-3;
  const Eigen::Quaterniond q = random_rotation(rng);
  const double angle = degrees * kPi / 180.0;
  Pair p;
  p.sa = SuperEllipse(kA, kB, m);
  p.sb = SuperEllipse(kA, kB, m);
  const Vector3d da = q * Vector3d::UnitX();
  const Vector3d db = q * Vector3d(std::cos(angle), std::sin(angle), 0.0);
  const Vector3d up = q * Vector3d::UnitZ();
  const Vector3d ca = 0.2 * length * (q * Vector3d(u(rng), u(rng), 0.0));
  const Vector3d cb =
      0.2 * length * (q * Vector3d(u(rng), u(rng), 0.0)) + 2.0 * kB * up + shift * length * da;
  random_element(rng, p.a, ca, da, da.cross(up), 0.4 * u(rng), length, 0.05);
  random_element(rng, p.b, cb, db, db.cross(up), 0.4 * u(rng), length, 0.05);
  return p;
}

/// Central difference of `f` with respect to DOF i, Richardson-extrapolated from steps h and
/// h/2 (as test_surface_friction.cpp: the share's window polynomial).
template <class F>
auto richardson(const Pair& base, int i, double h, F&& f) {
  auto central = [&](double step) {
    Pair plus = base;
    Pair minus = base;
    dof(plus, i) += step;
    dof(minus, i) -= step;
    return decltype(f(base))((f(plus) - f(minus)) / (2.0 * step));
  };
  return decltype(f(base))((4.0 * central(0.5 * h) - central(h)) / 3.0);
}

/// Max-norm relative error of `analytic` against `fd` after scaling column j by dof_scale(j)
/// (and row i by dof_scale(i) if `rows_are_dofs`).
template <class M>
double scaled_error(const M& fd, const M& analytic, bool rows_are_dofs) {
  double err = 0.0;
  double ref = 0.0;
  for (int i = 0; i < fd.rows(); ++i) {
    for (int j = 0; j < fd.cols(); ++j) {
      const double s = dof_scale(j) * (rows_are_dofs ? dof_scale(i) : 1.0);
      err = std::max(err, s * std::abs(fd(i, j) - analytic(i, j)));
      ref = std::max(ref, s * std::abs(analytic(i, j)));
    }
  }
  return err / ref;
}

const double kRho = footprint_radius(2.0 * kA, 2.0 * kA); // the default rho, m

/// Normal contact (with its sensitivity) and torsional friction of one evaluation.
struct Evaluation {
  SurfaceContactResult contact;
  SurfaceContactSensitivity sensitivity;
  SurfaceTorsionalFrictionResult twist;
};

Evaluation evaluate(const Pair& p, const InterfaceLaw& law, const TorsionalFriction& friction,
                    const SurfaceFrictionHistory& history, const SurfaceProjectionStart& start = {},
                    bool tangent = true) {
  Evaluation e;
  const SuperEllipticalCylinder A = p.A();
  const SuperEllipticalCylinder B = p.B();
  SurfaceContactOptions options;
  options.compute_tangent = tangent;
  surface_contact(A, B, start, law, e.contact, options, nullptr, &e.sensitivity);
  FrictionOptions friction_options;
  friction_options.compute_tangent = tangent;
  surface_torsional_friction(A, B, e.contact, &e.sensitivity, history, friction, e.twist,
                             friction_options);
  return e;
}

/// A history whose anchor angle puts the trial torque at `ratio` times the cone's radius
/// mu f_n rho (penalty k_r w), twisted by `sign`.
SurfaceFrictionHistory twisted(const Pair& p, const SurfaceContactResult& c, double k_r, double mu,
                               double ratio, double sign, bool stuck) {
  SurfaceFrictionHistory h = first_touch(c);
  h.twist = surface_crossing_angle(p.A(), p.B(), c) -
            sign * ratio * mu * c.force * kRho / (c.share * k_r);
  h.twist_stuck = stuck;
  return h;
}

TEST(SurfaceTorsionalFriction, SectionThirdDerivativeMatchesCentralDifferences) {
  double worst = 0.0;
  for (const double m : {2.0, 2.5, 3.0, 4.0, 8.0}) {
    const SuperEllipse s(kA, kB, m);
    for (int k = 0; k < 24; ++k) {
      const double theta = -kPi + (k + 0.37) * 2.0 * kPi / 24.0; // away from the vertices
      const double h = 1e-5;
      const Eigen::Vector2d fd = (s.point(theta + h).second - s.point(theta - h).second) / (2 * h);
      const Eigen::Vector2d third = s.third_derivative(theta);
      const double error = (fd - third).norm() / std::max(third.norm(), kA);
      EXPECT_LT(error, 1e-6) << "m " << m << " theta " << theta;
      worst = std::max(worst, error);
    }
  }
  std::printf("super-ellipse third derivative against central differences, worst %.2e\n", worst);
  RecordProperty("worst_error", scientific(worst));
}

/// The crossings of the tests: angle (degrees), section exponent, B's shift along A (elements;
/// 0.42 puts the contact near A's node B, inside its end window).
struct Case {
  double degrees;
  double m;
  double shift;
};
constexpr Case kCases[] = {{90.0, 2.0, 0.0},  {89.7, 2.0, 0.0},  {30.0, 2.0, 0.0},
                           {145.0, 2.0, 0.0}, {60.0, 4.0, 0.0},  {110.0, 2.5, 0.0},
                           {75.0, 2.0, 0.0},  {90.0, 2.0, 0.42}, {50.0, 2.0, 0.42}};

/// Builds case `c` at a random penetration; false if the draw leaves the regular path.
bool build(std::mt19937& rng, const Case& c, Pair& p) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  p = crossing(rng, c.degrees, c.m, c.shift);
  return place(p, -(2e-6 + 8e-6 * u(rng)));
}

TEST(SurfaceTorsionalFriction, StickResidualIsTheGradientOfTheStoredEnergy) {
  std::mt19937 rng(31);
  const LinearPenalty law(kEps);
  const double k_r = kEps * kRho * kRho;
  const double mu = 0.3;
  const TorsionalFriction friction(mu, mu, k_r, kRho);
  double worst = 0.0;
  int tested = 0;
  for (const Case& c : kCases) {
    if (c.shift != 0.0) {
      continue; // the energy's gradient is the residual at a fixed share only
    }
    Pair p;
    int attempts = 0;
    while (!(build(rng, c, p) && solve(p, law).share == 1.0) && ++attempts < 50) {
    }
    ASSERT_LT(attempts, 50);
    const SurfaceContactResult c0 = solve(p, law);
    const SurfaceFrictionHistory h = twisted(p, c0, k_r, mu, 0.5, tested % 2 ? 1.0 : -1.0, true);
    const Evaluation e = evaluate(p, law, friction, h);
    ASSERT_TRUE(e.twist.active);
    ASSERT_FALSE(e.twist.slipping);
    const SurfaceProjectionStart warm = warm_start(e.contact);
    Vec24 fd;
    for (int i = 0; i < 24; ++i) {
      fd(i) = richardson(p, i, 1e-6 * dof_scale(i), [&](const Pair& q) {
        const Evaluation eq = evaluate(q, law, friction, h, warm, false);
        EXPECT_FALSE(eq.twist.slipping);
        return eq.twist.energy;
      });
    }
    const double error =
        scaled_error(Eigen::Matrix<double, 1, 24>(fd.transpose()),
                     Eigen::Matrix<double, 1, 24>(e.twist.residual.transpose()), false);
    EXPECT_LT(error, 1e-6) << "case " << c.degrees << " deg, m " << c.m;
    worst = std::max(worst, error);
    ++tested;
  }
  EXPECT_EQ(tested, 7);
  std::printf("surface torsional friction: stick residual against the energy's gradient, worst "
              "%.2e\n",
              worst);
  RecordProperty("worst_error", scientific(worst));
}

TEST(SurfaceTorsionalFriction, TangentMatchesCentralDifferencesInStickAndSlip) {
  std::mt19937 rng(37);
  const LinearPenalty law(kEps);
  const double k_r = kEps * kRho * kRho;
  double worst[2] = {0.0, 0.0}; // stick, slip
  int windowed = 0;
  int tested = 0;
  // A constant penalty, then an elastic slip at the same trial ratio (the pair's stiffness
  // mu f_n rho^2 / gamma = w k_r: gamma = mu f_n rho^2 / (w k_r)).
  for (const bool elastic : {false, true})
    for (const Case& c : kCases) {
      for (const bool slip : {false, true}) {
        Pair p;
        int attempts = 0;
        while (!build(rng, c, p) && ++attempts < 50) {
        }
        ASSERT_LT(attempts, 50);
        const SurfaceContactResult c0 = solve(p, law);
        windowed += c0.share < 1.0 ? 1 : 0;
        const bool stuck = tested % 3 != 0;
        const double mu_s = 0.3;
        const double mu_k = tested % 2 == 0 ? 0.3 : 0.2;
        const double mu = stuck ? mu_s : mu_k;
        const double gamma = mu * c0.force * kRho * kRho / (c0.share * k_r);
        const TorsionalFriction friction = elastic ? TorsionalFriction(mu_s, mu_k, 0.0, kRho, gamma)
                                                   : TorsionalFriction(mu_s, mu_k, k_r, kRho);
        const SurfaceFrictionHistory h =
            twisted(p, c0, k_r, mu, slip ? 2.0 : 0.5, tested % 2 ? 1.0 : -1.0, stuck);
        const Evaluation e = evaluate(p, law, friction, h);
        ASSERT_TRUE(e.twist.active);
        EXPECT_EQ(e.twist.slipping, slip);
        EXPECT_EQ(e.twist.mu, mu);
        const SurfaceProjectionStart warm = warm_start(e.contact);
        Mat24 fd;
        for (int i = 0; i < 24; ++i) {
          fd.col(i) = richardson(p, i, 1e-6 * dof_scale(i), [&](const Pair& q) {
            const Evaluation eq = evaluate(q, law, friction, h, warm);
            EXPECT_EQ(eq.contact.status, ProjectionStatus::Converged);
            EXPECT_EQ(eq.twist.slipping, slip);
            return Vec24(eq.twist.residual);
          });
        }
        const double error = scaled_error(fd, e.twist.tangent, true);
        EXPECT_LT(error, 1e-6) << "case " << c.degrees << " deg, m " << c.m << ", shift " << c.shift
                               << ", slip " << slip << ", share " << c0.share
                               << (elastic ? ", elastic slip" : "");
        worst[slip ? 1 : 0] = std::max(worst[slip ? 1 : 0], error);
        ++tested;
      }
    }
  EXPECT_GE(windowed, 2);
  std::printf("surface torsional friction: tangent against central differences, worst %.2e in "
              "stick, %.2e in slip (%d of %d inside an end window)\n",
              worst[0], worst[1], windowed, tested);
  RecordProperty("worst_error_stick", scientific(worst[0]));
  RecordProperty("worst_error_slip", scientific(worst[1]));
}

TEST(SurfaceTorsionalFriction, SlipReturnsOntoTheConeAndTheResidualOnlyPathAgrees) {
  std::mt19937 rng(41);
  const LinearPenalty law(kEps);
  const double k_r = kEps * kRho * kRho;
  const TorsionalFriction friction(0.3, 0.2, k_r, kRho);
  for (const Case& c : kCases) {
    Pair p;
    int attempts = 0;
    while (!build(rng, c, p) && ++attempts < 50) {
    }
    ASSERT_LT(attempts, 50);
    const SurfaceContactResult c0 = solve(p, law);
    for (const double sign : {-1.0, 1.0}) {
      const SurfaceFrictionHistory h = twisted(p, c0, k_r, 0.3, 3.0, sign, true);
      const Evaluation e = evaluate(p, law, friction, h);
      ASSERT_TRUE(e.twist.slipping);
      const double bound = 0.3 * e.contact.force * kRho; // f_n = w f
      EXPECT_NEAR(e.twist.torque, sign * bound, 1e-14 * bound);
      EXPECT_NEAR(e.twist.elastic_twist, sign * 3.0 * bound / (c0.share * k_r), 1e-9);
      // The returned anchor leaves exactly the cone's twist; stuck = false.
      SurfaceFrictionHistory returned = h;
      returned.twist = e.twist.anchor;
      returned.twist_stuck = e.twist.stuck;
      EXPECT_FALSE(e.twist.stuck);
      const Evaluation again = evaluate(p, law, TorsionalFriction(0.3, 0.3, k_r, kRho), returned);
      EXPECT_NEAR(again.twist.torque, e.twist.torque, 1e-9 * bound);
      EXPECT_NEAR(e.twist.slip_increment, 2.0 * bound / (c0.share * k_r), 1e-9);
      EXPECT_NEAR(e.twist.dissipation, bound * e.twist.slip_increment, 1e-12 * bound);
      // Residual only: the same gradient (the jets' first-order arithmetic does not depend on
      // whether they carry a Hessian).
      const Evaluation r = evaluate(p, law, friction, h, {}, false);
      EXPECT_EQ(r.twist.residual, e.twist.residual);
      EXPECT_EQ(r.twist.torque, e.twist.torque);
      EXPECT_EQ(r.twist.angle, e.twist.angle);
    }
    // The angle the jets carry is the crossing angle of the converged contact.
    EXPECT_NEAR(std::remainder(evaluate(p, law, friction, first_touch(c0)).twist.angle -
                                   surface_crossing_angle(p.A(), p.B(), c0),
                               2.0 * kPi),
                0.0, 1e-12);
  }
}

/// The pair moved by the rigid motion x -> R x + t (the nodes' current rotations turned by R,
/// their Rodrigues increments kept).
Pair moved(const Pair& p, const Matrix3d& r, const Vector3d& t, bool only_b = false,
           const Vector3d& about = Vector3d::Zero()) {
  Pair out = p;
  const SuperEllipticalCylinder A = p.A();
  const SuperEllipticalCylinder B = p.B();
  for (int k = 0; k < 2; ++k) {
    if (!only_b) {
      out.a[k] = node(r * p.a[k].position + t, r * A.rotation(k), p.a[k].rotation_increment);
    }
    out.b[k] = node(about + r * (p.b[k].position - about) + t, r * B.rotation(k),
                    p.b[k].rotation_increment);
  }
  return out;
}

TEST(SurfaceTorsionalFriction, CrossingAngleIsObjectiveAndFollowsARotationAboutTheNormal) {
  std::mt19937 rng(43);
  const LinearPenalty law(kEps);
  double worst_rigid = 0.0, worst_turn = 0.0;
  for (const Case& c : kCases) {
    Pair p;
    int attempts = 0;
    while (!build(rng, c, p) && ++attempts < 50) {
    }
    ASSERT_LT(attempts, 50);
    const SurfaceContactResult c0 = solve(p, law);
    const double theta = surface_crossing_angle(p.A(), p.B(), c0);
    // Rigid motion of the whole pair.
    const Matrix3d r = random_rotation(rng).toRotationMatrix();
    const Pair q = moved(p, r, Vector3d(1e-3, -2e-3, 5e-4));
    const SurfaceContactResult c1 = solve(q, law, warm_start(c0));
    ASSERT_EQ(c1.status, ProjectionStatus::Converged);
    const double rigid =
        std::abs(std::remainder(surface_crossing_angle(q.A(), q.B(), c1) - theta, 2.0 * kPi));
    EXPECT_LT(rigid, 1e-10);
    worst_rigid = std::max(worst_rigid, rigid);
    // B turned by phi about the normal through its contact point: theta + phi.
    for (const double phi : {0.02, -0.3}) {
      const Matrix3d turn = Eigen::AngleAxisd(phi, c0.normal).toRotationMatrix();
      const Pair t = moved(p, turn, Vector3d::Zero(), true, c0.point_B);
      const SurfaceContactResult c2 = solve(t, law, warm_start(c0));
      ASSERT_EQ(c2.status, ProjectionStatus::Converged);
      const double error = std::abs(
          std::remainder(surface_crossing_angle(t.A(), t.B(), c2) - theta - phi, 2.0 * kPi));
      EXPECT_LT(error, 1e-9) << "case " << c.degrees << " deg, phi " << phi;
      worst_turn = std::max(worst_turn, error);
    }
  }
  std::printf("surface crossing angle: rigid motion changes it by %.2e rad at most, a turn about "
              "the normal differs from the turn by %.2e rad at most\n",
              worst_rigid, worst_turn);
  RecordProperty("worst_rigid", scientific(worst_rigid));
  RecordProperty("worst_turn", scientific(worst_turn));
}

TEST(SurfaceTorsionalFriction,
     NoTorqueWithoutARegularActiveContactAndTheTangentNeedsTheSensitivity) {
  std::mt19937 rng(47);
  const LinearPenalty law(kEps);
  const double k_r = kEps * kRho * kRho;
  const TorsionalFriction friction(0.3, 0.3, k_r, kRho);
  Pair p;
  int attempts = 0;
  while (!build(rng, kCases[0], p) && ++attempts < 50) {
  }
  ASSERT_LT(attempts, 50);
  SurfaceContactResult c = solve(p, law);
  SurfaceFrictionHistory h = first_touch(c);
  h.twist = 0.7;
  h.twist_stuck = false;
  SurfaceTorsionalFrictionResult out;
  EXPECT_THROW(surface_torsional_friction(p.A(), p.B(), c, nullptr, h, friction, out),
               std::invalid_argument);
  surface_torsional_friction(p.A(), p.B(), c, nullptr, h, friction, out, {false});
  EXPECT_TRUE(out.active);
  c.active = false;
  surface_torsional_friction(p.A(), p.B(), c, nullptr, h, friction, out);
  EXPECT_FALSE(out.active);
  EXPECT_EQ(out.anchor, 0.7);
  EXPECT_FALSE(out.stuck);
  EXPECT_EQ(out.residual, Vec24::Zero());
  EXPECT_THROW(surface_crossing_angle(p.A(), p.B(), c), std::invalid_argument);
  c.active = true;
  c.degeneration = SurfaceDegeneration::Parallel;
  surface_torsional_friction(p.A(), p.B(), c, nullptr, h, friction, out);
  EXPECT_FALSE(out.active);
}

} // namespace
} // namespace yarnsim::contact
