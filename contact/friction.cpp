#include "contact/friction.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

// Notation as in spline_contact.cpp: the kernel works in each segment's local variable
// u = (xi - mid) / h; with x the 18 positions [x_A0 x_A1 x_A2 x_B0 x_B1 x_B2],
//   w = [N_A(u_A); -N_B(u_B)], wa = [N_A'(u_A); 0], wb = [0; -N_B'(u_B)] (u-derivatives),
//   g_a = sum_k wa_k x_k = C_A,u, g_b = sum_k wb_k x_k = -C_B,u,
//   g_aa = C_A,uu, g_bb = -C_B,uu (constant on a segment).
// In local parameters the elastic gap is g_t = Delta_A g_a + Delta_B g_b, Delta = u - u^s:
// C'(xi) (xi - xi^s) does not depend on the segment's scale h.

namespace yarnsim::contact {

namespace {

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Vec18 = Eigen::Matrix<double, 18, 1>;
using Mat3x18 = Eigen::Matrix<double, 3, 18>;
using Eigen::Matrix3d;
using Eigen::Vector3d;

bool finite_non_negative(double v) {
  return std::isfinite(v) && v >= 0.0;
}

/// M += kron(c^T, s I3): block column k of M gains s c_k I3.
void add_identity_blocks(Mat3x18& m, const Vec6& c, double s) {
  for (int k = 0; k < 6; ++k) {
    for (int d = 0; d < 3; ++d) {
      m(d, 3 * k + d) += s * c(k);
    }
  }
}

} // namespace

CoulombFriction::CoulombFriction(double mu_s, double mu_k, double eps_t, double c_t,
                                 double elastic_slip)
    : mu_s_(mu_s), mu_k_(mu_k), eps_t_(eps_t), c_t_(c_t), elastic_slip_(elastic_slip) {
  if (!(finite_non_negative(mu_k) && std::isfinite(mu_s) && mu_s >= mu_k &&
        finite_non_negative(eps_t) && finite_non_negative(c_t) &&
        finite_non_negative(elastic_slip) && (eps_t > 0.0 || elastic_slip > 0.0))) {
    std::ostringstream msg;
    msg << "CoulombFriction: expected 0 <= mu_k <= mu_s, c_t >= 0, and eps_t > 0 or "
        << "elastic_slip > 0 (the other >= 0), all finite; found mu_s = " << mu_s
        << ", mu_k = " << mu_k << ", eps_t = " << eps_t << " N/m, c_t = " << c_t
        << " N s/m, elastic_slip = " << elastic_slip << " m";
    throw std::invalid_argument(msg.str());
  }
}

void spline_friction(const Matrix3d& control_A, const SegmentBasis& basis_A,
                     const Matrix3d& control_B, const SegmentBasis& basis_B,
                     const SplineContactState& contact, const SplineContactSensitivity* sensitivity,
                     const FrictionHistory& history, const CoulombFriction& law,
                     SplineFrictionResult& out, const FrictionOptions& options,
                     const PairRates* rates) {
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
  out.share = 1.0;
  const bool regular_point = contact.point_active && !contact.degenerate &&
                             contact.point_evaluated && contact.point_share > 0.0;
  if (!regular_point) {
    return;
  }
  const bool conjugate = options.force == FrictionForce::ConjugateToTheGap;
  if (conjugate && options.compute_tangent)
    throw std::invalid_argument(
        "spline_friction: the force conjugate to the gap is the explicit path's, which needs no "
        "tangent; ask for it with compute_tangent = false");
  if ((options.compute_tangent || conjugate) && (sensitivity == nullptr || !sensitivity->valid)) {
    throw std::invalid_argument(
        std::string("spline_friction: ") +
        (conjugate ? "the force conjugate to the gap" : "the tangent") +
        " needs the normal contact's SplineContactSensitivity (pass one to spline_contact); "
        "found " +
        (sensitivity == nullptr ? "none" : "one not valid for this contact"));
  }

  const double ha = basis_A.length();
  const double hb = basis_B.length();
  const double ua = basis_A.local(contact.xi_A);
  const double ub = basis_B.local(contact.xi_B);
  // Parameter differences in local units; the anchor may lie in a neighbouring segment.
  const double delta_a = (contact.xi_A - history.xi_A) / ha;
  const double delta_b = (contact.xi_B - history.xi_B) / hb;
  Vec6 w;
  w << basis_A.values_local(ua), -basis_B.values_local(ub);
  Vec6 wa;
  wa << basis_A.first_local(ua), Vector3d::Zero();
  Vec6 wb;
  wb << Vector3d::Zero(), -basis_B.first_local(ub);
  const Vector3d g_a = control_A * wa.head<3>();
  const Vector3d g_b = control_B * wb.tail<3>();
  const Vector3d g_t = delta_a * g_a + delta_b * g_b;
  const Vector3d& n = contact.normal;
  const double f_n = contact.point_force;

  // Stick predictor, slip corrector (Simo & Laursen 1992), with the stick stiffness of the law
  // at this normal force (constant, or mu f_n / gamma).
  const double mu = history.stuck ? law.mu_s() : law.mu_k();
  const double eps_t = law.stiffness(mu, f_n);
  const double gap_norm = g_t.norm();
  const double phi = eps_t * gap_norm - mu * f_n;
  out.active = true;
  out.mu = mu;
  out.stiffness = eps_t;
  out.elastic_gap = g_t;
  out.slip_function = phi;
  const bool slip = slips(phi, mu * f_n, history.stuck);
  out.history.stuck = !slip;
  Vector3d f_c = eps_t * g_t;
  Vector3d t = Vector3d::Zero();
  if (slip) {
    // |g_t| > (1 - kOnCone) mu f_n / eps_t >= 0 here.
    out.slipping = true;
    t = g_t / gap_norm;
    f_c = (mu * f_n) * t;
    const double scale = mu * f_n / (eps_t * gap_norm); // in [0, 1 + kOnCone)
    out.history.xi_A = contact.xi_A - (contact.xi_A - history.xi_A) * scale;
    out.history.xi_B = contact.xi_B - (contact.xi_B - history.xi_B) * scale;
    out.slip_increment = std::max(gap_norm - mu * f_n / eps_t, 0.0);
    out.dissipation = mu * f_n * out.slip_increment;
  }

  // Tangential damping on the relative velocity of the contact points at fixed parameters.
  const bool damped = rates != nullptr && law.c_t() > 0.0;
  Vector3d v_rel = Vector3d::Zero();
  if (damped) {
    v_rel = rates->velocity_A * w.head<3>() + rates->velocity_B * w.tail<3>();
    out.sliding_velocity = v_rel - n * n.dot(v_rel);
  }
  out.force = f_c - law.c_t() * out.sliding_velocity;

  // dg_t/dx, 3 x 18, through the local parameters' derivatives du/dx = dxi/dx / h: for the
  // tangent, and for the residual conjugate to the gap.
  const bool with_gradient = options.compute_tangent || conjugate;
  Vec18 du_a = Vec18::Zero(), du_b = Vec18::Zero();
  Mat3x18 dgt = Mat3x18::Zero();
  if (with_gradient) {
    du_a = sensitivity->parameters.row(0).transpose() / ha;
    du_b = sensitivity->parameters.row(1).transpose() / hb;
    const Vector3d g_aa = control_A * basis_A.second_local();
    const Vector3d g_bb = -(control_B * basis_B.second_local());
    add_identity_blocks(dgt, wa, delta_a);
    add_identity_blocks(dgt, wb, delta_b);
    dgt.noalias() += (g_a + delta_a * g_aa) * du_a.transpose();
    dgt.noalias() += (g_b + delta_b * g_bb) * du_b.transpose();
  }
  if (conjugate) {
    out.residual.noalias() = dgt.transpose() * out.force;
  } else {
    for (int k = 0; k < 6; ++k)
      out.residual.segment<3>(3 * k) = -w(k) * out.force;
  }
  // The blend of the all-angle contact: everything times the point share s (in its tangent,
  // r grad s^T); the slip, a distance, is the point's.
  const double s = contact.point_share;
  const bool blended = s < 1.0;
  const Vec18 unblended = out.residual;
  const Vector3d force = out.force; // before the blend
  if (blended) {
    out.share = s;
    out.force *= s;
    out.residual *= s;
    out.dissipation *= s;
  }
  if (!options.compute_tangent) {
    return;
  }

  // df/dx, 3 x 18.
  Mat3x18 df;
  if (out.slipping) {
    const double c = mu * f_n / gap_norm;
    df.noalias() = (mu * t) * sensitivity->force.transpose();
    df.noalias() += c * dgt;
    df.noalias() -= (c * t) * (t.transpose() * dgt);
  } else {
    // f = eps_t(f_n) g_t: with the elastic slip also (mu / gamma) g_t (df_n/dx)^T.
    df.noalias() = eps_t * dgt;
    if (const double rate = law.stiffness_rate(mu); rate > 0.0)
      df.noalias() += (rate * g_t) * sensitivity->force.transpose();
  }
  if (damped) {
    // v_rel = sum_k w_k v_k with dv_k/dx_k = vpd I3; v_t = P v_rel, P = I - n n^T;
    // dn/dx = P dg/dx / |g|, dg/dx = G + g_a du_a^T + g_b du_b^T (total, G = kron(w^T, I3)).
    const double vpd = rates->velocity_per_displacement;
    Vector3d va = rates->velocity_A * wa.head<3>();
    Vector3d vb = rates->velocity_B * wb.tail<3>();
    Mat3x18 dv = va * du_a.transpose() + vb * du_b.transpose();
    add_identity_blocks(dv, w, vpd);
    Mat3x18 dg = g_a * du_a.transpose() + g_b * du_b.transpose();
    add_identity_blocks(dg, w, 1.0);
    const Mat3x18 dn = (dg - n * (n.transpose() * dg)) / contact.distance;
    const double vn = n.dot(v_rel);
    const Mat3x18 dvt = dv - n * (n.transpose() * dv) - n * (v_rel.transpose() * dn) - vn * dn;
    df.noalias() -= law.c_t() * dvt;
  }

  // residual = -kron(w, f): tangent = -kron(wa, f) du_a^T - kron(wb, f) du_b^T - kron(w, df).
  for (int k = 0; k < 6; ++k) {
    out.tangent.block<3, 18>(3 * k, 0).noalias() =
        -(wa(k) * force) * du_a.transpose() - (wb(k) * force) * du_b.transpose();
    out.tangent.block<3, 18>(3 * k, 0).noalias() -= w(k) * df;
  }
  if (blended) {
    out.tangent *= s;
    out.tangent.noalias() += unblended * sensitivity->share.transpose();
  }
}

} // namespace yarnsim::contact
