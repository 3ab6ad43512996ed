#include "contact/interface_law.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <stdexcept>

namespace yarnsim::contact {
namespace {

/// Central difference of f(p) with a step relative to p.
template <class F>
double central(F f, double x, double h) {
  return (f(x + h) - f(x - h)) / (2.0 * h);
}

void expect_consistent(const InterfaceLaw& law, double p, double rate) {
  const double h = 1e-6 * p;
  const double dfdp = central([&](double q) { return law.force(q, rate); }, p, h);
  EXPECT_NEAR(law.stiffness(p, rate), dfdp, 1e-7 * std::abs(dfdp) + 1e-9) << "p = " << p;
  const double hr = 1e-6 * (std::abs(rate) + 1.0);
  const double dfdr = central([&](double v) { return law.force(p, v); }, rate, hr);
  EXPECT_NEAR(law.damping(p, rate), dfdr, 1e-7 * std::abs(dfdr) + 1e-9) << "rate = " << rate;
  const double dudp = central([&](double q) { return law.potential(q); }, p, h);
  const double f0 = law.force(p, 0.0);
  EXPECT_NEAR(dudp, f0, 1e-7 * f0) << "potential is not the integral of the force";
}

TEST(InterfaceLaw, LinearPenaltyIsEpsTimesPenetration) {
  const LinearPenalty law(1.5e6);
  EXPECT_DOUBLE_EQ(law.force(2e-6), 3.0);
  EXPECT_DOUBLE_EQ(law.stiffness(2e-6), 1.5e6);
  EXPECT_DOUBLE_EQ(law.potential(2e-6), 0.5 * 1.5e6 * 4e-12);
  for (const double p : {1e-7, 3e-6, 2e-4}) {
    expect_consistent(law, p, 0.0);
  }
}

TEST(InterfaceLaw, RegularisedPenaltyIsC1FromItsOnsetAndLinearInContact) {
  // Meier, Popp and Wall's regularised penalty: eps (p + g0)^2 / (2 g0) over -g0 < p < 0, then
  // eps (p + g0 / 2).
  const double eps = 1.5e6, g0 = 2e-6;
  const RegularisedPenalty law(eps, g0);
  EXPECT_EQ(law.onset(), g0);
  EXPECT_EQ(law.force(-g0), 0.0);
  EXPECT_EQ(law.force(-2 * g0), 0.0);
  EXPECT_EQ(law.stiffness(-g0), 0.0);
  EXPECT_EQ(law.potential(-g0), 0.0);
  EXPECT_DOUBLE_EQ(law.force(-0.5 * g0), eps * 0.25 * g0 / 2);
  EXPECT_DOUBLE_EQ(law.force(0.0), eps * g0 / 2);
  EXPECT_DOUBLE_EQ(law.force(4e-6), eps * (4e-6 + g0 / 2));
  // C1 at both joints: force and slope from either side.
  for (const double joint : {-g0, 0.0}) {
    const double d = 1e-9 * g0;
    EXPECT_NEAR(law.force(joint + d), law.force(joint - d), 1e-6 * eps * g0) << joint;
    EXPECT_NEAR(law.stiffness(joint + d), law.stiffness(joint - d), 1e-6 * eps) << joint;
  }
  for (const double p : {-0.9 * g0, -0.3 * g0, 0.2 * g0, 3e-6, 2e-4})
    expect_consistent(law, p, 0.0);
  // Damped: the same onset.
  const DampedLaw damped(std::make_shared<RegularisedPenalty>(eps, g0), 50.0);
  EXPECT_EQ(damped.onset(), g0);
  EXPECT_GT(damped.force(-0.5 * g0, 0.0), 0.0);
  EXPECT_EQ(damped.force(-1.5 * g0, 1.0), 0.0);
  EXPECT_THROW(RegularisedPenalty(eps, 0.0), std::invalid_argument);
  EXPECT_THROW(RegularisedPenalty(eps, -1e-6), std::invalid_argument);
  EXPECT_THROW(RegularisedPenalty(0.0, g0), std::invalid_argument);
}

TEST(InterfaceLaw, PowerLawMatchesFiniteDifferences) {
  for (const double n : {1.0, 1.5, 2.0, 3.7}) {
    const PowerLaw law(2e9, n);
    for (const double p : {1e-7, 3e-6, 2e-4}) {
      EXPECT_NEAR(law.force(p), 2e9 * std::pow(p, n), 1e-12 * 2e9 * std::pow(p, n));
      expect_consistent(law, p, 0.0);
    }
  }
}

TEST(InterfaceLaw, PowerLawStiffnessIsContinuousAtContactOnset) {
  const PowerLaw law(1e9, 2.0);
  EXPECT_EQ(law.stiffness(0.0), 0.0);
  EXPECT_NEAR(law.stiffness(1e-12), 0.0, 1e-2);
}

TEST(InterfaceLaw, NoForceWithoutPenetration) {
  const auto linear = std::make_shared<LinearPenalty>(1e5);
  const PowerLaw power(1e5, 2.0);
  const DampedLaw damped(linear, 10.0);
  for (const InterfaceLaw* law :
       {static_cast<const InterfaceLaw*>(linear.get()), static_cast<const InterfaceLaw*>(&power),
        static_cast<const InterfaceLaw*>(&damped)}) {
    for (const double p : {-1e-3, -1e-9, 0.0}) {
      EXPECT_EQ(law->force(p, 1.0), 0.0);
      EXPECT_EQ(law->force(p, -1.0), 0.0);
      EXPECT_EQ(law->stiffness(p, 1.0), 0.0);
      EXPECT_EQ(law->damping(p, 1.0), 0.0);
      EXPECT_EQ(law->potential(p), 0.0);
    }
  }
}

TEST(InterfaceLaw, DampingAddsRateTermWhilePenetrating) {
  const DampedLaw law(std::make_shared<PowerLaw>(1e9, 1.5), 50.0);
  const double p = 1e-5;
  EXPECT_DOUBLE_EQ(law.force(p, 0.01), 1e9 * std::pow(p, 1.5) + 50.0 * 0.01);
  expect_consistent(law, p, 0.01);
  expect_consistent(law, p, -0.5); // separating, still pressing
}

TEST(InterfaceLaw, DampingNeverPulls) {
  const DampedLaw law(std::make_shared<LinearPenalty>(1e5), 100.0);
  const double p = 1e-6;     // elastic force 0.1 N
  const double rate = -0.01; // damping -1 N: would pull
  EXPECT_EQ(law.force(p, rate), 0.0);
  EXPECT_EQ(law.stiffness(p, rate), 0.0);
  EXPECT_EQ(law.damping(p, rate), 0.0);
  EXPECT_GT(law.potential(p), 0.0);
}

TEST(InterfaceLaw, RejectsBadParameters) {
  EXPECT_THROW(LinearPenalty(0.0), std::invalid_argument);
  EXPECT_THROW(LinearPenalty(-1.0), std::invalid_argument);
  EXPECT_THROW(LinearPenalty(NAN), std::invalid_argument);
  EXPECT_THROW(PowerLaw(1.0, 0.5), std::invalid_argument);
  EXPECT_THROW(PowerLaw(-1.0, 2.0), std::invalid_argument);
  EXPECT_THROW(DampedLaw(nullptr, 1.0), std::invalid_argument);
  EXPECT_THROW(DampedLaw(std::make_shared<LinearPenalty>(1.0), -1.0), std::invalid_argument);
}

} // namespace
} // namespace yarnsim::contact
