#pragma once
// Pointwise Coulomb friction of surface-to-surface contact (formulation.md §5 and §6): the kernel
// of one contact point of an element pair, apart from the normal contact (surface_contact.hpp)
// whose state it takes. It carries the spline kernel's law (friction.hpp) over to the
// super-elliptical surfaces.
//
// Model: penalty-regularised (elastic-plastic) Coulomb friction of a point contact between two
// beam surfaces: a tangential penalty, a stick predictor and a slip corrector, with the
// tangential relative displacement measured through the convective coordinates of the contact
// points (Wriggers & Zavarise 1997, "On contact between three-dimensional beams undergoing large
// deflections"); the gap measured from the material points where the contact stuck, and static
// and dynamic coefficients (Gay Neto, Pimenta & Wriggers 2016, "A master-surface to
// master-surface formulation for beam to beam contact. Part II: Frictional interaction"). The
// slip corrector is the radial return of Simo & Laursen 1992 ("An augmented Lagrangian treatment
// of contact problems involving friction", penalty form), with its consistent linearisation.
// The formulas below are this file's own derivation in surface_contact.cpp's notation; no
// equation is taken over by number.
//
// History ("anchor"): the convective coordinates c^s = (zeta_A^s, theta_A^s, zeta_B^s,
// theta_B^s) of the material points of the two surfaces where the point stuck, and whether the
// point stuck in the last committed state. Convective coordinates are material coordinates of
// the surfaces, so the anchor moves with the yarns; zeta^s may lie beyond the element's range
// [-1, 1] (the anchor in the neighbouring element: only the coordinate differences enter, and
// the surface's polynomial is evaluated at the current point only).
//
// Elastic tangential gap (trial), with the current tangents at the current projection:
//   g_t = Gamma_A,c (c_A - c_A^s) - Gamma_B,c (c_B - c_B^s)                              [m]
// Gamma_X,c = [Gamma_X,zeta  Gamma_X,theta] (3 x 2) at the current contact point, c_X = (zeta_X,
// theta_X), the theta differences wrapped to (-pi, pi]. In surface_contact.cpp's notation,
// g_t = sum_i g_i Delta_i with g_i = dg/dc_i (g = Gamma_A - Gamma_B) and Delta = c - c^s. It is
// the first-order relative displacement of the anchor's material points with respect to the
// contact points (A minus B). At a converged regular projection both surfaces' tangent planes
// are orthogonal to n, so g_t is. It is objective: a rigid motion of a stuck pair (nodal triads
// turned with it) leaves the coordinates alone and rotates the tangents, so it rotates g_t and
// leaves |g_t| unchanged. It is linear in the coordinate differences, so the return mapping is
// exact: scaling all four differences by one factor scales g_t by it. After a converged step the
// anchor is never farther than the cone's radius mu f / eps_t (metres) from the contact point,
// so the linearisation of Gamma(c) - Gamma(c^s) is accurate.
//
// Share: near a node between two elements of a yarn both elements' pairs hold the contact, each
// carrying its share w of the normal force (SurfaceContactResult::share, f_n = w f). Each pair
// carries the same share of the friction of the whole contact: its tangential penalty is
// w eps_t, so the cone test eps_t |g_t| <= mu f does not depend on w, and two pairs holding the
// same material points (their own anchors) carry eps_t g_t together. At w = 1 this is exactly
// the spline kernel's law.
//
// Law (Simo & Laursen 1992, penalty form): f_tr = w eps_t g_t, phi = |f_tr| - mu f_n, with
// mu = mu_s if the point stuck in the last committed state, else mu_k. With an elastic slip
// gamma (friction.hpp, CoulombFriction::stiffness) w eps_t reads mu f_n / gamma throughout: the
// share enters through f_n = w f, the cone's radius is gamma, and in stick df/dd gains
// (mu / gamma) g_t (df_n/dd)^T in place of the share's eps_t g_t (dw/dd)^T.
//   stick (phi <= 0): f = f_tr, the anchor is kept;
//   slip  (phi > 0, or on the cone to kOnCone after a slip: slips() in friction.hpp):
//                     f = mu f_n g_t / |g_t|, the anchor is pulled onto the cone,
//                     c^s <- c - (c - c^s) mu f_n / (w eps_t |g_t|) (all four coordinates, theta
//                     differences wrapped), and the slip increment is |g_t| - mu f_n / (w eps_t).
// The coefficient is chosen from the committed state, not switched within a step, as in the
// spline kernel (the static-to-kinetic drop lags one step).
//
// Force and sign: f acts on A at Gamma_A and -f on B at Gamma_B, as generalized forces through
// the Jacobians of Gamma_A and Gamma_B with respect to the DOFs at fixed c (translations and
// Rodrigues increments, as the normal contact's G = dg/dd): the residual (contribution to the
// internal forces, as in surface_contact and spline_friction) is
//   residual = -(dGamma_A/dd)^T f + (dGamma_B/dd)^T f = -G^T f.
// Dragging A along +x over B moves A's anchor point ahead (+x) of the contact point: g_t points
// -x and so does the force on A, which opposes the sliding of A relative to B. Unlike the spline
// kernel, the surface points carry the force's moment about the nodes (through the Rodrigues
// DOFs), so no couple is dropped.
//
// Tangential damping (optional, c_t >= 0, with SurfacePairRates): as the spline kernel's, a
// dashpot in parallel with the Coulomb element on the relative tangential velocity of the
// contact points at fixed coordinates, v_t = (I - n n^T) G v (v the 24 DOF rates), with the
// share: f = f_c - w c_t v_t (two pairs sharing a contact damp with c_t together). It is not
// limited by the cone. Its tangent holds dv/dd = velocity_per_displacement I, the DOF
// derivatives of G v at fixed c (weighted_hessian, d_zeta_jacobian, d_theta_jacobian), those
// through dc/dd, the normal's through B's outward normal Gamma_B,theta x Gamma_B,zeta, and the
// share's. The engine does not feed the surface contact rates in this version (ContactRates
// carry no rotation rates), so the decks refuse tangential_damping on surface contacts.
//
// Limitations. The kernel
// evaluates friction only for an active regular projection (SurfaceDegeneration::None): on the
// degenerate paths (Parallel, Flat*, Ridge*) surface_contact gives no sensitivity and the kernel
// reports no friction (`active` false); those are left for later. The tangent's dc/dd is
// -H^-1 D with H the Hessian of |g|^2 / 2, which turns singular as the gap closes (the surfaces
// can slide together at no cost to second order): checked against central differences from
// 1e-10 m to 0.2 mm of penetration at the study's scales; at exact touching it is undefined.
// Two pairs sharing a contact in an end window keep separate anchors: a pair that starts to hold
// a contact anchors at first touch (its share rises from 0, so its force does).

#include "contact/friction.hpp" // CoulombFriction, FrictionOptions
#include "contact/superelliptical_cylinder.hpp"
#include "contact/surface_contact.hpp"

#include <Eigen/Core>

namespace yarnsim::contact {

/// History of one surface contact point: the anchor and the stick flag of the last committed
/// state.
struct SurfaceFrictionHistory {
  double zeta_A = 0.0;  ///< convective coordinates on A of the material point where it stuck
  double theta_A = 0.0; ///< radians
  double zeta_B = 0.0;  ///< the same on B
  double theta_B = 0.0;
  bool stuck = true; ///< stuck in the last committed state: mu_s applies, else mu_k
  /// Torsional friction (surface_torsional_friction.hpp): the anchor crossing angle, rad, and
  /// whether the crossing's twist stuck in the last committed state. Set by the caller where
  /// torsional friction applies (surface_crossing_angle at first touch).
  double twist = 0.0;
  bool twist_stuck = true;
};

/// The history of a contact point that has just closed: anchored where it touched, stuck (the
/// twist anchor, where torsional friction applies, is set by the caller: surface_crossing_angle).
inline SurfaceFrictionHistory first_touch(const SurfaceContactState& contact) {
  return {contact.zeta_A, contact.theta_A, contact.zeta_B, contact.theta_B, true};
}

/// Friction state of one surface contact point (SurfaceFrictionResult adds the residual and
/// tangent; a contact set keeps those of its active points alone).
struct SurfaceFrictionState {
  /// Evaluated: the normal contact is active on a regular projection. Otherwise every field
  /// below is zero, and `history` is the input's.
  bool active = false;
  bool slipping = false;  ///< the trial force left the cone (slips(): phi > 0, or on it after slip)
  double mu = 0.0;        ///< the coefficient used, mu_s or mu_k
  double stiffness = 0.0; ///< the stick stiffness used, N/m: w eps_t, or mu f_n / gamma
  Eigen::Vector3d elastic_gap = Eigen::Vector3d::Zero(); ///< trial g_t, metres
  /// v_t, m/s; zero without SurfacePairRates or damping (see the file's comment).
  Eigen::Vector3d sliding_velocity = Eigen::Vector3d::Zero();
  /// Friction force on A at its contact point (on B: the opposite), N: f_c - w c_t v_t.
  Eigen::Vector3d force = Eigen::Vector3d::Zero();
  double slip_function = 0.0;  ///< trial phi = w eps_t |g_t| - mu f_n, N
  double slip_increment = 0.0; ///< |g_t| - mu f_n / (w eps_t) when slipping, else 0, metres
  /// Energy the slip dissipates, the force on the cone times the slip: mu f_n slip_increment, J.
  double dissipation = 0.0;
  /// The history to commit if this iterate is accepted: the anchor (kept in stick, returned
  /// onto the cone in slip; thetas in [0, 2 pi)) and stuck = !slipping.
  SurfaceFrictionHistory history;
};

/// Friction state, residual and tangent of one surface contact point. The 24 DOFs are those of
/// SurfaceContactResult (per surface: node A and B translations, node A and B Rodrigues
/// increments).
struct SurfaceFrictionResult : SurfaceFrictionState {
  /// Contribution to the internal force vector: -G^T f (N for translations, N m per unit
  /// Rodrigues parameter), see the file's comment.
  Eigen::Matrix<double, 24, 1> residual = Eigen::Matrix<double, 24, 1>::Zero();
  /// d(residual)/dd at fixed history, including the dependence of c on d, of the tangents
  /// Gamma_,c and of the Jacobians dGamma/dd on d and c, of f_n (slip) and of the share (stick).
  /// Not symmetric: a model with friction needs an LU factorisation of the global tangent.
  Eigen::Matrix<double, 24, 24> tangent = Eigen::Matrix<double, 24, 24>::Zero();
};

/// Coulomb friction of the contact point of the element surfaces `A` and `B`, whose normal
/// contact is `contact`: the result of surface_contact for the same configuration.
/// `sensitivity` is the SurfaceContactSensitivity surface_contact wrote for it; it is needed
/// only for the tangent (nullptr with `options.compute_tangent` false). `history` is held fixed:
/// the caller commits `out.history` with a converged increment. `rates` (optional; the same as
/// surface_contact's, if the normal law damps) feed the tangential damping.
///
/// With G = dg/dd, J_i = dg_i/dd (both at fixed c), Delta = c - c^s, C = dc/dd (sensitivity),
///   dg_t/dd = sum_i Delta_i J_i + (g_c + K) C,   g_c = [g_1 .. g_4],
///             K_k = sum_i Delta_i d2g/dc_i dc_k (same surface only),
///   stick: df/dd = eps_t (g_t grad w^T + w dg_t/dd),
///   slip:  df/dd = mu t (df_n/dd)^T + mu f_n / |g_t| (I - t t^T) dg_t/dd,   t = g_t / |g_t|,
///   damped: df/dd -= c_t (w dv_t/dd + v_t (dw/dd)^T) (see the file's comment),
///   tangent = -G^T df/dd - d2(f . g)/dd2 |_(c, f fixed) - M(f)^T C,   M(f)_i = f^T J_i.
/// Throws std::invalid_argument if the tangent is asked for and `sensitivity` is null or not
/// valid. Writes into `out`; never allocates.
void surface_friction(const SuperEllipticalCylinder& A, const SuperEllipticalCylinder& B,
                      const SurfaceContactState& contact,
                      const SurfaceContactSensitivity* sensitivity,
                      const SurfaceFrictionHistory& history, const CoulombFriction& law,
                      SurfaceFrictionResult& out, const FrictionOptions& options = {},
                      const SurfacePairRates* rates = nullptr);

} // namespace yarnsim::contact
