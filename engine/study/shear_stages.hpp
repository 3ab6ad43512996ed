#pragma once
// The deformed specimen of a shear test (picture frame, bias extension) at stages of a run, read
// from the results.h5 the run wrote, with the local shear angle at every crossing: what yarnsim
// study draws in deformed-<case>.png, the picture a user compares with photographs of the test.

#include "engine/model/model.hpp"

#include <Eigen/Core>
#include <filesystem>
#include <span>
#include <vector>

namespace yarnsim {

/// The crossings of the model's shear test where the pictures read the local angle:
/// PictureFrameTest::all or BiasExtensionTest::all. Throws std::invalid_argument for a model
/// without a shear test.
const std::vector<CrossingNodes>& shear_crossings(const Model& model);

/// The output step shown at `fraction` (in (0, 1]) of a run's `steps` completed output steps
/// (steps >= 1): the 0-based index ceil(fraction x steps) - 1, so that 1 is the last step.
/// Throws std::invalid_argument for a fraction outside (0, 1] or no step.
int stage_step(double fraction, int steps);

/// The specimen at one stage of a run.
struct ShearStage {
  double fraction = 0; ///< of the run's completed output steps
  int step = 0;        ///< 0-based index among them (results.h5 /steps, in order)
  int increment = 0;   ///< of the run
  double time = 0;     ///< s
  /// Degrees: the test's own angle at that time, the frame angle of a picture frame or the
  /// central zone's ideal angle of a bias extension (the step's scalar in results.h5).
  double test_angle = 0;
  /// Degrees: measure_shear's mean over the test's central crossings (curves.csv's
  /// measured_angle).
  double measured = 0;
  Eigen::Matrix3Xd positions; ///< 3 x n_nodes, m
  /// 2 x n_crossings, m: the in-plane mid-point of each crossing's warp and weft nodes, in the
  /// order of shear_crossings(model).
  Eigen::Matrix2Xd crossings;
  /// Degrees, per crossing in the same order: textile::local_shear, 90 less the in-plane angle
  /// from the warp's tangent to the weft's.
  std::vector<double> shear;
};

/// The stages at `fractions` of the completed output steps in `results` (the results.h5 a run of
/// `model` wrote), in the order of `fractions`; empty when the file holds no step. Throws
/// std::invalid_argument for a model without a shear test or a bad fraction, std::runtime_error
/// when the file cannot be read or its positions are not the model's (another node count).
std::vector<ShearStage> read_shear_stages(const Model& model, const std::filesystem::path& results,
                                          std::span<const double> fractions);

/// The yarn centre lines at positions x (3 x n_nodes, m): the elements' nodes (first, middle,
/// last) chained into one polyline for as long as each element starts at the node where the
/// previous one ended (the fabric builders number each yarn's elements in order along it).
std::vector<Eigen::Matrix3Xd> centre_lines(const Model& model, const Eigen::Matrix3Xd& x);

} // namespace yarnsim
