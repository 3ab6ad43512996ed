// The tangent's sparsity pattern and contact couplings (engine/assembly/assembler.*): a spline
// pair couples translations only, a surface pair translations and rotations, and a pair
// assembled without its coupling is refused instead of writing outside the matrix.
#include "beam_models.hpp"
#include "engine/assembly/assembler.hpp"
#include "engine/contact/contact_set.hpp"
#include "engine/contact/contact_stage.hpp"
#include "engine/contact/spline_contact_set.hpp"
#include "engine/input/read_deck.hpp"
#include "engine/model/partition.hpp"
#include "engine/solver/simulation.hpp"
#include "engine/state/state.hpp"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <filesystem>
#include <numeric>
#include <random>
#include <stdexcept>

namespace yarnsim {
namespace {

/// Two parallel beams of 3 elements (7 nodes each, nodes 0-6 and 7-13), nothing constrained.
Model two_beams() {
  const Section s = test::stiffness_section(1e3, 1e3, 1, 1);
  Model m = test::straight_beam({0, 0, 0}, {1, 0, 0}, 3, s);
  const Model b = test::straight_beam({0, 1, 0}, {1, 1, 0}, 3, s);
  for (const Eigen::Vector3d& x : b.nodes)
    m.nodes.push_back(x);
  for (BeamElement e : b.elements) {
    for (int& n : e.nodes)
      n += 7;
    m.elements.push_back(e);
  }
  return m;
}

/// Whether the pattern holds entry (DOF i of node a, DOF j of node b); no DOF is constrained, so
/// equation = 6 node + DOF.
bool holds(const Assembler& assembler, int a, int i, int b, int j) {
  const auto& m = assembler.matrix();
  for (SparseMatrix::InnerIterator it(m, 6 * b + j); it; ++it)
    if (it.row() == 6 * a + i)
      return true;
  return false;
}

TEST(Assembler, SplineCouplingsHoldTranslationsOnlyAndSurfaceCouplingsRotationsToo) {
  const Model m = two_beams();
  Assembler assembler(m, std::vector<char>(6 * m.nodes.size(), 0));
  EXPECT_FALSE(holds(assembler, 0, 0, 7, 0)); // the beams are not coupled by their elements
  const int version = assembler.pattern_version();

  // A spline pair: control points 0, 1, 2 of one beam and 7, 8, 9 of the other.
  EXPECT_TRUE(assembler.ensure_couplings({ContactCoupling{{0, 1, 2, 7, 8, 9}, false}}));
  EXPECT_GT(assembler.pattern_version(), version);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      EXPECT_TRUE(holds(assembler, 0, i, 9, j));
  EXPECT_FALSE(holds(assembler, 0, 3, 9, 0)); // rotation-translation
  EXPECT_FALSE(holds(assembler, 0, 3, 9, 4)); // rotation-rotation
  EXPECT_FALSE(assembler.ensure_couplings({ContactCoupling{{0, 1, 2, 7, 8, 9}, false}}));

  // A spline pair's tangent has its slots, each entry its own, at its row and column; a surface
  // pair's between the same nodes needs rotations.
  std::array<int, 18 * 18> spline;
  EXPECT_NO_THROW(assembler.translation_block_slots({0, 1, 2, 7, 8, 9}, spline.data()));
  const std::array<int, 6> pair_nodes{0, 1, 2, 7, 8, 9};
  const SparseMatrix& K = assembler.matrix();
  for (int r = 0; r < 18; ++r)
    for (int c = 0; c < 18; ++c) {
      const int slot = spline[18 * r + c];
      ASSERT_GE(slot, 0);
      const int col = assembler.equation(6 * pair_nodes[c / 3] + c % 3);
      EXPECT_GE(slot, K.outerIndexPtr()[col]);
      EXPECT_LT(slot, K.outerIndexPtr()[col + 1]);
      EXPECT_EQ(K.innerIndexPtr()[slot], assembler.equation(6 * pair_nodes[r / 3] + r % 3));
    }
  std::array<int, 24 * 24> surface;
  EXPECT_THROW(assembler.surface_pair_block_slots({0, 2, 7, 9}, surface.data()), std::logic_error);

  // The translations present do not satisfy a surface coupling: it grows the pattern.
  EXPECT_TRUE(assembler.ensure_couplings({ContactCoupling{{0, 2, 7, 9, 9, 9}, true}}));
  EXPECT_TRUE(holds(assembler, 0, 3, 9, 4));
  EXPECT_TRUE(holds(assembler, 9, 5, 0, 1));
  EXPECT_NO_THROW(assembler.surface_pair_block_slots({0, 2, 7, 9}, surface.data()));

  // A pair never coupled is refused, with its nodes named.
  try {
    assembler.translation_block_slots({4, 5, 6, 11, 12, 13}, spline.data());
    FAIL() << "no exception";
  } catch (const std::logic_error& e) {
    EXPECT_NE(std::string(e.what()).find("4, 5, 6, 11, 12, 13"), std::string::npos) << e.what();
  }
}

TEST(Assembler, AGrownPatternKeepsTheEntriesAssembledBeforeIt) {
  // The beams are assembled before the narrow phase says which contact pairs need coupling; a
  // pattern grown then must keep them: the same values as an assembly into the grown pattern.
  const Model m = two_beams();
  const std::vector<char> free(6 * m.nodes.size(), 0);
  const int n = static_cast<int>(m.nodes.size());
  State state;
  state.x.resize(3, n);
  state.alpha.resize(3, n);
  state.Q_n.assign(n, Eigen::Matrix3d::Identity());
  for (int i = 0; i < n; ++i) { // a bent, twisted configuration: full beam blocks
    state.x.col(i) = m.nodes[i] + Eigen::Vector3d(0, 0, 0.01 * i * i);
    state.alpha.col(i) = Eigen::Vector3d(0.1 * i, -0.05 * i, 0.02 * i * i);
  }
  {
    const Assembler a(m, free);
    for (const BeamReference& ref : a.references())
      state.gauss.push_back({GaussState{ref.Q0[0], Eigen::Vector3d::Zero()},
                             GaussState{ref.Q0[1], Eigen::Vector3d::Zero()}});
  }
  const ContactCoupling pair{{1, 2, 3, 8, 9, 10}, false};
  Eigen::VectorXd r(6 * state.n_nodes());

  Assembler grown(m, free);
  r.setZero();
  grown.zero_matrix();
  grown.add_beams(state, r, true, {});
  const Eigen::Index before = grown.matrix().nonZeros();
  EXPECT_TRUE(grown.ensure_couplings({pair}));
  EXPECT_GT(grown.matrix().nonZeros(), before);

  Assembler from_start(m, free);
  from_start.ensure_couplings({pair});
  r.setZero();
  from_start.zero_matrix();
  from_start.add_beams(state, r, true, {});

  ASSERT_EQ(grown.matrix().nonZeros(), from_start.matrix().nonZeros());
  for (Eigen::Index k = 0; k < grown.matrix().nonZeros(); ++k) {
    ASSERT_EQ(grown.matrix().innerIndexPtr()[k], from_start.matrix().innerIndexPtr()[k]);
    ASSERT_EQ(grown.matrix().valuePtr()[k], from_start.matrix().valuePtr()[k]) << "entry " << k;
  }
  EXPECT_GT(grown.matrix().cwiseAbs().sum(), 0.0);
  // The contact pair's own entries: zero until its tangent is added.
  EXPECT_TRUE(holds(grown, 1, 0, 10, 2));
  EXPECT_EQ(grown.matrix().coeff(6 * 1 + 0, 6 * 10 + 2), 0.0);
  // The grown pattern merged the new entries into the old one (Assembler::grow_pattern): the
  // same columns as a pattern built with the pair, and the beams' slots moved with their
  // entries, so the beams assemble into the same places.
  for (Eigen::Index c = 0; c <= grown.matrix().outerSize(); ++c)
    ASSERT_EQ(grown.matrix().outerIndexPtr()[c], from_start.matrix().outerIndexPtr()[c]);
  r.setZero();
  grown.zero_matrix();
  grown.add_beams(state, r, true, {});
  for (Eigen::Index k = 0; k < grown.matrix().nonZeros(); ++k)
    ASSERT_EQ(grown.matrix().valuePtr()[k], from_start.matrix().valuePtr()[k]) << "entry " << k;
}

TEST(Assembler, CouplingsThePatternHoldsAlreadyDoNotRebuildIt) {
  const Model m = two_beams();
  Assembler assembler(m, std::vector<char>(6 * m.nodes.size(), 0));
  const int version = assembler.pattern_version();
  // Nodes of one element: the beams' pattern holds them; listed, not rebuilt.
  EXPECT_FALSE(assembler.ensure_couplings({ContactCoupling{{0, 1, 2, 2, 2, 2}, false}}));
  EXPECT_EQ(assembler.pattern_version(), version);
  EXPECT_EQ(assembler.couplings().size(), 1u);
  // Listed or not, the pattern is the same: set_couplings (a checkpoint's restore) rebuilds it.
  Assembler other(m, std::vector<char>(6 * m.nodes.size(), 0));
  other.set_couplings(assembler.couplings());
  EXPECT_EQ(other.couplings(), assembler.couplings());
  EXPECT_EQ(other.matrix().nonZeros(), assembler.matrix().nonZeros());
}

/// Contact pairs of 6 nodes each among `n_nodes`, some with a node twice, each with a residual
/// of 18 and a tangent of 18 x 18 whose values span twelve decades (so that the order of their
/// sums shows in the bits).
struct RandomPairs {
  std::vector<std::array<int, 6>> nodes;
  std::vector<Eigen::Matrix<double, 18, 1>> residual;
  std::vector<Eigen::Matrix<double, 18, 18>> tangent;
  RandomPairs(int n_pairs, int n_nodes, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_int_distribution<int> node(0, n_nodes - 1);
    std::uniform_real_distribution<double> unit(-1.0, 1.0), decade(-6.0, 6.0);
    const auto value = [&] { return unit(rng) * std::pow(10.0, decade(rng)); };
    for (int k = 0; k < n_pairs; ++k) {
      std::array<int, 6> n;
      for (int& i : n)
        i = node(rng);
      if (k % 5 == 0)
        n[4] = n[1]; // a node twice in the pair
      nodes.push_back(n);
      residual.emplace_back(Eigen::Matrix<double, 18, 1>::NullaryExpr(value));
      tangent.emplace_back(Eigen::Matrix<double, 18, 18>::NullaryExpr(value));
    }
  }
};

void check_pairs_added_over_their_nodes(const RandomPairs& pairs, int n_nodes) {
  const int n = 3 * n_nodes;
  // A dense matrix, column-major: slot of (row, column) = n column + row; column of the pair's
  // entry c is node nodes[c / 3]'s.
  const auto dof = [&](std::size_t k, int r) { return 3 * pairs.nodes[k][r / 3] + r % 3; };
  std::vector<double> serial_r(n, 0.0), serial_m(n * n, 0.0);
  for (std::size_t k = 0; k < pairs.nodes.size(); ++k)
    for (int r = 0; r < 18; ++r) {
      serial_r[dof(k, r)] += pairs.residual[k](r);
      for (int c = 0; c < 18; ++c)
        serial_m[n * dof(k, c) + dof(k, r)] += pairs.tangent[k](r, c);
    }
  std::vector<double> reversed_m(n * n, 0.0); // the same sums in another order
  for (std::size_t k = pairs.nodes.size(); k-- > 0;)
    for (int r = 0; r < 18; ++r)
      for (int c = 0; c < 18; ++c)
        reversed_m[n * dof(k, c) + dof(k, r)] += pairs.tangent[k](r, c);
  ASSERT_NE(reversed_m, serial_m) << "the test's values must make the order of the sums show";

  for (int threads : {1, 2, 4}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    std::vector<double> by_node_r(n, 0.0), by_node_m(n * n, 0.0);
    std::vector<int> offsets, incident;
    add_by_node(n_nodes, pairs.nodes, offsets, incident, [&](std::size_t k, int node) {
      for (int r = 0; r < 18; ++r) {
        if (pairs.nodes[k][r / 3] == node)
          by_node_r[dof(k, r)] += pairs.residual[k](r);
        for (int c = 0; c < 18; ++c)
          if (pairs.nodes[k][c / 3] == node)
            by_node_m[n * dof(k, c) + dof(k, r)] += pairs.tangent[k](r, c);
      }
    });
    EXPECT_EQ(by_node_r, serial_r) << threads << " threads";
    EXPECT_EQ(by_node_m, serial_m) << threads << " threads";
  }
}

TEST(ContactAssembly, PairsAddedOverTheirNodesGiveTheBitsOfOneLoopOverThePairs) {
  // add_by_node (engine/contact/contact_set.hpp) adds the pairs in parallel over the nodes: every
  // residual entry and matrix slot must receive the same additions in the same order as a serial
  // loop over the pairs, so the sums are the same bits on any thread count and as before.
  for (const int n_pairs : {50, 600}) { // below and above the serial loop's bound (kSerialBelow)
    SCOPED_TRACE(testing::Message() << n_pairs << " pairs");
    check_pairs_added_over_their_nodes(RandomPairs(n_pairs, 40, 7), 40);
  }
}

TEST(ContactSummary, TheParallelScanOfTheWorkListIsOneSerialPass) {
  // scan_work (engine/contact/contact_set.hpp) takes a set's work items in parallel blocks for
  // its summary and veto: it must give what one serial pass gives (the smallest gap, the first
  // vetoing item, the listed items in their order) on any thread count, so that the summary's
  // sums, taken over the listed items, keep their order. Sizes below, at and across the block
  // (256), items that veto only late and only in one block, and none at all.
  std::mt19937 random(11);
  for (const std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{255}, std::size_t{256},
                              std::size_t{257}, std::size_t{5000}}) {
    for (const double veto_rate : {0.0, 0.001, 0.3}) {
      SCOPED_TRACE(testing::Message() << n << " items, veto rate " << veto_rate);
      std::vector<ItemScan> items(n);
      std::uniform_real_distribution<double> u(0, 1);
      for (ItemScan& item : items) {
        if (u(random) < 0.7)
          item.gap = u(random) - 0.2; // converged in range, some penetrating
        item.vetoes = u(random) < veto_rate;
        item.listed = u(random) < 0.1;
      }
      WorkScan serial;
      for (std::size_t w = 0; w < n; ++w) {
        serial.min_gap = std::min(serial.min_gap, items[w].gap);
        if (items[w].vetoes && serial.first_vetoed < 0)
          serial.first_vetoed = static_cast<int>(w);
        if (items[w].listed)
          serial.listed.push_back(static_cast<int>(w));
      }
      for (const int threads : {1, 2, 4}) {
        tbb::global_control control(tbb::global_control::max_allowed_parallelism, threads);
        std::vector<WorkScan> blocks;
        WorkScan scan;
        scan.first_vetoed = 7; // left from an earlier pass: overwritten
        scan.listed = {3, 1};
        scan_work(n, blocks, scan, [&](std::size_t w) { return items[w]; });
        EXPECT_EQ(scan.min_gap, serial.min_gap) << threads << " threads";
        EXPECT_EQ(scan.first_vetoed, serial.first_vetoed) << threads << " threads";
        EXPECT_EQ(scan.listed, serial.listed) << threads << " threads";
      }
    }
  }
}

TEST(ContactAssembly, SlotsAreLookedUpAgainOnlyForNewPairsOrANewPattern) {
  // find_active_slots keeps the slots of the pairs it looked up (SlotCache) while the pattern
  // stays: a pair active again is not looked up again, a newly active one is, and a grown
  // pattern (whose entries moved) has every active pair looked up again.
  const Model m = two_beams();
  Assembler assembler(m, std::vector<char>(6 * m.nodes.size(), 0));
  struct Item {
    std::array<int, 6> nodes;
    struct {
      bool active;
    } result;
  };
  std::vector<Item> work{{{0, 1, 2, 7, 8, 9}, {true}}, {{1, 2, 3, 8, 9, 10}, {false}}};
  std::vector<ContactCoupling> couplings;
  for (const Item& w : work)
    couplings.push_back({w.nodes, false});
  assembler.ensure_couplings(couplings);
  std::vector<int> items;
  SlotCache cache;
  int looked_up = 0;
  const auto evaluate = [&] {
    find_active_slots(work, true, 324, assembler.pattern_id(), items, cache,
                      [&](const Item& item, int* slots) {
                        ++looked_up;
                        assembler.translation_block_slots(item.nodes, slots);
                      });
    // Every active pair's cached slots are those a fresh look-up gives.
    for (int w : items) {
      std::array<int, 324> fresh;
      assembler.translation_block_slots(work[w].nodes, fresh.data());
      EXPECT_TRUE(std::equal(fresh.begin(), fresh.end(), cache.slots(w))) << "pair " << w;
    }
  };
  evaluate();
  EXPECT_EQ(looked_up, 1);
  evaluate();
  EXPECT_EQ(looked_up, 1) << "the same active pair, the same pattern: no look-up";
  work[1].result.active = true;
  evaluate();
  EXPECT_EQ(looked_up, 2) << "only the newly active pair";
  // A coupling of other nodes grows the pattern: entries move, both pairs are looked up again.
  EXPECT_TRUE(assembler.ensure_couplings({ContactCoupling{{4, 5, 6, 11, 12, 13}, false}}));
  evaluate();
  EXPECT_EQ(looked_up, 4);
  // A new work list (the set clears the cache): looked up again.
  cache.clear();
  evaluate();
  EXPECT_EQ(looked_up, 6);
}

/// Whole yarns: every element's nodes on one process of `parts`.
void expect_whole_yarns(const Model& m, const std::vector<NodePartition>& parts) {
  for (const BeamElement& e : m.elements) {
    std::size_t owner = 0;
    while (owner < parts.size() && !parts[owner].owns(e.nodes[0]))
      ++owner;
    ASSERT_LT(owner, parts.size()) << "node " << e.nodes[0] << " on no process";
    for (int a : e.nodes)
      EXPECT_TRUE(parts[owner].owns(a));
  }
}

TEST(Partition, EveryContactPairIsFoundAndAssembledByExactlyOneProcess) {
  // A run over several processes (partition.hpp): each projects and assembles the contact pairs
  // whose first node it owns (ContactStage::set_partition) and the elements whose first node it
  // owns, and the run combines their figures and points and sums their residuals and matrices
  // (Simulation::evaluate). Over any number of processes those are the one-process ones, so no
  // pair is left out or found twice. On 2 processes the paper's fabric splits into its warp
  // (nodes of the first 6 yarns) and its weft, so every crossing pair couples nodes of both; the
  // pairs spread over the two about evenly (pair_owner_node).
  for (const char* deck : {"biaxial-k1.toml", "biaxial-surface-k1.toml"}) {
    SCOPED_TRACE(deck);
    Model m = read_deck(std::filesystem::path(YARNSIM_SOURCE_DIR) / "examples" / deck);
    m.steps[0].end_time = 0.4; // past the crossings' closing
    Simulation sim(m);
    sim.run();
    const State& state = sim.state();
    const int n = state.n_nodes();
    const std::unique_ptr<ContactStage> whole = ContactStage::of(m);
    ASSERT_EQ(whole->evaluate(state, true), "");
    ASSERT_GE(whole->active(), 36);
    const std::vector<ContactPoint> points_one = whole->points();
    Assembler assembler(m, std::vector<char>(static_cast<std::size_t>(6 * n), 0));
    assembler.ensure_couplings(whole->couplings());
    const auto assemble = [&](const ContactStage& stage, const NodePartition* owned) {
      Eigen::VectorXd r = Eigen::VectorXd::Zero(6 * n);
      assembler.zero_matrix();
      assembler.add_beams(state, r, true, {}, nullptr, owned);
      stage.assemble(r, assembler, true); // a share's stage holds its own pairs alone
      const SparseMatrix& K = assembler.matrix();
      return std::pair{
          r, Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(K.valuePtr(), K.nonZeros()))};
    };
    const auto [r_one, K_one] = assemble(*whole, nullptr);
    const SparseMatrix whole_matrix = assembler.matrix();
    for (const int ranks : {2, 3, 5}) {
      SCOPED_TRACE(ranks);
      const std::vector<NodePartition> parts = partition_all(m, ranks);
      ASSERT_EQ(parts.size(), std::size_t(ranks));
      EXPECT_EQ(parts.front().first, 0);
      EXPECT_EQ(parts.back().last, n);
      for (int k = 0; k + 1 < ranks; ++k)
        EXPECT_EQ(parts[k].last, parts[k + 1].first);
      if (ranks == 2) {
        EXPECT_EQ(parts[0].last, n / 2); // the warp's 6 yarns, then the weft's
      }
      expect_whole_yarns(m, parts);
      Eigen::VectorXd r_sum = Eigen::VectorXd::Zero(6 * n),
                      K_sum = Eigen::VectorXd::Zero(K_one.size());
      std::vector<ContactSummary> summaries;
      std::vector<ContactPoint> points;
      SparseMatrix shares_sum;
      for (const NodePartition& part : parts) {
        const std::unique_ptr<ContactStage> stage = ContactStage::of(m);
        stage->set_partition(part);
        ASSERT_TRUE(stage->partitioned());
        ASSERT_EQ(stage->evaluate(state, true), "");
        summaries.push_back(stage->local_summary());
        const std::vector<ContactPoint> own = stage->local_points();
        points.insert(points.end(), own.begin(), own.end());
        const auto [r, K] = assemble(*stage, &part);
        r_sum += r;
        K_sum += K;
        // The pattern of the share alone (Assembler::share, a solver summing the processes'
        // own entries): it holds what this process assembles and nothing else, the same values
        // in the same places of the whole system, and smaller than the whole pattern.
        Assembler share(m, std::vector<char>(static_cast<std::size_t>(6 * n), 0), part);
        const std::vector<ContactCoupling> couplings = stage->couplings();
        share.ensure_couplings(couplings);
        Eigen::VectorXd r_own = Eigen::VectorXd::Zero(6 * n);
        share.zero_matrix();
        share.add_beams(state, r_own, true, {}, nullptr, &part);
        stage->assemble(r_own, share, true);
        EXPECT_EQ(r_own, r);
        const std::vector<char> mine = share.own_entries(part, couplings);
        EXPECT_EQ(std::count(mine.begin(), mine.end(), char{1}), share.matrix().nonZeros());
        EXPECT_LT(share.matrix().nonZeros(), whole_matrix.nonZeros());
        shares_sum =
            shares_sum.nonZeros() == 0 ? share.matrix() : SparseMatrix(shares_sum + share.matrix());
        EXPECT_THROW(
            share.add_node_block(part.first > 0 ? 0 : n - 1, 0, 0, Eigen::Matrix3d::Identity()),
            std::logic_error); // a node of another process
      }
      // The shares' patterns together are the whole pattern, their sums its values.
      ASSERT_EQ(shares_sum.nonZeros(), whole_matrix.nonZeros());
      for (Eigen::Index k = 0; k < whole_matrix.nonZeros(); ++k)
        ASSERT_EQ(shares_sum.innerIndexPtr()[k], whole_matrix.innerIndexPtr()[k]);
      EXPECT_LE(
          (Eigen::Map<const Eigen::VectorXd>(shares_sum.valuePtr(), shares_sum.nonZeros()) - K_one)
              .cwiseAbs()
              .maxCoeff(),
          1e-12 * K_one.cwiseAbs().maxCoeff());
      // Each process is charged, in the partition's balance (add_candidate_loads), the
      // candidates it projects: those its nodes own.
      std::vector<double> load(static_cast<std::size_t>(n), 0.0);
      whole->add_candidate_loads(load, 1.0);
      for (std::size_t k = 0; k < parts.size(); ++k) {
        double charged = 0;
        for (int i = parts[k].first; i < parts[k].last; ++i)
          charged += load[static_cast<std::size_t>(i)];
        EXPECT_EQ(charged, summaries[k].candidates) << "process " << k;
      }
      // Found by the shares of its segments: each process's search lists the pairs with a
      // segment in its share (CandidateSearch::set_share), so a pair across two shares is listed
      // by both and one within a share by it alone. On 2 every pair couples the warp's share
      // with the weft's; on 5 each share lists less than the whole search.
      const int whole_search = whole->summary().searched;
      ASSERT_EQ(whole_search, whole->candidates());
      int searched = 0;
      for (const ContactSummary& s : summaries) {
        EXPECT_GE(s.searched, s.candidates);
        EXPECT_LE(s.searched, whole_search);
        if (ranks == 2)
          EXPECT_EQ(s.searched, whole_search);
        if (ranks == 5)
          EXPECT_LT(s.searched, whole_search);
        searched += s.searched;
      }
      EXPECT_GE(searched, whole_search);
      EXPECT_LE(searched, 2 * whole_search);
      // Found once: every active pair on one process.
      const ContactSummary combined = combine_summaries(summaries);
      if (ranks == 2) {
        for (const ContactSummary& s : summaries)
          EXPECT_GE(s.active_share, 0.4 * whole->active());
      }
      EXPECT_EQ(combined.candidates, whole->candidates());
      EXPECT_EQ(combined.active, whole->active());
      EXPECT_NEAR(combined.total_force, whole->total_force(), 1e-12 * whole->total_force());
      ASSERT_EQ(points.size(), points_one.size());
      std::sort(points.begin(), points.end(), [](const ContactPoint& a, const ContactPoint& b) {
        return std::tie(a.surface, a.definition, a.pair) <
               std::tie(b.surface, b.definition, b.pair);
      });
      for (std::size_t k = 0; k < points.size(); ++k) {
        EXPECT_EQ(points[k].pair, points_one[k].pair);
        EXPECT_EQ(points[k].force, points_one[k].force);
      }
      // Assembled once: the sums are the one-process assembly.
      EXPECT_LE((r_sum - r_one).cwiseAbs().maxCoeff(), 1e-12 * r_one.cwiseAbs().maxCoeff());
      EXPECT_LE((K_sum - K_one).cwiseAbs().maxCoeff(), 1e-12 * K_one.cwiseAbs().maxCoeff());
    }
  }
}

TEST(Partition, AShareRestoresEverySavedPairAndRefusesPairsThatDoNotFitTheModel) {
  // A process's share (its search lists the pairs with a segment in it: CandidateSearch::
  // set_share) restores the whole snapshot every process saved (Simulation::rebalance, a
  // restart), the run's figures as they stand, and keeps its own pairs from the next search on.
  // Saved pairs outside its search are not checked against it, so they are checked against the
  // model: a segment the model does not have, or pairs out of order, are refused with an error.
  Model m = read_deck(std::filesystem::path(YARNSIM_SOURCE_DIR) / "examples" / "biaxial-k1.toml");
  m.steps[0].end_time = 0.3;
  Simulation sim(m);
  sim.run();
  const std::unique_ptr<ContactStage> whole = ContactStage::of(m);
  ASSERT_EQ(whole->evaluate(sim.state(), true), "");
  const SplineContactSet::Snapshot saved = whole->spline()->snapshot();
  const NodePartition part = partition_all(m, 3)[1];
  const auto share = [&] {
    std::unique_ptr<ContactStage> stage = ContactStage::of(m);
    stage->set_partition(part);
    EXPECT_EQ(stage->evaluate(sim.state(), true), "");
    return stage;
  };
  const std::unique_ptr<ContactStage> stage = share();
  const int own = stage->local_summary().candidates;
  ASSERT_LT(stage->local_summary().searched, whole->candidates());
  stage->spline()->restore(saved);
  EXPECT_EQ(stage->spline()->summary().candidates, whole->candidates());
  EXPECT_EQ(stage->spline()->summary().active, whole->active());
  ASSERT_EQ(stage->evaluate(sim.state(), true), "");
  EXPECT_EQ(stage->local_summary().candidates, own);
  // The last saved pair's segments are the model's last: beyond them, none.
  const auto refused = [&](auto&& spoil) {
    SplineContactSet::Snapshot bad = saved;
    spoil(bad.pairs);
    EXPECT_THROW(share()->spline()->restore(bad), std::invalid_argument);
  };
  refused([](auto& pairs) { pairs.back().key[2] = 1 << 30; });
  refused([](auto& pairs) {
    pairs.push_back(pairs.back());
    pairs.back().key[0] += 1; // a definition the model does not have
  });
  refused([](auto& pairs) { std::swap(pairs.front(), pairs.back()); });
}

TEST(Partition, TheCutsBalanceTheElementsAndTheLoadOfTheNodes) {
  // partition_all with a load per node (Simulation::rebalance: the contact candidates each node
  // owns) cuts between whole yarns where the elements and the loads before the cut make
  // rank / ranks of the whole. No load cuts as the elements alone; a load on the first yarns
  // moves the cuts towards them; the largest share is then within a yarn's work of the mean,
  // where the elements alone left it far above.
  const Model m =
      read_deck(std::filesystem::path(YARNSIM_SOURCE_DIR) / "examples" / "biaxial-k1.toml");
  const int n = static_cast<int>(m.nodes.size());
  std::vector<double> load(static_cast<std::size_t>(n), 0.0);
  for (const int ranks : {2, 3, 4})
    EXPECT_EQ(partition_all(m, ranks, load), partition_all(m, ranks)) << ranks;
  // The first two yarns' nodes carry 4 elements' worth each (a yarn's own work is its elements).
  const std::vector<NodePartition> by_elements = partition_all(m, 3);
  const int first_two = by_elements[0].last / 2; // rank 0 holds the first 4 of the 12 yarns
  ASSERT_GT(first_two, 0);
  for (int i = 0; i < first_two; ++i)
    load[static_cast<std::size_t>(i)] = 4.0;
  std::vector<double> work(static_cast<std::size_t>(n), 0.0);
  for (const BeamElement& e : m.elements)
    work[static_cast<std::size_t>(e.nodes[0])] += 1.0;
  for (int i = 0; i < n; ++i)
    work[static_cast<std::size_t>(i)] += load[static_cast<std::size_t>(i)];
  const double total = std::accumulate(work.begin(), work.end(), 0.0);
  const double yarn = static_cast<double>(m.elements.size()) / 12 + 4.0 * first_two / 2;
  const auto largest = [&](const std::vector<NodePartition>& parts) {
    double out = 0;
    for (const NodePartition& p : parts)
      out = std::max(out, std::accumulate(work.begin() + p.first, work.begin() + p.last, 0.0));
    return out;
  };
  const std::vector<NodePartition> balanced = partition_all(m, 3, load);
  EXPECT_LT(balanced[0].last, by_elements[0].last) << "the loaded yarns' process takes fewer";
  EXPECT_LE(largest(balanced), total / 3 + yarn);
  EXPECT_GT(largest(by_elements), total / 3 + yarn);
  expect_whole_yarns(m, balanced);
  // share_work counts each process's work as this test does.
  const std::vector<double> shares = share_work(m, balanced, load);
  ASSERT_EQ(shares.size(), 3u);
  EXPECT_EQ(*std::max_element(shares.begin(), shares.end()), largest(balanced));
  // Bad loads: a size other than the nodes', negative, not finite.
  EXPECT_THROW(partition_all(m, 2, std::vector<double>(3, 0.0)), std::invalid_argument);
  load[5] = -1;
  EXPECT_THROW(partition_all(m, 2, load), std::invalid_argument);
  load[5] = std::nan("");
  EXPECT_THROW(partition_all(m, 2, load), std::invalid_argument);
}

} // namespace
} // namespace yarnsim
