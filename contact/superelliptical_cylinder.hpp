#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace yarnsim::contact {

/// Cross-section of a yarn's contact surface: the super-ellipse |x/a|^m + |y/b|^m = 1 in the
/// section's axes 1 and 2 (formulation.md §6), parametrised by the angle theta:
///   s(theta) = phi(theta) [a cos theta, b sin theta],
///   phi(theta) = (|cos theta|^m + |sin theta|^m)^(-1/m).
/// m = 2 is the ellipse (phi = 1, the study's section). For m > 2 the faces flatten: the
/// curvature at the four vertices (theta = 0, pi/2, pi, 3 pi/2) is zero, so there the point
/// with a given normal moves faster than any power of the normal's tilt (see
/// SurfaceContactOptions::flat_path). Exponents below 2 (corners, infinite curvature) are
/// refused.
class SuperEllipse {
public:
  /// Throws std::invalid_argument unless a > 0 and b > 0 (metres) and 2 <= m <= 1000, all
  /// finite.
  SuperEllipse(double a, double b, double m = 2.0);

  /// Semi-axis along section axis 1, metres.
  double a() const { return a_; }
  /// Semi-axis along section axis 2, metres.
  double b() const { return b_; }
  /// Exponent m, dimensionless.
  double m() const { return m_; }
  /// Whether m = 2 (an ellipse, curved everywhere).
  bool is_ellipse() const { return m_ == 2.0; }

  /// A section point and its derivatives with respect to theta (section axes 1, 2; metres).
  struct Point {
    Eigen::Vector2d value;  ///< s(theta)
    Eigen::Vector2d first;  ///< ds/dtheta
    Eigen::Vector2d second; ///< d2s/dtheta2
  };

  /// s(theta) and its first two derivatives; any theta (2 pi periodic). Never allocates.
  Point point(double theta) const;

  /// d3s/dtheta3 (section axes 1, 2; metres), for the second derivatives of the surface's
  /// theta-tangent (surface_torsional_friction.cpp). For 2 < m < 3 it is unbounded at the
  /// vertices (|sin theta|^(m - 3) or |cos theta|^(m - 3)); exactly at a vertex that term is
  /// taken as zero. Never allocates.
  Eigen::Vector2d third_derivative(double theta) const;

  /// Support function h(n) = max over the section of n . s = (|a n1|^q + |b n2|^q)^(1/q),
  /// q = m / (m - 1), for a direction n in the section plane (section axes 1, 2): for a unit n,
  /// the distance from the centre to the tangent line with outward normal n, metres. For the
  /// ellipse turned by psi against n = axis 2 it is sqrt(a^2 sin^2 psi + b^2 cos^2 psi).
  double support(const Eigen::Vector2d& direction) const;

  /// theta in (-pi, pi] of the section point whose outward normal points along `direction`
  /// (section axes 1, 2; any length but zero): the support point of `direction`.
  double normal_angle(const Eigen::Vector2d& direction) const;

  /// Radius of the circle through the section at theta, metres (infinite at a flat vertex).
  double radius_of_curvature(double theta) const;

private:
  double a_;
  double b_;
  double m_;
};

/// One end node of a beam element as its contact surface sees it. The node's rotation is
/// Q = Q(alpha) Q_n (formulation.md §2): the Rodrigues increment of the current step, which is
/// the Newton unknown, times the rotation at the last converged step.
struct SurfaceNode {
  Eigen::Vector3d position = Eigen::Vector3d::Zero(); ///< current position x = X + u, metres
  /// Rodrigues parameters alpha of the rotation increment since the last converged step.
  Eigen::Vector3d rotation_increment = Eigen::Vector3d::Zero();
  /// Q_n, rotation at the last converged step: columns are the section axes 1 (semi-axis a),
  /// 2 (semi-axis b) and 3 (along the beam).
  Eigen::Matrix3d converged_rotation = Eigen::Matrix3d::Identity();
};

/// The contact surface of one beam element (the paper's "Surface" model, eqs. 1-3): a
/// super-elliptical cylinder spanning the element's end nodes A (zeta = -1) and B (zeta = +1),
///   Gamma(zeta, theta) = (1 - zeta)/2 (x_A + Q_A s(theta)) + (1 + zeta)/2 (x_B + Q_B s(theta)),
/// with s(theta) = [s_1, s_2, 0] the section point. Its 12 DOFs are, in this order, x_A, x_B
/// (translations, metres), alpha_A, alpha_B (Rodrigues increments). The polynomial in zeta is
/// also evaluated outside [-1, 1] (the surface's extension), so a projection can leave the
/// element's range and be handed to its neighbour.
///
/// Holds a configuration: built from the nodes' current state, it computes Q = Q(alpha) Q_n and
/// Xi(alpha) once. Cheap to build, never allocates.
class SuperEllipticalCylinder {
public:
  /// `closes_end`: the element is the last of its yarn and also owns zeta = +1 (every other
  /// element owns [-1, 1), so a point on a node shared by two elements belongs to one of them;
  /// see owns).
  /// `previous` (optional): the first node of the element before this one along the yarn, whose
  /// second node is this element's node A. With it the contact kernel can own a contact on the
  /// ridge where the two surfaces meet at a convex kink, which neither element's own projection
  /// reaches (see SurfaceDegeneration::RidgeOnA); the neighbour is assumed to have the same
  /// section. Throws std::invalid_argument for non-finite node data.
  SuperEllipticalCylinder(const SurfaceNode& node_A, const SurfaceNode& node_B,
                          const SuperEllipse& section, bool closes_end = false,
                          const SurfaceNode* previous = nullptr);

  /// End node k (0 = A at zeta = -1, 1 = B at zeta = +1).
  const SurfaceNode& node(int k) const { return nodes_[k]; }
  /// Q_k = Q(alpha_k) Q_n,k.
  const Eigen::Matrix3d& rotation(int k) const { return rotation_[k]; }
  /// Xi(alpha_k): the spatial spin of a variation of alpha_k, delta theta = Xi delta alpha.
  const Eigen::Matrix3d& xi(int k) const { return xi_[k]; }
  const SuperEllipse& section() const { return section_; }
  bool closes_end() const { return closes_end_; }

  /// Whether the element before this one along the yarn is known.
  bool has_previous() const { return has_previous_; }

  /// dGamma/dzeta of the element before this one at the section they share (its zeta = +1),
  /// metres: 1/2 (x_A + Q_A s - x_P - Q_P s) with P the previous element's first node. Zero
  /// without a previous element.
  Eigen::Vector3d previous_d_zeta(double theta) const;

  /// Width of the band by which the ranges are moved towards node A, in zeta.
  static constexpr double kEndBand = 1e-9;

  /// Whether this element owns zeta: -1 - b <= zeta < 1 - b (b = kEndBand), or <= 1 + b for the
  /// last element of a yarn. Consecutive elements thus own consecutive ranges, and a contact
  /// exactly on a shared node, as in a symmetric mesh, belongs to the element after it even
  /// when rounding puts it a little to either side.
  bool owns(double zeta) const {
    return zeta >= -1.0 - kEndBand &&
           (zeta < 1.0 - kEndBand || (closes_end_ && zeta <= 1.0 + kEndBand));
  }

  /// Share of a contact at zeta that this element carries, in [0, 1], with d(share)/dzeta in
  /// `derivative` if given. At a node between two elements of a yarn the share passes smoothly
  /// from one element to the other over the window |zeta -+ 1| < h (h = `half_width`, in zeta,
  /// 0 < h < 1):
  ///   share = S((zeta + 1 + h) / (2 h)) at node A if the element before is known (`previous`),
  ///   share = S((1 + h - zeta) / (2 h)) at node B unless the element closes its yarn,
  ///   S(t) = t^3 (10 - 15 t + 6 t^2) on [0, 1] (0 below, 1 above; S' and S'' vanish at both
  ///   ends, and S(t) + S(1 - t) = 1),
  /// so that the two elements of a node, evaluated at the same point (zeta and zeta + 2 on a
  /// straight yarn), carry shares that sum to one. A yarn's own ends (no element before, or
  /// `closes_end`) are sharp: share 1 up to the end, 0 beyond. `half_width` <= 0 gives the sharp
  /// ownership of owns() everywhere.
  double share(double zeta, double half_width, double* derivative = nullptr) const;

  /// Axis point (1 - zeta)/2 x_A + (1 + zeta)/2 x_B, metres.
  Eigen::Vector3d axis_point(double zeta) const;

  /// An axis-aligned box, metres, that holds the surface for zeta in [-1 - h, 1 + h]
  /// (`window` = h >= 0: the end window over which a contact past a node keeps a share), with
  /// the sections as they are oriented, for the broad phase. At end k the section reaches
  /// e_i . x_k +- support(Q_k^T e_i) along axis e_i; Gamma is linear in zeta at fixed theta, so
  /// over [-1, 1] the surface lies within the union of the two end boxes, and with
  /// t = (1 + zeta) / 2 up to h / 2 beyond [0, 1], within that union grown by h / 2 of its size
  /// on every side.
  Eigen::AlignedBox3d bounding_box(double window) const;

  /// Gamma(zeta, theta), metres.
  Eigen::Vector3d point(double zeta, double theta) const;

  /// Gamma and its derivatives with respect to the convective coordinates at one point, plus
  /// the rotated section vectors the DOF derivatives need. Gamma_zz = 0 (linear in zeta).
  struct Point {
    double shape[2] = {0.0, 0.0}; ///< N_A = (1 - zeta)/2, N_B = (1 + zeta)/2
    Eigen::Vector3d x;            ///< Gamma, metres
    Eigen::Vector3d d_zeta;       ///< dGamma/dzeta
    Eigen::Vector3d d_theta;      ///< dGamma/dtheta
    Eigen::Vector3d d_zeta_theta; ///< d2Gamma/dzeta dtheta
    Eigen::Vector3d d_theta_theta;
    Eigen::Vector3d v[2];       ///< Q_k s(theta), node k's section vector
    Eigen::Vector3d dv[2];      ///< Q_k s'(theta)
    Eigen::Vector2d section;    ///< s(theta), section axes
    Eigen::Vector2d section_dt; ///< s'(theta)
  };

  /// Gamma and its derivatives at (zeta, theta). Never allocates.
  Point evaluate(double zeta, double theta) const;

  /// Derivatives of surface quantities with respect to the element's 12 DOFs (x_A, x_B,
  /// alpha_A, alpha_B) at fixed (zeta, theta), from an evaluated point: 3 x 12, metres per metre
  /// for the translations and metres per unit Rodrigues parameter for the increments, with
  /// d(Q(alpha) w)/dalpha = -skew(Q w) Xi(alpha). For the friction kernel (surface_friction.hpp).
  using Jacobian = Eigen::Matrix<double, 3, 12>;
  /// dGamma/dd: N_k I for x_k, -N_k skew(v_k) Xi_k for alpha_k.
  Jacobian jacobian(const Point& p) const;
  /// d(Gamma_zeta)/dd: -+1/2 I for x_k, -+1/2 (-skew(v_k) Xi_k) for alpha_k (minus for k = 0).
  Jacobian d_zeta_jacobian(const Point& p) const;
  /// d(Gamma_theta)/dd: zero for x_k, -N_k skew(Q_k s'(theta)) Xi_k for alpha_k.
  Jacobian d_theta_jacobian(const Point& p) const;
  /// d2(y . Gamma)/dd2 at fixed (zeta, theta) and fixed y (any 3-vector), 12 x 12: Gamma is
  /// linear in the translations, so only the two alpha_k blocks are non-zero: the Hessian of
  /// N_k y . Q(alpha_k) w_k, w_k = Q_n,k s(theta) (closed form as in surface_contact.cpp).
  Eigen::Matrix<double, 12, 12> weighted_hessian(const Point& p, const Eigen::Vector3d& y) const;

  /// Unit outward normal at an evaluated point: (Gamma_theta x Gamma_zeta) normalised, turned to
  /// point away from the axis (the section is convex around its centre). Zero if the tangents
  /// are parallel.
  Eigen::Vector3d outward_normal(const Point& p) const;

private:
  SurfaceNode nodes_[2];
  SuperEllipse section_;
  bool closes_end_;
  Eigen::Matrix3d rotation_[2];
  Eigen::Matrix3d xi_[2];
  bool has_previous_ = false;
  Eigen::Vector3d previous_position_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d previous_rotation_ = Eigen::Matrix3d::Identity();
};

} // namespace yarnsim::contact
