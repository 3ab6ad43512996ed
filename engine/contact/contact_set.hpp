#pragma once
// The contact stage of a Newton iteration, whatever the formulation: broad phase (candidate pairs
// kept across iterations) -> narrow phase (projections of all candidates in parallel, warm-started
// from the last converged increment) -> assembly of the active pairs in sorted order, so the sums
// do not depend on the thread count. ContactSet is one formulation's stage (spline_contact_set.hpp,
// surface_contact_set.hpp); ContactStage (contact_stage.hpp) runs all of a model's, in a fixed
// order.

#include "contact/spline_contact.hpp" // ProjectionStatus
#include "engine/contact/contact_target.hpp"
#include "engine/model/model.hpp"
#include "engine/model/partition.hpp"
#include "engine/state/state.hpp"

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cstdint>
#include <fmt/format.h>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <vector>

namespace yarnsim {

/// An active contact point, for output.
struct ContactPoint {
  Eigen::Vector3d position; ///< midpoint of the two contact points, m
  Eigen::Vector3d normal;   ///< from B to A
  double gap = 0;           ///< signed gap, m; negative: penetration
  double force = 0;         ///< normal force, N
  /// Friction (contacts with friction): the tangential force on A (on B the opposite), N; the
  /// state, 0 frictionless, 1 stick, 2 slip; the slip accumulated since the point closed, m.
  Eigen::Vector3d tangential_force = Eigen::Vector3d::Zero();
  int friction = 0;
  double slip = 0;
  /// Torsional friction (contacts that have it): the friction torque about the normal, N m
  /// (contact/torsional_friction.hpp, signed as the elastic twist); the state, 0 none, 1 stick,
  /// 2 slip; the twist slip accumulated since the point closed, rad.
  double torque = 0;
  int twist = 0;
  double twist_slip = 0;
  // What the point lies on: the definition and the two segments of its pair (A, B).
  bool surface = false; ///< a surface contact (Model::surface_contacts), else a spline contact
  int definition = -1;  ///< index into Model::spline_contacts or Model::surface_contacts
  /// Index into Model::splines (spline contact) or Model::surfaces (surface contact).
  std::array<int, 2> body{-1, -1};
  /// Spline contact: the segment along the spline (0-based; segment i runs over the spline's
  /// control points i, i + 1, i + 2). Surface contact: the element (index into Model::elements).
  std::array<int, 2> segment{-1, -1};
  /// The pair's segment ids within its definition (its place in the set's sorted work list):
  /// points gathered over several processes are put back in this order.
  std::array<int, 2> pair{-1, -1};
};

/// Figures of the last evaluation, over all its pairs.
struct ContactSummary {
  int candidates = 0; ///< the pairs projected (over several processes, each process's own)
  /// The pairs the broad phase listed: over several processes, each process's share's (its own
  /// and those across its share's edge, which the other side owns), so that summed over them a
  /// pair across two shares counts twice; candidates on one process.
  int searched = 0;
  int active = 0;
  /// The active pairs counted as contact points before rounding to `active`: a spline pair 1, a
  /// surface pair its share (a contact near a node, held by two pairs, counts once in all).
  /// Parts (sets, processes) are summed before rounding (combine_summaries).
  double active_share = 0;
  double max_penetration = 0;  ///< m, over active pairs (0 if none)
  double max_force = 0;        ///< N
  double potential = 0;        ///< elastic energy stored in the active pairs, J
  double total_force = 0;      ///< sum of the normal forces of the active pairs, N
  int stick = 0;               ///< active points with friction in stick
  int slip = 0;                ///< active points with friction in slip
  double tangential_force = 0; ///< sum of the friction forces' magnitudes, N
  int twist_stick = 0;         ///< crossings with torsional friction whose twist sticks
  int twist_slip = 0;          ///< crossings with torsional friction whose twist slips
  double torque = 0;           ///< sum of the friction torques' magnitudes, N m
  /// Active points of frictional contacts that carry no friction: those on a degenerate path of
  /// the projection (spline: the point contact alone, `line_contact = false`, between nearly
  /// parallel segments; surface: parallel axes, flat faces, ridges), where the kernels have no
  /// sensitivity of the contact point (contact/friction.hpp, contact/surface_friction.hpp).
  int frictionless = 0;
  /// Energy dissipated by friction from the start up to this evaluation (the completed
  /// increments' and this iterate's slips), J.
  double dissipation = 0;
  /// Contact points that carried force in the last converged state and now lie past the end of
  /// a yarn, closer to its continued centre line (the end segment's polynomial) than the two
  /// radii: no pair carries them (spline contact: the curve ends, and no neighbouring segment
  /// takes the point over). A yarn slid off the end of another: at a specimen's free sides that
  /// is the yarns' ends parting; an edge yarn of a frictionless weave that slides off the
  /// crossing yarns' ends loses its support (docs/performance.md, "The hand-over at a knot,
  /// completed"). `off_end_yarns`: the first such point's yarns, indices into Model::splines,
  /// the one whose end it passed second; -1 when there is none.
  int off_end = 0;
  std::array<int, 2> off_end_yarns{-1, -1};
  /// Smallest signed gap over the pairs whose projection converged in range, m; +infinity when
  /// there is none. Before loading it is the clearance the formulation sees.
  double min_gap = 0;
  /// Fingerprint of which pairs are active (0 when none): it changes when a pair opens or
  /// closes, so the Newton iteration can tell a step that crossed the contact's kink.
  std::uint64_t active_set = 0;
};

/// Whether a pair's last projection asks for its coupling in the tangent's pattern
/// (ContactSet::couplings): active, or converged in range with a gap below `reach` (m, the
/// definition's broad-phase margin). Spline and surface results alike.
template <class Result>
bool needs_coupling(const Result& r, double reach) {
  return r.active || (r.status == contact::ProjectionStatus::Converged && r.gap < reach);
}

/// The matrix slots of a contact set's pairs' tangents, kept across evaluations: a pair's slots
/// stay valid while the set's work list and the matrix's pattern stay, so an evaluation looks up
/// only the pairs that became active since (find_active_slots). The set clears it whenever it
/// makes its work list anew (new candidates, a restore).
struct SlotCache {
  std::vector<int> offset;    ///< per work item: where its block starts in `store`, or -1
  std::vector<int> store;     ///< the blocks' slots (ContactTarget::*_block_slots)
  std::uint64_t pattern = 0;  ///< ContactTarget::pattern_id() they were looked up in
  std::vector<int> looked_up; ///< scratch: the work items looked up in this evaluation
  void clear() {
    offset.clear();
    store.clear();
    pattern = 0;
  }
  const int* slots(int item) const { return store.data() + offset[static_cast<std::size_t>(item)]; }
};

/// The smallest of limit(k) over k in [0, n), in parallel: ContactSet::closing_limit over a
/// set's work list. A minimum, so the same value on any thread count.
template <class Limit>
double smallest_limit(std::size_t n, Limit limit) {
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, 1024), std::numeric_limits<double>::infinity(),
      [&](const tbb::blocked_range<std::size_t>& range, double smallest) {
        for (std::size_t k = range.begin(); k != range.end(); ++k)
          smallest = std::min(smallest, limit(k));
        return smallest;
      },
      [](double a, double b) { return std::min(a, b); });
}

/// A pass over a contact set's work list for its summary and veto (summarise), in parallel. The
/// work items lie kilobytes apart, so a serial pass is a cache miss per item at the end of every
/// projection. `scan(w)` looks at item w and returns its gap if its projection converged in
/// range (else +infinity), whether it vetoes the evaluation, and whether it adds to the summary
/// (an active pair, say). The items are taken in fixed blocks, and the result is what one serial
/// pass gives, on any thread count: the smallest gap, the first vetoing item (-1 for none) and,
/// in `listed`, the items that add, in their order, for the set to sum serially.
struct WorkScan {
  double min_gap = std::numeric_limits<double>::infinity();
  int first_vetoed = -1;
  std::vector<int> listed;
};
struct ItemScan {
  double gap = std::numeric_limits<double>::infinity();
  bool vetoes = false;
  bool listed = false;
};
/// The part of an item's scan (scan_work) its result decides alike in every set: its gap where
/// its projection converged in range, and whether it vetoes the evaluation (its projection
/// failed or jumped where the pair is active, or was at the last converged increment).
template <class Result>
ItemScan scan_result(const Result& r, bool was_active) {
  ItemScan out;
  if (r.status == contact::ProjectionStatus::Converged)
    out.gap = r.gap;
  out.vetoes = (r.status == contact::ProjectionStatus::NotConverged ||
                r.status == contact::ProjectionStatus::Jumped) &&
               (was_active || r.active);
  return out;
}
template <class Scan>
void scan_work(std::size_t n, std::vector<WorkScan>& blocks, WorkScan& out, Scan scan) {
  constexpr std::size_t kBlock = 256;
  blocks.resize((n + kBlock - 1) / kBlock);
  tbb::parallel_for(std::size_t{0}, blocks.size(), [&](std::size_t b) {
    WorkScan& block = blocks[b];
    block.min_gap = std::numeric_limits<double>::infinity();
    block.first_vetoed = -1;
    block.listed.clear();
    for (std::size_t w = b * kBlock; w < std::min(n, (b + 1) * kBlock); ++w) {
      const ItemScan item = scan(w);
      block.min_gap = std::min(block.min_gap, item.gap);
      if (item.vetoes && block.first_vetoed < 0)
        block.first_vetoed = static_cast<int>(w);
      if (item.listed)
        block.listed.push_back(static_cast<int>(w));
    }
  });
  out.min_gap = std::numeric_limits<double>::infinity();
  out.first_vetoed = -1;
  out.listed.clear();
  for (const WorkScan& block : blocks) {
    out.min_gap = std::min(out.min_gap, block.min_gap);
    if (out.first_vetoed < 0)
      out.first_vetoed = block.first_vetoed;
    out.listed.insert(out.listed.end(), block.listed.begin(), block.listed.end());
  }
}

/// The first step of a contact set's assembly: the indices of the active items of `work` (in
/// their order) into `items` and, for a tangent, each one's `block` matrix slots in `cache`
/// (cache.slots(item)): those the cache lacks (new active items, or all after the pattern
/// `pattern_id` changed) are looked up in parallel by slots_of(item, destination), an
/// ContactTarget::*_block_slots lookup. The set then adds the pairs in their order (add_by_node):
/// the same sums on any thread count.
template <class Work, class SlotsOf>
void find_active_slots(const std::vector<Work>& work, bool want_tangent, int block,
                       std::uint64_t pattern_id, std::vector<int>& items, SlotCache& cache,
                       SlotsOf slots_of) {
  items.clear();
  for (std::size_t w = 0; w < work.size(); ++w)
    if (work[w].result.active)
      items.push_back(static_cast<int>(w));
  if (!want_tangent)
    return;
  if (cache.pattern != pattern_id || cache.offset.size() != work.size()) {
    cache.clear();
    cache.offset.assign(work.size(), -1);
    cache.pattern = pattern_id;
  }
  cache.looked_up.clear();
  for (int w : items)
    if (cache.offset[static_cast<std::size_t>(w)] < 0) {
      cache.offset[static_cast<std::size_t>(w)] = static_cast<int>(cache.store.size());
      cache.store.resize(cache.store.size() + static_cast<std::size_t>(block));
      cache.looked_up.push_back(w);
    }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cache.looked_up.size(), 8),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t k = range.begin(); k != range.end(); ++k) {
                        const int w = cache.looked_up[k];
                        slots_of(work[static_cast<std::size_t>(w)],
                                 cache.store.data() + cache.offset[static_cast<std::size_t>(w)]);
                      }
                    });
}

/// The second step of a contact set's assembly: every active pair's contributions added to the
/// residual and the matrix, in parallel over the nodes they touch. `nodes[k]` (k over `items`,
/// unused slots repeating a node) are pair k's nodes; add(k, node) adds pair k's residual entries
/// of `node` and its tangent's entries in the matrix columns of `node`, each in the order the
/// pair's block is visited. Each node's pairs are visited in their order, so every residual entry
/// and matrix slot (a slot lies in one node's column) receives the same additions in the same
/// order as a serial loop over the pairs: the same bits on any thread count and as before the
/// loop ran in parallel. `offsets` and `incident` are scratch (node -> pairs, kept to spare the
/// allocations).
template <std::size_t N, class Add>
void add_by_node(int n_nodes, const std::vector<std::array<int, N>>& nodes,
                 std::vector<int>& offsets, std::vector<int>& incident, Add add) {
  const auto each_node = [&](std::size_t k, auto&& visit) {
    const std::array<int, N>& n = nodes[k];
    for (std::size_t a = 0; a < N; ++a)
      if (std::find(n.begin(), n.begin() + a, n[a]) == n.begin() + a) // once per pair
        visit(n[a]);
  };
  // Few pairs (an explicit step's, a small fabric's): one loop over the pairs, each pair's nodes
  // in turn, gives every entry the same additions in the same order (a pair's nodes touch
  // different entries) without the lists. The paper's explicit case on one thread, 5 000 steps:
  // 1.046 times the serial loop's time with the lists, 1.029 with this (medians of noisy runs).
  constexpr std::size_t kSerialBelow = 128;
  if (nodes.size() < kSerialBelow) {
    for (std::size_t k = 0; k < nodes.size(); ++k)
      each_node(k, [&](int node) { add(k, node); });
    return;
  }
  offsets.assign(static_cast<std::size_t>(n_nodes) + 1, 0);
  for (std::size_t k = 0; k < nodes.size(); ++k)
    each_node(k, [&](int node) { ++offsets[static_cast<std::size_t>(node) + 1]; });
  for (int i = 0; i < n_nodes; ++i)
    offsets[i + 1] += offsets[i];
  incident.resize(static_cast<std::size_t>(offsets[n_nodes]));
  // offsets[node] serves as the node's fill cursor, ending at the next node's start; shifted
  // back by one node afterwards (no buffer allocated per evaluation).
  for (std::size_t k = 0; k < nodes.size(); ++k)
    each_node(k, [&](int node) { incident[offsets[node]++] = static_cast<int>(k); });
  for (int i = n_nodes; i > 0; --i)
    offsets[i] = offsets[i - 1];
  offsets[0] = 0;
  tbb::parallel_for(tbb::blocked_range<int>(0, n_nodes, 64),
                    [&](const tbb::blocked_range<int>& range) {
                      for (int node = range.begin(); node != range.end(); ++node)
                        for (int i = offsets[node]; i < offsets[node + 1]; ++i)
                          add(static_cast<std::size_t>(incident[i]), node);
                    });
}

/// The node whose process (a process of a run over several: partition.hpp) projects and
/// assembles a contact pair between bodies a and b (indices into Model::splines or
/// Model::surfaces, each whole on one process), given a node of each: a's where a + b is even,
/// else b's. So every pair between two bodies has one owner (the hand-over of a point to a
/// neighbouring pair and the split contacts near a node stay on it), and a weave's warp-weft
/// crossings spread over the warp's and the weft's processes.
inline int pair_owner_node(int body_a, int body_b, int node_a, int node_b) {
  return (body_a + body_b) % 2 == 0 ? node_a : node_b;
}

/// Folds an active pair (definition, first, second) into ContactSummary::active_set.
inline std::uint64_t fold_active_pair(std::uint64_t h, int definition, int first, int second) {
  for (int v : {definition, first, second})
    h = (h ^ static_cast<std::uint64_t>(static_cast<std::uint32_t>(v))) * 0x100000001b3ull;
  return h;
}

/// Checks the pairs of a saved contact state (a checkpoint's, or every process's gathered)
/// before they are restored: each pair's key (definition, first, second segment) within the
/// model (`definitions` of them, `segments(k)` segments in definition k, first < second), the keys
/// strictly increasing, and every candidate of the saved boxes' search (`searched`, sorted) among
/// them; on one process (`whole`) the pairs are exactly those candidates, a process's share
/// (ContactSet::set_owned) searches the pairs with a segment in it, a part of them. Throws
/// std::invalid_argument naming the first that does not fit, `what` ("contact", "surface
/// contact") leading its message.
template <class Pair, class SegmentCount>
void check_saved_pairs(const std::vector<Pair>& pairs,
                       const std::vector<std::array<int, 3>>& searched, bool whole, int definitions,
                       SegmentCount segments, const char* what) {
  if (whole && searched.size() != pairs.size())
    throw std::invalid_argument(
        fmt::format("{} restart: the saved boxes give {} candidate pairs, the snapshot has {}",
                    what, searched.size(), pairs.size()));
  for (std::size_t w = 0; w < pairs.size(); ++w) {
    const std::array<int, 3>& key = pairs[w].key;
    if (key[0] < 0 || key[0] >= definitions || key[1] < 0 || key[1] >= key[2] ||
        key[2] >= segments(key[0]) || (w > 0 && !(pairs[w - 1].key < key)))
      throw std::invalid_argument(fmt::format(
          "{} restart: saved pair {} ({}, {}, {}) does not fit the model or is out of order", what,
          w, key[0], key[1], key[2]));
  }
  for (std::size_t c = 0, saved = 0; c < searched.size(); ++c) {
    while (saved < pairs.size() && pairs[saved].key < searched[c])
      ++saved;
    if (saved >= pairs.size() || pairs[saved].key != searched[c] || (whole && saved != c))
      throw std::invalid_argument(fmt::format(
          "{} restart: candidate {} of the saved search differs from the snapshot's", what, c));
  }
}

/// Links each candidate of a work list to its warm start: `work[i].warm` becomes the index of the
/// entry of `committed` with the same key (definition, first, second), or -1. Both lists are
/// sorted by that key (the candidates come sorted from the search, the warm starts are written in
/// the candidates' order), so one merge does it, in flat arrays instead of a map looked up per
/// candidate and iteration. Throws std::logic_error when either list is not sorted.
template <class Work, class Committed>
void link_warm_starts(std::vector<Work>& work, const std::vector<Committed>& committed) {
  const auto key = [](const Work& w) {
    return std::array<int, 3>{w.definition, w.pair.first, w.pair.second};
  };
  std::size_t c = 0;
  for (std::size_t i = 0; i < work.size(); ++i) {
    if (i > 0 && !(key(work[i - 1]) < key(work[i])))
      throw std::logic_error("link_warm_starts: the candidates are not sorted by key");
    while (c < committed.size() && committed[c].key < key(work[i])) {
      if (c + 1 < committed.size() && !(committed[c].key < committed[c + 1].key))
        throw std::logic_error("link_warm_starts: the warm starts are not sorted by key");
      ++c;
    }
    work[i].warm =
        c < committed.size() && committed[c].key == key(work[i]) ? static_cast<int>(c) : -1;
  }
}

/// Where a work item's entry lies in a SlotLists: the arena slot that appended it and its place
/// in that slot's list; slot -1 for none.
struct SlotEntry {
  int slot = -1, index = -1;
};

/// Entries appended per arena slot: inside a parallel loop each thread appends to its own slot's
/// list (tbb::this_task_arena::current_thread_index()), a serial pass to a slot past them, and a
/// work item keeps where its entry is (SlotEntry). A contact set keeps there the residual and
/// tangent of its pairs in contact, apart from its work list, whose candidates are mostly out of
/// reach (keep_terms). Cleared at each projection; the lists keep their capacity.
template <class Entry>
class SlotLists {
public:
  /// At least `slots` lists, every one empty.
  void reset(std::size_t slots) {
    lists_.resize(std::max(slots, lists_.size()));
    for (std::vector<Entry>& list : lists_)
      list.clear();
  }
  /// A new entry at the end of `slot`'s list; `where` is set to it.
  Entry& append(int slot, SlotEntry& where) {
    std::vector<Entry>& list = lists_[static_cast<std::size_t>(slot)];
    Entry& entry = list.emplace_back();
    where = {slot, static_cast<int>(list.size()) - 1};
    return entry;
  }
  const Entry& at(SlotEntry where) const {
    return lists_[static_cast<std::size_t>(where.slot)][static_cast<std::size_t>(where.index)];
  }
  Entry& at(SlotEntry where) {
    return lists_[static_cast<std::size_t>(where.slot)][static_cast<std::size_t>(where.index)];
  }

private:
  std::vector<std::vector<Entry>> lists_;
};

/// A contact pair's terms kept apart from its work item: the residual (N entries) and tangent
/// (N x N) of the pair's kernel (N = 18 for a spline pair, 24 for a surface pair).
template <int N>
struct PairTerms {
  Eigen::Matrix<double, N, 1> residual;
  Eigen::Matrix<double, N, N> tangent;
};

/// Where the pair's definition has friction: the normal contact's sensitivity, and the residual
/// and tangent of the friction kernels (point and torsional friction summed).
template <int N, class Sensitivity>
struct FrictionPairTerms {
  Sensitivity sensitivity;
  Eigen::Matrix<double, N, 1> residual;
  Eigen::Matrix<double, N, N> tangent;
};

/// Work item `item`'s state from its kernel's `result` (a contact state with residual and
/// tangent, sliced to the state); where the pair is in contact, its residual and tangent (the
/// tangent where computed) appended to `slot`'s list of `terms`, and where its definition has
/// friction, its `sensitivity` to `slot`'s list of `friction_terms`.
template <class Work, class Result, class Terms, class FrictionTerms>
void keep_terms(Work& item, const Result& result,
                const decltype(FrictionTerms::sensitivity)& sensitivity, bool friction, int slot,
                bool with_tangent, SlotLists<Terms>& terms,
                SlotLists<FrictionTerms>& friction_terms) {
  item.result = result;
  item.terms = item.friction_terms = {};
  if (!result.active)
    return;
  Terms& t = terms.append(slot, item.terms);
  t.residual = result.residual;
  if (with_tangent)
    t.tangent = result.tangent;
  if (friction)
    friction_terms.append(slot, item.friction_terms).sensitivity = sensitivity;
}

/// A frictional pair's friction kernels' result (point and torsional friction summed in
/// `result`): its state into `state` (the work item's), its residual and tangent (the tangent
/// where computed) into the pair's `terms`.
template <class State, class Result, class FrictionTerms>
void keep_friction_terms(const Result& result, bool with_tangent, State& state,
                         FrictionTerms& terms) {
  state = result;
  terms.residual = result.residual;
  if (with_tangent)
    terms.tangent = result.tangent;
}

/// Nodal velocities of the iterate, for contact damping (normal damping of the interface law,
/// tangential damping of friction): implicit dynamic steps only, where the time integrator ties
/// the velocities to the positions.
struct ContactRates {
  const Eigen::Matrix3Xd* velocity = nullptr; ///< 3 x n_nodes, m/s (Newmark's, of the iterate)
  /// dv/dx of the integrator, 1/s (Newmark: gamma / (beta dt)), for the tangent.
  double velocity_per_displacement = 0;
  /// 3 x n_nodes, rad/s: the nodes' spatial angular velocities (Newmark's, of the iterate), for
  /// the surface contact, whose points turn with the nodes' sections; null where no surface
  /// contact damps.
  const Eigen::Matrix3Xd* angular_velocity = nullptr;
};

/// One contact formulation's stage over all of its definitions in a model.
class ContactSet {
public:
  virtual ~ContactSet() = default;

  /// Broad phase alone: refits the boxes at the state's current configuration and searches
  /// again when the motion asks for it. Returns true when the candidate list changed.
  virtual bool update_candidates(const State& state) = 0;
  /// Narrow phase over the current candidates, in parallel, at the state's current
  /// configuration (positions x, rotations Q(alpha) Q_n). Returns an empty string, or why the
  /// configuration must be vetoed (a projection of a pair in contact failed or jumped). `rates`
  /// (dynamic steps, where some definition damps) feeds contact damping; without them damping
  /// has no effect.
  virtual std::string project(const State& state, bool want_tangent,
                              const ContactRates* rates = nullptr) = 0;
  /// The time (s) of the configurations project() will see next: time-dependent settings
  /// (SplineContactDefinition::compaction) are taken there.
  virtual void set_time(double /*time*/) {}
  /// A new attempt at an increment starts from the last converged state (after a failed one,
  /// from scratch): what the last attempt's iterates left (the anchors of the points that
  /// closed in it) is forgotten.
  virtual void begin_attempt() {}
  /// Whether the configurations project() sees next belong to an explicit step: its friction
  /// forces are conjugate to their elastic gaps, so that the energy balance it checks holds;
  /// implicit steps take them at the contact points (contact::FrictionForce).
  virtual void set_explicit_path(bool /*explicit_path*/) {}
  /// Whether project() reads the nodes' triads (State::Q_n, alpha) besides their positions.
  virtual bool reads_triads() const { return false; }
  /// A process's share of a run over several (partition.hpp): from the next update_candidates
  /// on (also after a restore), the work list holds only the pairs `owned` holds
  /// (pair_owner_node; none: every pair), and the candidate search those with a segment whose
  /// side of pair_owner_node is this process's node (broadphase::CandidateSearch::set_share).
  void set_owned(const std::optional<NodePartition>& owned) {
    owned_ = owned;
    rebuild_work_ = true;
  }
  /// Forgets the friction dissipated over the committed increments (a process of a run over
  /// several that is not the first, when it takes its share of pairs that every process held:
  /// the sum over the processes is then the first's).
  virtual void clear_dissipation() = 0;
  /// Changes whenever a broad-phase search changed the candidate list.
  virtual int candidates_version() const = 0;
  /// Adds `weight` to per_node[k] for every candidate pair this process owns (every pair on one
  /// process), k the node that owns it (pair_owner_node): the contact's work per node, for the
  /// partition's balance (Simulation::rebalance, which sums the processes' loads).
  virtual void add_candidate_loads(std::vector<double>& per_node, double weight) const = 0;
  /// Node groups of the pairs of the last projection that are active or within reach (a
  /// converged projection with a gap below the definition's broad-phase margin), for the
  /// tangent's pattern (unused slots repeat a node; translations only, or all six DOFs, as the
  /// set's pair tangents need). Candidates farther apart are left out: between neighbouring
  /// parallel yarns of a sheared fabric they are thousands, each coupling two yarns along their
  /// length in the factor long before they touch (docs/performance.md).
  virtual std::vector<ContactCoupling> couplings() const = 0;
  /// Adds the active pairs' residuals and, if want_tangent, tangents, in sorted pair order (of
  /// a share, its own pairs: set_owned).
  virtual void assemble(Eigen::VectorXd& residual, ContactTarget& target,
                        bool want_tangent) const = 0;
  /// Accepts the last evaluation as converged: warm starts and active flags for the next one.
  virtual void commit() = 0;
  /// Figures of the last evaluation (computed with it, not on each call).
  virtual const ContactSummary& summary() const = 0;
  /// The closing limit of a Newton correction (formulation.md "Solution"): the largest fraction
  /// lambda of a correction with nodal translations `du` (3 x n_nodes, m) for which no pair open
  /// where it starts penetrates deeper than `allowance` times the pair's smaller contact radius
  /// r, to first order in the translations (the contact points held: the gap is stationary in
  /// them): min over closing pairs of (g + allowance r) / (-dg/dlambda). The pairs and gaps are
  /// the last evaluation's (pairs whose projection converged in range); where the correction
  /// starts elsewhere, `offset` (3 x n_nodes, m, or null) is its start's motion from there, and
  /// a pair counts as open where its gap moved by it is positive. +infinity when no pair limits
  /// it. The same value on any thread count (a minimum).
  virtual double closing_limit(const Eigen::Matrix3Xd& /*du*/, const Eigen::Matrix3Xd* /*offset*/,
                               double /*allowance*/) const {
    return std::numeric_limits<double>::infinity();
  }
  virtual std::vector<ContactPoint> points() const = 0;

protected:
  /// The share of a candidate search (broadphase::CandidateSearch::set_share) under set_owned:
  /// per segment (`segments` of them), whether this process owns the node `node_of(s)` it gives
  /// pair_owner_node (so that the share's search lists every pair this process owns); empty
  /// without a share.
  template <class NodeOf>
  std::vector<char> share_flags(std::size_t segments, NodeOf node_of) const {
    if (!owned_)
      return {};
    std::vector<char> own(segments);
    for (std::size_t s = 0; s < segments; ++s)
      own[s] = owned_->owns(node_of(static_cast<int>(s))) ? 1 : 0;
    return own;
  }
  /// This process's share (set_owned): none, every pair.
  std::optional<NodePartition> owned_;
  bool rebuild_work_ = false; ///< the work list must follow a new share
};

} // namespace yarnsim
