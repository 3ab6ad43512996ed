#pragma once
// The engine's spline contact stage for one Newton iteration: broad phase (candidate segment
// pairs from the FCL-backed search, kept across iterations) -> narrow phase (closest-point
// projections of all candidates in parallel, warm-started from the last converged increment) ->
// assembly of the active pairs in sorted order, so the sums do not depend on the thread count.

#include "broadphase/candidate_search.hpp"
#include "contact/interface_law.hpp"
#include "contact/spline_contact.hpp"
#include "contact/spline_curve.hpp"
#include "engine/model/model.hpp"

#include <Eigen/Core>
#include <array>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace yarnsim {

class Assembler;

/// An active contact point, for output.
struct ContactPoint {
  Eigen::Vector3d position; ///< midpoint of the two contact points, m
  Eigen::Vector3d normal;   ///< from B to A
  double gap = 0;           ///< effective gap (eq. 12), m; negative: penetration
  double force = 0;         ///< normal force, N
};

class SplineContactSet {
public:
  explicit SplineContactSet(const Model& model);
  ~SplineContactSet();

  bool empty() const { return definitions_.empty(); }

  /// Broad and narrow phase at positions x (3 x n_nodes, m). Returns an empty string, or why
  /// the configuration must be vetoed (a projection of a pair in contact failed or jumped).
  std::string evaluate(const Eigen::Matrix3Xd& x, bool want_tangent);
  /// Broad phase alone: refits the boxes and searches again when the motion asks for it.
  /// Returns true when the candidate list changed.
  bool update_candidates(const Eigen::Matrix3Xd& x);
  /// Narrow phase alone, over the current candidates, in parallel; returns as evaluate().
  std::string project(const Eigen::Matrix3Xd& x, bool want_tangent);

  /// Changes whenever a broad-phase search changed the candidate list.
  int candidates_version() const { return candidates_version_; }
  /// Node groups of all current candidate pairs (6 control points each), for the pattern.
  std::vector<std::array<int, 6>> couplings() const;

  /// Adds the active pairs' residuals (translations) and tangents, in sorted pair order.
  void assemble(Eigen::VectorXd& residual, Assembler& assembler, bool want_tangent) const;

  /// Accepts the last evaluation as converged: warm starts and active flags for the next one.
  void commit();

  int candidates() const;
  int active() const;
  double max_penetration() const; ///< m, over active pairs (0 if none)
  double max_force() const;       ///< N
  double potential() const;       ///< elastic energy stored in the active pairs, J
  /// Smallest effective gap (eq. 12) over the pairs whose projection converged in range, m;
  /// +infinity when there is none. Before loading it is the clearance the contact sees.
  double min_gap() const;
  double total_force() const; ///< sum of the normal forces of the active pairs, N
  std::vector<ContactPoint> points() const;

  /// What a restart needs to continue bit for bit (engine/solver/checkpoint.hpp): the boxes of
  /// each definition's last broad-phase search (searching them again gives the same candidates
  /// and the same motion test), the committed warm starts, and the candidates with the outcome of
  /// the last evaluation. Residuals and tangents are left out: every use computes them again.
  using Key = std::array<int, 3>; ///< definition, first, second segment id
  struct Snapshot {
    struct Warm {
      Key key;
      double xi_A, xi_B;
      bool active;
    };
    /// A candidate and the scalar part of its last SplineContactResult.
    struct Pair {
      Key key;
      contact::ProjectionStatus status;
      bool degenerate, active;
      int iterations;
      double xi_A, xi_B, distance, gap, penetration, penetration_rate, force, potential;
      Eigen::Vector3d point_A, point_B, normal;
    };
    std::vector<std::vector<Eigen::AlignedBox3d>> search_boxes; ///< per definition, per segment
    std::vector<Warm> committed;                                ///< sorted by key
    std::vector<Pair> pairs;                                    ///< the work list, in order
    int candidates_version = 0;
  };
  Snapshot snapshot() const;
  /// Puts a snapshot of a set of the same model back. Throws std::invalid_argument when it does
  /// not fit the model or its boxes do not give its candidates.
  void restore(const Snapshot& snapshot);

private:
  struct Definition;
  struct Work {
    int definition;
    broadphase::CandidatePair pair;
    contact::SplineContactResult result;
  };

  std::array<int, 6> nodes_of(const Definition& d, const broadphase::CandidatePair& p) const;

  const Model& model_;
  std::vector<contact::SplineCurve> curves_; ///< per spline
  std::vector<std::unique_ptr<Definition>> definitions_;
  std::vector<Work> work_; ///< last evaluation, sorted by (definition, pair)
  struct Committed {
    double xi_A, xi_B;
    bool active;
  };
  std::map<Key, Committed> committed_;
  int candidates_version_ = 0;
};

} // namespace yarnsim
