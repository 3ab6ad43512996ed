// Restart from a checkpoint (engine/solver/checkpoint.*, engine/output/checkpoint_file.*): a
// simulation rebuilt from the checkpoint of any increment goes on bit for bit as the run straight
// through, on the implicit contact path and inside an explicit step, whether the checkpoint is
// kept in memory or read back from checkpoint.h5. And the serial writer that overlaps output
// with the next increment (engine/output/serial_writer.*).

#include "engine/model/deck.hpp"
#include "engine/output/checkpoint_file.hpp"
#include "engine/output/serial_writer.hpp"
#include "engine/solver/checkpoint.hpp"
#include "engine/solver/simulation.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
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
  Eigen::Matrix3Xd x, rotation, v;
  Eigen::Matrix<double, 6, Eigen::Dynamic> reactions;
  double kinetic = 0, contact_energy = 0, external_work = 0, balance_error = 0;
  int active = 0;
};

struct Recorder : SimulationObserver {
  std::vector<Increment> increments;
  std::vector<SimulationCheckpoint> checkpoints;
  void on_increment(const Simulation& s, const IncrementReport& r) override {
    Increment i;
    i.time = r.time;
    i.dt = r.dt;
    i.iterations = r.iterations;
    i.x = s.state().x_n;
    i.rotation = s.state().rotation_n;
    i.v = s.state().v_n;
    i.reactions = s.reactions();
    const EnergyBalance e = s.energy_balance();
    i.kinetic = e.kinetic;
    i.contact_energy = e.contact;
    i.external_work = e.external_work;
    i.balance_error = e.error;
    i.active = s.contact() ? s.contact()->active() : 0;
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
    EXPECT_TRUE(same_bits(a.x, b.x));
    EXPECT_TRUE(same_bits(a.rotation, b.rotation));
    EXPECT_TRUE(same_bits(a.v, b.v));
    EXPECT_TRUE(same_bits(a.reactions, b.reactions));
    EXPECT_EQ(a.kinetic, b.kinetic);
    EXPECT_EQ(a.contact_energy, b.contact_energy);
    EXPECT_EQ(a.external_work, b.external_work);
    EXPECT_EQ(a.balance_error, b.balance_error);
    EXPECT_EQ(a.active, b.active);
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
