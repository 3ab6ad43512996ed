#include "contact/surface_friction.hpp"

#include "engine/math/rotation.hpp" // skew

#include <cmath>
#include <stdexcept>
#include <string>

// Notation as in surface_contact.cpp: surfaces X = A (0) and B (1), sigma_A = +1, sigma_B = -1,
// c = (zeta_A, theta_A, zeta_B, theta_B), g = Gamma_A - Gamma_B, g_i = dg/dc_i = sigma_X t_i
// (t_i = Gamma_X,zeta or Gamma_X,theta), G = dg/dd = [J_A, -J_B] at fixed c (J_X = dGamma_X/dd,
// 3 x 12, SuperEllipticalCylinder::jacobian), J_i = dg_i/dd at fixed c (d_zeta_jacobian,
// d_theta_jacobian of the coordinate's surface, times sigma_X).

namespace yarnsim::contact {

namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using Vec4 = Eigen::Vector4d;
using Vec24 = Eigen::Matrix<double, 24, 1>;
using Mat3x4 = Eigen::Matrix<double, 3, 4>;
using Mat3x24 = Eigen::Matrix<double, 3, 24>;
using Mat4x24 = Eigen::Matrix<double, 4, 24>;
using Cylinder = SuperEllipticalCylinder;

constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoPi = 2.0 * kPi;

/// theta in (-pi, pi].
double wrap(double theta) {
  double t = std::remainder(theta, kTwoPi); // [-pi, pi]
  return t <= -kPi ? t + kTwoPi : t;
}

/// theta in [0, 2 pi), as SurfaceContactResult reports it.
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

} // namespace

void surface_friction(const SuperEllipticalCylinder& A, const SuperEllipticalCylinder& B,
                      const SurfaceContactState& contact,
                      const SurfaceContactSensitivity* sensitivity,
                      const SurfaceFrictionHistory& history, const CoulombFriction& law,
                      SurfaceFrictionResult& out, const FrictionOptions& options,
                      const SurfacePairRates* rates) {
  out.active = false;
  out.slipping = false;
  out.mu = 0.0;
  out.stiffness = 0.0;
  out.elastic_gap.setZero();
  out.sliding_velocity.setZero();
  out.force.setZero();
  out.slip_function = 0.0;
  out.slip_increment = 0.0;
  out.dissipation = 0.0;
  out.history = history;
  out.residual.setZero();
  out.tangent.setZero();
  const bool regular =
      contact.active && contact.degeneration == SurfaceDegeneration::None && contact.share > 0.0;
  if (!regular) {
    return;
  }
  if (options.compute_tangent && (sensitivity == nullptr || !sensitivity->valid)) {
    throw std::invalid_argument(
        "surface_friction: the tangent needs the normal contact's SurfaceContactSensitivity "
        "(pass one to surface_contact); found " +
        std::string(sensitivity == nullptr ? "none" : "one not valid for this contact"));
  }

  const Cylinder* s[2] = {&A, &B};
  const Cylinder::Point p[2] = {A.evaluate(contact.zeta_A, contact.theta_A),
                                B.evaluate(contact.zeta_B, contact.theta_B)};
  // Coordinate differences; the anchor may lie in a neighbouring element (zeta beyond [-1, 1]).
  const Vec4 delta(contact.zeta_A - history.zeta_A, wrap(contact.theta_A - history.theta_A),
                   contact.zeta_B - history.zeta_B, wrap(contact.theta_B - history.theta_B));
  Mat3x4 gc; // g_i = dg/dc_i
  for (int x = 0; x < 2; ++x) {
    gc.col(2 * x) = sigma(x) * p[x].d_zeta;
    gc.col(2 * x + 1) = sigma(x) * p[x].d_theta;
  }
  const Vector3d g_t = gc * delta;
  const double f_n = contact.force;
  const double w = contact.share;

  // Stick predictor, slip corrector (Simo & Laursen 1992), with the penalty w eps_t, or with an
  // elastic slip gamma mu f_n / gamma (f_n = w f: the radius gamma on every share).
  const double mu = history.stuck ? law.mu_s() : law.mu_k();
  const bool elastic = law.elastic_slip() > 0.0;
  const double eps_t = law.eps_t();
  const double k = elastic ? law.stiffness(mu, f_n) : w * eps_t; // N/m
  const double gap_norm = g_t.norm();
  const double phi = k * gap_norm - mu * f_n;
  out.active = true;
  out.mu = mu;
  out.stiffness = k;
  out.elastic_gap = g_t;
  out.slip_function = phi;
  const bool slip = slips(phi, mu * f_n, history.stuck);
  out.history.stuck = !slip;
  Vector3d f = k * g_t;
  Vector3d t = Vector3d::Zero();
  if (slip) {
    // |g_t| > (1 - kOnCone) mu f_n / k >= 0 here.
    out.slipping = true;
    t = g_t / gap_norm;
    f = (mu * f_n) * t;
    const double scale = mu * f_n / (k * gap_norm); // in [0, 1 + kOnCone)
    out.history.zeta_A = contact.zeta_A - delta(0) * scale;
    out.history.theta_A = wrap_positive(contact.theta_A - delta(1) * scale);
    out.history.zeta_B = contact.zeta_B - delta(2) * scale;
    out.history.theta_B = wrap_positive(contact.theta_B - delta(3) * scale);
    out.slip_increment = std::max(gap_norm - mu * f_n / k, 0.0);
    out.dissipation = mu * f_n * out.slip_increment;
  }
  // Tangential damping on the relative velocity of the contact points at fixed coordinates:
  // v_rel = G v = J_A v_A - J_B v_B, v_t = (I - n n^T) v_rel, f = f_c - w c_t v_t.
  Cylinder::Jacobian jac[2];
  for (int x = 0; x < 2; ++x) {
    jac[x] = s[x]->jacobian(p[x]);
  }
  const bool damped = rates != nullptr && law.c_t() > 0.0;
  const Vector3d& n = contact.normal;
  Vector3d v_rel = Vector3d::Zero();
  if (damped) {
    for (int x = 0; x < 2; ++x) {
      v_rel.noalias() += sigma(x) * (jac[x] * rates->rate.segment<12>(12 * x));
    }
    out.sliding_velocity = v_rel - n * n.dot(v_rel);
    f -= (w * law.c_t()) * out.sliding_velocity;
  }
  out.force = f;

  // residual = -G^T f = -J_A^T f (A's DOFs), +J_B^T f (B's).
  for (int x = 0; x < 2; ++x) {
    out.residual.segment<12>(12 * x).noalias() = -sigma(x) * (jac[x].transpose() * f);
  }
  if (!options.compute_tangent) {
    return;
  }

  const Mat4x24& dc = sensitivity->coordinates; // C = dc/dd
  // J_i = dg_i/dd at fixed c; each acts on its own surface's 12 DOFs only.
  Cylinder::Jacobian ji[4];
  for (int x = 0; x < 2; ++x) {
    ji[2 * x] = sigma(x) * s[x]->d_zeta_jacobian(p[x]);
    ji[2 * x + 1] = sigma(x) * s[x]->d_theta_jacobian(p[x]);
  }
  // K_k = sum_i Delta_i d2g/dc_i dc_k over the coordinates i of k's surface (Gamma_zz = 0).
  Mat3x4 k_mat;
  for (int x = 0; x < 2; ++x) {
    const double sg = sigma(x);
    const double dz = delta(2 * x);
    const double dt = delta(2 * x + 1);
    k_mat.col(2 * x) = sg * dt * p[x].d_zeta_theta;
    k_mat.col(2 * x + 1) = sg * (dz * p[x].d_zeta_theta + dt * p[x].d_theta_theta);
  }

  // dg_t/dd, 3 x 24.
  Mat3x24 dgt;
  dgt.noalias() = (gc + k_mat) * dc;
  for (int i = 0; i < 4; ++i) {
    dgt.middleCols<12>(12 * (i / 2)) += delta(i) * ji[i];
  }

  // df/dd, 3 x 24.
  Mat3x24 df;
  if (out.slipping) {
    const double cf = mu * f_n / gap_norm;
    df.noalias() = (mu * t) * sensitivity->force.transpose();
    df.noalias() += cf * dgt;
    df.noalias() -= (cf * t) * (t.transpose() * dgt);
  } else if (elastic) {
    // k = mu f_n / gamma, f_n = w f: dk/dd = (mu / gamma) df_n/dd, the share's part included.
    df.noalias() = k * dgt;
    df.noalias() += (law.stiffness_rate(mu) * g_t) * sensitivity->force.transpose();
  } else {
    df.noalias() = k * dgt;
    df.noalias() += (eps_t * g_t) * sensitivity->share.transpose();
  }
  if (damped) {
    // d(w c_t v_t)/dd = c_t (w dv_t/dd + v_t (dw/dd)^T), with
    //   dv_rel/dd = sum_X sigma_X [vpd J_X + d(J_X v_X)/dd_X + (dJ_X/dc v_X) dc/dd],
    //   d(J_X v_X)/dd_X row i = (d2(e_i . Gamma_X)/dd2 v_X)^T (weighted_hessian),
    //   dJ_X/dzeta = d_zeta_jacobian, dJ_X/dtheta = d_theta_jacobian (mixed partials);
    //   n = s_B nu / |nu|, nu = Gamma_B,theta x Gamma_B,zeta (B's outward normal, the contact
    //   normal at a regular projection), dn/dd = s_B (I - n n^T) dnu/dd / |nu|;
    //   dv_t/dd = (I - n n^T) dv_rel/dd - n v_rel^T dn/dd - (n . v_rel) dn/dd.
    const double vpd = rates->velocity_per_displacement;
    Mat3x24 dv = Mat3x24::Zero();
    for (int x = 0; x < 2; ++x) {
      const auto vx = rates->rate.segment<12>(12 * x);
      const double sg = sigma(x);
      dv.middleCols<12>(12 * x) += (sg * vpd) * jac[x];
      for (int i = 0; i < 3; ++i) {
        dv.block<1, 12>(i, 12 * x) +=
            sg * (s[x]->weighted_hessian(p[x], Vector3d::Unit(i)) * vx).transpose();
      }
      dv.noalias() += (sg * (s[x]->d_zeta_jacobian(p[x]) * vx)) * dc.row(2 * x);
      dv.noalias() += (sg * (s[x]->d_theta_jacobian(p[x]) * vx)) * dc.row(2 * x + 1);
    }
    const Cylinder::Point& pb = p[1];
    Mat3x24 db1 = Mat3x24::Zero(); // d(Gamma_B,zeta)/dd
    Mat3x24 db2 = Mat3x24::Zero(); // d(Gamma_B,theta)/dd
    db1.middleCols<12>(12) = B.d_zeta_jacobian(pb);
    db1.noalias() += pb.d_zeta_theta * dc.row(3);
    db2.middleCols<12>(12) = B.d_theta_jacobian(pb);
    db2.noalias() += pb.d_zeta_theta * dc.row(2);
    db2.noalias() += pb.d_theta_theta * dc.row(3);
    const Vector3d nu = pb.d_theta.cross(pb.d_zeta);
    const double nu_norm = nu.norm();
    const double s_b = nu.dot(n) < 0.0 ? -1.0 : 1.0;
    Mat3x24 dn;
    dn.noalias() = -skew<double>(pb.d_zeta) * db2;
    dn.noalias() += skew<double>(pb.d_theta) * db1;
    dn = (s_b / nu_norm) * (dn - n * (n.transpose() * dn));
    Mat3x24 dvt = dv - n * (n.transpose() * dv);
    dvt.noalias() -= n * (v_rel.transpose() * dn);
    dvt -= n.dot(v_rel) * dn;
    df.noalias() -= (w * law.c_t()) * dvt;
    df.noalias() -= (law.c_t() * out.sliding_velocity) * sensitivity->share.transpose();
  }

  // tangent = -G^T df - d2(f . g)/dd2 - M(f)^T C, M(f)_i = f^T J_i.
  Mat4x24 m = Mat4x24::Zero();
  for (int i = 0; i < 4; ++i) {
    m.block<1, 12>(i, 12 * (i / 2)).noalias() = f.transpose() * ji[i];
  }
  for (int x = 0; x < 2; ++x) {
    out.tangent.middleRows<12>(12 * x).noalias() = -sigma(x) * (jac[x].transpose() * df);
    out.tangent.block<12, 12>(12 * x, 12 * x) -= s[x]->weighted_hessian(p[x], sigma(x) * f);
  }
  out.tangent.noalias() -= m.transpose() * dc;
}

} // namespace yarnsim::contact
