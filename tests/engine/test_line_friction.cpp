// Coulomb friction between yarns side by side (the all-angle contact's line part,
// contact/line_friction.hpp, through the spline contact set): a slider lying along a rigid rail,
// pressed into it by a uniform depth p and dragged along it, against the exact answers of the
// elastic-plastic law with the line's stick stiffness K = eps_t lambda L and cone mu N, N the
// line's normal force eps lambda p L: the
// drag force at every increment of a cycle, the loop's area 4 mu N (u_a - mu N / K), the
// dissipation and the balance of the drag's work; Newton's rate in slip; the explicit path's cone
// and energy balance; one and two threads and a restart through the checkpoint file bitwise the
// same.
#include "beam_models.hpp"
#include "drag_recorder.hpp"
#include "engine/output/checkpoint_file.hpp"
#include "engine/solver/checkpoint.hpp"
#include "engine/solver/simulation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <gtest/gtest.h>
#include <numbers>
#include <tbb/global_control.h>
#include <unistd.h>
#include <vector>

namespace yarnsim {
namespace {

constexpr double kRadius = 0.01; // m
constexpr double kPress = 4e-6;  // m, the slider's depth into the rail
constexpr double kSlider = 0.5;  // m, the slider's length
constexpr double kEpsT = 1e4;    // N/m, tangential penalty (per unit length: eps_t lambda)
constexpr double kEps = 1e5;     // N/m, normal penalty
constexpr double kLambda = 1 / (2 * kRadius); // 1/m, the line scale's default 1 / (r_A + r_B)

/// The rail along x from -0.5 to 0.5 m (8 elements, every node clamped) and the slider along x
/// from -0.25 to 0.25 m (4 elements, 7 spline segments) on it, touching. The slider moves
/// rigidly (every DOF held or prescribed), so that every Gauss point presses as deep and slides
/// as far: the law's exact answer holds for the sum. The slider is the contact's first group: the
/// line contact's slave, whose Gauss points all project onto the rail's interior segments
/// throughout the drag. Step 1 presses it down by p (0 < t < 1); from t = 1 on its x is the table
/// `drag` (m, of time).
struct Drag {
  Model model;
  std::vector<int> slider;
};

/// With `elastic`, the slider is an elastic bar instead: pulled in x at its first node only,
/// free in x, z and its rotation about y elsewhere, and pressed by the uniform load of the rigid
/// case's normal force (consistent nodal loads of the quadratic elements), so that friction, the
/// bar's stretch and its contact pressure are coupled (Newton's rate).
Drag drag_model(double mu_s, double mu_k, const TimeTable& drag, double t_end, double dt,
                bool elastic = false) {
  const double E = 1e9, A = std::numbers::pi * kRadius * kRadius;
  const double I = std::numbers::pi * std::pow(kRadius, 4) / 4;
  const Section s = test::stiffness_section(E * A, E * A, E * I, E * I);
  const int n_slider = 4, n_rail = 8;
  Model m = test::straight_beam({-kSlider / 2, 0, 2 * kRadius}, {kSlider / 2, 0, 2 * kRadius},
                                n_slider, s, Eigen::Vector3d::UnitY());
  const Model rail =
      test::straight_beam({-0.5, 0, 0}, {0.5, 0, 0}, n_rail, s, Eigen::Vector3d::UnitY());
  const int offset = test::append_beam(m, rail);
  Drag d;
  NodeSet slide{"slider", {}}, fixed{"rail", {}};
  for (int i = 0; i <= 2 * n_slider; ++i)
    slide.nodes.push_back(i);
  for (int i = 0; i <= 2 * n_rail; ++i)
    fixed.nodes.push_back(offset + i);
  d.slider = slide.nodes;
  m.node_sets = {slide, fixed};
  if (elastic) {
    m.node_sets.push_back(NodeSet{"pulled", {0}});
    NodeSet ends{"ends", {0, 2 * n_slider}}, corners{"corners", {}}, mids{"mids", {}};
    for (int i = 1; i < 2 * n_slider; ++i)
      (i % 2 == 0 ? corners : mids).nodes.push_back(i);
    m.node_sets.insert(m.node_sets.end(), {ends, corners, mids});
    const double q = kEps * kLambda * kPress, le = kSlider / n_slider; // N/m, m
    const TimeTable press{{0.0, 1.0, t_end}, {0.0, 1.0, 1.0}};
    m.loads.push_back(NodalLoad{3, {0, 0, -q * le / 6}, {0, 0, 0}, false, press});
    m.loads.push_back(NodalLoad{4, {0, 0, -q * le / 3}, {0, 0, 0}, false, press});
    m.loads.push_back(NodalLoad{5, {0, 0, -2 * q * le / 3}, {0, 0, 0}, false, press});
    m.constraints.push_back(Constraint{0, {false, true, false, true, false, true}});
  } else {
    m.constraints.push_back(Constraint{0, {false, true, false, true, true, true}});
  }
  m.constraints.push_back(test::clamp(1));
  PrescribedMotion p;
  p.node_set = elastic ? 2 : 0;
  p.displacement[0] = drag;
  if (!elastic)
    p.displacement[2] = TimeTable{{0.0, 1.0, t_end}, {0.0, -kPress, -kPress}};
  m.prescribed.push_back(p);
  m.splines = {Spline{"slider", slide.nodes, kRadius}, Spline{"rail", fixed.nodes, kRadius}};
  SplineContactDefinition c;
  c.name = "side by side";
  c.group_a = {0};
  c.group_b = {1};
  c.law = {kEps, 1.0, 0.0};
  c.friction = {mu_s, mu_k, kEpsT};
  m.spline_contacts.push_back(c);
  SolutionStep pressing = test::static_step(1.0, 0.25, 1e-10);
  SolutionStep pull = test::static_step(t_end, dt, 1e-10);
  pull.dt_min = dt; // no halving: the increments are the test's sampling
  m.steps = {pressing, pull};
  d.model = std::move(m);
  return d;
}

using Sample = test::DragSample;

std::vector<Sample> run_drag(double mu_s, double mu_k, const TimeTable& table, double t_end,
                             double dt, bool elastic = false) {
  const Drag d = drag_model(mu_s, mu_k, table, t_end, dt, elastic);
  Simulation sim(d.model);
  test::DragRecorder rec(d.slider, table);
  sim.run(&rec);
  return rec.samples;
}

TEST(LineFriction, SideBySideYarnsFollowTheExactStickSlipCycle) {
  // N = eps lambda p L = 10 N; K = eps_t lambda L = 2.5e5 N/m; mu N / K = 0.02 mm with mu = 0.5.
  // The cycle 0 -> u_a -> -u_a -> u_a with u_a = 0.1 mm in steps of 5 um (on the cone's corners).
  const double mu = 0.5, ua = 1e-4, t_end = 6.0;
  const double normal = kEps * kLambda * kPress * kSlider, stiffness = kEpsT * kLambda * kSlider;
  const double cone = mu * normal / stiffness;
  const TimeTable drag{{0.0, 1.0, 2.0, 4.0, 6.0}, {0.0, 0.0, ua, -ua, ua}};
  const std::vector<Sample> samples = run_drag(mu, mu, drag, t_end, 0.05);
  ASSERT_NEAR(samples.back().time, t_end, 1e-12);
  // The exact law: f follows K du inside the cone, mu N on it.
  double f = 0, u_prev = 0, loop = 0, slipped = 0;
  int stuck = 0, slipping = 0;
  for (std::size_t k = 0; k < samples.size(); ++k) {
    const Sample& s = samples[k];
    if (s.time <= 1.0 + 1e-12) {
      EXPECT_NEAR(s.force, 0.0, 1e-9 * normal) << "t = " << s.time;
      continue;
    }
    const double trial = f + stiffness * (s.u - u_prev);
    f = std::clamp(trial, -mu * normal, mu * normal);
    slipped += std::abs(trial - f) / stiffness;
    u_prev = s.u;
    EXPECT_NEAR(s.force, f, 1e-8 * mu * normal) << "t = " << s.time << ", u = " << s.u;
    const bool slips = std::abs(trial) > mu * normal * (1 + 1e-9);
    // Every Gauss point of the slider (7 segments x 5) in one state; where the trial ends on the
    // cone (a corner of the cycle), round-off decides.
    EXPECT_EQ(s.contact.stick + s.contact.slip, 35) << "t = " << s.time;
    if (std::abs(std::abs(trial) - mu * normal) > 1e-9 * mu * normal) {
      EXPECT_EQ(s.contact.slip, slips ? 35 : 0) << "t = " << s.time;
    }
    (slips ? slipping : stuck) += 1;
    if (s.time >= 2.0 + 1e-12)
      loop += 0.5 * (samples[k - 1].force + s.force) * (s.u - samples[k - 1].u);
  }
  EXPECT_GT(stuck, 10);
  EXPECT_GT(slipping, 40);
  const double exact_loop = 4 * mu * normal * (ua - cone);
  std::printf("loop area %.9e J (exact %.9e), dissipated %.9e J (mu N times the slide %.9e)\n",
              loop, exact_loop, samples.back().contact.dissipation, mu * normal * slipped);
  EXPECT_NEAR(loop, exact_loop, 1e-8 * exact_loop);
  EXPECT_NEAR(samples.back().contact.dissipation, mu * normal * slipped, 1e-8 * loop);
}

TEST(LineFriction, NewtonConvergesQuadraticallyInStickAndSlip) {
  // The elastic slider pulled at one end by 20 um in 20 increments: stuck, then a slip zone
  // runs from the pulled end along the bar (the cone is 6 um, the bar stretches by 2.4 um under
  // mu N) until every Gauss point slips, with the bar's stretch, its pressure on the rail and
  // the friction coupled in the free DOFs.
  const double mu = 0.3, t_end = 2.0;
  const TimeTable drag{{0.0, 1.0, t_end}, {0.0, 0.0, -2e-5}};
  const std::vector<Sample> samples = run_drag(mu, mu, drag, t_end, 0.05, true);
  int stick = 0, partial = 0, slip = 0;
  for (const Sample& s : samples) {
    if (s.time <= 1.0 + 1e-12)
      continue;
    const std::vector<double>& r = s.residuals;
    std::printf("t = %.2f: %d stuck, %d slipping, residuals", s.time, s.contact.stick,
                s.contact.slip);
    for (const double v : r)
      std::printf(" %.1e", v);
    std::printf("\n");
    // Each residual between 1e-2 and 1e-6 (the round-off floor is 1e-10 here): r_k+1 < 10^1.5 r_k^2
    // (a linear rate fails it).
    for (std::size_t k = 1; k + 1 < r.size(); ++k) {
      if (r[k] > 1e-6 && r[k] < 1e-2) {
        EXPECT_LT(std::log10(r[k + 1]), 2 * std::log10(r[k]) + 1.5)
            << "t = " << s.time << ", iteration " << k;
      }
    }
    EXPECT_LE(r.size(), 8u) << "t = " << s.time;
    ++(s.contact.slip == 0 ? stick : s.contact.stick == 0 ? slip : partial);
  }
  EXPECT_GT(partial, 0);
  EXPECT_GT(slip, 3);
}

TEST(LineFriction, ExplicitDragSlipsOnTheConeAndItsEnergyBalanceHoldsTheDissipation) {
  // The elastic slider on the explicit path: pressed by its load over 0.5 s, then pulled at
  // 5 mm/s for 1 s. Every Gauss point in slip carries mu times its normal force; the friction
  // dissipates about mu N times the slide; the energy balance closes to a small part of it.
  const double mu = 0.3, t_end = 2.0, v = 5e-3;
  const double normal = kEps * kLambda * kPress * kSlider; // N, the load
  const TimeTable drag{{0.0, 1.0, t_end}, {0.0, 0.0, -v * (t_end - 1.0)}};
  Drag d = drag_model(mu, mu, drag, t_end, 1.0, true);
  const double rho = 1000, A = std::numbers::pi * kRadius * kRadius;
  const double I = std::numbers::pi * std::pow(kRadius, 4) / 4;
  for (Section& section : d.model.sections) {
    section.rhoA = rho * A;
    section.rhoJ = Eigen::Vector3d(rho * I, rho * I, 2 * rho * I);
  }
  for (NodalLoad& load : d.model.loads)
    load.factor = TimeTable{{0.0, 0.5, t_end}, {0.0, 1.0, 1.0}};
  SolutionStep step;
  step.type = StepType::Explicit;
  step.end_time = t_end;
  step.mass_scaling_dt = step.dt_initial = step.dt_max = 5e-5;
  step.dt_min = 1e-7;
  step.output_every = 100;
  d.model.steps = {step};
  Simulation sim(d.model);
  struct Explicit final : SimulationObserver {
    double mu;
    int slipping = 0;
    double worst_cone = 0, worst_balance = 0, friction = 0;
    explicit Explicit(double m) : mu(m) {}
    void on_increment(const Simulation& s, const IncrementReport& r) override {
      const ContactSummary c = s.contact()->summary();
      worst_balance = std::max(worst_balance, std::abs(s.energy_balance().error));
      friction = s.energy_balance().friction;
      if (r.time > 1.2 && c.stick == 0 && c.slip > 0) {
        ++slipping;
        worst_cone = std::max(worst_cone, std::abs(c.tangential_force - mu * c.total_force));
      }
    }
  } rec(mu);
  sim.run(&rec);
  std::printf("explicit line drag: %ld increments, %d samples in full slip, |sum f_t - mu sum "
              "f_n| <= %.3e N (mu N = %.4g N); friction dissipated %.6e J (mu N s = %.6e J), "
              "largest balance error %.3e J\n",
              sim.explicit_status().increments, rec.slipping, rec.worst_cone, mu * normal,
              rec.friction, mu * normal * v * (t_end - 1.0), rec.worst_balance);
  EXPECT_GT(rec.slipping, 5);
  EXPECT_LT(rec.worst_cone, 1e-9 * mu * normal);
  // The slide is the pull less the bar's stretch (0.2 %).
  EXPECT_NEAR(rec.friction, mu * normal * v * (t_end - 1.0), 0.01 * mu * normal * v);
  EXPECT_LT(rec.worst_balance, 1e-4 * rec.friction);
}

/// Positions and the contact summary of every increment, bit for bit.
struct Bits {
  std::vector<Eigen::Matrix3Xd> x;
  std::vector<double> dissipation;
  std::vector<int> slip;
  std::vector<SimulationCheckpoint> checkpoints;
};

class BitsRecorder final : public SimulationObserver {
public:
  explicit BitsRecorder(Bits& b) : b_(b) {}
  void on_increment(const Simulation& sim, const IncrementReport&) override {
    b_.x.push_back(sim.state().x);
    b_.dissipation.push_back(sim.contact()->summary().dissipation);
    b_.slip.push_back(sim.contact()->summary().slip);
    b_.checkpoints.push_back(sim.checkpoint());
  }

private:
  Bits& b_;
};

void expect_same_bits(const Bits& a, std::size_t from, const Bits& b) {
  ASSERT_EQ(a.x.size(), from + b.x.size());
  for (std::size_t k = 0; k < b.x.size(); ++k) {
    EXPECT_TRUE(a.x[from + k] == b.x[k]) << "increment " << from + k;
    EXPECT_EQ(a.dissipation[from + k], b.dissipation[k]) << "increment " << from + k;
    EXPECT_EQ(a.slip[from + k], b.slip[k]) << "increment " << from + k;
  }
}

TEST(LineFriction, IsBitwiseTheSameOnOneAndTwoThreadsAndAfterARestart) {
  // A drag back and forth with static and kinetic coefficients: histories in stick and slip,
  // handed over between the rail's segment pairs as the slider's Gauss points pass its knots.
  const TimeTable drag{{0.0, 1.0, 2.0, 3.0}, {0.0, 0.0, 0.08, 0.05}};
  const Drag d = drag_model(0.5, 0.3, drag, 3.0, 0.1);
  auto run = [&](int threads, const SimulationCheckpoint* from) {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, threads);
    Bits b;
    BitsRecorder rec(b);
    if (from)
      Simulation(d.model, {}, *from).run(&rec);
    else
      Simulation(d.model).run(&rec);
    return b;
  };
  const Bits one = run(1, nullptr);
  ASSERT_GT(one.dissipation.back(), 0.0);
  expect_same_bits(one, 0, run(2, nullptr));
  // Restarted through the checkpoint file from an increment in slip, 0.03 m into the drag (the
  // Gauss points have passed rail knots since they closed).
  std::size_t k = 0;
  while (k + 2 < one.x.size() && !(one.slip[k] > 0 && one.dissipation[k] > 0.1))
    ++k;
  ASSERT_GT(one.slip[k], 0);
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() /
      ("yarnsim_line_friction_checkpoint_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  output::write_checkpoint(dir, one.checkpoints[k], {1, {}, "line-friction"});
  const output::StoredCheckpoint stored = output::read_checkpoint(dir);
  std::filesystem::remove_all(dir);
  ASSERT_FALSE(stored.simulation.contact->line_committed.empty());
  const SimulationCheckpoint& read = stored.simulation;
  expect_same_bits(one, k + 1, run(1, &read));
}

} // namespace
} // namespace yarnsim
