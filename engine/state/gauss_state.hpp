#pragma once
// The history a beam element's Gauss point carries from one converged increment to the next
// (formulation.md §2): part of the state; the beam kernel (engine/beam/beam_element.hpp) reads
// and updates it.

#include <Eigen/Core>

namespace yarnsim {

/// History of a Gauss point: values at the last converged step.
struct GaussState {
  Eigen::Matrix3d Q_n = Eigen::Matrix3d::Identity(); ///< section rotation
  Eigen::Vector3d kappa_n = Eigen::Vector3d::Zero(); ///< spatial curvature change, 1/m
};

} // namespace yarnsim
