// Torsional friction of the surface contact in the engine
// (contact/surface_torsional_friction.hpp through the surface contact set), against the exact
// answers of the elastic-plastic law as the spline contact's test_torsional_friction.cpp: two
// crossed beams with their surfaces, pressed together by a fixed normal force N and turned
// against each other about the normal, carry the torque k_r phi while it is below mu N rho and
// mu N rho in slip (a static peak mu_s N rho, then mu_k N rho); the dissipation of the twist's
// slip enters the contact summary; Newton converges quadratically in stick and in slip; the run
// is the same bit for bit on one and two threads and after a restart through the checkpoint file.
#include "beam_models.hpp"
#include "contact/torsional_friction.hpp"
#include "engine/output/checkpoint_file.hpp"
#include "engine/solver/checkpoint.hpp"
#include "engine/solver/simulation.hpp"

#include <tbb/global_control.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <gtest/gtest.h>
#include <numbers>
#include <string>
#include <unistd.h>
#include <vector>

namespace yarnsim {
namespace {

constexpr double kRadius = 0.01; // m
constexpr double kNormal = 2.0;  // N, pressing the turner on the rail
constexpr double kEpsT = 1e4;    // N/m, tangential penalty
constexpr double kX0 = 1.0 / 16; // m, the turner's axis: the middle of a rail element

/// A rigid rail along x (8 elements, 1 m, all nodes clamped) and a turner along y across it at
/// x = 1/16 m (3 elements, 0.2 m), both circular (r = 10 mm) with their surfaces, touching at
/// the middle of a rail element and of the turner's middle element (shares 1). Step 1
/// (0 < t < 1) presses the turner down by N at its middle node; from t = 1 on every turner node
/// is turned rigidly about the vertical through (1/16, 0) by the table `turn` (rad, of time):
/// its x, y and rotations prescribed, z free; the tables are sampled at every increment. With
/// `free_rotations`, the rotations of the end nodes of the turner's middle element (those of the
/// contact surface) are left free: the beam and the contact then set them, and each increment
/// takes Newton iterations.
struct Turn {
  Model model;
  std::vector<int> turner;
  TimeTable drag{{0.0}, {0.0}}; ///< x of the turner's axis beyond 1/16 m, m, of time
};

/// `drag` (optional): the turner's axis moved along x by this table (m, of time) as it turns.
Turn turn_model(const FrictionParameters& friction, const TimeTable& turn, double t_end, double dt,
                bool free_rotations = false, const TimeTable* drag = nullptr) {
  const double E = 1e9, A = std::numbers::pi * kRadius * kRadius;
  const double I = std::numbers::pi * std::pow(kRadius, 4) / 4;
  Section s = test::stiffness_section(E * A, E * A, E * I, 2 * E * I);
  s.shape = SectionShape::Circle;
  s.a = s.b = kRadius;
  Model m = test::straight_beam({-0.5, 0, 0}, {0.5, 0, 0}, 8, s);
  const double z0 = 2 * kRadius - 1e-6; // a micron of overlap: in contact from the start
  const Model beam =
      test::straight_beam({kX0, -0.1, z0}, {kX0, 0.1, z0}, 3, s, Eigen::Vector3d::UnitX());
  const int offset = test::append_beam(m, beam);
  Turn t;
  if (drag)
    t.drag = *drag;
  NodeSet rail{"rail", {}}, turner{"turner", {}};
  for (int i = 0; i <= 16; ++i)
    rail.nodes.push_back(i);
  for (int i = 0; i <= 6; ++i)
    turner.nodes.push_back(offset + i);
  t.turner = turner.nodes;
  m.node_sets = {rail, turner, NodeSet{"turner_mid", {offset + 3}}};
  m.constraints.push_back(test::clamp(0));
  std::vector<double> times;
  for (double time = 0.0; time < t_end + 0.5 * dt; time += dt)
    times.push_back(time);
  for (int node : turner.nodes) {
    const double y0 = m.nodes[node].y();
    PrescribedMotion p;
    p.node_set = static_cast<int>(m.node_sets.size());
    m.node_sets.push_back(NodeSet{"turner" + std::to_string(node), {node}});
    TimeTable dx{times, {}}, dy{times, {}}, zero{times, std::vector<double>(times.size(), 0.0)};
    TimeTable rz{times, {}};
    for (double time : times) {
      const double phi = turn.at(time);
      dx.value.push_back(t.drag.at(time) - y0 * std::sin(phi));
      dy.value.push_back(y0 * (std::cos(phi) - 1.0));
      rz.value.push_back(phi);
    }
    p.displacement[0] = dx;
    p.displacement[1] = dy;
    if (!free_rotations || (node != offset + 2 && node != offset + 4))
      p.rotation = std::array<TimeTable, 3>{zero, zero, rz};
    m.prescribed.push_back(p);
  }
  m.loads.push_back(NodalLoad{2, Eigen::Vector3d(0, 0, -kNormal), Eigen::Vector3d::Zero(), false,
                              TimeTable{{0.0, 1.0, t_end}, {0.0, 1.0, 1.0}}});
  Surface r{"rail", {}, kRadius, kRadius, 2.0}, tu{"turner", {}, kRadius, kRadius, 2.0};
  for (int e = 0; e < 8; ++e)
    r.elements.push_back(e);
  for (int e = 0; e < 3; ++e)
    tu.elements.push_back(8 + e);
  m.surfaces = {r, tu};
  SurfaceContactDefinition c{"crossing", {0}, {1}, {1e5, 1.0, 0.0}, 0};
  c.friction = friction;
  m.surface_contacts.push_back(c);
  SolutionStep press = test::static_step(1.0, 0.25, 1e-10);
  SolutionStep turning = test::static_step(t_end, dt, 1e-10);
  turning.dt_min = dt; // no halving: the increments are the test's sampling
  m.steps = {press, turning};
  t.model = std::move(m);
  return t;
}

/// Per increment: time, imposed angle, the torque that turns the turner (the z moment of its
/// supports' reactions about its axis, N m), the contact's summary, the Newton residuals, the
/// positions and (if asked for) the checkpoint.
struct Sample {
  double time, phi, torque;
  ContactSummary contact;
  std::vector<double> residuals;
  Eigen::Matrix3Xd x;
  SimulationCheckpoint checkpoint;
};

class Recorder final : public SimulationObserver {
public:
  Recorder(const Turn& t, const TimeTable& turn, bool checkpoints = false)
      : turn_(t), table_(turn), keep_(checkpoints) {}
  void on_increment(const Simulation& sim, const IncrementReport& r) override {
    double mz = 0;
    for (int node : turn_.turner) {
      const Eigen::Vector3d x =
          sim.state().x.col(node) - Eigen::Vector3d(kX0 + turn_.drag.at(r.time), 0, 0);
      const Eigen::Vector3d f = sim.reactions().col(node).head<3>();
      mz += x.cross(f).z() + sim.reactions()(5, node);
    }
    samples.push_back({r.time, table_.at(r.time), mz, sim.contact()->summary(), r.residual_history,
                       sim.state().x_n, keep_ ? sim.checkpoint() : SimulationCheckpoint{}});
  }
  std::vector<Sample> samples;

private:
  const Turn& turn_;
  TimeTable table_;
  bool keep_;
};

std::vector<Sample> run_turn(const FrictionParameters& friction, const TimeTable& turn,
                             double t_end, double dt, bool free_rotations = false) {
  const Turn t = turn_model(friction, turn, t_end, dt, free_rotations);
  Simulation sim(t.model);
  Recorder rec(t, turn);
  sim.run(&rec);
  return rec.samples;
}

FrictionParameters torsional(double mu_s, double mu_k, double rho = 0, double k_r = 0) {
  FrictionParameters f;
  f.mu_static = mu_s;
  f.mu_kinetic = mu_k;
  f.tangential_penalty = kEpsT;
  f.torsional = true;
  f.torsional_radius = rho;
  f.torsional_penalty = k_r;
  return f;
}

/// Newton's rate: the correct digits at least double per iteration (as the spline tests);
/// returns the number of iterations checked.
int check_quadratic(const Sample& s) {
  const std::vector<double>& r = s.residuals;
  int checked = 0;
  for (std::size_t k = 1; k + 1 < r.size(); ++k)
    if (r[k] > 1e-12 && r[k] < 1e-2) {
      EXPECT_LT(std::log10(r[k + 1]), 2 * std::log10(r[k]) + 1.5)
          << "t = " << s.time << ", iteration " << k;
      ++checked;
    }
  EXPECT_LE(r.size(), 7u) << "t = " << s.time;
  return checked;
}

TEST(SurfaceTorsionalFrictionEngine, TurnedCrossingSticksThenSlipsAtMuNRhoWithAStaticPeak) {
  // Defaults: rho from the two surfaces' widths (2 a each), k_r = eps_t rho^2. The static stick
  // angle mu_s N rho / k_r = 0.013 rad; steps of 0.003 rad.
  const double mu_s = 0.5, mu_k = 0.3, t_end = 2.0;
  const double rho = contact::footprint_radius(2 * kRadius, 2 * kRadius);
  const double k_r = kEpsT * rho * rho;
  const TimeTable turn{{0.0, 1.0, t_end}, {0.0, 0.0, 0.06}};
  const std::vector<Sample> samples = run_turn(torsional(mu_s, mu_k), turn, t_end, 0.05);
  bool peaked = false;
  int sticking = 0, slipping = 0, checked_stick = 0, checked_slip = 0;
  double worst_stick = 0, worst_slip = 0, last_dissipation = 0;
  int most_iterations = 0;
  for (const Sample& s : samples) {
    if (s.time <= 1.0) {
      EXPECT_NEAR(s.torque, 0.0, 1e-12) << "t = " << s.time; // pressing only
      continue;
    }
    most_iterations = std::max(most_iterations, static_cast<int>(s.residuals.size()) - 1);
    const double stick = k_r * s.phi;
    EXPECT_NEAR(s.contact.total_force, kNormal, 1e-8 * kNormal) << "t = " << s.time;
    // The summary's torque and the supports' torque (the actuator's) agree.
    EXPECT_NEAR(s.contact.torque, std::abs(s.torque), 1e-9 * mu_s * kNormal * rho);
    EXPECT_NEAR(s.contact.tangential_force, 0.0, 1e-9 * kNormal); // no sliding of the points
    // The twist's slip dissipates: the summary's dissipation never decreases.
    EXPECT_GE(s.contact.dissipation, last_dissipation) << "t = " << s.time;
    last_dissipation = s.contact.dissipation;
    if (!peaked && stick <= mu_s * kNormal * rho) {
      EXPECT_NEAR(s.torque, stick, 1e-8 * mu_s * kNormal * rho) << "t = " << s.time;
      EXPECT_EQ(s.contact.twist_stick, 1);
      worst_stick = std::max(worst_stick, std::abs(s.torque - stick) / stick);
      checked_stick += check_quadratic(s);
      ++sticking;
    } else if (!peaked) {
      EXPECT_NEAR(s.torque, mu_s * kNormal * rho, 1e-8 * mu_s * kNormal * rho) << "t = " << s.time;
      EXPECT_EQ(s.contact.twist_slip, 1);
      peaked = true;
    } else {
      const double bound = mu_k * kNormal * rho;
      EXPECT_NEAR(s.torque, bound, 1e-8 * bound) << "t = " << s.time;
      EXPECT_EQ(s.contact.twist_slip, 1);
      worst_slip = std::max(worst_slip, std::abs(s.torque - bound) / bound);
      checked_slip += check_quadratic(s);
      ++slipping;
    }
  }
  std::printf("surface torsional friction: %d increments in stick (torque against k_r phi, worst "
              "%.2e relative), %d in slip after the peak (against mu_k N rho, worst %.2e); at most "
              "%d Newton iterations (the turner's motion is prescribed)\n",
              sticking, worst_stick, slipping, worst_slip, most_iterations);
  EXPECT_TRUE(peaked);
  EXPECT_GE(sticking, 3);
  EXPECT_GT(slipping, 10);
  EXPECT_GT(last_dissipation, 0.0);
}

TEST(SurfaceTorsionalFrictionEngine, NewtonConvergesQuadraticallyInStickAndSlip) {
  // The contact surface's nodes free to turn: the torque is the beam's and the contact's
  // equilibrium, found by Newton's method. In slip the torque is still mu N rho.
  const double mu = 0.3, t_end = 1.6;
  const double rho = contact::footprint_radius(2 * kRadius, 2 * kRadius);
  const TimeTable turn{{0.0, 1.0, t_end}, {0.0, 0.0, 0.03}}; // the stick angle: 3 increments
  const std::vector<Sample> samples = run_turn(torsional(mu, mu), turn, t_end, 0.05, true);
  int checked[2] = {0, 0}, increments[2] = {0, 0}, most_iterations = 0;
  double worst_slip = 0;
  for (const Sample& s : samples) {
    if (s.time <= 1.0)
      continue;
    const int slip = s.contact.twist_slip;
    ASSERT_EQ(s.contact.twist_stick + s.contact.twist_slip, 1) << "t = " << s.time;
    checked[slip] += check_quadratic(s);
    ++increments[slip];
    most_iterations = std::max(most_iterations, static_cast<int>(s.residuals.size()) - 1);
    if (increments[slip] == 2) {
      std::printf("  %s increment at t = %.2f, relative residuals:", slip ? "slip" : "stick",
                  s.time);
      for (double r : s.residuals)
        std::printf(" %.2e", r);
      std::printf("\n");
    }
    if (slip == 1) {
      const double bound = mu * kNormal * rho;
      EXPECT_NEAR(s.contact.torque, bound, 1e-8 * bound) << "t = " << s.time;
      EXPECT_NEAR(std::abs(s.torque), bound, 1e-6 * bound) << "t = " << s.time;
      worst_slip = std::max(worst_slip, std::abs(std::abs(s.torque) - bound) / bound);
    }
  }
  std::printf("surface torsional friction, free contact nodes: %d increments in stick, %d in "
              "slip, at most %d Newton iterations, %d and %d iterations checked quadratic; "
              "supports' torque in slip against mu N rho, worst %.2e relative\n",
              increments[0], increments[1], most_iterations, checked[0], checked[1], worst_slip);
  EXPECT_GE(increments[0], 2);
  EXPECT_GE(increments[1], 5);
  EXPECT_GT(checked[0], 0);
  EXPECT_GT(checked[1], 0);
}

TEST(SurfaceTorsionalFrictionEngine, DissipationOfTheTwistsSlipIsMuNRhoTimesTheSlip) {
  // A turn to phi_a past the stick angle phi_s = mu N rho / k_r (set): the twist slips by
  // phi_a - phi_s, dissipating mu N rho times it, and stores (mu N rho)^2 / (2 k_r). Turned back
  // by less than 2 phi_s, the crossing sticks from the anchor the slip left: the torque falls by
  // k_r times the turn back.
  const double mu = 0.5, rho = 0.008, phi_s = 0.01, phi_a = 0.05, t_turn = 2.0, t_end = 2.2;
  const double limit = mu * kNormal * rho, k_r = limit / phi_s;
  const TimeTable turn{{0.0, 1.0, t_turn, t_end}, {0.0, 0.0, phi_a, phi_a - 0.01}};
  const std::vector<Sample> samples = run_turn(torsional(mu, mu, rho, k_r), turn, t_end, 0.05);
  const Sample* pressed = nullptr;
  const Sample* turned = nullptr;
  for (const Sample& s : samples) {
    if (std::abs(s.time - 1.0) < 1e-9)
      pressed = &s;
    if (std::abs(s.time - t_turn) < 1e-9)
      turned = &s;
  }
  ASSERT_NE(pressed, nullptr);
  ASSERT_NE(turned, nullptr);
  const double slide = phi_a - phi_s;
  EXPECT_NEAR(turned->contact.dissipation, limit * slide, 1e-9 * limit * slide);
  const double stored = turned->contact.potential - pressed->contact.potential;
  EXPECT_NEAR(stored, limit * limit / (2 * k_r), 1e-6 * stored);
  int back = 0;
  for (const Sample& s : samples) {
    if (s.time <= t_turn + 1e-9)
      continue;
    EXPECT_EQ(s.contact.twist_stick, 1) << "t = " << s.time;
    EXPECT_NEAR(s.torque, limit - k_r * (phi_a - s.phi), 1e-8 * limit) << "t = " << s.time;
    EXPECT_EQ(s.contact.dissipation, turned->contact.dissipation) << "t = " << s.time;
    ++back;
  }
  EXPECT_EQ(back, 4);
  std::printf("surface torsional friction: dissipation %.9e J (mu N rho slip %.9e J)\n",
              turned->contact.dissipation, limit * slide);
}

TEST(SurfaceTorsionalFrictionEngine, TurnedWhileDraggedOverARailNodeTheTorqueStaysWithinTheBound) {
  // Turned in slip (0.3 rad, 40 stick angles) while dragged 0.15 m along the rail: past its node
  // at x = 1/8 m, where the contact passes from one element's pair to the next through the
  // shared end window, each pair with its share of the contact and its own twist anchor (the
  // next pair anchors at its first touch). Outside the window the torque is mu N rho; inside it
  // stays within [0, mu N rho] (it dips while the next pair's twist builds up, as the drag force
  // does, test_surface_friction.cpp).
  const double mu = 0.3, t_end = 2.0;
  const double rho = contact::footprint_radius(2 * kRadius, 2 * kRadius);
  const double bound = mu * kNormal * rho;
  const TimeTable turn{{0.0, 1.0, t_end}, {0.0, 0.0, 0.3}};
  const TimeTable drag{{0.0, 1.0, t_end}, {0.0, 0.0, 0.15}};
  const Turn t = turn_model(torsional(mu, mu), turn, t_end, 0.02, false, &drag);
  Simulation sim(t.model);
  Recorder rec(t, turn);
  sim.run(&rec);
  int full = 0, turning = 0, shared = 0;
  double lowest = bound;
  for (const Sample& s : rec.samples) {
    if (s.time <= 1.0 + 1e-9)
      continue;
    ++turning;
    EXPECT_NEAR(s.contact.total_force, kNormal, 1e-8 * kNormal) << "t = " << s.time;
    EXPECT_LE(std::abs(s.torque), bound * (1 + 1e-9)) << "t = " << s.time;
    EXPECT_GE(s.torque, -1e-9 * bound) << "t = " << s.time;
    // The supports' torque is the contact's (the pairs' torques with their shares).
    EXPECT_NEAR(s.contact.torque, std::abs(s.torque), 1e-8 * bound) << "t = " << s.time;
    full += std::abs(s.torque - bound) < 1e-8 * bound;
    shared += s.contact.twist_stick + s.contact.twist_slip > 1;
    lowest = std::min(lowest, s.torque);
  }
  std::printf("turned while dragged over the rail's node: %d of %d increments at mu N rho, %d "
              "with the contact held by two pairs, lowest torque %.4e N m (mu N rho = %.4e N m)\n",
              full, turning, shared, lowest, bound);
  EXPECT_EQ(turning, 50);
  EXPECT_GE(shared, 2); // the window was crossed
  EXPECT_GT(full, 35);  // of 50: all but the increments in the window
}

TEST(SurfaceTorsionalFrictionEngine, TurnIsBitwiseTheSameOnOneAndTwoThreadsAndAfterARestart) {
  // Turned forth and back: stick, slip, stick again and slip the other way.
  const double mu = 0.3, t_end = 2.0, dt = 0.05;
  const TimeTable turn{{0.0, 1.0, 1.5, t_end}, {0.0, 0.0, 0.05, -0.02}};
  const Turn t = turn_model(torsional(0.4, mu), turn, t_end, dt);
  auto run = [&](int threads) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    Simulation sim(t.model);
    Recorder rec(t, turn, true);
    sim.run(&rec);
    return rec.samples;
  };
  const std::vector<Sample> one = run(1), two = run(2);
  ASSERT_EQ(one.size(), two.size());
  int slipped = 0;
  for (std::size_t k = 0; k < one.size(); ++k) {
    EXPECT_TRUE((one[k].x.array() == two[k].x.array()).all()) << k;
    EXPECT_EQ(one[k].torque, two[k].torque) << k;
    EXPECT_EQ(one[k].contact.dissipation, two[k].contact.dissipation) << k;
    slipped += one[k].contact.twist_slip;
  }
  EXPECT_GT(slipped, 5);
  // Restart through checkpoint.h5 from an increment in slip, before the turn back.
  std::size_t from = 0;
  for (std::size_t k = 0; k < one.size(); ++k)
    if (one[k].time < 1.5 - 1e-9 && one[k].contact.twist_slip == 1)
      from = k;
  ASSERT_GT(from, 0u);
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() /
      ("yarnsim_surface_torsional_friction_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  output::write_checkpoint(dir, one[from].checkpoint, {1, {}, "surface-torsional-friction"});
  const output::StoredCheckpoint stored = output::read_checkpoint(dir);
  std::filesystem::remove_all(dir);
  Simulation resumed(t.model, {}, stored.simulation);
  Recorder rec(t, turn);
  resumed.run(&rec);
  ASSERT_EQ(rec.samples.size(), one.size() - from - 1);
  for (std::size_t k = 0; k < rec.samples.size(); ++k) {
    const Sample& a = rec.samples[k];
    const Sample& b = one[from + 1 + k];
    EXPECT_TRUE((a.x.array() == b.x.array()).all()) << k;
    EXPECT_EQ(a.torque, b.torque) << k;
    EXPECT_EQ(a.contact.dissipation, b.contact.dissipation) << k;
    EXPECT_EQ(a.contact.twist_slip, b.contact.twist_slip) << k;
  }
}

} // namespace
} // namespace yarnsim
