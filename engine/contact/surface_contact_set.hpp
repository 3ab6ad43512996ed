#pragma once
// The surface-to-surface contact stage (formulation.md §6, the paper's "Surface" model): on each
// element of a surface a super-elliptical cylinder between its end nodes; candidate element pairs
// from the FCL-backed search; the four-unknown local contact problem of every candidate in
// parallel, warm-started from the last converged increment; Coulomb friction at the active
// contact points of definitions that have it (contact/surface_friction.hpp: anchors committed
// with converged increments) and, where asked for, torsional friction at the crossings
// (contact/surface_torsional_friction.hpp: twist anchors committed alike); assembly of the
// active pairs' 24 x 24 blocks (translations and rotations of the four end nodes) in sorted
// order.

#include "broadphase/candidate_search.hpp"
#include "contact/interface_law.hpp"
#include "contact/surface_contact.hpp"
#include "contact/surface_friction.hpp"
#include "contact/surface_torsional_friction.hpp"
#include "engine/contact/contact_set.hpp"

#include <Eigen/Core>
#include <array>
#include <memory>
#include <string>
#include <vector>

namespace yarnsim {

class SurfaceContactSet final : public ContactSet {
public:
  /// Throws std::invalid_argument when a surface's elements do not form a chain.
  explicit SurfaceContactSet(const Model& model);
  ~SurfaceContactSet() override;

  bool update_candidates(const State& state) override;
  /// `rates` (dynamic steps, where a definition has tangential damping) feed the friction's
  /// dashpot: the nodes' velocities and spatial angular velocities, as the kernel's DOF rates
  /// (Rodrigues rates Xi(alpha)^-1 omega). The normal law has no damping on this contact in
  /// this version (the constructor refuses a damped law).
  std::string project(const State& state, bool want_tangent,
                      const ContactRates* rates = nullptr) override;
  /// Whether a definition has tangential damping (it needs the rates of dynamic steps).
  bool damped() const { return damped_; }
  /// The elements' sections turn with their nodes' triads (contact::SurfaceNode).
  bool reads_triads() const override { return true; }
  void clear_dissipation() override { dissipated_ = 0; }
  int candidates_version() const override { return candidates_version_; }
  void add_candidate_loads(std::vector<double>& per_node, double weight) const override;
  /// The four end nodes of each candidate pair (A's first and last, B's first and last).
  std::vector<ContactCoupling> couplings() const override;
  void assemble(Eigen::VectorXd& residual, ContactTarget& target, bool want_tangent) const override;
  void commit() override;
  /// Gaps are signed distances between the surfaces.
  const ContactSummary& summary() const override { return summary_; }
  double closing_limit(const Eigen::Matrix3Xd& du, const Eigen::Matrix3Xd* offset,
                       double allowance) const override;
  std::vector<ContactPoint> points() const override;

  /// What a restart needs to continue bit for bit (engine/solver/checkpoint.hpp), as
  /// SplineContactSet::Snapshot: the boxes of each definition's last broad-phase search
  /// (searching them again gives the same candidates and the same motion test), the committed
  /// warm starts, the candidates with the outcome of the last evaluation and its figures.
  /// Residuals and tangents are left out: every use computes them again.
  struct Snapshot {
    struct Warm {
      std::array<int, 3> key; ///< definition, first, second segment id
      double zeta_A, theta_A, zeta_B, theta_B;
      bool active;
      /// Friction history of an active contact with friction (surface_friction.hpp): the anchor
      /// (convective coordinates on the two surfaces), the slip accumulated since the point
      /// closed (m), and friction = 1 stuck, 2 slipping, 0 none.
      double anchor_zeta_A = 0, anchor_theta_A = 0, anchor_zeta_B = 0, anchor_theta_B = 0;
      double slip = 0;
      int friction = 0;
      /// Torsional friction of that point (contact/surface_torsional_friction.hpp): the anchor
      /// crossing angle (rad), the twist slip accumulated since it closed (rad), and twist = 1
      /// stuck, 2 slipping, 0 none.
      double twist_anchor = 0, twist_slip = 0;
      int twist = 0;
    };
    /// A candidate, the scalar part of its last SurfaceContactResult and its share factor.
    struct Pair {
      std::array<int, 3> key;
      contact::ProjectionStatus status;
      contact::SurfaceDegeneration degeneration;
      bool active;
      int iterations;
      double zeta_A, theta_A, zeta_B, theta_B, gap, penetration, penetration_rate, force, potential,
          share, share_A, share_B, factor;
      Eigen::Vector3d point_A, point_B, normal;
    };
    std::vector<std::vector<Eigen::AlignedBox3d>> search_boxes; ///< per definition, per segment
    std::vector<Warm> committed;                                ///< sorted by key
    std::vector<Pair> pairs;                                    ///< the work list, in order
    int candidates_version = 0;
    ContactSummary summary; ///< of the last evaluation
    double dissipated = 0;  ///< J, by friction over the completed increments
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
    contact::SurfaceContactState result;
    /// Where its residual and tangent (and friction terms) are kept: terms_, friction_terms_.
    SlotEntry terms, friction_terms;
    /// Factor on the pair's force where it and a neighbour's pair find two close points in a
    /// valley (share_split_contacts); 1 elsewhere.
    double factor = 1.0;
    int warm = -1; ///< index of its warm start in committed_, or -1 (link_warm_starts)
    /// Friction of an active contact: the history this evaluation holds fixed (its committed
    /// one, or a first touch) and the slip accumulated before this increment, m. A contact that
    /// closed in this increment carries no friction until the increment converges, which
    /// anchors it where it closed (as in SplineContactSet).
    contact::SurfaceFrictionHistory history{};
    double slip = 0;
    double twist_slip = 0; ///< rad, accumulated before this increment (torsional friction)
    bool first_touch = false;
  };
  using Key = std::array<int, 3>; ///< definition, first, second segment id

  /// End nodes of a pair's two elements: A first, A last, B first, B last.
  std::array<int, 4> nodes_of(const Definition& d, const broadphase::CandidatePair& p) const;
  /// Shares one contact between two pairs whose points lie close together on either side of a
  /// node (a valley between two elements' cylinders).
  void share_split_contacts();
  /// summary_ from work_ (and the friction results), and scan_ (the first vetoed item).
  void summarise();
  /// The cylinder of segment s of definition d at the state's configuration.
  contact::SuperEllipticalCylinder cylinder(const Definition& d, int s, const State& state) const;

  const Model& model_;
  std::vector<contact::SuperEllipse> sections_; ///< per surface
  std::vector<std::unique_ptr<Definition>> definitions_;
  std::vector<Work> work_; ///< last evaluation, sorted by (definition, pair)
  /// assemble()'s buffers, kept for their capacity: the active work items, the slots of the
  /// work items' tangents in the matrix (576 per item, ContactTarget::surface_pair_block_slots;
  /// cleared with each new work list), each active item's end nodes, and the node -> pairs lists
  /// of add_by_node.
  mutable std::vector<int> assembly_items_;
  mutable SlotCache assembly_slots_;
  mutable std::vector<std::array<int, 4>> assembly_nodes_;
  mutable std::vector<int> assembly_offsets_, assembly_incident_;
  /// Indices into work_ sorted by (definition, second, first); rebuilt with the work list.
  std::vector<std::size_t> by_second_;
  /// Warm starts of the last converged increment's candidates, sorted by key.
  std::vector<Snapshot::Warm> committed_;
  std::vector<Snapshot::Warm> next_committed_; ///< commit()'s buffer, kept for its capacity
  bool any_friction_ = false;
  /// Per work item, when a definition has friction: the friction state (active where it was
  /// evaluated; its residual and tangent in friction_terms_).
  std::vector<contact::SurfaceFrictionState> friction_;
  /// The residual (24) and tangent (24 x 24) of the pairs in contact at the last projection,
  /// held apart from the work list, whose candidates are mostly out of reach (4.8 kB a
  /// candidate otherwise): one list per arena slot, each pair's appended by the thread that
  /// projected it. Where the definition has friction, the contact's sensitivity and the friction
  /// (and torsional friction) terms likewise. Cleared at each projection (kept for their
  /// capacity).
  using Terms = PairTerms<24>;
  using FrictionTerms = FrictionPairTerms<24, contact::SurfaceContactSensitivity>;
  SlotLists<Terms> terms_;
  SlotLists<FrictionTerms> friction_terms_;
  /// Per arena slot, what a pair's kernels write before keep() takes their state and terms.
  struct Scratch {
    contact::SurfaceContactResult result;
    contact::SurfaceContactSensitivity sensitivity;
    contact::SurfaceFrictionResult friction;
    contact::SurfaceTorsionalFrictionResult torsion;
  };
  std::vector<Scratch> scratch_;
  /// Work item w's state from a kernel's result; where the pair is in contact, its residual and
  /// tangent (where computed) appended to slot's list of terms_, and where its definition has
  /// friction, its `sensitivity` to slot's list of friction_terms_.
  void keep(std::size_t w, const contact::SurfaceContactResult& result,
            const contact::SurfaceContactSensitivity& sensitivity, int slot, bool with_tangent);
  const Terms& terms_of(const Work& item) const;
  FrictionTerms& friction_terms_of(const Work& item);
  const FrictionTerms& friction_terms_of(const Work& item) const;
  bool damped_ = false; ///< some definition has tangential damping
  /// Per work item: the torsional result's scalars (active where it was evaluated; its residual
  /// and tangent are added to the friction terms).
  struct Twist {
    bool active = false, slipping = false;
    double torque = 0, slip_increment = 0, dissipation = 0, energy = 0, anchor = 0;
  };
  std::vector<Twist> twist_;
  double dissipated_ = 0; ///< J, by friction over the committed increments
  int candidates_version_ = 0;
  /// The first node of segment s of `d`: the node pair_owner_node takes on its side
  /// (owner_node), and so the share of the search (share_flags).
  int first_node(const Definition& d, int s) const;
  /// The node whose process projects pair p of definition d over several (pair_owner_node), and
  /// whether that is this process (set_owned).
  int owner_node(const Definition& d, const broadphase::CandidatePair& p) const;
  bool owns(const Definition& d, const broadphase::CandidatePair& p) const;
  ContactSummary summary_;
  /// summarise()'s pass (scan_work): the smallest gap, the first vetoed item (project's veto)
  /// and the items that add to the summary; and its blocks, kept for their capacity.
  WorkScan scan_;
  std::vector<WorkScan> scan_blocks_;
};

} // namespace yarnsim
