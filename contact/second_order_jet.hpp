#pragma once
// Forward-mode differentiation over the N DOFs of a contact pair (18 positions of a spline
// segment pair; 24 DOFs of a surface element pair, surface_torsional_friction.cpp): a value
// with its gradient and (for the tangent) its Hessian, carried through the arithmetic of a
// contact kernel. Used where the hand-written chain rule would be long and error-prone (the angle
// between the tangents at projected points, whose second derivatives need the second
// derivatives of the projections). Fixed size, no allocation.

#include <Eigen/Core>

#include <cmath>

namespace yarnsim::contact {

/// A scalar function of the N variables x at one point: value, d/dx (N) and, for H = N,
/// d2/dx2 (N x N); H = 0 carries no Hessian (residual only: explicit dynamics), and every
/// operation on it then costs a gradient's work. N = 18 (the default): the spline kernels'
/// positions.
template <int H, int N = 18>
struct JetT {
  static_assert(H == 0 || H == N);
  using Vec = Eigen::Matrix<double, N, 1>;
  using Mat = Eigen::Matrix<double, H, H>;
  double v;
  Vec g;
  Mat h;

  /// A constant.
  JetT() : JetT(0.0) {}
  explicit JetT(double value) : v(value), g(Vec::Zero()), h(Mat::Zero()) {}
  /// Left unset, for the operators below that write every entry (saves zeroing 2.6 KB).
  struct Unset {};
  explicit JetT(Unset) : v(0.0) {}
};

/// Value, gradient and Hessian.
using Jet = JetT<18>;

/// h += s (a b^T + b a^T), column by column (Eigen's outer products of fixed 18-vectors cost
/// more).
template <int H, int N>
void add_symmetric(Eigen::Matrix<double, H, H>& h, const Eigen::Matrix<double, N, 1>& a,
                   const Eigen::Matrix<double, N, 1>& b, double s) {
  if constexpr (H > 0) {
    const Eigen::Matrix<double, N, 1> sa = s * a, sb = s * b;
    for (int j = 0; j < N; ++j)
      h.col(j) += sa * b(j) + sb * a(j);
  }
}

template <int H, int N>
JetT<H, N> operator+(const JetT<H, N>& a, const JetT<H, N>& b) {
  JetT<H, N> out{typename JetT<H, N>::Unset{}};
  out.v = a.v + b.v;
  out.g = a.g + b.g;
  out.h = a.h + b.h;
  return out;
}
template <int H, int N>
JetT<H, N> operator-(const JetT<H, N>& a, const JetT<H, N>& b) {
  JetT<H, N> out{typename JetT<H, N>::Unset{}};
  out.v = a.v - b.v;
  out.g = a.g - b.g;
  out.h = a.h - b.h;
  return out;
}
template <int H, int N>
JetT<H, N> operator-(const JetT<H, N>& a) {
  JetT<H, N> out{typename JetT<H, N>::Unset{}};
  out.v = -a.v;
  out.g = -a.g;
  out.h = -a.h;
  return out;
}
template <int H, int N>
JetT<H, N> operator*(double s, const JetT<H, N>& a) {
  JetT<H, N> out{typename JetT<H, N>::Unset{}};
  out.v = s * a.v;
  out.g = s * a.g;
  out.h = s * a.h;
  return out;
}
template <int H, int N>
JetT<H, N> operator*(const JetT<H, N>& a, const JetT<H, N>& b) {
  JetT<H, N> out{typename JetT<H, N>::Unset{}};
  out.v = a.v * b.v;
  out.g = b.v * a.g + a.v * b.g;
  out.h = b.v * a.h + a.v * b.h;
  add_symmetric(out.h, a.g, b.g, 1.0);
  return out;
}

/// f(a) from f, f' and f'' at a.v (the chain rule of second order).
template <int H, int N>
JetT<H, N> apply(const JetT<H, N>& a, double f, double df, double d2f) {
  JetT<H, N> out{typename JetT<H, N>::Unset{}};
  out.v = f;
  out.g = df * a.g;
  out.h = df * a.h;
  add_symmetric(out.h, a.g, a.g, 0.5 * d2f);
  return out;
}
template <int H, int N>
JetT<H, N> reciprocal(const JetT<H, N>& a) {
  const double r = 1.0 / a.v;
  return apply(a, r, -r * r, 2.0 * r * r * r);
}
template <int H, int N>
JetT<H, N> operator/(const JetT<H, N>& a, const JetT<H, N>& b) {
  return a * reciprocal(b);
}
template <int H, int N>
JetT<H, N> sqrt(const JetT<H, N>& a) {
  const double s = std::sqrt(a.v);
  return apply(a, s, 0.5 / s, -0.25 / (s * a.v));
}

/// A 3-vector of jets.
template <int H, int N = 18>
struct Jet3T {
  JetT<H, N> c[3];
};
template <int H, int N>
JetT<H, N> dot(const Jet3T<H, N>& a, const Jet3T<H, N>& b) {
  return a.c[0] * b.c[0] + a.c[1] * b.c[1] + a.c[2] * b.c[2];
}
template <int H, int N>
Jet3T<H, N> operator-(const Jet3T<H, N>& a, const Jet3T<H, N>& b) {
  return {{a.c[0] - b.c[0], a.c[1] - b.c[1], a.c[2] - b.c[2]}};
}
template <int H, int N>
Eigen::Vector3d value(const Jet3T<H, N>& a) {
  return {a.c[0].v, a.c[1].v, a.c[2].v};
}

/// a . (b x c) of jets.
template <int H, int N>
JetT<H, N> triple(const Jet3T<H, N>& a, const Jet3T<H, N>& b, const Jet3T<H, N>& c) {
  return a.c[0] * (b.c[1] * c.c[2] - b.c[2] * c.c[1]) +
         a.c[1] * (b.c[2] * c.c[0] - b.c[0] * c.c[2]) +
         a.c[2] * (b.c[0] * c.c[1] - b.c[1] * c.c[0]);
}

/// atan2(y, x) of jets: atan(y / x) (plus a constant) where |x| >= |y|, else
/// pi / 2 - atan(x / y) (plus a constant), which have atan2's derivatives.
template <int H, int N>
JetT<H, N> atan2_jet(const JetT<H, N>& y, const JetT<H, N>& x) {
  const double value = std::atan2(y.v, x.v);
  if (std::abs(x.v) >= std::abs(y.v)) {
    const JetT<H, N> q = y / x;
    const double s = 1.0 / (1.0 + q.v * q.v);
    return apply(q, value, s, -2.0 * q.v * s * s);
  }
  const JetT<H, N> q = x / y;
  const double s = 1.0 / (1.0 + q.v * q.v);
  return apply(q, value, -s, 2.0 * q.v * s * s);
}

/// F(u) = sum_k phi_k(u) X_k as a jet of the positions, where X (columns, metres) are three
/// control points whose coordinates are positions first * 3 ... first * 3 + 8 of x (first = 0
/// for curve A, 3 for curve B), and u is a jet (a parameter that depends on x). phi, dphi, d2phi:
/// the three functions' values and first and second u-derivatives at u.v.
template <int H>
Jet3T<H> curve_jet(const Eigen::Matrix3d& X, int first, const JetT<H>& u,
                   const Eigen::Vector3d& phi, const Eigen::Vector3d& dphi,
                   const Eigen::Vector3d& d2phi) {
  using J = JetT<H>;
  Jet3T<H> out{{J(typename J::Unset{}), J(typename J::Unset{}), J(typename J::Unset{})}};
  const Eigen::Vector3d f = X * phi;
  const Eigen::Vector3d df = X * dphi;
  const Eigen::Vector3d d2f = X * d2phi;
  for (int d = 0; d < 3; ++d) {
    J& o = out.c[d];
    o.v = f(d);
    o.g = df(d) * u.g;
    o.h = df(d) * u.h;
    add_symmetric(o.h, u.g, u.g, 0.5 * d2f(d));
    for (int k = 0; k < 3; ++k) {
      const int i = 3 * (first + k) + d;
      o.g(i) += phi(k);
      if constexpr (H > 0) {
        o.h.col(i) += dphi(k) * u.g;
        o.h.row(i) += dphi(k) * u.g.transpose();
      }
    }
  }
  return out;
}

} // namespace yarnsim::contact
