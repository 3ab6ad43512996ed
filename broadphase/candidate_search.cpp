#include "broadphase/candidate_search.hpp"

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/narrowphase/collision_object.h>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <string>

namespace yarnsim::broadphase {

namespace {

/// Segments per task in the parallel loops; large enough that small problems run in one task.
constexpr int grain_size = 4096;

/// Centre and half-extent of an inflated box, metres. Not inlined so that every caller, the tree
/// and the brute force alike, gets the same bits whatever the compiler's contraction choices.
struct CentreHalf {
  Eigen::Vector3d centre;
  Eigen::Vector3d half;
};

[[gnu::noinline]] CentreHalf centre_half(const Eigen::AlignedBox3d& tight, double radius,
                                         double margin) {
  const double grow = radius + margin;
  CentreHalf out;
  for (int k = 0; k < 3; ++k) {
    const double lo = tight.min()[k];
    const double hi = tight.max()[k];
    out.centre[k] = 0.5 * (lo + hi);
    out.half[k] = 0.5 * (hi - lo);
    out.half[k] += grow;
  }
  return out;
}

void check_options(const CandidateSearchOptions& o) {
  if (!(std::isfinite(o.margin) && o.margin >= 0.0)) {
    throw std::invalid_argument("CandidateSearchOptions: expected margin >= 0 (finite), found " +
                                std::to_string(o.margin));
  }
  if (!(o.refresh_fraction > 0.0 && o.refresh_fraction <= 1.0)) {
    throw std::invalid_argument(
        "CandidateSearchOptions: expected refresh_fraction in (0, 1] (a larger fraction lets a "
        "pair outside the list come into contact), found " +
        std::to_string(o.refresh_fraction));
  }
  if (o.same_curve_skip < 0) {
    throw std::invalid_argument("CandidateSearchOptions: expected same_curve_skip >= 0, found " +
                                std::to_string(o.same_curve_skip));
  }
}

/// Which pairs of segments may be candidates, from topology and contact groups alone.
class PairFilter {
public:
  PairFilter(std::vector<SegmentInfo> segments, std::span<const std::pair<int, int>> group_pairs,
             const CandidateSearchOptions& options)
      : segments_(std::move(segments)), skip_(options.same_curve_skip),
        self_contact_(options.self_contact) {
    check_options(options);
    int max_group = -1;
    for (std::size_t i = 0; i < segments_.size(); ++i) {
      if (segments_[i].group < 0) {
        throw std::invalid_argument(
            "CandidateSearch: expected group >= 0 for every segment, found " +
            std::to_string(segments_[i].group) + " at segment " + std::to_string(i));
      }
      max_group = std::max(max_group, segments_[i].group);
    }
    for (const auto& [a, b] : group_pairs) {
      if (a < 0 || b < 0) {
        throw std::invalid_argument("CandidateSearch: expected group pairs of ids >= 0, found (" +
                                    std::to_string(a) + ", " + std::to_string(b) + ")");
      }
    }
    if (segments_.size() > static_cast<std::size_t>(std::numeric_limits<int>::max())) {
      throw std::invalid_argument("CandidateSearch: too many segments for int ids: " +
                                  std::to_string(segments_.size()));
    }
    num_groups_ = max_group + 1;
    allowed_.assign(static_cast<std::size_t>(num_groups_) * num_groups_, 0);
    for (const auto& [a, b] : group_pairs) {
      if (a < num_groups_ && b < num_groups_) { // a group no segment has allows nothing
        allowed_[static_cast<std::size_t>(a) * num_groups_ + b] = 1;
        allowed_[static_cast<std::size_t>(b) * num_groups_ + a] = 1;
      }
    }
  }

  int size() const { return static_cast<int>(segments_.size()); }
  int num_groups() const { return num_groups_; }
  int group(int segment) const { return segments_[segment].group; }
  /// Whether segments of groups a and b may touch.
  bool groups_touch(int a, int b) const {
    return allowed_[static_cast<std::size_t>(a) * num_groups_ + b] != 0;
  }

  /// Whether segments a != b may form a candidate pair.
  bool allows(int a, int b) const {
    const SegmentInfo& sa = segments_[a];
    const SegmentInfo& sb = segments_[b];
    if (sa.curve == sb.curve) {
      if (!self_contact_) {
        return false;
      }
      const std::int64_t gap = std::llabs(static_cast<std::int64_t>(sa.index_on_curve) -
                                          static_cast<std::int64_t>(sb.index_on_curve));
      if (gap <= skip_) {
        return false;
      }
    }
    return groups_touch(sa.group, sb.group);
  }

private:
  std::vector<SegmentInfo> segments_;
  int skip_;
  bool self_contact_;
  int num_groups_ = 0;
  std::vector<char> allowed_; ///< num_groups x num_groups, row-major, symmetric
};

bool valid_box(const Eigen::AlignedBox3d& b) {
  return b.min().allFinite() && b.max().allFinite() && (b.min().array() <= b.max().array()).all();
}

bool valid_radius(double r) {
  return std::isfinite(r) && r >= 0.0;
}

void check_sizes(int n, std::span<const Eigen::AlignedBox3d> boxes,
                 std::span<const double> radius) {
  if (boxes.size() != static_cast<std::size_t>(n) || radius.size() != static_cast<std::size_t>(n)) {
    throw std::invalid_argument("CandidateSearch: expected " + std::to_string(n) +
                                " boxes and radii (one per segment), found " +
                                std::to_string(boxes.size()) + " boxes and " +
                                std::to_string(radius.size()) + " radii");
  }
}

[[noreturn]] void throw_bad_input(int i, const Eigen::AlignedBox3d& b, double r) {
  auto vec = [](const Eigen::Vector3d& v) {
    return "(" + std::to_string(v[0]) + ", " + std::to_string(v[1]) + ", " + std::to_string(v[2]) +
           ")";
  };
  throw std::invalid_argument(
      "CandidateSearch: expected a finite, non-empty box and a finite radius >= 0 for segment " +
      std::to_string(i) + ", found box min " + vec(b.min()) + ", max " + vec(b.max()) +
      ", radius " + std::to_string(r));
}

/// Sorts canonical pairs by (first, second) and removes duplicates: a counting sort on first
/// (linear in pairs + segments), then a sort of each short run on second.
void sort_unique(std::vector<CandidatePair>& pairs, int num_segments,
                 std::vector<CandidatePair>& scratch, std::vector<int>& offsets) {
  offsets.assign(static_cast<std::size_t>(num_segments) + 1, 0);
  for (const CandidatePair& p : pairs) {
    ++offsets[p.first + 1];
  }
  for (int i = 0; i < num_segments; ++i) {
    offsets[i + 1] += offsets[i];
  }
  scratch.resize(pairs.size());
  for (const CandidatePair& p : pairs) {
    scratch[offsets[p.first]++] = p;
  }
  // offsets[i] is now the end of run i, which starts at offsets[i - 1] (0 for i = 0). The runs
  // are disjoint, so sorting them in parallel gives the same result on any thread count.
  tbb::parallel_for(tbb::blocked_range<int>(0, num_segments, grain_size),
                    [&](const tbb::blocked_range<int>& range) {
                      for (int i = range.begin(); i != range.end(); ++i) {
                        const int begin = i == 0 ? 0 : offsets[i - 1];
                        const int end = offsets[i];
                        if (end - begin > 1) {
                          std::sort(scratch.begin() + begin, scratch.begin() + end);
                        }
                      }
                    });
  scratch.erase(std::unique(scratch.begin(), scratch.end()), scratch.end());
  pairs.swap(scratch);
}

/// State handed to FCL's collision callback through void*.
struct CollideState {
  const PairFilter* filter;
  std::vector<CandidatePair>* pairs;
  std::int64_t reported = 0;
};

int segment_id(const fcl::CollisionObjectd* o) {
  return static_cast<int>(reinterpret_cast<std::intptr_t>(o->getUserData()));
}

/// Fits an object to an inflated box. The box keeps the identity rotation, so its world box is
/// exactly centre -+ half (a rotated box would get a cube around its bounding sphere). FCL does
/// not refresh an object's box on a move: computeLocalAABB() after the resize and computeAABB()
/// after the translation are needed, or every pair overlaps.
void place(fcl::Boxd& shape, fcl::CollisionObjectd& object, const CentreHalf& ch) {
  shape.side = 2.0 * ch.half; // FCL halves it back exactly
  shape.computeLocalAABB();
  object.setTranslation(ch.centre);
  object.computeAABB();
}

/// FCL calls this for every pair of objects whose world boxes overlap; returns false to go on.
bool collect_pair(fcl::CollisionObjectd* o1, fcl::CollisionObjectd* o2, void* data) {
  auto& state = *static_cast<CollideState*>(data);
  ++state.reported;
  int a = segment_id(o1);
  int b = segment_id(o2);
  if (a > b) {
    std::swap(a, b);
  }
  if (a != b && state.filter->allows(a, b)) {
    state.pairs->push_back({a, b});
  }
  return false;
}

/// Result of the parallel scan over the inputs: the largest motion and the first bad segment.
struct Scan {
  double motion = 0.0;
  int first_bad = std::numeric_limits<int>::max();
};

} // namespace

Eigen::AlignedBox3d inflated_box(const Eigen::AlignedBox3d& tight, double radius, double margin) {
  const CentreHalf ch = centre_half(tight, radius, margin);
  return Eigen::AlignedBox3d(ch.centre - ch.half, ch.centre + ch.half);
}

struct CandidateSearch::Impl {
  Impl(std::vector<SegmentInfo> segments, std::span<const std::pair<int, int>> group_pairs,
       const CandidateSearchOptions& opts)
      : filter(std::move(segments), group_pairs, opts), options(opts) {
    contact_boxes.resize(filter.size());
  }

  bool in_share(int segment) const { return own.empty() || own[segment] != 0; }

  /// The FCL objects of the segments in the share (every segment without one), one tree per
  /// contact group that may touch some group: pairs between groups that may not touch (warp
  /// with warp in a plain weave, say) are then never visited. Built at the first search after
  /// construction or a new share (a share set before the first search builds no other objects).
  void build_trees() {
    built = true;
    const int n = filter.size();
    const int g = filter.num_groups();
    scope.clear();
    others.clear();
    for (int i = 0; i < n; ++i)
      (in_share(i) ? scope : others).push_back(i);
    shapes.clear();
    objects.clear();
    shapes.reserve(scope.size());
    objects.reserve(scope.size());
    members.assign(g, {});
    for (const int i : scope) {
      shapes.push_back(std::make_shared<fcl::Boxd>(0.0, 0.0, 0.0));
      objects.push_back(std::make_unique<fcl::CollisionObjectd>(shapes.back()));
      objects.back()->setUserData(reinterpret_cast<void*>(static_cast<std::intptr_t>(i)));
      members[filter.group(i)].push_back(objects.back().get());
    }
    trees.clear();
    trees.resize(g);
    tree_pairs.clear();
    for (int a = 0; a < g; ++a) {
      for (int b = a; b < g; ++b) {
        if (filter.groups_touch(a, b) && !members[a].empty() && !members[b].empty()) {
          tree_pairs.emplace_back(a, b);
          for (const int t : {a, b}) {
            if (!trees[t]) {
              trees[t] = std::make_unique<fcl::DynamicAABBTreeCollisionManagerd>();
            }
          }
        }
      }
    }
    // A segment outside the share is queried against the trees of the groups its own touches.
    if (!own.empty()) {
      for (int a = 0; a < g; ++a) {
        if (members[a].empty() || trees[a]) {
          continue;
        }
        for (int b = 0; b < g; ++b) {
          if (filter.groups_touch(a, b)) {
            trees[a] = std::make_unique<fcl::DynamicAABBTreeCollisionManagerd>();
            break;
          }
        }
      }
    }
  }

  /// Checks the inputs and measures the motion since the last search (0 before the first).
  Scan scan(std::span<const Eigen::AlignedBox3d> boxes, std::span<const double> radius) const {
    const bool measure = stats.searches > 0;
    // Both max and min are exact and order-free, so the reduction is deterministic.
    return tbb::parallel_reduce(
        tbb::blocked_range<int>(0, filter.size(), grain_size), Scan{},
        [&](const tbb::blocked_range<int>& range, Scan s) {
          for (int i = range.begin(); i != range.end(); ++i) {
            const Eigen::AlignedBox3d& b = boxes[i];
            const double r = radius[i];
            if (!valid_box(b) || !valid_radius(r)) {
              s.first_bad = std::min(s.first_bad, i);
              continue;
            }
            if (measure) {
              const Eigen::AlignedBox3d& old = contact_boxes[i];
              const Eigen::Vector3d lo = b.min().array() - r;
              const Eigen::Vector3d hi = b.max().array() + r;
              const double d = std::max((old.min() - lo).maxCoeff(), (hi - old.max()).maxCoeff());
              s.motion = std::max(s.motion, d);
            }
          }
          return s;
        },
        [](Scan a, const Scan& b) {
          a.motion = std::max(a.motion, b.motion);
          a.first_bad = std::min(a.first_bad, b.first_bad);
          return a;
        },
        tbb::static_partitioner());
  }

  void search(std::span<const Eigen::AlignedBox3d> boxes, std::span<const double> radius) {
    const auto start = std::chrono::steady_clock::now();
    searched.assign(boxes.begin(), boxes.end());
    searched_radius.assign(radius.begin(), radius.end());
    if (!built) {
      build_trees();
    }
    const int n = filter.size();
    const double margin = options.margin;
    tbb::parallel_for(
        tbb::blocked_range<int>(0, n, grain_size), [&](const tbb::blocked_range<int>& range) {
          for (int i = range.begin(); i != range.end(); ++i) {
            contact_boxes[i] = Eigen::AlignedBox3d(boxes[i].min().array() - radius[i],
                                                   boxes[i].max().array() + radius[i]);
          }
        });
    // Refit every object (the share's) to its inflated box (place).
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, scope.size(), grain_size),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                        for (std::size_t k = range.begin(); k != range.end(); ++k) {
                          const int i = scope[k];
                          place(*shapes[k], *objects[k], centre_half(boxes[i], radius[i], margin));
                        }
                      });
    for (std::size_t g = 0; g < trees.size(); ++g) {
      if (!trees[g]) {
        continue;
      }
      if (trees[g]->empty()) {
        // Built from the real boxes on the first search, the tree starts balanced.
        trees[g]->registerObjects(members[g]);
      }
      trees[g]->update(); // refits the tree to the objects' boxes and rebalances it
    }

    pairs.clear();
    CollideState state{&filter, &pairs};
    for (const auto& [a, b] : tree_pairs) { // sequential traversals
      if (a == b) {
        trees[a]->collide(&state, &collect_pair);
      } else {
        trees[a]->collide(trees[b].get(), &state, &collect_pair);
      }
    }
    // The segments outside the share, each queried against the share's trees of the groups it
    // may touch (a tree is only read by a query, so they run in parallel, each thread with its
    // own box and list).
    std::int64_t reported = state.reported;
    if (!own.empty() && !others.empty()) {
      struct Query {
        std::shared_ptr<fcl::Boxd> shape = std::make_shared<fcl::Boxd>(0.0, 0.0, 0.0);
        fcl::CollisionObjectd object{shape};
        std::vector<CandidatePair> pairs;
        std::int64_t reported = 0;
      };
      tbb::enumerable_thread_specific<Query> queries;
      tbb::parallel_for(
          tbb::blocked_range<std::size_t>(0, others.size(), 256),
          [&](const tbb::blocked_range<std::size_t>& range) {
            Query& q = queries.local();
            CollideState local{&filter, &q.pairs};
            for (std::size_t k = range.begin(); k != range.end(); ++k) {
              const int j = others[k];
              q.object.setUserData(reinterpret_cast<void*>(static_cast<std::intptr_t>(j)));
              place(*q.shape, q.object, centre_half(boxes[j], radius[j], margin));
              for (int a = 0; a < filter.num_groups(); ++a) {
                if (trees[a] && !members[a].empty() && filter.groups_touch(a, filter.group(j))) {
                  trees[a]->collide(&q.object, &local, &collect_pair);
                }
              }
            }
            q.reported += local.reported;
          });
      for (Query& q : queries) {
        pairs.insert(pairs.end(), q.pairs.begin(), q.pairs.end());
        reported += q.reported;
      }
    }
    // The traversal order depends on the tree's history: sort so that nothing downstream does.
    sort_unique(pairs, n, scratch, offsets);

    stats.reported_pairs = reported;
    stats.last_search_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ++stats.searches;
  }

  PairFilter filter;
  CandidateSearchOptions options;
  /// Per segment in the share (scope's order), its box, shared with its object.
  std::vector<std::shared_ptr<fcl::Boxd>> shapes;
  std::vector<std::unique_ptr<fcl::CollisionObjectd>> objects; ///< user data: segment id
  std::vector<std::vector<fcl::CollisionObjectd*>> members;    ///< per group, its objects
  /// Per group, its tree, or null when the group may touch no group.
  std::vector<std::unique_ptr<fcl::DynamicAABBTreeCollisionManagerd>> trees;
  std::vector<std::pair<int, int>> tree_pairs; ///< (a, b), a <= b, whose trees are collided
  /// Per segment, whether it is in this process's share (set_share); empty: every segment.
  std::vector<char> own;
  std::vector<int> scope;  ///< the segments in the share, which have objects in the trees
  std::vector<int> others; ///< the segments outside it, queried against the trees
  bool built = false;      ///< the objects and trees are the share's (build_trees)
  /// Per segment, its box inflated by the radius only at the last search, metres.
  std::vector<Eigen::AlignedBox3d> contact_boxes;
  std::vector<CandidatePair> pairs;          ///< the candidates
  std::vector<Eigen::AlignedBox3d> searched; ///< tight boxes of the last search, metres
  std::vector<double> searched_radius;       ///< radii of the last search, metres
  std::vector<CandidatePair> scratch;
  std::vector<int> offsets;
  CandidateSearchStatistics stats;
};

CandidateSearch::CandidateSearch(std::vector<SegmentInfo> segments,
                                 std::vector<std::pair<int, int>> group_pairs,
                                 CandidateSearchOptions options)
    : impl_(std::make_unique<Impl>(std::move(segments), group_pairs, options)) {}

CandidateSearch::~CandidateSearch() = default;
CandidateSearch::CandidateSearch(CandidateSearch&&) noexcept = default;
CandidateSearch& CandidateSearch::operator=(CandidateSearch&&) noexcept = default;

bool CandidateSearch::update(std::span<const Eigen::AlignedBox3d> tight_boxes,
                             std::span<const double> radius, bool force) {
  Impl& m = *impl_;
  check_sizes(m.filter.size(), tight_boxes, radius);
  const Scan s = m.scan(tight_boxes, radius);
  if (s.first_bad < m.filter.size()) {
    throw_bad_input(s.first_bad, tight_boxes[s.first_bad], radius[s.first_bad]);
  }
  ++m.stats.updates;
  m.stats.motion_since_search = s.motion;
  // See the header for why motion <= refresh_fraction * margin (<= margin) per box is safe.
  const bool keep =
      m.stats.searches > 0 && !force && s.motion <= m.options.refresh_fraction * m.options.margin;
  if (keep) {
    return false;
  }
  m.search(tight_boxes, radius);
  return true;
}

void CandidateSearch::set_share(std::vector<char> own) {
  Impl& m = *impl_;
  if (!own.empty() && own.size() != static_cast<std::size_t>(m.filter.size())) {
    throw std::invalid_argument(
        "CandidateSearch::set_share: expected " + std::to_string(m.filter.size()) +
        " flags (one per segment) or none, found " + std::to_string(own.size()));
  }
  if (!own.empty() && std::all_of(own.begin(), own.end(), [](char c) { return c != 0; })) {
    own.clear(); // every segment: the whole search
  }
  if (own == m.own) {
    return;
  }
  m.own = std::move(own);
  m.built = false;
  // The last search again, on its own boxes: the candidates are the whole search's that the
  // share holds, and the motion test keeps its reference (searched where a whole search would).
  if (m.stats.searches > 0) {
    // Copies: search() writes its boxes into `searched` first.
    const std::vector<Eigen::AlignedBox3d> boxes = m.searched;
    const std::vector<double> radius = m.searched_radius;
    m.search(boxes, radius);
  }
}

const std::vector<CandidatePair>& CandidateSearch::candidates() const {
  return impl_->pairs;
}

const std::vector<Eigen::AlignedBox3d>& CandidateSearch::searched_boxes() const {
  return impl_->searched;
}

const CandidateSearchStatistics& CandidateSearch::statistics() const {
  return impl_->stats;
}

int CandidateSearch::num_segments() const {
  return impl_->filter.size();
}

const CandidateSearchOptions& CandidateSearch::options() const {
  return impl_->options;
}

std::vector<CandidatePair> brute_force_candidates(std::span<const SegmentInfo> segments,
                                                  std::span<const std::pair<int, int>> group_pairs,
                                                  const CandidateSearchOptions& options,
                                                  std::span<const Eigen::AlignedBox3d> tight_boxes,
                                                  std::span<const double> radius) {
  const PairFilter filter(std::vector<SegmentInfo>(segments.begin(), segments.end()), group_pairs,
                          options);
  const int n = filter.size();
  check_sizes(n, tight_boxes, radius);
  // Inflated boxes as structure of arrays: lo[k][i], hi[k][i].
  std::vector<double> lo[3], hi[3];
  for (int k = 0; k < 3; ++k) {
    lo[k].resize(n);
    hi[k].resize(n);
  }
  for (int i = 0; i < n; ++i) {
    if (!valid_box(tight_boxes[i]) || !valid_radius(radius[i])) {
      throw_bad_input(i, tight_boxes[i], radius[i]);
    }
    const Eigen::AlignedBox3d b = inflated_box(tight_boxes[i], radius[i], options.margin);
    for (int k = 0; k < 3; ++k) {
      lo[k][i] = b.min()[k];
      hi[k][i] = b.max()[k];
    }
  }
  std::vector<CandidatePair> out;
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      // Overlap with touching included, as fcl::AABB::overlap.
      const bool overlap = !(lo[0][i] > hi[0][j] || lo[0][j] > hi[0][i] || lo[1][i] > hi[1][j] ||
                             lo[1][j] > hi[1][i] || lo[2][i] > hi[2][j] || lo[2][j] > hi[2][i]);
      if (overlap && filter.allows(i, j)) {
        out.push_back({i, j});
      }
    }
  }
  return out;
}

} // namespace yarnsim::broadphase
