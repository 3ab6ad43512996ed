// The shear tests' kinematics and normalisations (engine/textile/shear_kinematics.hpp) against
// the benchmark's definitions (../shared/docs/shear-tests.md): inverses, the kinematic limits,
// and the energy method of the bias extension recovering the torque curve of a synthetic fabric
// whose pulling force is built from the power balance.
#include "engine/textile/shear_kinematics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <vector>

namespace yarnsim::textile {
namespace {

constexpr double kDeg = std::numbers::pi / 180;

TEST(ShearKinematics, PictureFrameAngleAndDisplacementAreInverse) {
  const double L = 0.2;
  EXPECT_NEAR(picture_frame_angle(0.0, L), 0.0, 1e-15);
  // 30 degrees: d = 2 L cos 30 - sqrt(2) L = (sqrt 3 - sqrt 2) L.
  EXPECT_NEAR(picture_frame_displacement(30 * kDeg, L), (std::sqrt(3.0) - std::sqrt(2.0)) * L,
              1e-15);
  for (double gamma = 0; gamma <= 85 * kDeg; gamma += 5 * kDeg)
    EXPECT_NEAR(picture_frame_angle(picture_frame_displacement(gamma, L), L), gamma, 1e-12);
  // At gamma = 0 the shear force is F / (2 cos 45) = F / sqrt 2; the normalised force F_s / L
  // when the fabric fills the frame.
  EXPECT_NEAR(picture_frame_shear_force(10.0, 0.0), 10.0 / std::sqrt(2.0), 1e-14);
  EXPECT_NEAR(picture_frame_normalised_force(10.0, 0.0, L, L), 10.0 / std::sqrt(2.0) / L, 1e-12);
  EXPECT_THROW(picture_frame_angle(0.7 * L, L), std::invalid_argument);
  EXPECT_THROW(picture_frame_angle(0.0, 0.0), std::invalid_argument);
}

TEST(ShearKinematics, BiasExtensionAngleReachesNinetyDegreesAtTheLimit) {
  const double H = 0.2, W = 0.1;
  EXPECT_NEAR(bias_extension_angle(0.0, H, W), 0.0, 1e-15);
  EXPECT_NEAR(bias_extension_angle((std::sqrt(2.0) - 1) * (H - W), H, W), 90 * kDeg, 1e-7);
  for (double gamma = 0; gamma <= 85 * kDeg; gamma += 5 * kDeg)
    EXPECT_NEAR(bias_extension_angle(bias_extension_displacement(gamma, H, W), H, W), gamma, 1e-12);
  EXPECT_THROW(bias_extension_angle(0.05, H, W), std::invalid_argument); // beyond the limit
  EXPECT_THROW(bias_extension_angle(0.0, W, W), std::invalid_argument);
}

/// A synthetic fabric with shear torque per area C_s(gamma) (N/m): the bias extension's pulling
/// force from the power balance F = (C_s(gamma) A_C + C_s(gamma/2) A_B / 2) dgamma/dd. The energy
/// method must give back F_sh = C_s / cos(gamma).
TEST(ShearKinematics, BiasExtensionEnergyMethodRecoversTheTorqueCurve) {
  const double H = 0.23, W = 0.115;
  const double A_C = (2 * H * W - 3 * W * W) / 2, A_B = W * W;
  const auto torque = [](double g) { return 0.8 * g + 5.0 * g * g * g; }; // N/m
  std::vector<double> gamma, F;
  const int n = 2000;
  for (int i = 0; i <= n; ++i) {
    const double g = 60 * kDeg * i / n;
    // dgamma/dd from d(gamma) = sqrt(2) (H - W) cos(pi/4 - gamma/2) - (H - W).
    const double dd = std::sqrt(2.0) * (H - W) * std::sin(std::numbers::pi / 4 - g / 2) / 2;
    gamma.push_back(g);
    F.push_back((torque(g) * A_C + torque(g / 2) * A_B / 2) / dd);
  }
  const std::vector<double> f_sh = bias_extension_normalised_force(gamma, F, H, W);
  double worst = 0;
  for (int i = 1; i <= n; ++i) {
    const double exact = torque(gamma[i]) / std::cos(gamma[i]);
    worst = std::max(worst, std::abs(f_sh[i] - exact) / exact);
  }
  RecordProperty("worst_relative_error", std::to_string(worst));
  EXPECT_LT(worst, 1e-5); // the linear interpolation of F_sh(gamma / 2) on 2000 samples
  EXPECT_NEAR(f_sh[0], 0.0, 1e-15);
  EXPECT_THROW(bias_extension_normalised_force(gamma, F, 1.5 * W, W), std::invalid_argument);
  // The benchmark's H / W = 2 from a height and two clamps (0.21 - 2 x 0.005 m, a round-off
  // below 0.2 m for W = 0.1 m) is H = 2 W: accepted, as the deck and the test's set-up accept it
  // (it stopped a 100 x 200 mm run at its first curve's row).
  const double H2 = 0.21 - 2 * 0.005, W2 = 0.1;
  ASSERT_LT(H2, 2 * W2);
  EXPECT_TRUE(bias_extension_zones_fit(H2, W2));
  EXPECT_NO_THROW(bias_extension_normalised_force(gamma, F, H2, W2));
  EXPECT_FALSE(bias_extension_zones_fit(2 * W2 * (1 - 1e-9), W2));
}

TEST(ShearKinematics, LockingAngleOfThePapersFabricIsSixtyDegrees) {
  EXPECT_NEAR(locking_angle(2 * 1.136364e-3, 4.54545e-3) / kDeg, 60.0, 1e-3);
  EXPECT_THROW(locking_angle(5e-3, 4e-3), std::invalid_argument);
}

} // namespace
} // namespace yarnsim::textile
