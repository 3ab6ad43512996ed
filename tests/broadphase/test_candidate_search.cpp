#include "broadphase/candidate_search.hpp"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <random>
#include <set>
#include <stdexcept>
#include <utility>
#include <vector>

namespace yarnsim::broadphase {
namespace {

/// Random yarn layout: curves as random walks of some stiffness in a cube, segments of unit length,
/// one box per segment from its two end points, radii per segment in [0.05, 0.15].
struct Layout {
  std::vector<SegmentInfo> segments;
  std::vector<Eigen::AlignedBox3d> boxes;
  std::vector<double> radius;
};

Layout random_layout(int num_segments, int segments_per_curve, int num_groups, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_real_distribution<double> radius(0.05, 0.15);
  // About 0.5 segments per unit volume: roughly one candidate per segment.
  const double side = std::cbrt(num_segments / 0.5);
  std::uniform_real_distribution<double> inside(0.0, side);
  Layout out;
  int curve = 0;
  while (static_cast<int>(out.segments.size()) < num_segments) {
    const int group = curve % num_groups;
    Eigen::Vector3d p(inside(rng), inside(rng), inside(rng));
    Eigen::Vector3d dir = Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized();
    for (int i = 0; i < segments_per_curve && static_cast<int>(out.segments.size()) < num_segments;
         ++i) {
      dir = (dir + 0.8 * Eigen::Vector3d(unit(rng), unit(rng), unit(rng))).normalized();
      for (int k = 0; k < 3; ++k) { // reflect at the walls: the density stays as set
        if (p[k] + dir[k] < 0.0 || p[k] + dir[k] > side) {
          dir[k] = -dir[k];
        }
      }
      const Eigen::Vector3d q = p + dir;
      Eigen::AlignedBox3d box(p);
      box.extend(q);
      out.segments.push_back({curve, i, group});
      out.boxes.push_back(box);
      out.radius.push_back(radius(rng));
      p = q;
    }
    ++curve;
  }
  return out;
}

Eigen::AlignedBox3d translated(const Eigen::AlignedBox3d& b, const Eigen::Vector3d& t) {
  return Eigen::AlignedBox3d(b.min() + t, b.max() + t);
}

/// Straight curves along x, each segment spanning [i, i + 1] in x, at the given y.
Layout straight_curves(const std::vector<double>& y, int segments_per_curve) {
  Layout out;
  for (int c = 0; c < static_cast<int>(y.size()); ++c) {
    for (int i = 0; i < segments_per_curve; ++i) {
      out.segments.push_back({c, i, c});
      out.boxes.emplace_back(Eigen::Vector3d(i, y[c], 0.0), Eigen::Vector3d(i + 1, y[c], 0.0));
      out.radius.push_back(0.1);
    }
  }
  return out;
}

std::vector<CandidatePair> search_once(const Layout& l,
                                       const std::vector<std::pair<int, int>>& group_pairs,
                                       const CandidateSearchOptions& o) {
  CandidateSearch search(l.segments, group_pairs, o);
  EXPECT_TRUE(search.update(l.boxes, l.radius));
  return search.candidates();
}

const std::vector<std::pair<int, int>> all_of_two_groups = {{0, 0}, {0, 1}, {1, 1}};
const std::vector<std::pair<int, int>> one_group = {{0, 0}};

class MatchesBruteForce : public ::testing::TestWithParam<int> {};

TEST_P(MatchesBruteForce, OnRandomYarnLayouts) {
  const int n = GetParam();
  const Layout l = random_layout(n, 20, 2, 1234u + n);
  for (const bool self_contact : {false, true}) {
    CandidateSearchOptions o{.margin = 0.1, .same_curve_skip = 2, .self_contact = self_contact};
    CandidateSearch search(l.segments, all_of_two_groups, o);
    ASSERT_TRUE(search.update(l.boxes, l.radius));
    const auto expected =
        brute_force_candidates(l.segments, all_of_two_groups, o, l.boxes, l.radius);
    const auto same_curve = std::count_if(expected.begin(), expected.end(), [&](const auto& p) {
      return l.segments[p.first].curve == l.segments[p.second].curve;
    });
    EXPECT_EQ(same_curve > 0, self_contact) << "layout does not exercise self-contact";
    EXPECT_GT(expected.size(), static_cast<std::size_t>(n / 2)) << "layout too sparse to test";
    EXPECT_EQ(search.candidates(), expected);
    // The tree's boxes are tight: FCL reported few pairs beyond those kept (same-curve neighbours).
    EXPECT_LT(search.statistics().reported_pairs,
              2 * static_cast<std::int64_t>(expected.size()) + 2 * n);
  }
}

INSTANTIATE_TEST_SUITE_P(Sizes, MatchesBruteForce, ::testing::Values(100, 1000, 10000));

TEST(CandidateSearch, CandidatesAreCanonicalSortedAndUnique) {
  const Layout l = random_layout(2000, 10, 1, 7u);
  CandidateSearchOptions o{.margin = 0.2, .self_contact = true};
  const auto c = search_once(l, {{0, 0}}, o);
  ASSERT_FALSE(c.empty());
  for (const auto& p : c) {
    EXPECT_LT(p.first, p.second);
  }
  EXPECT_TRUE(std::is_sorted(c.begin(), c.end()));
  EXPECT_EQ(std::adjacent_find(c.begin(), c.end()), c.end());
}

// Two parallel straight curves of 5 segments, 1 apart in y; radius 0.1, margin 0.6: the inflated
// boxes have half-extent 1.2 along x, so segments overlap when their indices differ by <= 2.
std::vector<CandidatePair> cross_pairs() {
  std::vector<CandidatePair> out;
  for (int i = 0; i < 5; ++i) {
    for (int j = 0; j < 5; ++j) {
      if (std::abs(i - j) <= 2) {
        out.push_back({i, 5 + j});
      }
    }
  }
  return out;
}

std::vector<CandidatePair> sorted(std::vector<CandidatePair> v) {
  std::sort(v.begin(), v.end());
  return v;
}

TEST(TopologyFilter, SelfContactOffExcludesTheSameCurve) {
  const Layout l = straight_curves({0.0, 1.0}, 5);
  CandidateSearchOptions o{.margin = 0.6, .same_curve_skip = 1, .self_contact = false};
  const std::vector<std::pair<int, int>> groups = {{0, 1}, {0, 0}, {1, 1}};
  EXPECT_EQ(search_once(l, groups, o), cross_pairs());
  EXPECT_EQ(brute_force_candidates(l.segments, groups, o, l.boxes, l.radius), cross_pairs());
}

TEST(TopologyFilter, NeighboursOnTheSameCurveExcluded) {
  const Layout l = straight_curves({0.0, 1.0}, 5);
  const std::vector<std::pair<int, int>> groups = {{0, 1}, {0, 0}, {1, 1}};
  CandidateSearchOptions o{.margin = 0.6, .same_curve_skip = 1, .self_contact = true};
  auto expected = cross_pairs();
  for (const int base : {0, 5}) {
    for (int i = 0; i + 2 < 5; ++i) {
      expected.push_back({base + i, base + i + 2});
    }
  }
  expected = sorted(expected);
  EXPECT_EQ(search_once(l, groups, o), expected);
  EXPECT_EQ(brute_force_candidates(l.segments, groups, o, l.boxes, l.radius), expected);

  o.same_curve_skip = 0; // now direct neighbours come back as well
  for (const int base : {0, 5}) {
    for (int i = 0; i + 1 < 5; ++i) {
      expected.push_back({base + i, base + i + 1});
    }
  }
  expected = sorted(expected);
  EXPECT_EQ(search_once(l, groups, o), expected);

  o.same_curve_skip = 2; // nothing within a curve overlaps beyond index distance 2
  EXPECT_EQ(search_once(l, groups, o), cross_pairs());
}

TEST(GroupFilter, PairsOnlyBetweenAllowedGroups) {
  // Three curves (groups 0, 1, 2) close enough that every curve overlaps every other.
  const Layout l = straight_curves({0.0, 0.5, 1.0}, 5);
  CandidateSearchOptions o{.margin = 0.6, .same_curve_skip = 1, .self_contact = true};
  // Given as (1, 0): the pairs are symmetric.
  EXPECT_EQ(search_once(l, {{1, 0}}, o), cross_pairs());
  // Only within group 2.
  const std::vector<CandidatePair> within_2 = {{10, 12}, {11, 13}, {12, 14}};
  EXPECT_EQ(search_once(l, {{2, 2}}, o), within_2);
  // No pairs listed: no candidates.
  EXPECT_TRUE(search_once(l, {}, o).empty());
}

TEST(GroupFilter, RandomLayoutRespectsGroupsAndMatchesBruteForce) {
  const Layout l = random_layout(3000, 15, 3, 99u);
  const std::vector<std::pair<int, int>> groups = {{0, 1}, {2, 2}};
  const std::set<std::pair<int, int>> allowed = {{0, 1}, {1, 0}, {2, 2}};
  CandidateSearchOptions o{.margin = 0.1, .self_contact = true};
  const auto c = search_once(l, groups, o);
  ASSERT_FALSE(c.empty());
  bool saw_01 = false, saw_22 = false;
  for (const auto& p : c) {
    const int ga = l.segments[p.first].group, gb = l.segments[p.second].group;
    EXPECT_TRUE(allowed.count({ga, gb})) << "pair (" << p.first << ", " << p.second << ")";
    saw_01 = saw_01 || ga != gb;
    saw_22 = saw_22 || ga == 2;
  }
  EXPECT_TRUE(saw_01 && saw_22);
  EXPECT_EQ(c, brute_force_candidates(l.segments, groups, o, l.boxes, l.radius));
}

TEST(Refresh, SmallMotionKeepsTheListWithoutSearch) {
  const Layout l = random_layout(2000, 20, 1, 5u);
  CandidateSearchOptions o{.margin = 0.1, .refresh_fraction = 0.5, .self_contact = true};
  CandidateSearch search(l.segments, {{0, 0}}, o);
  ASSERT_TRUE(search.update(l.boxes, l.radius));
  const auto before = search.candidates();
  const double threshold = o.refresh_fraction * o.margin;

  // Every box moves by 0.9 of the threshold (along all axes): no search.
  std::mt19937_64 rng(3);
  std::uniform_int_distribution<int> sign(0, 1);
  std::vector<Eigen::AlignedBox3d> moved(l.boxes);
  for (auto& b : moved) {
    const Eigen::Vector3d t(sign(rng) ? 1 : -1, sign(rng) ? 1 : -1, sign(rng) ? 1 : -1);
    b = translated(b, 0.9 * threshold * t);
  }
  EXPECT_FALSE(search.update(moved, l.radius));
  EXPECT_EQ(search.statistics().searches, 1);
  EXPECT_EQ(search.statistics().updates, 2);
  EXPECT_NEAR(search.statistics().motion_since_search, 0.9 * threshold, 1e-12);
  EXPECT_EQ(search.candidates(), before);
  // ... but a forced update searches, and finds the moved layout's pairs.
  EXPECT_TRUE(search.update(moved, l.radius, /*force=*/true));
  EXPECT_EQ(search.candidates(), brute_force_candidates(l.segments, one_group, o, moved, l.radius));
}

TEST(Refresh, LargerMotionOfOneSegmentTriggersASearch) {
  const Layout l = random_layout(2000, 20, 1, 6u);
  CandidateSearchOptions o{.margin = 0.1, .refresh_fraction = 0.5, .self_contact = true};
  const std::vector<std::pair<int, int>> groups = {{0, 0}};
  CandidateSearch search(l.segments, groups, o);
  ASSERT_TRUE(search.update(l.boxes, l.radius));
  const double threshold = o.refresh_fraction * o.margin;

  // Move one segment by 1.1 threshold: search again.
  std::vector<Eigen::AlignedBox3d> moved(l.boxes);
  moved[777] = translated(moved[777], Eigen::Vector3d(0.0, 1.1 * threshold, 0.0));
  EXPECT_TRUE(search.update(moved, l.radius));
  EXPECT_EQ(search.statistics().searches, 2);
  EXPECT_EQ(search.candidates(), brute_force_candidates(l.segments, groups, o, moved, l.radius));

  // Motion is measured from the last search, not the last update: creeping by 0.6 threshold
  // twice triggers on the second step.
  std::vector<Eigen::AlignedBox3d> creep(moved);
  creep[100] = translated(creep[100], Eigen::Vector3d(0.6 * threshold, 0.0, 0.0));
  EXPECT_FALSE(search.update(creep, l.radius));
  creep[100] = translated(creep[100], Eigen::Vector3d(0.6 * threshold, 0.0, 0.0));
  EXPECT_TRUE(search.update(creep, l.radius));
  EXPECT_EQ(search.candidates(), brute_force_candidates(l.segments, groups, o, creep, l.radius));

  // A growing radius counts as motion as well.
  std::vector<double> fatter(l.radius);
  fatter[5] += 1.1 * threshold;
  EXPECT_TRUE(search.update(creep, fatter));
  EXPECT_EQ(search.candidates(), brute_force_candidates(l.segments, groups, o, creep, fatter));
}

// The refresh rule at its limit (refresh_fraction = 1): every box moves by up to the whole margin
// without a new search, towards or away from its neighbours. No pair whose radius-inflated boxes
// now overlap may be missing from the kept list.
TEST(Refresh, NoPairOutsideTheListComesIntoContactBeforeASearch) {
  const Layout l = random_layout(5000, 20, 1, 11u);
  CandidateSearchOptions o{.margin = 0.1, .refresh_fraction = 1.0, .self_contact = true};
  const std::vector<std::pair<int, int>> groups = {{0, 0}};
  CandidateSearch search(l.segments, groups, o);
  ASSERT_TRUE(search.update(l.boxes, l.radius));
  const auto kept = search.candidates();

  CandidateSearchOptions contact = o;
  contact.margin = 0.0;
  const auto in_contact_before =
      brute_force_candidates(l.segments, groups, contact, l.boxes, l.radius);

  std::mt19937_64 rng(17);
  std::uniform_int_distribution<int> sign(0, 1);
  const double step = 0.999 * o.margin;
  std::vector<Eigen::AlignedBox3d> moved(l.boxes);
  for (auto& b : moved) {
    const Eigen::Vector3d t(sign(rng) ? step : -step, sign(rng) ? step : -step,
                            sign(rng) ? step : -step);
    b = translated(b, t);
  }
  ASSERT_FALSE(search.update(moved, l.radius));
  ASSERT_EQ(search.candidates(), kept);

  const auto in_contact_after =
      brute_force_candidates(l.segments, groups, contact, moved, l.radius);
  std::vector<CandidatePair> missing, new_contacts;
  std::set_difference(in_contact_after.begin(), in_contact_after.end(), kept.begin(), kept.end(),
                      std::back_inserter(missing));
  std::set_difference(in_contact_after.begin(), in_contact_after.end(), in_contact_before.begin(),
                      in_contact_before.end(), std::back_inserter(new_contacts));
  EXPECT_TRUE(missing.empty()) << missing.size() << " pairs in contact but not candidates";
  // The motion did bring new pairs into contact, so the check above was not vacuous.
  EXPECT_GT(new_contacts.size(), 10u);
}

TEST(Determinism, SameCandidatesOnOneAndTwoThreads) {
  const Layout l = random_layout(20000, 25, 2, 21u);
  CandidateSearchOptions o{.margin = 0.1, .self_contact = true};
  std::vector<CandidatePair> one, two;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    one = search_once(l, all_of_two_groups, o);
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    two = search_once(l, all_of_two_groups, o);
  }
  ASSERT_FALSE(one.empty());
  EXPECT_EQ(one, two);
}

TEST(Determinism, RepeatedSearchesAfterMotionGiveTheSameList) {
  // The tree's history (built once, then refitted) must not change the result.
  const Layout l = random_layout(3000, 20, 1, 8u);
  CandidateSearchOptions o{.margin = 0.1, .self_contact = true};
  CandidateSearch search(l.segments, {{0, 0}}, o);
  ASSERT_TRUE(search.update(l.boxes, l.radius));
  std::vector<Eigen::AlignedBox3d> far(l.boxes);
  for (auto& b : far) {
    b = translated(b, Eigen::Vector3d(3.0, -2.0, 1.0));
  }
  ASSERT_TRUE(search.update(far, l.radius));
  ASSERT_TRUE(search.update(l.boxes, l.radius));
  EXPECT_EQ(search.candidates(),
            brute_force_candidates(l.segments, one_group, o, l.boxes, l.radius));
}

/// The pairs of `all` with at least one segment in `own`.
std::vector<CandidatePair> with_a_segment_in(const std::vector<CandidatePair>& all,
                                             const std::vector<char>& own) {
  std::vector<CandidatePair> out;
  std::copy_if(all.begin(), all.end(), std::back_inserter(out),
               [&](const CandidatePair& p) { return own[p.first] || own[p.second]; });
  return out;
}

TEST(Share, EachProcessFindsThePairsWithASegmentInItsShare) {
  // Three processes' shares of whole curves (contiguous curve ranges, as partition.hpp cuts),
  // over three groups of which two touch each other and one itself, self-contact on.
  const Layout l = random_layout(6000, 20, 3, 77u);
  const std::vector<std::pair<int, int>> groups = {{0, 1}, {2, 2}, {1, 2}};
  CandidateSearchOptions o{.margin = 0.1, .same_curve_skip = 2, .self_contact = true};
  const auto whole = brute_force_candidates(l.segments, groups, o, l.boxes, l.radius);
  const int curves = l.segments.back().curve + 1;
  std::set<CandidatePair> found;
  std::size_t across = 0; // pairs whose segments lie in two shares
  for (int rank = 0; rank < 3; ++rank) {
    std::vector<char> own(l.segments.size());
    for (std::size_t i = 0; i < own.size(); ++i)
      own[i] = l.segments[i].curve * 3 / curves == rank;
    CandidateSearch search(l.segments, groups, o);
    search.set_share(own);
    ASSERT_TRUE(search.update(l.boxes, l.radius));
    const auto expected = with_a_segment_in(whole, own);
    ASSERT_FALSE(expected.empty());
    EXPECT_EQ(search.candidates(), expected) << "rank " << rank;
    for (const CandidatePair& p : search.candidates()) {
      found.insert(p);
      across += own[p.first] != own[p.second];
    }
  }
  // Every pair of the whole search is found by the share of one of its segments.
  EXPECT_EQ(std::vector<CandidatePair>(found.begin(), found.end()), whole);
  EXPECT_GT(across, 0u) << "no pair across two shares: the layout tests nothing";
}

TEST(Share, ANewShareSearchesTheLastBoxesAgainAndKeepsTheMotionReference) {
  const Layout l = random_layout(3000, 20, 2, 78u);
  CandidateSearchOptions o{.margin = 0.1, .refresh_fraction = 0.5, .self_contact = true};
  CandidateSearch search(l.segments, all_of_two_groups, o);
  ASSERT_TRUE(search.update(l.boxes, l.radius));
  const auto whole = search.candidates();
  // Every box moved by 0.9 of the refresh threshold: not searched again.
  std::vector<Eigen::AlignedBox3d> moved(l.boxes);
  for (auto& b : moved)
    b = translated(b, Eigen::Vector3d::Constant(0.9 * o.refresh_fraction * o.margin));
  EXPECT_FALSE(search.update(moved, l.radius));
  std::vector<char> own(l.segments.size());
  for (std::size_t i = 0; i < own.size(); ++i)
    own[i] = l.segments[i].curve % 2;
  search.set_share(own);
  // The share's pairs of the search made on the first boxes, and still no search for the motion.
  EXPECT_EQ(search.candidates(), with_a_segment_in(whole, own));
  ASSERT_EQ(search.searched_boxes().size(), l.boxes.size());
  for (std::size_t i = 0; i < l.boxes.size(); ++i)
    ASSERT_TRUE(search.searched_boxes()[i].isApprox(l.boxes[i], 0.0)) << "segment " << i;
  EXPECT_FALSE(search.update(moved, l.radius));
  EXPECT_EQ(search.statistics().searches, 2);
  // Back to every segment (all flags, or none): the whole search again.
  search.set_share(std::vector<char>(own.size(), 1));
  EXPECT_EQ(search.candidates(), whole);
  EXPECT_THROW(search.set_share(std::vector<char>(3, 1)), std::invalid_argument);
}

TEST(Inputs, BadInputsThrow) {
  const Layout l = straight_curves({0.0, 1.0}, 5);
  CandidateSearchOptions o{.margin = 0.1};
  EXPECT_THROW(CandidateSearch(l.segments, {}, {.margin = -1.0}), std::invalid_argument);
  EXPECT_THROW(CandidateSearch(l.segments, {}, {.margin = 0.1, .refresh_fraction = 1.5}),
               std::invalid_argument);
  EXPECT_THROW(CandidateSearch(l.segments, {}, {.margin = 0.1, .refresh_fraction = 0.0}),
               std::invalid_argument);
  EXPECT_THROW(CandidateSearch(l.segments, {{-1, 0}}, o), std::invalid_argument);
  std::vector<SegmentInfo> bad_group(l.segments);
  bad_group[3].group = -2;
  EXPECT_THROW(CandidateSearch(bad_group, {}, o), std::invalid_argument);

  CandidateSearch search(l.segments, {{0, 1}}, o);
  std::vector<Eigen::AlignedBox3d> short_boxes(l.boxes.begin(), l.boxes.end() - 1);
  EXPECT_THROW(search.update(short_boxes, l.radius), std::invalid_argument);
  std::vector<Eigen::AlignedBox3d> empty_box(l.boxes);
  empty_box[4] = Eigen::AlignedBox3d(); // empty
  EXPECT_THROW(search.update(empty_box, l.radius), std::invalid_argument);
  std::vector<double> negative(l.radius);
  negative[2] = -0.1;
  EXPECT_THROW(search.update(l.boxes, negative), std::invalid_argument);
  std::vector<double> nan(l.radius);
  nan[1] = std::nan("");
  EXPECT_THROW(search.update(l.boxes, nan), std::invalid_argument);
  EXPECT_EQ(search.statistics().updates, 0);
  EXPECT_TRUE(search.update(l.boxes, l.radius));
}

TEST(Inputs, NoSegments) {
  CandidateSearch search({}, {}, {.margin = 0.1});
  EXPECT_TRUE(search.update({}, {}));
  EXPECT_TRUE(search.candidates().empty());
  EXPECT_FALSE(search.update({}, {}));
}

} // namespace
} // namespace yarnsim::broadphase
