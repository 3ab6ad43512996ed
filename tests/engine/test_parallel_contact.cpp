// Contact between nearly parallel yarns in the engine (the all-angle spline contact,
// contact/line_contact.hpp; docs/verification.md, "Parallel contact"): two beams side by side
// carrying a uniform load through contact, a yarn turned from crossing to parallel against
// another, and the double helix of examples/double-helix.toml.
#include "beam_models.hpp"
#include "engine/input/read_deck.hpp"
#include "engine/output/checkpoint_file.hpp"
#include "engine/solver/checkpoint.hpp"
#include "engine/solver/simulation.hpp"

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <gtest/gtest.h>
#include <numbers>
#include <stdexcept>
#include <tbb/global_control.h>
#include <unistd.h>
#include <vector>

namespace yarnsim {
namespace {

constexpr double kE = 1e9, kRadius = 0.01, kL = 1.0, kEps = 1e5;

Section rod() {
  const double A = std::numbers::pi * kRadius * kRadius;
  const double I = std::numbers::pi * std::pow(kRadius, 4) / 4;
  return test::stiffness_section(kE * A, kE * A / 2.6 * 5 / 6, kE * I, kE * I / 1.3);
}

/// Beam "top" (nodes 0 .. 2 n) from `top_from` to `top_to`, beam "bottom" (the next 2 n + 1)
/// from `bottom_from` to `bottom_to`, each with its contact spline through all its nodes, and the
/// all-angle contact between them (penalty kEps). Node sets 0: top, 1: bottom.
Model two_beams(const Eigen::Vector3d& top_from, const Eigen::Vector3d& top_to,
                const Eigen::Vector3d& bottom_from, const Eigen::Vector3d& bottom_to, int n,
                const Eigen::Vector3d& reference) {
  Model m = test::straight_beam(top_from, top_to, n, rod(), reference);
  const Model bottom = test::straight_beam(bottom_from, bottom_to, n, rod(), reference);
  const int offset = test::append_beam(m, bottom);
  m.node_sets.clear();
  NodeSet top{"top", {}}, bot{"bottom", {}};
  Spline a{"top", {}, kRadius}, b{"bottom", {}, kRadius};
  for (int i = 0; i <= 2 * n; ++i) {
    top.nodes.push_back(i);
    bot.nodes.push_back(offset + i);
    a.nodes.push_back(i);
    b.nodes.push_back(offset + i);
  }
  m.node_sets = {top, bot};
  m.splines = {a, b};
  m.spline_contacts.push_back(
      SplineContactDefinition{"pair", {0}, {1}, {kEps, 1.0, 0.0}, false, 0});
  return m;
}

int add_set(Model& m, std::string name, std::vector<int> nodes) {
  m.node_sets.push_back(NodeSet{std::move(name), std::move(nodes)});
  return static_cast<int>(m.node_sets.size()) - 1;
}

double total_contact_force(const Simulation& sim) {
  double f = 0;
  for (const ContactPoint& p : sim.contact()->points())
    f += p.force;
  return f;
}

/// Top beam on the bottom one, both along x, centre lines 2 r apart (touching); a uniform load
/// q (N/m, downwards) on the top beam as consistent nodal loads of the quadratic elements. The
/// top beam is held only in y and in its spin, and in x at one end, so the whole load goes
/// through contact. `rigid_bottom`: every node of the bottom beam held (a rigid foundation:
/// the pressure is q all along); otherwise the bottom beam is simply supported.
Model side_by_side(int n, double q, bool rigid_bottom) {
  Model m = two_beams({-kL / 2, 0, 2 * kRadius}, {kL / 2, 0, 2 * kRadius}, {-kL / 2, 0, 0},
                      {kL / 2, 0, 0}, n, Eigen::Vector3d::UnitY());
  const int last = 2 * n, offset = last + 1;
  const double le = kL / n;
  std::vector<int> ends{0, last}, corners, mids;
  for (int i = 1; i < last; ++i)
    (i % 2 == 0 ? corners : mids).push_back(i);
  const int s_ends = add_set(m, "ends", ends), s_corners = add_set(m, "corners", corners),
            s_mids = add_set(m, "mids", mids);
  const TimeTable ramp = TimeTable::ramp(1.0);
  m.loads.push_back(NodalLoad{s_ends, {0, 0, -q * le / 6}, {0, 0, 0}, false, ramp});
  m.loads.push_back(NodalLoad{s_corners, {0, 0, -q * le / 3}, {0, 0, 0}, false, ramp});
  m.loads.push_back(NodalLoad{s_mids, {0, 0, -2 * q * le / 3}, {0, 0, 0}, false, ramp});
  // Top: y and the spin about x everywhere (a cylinder on a cylinder has no lateral stability),
  // x at its first node.
  m.constraints.push_back(Constraint{0, {false, true, false, true, false, true}});
  m.constraints.push_back(Constraint{add_set(m, "top_start", {0}), {true, false, false}});
  if (rigid_bottom) {
    m.constraints.push_back(test::clamp(1));
  } else {
    m.constraints.push_back(Constraint{1, {false, true, false, true, false, true}});
    m.constraints.push_back(Constraint{add_set(m, "supports", {offset, offset + last}),
                                       {true, false, true, false, false, false}});
  }
  SolutionStep step = test::static_step(1.0, 0.25, 1e-10);
  step.tol_increment = 1e-8;
  m.steps.push_back(step);
  return m;
}

TEST(ParallelContact, BeamsSideBySideCarryAUniformLoadThroughContactAtEveryMesh) {
  for (const bool rigid : {true, false})
    for (const int n : {4, 8, 16, 32}) {
      // Rigid foundation: 2e-5 m of penetration at the default line penalty. Simply supported
      // bottom beam: a load small enough for small deflections (1.7 mm at mid-span).
      const double q = rigid ? 100.0 : 1.0; // N/m
      const Model m = side_by_side(n, q, rigid);
      Simulation sim(m);
      sim.run();
      const double total = total_contact_force(sim);
      // The bottom beam's supports carry the whole load: it reached them through contact.
      double supports = 0;
      for (int i = 2 * n + 1; i < static_cast<int>(m.nodes.size()); ++i)
        supports += sim.reactions()(2, i);
      // Pressure per segment of the top spline: each pair's force over its slave segment's
      // length along x, the pair found by the position of its deepest point. Segment i spans
      // the knot points m_i .. m_i+1: x_0, the midpoints of consecutive interior control
      // points, x_2n.
      std::vector<double> knots{-kL / 2};
      for (int j = 1; j <= 2 * n - 2; ++j)
        knots.push_back(0.5 * (m.nodes[j].x() + m.nodes[j + 1].x()));
      knots.push_back(kL / 2);
      std::vector<double> force(knots.size() - 1, 0.0);
      for (const ContactPoint& p : sim.contact()->points())
        for (std::size_t i = 0; i + 1 < knots.size(); ++i)
          if (p.position.x() >= knots[i] && p.position.x() < knots[i + 1])
            force[i] += p.force;
      double lo = 1e300, hi = 0, worst_step = 0;
      for (std::size_t i = 0; i < force.size(); ++i) {
        const double pressure = force[i] / (knots[i + 1] - knots[i]);
        lo = std::min(lo, pressure);
        hi = std::max(hi, pressure);
        if (i > 0)
          worst_step =
              std::max(worst_step, std::abs(pressure - force[i - 1] / (knots[i] - knots[i - 1])));
      }
      std::printf("%s bottom, %2d elements: contact forces %.9f N, supports %.9f N (load "
                  "%.1f N: %+.1e, %+.1e), %d pairs; pressure per segment %.4g to %.4g N/m, "
                  "largest change between neighbours %.3g N/m\n",
                  rigid ? "rigid" : "simply supported", n, total, supports, q * kL,
                  total / (q * kL) - 1, supports / (q * kL) - 1, sim.contact()->active(), lo, hi,
                  worst_step);
      EXPECT_NEAR(supports, q * kL, 1e-6 * q * kL) << n; // Newton's tolerance
      if (rigid) {
        EXPECT_EQ(sim.contact()->active(), 2 * n - 1) << n; // every segment, one pair each
        // Normals vertical: the forces sum to the load. The pressure is q up to the mismatch
        // between the beam's consistent nodal loads (Lagrange) and the spline's (B-spline)
        // distribution of the contact, which falls with the mesh.
        EXPECT_NEAR(total, q * kL, 1e-9 * q * kL) << n;
        const double spread = n >= 32 ? 0.02 : n >= 16 ? 0.04 : 0.08;
        EXPECT_GT(lo, (1 - spread) * q) << n;
        EXPECT_LT(hi, (1 + spread) * q) << n;
        EXPECT_LT(worst_step, 1.5 * spread * q) << n;
      } else {
        // The top beam, free at its ends, lifts off near them; the normals are within 1e-2 of
        // vertical.
        EXPECT_NEAR(total, q * kL, 1e-4 * q * kL) << n;
      }
    }
}

/// Records the contact force and the top beam's mid-node height after every increment.
struct History : SimulationObserver {
  int node = 0;
  int first_support = 0; ///< nodes from here on: the supports whose z reactions are summed
  std::vector<double> time, force, z, supports;
  std::vector<int> active;
  void on_increment(const Simulation& sim, const IncrementReport& r) override {
    time.push_back(r.time);
    force.push_back(total_contact_force(sim));
    z.push_back(sim.state().x(2, node));
    active.push_back(sim.contact()->active());
    double sum = 0;
    for (int i = first_support; i < static_cast<int>(sim.model().nodes.size()); ++i)
      sum += sim.reactions()(2, i);
    supports.push_back(sum);
  }
};

/// A beam (16 elements) pressed by P = 1 N at its mid node onto a rigid one it crosses at right
/// angles, the mid node held in x and y and turned about z by 90 degrees in `increments`
/// increments, so that the beam ends lying along the other.
History turned_from_crossing_to_parallel(int increments) {
  const int n = 16;
  // Started 5e-6 m into the bottom beam (half of P / eps), so that contact holds the top beam
  // from the first iteration.
  const double z0 = 2 * kRadius - 5e-6;
  Model m = two_beams({0, -kL / 2, z0}, {0, kL / 2, z0}, {-kL / 2, 0, 0}, {kL / 2, 0, 0}, n,
                      Eigen::Vector3d::UnitZ());
  m.constraints.push_back(test::clamp(1));
  const int mid = add_set(m, "mid", {n});
  PrescribedMotion turn;
  turn.node_set = mid;
  turn.displacement[0] = TimeTable::constant(0.0);
  turn.displacement[1] = TimeTable::constant(0.0);
  TimeTable angle;
  angle.time = {0.0, 1.0};
  angle.value = {0.0, -std::numbers::pi / 2};
  turn.rotation =
      std::array<TimeTable, 3>{TimeTable::constant(0.0), TimeTable::constant(0.0), angle};
  m.prescribed.push_back(turn);
  m.loads.push_back(NodalLoad{mid, {0, 0, -1.0}, {0, 0, 0}, false, TimeTable::constant(1.0)});
  m.steps.push_back(test::static_step(1.0, 1.0 / increments, 1e-9));
  Simulation sim(m);
  History h;
  h.node = n;
  h.first_support = 2 * n + 1;
  sim.run(&h);
  EXPECT_NEAR(h.time.back(), 1.0, 1e-12);
  return h;
}

TEST(ParallelContact, ContactPointsNameTheirSegmentsAndSumToTheTotalForce) {
  // Rigid foundation, 4 elements: a pair per segment of the top spline (7 segments), each on the
  // segment below it.
  const int n = 4;
  const Model m = side_by_side(n, 100.0, true);
  Simulation sim(m);
  sim.run();
  const std::vector<ContactPoint> points = sim.contact()->points();
  ASSERT_EQ(static_cast<int>(points.size()), 2 * n - 1);
  double sum = 0;
  for (std::size_t k = 0; k < points.size(); ++k) {
    const ContactPoint& p = points[k];
    EXPECT_FALSE(p.surface);
    EXPECT_EQ(p.definition, 0);
    EXPECT_EQ(p.body, (std::array<int, 2>{0, 1})) << "point " << k; // top (A), bottom (B)
    // The segment of the top spline over [knot k, knot k + 1], the same below.
    EXPECT_EQ(p.segment, (std::array<int, 2>{static_cast<int>(k), static_cast<int>(k)}))
        << "point " << k << " at x = " << p.position.x();
    sum += p.force;
  }
  // Summed in the points' order: the same double.
  EXPECT_EQ(sim.contact()->total_force(), sum);
  EXPECT_NEAR(sum, 100.0, 1e-6 * 100.0); // the load q L
}

TEST(ParallelContact, AYarnTurnedFromCrossingToParallelKeepsAContinuousForceHistory) {
  // The contact force stays P; the mid node's height (-penetration there) goes from -P / eps at
  // the crossing to the line contact's smaller value, and must not jump: the largest change in
  // an increment halves with the increment (a jump would not).
  double coarse_dz = 0;
  for (const int increments : {180, 360}) {
    const History h = turned_from_crossing_to_parallel(increments);
    double worst_force = 0, worst_support = 0, worst_dz = 0, z_scale = 0;
    int worst_at = 0;
    for (std::size_t k = 0; k < h.time.size(); ++k) {
      worst_force = std::max(worst_force, std::abs(h.force[k] - 1.0));
      worst_support = std::max(worst_support, std::abs(h.supports[k] - 1.0));
      z_scale = std::max(z_scale, std::abs(h.z[k] - 2 * kRadius));
      if (k > 0 && std::abs(h.z[k] - h.z[k - 1]) > worst_dz) {
        worst_dz = std::abs(h.z[k] - h.z[k - 1]);
        worst_at = static_cast<int>(k);
      }
    }
    std::printf("turned in %zu increments: support reactions within %.1e N of P, contact forces "
                "within %.1e N; mid-node penetration %.3e m crossing, %.3e m parallel; largest "
                "change in an increment %.2e m (%.1f %% of the largest, at %.1f degrees); %d to "
                "%d pairs\n",
                h.time.size(), worst_support, worst_force, 2 * kRadius - h.z.front(),
                2 * kRadius - h.z.back(), worst_dz, 100 * worst_dz / z_scale,
                90 * (1 - h.time[worst_at]), h.active.front(), h.active.back());
    EXPECT_LT(worst_support, 1e-6);
    // The sum of the force magnitudes is P where the normals are vertical, and a little more
    // where the top beam tilts on the line of contact.
    EXPECT_LT(worst_force, 1e-3);
    // The steepest change is the line contact's below the line angle, where the contact
    // lengthens like 1 / angle and the penetration falls with it; measured 8.7 % in 180.
    EXPECT_LT(worst_dz, 0.12 * z_scale);
    if (increments == 180)
      coarse_dz = worst_dz;
    else
      EXPECT_LT(worst_dz, 0.6 * coarse_dz);
  }
}

TEST(ParallelContact, TheDoubleHelixTwistsAFullTurn) {
  const Model m =
      read_deck(std::filesystem::path(YARNSIM_SOURCE_DIR) / "examples" / "double-helix.toml");
  Simulation sim(m);
  History h;
  h.node = 16; // the right strand's mid-height node
  sim.run(&h);
  ASSERT_NEAR(h.time.back(), 1.0, 1e-12);
  // The top end went round the full circle; the mid-height node has wound round the axis by
  // about half a turn (less near a clamp's straight start).
  const Eigen::Vector3d top = sim.state().x.col(32), mid = sim.state().x.col(16);
  const double mid_angle = std::atan2(mid.y(), mid.x());
  std::printf("double helix: %zu increments, %d iterations; top end at (%.5f, %.5f), mid-height "
              "node at %.1f degrees, %.5f m from the axis; %d pairs in contact, %.1f N\n",
              h.time.size(), sim.total_iterations(), top.x(), top.y(),
              mid_angle * 180 / std::numbers::pi, std::hypot(mid.x(), mid.y()),
              sim.contact()->active(), h.force.back());
  EXPECT_NEAR(top.x(), kRadius, 1e-9);
  EXPECT_NEAR(top.y(), 0.0, 1e-9);
  EXPECT_GT(std::abs(mid_angle), 150 * std::numbers::pi / 180);
  EXPECT_NEAR(std::hypot(mid.x(), mid.y()), kRadius, 0.1 * kRadius);
  EXPECT_GT(sim.contact()->active(), 25); // in contact along the whole length
  // The contact spreads along the strands as they wind: no pair drops out on the way.
  for (std::size_t k = 1; k < h.active.size(); ++k)
    EXPECT_GE(h.active[k], h.active[k - 1]) << "increment " << k + 1;
}

TEST(ParallelContact, AModelWithBadAllAngleSettingsIsRefused) {
  Model m = side_by_side(4, 1.0, true);
  m.spline_contacts[0].line_angle = 30; // above point_angle
  EXPECT_THROW(Simulation{m}, std::invalid_argument);
  m.spline_contacts[0].line_angle = 10;
  m.spline_contacts[0].gauss_points = 0;
  EXPECT_THROW(Simulation{m}, std::invalid_argument);
}

/// Positions, reactions and contact figures after every increment, and the checkpoints.
struct Bits : SimulationObserver {
  std::vector<Eigen::Matrix3Xd> x;
  std::vector<Eigen::Matrix<double, 6, Eigen::Dynamic>> reactions;
  std::vector<double> force, potential, dissipation;
  std::vector<int> iterations, slipping;
  std::vector<SimulationCheckpoint> checkpoints;
  void on_increment(const Simulation& s, const IncrementReport& r) override {
    x.push_back(s.state().x_n);
    reactions.push_back(s.reactions());
    force.push_back(s.contact()->total_force());
    potential.push_back(s.contact_energy());
    dissipation.push_back(s.contact()->summary().dissipation);
    slipping.push_back(s.contact()->summary().slip + s.contact()->summary().twist_slip);
    iterations.push_back(r.iterations);
    checkpoints.push_back(s.checkpoint());
  }
};

/// Increments `from` on of `a` equal those of `b` bit for bit.
void expect_same_bits(const Bits& a, std::size_t from, const Bits& b) {
  ASSERT_EQ(a.x.size() - from, b.x.size());
  for (std::size_t k = 0; k < b.x.size(); ++k) {
    EXPECT_TRUE((a.x[from + k].array() == b.x[k].array()).all()) << "positions, " << k;
    EXPECT_TRUE((a.reactions[from + k].array() == b.reactions[k].array()).all()) << k;
    EXPECT_EQ(a.force[from + k], b.force[k]) << k;
    EXPECT_EQ(a.potential[from + k], b.potential[k]) << k;
    EXPECT_EQ(a.dissipation[from + k], b.dissipation[k]) << k;
    EXPECT_EQ(a.iterations[from + k], b.iterations[k]) << k;
  }
}

/// The run of `m` on `threads` threads.
Bits run_on(const Model& m, int threads) {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
  Bits bits;
  Simulation(m).run(&bits);
  return bits;
}

/// The run of `m` from `checkpoint`, written to checkpoint.h5 and read back.
Bits run_from_file(const Model& m, const SimulationCheckpoint& checkpoint,
                   const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() /
      ("yarnsim_" + name + "_checkpoint_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  output::write_checkpoint(dir, checkpoint, {1, {}, name});
  const output::StoredCheckpoint stored = output::read_checkpoint(dir);
  std::filesystem::remove_all(dir);
  Bits bits;
  Simulation(m, {}, stored.simulation).run(&bits);
  return bits;
}

TEST(ParallelContact, TheDoubleHelixIsBitwiseTheSameOnOneAndTwoThreadsAndAfterARestart) {
  // The first 0.3 s (a tenth of the turn to 0.3 of it: line contact along most of the strands).
  Model m = read_deck(std::filesystem::path(YARNSIM_SOURCE_DIR) / "examples" / "double-helix.toml");
  m.steps.back().end_time = 0.3;
  const Bits one = run_on(m, 1);
  ASSERT_GT(one.force.back(), 0.0);
  expect_same_bits(one, 0, run_on(m, 2));
  // Restarted from an increment's checkpoint in memory and through the file.
  const std::size_t k = one.x.size() / 2;
  Bits resumed;
  Simulation(m, {}, one.checkpoints[k]).run(&resumed);
  expect_same_bits(one, k + 1, resumed);
  expect_same_bits(one, k + 1, run_from_file(m, one.checkpoints[k], "helix"));
}

TEST(ParallelContact, FrictionIsBitwiseTheSameOnOneAndTwoThreadsAndAfterARestart) {
  // The paper's k = 1 fabric with mu = 0.2 at the crossings (examples/biaxial-k1-friction.toml),
  // to t = 0.4 s: the crossings close from about t = 0.1 s on and some of them slip (the yarns
  // straighten under them).
  Model m = read_deck(std::filesystem::path(YARNSIM_SOURCE_DIR) / "examples" /
                      "biaxial-k1-friction.toml");
  m.steps.back().end_time = 0.4;
  ASSERT_TRUE(m.spline_contacts[0].friction.active());
  const Bits one = run_on(m, 1);
  ASSERT_GT(one.force.back(), 0.0);
  ASSERT_GT(one.dissipation.back(), 0.0) << "no slip: the test would not exercise the history";
  expect_same_bits(one, 0, run_on(m, 2));
  // Restarted through the checkpoint file from an increment with points in slip.
  std::size_t k = one.x.size() / 2;
  while (k + 2 < one.x.size() && one.slipping[k] == 0)
    ++k;
  ASSERT_GT(one.slipping[k], 0);
  expect_same_bits(one, k + 1, run_from_file(m, one.checkpoints[k], "friction"));
}

TEST(ParallelContact, TorsionalFrictionIsBitwiseTheSameOnOneAndTwoThreadsAndAfterARestart) {
  // As above with torsional friction at the crossings (its anchors and states in the
  // checkpoint's committed_twist table), to t = 0.3 s.
  Model m = read_deck(std::filesystem::path(YARNSIM_SOURCE_DIR) / "examples" /
                      "biaxial-k1-friction.toml");
  m.steps.back().end_time = 0.3;
  m.spline_contacts[0].friction.torsional = true;
  const Bits one = run_on(m, 1);
  ASSERT_GT(one.force.back(), 0.0);
  ASSERT_GT(one.dissipation.back(), 0.0);
  expect_same_bits(one, 0, run_on(m, 2));
  std::size_t k = one.x.size() / 2;
  while (k + 2 < one.x.size() && one.slipping[k] == 0)
    ++k;
  expect_same_bits(one, k + 1, run_from_file(m, one.checkpoints[k], "torsion"));
}

} // namespace
} // namespace yarnsim
