#include "engine/math/rotation.hpp"

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <cmath>
#include <stdexcept>

namespace yarnsim {

Eigen::Matrix3d rotation_matrix(const Eigen::Vector3d& theta) {
  const double angle = theta.norm();
  if (angle < 1e-300)
    return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, theta / angle).toRotationMatrix();
}

Eigen::Vector3d rotation_vector(const Eigen::Matrix3d& Q) {
  const Eigen::AngleAxisd aa(Q);
  return aa.angle() * aa.axis();
}

Eigen::Vector3d rodrigues_of(const Eigen::Matrix3d& Q) {
  const Eigen::Quaterniond q(Q);
  // alpha = 2 tan(theta/2) e = 2 v / w for the unit quaternion (w, v).
  const double w = q.w();
  if (std::abs(w) < 1e-12)
    throw std::domain_error("rodrigues_of: rotation of pi has no Rodrigues parameters");
  return 2.0 * q.vec() / w;
}

Eigen::Vector3d rodrigues_of_vector(const Eigen::Vector3d& phi) {
  const double a = phi.norm();
  if (a < 1e-6)
    return (1.0 + a * a / 12.0) * phi;
  return (2.0 * std::tan(0.5 * a) / a) * phi;
}

Eigen::Matrix3d triad_from(const Eigen::Vector3d& axis, const Eigen::Vector3d& reference) {
  const Eigen::Vector3d e3 = axis.normalized();
  Eigen::Vector3d e1 = reference - reference.dot(e3) * e3;
  const double n = e1.norm();
  if (!(n > 1e-8 * reference.norm()) || reference.norm() == 0.0)
    throw std::invalid_argument("reference vector is parallel to the beam axis");
  e1 /= n;
  Eigen::Matrix3d Q;
  Q.col(0) = e1;
  Q.col(1) = e3.cross(e1);
  Q.col(2) = e3;
  return Q;
}

Eigen::Matrix3d orthonormalized(const Eigen::Matrix3d& Q) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(Q, Eigen::ComputeFullU | Eigen::ComputeFullV);
  return svd.matrixU() * svd.matrixV().transpose();
}

} // namespace yarnsim
