#pragma once

// Broad phase: candidate pairs of contact segments whose inflated axis-aligned boxes overlap.
//
// Each contact segment is bounded by the axis-aligned box of its current geometry (for instance
// of its control points), inflated by its section radius plus a margin. Pairs of segments whose
// inflated boxes overlap, and whose topology allows contact, are the candidates handed to the
// narrow phase. The candidate list is kept across Newton iterations and searched again only when
// some box has moved far enough that a pair outside the list could come into contact.
//
// The search is backed by FCL's dynamic AABB trees, one per contact group, each tree collided with
// itself or another for every pair of groups that may touch; FCL stays inside
// candidate_search.cpp. A process of a run over several (MPI) searches its share alone
// (set_share): its segments in the trees, every other segment's box queried against them.

#include <Eigen/Geometry>

#include <compare>
#include <cstdint>
#include <memory>
#include <span>
#include <utility>
#include <vector>

namespace yarnsim::broadphase {

/// Topology of one contact segment: the curve (yarn) it lies on, its index along that curve, and
/// its contact group (for instance warp, weft, or a rigid tool).
struct SegmentInfo {
  int curve = 0;
  int index_on_curve = 0;
  int group = 0; ///< >= 0
};

/// A candidate pair of segment ids (indices into the segment list), first < second.
struct CandidatePair {
  int first = 0;
  int second = 0;
  auto operator<=>(const CandidatePair&) const = default;
};

/// How boxes are inflated, when the list is searched again, and which pairs are never candidates.
struct CandidateSearchOptions {
  /// Metres, >= 0: added to each box beyond the section radius.
  double margin = 0.0;
  /// In (0, 1]: search again when some segment's box has moved more than
  /// refresh_fraction * margin since the last search (see CandidateSearch::update).
  double refresh_fraction = 0.5;
  /// >= 0: segments on one curve with |index difference| <= same_curve_skip are never candidates
  /// (neighbours along a yarn always overlap).
  int same_curve_skip = 1;
  /// If false, no pairs between segments of the same curve at all.
  bool self_contact = false;
};

/// Counters of a CandidateSearch since its construction.
struct CandidateSearchStatistics {
  std::int64_t updates = 0;         ///< calls to update()
  std::int64_t searches = 0;        ///< calls to update() that searched (rebuilt the list)
  std::int64_t reported_pairs = 0;  ///< box overlaps found by the last search, before filtering
  double last_search_seconds = 0.0; ///< wall time of the last search (refit, tree, sort)
  double motion_since_search = 0.0; ///< metres, the largest box motion seen by the last update
};

/// The box used for candidate tests: `tight` grown by `radius + margin` on every side.
/// It is computed as centre +- half-extent, the exact arithmetic the tree uses, so that the
/// reference brute_force_candidates and CandidateSearch agree to the last bit.
/// tight: metres, not empty; radius, margin: metres, >= 0.
Eigen::AlignedBox3d inflated_box(const Eigen::AlignedBox3d& tight, double radius, double margin);

/// Candidate pairs of contact segments, kept across Newton iterations and refreshed on motion.
///
/// Usage: construct once per topology; call update() with the current boxes at each Newton
/// iteration; when it returns true the list changed, so rebuild whatever depends on it.
class CandidateSearch {
public:
  /// segments: topology per segment (segment id = index in this list).
  /// group_pairs: the (group, group) pairs that may touch; symmetric, (g, g) allows contact
  /// within group g only when listed. Throws std::invalid_argument on bad options or negative
  /// group ids.
  CandidateSearch(std::vector<SegmentInfo> segments, std::vector<std::pair<int, int>> group_pairs,
                  CandidateSearchOptions options);
  ~CandidateSearch();
  CandidateSearch(CandidateSearch&&) noexcept;
  CandidateSearch& operator=(CandidateSearch&&) noexcept;
  CandidateSearch(const CandidateSearch&) = delete;
  CandidateSearch& operator=(const CandidateSearch&) = delete;

  /// tight_boxes: per segment, the axis-aligned box of its current geometry, metres;
  /// radius: per segment, the section radius, metres. Both of size num_segments().
  ///
  /// Searches again (refits the tree to the inflated boxes and rebuilds the list) on the first
  /// call, when force is true, or when the motion since the last search exceeds
  /// refresh_fraction * margin; otherwise keeps the list. Returns true if it searched.
  ///
  /// Motion of segment i: the smallest d_i >= 0 such that its current radius-inflated box lies
  /// within its radius-inflated box at the last search grown by d_i on every side.
  /// Why this is safe: a pair (i, j) left out at the last search had disjoint
  /// (radius + margin)-inflated boxes, so along some axis its radius-inflated boxes were more
  /// than 2 * margin apart. Without a new search d_i, d_j <= refresh_fraction * margin <= margin,
  /// so that gap is still more than 2 * margin - d_i - d_j >= 0: the radius-inflated boxes of
  /// (i, j) do not overlap, and no pair missing from the list can be in contact. With the
  /// default fraction 0.5 the two boxes together close at most one margin of the two.
  ///
  /// Throws std::invalid_argument on wrong sizes, empty or non-finite boxes, or a negative or
  /// non-finite radius.
  bool update(std::span<const Eigen::AlignedBox3d> tight_boxes, std::span<const double> radius,
              bool force = false);

  /// A process's share of a run over several (MPI, engine/model/partition.hpp): one flag per
  /// segment, those of the segments whose pairs the process may own; empty (the default), or
  /// every flag set: every segment. The candidates are then the pairs with at least one segment
  /// in the share, found by that segment's process (a pair across two shares by both): only the
  /// share's segments have objects in FCL's trees, and each segment outside it is queried
  /// against them. The motion test still sees every segment, so that every process searches
  /// at the same updates as one process would. Where a search was made, it is made again on
  /// its own boxes: the candidates are that search's that the share holds. Throws
  /// std::invalid_argument for a size other than num_segments() or 0.
  void set_share(std::vector<char> own);

  /// The candidates of the last search: canonical (first < second), sorted, without duplicates;
  /// independent of thread count and of the tree's traversal order. Empty before update().
  /// Within a share (set_share), those with at least one segment in it.
  const std::vector<CandidatePair>& candidates() const;

  /// The tight boxes of the last search, metres (empty before it): searched again (update with
  /// force), they give the same candidates and the same reference for the motion test, as a
  /// restart needs (engine/solver/checkpoint.hpp).
  const std::vector<Eigen::AlignedBox3d>& searched_boxes() const;

  const CandidateSearchStatistics& statistics() const;
  int num_segments() const;
  const CandidateSearchOptions& options() const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Reference for tests: all pairs whose inflated boxes (inflated_box) overlap, touching
/// included, with the same topology and group filters as CandidateSearch; O(n^2).
/// Returns the pairs canonical and sorted. Throws std::invalid_argument as CandidateSearch does.
std::vector<CandidatePair> brute_force_candidates(std::span<const SegmentInfo> segments,
                                                  std::span<const std::pair<int, int>> group_pairs,
                                                  const CandidateSearchOptions& options,
                                                  std::span<const Eigen::AlignedBox3d> tight_boxes,
                                                  std::span<const double> radius);

} // namespace yarnsim::broadphase
