#pragma once
// Torsional friction at a crossing of two yarns (issue "Friction between yarns", item 3): a
// friction torque about the contact normal that resists the relative rotation of the two yarns
// about it, the rotation that dominates at the crossings of a sheared fabric and that pointwise
// friction (friction.hpp) does not see. The kernel of one contact point of the spline contact,
// apart from the normal contact (spline_contact.hpp) whose state it takes.
//
// Model. The spline carries translations only, so the yarns' rotation about the normal is read
// from their tangents: the crossing angle
//   theta = atan2(n . (a x b), a . b),   a = C_A'(xi_A), b = C_B'(xi_B), n = (C_A - C_B) / |.|,
// the angle from A's tangent to B's about n (rad, in (-pi, pi]). At a projection a and b are
// orthogonal to n, so theta is the angle between the two yarns in the contact plane; it is
// unchanged by rigid motions of the pair and changes by exactly the relative rotation of the two
// yarns about n. The history is the anchor angle theta^s where the crossing stuck; the elastic
// twist is dtheta = theta - theta^s (wrapped to (-pi, pi]).
//
// Law: the same elastic-plastic Coulomb law as pointwise friction (Simo & Laursen 1992, penalty
// form), for a torque: trial m = k_r dtheta (k_r the torsional penalty, N m/rad), slip function
// phi = |m| - mu f_n rho (rho the effective contact radius, m), mu = mu_s if the crossing stuck
// in the last committed state, else mu_k.
//   stick (phi <= 0): m = k_r dtheta, the anchor kept;
//   slip  (phi > 0, or on the cone after a slip: slips() in friction.hpp):
//                     m = mu f_n rho sign(dtheta), theta^s <- theta - m / k_r,
//                     slip increment |dtheta| - mu f_n rho / k_r (rad), dissipation m times it.
// Unlike the pointwise force, the torque enters as the variation of the angle: the residual is
// m dtheta/dx, the gradient of the stored energy m^2 / (2 k_r) in stick (exactly conservative),
// and carries no net force or moment about any point but the torque m about n (theta being
// invariant under rigid motions). The tangent, m d2theta/dx2 + dtheta/dx (dm/dx)^T with
// dm/dx = k_r dtheta/dx (stick) or mu rho sign(dtheta) df_n/dx (slip), holds the second
// derivatives of the projection (xi_A, xi_B)(x): theta is differentiated as a second-order jet
// of the positions through two Newton steps of the projection (projection_jet.hpp). It is
// symmetric in stick, not in slip.
//
// Defaults (documented in docs/input.md): rho, the mean distance from its centre of the
// footprint of the crossing, taken as a rectangle of the two yarns' widths; k_r = eps_t rho^2
// (eps_t the tangential penalty, N/m), so that a twist stiffens like a ring of the pointwise
// law's springs at radius rho and slips at the twist where such a ring slips; with an elastic
// slip gamma, k_r = mu f_n rho^2 / gamma for the same reason (TorsionalFriction).
//
// In the all-angle contact's blend (line_contact.hpp) the torque is the point part's share s of
// the above (bound, spring and dissipation; the tangent gains r (ds/dx)^T), f_n the point part's
// own force, as for the pointwise friction (friction.hpp).
//
// Limitations: as for pointwise friction, only regular point projections (not the degenerate
// path of nearly parallel yarns; the line contact's yarns side by side have no crossing angle); a
// crossing that turns through 180 degrees within one increment would wrap.

#include "contact/friction.hpp"
#include "contact/spline_contact.hpp"
#include "contact/spline_curve.hpp"

#include <Eigen/Core>

namespace yarnsim::contact {

/// Coefficients of the torsional law.
///
/// With an elastic slip gamma (friction.hpp, CoulombFriction) the torsional stiffness follows
/// the normal force as the pointwise one does: k_r(f_n) = mu f_n rho^2 / gamma, the stiffness of
/// a ring of the pointwise law's springs at radius rho, so that the twist slips at gamma / rho
/// whatever the normal force; in stick dm/dx gains (mu rho^2 / gamma) dtheta df_n/dx.
class TorsionalFriction {
public:
  /// mu_s, mu_k: static and kinetic coefficients (dimensionless, those of the pointwise law);
  /// k_r: torsional penalty, N m/rad (unused with an elastic slip); rho: effective contact
  /// radius, m; elastic_slip: gamma, m, 0 for the constant penalty. Throws
  /// std::invalid_argument unless 0 <= mu_k <= mu_s, rho > 0, and k_r > 0 or elastic_slip > 0
  /// with the other >= 0, all finite.
  TorsionalFriction(double mu_s, double mu_k, double k_r, double rho, double elastic_slip = 0.0);

  double mu_s() const { return mu_s_; }
  double mu_k() const { return mu_k_; }
  double k_r() const { return k_r_; }
  double rho() const { return rho_; }
  double elastic_slip() const { return elastic_slip_; }
  /// The torsional stiffness at coefficient mu and normal force f_n (N), N m/rad: k_r, or
  /// mu f_n rho^2 / gamma.
  double stiffness(double mu, double f_n) const {
    return elastic_slip_ > 0.0 ? stiffness_rate(mu) * f_n : k_r_;
  }
  /// d stiffness / d f_n, m/rad: 0, or mu rho^2 / gamma.
  double stiffness_rate(double mu) const {
    return elastic_slip_ > 0.0 ? mu * rho_ * rho_ / elastic_slip_ : 0.0;
  }

private:
  double mu_s_;
  double mu_k_;
  double k_r_;
  double rho_;
  double elastic_slip_;
};

/// Mean distance from the centre of a rectangle of sides `width_A` and `width_B` (metres): the
/// default effective contact radius of a crossing of yarns of those widths (uniform pressure on
/// the footprint), m. For a square of side w: w (sqrt 2 + ln(1 + sqrt 2)) / 6 = 0.383 w.
double footprint_radius(double width_A, double width_B);

/// The torsional law of a crossing of yarns of widths `width_A`, `width_B` (m) from a contact's
/// settings: rho = `radius` (m), or footprint_radius(width_A, width_B) where it is 0; k_r =
/// `penalty` (N m/rad), or where it is 0 eps_t rho^2 (eps_t the tangential penalty, N/m) or,
/// with an `elastic_slip` gamma > 0 (m), mu f_n rho^2 / gamma. The defaults of docs/input.md, for
/// both contact formulations and the explicit stable step.
TorsionalFriction torsional_law(double mu_s, double mu_k, double eps_t, double radius,
                                double penalty, double width_A, double width_B,
                                double elastic_slip = 0.0);

/// Crossing angle theta (see the file's comment) of the point contact `contact` (regular and
/// active, on the segments `basis_A`, `basis_B` with control points `control_A`, `control_B`),
/// rad in (-pi, pi]: the anchor of a crossing that has just closed.
double crossing_angle(const Eigen::Matrix3d& control_A, const SegmentBasis& basis_A,
                      const Eigen::Matrix3d& control_B, const SegmentBasis& basis_B,
                      const SplineContactState& contact);

/// The law of the file's comment for one crossing, the scalars both contact formulations share
/// (surface_torsional_friction.hpp scales the penalty by its share).
struct TwistReturn {
  double mu = 0.0;             ///< mu_s if the twist stuck in the committed state, else mu_k
  double twist = 0.0;          ///< trial dtheta = theta - theta^s, wrapped to (-pi, pi], rad
  double limit = 0.0;          ///< mu f_n rho, N m
  double slip_function = 0.0;  ///< k |dtheta| - mu f_n rho, N m
  bool slipping = false;       ///< slips(slip_function, limit, stuck)
  double torque = 0.0;         ///< m, N m
  double anchor = 0.0;         ///< theta^s to commit (returned onto the cone in slip), rad
  double slip_increment = 0.0; ///< |dtheta| - limit / k in slip, rad
  double dissipation = 0.0;    ///< limit times the slip increment, J
  double energy = 0.0;         ///< m^2 / (2 k), J
};

/// The return mapping of the crossing angle `theta` (rad) against the committed anchor
/// `anchor` (rad) and stick flag `stuck`: penalty k (N m/rad, >= 0; 0 with no normal force under
/// an elastic slip), normal force f_n (N), the coefficients and rho of `law`.
TwistReturn twist_return(double theta, double anchor, bool stuck, double k, double f_n,
                         const TorsionalFriction& law);

/// Copies the law's scalars of `r` and the angle `theta` (rad) into a kernel's result `out`
/// (TorsionalFrictionResult, SurfaceTorsionalFrictionResult: the same fields) and marks it
/// active.
template <class Result>
void set_twist_result(const TwistReturn& r, double theta, Result& out) {
  out.active = true;
  out.mu = r.mu;
  out.angle = theta;
  out.elastic_twist = r.twist;
  out.slip_function = r.slip_function;
  out.slipping = r.slipping;
  out.stuck = !r.slipping;
  out.anchor = r.anchor;
  out.slip_increment = r.slip_increment;
  out.dissipation = r.dissipation;
  out.torque = r.torque;
  out.energy = r.energy;
}

/// Torsional friction state, residual and tangent of one crossing. The 18 DOFs are those of
/// SplineContactResult (A's three control points, then B's, each x, y, z).
struct TorsionalFrictionResult {
  /// Evaluated: the normal contact is active on a regular point projection. Otherwise every
  /// field below is zero and the history fields are the input's.
  bool active = false;
  bool slipping = false;      ///< the trial torque left the cone (slips())
  double mu = 0.0;            ///< the coefficient used, mu_s or mu_k
  double angle = 0.0;         ///< theta, rad
  double elastic_twist = 0.0; ///< trial dtheta = theta - theta^s, rad
  /// Friction torque m about n, N m (signed as dtheta): the torque the crossing's stick spring
  /// holds, resisting the twist.
  double torque = 0.0;
  double slip_function = 0.0;  ///< trial phi = k_r |dtheta| - mu f_n rho, N m
  double slip_increment = 0.0; ///< |dtheta| - mu f_n rho / k_r when slipping, else 0, rad
  double dissipation = 0.0;    ///< |m| slip_increment, J
  double energy = 0.0;         ///< stored in the torsional spring, m^2 / (2 k_r), J
  /// History to commit if this iterate is accepted: the anchor angle (kept in stick, returned
  /// onto the cone in slip) and stuck = !slipping.
  double anchor = 0.0;
  bool stuck = true;
  /// Contribution to the internal force vector, N: m dtheta/dx.
  Eigen::Matrix<double, 18, 1> residual = Eigen::Matrix<double, 18, 1>::Zero();
  /// d(residual)/dx at fixed history, N/m (see the file's comment).
  Eigen::Matrix<double, 18, 18> tangent = Eigen::Matrix<double, 18, 18>::Zero();
};

/// Torsional friction of the crossing of the segment pair (`control_A`, `basis_A`),
/// (`control_B`, `basis_B`) whose normal contact is `contact` (spline_contact's result for the
/// same positions). `sensitivity`: spline_contact's for it, needed only for the tangent in slip
/// (df_n/dx); may be null with `options.compute_tangent` false. The history (`history.twist`,
/// `history.twist_stuck`) is held fixed; the caller commits `out.anchor`, `out.stuck` with a
/// converged increment. Throws std::invalid_argument if the tangent is asked for and
/// `sensitivity` is null or not valid for an active regular contact. Writes into `out`; never
/// allocates.
void torsional_friction(const Eigen::Matrix3d& control_A, const SegmentBasis& basis_A,
                        const Eigen::Matrix3d& control_B, const SegmentBasis& basis_B,
                        const SplineContactState& contact,
                        const SplineContactSensitivity* sensitivity, const FrictionHistory& history,
                        const TorsionalFriction& law, TorsionalFrictionResult& out,
                        const FrictionOptions& options = {});

} // namespace yarnsim::contact
