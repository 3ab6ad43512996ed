#pragma once
// Second-order forward-mode differentiation over the 18 positions of a segment pair: a value
// with its gradient and Hessian, carried through the arithmetic of a contact kernel. Used where
// the hand-written chain rule would be long and error-prone (the angle between the tangents at
// projected points, whose second derivatives need the second derivatives of the projections).
// Fixed size, no allocation.

#include <Eigen/Core>

#include <cmath>

namespace yarnsim::contact {

/// A scalar function of the 18 positions x at one point: value, d/dx (18) and d2/dx2 (18 x 18).
struct Jet {
  using Vec = Eigen::Matrix<double, 18, 1>;
  using Mat = Eigen::Matrix<double, 18, 18>;
  double v;
  Vec g;
  Mat h;

  /// A constant.
  Jet() : Jet(0.0) {}
  explicit Jet(double value) : v(value), g(Vec::Zero()), h(Mat::Zero()) {}
  /// Left unset, for the operators below that write every entry (saves zeroing 2.6 KB).
  struct Unset {};
  explicit Jet(Unset) : v(0.0) {}
  /// The linear function sum_k w_k x(3 k + d) (a curve point's component d with weights w).
  static Jet linear(const Eigen::Matrix<double, 6, 1>& w, int d) {
    Jet out;
    for (int k = 0; k < 6; ++k)
      out.g(3 * k + d) = w(k);
    return out;
  }
};

/// h += s (a b^T + b a^T), column by column (Eigen's outer products of fixed 18-vectors cost
/// more).
inline void add_symmetric(Jet::Mat& h, const Jet::Vec& a, const Jet::Vec& b, double s) {
  const Jet::Vec sa = s * a, sb = s * b;
  for (int j = 0; j < 18; ++j)
    h.col(j) += sa * b(j) + sb * a(j);
}

inline Jet operator+(const Jet& a, const Jet& b) {
  Jet out{Jet::Unset{}};
  out.v = a.v + b.v;
  out.g = a.g + b.g;
  out.h = a.h + b.h;
  return out;
}
inline Jet operator-(const Jet& a, const Jet& b) {
  Jet out{Jet::Unset{}};
  out.v = a.v - b.v;
  out.g = a.g - b.g;
  out.h = a.h - b.h;
  return out;
}
inline Jet operator-(const Jet& a) {
  Jet out{Jet::Unset{}};
  out.v = -a.v;
  out.g = -a.g;
  out.h = -a.h;
  return out;
}
inline Jet operator*(double s, const Jet& a) {
  Jet out{Jet::Unset{}};
  out.v = s * a.v;
  out.g = s * a.g;
  out.h = s * a.h;
  return out;
}
inline Jet operator+(const Jet& a, double s) {
  Jet out = a;
  out.v += s;
  return out;
}
inline Jet operator*(const Jet& a, const Jet& b) {
  Jet out{Jet::Unset{}};
  out.v = a.v * b.v;
  out.g = b.v * a.g + a.v * b.g;
  out.h = b.v * a.h + a.v * b.h;
  add_symmetric(out.h, a.g, b.g, 1.0);
  return out;
}

/// f(a) from f, f' and f'' at a.v (the chain rule of second order).
inline Jet apply(const Jet& a, double f, double df, double d2f) {
  Jet out{Jet::Unset{}};
  out.v = f;
  out.g = df * a.g;
  out.h = df * a.h;
  add_symmetric(out.h, a.g, a.g, 0.5 * d2f);
  return out;
}
inline Jet reciprocal(const Jet& a) {
  const double r = 1.0 / a.v;
  return apply(a, r, -r * r, 2.0 * r * r * r);
}
inline Jet operator/(const Jet& a, const Jet& b) {
  return a * reciprocal(b);
}
inline Jet sqrt(const Jet& a) {
  const double s = std::sqrt(a.v);
  return apply(a, s, 0.5 / s, -0.25 / (s * a.v));
}

/// A 3-vector of jets.
struct Jet3 {
  Jet c[3];
};
inline Jet dot(const Jet3& a, const Jet3& b) {
  return a.c[0] * b.c[0] + a.c[1] * b.c[1] + a.c[2] * b.c[2];
}
inline Jet3 operator-(const Jet3& a, const Jet3& b) {
  return {{a.c[0] - b.c[0], a.c[1] - b.c[1], a.c[2] - b.c[2]}};
}
inline Jet3 operator*(const Jet& s, const Jet3& a) {
  return {{s * a.c[0], s * a.c[1], s * a.c[2]}};
}
inline Jet3 operator+(const Jet3& a, const Jet3& b) {
  return {{a.c[0] + b.c[0], a.c[1] + b.c[1], a.c[2] + b.c[2]}};
}
inline Eigen::Vector3d value(const Jet3& a) {
  return {a.c[0].v, a.c[1].v, a.c[2].v};
}

/// F(u) = sum_k phi_k(u) X_k as a jet of the positions, where X (columns, metres) are three
/// control points whose coordinates are positions first * 3 ... first * 3 + 8 of x (first = 0
/// for curve A, 3 for curve B), scaled by `sign`, and u is a jet (a parameter that depends on
/// x). phi, dphi, d2phi: the three functions' values and first and second u-derivatives at u.v.
inline Jet3 curve_jet(const Eigen::Matrix3d& X, int first, double sign, const Jet& u,
                      const Eigen::Vector3d& phi, const Eigen::Vector3d& dphi,
                      const Eigen::Vector3d& d2phi) {
  Jet3 out{{Jet(Jet::Unset{}), Jet(Jet::Unset{}), Jet(Jet::Unset{})}};
  const Eigen::Vector3d f = sign * (X * phi);
  const Eigen::Vector3d df = sign * (X * dphi);
  const Eigen::Vector3d d2f = sign * (X * d2phi);
  for (int d = 0; d < 3; ++d) {
    Jet& o = out.c[d];
    o.v = f(d);
    o.g = df(d) * u.g;
    o.h = df(d) * u.h;
    add_symmetric(o.h, u.g, u.g, 0.5 * d2f(d));
    for (int k = 0; k < 3; ++k) {
      const int i = 3 * (first + k) + d;
      o.g(i) += sign * phi(k);
      o.h.col(i) += (sign * dphi(k)) * u.g;
      o.h.row(i) += (sign * dphi(k)) * u.g.transpose();
    }
  }
  return out;
}

} // namespace yarnsim::contact
