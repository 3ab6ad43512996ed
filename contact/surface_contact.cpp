#include "contact/surface_contact.hpp"

#include "engine/math/rotation.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <type_traits>

// Notation (formulation.md §6). Surfaces X = A (0) and B (1), each with end nodes k = 0 (zeta =
// -1) and 1, N_k(zeta) the linear shape functions, v_k = Q_k s(theta) the rotated section point,
// w_k = Q_n,k s(theta) the same before the step's rotation increment (v_k = Q(alpha_k) w_k).
// c = (zeta_A, theta_A, zeta_B, theta_B); sigma_A = +1, sigma_B = -1, so that
//   g = Gamma_A - Gamma_B,  g_i = dg/dc_i = sigma_X t_i  (t_i = Gamma_X,zeta or Gamma_X,theta),
//   Phi = |g|^2 / 2,  r = dPhi/dc (eq. 5),  H = dr/dc,  D = dr/dd (4 x 24),  G = dg/dd (3 x 24).
// The distance as a function of the DOFs alone, psi(d) = |g(c(d), d)|, has the gradient and
// Hessian that give the residual and tangent: with c(d) a critical point of Phi,
// grad Phi* = G^T g and hess Phi* = d2Phi/dd2 - D^T H^-1 D (dc/dd = -H^-1 D); psi = sqrt(2 Phi*).
// The DOF derivatives of a rotated vector use d(Q(alpha) w)/dalpha = -skew(Q w) Xi(alpha) and the
// closed-form Hessian of y . Q(alpha) w (rotation_hessian below).

namespace yarnsim::contact {

namespace {

using Eigen::Matrix3d;
using Eigen::Vector2d;
using Eigen::Vector3d;
using Vec4 = Eigen::Vector4d;
using Mat4 = Eigen::Matrix4d;
using Vec12 = Eigen::Matrix<double, 12, 1>;
using Vec24 = Eigen::Matrix<double, 24, 1>;
using Mat24 = Eigen::Matrix<double, 24, 24>;
using Mat3x24 = Eigen::Matrix<double, 3, 24>;
using Mat4x24 = Eigen::Matrix<double, 4, 24>;
using Cylinder = SuperEllipticalCylinder;

constexpr double kTwoPi = 6.283185307179586476925;
/// Largest Newton step per iteration in zeta (half an element) and in theta (radians).
constexpr double kMaxZetaStep = 1.0;
constexpr double kMaxThetaStep = 0.5;
/// Uncapped Newton steps shorter than this skip the line search: the linear model is then
/// accurate, and near the solution rounding in the merit would make the test fail spuriously.
constexpr double kTrustedStep = 1e-3;

/// theta in [-pi, pi] (cheaper than std::remainder when it is there already).
double wrap(double theta) {
  constexpr double kPi = 0.5 * kTwoPi;
  if (theta >= -kPi && theta <= kPi) {
    return theta;
  }
  return theta - kTwoPi * std::floor((theta + kPi) / kTwoPi);
}

/// theta in [0, 2 pi), the paper's range.
double wrap_positive(double theta) {
  double t = std::fmod(theta, kTwoPi);
  if (t < 0.0) {
    t += kTwoPi;
  }
  return t >= kTwoPi ? 0.0 : t;
}

double sigma(int surface) {
  return surface == 0 ? 1.0 : -1.0;
}

/// Both surfaces evaluated at c, and the gap vector.
struct PairPoint {
  Cylinder::Point p[2];
  Vector3d g;
};

/// g = Gamma_A - Gamma_B - offset: a non-zero offset moves B by it (the shifted problem of the
/// cold start, see minimise).
PairPoint evaluate(const Cylinder& A, const Cylinder& B, const Vec4& c,
                   const Vector3d& offset = Vector3d::Zero()) {
  PairPoint e;
  e.p[0] = A.evaluate(c(0), c(1));
  e.p[1] = B.evaluate(c(2), c(3));
  e.g = e.p[0].x - e.p[1].x - offset;
  return e;
}

/// t_i: dGamma_X/dc_i of the surface X = i / 2 the coordinate belongs to.
const Vector3d& tangent(const PairPoint& e, int i) {
  const Cylinder::Point& p = e.p[i / 2];
  return i % 2 == 0 ? p.d_zeta : p.d_theta;
}

/// d2Gamma_X/dc_i dc_k for two coordinates of the same surface.
Vector3d second(const PairPoint& e, int i, int k) {
  const Cylinder::Point& p = e.p[i / 2];
  const int n = i % 2 + k % 2;
  if (n == 0) {
    return Vector3d::Zero();
  }
  return n == 1 ? p.d_zeta_theta : p.d_theta_theta;
}

Vec4 phi_gradient(const PairPoint& e) {
  Vec4 r;
  for (int i = 0; i < 4; ++i) {
    r(i) = sigma(i / 2) * tangent(e, i).dot(e.g);
  }
  return r;
}

Mat4 phi_hessian(const PairPoint& e) {
  Mat4 h;
  for (int i = 0; i < 4; ++i) {
    for (int k = i; k < 4; ++k) {
      double v = sigma(i / 2) * sigma(k / 2) * tangent(e, i).dot(tangent(e, k));
      if (i / 2 == k / 2) {
        v += sigma(i / 2) * second(e, i, k).dot(e.g);
      }
      h(i, k) = v;
      h(k, i) = v;
    }
  }
  return h;
}

/// The coordinates a solve fixes and the equations it uses.
struct Mode {
  SurfaceDegeneration degeneration = SurfaceDegeneration::None;
  bool fixed[4] = {false, false, false, false};
  /// A surface whose two coordinates are both free: the other surface's equations use its
  /// normal instead of g (see surface_projection). -1: none, all equations are r = 0.
  int reference = 1;
};

Mode make_mode(SurfaceDegeneration degeneration) {
  Mode m;
  m.degeneration = degeneration;
  switch (degeneration) {
  case SurfaceDegeneration::None:
    break;
  case SurfaceDegeneration::Parallel:
  case SurfaceDegeneration::FlatOnB:
  case SurfaceDegeneration::RidgeOnA:
    m.fixed[0] = true;
    break;
  case SurfaceDegeneration::FlatOnA:
  case SurfaceDegeneration::RidgeOnB:
    m.fixed[2] = true;
    m.reference = 0;
    break;
  case SurfaceDegeneration::FlatOnBoth:
  case SurfaceDegeneration::RidgeOnBoth:
    m.fixed[0] = true;
    m.fixed[2] = true;
    m.reference = -1;
    break;
  }
  return m;
}

bool is_ridge(SurfaceDegeneration degeneration) {
  return degeneration == SurfaceDegeneration::RidgeOnA ||
         degeneration == SurfaceDegeneration::RidgeOnB ||
         degeneration == SurfaceDegeneration::RidgeOnBoth;
}

/// The equations F(c) = 0 solved in `mode`, row scales making them dimensionless for the merit
/// function, and (if `jac`) their Jacobian. A fixed coordinate gets the row F = 0, dF = e_i, so
/// that Newton leaves it alone.
void equations(const PairPoint& e, const Mode& mode, double length, Vec4& f, Vec4& scale,
               Mat4* jac) {
  const int ref = mode.reference;
  Vector3d nu = Vector3d::Zero();
  Vector3d dnu[2] = {Vector3d::Zero(), Vector3d::Zero()};
  double nu_norm = 1.0;
  if (ref >= 0) {
    const Cylinder::Point& p = e.p[ref];
    nu = p.d_theta.cross(p.d_zeta);
    nu_norm = std::max(nu.norm(), 1e-300);
    if (jac != nullptr) {
      dnu[0] = p.d_zeta_theta.cross(p.d_zeta);
      dnu[1] = p.d_theta_theta.cross(p.d_zeta) + p.d_theta.cross(p.d_zeta_theta);
    }
  }
  Mat4 h;
  if (jac != nullptr) {
    h = phi_hessian(e);
    jac->setZero();
  }
  for (int i = 0; i < 4; ++i) {
    if (mode.fixed[i]) {
      f(i) = 0.0;
      scale(i) = 1.0;
      if (jac != nullptr) {
        (*jac)(i, i) = 1.0;
      }
      continue;
    }
    const int x = i / 2;
    const Vector3d& t = tangent(e, i);
    const double t_norm = std::max(t.norm(), 1e-300);
    if (ref >= 0 && ref != x) {
      f(i) = t.dot(nu);
      scale(i) = 1.0 / (t_norm * nu_norm);
      if (jac != nullptr) {
        for (int k = 0; k < 4; ++k) {
          (*jac)(i, k) = k / 2 == x ? second(e, i, k).dot(nu) : t.dot(dnu[k % 2]);
        }
      }
    } else {
      f(i) = sigma(x) * t.dot(e.g);
      scale(i) = 1.0 / (t_norm * length);
      if (jac != nullptr) {
        jac->row(i) = h.row(i);
      }
    }
  }
}

struct Solve {
  bool converged = false;
  bool left = false; // an iterate went beyond the elements' extension
  int iterations = 0;
  Vec4 c = Vec4::Zero();
};

/// Newton's method on the equations of `mode` from c, with capped steps and a backtracking
/// line search on the scaled residual norm (the Newton direction is a descent direction of it).
Solve newton(const Cylinder& A, const Cylinder& B, Vec4 c, const Mode& mode,
             const SurfaceContactOptions& opt, double length) {
  Solve s;
  const double limit = 1.0 + 2.0 * opt.max_extension;
  double previous = 0.0; // length of the previous step if it was a full Newton step
  for (int it = 0; it < opt.max_iterations; ++it) {
    s.iterations = it + 1;
    const PairPoint e = evaluate(A, B, c);
    Vec4 f;
    Vec4 scale;
    Mat4 jac;
    equations(e, mode, length, f, scale, &jac);
    // A 4 x 4 inverse by cofactors is four times faster than a pivoted LU here; a singular
    // Jacobian shows as a non-finite step.
    Vec4 step = -(jac.inverse() * f);
    if (!step.allFinite()) {
      break;
    }
    const double size = step.cwiseAbs().maxCoeff();
    if (newton_step_converges(size, previous, opt.step_tolerance)) {
      c += step;
      c(1) = wrap(c(1));
      c(3) = wrap(c(3));
      s.converged = true;
      s.c = c;
      return s;
    }
    double factor = 1.0;
    for (int i = 0; i < 4; ++i) {
      const double cap = i % 2 == 0 ? kMaxZetaStep : kMaxThetaStep;
      if (std::abs(step(i)) > cap) {
        factor = std::min(factor, cap / std::abs(step(i)));
      }
    }
    step *= factor;
    double t = 1.0;
    const double merit = scale.cwiseProduct(f).squaredNorm();
    if (!(factor == 1.0 && size < kTrustedStep) && merit > 0.0) {
      for (;;) {
        const PairPoint trial = evaluate(A, B, c + t * step);
        Vec4 ft;
        Vec4 unused;
        equations(trial, mode, length, ft, unused, nullptr);
        if (scale.cwiseProduct(ft).squaredNorm() <= (1.0 - 1e-4 * t) * merit) {
          break;
        }
        t *= 0.5;
        if (t < 1e-4) {
          s.c = c;
          return s;
        }
      }
    }
    previous = factor == 1.0 && t == 1.0 ? size : 0.0;
    c += t * step;
    c(1) = wrap(c(1));
    c(3) = wrap(c(3));
    if (std::abs(c(0)) > limit || std::abs(c(2)) > limit) {
      s.left = true;
      break;
    }
  }
  s.c = c;
  return s;
}

// ---- The degenerate paths' fixed coordinates -------------------------------------------------
// Explicit functions of the four end positions (x_A0, x_A1, x_B0, x_B1), written once for
// doubles and once for a second-order forward-mode number that carries the gradient and Hessian
// with respect to those 12 coordinates.

/// A value with its gradient and (if `Second`) its Hessian with respect to 12 variables.
template <bool Second>
struct Jet {
  static constexpr int kH = Second ? 12 : 0;
  double v = 0.0;
  Vec12 g = Vec12::Zero();
  Eigen::Matrix<double, kH, kH> h = Eigen::Matrix<double, kH, kH>::Zero();
  Jet() = default;
  Jet(double value) : v(value) {} // NOLINT: constants mix with jets in the templates
};

template <bool S>
Jet<S> operator+(const Jet<S>& a, const Jet<S>& b) {
  Jet<S> r;
  r.v = a.v + b.v;
  r.g = a.g + b.g;
  if constexpr (S) {
    r.h = a.h + b.h;
  }
  return r;
}

template <bool S>
Jet<S> operator-(const Jet<S>& a, const Jet<S>& b) {
  Jet<S> r;
  r.v = a.v - b.v;
  r.g = a.g - b.g;
  if constexpr (S) {
    r.h = a.h - b.h;
  }
  return r;
}

template <bool S>
Jet<S> operator*(const Jet<S>& a, const Jet<S>& b) {
  Jet<S> r;
  r.v = a.v * b.v;
  r.g = a.v * b.g + b.v * a.g;
  if constexpr (S) {
    r.h = a.v * b.h + b.v * a.h;
    r.h.noalias() += a.g * b.g.transpose();
    r.h.noalias() += b.g * a.g.transpose();
  }
  return r;
}

template <bool S>
Jet<S> operator/(const Jet<S>& a, const Jet<S>& b) {
  Jet<S> inv;
  const double i1 = 1.0 / b.v;
  inv.v = i1;
  inv.g = -i1 * i1 * b.g;
  if constexpr (S) {
    inv.h = -i1 * i1 * b.h;
    inv.h.noalias() += (2.0 * i1 * i1 * i1) * b.g * b.g.transpose();
  }
  return a * inv;
}

double value(double x) {
  return x;
}
template <bool S>
double value(const Jet<S>& x) {
  return x.v;
}

template <class T>
struct V3 {
  T x[3];
};

template <class T>
V3<T> sub(const V3<T>& a, const V3<T>& b) {
  return {{a.x[0] - b.x[0], a.x[1] - b.x[1], a.x[2] - b.x[2]}};
}

template <class T>
T dot(const V3<T>& a, const V3<T>& b) {
  return a.x[0] * b.x[0] + a.x[1] * b.x[1] + a.x[2] * b.x[2];
}

/// Parallel path: zeta_A at the midpoint of the overlap of the two elements along A's axis.
/// t_j = ((x_Bj - x_A0) . e) / (e . e), e = x_A1 - x_A0, is B's end j measured along A's axis
/// (0 and 1 at A's ends); the overlap is [max(0, min t), min(1, max t)], and zeta = 2 t - 1. An
/// empty overlap puts zeta outside [-1, 1].
template <class T>
T overlap_midpoint(const V3<T> (&p)[4]) {
  const V3<T> e = sub(p[1], p[0]);
  const T beta = dot(e, e);
  T t[2];
  for (int j = 0; j < 2; ++j) {
    t[j] = dot(sub(p[2 + j], p[0]), e) / beta;
  }
  const int lo = value(t[0]) <= value(t[1]) ? 0 : 1;
  const T lower = value(t[lo]) > 0.0 ? t[lo] : T(0.0);
  const T upper = value(t[1 - lo]) < 1.0 ? t[1 - lo] : T(1.0);
  return lower + upper - T(1.0);
}

/// Flat paths: zeta_A and zeta_B at the closest points of the two (non-parallel) axes.
template <class T>
void axes_closest(const V3<T> (&p)[4], T& zeta_a, T& zeta_b) {
  const V3<T> e = sub(p[1], p[0]);
  const V3<T> f = sub(p[3], p[2]);
  const V3<T> w = sub(p[0], p[2]);
  const T a = dot(e, e);
  const T b = dot(e, f);
  const T c = dot(f, f);
  const T d = dot(e, w);
  const T q = dot(f, w);
  const T det = a * c - b * b;
  const T s = (b * q - c * d) / det;
  const T t = (a * q - b * d) / det;
  zeta_a = T(2.0) * s - T(1.0);
  zeta_b = T(2.0) * t - T(1.0);
}

/// DOF index of variable j (0..11) of the four end positions.
int translation_dof(int j) {
  const int point = j / 3;
  return (point < 2 ? 3 * point : 12 + 3 * (point - 2)) + j % 3;
}

template <class T>
void end_positions(const Cylinder& A, const Cylinder& B, V3<T> (&p)[4]) {
  const Vector3d* x[4] = {&A.node(0).position, &A.node(1).position, &B.node(0).position,
                          &B.node(1).position};
  for (int q = 0; q < 4; ++q) {
    for (int i = 0; i < 3; ++i) {
      p[q].x[i] = T((*x[q])(i));
      if constexpr (!std::is_same_v<T, double>) {
        p[q].x[i].g(3 * q + i) = 1.0;
      }
    }
  }
}

/// Sets the fixed coordinates of `mode` in c (the others untouched).
void fixed_values(const Cylinder& A, const Cylinder& B, const Mode& mode, Vec4& c) {
  if (mode.degeneration == SurfaceDegeneration::None) {
    return;
  }
  if (is_ridge(mode.degeneration)) {
    for (int i = 0; i < 4; i += 2) {
      if (mode.fixed[i]) {
        c(i) = -1.0;
      }
    }
    return;
  }
  V3<double> p[4];
  end_positions(A, B, p);
  if (mode.degeneration == SurfaceDegeneration::Parallel) {
    c(0) = overlap_midpoint(p);
    return;
  }
  double z[2];
  axes_closest(p, z[0], z[1]);
  for (int n = 0; n < 2; ++n) {
    if (mode.fixed[2 * n]) {
      c(2 * n) = z[n];
    }
  }
}

/// Gradients and Hessians of the fixed coordinates with respect to the 24 DOFs.
struct FixedDerivatives {
  Vec24 grad[4];
  Mat24 hess[4];
};

template <bool Second>
void fixed_jets(const Cylinder& A, const Cylinder& B, const Mode& mode, FixedDerivatives& out) {
  V3<Jet<Second>> p[4];
  end_positions(A, B, p);
  Jet<Second> z[2];
  if (mode.degeneration == SurfaceDegeneration::Parallel) {
    z[0] = overlap_midpoint(p);
  } else {
    axes_closest(p, z[0], z[1]);
  }
  for (int n = 0; n < 2; ++n) {
    const int i = 2 * n;
    if (!mode.fixed[i]) {
      continue;
    }
    Vec24& grad = out.grad[i];
    grad.setZero();
    for (int j = 0; j < 12; ++j) {
      grad(translation_dof(j)) = z[n].g(j);
    }
    if constexpr (Second) {
      Mat24& hess = out.hess[i];
      hess.setZero();
      for (int j = 0; j < 12; ++j) {
        for (int k = 0; k < 12; ++k) {
          hess(translation_dof(j), translation_dof(k)) = z[n].h(j, k);
        }
      }
    }
  }
}

void fixed_derivatives(const Cylinder& A, const Cylinder& B, const Mode& mode,
                       FixedDerivatives& out, bool with_hessian) {
  if (is_ridge(mode.degeneration)) {
    for (int i = 0; i < 4; i += 2) {
      out.grad[i].setZero(); // a constant: zeta = -1
      if (with_hessian) {
        out.hess[i].setZero();
      }
    }
    return;
  }
  if (with_hessian) {
    fixed_jets<true>(A, B, mode, out);
  } else {
    fixed_jets<false>(A, B, mode, out);
  }
}

// ---- Starts and classification -------------------------------------------------------------

/// Closest points of the lines p + s e and q + t f; false when they are parallel.
bool line_closest(const Vector3d& p, const Vector3d& e, const Vector3d& q, const Vector3d& f,
                  double& s, double& t) {
  const Vector3d w = p - q;
  const double a = e.dot(e);
  const double b = e.dot(f);
  const double c = f.dot(f);
  const double d = e.dot(w);
  const double r = f.dot(w);
  const double det = a * c - b * b;
  if (!(det > 1e-14 * a * c)) {
    return false;
  }
  s = (b * r - c * d) / det;
  t = (a * r - b * d) / det;
  return std::isfinite(s) && std::isfinite(t);
}

/// theta of the section point of surface `s` at zeta whose outward normal points along
/// `direction` (the section frame interpolated between the nodes, zeta clamped to the element).
double facing_angle(const Cylinder& s, double zeta, const Vector3d& direction) {
  const double z = std::clamp(zeta, -1.0, 1.0);
  const Matrix3d frame = 0.5 * (1.0 - z) * s.rotation(0) + 0.5 * (1.0 + z) * s.rotation(1);
  Vector2d local(frame.col(0).dot(direction), frame.col(1).dot(direction));
  if (!(local.squaredNorm() > 0.0)) {
    local << 1.0, 0.0;
  }
  return s.section().normal_angle(local);
}

/// Section offset Gamma - axis point at (zeta clamped to the element, theta).
Vector3d section_offset(const Cylinder& s, double zeta, double theta) {
  const double z = std::clamp(zeta, -1.0, 1.0);
  return s.evaluate(z, theta).x - s.axis_point(z);
}

/// A start of the solve and the contact normal it expects (unit, from B towards A).
struct Start {
  Vec4 c = Vec4::Zero();
  Vector3d normal = Vector3d::UnitZ();
};

/// The geometric start. Crossing axes: n0 = e_A x e_B, turned to point from B's axis to A's;
/// the sections face each other (A's point with outward normal -n0, B's with n0); the zetas are
/// the closest points of the axes shifted by those section points, which is the exact solution
/// for straight untwisted cylinders. Two passes let the section frame follow the new zetas.
/// Parallel: zeta_B projects A's fixed point onto B's axis, n0 is the part of the axis points'
/// difference normal to the axes.
Start geometric_start(const Cylinder& A, const Cylinder& B, bool parallel, double zeta_a,
                      double limit) {
  const Vector3d& xa = A.node(0).position;
  const Vector3d& xb = B.node(0).position;
  const Vector3d ea = A.node(1).position - xa;
  const Vector3d eb = B.node(1).position - xb;
  Start st;
  Vec4& c = st.c;
  Vector3d& n0 = st.normal;
  if (parallel) {
    c(0) = zeta_a;
    const Vector3d ca = A.axis_point(c(0));
    const double t = (ca - xb).dot(eb) / eb.squaredNorm();
    c(2) = std::clamp(2.0 * t - 1.0, -limit, limit);
    n0 = ca - B.axis_point(c(2));
    n0 -= n0.dot(eb) / eb.squaredNorm() * eb;
    if (!(n0.norm() > 1e-12 * std::sqrt(eb.squaredNorm()))) {
      n0 = B.rotation(0).col(1); // coaxial: any direction across the axes
    }
    n0.normalize();
    c(1) = facing_angle(A, c(0), -n0);
    c(3) = facing_angle(B, c(2), n0);
    return st;
  }
  n0 = ea.cross(eb).normalized();
  double s = 0.0;
  double t = 0.0;
  if (line_closest(xa, ea, xb, eb, s, t)) {
    c(0) = std::clamp(2.0 * s - 1.0, -limit, limit);
    c(2) = std::clamp(2.0 * t - 1.0, -limit, limit);
  }
  if ((A.axis_point(c(0)) - B.axis_point(c(2))).dot(n0) < 0.0) {
    n0 = -n0;
  }
  for (int pass = 0; pass < 2; ++pass) {
    c(1) = facing_angle(A, c(0), -n0);
    c(3) = facing_angle(B, c(2), n0);
    const Vector3d ra = section_offset(A, c(0), c(1));
    const Vector3d rb = section_offset(B, c(2), c(3));
    if (line_closest(xa + ra, ea, xb + rb, eb, s, t)) {
      c(0) = std::clamp(2.0 * s - 1.0, -limit, limit);
      c(2) = std::clamp(2.0 * t - 1.0, -limit, limit);
    }
  }
  c(1) = facing_angle(A, c(0), -n0);
  c(3) = facing_angle(B, c(2), n0);
  return st;
}

/// Whether a critical point is the contact: the outward normals are opposite, and the pair's
/// normal (B's outward normal, minus A's) points from B's axis point to A's. The second test
/// rejects the far-side points of a section (n_A . n_B < 0 as well, but a "penetration" through
/// the whole section); it holds for every separated pair of convex sections.
bool acceptable(const Cylinder& A, const Cylinder& B, const Vec4& c) {
  const PairPoint e = evaluate(A, B, c);
  const Vector3d na = A.outward_normal(e.p[0]);
  const Vector3d nb = B.outward_normal(e.p[1]);
  if (!(na.dot(nb) < 0.0)) {
    return false;
  }
  return (A.axis_point(c(0)) - B.axis_point(c(2))).dot(nb - na) > 0.0;
}

/// Minimises |g|^2 / 2 with g = Gamma_A - Gamma_B - offset over the free coordinates of `mode`:
/// Newton's method in coordinates scaled by the tangents' lengths, the Hessian shifted to be
/// positive definite where it is not, steps capped and backtracked (Armijo). Moving B by an
/// offset along the contact normal does not move the critical point of a straight cylinder pair
/// (g stays along the normals), so the cold start minimises the separated problem, B moved away
/// by `offset`: a strict minimum that descent finds reliably, where the overlapping problem is a
/// saddle point and, near touching, ill-conditioned.
Solve minimise(const Cylinder& A, const Cylinder& B, Vec4 c, const Mode& mode,
               const SurfaceContactOptions& opt, const Vector3d& offset, double tolerance) {
  Solve s;
  const double limit = 1.0 + 2.0 * opt.max_extension;
  for (int it = 0; it < opt.max_iterations; ++it) {
    s.iterations = it + 1;
    const PairPoint e = evaluate(A, B, c, offset);
    Vec4 r = phi_gradient(e);
    Mat4 h = phi_hessian(e);
    Vec4 scale;
    for (int i = 0; i < 4; ++i) {
      scale(i) = 1.0 / std::max(tangent(e, i).norm(), 1e-300);
    }
    for (int i = 0; i < 4; ++i) {
      if (mode.fixed[i]) {
        h.row(i).setZero();
        h.col(i).setZero();
        h(i, i) = 1.0 / (scale(i) * scale(i));
        r(i) = 0.0;
      }
    }
    // Scaled Hessian, shifted by mu I until its Cholesky factorisation succeeds with a
    // well-conditioned factor (mu = 0 when it is positive definite already).
    const Mat4 hs = scale.asDiagonal() * h * scale.asDiagonal();
    const double norm = hs.cwiseAbs().rowwise().sum().maxCoeff();
    if (!(norm > 0.0) || !std::isfinite(norm)) {
      break;
    }
    double mu = 0.0;
    Eigen::LLT<Mat4> llt;
    for (int k = 0; k < 60; ++k) {
      llt.compute(hs + mu * Mat4::Identity());
      if (llt.info() == Eigen::Success &&
          llt.matrixLLT().diagonal().minCoeff() > 1e-5 * std::sqrt(norm)) {
        break;
      }
      mu = mu == 0.0 ? 1e-3 * norm : 4.0 * mu;
    }
    const bool definite = mu == 0.0;
    Vec4 step = -(scale.asDiagonal() * llt.solve(scale.cwiseProduct(r)));
    if (!step.allFinite()) {
      break;
    }
    const double size = step.cwiseAbs().maxCoeff();
    if (definite && size <= tolerance) {
      c += step;
      s.converged = true;
      break;
    }
    double factor = 1.0;
    for (int i = 0; i < 4; ++i) {
      const double cap = i % 2 == 0 ? kMaxZetaStep : kMaxThetaStep;
      if (std::abs(step(i)) > cap) {
        factor = std::min(factor, cap / std::abs(step(i)));
      }
    }
    step *= factor;
    const double phi = 0.5 * e.g.squaredNorm();
    const double slope = r.dot(step);
    double t = 1.0;
    for (;;) {
      const Vector3d g = A.point(c(0) + t * step(0), c(1) + t * step(1)) -
                         B.point(c(2) + t * step(2), c(3) + t * step(3)) - offset;
      if (0.5 * g.squaredNorm() <= phi + 1e-4 * t * slope) {
        break;
      }
      t *= 0.5;
      if (t < 1e-10) {
        s.c = c;
        return s; // no descent: rounding level
      }
    }
    c += t * step;
    c(1) = wrap(c(1));
    c(3) = wrap(c(3));
    if (std::abs(c(0)) > limit || std::abs(c(2)) > limit) {
      s.left = true;
      break;
    }
  }
  c(1) = wrap(c(1));
  c(3) = wrap(c(3));
  s.c = c;
  return s;
}

/// Whether a section counts as flat at theta (see SurfaceContactOptions::flat_radius).
bool flat_at(const SuperEllipse& section, double theta, const SurfaceContactOptions& opt) {
  return opt.flat_path && !section.is_ellipse() &&
         section.radius_of_curvature(theta) > opt.flat_radius * std::max(section.a(), section.b());
}

/// The crossing path for contact points at (theta_A, theta_B): a flat section at its point
/// makes the other element's axial direction degenerate (both surfaces straight along it).
SurfaceDegeneration crossing_path(const Cylinder& A, const Cylinder& B, const Vec4& c,
                                  const SurfaceContactOptions& opt) {
  const bool flat_a = flat_at(A.section(), c(1), opt);
  const bool flat_b = flat_at(B.section(), c(3), opt);
  if (flat_a && flat_b) {
    return SurfaceDegeneration::FlatOnBoth;
  }
  if (flat_a) {
    return SurfaceDegeneration::FlatOnA;
  }
  return flat_b ? SurfaceDegeneration::FlatOnB : SurfaceDegeneration::None;
}

struct LocalProjection {
  SurfaceProjectionResult result;
  Vec4 c = Vec4::Zero(); // the solution, theta in [-pi, pi]
  Mode mode;
};

/// One attempt in a given mode from c: fixed coordinates set, Newton's method, classification.
struct Attempt {
  Solve solve;
  Mode mode;
  bool found = false;
};

Attempt attempt(const Cylinder& A, const Cylinder& B, Vec4 c, SurfaceDegeneration degeneration,
                const SurfaceContactOptions& opt, double length) {
  Attempt a;
  a.mode = make_mode(degeneration);
  fixed_values(A, B, a.mode, c);
  if (!c.allFinite()) {
    return a;
  }
  a.solve = newton(A, B, c, a.mode, opt, length);
  a.found = a.solve.converged && acceptable(A, B, a.solve.c);
  return a;
}

/// The ridge at a convex kink: when a surface's solution lies below its zeta = -1 and the
/// element before it is known, the contact may sit on the shared section, which neither element
/// reaches on its own. Solved with that zeta fixed at -1; owned here when, at the ridge point,
/// the signed gap grows into this element (s r_zeta > 0) and into the previous one
/// (s Gamma_P,zeta . g < 0 with the previous element's zeta running towards the node), that is
/// when both elements' own solutions lie on the other side of the node. Replaces `a` if so.
void ridge(const Cylinder& A, const Cylinder& B, const SurfaceContactOptions& opt, double length,
           Attempt& a, int& iterations) {
  const Cylinder* s[2] = {&A, &B};
  bool on[2] = {false, false};
  for (int x = 0; x < 2; ++x) {
    on[x] = s[x]->has_previous() && a.solve.c(2 * x) < -1.0 - Cylinder::kEndBand;
  }
  for (int pass = 0; pass < 2 && (on[0] || on[1]); ++pass) {
    const SurfaceDegeneration path = on[0] && on[1] ? SurfaceDegeneration::RidgeOnBoth
                                     : on[0]        ? SurfaceDegeneration::RidgeOnA
                                                    : SurfaceDegeneration::RidgeOnB;
    const double limit = 1.0 + 2.0 * opt.max_extension;
    Vec4 c0 = a.solve.c;
    c0(0) = std::clamp(c0(0), -limit, limit);
    c0(2) = std::clamp(c0(2), -limit, limit);
    const Attempt b = attempt(A, B, c0, path, opt, length);
    iterations += b.solve.iterations;
    if (!b.found) {
      return;
    }
    // A free surface that went below its range as well: a ridge there too, one more pass.
    bool more = false;
    for (int x = 0; x < 2; ++x) {
      if (!on[x] && s[x]->has_previous() && b.solve.c(2 * x) < -1.0 - Cylinder::kEndBand) {
        on[x] = true;
        more = true;
      }
    }
    if (more) {
      continue;
    }
    const PairPoint e = evaluate(A, B, b.solve.c);
    const double sg =
        e.g.dot(B.outward_normal(e.p[1]) - A.outward_normal(e.p[0])) >= 0.0 ? 1.0 : -1.0;
    for (int x = 0; x < 2; ++x) {
      if (!on[x]) {
        continue;
      }
      const double own = sigma(x) * e.p[x].d_zeta.dot(e.g);
      const double before = sigma(x) * s[x]->previous_d_zeta(b.solve.c(2 * x + 1)).dot(e.g);
      if (!(sg * own > 0.0 && sg * before < 0.0)) {
        return; // an element's own solution is on its side of the node: it owns the contact
      }
    }
    a = b;
    return;
  }
}

/// Share of coordinate i (0: zeta_A, 2: zeta_B) of a solution in `mode`, with its derivative
/// with respect to zeta: a ridge's fixed zeta = -1 holds the whole contact, see
/// SurfaceDegeneration::RidgeOnA.
double coordinate_share(const Cylinder& s, const Mode& mode, int i, double zeta,
                        const SurfaceContactOptions& opt, double* derivative = nullptr) {
  if (is_ridge(mode.degeneration) && mode.fixed[i]) {
    if (derivative != nullptr) {
      *derivative = 0.0;
    }
    return 1.0;
  }
  return s.share(zeta, opt.end_window, derivative);
}

LocalProjection project(const Cylinder& A, const Cylinder& B, const SurfaceProjectionStart& start,
                        const SurfaceContactOptions& opt) {
  LocalProjection out;
  SurfaceProjectionResult& res = out.result;
  const double limit = 1.0 + 2.0 * opt.max_extension;
  const SuperEllipse& sa = A.section();
  const SuperEllipse& sb = B.section();
  const double length = std::max({sa.a(), sa.b(), sb.a(), sb.b()});

  const Vector3d ea = A.node(1).position - A.node(0).position;
  const Vector3d eb = B.node(1).position - B.node(0).position;
  const double la = ea.squaredNorm();
  const double lb = eb.squaredNorm();
  Vec4 warm(start.zeta_A, wrap(start.theta_A), start.zeta_B, wrap(start.theta_B));
  if (!warm.allFinite()) {
    warm.setZero();
  }
  out.c = warm;
  if (!(la > 0.0 && lb > 0.0) || !std::isfinite(la) || !std::isfinite(lb)) {
    res.status = ProjectionStatus::NotConverged; // a collapsed element has no axis
    return out;
  }
  const bool parallel =
      ea.cross(eb).squaredNorm() < opt.parallel_sine * opt.parallel_sine * (la * lb);
  Vec4 fixed = Vec4::Zero();
  if (parallel) {
    fixed_values(A, B, make_mode(SurfaceDegeneration::Parallel), fixed);
  }
  // The path is a function of the configuration alone, the same for a warm and a cold start:
  // flatness is judged at the geometric start's points (exact for straight cylinders).
  const bool may_be_flat = !parallel && opt.flat_path && !(sa.is_ellipse() && sb.is_ellipse());
  Start st;
  bool have_start = false;
  SurfaceDegeneration path = parallel ? SurfaceDegeneration::Parallel : SurfaceDegeneration::None;
  if (may_be_flat) {
    st = geometric_start(A, B, parallel, fixed(0), limit);
    have_start = true;
    path = crossing_path(A, B, st.c, opt);
  }

  Attempt a;
  int iterations = 0;
  if (start.warm) {
    Vec4 c0 = warm;
    c0(0) = std::clamp(c0(0), -limit, limit);
    c0(2) = std::clamp(c0(2), -limit, limit);
    a = attempt(A, B, c0, path, opt, length);
    iterations = a.solve.iterations;
  }
  if (!a.found) {
    // Cold: the geometric start, then the minimum of the problem with B moved away along the
    // expected normal until the start's gap is `length`, then Newton on the real problem.
    if (!have_start) {
      st = geometric_start(A, B, parallel, fixed(0), limit);
    }
    const Mode mode = make_mode(path);
    Vec4 c0 = st.c;
    fixed_values(A, B, mode, c0);
    Solve m;
    if (c0.allFinite()) {
      const PairPoint e0 = evaluate(A, B, c0);
      const double shift = std::max(0.0, length - e0.g.dot(st.normal));
      m = minimise(A, B, c0, mode, opt, -shift * st.normal, 1e-2);
      iterations += m.iterations;
      c0 = m.c;
    }
    a = attempt(A, B, c0, path, opt, length);
    iterations += a.solve.iterations;
    if (m.left && !a.found) {
      a.solve.left = true; // the shifted problem's minimum lies beyond the range as well
    }
  }
  if (path == SurfaceDegeneration::None && (A.has_previous() || B.has_previous())) {
    ridge(A, B, opt, length, a, iterations);
  }
  const Solve& s = a.solve;
  out.mode = a.mode;
  out.c = s.c;
  res.degeneration = a.mode.degeneration;
  res.iterations = iterations;
  res.zeta_A = s.c(0);
  res.theta_A = wrap_positive(s.c(1));
  res.zeta_B = s.c(2);
  res.theta_B = wrap_positive(s.c(3));
  if (!s.converged) {
    res.status = s.left ? ProjectionStatus::OutOfRange : ProjectionStatus::NotConverged;
  } else if (!a.found) {
    res.status = ProjectionStatus::NotConverged; // only far-side critical points were found
  } else if (!(coordinate_share(A, a.mode, 0, s.c(0), opt) > 0.0 &&
               coordinate_share(B, a.mode, 2, s.c(2), opt) > 0.0)) {
    res.status = ProjectionStatus::OutOfRange;
  } else if (start.warm && (std::abs(s.c(0) - warm(0)) > 2.0 * opt.jump_fraction ||
                            std::abs(s.c(2) - warm(2)) > 2.0 * opt.jump_fraction ||
                            std::abs(wrap(s.c(1) - warm(1))) > opt.jump_angle ||
                            std::abs(wrap(s.c(3) - warm(3))) > opt.jump_angle)) {
    res.status = ProjectionStatus::Jumped;
  } else {
    res.status = ProjectionStatus::Converged;
  }
  return out;
}

// ---- Derivatives with respect to the DOFs ----------------------------------------------------

/// DOF index of node k's translation (rotation) on surface x.
int translation_index(int x, int k) {
  return 12 * x + 3 * k;
}
int rotation_index(int x, int k) {
  return 12 * x + 6 + 3 * k;
}

/// G = dg/dd at fixed c (3 x 24).
Mat3x24 gap_jacobian(const Cylinder* s[2], const PairPoint& e) {
  Mat3x24 gj = Mat3x24::Zero();
  for (int x = 0; x < 2; ++x) {
    const double sg = sigma(x);
    for (int k = 0; k < 2; ++k) {
      const double n = sg * e.p[x].shape[k];
      gj.block<3, 3>(0, translation_index(x, k)).diagonal().setConstant(n);
      gj.block<3, 3>(0, rotation_index(x, k)) = -n * skew<double>(e.p[x].v[k]) * s[x]->xi(k);
    }
  }
  return gj;
}

/// D = dr/dd (4 x 24): row i is g_i^T G + g^T dg_i/dd.
Mat4x24 mixed_derivative(const Cylinder* s[2], const PairPoint& e, const Mat3x24& gj) {
  Mat4x24 d;
  for (int i = 0; i < 4; ++i) {
    const int x = i / 2;
    const double sg = sigma(x);
    d.row(i).noalias() = (sg * tangent(e, i)).transpose() * gj;
    const Cylinder::Point& p = e.p[x];
    for (int k = 0; k < 2; ++k) {
      if (i % 2 == 0) {
        // Gamma_zeta = (x_1 + v_1 - x_0 - v_0) / 2
        const double sk = sg * (k == 0 ? -0.5 : 0.5);
        d.block<1, 3>(i, translation_index(x, k)) += sk * e.g.transpose();
        d.block<1, 3>(i, rotation_index(x, k)) +=
            sk * (s[x]->xi(k).transpose() * p.v[k].cross(e.g)).transpose();
      } else {
        // Gamma_theta = N_0 v'_0 + N_1 v'_1
        d.block<1, 3>(i, rotation_index(x, k)) +=
            (sg * p.shape[k]) * (s[x]->xi(k).transpose() * p.dv[k].cross(e.g)).transpose();
      }
    }
  }
  return d;
}

/// Hessian of y . Q(alpha) w with respect to alpha, y and w fixed. With A = skew(alpha),
/// gam = 4 / (4 + alpha . alpha): y . Q w = y . w + gam h, h = alpha . (w x y) + alpha^T M alpha /
/// 2, M = sym(y w^T) - (y . w) I; grad gam = -gam^2 alpha / 2.
Matrix3d rotation_hessian(const Vector3d& alpha, const Vector3d& w, const Vector3d& y) {
  const double gam = 4.0 / (4.0 + alpha.squaredNorm());
  Matrix3d m = 0.5 * (y * w.transpose() + w * y.transpose());
  m.diagonal().array() -= y.dot(w);
  const Vector3d b = w.cross(y);
  const Vector3d q = b + m * alpha;
  const double h = alpha.dot(b) + 0.5 * alpha.dot(m * alpha);
  Matrix3d out = gam * m;
  out.diagonal().array() -= 0.5 * gam * gam * h;
  out.noalias() += (0.5 * gam * gam * gam * h) * alpha * alpha.transpose();
  out.noalias() -= (0.5 * gam * gam) * (alpha * q.transpose() + q * alpha.transpose());
  return out;
}

/// The sensitivity of an active regular contact (SurfaceContactSensitivity), computed apart
/// from the tangent so that the contact's outputs do not depend on whether it is asked for.
/// dc/dd = -H^-1 D; with f_n = w f(p, pdot), p = -g_n:
///   df_n/dd = w (-f_p grad g_n + f_pdot grad pdot) + f grad w,
///   grad w = w_,zeta_A dzeta_A/dd + w_,zeta_B dzeta_B/dd,
///   grad pdot = -(hess g_n rate + vpd grad g_n) (as in the damped tangent),
///   hess g_n rate = (sg / |g|) (hess Phi* rate - grad g_n (grad g_n . rate)).
void write_sensitivity(const Cylinder* s[2], const PairPoint& e, const Mat3x24& gj,
                       const Vec24& grad, double sg, double dist, double w, const double (&dw)[2],
                       double f, double fp, double fv, const SurfacePairRates* rates,
                       SurfaceContactSensitivity& out) {
  const Mat4 h = phi_hessian(e);
  const Mat4x24 d = mixed_derivative(s, e, gj);
  const Mat4 h_inv = Eigen::PartialPivLU<Mat4>(h).inverse();
  const Mat4x24 y = h_inv.lazyProduct(d); // H^-1 D
  out.coordinates = -y;
  out.share = -(dw[0] * y.row(0) + dw[1] * y.row(2)).transpose();
  out.force = (-w * fp) * grad + f * out.share;
  if (rates != nullptr && fv != 0.0) {
    const Vec24& rate = rates->rate;
    Vec24 hess_rate = gj.transpose() * (gj * rate) - d.transpose() * (y * rate);
    for (int x = 0; x < 2; ++x) {
      const Cylinder::Point& pt = e.p[x];
      for (int k = 0; k < 2; ++k) {
        const Matrix3d& qn = s[x]->node(k).converged_rotation;
        const Vector3d wk = pt.section.x() * qn.col(0) + pt.section.y() * qn.col(1);
        const int j = rotation_index(x, k);
        hess_rate.segment<3>(j) +=
            rotation_hessian(s[x]->node(k).rotation_increment, wk, (sigma(x) * pt.shape[k]) * e.g) *
            rate.segment<3>(j);
      }
    }
    const Vec24 hess_gn_rate = (sg / dist) * (hess_rate - grad * grad.dot(rate));
    const Vec24 grad_pdot = -(hess_gn_rate + rates->velocity_per_displacement * grad);
    out.force += (w * fv) * grad_pdot;
  }
  out.valid = true;
}

/// The body of surface_contact; returns whether it wrote the tangent.
bool fill_contact(const Cylinder& A, const Cylinder& B, const SurfaceProjectionStart& start,
                  const InterfaceLaw& law, SurfaceContactResult& out,
                  const SurfaceContactOptions& options, const SurfacePairRates* rates,
                  SurfaceContactSensitivity* sensitivity) {
  if (sensitivity != nullptr) {
    sensitivity->valid = false;
  }
  const LocalProjection lp = project(A, B, start, options);
  out.status = lp.result.status;
  out.degeneration = lp.result.degeneration;
  out.iterations = lp.result.iterations;
  out.zeta_A = lp.result.zeta_A;
  out.theta_A = lp.result.theta_A;
  out.zeta_B = lp.result.zeta_B;
  out.theta_B = lp.result.theta_B;
  out.active = false;
  out.share = 0.0;
  out.share_A = 0.0;
  out.share_B = 0.0;
  out.penetration_rate = 0.0;
  out.force = 0.0;
  out.potential = 0.0;
  out.residual.setZero();

  const PairPoint e = evaluate(A, B, lp.c);
  out.point_A = e.p[0].x;
  out.point_B = e.p[1].x;
  const Vector3d na = A.outward_normal(e.p[0]);
  const Vector3d nb = B.outward_normal(e.p[1]);
  const Vector3d pair_normal = nb - na;
  const double dist = e.g.norm();
  const double sg = e.g.dot(pair_normal) >= 0.0 ? 1.0 : -1.0;
  out.gap = sg * dist;
  out.penetration = -out.gap;
  if (dist > 0.0) {
    out.normal = (sg / dist) * e.g;
  } else {
    const double n = pair_normal.norm();
    out.normal = n > 0.0 ? Vector3d(pair_normal / n) : Vector3d::Zero();
  }

  const bool owned =
      out.status == ProjectionStatus::Converged || out.status == ProjectionStatus::Jumped;
  const double p = out.penetration;
  if (!owned || !(p > -law.onset())) { // apart (the law acts from a gap of onset() on)
    return false;
  }

  const Cylinder* s[2] = {&A, &B};
  const Mode& mode = lp.mode;
  const bool degenerate = mode.degeneration != SurfaceDegeneration::None;
  const Mat3x24 gj = gap_jacobian(s, e);
  Vec24 grad_phi = gj.transpose() * e.g;
  const Vec4 r = phi_gradient(e);
  FixedDerivatives fd;
  if (degenerate) {
    fixed_derivatives(A, B, mode, fd, options.compute_tangent);
    for (int i = 0; i < 4; ++i) {
      if (mode.fixed[i]) {
        grad_phi += r(i) * fd.grad[i];
      }
    }
  }
  const Vec24 grad = (sg / dist) * grad_phi; // grad g_n

  if (rates != nullptr) {
    out.penetration_rate = -grad.dot(rates->rate);
  }
  const double pdot = out.penetration_rate;
  // The pair carries its share w of the contact near a node (SurfaceContactOptions::end_window):
  // residual w (-f grad g_n), tangent w K + (-f grad g_n) grad w^T.
  const double f = law.force(p, pdot);
  double dshare[2] = {0.0, 0.0};
  const double share_a = coordinate_share(A, mode, 0, lp.c(0), options, &dshare[0]);
  const double share_b = coordinate_share(B, mode, 2, lp.c(2), options, &dshare[1]);
  const double w = share_a * share_b;
  out.share = w;
  out.share_A = share_a;
  out.share_B = share_b;
  out.force = w * f;
  out.potential = w * law.potential(p);
  out.active = true;
  out.residual = -f * grad;
  if (sensitivity != nullptr && !degenerate) {
    const double dws[2] = {dshare[0] * share_b, share_a * dshare[1]};
    write_sensitivity(s, e, gj, grad, sg, dist, w, dws, f, law.stiffness(p, pdot),
                      rates != nullptr ? law.damping(p, pdot) : 0.0, rates, *sensitivity);
  }
  if (!options.compute_tangent) {
    out.residual *= w;
    return false;
  }

  // hess Phi* = G^T G + R - D_f^T H_ff^-1 D_f (+ E on a degenerate path), R the four 3 x 3
  // rotation blocks sum_i g_i d2g_i/dalpha2. With psi = |g| = sqrt(2 Phi*), g_n = sg psi and
  // c = f sg / psi: hess g_n = (sg / psi)(hess Phi* - grad psi grad psi^T), so
  //   tangent = fp grad grad^T - f hess g_n = (fp + c) grad grad^T - c hess Phi*.
  // The low-rank part is U^T C U with U = [G; D_f; grad^T] (8 x 24) and
  // C = diag(-c I3, c H_ff^-1, fp + c): one 24 x 8 x 24 product.
  const double fp = law.stiffness(p, pdot);
  const double c = f * sg / dist;
  const Mat4 h = phi_hessian(e);
  const Mat4x24 d = mixed_derivative(s, e, gj);
  Mat4 h_free = h;
  Mat4x24 d_free = d;
  for (int i = 0; i < 4; ++i) {
    if (mode.fixed[i]) {
      h_free.row(i).setZero();
      h_free.col(i).setZero();
      h_free(i, i) = 1.0;
      d_free.row(i).setZero();
    }
  }
  // H_ff^-1 from a pivoted LU: near touching H is ill-conditioned and a cofactor inverse loses
  // the tangent's accuracy there (the tests at 1e-10 m penetration see it). Multiplying by the
  // inverse avoids the blocked solver's packing for the 24 right-hand sides.
  const Mat4 h_inv = Eigen::PartialPivLU<Mat4>(h_free).inverse();
  const Mat4x24 y = h_inv.lazyProduct(d_free); // H_ff^-1 D_f
  Eigen::Matrix<double, 8, 24> u;
  Eigen::Matrix<double, 8, 24> cu; // C U
  u.topRows<3>() = gj;
  u.middleRows<4>(3) = d_free;
  u.row(7) = grad.transpose();
  cu.topRows<3>() = -c * gj;
  cu.middleRows<4>(3) = c * y;
  cu.row(7) = (fp + c) * grad.transpose();
  out.tangent.noalias() = u.transpose().lazyProduct(cu);
  Matrix3d rot[2][2];
  for (int x = 0; x < 2; ++x) {
    const Cylinder::Point& pt = e.p[x];
    for (int k = 0; k < 2; ++k) {
      const Matrix3d& qn = s[x]->node(k).converged_rotation;
      const Vector3d wk = pt.section.x() * qn.col(0) + pt.section.y() * qn.col(1);
      rot[x][k] =
          rotation_hessian(s[x]->node(k).rotation_increment, wk, (sigma(x) * pt.shape[k]) * e.g);
      const int j = rotation_index(x, k);
      out.tangent.block<3, 3>(j, j) -= c * rot[x][k];
    }
  }
  // On a degenerate path Phi*(d) = Phi~(c_F(d), d) with Phi~ the reduced function:
  // Phi~_dF = D_F - D_f^T H_ff^-1 H_fF, Phi~_FF = H_FF - H_Ff H_ff^-1 H_fF, Phi~_F = r_F, so
  // E = X_F grad c_F^T + grad c_F X_F^T + S_FF' grad c_F grad c_F'^T + r_F hess c_F.
  // H_fk: column k of H in the free coordinates' rows (zero in the fixed ones).
  const auto free_column = [&](int k) {
    Vec4 v = h.col(k);
    for (int l = 0; l < 4; ++l) {
      if (mode.fixed[l]) {
        v(l) = 0.0;
      }
    }
    return v;
  };
  Mat24 extra;
  if (degenerate) {
    extra.setZero();
    for (int i = 0; i < 4; ++i) {
      if (!mode.fixed[i]) {
        continue;
      }
      const Vec4 hi = free_column(i);
      const Vec4 zi = h_inv * hi;
      const Vec24 xi = d.row(i).transpose() - d_free.transpose() * zi;
      extra.noalias() += xi * fd.grad[i].transpose();
      extra.noalias() += fd.grad[i] * xi.transpose();
      for (int k = 0; k < 4; ++k) {
        if (!mode.fixed[k]) {
          continue;
        }
        const double sik = h(i, k) - hi.dot(h_inv * free_column(k));
        extra.noalias() += sik * fd.grad[i] * fd.grad[k].transpose();
      }
      extra += r(i) * fd.hess[i];
    }
    out.tangent -= c * extra;
  }
  if (rates != nullptr) {
    const double fv = law.damping(p, pdot);
    if (fv != 0.0) {
      // pdot = -grad g_n . rate with rate = rate(d): grad pdot = -(hess g_n rate + cv grad).
      const Vec24& rate = rates->rate;
      Vec24 hess_rate = gj.transpose() * (gj * rate) - d_free.transpose() * (y * rate);
      for (int x = 0; x < 2; ++x) {
        for (int k = 0; k < 2; ++k) {
          const int j = rotation_index(x, k);
          hess_rate.segment<3>(j) += rot[x][k] * rate.segment<3>(j);
        }
      }
      if (degenerate) {
        hess_rate += extra * rate;
      }
      const Vec24 hess_gn_rate = (sg / dist) * (hess_rate - grad * grad.dot(rate));
      const Vec24 grad_pdot = -(hess_gn_rate + rates->velocity_per_displacement * grad);
      out.tangent.noalias() -= (fv * grad) * grad_pdot.transpose();
    }
  }
  // grad w = w_,zeta_A grad zeta_A + w_,zeta_B grad zeta_B, with grad c_f = -H_ff^-1 (D_f +
  // H_fF grad c_F^T) for the free coordinates (the implicit function theorem on r_f = 0) and
  // grad c_F known for the fixed ones.
  const double dw[2] = {dshare[0] * share_b, share_a * dshare[1]};
  if (dw[0] != 0.0 || dw[1] != 0.0) {
    Vec24 grad_w = Vec24::Zero();
    for (int x = 0; x < 2; ++x) {
      const int i = 2 * x;
      if (dw[x] == 0.0) {
        continue;
      }
      if (mode.fixed[i]) {
        grad_w += dw[x] * fd.grad[i];
        continue;
      }
      Vec24 grad_zeta = -y.row(i).transpose();
      for (int k = 0; k < 4; ++k) {
        if (!mode.fixed[k]) {
          continue;
        }
        grad_zeta -= h_inv.row(i).dot(free_column(k)) * fd.grad[k];
      }
      grad_w += dw[x] * grad_zeta;
    }
    out.tangent *= w;
    out.tangent.noalias() += out.residual * grad_w.transpose();
  } else if (w != 1.0) {
    out.tangent *= w;
  }
  out.residual *= w;
  return true;
}

} // namespace

SurfaceProjectionResult surface_projection(const SuperEllipticalCylinder& A,
                                           const SuperEllipticalCylinder& B,
                                           const SurfaceProjectionStart& start,
                                           const SurfaceContactOptions& options) {
  return project(A, B, start, options).result;
}

void surface_contact(const SuperEllipticalCylinder& A, const SuperEllipticalCylinder& B,
                     const SurfaceProjectionStart& start, const InterfaceLaw& law,
                     SurfaceContactResult& out, const SurfaceContactOptions& options,
                     const SurfacePairRates* rates, SurfaceContactSensitivity* sensitivity) {
  if (!fill_contact(A, B, start, law, out, options, rates, sensitivity)) {
    out.tangent.setZero();
  }
}

SurfaceContactResult surface_contact(const SuperEllipticalCylinder& A,
                                     const SuperEllipticalCylinder& B,
                                     const SurfaceProjectionStart& start, const InterfaceLaw& law,
                                     const SurfaceContactOptions& options,
                                     const SurfacePairRates* rates,
                                     SurfaceContactSensitivity* sensitivity) {
  SurfaceContactResult out;
  surface_contact(A, B, start, law, out, options, rates, sensitivity);
  return out;
}

const char* to_string(SurfaceDegeneration degeneration) {
  switch (degeneration) {
  case SurfaceDegeneration::None:
    return "none";
  case SurfaceDegeneration::Parallel:
    return "parallel";
  case SurfaceDegeneration::FlatOnA:
    return "flat on A";
  case SurfaceDegeneration::FlatOnB:
    return "flat on B";
  case SurfaceDegeneration::FlatOnBoth:
    return "flat on both";
  case SurfaceDegeneration::RidgeOnA:
    return "ridge on A";
  case SurfaceDegeneration::RidgeOnB:
    return "ridge on B";
  case SurfaceDegeneration::RidgeOnBoth:
    return "ridge on both";
  }
  return "unknown";
}

} // namespace yarnsim::contact
