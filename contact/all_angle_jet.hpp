#pragma once
// Pieces of the all-angle contact (line_contact.hpp) as jets of the 18 positions
// (second_order_jet.hpp), shared by its line part (line_contact.cpp) and the line part's friction
// (line_friction.cpp): a Gauss point's projection onto the master curve, the squared sine between
// two tangents and the point share of the blend.

#include "contact/line_contact.hpp"
#include "contact/projection_jet.hpp"

namespace yarnsim::contact {

/// The local parameter v on segment `basis_B` (control points `control_B`, positions 9 to 17) of
/// the orthogonal projection of the point jet `a`, C_B,u(v) . (C_B(v) - a) = 0, as a jet of the
/// positions: two Newton steps from the converged value `v0` (projection_jet.hpp's argument: the
/// jet agrees with the implicit v(x) to second order).
template <int H>
JetT<H> point_projection_jet(const Jet3T<H>& a, const Eigen::Matrix3d& control_B,
                             const SegmentBasis& basis_B, double v0) {
  JetT<H> v(v0);
  for (int step = 0; step < 2; ++step) {
    const Jet3T<H> d = jet_point(control_B, basis_B, 3, v) - a;
    const Jet3T<H> t = jet_tangent(control_B, basis_B, 3, v);
    const Jet3T<H> k = jet_curvature(control_B, basis_B, 3, v);
    v = v - dot(t, d) / (dot(t, t) + dot(k, d));
  }
  return v;
}

/// Squared sine of the angle between t1 and t2.
template <int H>
JetT<H> sine2_of(const Jet3T<H>& t1, const Jet3T<H>& t2) {
  const JetT<H> c = dot(t1, t2);
  return JetT<H>(1.0) - (c * c) / (dot(t1, t1) * dot(t2, t2));
}

/// The point share s(sine2) of the blend (point_share) as a jet.
template <int H>
JetT<H> share_jet(const JetT<H>& sine2, const AllAngleOptions& opt) {
  double ds = 0.0, d2s = 0.0;
  const double s = point_share(sine2.v, opt, &ds, &d2s);
  return apply(sine2, s, ds, d2s);
}

} // namespace yarnsim::contact
