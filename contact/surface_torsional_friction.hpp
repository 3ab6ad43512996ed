#pragma once
// Torsional friction at a crossing of two yarns for the surface contact (formulation.md §6,
// "Surface contact friction"): the friction torque about the contact normal that resists the
// relative rotation of the two yarns about it, the law of the spline kernel
// (torsional_friction.hpp) carried over to the super-elliptical surfaces (surface_contact.hpp).
// The kernel of one contact point of an element pair, apart from the normal contact whose state
// it takes and from the pointwise friction (surface_friction.hpp), whose history it shares.
//
// Model. The crossing angle
//   theta = atan2(nu_B . (a x b), |nu_B| a . b),   a = Gamma_A,zeta, b = Gamma_B,zeta,
//   nu_B = s_B Gamma_B,theta x Gamma_B,zeta,
// at the contact points (zeta_A, theta_A), (zeta_B, theta_B), rad in (-pi, pi]: the angle from
// A's surface tangent along its axis to B's, about B's outward normal (s_B = +-1 turns
// Gamma_B,theta x Gamma_B,zeta outward; at a regular projection it is the contact normal n,
// pointing from B towards A). At a regular projection both tangent planes are orthogonal to n,
// so a and b lie in the contact plane and theta is the angle between the two yarns there, as
// the spline kernel's angle between the centre lines' tangents. Why these choices:
//  - the surface tangents along the axes carry the nodes' rotations (through the sections'
//    Q_k s(theta)), so theta sees a yarn's rotation about n whether it comes from the node
//    positions or from the Rodrigues DOFs;
//  - theta is objective: a rigid motion of the pair (triads turned with it) leaves the contact
//    coordinates alone and rotates a, b and nu_B together; a relative rotation of one yarn about
//    n changes theta by exactly that angle;
//  - B's normal nu_B, rather than g / |g| (g = Gamma_A - Gamma_B) as the spline kernel's n: the
//    surfaces' gap g vanishes as the contact closes, where g / |g| and its derivatives are
//    undefined; nu_B is smooth through closing and equals |nu_B| n at the projection.
// The elastic twist is dtheta = theta - theta^s (wrapped to (-pi, pi]), theta^s the anchor
// angle where the crossing stuck (SurfaceFrictionHistory::twist).
//
// Law: the spline kernel's elastic-plastic Coulomb law for a torque (Simo & Laursen 1992,
// penalty form), scaled by the share w of the contact this pair carries near a node
// (SurfaceContactResult::share), as surface_friction.hpp scales the pointwise law: penalty
// w k_r (k_r in N m/rad), bound mu f_n rho with f_n = w f the pair's normal force (rho in m),
//   trial m = w k_r dtheta, phi = |m| - mu f_n rho, mu = mu_s if the twist stuck in the last
//   committed state, else mu_k;
//   stick (phi <= 0): m = w k_r dtheta, the anchor kept;
//   slip  (phi > 0, or on the cone after a slip: slips() in friction.hpp):
//                     m = mu f_n rho sign(dtheta), theta^s <- theta - m / (w k_r), slip
//                     increment |dtheta| - mu f_n rho / (w k_r) (rad), dissipation |m| times it.
// The cone test k_r |dtheta| <= mu f rho does not depend on w, and two pairs sharing a contact
// carry k_r dtheta together; at w = 1 this is the spline kernel's law. Residual: m dtheta/dd
// (24 DOFs), the gradient of the stored energy m^2 / (2 w k_r) in stick at fixed w. Tangent:
//   m d2theta/dd2 + dtheta/dd (dm/dd)^T,
//   dm/dd = k_r (w dtheta/dd + dtheta dw/dd) (stick), mu rho sign(dtheta) df_n/dd (slip);
// symmetric in stick away from the end windows, not in slip.
//
// Derivatives. theta depends on the DOFs directly and through the contact coordinates
// c = (zeta_A, theta_A, zeta_B, theta_B)(d), so its Hessian needs the second derivatives of the
// projection. As in the spline kernel (projection_jet.hpp), theta is evaluated as a
// second-order jet of the 24 DOFs (second_order_jet.hpp) at c(d) given by two steps of a chord
// Newton iteration on the projection's equations started at the converged c0, with the
// converged Jacobian J0 = dr/dc held fixed:
//   r(c, d) = [Gamma_A,zeta . nu, Gamma_A,theta . nu, -Gamma_B,zeta . g, -Gamma_B,theta . g],
//   nu = Gamma_B,theta x Gamma_B,zeta, g = Gamma_A - Gamma_B
// (surface_contact's system: regular where the gap closes, unlike the Hessian of |g|^2 / 2).
// With e_k the error after k steps, e_0 = O(|dd|), and e_{k+1} = (I - J0^-1 J) e_k + O(e_k^2)
// with J - J0 = O(|dd|), so e_2 = O(|dd|^3) and the two-step map agrees with c(d) to second
// order at d0. J0 itself is the gradient of the same equations as a first-order jet of c. The
// surface jets need s(theta) to its third derivative (SuperEllipse::third_derivative) and
// Q(alpha) to second order (Q = I + g (A + A^2 / 2), A = skew(alpha), g = 4 / (4 + |alpha|^2),
// engine/math/rotation.hpp), both exact.
//
// Limitations: as the surface pointwise friction, only the regular path
// (SurfaceDegeneration::None): on the degenerate paths (Parallel, Flat*, Ridge*) the kernel
// reports no torsional friction (`active` false). A crossing that turns through 180 degrees
// within one increment would wrap. Cost: the 24 x 24 Hessians of the jets (the rotations' own
// 3 x 3 apart, no further sparsity exploited), about 80 us per active point and evaluation with
// the tangent (docs/performance.md, "Torsional friction on the surface contact").

#include "contact/friction.hpp" // FrictionOptions
#include "contact/superelliptical_cylinder.hpp"
#include "contact/surface_contact.hpp"
#include "contact/surface_friction.hpp"   // SurfaceFrictionHistory
#include "contact/torsional_friction.hpp" // TorsionalFriction, footprint_radius

#include <Eigen/Core>

namespace yarnsim::contact {

/// Crossing angle theta (see the file's comment) of the regular active surface contact
/// `contact` of the element surfaces `A` and `B` (surface_contact's result for them), rad in
/// (-pi, pi]: the anchor of a crossing that has just closed. Throws std::invalid_argument if the
/// contact is not active on the regular path.
double surface_crossing_angle(const SuperEllipticalCylinder& A, const SuperEllipticalCylinder& B,
                              const SurfaceContactState& contact);

/// Torsional friction state, residual and tangent of one surface contact point. The 24 DOFs
/// are those of SurfaceContactResult (per surface: node A and B translations, node A and B
/// Rodrigues increments).
struct SurfaceTorsionalFrictionResult {
  /// Evaluated: the normal contact is active on a regular projection. Otherwise every field
  /// below is zero and the history fields are the input's.
  bool active = false;
  bool slipping = false;      ///< the trial torque left the cone (slips())
  double mu = 0.0;            ///< the coefficient used, mu_s or mu_k
  double angle = 0.0;         ///< theta, rad
  double elastic_twist = 0.0; ///< trial dtheta = theta - theta^s, rad
  /// Friction torque m about n, N m (signed as dtheta; the share w included).
  double torque = 0.0;
  double slip_function = 0.0;  ///< trial phi = w k_r |dtheta| - mu f_n rho, N m
  double slip_increment = 0.0; ///< |dtheta| - mu f_n rho / (w k_r) when slipping, else 0, rad
  double dissipation = 0.0;    ///< |m| slip_increment, J
  double energy = 0.0;         ///< stored in the torsional spring, m^2 / (2 w k_r), J
  /// History to commit if this iterate is accepted: the anchor angle (kept in stick, returned
  /// onto the cone in slip), rad, and stuck = !slipping.
  double anchor = 0.0;
  bool stuck = true;
  /// Contribution to the internal force vector: m dtheta/dd (N for translations, N m per unit
  /// Rodrigues parameter).
  Eigen::Matrix<double, 24, 1> residual = Eigen::Matrix<double, 24, 1>::Zero();
  /// d(residual)/dd at fixed history (see the file's comment). Not symmetric in slip.
  Eigen::Matrix<double, 24, 24> tangent = Eigen::Matrix<double, 24, 24>::Zero();
};

/// Torsional friction of the contact point of the element surfaces `A` and `B` whose normal
/// contact is `contact` (surface_contact's result for the same configuration). `sensitivity`:
/// the SurfaceContactSensitivity surface_contact wrote for it, needed only for the tangent
/// (df_n/dd in slip, dw/dd in stick); may be null with `options.compute_tangent` false. The
/// history (`history.twist`, `history.twist_stuck`) is held fixed; the caller commits
/// `out.anchor`, `out.stuck` with a converged increment. Throws std::invalid_argument if the
/// tangent is asked for and `sensitivity` is null or not valid. Writes into `out`; never
/// allocates.
void surface_torsional_friction(const SuperEllipticalCylinder& A, const SuperEllipticalCylinder& B,
                                const SurfaceContactState& contact,
                                const SurfaceContactSensitivity* sensitivity,
                                const SurfaceFrictionHistory& history, const TorsionalFriction& law,
                                SurfaceTorsionalFrictionResult& out,
                                const FrictionOptions& options = {});

} // namespace yarnsim::contact
