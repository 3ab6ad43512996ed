#include "engine/beam/nodal_terms.hpp"

#include "engine/math/rotation.hpp"

#include <unsupported/Eigen/AutoDiff>

namespace yarnsim {

namespace {
using AD = Eigen::AutoDiffScalar<Eigen::Vector3d>;

/// alpha as a vector of active variables (derivatives seeded with the identity).
Vec3<AD> active(const Eigen::Vector3d& alpha) {
  Vec3<AD> a;
  for (int i = 0; i < 3; ++i)
    a(i) = AD(alpha(i), 3, i);
  return a;
}

void extract(const Vec3<AD>& r, Eigen::Vector3d& value, Eigen::Matrix3d& jacobian) {
  for (int i = 0; i < 3; ++i) {
    value(i) = r(i).value();
    jacobian.row(i) = r(i).derivatives().transpose();
  }
}

template <typename T>
void angular_rates(const NewmarkCoefficients& c, const NodeRotationHistory& h, const Vec3<T>& alpha,
                   Vec3<T>& W, Vec3<T>& A) {
  const Vec3<T> Theta = h.Q_n.transpose().cast<T>() * rotation_vector_of_rodrigues<T>(alpha);
  const Vec3<T> Wn = h.W_n.cast<T>(), An = h.A_n.cast<T>();
  A = T(c.a1) * Theta - T(c.a2) * Wn - T(c.a3) * An;
  W = T(c.a4) * Theta + T(c.a5) * Wn + T(c.a6) * An;
}
} // namespace

NewmarkCoefficients::NewmarkCoefficients(double beta, double gamma, double dt)
    : a1(1.0 / (beta * dt * dt)), a2(1.0 / (beta * dt)), a3(1.0 / (2.0 * beta) - 1.0),
      a4(gamma / (beta * dt)), a5(1.0 - gamma / beta), a6(dt * (1.0 - gamma / (2.0 * beta))) {}

void newmark_angular(const NewmarkCoefficients& c, const NodeRotationHistory& h,
                     const Eigen::Vector3d& alpha, Eigen::Vector3d& W, Eigen::Vector3d& A) {
  angular_rates<double>(c, h, alpha, W, A);
}

void rotary_inertia(const Eigen::Vector3d& J_material, double damping, const NewmarkCoefficients& c,
                    const NodeRotationHistory& h, const Eigen::Vector3d& alpha,
                    Eigen::Vector3d& residual, Eigen::Matrix3d& tangent) {
  const Vec3<AD> a = active(alpha);
  Vec3<AD> W, A;
  angular_rates<AD>(c, h, a, W, A);
  const Vec3<AD> J = J_material.cast<AD>();
  const Vec3<AD> JW = J.cwiseProduct(W);
  const Vec3<AD> material = J.cwiseProduct(A) + W.cross(JW) + AD(damping) * JW;
  const Mat3<AD> Q = rodrigues_rotation<AD>(a) * h.Q_n.cast<AD>();
  const Vec3<AD> r = rodrigues_xi<AD>(a).transpose() * (Q * material);
  extract(r, residual, tangent);
}

void applied_moment(const Eigen::Vector3d& moment, bool follower, const Eigen::Matrix3d& R_n,
                    const Eigen::Vector3d& alpha, Eigen::Vector3d& residual,
                    Eigen::Matrix3d& tangent) {
  const Vec3<AD> a = active(alpha);
  Vec3<AD> M = moment.cast<AD>();
  if (follower)
    M = rodrigues_rotation<AD>(a) * (R_n.cast<AD>() * M);
  const Vec3<AD> r = -(rodrigues_xi<AD>(a).transpose() * M);
  extract(r, residual, tangent);
}

} // namespace yarnsim
