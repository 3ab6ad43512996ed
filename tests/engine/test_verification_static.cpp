// Single-beam static cases of shared/docs/verification.md: roll-up (exact), ten turns, elastica;
// Newton's quadratic convergence.
#include "beam_models.hpp"
#include "engine/solver/simulation.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <fmt/format.h>
#include <gtest/gtest.h>

namespace yarnsim {
namespace {

using test::clamp;
using test::static_step;
using test::stiffness_section;
using test::straight_beam;

struct Recorder : SimulationObserver {
  std::vector<IncrementReport> reports;
  void on_increment(const Simulation&, const IncrementReport& r) override { reports.push_back(r); }
};

/// Cantilever along x of length L clamped at 0 under a tip moment about z ramped to M.
Model rollup(double L, int n, double EA, double EI, double M, double dt) {
  Model m = straight_beam({0, 0, 0}, {L, 0, 0}, n, stiffness_section(EA, EA, EI, EI));
  m.constraints.push_back(clamp(1));
  m.loads.push_back(
      NodalLoad{2, Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 0, M), false, TimeTable::ramp(1.0)});
  m.steps.push_back(static_step(1.0, dt));
  return m;
}

TEST(VerificationStatic, RollUpMatchesTheExactArcAtEveryLambda) {
  const double L = 1.0, EI = 1.0;
  for (const double lambda : {0.125, 0.25, 0.5, 0.75, 1.0}) {
    const double M = lambda * 2 * std::numbers::pi * EI / L;
    const Model m = rollup(L, 32, 1e4, EI, M, 0.1);
    Simulation sim(m);
    sim.run();
    const double phi = 2 * std::numbers::pi * lambda;
    const Eigen::Vector3d tip = sim.state().x_n.col(m.nodes.size() - 1);
    const double x_exact = std::sin(phi) / phi, y_exact = (1 - std::cos(phi)) / phi;
    std::printf("roll-up lambda %.3f: tip error (%.2e, %.2e) L, rotation error %.2e rad\n", lambda,
                tip.x() / L - x_exact, tip.y() / L - y_exact,
                sim.state().rotation_n(2, m.nodes.size() - 1) - phi);
    EXPECT_NEAR(tip.x() / L, x_exact, 1e-6) << "lambda " << lambda;
    EXPECT_NEAR(tip.y() / L, y_exact, 1e-6) << "lambda " << lambda;
    EXPECT_NEAR(sim.state().rotation_n(2, m.nodes.size() - 1), phi, 1e-8) << "lambda " << lambda;
  }
}

TEST(VerificationStatic, TenTurnsBringTheTipBackToTheClamp) {
  // verification.md: L = 10, EA = GA = 1e4, EI = GJ = 1e2, M = 200 pi.
  const double L = 10;
  const Model m = rollup(L, 80, 1e4, 1e2, 200 * std::numbers::pi, 0.01);
  Simulation sim(m);
  sim.run();
  const Eigen::Vector3d tip = sim.state().x_n.col(m.nodes.size() - 1);
  std::printf("ten turns: tip %.2e L from the clamp, rotation %.9f rad (20 pi = %.9f)\n",
              tip.norm() / L, sim.state().rotation_n(2, m.nodes.size() - 1), 20 * std::numbers::pi);
  EXPECT_LT(tip.norm() / L, 1e-6) << "tip at " << tip.transpose();
  EXPECT_NEAR(sim.state().rotation_n(2, m.nodes.size() - 1), 20 * std::numbers::pi, 1e-6);
}

TEST(VerificationStatic, NewtonConvergesQuadraticallyOnTheRollUp) {
  // lambda = 1 in 20 increments; the energy norm |delta . r| of each correction, relative to the
  // first, must fall quadratically: log(e_{k+1}) / log(e_k) close to 2 once e_k is small.
  const Model m = rollup(1.0, 16, 1e4, 1.0, 2 * std::numbers::pi, 0.05);
  Simulation sim(m);
  Recorder rec;
  sim.run(&rec);
  ASSERT_EQ(rec.reports.size(), 20u);
  for (const IncrementReport& r : rec.reports) {
    ASSERT_GE(r.energy_history.size(), 3u);
    const double e0 = r.energy_history.front();
    int checked = 0;
    for (std::size_t k = 1; k + 1 < r.energy_history.size(); ++k) {
      const double a = r.energy_history[k] / e0, b = r.energy_history[k + 1] / e0;
      if (a < 1e-3 && a > 1e-14 && b > 1e-30) {
        EXPECT_GT(std::log(b) / std::log(a), 1.7)
            << fmt::format("increment {} iteration {}: {:.3e} -> {:.3e}", r.increment, k, a, b);
        ++checked;
      }
    }
    EXPECT_GT(checked, 0) << "increment " << r.increment << " showed no quadratic phase";
    EXPECT_LE(r.iterations, 6) << "increment " << r.increment;
  }
}

} // namespace
} // namespace yarnsim

namespace yarnsim {
namespace {

TEST(VerificationStatic, ElasticaUnderADeadTipLoadOnAConvergedMesh) {
  // verification.md, Euler elastica: w/L, u/L and tip rotation for alpha = P L^2 / EI.
  struct Row {
    double alpha, w, u, rot;
  };
  const Row rows[] = {{1, 0.30172, 0.05643, 0.46135},
                      {3, 0.60325, 0.25442, 0.98602},
                      {10, 0.81061, 0.55500, 1.43029}};
  const double L = 1.0, EI = 1.0;
  for (const Row& row : rows) {
    Model m =
        test::straight_beam({0, 0, 0}, {L, 0, 0}, 32, test::stiffness_section(1e7, 1e7, EI, EI));
    m.constraints.push_back(test::clamp(1));
    m.loads.push_back(NodalLoad{2, Eigen::Vector3d(0, row.alpha * EI / (L * L), 0),
                                Eigen::Vector3d::Zero(), false, TimeTable::ramp(1.0)});
    m.steps.push_back(test::static_step(1.0, 0.1, 1e-9));
    Simulation sim(m);
    sim.run();
    const int tip = static_cast<int>(m.nodes.size()) - 1;
    const Eigen::Vector3d x = sim.state().x_n.col(tip);
    std::printf("elastica alpha %g: relative errors w %.2e, u %.2e, rotation %.2e\n", row.alpha,
                x.y() / L / row.w - 1, (L - x.x()) / L / row.u - 1,
                sim.state().rotation_n(2, tip) / row.rot - 1);
    EXPECT_NEAR(x.y() / L, row.w, 1e-3 * row.w) << "alpha " << row.alpha;
    EXPECT_NEAR((L - x.x()) / L, row.u, 1e-3 * row.u) << "alpha " << row.alpha;
    EXPECT_NEAR(sim.state().rotation_n(2, tip), row.rot, 1e-3 * row.rot) << "alpha " << row.alpha;
  }
}

} // namespace
} // namespace yarnsim

namespace yarnsim {
namespace {

/// A cantilever along a skew axis whose section axes e1, e2, e3 are none of the global ones,
/// clamped at its start, loaded at its tip by `load` (ramped to 1); returns the tip's position
/// and rotation vector at the end.
std::pair<Eigen::Vector3d, Eigen::Vector3d> skew_cantilever_tip(NodalLoad load) {
  Model m = test::straight_beam({0, 0, 0}, {0.6, 0.48, 0.64}, 16,
                                test::stiffness_section(1e4, 1e4, 1.0, 1.0),
                                Eigen::Vector3d(0.0, 0.0, 1.0));
  m.sections[0].EI2 = 2.0; // unequal bending stiffnesses: the section's orientation matters
  m.sections[0].GJ = 1.5;
  m.constraints.push_back(test::clamp(1));
  load.node_set = 2;
  load.factor = TimeTable::ramp(1.0);
  m.loads.push_back(load);
  m.steps.push_back(test::static_step(1.0, 0.1));
  Simulation sim(m);
  sim.run();
  const int tip = static_cast<int>(m.nodes.size()) - 1;
  return {sim.state().x_n.col(tip), sim.state().rotation_n.col(tip)};
}

TEST(LoadAxes, LoadGivenAlongTheSectionAxesActsAsItsGlobalComponents) {
  // The section axes of the skew cantilever, written out here: e3 along the beam, e1 the
  // reference vector z without its part along e3, e2 = e3 x e1.
  const Eigen::Vector3d e3 = Eigen::Vector3d(0.6, 0.48, 0.64).normalized();
  const Eigen::Vector3d e1 = (Eigen::Vector3d::UnitZ() - e3.z() * e3).normalized();
  Eigen::Matrix3d triad;
  triad << e1, e3.cross(e1), e3;
  for (int i = 0; i < 3; ++i) // no section axis along a global one
    ASSERT_LT(triad.col(i).cwiseAbs().maxCoeff(), 0.9) << triad;
  // Components along e1, e2, e3 (N m, or N): tip rotations of order one radian.
  const Eigen::Vector3d in_section(0.3, -0.5, 0.8);
  const Eigen::Vector3d global = triad * in_section;
  for (const bool follower : {false, true}) {
    for (const bool force : {false, true}) {
      if (force && follower)
        continue; // forces are dead loads
      NodalLoad as_global, as_section, unrotated;
      for (NodalLoad* l : {&as_global, &as_section, &unrotated}) {
        l->follower_moment = follower;
        (force ? l->force : l->moment) = l == &as_global ? global : in_section;
      }
      as_section.axes = LoadAxes::Section;
      const auto [x_global, r_global] = skew_cantilever_tip(as_global);
      const auto [x_section, r_section] = skew_cantilever_tip(as_section);
      const auto [x_unrotated, r_unrotated] = skew_cantilever_tip(unrotated);
      const std::string what = force ? "dead force" : follower ? "follower moment" : "dead moment";
      std::printf("%s: tip rotation %.4f rad; section - global: position %.2e m, rotation %.2e "
                  "rad\n",
                  what.c_str(), r_global.norm(), (x_section - x_global).norm(),
                  (r_section - r_global).norm());
      // Round-off: the two runs' loads differ in the last bits (Q0 v against v given rotated).
      EXPECT_LT((x_section - x_global).norm(), 1e-12) << what;
      EXPECT_LT((r_section - r_global).norm(), 1e-12) << what;
      // The components taken as global ones bend the beam elsewhere.
      EXPECT_GT((x_unrotated - x_global).norm(), 1e-2) << what;
      EXPECT_GT(r_global.norm(), 0.1) << what; // a large rotation: 0.2 to 0.7 rad
    }
  }
}

} // namespace
} // namespace yarnsim
