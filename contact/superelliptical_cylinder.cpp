#include "contact/superelliptical_cylinder.hpp"

#include "engine/math/rotation.hpp"

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace yarnsim::contact {

namespace {

void require(bool condition, const char* what, double value) {
  if (!condition) {
    std::ostringstream message;
    message << "super-elliptical cylinder: expected " << what << ", found " << value;
    throw std::invalid_argument(message.str());
  }
}

bool finite(const Eigen::Vector3d& v) {
  return v.allFinite();
}

} // namespace

SuperEllipse::SuperEllipse(double a, double b, double m) : a_(a), b_(b), m_(m) {
  require(std::isfinite(a) && a > 0.0, "a finite semi-axis a > 0 (m)", a);
  require(std::isfinite(b) && b > 0.0, "a finite semi-axis b > 0 (m)", b);
  require(std::isfinite(m) && m >= 2.0 && m <= 1000.0, "an exponent 2 <= m <= 1000", m);
}

SuperEllipse::Point SuperEllipse::point(double theta) const {
  const double c = std::cos(theta);
  const double s = std::sin(theta);
  Point p;
  if (m_ == 2.0) {
    p.value << a_ * c, b_ * s;
    p.first << -a_ * s, b_ * c;
    p.second << -a_ * c, -b_ * s;
    return p;
  }
  // S = |c|^m + |s|^m, phi = S^(-1/m):
  //   S'  = m c s (|s|^(m-2) - |c|^(m-2))
  //   S'' = m (c^2 - s^2)(|s|^(m-2) - |c|^(m-2)) + m (m-2)(c^2 |s|^(m-2) + s^2 |c|^(m-2))
  //   phi' = -phi S' / (m S),  phi'' = phi / (m S) ((1 + 1/m) S'^2 / S - S'')
  // All finite for m >= 2 (|.|^(m-2) is continuous there).
  const double m = m_;
  const double pc = std::pow(std::abs(c), m - 2.0);
  const double ps = std::pow(std::abs(s), m - 2.0);
  const double S = pc * c * c + ps * s * s;
  const double S1 = m * c * s * (ps - pc);
  const double S2 = m * (c * c - s * s) * (ps - pc) + m * (m - 2.0) * (c * c * ps + s * s * pc);
  const double phi = std::pow(S, -1.0 / m);
  const double phi1 = -phi * S1 / (m * S);
  const double phi2 = phi / (m * S) * ((1.0 + 1.0 / m) * S1 * S1 / S - S2);
  const double x0 = phi * c;
  const double x1 = phi1 * c - phi * s;
  const double x2 = phi2 * c - 2.0 * phi1 * s - phi * c;
  const double y0 = phi * s;
  const double y1 = phi1 * s + phi * c;
  const double y2 = phi2 * s + 2.0 * phi1 * c - phi * s;
  p.value << a_ * x0, b_ * y0;
  p.first << a_ * x1, b_ * y1;
  p.second << a_ * x2, b_ * y2;
  return p;
}

Eigen::Vector2d SuperEllipse::third_derivative(double theta) const {
  const double c = std::cos(theta);
  const double s = std::sin(theta);
  if (m_ == 2.0) {
    return {a_ * s, -b_ * c};
  }
  // As in point(), with pc = |c|^(m-2), ps = |s|^(m-2), D = ps - pc, E = c^2 ps + s^2 pc:
  //   S''' = -4 m c s D + m (c^2 - s^2) D' + m (m-2) E',
  //   D' = ps' - pc',  E' = 2 c s (pc - ps) + c^2 ps' + s^2 pc',
  //   ps' = (m-2) |s|^(m-3) sgn(s) c,  pc' = -(m-2) |c|^(m-3) sgn(c) s;
  // with L = phi'/phi = -S'/(m S): L' = -(S'' S - S'^2)/(m S^2),
  //   L'' = -(S'''/S - 3 S' S''/S^2 + 2 S'^3/S^3)/m,
  //   phi'' = phi (L^2 + L'),  phi''' = phi' (L^2 + L') + phi (2 L L' + L''),
  //   x''' = phi''' c - 3 phi'' s - 3 phi' c + phi s,  y''' = phi''' s + 3 phi'' c - 3 phi' s - phi
  //   c.
  const double m = m_;
  const double pc = std::pow(std::abs(c), m - 2.0);
  const double ps = std::pow(std::abs(s), m - 2.0);
  const double ps1 =
      s == 0.0 ? 0.0 : (m - 2.0) * std::pow(std::abs(s), m - 3.0) * std::copysign(1.0, s) * c;
  const double pc1 =
      c == 0.0 ? 0.0 : -(m - 2.0) * std::pow(std::abs(c), m - 3.0) * std::copysign(1.0, c) * s;
  const double S = pc * c * c + ps * s * s;
  const double D = ps - pc;
  const double S1 = m * c * s * D;
  const double S2 = m * (c * c - s * s) * D + m * (m - 2.0) * (c * c * ps + s * s * pc);
  const double E1 = 2.0 * c * s * (pc - ps) + c * c * ps1 + s * s * pc1;
  const double S3 = -4.0 * m * c * s * D + m * (c * c - s * s) * (ps1 - pc1) + m * (m - 2.0) * E1;
  const double phi = std::pow(S, -1.0 / m);
  const double L = -S1 / (m * S);
  const double L1 = -(S2 * S - S1 * S1) / (m * S * S);
  const double L2 = -(S3 / S - 3.0 * S1 * S2 / (S * S) + 2.0 * S1 * S1 * S1 / (S * S * S)) / m;
  const double phi1 = phi * L;
  const double phi2 = phi * (L * L + L1);
  const double phi3 = phi1 * (L * L + L1) + phi * (2.0 * L * L1 + L2);
  const double x3 = phi3 * c - 3.0 * phi2 * s - 3.0 * phi1 * c + phi * s;
  const double y3 = phi3 * s + 3.0 * phi2 * c - 3.0 * phi1 * s - phi * c;
  return {a_ * x3, b_ * y3};
}

double SuperEllipse::support(const Eigen::Vector2d& n) const {
  if (m_ == 2.0) {
    return std::sqrt(a_ * a_ * n.x() * n.x() + b_ * b_ * n.y() * n.y());
  }
  // Dual norm of the l_m norm of (x/a, y/b): the l_q norm of (a n1, b n2), 1/m + 1/q = 1.
  const double q = m_ / (m_ - 1.0);
  return std::pow(std::pow(std::abs(a_ * n.x()), q) + std::pow(std::abs(b_ * n.y()), q), 1.0 / q);
}

double SuperEllipse::normal_angle(const Eigen::Vector2d& n) const {
  // The gradient of |X|^m + |Y|^m (X = x/a, Y = y/b) is parallel to n where
  // |X|^(m-1) ~ a |n1| and |Y|^(m-1) ~ b |n2|, with the signs of n; theta = atan2(Y, X) since
  // (X, Y) = phi (cos theta, sin theta).
  if (m_ == 2.0) {
    return std::atan2(b_ * n.y(), a_ * n.x());
  }
  const double e = 1.0 / (m_ - 1.0);
  const double X = std::copysign(std::pow(a_ * std::abs(n.x()), e), n.x());
  const double Y = std::copysign(std::pow(b_ * std::abs(n.y()), e), n.y());
  return std::atan2(Y, X);
}

double SuperEllipse::radius_of_curvature(double theta) const {
  const Point p = point(theta);
  const double speed = p.first.norm();
  const double cross = std::abs(p.first.x() * p.second.y() - p.first.y() * p.second.x());
  return cross > 0.0 ? speed * speed * speed / cross : std::numeric_limits<double>::infinity();
}

namespace {

void require_finite(const SurfaceNode& n, const char* which) {
  if (!finite(n.position) || !finite(n.rotation_increment) || !n.converged_rotation.allFinite()) {
    std::ostringstream message;
    message << "super-elliptical cylinder: expected finite data at " << which << ", found position "
            << n.position.transpose() << ", rotation increment "
            << n.rotation_increment.transpose();
    throw std::invalid_argument(message.str());
  }
}

} // namespace

SuperEllipticalCylinder::SuperEllipticalCylinder(const SurfaceNode& node_A,
                                                 const SurfaceNode& node_B,
                                                 const SuperEllipse& section, bool closes_end,
                                                 const SurfaceNode* previous)
    : nodes_{node_A, node_B}, section_(section), closes_end_(closes_end) {
  for (int k = 0; k < 2; ++k) {
    const SurfaceNode& n = nodes_[k];
    require_finite(n, k == 0 ? "node A" : "node B");
    rotation_[k] = rodrigues_rotation<double>(n.rotation_increment) * n.converged_rotation;
    xi_[k] = rodrigues_xi<double>(n.rotation_increment);
  }
  if (previous != nullptr) {
    require_finite(*previous, "the previous element's first node");
    has_previous_ = true;
    previous_position_ = previous->position;
    previous_rotation_ =
        rodrigues_rotation<double>(previous->rotation_increment) * previous->converged_rotation;
  }
}

namespace {

/// S(t) = t^3 (10 - 15 t + 6 t^2) clamped to [0, 1], and S'(t) = 30 t^2 (1 - t)^2.
double smooth_step(double t, double& derivative) {
  if (t <= 0.0) {
    derivative = 0.0;
    return 0.0;
  }
  if (t >= 1.0) {
    derivative = 0.0;
    return 1.0;
  }
  derivative = 30.0 * t * t * (1.0 - t) * (1.0 - t);
  return t * t * t * (10.0 + t * (-15.0 + 6.0 * t));
}

} // namespace

double SuperEllipticalCylinder::share(double zeta, double half_width, double* derivative) const {
  const double h = half_width;
  double value = 1.0;
  double slope = 0.0;
  if (h <= 0.0) {
    value = owns(zeta) ? 1.0 : 0.0;
  } else {
    if (has_previous_) {
      double d = 0.0;
      value = smooth_step((zeta + 1.0 + h) / (2.0 * h), d);
      slope = d / (2.0 * h);
    } else if (zeta < -1.0 - kEndBand) {
      value = 0.0;
    }
    if (!closes_end_) {
      double d = 0.0;
      const double v = smooth_step((1.0 + h - zeta) / (2.0 * h), d);
      slope = slope * v - value * d / (2.0 * h);
      value *= v;
    } else if (zeta > 1.0 + kEndBand) {
      value = 0.0;
      slope = 0.0;
    }
  }
  if (derivative != nullptr) {
    *derivative = slope;
  }
  return value;
}

Eigen::Vector3d SuperEllipticalCylinder::previous_d_zeta(double theta) const {
  if (!has_previous_) {
    return Eigen::Vector3d::Zero();
  }
  const Eigen::Vector2d s = section_.point(theta).value;
  const Eigen::Matrix3d dq = rotation_[0] - previous_rotation_;
  return 0.5 * (nodes_[0].position - previous_position_ + s.x() * dq.col(0) + s.y() * dq.col(1));
}

Eigen::Vector3d SuperEllipticalCylinder::axis_point(double zeta) const {
  return 0.5 * (1.0 - zeta) * nodes_[0].position + 0.5 * (1.0 + zeta) * nodes_[1].position;
}

Eigen::AlignedBox3d SuperEllipticalCylinder::bounding_box(double window) const {
  Eigen::AlignedBox3d box;
  for (int k = 0; k < 2; ++k) {
    Eigen::Vector3d extent;
    for (int i = 0; i < 3; ++i)
      extent(i) = section_.support(Eigen::Vector2d(rotation_[k](i, 0), rotation_[k](i, 1)));
    box.extend(nodes_[k].position - extent);
    box.extend(nodes_[k].position + extent);
  }
  const Eigen::Vector3d grow = 0.5 * window * box.sizes();
  return {box.min() - grow, box.max() + grow};
}

Eigen::Vector3d SuperEllipticalCylinder::point(double zeta, double theta) const {
  const Eigen::Vector2d s = section_.point(theta).value;
  const double n0 = 0.5 * (1.0 - zeta);
  const double n1 = 0.5 * (1.0 + zeta);
  return n0 * (nodes_[0].position + s.x() * rotation_[0].col(0) + s.y() * rotation_[0].col(1)) +
         n1 * (nodes_[1].position + s.x() * rotation_[1].col(0) + s.y() * rotation_[1].col(1));
}

SuperEllipticalCylinder::Point SuperEllipticalCylinder::evaluate(double zeta, double theta) const {
  const SuperEllipse::Point s = section_.point(theta);
  Point p;
  p.shape[0] = 0.5 * (1.0 - zeta);
  p.shape[1] = 0.5 * (1.0 + zeta);
  p.section = s.value;
  p.section_dt = s.first;
  Eigen::Vector3d ddv[2];
  for (int k = 0; k < 2; ++k) {
    const Eigen::Matrix3d& q = rotation_[k];
    p.v[k] = s.value.x() * q.col(0) + s.value.y() * q.col(1);
    p.dv[k] = s.first.x() * q.col(0) + s.first.y() * q.col(1);
    ddv[k] = s.second.x() * q.col(0) + s.second.y() * q.col(1);
  }
  const Eigen::Vector3d& x0 = nodes_[0].position;
  const Eigen::Vector3d& x1 = nodes_[1].position;
  p.x = p.shape[0] * (x0 + p.v[0]) + p.shape[1] * (x1 + p.v[1]);
  p.d_zeta = 0.5 * ((x1 + p.v[1]) - (x0 + p.v[0]));
  p.d_theta = p.shape[0] * p.dv[0] + p.shape[1] * p.dv[1];
  p.d_zeta_theta = 0.5 * (p.dv[1] - p.dv[0]);
  p.d_theta_theta = p.shape[0] * ddv[0] + p.shape[1] * ddv[1];
  return p;
}

namespace {

/// Hessian of y . Q(alpha) w with respect to alpha, y and w fixed (the same closed form as
/// surface_contact.cpp's). With A = skew(alpha), gam = 4 / (4 + alpha . alpha):
/// y . Q w = y . w + gam h, h = alpha . (w x y) + alpha^T M alpha / 2, M = sym(y w^T) - (y . w)
/// I; grad gam = -gam^2 alpha / 2.
Eigen::Matrix3d rotation_hessian(const Eigen::Vector3d& alpha, const Eigen::Vector3d& w,
                                 const Eigen::Vector3d& y) {
  const double gam = 4.0 / (4.0 + alpha.squaredNorm());
  Eigen::Matrix3d m = 0.5 * (y * w.transpose() + w * y.transpose());
  m.diagonal().array() -= y.dot(w);
  const Eigen::Vector3d b = w.cross(y);
  const Eigen::Vector3d q = b + m * alpha;
  const double h = alpha.dot(b) + 0.5 * alpha.dot(m * alpha);
  Eigen::Matrix3d out = gam * m;
  out.diagonal().array() -= 0.5 * gam * gam * h;
  out.noalias() += (0.5 * gam * gam * gam * h) * alpha * alpha.transpose();
  out.noalias() -= (0.5 * gam * gam) * (alpha * q.transpose() + q * alpha.transpose());
  return out;
}

} // namespace

SuperEllipticalCylinder::Jacobian SuperEllipticalCylinder::jacobian(const Point& p) const {
  Jacobian j = Jacobian::Zero();
  for (int k = 0; k < 2; ++k) {
    j.block<3, 3>(0, 3 * k).diagonal().setConstant(p.shape[k]);
    j.block<3, 3>(0, 6 + 3 * k) = -p.shape[k] * skew<double>(p.v[k]) * xi_[k];
  }
  return j;
}

SuperEllipticalCylinder::Jacobian SuperEllipticalCylinder::d_zeta_jacobian(const Point& p) const {
  Jacobian j = Jacobian::Zero();
  for (int k = 0; k < 2; ++k) {
    const double s = k == 0 ? -0.5 : 0.5;
    j.block<3, 3>(0, 3 * k).diagonal().setConstant(s);
    j.block<3, 3>(0, 6 + 3 * k) = -s * skew<double>(p.v[k]) * xi_[k];
  }
  return j;
}

SuperEllipticalCylinder::Jacobian SuperEllipticalCylinder::d_theta_jacobian(const Point& p) const {
  Jacobian j = Jacobian::Zero();
  for (int k = 0; k < 2; ++k) {
    j.block<3, 3>(0, 6 + 3 * k) = -p.shape[k] * skew<double>(p.dv[k]) * xi_[k];
  }
  return j;
}

Eigen::Matrix<double, 12, 12>
SuperEllipticalCylinder::weighted_hessian(const Point& p, const Eigen::Vector3d& y) const {
  Eigen::Matrix<double, 12, 12> h = Eigen::Matrix<double, 12, 12>::Zero();
  for (int k = 0; k < 2; ++k) {
    const Eigen::Matrix3d& qn = nodes_[k].converged_rotation;
    const Eigen::Vector3d w = p.section.x() * qn.col(0) + p.section.y() * qn.col(1);
    h.block<3, 3>(6 + 3 * k, 6 + 3 * k) =
        rotation_hessian(nodes_[k].rotation_increment, w, p.shape[k] * y);
  }
  return h;
}

Eigen::Vector3d SuperEllipticalCylinder::outward_normal(const Point& p) const {
  Eigen::Vector3d n = p.d_theta.cross(p.d_zeta);
  const double length = n.norm();
  if (!(length > 0.0)) {
    return Eigen::Vector3d::Zero();
  }
  const Eigen::Vector3d radial = p.shape[0] * p.v[0] + p.shape[1] * p.v[1];
  return (n.dot(radial) < 0.0 ? -1.0 : 1.0) / length * n;
}

} // namespace yarnsim::contact
