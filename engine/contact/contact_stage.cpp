#include "engine/contact/contact_stage.hpp"

#include "engine/contact/spline_contact_set.hpp"
#include "engine/contact/surface_contact_set.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

namespace yarnsim {

std::unique_ptr<ContactStage> ContactStage::of(const Model& model) {
  if (model.spline_contacts.empty() && model.surface_contacts.empty())
    return nullptr;
  auto stage = std::make_unique<ContactStage>();
  if (!model.spline_contacts.empty()) {
    stage->sets_.push_back(std::make_unique<SplineContactSet>(model));
    stage->names_.push_back("spline");
  }
  if (!model.surface_contacts.empty()) {
    stage->sets_.push_back(std::make_unique<SurfaceContactSet>(model));
    stage->names_.push_back("surface");
  }
  return stage;
}

bool ContactStage::update_candidates(const State& state) {
  bool changed = false;
  for (auto& set : sets_)
    changed = set->update_candidates(state) || changed;
  return changed;
}

void ContactStage::set_time(double t) {
  for (const auto& set : sets_)
    set->set_time(t);
}

void ContactStage::begin_attempt() {
  for (const auto& set : sets_)
    set->begin_attempt();
}

void ContactStage::set_explicit_path(bool explicit_path) {
  for (const auto& set : sets_)
    set->set_explicit_path(explicit_path);
}

std::string ContactStage::project(const State& state, bool want_tangent,
                                  const ContactRates* rates) {
  agreed_.reset();
  std::string veto;
  for (auto& set : sets_) {
    std::string why = set->project(state, want_tangent, rates);
    if (veto.empty())
      veto = std::move(why);
  }
  return veto;
}

std::string ContactStage::evaluate(const State& state, bool want_tangent) {
  update_candidates(state);
  return project(state, want_tangent);
}

int ContactStage::candidates_version() const {
  // Each set's version only grows, so the sum changes whenever one of them does.
  int version = 0;
  for (const auto& set : sets_)
    version += set->candidates_version();
  return version;
}

void ContactStage::add_candidate_loads(std::vector<double>& per_node, double weight) const {
  for (const auto& set : sets_)
    set->add_candidate_loads(per_node, weight);
}

std::vector<ContactCoupling> ContactStage::couplings() const {
  std::vector<ContactCoupling> out;
  for (const auto& set : sets_) {
    const auto c = set->couplings();
    out.insert(out.end(), c.begin(), c.end());
  }
  return out;
}

bool ContactStage::reads_triads() const {
  return std::any_of(sets_.begin(), sets_.end(),
                     [](const auto& set) { return set->reads_triads(); });
}

bool ContactStage::partitioned() const {
  return partition_.has_value();
}

void ContactStage::assemble(Eigen::VectorXd& residual, ContactTarget& target,
                            bool want_tangent) const {
  for (const auto& set : sets_)
    set->assemble(residual, target, want_tangent);
}

void ContactStage::commit() {
  for (auto& set : sets_)
    set->commit();
}

double ContactStage::closing_limit(const Eigen::Matrix3Xd& du, const Eigen::Matrix3Xd* offset,
                                   double allowance) const {
  double limit = std::numeric_limits<double>::infinity();
  for (const auto& set : sets_)
    limit = std::min(limit, set->closing_limit(du, offset, allowance));
  return limit;
}

ContactSummary combine_summaries(const std::vector<ContactSummary>& parts) {
  if (parts.size() == 1)
    return parts.front();
  ContactSummary out;
  out.min_gap = std::numeric_limits<double>::infinity();
  for (const ContactSummary& s : parts) {
    out.candidates += s.candidates;
    out.active_share += s.active_share;
    out.max_penetration = std::max(out.max_penetration, s.max_penetration);
    out.max_force = std::max(out.max_force, s.max_force);
    out.potential += s.potential;
    out.total_force += s.total_force;
    out.stick += s.stick;
    out.slip += s.slip;
    out.searched += s.searched;
    out.tangential_force += s.tangential_force;
    out.twist_stick += s.twist_stick;
    out.twist_slip += s.twist_slip;
    out.torque += s.torque;
    out.frictionless += s.frictionless;
    if (out.off_end == 0)
      out.off_end_yarns = s.off_end_yarns;
    out.off_end += s.off_end;
    out.dissipation += s.dissipation;
    out.min_gap = std::min(out.min_gap, s.min_gap);
    out.active_set = out.active_set * 0x9e3779b97f4a7c15ull + s.active_set;
  }
  out.active = static_cast<int>(std::lround(out.active_share));
  return out;
}

ContactSummary ContactStage::local_summary() const {
  std::vector<ContactSummary> parts;
  for (const auto& set : sets_)
    parts.push_back(set->summary());
  return combine_summaries(parts);
}

ContactSummary ContactStage::summary() const {
  return agreed_ ? *agreed_ : local_summary();
}

void ContactStage::set_partition(const std::optional<NodePartition>& owned) {
  partition_ = owned;
  for (auto& set : sets_)
    set->set_owned(partition_);
  agreed_.reset();
}

void ContactStage::agree(const ContactSummary& over_processes) {
  agreed_ = over_processes;
}

std::vector<ContactPoint> ContactStage::points() const {
  if (partitioned())
    return gathered_points_;
  return local_points();
}

void ContactStage::clear_dissipation() {
  for (auto& set : sets_)
    set->clear_dissipation();
}

void ContactStage::set_gathered_points(std::vector<ContactPoint> points) {
  gathered_points_ = std::move(points);
}

std::vector<ContactPoint> ContactStage::local_points() const {
  std::vector<ContactPoint> out;
  for (const auto& set : sets_) {
    const auto p = set->points();
    out.insert(out.end(), p.begin(), p.end());
  }
  return out;
}

std::string ContactStage::formulations() const {
  std::string out;
  for (std::size_t k = 0; k < names_.size(); ++k)
    out += (k == 0 ? "" : " and ") + names_[k];
  return out;
}

bool ContactStage::damped() const {
  const SplineContactSet* s = spline();
  const SurfaceContactSet* f = surface();
  return (s != nullptr && s->damped()) || (f != nullptr && f->damped());
}

SplineContactSet* ContactStage::spline() {
  return !names_.empty() && names_.front() == "spline"
             ? static_cast<SplineContactSet*>(sets_.front().get())
             : nullptr;
}

const SplineContactSet* ContactStage::spline() const {
  return const_cast<ContactStage*>(this)->spline();
}

SurfaceContactSet* ContactStage::surface() {
  return !names_.empty() && names_.back() == "surface"
             ? static_cast<SurfaceContactSet*>(sets_.back().get())
             : nullptr;
}

const SurfaceContactSet* ContactStage::surface() const {
  return const_cast<ContactStage*>(this)->surface();
}

} // namespace yarnsim
