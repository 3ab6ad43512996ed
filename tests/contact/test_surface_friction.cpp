#include "contact/surface_friction.hpp"

#include "surface_pairs.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <memory>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>

namespace yarnsim::contact {
namespace {

using namespace surface_test;

using Eigen::Matrix3d;
using Eigen::Vector3d;
using Vec4 = Eigen::Vector4d;
using Vec12 = Eigen::Matrix<double, 12, 1>;
using Vec24 = Eigen::Matrix<double, 24, 1>;
using Mat24 = Eigen::Matrix<double, 24, 24>;
using Mat4x24 = Eigen::Matrix<double, 4, 24>;

std::string scientific(double v) {
  std::ostringstream s;
  s << std::scientific << std::setprecision(2) << v;
  return s.str();
}

/// theta difference in (-pi, pi].
double angle_difference(double a, double b) {
  return std::remainder(a - b, 2.0 * kPi);
}

// ---- Configurations (as in test_surface_contact.cpp) -------------------------------------------

/// Two element surfaces.
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

void translate_b(Pair& p, const Vector3d& t) {
  p.b[0].position += t;
  p.b[1].position += t;
}

SurfaceContactResult solve(const Pair& p, const InterfaceLaw& law,
                           const SurfaceProjectionStart& start = {},
                           const SurfacePairRates* rates = nullptr,
                           SurfaceContactSensitivity* sensitivity = nullptr) {
  return surface_contact(p.A(), p.B(), start, law, {}, rates, sensitivity);
}

SurfaceProjectionStart warm_start(const SurfaceContactResult& r) {
  return {r.zeta_A, r.theta_A, r.zeta_B, r.theta_B, true};
}

/// Moves B along the contact normal so that the signed gap becomes `gap`; false if the
/// projection fails or leaves the regular path.
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
    translate_b(p, (r.gap - gap) * r.normal);
  }
  const SurfaceContactResult r = solve(p, law);
  return r.status == ProjectionStatus::Converged && r.active &&
         r.degeneration == SurfaceDegeneration::None;
}

/// A random bent and twisted element (see test_surface_contact.cpp).
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

/// A random crossing at an angle in [20, 160] degrees, turned by a random rotation, with random
/// Rodrigues increments at all four nodes; gap not yet set (see place). `m`: both sections'
/// exponent.
Pair random_crossing(std::mt19937& rng, double m = 2.0) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double length = 1e-3;
  const Eigen::Quaterniond q = random_rotation(rng);
  const double angle = (20.0 + 140.0 * (0.5 + 0.5 * u(rng))) * kPi / 180.0;
  Pair p;
  p.sa = SuperEllipse(kA, kB, m);
  p.sb = SuperEllipse(kA, kB, m);
  const Vector3d da = q * Vector3d::UnitX();
  const Vector3d db = q * Vector3d(std::cos(angle), std::sin(angle), 0.0);
  const Vector3d up = q * Vector3d::UnitZ();
  const Vector3d ca = 0.2 * length * (q * Vector3d(u(rng), u(rng), 0.0));
  const Vector3d cb = 0.2 * length * (q * Vector3d(u(rng), u(rng), 0.0)) + 2.0 * kB * up;
  random_element(rng, p.a, ca, da, da.cross(up), 0.4 * u(rng), length, 0.05);
  random_element(rng, p.b, cb, db, db.cross(up), 0.4 * u(rng), length, 0.05);
  return p;
}

/// Slides B so that the contact sits at zeta_A ~ `target_a` (inside A's window at node B for
/// 1 - h < target_a < 1, h = SurfaceContactOptions::end_window), then places it at `gap`.
bool place_near_end(Pair& p, double target_a, double gap) {
  const LinearPenalty law(kEps);
  const SurfaceContactResult r0 = solve(p, law);
  if (r0.status != ProjectionStatus::Converged) {
    return false;
  }
  translate_b(p, (target_a - r0.zeta_A) * 0.5 * (p.a[1].position - p.a[0].position));
  return place(p, gap);
}

/// Central difference of `f` (any Eigen vector of the configuration) with respect to DOF i,
/// Richardson-extrapolated from steps h and h/2 (the share's window polynomial leaves a plain
/// central difference an O(h^2 / t^2) error near the window's edge).
template <class F>
auto richardson(const Pair& base, int i, double h, F&& f) {
  auto central = [&](double step) {
    Pair plus = base;
    Pair minus = base;
    dof(plus, i) += step;
    dof(minus, i) -= step;
    return decltype(f(base, 0.0))((f(plus, step) - f(minus, -step)) / (2.0 * step));
  };
  return decltype(f(base, 0.0))((4.0 * central(0.5 * h) - central(h)) / 3.0);
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

// ---- Derivatives of the cylinder ---------------------------------------------------------------

double& element_dof(SurfaceNode (&n)[2], int j) {
  return j < 6 ? n[j / 3].position(j % 3) : n[(j - 6) / 3].rotation_increment(j % 3);
}

TEST(SuperEllipticalCylinder, DofDerivativesMatchCentralDifferences) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double worst = 0.0;
  for (const double m : {2.0, 2.5, 4.0}) {
    for (int trial = 0; trial < 4; ++trial) {
      SurfaceNode n[2];
      random_element(rng, n, Vector3d::Zero(), Vector3d(u(rng), u(rng), u(rng)),
                     Vector3d(u(rng), u(rng), u(rng)), u(rng), 1e-3, 0.1);
      const SuperEllipse section(kA, kB, m);
      const double zeta = 1.5 * u(rng);
      const double theta = kPi * u(rng);
      const Vector3d y(u(rng), u(rng), u(rng));
      const SuperEllipticalCylinder c(n[0], n[1], section);
      const SuperEllipticalCylinder::Point p = c.evaluate(zeta, theta);
      Eigen::Matrix<double, 3, 12> fd_j, fd_z, fd_t;
      Eigen::Matrix<double, 12, 12> fd_h;
      for (int j = 0; j < 12; ++j) {
        const double h = 1e-6 * dof_scale(j);
        SurfaceNode plus[2] = {n[0], n[1]};
        SurfaceNode minus[2] = {n[0], n[1]};
        element_dof(plus, j) += h;
        element_dof(minus, j) -= h;
        const SuperEllipticalCylinder cp(plus[0], plus[1], section);
        const SuperEllipticalCylinder cm(minus[0], minus[1], section);
        const SuperEllipticalCylinder::Point pp = cp.evaluate(zeta, theta);
        const SuperEllipticalCylinder::Point pm = cm.evaluate(zeta, theta);
        fd_j.col(j) = (pp.x - pm.x) / (2 * h);
        fd_z.col(j) = (pp.d_zeta - pm.d_zeta) / (2 * h);
        fd_t.col(j) = (pp.d_theta - pm.d_theta) / (2 * h);
        fd_h.col(j) = (cp.jacobian(pp).transpose() * y - cm.jacobian(pm).transpose() * y) / (2 * h);
      }
      const double errors[4] = {scaled_error(fd_j, c.jacobian(p), false),
                                scaled_error(fd_z, c.d_zeta_jacobian(p), false),
                                scaled_error(fd_t, c.d_theta_jacobian(p), false),
                                scaled_error(fd_h, c.weighted_hessian(p, y), true)};
      for (const double e : errors) {
        EXPECT_LT(e, 1e-6) << "m " << m << ", trial " << trial;
        worst = std::max(worst, e);
      }
    }
  }
  RecordProperty("worst_error", scientific(worst));
}

// ---- Sensitivity of the normal contact ---------------------------------------------------------

TEST(SurfaceFriction, SensitivityMatchesCentralDifferencesAndLeavesTheContactAlone) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const DampedLaw damped(std::make_shared<LinearPenalty>(kEps), 20.0);
  const PowerLaw power(3e7, 1.5);
  double worst = 0.0;
  int tested = 0;
  int windowed = 0;
  int attempts = 0;
  while (tested < 16 && ++attempts < 400) {
    const double m = tested % 4 < 2 ? 2.0 : (tested % 4 == 2 ? 2.5 : 4.0);
    Pair p = random_crossing(rng, m);
    const double gap = -(1e-6 + 1e-5 * (0.5 + 0.5 * u(rng)));
    const bool near_end = tested % 3 == 2;
    if (!(near_end ? place_near_end(p, 0.9, gap) : place(p, gap))) {
      continue;
    }
    const bool with_rates = tested % 2 == 1;
    const InterfaceLaw& law = with_rates ? static_cast<const InterfaceLaw&>(damped) : power;
    SurfacePairRates rates;
    for (int i = 0; i < 24; ++i) {
      rates.rate(i) = (i % 12 < 6 ? 0.01 : 10.0) * u(rng);
    }
    rates.velocity_per_displacement = 0.5 / (0.3 * 1e-4);
    const SurfacePairRates* rp = with_rates ? &rates : nullptr;
    const SurfaceContactResult plain = solve(p, law, {}, rp);
    SurfaceContactSensitivity s;
    const SurfaceContactResult r = solve(p, law, {}, rp, &s);
    if (!r.active || r.degeneration != SurfaceDegeneration::None || !(r.force > 0.0)) {
      continue;
    }
    ++tested;
    ASSERT_TRUE(s.valid);
    EXPECT_EQ(r.zeta_A, plain.zeta_A);
    EXPECT_EQ(r.theta_B, plain.theta_B);
    EXPECT_EQ(r.force, plain.force);
    EXPECT_EQ(r.residual, plain.residual);
    EXPECT_EQ(r.tangent, plain.tangent);
    {
      // The same sensitivity without the tangent.
      SurfaceContactOptions residual_only;
      residual_only.compute_tangent = false;
      SurfaceContactSensitivity s2;
      const SurfaceContactResult r2 =
          surface_contact(p.A(), p.B(), {}, law, residual_only, rp, &s2);
      EXPECT_TRUE(s2.valid);
      EXPECT_EQ(r2.residual, plain.residual);
      EXPECT_EQ(s2.coordinates, s.coordinates);
      EXPECT_EQ(s2.force, s.force);
    }
    if (r.share < 1.0) {
      ++windowed;
      EXPECT_NE(s.share.cwiseAbs().maxCoeff(), 0.0);
    }
    const SurfaceProjectionStart warm = warm_start(r);
    Mat4x24 fd_c;
    Vec24 fd_f;
    Vec24 fd_w;
    for (int i = 0; i < 24; ++i) {
      // (c - c0, f_n, w) of a perturbed configuration, theta differences wrapped.
      const auto state = [&](const Pair& q, double step) {
        SurfacePairRates moved = rates;
        moved.rate(i) += rates.velocity_per_displacement * step;
        const SurfaceContactResult e = solve(q, law, warm, with_rates ? &moved : nullptr);
        EXPECT_EQ(e.status, ProjectionStatus::Converged);
        Eigen::Matrix<double, 6, 1> v;
        v << e.zeta_A - r.zeta_A, angle_difference(e.theta_A, r.theta_A), e.zeta_B - r.zeta_B,
            angle_difference(e.theta_B, r.theta_B), e.force, e.share;
        return v;
      };
      const Eigen::Matrix<double, 6, 1> d = richardson(p, i, 1e-6 * dof_scale(i), state);
      fd_c.col(i) = d.head<4>();
      fd_f(i) = d(4);
      fd_w(i) = d(5);
    }
    const double c_error = scaled_error(fd_c, s.coordinates, false);
    const double f_error = scaled_error(fd_f.transpose(), s.force.transpose(), false);
    EXPECT_LT(c_error, 1e-6) << "configuration " << tested;
    EXPECT_LT(f_error, 1e-6) << "configuration " << tested;
    if (r.share < 1.0) {
      const double w_error = scaled_error(fd_w.transpose(), s.share.transpose(), false);
      EXPECT_LT(w_error, 1e-6) << "configuration " << tested;
      worst = std::max(worst, w_error);
    }
    worst = std::max({worst, c_error, f_error});
  }
  EXPECT_EQ(tested, 16);
  EXPECT_GE(windowed, 2);
  RecordProperty("worst_error", scientific(worst));
}

// ---- Friction tangent --------------------------------------------------------------------------

/// Normal contact (with its sensitivity) and friction of one evaluation.
struct Evaluation {
  SurfaceContactResult contact;
  SurfaceContactSensitivity sensitivity;
  SurfaceFrictionResult friction;
};

Evaluation evaluate(const Pair& p, const InterfaceLaw& law, const CoulombFriction& friction,
                    const SurfaceFrictionHistory& history, const SurfaceProjectionStart& start = {},
                    const FrictionOptions& options = {}) {
  Evaluation e;
  const SuperEllipticalCylinder A = p.A();
  const SuperEllipticalCylinder B = p.B();
  surface_contact(A, B, start, law, e.contact, {}, nullptr, &e.sensitivity);
  surface_friction(A, B, e.contact, &e.sensitivity, history, friction, e.friction, options);
  return e;
}

/// Max-norm relative error (scaled DOFs) of the friction tangent against central differences of
/// the friction residual at fixed history; the perturbed projections are warm-started from the
/// base one. Also checks that the state (stick or slip) does not switch.
double friction_tangent_error(const Pair& base, const InterfaceLaw& law,
                              const CoulombFriction& friction,
                              const SurfaceFrictionHistory& history, double relative_step = 1e-6) {
  const Evaluation e0 = evaluate(base, law, friction, history);
  EXPECT_TRUE(e0.friction.active);
  const SurfaceProjectionStart warm = warm_start(e0.contact);
  Mat24 fd;
  for (int i = 0; i < 24; ++i) {
    fd.col(i) = richardson(base, i, relative_step * dof_scale(i), [&](const Pair& q, double) {
      const Evaluation e = evaluate(q, law, friction, history, warm);
      EXPECT_EQ(e.contact.status, ProjectionStatus::Converged);
      EXPECT_EQ(e.friction.slipping, e0.friction.slipping);
      return Vec24(e.friction.residual);
    });
  }
  return scaled_error(fd, e0.friction.tangent, true);
}

/// A random anchor at coordinate offsets from the contact point (zeta_A^s beyond A's range in
/// the neighbouring element if `neighbour`), and the tangential penalty that puts the trial
/// force at `ratio` times the cone's radius.
struct Anchored {
  SurfaceFrictionHistory history;
  double eps_t = 0.0;
};

Anchored anchored(std::mt19937& rng, const Pair& p, const InterfaceLaw& law, bool neighbour,
                  bool stuck, double mu, double ratio) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const SurfaceContactResult c = solve(p, law);
  Anchored a;
  a.history = first_touch(c);
  a.history.stuck = stuck;
  a.history.zeta_A =
      neighbour ? std::copysign(1.05 + 0.2 * std::abs(u(rng)), c.zeta_A) : c.zeta_A + 0.3 * u(rng);
  a.history.theta_A = c.theta_A + 0.2 * u(rng);
  a.history.zeta_B = c.zeta_B + 0.3 * u(rng);
  a.history.theta_B = c.theta_B + 0.2 * u(rng);
  // The elastic gap does not depend on eps_t: evaluate once with any law.
  SurfaceFrictionResult f;
  surface_friction(p.A(), p.B(), c, nullptr, a.history, CoulombFriction(mu, mu, 1.0), f, {false});
  a.eps_t = ratio * mu * c.force / (c.share * f.elastic_gap.norm());
  return a;
}

/// The friction tangent in stick and slip, mu_s = mu_k and mu_s > mu_k, stuck and slipping
/// histories, anchors in the contact's element and in the neighbouring one, elliptical and
/// super-elliptical sections, and contacts inside the end window at A's node B (share < 1);
/// with `elastic`, the stick stiffness set by an elastic slip (mu f_n / gamma) instead of a
/// constant penalty, at the same trial ratio.
void check_tangent(const char* name, std::mt19937& rng, bool near_end, bool elastic = false) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const LinearPenalty law(kEps);
  double worst[2] = {0.0, 0.0}; // stick, slip
  int tested = 0;
  int windowed = 0;
  int attempts = 0;
  while (tested < 16 && ++attempts < 400) {
    const double m = tested % 4 == 3 ? 4.0 : (tested % 4 == 2 ? 2.5 : 2.0);
    Pair p = random_crossing(rng, m);
    const double gap = -(2e-6 + 8e-6 * (0.5 + 0.5 * u(rng)));
    if (!(near_end ? place_near_end(p, 0.88 + 0.08 * u(rng), gap) : place(p, gap))) {
      continue;
    }
    const SurfaceContactResult c = solve(p, law);
    if (!(c.share > 0.0)) {
      continue;
    }
    ++tested;
    windowed += c.share < 1.0 ? 1 : 0;
    const bool slip = tested % 2 == 0;
    const bool stuck = tested % 4 < 2;
    const double mu_s = 0.3;
    const double mu_k = tested % 3 == 0 ? 0.3 : 0.2;
    const double mu = stuck ? mu_s : mu_k;
    const bool neighbour = tested % 3 == 1;
    const Anchored a = anchored(rng, p, law, neighbour, stuck, mu, slip ? 2.0 : 0.5);
    // The same trial ratio by an elastic slip: w eps_t = mu f_n / gamma.
    const double gamma = elastic ? mu * c.force / (c.share * a.eps_t) : 0.0;
    const CoulombFriction friction(mu_s, mu_k, elastic ? 0.0 : a.eps_t, 0.0, gamma);
    const Evaluation e = evaluate(p, law, friction, a.history);
    ASSERT_TRUE(e.friction.active);
    EXPECT_EQ(e.friction.slipping, slip);
    EXPECT_EQ(e.friction.mu, mu);
    EXPECT_NEAR(e.friction.stiffness, c.share * a.eps_t, 1e-12 * c.share * a.eps_t);
    const double error = friction_tangent_error(p, law, friction, a.history);
    EXPECT_LT(error, 1e-6) << name << " configuration " << tested << " slip " << slip << " share "
                           << c.share;
    worst[slip ? 1 : 0] = std::max(worst[slip ? 1 : 0], error);
  }
  EXPECT_EQ(tested, 16);
  if (near_end) {
    EXPECT_GE(windowed, 8);
  }
  ::testing::Test::RecordProperty("worst_error_stick", scientific(worst[0]));
  ::testing::Test::RecordProperty("worst_error_slip", scientific(worst[1]));
}

TEST(SurfaceFriction, TangentMatchesCentralDifferencesInStickAndSlip) {
  std::mt19937 rng(11);
  check_tangent("crossing", rng, false);
}

TEST(SurfaceFriction, TangentMatchesCentralDifferencesInsideTheEndWindow) {
  std::mt19937 rng(12);
  check_tangent("end window", rng, true);
}

TEST(SurfaceFriction, TangentWithAnElasticSlipMatchesCentralDifferences) {
  std::mt19937 rng(13);
  check_tangent("crossing, elastic slip", rng, false, true);
  check_tangent("end window, elastic slip", rng, true, true);
}

/// The tangent at penetrations from 1e-10 m to 0.2 mm. The friction force depends on the contact
/// coordinates at first order, so the central differences see the projection's accuracy directly:
/// at 1e-8 m the default step tolerance (1e-12) leaves 4e-7 (2e-9 at 1e-14); at 1e-10 m the steps
/// must stay below the depth (a tenth of it here), and the error measured grows as 1 / step there
/// (rounding in the re-solved projections, 5e-6 at depth / 300), not from the tangent.
/// Tangential damping (CoulombFriction::c_t with SurfacePairRates): the tangent against central
/// differences of the residual, the rates moved with the DOFs (dv/dd = velocity_per_displacement),
/// in stick and slip, with and without a damped normal law, in and out of the end window; and
/// the undamped results bitwise unchanged by rates with c_t = 0 or by c_t without rates.
TEST(SurfaceFriction, DampedTangentMatchesCentralDifferencesInStickAndSlip) {
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const LinearPenalty linear(kEps);
  const DampedLaw damped(std::make_shared<LinearPenalty>(kEps), 20.0);
  double worst[2] = {0.0, 0.0};
  int tested = 0;
  int windowed = 0;
  int attempts = 0;
  while (tested < 12 && ++attempts < 400) {
    const double m = tested % 4 == 3 ? 4.0 : 2.0;
    Pair p = random_crossing(rng, m);
    const double gap = -(2e-6 + 8e-6 * (0.5 + 0.5 * u(rng)));
    const bool near_end = tested % 3 == 2;
    if (!(near_end ? place_near_end(p, 0.88 + 0.08 * u(rng), gap) : place(p, gap))) {
      continue;
    }
    const InterfaceLaw& law = tested % 2 == 1 ? static_cast<const InterfaceLaw&>(damped) : linear;
    SurfacePairRates rates;
    for (int i = 0; i < 24; ++i) {
      rates.rate(i) = (i % 12 < 6 ? 0.01 : 10.0) * u(rng);
    }
    rates.velocity_per_displacement = 0.5 / (0.3 * 1e-4);
    const SurfaceContactResult c = solve(p, law, {}, &rates);
    if (!(c.share > 0.0) || !c.active || c.degeneration != SurfaceDegeneration::None) {
      continue;
    }
    ++tested;
    windowed += c.share < 1.0 ? 1 : 0;
    const bool slip = tested % 2 == 0;
    const double mu = 0.3;
    const Anchored a = anchored(rng, p, linear, false, true, mu, slip ? 2.0 : 0.5);
    const double c_t = 30.0; // N s/m: c_t |v_t| comparable to mu f_n
    const CoulombFriction friction(mu, mu, a.eps_t, c_t);
    auto run = [&](const Pair& q, const SurfacePairRates* r, const CoulombFriction& law_t,
                   const SurfaceProjectionStart& start) {
      Evaluation e;
      const SuperEllipticalCylinder A = q.A();
      const SuperEllipticalCylinder B = q.B();
      surface_contact(A, B, start, law, e.contact, {}, r, &e.sensitivity);
      surface_friction(A, B, e.contact, &e.sensitivity, a.history, law_t, e.friction, {}, r);
      return e;
    };
    const Evaluation e0 = run(p, &rates, friction, {});
    ASSERT_TRUE(e0.friction.active);
    EXPECT_GT(e0.friction.sliding_velocity.norm(), 0.0);
    EXPECT_LT(std::abs(e0.friction.sliding_velocity.dot(e0.contact.normal)),
              1e-12 * e0.friction.sliding_velocity.norm());
    {
      // Undamped: rates with c_t = 0, or c_t without rates, leave the results bitwise alone.
      const CoulombFriction undamped(mu, mu, a.eps_t);
      const Evaluation plain = run(p, &rates, undamped, {});
      const Evaluation norates = run(p, nullptr, friction, {});
      const Evaluation reference = run(p, nullptr, undamped, {});
      EXPECT_EQ(plain.friction.sliding_velocity, Vector3d::Zero());
      EXPECT_EQ(norates.friction.residual, reference.friction.residual);
      EXPECT_EQ(norates.friction.tangent, reference.friction.tangent);
      EXPECT_EQ(plain.friction.history.zeta_A, e0.friction.history.zeta_A);
    }
    const SurfaceProjectionStart warm = warm_start(e0.contact);
    Mat24 fd;
    for (int i = 0; i < 24; ++i) {
      fd.col(i) = richardson(p, i, 1e-6 * dof_scale(i), [&](const Pair& q, double step) {
        SurfacePairRates moved = rates;
        moved.rate(i) += rates.velocity_per_displacement * step;
        const Evaluation e = run(q, &moved, friction, warm);
        EXPECT_EQ(e.contact.status, ProjectionStatus::Converged);
        EXPECT_EQ(e.friction.slipping, e0.friction.slipping);
        return Vec24(e.friction.residual);
      });
    }
    EXPECT_EQ(e0.friction.slipping, slip);
    const double error = scaled_error(fd, e0.friction.tangent, true);
    EXPECT_LT(error, 1e-6) << "configuration " << tested << " slip " << slip << " share "
                           << c.share;
    worst[slip ? 1 : 0] = std::max(worst[slip ? 1 : 0], error);
  }
  EXPECT_EQ(tested, 12);
  EXPECT_GE(windowed, 2);
  std::printf("surface friction with tangential damping: tangent against central differences, "
              "worst %.2e in stick, %.2e in slip (%d of %d in an end window)\n",
              worst[0], worst[1], windowed, tested);
  RecordProperty("worst_error_stick", scientific(worst[0]));
  RecordProperty("worst_error_slip", scientific(worst[1]));
}

TEST(SurfaceFriction, TangentMatchesCentralDifferencesAtTinyAndDeepPenetrations) {
  std::mt19937 rng(17);
  const LinearPenalty law(kEps);
  for (const double depth : {1e-10, 1e-8, 1e-7, 5e-5, 2e-4}) {
    // Steps well below the depth, so that no perturbation opens the gap.
    const double step = std::min(1e-6, 0.1 * depth / 1e-3);
    double worst = 0.0;
    int tested = 0;
    while (tested < 4) {
      Pair p = random_crossing(rng);
      if (!place(p, -depth)) {
        continue;
      }
      ++tested;
      const bool slip = tested % 2 == 0;
      const Anchored a = anchored(rng, p, law, false, true, 0.3, slip ? 2.0 : 0.5);
      const CoulombFriction friction(0.3, 0.2, a.eps_t);
      const double error = friction_tangent_error(p, law, friction, a.history, step);
      EXPECT_LT(error, 1e-6) << "depth " << depth << ", slip " << slip;
      worst = std::max(worst, error);
    }
    RecordProperty("worst_error_depth_" + scientific(depth), scientific(worst));
  }
}

// ---- Straight crossing cylinders ---------------------------------------------------------------

/// A along x and B along y, straight and untwisted, section axis 2 (semi-axis b) vertical, B on
/// top of A overlapping by `depth`; elements 1 mm long, the contact at both midpoints.
Pair straight_crossing(double depth) {
  Pair p;
  const double length = 1e-3;
  const Matrix3d qa = frame(Vector3d::UnitY(), Vector3d::UnitX());
  const Matrix3d qb = frame(-Vector3d::UnitX(), Vector3d::UnitY());
  p.a[0] = node(Vector3d(-0.5 * length, 0, 0), qa);
  p.a[1] = node(Vector3d(0.5 * length, 0, 0), qa);
  p.b[0] = node(Vector3d(0, -0.5 * length, 2 * kB - depth), qb);
  p.b[1] = node(Vector3d(0, 0.5 * length, 2 * kB - depth), qb);
  return p;
}

TEST(SurfaceFriction, DraggedCylinderSticksThenSlipsAtMuTimesTheNormalForce) {
  const LinearPenalty law(kEps);
  const double depth = 5e-6;
  const double mu_s = 0.3;
  const double mu_k = 0.2;
  const double eps_t = 1e5;
  const CoulombFriction friction(mu_s, mu_k, eps_t);
  Pair p = straight_crossing(depth);
  const SurfaceContactResult touch = solve(p, law);
  ASSERT_TRUE(touch.active);
  ASSERT_EQ(touch.degeneration, SurfaceDegeneration::None);
  const double f_n = touch.force;
  EXPECT_NEAR(f_n, kEps * depth, 1e-9 * kEps * depth);
  SurfaceFrictionHistory history = first_touch(touch);
  const double limit = mu_s * f_n / eps_t; // the stick range, metres
  for (const double fraction : {0.1, 0.5, 0.99, 1.5, 3.0}) {
    const double u = fraction * limit;
    Pair q = p;
    translate_b(q, Vector3d(u, 0, 0)); // B dragged along A's axis
    const Evaluation e = evaluate(q, law, friction, history, warm_start(touch));
    ASSERT_TRUE(e.friction.active);
    EXPECT_NEAR(e.contact.force, f_n, 1e-9 * f_n);
    // The contact moves along A by u; B's contact point stays: g_t = u e_x, the force on A
    // drags it along with B, the force on B (-f) opposes its motion.
    EXPECT_LT((e.friction.elastic_gap - Vector3d(u, 0, 0)).norm(), 1e-8 * u);
    const double expected = fraction < 1.0 ? eps_t * u : mu_s * f_n;
    EXPECT_EQ(e.friction.slipping, fraction > 1.0);
    EXPECT_LT((e.friction.force - Vector3d(expected, 0, 0)).norm(), 1e-8 * expected)
        << "fraction " << fraction;
    // Generalised forces: the residual on B's translations is +f split over its nodes.
    EXPECT_NEAR(e.friction.residual(12) + e.friction.residual(15), expected, 1e-8 * expected);
    if (fraction > 1.0) {
      EXPECT_NEAR(e.friction.slip_increment, u - limit, 1e-8 * u);
      EXPECT_NEAR(e.friction.dissipation, mu_s * f_n * (u - limit), 1e-8 * mu_s * f_n * u);
      // The returned anchor is on the cone: re-evaluated with the same coefficient, phi = 0,
      // and then the slipping history carries mu_k.
      SurfaceFrictionHistory returned = e.friction.history;
      EXPECT_FALSE(returned.stuck);
      returned.stuck = true;
      const Evaluation again = evaluate(q, law, friction, returned, warm_start(touch));
      EXPECT_NEAR(again.friction.slip_function, 0.0, 1e-10 * mu_s * f_n);
      EXPECT_NEAR(again.friction.force.norm(), mu_s * f_n, 1e-8 * mu_s * f_n);
      const Evaluation kinetic = evaluate(q, law, friction, e.friction.history, warm_start(touch));
      EXPECT_TRUE(kinetic.friction.slipping);
      EXPECT_NEAR(kinetic.friction.force.norm(), mu_k * f_n, 1e-8 * mu_k * f_n);
    } else {
      EXPECT_TRUE(e.friction.history.stuck);
      EXPECT_EQ(e.friction.history.zeta_A, history.zeta_A);
      EXPECT_EQ(e.friction.slip_increment, 0.0);
      EXPECT_EQ(e.friction.dissipation, 0.0);
    }
  }
}

TEST(SurfaceFriction, ReturnMappingPutsTheAnchorOnTheConeAtRandomCrossings) {
  std::mt19937 rng(21);
  const LinearPenalty law(kEps);
  int tested = 0;
  while (tested < 8) {
    Pair p = random_crossing(rng, tested % 2 == 0 ? 2.0 : 4.0);
    if (!place(p, -5e-6)) {
      continue;
    }
    ++tested;
    const Anchored a = anchored(rng, p, law, tested % 2 == 0, true, 0.25, 3.0);
    const CoulombFriction friction(0.25, 0.25, a.eps_t);
    const Evaluation e = evaluate(p, law, friction, a.history);
    ASSERT_TRUE(e.friction.slipping);
    const Evaluation again = evaluate(p, law, friction, e.friction.history, warm_start(e.contact));
    const double cone = 0.25 * e.contact.force;
    EXPECT_NEAR(again.friction.slip_function, 0.0, 1e-10 * cone);
    EXPECT_LT((again.friction.force - e.friction.force).norm(), 1e-9 * cone);
    EXPECT_NEAR(e.friction.slip_increment,
                e.friction.elastic_gap.norm() - again.friction.elastic_gap.norm(),
                1e-9 * e.friction.elastic_gap.norm());
    EXPECT_NEAR(std::abs(e.friction.elastic_gap.dot(e.contact.normal)), 0.0,
                1e-9 * e.friction.elastic_gap.norm()); // g_t is tangential
  }
}

/// Turns every node of `p` by `r` about the origin: positions, and the nodal triads consistently
/// (Q = Q(alpha) Q_n -> R Q = Q(R alpha) R Q_n).
Pair rotated(const Pair& p, const Matrix3d& r) {
  Pair q = p;
  for (SurfaceNode* n : {&q.a[0], &q.a[1], &q.b[0], &q.b[1]}) {
    n->position = r * n->position;
    n->rotation_increment = r * n->rotation_increment;
    n->converged_rotation = r * n->converged_rotation;
  }
  return q;
}

TEST(SurfaceFriction, RigidRotationOfAStuckPairRotatesTheForce) {
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const LinearPenalty law(kEps);
  int tested = 0;
  while (tested < 6) {
    Pair p = random_crossing(rng, tested % 2 == 0 ? 2.0 : 2.5);
    if (!place(p, -4e-6)) {
      continue;
    }
    ++tested;
    const Anchored a = anchored(rng, p, law, false, true, 0.3, 0.6);
    const CoulombFriction friction(0.3, 0.2, a.eps_t);
    const Evaluation e0 = evaluate(p, law, friction, a.history);
    ASSERT_FALSE(e0.friction.slipping);
    for (const double degrees : {10.0, 45.0, 90.0}) {
      const Vector3d axis = Vector3d(u(rng), u(rng), u(rng)).normalized();
      const Matrix3d r = Eigen::AngleAxisd(degrees * kPi / 180.0, axis).toRotationMatrix();
      const Evaluation e =
          evaluate(rotated(p, r), law, friction, a.history, warm_start(e0.contact));
      ASSERT_TRUE(e.friction.active);
      EXPECT_FALSE(e.friction.slipping);
      const double f = e0.friction.force.norm();
      EXPECT_NEAR(e.friction.force.norm(), f, 1e-8 * f) << degrees << " degrees";
      EXPECT_LT((e.friction.force - r * e0.friction.force).norm(), 1e-8 * f);
      EXPECT_NEAR(e.contact.zeta_A, e0.contact.zeta_A, 1e-10);
      EXPECT_NEAR(angle_difference(e.contact.theta_B, e0.contact.theta_B), 0.0, 1e-10);
    }
  }
}

TEST(SurfaceFriction, NoFrictionWithoutAnActiveRegularContact) {
  const LinearPenalty law(kEps);
  const CoulombFriction friction(0.3, 0.2, 1e5);
  SurfaceFrictionHistory history{0.1, 4.0, -0.1, 1.0, true};
  // Separated.
  {
    const Pair p = straight_crossing(-1e-6);
    const Evaluation e = evaluate(p, law, friction, history);
    EXPECT_FALSE(e.contact.active);
    EXPECT_FALSE(e.sensitivity.valid);
    EXPECT_FALSE(e.friction.active);
    EXPECT_EQ(e.friction.residual, Vec24::Zero());
    EXPECT_EQ(e.friction.tangent, Mat24::Zero());
    EXPECT_EQ(e.friction.history.zeta_A, history.zeta_A);
  }
  // Parallel elements: a degenerate path, active but no sensitivity and no friction.
  {
    Pair p;
    const Matrix3d q = frame(Vector3d::UnitY(), Vector3d::UnitX());
    p.a[0] = node(Vector3d(-1e-3, 0, 0), q);
    p.a[1] = node(Vector3d(1e-3, 0, 0), q);
    p.b[0] = node(Vector3d(0, 0, 2 * kB - 2e-6), q);
    p.b[1] = node(Vector3d(2e-3, 0, 2 * kB - 2e-6), q);
    SurfaceContactSensitivity s;
    s.valid = true;
    const SurfaceContactResult c = solve(p, law, {}, nullptr, &s);
    ASSERT_TRUE(c.active);
    ASSERT_EQ(c.degeneration, SurfaceDegeneration::Parallel);
    EXPECT_FALSE(s.valid);
    SurfaceFrictionResult f;
    f.active = true;
    surface_friction(p.A(), p.B(), c, &s, history, friction, f);
    EXPECT_FALSE(f.active);
    EXPECT_EQ(f.force, Vector3d::Zero());
    EXPECT_EQ(f.residual, Vec24::Zero());
  }
}

TEST(SurfaceFriction, TangentNeedsTheNormalContactSensitivity) {
  const LinearPenalty law(kEps);
  const CoulombFriction friction(0.3, 0.2, 1e5);
  const Pair p = straight_crossing(5e-6);
  const SurfaceContactResult c = solve(p, law);
  ASSERT_TRUE(c.active);
  SurfaceFrictionHistory history = first_touch(c);
  history.zeta_A -= 0.01;
  SurfaceFrictionResult f;
  EXPECT_THROW(surface_friction(p.A(), p.B(), c, nullptr, history, friction, f),
               std::invalid_argument);
  SurfaceContactSensitivity stale;
  EXPECT_THROW(surface_friction(p.A(), p.B(), c, &stale, history, friction, f),
               std::invalid_argument);
  // Residual only: no sensitivity needed, and the residual is the same as with the tangent.
  EXPECT_NO_THROW(surface_friction(p.A(), p.B(), c, nullptr, history, friction, f, {false}));
  EXPECT_TRUE(f.active);
  EXPECT_EQ(f.tangent, Mat24::Zero());
  const Evaluation e = evaluate(p, law, friction, history);
  EXPECT_EQ(f.residual, e.friction.residual);
  EXPECT_EQ(f.force, e.friction.force);
}

} // namespace
} // namespace yarnsim::contact
