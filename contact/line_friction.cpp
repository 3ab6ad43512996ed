#include "contact/line_friction.hpp"

#include "contact/all_angle_jet.hpp"

#include <algorithm>
#include <cmath>

// Each quantity is a first-order jet of the 18 positions (value and gradient): the residual's
// entries come out with their rows of the tangent. Notation as in line_friction.hpp.

namespace yarnsim::contact {

namespace {

using J = JetT<0>;
using J3 = Jet3T<0>;

/// N_k(v) of segment `b` as a jet of the positions through the jet v.
J shape_jet(const SegmentBasis& b, int k, const J& v) {
  return apply(v, b.values_local(v.v)(k), b.first_local(v.v)(k), 0.0);
}

} // namespace

void line_friction(const Eigen::Matrix3d& control_A, const SegmentBasis& basis_A, double radius_A,
                   const Eigen::Matrix3d& control_B, const SegmentBasis& basis_B, double radius_B,
                   const InterfaceLaw& law, const AllAngleOptions& all_angle,
                   const SplineContactState& contact, std::uint16_t with_history,
                   const std::array<LineFrictionHistory, kMaxGaussPoints>& history,
                   const CoulombFriction& friction, LineFrictionResult& out,
                   const FrictionOptions& options) {
  out.mask = 0;
  out.residual.setZero();
  out.tangent.setZero();
  const std::uint16_t mask = contact.line_mask & with_history;
  if (mask == 0)
    return;
  const GaussRule& rule = gauss_rule(all_angle.gauss_points);
  const double reach = radius_A + radius_B;
  const double lambda = all_angle.line_scale;
  for (int i = 0; i < rule.n; ++i) {
    if (!(mask & (1u << i)))
      continue;
    const LineFrictionHistory& h = history[i];
    LineFrictionPoint& point = out.points[i];
    const J fixed(rule.u[i]);
    const J3 a = jet_point(control_A, basis_A, 0, fixed);
    const J3 ta = jet_tangent(control_A, basis_A, 0, fixed);
    const J v = point_projection_jet(a, control_B, basis_B, contact.line_u[i]);
    const J3 g = a - jet_point(control_B, basis_B, 3, v);
    const J3 tb = jet_tangent(control_B, basis_B, 3, v);
    const J p = J(reach) - sqrt(dot(g, g));
    const J f_line = apply(p, lambda * law.force(p.v, 0.0), lambda * law.stiffness(p.v, 0.0), 0.0);
    const J weight =
        (rule.w[i] * sqrt(dot(ta, ta))) * (J(1.0) - share_jet(sine2_of(ta, tb), all_angle));
    const J normal = weight * f_line;
    // Elastic tangential gap, local parameters (the anchor may lie in a neighbouring segment).
    const double anchor = basis_B.local(h.xi_B);
    const J delta = J(anchor) - v;
    const J3 g_t{{tb.c[0] * delta, tb.c[1] * delta, tb.c[2] * delta}};
    const double gap_norm = value(g_t).norm();
    const double mu = h.stuck ? friction.mu_s() : friction.mu_k();
    // Stick stiffness per unit length, N/m^2: lambda eps_t, or mu f / gamma with an elastic slip
    // (f = lambda f(p) the line force per unit length, CoulombFriction::stiffness).
    const double eps = friction.elastic_slip() > 0.0 ? friction.stiffness(mu, f_line.v)
                                                     : friction.eps_t() * lambda;
    const double phi = eps * gap_norm - mu * f_line.v; // N/m: K |g_t| - mu N over W
    const bool slip = slips(phi, mu * f_line.v, h.stuck);
    J3 f;
    point.history = h;
    point.history.stuck = !slip;
    point.slipping = slip;
    point.slip_increment = 0.0;
    point.dissipation = 0.0;
    if (slip) {
      // |g_t| > (1 - kOnCone) mu f / eps >= 0 here.
      const J scale = (mu * normal) * reciprocal(sqrt(dot(g_t, g_t)));
      for (int d = 0; d < 3; ++d)
        f.c[d] = scale * g_t.c[d];
      const double ratio = mu * f_line.v / (eps * gap_norm); // in [0, 1 + kOnCone)
      point.history.xi_B = basis_B.global(v.v + (anchor - v.v) * ratio);
      point.slip_increment = std::max(gap_norm - mu * f_line.v / eps, 0.0);
      point.dissipation = mu * normal.v * point.slip_increment;
    } else {
      // K = eps W; with the elastic slip mu N / gamma, a jet through N = W f.
      const J stiffness =
          friction.elastic_slip() > 0.0 ? friction.stiffness_rate(mu) * normal : eps * weight;
      for (int d = 0; d < 3; ++d)
        f.c[d] = stiffness * g_t.c[d];
    }
    point.normal_force = normal.v;
    point.force = value(f);
    const double k = eps * weight.v;
    point.energy = k > 0.0 ? point.force.squaredNorm() / (2.0 * k) : 0.0;
    out.mask |= static_cast<std::uint16_t>(1u << i);
    // residual: -N_A,k(u_i) f at A's control points, +N_B,k(v) f at B's.
    const Eigen::Vector3d na = basis_A.values_local(rule.u[i]);
    for (int c = 0; c < 3; ++c) {
      const J nb = shape_jet(basis_B, c, v);
      for (int d = 0; d < 3; ++d) {
        out.residual(3 * c + d) -= na(c) * f.c[d].v;
        const J rb = nb * f.c[d];
        out.residual(9 + 3 * c + d) += rb.v;
        if (options.compute_tangent) {
          out.tangent.row(3 * c + d) -= na(c) * f.c[d].g.transpose();
          out.tangent.row(9 + 3 * c + d) += rb.g.transpose();
        }
      }
    }
  }
}

} // namespace yarnsim::contact
