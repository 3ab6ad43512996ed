// Taking and restoring a Simulation's checkpoint (checkpoint.hpp). A restored simulation holds
// the same numbers as the one that took the checkpoint, bit for bit, wherever they feed the next
// increment: the converged state and its histories, the step size in use, the work sums, the
// contact sets' search boxes, warm starts and last evaluation, the tangent's sparsity pattern
// (replayed, so that the fill-reducing ordering and hence the round-off are the same) and, inside
// an explicit step, the central-difference integrator.

#include "engine/solver/checkpoint.hpp"
#include "engine/solver/distributed.hpp"

#include <algorithm>
#include <fmt/format.h>
#include <stdexcept>

namespace yarnsim {

namespace {

void require_columns(const char* what, Eigen::Index found, Eigen::Index expected) {
  if (found != expected)
    throw std::invalid_argument(
        fmt::format("checkpoint: {} has {} columns, the model needs {}", what, found, expected));
}

} // namespace

SimulationCheckpoint Simulation::checkpoint() const {
  SimulationCheckpoint c;
  c.step = step_;
  c.next_dt = next_dt_;
  c.state = state_;
  c.reactions = reactions_;
  c.load_n = load_n_;
  c.external_work = external_work_;
  c.prescribed_work = prescribed_work_;
  c.damping_work = damping_work_;
  c.energy_reference = energy_reference_;
  c.total_iterations = total_iterations_;
  c.simplified_trials = simplified_trials_;
  c.secant_motion = secant_motion_;
  c.secant_rotation = secant_rotation_;
  c.secant_dt = secant_dt_;
  c.secant_step = secant_step_;
  c.secant_reach = secant_reach_;
  c.explicit_status = explicit_status_;
  for (const NodePartition& p : shares_)
    c.partition_cuts.push_back(p.first);
  if (!shares_.empty())
    c.partition_cuts.push_back(shares_.back().last);
  if (explicit_)
    c.explicit_progress = explicit_progress();
  // Over several processes, the processes' histories gathered at the last commit.
  const bool gathered = contact_ && contact_->partitioned();
  if (gathered &&
      ((contact_->spline() && !gathered_spline_) || (contact_->surface() && !gathered_surface_)))
    throw std::logic_error("checkpoint: over several processes the contact histories are gathered "
                           "at each commit, and none has been gathered yet");
  if (contact_ && contact_->spline())
    c.contact = gathered ? *gathered_spline_ : contact_->spline()->snapshot();
  if (contact_ && contact_->surface())
    c.surface_contact = gathered ? *gathered_surface_ : contact_->surface()->snapshot();
  // Each process's pattern of its share holds its own couplings: the checkpoint holds them all.
  c.pattern_groups = assembler_->share() ? gathered_couplings_ : assembler_->couplings();
  c.ordering = solver_->ordering();
  return c;
}

Simulation::Simulation(const Model& model, SimulationOptions options,
                       const SimulationCheckpoint& from)
    : Simulation(model, options) {
  const int n = state_.n_nodes();
  const auto ne = static_cast<Eigen::Index>(model.elements.size());
  if (from.step < 0 || from.step >= static_cast<int>(model.steps.size()))
    throw std::invalid_argument(fmt::format("checkpoint: step {} of a model with {} steps",
                                            from.step + 1, model.steps.size()));
  const State& s = from.state;
  require_columns("x_n", s.x_n.cols(), n);
  require_columns("v_n", s.v_n.cols(), n);
  require_columns("a_n", s.a_n.cols(), n);
  require_columns("W_n", s.W_n.cols(), n);
  require_columns("A_n", s.A_n.cols(), n);
  require_columns("rotation_n", s.rotation_n.cols(), n);
  require_columns("Q_n", static_cast<Eigen::Index>(s.Q_n.size()), n);
  require_columns("gauss", static_cast<Eigen::Index>(s.gauss.size()), ne);
  require_columns("reactions", from.reactions.cols(), n);
  require_columns("load_n", from.load_n.cols(), n);
  const bool spline = contact_ && contact_->spline();
  if (from.contact.has_value() != spline)
    throw std::invalid_argument(fmt::format("checkpoint: {} spline contact, the model {}",
                                            from.contact ? "has" : "has no",
                                            spline ? "has" : "has none"));
  const bool surface = contact_ && contact_->surface();
  if (from.surface_contact.has_value() != surface)
    throw std::invalid_argument(fmt::format("checkpoint: {} surface contact, the model {}",
                                            from.surface_contact ? "has" : "has no",
                                            surface ? "has" : "has none"));
  if (from.explicit_progress && (from.explicit_progress->step != from.step ||
                                 model.steps[from.step].type != StepType::Explicit))
    throw std::invalid_argument(fmt::format(
        "checkpoint: explicit integrator state for step {}, but step {} is in progress and is "
        "not that explicit step",
        from.explicit_progress->step + 1, from.step + 1));

  step_ = from.step;
  next_dt_ = from.next_dt;
  state_ = s;
  state_.x = state_.x_n;
  state_.alpha.setZero(3, n);
  reactions_ = from.reactions;
  load_n_ = from.load_n;
  external_work_ = from.external_work;
  prescribed_work_ = from.prescribed_work;
  damping_work_ = from.damping_work;
  energy_reference_ = from.energy_reference;
  total_iterations_ = from.total_iterations;
  simplified_trials_ = from.simplified_trials;
  if (from.secant_step >= 0 &&
      (from.secant_motion.cols() != n || from.secant_rotation.cols() != n || !(from.secant_dt > 0)))
    throw std::invalid_argument(fmt::format("checkpoint: the secant predictor's motion and "
                                            "rotation have {} and {} columns over {} s, "
                                            "expected {} (the model's nodes) over a time > 0",
                                            from.secant_motion.cols(), from.secant_rotation.cols(),
                                            from.secant_dt, n));
  if (!(from.secant_reach > 0))
    throw std::invalid_argument(fmt::format(
        "checkpoint: the secant predictor's reach is {}, expected > 0", from.secant_reach));
  secant_motion_ = from.secant_motion;
  secant_rotation_ = from.secant_rotation;
  secant_dt_ = from.secant_dt;
  secant_step_ = from.secant_step;
  secant_reach_ = from.secant_reach;
  explicit_status_ = from.explicit_status;
  // The partition the run had at its last commit, where it ran on as many processes (on
  // another number the elements' cuts stand, and rebalance decides at the run's start).
  const std::vector<int>& cuts = from.partition_cuts;
  if (partition_ && cuts.size() == shares_.size() + 1) {
    std::vector<NodePartition> shares;
    for (std::size_t k = 0; k + 1 < cuts.size(); ++k) {
      if (!(cuts[k] >= 0 && cuts[k] <= cuts[k + 1] && cuts[k + 1] <= n))
        throw std::invalid_argument(
            fmt::format("checkpoint: the partition's cuts are not ascending nodes in [0, {}]", n));
      shares.push_back({cuts[k], cuts[k + 1]});
    }
    if (shares.front().first != 0 || shares.back().last != n)
      throw std::invalid_argument(
          fmt::format("checkpoint: the partition's cuts do not span the {} nodes", n));
    shares_ = std::move(shares);
    partition_ = shares_[static_cast<std::size_t>(distributed::rank())];
    if (contact_)
      contact_->set_partition(partition_);
    if (assembler_->share())
      assembler_->set_share(*partition_);
  }
  if (from.explicit_progress)
    resume_explicit_ = std::make_unique<ExplicitProgress>(*from.explicit_progress);
  if (contact_)
    contact_->set_time(state_.time);
  if (spline)
    contact_->spline()->restore(*from.contact);
  if (surface)
    contact_->surface()->restore(*from.surface_contact);
  // Over several processes every one has restored the whole snapshot, as after an explicit step,
  // and keeps its own pairs from the next search on (ContactSet::set_owned).
  if (contact_ && contact_->partitioned())
    share_contact_pairs();

  for (const auto& g : from.pattern_groups)
    for (int node : g.nodes)
      if (node < 0 || node >= n)
        throw std::invalid_argument(
            fmt::format("checkpoint: a contact coupling names node index {} of {}", node, n));
  // A pattern of a process's share takes the couplings that touch its nodes (its own pairs' are
  // among them); the next pruning keeps those its pairs need.
  if (const auto& share = assembler_->share()) {
    std::vector<ContactCoupling> touching;
    for (const auto& g : from.pattern_groups)
      if (std::any_of(g.nodes.begin(), g.nodes.end(), [&](int node) { return share->owns(node); }))
        touching.push_back(g);
    assembler_->set_couplings(std::move(touching));
  } else {
    assembler_->set_couplings(from.pattern_groups);
  }
  solver_->set_ordering(from.ordering);
}

} // namespace yarnsim
