#pragma once
// The contact stage of a Newton iteration over all of a model's contact formulations: the
// formulations' sets (contact_set.hpp, spline_contact_set.hpp, surface_contact_set.hpp) run in a
// fixed order, so results do not depend on scheduling. It sits above the sets it builds.
#include "engine/contact/contact_set.hpp"

#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace yarnsim {

class SplineContactSet;
class SurfaceContactSet;

/// The figures of several parts (sets, processes) as one: counts, forces and energies summed,
/// penetration and force the largest, the gap the smallest, the active-set fingerprints folded
/// in order, the first part's off-end yarns that has any.
ContactSummary combine_summaries(const std::vector<ContactSummary>& parts);

/// All contact sets of a model: spline contacts first, then surface contacts. Each call runs the
/// sets in that order, so results do not depend on scheduling.
class ContactStage {
public:
  /// Null when the model has no contact definitions.
  static std::unique_ptr<ContactStage> of(const Model& model);

  bool update_candidates(const State& state);
  /// ContactSet::set_time of every set: call before projecting the configuration of time t.
  void set_time(double t);
  /// ContactSet::begin_attempt of every set: call before the first projection of an attempt.
  void begin_attempt();
  /// ContactSet::set_explicit_path of every set: call before the first projection of a step.
  void set_explicit_path(bool explicit_path);
  /// Whether some set's projections read the nodes' triads (ContactSet::reads_triads).
  bool reads_triads() const;
  std::string project(const State& state, bool want_tangent, const ContactRates* rates = nullptr);
  /// Whether some definition damps (normal or tangential damping): its project() then wants
  /// ContactRates on dynamic steps.
  bool damped() const;
  /// Broad and narrow phase; returns as project().
  std::string evaluate(const State& state, bool want_tangent);
  int candidates_version() const;
  /// Every set's ContactSet::add_candidate_loads.
  void add_candidate_loads(std::vector<double>& per_node, double weight) const;
  std::vector<ContactCoupling> couplings() const;
  void assemble(Eigen::VectorXd& residual, ContactTarget& target, bool want_tangent) const;
  void commit();
  /// The smallest ContactSet::closing_limit of the sets.
  double closing_limit(const Eigen::Matrix3Xd& du, const Eigen::Matrix3Xd* offset,
                       double allowance) const;

  /// Figures of the last evaluation, summed (counts, forces, energies) or extreme (penetration,
  /// force, gap) over the sets.
  ContactSummary summary() const;
  int candidates() const { return summary().candidates; }
  int active() const { return summary().active; }
  double max_penetration() const { return summary().max_penetration; }
  double max_force() const { return summary().max_force; }
  double potential() const { return summary().potential; }
  double min_gap() const { return summary().min_gap; }
  double total_force() const { return summary().total_force; }
  /// The active points, in the order of the sets and their pairs. Over several processes
  /// (partitioned()): the gathered points of the last converged state (set_gathered_points).
  std::vector<ContactPoint> points() const;

  /// A run over several processes (MPI, partition.hpp): each set projects and assembles only the
  /// pairs `owned` holds (ContactSet::set_owned), on implicit and explicit steps alike. None:
  /// every pair (one process).
  void set_partition(const std::optional<NodePartition>& owned);
  /// Whether the sets project this process's pairs only (a run over several processes).
  bool partitioned() const;
  /// This process's own figures (its pairs') and points, which a run over several processes
  /// combines (Simulation): combine_summaries, gathered and sorted points.
  ContactSummary local_summary() const;
  std::vector<ContactPoint> local_points() const;
  /// The processes' combined figures of this evaluation: summary() returns them until the next
  /// projection.
  void agree(const ContactSummary& over_processes);
  /// ContactSet::clear_dissipation of every set.
  void clear_dissipation();
  /// The processes' points of the last converged state, for points().
  void set_gathered_points(std::vector<ContactPoint> points);
  /// "spline", "surface" or "spline and surface".
  std::string formulations() const;
  /// The spline contact set, or null (checkpoints save and restore it).
  SplineContactSet* spline();
  const SplineContactSet* spline() const;
  /// The surface contact set, or null (checkpoints save and restore it).
  SurfaceContactSet* surface();
  const SurfaceContactSet* surface() const;

private:
  std::vector<std::unique_ptr<ContactSet>> sets_;
  std::vector<std::string> names_;
  std::optional<NodePartition> partition_;
  std::optional<ContactSummary> agreed_;
  std::vector<ContactPoint> gathered_points_;
};

} // namespace yarnsim
