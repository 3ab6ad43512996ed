// The paper's study on the spline model: the balanced fabric gives coinciding warp and weft
// curves at k = 1, and the warp curve at k = 2 matches the weft curve at k = 0.5 (the fabric is
// the same under x <-> y with z -> -z). Also: the same numbers on 1 and 2 threads, and the
// explicit path against the implicit one (issue 6's acceptance, on a 3 x 3 weave).
#include "convergence_message.hpp"
#include "deck_text.hpp"
#include "engine/input/read_deck.hpp"
#include "engine/run/run.hpp"
#include "engine/solver/simulation.hpp"
#include "engine/textile/biaxial.hpp"
#include "engine/textile/weave.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <tbb/global_control.h>

namespace yarnsim {
namespace {

const std::filesystem::path kExamples = std::filesystem::path(YARNSIM_SOURCE_DIR) / "examples";

struct Curves {
  std::vector<double> strain_warp, strain_weft, force_warp, force_weft;
  std::vector<double> energy_ratio; ///< kinetic / (internal + contact), -
};

struct CurveRecorder : SimulationObserver {
  Curves c;
  const Model& m;
  explicit CurveRecorder(const Model& model) : m(model) {}
  void on_increment(const Simulation& sim, const IncrementReport&) override {
    const textile::BiaxialReading r = textile::read_biaxial(m, sim.state().x_n, sim.reactions());
    c.strain_warp.push_back(r.strain_warp);
    c.strain_weft.push_back(r.strain_weft);
    c.force_warp.push_back(r.force_warp);
    c.force_weft.push_back(r.force_weft);
    const EnergyBalance e = sim.energy_balance();
    c.energy_ratio.push_back(e.kinetic / (e.internal + e.contact));
  }
};

Curves run_case(const std::string& deck) {
  const Model m = read_deck(kExamples / deck);
  Simulation sim(m);
  CurveRecorder rec(m);
  sim.run(&rec);
  return rec.c;
}

/// A biaxial run's warp force per increment, the largest relative residual an increment was
/// accepted at, and the failed attempts ("t = ..., dt = ...: why"): for tests that run one deck
/// with a Newton option on and off.
struct WarpForceHistory : SimulationObserver {
  const Model& m;
  std::vector<double> time, force;
  std::vector<int> iterations, closing_iterations; // of each increment's converged attempt
  double worst_residual = 0;
  int simplified_trials = 0; // the run's damped points judged by one solve so far
  std::vector<std::string> failures;
  explicit WarpForceHistory(const Model& model) : m(model) {}
  void on_increment(const Simulation& sim, const IncrementReport& r) override {
    simplified_trials = sim.simplified_trials();
    time.push_back(r.time);
    iterations.push_back(r.iterations);
    closing_iterations.push_back(r.closing_iterations);
    force.push_back(textile::read_biaxial(m, sim.state().x_n, sim.reactions()).force_warp);
    worst_residual = std::max(worst_residual, r.residual_history.back());
  }
  void on_attempt_failed(const Simulation&, double t, double dt, const std::string& why) override {
    failures.push_back(fmt::format("t = {:.6g} s, dt = {:.3g} s: {}", t, dt, why));
  }
};

/// Runs `m` with `options`, prints what the run took (`label` first) and returns its Newton
/// iterations and history.
std::pair<int, WarpForceHistory> run_history(const Model& m, const SimulationOptions& options,
                                             const std::string& label) {
  Simulation sim(m, options);
  WarpForceHistory rec(m);
  sim.run(&rec);
  std::printf("%s: %d increments, %d Newton iterations (damped points judged by one solve: "
              "%d), accepted at relative residuals up to %.2e; warp force %.9f N\n",
              label.c_str(), sim.state().increment, sim.total_iterations(), rec.simplified_trials,
              rec.worst_residual, rec.force.back());
  for (const std::string& f : rec.failures)
    std::printf("  failed: %s\n", f.c_str());
  return {sim.total_iterations(), rec};
}

/// An example deck read with its `dt_max` set (the increments' longest, s).
Model example_with_dt_max(const std::string& name, const std::string& dt_max) {
  std::string deck = test::example_text(name);
  EXPECT_TRUE(test::set_key(deck, "dt_max", dt_max));
  return read_deck_string(deck, name);
}

/// The same end of a frictional test along other increments: friction makes the curve depend on
/// the increments (the slip integrated over each), so two runs' ends agree within that
/// dependence, closer to each other than the first is to a run in increments half as long.
void expect_same_end_within_the_increments_dependence(const WarpForceHistory& first,
                                                      const WarpForceHistory& other,
                                                      const WarpForceHistory& half) {
  ASSERT_EQ(first.time.back(), other.time.back());
  ASSERT_EQ(first.time.back(), half.time.back());
  EXPECT_LT(std::abs(first.force.back() - other.force.back()),
            std::abs(first.force.back() - half.force.back()));
}

/// Linear interpolation of y(x) at x0 on increasing x.
double at(const std::vector<double>& x, const std::vector<double>& y, double x0) {
  for (std::size_t i = 1; i < x.size(); ++i)
    if (x[i] >= x0) {
      const double w = (x0 - x[i - 1]) / (x[i] - x[i - 1]);
      return (1 - w) * y[i - 1] + w * y[i];
    }
  return y.back();
}

/// The final tangent slope dF/d(eps) over the last 20 % of the curve.
double final_slope(const std::vector<double>& s, const std::vector<double>& f) {
  const double s1 = s.back(), s0 = 0.8 * s1;
  return (f.back() - at(s, f, s0)) / (s1 - s0);
}

TEST(Biaxial, BalancedFabricCurvesCoincide) {
  const Curves k1 = run_case("biaxial-k1.toml");
  const Curves k2 = run_case("biaxial-k2.toml");
  const Curves k05 = run_case("biaxial-k0.5.toml");
  ASSERT_NEAR(k1.strain_warp.back(), 0.015, 1e-9);
  ASSERT_NEAR(k2.strain_warp.back(), 0.015, 1e-9);
  ASSERT_NEAR(k05.strain_weft.back(), 0.015, 1e-9);
  // Past the toe the curves agree at equal strain: warp and weft at k = 1 to round-off (one
  // run), k = 2 warp and k = 0.5 weft within 0.2 %. The mirrored runs are mirror images up to
  // round-off, which the fill-reducing ordering (not mirror-symmetric) changes: their adaptive
  // steps then differ (52 and 53 increments), and at the toe's end, 0.3 %, where the slope grows
  // from nearly zero to its final value within one increment, linear interpolation between
  // different increments differs by 2 N of 70 (2.8 %). So the comparison starts at 0.35 %.
  double worst_k1 = 0, worst_k2 = 0;
  for (double s = 0.003; s <= 0.015 + 1e-12; s += 0.0005) {
    const double fw = at(k1.strain_warp, k1.force_warp, s),
                 ff = at(k1.strain_weft, k1.force_weft, s);
    worst_k1 = std::max(worst_k1, std::abs(fw - ff) / std::abs(fw));
  }
  for (double s = 0.0035; s <= 0.015 + 1e-12; s += 0.0005) {
    const double a = at(k2.strain_warp, k2.force_warp, s);
    const double b = at(k05.strain_weft, k05.force_weft, s);
    worst_k2 = std::max(worst_k2, std::abs(a - b) / std::abs(a));
  }
  const double EA = 38000, n = 6;
  std::printf("k = 1: warp %.1f N, weft %.1f N at 1.5 %%; largest warp/weft difference %.2e\n",
              k1.force_warp.back(), k1.force_weft.back(), worst_k1);
  std::printf("k = 2 warp vs k = 0.5 weft: %.1f N vs %.1f N at 1.5 %%; largest difference %.2e\n",
              k2.force_warp.back(), k05.force_weft.back(), worst_k2);
  std::printf("final slopes / (n EA): k = 1 warp %.3f weft %.3f; k = 2 warp %.3f weft %.3f; "
              "k = 0.5 warp %.3f weft %.3f\n",
              final_slope(k1.strain_warp, k1.force_warp) / (n * EA),
              final_slope(k1.strain_weft, k1.force_weft) / (n * EA),
              final_slope(k2.strain_warp, k2.force_warp) / (n * EA),
              final_slope(k2.strain_weft, k2.force_weft) / (n * EA),
              final_slope(k05.strain_warp, k05.force_warp) / (n * EA),
              final_slope(k05.strain_weft, k05.force_weft) / (n * EA));
  EXPECT_LT(worst_k1, 1e-9);
  EXPECT_LT(worst_k2, 0.002);
  // The stiff part cannot be stiffer than the straight yarns themselves.
  EXPECT_LT(final_slope(k1.strain_warp, k1.force_warp), n * EA);
  EXPECT_GT(final_slope(k1.strain_warp, k1.force_warp), 0.5 * n * EA);
}

/// A deck of examples/ on a 4 x 4 weave (yarns 7 spacings long), everything else as given.
Curves run_four_by_four(const std::string& deck) {
  std::string s = test::example_text(deck);
  const auto set = [&s](const std::string& key, const std::string& value) {
    EXPECT_TRUE(test::set_key(s, key, value)) << key;
  };
  set("n_warp", "4");
  set("n_weft", "4");
  set("length_warp", "31.81815e-3");
  set("length_weft", "31.81815e-3");
  const Model m = read_deck_string(s, deck);
  Simulation sim(m);
  CurveRecorder rec(m);
  sim.run(&rec);
  return rec.c;
}

TEST(Biaxial, SurfaceContactCarriesTheWeaveToFullStrain) {
  // Around a crossing each yarn's surface is kinked at the nodes between its elements; as the
  // fabric straightens, the critical point of one element pair runs past a node where the
  // neighbouring element holds a contact of its own. Before the pairs shared contacts over
  // windows around the nodes that pair's force vanished there at once and Newton cycled
  // between the two states (this weave stopped at t = 0.826 s, 1.24 % strain).
  const Curves surface = run_four_by_four("biaxial-surface-k1.toml");
  const Curves spline = run_four_by_four("biaxial-k1.toml");
  ASSERT_NEAR(surface.strain_warp.back(), 0.015, 1e-9);
  ASSERT_NEAR(spline.strain_warp.back(), 0.015, 1e-9);
  double worst = 0;
  for (double s = 0.003; s <= 0.015 + 1e-12; s += 0.0005)
    worst = std::max(worst, std::abs(at(surface.strain_warp, surface.force_warp, s) -
                                     at(surface.strain_weft, surface.force_weft, s)) /
                                at(surface.strain_warp, surface.force_warp, s));
  const double ratio = surface.force_warp.back() / spline.force_warp.back();
  std::printf("4 x 4, k = 1 at 1.5 %%: surface %.1f N, spline %.1f N (%+.2f %%); warp/weft "
              "difference past the toe %.2e\n",
              surface.force_warp.back(), spline.force_warp.back(), 100 * (ratio - 1), worst);
  EXPECT_LT(worst, 0.01); // a balanced fabric: the warp and weft curves coincide
  // The paper finds the two formulations' curves very similar once the yarns are straight.
  EXPECT_NEAR(ratio, 1.0, 0.01);
}

/// The first end_time seconds of a k = 1 deck (contact must be active by then) on 1 and 2
/// threads: positions, reactions and contact forces bitwise identical at every increment.
void expect_same_on_one_and_two_threads(const std::filesystem::path& deck, double end_time) {
  Model m = read_deck(deck);
  m.steps.back().end_time = end_time;
  struct Snapshot : SimulationObserver {
    std::vector<Eigen::Matrix3Xd> x;
    std::vector<Eigen::Matrix<double, 6, Eigen::Dynamic>> r;
    std::vector<double> f;
    void on_increment(const Simulation& s, const IncrementReport&) override {
      x.push_back(s.state().x_n);
      r.push_back(s.reactions());
      f.push_back(s.contact()->total_force());
    }
  };
  Snapshot one, two;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    Simulation sim(m);
    sim.run(&one);
  }
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    Simulation sim(m);
    sim.run(&two);
  }
  ASSERT_EQ(one.x.size(), two.x.size());
  ASSERT_GT(one.f.back(), 0.0) << "no contact: the test would not exercise the contact stage";
  for (std::size_t k = 0; k < one.x.size(); ++k) {
    EXPECT_TRUE((one.x[k].array() == two.x[k].array()).all()) << "positions, increment " << k;
    EXPECT_TRUE((one.r[k].array() == two.r[k].array()).all()) << "reactions, increment " << k;
    EXPECT_EQ(one.f[k], two.f[k]) << "contact force, increment " << k;
  }
}

TEST(Biaxial, OneAndTwoThreadsGiveBitwiseIdenticalResults) {
  expect_same_on_one_and_two_threads(kExamples / "biaxial-k1.toml", 0.2);
}

TEST(Uniaxial, OneAndTwoThreadsGiveBitwiseIdenticalResults) {
  expect_same_on_one_and_two_threads(kExamples / "uniaxial-warp.toml", 0.4);
}

TEST(BiasExtension, OneAndTwoThreadsGiveBitwiseIdenticalResults) {
  // The benchmark-like specimen with friction: three quarters of the compaction step (0.2 s),
  // where the crossings close and press with friction. (Its pull starts slowly: to 0.24 s this
  // test took 72 s.)
  expect_same_on_one_and_two_threads(kExamples / "bias-extension-twintex-friction.toml", 0.15);
}

TEST(PictureFrame, OneAndTwoThreadsGiveBitwiseIdenticalResults) {
  // The pretension (0.2 s) closes the crossings; then 10 degrees of shear.
  expect_same_on_one_and_two_threads(kExamples / "picture-frame.toml", 0.35);
}

/// The paper's deck with n yarns a side (n + 3 spacings long) and `gap`, pulled over `time` s
/// to 1.5 % x time (the paper's rate).
std::string weave_deck(int n, double gap, double time) {
  std::string deck = test::example_text("biaxial-k1.toml");
  const auto set = [&deck](const std::string& key, const std::string& value) {
    EXPECT_TRUE(test::set_key(deck, key, value)) << key;
  };
  const double length = (n + 3) * 4.54545e-3;
  set("n_warp", std::to_string(n));
  set("n_weft", std::to_string(n));
  set("length_warp", fmt::format("{}", length));
  set("length_weft", fmt::format("{}", length));
  set("gap", fmt::format("{}", gap));
  set("max_strain", fmt::format("{}", 0.015 * time));
  set("loading_time", fmt::format("{}", time));
  return deck;
}

/// weave_deck's fabric with friction between warp and weft: mu = 0.2, the stick stiffness from
/// an elastic slip of 5 um (the benchmark's frictional weaves, scripts/bench).
std::string frictional_weave_deck(int n, double gap, double time) {
  std::string deck = weave_deck(n, gap, time);
  const std::size_t contact = deck.find("[contact]\n");
  EXPECT_NE(contact, std::string::npos);
  if (contact != std::string::npos)
    deck.insert(contact + 10, "friction = 0.2\nelastic_slip = 5e-6\n");
  return deck;
}

TEST(Biaxial, TouchingYarnsOfALargeWeaveKeepTheirNewtonCorrectionsBounded) {
  // A 12 x 12 weave woven without a gap (the splines then overlap by 12 um at every crossing),
  // the first 5 % of the test. Its tangent has near-mechanisms (a yarn pinned at its ends turns
  // about the line between them): without the step limit (formulation.md "Solution") the
  // second attempt's corrections moved yarns by 13 mm, then 42 m, until the linear solve
  // returned non-finite values; the broad phase filled with wrong candidates on the way, and
  // this test took 150 s instead of 5 (the same increments and halvings otherwise). With it,
  // every attempt that fails runs out of iterations with its yarns in place.
  const Model m = read_deck_string(weave_deck(12, 0.0, 0.05), "weave.toml");
  struct Failures : SimulationObserver {
    std::vector<std::string> why;
    int increments = 0;
    void on_attempt_failed(const Simulation&, double t, double dt,
                           const std::string& reason) override {
      std::printf("  t = %g s, dt = %g s: %s\n", t, dt, reason.c_str());
      why.push_back(reason);
    }
    void on_increment(const Simulation&, const IncrementReport&) override { ++increments; }
  } rec;
  Simulation sim(m);
  sim.run(&rec);
  std::printf("12 x 12, gap 0, to 0.075 %%: %d increments, %zu halvings, %d Newton iterations\n",
              rec.increments, rec.why.size(), sim.total_iterations());
  EXPECT_LE(rec.why.size(), 2u);
  for (const std::string& why : rec.why)
    EXPECT_EQ(test::iterations_toward_limit(why), 20) << why;
}

TEST(Biaxial, CrossingsThatCloseTogetherNeedNoHalvingWithTheClosingLimit) {
  // The toe of the 24 x 24 weave (the first tenth of the test), where its crossings close. A
  // correction from a tangent that lacks the pairs it closes threw floating yarns across the
  // clearance, the next one threw them back: at t = 0.065 s the active set went 4, 64, 40, 60,
  // 64, 32, ... pairs over 20 iterations and the increment was halved. The closing limit
  // (formulation.md "Solution") lets a pair open at a correction's start penetrate at most a
  // fiftieth of its contact radius in that correction.
  const Model m = read_deck_string(weave_deck(24, 0.11364e-3, 0.1), "weave.toml");
  struct Attempts : SimulationObserver {
    int failed = 0, longest = 0;
    void on_attempt_failed(const Simulation&, double t, double dt,
                           const std::string& reason) override {
      std::printf("  t = %g s, dt = %g s: %s\n", t, dt, reason.c_str());
      ++failed;
    }
    void on_increment(const Simulation&, const IncrementReport& r) override {
      longest = std::max(longest, r.iterations);
    }
  };
  const auto run = [&](double allowance) {
    SimulationOptions options;
    options.closing_allowance = allowance;
    Simulation sim(m, options);
    Attempts rec;
    sim.run(&rec);
    std::printf("closing allowance %g: %d increments, %d Newton iterations, %d failed attempts, "
                "at most %d iterations in an increment\n",
                allowance, sim.state().increment, sim.total_iterations(), rec.failed, rec.longest);
    return rec;
  };
  const Attempts limited = run(SimulationOptions{}.closing_allowance);
  EXPECT_EQ(limited.failed, 0);
  EXPECT_LE(limited.longest, 10);
  const Attempts free = run(0.0);
  EXPECT_GE(free.failed, 1) << "the case no longer shows what the limit is for";
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

TEST(Biaxial, ThePredictorStretchesThePulledYarnsWithTheirEnds) {
  // Simulation::predict: with frictionless crossings each node of a pulled yarn moves along it
  // with its ends' stretch, instead of the ends alone pulling the increment's stretch into the
  // end elements. The residual at the predictor falls, the converged path stays the same.
  const Model m = read_deck_string(weave_deck(4, 0.11364e-3, 0.5), "weave.toml");
  struct Start : SimulationObserver {
    std::vector<double> residual, force;
    const Model& m;
    explicit Start(const Model& model) : m(model) {}
    void on_increment(const Simulation& sim, const IncrementReport& r) override {
      if (r.failed_attempts == 0)
        residual.push_back(r.residual_history.front());
      force.push_back(textile::read_biaxial(m, sim.state().x_n, sim.reactions()).force_warp);
    }
  };
  const auto run = [&](bool kinematic) {
    SimulationOptions options;
    options.kinematic_predictor = kinematic;
    Simulation sim(m, options);
    Start rec(m);
    sim.run(&rec);
    std::printf("predictor %s: %d increments, %d Newton iterations, median relative residual at "
                "the predictor %.3g\n",
                kinematic ? "stretching the yarns" : "of the ends alone", sim.state().increment,
                sim.total_iterations(), median(rec.residual));
    return rec;
  };
  const Start stretched = run(true), ends = run(false);
  EXPECT_LT(median(stretched.residual), 0.1 * median(ends.residual));
  // The same end of the test (the step sizes may differ): the same force.
  EXPECT_NEAR(stretched.force.back(), ends.force.back(), 1e-4 * std::abs(ends.force.back()));
}

TEST(Biaxial, TheIncrementTestOnTheSimplifiedCorrectionSparesTheConfirmingIteration) {
  // Simulation::attempt: where the residual is within its tolerance but the last correction, as
  // applied, is not within the increment tolerance, the simplified Newton correction at the
  // point reached (one solve with the factorisation in hand) is tested instead of one more
  // iteration (formulation.md "Solution"). The last correction bounds the error of the point
  // it started from, the simplified one estimates that of the point reached: the same answer
  // to the tolerance, an iteration fewer in most increments.
  const auto run = [](const Model& m, bool simplified) {
    SimulationOptions options;
    options.simplified_correction_check = simplified;
    return run_history(m, options,
                       fmt::format("simplified correction check {}", simplified ? "on" : "off"));
  };
  // The paper's fabric and test, frictionless and with an elastic slip.
  for (const bool friction : {false, true}) {
    const Model m = read_deck_string(friction ? frictional_weave_deck(6, 0.11364e-3, 1.0)
                                              : weave_deck(6, 0.11364e-3, 1.0),
                                     "weave.toml");
    ASSERT_EQ(has_friction(m), friction);
    const auto [iterations, curve] = run(m, true);
    const auto [confirmed_iterations, confirmed] = run(m, false);
    // Measured: 128 against 175 iterations frictionless, 124 against 172 with friction.
    EXPECT_LT(iterations, 0.8 * confirmed_iterations);
    EXPECT_LE(curve.worst_residual, 1e-4); // the deck's force tolerance
    // The same curve: the forces of the two runs agree far within the tolerance. Measured: at
    // most 4.3e-4 N (1.7e-7 of the end force, in the toe) frictionless and 3.8e-4 N with
    // friction; at the end 4e-7 N and 6e-6 N of 2 546 and 2 559 N. Accepting wherever the
    // residual passes, without the increment test, leaves the frictional curve 1.1e-2 N
    // (4.3e-6) off at the end: the test fails. (Frictionless, the two acceptances differ by one
    // iteration and do not part.)
    ASSERT_EQ(curve.time, confirmed.time);
    const double end = std::abs(confirmed.force.back());
    for (std::size_t i = 0; i < curve.force.size(); ++i)
      EXPECT_NEAR(curve.force[i], confirmed.force[i], 1e-6 * end)
          << "at t = " << curve.time[i] << " s" << (friction ? ", with friction" : "");
    EXPECT_NEAR(curve.force.back(), confirmed.force.back(), 1e-8 * end);
  }
}

TEST(Biaxial, AnAttemptWhoseStickAndSlipDoNotSettleIsCutBeforeTheIterationLimit) {
  // Simulation::attempt: with the same number of active pairs over three iterates, a residual and a
  // number of slipping points that both grew twice running cut the attempt (the step is halved,
  // as at the iteration limit; SimulationOptions::stick_slip_check). The frictional 16 x 16
  // weave in increments of up to 0.04 s meets it in its toe.
  std::string deck = frictional_weave_deck(16, 0.11364e-3, 1.0);
  for (const char* key : {"dt", "dt_max"})
    ASSERT_TRUE(test::set_key(deck, key, "0.04")) << key;
  const Model m = read_deck_string(deck, "weave.toml");
  const auto run = [&m](bool check) {
    SimulationOptions options;
    options.stick_slip_check = check;
    return run_history(m, options, fmt::format("stick and slip check {}", check ? "on" : "off"));
  };
  const auto [iterations, cut] = run(true);
  const auto [limit_iterations, at_limit] = run(false);
  // The same attempts fail, each halved: the same increments. Measured: 100 against 111
  // iterations; the failed attempt cut after 13 iterations instead of 24 (20 and 4 where
  // crossings closed, counted apart: SimulationOptions::closing_iterations_apart).
  ASSERT_EQ(cut.failures.size(), at_limit.failures.size());
  ASSERT_FALSE(cut.failures.empty());
  for (std::size_t i = 0; i < cut.failures.size(); ++i) {
    EXPECT_NE(cut.failures[i].find("stick and slip not settling"), std::string::npos)
        << cut.failures[i];
    EXPECT_EQ(test::iterations_toward_limit(at_limit.failures[i]), 20) << at_limit.failures[i];
  }
  EXPECT_LT(iterations, limit_iterations);
  ASSERT_EQ(cut.time, at_limit.time);
  // The retry starts from the same converged state; the pattern keeps what the failed attempt
  // coupled (Simulation::run), so the sums may part in round-off.
  const double end = std::abs(at_limit.force.back());
  for (std::size_t i = 0; i < cut.force.size(); ++i)
    EXPECT_NEAR(cut.force[i], at_limit.force[i], 1e-9 * end) << "at t = " << cut.time[i] << " s";
}

TEST(Biaxial, IteratesWhereCrossingsCloseCountApartFromTheIterationLimit) {
  // Simulation::attempt: an iterate reached by a correction the closing limit cut, with more
  // active pairs than any iterate of the attempt before it, counts apart from max_iterations,
  // under a bound of kClosingIterationFactor times it in all
  // (SimulationOptions::closing_iterations_apart; as Abaqus counts severe discontinuity
  // iterations apart from equilibrium iterations). The TexGen plain weave's crossings close
  // over a few increments of its toe, in attempts that reached the limit while still closing,
  // with the stagnation test on the relative residual (before 2026-12-07). With the fixed
  // scale's (the default) its attempts converge within the limit either way (50 increments, 155
  // iterations, none beyond 20); the 96 x 96 weave's toe still takes increments beyond it
  // (docs/performance.md, "Stagnation on the attempt's fixed scale"). So also with damped points
  // judged by the next correction alone (before 2026-12-07; with the simplified correction's
  // test the old stagnation test's run takes 160 iterations either way, none beyond 20).
  const Model m = read_deck(std::filesystem::path(YARNSIM_SOURCE_DIR) / "examples" /
                            "biaxial-texgen-pweave.toml");
  ASSERT_EQ(m.steps.size(), 1u);
  const int limit = m.steps[0].max_iterations;
  const auto run = [&m](bool apart) {
    SimulationOptions options;
    options.closing_iterations_apart = apart;
    options.stagnation_on_fixed_scale = false;
    options.simplified_monotonicity = false;
    return run_history(m, options,
                       fmt::format("closing iterates {}", apart ? "counted apart" : "counted"));
  };
  const auto [iterations, apart] = run(true);
  const auto [counted_iterations, counted] = run(false);
  // Measured: 50 increments, 169 iterations, no failed attempt against 53, 217 and two failed
  // attempts (t = 0.02 and 0.04 s, each at the limit while closing).
  EXPECT_LT(apart.failures.size(), counted.failures.size());
  for (const std::string& why : counted.failures)
    EXPECT_EQ(test::iterations_toward_limit(why), limit) << why;
  EXPECT_LT(iterations, counted_iterations);
  // Accepted beyond the limit, the excess its closing iterates; none counted apart without.
  int beyond = 0;
  for (std::size_t i = 0; i < apart.iterations.size(); ++i) {
    EXPECT_LE(apart.iterations[i] - apart.closing_iterations[i], limit) << "increment " << i;
    EXPECT_LE(apart.iterations[i], kClosingIterationFactor * limit) << "increment " << i;
    beyond += apart.iterations[i] > limit;
  }
  std::printf("%d increments accepted beyond %d iterations\n", beyond, limit);
  EXPECT_GE(beyond, 1) << "the case no longer shows what the option is for";
  for (const int c : counted.closing_iterations)
    EXPECT_EQ(c, 0);
  // The same end of the test along other increments: the same force (measured 1.7e-8 of it
  // apart).
  EXPECT_NEAR(apart.force.back(), counted.force.back(), 1e-6 * std::abs(counted.force.back()));
}

TEST(Biaxial, FullStepsStagnateOnTheAttemptsFixedResidualScale) {
  // Simulation::attempt: the line search's damping acts on full Newton steps where the residual
  // on the attempt's fixed scale fell by less than a fifth over the last iteration or two
  // (SimulationOptions::stagnation_on_fixed_scale); before, on the relative residual over two,
  // whose reference (the iterate's largest nodal force) moves with the out-of-balance force
  // while crossings close: it saw stagnation where the force residual fell, and caught full
  // steps stalled with unchanged contact states an iteration late. The paper's k = 1 fabric
  // with friction (mu = 0.2) meets both in its toe.
  const auto run = [](bool fixed, const std::string& dt_max) {
    const Model m = example_with_dt_max("biaxial-k1-friction.toml", dt_max);
    EXPECT_TRUE(has_friction(m));
    SimulationOptions options;
    options.stagnation_on_fixed_scale = fixed;
    return run_history(m, options,
                       fmt::format("stagnation on the {}, dt_max = {} s",
                                   fixed ? "fixed scale" : "relative residual", dt_max));
  };
  const auto [iterations, fixed] = run(true, "0.02"); // the deck's
  const auto [relative_iterations, relative] = run(false, "0.02");
  // Measured: 52 increments and 146 iterations against 53 and 176 (158 against 192 with damped
  // points judged by the next correction alone, before the simplified correction's test).
  EXPECT_LT(iterations, 0.9 * relative_iterations);
  EXPECT_LE(fixed.worst_residual, 1e-4); // the deck's force tolerance
  // The same end of the test along other increments. Measured: 2 557.3526 and 2 557.3691 N apart
  // by 0.0165 N; the halved increments' 2 557.3790 N, 0.026 N from the first.
  const auto [half_iterations, half] = run(true, "0.01");
  expect_same_end_within_the_increments_dependence(fixed, relative, half);
}

TEST(Biaxial, DampedPointsThatKeptTheActiveSetAreJudgedByTheSimplifiedCorrection) {
  // Simulation::attempt: where a damped step kept the active set, the line search's
  // monotonicity test reads the simplified Newton correction at the point reached (one solve
  // with the factorisation delta came from) instead of the next Newton correction (a
  // factorisation more): NLEQ-ERR's test (SimulationOptions::simplified_monotonicity). A
  // rejected point then costs no Newton iteration. The paper's k = 1 fabric with friction and
  // torsional friction damps such points in its toe, where points stick and slip.
  const auto run = [](bool simplified, const std::string& dt_max) {
    const Model m = example_with_dt_max("biaxial-k1-torsion.toml", dt_max);
    EXPECT_TRUE(has_torsional_friction(m));
    SimulationOptions options;
    options.simplified_monotonicity = simplified;
    return run_history(m, options,
                       fmt::format("monotonicity test on the {} correction, dt_max = {} s",
                                   simplified ? "simplified" : "next", dt_max));
  };
  const auto [iterations, simplified] = run(true, "0.02"); // the deck's
  const auto [next_iterations, next] = run(false, "0.02");
  EXPECT_EQ(next.simplified_trials, 0);
  EXPECT_GT(simplified.simplified_trials, 0);
  // Measured: 51 increments and 133 Newton iterations (8 damped points judged by a solve)
  // against 52 and 165.
  EXPECT_LT(iterations, 0.9 * next_iterations);
  EXPECT_LE(simplified.worst_residual, 1e-4); // the deck's force tolerance
  // The same end of the test along other increments. Measured: 2 558.4708 and 2 558.4757 N
  // apart by 0.0049 N; the halved increments' 2 558.4810 N, 0.0103 N from the first.
  const auto [half_iterations, half] = run(true, "0.01");
  expect_same_end_within_the_increments_dependence(simplified, next, half);

  // Only with the factorisation delta was solved with: where the next correction's test rejected
  // a point whose step changed the active set (a factorisation there) and the point moved back
  // to the start's active set, the tangent in hand is the rejected point's, and a "simplified"
  // correction from it rejected the points in between down to lambda / 10 again and again (the
  // TexGen example: 395 iterations in 65 increments, against 155 in 50).
  const Model tg = read_deck(std::filesystem::path(YARNSIM_SOURCE_DIR) / "examples" /
                             "biaxial-texgen-pweave.toml");
  const auto texgen = [&tg](bool simplified) {
    SimulationOptions options;
    options.simplified_monotonicity = simplified;
    return run_history(tg, options,
                       fmt::format("TexGen example, monotonicity test on the {} correction",
                                   simplified ? "simplified" : "next"))
        .first;
  };
  EXPECT_LE(texgen(true), texgen(false)); // measured: 155 and 155
}

TEST(Biaxial, TensionTestsPredictWithTheLastIncrementWhereItLeavesTheShorterCorrection) {
  // A tension test predicts with its ends' predictor (with friction the ends alone: stretching
  // a pulled yarn would slip it at every crossing, measured 299 -> 8 369 iterations on
  // biaxial-k1-friction.toml; frictionless with the pulled yarns' stretch) or with the last
  // increment's motion and rotations held short of closing crossings, whichever leaves the
  // shorter simplified Newton correction after the attempt's first correction from the
  // converged state's tangent; where a predictor's active set is not the converged state's,
  // the smaller residual at the predictors decides (Simulation::choose_predictor;
  // docs/performance.md, "The predictor chosen after its first correction", "The secant's
  // rotations").
  struct Choices : SimulationObserver {
    const Model& m;
    int secant = 0, ends = 0, none = 0, failed = 0;
    int compared = 0; ///< attempts whose predictors were compared after the correction
    /// Largest |first residual - the chosen predictor's| / the chosen, and the same of the
    /// first iterate's residual against the chosen corrected one.
    double worst = 0, worst_corrected = 0;
    /// The secant's residual at its predictor over the ends', past the toe (t > 0.5 s).
    std::vector<double> secant_over_ends;
    double force = 0; ///< N, warp force at the end
    explicit Choices(const Model& model) : m(model) {}
    void on_increment(const Simulation& sim, const IncrementReport& r) override {
      failed += r.failed_attempts;
      force = textile::read_biaxial(m, sim.state().x_n, sim.reactions()).force_warp;
      if (std::isnan(r.ends_residual) || std::isnan(r.secant_residual)) {
        ++none;
        return;
      }
      if (sim.state().time > 0.5)
        secant_over_ends.push_back(r.secant_residual / r.ends_residual);
      bool secant_taken = r.secant_residual < r.ends_residual;
      if (!std::isnan(r.secant_corrected)) {
        ++compared;
        secant_taken = r.secant_next_correction < r.ends_next_correction;
        const double corrected = secant_taken ? r.secant_corrected : r.ends_corrected;
        worst_corrected =
            std::max(worst_corrected, std::abs(r.residual_history.at(1) - corrected) / corrected);
      }
      const double chosen = secant_taken ? r.secant_residual : r.ends_residual;
      worst = std::max(worst, std::abs(r.residual_history.front() - chosen) / chosen);
      ++(secant_taken ? secant : ends);
    }
  };
  const auto run = [](const Model& m, bool kinematic) {
    SimulationOptions options;
    options.kinematic_predictor = kinematic;
    Simulation sim(m, options);
    Choices rec(m);
    sim.run(&rec);
    std::printf("%s, predictor %s: %d increments, %d Newton iterations, %d failed attempts; the "
                "secant chosen %d times, the ends' %d (%d after the correction), no choice %d; "
                "first residuals off the chosen by %.2e and %.2e; the secant's residual at the "
                "predictor over the ends' %.3g (median past 0.5 s); warp force %.6f N\n",
                has_friction(m) ? "friction" : "frictionless",
                kinematic ? "chosen" : "of the ends alone", sim.state().increment,
                sim.total_iterations(), rec.failed, rec.secant, rec.ends, rec.compared, rec.none,
                rec.worst, rec.worst_corrected, median(rec.secant_over_ends), rec.force);
    return rec;
  };
  for (const bool friction : {true, false}) {
    SCOPED_TRACE(friction ? "with friction" : "frictionless");
    // The paper's fabric, with an elastic slip or frictionless, the whole test.
    const Model m = read_deck_string(friction ? frictional_weave_deck(6, 0.11364e-3, 1.0)
                                              : weave_deck(6, 0.11364e-3, 1.0),
                                     "weave.toml");
    ASSERT_EQ(has_friction(m), friction);
    const Choices chosen = run(m, true), ends = run(m, false);
    // Both predictors are taken, mostly after the correction. The attempt starts from the one
    // chosen (a secant chosen at the predictors is evaluated again there: the projections'
    // warm starts differ), and its first iterate is the chosen corrected point, evaluated
    // again with the tangent. With the choice reversed both checks fail.
    EXPECT_GT(chosen.secant, 10);
    EXPECT_GT(chosen.ends, 3); // measured: 5 with friction, 6 frictionless
    EXPECT_GT(chosen.compared, 30);
    EXPECT_EQ(chosen.none, 1); // the first increment: no last increment yet
    EXPECT_LT(chosen.worst, 1e-6);
    EXPECT_EQ(chosen.worst_corrected, 0.0); // the same point after the same dropped anchors
    EXPECT_EQ(ends.secant + ends.ends, 0);
    EXPECT_EQ(chosen.failed, 0);
    // The secant carries the last increment's rotations with its translations: without them
    // the carried translations turn the yarns' tangents away from their sections, and the
    // secant's residual at the predictor is the larger (measured: 19 against 1.1 at 24 x 24).
    EXPECT_LT(median(chosen.secant_over_ends), 0.5);
    // Within an increment the histories are fixed, so the converged states do not depend on
    // where Newton starts, but for the anchors of points that close during an attempt and for
    // where within the tolerance each increment is accepted (measured with friction:
    // 2 558.534365 against 2 558.534390 N, 1e-8 relative).
    EXPECT_NEAR(chosen.force, ends.force, 1e-7 * ends.force);
  }
}

TEST(Uniaxial, PulledCrimpGoesOutFreeCrimpGrowsAndFreeEndsCarryNoForce) {
  // examples/uniaxial-warp.toml: the warp pulled to 1.5 %, the weft's ends free. Without the
  // default stabilising damping: with it a free end carries the viscous force c m v of the
  // contracting weft it drags (2.0e-3 N here, 1.1e-6 of the warp force), without it nothing.
  Model m = read_deck(kExamples / "uniaxial-warp.toml");
  for (SolutionStep& step : m.steps)
    step.rayleigh_mass = 0;
  ASSERT_TRUE(m.biaxial && m.biaxial->uniaxial == FabricDirection::Warp);
  // Only the warp ends are prescribed: 6 yarns, two ends each.
  EXPECT_EQ(m.prescribed.size(), 12u);
  struct Recorder : SimulationObserver {
    const Model& m;
    std::vector<textile::BiaxialReading> readings;
    double worst_free_end = 0; ///< N, the largest force resultant next to a weft yarn's end
    std::vector<int> free_end_elements;
    explicit Recorder(const Model& model) : m(model) {
      // The elements at the weft yarns' ends (yarn_nodes: warp yarns first).
      const std::size_t n_warp = m.biaxial->warp_start.size();
      for (std::size_t y = n_warp; y < m.biaxial->yarn_nodes.size(); ++y)
        for (const int end : {m.biaxial->yarn_nodes[y].front(), m.biaxial->yarn_nodes[y].back()})
          for (std::size_t e = 0; e < m.elements.size(); ++e)
            if (m.elements[e].nodes.front() == end || m.elements[e].nodes.back() == end)
              free_end_elements.push_back(static_cast<int>(e));
    }
    void on_increment(const Simulation& sim, const IncrementReport&) override {
      readings.push_back(textile::read_biaxial(m, sim.state().x_n, sim.reactions()));
      const Eigen::Matrix<double, 6, Eigen::Dynamic> q = sim.section_resultants();
      for (const int e : free_end_elements)
        for (const int g : {0, 1})
          worst_free_end = std::max(worst_free_end, q.col(2 * e + g).head<3>().norm());
    }
  };
  Recorder rec(m);
  Simulation sim(m);
  sim.run(&rec);
  ASSERT_EQ(rec.free_end_elements.size(), 12u);
  const textile::BiaxialReading& first = rec.readings.front();
  const textile::BiaxialReading& last = rec.readings.back();
  std::printf("uniaxial, warp to %.2f %%: crimp warp %.3f %% -> %.3f %%, weft %.3f %% -> %.3f %%; "
              "weft strain %.3f %%; warp force %.1f N; largest force next to a free end %.2e N\n",
              100 * last.strain_warp, 100 * first.crimp_warp, 100 * last.crimp_warp,
              100 * first.crimp_weft, 100 * last.crimp_weft, 100 * last.strain_weft,
              last.force_warp, rec.worst_free_end);
  EXPECT_NEAR(last.strain_warp, 0.015, 1e-9);
  // The pulled direction's crimp goes out, the free direction's grows, and it contracts.
  EXPECT_LT(last.crimp_warp, 0.25 * first.crimp_warp);
  EXPECT_GT(last.crimp_weft, 1.5 * first.crimp_weft);
  EXPECT_LT(last.strain_weft, -0.005);
  // The free ends: no reaction (no prescribed DOF), and no force in the yarn next to them.
  EXPECT_EQ(last.force_weft, 0.0);
  EXPECT_GT(last.force_warp, 1000.0);
  EXPECT_LT(rec.worst_free_end, 1e-6 * last.force_warp);
}

TEST(Biaxial, SurfaceContactGivesBitwiseIdenticalResultsOnOneAndTwoThreads) {
  // The surface pairs close from t = 0.045 s on: 0.1 s has dozens of them active.
  expect_same_on_one_and_two_threads(kExamples / "biaxial-surface-k1.toml", 0.1);
}

TEST(Biaxial, ExplicitPathFollowsTheImplicitCurvePastTheToe) {
  // Issue 6's acceptance on a 3 x 3 weave of the paper's fabric (the full 6 x 6 case takes a
  // minute or more on the explicit path; its figures are in docs/verification.md): k = 1 to
  // 1.5 % in 1 s, implicit (Newmark, the paper's) and explicit with the deck's default mass
  // scaling (to loading_time / 50 000). Past the toe (strain >= 0.3 %, a fifth of the final
  // strain, where the crimp is gone and the force rises steeply) the explicit force is within
  // 5 % of the implicit one at equal strain in both directions, and the kinetic energy stays
  // below 5 % of the stored (strain + contact) energy.
  auto weave = [](StepType type) {
    textile::WeaveParameters p = textile::paper_fabric();
    p.n_warp = p.n_weft = 3;
    p.length_warp = 6 * p.spacing_weft; // 1.5 spacings past the outer crossings, as the paper's
    p.length_weft = 6 * p.spacing_warp;
    textile::Fabric f = textile::build_weave(p);
    textile::BiaxialParameters b;
    b.type = type;
    textile::add_biaxial_test(f, b);
    return std::move(f.model);
  };
  auto run = [](const Model& m, double& seconds, long& increments, ExplicitStatus* status) {
    const auto start = std::chrono::steady_clock::now();
    Simulation sim(m);
    CurveRecorder rec(m);
    sim.run(&rec);
    seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    increments = sim.state().increment;
    if (status)
      *status = sim.explicit_status();
    EXPECT_GT(sim.contact()->active(), 0) << "no contact: the test would not exercise it";
    return rec.c;
  };
  const Model implicit_model = weave(StepType::Dynamic);
  const Model explicit_model = weave(StepType::Explicit);
  ASSERT_EQ(explicit_model.steps.back().type, StepType::Explicit);
  double t_implicit = 0, t_explicit = 0;
  long n_implicit = 0, n_explicit = 0;
  ExplicitStatus scaling;
  const Curves imp = run(implicit_model, t_implicit, n_implicit, nullptr);
  const Curves exp = run(explicit_model, t_explicit, n_explicit, &scaling);
  ASSERT_NEAR(imp.strain_warp.back(), 0.015, 1e-9);
  ASSERT_NEAR(exp.strain_warp.back(), 0.015, 1e-9);

  constexpr double kToe = 0.003;
  double worst = 0, worst_at = 0, worst_ratio = 0;
  int compared = 0;
  for (std::size_t i = 0; i < exp.strain_warp.size(); ++i) {
    for (int dir = 0; dir < 2; ++dir) {
      const double s = dir == 0 ? exp.strain_warp[i] : exp.strain_weft[i];
      if (s < kToe)
        continue;
      const double f = dir == 0 ? exp.force_warp[i] : exp.force_weft[i];
      const double f0 = dir == 0 ? at(imp.strain_warp, imp.force_warp, s)
                                 : at(imp.strain_weft, imp.force_weft, s);
      const double d = std::abs(f - f0) / std::abs(f0);
      ++compared;
      if (d > worst) {
        worst = d;
        worst_at = s;
      }
    }
    if (exp.strain_warp[i] >= kToe)
      worst_ratio = std::max(worst_ratio, exp.energy_ratio[i]);
  }
  std::printf("3 x 3 weave, k = 1: implicit %ld increments in %.2f s, explicit %ld increments in "
              "%.2f s (dt %.3g s, mass scaling added %.3g %% of the mass); force at 1.5 %%: "
              "implicit %.2f N, explicit %.2f N; past 0.3 %% strain the largest difference is "
              "%.2f %% (at %.3f %% strain, %d points) and kinetic/internal energy at most %.3g\n",
              n_implicit, t_implicit, n_explicit, t_explicit, scaling.dt,
              scaling.added_mass_percent, imp.force_warp.back(), exp.force_warp.back(), 100 * worst,
              100 * worst_at, compared, worst_ratio);
  EXPECT_GT(compared, 100);
  EXPECT_GT(scaling.added_mass_percent, 0.0);
  EXPECT_LT(worst, 0.05);
  EXPECT_LT(worst_ratio, 0.05);
}

TEST(Biaxial, ExplicitPathGivesBitwiseIdenticalResultsOnOneAndTwoThreads) {
  // A 3 x 3 weave pulled to 1.5 % in 1500 mass-scaled increments (a timing-free stand-in for the
  // full test: fast, but every crossing closes after the first tenth).
  textile::WeaveParameters p = textile::paper_fabric();
  p.n_warp = p.n_weft = 3;
  p.length_warp = 6 * p.spacing_weft;
  p.length_weft = 6 * p.spacing_warp;
  textile::Fabric f = textile::build_weave(p);
  textile::BiaxialParameters b;
  b.type = StepType::Explicit;
  b.explicit_.mass_scaling_dt = 2e-5;
  b.explicit_.output_every = 50;
  b.loading_time = 1500 * 2e-5;
  textile::add_biaxial_test(f, b);
  const Model& m = f.model;
  struct Snapshot : SimulationObserver {
    std::vector<Eigen::Matrix3Xd> x;
    std::vector<Eigen::Matrix<double, 6, Eigen::Dynamic>> r;
    std::vector<double> f, energy;
    void on_increment(const Simulation& s, const IncrementReport&) override {
      x.push_back(s.state().x_n);
      r.push_back(s.reactions());
      f.push_back(s.contact()->total_force());
      energy.push_back(s.energy_balance().error);
    }
  };
  Snapshot one, two;
  for (int threads : {1, 2}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    Simulation sim(m);
    sim.run(threads == 1 ? &one : &two);
  }
  ASSERT_EQ(one.x.size(), two.x.size());
  ASSERT_EQ(one.x.size(), 30u);
  ASSERT_GT(one.f.back(), 0.0) << "no contact: the test would not exercise the contact stage";
  for (std::size_t k = 0; k < one.x.size(); ++k) {
    EXPECT_TRUE((one.x[k].array() == two.x[k].array()).all()) << "positions, output " << k;
    EXPECT_TRUE((one.r[k].array() == two.r[k].array()).all()) << "reactions, output " << k;
    EXPECT_EQ(one.f[k], two.f[k]) << "contact force, output " << k;
    EXPECT_EQ(one.energy[k], two.energy[k]) << "energy balance, output " << k;
  }
}

} // namespace
} // namespace yarnsim
