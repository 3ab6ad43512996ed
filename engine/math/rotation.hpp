#pragma once
// Finite rotations through Rodrigues parameters (formulation.md §2; Campello, Pimenta and Wriggers,
// "A triangular finite shell element based on a fully nonlinear shell formulation", and Giraffe's
// Beam_1). A rotation increment alpha = 2 tan(theta/2) e with |alpha| finite up to theta = pi:
//   Q(alpha)  = I + g (A + A^2 / 2),   g = 4 / (4 + alpha . alpha),  A = skew(alpha)
//   Xi(alpha) = g (I + A / 2),          spatial spin: delta theta = Xi(alpha) delta alpha
// Only increments since the last converged step are parametrised, so a node may turn any number
// of times.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace yarnsim {

template <typename T>
using Vec3 = Eigen::Matrix<T, 3, 1>;
template <typename T>
using Mat3 = Eigen::Matrix<T, 3, 3>;

/// skew(v) w = v x w.
template <typename T>
Mat3<T> skew(const Vec3<T>& v) {
  Mat3<T> s;
  s << T(0), -v(2), v(1), v(2), T(0), -v(0), -v(1), v(0), T(0);
  return s;
}

/// Axial vector of the skew part of m: axial(skew(v)) = v.
inline Eigen::Vector3d axial(const Eigen::Matrix3d& m) {
  return 0.5 * Eigen::Vector3d(m(2, 1) - m(1, 2), m(0, 2) - m(2, 0), m(1, 0) - m(0, 1));
}

/// Rotation tensor of Rodrigues parameters alpha.
template <typename T>
Mat3<T> rodrigues_rotation(const Vec3<T>& alpha) {
  const T g = T(4) / (T(4) + alpha.dot(alpha));
  const Mat3<T> A = skew(alpha);
  return Mat3<T>::Identity() + g * (A + T(0.5) * A * A);
}

/// Xi(alpha): maps the variation of Rodrigues parameters to the spatial spin.
template <typename T>
Mat3<T> rodrigues_xi(const Vec3<T>& alpha) {
  const T g = T(4) / (T(4) + alpha.dot(alpha));
  return g * (Mat3<T>::Identity() + T(0.5) * skew(alpha));
}

/// Rotation vector theta e of the rotation with Rodrigues parameters alpha (theta < pi).
template <typename T>
Vec3<T> rotation_vector_of_rodrigues(const Vec3<T>& alpha) {
  using std::asin;
  using std::sqrt;
  const T s2 = alpha.dot(alpha);
  // theta / |alpha| = 2 atan(|alpha| / 2) / |alpha|; series near zero keeps derivatives finite.
  T factor;
  if (s2 < T(1e-4))
    factor = T(1) - s2 / T(12) + s2 * s2 / T(80) - s2 * s2 * s2 / T(448);
  else {
    const T s = sqrt(s2);
    const T half = s / T(2);
    // atan(h) = asin(h / sqrt(1 + h^2)): Eigen's AutoDiffScalar has asin but no atan.
    const T angle = asin(half / sqrt(T(1) + half * half));
    factor = T(2) * angle / s;
  }
  return factor * alpha;
}

/// Exponential map: rotation tensor of the rotation vector theta (any angle).
Eigen::Matrix3d rotation_matrix(const Eigen::Vector3d& theta);

/// Rotation vector of a rotation tensor, angle in [0, pi].
Eigen::Vector3d rotation_vector(const Eigen::Matrix3d& Q);

/// Rodrigues parameters of a rotation tensor whose angle is below pi.
Eigen::Vector3d rodrigues_of(const Eigen::Matrix3d& Q);

/// Rodrigues parameters 2 tan(|phi| / 2) phi / |phi| of the rotation vector phi (|phi| < pi):
/// rodrigues_rotation of them is rotation_matrix(phi).
Eigen::Vector3d rodrigues_of_vector(const Eigen::Vector3d& phi);

/// An orthonormal triad (columns e1, e2, e3) with e3 along axis and e1 along the part of
/// reference normal to it. Throws std::invalid_argument when reference is parallel to axis.
Eigen::Matrix3d triad_from(const Eigen::Vector3d& axis, const Eigen::Vector3d& reference);

/// Re-orthonormalise a rotation tensor drifting by round-off (polar decomposition by SVD).
Eigen::Matrix3d orthonormalized(const Eigen::Matrix3d& Q);

} // namespace yarnsim
