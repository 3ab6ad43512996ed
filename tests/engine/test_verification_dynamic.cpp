// Single-beam dynamic cases of shared/docs/verification.md: cantilever frequencies from a free
// vibration, and the free-flying beam's momenta and energy after the load.
#include "beam_models.hpp"
#include "engine/solver/simulation.hpp"
#include "signal_analysis.hpp"

#include <cmath>
#include <cstdio>
#include <gtest/gtest.h>
#include <numbers>

namespace yarnsim {
namespace {

using test::spectral_peak;
using test::TipRecorder;

TEST(VerificationDynamic, CantileverFrequenciesFromAFreeVibration) {
  // Slender cantilever: EI = 1, rho A = 1, L = 1, shear and axial stiff, no rotary inertia, so the
  // Euler-Bernoulli values omega_n = (beta_n L)^2 sqrt(EI / (rho A L^4)) apply.
  const double L = 1, EI = 1, rhoA = 1;
  Model m = test::straight_beam({0, 0, 0}, {L, 0, 0}, 16,
                                test::stiffness_section(1e6, 1e6, EI, EI, rhoA));
  m.constraints.push_back(test::clamp(1));
  // A short transverse pulse at the tip excites the first modes, then the beam vibrates freely.
  m.loads.push_back(NodalLoad{2, Eigen::Vector3d(0, 1e-3, 0), Eigen::Vector3d::Zero(), false,
                              TimeTable{{0.0, 0.01, 0.02}, {0.0, 1.0, 0.0}}});
  const double w1 = 1.875104 * 1.875104, w2 = 4.694091 * 4.694091;
  SolutionStep step;
  step.type = StepType::Dynamic;
  step.newmark_beta = 0.25;
  step.newmark_gamma = 0.5;
  step.dt_initial = step.dt_max = step.dt_min = (2 * std::numbers::pi / w2) / 40; // T2 / 40
  step.end_time = 16 * 2 * std::numbers::pi / w1;                                 // 16 T1
  step.tol_force = step.tol_increment = 1e-9;
  m.steps.push_back(step);
  Simulation sim(m);
  TipRecorder rec(static_cast<int>(m.nodes.size()) - 1);
  sim.run(&rec);
  // Skip the pulse.
  std::vector<double> t(rec.t.begin() + 10, rec.t.end()), y(rec.y.begin() + 10, rec.y.end());
  const double m1 = spectral_peak(t, y, 0.7 * w1, 1.3 * w1);
  const double m2 = spectral_peak(t, y, 0.8 * w2, 1.2 * w2);
  std::printf("cantilever: omega1 %.5f (exact %.5f, %.3f %%), omega2 %.5f (exact %.5f, %.3f %%)\n",
              m1, w1, 100 * (m1 / w1 - 1), m2, w2, 100 * (m2 / w2 - 1));
  EXPECT_NEAR(m1, w1, 0.01 * w1);
  EXPECT_NEAR(m2, w2, 0.01 * w2);
}

struct EnergyRecorder : SimulationObserver {
  std::vector<double> t, energy, work;
  std::vector<Eigen::Vector3d> p, L;
  void on_increment(const Simulation& s, const IncrementReport& r) override {
    t.push_back(r.time);
    energy.push_back(s.kinetic_energy() + s.strain_energy());
    work.push_back(s.external_work());
    p.push_back(s.linear_momentum());
    L.push_back(s.angular_momentum());
  }
};

TEST(VerificationDynamic, FlyingBeamKeepsMomentaAndEnergyAfterTheLoad) {
  // Simo and Vu-Quoc's free-flying beam: L = 10 at atan(4/3) to x, EA = GA = 1e4, EI = GJ = 500,
  // rho A = 1, rho J = diag(10, 10, 20) (axis 3 along the beam); hat load on [0, 5] at one end.
  Model m = test::straight_beam(
      {0, 0, 0}, {6, 8, 0}, 10,
      test::stiffness_section(1e4, 1e4, 500, 500, 1.0, Eigen::Vector3d(10, 10, 20)),
      Eigen::Vector3d::UnitZ());
  const TimeTable hat{{0.0, 2.5, 5.0}, {0.0, 1.0, 0.0}};
  m.loads.push_back(
      NodalLoad{1, Eigen::Vector3d(20, 0, 0), Eigen::Vector3d(0, 200, 100), false, hat});
  SolutionStep step;
  step.type = StepType::Dynamic;
  step.newmark_beta = 0.25;
  step.newmark_gamma = 0.5;
  step.dt_initial = step.dt_max = 0.05;
  step.dt_min = 1e-4;
  step.end_time = 15;
  step.tol_force = step.tol_increment = 1e-10;
  m.steps.push_back(step);
  Simulation sim(m);
  EnergyRecorder rec;
  sim.run(&rec);
  // After t = 5: compare every later increment with the state at t = 5.
  std::size_t k5 = 0;
  while (rec.t[k5] < 5 - 1e-9)
    ++k5;
  const double E5 = rec.energy[k5];
  double drift_E = 0, drift_p = 0, drift_L = 0;
  for (std::size_t k = k5; k < rec.t.size(); ++k) {
    drift_E = std::max(drift_E, std::abs(rec.energy[k] - E5) / E5);
    drift_p = std::max(drift_p, (rec.p[k] - rec.p[k5]).norm() / rec.p[k5].norm());
    drift_L = std::max(drift_L, (rec.L[k] - rec.L[k5]).norm() / rec.L[k5].norm());
  }
  std::printf("flying beam, t = 5..15: energy %.6g J (work of the loads %.6g J); max relative "
              "drift: energy %.3e, linear momentum %.3e, angular momentum %.3e\n",
              E5, rec.work[k5], drift_E, drift_p, drift_L);
  // The loads' work is all in the beam at t = 5 (up to the scheme's error).
  EXPECT_NEAR(E5, rec.work[k5], 0.02 * rec.work[k5]);
  EXPECT_LT(drift_p, 1e-9); // translation invariance of the residual: exact
  EXPECT_LT(drift_L, 1e-2);
  EXPECT_LT(drift_E, 1e-2);
}

/// The end of a damped cantilever's response to a suddenly applied tip load: the balance |work
/// of the loads - (kinetic + strain energy + damping dissipation)| / work, the work, the
/// dissipation and the tip's position.
struct DampedCantilever {
  double balance = 0, work = 0, dissipated = 0;
  Eigen::Vector3d tip;
};

/// The cantilever along x with increments dt, a tip load of 1e-3 N along `direction`, mass
/// damping `mass` on every component and `out_of_plane` on z alone (1/s).
DampedCantilever damped_cantilever(double dt, const Eigen::Vector3d& direction, double mass,
                                   double out_of_plane) {
  const double L = 1, EI = 1, rhoA = 1;
  Model m =
      test::straight_beam({0, 0, 0}, {L, 0, 0}, 8, test::stiffness_section(1e6, 1e6, EI, EI, rhoA));
  m.constraints.push_back(test::clamp(1));
  // A tip load of 1e-3 N (deflection ~ L / 3000: the response is linear) ramped up over 0.4 s
  // from zero (the start at rest then satisfies the equation of motion, as the balance needs).
  m.loads.push_back(NodalLoad{2, 1e-3 * direction, Eigen::Vector3d::Zero(), false,
                              TimeTable{{0.0, 0.4, 100.0}, {0.0, 1.0, 1.0}}});
  SolutionStep step;
  step.type = StepType::Dynamic;
  step.newmark_beta = 0.25; // trapezoidal: no numerical dissipation
  step.newmark_gamma = 0.5;
  step.rayleigh_mass = mass;
  step.rayleigh_out_of_plane = out_of_plane;
  step.dt_initial = step.dt_max = step.dt_min = dt;
  step.end_time = 4; // two periods of the first mode (omega_1 = 3.516 rad/s)
  step.tol_force = step.tol_increment = 1e-11;
  m.steps.push_back(step);
  Simulation sim(m);
  sim.run();
  const EnergyBalance e = sim.energy_balance();
  return {std::abs(e.external_work - (e.kinetic + e.internal + e.damping)) / e.external_work,
          e.external_work, e.damping, sim.state().x.col(2)};
}

double damped_cantilever_balance(double dt, double& work, double& dissipated) {
  // 0.7 1/s: a damping ratio c / (2 omega_1) of 0.1 on the first mode.
  const DampedCantilever c = damped_cantilever(dt, Eigen::Vector3d::UnitY(), 0.7, 0.0);
  work = c.work;
  dissipated = c.dissipated;
  return c.balance;
}

TEST(VerificationDynamic, RayleighDampingDissipationClosesTheEnergyBalance) {
  // The implicit path counts what mass-proportional damping dissipates (EnergyBalance::damping):
  // with the trapezoidal rule (beta = 1/4) and a linear response, the discrete equations of
  // motion at t_n and t_n+1 averaged and dotted with the increment give exactly
  // work = kinetic + strain + dissipated, at any step: measured 6.6e-11 and 1.7e-11 (Newton's
  // tolerance and the response's slight geometric nonlinearity).
  double work = 0, dissipated = 0, work2 = 0, dissipated2 = 0;
  const double coarse = damped_cantilever_balance(0.02, work, dissipated);
  const double fine = damped_cantilever_balance(0.01, work2, dissipated2);
  std::printf("damped cantilever: work %.6e J, dissipated %.6e J (%.1f %%); balance error %.2e "
              "(dt 0.02), %.2e (dt 0.01)\n",
              work, dissipated, 100 * dissipated / work, coarse, fine);
  EXPECT_GT(dissipated, 0.2 * work) << "the damping must matter for the test to mean anything";
  EXPECT_LT(coarse, 1e-8);
  EXPECT_LT(fine, 1e-8);
}

TEST(VerificationDynamic, OutOfPlaneDampingActsOnTheZTranslationsAlone) {
  // rayleigh.out_of_plane damps c m v_z only (the shear tests' floating yarns across the weave's
  // clearance; formulation.md "Solution"). Loaded out of plane, the cantilever is damped as by
  // the full mass-proportional damping and the balance closes with its dissipation; loaded in
  // plane, it moves as with no damping at all.
  const DampedCantilever out = damped_cantilever(0.02, Eigen::Vector3d::UnitZ(), 0.0, 0.7);
  const DampedCantilever full = damped_cantilever(0.02, Eigen::Vector3d::UnitZ(), 0.7, 0.0);
  std::printf("out-of-plane load: out-of-plane damping dissipated %.6e J of %.6e J, balance "
              "%.2e; full mass damping %.6e J\n",
              out.dissipated, out.work, out.balance, full.dissipated);
  EXPECT_GT(out.dissipated, 0.2 * out.work);
  EXPECT_LT(out.balance, 1e-8);
  // A load along z moves the tip along z alone to first order: the z damping is all there is,
  // so the two agree but for the rotary damping of the full one (small: rhoJ << rhoA L^2).
  EXPECT_NEAR(out.dissipated, full.dissipated, 1e-3 * full.dissipated);
  const DampedCantilever in_plane = damped_cantilever(0.02, Eigen::Vector3d::UnitY(), 0.0, 0.7);
  const DampedCantilever undamped = damped_cantilever(0.02, Eigen::Vector3d::UnitY(), 0.0, 0.0);
  EXPECT_LT(in_plane.dissipated, 1e-12 * in_plane.work); // the z motion of round-off
  EXPECT_LT((in_plane.tip - undamped.tip).norm(), 1e-14);
  EXPECT_GT((undamped.tip - Eigen::Vector3d(1, 0, 0)).norm(), 1e-5) << "the tip must move";
}

} // namespace
} // namespace yarnsim
