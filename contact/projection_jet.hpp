#pragma once
// The closest points of a segment pair of the C1 quadratic contact splines, and the curves'
// points and tangents there, as second-order jets of the 18 positions (second_order_jet.hpp):
// shared by the kernels whose energy depends on the projection through more than the distance
// (the all-angle contact's point share, line_contact.cpp; the torsional friction at crossings,
// torsional_friction.cpp).
//
// The closest points (u_A, u_B)(x) are implicit functions of the positions x. Their first and
// second derivatives at x0 are those of two Newton steps on r = [C_A,u . g, -C_B,u . g] started at
// the converged value c0 = c(x0) (held fixed) and carried out on jets of x: with e_k the error
// after k steps, e_0 = O(|dx|), e_1 = O(e_0^2), e_2 = O(|dx|^4), so the two-step map agrees with
// c(x) to second order at x0 (to the projection's tolerance).

#include "contact/second_order_jet.hpp"
#include "contact/spline_curve.hpp"

#include <Eigen/Core>

namespace yarnsim::contact {

/// C(u) of segment `b` (control points `x`, columns, metres; positions 3 first ... 3 first + 8 of
/// the 18, first = 0 for curve A, 3 for B) at the local parameter jet u, metres.
template <int H>
Jet3T<H> jet_point(const Eigen::Matrix3d& x, const SegmentBasis& b, int first, const JetT<H>& u) {
  return curve_jet(x, first, u, b.values_local(u.v), b.first_local(u.v), b.second_local());
}
/// C_u(u), metres per unit of u.
template <int H>
Jet3T<H> jet_tangent(const Eigen::Matrix3d& x, const SegmentBasis& b, int first, const JetT<H>& u) {
  return curve_jet(x, first, u, b.first_local(u.v), b.second_local(), Eigen::Vector3d::Zero());
}
/// C_uu (constant on a segment: quadratic splines), metres per unit of u squared.
template <int H>
Jet3T<H> jet_curvature(const Eigen::Matrix3d& x, const SegmentBasis& b, int first,
                       const JetT<H>& u) {
  return curve_jet(x, first, u, b.second_local(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
}

/// The closest points' local parameters (u_A, u_B) as jets of the positions: two Newton steps on
/// r = [C_A,u . g, -C_B,u . g], g = C_A - C_B, from their converged values `ua`, `ub`.
template <int H>
void closest_point_jets(const Eigen::Matrix3d& control_A, const SegmentBasis& basis_A, double ua,
                        const Eigen::Matrix3d& control_B, const SegmentBasis& basis_B, double ub,
                        JetT<H>& jua, JetT<H>& jub) {
  using J = JetT<H>;
  jua = J(ua);
  jub = J(ub);
  for (int step = 0; step < 2; ++step) {
    const Jet3T<H> g =
        jet_point(control_A, basis_A, 0, jua) - jet_point(control_B, basis_B, 3, jub);
    const Jet3T<H> ta = jet_tangent(control_A, basis_A, 0, jua);
    const Jet3T<H> tb = jet_tangent(control_B, basis_B, 3, jub);
    const J r0 = dot(ta, g);
    const J r1 = -dot(tb, g);
    const J h00 = dot(ta, ta) + dot(jet_curvature(control_A, basis_A, 0, jua), g);
    const J h01 = -dot(ta, tb);
    const J h11 = dot(tb, tb) - dot(jet_curvature(control_B, basis_B, 3, jub), g);
    const J inv = reciprocal(h00 * h11 - h01 * h01);
    const J da = inv * (h11 * r0 - h01 * r1);
    const J db = inv * (h00 * r1 - h01 * r0);
    jua = jua - da;
    jub = jub - db;
  }
}

} // namespace yarnsim::contact
