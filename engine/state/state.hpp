#pragma once
// The state of a run: current unknowns and the history of the last converged increment.

#include "engine/state/gauss_state.hpp"

#include <Eigen/Core>
#include <array>
#include <vector>

namespace yarnsim {

struct State {
  double time = 0; ///< s, of the last converged increment
  int increment = 0;

  // Unknowns of the increment in progress.
  Eigen::Matrix3Xd x;     ///< current positions, 3 x n_nodes, m
  Eigen::Matrix3Xd alpha; ///< Rodrigues parameters of the rotation increment, 3 x n_nodes

  // Last converged increment.
  Eigen::Matrix3Xd x_n;             ///< positions, m
  std::vector<Eigen::Matrix3d> Q_n; ///< nodal rotation tensors (triads), per node
  Eigen::Matrix3Xd v_n, a_n;        ///< velocity (m/s) and acceleration (m/s^2), spatial
  Eigen::Matrix3Xd W_n, A_n;        ///< angular velocity and acceleration, material frame
  Eigen::Matrix3Xd rotation_n;      ///< unwrapped rotation vector from the reference triad, rad
  std::vector<std::array<GaussState, 2>> gauss; ///< per element

  int n_nodes() const { return static_cast<int>(x.cols()); }
};

} // namespace yarnsim
