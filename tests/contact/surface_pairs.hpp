#pragma once
// Element surfaces shared by the surface contact and surface friction tests: the study's scales,
// node frames and random rotations drawn from a test's own engine. (Its own namespace: the
// spline tests' spline_pairs.hpp has a random_rotation of the same signature.)
#include "contact/superelliptical_cylinder.hpp"
#include "engine/math/rotation.hpp"

#include <Eigen/Geometry>

#include <random>

namespace yarnsim::contact::surface_test {

// Scales of the study (formulation.md §1): semi-axes 1.136 mm and 0.284 mm, surface penalty
// 3.5e5 N/m, penetrations of microns, elements about 1 mm long.
constexpr double kA = 1.136364e-3;
constexpr double kB = 2.840909e-4;
constexpr double kEps = 3.5e5;
constexpr double kPi = 3.14159265358979323846;

/// Rotation with columns e1, e2 = e3 x e1, e3.
inline Eigen::Matrix3d frame(const Eigen::Vector3d& e1, const Eigen::Vector3d& e3) {
  Eigen::Matrix3d q;
  q.col(0) = e1.normalized();
  q.col(2) = e3.normalized();
  q.col(1) = q.col(2).cross(q.col(0));
  return q;
}

/// A uniformly random rotation drawn from `rng` (Eigen's UnitRandom uses the global std::rand,
/// which would make each test depend on the ones before it). The four deviates are drawn as the
/// compiler evaluates the constructor's arguments (unspecified order: GCC's configurations are
/// the ones the tests' figures were measured on; spline_pairs.hpp draws one per statement).
inline Eigen::Quaterniond random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized();
}

/// A node whose current rotation is `q`, reached by the Rodrigues increment `alpha` from
/// Q_n = Q(alpha)^T q.
inline SurfaceNode node(const Eigen::Vector3d& x, const Eigen::Matrix3d& q,
                        const Eigen::Vector3d& alpha = Eigen::Vector3d::Zero()) {
  SurfaceNode n;
  n.position = x;
  n.rotation_increment = alpha;
  n.converged_rotation = rodrigues_rotation<double>(alpha).transpose() * q;
  return n;
}

} // namespace yarnsim::contact::surface_test
