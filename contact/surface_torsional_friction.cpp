#include "contact/surface_torsional_friction.hpp"

#include "contact/second_order_jet.hpp"

#include <Eigen/LU>

#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>

// Notation as in the header and surface_contact.cpp: surfaces A (0) and B (1), each with 12 DOFs
// (x_A, x_B, alpha_A, alpha_B of its end nodes), at offset 12 X in the pair's 24;
// c = (zeta_A, theta_A, zeta_B, theta_B). Jets (second_order_jet.hpp) of N variables: N = 24
// for the DOFs (the angle and its derivatives), N = 4 for the coordinates (the projection's
// Jacobian J0 = dr/dc).

namespace yarnsim::contact {

namespace {

using Eigen::Matrix3d;
using Eigen::Vector2d;
using Eigen::Vector3d;
using Mat4 = Eigen::Matrix4d;
using Vec4 = Eigen::Vector4d;

template <int H, int N>
Jet3T<H, N> operator+(const Jet3T<H, N>& a, const Jet3T<H, N>& b) {
  return {{a.c[0] + b.c[0], a.c[1] + b.c[1], a.c[2] + b.c[2]}};
}
template <int H, int N>
Jet3T<H, N> operator*(const JetT<H, N>& s, const Jet3T<H, N>& a) {
  return {{s * a.c[0], s * a.c[1], s * a.c[2]}};
}
template <int H, int N>
Jet3T<H, N> operator*(double s, const Jet3T<H, N>& a) {
  return {{s * a.c[0], s * a.c[1], s * a.c[2]}};
}
template <int H, int N>
Jet3T<H, N> cross(const Jet3T<H, N>& a, const Jet3T<H, N>& b) {
  return {{a.c[1] * b.c[2] - a.c[2] * b.c[1], a.c[2] * b.c[0] - a.c[0] * b.c[2],
           a.c[0] * b.c[1] - a.c[1] * b.c[0]}};
}

/// The jet of the variable `index` at `value`.
template <int H, int N>
JetT<H, N> variable(double value, int index) {
  JetT<H, N> out(value);
  out.g(index) = 1.0;
  return out;
}

/// A constant 3-vector as jets.
template <int H, int N>
Jet3T<H, N> constant(const Vector3d& v) {
  return {{JetT<H, N>(v.x()), JetT<H, N>(v.y()), JetT<H, N>(v.z())}};
}

/// One element surface's node data as jets: the end nodes' positions and their section axes 1
/// and 2 (the first two columns of Q_k = Q(alpha_k) Q_n,k), metres and dimensionless.
template <int H, int N>
struct SurfaceJet {
  Jet3T<H, N> x[2];
  Jet3T<H, N> axis[2][2]; ///< [node][section axis]
};

/// The surface's node data as constants (N = 4: the coordinates are the variables).
template <int H, int N>
SurfaceJet<H, N> constant_surface(const SuperEllipticalCylinder& s) {
  SurfaceJet<H, N> out;
  for (int k = 0; k < 2; ++k) {
    out.x[k] = constant<H, N>(s.node(k).position);
    for (int i = 0; i < 2; ++i)
      out.axis[k][i] = constant<H, N>(s.rotation(k).col(i));
  }
  return out;
}

/// A jet of the 3 variables `first` ... `first` + 2 of the 24 DOFs as a jet of all 24.
template <int H>
JetT<H, 24> embed(const JetT<(H > 0 ? 3 : 0), 3>& a, int first) {
  JetT<H, 24> out(a.v);
  out.g.template segment<3>(first) = a.g;
  if constexpr (H > 0)
    out.h.template block<3, 3>(first, first) = a.h;
  return out;
}

/// The surface's node data as jets of the 24 DOFs, the surface's own 12 at `offset` (0 for A,
/// 12 for B): x_k linear; Q(alpha_k) = I + g (S + S^2 / 2), S = skew(alpha_k),
/// g = 4 / (4 + alpha_k . alpha_k) (engine/math/rotation.hpp's rodrigues_rotation), times Q_n,k,
/// evaluated as jets of alpha_k's 3 variables alone, then embedded.
template <int H>
SurfaceJet<H, 24> dof_surface(const SuperEllipticalCylinder& s, int offset) {
  constexpr int H3 = H > 0 ? 3 : 0;
  using J = JetT<H3, 3>;
  SurfaceJet<H, 24> out;
  for (int k = 0; k < 2; ++k) {
    const SurfaceNode& node = s.node(k);
    for (int d = 0; d < 3; ++d)
      out.x[k].c[d] = variable<H, 24>(node.position(d), offset + 3 * k + d);
    J a[3];
    for (int d = 0; d < 3; ++d)
      a[d] = variable<H3, 3>(node.rotation_increment(d), d);
    // S = skew(a): S(0,1) = -a2, S(0,2) = a1, S(1,0) = a2, S(1,2) = -a0, S(2,0) = -a1,
    // S(2,1) = a0; S^2 = a a^T - |a|^2 I.
    const J sq = a[0] * a[0] + a[1] * a[1] + a[2] * a[2];
    J four(4.0);
    const J g = 4.0 * reciprocal(four + sq);
    J q[3][3];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        J s2 = a[i] * a[j];
        if (i == j)
          s2 = s2 - sq;
        J e = 0.5 * s2;
        if (i != j) {
          // skew entries: sign of the permutation (i, j, l).
          const int l = 3 - i - j;
          const double sign = ((j - i + 3) % 3 == 1) ? -1.0 : 1.0;
          e = e + sign * a[l];
        }
        q[i][j] = g * e;
        if (i == j)
          q[i][j].v += 1.0;
      }
    const Matrix3d& qn = node.converged_rotation;
    for (int col = 0; col < 2; ++col)
      for (int i = 0; i < 3; ++i) {
        J e = qn(0, col) * q[i][0];
        e = e + qn(1, col) * q[i][1];
        e = e + qn(2, col) * q[i][2];
        out.axis[k][col].c[i] = embed<H>(e, offset + 6 + 3 * k);
      }
  }
  return out;
}

/// Gamma, Gamma_zeta and Gamma_theta of a surface at the coordinate jets (zeta, theta):
///   Gamma = N_A (x_A + v_A) + N_B (x_B + v_B),  v_k = s_1 q_k1 + s_2 q_k2,
///   Gamma_zeta = ((x_B + v_B) - (x_A + v_A)) / 2,  Gamma_theta = N_A v'_A + N_B v'_B,
/// s(theta) carried to second order through s', s'' (and s' through s'', s''').
template <int H, int N>
struct SurfaceTangents {
  Jet3T<H, N> point, d_zeta, d_theta;
};
template <int H, int N>
SurfaceTangents<H, N> surface_jet(const SurfaceJet<H, N>& s, const SuperEllipse& section,
                                  const JetT<H, N>& zeta, const JetT<H, N>& theta) {
  using J = JetT<H, N>;
  const SuperEllipse::Point p = section.point(theta.v);
  const Vector2d third = section.third_derivative(theta.v);
  const J s1 = apply(theta, p.value.x(), p.first.x(), p.second.x());
  const J s2 = apply(theta, p.value.y(), p.first.y(), p.second.y());
  const J t1 = apply(theta, p.first.x(), p.second.x(), third.x());
  const J t2 = apply(theta, p.first.y(), p.second.y(), third.y());
  J n0 = -0.5 * zeta;
  n0.v += 0.5;
  J n1 = 0.5 * zeta;
  n1.v += 0.5;
  Jet3T<H, N> e[2], dv[2];
  for (int k = 0; k < 2; ++k) {
    e[k] = s.x[k] + (s1 * s.axis[k][0] + s2 * s.axis[k][1]);
    dv[k] = t1 * s.axis[k][0] + t2 * s.axis[k][1];
  }
  return {n0 * e[0] + n1 * e[1], 0.5 * (e[1] - e[0]), n0 * dv[0] + n1 * dv[1]};
}

/// The same at constant coordinates (zeta, theta): combinations of the node jets with scalar
/// coefficients (the first chord step, which starts from the converged coordinates).
template <int H, int N>
SurfaceTangents<H, N> surface_jet(const SurfaceJet<H, N>& s, const SuperEllipse& section,
                                  double zeta, double theta) {
  const SuperEllipse::Point p = section.point(theta);
  const double n0 = 0.5 * (1.0 - zeta), n1 = 0.5 * (1.0 + zeta);
  Jet3T<H, N> e[2], dv[2];
  for (int k = 0; k < 2; ++k) {
    e[k] = s.x[k] + (p.value.x() * s.axis[k][0] + p.value.y() * s.axis[k][1]);
    dv[k] = p.first.x() * s.axis[k][0] + p.first.y() * s.axis[k][1];
  }
  return {n0 * e[0] + n1 * e[1], 0.5 * (e[1] - e[0]), n0 * dv[0] + n1 * dv[1]};
}

/// The projection's equations (surface_contact.hpp):
///   r = [Gamma_A,zeta . nu, Gamma_A,theta . nu, -Gamma_B,zeta . g, -Gamma_B,theta . g].
template <int H, int N>
void projection_residual(const SurfaceTangents<H, N>& a, const SurfaceTangents<H, N>& b,
                         JetT<H, N> (&r)[4]) {
  const Jet3T<H, N> nu = cross(b.d_theta, b.d_zeta);
  const Jet3T<H, N> g = a.point - b.point;
  r[0] = dot(a.d_zeta, nu);
  r[1] = dot(a.d_theta, nu);
  r[2] = -dot(b.d_zeta, g);
  r[3] = -dot(b.d_theta, g);
}

Vec4 coordinates(const SurfaceContactState& contact) {
  return {contact.zeta_A, contact.theta_A, contact.zeta_B, contact.theta_B};
}

/// J0 = dr/dc at the converged coordinates, inverted. Throws std::domain_error if singular.
Mat4 inverse_projection_jacobian(const SuperEllipticalCylinder& A, const SuperEllipticalCylinder& B,
                                 const Vec4& c0) {
  using J = JetT<0, 4>;
  const SurfaceJet<0, 4> sa = constant_surface<0, 4>(A);
  const SurfaceJet<0, 4> sb = constant_surface<0, 4>(B);
  J c[4];
  for (int i = 0; i < 4; ++i)
    c[i] = variable<0, 4>(c0(i), i);
  J r[4];
  projection_residual(surface_jet(sa, A.section(), c[0], c[1]),
                      surface_jet(sb, B.section(), c[2], c[3]), r);
  Mat4 j0;
  for (int i = 0; i < 4; ++i)
    j0.row(i) = r[i].g.transpose();
  const double det = j0.determinant();
  if (!(std::isfinite(det) && det != 0.0)) {
    std::ostringstream msg;
    msg << "surface_torsional_friction: the projection's Jacobian is singular at (zeta_A, "
           "theta_A, zeta_B, theta_B) = ("
        << c0.transpose() << "), determinant " << det;
    throw std::domain_error(msg.str());
  }
  return j0.inverse();
}

/// s_B: the sign that turns Gamma_B,theta x Gamma_B,zeta along the contact normal.
double normal_sign(const SuperEllipticalCylinder& B, const SurfaceContactState& contact) {
  const SuperEllipticalCylinder::Point p = B.evaluate(contact.zeta_B, contact.theta_B);
  return p.d_theta.cross(p.d_zeta).dot(contact.normal) < 0.0 ? -1.0 : 1.0;
}

/// theta as a jet of the 24 DOFs (the header's "Derivatives").
template <int H>
JetT<H, 24> angle_jet(const SuperEllipticalCylinder& A, const SuperEllipticalCylinder& B,
                      const SurfaceContactState& contact) {
  using J = JetT<H, 24>;
  const Vec4 c0 = coordinates(contact);
  const Mat4 inverse = inverse_projection_jacobian(A, B, c0);
  const SurfaceJet<H, 24> sa = dof_surface<H>(A, 0);
  const SurfaceJet<H, 24> sb = dof_surface<H>(B, 12);
  J c[4];
  for (int i = 0; i < 4; ++i)
    c[i] = J(c0(i));
  for (int step = 0; step < 2; ++step) {
    J r[4];
    if (step == 0)
      projection_residual(surface_jet(sa, A.section(), c0(0), c0(1)),
                          surface_jet(sb, B.section(), c0(2), c0(3)), r);
    else
      projection_residual(surface_jet(sa, A.section(), c[0], c[1]),
                          surface_jet(sb, B.section(), c[2], c[3]), r);
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j)
        c[i] = c[i] - inverse(i, j) * r[j];
  }
  const SurfaceTangents<H, 24> ta = surface_jet(sa, A.section(), c[0], c[1]);
  const SurfaceTangents<H, 24> tb = surface_jet(sb, B.section(), c[2], c[3]);
  const Jet3T<H, 24> nu = normal_sign(B, contact) * cross(tb.d_theta, tb.d_zeta);
  return atan2_jet(triple(nu, ta.d_zeta, tb.d_zeta), sqrt(dot(nu, nu)) * dot(ta.d_zeta, tb.d_zeta));
}

bool regular(const SurfaceContactState& contact) {
  return contact.active && contact.degeneration == SurfaceDegeneration::None && contact.share > 0.0;
}

/// The law (the header's "Law") and the residual; the tangent where the jet carries a Hessian.
template <int H>
void evaluate_law(const JetT<H, 24>& theta, const SurfaceContactState& contact,
                  const SurfaceContactSensitivity* sensitivity,
                  const SurfaceFrictionHistory& history, const TorsionalFriction& law,
                  SurfaceTorsionalFrictionResult& out) {
  const double w = contact.share;
  // The pair's penalty, N m/rad: w k_r, or with an elastic slip mu f_n rho^2 / gamma (f_n = w f,
  // the share included through the force).
  const bool elastic = law.elastic_slip() > 0.0;
  const double k = elastic
                       ? law.stiffness(history.twist_stuck ? law.mu_s() : law.mu_k(), contact.force)
                       : w * law.k_r();
  // f_n = w f, contact.force: the pair's share of the normal force.
  const TwistReturn r =
      twist_return(theta.v, history.twist, history.twist_stuck, k, contact.force, law);
  const double mu = r.mu, twist = r.twist, m = r.torque;
  set_twist_result(r, theta.v, out);
  out.residual = m * theta.g;
  if constexpr (H > 0) {
    out.tangent = m * theta.h;
    if (out.slipping) {
      out.tangent.noalias() +=
          theta.g * (mu * law.rho() * std::copysign(1.0, twist) * sensitivity->force.transpose());
    } else if (elastic) {
      out.tangent.noalias() += k * theta.g * theta.g.transpose();
      out.tangent.noalias() +=
          theta.g * ((law.stiffness_rate(mu) * twist) * sensitivity->force.transpose());
    } else {
      out.tangent.noalias() += k * theta.g * theta.g.transpose();
      out.tangent.noalias() += theta.g * ((law.k_r() * twist) * sensitivity->share.transpose());
    }
  }
}

} // namespace

double surface_crossing_angle(const SuperEllipticalCylinder& A, const SuperEllipticalCylinder& B,
                              const SurfaceContactState& contact) {
  if (!regular(contact)) {
    std::ostringstream msg;
    msg << "surface_crossing_angle: expected an active contact on the regular path; found "
        << (contact.active ? "an active" : "an inactive") << " contact on the "
        << to_string(contact.degeneration) << " path with share " << contact.share;
    throw std::invalid_argument(msg.str());
  }
  const SuperEllipticalCylinder::Point pa = A.evaluate(contact.zeta_A, contact.theta_A);
  const SuperEllipticalCylinder::Point pb = B.evaluate(contact.zeta_B, contact.theta_B);
  const Vector3d nu = normal_sign(B, contact) * pb.d_theta.cross(pb.d_zeta);
  return std::atan2(nu.dot(pa.d_zeta.cross(pb.d_zeta)), nu.norm() * pa.d_zeta.dot(pb.d_zeta));
}

void surface_torsional_friction(const SuperEllipticalCylinder& A, const SuperEllipticalCylinder& B,
                                const SurfaceContactState& contact,
                                const SurfaceContactSensitivity* sensitivity,
                                const SurfaceFrictionHistory& history, const TorsionalFriction& law,
                                SurfaceTorsionalFrictionResult& out,
                                const FrictionOptions& options) {
  out.active = false;
  out.slipping = false;
  out.mu = out.angle = out.elastic_twist = out.torque = 0.0;
  out.slip_function = out.slip_increment = out.dissipation = out.energy = 0.0;
  out.anchor = history.twist;
  out.stuck = history.twist_stuck;
  out.residual.setZero();
  out.tangent.setZero();
  if (!regular(contact))
    return;
  if (options.compute_tangent && (sensitivity == nullptr || !sensitivity->valid)) {
    throw std::invalid_argument(
        "surface_torsional_friction: the tangent needs the normal contact's "
        "SurfaceContactSensitivity (pass one to surface_contact); found " +
        std::string(sensitivity == nullptr ? "none" : "one not valid for this contact"));
  }
  if (options.compute_tangent)
    evaluate_law(angle_jet<24>(A, B, contact), contact, sensitivity, history, law, out);
  else
    evaluate_law(angle_jet<0>(A, B, contact), contact, sensitivity, history, law, out);
}

} // namespace yarnsim::contact
