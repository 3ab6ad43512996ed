#pragma once
// The beam-to-beam spline contact stage (formulation.md §5): candidate segment pairs of the C1
// quadratic contact splines from the FCL-backed search, closest-point projections in parallel,
// Coulomb friction at the active point contacts of definitions that have it (contact/friction.hpp:
// anchors committed with converged increments, handed over between neighbouring segment pairs)
// and at the line contact's Gauss points (contact/line_friction.hpp: one history per Gauss point
// of the slave segment and master spline, whichever segment pair owns it) and, where asked for,
// torsional friction at the crossings (contact/torsional_friction.hpp), assembly of the active
// pairs' 18 x 18 translational blocks in sorted order.

#include "broadphase/candidate_search.hpp"
#include "contact/friction.hpp"
#include "contact/interface_law.hpp"
#include "contact/line_friction.hpp"
#include "contact/spline_contact.hpp"
#include "contact/spline_curve.hpp"
#include "contact/torsional_friction.hpp"
#include "engine/contact/contact_set.hpp"

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace yarnsim {

/// Normal law of a contact definition (linear, power, optionally damped).
std::shared_ptr<const contact::InterfaceLaw> make_interface_law(const InterfaceLawParameters& p);

class SplineContactSet final : public ContactSet {
public:
  explicit SplineContactSet(const Model& model);
  ~SplineContactSet() override;

  bool empty() const { return definitions_.empty(); }

  bool update_candidates(const State& state) override;
  /// With `rates`, definitions that damp (normal damping of the law, tangential damping of
  /// friction) get their pairs' control-point velocities.
  std::string project(const State& state, bool want_tangent,
                      const ContactRates* rates = nullptr) override;
  /// Whether some definition damps.
  bool damped() const { return damped_; }
  void set_time(double time) override { time_ = time; }
  void begin_attempt() override { attempt_anchors_.clear(); }
  void set_explicit_path(bool explicit_path) override {
    friction_force_ = explicit_path ? contact::FrictionForce::ConjugateToTheGap
                                    : contact::FrictionForce::AtContactPoints;
  }
  void clear_dissipation() override { dissipated_ = 0; }
  int candidates_version() const override { return candidates_version_; }
  void add_candidate_loads(std::vector<double>& per_node, double weight) const override;
  /// The 6 control points of each candidate pair.
  std::vector<ContactCoupling> couplings() const override;
  /// Translations only: the splines' control points carry no rotations.
  void assemble(Eigen::VectorXd& residual, ContactTarget& target, bool want_tangent) const override;
  void commit() override;
  /// Gaps are effective gaps (eq. 12).
  const ContactSummary& summary() const override { return summary_; }
  double closing_limit(const Eigen::Matrix3Xd& du, const Eigen::Matrix3Xd* offset,
                       double allowance) const override;
  std::vector<ContactPoint> points() const override;

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
      /// Friction history of an active point contact with friction (friction.hpp): the anchor
      /// (global parameters on the two splines), the slip accumulated since the point closed
      /// (m), and friction = 1 stuck, 2 slipping, 0 none.
      double anchor_A = 0, anchor_B = 0, slip = 0;
      int friction = 0;
      /// Torsional friction of that point: the anchor crossing angle (rad), the twist slip
      /// accumulated since it closed (rad), and twist = 1 stuck, 2 slipping, 0 none.
      double twist_anchor = 0, twist_slip = 0;
      int twist = 0;
    };
    /// Friction history of a Gauss point of the line contact (line_friction.hpp), keyed by
    /// definition, the slave's segment id, the Gauss point's index and the master's spline (not
    /// segment: the point passes from one segment pair to the next with its history): the anchor
    /// (global parameter on the master spline), the slip accumulated since it closed (m), and
    /// friction = 1 stuck, 2 slipping.
    using LineKey = std::array<int, 4>;
    struct LineWarm {
      LineKey key;
      double anchor = 0, slip = 0;
      int friction = 1;
    };
    /// A candidate and the scalar part of its last contact state.
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
    std::vector<LineWarm> line_committed;                       ///< sorted by key
    std::vector<Pair> pairs;                                    ///< the work list, in order
    int candidates_version = 0;
    double dissipated = 0; ///< J, by friction over the completed increments
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
    contact::SplineContactState result;
    /// Where its residual and tangent (and friction terms) are kept: terms_, friction_terms_.
    SlotEntry terms, friction_terms;
    int warm = -1; ///< index of its warm start in committed_, or -1 (link_warm_starts)
    /// Friction of an active point contact: the history this evaluation holds fixed (its own
    /// committed one, one handed over from a neighbouring pair, or a first touch) and the slip
    /// accumulated before this increment, m.
    contact::FrictionHistory history{};
    double slip = 0;
    double twist_slip = 0; ///< rad, accumulated before this increment (torsional friction)
    /// An active point contact with friction and no history: it closed at this iterate. It
    /// carries no friction here. With an elastic slip it is anchored where it touched for the
    /// rest of the attempt (attempt_anchors_); with a constant penalty it carries none until the
    /// increment converges, which anchors it where it is then. (A history that followed the
    /// iterate would give zero force with a tangent that is not.)
    bool first_touch = false;
    Key key() const { return {definition, pair.first, pair.second}; }
  };
  /// Where a point contact of a definition with an elastic slip first touched in the current
  /// attempt (its pair had no history): the next iterates hold it as their history, stuck, as
  /// a committed one, so the point resists sliding from the iterate it closed at instead of
  /// sliding freely until the increment converges. Dropped where the pair opens again (a new
  /// touch anchors anew), by begin_attempt and by commit (the committed histories take over).
  struct AttemptAnchor {
    Key key;
    contact::FrictionHistory history;
  };
  std::vector<AttemptAnchor> attempt_anchors_; ///< sorted by key

  std::array<int, 6> nodes_of(const Definition& d, const broadphase::CandidatePair& p) const;
  /// The pair's control points at positions x (3 x n_nodes, m): A's and B's three, as columns.
  void control_points(const Definition& d, const broadphase::CandidatePair& p,
                      const Eigen::Matrix3Xd& x, Eigen::Matrix3d& A, Eigen::Matrix3d& B) const;
  /// The pair's control-point velocities from the nodal `rates` (A's three, then B's).
  void pair_velocities(const Definition& d, const broadphase::CandidatePair& p,
                       const ContactRates& rates, contact::PairRates& out) const;
  /// summary_ from work_, and scan_ (the first vetoed item).
  void summarise();
  /// Gives each active frictional point contact the history it holds fixed (serial: a history
  /// handed over from a neighbouring pair goes to one point only).
  void assign_friction_histories();
  /// Adds the points that touched first at the last projection, of definitions with an elastic
  /// slip, to attempt_anchors_ (after the friction pass has set their twist anchors).
  void anchor_first_touches();
  /// Index of the work item / committed entry with this key, or -1.
  int work_index(const Key& key) const;
  int committed_index(const Key& key) const;

  const Model& model_;
  std::vector<contact::SplineCurve> curves_; ///< per spline
  std::vector<std::unique_ptr<Definition>> definitions_;
  std::vector<Work> work_; ///< last evaluation, sorted by (definition, pair)
  /// The residual (18) and tangent (18 x 18) of the pairs in contact at the last projection, held
  /// apart from the work list, whose candidates are mostly out of reach (2.7 kB a candidate
  /// otherwise): one list per arena slot, each pair's appended by the thread that projected it,
  /// the hand-over pass's in the last list. Cleared at each projection (kept for their capacity).
  /// Where the definition has friction, the point contact's sensitivity and the friction
  /// kernel's residual and tangent (3.3 kB more) are kept likewise (friction_terms_).
  using Terms = PairTerms<18>;
  using FrictionTerms = FrictionPairTerms<18, contact::SplineContactSensitivity>;
  SlotLists<Terms> terms_;
  SlotLists<FrictionTerms> friction_terms_;
  /// Per arena slot, what a pair's kernels write before keep() takes their state and terms.
  struct Scratch {
    contact::SplineContactResult result;
    contact::SplineContactSensitivity sensitivity;
    contact::SplineFrictionResult friction;
  };
  std::vector<Scratch> scratch_;
  /// Work item w's state from a kernel's result; where the pair is in contact, its residual and
  /// tangent (where computed) appended to slot's list of terms_, and where its definition has
  /// friction, its `sensitivity` to slot's list of friction_terms_.
  void keep(std::size_t w, const contact::SplineContactResult& result,
            const contact::SplineContactSensitivity& sensitivity, int slot, bool with_tangent);
  const Terms& terms_of(const Work& item) const;
  FrictionTerms& friction_terms_of(const Work& item);
  const FrictionTerms& friction_terms_of(const Work& item) const;
  bool any_friction_ = false;
  bool damped_ = false;
  /// Per work item, when a definition has friction: the friction state (active where it was
  /// evaluated; its residual and tangent in friction_terms_).
  std::vector<contact::SplineFrictionState> friction_;
  /// Per work item, where the definition has torsional friction: the torsional result's scalars
  /// (its residual and tangent are added to friction_'s).
  struct Twist {
    bool active = false, slipping = false;
    double torque = 0, slip_increment = 0, dissipation = 0, energy = 0, anchor = 0;
  };
  std::vector<Twist> twist_;
  /// The line contact's friction, for the work items of the last evaluation whose line part has
  /// Gauss points in contact and whose definition has friction (`line_items_`, ascending): the
  /// histories they hold fixed (bit i of `with_history`: Gauss point i has one; of `first_touch`:
  /// it closed in this increment and carries no friction until it converges, as a point contact
  /// that closes), the slip accumulated before this increment (m), and the kernel's result.
  struct LineWork {
    std::uint16_t with_history = 0, first_touch = 0;
    std::array<contact::LineFrictionHistory, contact::kMaxGaussPoints> history{};
    std::array<double, contact::kMaxGaussPoints> slip{};
  };
  std::vector<int> line_items_;
  std::vector<LineWork> line_work_;
  std::vector<contact::LineFrictionResult> line_friction_;
  std::vector<Snapshot::LineWarm> line_committed_; ///< of the last converged increment, sorted
  /// Gives each Gauss point in contact of a frictional line contact its history (serial: one
  /// point per history).
  void assign_line_histories();
  /// The contact spline's segment of segment id `id` of definition `d`.
  const contact::SegmentBasis& segment_of(const Definition& d, int id) const;
  /// Whether the global parameter xi lies before the first segment or after the last segment of
  /// the spline of segment `id` (past the curve's end, where no neighbour takes a point over).
  bool past_curve_end(const Definition& d, int id, double xi) const;
  /// The definition's all-angle options for a pair of contact radii ra, rb (m): the line scale
  /// is its line_penalty / penalty, or 1 / (ra + rb).
  contact::AllAngleOptions all_angle_of(const Definition& d, double ra, double rb) const;
  double dissipated_ = 0; ///< J, by friction over the committed increments
  /// Per work item of the last projection: its point lies out of range with the surfaces
  /// overlapping, so it may hand the point to a neighbouring pair (project's hand-over pass).
  std::vector<char> may_hand_over_;
  /// The hand-over pass's points: the pair handing its point and the neighbour taking it, the
  /// neighbours' projections from them (kept for their capacity: only the first
  /// hand_overs_.size() are this pass's), and per work item whether it took one.
  struct HandOver {
    int from = -1, to = -1;
  };
  std::vector<HandOver> hand_overs_;
  std::vector<contact::SplineContactResult> handed_results_;
  std::vector<contact::SplineContactSensitivity> handed_sensitivity_;
  std::vector<char> handed_;
  /// summarise()'s pass (scan_work): the smallest gap, the first vetoed item (project's veto)
  /// and the items that add to the summary; and its blocks, kept for their capacity.
  WorkScan scan_;
  std::vector<WorkScan> scan_blocks_;
  /// Whether the last projection computed the active pairs' tangents (assemble reads them).
  bool tangents_computed_ = false;
  /// assemble()'s buffers, kept for their capacity: the active work items, the slots of the
  /// work items' tangents in the matrix (324 per item, ContactTarget::translation_block_slots;
  /// cleared with each new work list), each active item's nodes and line friction (an index into
  /// line_friction_, or -1), and the node -> pairs lists of add_by_node.
  mutable std::vector<int> assembly_items_, assembly_lines_;
  mutable SlotCache assembly_slots_;
  mutable std::vector<std::array<int, 6>> assembly_nodes_;
  mutable std::vector<int> assembly_offsets_, assembly_incident_;
  /// Warm starts of the last converged increment's candidates, sorted by key.
  std::vector<Snapshot::Warm> committed_;
  std::vector<Snapshot::Warm> next_committed_; ///< commit()'s buffer, kept for its capacity
  int candidates_version_ = 0;
  double time_ = 0; ///< s, of the configurations projected (the compaction's time)
  /// How the point friction's force reaches the positions: set_explicit_path.
  contact::FrictionForce friction_force_ = contact::FrictionForce::AtContactPoints;
  /// The first node of segment s of `d`: the node pair_owner_node takes on its side
  /// (owner_node), and so the share of the search (share_flags).
  int first_node(const Definition& d, int s) const;
  /// The node whose process projects pair p of definition d over several (pair_owner_node), and
  /// whether that is this process (set_owned).
  int owner_node(const Definition& d, const broadphase::CandidatePair& p) const;
  bool owns(const Definition& d, const broadphase::CandidatePair& p) const;
  ContactSummary summary_;
};

} // namespace yarnsim
