// Coulomb friction in the engine (contact/friction.hpp through the spline contact set): a slider
// pressed on a rail by a fixed normal force N and dragged along it, checked against the exact
// answers of the elastic-plastic friction law (issue "Friction between yarns", acceptance):
// stick while eps_t u < mu N, then |f_t| = mu N; a static peak mu_s N, then mu_k N; the
// hysteresis loop's area 4 mu N (u_a - mu N / eps_t); the dissipated energy mu N s and the
// balance of the work of the drag; the force held while the point slides over the rail's
// segment boundaries (history handed over between segment pairs); Newton's rate in slip.
#include "beam_models.hpp"
#include "drag_recorder.hpp"
#include "engine/contact/contact_stage.hpp"
#include "engine/input/read_deck.hpp"
#include "engine/solver/simulation.hpp"
#include "notices.hpp"

#include <cmath>
#include <cstdio>
#include <gtest/gtest.h>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

namespace yarnsim {
namespace {

constexpr double kRadius = 0.01;    // m
constexpr double kNormal = 2.0;     // N, pressing the slider on the rail
constexpr double kEpsT = 1e4;       // N/m, tangential penalty
constexpr double kRailElements = 8; // rail of 1 m: 17 nodes, 15 spline segments

/// The drag: a rigid rail along x (all nodes clamped) and a slider along y across it at x = 0,
/// touching; every slider node may move only in z (y and rotations held, x prescribed). Step 1
/// presses the slider down by N at its middle node (0 < t < 1); from t = 1 on the slider's x is
/// the table `drag` (m, of time) while N stays. The friction force is the x reaction of the
/// slider's nodes (the drag force).
struct Drag {
  Model model;
  std::vector<int> slider;
};

Drag drag_model(double mu_s, double mu_k, const TimeTable& drag, double t_end, double dt,
                double elastic_slip = 0) {
  const double E = 1e9, A = std::numbers::pi * kRadius * kRadius;
  const double I = std::numbers::pi * std::pow(kRadius, 4) / 4;
  const Section s = test::stiffness_section(E * A, E * A, E * I, E * I);
  const int n_rail = static_cast<int>(kRailElements), n_slider = 4;
  Model m = test::straight_beam({-0.5, 0, 0}, {0.5, 0, 0}, n_rail, s);
  const Model slider = test::straight_beam({0, -0.1, 2 * kRadius}, {0, 0.1, 2 * kRadius}, n_slider,
                                           s, Eigen::Vector3d::UnitX());
  const int offset = test::append_beam(m, slider);
  Drag d;
  NodeSet rail{"rail", {}}, slide{"slider", {}};
  for (int i = 0; i <= 2 * n_rail; ++i)
    rail.nodes.push_back(i);
  for (int i = 0; i <= 2 * n_slider; ++i)
    slide.nodes.push_back(offset + i);
  d.slider = slide.nodes;
  m.node_sets = {rail, slide, NodeSet{"slider_mid", {offset + n_slider}}};
  m.constraints.push_back(test::clamp(0));
  m.constraints.push_back(Constraint{1, {false, true, false, true, true, true}});
  PrescribedMotion p;
  p.node_set = 1;
  p.displacement[0] = drag;
  m.prescribed.push_back(p);
  m.loads.push_back(NodalLoad{2, Eigen::Vector3d(0, 0, -kNormal), Eigen::Vector3d::Zero(), false,
                              TimeTable{{0.0, 1.0, t_end}, {0.0, 1.0, 1.0}}});
  Spline a{"rail", rail.nodes, kRadius}, b{"slider", slide.nodes, kRadius};
  m.splines = {a, b};
  SplineContactDefinition c;
  c.name = "drag";
  c.group_a = {0};
  c.group_b = {1};
  c.law = {1e5, 1.0, 0.0};
  c.friction = {mu_s, mu_k, kEpsT};
  if (elastic_slip > 0) {
    c.friction.tangential_penalty = 0;
    c.friction.elastic_slip = elastic_slip;
  }
  m.spline_contacts.push_back(c);
  SolutionStep press = test::static_step(1.0, 0.25, 1e-10);
  SolutionStep pull = test::static_step(t_end, dt, 1e-10);
  pull.dt_min = dt; // no halving: the increments are the test's sampling
  m.steps = {press, pull};
  d.model = std::move(m);
  return d;
}

/// Per increment of the drag: time, imposed x, drag force (x reaction sum of the slider, N),
/// the contact's summary, and the Newton residuals.
using Sample = test::DragSample;

std::vector<Sample> run_drag(double mu_s, double mu_k, const TimeTable& table, double t_end,
                             double dt, double elastic_slip = 0) {
  const Drag d = drag_model(mu_s, mu_k, table, t_end, dt, elastic_slip);
  Simulation sim(d.model);
  test::DragRecorder rec(d.slider, table);
  sim.run(&rec);
  return rec.samples;
}

/// The sample at time t (an increment ends there), or null.
const Sample* sample_at(const std::vector<Sample>& samples, double t) {
  for (const Sample& s : samples)
    if (std::abs(s.time - t) < 1e-9)
      return &s;
  return nullptr;
}

TEST(Friction, DraggedSliderSticksThenSlipsAtMuNOverManySegments) {
  // 0 to 0.2 m in 100 increments of 2 mm: stick up to mu N / eps_t = 0.06 mm... so the first
  // increment already slips; the slide crosses three rail segments (15 spline segments over the 1 m
  // rail).
  const double mu = 0.3, t_end = 2.0;
  const TimeTable drag{{0.0, 1.0, t_end}, {0.0, 0.0, 0.2}};
  const std::vector<Sample> samples = run_drag(mu, mu, drag, t_end, 0.01);
  int slipping = 0;
  for (const Sample& s : samples) {
    if (s.time <= 1.0) {
      EXPECT_NEAR(s.force, 0.0, 1e-9) << "t = " << s.time; // pressing only
      continue;
    }
    const double stick = kEpsT * s.u;
    const double expected = std::min(stick, mu * kNormal);
    EXPECT_NEAR(s.force, expected, 1e-8 * mu * kNormal) << "t = " << s.time << ", u = " << s.u;
    if (stick > mu * kNormal) {
      ++slipping;
      EXPECT_EQ(s.contact.slip, 1) << "t = " << s.time;
    }
  }
  EXPECT_GT(slipping, 90);
}

TEST(Friction, StickBelowTheConeThenSlipWithAStaticPeak) {
  // mu_s N / eps_t = 0.1 mm, mu_k N / eps_t = 0.06 mm; steps of 0.021 mm (none on the cone).
  const double mu_s = 0.5, mu_k = 0.3, t_end = 1.5;
  const TimeTable drag{{0.0, 1.0, t_end}, {0.0, 0.0, 0.21e-3}};
  const std::vector<Sample> samples = run_drag(mu_s, mu_k, drag, t_end, 0.05);
  bool peaked = false;
  for (const Sample& s : samples) {
    if (s.time <= 1.0)
      continue;
    const double stick = kEpsT * s.u;
    if (!peaked && stick <= mu_s * kNormal * (1 + 1e-12)) {
      // Held by the static coefficient: elastic, |f| = eps_t u (above mu_k N too).
      EXPECT_NEAR(s.force, stick, 1e-8 * mu_s * kNormal) << "t = " << s.time;
      EXPECT_EQ(s.contact.stick, 1) << "t = " << s.time;
    } else if (!peaked) {
      // The increment it breaks loose: bounded by mu_s N.
      EXPECT_NEAR(s.force, mu_s * kNormal, 1e-8 * mu_s * kNormal) << "t = " << s.time;
      peaked = true;
    } else {
      EXPECT_NEAR(s.force, mu_k * kNormal, 1e-8 * mu_k * kNormal) << "t = " << s.time;
    }
  }
  EXPECT_TRUE(peaked);
}

/// The loop of a drag u: 0 -> u_a -> -u_a -> u_a whose cone's radius in displacement is `cone`
/// (m): its area, the dissipation and the balance of the drag's work, against the exact answers;
/// `elastic_slip` > 0 sets the stick stiffness mu N / elastic_slip (then `cone` = elastic_slip).
void check_hysteresis(double mu, double cone, double elastic_slip) {
  const double ua = 1e-3, t_end = 6.0;
  const TimeTable drag{{0.0, 1.0, 2.0, 4.0, 6.0}, {0.0, 0.0, ua, -ua, ua}};
  const std::vector<Sample> samples = run_drag(mu, mu, drag, t_end, 0.05, elastic_slip);
  // Work of the drag, W = integral f du, over the first pull (t 1 to 2) and over the closed
  // cycle (t 2 to 6).
  double first = 0, loop = 0;
  for (std::size_t k = 1; k < samples.size(); ++k) {
    const Sample &a = samples[k - 1], &b = samples[k];
    const double w = 0.5 * (a.force + b.force) * (b.u - a.u);
    if (b.time <= 2.0 + 1e-12 && a.time >= 1.0 - 1e-12)
      first += w;
    else if (a.time >= 2.0 - 1e-12)
      loop += w;
  }
  const double exact_loop = 4 * mu * kNormal * (ua - cone);
  std::printf("loop area %.9e J (exact %.9e), first pull %.9e J\n", loop, exact_loop, first);
  EXPECT_NEAR(loop, exact_loop, 1e-9 * exact_loop);
  // First pull: a slide of s = u_a - mu N / eps_t dissipates mu N s; the rest is stored in the
  // tangential spring, (mu N)^2 / (2 eps_t).
  const Sample* end_of_pull = sample_at(samples, 2.0);
  const Sample* pressed = sample_at(samples, 1.0);
  ASSERT_NE(end_of_pull, nullptr);
  ASSERT_NE(pressed, nullptr);
  const double slide = ua - cone;
  EXPECT_NEAR(end_of_pull->contact.dissipation, mu * kNormal * slide, 1e-9 * mu * kNormal * slide);
  const double stored = end_of_pull->contact.potential - pressed->contact.potential;
  // The spring holds mu N at the cone's radius: (mu N)^2 / (2 k) = mu N cone / 2.
  EXPECT_NEAR(stored, mu * kNormal * cone / 2, 1e-6 * stored);
  EXPECT_NEAR(first, stored + end_of_pull->contact.dissipation, 1e-9 * first);
  // The whole cycle dissipates the loop's area on top of the first slide.
  EXPECT_NEAR(samples.back().contact.dissipation - end_of_pull->contact.dissipation, loop,
              1e-9 * loop);
}

TEST(Friction, HysteresisLoopAreaDissipationAndEnergyBalanceAreExact) {
  // mu N / eps_t = 0.25 mm falls on the increments (0.05 mm), so the trapezoidal integral of the
  // piecewise linear f(u) is exact.
  const double mu = 0.5;
  check_hysteresis(mu, mu * kNormal / kEpsT, 0.0);
}

TEST(Friction, WithAnElasticSlipTheLoopIsThatOfItsRadius) {
  // The stick stiffness mu N / gamma: a cone of radius gamma = 0.15 mm (on the increments).
  check_hysteresis(0.5, 0.15e-3, 0.15e-3);
}

TEST(Friction, WithAnElasticSlipAPointHoldsWhereItTouchedForTheRestOfTheAttempt) {
  // The slider's crossing seen through the contact stage as Newton's iterates would show it: open
  // (the slider 10 um above the rail), touching (10 um into it), then slid 2 um along the rail.
  // With an elastic slip gamma = 10 um the touch anchors the point for the rest of the attempt:
  // slid, it sticks with the stick spring mu f_n / gamma, so its friction force is mu f_n
  // (2 um / gamma) (formulation.md, "Friction", "In the stage"). The touch itself carries none,
  // a new attempt (begin_attempt) or the pair opening again forgets the anchor, and with a
  // constant penalty the point carries none until the increment converges (as before).
  constexpr double kMu = 0.3, kGamma = 1e-5, kSlid = 2e-6, kDepth = 1e-5;
  const TimeTable hold{{0.0, 2.0}, {0.0, 0.0}};
  for (const double elastic_slip : {kGamma, 0.0}) {
    SCOPED_TRACE(elastic_slip);
    const Drag d = drag_model(kMu, kMu, hold, 2.0, 0.5, elastic_slip);
    const Simulation sim(d.model);
    State open = sim.state(), touching = open, slid = open;
    for (const int i : d.slider) {
      open.x(2, i) += kDepth;
      touching.x(2, i) -= kDepth;
      slid.x(2, i) -= kDepth;
      slid.x(0, i) += kSlid;
    }
    const std::unique_ptr<ContactStage> stage = ContactStage::of(d.model);
    // One iterate: the pair's projection and friction at `state`.
    const auto iterate = [&stage](const State& state) {
      stage->update_candidates(state);
      EXPECT_EQ(stage->project(state, false), "");
      return stage->summary();
    };
    stage->begin_attempt();
    ASSERT_EQ(iterate(open).active, 0);
    const ContactSummary touch = iterate(touching);
    ASSERT_EQ(touch.active, 1);
    EXPECT_EQ(touch.stick + touch.slip, 0) << "the touch carries no friction";
    EXPECT_EQ(touch.tangential_force, 0.0);
    const ContactSummary after = iterate(slid);
    ASSERT_EQ(after.active, 1);
    if (elastic_slip > 0) {
      EXPECT_EQ(after.stick, 1);
      const double expected = kMu * after.total_force * kSlid / kGamma;
      EXPECT_NEAR(after.tangential_force, expected, 1e-6 * expected);
    } else {
      EXPECT_EQ(after.stick + after.slip, 0) << "a constant penalty anchors at the commit";
      EXPECT_EQ(after.tangential_force, 0.0);
    }
    // Opened again: the next touch (slid) anchors anew, and sliding back from it sticks with
    // the same force the other way.
    ASSERT_EQ(iterate(open).active, 0);
    EXPECT_EQ(iterate(slid).tangential_force, 0.0);
    if (elastic_slip > 0) {
      EXPECT_NEAR(iterate(touching).tangential_force, after.tangential_force,
                  1e-6 * after.tangential_force);
    }
    // A new attempt forgets the anchor of the last one.
    stage->begin_attempt();
    EXPECT_EQ(iterate(touching).tangential_force, 0.0);
  }
}

TEST(Friction, NewtonConvergesQuadraticallyInSlip) {
  const double mu = 0.3, t_end = 1.5;
  const TimeTable drag{{0.0, 1.0, t_end}, {0.0, 0.0, 0.05}};
  const std::vector<Sample> samples = run_drag(mu, mu, drag, t_end, 0.05);
  int checked = 0;
  for (const Sample& s : samples) {
    if (s.time <= 1.0 || s.contact.slip != 1)
      continue;
    const std::vector<double>& r = s.residuals;
    // Each residual between 1e-2 and round-off: r_k+1 < 10^1.5 r_k^2, i.e. the number of
    // correct digits about doubles (a linear rate, r_k+1 ~ r_k / 2, fails it).
    for (std::size_t k = 1; k + 1 < r.size(); ++k) {
      if (r[k] > 1e-12 && r[k] < 1e-2) {
        EXPECT_LT(std::log10(r[k + 1]), 2 * std::log10(r[k]) + 1.5)
            << "t = " << s.time << ", iteration " << k;
      }
    }
    EXPECT_LE(r.size(), 7u) << "t = " << s.time;
    ++checked;
  }
  EXPECT_GT(checked, 5);
}

/// Contact damping on a dynamic step (the velocities of Newmark's integrator reach the contact
/// stage): the drag above with a tangential dashpot c_t beside the Coulomb element. In slip the
/// drag force is mu N + c_t v exactly, v the slider's Newmark velocity at the increment (the
/// prescribed motion is linear in time but Newmark's velocity of it, started from rest, rings
/// about du/dt: the force follows the ringing).
TEST(Friction, TangentialDampingAddsCTimesTheSlidingVelocityOnDynamicSteps) {
  const double mu = 0.3, c_t = 50.0, t_end = 2.0;
  const TimeTable drag{{0.0, 1.0, t_end}, {0.0, 0.0, 0.02}};
  Drag d = drag_model(mu, mu, drag, t_end, 0.02);
  d.model.spline_contacts[0].friction.tangential_damping = c_t;
  d.model.steps[1].type = StepType::Dynamic;
  Simulation sim(d.model);
  struct Damped final : SimulationObserver {
    const Drag& d;
    std::vector<double> force, velocity;
    int slipping = 0;
    explicit Damped(const Drag& drag) : d(drag) {}
    void on_increment(const Simulation& s, const IncrementReport& r) override {
      if (r.time <= 1.0 + 1e-12)
        return;
      double rx = 0;
      for (int node : d.slider)
        rx += s.reactions()(0, node);
      force.push_back(rx);
      velocity.push_back(s.state().v_n(0, d.slider[0]));
      slipping += s.contact()->summary().slip;
    }
  } rec(d);
  sim.run(&rec);
  ASSERT_EQ(rec.force.size(), 50u);
  EXPECT_EQ(rec.slipping, 50);
  double spread = 0;
  for (std::size_t k = 0; k < rec.force.size(); ++k) {
    EXPECT_NEAR(rec.force[k], mu * kNormal + c_t * rec.velocity[k], 1e-8 * mu * kNormal)
        << "increment " << k << ", v = " << rec.velocity[k];
    spread = std::max(spread, std::abs(rec.velocity[k] - 0.02));
  }
  // The test sees the dashpot: the velocities differ from du/dt and the force with them.
  EXPECT_GT(spread, 1e-3);
  EXPECT_GT(c_t * 0.02, 0.5 * mu * kNormal);
}

/// Normal damping on a dynamic step: the slider pushed into the rail by a prescribed z motion;
/// the normal force is eps p + c dp/dt, dp/dt the approach velocity (Newmark's).
TEST(Friction, NormalDampingAddsCTimesThePenetrationRateOnDynamicSteps) {
  const double c = 5e4, t_end = 2.0;
  const TimeTable still{{0.0, t_end}, {0.0, 0.0}};
  Drag d = drag_model(0.0, 0.0, still, t_end, 0.05);
  SplineContactDefinition& contact = d.model.spline_contacts[0];
  contact.friction = {};
  contact.law.damping = c;
  d.model.loads.clear();
  // Slider nodes: z prescribed from 0 down by 40 microns over t = 1 ... 2 (touching at t = 1).
  d.model.prescribed[0].displacement[2] = TimeTable{{0.0, 1.0, t_end}, {0.0, 0.0, -4e-5}};
  d.model.steps[1].type = StepType::Dynamic;
  Simulation sim(d.model);
  struct Pressed final : SimulationObserver {
    const Drag& d;
    int checked = 0;
    double c = 0, damping = 0, total = 0;
    explicit Pressed(const Drag& drag, double damping) : d(drag), c(damping) {}
    void on_increment(const Simulation& s, const IncrementReport& r) override {
      const ContactSummary summary = s.contact()->summary();
      if (r.time <= 1.0 + 1e-12 || summary.active == 0)
        return;
      double rz = 0;
      for (int node : d.slider)
        rz += s.reactions()(2, node);
      const double rate = -s.state().v_n(2, d.slider[0]); // dp/dt, m/s
      const double expected = 1e5 * summary.max_penetration + c * rate;
      EXPECT_NEAR(summary.total_force, expected, 1e-8 * expected) << "t = " << r.time;
      EXPECT_NEAR(-rz, summary.total_force, 1e-8 * expected) << "t = " << r.time;
      damping += c * rate;
      total += expected;
      ++checked;
    }
  } rec(d, c);
  sim.run(&rec);
  EXPECT_GE(rec.checked, 15);
  EXPECT_GT(rec.damping, 0.2 * rec.total); // the damping term counts
}

/// The drag on the explicit path: the same rail and slider with mass (rho = 1000 kg/m^3), pressed
/// by N over t = 0 ... 0.5 s and held (undamped: the normal force rings about N), then dragged
/// from t = 1 s at 5 mm/s (mass-scaled to a step of 5e-5 s). In slip the friction force is mu f_n
/// at every increment (the return mapping, exactly) and the drag force is the friction force, and
/// the energy balance closes with the dissipation counted: the work of the loads and the drag
/// equals the kinetic, strain and contact energies plus what damping and friction dissipated.
TEST(Friction, ExplicitDragSlipsAtMuFnAndItsEnergyBalanceHoldsTheDissipation) {
  const double mu = 0.3, t_end = 2.0, v = 5e-3;
  const TimeTable drag{{0.0, 1.0, t_end}, {0.0, 0.0, v * (t_end - 1.0)}};
  Drag d = drag_model(mu, mu, drag, t_end, 1.0);
  const double rho = 1000, A = std::numbers::pi * kRadius * kRadius;
  const double I = std::numbers::pi * std::pow(kRadius, 4) / 4;
  for (Section& s : d.model.sections) {
    s.rhoA = rho * A;
    s.rhoJ = Eigen::Vector3d(rho * I, rho * I, 2 * rho * I);
  }
  d.model.loads[0].factor = TimeTable{{0.0, 0.5, t_end}, {0.0, 1.0, 1.0}};
  SolutionStep s;
  s.type = StepType::Explicit;
  s.end_time = t_end;
  s.mass_scaling_dt = s.dt_initial = s.dt_max = 5e-5;
  s.dt_min = 1e-7;
  s.output_every = 100;
  d.model.steps = {s};
  Simulation sim(d.model);
  struct Explicit final : SimulationObserver {
    const Drag& d;
    double mu;
    int slipping = 0;
    double worst_cone = 0, worst_balance = 0, work = 0, friction = 0, worst_drag = 0;
    double worst_bounce = 0;
    Explicit(const Drag& drag, double m) : d(drag), mu(m) {}
    void on_increment(const Simulation& s, const IncrementReport& r) override {
      const ContactSummary c = s.contact()->summary();
      const EnergyBalance e = s.energy_balance();
      worst_balance = std::max(worst_balance, std::abs(e.error));
      work = e.external_work + e.prescribed_work;
      friction = e.friction;
      if (r.time > 1.0 && c.slip == 1) {
        ++slipping;
        worst_cone = std::max(worst_cone, std::abs(c.tangential_force - mu * c.total_force));
      }
      if (r.time > 1.5 && r.time < 1.9) { // in slip, away from the drag's start and end
        double rx = 0;
        for (int node : d.slider)
          rx += s.reactions()(0, node);
        worst_drag = std::max(worst_drag, std::abs(rx - mu * c.total_force));
        worst_bounce = std::max(worst_bounce, std::abs(rx - mu * kNormal));
      }
    }
  } rec(d, mu);
  sim.run(&rec);
  std::printf(
      "explicit drag: %ld increments, %d samples in slip, |f_t - mu f_n| <= %.3e N, |drag - "
      "mu f_n| <= %.3e N, |drag - mu N| <= %.3e N (mu N = %.6g N); work %.6e J, friction "
      "dissipated %.6e J, largest "
      "balance error %.3e J\n",
      sim.explicit_status().increments, rec.slipping, rec.worst_cone, rec.worst_drag,
      rec.worst_bounce, mu * kNormal, rec.work, rec.friction, rec.worst_balance);
  EXPECT_GT(rec.slipping, 15);
  EXPECT_LT(rec.worst_cone, 1e-10 * mu * kNormal);
  EXPECT_LT(rec.worst_drag, 1e-9 * mu * kNormal);
  // The press is not damped: f_n rings about N by a fraction of a per cent.
  EXPECT_LT(rec.worst_bounce, 1e-2 * mu * kNormal);
  // Dragging 5 mm at mu N dissipates about 3 mJ.
  EXPECT_NEAR(rec.friction, mu * kNormal * v * (t_end - 1.0), 0.02 * mu * kNormal * v);
  EXPECT_LT(rec.worst_balance, 1e-3 * rec.friction);
}

} // namespace
} // namespace yarnsim

namespace yarnsim {
namespace {

TEST(Friction, PointsThatCarryNoFrictionAreSaid) {
  // A rod pressed on a parallel one with the point contact alone (line_contact = false): every
  // active point lies on its near-parallel path, where the kernel has no sensitivity of the
  // contact point and no friction. The run says so once instead of running frictionless
  // silently (ContactSummary::frictionless); with the all-angle contact there is nothing to say.
  const auto deck = [](bool line_contact) {
    return std::string(R"(
title = "parallel rods"
[[sections]]
name = "rod"
EA = 1e6
GA = 1e6
EI = 1.0
GJ = 1.0
[[lines]]
name = "base"
from = [0.0, 0.0, 0.0]
to = [1.0, 0.0, 0.0]
elements = 4
section = "rod"
reference_vector = [0.0, 1.0, 0.0]
[[lines]]
name = "top"
from = [0.0, 0.0, 0.0201]
to = [1.0, 0.0, 0.0201]
elements = 4
section = "rod"
reference_vector = [0.0, 1.0, 0.0]
[[splines]]
name = "base"
node_set = "base"
radius = 0.01
[[splines]]
name = "top"
node_set = "top"
radius = 0.01
[[contacts]]
name = "rods"
type = "spline"
between = [["base"], ["top"]]
penalty = 1e5
friction = 0.3
line_contact = )") +
           (line_contact ? "true" : "false") + R"(
[[constraints]]
node_set = "base"
dofs = "all"
[[constraints]]
node_set = "top"
dofs = ["ux", "uy", "rx", "ry", "rz"]
[[loads]]
node_set = "top"
force = [0.0, 0.0, -10.0]
table = [[0.0, 0.0], [1.0, 1.0]]
[[steps]]
type = "static"
end_time = 1.0
dt = 0.25
dt_max = 0.25
)";
  };
  for (const bool line_contact : {false, true}) {
    const Model m = read_deck_string(deck(line_contact), "parallel.toml");
    Simulation sim(m);
    test::Notices notices;
    sim.run(&notices);
    ASSERT_GT(sim.contact()->summary().active, 0);
    std::size_t frictionless = 0;
    for (const std::string& s : notices.said)
      if (s.find("carry no friction there") != std::string::npos)
        ++frictionless;
    if (line_contact) {
      EXPECT_EQ(sim.contact()->summary().frictionless, 0);
      EXPECT_EQ(frictionless, 0u);
    } else {
      EXPECT_GT(sim.contact()->summary().frictionless, 0);
      EXPECT_EQ(frictionless, 1u) << "said once";
      if (!notices.said.empty())
        std::printf("%s\n", notices.said.front().c_str());
    }
  }
}

} // namespace
} // namespace yarnsim
