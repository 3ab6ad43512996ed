#pragma once

#include "contact/interface_law.hpp"
#include "contact/spline_contact.hpp" // ProjectionStatus, to_string
#include "contact/superelliptical_cylinder.hpp"

#include <Eigen/Core>

namespace yarnsim::contact {

/// Starting point of the surface LCP: the pair's last solution (`warm`), or a start built from
/// the geometry (the closest points of the two axes, moved by the section points that face each
/// other, exact for straight untwisted cylinders).
struct SurfaceProjectionStart {
  double zeta_A = 0.0;  ///< convective coordinates of the last solution (eq. 1)
  double theta_A = 0.0; ///< radians
  double zeta_B = 0.0;
  double theta_B = 0.0;
  bool warm = false; ///< false: geometric start, and no jump test
};

/// Which coordinates the LCP solved. A degenerate path fixes some zeta to an explicit, smooth
/// function of the node positions and solves the reduced problem (formulation.md §6, item 4);
/// the residual and tangent then include the derivatives of that function.
enum class SurfaceDegeneration {
  None,     ///< all four coordinates solve eq. 5
  Parallel, ///< the axes are parallel within `parallel_sine`: zeta_A is fixed at the midpoint of
            ///< the axial overlap of the two elements (B's end nodes projected onto A's axis)
  /// A's section is flat at its contact point (m > 2, near a vertex, see `flat_radius`): both
  /// surfaces are straight along B's axis there, so zeta_B is fixed at the closest point of the
  /// two axes. Flatness is judged at the geometric start's points, so the path depends on the
  /// configuration only, not on the start.
  FlatOnA,
  FlatOnB,    ///< the same with A and B swapped: zeta_A fixed
  FlatOnBoth, ///< flat face on flat face: zeta_A and zeta_B fixed, theta_A and theta_B solved
  /// The contact sits on the ridge where A's element meets the previous one at a convex kink
  /// (A's node A): each element's own solution lies beyond the shared node, on the other's
  /// side. zeta_A = -1 (a constant); the element after the kink owns the ridge. Needs
  /// SuperEllipticalCylinder's `previous`; tried from the regular path only (not combined with
  /// the parallel and flat paths).
  RidgeOnA,
  RidgeOnB,    ///< the same on B's node A: zeta_B = -1
  RidgeOnBoth, ///< ridge against ridge: zeta_A = zeta_B = -1
};

/// Controls of the surface LCP solver.
struct SurfaceContactOptions {
  int max_iterations = 50; ///< Newton iterations per start (a failed warm start is retried cold)
  /// Converged when a full Newton step, or the next one predicted from the last two (quadratic
  /// convergence), is below this in both zeta and theta (radians).
  double step_tolerance = 1e-12;
  /// Axes (chords x_B - x_A) making an angle with sine below this are treated as parallel.
  double parallel_sine = 1e-2;
  /// Jumped above this move of zeta from a warm start, in elements (zeta spans 2 per element).
  double jump_fraction = 0.5;
  /// Jumped above this move of theta from a warm start, radians.
  double jump_angle = 1.0;
  /// Iterates farther than this beyond an element's ends (in elements) end the solve as
  /// OutOfRange.
  double max_extension = 1.0;
  /// Half-width h of the window, in zeta, over which a contact near a node between two
  /// elements of a yarn passes from one element's pair to the other's
  /// (SuperEllipticalCylinder::share); 0 < h < 1, or 0 for sharp ownership. Each pair carries
  /// its share of the force, so a contact crossing a node, and a contact whose own critical
  /// point runs past a node where the next element holds a contact of its own (two overlaps of
  /// a crossing merging), changes its force continuously instead of jumping.
  double end_window = 0.25;
  /// Use the Flat paths for crossing pairs of sections with m > 2. Without them the solver
  /// meets the flat vertices' zero curvature: Newton slows to linear convergence and the
  /// projection's derivative, hence the tangent, grows without bound near a vertex contact.
  bool flat_path = true;
  /// A section with m > 2 counts as flat at a point whose radius of curvature exceeds this
  /// multiple of its larger semi-axis. Ellipses (m = 2) are never flat.
  double flat_radius = 10.0;
  bool compute_tangent = true; ///< false: residual only (explicit dynamics)
};

/// DOF rates, for normal damping only: the time derivatives of the 24 DOFs in the kernel's order
/// (m/s for translations, 1/s for the Rodrigues increments). The penetration rate is then
/// exactly dp/dt = -grad g_n . rate.
struct SurfacePairRates {
  Eigen::Matrix<double, 24, 1> rate = Eigen::Matrix<double, 24, 1>::Zero();
  /// d(rate)/d(DOF), 1/s, the same for every DOF (Newmark on the DOFs: gamma / (beta dt));
  /// 0 treats the rates as independent of the DOFs in the tangent.
  double velocity_per_displacement = 0.0;
};

/// LCP solution of one surface pair.
struct SurfaceProjectionResult {
  ProjectionStatus status = ProjectionStatus::NotConverged;
  SurfaceDegeneration degeneration = SurfaceDegeneration::None;
  int iterations = 0;
  double zeta_A = 0.0;  ///< convective coordinates of the contact points (eq. 1)
  double theta_A = 0.0; ///< radians, in [0, 2 pi)
  double zeta_B = 0.0;
  double theta_B = 0.0;
};

/// Contact state of one surface pair: the projection, the gap, the law's force and what the
/// friction kernels start from (SurfaceContactResult adds the residual and tangent). A contact
/// set holds one per candidate pair and the residual and tangent of its active pairs alone.
struct SurfaceContactState {
  ProjectionStatus status = ProjectionStatus::NotConverged;
  SurfaceDegeneration degeneration = SurfaceDegeneration::None;
  int iterations = 0;
  double zeta_A = 0.0; ///< as in SurfaceProjectionResult
  double theta_A = 0.0;
  double zeta_B = 0.0;
  double theta_B = 0.0;
  Eigen::Vector3d point_A = Eigen::Vector3d::Zero(); ///< Gamma_A at the solution, metres
  Eigen::Vector3d point_B = Eigen::Vector3d::Zero(); ///< Gamma_B at the solution, metres
  /// Unit contact normal, pointing from B towards A: the direction in which the contact pushes
  /// A. At a regular solution it is B's outward normal and minus A's, and g = Gamma_A - Gamma_B
  /// = g_n n.
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  double gap = 0.0;              ///< signed gap g_n = +-|g|: negative when the surfaces overlap, m
  double penetration = 0.0;      ///< p = -g_n, metres
  double penetration_rate = 0.0; ///< dp/dt, m/s (zero without SurfacePairRates)
  double force = 0.0;            ///< normal force carried: the share times the law's f(p), N
  double potential = 0.0;        ///< the share times the law's elastic potential U(p), J
  /// Owned by this pair (Converged or Jumped) with p > 0 and a non-zero share. Only then are
  /// residual and tangent non-zero.
  bool active = false;
  /// Share of the contact this pair carries near a node between elements, in (0, 1]
  /// (SurfaceContactOptions::end_window): the product of both surfaces' shares at the contact
  /// point (1 on a ridge coordinate). `force`, `potential`, `residual` and `tangent` include it
  /// (the tangent with the share's own derivative).
  double share = 1.0;
  double share_A = 1.0; ///< A's factor of `share` (its share at zeta_A)
  double share_B = 1.0; ///< B's factor of `share`
};

/// Contact state, residual and tangent of one surface pair. The 24 DOFs follow eq. 2: surface
/// A's node A translation, node B translation, node A Rodrigues increment, node B Rodrigues
/// increment (3 each), then the same for surface B.
struct SurfaceContactResult : SurfaceContactState {
  /// Contact contribution to the internal force vector, dU/dd = -f grad g_n (N for
  /// translations, N m per unit Rodrigues parameter for rotations): added to the internal
  /// forces. The engine's Newton unknowns are additive increments of alpha, so this is the
  /// gradient with respect to alpha itself, not a spatial moment.
  Eigen::Matrix<double, 24, 1> residual = Eigen::Matrix<double, 24, 1>::Zero();
  /// d(residual)/dd including the dependence of the contact points on the DOFs
  /// (dc/dd = -(dr/dc)^-1 dr/dd). Symmetric unless the law damps.
  Eigen::Matrix<double, 24, 24> tangent = Eigen::Matrix<double, 24, 24>::Zero();
};

/// First derivatives of a regular surface contact's state with respect to the 24 DOFs (in
/// SurfaceContactResult's order), for the kernels that build on the normal contact (Coulomb
/// friction, surface_friction.hpp), as SplineContactSensitivity is for the spline contact.
/// surface_contact writes them only when handed this struct.
struct SurfaceContactSensitivity {
  /// Whether the fields below belong to the last evaluation: true only for an active pair on
  /// the regular path (SurfaceDegeneration::None). On a degenerate path, or for an inactive
  /// pair, false and the fields are left as they were: friction is not evaluated there.
  bool valid = false;
  /// dc/dd = -H^-1 D, c = (zeta_A, theta_A, zeta_B, theta_B), H = dr/dc, D = dr/dd (r of eq. 5,
  /// the gradient of |g|^2 / 2): 4 x 24, per metre (translations) or per unit Rodrigues
  /// parameter (rotations); theta rows in radians.
  Eigen::Matrix<double, 4, 24> coordinates = Eigen::Matrix<double, 4, 24>::Zero();
  /// Gradient of the carried normal force f_n = w f(p, dp/dt) (SurfaceContactResult::force, the
  /// share w included): df_n/dd = w (-f_p grad g_n + f_pdot grad(dp/dt)) + f grad w, N/m or
  /// N per unit Rodrigues parameter; the rate term only with SurfacePairRates and a damping law.
  Eigen::Matrix<double, 24, 1> force = Eigen::Matrix<double, 24, 1>::Zero();
  /// Gradient of the share w = w_A(zeta_A) w_B(zeta_B) (SurfaceContactResult::share), through
  /// dzeta/dd above: zero outside the end windows.
  Eigen::Matrix<double, 24, 1> share = Eigen::Matrix<double, 24, 1>::Zero();
};

/// Solves the local contact problem (eq. 5) between the surfaces of two beam elements:
/// r(c) = [Gamma_A,zeta . g, Gamma_A,theta . g, -Gamma_B,zeta . g, -Gamma_B,theta . g] = 0,
/// g = Gamma_A - Gamma_B, c = (zeta_A, theta_A, zeta_B, theta_B).
///
/// Both the separated case (the minimum of |g|^2 / 2) and the overlapping one (its saddle point,
/// where the normals are opposite and g is along them) are critical points of |g|^2 / 2, found
/// by Newton's method. With g along B's normal nu_B = Gamma_B,theta x Gamma_B,zeta, A's two
/// equations Gamma_A,. . g = 0 are replaced by Gamma_A,. . nu_B = 0 (A's tangent plane parallel
/// to B's): the same solutions, but a Jacobian that stays regular when the gap closes, where the
/// Hessian of |g|^2 / 2 turns singular (the surfaces can slide together at no cost to second
/// order). Steps are capped (1 in zeta, 0.5 rad in theta) and backtracked on the scaled residual
/// norm. A critical point is accepted if the outward normals are opposite and the normal points
/// from B's axis to A's; this rejects the points on the far sides of the sections (a
/// "penetration" through a whole section).
///
/// Starts: a warm start is tried first. The cold start takes the closest points of the two axes,
/// moved by the section points that face each other (exact for straight untwisted cylinders),
/// then minimises |g|^2 / 2 with B moved away along the expected normal until the gap is about
/// a semi-axis: moving B along the contact normal leaves the contact points of a straight pair
/// where they are, and the separated problem is a well-conditioned minimum that a descent method
/// finds reliably. Newton's method on the real problem finishes from there.
///
/// Ownership: a solution with no share in an element (SuperEllipticalCylinder::share: beyond
/// the window around a node shared with a neighbour, or beyond a yarn's end) belongs to a
/// neighbour and is OutOfRange, as is an iterate that leaves the range by more than
/// `max_extension`; within the window both elements' pairs hold the contact, each with its
/// share. At a convex kink between two elements of a yarn (a crest facing the other
/// yarn), each element's own solution lies beyond the shared node; when the element after the
/// kink knows the one before it (`previous`), it owns the contact on the shared section
/// (RidgeOnA, RidgeOnB). See SurfaceDegeneration for the other degenerate paths: near-parallel
/// axes and flat faces (m > 2). Never allocates.
SurfaceProjectionResult surface_projection(const SuperEllipticalCylinder& A,
                                           const SuperEllipticalCylinder& B,
                                           const SurfaceProjectionStart& start,
                                           const SurfaceContactOptions& options = {});

/// Surface-to-surface contact of one element pair: the projection above, the signed gap, the
/// normal, the force from `law` with p = -g_n and the residual and consistent tangent of the
/// contact potential U(p) (the virtual work of eq. 6) with respect to the 24 DOFs.
///
/// With Phi*(d) = |g|^2 / 2 at the solution, grad Phi* = G^T g (G = dg/dd at fixed c, the
/// Rodrigues derivative d(Q(alpha) w)/dalpha = -skew(Q w) Xi(alpha)) and
/// hess Phi* = G^T G + sum_i g_i d2 g_i/dd2 - D^T H^-1 D (H = dr/dc, D = dr/dd: the implicit
/// dependence of c on d); |g| = sqrt(2 Phi*) then gives grad g_n and hess g_n, the residual
/// -f grad g_n and the tangent f' grad g_n grad g_n^T - f hess g_n. On the degenerate paths the
/// fixed coordinates' derivatives enter through the reduced problem. `rates` (optional) feeds
/// normal damping. `sensitivity` (optional) receives dc/dd and df_n/dd on the regular path
/// (with or without `options.compute_tangent`); it does not change `out`. Writes into `out`;
/// never allocates.
void surface_contact(const SuperEllipticalCylinder& A, const SuperEllipticalCylinder& B,
                     const SurfaceProjectionStart& start, const InterfaceLaw& law,
                     SurfaceContactResult& out, const SurfaceContactOptions& options = {},
                     const SurfacePairRates* rates = nullptr,
                     SurfaceContactSensitivity* sensitivity = nullptr);

/// As above, returning the result.
SurfaceContactResult surface_contact(const SuperEllipticalCylinder& A,
                                     const SuperEllipticalCylinder& B,
                                     const SurfaceProjectionStart& start, const InterfaceLaw& law,
                                     const SurfaceContactOptions& options = {},
                                     const SurfacePairRates* rates = nullptr,
                                     SurfaceContactSensitivity* sensitivity = nullptr);

/// Name of a degeneration, for messages.
const char* to_string(SurfaceDegeneration degeneration);

} // namespace yarnsim::contact
