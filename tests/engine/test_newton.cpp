// The Newton iteration's controls: tolerances against the residual's round-off level, the
// tangent's pattern following the contacts within reach down as well as up, and the closing limit
// of a correction.

#include "convergence_message.hpp"
#include "deck_text.hpp"
#include "engine/assembly/assembler.hpp"
#include "engine/contact/contact_set.hpp"
#include "engine/contact/contact_stage.hpp"
#include "engine/input/read_deck.hpp"
#include "engine/solver/simulation.hpp"
#include "notices.hpp"

#include <filesystem>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <limits>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

namespace yarnsim {
namespace {

/// A cantilever of length 1 m along x, clamped at x = 0, with the given section stiffnesses (N,
/// N m^2; EI = 1 N m^2), rolled up by a dead end moment 2 pi EI / L about z ramped over t in [0,
/// 1] (a circle at t = 1; examples/rollup.toml), in steps of dt to end_time; `extra` goes into
/// [[steps]].
Model rollup_deck(double EA, double GA, double GJ, int elements, double end_time, double dt,
                  int max_iterations, const std::string& extra = "") {
  const std::string deck =
      fmt::format(R"(
title = "roll-up"
[[sections]]
name = "rod"
EA = {:.17g}
GA = {:.17g}
EI = 1.0
GJ = {:.17g}
[[lines]]
name = "rod"
from = [0.0, 0.0, 0.0]
to = [1.0, 0.0, 0.0]
elements = {}
section = "rod"
reference_vector = [0.0, 1.0, 0.0]
[[constraints]]
node_set = "rod.start"
dofs = "all"
[[loads]]
node_set = "rod.end"
moment = [0.0, 0.0, 6.283185307179586]
table = [[0.0, 0.0], [1.0, 1.0]]
[[steps]]
type = "static"
end_time = {:.17g}
dt = {:.17g}
dt_max = {:.17g}
max_iterations = {}
{}
)",
                  EA, GA, GJ, elements, end_time, dt, dt, max_iterations, extra);
  return read_deck_string(deck, "rollup.toml");
}

/// Length / radius 2e4 (circular section, EA = 4 / r^2 = 1.6e9 N), 40 elements, 10 increments of
/// lambda = 0.05 (half way to the circle), with the given tolerance.
Model slender_rollup(double tolerance) {
  return rollup_deck(1.6e9, 5.5e8, 0.77, 40, 0.5, 0.05, 40,
                     fmt::format("tolerance = {{ force = {0}, increment = {0} }}", tolerance));
}

using test::Notices;

TEST(Newton, ToleranceAboveTheRoundOffLevelIsHonouredWithoutANote) {
  // Before the floors were measured, 1e-12 EA (size / element) lay above 1e-4 on this rod: the
  // results were the same bits for 1e-4 and 1e-8 on a finer mesh (100 elements).
  const Model loose = slender_rollup(1e-3), tight = slender_rollup(1e-5);
  Simulation a(loose), b(tight);
  Notices na, nb;
  a.run(&na);
  b.run(&nb);
  EXPECT_TRUE(na.said.empty()) << na.said.front();
  EXPECT_TRUE(nb.said.empty()) << nb.said.front();
  const Eigen::Vector3d tip_a = a.state().x.col(a.state().n_nodes() - 1);
  const Eigen::Vector3d tip_b = b.state().x.col(b.state().n_nodes() - 1);
  EXPECT_NE(tip_a, tip_b);
  // Exact: the tip of a rod bent to curvature kappa = lambda 2 pi / L lies at
  // (sin(kappa L) / kappa, (1 - cos(kappa L)) / kappa); lambda = 0.5: (0, 2 / pi).
  EXPECT_NEAR(tip_b.x(), 0.0, 2e-6);
  EXPECT_NEAR(tip_b.y(), 2 / std::numbers::pi, 2e-6);
}

TEST(Newton, ToleranceBelowTheRoundOffLevelIsSaidOnce) {
  const Model m = slender_rollup(1e-13);
  Simulation sim(m);
  Notices notices;
  sim.run(&notices); // converges: the floor, not the tolerance, ends the iterations
  EXPECT_NEAR(sim.state().time, 0.5, 1e-12);
  ASSERT_EQ(notices.said.size(), 1u);
  EXPECT_NE(notices.said.front().find("the force tolerance 1e-13 asked is below the round-off"),
            std::string::npos)
      << notices.said.front();
}

TEST(Newton, AModelWithoutContactTakesFullNewtonSteps) {
  // The damped Newton is contact's (an active set that changes, stick/slip that cycles): a model
  // without contact runs bit for bit as with the damping switched off. On this rod the damping
  // had stepped in where the residual stagnates on the path through large axial forces.
  const Model m = slender_rollup(1e-6);
  SimulationOptions plain;
  plain.line_search = false;
  Simulation damped(m), undamped(m, plain);
  damped.run();
  undamped.run();
  EXPECT_EQ(damped.total_iterations(), undamped.total_iterations());
  EXPECT_TRUE((damped.state().x.array() == undamped.state().x.array()).all());
}

/// The given length / radius (EA = 4 (L / r)^2 EI, GA = 0.35 EA), 16 elements, rolled into a
/// full circle in the given number of increments.
Model rollup_circle(double slenderness, int increments) {
  const double EA = 4 * slenderness * slenderness;
  return rollup_deck(EA, 0.35 * EA, 0.77, 16, 1.0, 1.0 / increments, 30);
}

TEST(Newton, SlenderRodsRollUpInFewIterationsWithTheMixedStresses) {
  // Issue 14: rods up to L / r = 1e5 rolled into a circle in 20 to 100 increments with at most 8
  // iterations per increment and no halving. The displacement-based Newton's tangent carries the
  // axial force of the strains at the iterate: a bending correction lengthens the chord by
  // (theta^2 / 2) h, and EA times that, 1e10 times the bending stiffness, swamps the next
  // tangent's stress terms (docs/performance.md: 30 increments, 366 iterations, 10 halvings in
  // 20). The mixed integration point Newton's tangent takes the resultants of the strains
  // linearised along the correction instead (formulation.md "Solution").
  struct Counter : SimulationObserver {
    int failed = 0, increments = 0;
    void on_attempt_failed(const Simulation&, double, double, const std::string&) override {
      ++failed;
    }
    void on_increment(const Simulation&, const IncrementReport& r) override {
      ++increments;
      if (std::getenv("YARNSIM_DEBUG")) {
        for (double v : r.residual_history)
          std::printf(" %.2e", v);
        std::printf("\n");
      }
    }
  };
  for (const double slenderness : {2e4, 1e5})
    for (const int increments : {20, 100}) {
      const Model m = rollup_circle(slenderness, increments);
      Simulation sim(m);
      Counter counter;
      sim.run(&counter);
      const double per_increment = double(sim.total_iterations()) / counter.increments;
      std::printf("L / r = %g, %d increments: %d increments, %d iterations (%.2f per increment), "
                  "%d halvings\n",
                  slenderness, increments, counter.increments, sim.total_iterations(),
                  per_increment, counter.failed);
      EXPECT_EQ(counter.failed, 0);
      EXPECT_EQ(counter.increments, increments);
      EXPECT_LE(per_increment, 8.0);
      // Exact: the tip returns to the clamp.
      EXPECT_LT(sim.state().x.col(sim.state().n_nodes() - 1).norm(), 1e-8);
    }
  // The displacement-based Newton on the same rod halves increments.
  SimulationOptions displacement;
  displacement.mixed_integration_point = false;
  const Model m = rollup_circle(1e5, 20);
  Simulation sim(m, displacement);
  Counter counter;
  sim.run(&counter);
  std::printf("displacement-based, L / r = 1e5, 20 increments: %d increments, %d iterations, %d "
              "halvings\n",
              counter.increments, sim.total_iterations(), counter.failed);
  EXPECT_GT(counter.failed, 0);
  EXPECT_GT(double(sim.total_iterations()) / counter.increments, 8.0);
}

/// Two straight beams of circular section (r = 0.01 m) crossing at right angles with a gap of
/// 1 mm between their surfaces, in spline or surface contact: the bottom one along x (group A),
/// the top one along y (group B, nodes 22 to 42), crossing a quarter into an element of each.
Model gapped_crossing(bool surface) {
  const std::string contact = surface ? R"(
[[surfaces]]
name = "bottom"
node_set = "bottom"
[[surfaces]]
name = "top"
node_set = "top"
[[contacts]]
name = "crossing"
type = "surface"
between = ["bottom", "top"]
law = "linear"
penalty = 1e4
)"
                                      : R"(
[[splines]]
name = "bottom"
node_set = "bottom"
radius = 0.01
[[splines]]
name = "top"
node_set = "top"
radius = 0.01
[[contacts]]
name = "crossing"
type = "spline"
between = ["bottom", "top"]
law = "linear"
penalty = 1e5
)";
  return read_deck_string(R"(
title = "crossing beams 1 mm apart"
[[materials]]
name = "rod"
E = 1e9
nu = 0.3
density = 1000.0
[[sections]]
name = "rod"
shape = "circle"
radius = 0.01
material = "rod"
[[lines]]
name = "bottom"
from = [-0.5, 0.025, 0.0]
to = [0.5, 0.025, 0.0]
elements = 10
section = "rod"
reference_vector = [0.0, 1.0, 0.0]
[[lines]]
name = "top"
from = [0.025, -0.5, 0.021]
to = [0.025, 0.5, 0.021]
elements = 10
section = "rod"
reference_vector = [1.0, 0.0, 0.0]
[[constraints]]
node_set = "bottom"
dofs = "all"
)" + contact + R"(
[[steps]]
type = "static"
end_time = 1.0
dt = 1.0
)",
                          surface ? "surface.toml" : "spline.toml");
}

TEST(Newton, TheClosingLimitLetsAnOpenPairPenetrateTheAllowanceInOneCorrection) {
  // ContactSet::closing_limit: a correction that closes a pair open by g = 1 mm scaled to the
  // fraction where the pair penetrates allowance x r, to first order; exact for a translation of
  // a straight beam (the contact point stays), which the evaluation after the move confirms.
  constexpr double kGap = 1e-3, kRadius = 0.01, kAllowance = 0.02, kDrop = 4e-3;
  for (const bool surface : {false, true}) {
    SCOPED_TRACE(surface ? "surface contact" : "spline contact");
    const Model m = gapped_crossing(surface);
    const Simulation sim(m);
    State state = sim.state();
    const std::unique_ptr<ContactStage> stage = ContactStage::of(m);
    stage->update_candidates(state);
    ASSERT_EQ(stage->evaluate(state, false), "");
    ASSERT_EQ(stage->active(), 0);
    ASSERT_NEAR(stage->min_gap(), kGap, 1e-12);
    const int n = state.n_nodes();
    // The top beam (nodes 21 to 41, from 0) translated by `by`.
    const auto top_moved = [&](const Eigen::Vector3d& by) {
      Eigen::Matrix3Xd u = Eigen::Matrix3Xd::Zero(3, n);
      for (int i = 21; i < n; ++i)
        u.col(i) = by;
      return u;
    };
    const double expected = (kGap + kAllowance * kRadius) / kDrop; // 0.3
    const Eigen::Matrix3Xd down = top_moved({0, 0, -kDrop});
    const double limit = stage->closing_limit(down, nullptr, kAllowance);
    EXPECT_NEAR(limit, expected, 1e-12);
    // Opening limits nothing, nor does sliding along the top beam (beyond the round-off of the
    // normal's other components).
    EXPECT_EQ(stage->closing_limit(top_moved({0, 0, kDrop}), nullptr, kAllowance),
              std::numeric_limits<double>::infinity());
    EXPECT_GT(stage->closing_limit(top_moved({0, kDrop, 0}), nullptr, kAllowance), 1e9);
    // A correction starting 0.5 mm lower (the offset): half the gap left; none where the start
    // already penetrates.
    const Eigen::Matrix3Xd half = top_moved({0, 0, -0.5 * kGap});
    EXPECT_NEAR(stage->closing_limit(down, &half, kAllowance),
                (0.5 * kGap + kAllowance * kRadius) / kDrop, 1e-12);
    const Eigen::Matrix3Xd past = top_moved({0, 0, -2 * kGap});
    EXPECT_EQ(stage->closing_limit(down, &past, kAllowance),
              std::numeric_limits<double>::infinity());
    // The configuration the limit allows: the pair penetrates the allowance.
    state.x += limit * down;
    stage->update_candidates(state);
    ASSERT_EQ(stage->evaluate(state, false), "");
    EXPECT_EQ(stage->active(), 1);
    EXPECT_NEAR(stage->max_penetration(), kAllowance * kRadius, 1e-12);
    // An active pair limits nothing: Newton deepens it freely.
    EXPECT_EQ(stage->closing_limit(down, nullptr, kAllowance),
              std::numeric_limits<double>::infinity());
  }
}

TEST(Newton, AFailedIncrementNamesTheSplineAndControlPointOfItsWorstNode) {
  // On a fabric the worst DOF's node number alone does not tell a user which yarn misbehaves
  // (the 96 x 96 weave's edge yarns: "worst: node 151824 DOF uz"); the message names the spline
  // (a fabric's yarn) and the node's place along it. The crossing beams, the top one's ends
  // pushed 3 mm down onto the bottom one, one Newton iteration allowed.
  Model m = gapped_crossing(false);
  const auto set_of = [&m](const std::string& name) {
    for (std::size_t k = 0; k < m.node_sets.size(); ++k)
      if (m.node_sets[k].name == name)
        return static_cast<int>(k);
    ADD_FAILURE() << "no node set " << name;
    return 0;
  };
  for (const char* end : {"top.start", "top.end"}) {
    PrescribedMotion pm;
    pm.node_set = set_of(end);
    pm.displacement = {TimeTable{{0.0}, {0.0}}, TimeTable{{0.0}, {0.0}},
                       TimeTable{{0.0, 1.0}, {0.0, -3e-3}}};
    m.prescribed.push_back(pm);
  }
  m.steps[0].max_iterations = 1;
  m.steps[0].dt_min = m.steps[0].dt_initial;
  Simulation sim(m);
  try {
    sim.run();
    FAIL() << "one iteration cannot converge here";
  } catch (const ConvergenceError& e) {
    const std::string what = e.what();
    // One iteration besides those where crossings closed (counted apart).
    EXPECT_EQ(test::iterations_toward_limit(what), 1) << what;
    EXPECT_TRUE(what.find("(on spline 'top', control point ") != std::string::npos ||
                what.find("(on spline 'bottom', control point ") != std::string::npos)
        << what;
    EXPECT_NE(what.find(" of 21)"), std::string::npos) << what;
  }
}

TEST(Newton, ThePatternDropsCouplingsNoCandidateNeeds) {
  // Yarns touching from the start (gap = 0): the first increments' attempts meet candidates that
  // the converged state does not keep. Before, the pattern kept every coupling ever met (its
  // factor grew tenfold, each factorisation took 40 times as long).
  std::string deck = test::example_text("biaxial-k1.toml");
  ASSERT_TRUE(test::set_key(deck, "gap", "0.0"));
  const Model m = read_deck_string(deck, "gap0.toml");
  struct Watch : SimulationObserver {
    int increments = 0;
    std::size_t worst_excess = 0;
    void on_increment(const Simulation& s, const IncrementReport&) override {
      ++increments;
      const std::size_t held = s.assembler().couplings().size();
      const std::size_t needed = s.contact()->couplings().size();
      worst_excess = std::max(worst_excess, held > needed ? held - needed : 0);
      EXPECT_LE(4 * held, 5 * needed + 64) << "increment " << increments;
      if (increments == 8)
        throw Interrupted("enough");
    }
  } watch;
  // Plain Newton: the damped one keeps this deck's first attempts from wandering, and so from
  // meeting the couplings this test is about.
  SimulationOptions plain;
  plain.line_search = false;
  Simulation sim(m, plain);
  EXPECT_THROW(sim.run(&watch), Interrupted);
  EXPECT_EQ(watch.increments, 8);
}

TEST(Newton, ThePatternCouplesOnlyThePairsWithinReachOfContact) {
  // The paper's k = 1 deck: about 1 600 candidate pairs for 36 contacts. Every candidate coupled
  // two yarns in the factor; pairs farther apart than the broad-phase margin no longer do (the
  // k = 1 run 0.95 s -> 0.62 s, the picture frame's factorisation seven times faster).
  const Model m =
      read_deck(std::filesystem::path(YARNSIM_SOURCE_DIR) / "examples" / "biaxial-k1.toml");
  struct Watch : SimulationObserver {
    int increments = 0;
    void on_increment(const Simulation& s, const IncrementReport&) override {
      ++increments;
      const ContactSummary c = s.contact()->summary();
      const std::size_t held = s.assembler().couplings().size();
      EXPECT_GE(held, static_cast<std::size_t>(c.active)) << "increment " << increments;
      EXPECT_LT(4 * held, static_cast<std::size_t>(c.candidates)) << "increment " << increments;
      if (increments == 5)
        throw Interrupted("enough");
    }
  } watch;
  Simulation sim(m);
  EXPECT_THROW(sim.run(&watch), Interrupted);
  EXPECT_EQ(watch.increments, 5);
}

TEST(Newton, SetCouplingsShrinksThePatternBackToTheBeams) {
  const Model m = slender_rollup(1e-4);
  std::vector<char> constrained(6 * m.nodes.size(), 0);
  Assembler a(m, constrained);
  const Eigen::Index beams = a.matrix().nonZeros();
  const int version = a.pattern_version();
  // A coupling between the two ends: entries the beams' pattern does not hold.
  const int last = static_cast<int>(m.nodes.size()) - 1;
  const ContactCoupling far{{0, 1, 2, last - 2, last - 1, last}, false};
  EXPECT_TRUE(a.ensure_couplings({far}));
  EXPECT_GT(a.matrix().nonZeros(), beams);
  EXPECT_FALSE(a.set_couplings({far})); // already exactly these
  EXPECT_TRUE(a.set_couplings({}));
  EXPECT_EQ(a.matrix().nonZeros(), beams);
  EXPECT_TRUE(a.couplings().empty());
  EXPECT_EQ(a.pattern_version(), version + 2);
}

} // namespace
} // namespace yarnsim
