#include "engine/contact/surface_contact_set.hpp"

#include "engine/contact/spline_contact_set.hpp" // make_interface_law

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <tuple>
#include <utility>

namespace yarnsim {

/// One contact definition: its segments (one per element of each surface in its groups), the
/// broad phase over them and the interface law.
struct SurfaceContactSet::Definition {
  std::vector<int> surface;  ///< per segment id
  std::vector<int> position; ///< per segment id: index of its element along the surface
  /// Per segment id, zero: the boxes (SuperEllipticalCylinder::bounding_box) hold the sections.
  std::vector<double> radius;
  std::unique_ptr<broadphase::CandidateSearch> search;
  std::shared_ptr<const contact::InterfaceLaw> law;
  std::vector<Eigen::AlignedBox3d> boxes;
  std::optional<contact::CoulombFriction> friction; ///< none: frictionless
  bool torsional = false;       ///< torsional friction at the crossings (with `friction`)
  double torsional_radius = 0;  ///< rho, m; 0: from the pair's widths
  double torsional_penalty = 0; ///< k_r, N m/rad; 0: eps_t rho^2
  /// m: a pair whose gap is below it is coupled in the tangent's pattern (couplings()): the
  /// broad-phase margin, as SplineContactSet's.
  double reach = 0;
  /// The torsional law of a pair of surfaces of widths wa, wb (m, twice the semi-axis a):
  /// FrictionParameters' defaults, as SplineContactSet's.
  contact::TorsionalFriction torsion(double wa, double wb) const {
    return contact::torsional_law(friction->mu_s(), friction->mu_k(), friction->eps_t(),
                                  torsional_radius, torsional_penalty, wa, wb,
                                  friction->elastic_slip());
  }
};

SurfaceContactSet::SurfaceContactSet(const Model& model) : model_(model) {
  for (const Surface& s : model.surfaces) {
    sections_.emplace_back(s.a, s.b, s.exponent);
    for (std::size_t k = 1; k < s.elements.size(); ++k)
      if (model.elements[s.elements[k]].nodes[0] != model.elements[s.elements[k - 1]].nodes[2])
        throw std::invalid_argument(fmt::format(
            "surface '{}': element {} does not start at the last node of element {} (a surface's "
            "elements must form a chain in order)",
            s.name, s.elements[k] + 1, s.elements[k - 1] + 1));
  }
  for (const SurfaceContactDefinition& def : model.surface_contacts) {
    auto d = std::make_unique<Definition>();
    std::vector<broadphase::SegmentInfo> info;
    double margin = def.margin;
    for (int group = 0; group < 2; ++group)
      for (int s : group == 0 ? def.group_a : def.group_b) {
        const Surface& surface = model.surfaces[s];
        for (std::size_t k = 0; k < surface.elements.size(); ++k) {
          d->surface.push_back(s);
          d->position.push_back(static_cast<int>(k));
          d->radius.push_back(0.0);
          info.push_back({s, static_cast<int>(k), group});
          // Default: the smaller semi-axis, the radius of a circle (as the spline contact's).
          // On the paper's fabric (a = 4 b) the larger one held 2 304 candidates for 138
          // contacts and cost 1.4 times the wall time (docs/performance.md, "The surface
          // contact at scale").
          if (def.margin <= 0)
            margin = std::max(margin, std::min(surface.a, surface.b));
        }
      }
    d->reach = margin;
    broadphase::CandidateSearchOptions options;
    options.margin = margin;
    options.same_curve_skip = 1;
    options.self_contact = false;
    d->search = std::make_unique<broadphase::CandidateSearch>(
        std::move(info), std::vector<std::pair<int, int>>{{0, 1}}, options);
    if (def.law.damping > 0)
      throw std::invalid_argument(
          fmt::format("contact '{}': surface contact damping is not available in this version "
                      "(found damping = {} N s/m)",
                      def.name, def.law.damping));
    d->law = make_interface_law(def.law);
    if (def.friction.active()) {
      const FrictionParameters& f = def.friction;
      try {
        d->friction.emplace(f.mu_static, f.mu_kinetic, f.tangential_penalty, f.tangential_damping,
                            f.elastic_slip);
      } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(fmt::format("contact '{}': {}", def.name, e.what()));
      }
      if (f.torsional) {
        if (!(std::isfinite(f.torsional_radius) && f.torsional_radius >= 0 &&
              std::isfinite(f.torsional_penalty) && f.torsional_penalty >= 0))
          throw std::invalid_argument(fmt::format(
              "contact '{}': expected torsional_radius >= 0 m and torsional_penalty >= 0 N m/rad "
              "(0: the defaults), found {} and {}",
              def.name, f.torsional_radius, f.torsional_penalty));
        d->torsional = true;
        d->torsional_radius = f.torsional_radius;
        d->torsional_penalty = f.torsional_penalty;
      }
      any_friction_ = true;
      damped_ = damped_ || d->friction->c_t() > 0;
    }
    d->boxes.resize(d->surface.size());
    definitions_.push_back(std::move(d));
  }
}

SurfaceContactSet::~SurfaceContactSet() = default;

std::array<int, 4> SurfaceContactSet::nodes_of(const Definition& d,
                                               const broadphase::CandidatePair& p) const {
  const BeamElement& a =
      model_.elements[model_.surfaces[d.surface[p.first]].elements[d.position[p.first]]];
  const BeamElement& b =
      model_.elements[model_.surfaces[d.surface[p.second]].elements[d.position[p.second]]];
  return {a.nodes[0], a.nodes[2], b.nodes[0], b.nodes[2]};
}

contact::SuperEllipticalCylinder SurfaceContactSet::cylinder(const Definition& d, int s,
                                                             const State& state) const {
  const Surface& surface = model_.surfaces[d.surface[s]];
  const int k = d.position[s];
  auto node = [&state](int n) {
    return contact::SurfaceNode{state.x.col(n), state.alpha.col(n), state.Q_n[n]};
  };
  const BeamElement& el = model_.elements[surface.elements[k]];
  const bool last = k + 1 == static_cast<int>(surface.elements.size());
  if (k == 0)
    return {node(el.nodes[0]), node(el.nodes[2]), sections_[d.surface[s]], last};
  // The element before knows the ridge at the shared node (SurfaceDegeneration::RidgeOnA).
  const contact::SurfaceNode previous = node(model_.elements[surface.elements[k - 1]].nodes[0]);
  return {node(el.nodes[0]), node(el.nodes[2]), sections_[d.surface[s]], last, &previous};
}

int SurfaceContactSet::first_node(const Definition& d, int s) const {
  return model_.elements[model_.surfaces[d.surface[s]].elements[d.position[s]]].nodes[0];
}

int SurfaceContactSet::owner_node(const Definition& d, const broadphase::CandidatePair& p) const {
  return pair_owner_node(d.surface[p.first], d.surface[p.second], first_node(d, p.first),
                         first_node(d, p.second));
}

bool SurfaceContactSet::owns(const Definition& d, const broadphase::CandidatePair& p) const {
  return !owned_ || owned_->owns(owner_node(d, p));
}

void SurfaceContactSet::add_candidate_loads(std::vector<double>& per_node, double weight) const {
  for (const auto& d : definitions_)
    for (const broadphase::CandidatePair& p : d->search->candidates())
      if (const int k = owner_node(*d, p); !owned_ || owned_->owns(k))
        per_node[static_cast<std::size_t>(k)] += weight;
}

bool SurfaceContactSet::update_candidates(const State& state) {
  bool changed = (work_.empty() && candidates_version_ == 0) || rebuild_work_;
  if (rebuild_work_) // a new share: each search holds the pairs it may own (set_owned)
    for (auto& d : definitions_)
      d->search->set_share(
          share_flags(d->surface.size(), [&](int s) { return first_node(*d, s); }));
  rebuild_work_ = false;
  // The boxes hold the sections as they are oriented, and the end windows of the options
  // project() uses.
  const double window = contact::SurfaceContactOptions{}.end_window;
  for (auto& dp : definitions_) {
    Definition& d = *dp;
    for (std::size_t s = 0; s < d.surface.size(); ++s)
      d.boxes[s] = cylinder(d, static_cast<int>(s), state).bounding_box(window);
    changed = d.search->update(d.boxes, d.radius) || changed;
  }
  if (!changed)
    return false;
  // The work list follows the candidates: rebuilt only when a search changed them.
  ++candidates_version_;
  work_.clear();
  assembly_slots_.clear();
  for (std::size_t k = 0; k < definitions_.size(); ++k)
    for (const broadphase::CandidatePair& p : definitions_[k]->search->candidates())
      if (owns(*definitions_[k], p))
        work_.push_back({static_cast<int>(k), p, {}, {}, {}});
  link_warm_starts(work_, committed_);
  by_second_.resize(work_.size());
  for (std::size_t i = 0; i < by_second_.size(); ++i)
    by_second_[i] = i;
  std::sort(by_second_.begin(), by_second_.end(), [&](std::size_t i, std::size_t j) {
    const Work& p = work_[i];
    const Work& q = work_[j];
    return std::tie(p.definition, p.pair.second, p.pair.first) <
           std::tie(q.definition, q.pair.second, q.pair.first);
  });
  return true;
}

std::string SurfaceContactSet::project(const State& state, bool want_tangent,
                                       const ContactRates* rates) {
  contact::SurfaceContactOptions options;
  options.compute_tangent = want_tangent;
  if (any_friction_) {
    friction_.resize(work_.size());
    twist_.resize(work_.size());
  }
  // One list of terms and one scratch per arena slot.
  const std::size_t slots = static_cast<std::size_t>(tbb::this_task_arena::max_concurrency());
  terms_.reset(slots);
  friction_terms_.reset(slots);
  scratch_.resize(std::max(slots, scratch_.size()));
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, work_.size(), 8),
      [&](const tbb::blocked_range<std::size_t>& range) {
        for (std::size_t w = range.begin(); w != range.end(); ++w) {
          Work& item = work_[w];
          const Definition& d = *definitions_[item.definition];
          const int slot = tbb::this_task_arena::current_thread_index();
          Scratch& scratch = scratch_[static_cast<std::size_t>(slot)];
          contact::SurfaceContactResult& result = scratch.result;
          contact::SurfaceContactSensitivity* sensitivity =
              d.friction ? &scratch.sensitivity : nullptr;
          contact::SurfaceProjectionStart start;
          if (item.warm >= 0) {
            const Snapshot::Warm& c = committed_[item.warm];
            start = {c.zeta_A, c.theta_A, c.zeta_B, c.theta_B, true};
          }
          try {
            const auto A = cylinder(d, item.pair.first, state);
            const auto B = cylinder(d, item.pair.second, state);
            contact::surface_contact(A, B, start, *d.law, result, options, nullptr, sensitivity);
            if (result.status == contact::ProjectionStatus::Jumped) {
              // The warm start led far away. Where the last solution has vanished (two critical
              // points of the distance met and annihilated, as happens on the flat faces of
              // wide ellipses), no smaller step brings it back: the solution a cold start finds
              // from the geometry alone is then the pair's contact. The jump stands (and vetoes
              // the increment) only if the cold start finds another point.
              const contact::SurfaceContactResult& warm = result;
              contact::SurfaceContactSensitivity cold_sensitivity;
              const auto cold = contact::surface_contact(A, B, {}, *d.law, options, nullptr,
                                                         sensitivity ? &cold_sensitivity : nullptr);
              const double tolerance = 1e-6;
              if (cold.status == contact::ProjectionStatus::Converged &&
                  std::abs(cold.zeta_A - warm.zeta_A) < tolerance &&
                  std::abs(cold.zeta_B - warm.zeta_B) < tolerance &&
                  std::abs(std::remainder(cold.theta_A - warm.theta_A, 2 * std::numbers::pi)) <
                      tolerance &&
                  std::abs(std::remainder(cold.theta_B - warm.theta_B, 2 * std::numbers::pi)) <
                      tolerance) {
                result = cold;
                if (sensitivity)
                  *sensitivity = cold_sensitivity;
              }
            }
          } catch (const std::invalid_argument&) {
            // Non-finite node data (a diverging iterate): the pair cannot be projected.
            result = {};
            result.status = contact::ProjectionStatus::NotConverged;
            if (sensitivity)
              sensitivity->valid = false;
          }
          keep(w, result, scratch.sensitivity, slot, want_tangent);
        }
      });

  share_split_contacts();

  if (any_friction_) {
    // Friction at the active regular contacts, on the histories of the last converged
    // increment (held fixed through the iterations): the committed one of the pair, or a first
    // touch. Near a node both elements' pairs hold the contact with their shares, each with its
    // own anchor (contact/surface_friction.hpp), so no history is handed over.
    for (std::size_t w = 0; w < work_.size(); ++w) {
      Work& item = work_[w];
      item.first_touch = false;
      if (!definitions_[item.definition]->friction || !item.result.active ||
          !friction_terms_of(item).sensitivity.valid)
        continue;
      const Snapshot::Warm* c = item.warm >= 0 ? &committed_[item.warm] : nullptr;
      if (c != nullptr && c->friction != 0) {
        item.history = {c->anchor_zeta_A, c->anchor_theta_A, c->anchor_zeta_B, c->anchor_theta_B,
                        c->friction == 1, c->twist_anchor,   c->twist != 2};
        item.slip = c->slip;
        item.twist_slip = c->twist_slip;
      } else {
        item.history = contact::first_touch(item.result);
        item.slip = 0;
        item.twist_slip = 0;
        item.first_touch = true;
      }
    }
    contact::FrictionOptions friction_options;
    friction_options.compute_tangent = want_tangent;
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, work_.size(), 8),
        [&](const tbb::blocked_range<std::size_t>& range) {
          for (std::size_t w = range.begin(); w != range.end(); ++w) {
            Work& item = work_[w];
            const Definition& d = *definitions_[item.definition];
            friction_[w].active = false;
            twist_[w].active = false;
            if (!d.friction || !item.result.active)
              continue;
            FrictionTerms& terms = friction_terms_of(item);
            if (!terms.sensitivity.valid)
              continue;
            const auto A = cylinder(d, item.pair.first, state);
            const auto B = cylinder(d, item.pair.second, state);
            if (item.first_touch) {
              // Anchored where it is if this increment converges (commit).
              if (d.torsional)
                item.history.twist = contact::surface_crossing_angle(A, B, item.result);
              continue;
            }
            // Tangential damping: the kernel's DOF rates, per surface node A, node B translations
            // then Rodrigues rates alpha' = Xi(alpha)^-1 omega (omega spatial).
            contact::SurfacePairRates pair_rates;
            const bool damped =
                rates != nullptr && rates->velocity != nullptr && d.friction->c_t() > 0;
            if (damped) {
              const std::array<int, 4> nodes = nodes_of(d, item.pair);
              const contact::SuperEllipticalCylinder* cyl[2] = {&A, &B};
              for (int X = 0; X < 2; ++X)
                for (int k = 0; k < 2; ++k) {
                  const int node = nodes[2 * X + k];
                  pair_rates.rate.segment<3>(12 * X + 3 * k) = rates->velocity->col(node);
                  if (rates->angular_velocity != nullptr)
                    pair_rates.rate.segment<3>(12 * X + 6 + 3 * k) =
                        cyl[X]->xi(k).inverse() * rates->angular_velocity->col(node);
                }
              pair_rates.velocity_per_displacement = rates->velocity_per_displacement;
            }
            Scratch& scratch =
                scratch_[static_cast<std::size_t>(tbb::this_task_arena::current_thread_index())];
            contact::SurfaceFrictionResult& f = scratch.friction;
            contact::surface_friction(
                A, B, item.result, want_tangent ? &terms.sensitivity : nullptr, item.history,
                *d.friction, f, friction_options, damped ? &pair_rates : nullptr);
            if (d.torsional) {
              const Surface& sa = model_.surfaces[d.surface[item.pair.first]];
              const Surface& sb = model_.surfaces[d.surface[item.pair.second]];
              contact::SurfaceTorsionalFrictionResult& t = scratch.torsion;
              contact::surface_torsional_friction(
                  A, B, item.result, want_tangent ? &terms.sensitivity : nullptr, item.history,
                  d.torsion(2 * sa.a, 2 * sb.a), t, friction_options);
              f.residual += t.residual;
              if (want_tangent)
                f.tangent += t.tangent;
              twist_[w] = {t.active,      t.slipping, t.torque, t.slip_increment,
                           t.dissipation, t.energy,   t.anchor};
            }
            keep_friction_terms(f, want_tangent, friction_[w], terms);
          }
        });
  }

  summarise();

  // Veto: a pair in contact at the last converged increment, or now, whose projection failed or
  // jumped (the first in the work list's order, found by summarise).
  if (scan_.first_vetoed >= 0) {
    const Work& item = work_[static_cast<std::size_t>(scan_.first_vetoed)];
    const Definition& d = *definitions_[item.definition];
    const auto element = [&](int s) {
      return model_.surfaces[d.surface[s]].elements[d.position[s]] + 1;
    };
    return fmt::format(
        "contact '{}': surface projection {} between surface '{}' element {} "
        "and surface '{}' element {}",
        model_.surface_contacts[item.definition].name, contact::to_string(item.result.status),
        model_.surfaces[d.surface[item.pair.first]].name, element(item.pair.first),
        model_.surfaces[d.surface[item.pair.second]].name, element(item.pair.second));
  }
  return {};
}

void SurfaceContactSet::summarise() {
  summary_ = {};
  summary_.candidates = static_cast<int>(work_.size());
  summary_.searched = 0;
  for (const auto& d : definitions_)
    summary_.searched += static_cast<int>(d->search->candidates().size());
  // In parallel (scan_work); the active items are then summed here in their order.
  scan_work(work_.size(), scan_blocks_, scan_, [&](std::size_t w) {
    const Work& item = work_[w];
    const contact::SurfaceContactState& r = item.result;
    const bool was_active = item.warm >= 0 && committed_[item.warm].active;
    ItemScan out = scan_result(r, was_active);
    out.listed = r.active || (any_friction_ && w < friction_.size() && friction_[w].active);
    return out;
  });
  summary_.min_gap = scan_.min_gap;
  double active_share = 0;
  for (const int k : scan_.listed) {
    const Work& w = work_[static_cast<std::size_t>(k)];
    const auto& r = w.result;
    if (!r.active)
      continue;
    summary_.active_set =
        fold_active_pair(summary_.active_set | 1, w.definition, w.pair.first, w.pair.second);
    // Contact points: a contact near a node, held by two pairs, counts once in all (their
    // shares sum to one).
    active_share += w.factor * r.share;
    summary_.max_penetration = std::max(summary_.max_penetration, r.penetration);
    summary_.max_force = std::max(summary_.max_force, w.factor * r.force);
    summary_.potential += w.factor * r.potential;
    summary_.total_force += w.factor * r.force;
    if (r.degeneration != contact::SurfaceDegeneration::None &&
        definitions_[w.definition]->friction)
      ++summary_.frictionless;
  }
  summary_.active = static_cast<int>(std::lround(active_share));
  summary_.active_share = active_share;
  summary_.dissipation = dissipated_;
  if (!any_friction_)
    return;
  for (const int listed : scan_.listed) {
    const std::size_t k = static_cast<std::size_t>(listed);
    if (k >= friction_.size())
      break;
    const contact::SurfaceFrictionState& f = friction_[k];
    if (!f.active)
      continue;
    const Work& w = work_[k];
    ++(f.slipping ? summary_.slip : summary_.stick);
    // A stick/slip switch is a kink of the law, as a pair that opens or closes.
    if (f.slipping)
      summary_.active_set =
          fold_active_pair(summary_.active_set, -1 - w.definition, w.pair.first, w.pair.second);
    summary_.tangential_force += w.factor * f.force.norm();
    // The spring's elastic energy |f|^2 / (2 k) (k the stick stiffness: w eps_t, or
    // mu f_n / gamma).
    if (f.stiffness > 0)
      summary_.potential += w.factor * f.force.squaredNorm() / (2.0 * f.stiffness);
    summary_.dissipation += w.factor * f.dissipation;
    const Twist& t = twist_[k];
    if (!t.active)
      continue;
    ++(t.slipping ? summary_.twist_slip : summary_.twist_stick);
    if (t.slipping) // a kink of the torsional law, as above
      summary_.active_set = fold_active_pair(summary_.active_set, -(1 << 20) - w.definition,
                                             w.pair.first, w.pair.second);
    summary_.torque += w.factor * std::abs(t.torque);
    summary_.potential += w.factor * t.energy;
    summary_.dissipation += w.factor * t.dissipation;
  }
}

void SurfaceContactSet::share_split_contacts() {
  // The surface of a yarn is kinked at the nodes between its elements' cylinders. Where the kink
  // faces the other yarn as a valley, the pairs of the two elements with one element of the
  // other yarn find two critical points, one on either side of the node, where a smooth yarn
  // would have one contact; their shares (contact::SurfaceContactOptions::end_window) then sum
  // to more than one. Where the two points lie within l of each other on the shared element
  // (l = min(a, b) / 2 of its surface), the pairs' forces are scaled by
  //   m = 1 - phi + phi / (s_p + s_q),  phi = (1 - r^2)^2 for r = d / l < 1, else 0,
  // s_p, s_q the two pairs' shares on the kinked side: one contact in all where the points
  // coincide, two separate ones from l apart. Where one pair's point is the other's seen from
  // across the node (a contact passing a node of a straight or convex stretch), s_p + s_q = 1
  // and m = 1: the windows share such a contact already. The tangent leaves out dm/dd.
  for (Work& w : work_)
    w.factor = 1.0;
  auto share = [&](Work& p, Work& q, bool shared_first) {
    if (p.definition != q.definition || !p.result.active || !q.result.active)
      return;
    const Definition& d = *definitions_[p.definition];
    const int ps = shared_first ? p.pair.first : p.pair.second;
    const int qs = shared_first ? q.pair.first : q.pair.second;
    const int po = shared_first ? p.pair.second : p.pair.first;
    const int qo = shared_first ? q.pair.second : q.pair.first;
    if (ps != qs || d.surface[po] != d.surface[qo] ||
        std::abs(d.position[po] - d.position[qo]) != 1)
      return;
    const Surface& shared = model_.surfaces[d.surface[ps]];
    const double l = 0.5 * std::min(shared.a, shared.b);
    const Eigen::Vector3d& x_p = shared_first ? p.result.point_A : p.result.point_B;
    const Eigen::Vector3d& x_q = shared_first ? q.result.point_A : q.result.point_B;
    const double r = (x_p - x_q).norm() / l;
    if (r >= 1)
      return;
    const double phi = (1 - r * r) * (1 - r * r);
    const double sum =
        shared_first ? p.result.share_B + q.result.share_B : p.result.share_A + q.result.share_A;
    const double m = 1 - phi + phi / sum;
    p.factor *= m;
    q.factor *= m;
  };
  // work_ is sorted by (definition, first, second): pairs sharing a first element are adjacent;
  // pairs sharing a second element are adjacent in by_second_.
  for (std::size_t i = 0; i + 1 < work_.size(); ++i)
    share(work_[i], work_[i + 1], true);
  for (std::size_t k = 0; k + 1 < by_second_.size(); ++k)
    share(work_[by_second_[k]], work_[by_second_[k + 1]], false);
}

void SurfaceContactSet::keep(std::size_t w, const contact::SurfaceContactResult& result,
                             const contact::SurfaceContactSensitivity& sensitivity, int slot,
                             bool with_tangent) {
  Work& item = work_[w];
  keep_terms(item, result, sensitivity, definitions_[item.definition]->friction.has_value(), slot,
             with_tangent, terms_, friction_terms_);
}

const SurfaceContactSet::Terms& SurfaceContactSet::terms_of(const Work& item) const {
  if (item.terms.slot < 0)
    throw std::logic_error(fmt::format("SurfaceContactSet: pair ({}, {}) of definition {} is in "
                                       "contact with no residual kept (assembled before a "
                                       "projection)",
                                       item.pair.first, item.pair.second, item.definition));
  return terms_.at(item.terms);
}

SurfaceContactSet::FrictionTerms& SurfaceContactSet::friction_terms_of(const Work& item) {
  return const_cast<FrictionTerms&>(std::as_const(*this).friction_terms_of(item));
}

const SurfaceContactSet::FrictionTerms&
SurfaceContactSet::friction_terms_of(const Work& item) const {
  if (item.friction_terms.slot < 0)
    throw std::logic_error(fmt::format("SurfaceContactSet: pair ({}, {}) of definition {} is in "
                                       "contact with no friction terms kept",
                                       item.pair.first, item.pair.second, item.definition));
  return friction_terms_.at(item.friction_terms);
}

std::vector<ContactCoupling> SurfaceContactSet::couplings() const {
  std::vector<ContactCoupling> out;
  for (const Work& item : work_) {
    const Definition& d = *definitions_[item.definition];
    if (!needs_coupling(item.result, d.reach))
      continue;
    const std::array<int, 4> n = nodes_of(d, item.pair);
    out.push_back({{n[0], n[1], n[2], n[3], n[3], n[3]}, true});
  }
  return out;
}

void SurfaceContactSet::assemble(Eigen::VectorXd& residual, ContactTarget& target,
                                 bool want_tangent) const {
  // The tangents' slots in the matrix are looked up in parallel, then every pair is added in
  // its order (find_active_slots).
  constexpr int kBlock = 24 * 24;
  find_active_slots(work_, want_tangent, kBlock, target.pattern_id(), assembly_items_,
                    assembly_slots_, [&](const Work& item, int* slots) {
                      target.surface_pair_block_slots(
                          nodes_of(*definitions_[item.definition], item.pair), slots);
                    });
  // The items added in parallel over their end nodes, each node's in the items' order
  // (add_by_node): the same sums as one loop over the items.
  assembly_nodes_.resize(assembly_items_.size());
  for (std::size_t i = 0; i < assembly_items_.size(); ++i) {
    const Work& item = work_[static_cast<std::size_t>(assembly_items_[i])];
    assembly_nodes_[i] = nodes_of(*definitions_[item.definition], item.pair);
  }
  double* values = target.tangent_values();
  add_by_node(target.n_nodes(), assembly_nodes_, assembly_offsets_, assembly_incident_,
              [&](std::size_t i, int node) {
                const std::size_t k = static_cast<std::size_t>(assembly_items_[i]);
                const Work& item = work_[k];
                const Terms& terms = terms_of(item);
                const std::array<int, 4>& n = assembly_nodes_[i];
                // Kernel order per surface X (0: A, 1: B): x_first, x_last, alpha_first,
                // alpha_last.
                const double w = item.factor;
                for (int X = 0; X < 2; ++X)
                  for (int j = 0; j < 2; ++j) {
                    if (n[2 * X + j] != node)
                      continue;
                    residual.segment<3>(6 * node) += w * terms.residual.segment<3>(12 * X + 3 * j);
                    residual.segment<3>(6 * node + 3) +=
                        w * terms.residual.segment<3>(12 * X + 6 + 3 * j);
                  }
                const FrictionTerms* f =
                    any_friction_ && friction_[k].active ? &friction_terms_of(item) : nullptr;
                if (f)
                  for (int X = 0; X < 2; ++X)
                    for (int j = 0; j < 2; ++j) {
                      if (n[2 * X + j] != node)
                        continue;
                      residual.segment<3>(6 * node) += w * f->residual.segment<3>(12 * X + 3 * j);
                      residual.segment<3>(6 * node + 3) +=
                          w * f->residual.segment<3>(12 * X + 6 + 3 * j);
                    }
                if (!want_tangent)
                  return;
                // Slot (r, c) lies in the column of kernel index c's node
                // (surface_pair_block_slots).
                const int* slots = assembly_slots_.slots(assembly_items_[i]);
                for (int c = 0; c < 24; ++c) {
                  const int X = c / 12, rest = c % 12;
                  if (n[2 * X + (rest % 6) / 3] != node)
                    continue;
                  for (int r = 0; r < 24; ++r) {
                    const int slot = slots[24 * c + r];
                    if (slot < 0)
                      continue;
                    values[slot] +=
                        f ? w * (terms.tangent(r, c) + f->tangent(r, c)) : w * terms.tangent(r, c);
                  }
                }
              });
}

void SurfaceContactSet::commit() {
  // Keep warm starts of the current candidates only; pairs that left the list start cold.
  next_committed_.clear();
  for (Work& item : work_) {
    const auto& r = item.result;
    item.warm = -1;
    if (r.status == contact::ProjectionStatus::NotConverged)
      continue;
    item.warm = static_cast<int>(next_committed_.size());
    Snapshot::Warm& warm = next_committed_.emplace_back(
        Snapshot::Warm{Key{item.definition, item.pair.first, item.pair.second}, r.zeta_A, r.theta_A,
                       r.zeta_B, r.theta_B, r.active});
    const std::size_t k = static_cast<std::size_t>(&item - work_.data());
    const contact::SurfaceFrictionHistory* h = nullptr;
    if (any_friction_ && friction_[k].active) {
      const contact::SurfaceFrictionState& f = friction_[k];
      h = &f.history;
      warm.friction = f.slipping ? 2 : 1;
      warm.slip = item.slip + f.slip_increment;
      dissipated_ += item.factor * f.dissipation;
      const Twist& t = twist_[k];
      if (t.active) {
        warm.twist_anchor = t.anchor;
        warm.twist = t.slipping ? 2 : 1;
        warm.twist_slip = item.twist_slip + t.slip_increment;
        dissipated_ += item.factor * t.dissipation;
      }
    } else if (any_friction_ && item.first_touch) {
      // Closed in this increment: anchored where it is, stuck.
      h = &item.history;
      warm.friction = 1;
      warm.slip = 0;
      if (definitions_[item.definition]->torsional) {
        warm.twist_anchor = item.history.twist;
        warm.twist = 1;
        warm.twist_slip = 0;
      }
    }
    if (h) {
      warm.anchor_zeta_A = h->zeta_A;
      warm.anchor_theta_A = h->theta_A;
      warm.anchor_zeta_B = h->zeta_B;
      warm.anchor_theta_B = h->theta_B;
    }
  }
  std::swap(committed_, next_committed_);
}

std::vector<ContactPoint> SurfaceContactSet::points() const {
  std::vector<ContactPoint> out;
  for (const Work& w : work_) {
    if (!w.result.active)
      continue;
    const Definition& d = *definitions_[w.definition];
    ContactPoint& p = out.emplace_back();
    p.position = 0.5 * (w.result.point_A + w.result.point_B);
    p.normal = w.result.normal;
    p.gap = w.result.gap;
    p.force = w.factor * w.result.force;
    p.surface = true;
    p.definition = w.definition;
    const int a = d.surface[w.pair.first], b = d.surface[w.pair.second];
    p.body = {a, b};
    p.segment = {model_.surfaces[a].elements[d.position[w.pair.first]],
                 model_.surfaces[b].elements[d.position[w.pair.second]]};
    p.pair = {w.pair.first, w.pair.second};
    const std::size_t k = static_cast<std::size_t>(&w - work_.data());
    if (any_friction_ && friction_[k].active) {
      const contact::SurfaceFrictionState& f = friction_[k];
      p.tangential_force = w.factor * f.force;
      p.friction = f.slipping ? 2 : 1;
      p.slip = w.slip + f.slip_increment;
      const Twist& t = twist_[k];
      if (t.active) {
        p.torque = w.factor * t.torque;
        p.twist = t.slipping ? 2 : 1;
        p.twist_slip = w.twist_slip + t.slip_increment;
      }
    }
  }
  return out;
}

SurfaceContactSet::Snapshot SurfaceContactSet::snapshot() const {
  Snapshot out;
  for (const auto& d : definitions_)
    out.search_boxes.push_back(d->search->searched_boxes());
  out.committed = committed_;
  out.pairs.reserve(work_.size());
  for (const Work& w : work_) {
    const contact::SurfaceContactState& r = w.result;
    out.pairs.push_back({Key{w.definition, w.pair.first, w.pair.second},
                         r.status,
                         r.degeneration,
                         r.active,
                         r.iterations,
                         r.zeta_A,
                         r.theta_A,
                         r.zeta_B,
                         r.theta_B,
                         r.gap,
                         r.penetration,
                         r.penetration_rate,
                         r.force,
                         r.potential,
                         r.share,
                         r.share_A,
                         r.share_B,
                         w.factor,
                         r.point_A,
                         r.point_B,
                         r.normal});
  }
  out.candidates_version = candidates_version_;
  out.summary = summary_;
  out.dissipated = dissipated_;
  return out;
}

void SurfaceContactSet::restore(const Snapshot& snapshot) {
  if (snapshot.search_boxes.size() != definitions_.size())
    throw std::invalid_argument(
        fmt::format("surface contact restart: {} contact definitions saved, the model has {}",
                    snapshot.search_boxes.size(), definitions_.size()));
  // Searching the saved boxes again makes them the reference of the motion test and gives the
  // candidates of the saved search (sorted, independent of the tree).
  std::vector<Key> searched;
  for (std::size_t k = 0; k < definitions_.size(); ++k) {
    Definition& d = *definitions_[k];
    if (snapshot.search_boxes[k].size() != d.boxes.size())
      throw std::invalid_argument(fmt::format(
          "surface contact restart: definition '{}' has {} segments, the snapshot {} boxes",
          model_.surface_contacts[k].name, d.boxes.size(), snapshot.search_boxes[k].size()));
    d.search->update(snapshot.search_boxes[k], d.radius, true);
    for (const broadphase::CandidatePair& p : d.search->candidates())
      searched.push_back({static_cast<int>(k), p.first, p.second});
  }
  // Every saved pair is restored (the run's figures, points and snapshots as they stand:
  // Simulation::share_contact_pairs); the next search's work list keeps this process's own.
  check_saved_pairs(
      snapshot.pairs, searched, !owned_, static_cast<int>(definitions_.size()),
      [&](int k) { return static_cast<int>(definitions_[k]->surface.size()); }, "surface contact");
  std::vector<Work> work;
  work.reserve(snapshot.pairs.size());
  for (std::size_t w = 0; w < snapshot.pairs.size(); ++w) {
    const Snapshot::Pair& p = snapshot.pairs[w];
    work.push_back({p.key[0], {p.key[1], p.key[2]}, {}, {}, {}});
    contact::SurfaceContactState& r = work[w].result;
    r.status = p.status;
    r.degeneration = p.degeneration;
    r.iterations = p.iterations;
    r.zeta_A = p.zeta_A;
    r.theta_A = p.theta_A;
    r.zeta_B = p.zeta_B;
    r.theta_B = p.theta_B;
    r.point_A = p.point_A;
    r.point_B = p.point_B;
    r.normal = p.normal;
    r.gap = p.gap;
    r.penetration = p.penetration;
    r.penetration_rate = p.penetration_rate;
    r.force = p.force;
    r.potential = p.potential;
    r.active = p.active;
    r.share = p.share;
    r.share_A = p.share_A;
    r.share_B = p.share_B;
    work[w].factor = p.factor;
  }
  work_ = std::move(work);
  assembly_slots_.clear();
  // The by-second index as update_candidates builds it.
  by_second_.resize(work_.size());
  for (std::size_t i = 0; i < by_second_.size(); ++i)
    by_second_[i] = i;
  std::sort(by_second_.begin(), by_second_.end(), [&](std::size_t i, std::size_t j) {
    const Work& p = work_[i];
    const Work& q = work_[j];
    return std::tie(p.definition, p.pair.second, p.pair.first) <
           std::tie(q.definition, q.pair.second, q.pair.first);
  });
  committed_ = snapshot.committed;
  link_warm_starts(work_, committed_);
  candidates_version_ = snapshot.candidates_version;
  summary_ = snapshot.summary;
  dissipated_ = snapshot.dissipated;
  // The friction results are not saved: the next evaluation computes them (the saved summary
  // holds their figures until then).
  if (any_friction_) {
    friction_.assign(work_.size(), {});
    twist_.assign(work_.size(), {});
  }
  // A share of the pairs (set_owned): the next search's work list keeps this process's alone
  // (the summary above is the whole snapshot's, as saved).
  if (owned_)
    rebuild_work_ = true;
}

double SurfaceContactSet::closing_limit(const Eigen::Matrix3Xd& du, const Eigen::Matrix3Xd* offset,
                                        double allowance) const {
  return smallest_limit(work_.size(), [&](std::size_t w) {
    const Work& item = work_[w];
    const contact::SurfaceContactState& r = item.result;
    constexpr double kNone = std::numeric_limits<double>::infinity();
    if (r.status != contact::ProjectionStatus::Converged || r.active)
      return kNone;
    const Definition& d = *definitions_[item.definition];
    const std::array<int, 4> n = nodes_of(d, item.pair);
    // The motion of the axis points under nodal translations u, (1 - zeta)/2 u_A +
    // (1 + zeta)/2 u_B on each surface; the sections' rotations are left out.
    const auto relative = [&](const Eigen::Matrix3Xd& u) -> Eigen::Vector3d {
      return 0.5 * (1 - r.zeta_A) * u.col(n[0]) + 0.5 * (1 + r.zeta_A) * u.col(n[1]) -
             0.5 * (1 - r.zeta_B) * u.col(n[2]) - 0.5 * (1 + r.zeta_B) * u.col(n[3]);
    };
    const double gap = offset ? r.gap + r.normal.dot(relative(*offset)) : r.gap;
    const double rate = r.normal.dot(relative(du));
    if (!(gap > 0) || !(rate < 0))
      return kNone;
    const contact::SuperEllipse& a = sections_[d.surface[item.pair.first]];
    const contact::SuperEllipse& b = sections_[d.surface[item.pair.second]];
    return (gap + allowance * std::min({a.a(), a.b(), b.a(), b.b()})) / -rate;
  });
}

} // namespace yarnsim
