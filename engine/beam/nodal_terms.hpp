#pragma once
// Node-wise terms of the residual: rotary inertia under Newmark and applied moments. Each returns
// its contribution to the residual conjugate to the Rodrigues parameters alpha of the node's
// rotation increment (r = Xi(alpha)^T m for a spatial moment m) and the derivative of that
// contribution with respect to alpha. Translational inertia and forces are linear and live in the
// assembly.

#include <Eigen/Core>

namespace yarnsim {

/// Newmark coefficients for a step dt (formulation.md §3).
struct NewmarkCoefficients {
  double a1, a2, a3, a4, a5, a6;
  NewmarkCoefficients(double beta, double gamma, double dt);
};

/// Rotational state of a node at the start of the step.
struct NodeRotationHistory {
  Eigen::Matrix3d Q_n; ///< rotation tensor
  Eigen::Vector3d W_n; ///< material angular velocity, rad/s
  Eigen::Vector3d A_n; ///< material angular acceleration, rad/s^2
};

/// Material angular velocity and acceleration at the end of the step for the increment alpha,
/// Simo and Vu-Quoc's material form of Newmark: Theta = Q_n^T theta(alpha),
/// A = a1 Theta - a2 W_n - a3 A_n, W = a4 Theta + a5 W_n + a6 A_n.
void newmark_angular(const NewmarkCoefficients& c, const NodeRotationHistory& h,
                     const Eigen::Vector3d& alpha, Eigen::Vector3d& W, Eigen::Vector3d& A);

/// Inertia moment m = Q (J A + W x J W) + damping * Q J W of a node with material rotary inertia
/// J = diag(J_material) (kg m^2): residual Xi^T m and its derivative with respect to alpha.
void rotary_inertia(const Eigen::Vector3d& J_material, double damping, const NewmarkCoefficients& c,
                    const NodeRotationHistory& h, const Eigen::Vector3d& alpha,
                    Eigen::Vector3d& residual, Eigen::Matrix3d& tangent);

/// External moment M (N m): dead (fixed in space) or follower (M = R M0 with R = Q(alpha) R_n the
/// node's rotation from its reference triad). Contribution to the internal-minus-external
/// residual: -Xi(alpha)^T M, and its derivative with respect to alpha.
void applied_moment(const Eigen::Vector3d& moment, bool follower, const Eigen::Matrix3d& R_n,
                    const Eigen::Vector3d& alpha, Eigen::Vector3d& residual,
                    Eigen::Matrix3d& tangent);

} // namespace yarnsim
