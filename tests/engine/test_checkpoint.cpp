// Restart from a checkpoint (engine/solver/checkpoint.*, engine/output/checkpoint_file.*): a
// simulation rebuilt from the checkpoint of any increment goes on bit for bit as the run straight
// through, on the implicit contact path (spline and surface contact) and inside an explicit step,
// whether the checkpoint is kept in memory or read back from checkpoint.h5. And the serial writer
// that overlaps output with the next increment (engine/output/serial_writer.*).

#include "engine/input/read_deck.hpp"
#include "engine/output/checkpoint_file.hpp"
#include "engine/output/serial_writer.hpp"
#include "engine/solver/checkpoint.hpp"
#include "engine/solver/simulation.hpp"
#include "engine/textile/biaxial.hpp"
#include "engine/textile/weave.hpp"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <unistd.h>
#include <vector>

namespace yarnsim {
namespace {

namespace fs = std::filesystem;
const fs::path kExamples = fs::path(YARNSIM_SOURCE_DIR) / "examples";

std::string read_text(const fs::path& file) {
  std::ifstream in(file);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// An example deck with `key = value` lines replaced (the key at the start of a line).
Model example(const std::string& name,
              const std::vector<std::pair<std::string, std::string>>& set) {
  std::string text = read_text(kExamples / name);
  for (const auto& [key, value] : set)
    text =
        std::regex_replace(text, std::regex("\n" + key + " = [^\n]*"), "\n" + key + " = " + value);
  return read_deck_string(text, name);
}

/// What an increment leaves that the output shows, and the checkpoint taken after it.
struct Increment {
  double time = 0, dt = 0;
  int iterations = 0;
  /// The run's counts so far (the checkpoint carries them): Newton iterations, and damped points
  /// judged by one solve.
  int total_iterations = 0, simplified_trials = 0;
  Eigen::Matrix3Xd x, rotation, v;
  Eigen::Matrix<double, 6, Eigen::Dynamic> reactions;
  double kinetic = 0, contact_energy = 0, external_work = 0, balance_error = 0;
  int active = 0, candidates = 0;
  double max_penetration = 0, max_force = 0;
  std::size_t points = 0; ///< active contact points
};

struct Recorder : SimulationObserver {
  std::vector<Increment> increments;
  std::vector<SimulationCheckpoint> checkpoints;
  void on_increment(const Simulation& s, const IncrementReport& r) override {
    Increment i;
    i.time = r.time;
    i.dt = r.dt;
    i.iterations = r.iterations;
    i.total_iterations = s.total_iterations();
    i.simplified_trials = s.simplified_trials();
    i.x = s.state().x_n;
    i.rotation = s.state().rotation_n;
    i.v = s.state().v_n;
    i.reactions = s.reactions();
    const EnergyBalance e = s.energy_balance();
    i.kinetic = e.kinetic;
    i.contact_energy = e.contact;
    i.external_work = e.external_work;
    i.balance_error = e.error;
    if (s.contact()) {
      const ContactSummary c = s.contact()->summary();
      i.active = c.active;
      i.candidates = c.candidates;
      i.max_penetration = c.max_penetration;
      i.max_force = c.max_force;
      i.points = s.contact()->points().size();
    }
    increments.push_back(std::move(i));
    checkpoints.push_back(s.checkpoint());
  }
};

template <class A, class B>
bool same_bits(const A& a, const B& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() && (a.array() == b.array()).all();
}

/// The increments after checkpoint k of the straight run equal those of the restarted run.
void expect_same_continuation(const Recorder& straight, std::size_t k, const Recorder& restarted) {
  ASSERT_EQ(restarted.increments.size(), straight.increments.size() - k - 1);
  for (std::size_t j = 0; j < restarted.increments.size(); ++j) {
    SCOPED_TRACE("increment " + std::to_string(k + 2 + j));
    const Increment& a = straight.increments[k + 1 + j];
    const Increment& b = restarted.increments[j];
    EXPECT_EQ(a.time, b.time);
    EXPECT_EQ(a.dt, b.dt);
    EXPECT_EQ(a.iterations, b.iterations);
    EXPECT_EQ(a.total_iterations, b.total_iterations);
    EXPECT_EQ(a.simplified_trials, b.simplified_trials);
    EXPECT_TRUE(same_bits(a.x, b.x));
    EXPECT_TRUE(same_bits(a.rotation, b.rotation));
    EXPECT_TRUE(same_bits(a.v, b.v));
    EXPECT_TRUE(same_bits(a.reactions, b.reactions));
    EXPECT_EQ(a.kinetic, b.kinetic);
    EXPECT_EQ(a.contact_energy, b.contact_energy);
    EXPECT_EQ(a.external_work, b.external_work);
    EXPECT_EQ(a.balance_error, b.balance_error);
    EXPECT_EQ(a.active, b.active);
    EXPECT_EQ(a.candidates, b.candidates);
    EXPECT_EQ(a.max_penetration, b.max_penetration);
    EXPECT_EQ(a.max_force, b.max_force);
    EXPECT_EQ(a.points, b.points);
  }
}

/// The surface contact state after each increment of the restarted run equals the straight run's:
/// the same searches (candidate versions, boxes), warm starts, candidates and pattern growth.
/// A checkpoint whose contact state (`contact`: the spline or the surface contact's) has pairs
/// that do not fit its saved search is refused with an error, not read out of bounds: a pair
/// left out, a segment or definition the model does not have, pairs out of order.
template <class Snapshot>
void expect_spoiled_pairs_refused(const Model& m, const SimulationCheckpoint& checkpoint,
                                  std::optional<Snapshot> SimulationCheckpoint::*contact) {
  ASSERT_TRUE(checkpoint.*contact);
  ASSERT_GE((checkpoint.*contact)->pairs.size(), 2u);
  const auto refused = [&](auto&& spoil) {
    SimulationCheckpoint bad = checkpoint;
    spoil((bad.*contact)->pairs);
    EXPECT_THROW(Simulation(m, {}, bad), std::invalid_argument);
  };
  refused([](auto& pairs) { pairs.pop_back(); });
  refused([](auto& pairs) { pairs.back().key[2] = 1 << 30; });
  refused([](auto& pairs) { pairs.front().key[0] = -1; });
  refused([](auto& pairs) { std::swap(pairs[0], pairs[1]); });
}

void expect_same_surface_checkpoints(const Recorder& straight, std::size_t k,
                                     const Recorder& restarted) {
  ASSERT_EQ(restarted.checkpoints.size(), straight.checkpoints.size() - k - 1);
  for (std::size_t j = 0; j < restarted.checkpoints.size(); ++j) {
    SCOPED_TRACE("checkpoint after increment " + std::to_string(k + 2 + j));
    const SimulationCheckpoint& a = straight.checkpoints[k + 1 + j];
    const SimulationCheckpoint& b = restarted.checkpoints[j];
    EXPECT_EQ(a.pattern_groups, b.pattern_groups);
    EXPECT_EQ(a.ordering.inverse_permutation, b.ordering.inverse_permutation);
    EXPECT_EQ(a.ordering.fill, b.ordering.fill);
    ASSERT_TRUE(a.surface_contact && b.surface_contact);
    const SurfaceContactSet::Snapshot& p = *a.surface_contact;
    const SurfaceContactSet::Snapshot& q = *b.surface_contact;
    EXPECT_EQ(p.candidates_version, q.candidates_version);
    ASSERT_EQ(p.search_boxes.size(), q.search_boxes.size());
    for (std::size_t d = 0; d < p.search_boxes.size(); ++d) {
      ASSERT_EQ(p.search_boxes[d].size(), q.search_boxes[d].size());
      for (std::size_t i = 0; i < p.search_boxes[d].size(); ++i)
        EXPECT_TRUE(p.search_boxes[d][i].min() == q.search_boxes[d][i].min() &&
                    p.search_boxes[d][i].max() == q.search_boxes[d][i].max());
    }
    ASSERT_EQ(p.committed.size(), q.committed.size());
    for (std::size_t i = 0; i < p.committed.size(); ++i) {
      EXPECT_EQ(p.committed[i].key, q.committed[i].key);
      EXPECT_EQ(p.committed[i].zeta_A, q.committed[i].zeta_A);
      EXPECT_EQ(p.committed[i].theta_A, q.committed[i].theta_A);
      EXPECT_EQ(p.committed[i].zeta_B, q.committed[i].zeta_B);
      EXPECT_EQ(p.committed[i].theta_B, q.committed[i].theta_B);
      EXPECT_EQ(p.committed[i].active, q.committed[i].active);
      // Friction histories: the pointwise anchor and the twist anchor (torsional friction).
      EXPECT_EQ(p.committed[i].anchor_zeta_A, q.committed[i].anchor_zeta_A);
      EXPECT_EQ(p.committed[i].anchor_theta_B, q.committed[i].anchor_theta_B);
      EXPECT_EQ(p.committed[i].slip, q.committed[i].slip);
      EXPECT_EQ(p.committed[i].friction, q.committed[i].friction);
      EXPECT_EQ(p.committed[i].twist_anchor, q.committed[i].twist_anchor);
      EXPECT_EQ(p.committed[i].twist_slip, q.committed[i].twist_slip);
      EXPECT_EQ(p.committed[i].twist, q.committed[i].twist);
    }
    ASSERT_EQ(p.pairs.size(), q.pairs.size());
    for (std::size_t i = 0; i < p.pairs.size(); ++i) {
      EXPECT_EQ(p.pairs[i].key, q.pairs[i].key);
      EXPECT_EQ(p.pairs[i].force, q.pairs[i].force);
      EXPECT_EQ(p.pairs[i].factor, q.pairs[i].factor);
    }
    EXPECT_EQ(p.summary.potential, q.summary.potential);
    EXPECT_EQ(p.summary.min_gap, q.summary.min_gap);
    EXPECT_EQ(p.summary.dissipation, q.summary.dissipation);
    EXPECT_EQ(p.summary.torque, q.summary.torque);
    EXPECT_EQ(p.dissipated, q.dissipated);
  }
}

class Checkpoint : public ::testing::Test {
protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir = fs::temp_directory_path() /
          (std::string("yarnsim_checkpoint_") + info->name() + "_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }
  fs::path dir;
};

TEST_F(Checkpoint, ImplicitContactRunGoesOnBitForBitFromEveryIncrement) {
  // Crossing beams in 20 increments: the pattern grows with the contact, warm starts carry over.
  const Model m = example("crossing-beams.toml", {{"dt", "0.05"}, {"dt_max", "0.05"}});
  Recorder straight;
  Simulation(m).run(&straight);
  ASSERT_EQ(straight.increments.size(), 20u);
  ASSERT_GT(straight.increments.back().active, 0);
  for (std::size_t k : {0u, 6u, 13u, 18u}) {
    Recorder restarted;
    Simulation(m, {}, straight.checkpoints[k]).run(&restarted);
    expect_same_continuation(straight, k, restarted);
  }
}

TEST_F(Checkpoint, DynamicFabricThroughTheFileGoesOnBitForBit) {
  // A 3 x 3 plain weave pulled dynamically (Newmark, contact, growing steps).
  const Model m = example("biaxial-k1.toml", {{"n_warp", "3"},
                                              {"n_weft", "3"},
                                              {"length_warp", "18.18182e-3"},
                                              {"length_weft", "18.18182e-3"},
                                              {"elements_per_spacing", "2"},
                                              {"max_strain", "0.003"},
                                              {"loading_time", "0.1"}});
  Recorder straight;
  Simulation(m).run(&straight);
  ASSERT_GE(straight.increments.size(), 6u);
  const std::size_t k = straight.increments.size() / 2;
  output::write_checkpoint(dir, straight.checkpoints[k], {3, {{"tip.csv", 7}}, "0123abcd"});
  EXPECT_FALSE(fs::exists(dir / "checkpoint.h5.tmp"));
  const output::StoredCheckpoint stored = output::read_checkpoint(dir);
  EXPECT_EQ(stored.outputs.results_steps, 3);
  EXPECT_EQ(stored.outputs.csv_rows.at("tip.csv"), 7);
  EXPECT_EQ(stored.outputs.deck_hash, "0123abcd");
  Recorder restarted;
  Simulation(m, {}, stored.simulation).run(&restarted);
  expect_same_continuation(straight, k, restarted);
  // A saved contact state that does not fit the saved search is refused.
  expect_spoiled_pairs_refused(m, stored.simulation, &SimulationCheckpoint::contact);
}

TEST_F(Checkpoint, PictureFrameWithFrictionGoesOnBitForBit) {
  // The paper's fabric in the picture frame (examples/picture-frame.toml) with Coulomb and
  // torsional friction (mu = 0.2): the pretension step, then the start of the shear, where the
  // crossings twist and stick or slip. Restarted through the file from the middle of the shear;
  // with the constant tangential penalty, then with an elastic slip (the stick stiffness from the
  // normal force, not a history: nothing more to carry over).
  for (const std::string stick : {"", "\nelastic_slip = 5e-6"}) {
    SCOPED_TRACE(stick.empty() ? "tangential penalty" : "elastic slip");
    Model m = example("picture-frame.toml",
                      {{"penalty", "1.5e6\nfriction = 0.2\ntorsional_friction = true" + stick},
                       {"max_angle", "65.0"}});
    ASSERT_EQ(m.steps.size(), 2u);
    ASSERT_EQ(m.spline_contacts[0].friction.elastic_slip, stick.empty() ? 0.0 : 5e-6);
    m.steps.back().end_time = m.picture_frame->shear_start + 0.06;
    Recorder straight;
    Simulation(m).run(&straight);
    std::size_t first_shear = 0;
    while (straight.increments[first_shear].time <= m.picture_frame->shear_start)
      ++first_shear;
    ASSERT_GE(straight.increments.size(), first_shear + 4);
    const std::size_t k = (first_shear + straight.increments.size()) / 2;
    output::write_checkpoint(dir, straight.checkpoints[k],
                             {static_cast<int>(k), {{"curves.csv", 7}}, "frame"});
    const output::StoredCheckpoint stored = output::read_checkpoint(dir);
    Recorder restarted;
    Simulation(m, {}, stored.simulation).run(&restarted);
    expect_same_continuation(straight, k, restarted);
    // The crossings twisted against friction: torsional friction was at work.
    ASSERT_TRUE(straight.increments.back().points > 0);
  }
}

TEST_F(Checkpoint, BiasExtensionWithTheSecantPredictorGoesOnBitForBit) {
  // examples/bias-extension-twintex-friction.toml cut to a 20 x 50 mm specimen: its steps take
  // the secant predictor (SolutionStep::secant_predictor), which carries the last increment's
  // motion into the next. Restarted through the file from the middle of the pull, and from the
  // first increment of the pull (whose last increment is the compaction's, of another step).
  Model m = example("bias-extension-twintex-friction.toml",
                    {{"width", "20e-3"}, {"height", "50e-3"}, {"max_angle", "20.0"}});
  ASSERT_EQ(m.steps.size(), 2u);
  ASSERT_TRUE(m.steps[0].secant_predictor && m.steps[1].secant_predictor);
  const double pull_start = m.steps[0].end_time;
  m.steps.back().end_time = pull_start + 0.12;
  Recorder straight;
  Simulation(m).run(&straight);
  std::size_t first_pull = 0;
  while (straight.increments[first_pull].time <= pull_start + 1e-12)
    ++first_pull;
  ASSERT_GE(straight.increments.size(), first_pull + 6);
  ASSERT_EQ(straight.checkpoints[first_pull].secant_step, 1);
  for (const std::size_t k :
       {first_pull - 1, first_pull, (first_pull + straight.increments.size()) / 2}) {
    SCOPED_TRACE("from increment " + std::to_string(k + 1));
    output::write_checkpoint(dir, straight.checkpoints[k],
                             {static_cast<int>(k), {{"curves.csv", 7}}, "bias"});
    const output::StoredCheckpoint stored = output::read_checkpoint(dir);
    EXPECT_TRUE(same_bits(stored.simulation.secant_motion, straight.checkpoints[k].secant_motion));
    EXPECT_TRUE(
        same_bits(stored.simulation.secant_rotation, straight.checkpoints[k].secant_rotation));
    Recorder restarted;
    Simulation(m, {}, stored.simulation).run(&restarted);
    expect_same_continuation(straight, k, restarted);
  }
}

TEST_F(Checkpoint, FrictionalTensionTestWithTheChosenPredictorGoesOnBitForBit) {
  // examples/biaxial-k1-friction.toml made 4 x 4 with an elastic slip, pulled to 0.9 %: from a
  // step's second increment on its predictor is the ends' or the last increment's motion held to
  // its reach, whichever leaves the smaller residual (Simulation::choose_predictor). The motion
  // and the reach are in the checkpoint. Restarted through the file where the reach holds the
  // secant back (in the toe, where crossings close: the secant's residual depends on the reach)
  // and from an increment whose next takes the secant.
  struct Choices : Recorder {
    std::vector<double> secant_residual, ends_residual;
    void on_increment(const Simulation& s, const IncrementReport& r) override {
      Recorder::on_increment(s, r);
      secant_residual.push_back(r.secant_residual);
      ends_residual.push_back(r.ends_residual);
    }
  };
  const Model m = example("biaxial-k1-friction.toml", {{"n_warp", "4"},
                                                       {"n_weft", "4"},
                                                       {"length_warp", "31.81815e-3"},
                                                       {"length_weft", "31.81815e-3"},
                                                       {"friction", "0.2\nelastic_slip = 5e-6"},
                                                       {"max_strain", "0.009"},
                                                       {"loading_time", "0.6"}});
  ASSERT_EQ(m.spline_contacts[0].friction.elastic_slip, 5e-6);
  Choices straight;
  Simulation(m).run(&straight);
  const std::size_t n = straight.increments.size();
  std::size_t held = n, to_secant = n;
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const double ratio = straight.increments[k + 1].dt / straight.increments[k].dt;
    if (held == n && straight.checkpoints[k].secant_reach < ratio)
      held = k;
    if (to_secant == n && straight.secant_residual[k + 1] < straight.ends_residual[k + 1])
      to_secant = k;
  }
  ASSERT_LT(held, n) << "the reach never held the secant back";
  ASSERT_LT(to_secant, n) << "the secant was never the predictor";
  for (const std::size_t k : {held, to_secant}) {
    SCOPED_TRACE("from increment " + std::to_string(k + 1));
    output::write_checkpoint(dir, straight.checkpoints[k],
                             {static_cast<int>(k), {{"curves.csv", 7}}, "biaxial"});
    const output::StoredCheckpoint stored = output::read_checkpoint(dir);
    EXPECT_EQ(stored.simulation.secant_reach, straight.checkpoints[k].secant_reach);
    EXPECT_TRUE(same_bits(stored.simulation.secant_motion, straight.checkpoints[k].secant_motion));
    EXPECT_TRUE(
        same_bits(stored.simulation.secant_rotation, straight.checkpoints[k].secant_rotation));
    Choices restarted;
    Simulation(m, {}, stored.simulation).run(&restarted);
    expect_same_continuation(straight, k, restarted);
    ASSERT_FALSE(restarted.secant_residual.empty());
    EXPECT_EQ(restarted.secant_residual[0], straight.secant_residual[k + 1]);
    EXPECT_EQ(restarted.ends_residual[0], straight.ends_residual[k + 1]);
  }
}

TEST_F(Checkpoint, SurfaceContactFabricThroughTheFileGoesOnBitForBit) {
  // A 3 x 3 plain weave with surface contact pulled dynamically (examples/biaxial-surface-k1.toml
  // made small). A broad-phase margin of 20 um, against end displacements of 27 um, makes the
  // yarns' motion search again during the run, so that the checkpoint's search boxes, warm starts
  // and candidates all carry over.
  Model m = example("biaxial-surface-k1.toml", {{"n_warp", "3"},
                                                {"n_weft", "3"},
                                                {"length_warp", "18.18182e-3"},
                                                {"length_weft", "18.18182e-3"},
                                                {"elements_per_spacing", "2"},
                                                {"max_strain", "0.003"},
                                                {"loading_time", "0.1"}});
  ASSERT_EQ(m.surface_contacts.size(), 1u);
  m.surface_contacts[0].margin = 20e-6;
  Recorder straight;
  Simulation(m).run(&straight);
  ASSERT_GE(straight.increments.size(), 6u);
  ASSERT_GT(straight.increments.back().active, 0);
  for (const SimulationCheckpoint& c : straight.checkpoints) {
    ASSERT_TRUE(c.surface_contact.has_value());
    EXPECT_FALSE(c.contact.has_value());
  }
  // Through checkpoint.h5, from an increment after a search other than the first, with contact.
  std::size_t k = straight.increments.size() / 2;
  while (k + 2 < straight.increments.size() &&
         (straight.checkpoints[k].surface_contact->candidates_version < 2 ||
          straight.increments[k].active == 0))
    ++k;
  ASSERT_GE(straight.checkpoints[k].surface_contact->candidates_version, 2);
  ASSERT_GT(straight.increments[k].active, 0);
  ASSERT_FALSE(straight.checkpoints[k].surface_contact->committed.empty());
  output::write_checkpoint(dir, straight.checkpoints[k], {3, {}, "x"});
  const output::StoredCheckpoint stored = output::read_checkpoint(dir);
  ASSERT_TRUE(stored.simulation.surface_contact.has_value());
  // The LDL^T's kept ordering (ldlt-gmres with surface contact) goes through the file whole.
  ASSERT_FALSE(straight.checkpoints[k].ordering.inverse_permutation.empty());
  EXPECT_EQ(stored.simulation.ordering.inverse_permutation,
            straight.checkpoints[k].ordering.inverse_permutation);
  EXPECT_EQ(stored.simulation.ordering.fill, straight.checkpoints[k].ordering.fill);
  {
    // Before its first increment the restored set shows the last evaluation's figures, which an
    // explicit step's stable-step estimate reads.
    const Simulation resumed(m, {}, stored.simulation);
    const ContactSummary s = resumed.contact()->summary();
    EXPECT_EQ(s.candidates, straight.increments[k].candidates);
    EXPECT_EQ(s.active, straight.increments[k].active);
    EXPECT_EQ(s.max_penetration, straight.increments[k].max_penetration);
    EXPECT_EQ(s.max_force, straight.increments[k].max_force);
    EXPECT_EQ(resumed.contact()->points().size(), straight.increments[k].points);
  }
  Recorder restarted;
  Simulation(m, {}, stored.simulation).run(&restarted);
  expect_same_continuation(straight, k, restarted);
  expect_same_surface_checkpoints(straight, k, restarted);
  // In memory, from the first increment.
  Recorder early;
  Simulation(m, {}, straight.checkpoints[0]).run(&early);
  expect_same_continuation(straight, 0, early);
  expect_same_surface_checkpoints(straight, 0, early);
  // A checkpoint without the surface contact's state does not fit the model, nor one whose
  // pairs do not fit the saved search (a pair left out, a segment the model does not have,
  // pairs out of order).
  SimulationCheckpoint stripped = straight.checkpoints[k];
  stripped.surface_contact.reset();
  EXPECT_THROW(Simulation(m, {}, stripped), std::invalid_argument);
  expect_spoiled_pairs_refused(m, straight.checkpoints[k], &SimulationCheckpoint::surface_contact);
}

TEST_F(Checkpoint,
       SurfaceContactFabricWithTorsionalFrictionIsBitwiseTheSameOnTwoThreadsAndAfterARestart) {
  // The 3 x 3 weave of the test above from examples/biaxial-surface-k1-friction.toml (mu = 0.2),
  // with torsional friction at the crossings (contact/surface_torsional_friction.hpp): on one and
  // two threads, and restarted through checkpoint.h5 from an increment with twist anchors.
  Model m =
      example("biaxial-surface-k1-friction.toml", {{"n_warp", "3"},
                                                   {"n_weft", "3"},
                                                   {"length_warp", "18.18182e-3"},
                                                   {"length_weft", "18.18182e-3"},
                                                   {"elements_per_spacing", "2"},
                                                   {"friction", "0.2\ntorsional_friction = true"},
                                                   {"max_strain", "0.003"},
                                                   {"loading_time", "0.1"}});
  ASSERT_EQ(m.surface_contacts.size(), 1u);
  ASSERT_TRUE(m.surface_contacts[0].friction.torsional);
  auto run = [&](int threads) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    Recorder r;
    Simulation(m).run(&r);
    return r;
  };
  const Recorder one = run(1);
  const Recorder two = run(2);
  ASSERT_GE(one.increments.size(), 6u);
  ASSERT_EQ(one.increments.size(), two.increments.size());
  // The whole run on two threads: the continuation of one's from before its first increment.
  Recorder two_shifted;
  two_shifted.increments.assign(two.increments.begin() + 1, two.increments.end());
  two_shifted.checkpoints.assign(two.checkpoints.begin() + 1, two.checkpoints.end());
  EXPECT_TRUE(same_bits(one.increments[0].x, two.increments[0].x));
  expect_same_continuation(one, 0, two_shifted);
  expect_same_surface_checkpoints(one, 0, two_shifted);
  // Twist anchors committed (stick or slip) in the checkpoint the restart starts from.
  std::size_t k = one.increments.size() / 2;
  const auto twisted = [&](std::size_t i) {
    int n = 0;
    for (const auto& w : one.checkpoints[i].surface_contact->committed)
      n += w.twist != 0;
    return n;
  };
  while (k + 2 < one.increments.size() && twisted(k) == 0)
    ++k;
  ASSERT_GT(twisted(k), 0);
  output::write_checkpoint(dir, one.checkpoints[k], {3, {}, "torsion"});
  const output::StoredCheckpoint stored = output::read_checkpoint(dir);
  Recorder restarted;
  Simulation(m, {}, stored.simulation).run(&restarted);
  expect_same_continuation(one, k, restarted);
  expect_same_surface_checkpoints(one, k, restarted);
}

TEST_F(Checkpoint, ExplicitSurfaceContactStepGoesOnBitForBit) {
  // A 3 x 3 weave with surface contact pulled in 1000 mass-scaled explicit increments, output
  // every 50; the stable step is estimated every 100 from the last contact evaluation, so a
  // restart after an even output increment starts with an estimate from the restored figures.
  textile::WeaveParameters p = textile::paper_fabric();
  p.n_warp = p.n_weft = 3;
  p.length_warp = 4 * p.spacing_weft;
  p.length_weft = 4 * p.spacing_warp;
  p.elements_per_spacing = 2;
  p.contact = textile::ContactFormulation::Surface;
  p.contact_law = {3.5e5, 1.0, 0.0};
  textile::Fabric f = textile::build_weave(p);
  textile::BiaxialParameters b;
  b.type = StepType::Explicit;
  b.explicit_.mass_scaling_dt = 5e-7;
  b.explicit_.output_every = 50;
  b.loading_time = 1000 * 5e-7;
  textile::add_biaxial_test(f, b);
  const Model& m = f.model;
  Recorder straight;
  Simulation(m).run(&straight);
  ASSERT_EQ(straight.increments.size(), 20u);
  ASSERT_GT(straight.increments.back().active, 0);
  std::size_t k = 9; // after increment 500
  while (k + 2 < straight.increments.size() && straight.increments[k].active == 0)
    k += 2;
  ASSERT_GT(straight.increments[k].active, 0);
  ASSERT_TRUE(straight.checkpoints[k].explicit_progress.has_value());
  ASSERT_TRUE(straight.checkpoints[k].surface_contact.has_value());
  output::write_checkpoint(dir, straight.checkpoints[k], {static_cast<int>(k + 1), {}, "x"});
  const output::StoredCheckpoint stored = output::read_checkpoint(dir);
  Recorder restarted;
  Simulation(m, {}, stored.simulation).run(&restarted);
  expect_same_continuation(straight, k, restarted);
  expect_same_surface_checkpoints(straight, k, restarted);
}

TEST_F(Checkpoint, ExplicitFabricWithFrictionGoesOnBitForBit) {
  // A 3 x 3 weave of the paper's fabric pulled on the explicit path with Coulomb and torsional
  // friction (mu = 0.2): 5 000 mass-scaled increments, output every 250; restarted through the
  // file from the middle, where the crossings stick and slip. The smooth ramp accelerates the
  // pulled ends there, so the prescribed motions' inertia is at work across the restart.
  const Model m = example("biaxial-k1-explicit.toml",
                          {{"n_warp", "3"},
                           {"n_weft", "3"},
                           {"length_warp", "18.18182e-3"},
                           {"length_weft", "18.18182e-3"},
                           {"penalty", "1.5e6\nfriction = 0.2\ntorsional_friction = true"},
                           {"loading_time", "0.1"},
                           {"ramp", "\"smooth\""}});
  Recorder straight;
  Simulation run(m);
  run.run(&straight);
  ASSERT_EQ(straight.increments.size(), 20u);
  const ContactSummary friction = run.contact()->summary();
  EXPECT_GT(friction.dissipation, 0.0);
  EXPECT_GT(friction.stick + friction.slip, 0);
  EXPECT_GT(friction.twist_stick + friction.twist_slip, 0);
  const std::size_t k = 11;
  ASSERT_GT(straight.increments[k].points, 0);
  output::write_checkpoint(dir, straight.checkpoints[k], {static_cast<int>(k + 1), {}, "x"});
  const output::StoredCheckpoint stored = output::read_checkpoint(dir);
  ASSERT_TRUE(stored.simulation.explicit_progress.has_value());
  Recorder restarted;
  Simulation(m, {}, stored.simulation).run(&restarted);
  expect_same_continuation(straight, k, restarted);
}

TEST(ExplicitFriction, ForcesConjugateToTheGapCloseTheBalanceWhereTheCrossingsRoll) {
  // A 4 x 4 weave of the paper's fabric pulled on the explicit path in 0.3 s with spline friction
  // (mu = 0.2, torsional friction on): as the crimp changes the crossings roll. With the point
  // forces the anchors counted slip the forces did no work on, the balance error followed the
  // dissipation and the run stopped at t = 0.048 s (docs/formulation.md, "Friction on the
  // explicit path"). The explicit path's friction forces are conjugate to their gaps
  // (contact::FrictionForce): the run goes through, and the balance closes to a small fraction of
  // what friction dissipates.
  const Model m = example("biaxial-k1-explicit.toml",
                          {{"n_warp", "4"},
                           {"n_weft", "4"},
                           {"length_warp", "31.81815e-3"},
                           {"length_weft", "31.81815e-3"},
                           {"penalty", "1.5e6\nfriction = 0.2\ntorsional_friction = true"},
                           {"loading_time", "0.3"}});
  Recorder rec;
  Simulation run(m);
  run.run(&rec);
  ASSERT_FALSE(rec.increments.empty());
  EXPECT_NEAR(rec.increments.back().time, 0.3, 1e-9);
  const ContactSummary friction = run.contact()->summary();
  double worst = 0.0;
  for (const auto& i : rec.increments)
    worst = std::max(worst, std::abs(i.balance_error));
  std::printf("explicit 4 x 4 weave with friction: dissipated %.4e J, largest balance error "
              "%.4e J\n",
              friction.dissipation, worst);
  EXPECT_GT(friction.dissipation, 0.0);
  EXPECT_LT(worst, 0.01 * friction.dissipation);
}

TEST_F(Checkpoint, ExplicitStepGoesOnBitForBitFromTheMiddle) {
  const Model m = example("flying-beam-explicit.toml", {{"end_time", "2.0"}});
  Recorder straight;
  Simulation(m).run(&straight);
  ASSERT_EQ(straight.increments.size(), 20u); // 1000 increments, output every 50
  const std::size_t k = 8;
  ASSERT_TRUE(straight.checkpoints[k].explicit_progress.has_value());
  output::write_checkpoint(dir, straight.checkpoints[k], {9, {}, "x"});
  const output::StoredCheckpoint stored = output::read_checkpoint(dir);
  ASSERT_TRUE(stored.simulation.explicit_progress.has_value());
  Recorder restarted;
  Simulation(m, {}, stored.simulation).run(&restarted);
  expect_same_continuation(straight, k, restarted);
}

TEST_F(Checkpoint, ACheckpointOfAnotherModelIsRefused) {
  const Model crossing = example("crossing-beams.toml", {});
  Recorder r;
  Simulation(crossing).run(&r);
  const Model flying = example("flying-beam-explicit.toml", {{"end_time", "0.2"}});
  EXPECT_THROW(Simulation(flying, {}, r.checkpoints.back()), std::invalid_argument);
  EXPECT_THROW(output::read_checkpoint(dir), output::RestartError); // no checkpoint.h5
  std::ofstream(dir / "checkpoint.h5") << "not HDF5";
  EXPECT_ANY_THROW(output::read_checkpoint(dir));
}

TEST_F(Checkpoint, DeckFingerprintFollowsTheTextAndTheGeometry) {
  const Model a = example("crossing-beams.toml", {});
  Model b = a;
  b.nodes[3].x() += 1e-12;
  const std::string text = read_text(kExamples / "crossing-beams.toml");
  EXPECT_EQ(output::deck_fingerprint(text, a), output::deck_fingerprint(text, a));
  EXPECT_NE(output::deck_fingerprint(text, a), output::deck_fingerprint(text + " ", a));
  EXPECT_NE(output::deck_fingerprint(text, a), output::deck_fingerprint(text, b));
  EXPECT_EQ(output::deck_fingerprint(text, a).size(), 16u);
}

// ---- the serial writer ----

TEST(SerialWriter, RunsTasksInTheOrderPostedOffTheCallersThread) {
  std::vector<int> order;
  std::thread::id caller = std::this_thread::get_id(), ran_on;
  {
    output::SerialWriter writer(2);
    for (int i = 0; i < 50; ++i)
      writer.post([&order, &ran_on, i] {
        order.push_back(i);
        ran_on = std::this_thread::get_id();
      });
    writer.drain();
    EXPECT_EQ(order.size(), 50u);
  }
  for (int i = 0; i < 50; ++i)
    EXPECT_EQ(order[i], i);
  EXPECT_NE(ran_on, caller);
}

TEST(SerialWriter, PostWaitsWhileTheQueueIsFull) {
  output::SerialWriter writer(1);
  std::atomic<bool> release{false};
  std::atomic<int> done{0};
  writer.post([&] {
    while (!release)
      std::this_thread::yield();
    ++done;
  });
  writer.post([&] { ++done; }); // waits in the queue
  std::atomic<bool> posted{false};
  std::thread third([&] {
    writer.post([&] { ++done; });
    posted = true;
  });
  // The third post cannot return before the first task ends: the queue holds one task.
  EXPECT_FALSE(posted.load());
  release = true;
  third.join();
  EXPECT_TRUE(posted.load());
  writer.drain();
  EXPECT_EQ(done.load(), 3);
}

TEST(SerialWriter, AFailedTaskStopsTheRestAndIsThrownByDrainAndPost) {
  output::SerialWriter writer(4);
  std::vector<int> ran;
  std::atomic<bool> all_posted{false};
  writer.post([&] {
    while (!all_posted) // the failure comes after the three posts
      std::this_thread::yield();
    ran.push_back(1);
  });
  writer.post([] { throw std::runtime_error("disk full"); });
  writer.post([&] { ran.push_back(3); });
  all_posted = true;
  try {
    writer.drain();
    ADD_FAILURE() << "drain did not throw";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "disk full");
  }
  EXPECT_THROW(writer.post([&] { ran.push_back(4); }), std::runtime_error);
  EXPECT_THROW(writer.drain(), std::runtime_error);
  EXPECT_EQ(ran, std::vector<int>{1});
}

TEST(SerialWriter, DestructorRunsWhatIsQueued) {
  int count = 0;
  {
    output::SerialWriter writer(8);
    for (int i = 0; i < 5; ++i)
      writer.post([&count] { ++count; });
  }
  EXPECT_EQ(count, 5);
}

} // namespace
} // namespace yarnsim
