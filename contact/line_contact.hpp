#pragma once
// The all-angle beam contact (ABC) of Meier, Popp and Wall ("A unified approach for
// beam-to-beam contact", CMAME 315 (2017) 972-1010; the line part from "A finite element
// approach for the line-to-line contact interaction of thin beams with arbitrary orientation",
// CMAME 308 (2016) 377-413) on the C1 quadratic contact splines: a line-to-line penalty contact
// for small angles between the yarns, the point-to-point contact of spline_contact.hpp for
// large ones, and a smooth blend of the two between two angles.

#include "contact/interface_law.hpp"
#include "contact/spline_contact.hpp"
#include "contact/spline_curve.hpp"

#include <Eigen/Core>
#include <array>
#include <cstdint>

namespace yarnsim::contact {

/// Controls of the all-angle contact.
struct AllAngleOptions {
  /// Below this sine of the angle between the two curves' tangents, line contact alone
  /// (default sin 10 degrees).
  double line_sine = 0.17364817766693033;
  /// Above this sine, point contact alone (default sin 20 degrees); > line_sine.
  double point_sine = 0.3420201433256687;
  /// Gauss points on each slave (curve A) segment, 1 to 10.
  int gauss_points = 5;
  /// Line contact per unit length = the interface law times this (1/m): with a linear law of
  /// penalty eps (N/m), the line penalty is eps * line_scale (N/m^2). Must be > 0.
  double line_scale = 1.0;
};

/// Gauss-Legendre points `u` and weights `w` on a segment's local range [-1/2, 1/2] (weights
/// sum to 1); n in [1, kMaxGaussPoints].
struct GaussRule {
  int n = 0;
  std::array<double, kMaxGaussPoints> u{};
  std::array<double, kMaxGaussPoints> w{};
};
/// The rule of n points (n clamped to [1, kMaxGaussPoints]), by Newton's method on the Legendre
/// polynomial P_n (Abramowitz and Stegun 25.4.29; Tricomi's starting guesses), computed once
/// for every n on the first call.
const GaussRule& gauss_rule(int n);

/// The point contact's share s of a contact whose tangents make an angle of squared sine
/// `sine2`: 0 at or below line_sine, 1 at or above point_sine, and between them the quintic
/// smoothstep 6 q^5 - 15 q^4 + 10 q^3 of q = (sine2 - line_sine^2) / (point_sine^2 -
/// line_sine^2), so that s, ds and d2s are continuous (the tangent of the blended potential
/// holds ds and d2s). The line contact's share is 1 - s. `ds`, `d2s` (optional): derivatives
/// with respect to sine2.
double point_share(double sine2, const AllAngleOptions& options, double* ds = nullptr,
                   double* d2s = nullptr);

/// Outcome of the line part of one segment pair.
struct LineContactResult {
  int points = 0; ///< Gauss points of A owned by this pair (projection in B's range) and in contact
  /// Gauss points whose projection onto B did not converge (skipped), beside those that left
  /// B's neighbourhood (another pair's).
  int failed = 0;
  int owned = 0; ///< Gauss points of A owned by this pair, in contact or not
  /// Bit i: Gauss point i is among `points`; `u_B` its projection's local parameter on B.
  std::uint16_t mask = 0;
  std::array<double, kMaxGaussPoints> u_B{};
  double min_gap = 0.0;   ///< smallest effective gap of the owned points, m (infinite if none)
  double force = 0.0;     ///< sum over the points of weight * (1 - s) * line force, N
  double potential = 0.0; ///< J
  /// The deepest point in contact: its gap (m), curve points and normal (B to A).
  double gap = 0.0;
  Eigen::Vector3d point_A = Eigen::Vector3d::Zero();
  Eigen::Vector3d point_B = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  Eigen::Matrix<double, 18, 1> residual = Eigen::Matrix<double, 18, 1>::Zero();  ///< N
  Eigen::Matrix<double, 18, 18> tangent = Eigen::Matrix<double, 18, 18>::Zero(); ///< N/m
};

/// Line-to-line contact of segment `basis_A` of curve A (the slave) against segment `basis_B`
/// of curve B (the master), weighted by the line share 1 - s. Its potential is
///   sum_i w_i |C_A'(u_i)| (1 - s(sine2_i)) U(p_i) line_scale,
/// over A's Gauss points u_i (weights w_i on the segment's local range [-1/2, 1/2]), with
/// p_i = r_A + r_B - |C_A(u_i) - C_B(v_i)| and v_i the orthogonal projection of C_A(u_i) onto
/// B's curve (C_B'(v_i) . (C_A(u_i) - C_B(v_i)) = 0), sine2_i the squared sine between
/// C_A'(u_i) and C_B'(v_i), U the law's elastic potential (damping is not applied). A point
/// contributes to this pair only when v_i lies in B's segment (SegmentBasis::owns; within 1e-8
/// segments of an interior knot the side is decided by the sign of the projection residual at
/// the knot, from the two shared control points only, so the two pairs sharing the knot agree
/// bit for bit): a point whose projection leaves B's segment is the neighbouring pair's.
/// Residual = gradient and tangent = Hessian of the potential, including the dependence of
/// v_i and of the shares on the positions (exact second-order differentiation). Writes `out`
/// (residual and tangent zeroed first; the tangent only when options.compute_tangent); never
/// allocates.
void line_contact(const Eigen::Matrix3d& control_A, const SegmentBasis& basis_A, double radius_A,
                  const Eigen::Matrix3d& control_B, const SegmentBasis& basis_B, double radius_B,
                  const InterfaceLaw& law, const AllAngleOptions& all_angle, LineContactResult& out,
                  const SplineContactOptions& options = {});

/// The all-angle contact of one segment pair: s times the point contact of spline_contact (s
/// from the tangents at its closest points; evaluated only where the chords' sine is at least
/// half of line_sine, below which s is 0 for all but strongly curved segments) plus the line
/// contact above. Where s = 1 the result is spline_contact's, bit for bit. `out` holds the
/// sum: active when either part is, force and potential summed, gap, points and normal of the
/// point contact when it is active, otherwise of the deepest line point (or, with none in
/// contact, the smallest gap of the owned line points); xi and iterations of the point contact
/// (the start's xi when it was not evaluated); status the point contact's, or Converged where
/// it is not (OutOfRange, not evaluated) but the line part owns Gauss points.
/// `sensitivity` (optional) receives the point part's (spline_contact), valid where the point part
/// is active with a share s > 0 (with or without line points), with the share's gradient in
/// `share`; `point_active` and `point_force` hold the point part's state before the blend. `rates`
/// (optional) feeds the law's normal damping to the point part (the blend scales the damped force
/// by s; the line part is not damped). Never allocates.
void all_angle_contact(const Eigen::Matrix3d& control_A, const SegmentBasis& basis_A,
                       double radius_A, const Eigen::Matrix3d& control_B,
                       const SegmentBasis& basis_B, double radius_B, const ProjectionStart& start,
                       const InterfaceLaw& law, const AllAngleOptions& all_angle,
                       SplineContactResult& out, const SplineContactOptions& options = {},
                       SplineContactSensitivity* sensitivity = nullptr,
                       const PairRates* rates = nullptr);

} // namespace yarnsim::contact
