#include "contact/torsional_friction.hpp"

#include "contact/projection_jet.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>

namespace yarnsim::contact {

namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

/// theta (the file header's crossing angle) as a jet of the positions: atan2 of
/// (g . (a x b), |g| a . b), which are n . (a x b) and a . b times |g| > 0.
template <int H>
JetT<H> angle_jet(const Matrix3d& control_A, const SegmentBasis& basis_A, double ua,
                  const Matrix3d& control_B, const SegmentBasis& basis_B, double ub) {
  JetT<H> jua, jub;
  closest_point_jets(control_A, basis_A, ua, control_B, basis_B, ub, jua, jub);
  const Jet3T<H> g = jet_point(control_A, basis_A, 0, jua) - jet_point(control_B, basis_B, 3, jub);
  const Jet3T<H> a = jet_tangent(control_A, basis_A, 0, jua);
  const Jet3T<H> b = jet_tangent(control_B, basis_B, 3, jub);
  return atan2_jet(triple(g, a, b), sqrt(dot(g, g)) * dot(a, b));
}

/// An active point contact on the regular path (in the all-angle contact: its point part, with a
/// share s > 0).
bool regular_point(const SplineContactState& contact) {
  return contact.point_active && !contact.degenerate && contact.point_evaluated &&
         contact.point_share > 0.0;
}

} // namespace

TwistReturn twist_return(double theta, double anchor, bool stuck, double k, double f_n,
                         const TorsionalFriction& law) {
  TwistReturn r;
  r.mu = stuck ? law.mu_s() : law.mu_k();
  r.twist = std::remainder(theta - anchor, 2.0 * std::numbers::pi);
  r.limit = r.mu * f_n * law.rho(); // N m
  r.slip_function = k * std::abs(r.twist) - r.limit;
  r.slipping = slips(r.slip_function, r.limit, stuck);
  r.anchor = anchor;
  double m = k * r.twist;
  if (r.slipping) { // k > 0 here: k |dtheta| > limit >= 0
    m = std::copysign(r.limit, r.twist);
    r.anchor = std::remainder(theta - m / k, 2.0 * std::numbers::pi);
    r.slip_increment = std::max(std::abs(r.twist) - r.limit / k, 0.0);
    r.dissipation = r.limit * r.slip_increment;
  }
  r.torque = m;
  r.energy = k > 0.0 ? m * m / (2.0 * k) : 0.0;
  return r;
}

namespace {

/// The law and the residual; the tangent where J carries a Hessian.
template <int H>
void evaluate(const JetT<H>& theta, double f_n, const SplineContactSensitivity* sensitivity,
              const FrictionHistory& history, const TorsionalFriction& law,
              TorsionalFrictionResult& out) {
  const double k_r = law.stiffness(history.twist_stuck ? law.mu_s() : law.mu_k(), f_n);
  const TwistReturn r = twist_return(theta.v, history.twist, history.twist_stuck, k_r, f_n, law);
  const double mu = r.mu, twist = r.twist, m = r.torque;
  set_twist_result(r, theta.v, out);
  out.residual = m * theta.g;
  if constexpr (H > 0) {
    out.tangent = m * theta.h;
    if (out.slipping)
      out.tangent.noalias() +=
          theta.g * (mu * law.rho() * std::copysign(1.0, twist) * sensitivity->force.transpose());
    else if (const double rate = law.stiffness_rate(mu); rate > 0.0)
      // m = k_r(f_n) dtheta: dm/dx = k_r dtheta/dx + (mu rho^2 / gamma) dtheta df_n/dx.
      out.tangent.noalias() +=
          theta.g * (k_r * theta.g + (rate * twist) * sensitivity->force).transpose();
    else
      out.tangent.noalias() += k_r * theta.g * theta.g.transpose();
  }
}

} // namespace

TorsionalFriction::TorsionalFriction(double mu_s, double mu_k, double k_r, double rho,
                                     double elastic_slip)
    : mu_s_(mu_s), mu_k_(mu_k), k_r_(k_r), rho_(rho), elastic_slip_(elastic_slip) {
  if (!(std::isfinite(mu_k) && mu_k >= 0.0 && std::isfinite(mu_s) && mu_s >= mu_k &&
        std::isfinite(k_r) && k_r >= 0.0 && std::isfinite(rho) && rho > 0.0 &&
        std::isfinite(elastic_slip) && elastic_slip >= 0.0 && (k_r > 0.0 || elastic_slip > 0.0))) {
    std::ostringstream msg;
    msg << "TorsionalFriction: expected 0 <= mu_k <= mu_s, rho > 0, and k_r > 0 or "
        << "elastic_slip > 0 (the other >= 0), all finite; found mu_s = " << mu_s
        << ", mu_k = " << mu_k << ", k_r = " << k_r << " N m/rad, rho = " << rho
        << " m, elastic_slip = " << elastic_slip << " m";
    throw std::invalid_argument(msg.str());
  }
}

TorsionalFriction torsional_law(double mu_s, double mu_k, double eps_t, double radius,
                                double penalty, double width_A, double width_B,
                                double elastic_slip) {
  const double rho = radius > 0 ? radius : footprint_radius(width_A, width_B);
  if (penalty > 0)
    return {mu_s, mu_k, penalty, rho};
  if (elastic_slip > 0)
    return {mu_s, mu_k, 0.0, rho, elastic_slip};
  return {mu_s, mu_k, eps_t * rho * rho, rho};
}

double footprint_radius(double width_A, double width_B) {
  // Mean of |r| over [-p, p] x [-q, q]: (1 / (6 p q)) (2 p q d + p^3 ln((q + d) / p)
  // + q^3 ln((p + d) / q)), d = sqrt(p^2 + q^2) (the integral of |r| over a quarter).
  const double p = 0.5 * width_A, q = 0.5 * width_B;
  const double d = std::hypot(p, q);
  return (2.0 * p * q * d + p * p * p * std::log((q + d) / p) + q * q * q * std::log((p + d) / q)) /
         (6.0 * p * q);
}

double crossing_angle(const Matrix3d& control_A, const SegmentBasis& basis_A,
                      const Matrix3d& control_B, const SegmentBasis& basis_B,
                      const SplineContactState& contact) {
  const Vector3d a = control_A * basis_A.first_local(basis_A.local(contact.xi_A));
  const Vector3d b = control_B * basis_B.first_local(basis_B.local(contact.xi_B));
  return std::atan2(contact.normal.dot(a.cross(b)), a.dot(b));
}

void torsional_friction(const Matrix3d& control_A, const SegmentBasis& basis_A,
                        const Matrix3d& control_B, const SegmentBasis& basis_B,
                        const SplineContactState& contact,
                        const SplineContactSensitivity* sensitivity, const FrictionHistory& history,
                        const TorsionalFriction& law, TorsionalFrictionResult& out,
                        const FrictionOptions& options) {
  out.active = false;
  out.slipping = false;
  out.mu = out.angle = out.elastic_twist = out.torque = 0.0;
  out.slip_function = out.slip_increment = out.dissipation = out.energy = 0.0;
  out.anchor = history.twist;
  out.stuck = history.twist_stuck;
  out.residual.setZero();
  out.tangent.setZero();
  if (!regular_point(contact))
    return;
  if (options.compute_tangent && (sensitivity == nullptr || !sensitivity->valid)) {
    throw std::invalid_argument(
        "torsional_friction: the tangent needs the normal contact's SplineContactSensitivity "
        "(pass one to spline_contact); found " +
        std::string(sensitivity == nullptr ? "none" : "one not valid for this contact"));
  }
  const double ua = basis_A.local(contact.xi_A);
  const double ub = basis_B.local(contact.xi_B);
  if (options.compute_tangent)
    evaluate(angle_jet<18>(control_A, basis_A, ua, control_B, basis_B, ub), contact.point_force,
             sensitivity, history, law, out);
  else
    evaluate(angle_jet<0>(control_A, basis_A, ua, control_B, basis_B, ub), contact.point_force,
             sensitivity, history, law, out);
  // The all-angle contact's blend: s times the point's torque (bound, spring and tangent
  // included, as for the pointwise friction: friction.hpp); the twist slip is the point's.
  const double s = contact.point_share;
  if (s < 1.0) {
    if (options.compute_tangent) {
      out.tangent *= s;
      out.tangent.noalias() += out.residual * sensitivity->share.transpose();
    }
    out.residual *= s;
    out.torque *= s;
    out.dissipation *= s;
    out.energy *= s;
  }
}

} // namespace yarnsim::contact
