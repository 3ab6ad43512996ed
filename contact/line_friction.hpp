#pragma once
// Coulomb friction of the all-angle contact's line part (line_contact.hpp): nearly parallel yarns
// that touch along a line slide along each other (yarns side by side in a sheared fabric, the
// plies of a twisted yarn). The kernel of one segment pair's Gauss points, apart from the normal
// contact whose state it takes; the pointwise law of friction.hpp at each Gauss point.
//
// Gauss point i is a material point of the slave A (the fixed parameter u_i of A's segment); its
// projection v_i(x) onto the master B is where it touches. History ("anchor"): the global
// parameter xi_B^s of B's material point under it when it stuck, and whether it stuck in the
// last committed state. The elastic tangential gap is that of friction.hpp with A's parameter
// difference zero (A's point is material):
//   g_t = C_B'(v) (v^s - v)                                                              [m]
// (local parameters; C_B' (v^s - v) does not depend on the segment's scale), the first-order
// displacement of B's anchor point relative to the touching point, orthogonal to the normal at
// the projection, objective (a rigid motion rotates C_B' and leaves the parameters) and linear in
// v^s - v, so the return mapping is exact. It runs along B's tangent: transverse relative motion
// of two side-by-side centre lines is rolling for the spline contact, which has no rotations.
//
// Law per Gauss point, on its share of the line load: with W = w_i |C_A,u(u_i)| (1 - s_i) (the
// quadrature weight of the line potential: metres of A carried by the point, times the line
// share), lambda = line_scale (1/m) and f(p) the normal law,
//   normal force       N   = W lambda f(p_i)                              [N]
//   stick stiffness    K   = W lambda eps_t, or mu N / gamma with an      [N/m]
//                            elastic slip gamma (friction.hpp; a jet through N)
//   trial              f   = K g_t,  phi = K |g_t| - mu N  (mu = mu_s after stick, mu_k after
//                                                            slip; slips() of friction.hpp)
//   slip               f   = mu N g_t / |g_t|, the anchor returned onto the cone,
//                      v^s <- v + (v^s - v) mu f(p) / (eps_t |g_t|), slip |g_t| - mu f(p) / eps_t,
//                      dissipation mu N times it (eps_t lambda read as mu lambda f(p) / gamma
//                      with the elastic slip: the radius gamma).
// W lambda cancels in the stick/slip decision (eps_t |g_t| against mu f(p)), so a point's slip
// does not depend on its share: the line share fades the line friction out exactly as it fades
// the line load, and the line penalty per unit length of line_contact.hpp, eps lambda, has the
// tangential penalty eps_t lambda (N/m^2) beside it.
//
// Force and sign as in friction.hpp: f acts on A at C_A(u_i) and -f on B at C_B(v_i); residual
// -N_A,k(u_i) f at A's control point k, +N_B,k(v_i) f at B's. The tangent holds the history
// fixed and differentiates v_i (from the projection), C_B'(v_i), the share and, in slip, N, by
// forward-mode differentiation (first-order jets, second_order_jet.hpp). Not symmetric.
//
// Limitations (formulation.md, "Friction on the line contact"): no tangential damping on the line
// contact (as its normal law is not damped); the couple that carries the force from the yarns'
// surfaces to their centre lines is dropped, as at the point contacts.

#include "contact/friction.hpp"
#include "contact/interface_law.hpp"
#include "contact/line_contact.hpp"
#include "contact/spline_contact.hpp"
#include "contact/spline_curve.hpp"

#include <Eigen/Core>
#include <array>
#include <cstdint>

namespace yarnsim::contact {

/// History of one Gauss point of the line contact.
struct LineFrictionHistory {
  double xi_B = 0.0; ///< global parameter on B of the material point where it stuck
  bool stuck = true; ///< stuck in the last committed state: mu_s applies, else mu_k
};

/// The friction state of one Gauss point.
struct LineFrictionPoint {
  bool slipping = false;
  double normal_force = 0.0;                       ///< N = W lambda f(p), N
  Eigen::Vector3d force = Eigen::Vector3d::Zero(); ///< on A at C_A(u_i), N (on B: the opposite)
  double slip_increment = 0.0; ///< |g_t| - mu f / eps_t when slipping, else 0, metres
  double dissipation = 0.0;    ///< mu N slip_increment, J
  double energy = 0.0;         ///< the stick spring's elastic energy |f|^2 / (2 K), J
  LineFrictionHistory history; ///< to commit if this iterate is accepted
};

/// Friction of a segment pair's line part. The 18 DOFs are those of SplineContactResult.
struct LineFrictionResult {
  std::uint16_t mask = 0; ///< bit i: Gauss point i evaluated (in contact, with a history)
  std::array<LineFrictionPoint, kMaxGaussPoints> points{}; ///< valid where `mask` has the bit
  /// Contribution to the internal force vector, N: the sum over the points above.
  Eigen::Matrix<double, 18, 1> residual = Eigen::Matrix<double, 18, 1>::Zero();
  /// d(residual)/dx at fixed histories, N/m (zeroed when the tangent is not asked for).
  Eigen::Matrix<double, 18, 18> tangent = Eigen::Matrix<double, 18, 18>::Zero();
};

/// Coulomb friction at the Gauss points of the line part of the all-angle contact `contact`
/// (all_angle_contact for the same positions, radii, law and options): each Gauss point i whose
/// bits are set in both `contact.line_mask` (in contact) and `with_history` is evaluated on
/// `history[i]`, held fixed (the caller commits `out.points[i].history` with a converged
/// increment). `all_angle.line_scale` is lambda. Writes into `out`; never allocates.
void line_friction(const Eigen::Matrix3d& control_A, const SegmentBasis& basis_A, double radius_A,
                   const Eigen::Matrix3d& control_B, const SegmentBasis& basis_B, double radius_B,
                   const InterfaceLaw& law, const AllAngleOptions& all_angle,
                   const SplineContactState& contact, std::uint16_t with_history,
                   const std::array<LineFrictionHistory, kMaxGaussPoints>& history,
                   const CoulombFriction& friction, LineFrictionResult& out,
                   const FrictionOptions& options = {});

} // namespace yarnsim::contact
