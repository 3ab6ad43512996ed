#pragma once

#include "contact/interface_law.hpp"
#include "contact/spline_curve.hpp"

#include <Eigen/Core>
#include <array>
#include <cstdint>

namespace yarnsim::contact {

/// Outcome of the local contact problem (LCP, eq. 11) of one segment pair.
enum class ProjectionStatus {
  Converged,    ///< a strict local minimum of the distance, inside both segments' ranges
  OutOfRange,   ///< converged, or left the segment's neighbourhood, outside a range: a
                ///< neighbouring pair owns the point (none beyond a yarn's end) and this
                ///< pair contributes nothing
  NotConverged, ///< no minimum within the iteration limit, or the centre lines intersect
                ///< (no normal): the caller vetoes the step
  Jumped,       ///< converged in range, but the point moved more than `jump_fraction` of a
                ///< segment from the warm start to a point a cold start does not find (the
                ///< spline contact; the surface contact's caller makes that test): the caller
                ///< vetoes the step
};

/// Whether a full Newton step of `length` ends a projection's iteration (spline and surface
/// contact): it is below the tolerance, or, in the quadratic regime after a previous full step,
/// the step after it would be (|s_k+1| ~ |s_k|^3 / |s_k-1|^2, the constant of quadratic
/// convergence estimated from the last two steps). Saves the last, confirming iteration.
/// length, previous (0 when there is none), tolerance: in the problem's coordinates.
inline bool newton_step_converges(double length, double previous, double tolerance) {
  if (length <= tolerance)
    return true;
  return previous > 0.0 && length < 1e-2 * previous &&
         length * length * length <= tolerance * previous * previous;
}

/// Starting point of the LCP: the pair's last solution (`warm`), or the segments' midpoints.
struct ProjectionStart {
  double xi_A = 0.0; ///< global parameter on curve A
  double xi_B = 0.0; ///< global parameter on curve B
  bool warm = false; ///< false: start at the midpoints and skip the jump test
};

/// Controls of the LCP solver.
struct SplineContactOptions {
  int max_iterations = 50; ///< safeguarded Newton iterations
  /// Converged when a full Newton step, or the next one predicted from the last two (quadratic
  /// convergence), is below this (segments).
  double step_tolerance = 1e-12;
  /// Segments whose chords make an angle with sine below this are treated as parallel.
  double parallel_sine = 1e-2;
  /// Jumped above this move from a warm start (segments), unless a cold start finds the same
  /// point.
  double jump_fraction = 0.5;
  /// Iterates farther than this beyond a segment's range end the solve as OutOfRange (segments).
  double max_extension = 1.0;
  bool compute_tangent = true; ///< false: residual only (explicit dynamics)
  /// false: a tangent that is not computed (inactive pair, or compute_tangent false) is left as
  /// it was instead of zeroed, for callers that read it only where it was computed: it saves
  /// writing 2.6 KB per open pair, which made the narrow phase of a large weave memory-bound
  /// (docs/performance.md).
  bool zero_unused_tangent = true;
};

/// Control-point velocities, for normal damping only. The penetration rate is
/// dp/dt = -n . (dg/dt at fixed xi) (exact at the projection).
struct PairRates {
  Eigen::Matrix3d velocity_A = Eigen::Matrix3d::Zero(); ///< columns, m/s
  Eigen::Matrix3d velocity_B = Eigen::Matrix3d::Zero(); ///< columns, m/s
  /// dv/dx of the time integrator, 1/s (Newmark: gamma / (beta dt)); 0 treats the velocities as
  /// independent of the positions in the tangent.
  double velocity_per_displacement = 0.0;
};

/// LCP solution of one segment pair.
struct ProjectionResult {
  ProjectionStatus status = ProjectionStatus::NotConverged;
  bool degenerate = false; ///< near-parallel path: xi_A fixed at the overlap midpoint
  int iterations = 0;
  double xi_A = 0.0; ///< global parameters of the contact points
  double xi_B = 0.0;
};

/// Most Gauss points of the all-angle contact's line part on one segment (line_contact.hpp).
inline constexpr int kMaxGaussPoints = 10;

/// Contact state of one segment pair: the projection, the gap, the law's force and what the
/// friction kernels start from (SplineContactResult adds the residual and tangent). A contact
/// set holds one per candidate pair and the residual and tangent of its active pairs alone.
struct SplineContactState {
  ProjectionStatus status = ProjectionStatus::NotConverged;
  bool degenerate = false; ///< see ProjectionResult
  int iterations = 0;
  double xi_A = 0.0; ///< global parameters of the contact points
  double xi_B = 0.0;
  Eigen::Vector3d point_A = Eigen::Vector3d::Zero(); ///< C_A(xi_A), metres
  Eigen::Vector3d point_B = Eigen::Vector3d::Zero(); ///< C_B(xi_B), metres
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< n = g / |g|, g = C_A - C_B (B to A)
  double distance = 0.0;                             ///< |g|, metres
  double gap = 0.0;              ///< effective gap g_e = |g| - (r_A + r_B) (eq. 12), metres
  double penetration = 0.0;      ///< p = -g_e, metres
  double penetration_rate = 0.0; ///< dp/dt, m/s (zero without PairRates)
  double force = 0.0;            ///< normal force magnitude f from the law, N
  double potential = 0.0;        ///< the law's elastic potential U(p), J
  /// Owned by this pair (Converged or Jumped) with p > 0. Only then are residual and tangent
  /// non-zero.
  bool active = false;
  /// All-angle contact (line_contact.hpp) only: whether the point contact was evaluated (the
  /// chords not nearly parallel), its share s, and the line part's Gauss points in contact.
  bool point_evaluated = true;
  double point_share = 1.0;
  int line_points = 0;
  /// The point contact's own state before the blend: whether it is active (p > 0 with a share
  /// s > 0) and its normal force f (N; s f is what `force` holds of it). For the point contact
  /// alone: `active` and `force`. The point friction (friction.hpp) acts on these.
  bool point_active = false;
  double point_force = 0.0;
  /// The line part's Gauss points in contact (bit i: Gauss point i of A's segment, with a line
  /// share above 0) and the local parameters on B's segment of their projections (valid where
  /// the bit is set): what the line contact's friction (line_friction.hpp) starts from.
  std::uint16_t line_mask = 0;
  std::array<double, kMaxGaussPoints> line_u{};
};

/// Contact state, residual and tangent of one segment pair. The 18 DOFs are the translations of
/// A's three control points, then B's (each x, y, z).
struct SplineContactResult : SplineContactState {
  /// Contact contribution to the internal force vector: dU/dx = -f d|g|/dx, N. Added to the
  /// internal forces; for A it is -f N_k(xi_A) n at control point k (the contact pushes A along
  /// +n).
  Eigen::Matrix<double, 18, 1> residual = Eigen::Matrix<double, 18, 1>::Zero();
  /// d(residual)/dx, N/m, including the dependence of (xi_A, xi_B) on x. Symmetric unless the
  /// law damps.
  Eigen::Matrix<double, 18, 18> tangent = Eigen::Matrix<double, 18, 18>::Zero();
};

/// First derivatives of a regular point contact's state with respect to the 18 positions (A's
/// control points, then B's, each x, y, z), for the kernels that build on the normal contact
/// (Coulomb friction, friction.hpp). spline_contact writes them only when handed this struct.
struct SplineContactSensitivity {
  /// Whether the fields below belong to the last evaluation: true only for an active pair on
  /// the regular (not degenerate) path. When false the fields are left as they were.
  bool valid = false;
  /// d(xi_A, xi_B)/dx = -H^-1 D (formulation.md §4, in global parameters), 1/m, 2 x 18.
  Eigen::Matrix<double, 2, 18> parameters = Eigen::Matrix<double, 2, 18>::Zero();
  /// Gradient of the normal force magnitude, df/dx = -f_p d|g|/dx + f_pdot d(dp/dt)/dx, N/m;
  /// the second term only with PairRates and a damping law.
  Eigen::Matrix<double, 18, 1> force = Eigen::Matrix<double, 18, 1>::Zero();
  /// Gradient of the point share s of the all-angle contact (line_contact.hpp), 1/m: non-zero
  /// only in the blend (0 < s < 1); zero for the point contact alone.
  Eigen::Matrix<double, 18, 1> share = Eigen::Matrix<double, 18, 1>::Zero();
};

/// Solves the LCP (eq. 11) between segment `basis_A` of curve A (control points `control_A`,
/// columns, metres) and segment `basis_B` of curve B: r = [C_A'.g, -C_B'.g] = 0, g = C_A - C_B,
/// taken as a local minimum of |g|^2 / 2 by Newton's method: where the Hessian is not positive
/// definite, its eigenvalues that are not positive are replaced by their magnitudes plus a small
/// shift; steps are capped at one segment; a capped or modified step is cut to the first
/// minimum of |g|^2 / 2 along it; an Armijo backtracking follows. The segments' polynomials are
/// extended beyond their ranges, so a point that leaves a range is found and handed to the
/// neighbour (OutOfRange). Curved pairs can have several local minima: the one found is the one
/// this descent from `start` reaches, not necessarily the closest over the ranges.
///
/// Ownership: the segment owning xi is the one of SegmentBasis::owns. Where a solution lies
/// within 1e-8 segments of an interior knot, the side is decided instead by the sign of
/// dr/dxi at the knot from quantities the two neighbouring pairs compute bit for bit alike
/// (the knot point is the midpoint of the two shared control points), so a contact sliding over
/// a knot is owned by exactly one pair at every position.
///
/// Degenerate treatment: when the chords of the two segments are parallel within
/// `parallel_sine`, the minimum is not unique (a line contact) or ill-conditioned, so xi_A is
/// fixed at the midpoint of the overlap of the segments, measured by projecting B's end points
/// onto A's chord (an explicit, smooth function of the positions where the overlap's ends do not
/// switch), and xi_B solves the remaining equation -C_B'.g = 0. An empty overlap puts xi_A
/// outside A's range (OutOfRange).
///
/// Never allocates.
ProjectionResult closest_point_projection(const Eigen::Matrix3d& control_A,
                                          const SegmentBasis& basis_A,
                                          const Eigen::Matrix3d& control_B,
                                          const SegmentBasis& basis_B, const ProjectionStart& start,
                                          const SplineContactOptions& options = {});

/// Beam-to-beam spline contact of one segment pair with circular sections of radii `radius_A`
/// and `radius_B` (metres): the projection above, the effective gap (eq. 12), the normal, the
/// force from `law` and the residual and consistent tangent of the contact potential (the
/// virtual work of eq. 13).
///
/// At a regular projection the residual is -f G^T n (G = dg/dx at fixed xi) and the tangent
/// f' G^T n n^T G - f (G^T (I - n n^T) G - D^T H^-1 D) / |g|, H = dr/dc, D = dr/dx: the second
/// term is the dependence of the projection on the positions, dc/dx = -H^-1 D. On the
/// degenerate path the residual and tangent also carry the derivatives of the overlap midpoint.
/// `rates` (optional) feeds normal damping. `sensitivity` (optional) receives dxi/dx and df/dx
/// (with or without `options.compute_tangent`); it does not change `out`. Writes into `out`;
/// never allocates.
void spline_contact(const Eigen::Matrix3d& control_A, const SegmentBasis& basis_A, double radius_A,
                    const Eigen::Matrix3d& control_B, const SegmentBasis& basis_B, double radius_B,
                    const ProjectionStart& start, const InterfaceLaw& law, SplineContactResult& out,
                    const SplineContactOptions& options = {}, const PairRates* rates = nullptr,
                    SplineContactSensitivity* sensitivity = nullptr);

/// As above, returning the result.
SplineContactResult spline_contact(const Eigen::Matrix3d& control_A, const SegmentBasis& basis_A,
                                   double radius_A, const Eigen::Matrix3d& control_B,
                                   const SegmentBasis& basis_B, double radius_B,
                                   const ProjectionStart& start, const InterfaceLaw& law,
                                   const SplineContactOptions& options = {},
                                   const PairRates* rates = nullptr,
                                   SplineContactSensitivity* sensitivity = nullptr);

/// Name of a status, for messages.
const char* to_string(ProjectionStatus status);

} // namespace yarnsim::contact
