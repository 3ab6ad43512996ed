#pragma once
// Pointwise Coulomb friction of beam-to-beam spline contact (formulation.md §5): the kernel of
// one contact point, apart from the normal contact (spline_contact.hpp) whose state it takes.
//
// Model: penalty-regularised (elastic-plastic) Coulomb friction of a point contact between two
// beams: a tangential penalty, a stick predictor and a slip corrector, with the tangential
// relative displacement measured through the convective coordinates of the contact points
// (Wriggers & Zavarise 1997, "On contact between three-dimensional beams undergoing large
// deflections"); the gap measured from the material points where the contact stuck, and static
// and dynamic coefficients (Gay Neto, Pimenta & Wriggers 2016, "A master-surface to
// master-surface formulation for beam to beam contact. Part II: Frictional interaction"). The
// slip corrector is the radial return of Simo & Laursen 1992 ("An augmented Lagrangian treatment
// of contact problems involving friction", penalty form), with its consistent linearisation.
// The formulas below are this file's own derivation in the spline kernel's notation; no
// equation is taken over by number.
//
// History ("anchor"): the global parameters (xi_A^s, xi_B^s) of the material points of the two
// centre lines where the point stuck, and whether the point stuck in the last committed state.
// Global parameters are material coordinates of the centre lines, so the anchor moves with the
// yarns, and it may lie in another segment than the current contact point (no hand-over at a
// knot: the curves are C1 and only the parameter differences enter).
//
// Elastic tangential gap (trial), with the current tangents at the current projection:
//   g_t = C_A'(xi_A) (xi_A - xi_A^s) - C_B'(xi_B) (xi_B - xi_B^s)                      [m]
// the first-order relative displacement of the anchor's material points with respect to the
// contact points (A minus B). At a converged projection C_A'.g = C_B'.g = 0, so g_t is
// orthogonal to n. It is objective: a rigid motion of a stuck pair leaves the parameters alone
// and rotates the tangents, so it rotates g_t and leaves |g_t| and the force's magnitude
// unchanged. It is linear in the parameter differences, so the return mapping is exact: scaling
// both differences by one factor scales g_t by it. After a converged step the anchor is never
// farther than the cone's radius mu f_n / eps_t (metres along the tangents) from the contact
// point, so the linearisation of C(xi) - C(xi^s) is accurate.
//
// Law (Simo & Laursen 1992, penalty form): f_tr = eps_t g_t, phi = |f_tr| - mu f_n, with
// mu = mu_s if the point stuck in the last committed state, else mu_k, and eps_t the law's
// constant penalty or, with an elastic slip gamma, mu f_n / gamma (CoulombFriction::stiffness:
// the cone's radius in displacement is then gamma; in stick df/dx gains (mu / gamma) g_t
// (df_n/dx)^T).
//   stick (phi <= 0): f_c = f_tr, the anchor is kept;
//   slip  (phi > 0, or phi > -kOnCone mu f_n for a point that slipped in the committed state:
//         slips() below): f_c = mu f_n g_t / |g_t|, the anchor is pulled onto the cone,
//                     xi^s <- xi - (xi - xi^s) mu f_n / (eps_t |g_t|) on both curves, and the
//                     slip increment is |g_t| - mu f_n / eps_t.
// The coefficient is chosen from the committed state, not switched within a step, so the force
// is a continuous function of the positions during a Newton solve: the step in which a stuck
// point breaks loose carries mu_s f_n, and the following steps (history committed as slipping)
// carry mu_k f_n. The static-to-kinetic drop thus lags one step.
//
// Tangential damping (optional, c_t >= 0): a dashpot in parallel with the Coulomb element on the
// relative tangential velocity of the contact points, v_t = (I - n n^T) (v_A(xi_A) - v_B(xi_B))
// at fixed parameters; f = f_c - c_t v_t (on A, opposing A's sliding relative to B, as f_c does).
// It is not limited by the cone (like the normal law's
// damping, which adds to f_n), so the force stays continuous through stick-slip switches; it
// enters the tangent through PairRates::velocity_per_displacement as the normal damping does.
//
// Force and sign: f is the force on A (on B: the opposite). Dragging A along +x over B moves A's
// anchor point ahead (+x) of the contact point: g_t points -x and so does the force on A, which
// opposes the sliding of A relative to B.
//
// Force and work (FrictionForce). Two ways carry f to the positions (residual: the contribution
// to the internal forces, as in spline_contact):
//   at the contact points: f at C_A and -f at C_B, residual = -kron(w, f), w = [N_A; -N_B];
//   conjugate to the gap:  residual = (dg_t/dx)^T f.
// The second does work on the elastic gap it is computed from: in stick with a constant penalty
// it is the gradient of the stored energy eps_t |g_t|^2 / 2, in slip its work on the slip is the
// dissipation mu f_n |dg_t|, and as g_t is objective it has no resultant and, f parallel to g_t
// (no damping), no moment. To leading order in the anchor's distance, dg_t = C_A,u du_A -
// C_B,u du_B = -(I - n n^T) G dx + |g| dn, G = kron(w^T, I3): the point forces plus
// |g| (dn/dx)^T f, forces through the turning of the normal that balance the point forces'
// couple g x f (|g| ~ r_A + r_B). The point forces' work differs from f . dg_t by f . |g| dn:
// where crimped yarns roll over each other the explicit path's energy balance failed with them
// (formulation.md, "Friction on the explicit path"). On each yarn the two have the same
// resultant; they differ by that couple, which the conjugate force puts where the translations
// can carry it (on straight yarns crossing at right angles, with f along A: all of it in A's
// bending, as B could take its share only as torsion), and they do the same work on motions
// that do not turn the normal.
//
// Limitations. The spline carries translations only, so the moments r_A n x f and r_B n x f of
// the force at the yarns' surfaces about their centre lines are either dropped (point forces) or
// carried by translations through dn/dx, spread over the two segments' control points, which
// asks for bending stiffness where the contact conforms (a flexible yarn wrapped over a pin:
// 1 - kappa |g| -> 0 makes dxi/dx large). Moments on the nodes' rotations, as the surface
// contact's friction has, would carry them as they are. The kernel evaluates friction only for a
// regular point projection: on the degenerate
// (near-parallel) path of the point contact alone it reports no friction (`active` false). In the
// all-angle contact (line_contact.hpp) it acts on the point part with its share s: the force,
// the bound mu f_n and the stick stiffness all scale by s, so the stick/slip decision is the
// point's; the line part has its own friction (line_friction.hpp).
//
// Blend: with the all-angle contact's point share s(x) (0 < s <= 1) the result is s times the
// above, f_n the point part's own force (SplineContactResult::point_force), and the tangent
// s (d residual/dx) + residual (ds/dx)^T, ds/dx from SplineContactSensitivity::share.

#include "contact/spline_contact.hpp"
#include "contact/spline_curve.hpp"

#include <Eigen/Core>

namespace yarnsim::contact {

/// Coefficients of the penalty-regularised Coulomb law.
///
/// The stick stiffness is either a constant tangential penalty eps_t, or set by an elastic slip
/// gamma: eps_t(f_n) = mu f_n / gamma, the stiffness of a point that reaches the cone after an
/// elastic (reversible) slip of gamma whatever its normal force (the "elastic slip" of the
/// stiffness method of Abaqus/Standard's penalty friction, whose default is 0.5 % of a
/// characteristic element length). With a constant penalty the cone's radius in displacement,
/// mu f_n / eps_t, shrinks with the normal force: at crossings that carry 1e-2 N it is 1e-9 m, the
/// slip direction g_t / |g_t| turns over that length, and Newton's corrections, far longer,
/// make such points change between stick and slip at every iterate (docs/verification.md, "Bias
/// extension"). With the elastic slip the radius is gamma at every point, and the stick force
/// vanishes with the normal force.
class CoulombFriction {
public:
  /// mu_s, mu_k: static and kinetic coefficients (dimensionless); eps_t: tangential penalty,
  /// N/m (unused with an elastic slip); c_t: tangential damping, N s/m; elastic_slip: gamma, m,
  /// 0 for the constant penalty. Throws std::invalid_argument unless 0 <= mu_k <= mu_s,
  /// c_t >= 0, and eps_t > 0 or elastic_slip > 0 with the other >= 0, all finite.
  CoulombFriction(double mu_s, double mu_k, double eps_t, double c_t = 0.0,
                  double elastic_slip = 0.0);

  double mu_s() const { return mu_s_; }
  double mu_k() const { return mu_k_; }
  double eps_t() const { return eps_t_; }
  double c_t() const { return c_t_; }
  double elastic_slip() const { return elastic_slip_; }
  /// The stick stiffness of a point with coefficient mu and normal force f_n (N; per unit length
  /// on a line contact, and the stiffness then per unit length too), N/m: eps_t, or
  /// mu f_n / gamma.
  double stiffness(double mu, double f_n) const {
    return elastic_slip_ > 0.0 ? mu * f_n / elastic_slip_ : eps_t_;
  }
  /// d stiffness / d f_n, 1/m: 0, or mu / gamma.
  double stiffness_rate(double mu) const { return elastic_slip_ > 0.0 ? mu / elastic_slip_ : 0.0; }

private:
  double mu_s_;
  double mu_k_;
  double eps_t_;
  double c_t_;
  double elastic_slip_;
};

/// The stick/slip decision of a return mapping with trial slip function phi and cone radius
/// `limit` (phi = |trial| - limit, in the units of the limit). A point that slipped in the
/// committed state (`stuck` false) was returned onto the cone, so its first evaluation of the
/// next increment at unmoved positions has phi at round-off (the projection's tolerance makes it
/// 1e-9 relative) and the sign decides nothing: it keeps slipping until its trial falls inside
/// the cone by kOnCone of the radius. The force is the same on both sides of the cone, so this
/// moves no force; it gives the slip tangent to a point that goes on slipping (the first
/// correction of an increment is solved with the converged state's tangent: simulation.cpp).
inline constexpr double kOnCone = 1e-6;
inline bool slips(double phi, double limit, bool stuck) {
  return phi > (stuck ? 0.0 : -kOnCone * limit);
}

/// History of one contact point: the anchor and the stick flag of the last committed state.
struct FrictionHistory {
  double xi_A = 0.0; ///< global parameter on curve A of the material point where it stuck
  double xi_B = 0.0; ///< the same on curve B
  bool stuck = true; ///< stuck in the last committed state: mu_s applies, else mu_k
  /// Torsional friction (torsional_friction.hpp): the anchor crossing angle, rad, and whether
  /// the crossing's twist stuck in the last committed state.
  double twist = 0.0;
  bool twist_stuck = true;
};

/// The history of a contact point that has just closed: anchored where it touched, stuck (the
/// twist anchor, where torsional friction applies, is set by the caller: crossing_angle).
inline FrictionHistory first_touch(const SplineContactState& contact) {
  return {contact.xi_A, contact.xi_B, true, 0.0, true};
}

/// How the friction force f of a point reaches the 18 positions (the file's comment, "Force and
/// work").
enum class FrictionForce {
  /// Point forces f at C_A and -f at C_B: residual = -kron(w, f). They leave the couple g x f,
  /// and their work is not f . dg_t; but a flexible yarn wrapped over a crossing yarn (the
  /// capstan) carries them, and Newton converges there. The implicit path's.
  AtContactPoints,
  /// residual = (dg_t/dx)^T f: the force does work on the elastic gap it is computed from, with
  /// no resultant and no moment. It carries the couple by translations through the turning of
  /// the normal, which a yarn without bending stiffness wrapped over a crossing yarn cannot take
  /// (tests/engine/test_capstan.cpp: Newton stalls). The explicit path's, whose energy balance
  /// needs it (formulation.md, "Friction on the explicit path"); residual only (no tangent).
  ConjugateToTheGap,
};

/// Controls of the friction kernel.
struct FrictionOptions {
  bool compute_tangent = true; ///< false: residual only (explicit dynamics); tangent zeroed
  FrictionForce force = FrictionForce::AtContactPoints;
};

/// Friction state of one contact point (SplineFrictionResult adds the residual and tangent; a
/// contact set keeps those of its active points alone).
struct SplineFrictionState {
  /// Evaluated: the normal contact is active on a regular point projection. Otherwise every
  /// field below is zero, and `history` is the input's.
  bool active = false;
  bool slipping = false;  ///< the trial force left the cone (slips(): phi > 0, or on it after slip)
  double mu = 0.0;        ///< the coefficient used, mu_s or mu_k
  double stiffness = 0.0; ///< the stick stiffness used, N/m (CoulombFriction::stiffness)
  Eigen::Vector3d elastic_gap = Eigen::Vector3d::Zero(); ///< trial g_t, metres
  /// v_t, m/s; zero without PairRates or damping.
  Eigen::Vector3d sliding_velocity = Eigen::Vector3d::Zero();
  /// Friction force on A at its contact point (on B: the opposite), N: f_c - c_t v_t.
  Eigen::Vector3d force = Eigen::Vector3d::Zero();
  double slip_function = 0.0;  ///< trial phi = eps_t |g_t| - mu f_n, N
  double slip_increment = 0.0; ///< |g_t| - mu f_n / eps_t when slipping, else 0, metres
  /// Energy the slip dissipates, the force on the cone times the slip: mu f_n slip_increment, J.
  double dissipation = 0.0;
  /// The all-angle contact's point share s (line_contact.hpp; 1 for the point contact alone):
  /// `force`, `residual`, `tangent` and `dissipation` are s times the point's; the stick
  /// spring's energy is |force|^2 / (2 s stiffness).
  double share = 1.0;
  /// The history to commit if this iterate is accepted: the anchor (kept in stick, returned
  /// onto the cone in slip) and stuck = !slipping.
  FrictionHistory history;
};

/// Friction state, residual and tangent of one contact point. The 18 DOFs are those of
/// SplineContactResult (A's three control points, then B's, each x, y, z).
struct SplineFrictionResult : SplineFrictionState {
  /// Contribution to the internal force vector, N: -kron(w, f) or (dg_t/dx)^T f
  /// (FrictionOptions::force), see the file's comment.
  Eigen::Matrix<double, 18, 1> residual = Eigen::Matrix<double, 18, 1>::Zero();
  /// d(residual)/dx at fixed history, N/m, including the dependence of (xi_A, xi_B), of the
  /// tangents C'(xi), of f_n (slip) and of the normal and velocities (damping) on x. Not
  /// symmetric: a model with friction needs an LU factorisation of the global tangent.
  Eigen::Matrix<double, 18, 18> tangent = Eigen::Matrix<double, 18, 18>::Zero();
};

/// Coulomb friction of one contact point of the segment pair (`control_A`, `basis_A`),
/// (`control_B`, `basis_B`) (control points as columns, metres), whose normal contact is
/// `contact`: the result of spline_contact for the same positions (and the same `rates`, if the
/// normal law damps). `sensitivity` is the SplineContactSensitivity spline_contact wrote for it:
/// the tangent needs its dxi/dx, and so does the residual conjugate to the gap (nullptr is
/// allowed for the point forces' residual alone). The force conjugate to the gap is residual
/// only: the explicit path's (FrictionForce). `history` is held fixed: the caller commits
/// `out.history` with a converged increment. `rates` (optional) feeds the tangential damping.
///
/// With `du/dx = dxi/dx / h` (local u) from the projection and G_a = kron(N_A'^T, I3) (likewise
/// G_b):
///   dg_t/dx = Delta_A G_a + Delta_B G_b + (C_A,u + Delta_A C_A,uu) du_A/dx
///             + (-C_B,u - Delta_B C_B,uu) du_B/dx,   Delta = u - u^s (local parameters),
///   stick: df/dx = eps_t dg_t/dx,
///   slip:  df/dx = mu t (df_n/dx)^T + mu f_n / |g_t| (I - t t^T) dg_t/dx,   t = g_t / |g_t|,
///   tangent = -kron(w', f) du/dx - kron(w, I3) df/dx   (w' = dw/du_A, dw/du_B),
///   conjugate to the gap: residual = (dg_t/dx)^T f.
/// Throws std::invalid_argument if the tangent is asked for with the force conjugate to the gap,
/// or if the contact is an active regular point, the tangent or the conjugate residual is asked
/// for, and `sensitivity` is null or not valid for it. Writes into `out`; never allocates.
void spline_friction(const Eigen::Matrix3d& control_A, const SegmentBasis& basis_A,
                     const Eigen::Matrix3d& control_B, const SegmentBasis& basis_B,
                     const SplineContactState& contact, const SplineContactSensitivity* sensitivity,
                     const FrictionHistory& history, const CoulombFriction& law,
                     SplineFrictionResult& out, const FrictionOptions& options = {},
                     const PairRates* rates = nullptr);

} // namespace yarnsim::contact
