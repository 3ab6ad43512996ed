#include "engine/contact/spline_contact_set.hpp"

#include "contact/line_contact.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <fmt/format.h>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <utility>

namespace yarnsim {

/// One contact definition: its segments (spline, segment index), the broad phase over them and
/// the interface law.
struct SplineContactSet::Definition {
  std::vector<int> spline;  ///< per segment id
  std::vector<int> segment; ///< per segment id: index along the spline
  std::vector<double> radius;
  std::vector<double> width; ///< per segment id: the spline's width (torsional friction), m
  std::unique_ptr<broadphase::CandidateSearch> search;
  std::shared_ptr<const contact::InterfaceLaw> law;
  std::vector<Eigen::AlignedBox3d> boxes;
  std::vector<Eigen::AlignedBox3d> searched; ///< boxes of the last search (for a restart)
  bool line_contact = true;                  ///< all-angle contact, or point contact alone
  contact::AllAngleOptions all_angle;        ///< line_scale set per pair
  double line_per_point = 0; ///< line_penalty / penalty, 1/m; 0: 1 / (r_A + r_B) per pair
  std::optional<contact::CoulombFriction> friction; ///< none: frictionless
  bool torsional = false;       ///< torsional friction at the crossings (with `friction`)
  bool damped = false;          ///< normal damping of the law or tangential damping of friction
  double torsional_radius = 0;  ///< rho, m; 0: from the pair's widths
  double torsional_penalty = 0; ///< k_r, N m/rad; 0: eps_t rho^2
  TimeTable compaction = TimeTable::constant(0.0); ///< c(t), m: added to r_A + r_B
  /// m: a pair whose gap is below it is coupled in the tangent's pattern (couplings()): the
  /// broad-phase margin, the distance the search already looks beyond contact.
  double reach = 0;

  /// The torsional law of a pair of splines of widths wa, wb (m): FrictionParameters' defaults.
  contact::TorsionalFriction torsion(double wa, double wb) const {
    return contact::torsional_law(friction->mu_s(), friction->mu_k(), friction->eps_t(),
                                  torsional_radius, torsional_penalty, wa, wb,
                                  friction->elastic_slip());
  }
};

std::shared_ptr<const contact::InterfaceLaw> make_interface_law(const InterfaceLawParameters& p) {
  std::shared_ptr<const contact::InterfaceLaw> law;
  if (p.exponent == 1.0 && p.regularisation > 0)
    law = std::make_shared<contact::RegularisedPenalty>(p.penalty, p.regularisation);
  else if (p.exponent == 1.0)
    law = std::make_shared<contact::LinearPenalty>(p.penalty);
  else
    law = std::make_shared<contact::PowerLaw>(p.penalty, p.exponent);
  if (p.damping > 0)
    law = std::make_shared<contact::DampedLaw>(law, p.damping);
  return law;
}

SplineContactSet::SplineContactSet(const Model& model) : model_(model) {
  for (const Spline& s : model.splines)
    curves_.emplace_back(static_cast<int>(s.nodes.size()));
  for (const SplineContactDefinition& def : model.spline_contacts) {
    auto d = std::make_unique<Definition>();
    std::vector<broadphase::SegmentInfo> info;
    double margin = def.margin;
    for (int group = 0; group < 2; ++group)
      for (int s : group == 0 ? def.group_a : def.group_b)
        for (int i = 0; i < curves_[s].num_segments(); ++i) {
          d->spline.push_back(s);
          d->segment.push_back(i);
          const double radius = def.radius > 0 ? def.radius : model.splines[s].radius;
          d->radius.push_back(radius);
          d->width.push_back(model.splines[s].width > 0 ? model.splines[s].width : 2 * radius);
          info.push_back({s, i, group});
          if (def.margin <= 0)
            margin = std::max(margin, radius);
        }
    d->reach = margin;
    std::vector<std::pair<int, int>> groups{{0, 1}};
    if (def.self_contact)
      groups.insert(groups.end(), {{0, 0}, {1, 1}});
    // The compaction brings pairs into contact from farther apart: the search looks that far.
    d->compaction = def.compaction;
    for (double c : def.compaction.value) {
      if (!(std::isfinite(c) && c >= 0))
        throw std::invalid_argument(fmt::format(
            "contact '{}': expected a compaction >= 0 m at every time, found {}", def.name, c));
    }
    if (!def.compaction.value.empty())
      margin += *std::max_element(def.compaction.value.begin(), def.compaction.value.end());
    broadphase::CandidateSearchOptions options;
    options.margin = margin;
    options.same_curve_skip = 1;
    options.self_contact = def.self_contact && def.within_spline;
    d->search = std::make_unique<broadphase::CandidateSearch>(std::move(info), groups, options);
    d->law = make_interface_law(def.law);
    if (def.line_contact &&
        !(def.line_angle > 0 && def.line_angle < def.point_angle && def.point_angle <= 90 &&
          def.gauss_points >= 1 && def.gauss_points <= 10 && def.line_penalty >= 0))
      throw std::invalid_argument(fmt::format(
          "contact '{}': expected 0 < line_angle < point_angle <= 90 degrees, gauss_points in "
          "[1, 10] and line_penalty >= 0, found {}, {}, {} and {}",
          def.name, def.line_angle, def.point_angle, def.gauss_points, def.line_penalty));
    d->line_contact = def.line_contact;
    const double degree = std::numbers::pi / 180;
    d->all_angle.line_sine = std::sin(def.line_angle * degree);
    d->all_angle.point_sine = std::sin(def.point_angle * degree);
    d->all_angle.gauss_points = def.gauss_points;
    d->line_per_point = def.line_penalty > 0 ? def.line_penalty / def.law.penalty : 0.0;
    if (def.friction.active()) {
      try {
        d->friction.emplace(def.friction.mu_static, def.friction.mu_kinetic,
                            def.friction.tangential_penalty, def.friction.tangential_damping,
                            def.friction.elastic_slip);
      } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(fmt::format("contact '{}': {}", def.name, e.what()));
      }
      any_friction_ = true;
      const FrictionParameters& f = def.friction;
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
    }
    d->damped = def.law.damping > 0 || (d->friction && d->friction->c_t() > 0);
    damped_ = damped_ || d->damped;
    d->boxes.resize(d->spline.size());
    definitions_.push_back(std::move(d));
  }
}

SplineContactSet::~SplineContactSet() = default;

std::array<int, 6> SplineContactSet::nodes_of(const Definition& d,
                                              const broadphase::CandidatePair& p) const {
  const auto& a = model_.splines[d.spline[p.first]].nodes;
  const auto& b = model_.splines[d.spline[p.second]].nodes;
  const int i = d.segment[p.first], j = d.segment[p.second];
  return {a[i], a[i + 1], a[i + 2], b[j], b[j + 1], b[j + 2]};
}

void SplineContactSet::pair_velocities(const Definition& d, const broadphase::CandidatePair& p,
                                       const ContactRates& rates, contact::PairRates& out) const {
  const std::array<int, 6> n = nodes_of(d, p);
  for (int k = 0; k < 3; ++k) {
    out.velocity_A.col(k) = rates.velocity->col(n[k]);
    out.velocity_B.col(k) = rates.velocity->col(n[3 + k]);
  }
  out.velocity_per_displacement = rates.velocity_per_displacement;
}

void SplineContactSet::control_points(const Definition& d, const broadphase::CandidatePair& p,
                                      const Eigen::Matrix3Xd& x, Eigen::Matrix3d& A,
                                      Eigen::Matrix3d& B) const {
  const std::array<int, 6> n = nodes_of(d, p);
  for (int c = 0; c < 3; ++c) {
    A.col(c) = x.col(n[c]);
    B.col(c) = x.col(n[3 + c]);
  }
}

const contact::SegmentBasis& SplineContactSet::segment_of(const Definition& d, int id) const {
  return curves_[d.spline[id]].segment(d.segment[id]);
}

contact::AllAngleOptions SplineContactSet::all_angle_of(const Definition& d, double ra,
                                                        double rb) const {
  contact::AllAngleOptions all_angle = d.all_angle;
  all_angle.line_scale = d.line_per_point > 0 ? d.line_per_point : 1.0 / (ra + rb);
  return all_angle;
}

int SplineContactSet::first_node(const Definition& d, int s) const {
  return model_.splines[d.spline[s]].nodes[d.segment[s]];
}

int SplineContactSet::owner_node(const Definition& d, const broadphase::CandidatePair& p) const {
  return pair_owner_node(d.spline[p.first], d.spline[p.second], first_node(d, p.first),
                         first_node(d, p.second));
}

bool SplineContactSet::owns(const Definition& d, const broadphase::CandidatePair& p) const {
  return !owned_ || owned_->owns(owner_node(d, p));
}

void SplineContactSet::add_candidate_loads(std::vector<double>& per_node, double weight) const {
  for (const auto& d : definitions_)
    for (const broadphase::CandidatePair& p : d->search->candidates())
      if (const int k = owner_node(*d, p); !owned_ || owned_->owns(k))
        per_node[static_cast<std::size_t>(k)] += weight;
}

bool SplineContactSet::update_candidates(const State& state) {
  const Eigen::Matrix3Xd& x = state.x;
  bool changed = (work_.empty() && candidates_version_ == 0) || rebuild_work_;
  if (rebuild_work_) // a new share: each search holds the pairs it may own (set_owned)
    for (auto& d : definitions_)
      d->search->set_share(share_flags(d->spline.size(), [&](int s) { return first_node(*d, s); }));
  rebuild_work_ = false;
  for (std::size_t k = 0; k < definitions_.size(); ++k) {
    Definition& d = *definitions_[k];
    for (std::size_t s = 0; s < d.spline.size(); ++s) {
      const auto& nodes = model_.splines[d.spline[s]].nodes;
      const int i = d.segment[s];
      Eigen::AlignedBox3d box(x.col(nodes[i]));
      box.extend(x.col(nodes[i + 1]));
      box.extend(x.col(nodes[i + 2]));
      d.boxes[s] = box;
    }
    if (d.search->update(d.boxes, d.radius)) {
      d.searched = d.boxes;
      changed = true;
    }
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
  return true;
}

std::string SplineContactSet::project(const State& state, bool want_tangent,
                                      const ContactRates* rates) {
  const Eigen::Matrix3Xd& x = state.x;
  contact::SplineContactOptions options;
  options.compute_tangent = want_tangent;
  options.zero_unused_tangent = false; // assemble() reads the tangents of active pairs only
  tangents_computed_ = want_tangent;
  if (any_friction_) {
    friction_.resize(work_.size());
    twist_.resize(work_.size());
  }
  // Half of each definition's compaction at this time, m: looked up once, not per pair.
  std::vector<double> half_compaction(definitions_.size());
  for (std::size_t k = 0; k < definitions_.size(); ++k)
    half_compaction[k] = definitions_[k]->compaction.at(time_) / 2;
  // One work item's projection and contact from `start`, into `result` (and, where the
  // definition has friction, `sensitivity`).
  const auto project_item_into = [&](std::size_t w, const contact::ProjectionStart& start,
                                     contact::SplineContactResult& result,
                                     contact::SplineContactSensitivity* sensitivity_out) {
    const Work& item = work_[w];
    const Definition& d = *definitions_[item.definition];
    Eigen::Matrix3d A, B;
    control_points(d, item.pair, x, A, B);
    // The compaction grows both contact radii by half of it.
    const double half = half_compaction[item.definition];
    const double ra = d.radius[item.pair.first] + half;
    const double rb = d.radius[item.pair.second] + half;
    const auto& sa = segment_of(d, item.pair.first);
    const auto& sb = segment_of(d, item.pair.second);
    contact::SplineContactSensitivity* sensitivity = d.friction ? sensitivity_out : nullptr;
    const contact::PairRates* pair_rates = nullptr;
    contact::PairRates local_rates;
    if (rates != nullptr && d.damped) {
      pair_velocities(d, item.pair, *rates, local_rates);
      pair_rates = &local_rates;
    }
    if (d.line_contact) {
      // The first segment of a pair is the line contact's slave.
      contact::all_angle_contact(A, sa, ra, B, sb, rb, start, *d.law, all_angle_of(d, ra, rb),
                                 result, options, sensitivity, pair_rates);
    } else {
      contact::spline_contact(A, sa, ra, B, sb, rb, start, *d.law, result, options, pair_rates,
                              sensitivity);
    }
  };
  // One list of terms and one scratch result per arena slot, and one for the serial hand-over
  // pass.
  const int serial_slot = tbb::this_task_arena::max_concurrency();
  const std::size_t slots = static_cast<std::size_t>(serial_slot) + 1;
  terms_.reset(slots);
  friction_terms_.reset(slots);
  scratch_.resize(std::max(slots, scratch_.size()));
  const auto project_item = [&](std::size_t w, const contact::ProjectionStart& start) {
    const int slot = tbb::this_task_arena::current_thread_index();
    Scratch& scratch = scratch_[static_cast<std::size_t>(slot)];
    project_item_into(w, start, scratch.result, any_friction_ ? &scratch.sensitivity : nullptr);
    keep(w, scratch.result, scratch.sensitivity, slot, want_tangent);
  };
  // Each item also notes whether it may hand its point over (below): the hand-over pass then
  // collects them from one byte per item, not from the items' states (hundreds of bytes apart).
  may_hand_over_.assign(work_.size(), 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, work_.size(), 16),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t w = range.begin(); w != range.end(); ++w) {
                        contact::ProjectionStart start;
                        if (const int k = work_[w].warm; k >= 0)
                          start = {committed_[k].xi_A, committed_[k].xi_B, true};
                        project_item(w, start);
                        const contact::SplineContactState& r = work_[w].result;
                        may_hand_over_[w] =
                            r.status == contact::ProjectionStatus::OutOfRange && r.gap < 0;
                      }
                    });
  // The hand-over at a knot (formulation.md §5): a contact point that leaves its pair's range is
  // the neighbouring pair's, which finds it from its own start. Where the neighbour's polynomial,
  // extended past its range, leaves the curve (a yarn's first and last segments: the clamped
  // end's polynomial turns back about a segment past their knot), from its own start it may
  // converge to a point a segment away or leave its neighbourhood, out of range too: no pair
  // owned the contact (the 96 x 96 weave's edge crossings, performance.md "The closing limit").
  // So a pair whose point lies out of its range within the neighbouring segment's range, the
  // surfaces overlapping, hands that point to that neighbour (on both curves where it left both
  // ranges) when that neighbour's point is out of range too: the neighbour is projected again
  // from it, and keeps its first result unless it now owns a point.
  //
  // As one serial pass in the work list's order, with the same result on any thread count: a
  // pair handed a point that it owns hands none of its own, and a neighbour takes the first
  // point it owns. Each handed point's projection depends on the first results alone (of the
  // handing pair, which has kept its own, and of its neighbour, still out of range), so they are
  // all computed in parallel first, then taken in that order.
  hand_overs_.clear();
  for (std::size_t w = 0; w < work_.size(); ++w)
    if (may_hand_over_[w])
      hand_overs_.push_back({static_cast<int>(w), -1});
  // The neighbour each point would go to (most overlapping out-of-range pairs have none).
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, hand_overs_.size(), 16),
      [&](const tbb::blocked_range<std::size_t>& range) {
        for (std::size_t h = range.begin(); h != range.end(); ++h) {
          HandOver& hand = hand_overs_[h];
          const Work& item = work_[static_cast<std::size_t>(hand.from)];
          const contact::SplineContactState& r = item.result;
          const Definition& d = *definitions_[item.definition];
          // The neighbouring segment id on the side the point left (or id itself), -1 for
          // none: the point lies within that neighbour's range (the ranges are equally long in
          // xi).
          const auto neighbour = [&](int id, double xi) {
            const contact::SegmentBasis& b = segment_of(d, id);
            if (b.owns(xi))
              return id;
            if (std::abs(b.local(xi)) > 1.5)
              return -1;
            const int next = xi < b.begin() ? id - 1 : id + 1;
            if (next < 0 || next >= static_cast<int>(d.spline.size()) ||
                d.spline[next] != d.spline[id])
              return -1;
            return next;
          };
          const int na = neighbour(item.pair.first, r.xi_A);
          const int nb = neighbour(item.pair.second, r.xi_B);
          const int n = na < 0 || nb < 0 ? -1 : work_index(Key{item.definition, na, nb});
          if (n >= 0 && work_[static_cast<std::size_t>(n)].result.status ==
                            contact::ProjectionStatus::OutOfRange)
            hand.to = n;
        }
      });
  std::erase_if(hand_overs_, [](const HandOver& hand) { return hand.to < 0; });
  // The neighbours' projections from the handed points (the buffers keep their capacity).
  if (handed_results_.size() < hand_overs_.size())
    handed_results_.resize(hand_overs_.size());
  if (handed_sensitivity_.size() < hand_overs_.size())
    handed_sensitivity_.resize(hand_overs_.size());
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, hand_overs_.size(), 1),
      [&](const tbb::blocked_range<std::size_t>& range) {
        for (std::size_t h = range.begin(); h != range.end(); ++h) {
          const HandOver& hand = hand_overs_[h];
          const contact::SplineContactState& r = work_[static_cast<std::size_t>(hand.from)].result;
          project_item_into(static_cast<std::size_t>(hand.to),
                            contact::ProjectionStart{r.xi_A, r.xi_B, true}, handed_results_[h],
                            any_friction_ ? &handed_sensitivity_[h] : nullptr);
        }
      });
  handed_.assign(work_.size(), 0);
  for (std::size_t h = 0; h < hand_overs_.size(); ++h) {
    const std::size_t from = static_cast<std::size_t>(hand_overs_[h].from);
    const std::size_t to = static_cast<std::size_t>(hand_overs_[h].to);
    if (handed_[from] || handed_[to] ||
        handed_results_[h].status != contact::ProjectionStatus::Converged)
      continue;
    handed_[to] = 1;
    keep(to, handed_results_[h], handed_sensitivity_[h], serial_slot, want_tangent);
  }

  if (any_friction_) {
    // Friction at the active point contacts, on the histories of the last converged increment
    // (held fixed through the iterations).
    assign_friction_histories();
    contact::FrictionOptions friction_options;
    friction_options.compute_tangent = want_tangent;
    friction_options.force = friction_force_;
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, work_.size(), 16),
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
            Eigen::Matrix3d A, B;
            control_points(d, item.pair, x, A, B);
            const auto& sa = segment_of(d, item.pair.first);
            const auto& sb = segment_of(d, item.pair.second);
            if (item.first_touch) {
              // Anchored where it is if this increment converges (commit).
              if (d.torsional)
                item.history.twist = contact::crossing_angle(A, sa, B, sb, item.result);
              continue;
            }
            const contact::PairRates* pair_rates = nullptr;
            contact::PairRates local_rates;
            if (rates != nullptr && d.damped) {
              pair_velocities(d, item.pair, *rates, local_rates);
              pair_rates = &local_rates;
            }
            contact::SplineFrictionResult& f =
                scratch_[static_cast<std::size_t>(tbb::this_task_arena::current_thread_index())]
                    .friction;
            contact::spline_friction(A, sa, B, sb, item.result, &terms.sensitivity, item.history,
                                     *d.friction, f, friction_options, pair_rates);
            if (d.torsional) {
              contact::TorsionalFrictionResult t;
              contact::torsional_friction(
                  A, sa, B, sb, item.result, want_tangent ? &terms.sensitivity : nullptr,
                  item.history, d.torsion(d.width[item.pair.first], d.width[item.pair.second]), t,
                  friction_options);
              f.residual += t.residual;
              if (want_tangent)
                f.tangent += t.tangent;
              twist_[w] = {t.active,      t.slipping, t.torque, t.slip_increment,
                           t.dissipation, t.energy,   t.anchor};
            }
            keep_friction_terms(f, want_tangent, friction_[w], terms);
          }
        });

    // Where points touched first at this iterate (their twist anchors set above), they are
    // anchored for the attempt's next iterates (elastic slip).
    anchor_first_touches();
    // Friction at the line contacts' Gauss points, on the histories of the last converged
    // increment.
    line_items_.clear();
    for (std::size_t w = 0; w < work_.size(); ++w)
      if (work_[w].result.line_mask != 0 && definitions_[work_[w].definition]->friction)
        line_items_.push_back(static_cast<int>(w));
    line_work_.resize(line_items_.size());
    line_friction_.resize(line_items_.size());
    assign_line_histories();
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, line_items_.size(), 4),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                        for (std::size_t l = range.begin(); l != range.end(); ++l) {
                          const Work& item = work_[line_items_[l]];
                          const Definition& d = *definitions_[item.definition];
                          Eigen::Matrix3d A, B;
                          control_points(d, item.pair, x, A, B);
                          const double half = half_compaction[item.definition];
                          const double ra = d.radius[item.pair.first] + half;
                          const double rb = d.radius[item.pair.second] + half;
                          const auto& sa = segment_of(d, item.pair.first);
                          const auto& sb = segment_of(d, item.pair.second);
                          contact::line_friction(A, sa, ra, B, sb, rb, *d.law,
                                                 all_angle_of(d, ra, rb), item.result,
                                                 line_work_[l].with_history, line_work_[l].history,
                                                 *d.friction, line_friction_[l], friction_options);
                        }
                      });
  }

  summarise();

  // Veto: a pair in contact at the last converged increment whose projection failed or jumped
  // (the first in the work list's order, found by summarise).
  if (scan_.first_vetoed >= 0) {
    const Work& item = work_[static_cast<std::size_t>(scan_.first_vetoed)];
    const Definition& d = *definitions_[item.definition];
    return fmt::format(
        "contact '{}': projection {} between spline '{}' segment {} and spline '{}' segment {}",
        model_.spline_contacts[item.definition].name, contact::to_string(item.result.status),
        model_.splines[d.spline[item.pair.first]].name, d.segment[item.pair.first] + 1,
        model_.splines[d.spline[item.pair.second]].name, d.segment[item.pair.second] + 1);
  }
  return {};
}

std::vector<ContactCoupling> SplineContactSet::couplings() const {
  std::vector<ContactCoupling> out;
  for (const Work& item : work_) {
    const Definition& d = *definitions_[item.definition];
    if (needs_coupling(item.result, d.reach))
      out.push_back({nodes_of(d, item.pair), false});
  }
  return out;
}

void SplineContactSet::assemble(Eigen::VectorXd& residual, ContactTarget& target,
                                bool want_tangent) const {
  // Tangents are left as they were where they were not computed (project), so a tangent asked
  // for here must come from a projection that computed it.
  if (want_tangent && !tangents_computed_)
    throw std::logic_error("SplineContactSet::assemble: tangents asked for after a projection "
                           "without tangents");
  // The tangents' slots in the matrix are looked up in parallel, then every pair is added in
  // its order (find_active_slots).
  constexpr int kBlock = 18 * 18;
  find_active_slots(work_, want_tangent, kBlock, target.pattern_id(), assembly_items_,
                    assembly_slots_, [&](const Work& item, int* slots) {
                      target.translation_block_slots(
                          nodes_of(*definitions_[item.definition], item.pair), slots);
                    });
  // Each item's nodes and line friction, then the items added in parallel over their nodes,
  // each node's in the items' order (add_by_node): the same sums as one loop over the items.
  assembly_nodes_.resize(assembly_items_.size());
  assembly_lines_.resize(assembly_items_.size());
  std::size_t next_line = 0; // line_items_ ascend with the work items
  for (std::size_t k = 0; k < assembly_items_.size(); ++k) {
    const int w = assembly_items_[k];
    const Work& item = work_[static_cast<std::size_t>(w)];
    assembly_nodes_[k] = nodes_of(*definitions_[item.definition], item.pair);
    while (next_line < line_items_.size() && line_items_[next_line] < w)
      ++next_line;
    assembly_lines_[k] = next_line < line_items_.size() && line_items_[next_line] == w &&
                                 line_friction_[next_line].mask != 0
                             ? static_cast<int>(next_line)
                             : -1;
  }
  double* values = target.tangent_values();
  add_by_node(target.n_nodes(), assembly_nodes_, assembly_offsets_, assembly_incident_,
              [&](std::size_t k, int node) {
                const std::size_t w = static_cast<std::size_t>(assembly_items_[k]);
                const Terms& terms = terms_of(work_[w]);
                const std::array<int, 6>& n = assembly_nodes_[k];
                const FrictionTerms* f =
                    any_friction_ && friction_[w].active ? &friction_terms_of(work_[w]) : nullptr;
                const contact::LineFrictionResult* line =
                    assembly_lines_[k] >= 0
                        ? &line_friction_[static_cast<std::size_t>(assembly_lines_[k])]
                        : nullptr;
                for (int a = 0; a < 6; ++a) {
                  if (n[a] != node)
                    continue;
                  residual.segment<3>(6 * node) += terms.residual.segment<3>(3 * a);
                  if (f)
                    residual.segment<3>(6 * node) += f->residual.segment<3>(3 * a);
                  if (line)
                    residual.segment<3>(6 * node) += line->residual.segment<3>(3 * a);
                }
                if (!want_tangent)
                  return;
                // Slot (r, c) lies in the column of node n[c / 3] (translation_block_slots):
                // this node's columns, visited row by row as one loop over the block would.
                std::array<int, 18> columns;
                int n_columns = 0;
                for (int c = 0; c < 18; ++c)
                  if (n[c / 3] == node)
                    columns[n_columns++] = c;
                const int* slots = assembly_slots_.slots(assembly_items_[k]);
                for (int r = 0; r < 18; ++r)
                  for (int q = 0; q < n_columns; ++q) {
                    const int c = columns[q];
                    const int slot = slots[18 * r + c];
                    if (slot < 0)
                      continue;
                    double v = terms.tangent(r, c);
                    if (f)
                      v += f->tangent(r, c);
                    if (line)
                      v += line->tangent(r, c);
                    values[slot] += v;
                  }
              });
}

void SplineContactSet::keep(std::size_t w, const contact::SplineContactResult& result,
                            const contact::SplineContactSensitivity& sensitivity, int slot,
                            bool with_tangent) {
  Work& item = work_[w];
  keep_terms(item, result, sensitivity, definitions_[item.definition]->friction.has_value(), slot,
             with_tangent, terms_, friction_terms_);
}

SplineContactSet::FrictionTerms& SplineContactSet::friction_terms_of(const Work& item) {
  return const_cast<FrictionTerms&>(std::as_const(*this).friction_terms_of(item));
}

const SplineContactSet::FrictionTerms& SplineContactSet::friction_terms_of(const Work& item) const {
  if (item.friction_terms.slot < 0)
    throw std::logic_error(fmt::format("SplineContactSet: pair ({}, {}) of definition {} is in "
                                       "contact with no friction terms kept",
                                       item.pair.first, item.pair.second, item.definition));
  return friction_terms_.at(item.friction_terms);
}

const SplineContactSet::Terms& SplineContactSet::terms_of(const Work& item) const {
  if (item.terms.slot < 0)
    throw std::logic_error(fmt::format("SplineContactSet: pair ({}, {}) of definition {} is in "
                                       "contact with no residual kept (assembled before a "
                                       "projection)",
                                       item.pair.first, item.pair.second, item.definition));
  return terms_.at(item.terms);
}

int SplineContactSet::work_index(const Key& key) const {
  const auto it = std::lower_bound(work_.begin(), work_.end(), key,
                                   [](const Work& w, const Key& k) { return w.key() < k; });
  if (it == work_.end() || it->key() != key)
    return -1;
  return static_cast<int>(it - work_.begin());
}

int SplineContactSet::committed_index(const Key& key) const {
  const auto it = std::lower_bound(committed_.begin(), committed_.end(), key,
                                   [](const Snapshot::Warm& w, const Key& k) { return w.key < k; });
  if (it == committed_.end() || it->key != key)
    return -1;
  return static_cast<int>(it - committed_.begin());
}

void SplineContactSet::assign_friction_histories() {
  // A point contact keeps its own history while its pair owns it. When it slides over a knot of
  // either spline, the neighbouring pair (a segment further along one spline or both) takes it
  // over; the anchor, in global parameters of the two splines, is valid on that pair as well,
  // so the history goes with it: the committed history of a neighbouring pair that no longer
  // owns an active point. Each history is handed to one point at most.
  std::vector<char> taken(committed_.size(), 0);
  // A point that closed earlier in this attempt keeps its anchor while its pair stays active.
  std::erase_if(attempt_anchors_, [this](const AttemptAnchor& a) {
    const int w = work_index(a.key);
    return w < 0 || !work_[w].result.active;
  });
  for (std::size_t w = 0; w < work_.size(); ++w) {
    Work& item = work_[w];
    item.first_touch = false;
    const Definition& d = *definitions_[item.definition];
    if (!d.friction || !item.result.active || !friction_terms_of(item).sensitivity.valid)
      continue;
    int from = item.warm >= 0 && committed_[item.warm].friction != 0 ? item.warm : -1;
    if (from < 0) {
      static constexpr std::array<std::array<int, 2>, 8> kNeighbours{
          {{-1, 0}, {1, 0}, {0, -1}, {0, 1}, {-1, -1}, {-1, 1}, {1, -1}, {1, 1}}};
      const int first = item.pair.first, second = item.pair.second;
      const int segments = static_cast<int>(d.spline.size());
      for (const auto& [da, db] : kNeighbours) {
        const int a = first + da, b = second + db;
        if (a < 0 || b < 0 || a >= segments || b >= segments || d.spline[a] != d.spline[first] ||
            d.spline[b] != d.spline[second])
          continue;
        const Key key{item.definition, a, b};
        const int c = committed_index(key);
        if (c < 0 || committed_[c].friction == 0 || taken[c])
          continue;
        const int now = work_index(key);
        if (now >= 0 && work_[now].result.active)
          continue; // that pair still owns a point of its own
        from = c;
        break;
      }
    }
    if (from >= 0) {
      const Snapshot::Warm& h = committed_[from];
      item.history = {h.anchor_A, h.anchor_B, h.friction == 1, h.twist_anchor, h.twist != 2};
      item.slip = h.slip;
      item.twist_slip = h.twist_slip;
      taken[from] = 1;
    } else {
      const Key key = item.key();
      const auto anchor =
          std::lower_bound(attempt_anchors_.begin(), attempt_anchors_.end(), key,
                           [](const AttemptAnchor& a, const Key& k) { return a.key < k; });
      const bool anchored = anchor != attempt_anchors_.end() && anchor->key == key;
      item.history = anchored ? anchor->history : contact::first_touch(item.result);
      item.first_touch = !anchored;
      item.slip = 0;
      item.twist_slip = 0;
    }
  }
}

void SplineContactSet::anchor_first_touches() {
  // Work items are in key order, so the new anchors are appended sorted: one in-place merge
  // keeps the whole list sorted.
  const auto held = static_cast<std::ptrdiff_t>(attempt_anchors_.size());
  for (const Work& item : work_)
    if (item.first_touch && definitions_[item.definition]->friction->elastic_slip() > 0)
      attempt_anchors_.push_back({item.key(), item.history});
  std::inplace_merge(attempt_anchors_.begin(), attempt_anchors_.begin() + held,
                     attempt_anchors_.end(),
                     [](const AttemptAnchor& a, const AttemptAnchor& b) { return a.key < b.key; });
}

void SplineContactSet::assign_line_histories() {
  // A Gauss point of the slave segment keeps its history while it touches the same master
  // spline, whichever of its segments owns the projection (the anchor is a global parameter of
  // that spline). Each history goes to one point at most: the first work item that claims it.
  std::vector<char> taken(line_committed_.size(), 0);
  for (std::size_t l = 0; l < line_items_.size(); ++l) {
    const Work& item = work_[line_items_[l]];
    const Definition& d = *definitions_[item.definition];
    const auto& sb = segment_of(d, item.pair.second);
    LineWork& lw = line_work_[l];
    lw.with_history = lw.first_touch = 0;
    for (int i = 0; i < contact::kMaxGaussPoints; ++i) {
      const std::uint16_t bit = static_cast<std::uint16_t>(1u << i);
      if (!(item.result.line_mask & bit))
        continue;
      const Snapshot::LineKey key{item.definition, item.pair.first, i, d.spline[item.pair.second]};
      const auto it = std::lower_bound(
          line_committed_.begin(), line_committed_.end(), key,
          [](const Snapshot::LineWarm& w, const Snapshot::LineKey& k) { return w.key < k; });
      const std::size_t c = static_cast<std::size_t>(it - line_committed_.begin());
      if (it != line_committed_.end() && it->key == key && !taken[c]) {
        taken[c] = 1;
        lw.with_history |= bit;
        lw.history[i] = {it->anchor, it->friction == 1};
        lw.slip[i] = it->slip;
      } else {
        // Anchored where it touches if this increment converges (commit).
        lw.first_touch |= bit;
        lw.history[i] = {sb.global(item.result.line_u[i]), true};
        lw.slip[i] = 0;
      }
    }
  }
}

void SplineContactSet::commit() {
  // The committed histories take over from the attempt's anchors.
  attempt_anchors_.clear();
  // Keep warm starts of the current candidates only; pairs that left the list start cold.
  next_committed_.clear();
  for (Work& item : work_) {
    const auto& r = item.result;
    item.warm = -1;
    // A point contact that was not evaluated (nearly parallel chords) leaves no warm start, nor
    // does a projection that left a segment's neighbourhood (more than max_extension segments
    // past its range): started there again, it would leave again, and where the segment's
    // extended polynomial turns back (a yarn's first and last segments') it would never come to a
    // point in its range (the 96 x 96 weave's edge crossings, performance.md "The hand-over at
    // a knot, completed"). It starts cold, from the segments' middles.
    if (r.status == contact::ProjectionStatus::NotConverged || !r.point_evaluated)
      continue;
    if (r.status == contact::ProjectionStatus::OutOfRange) {
      // Only where the segment it left is a spline's first or last: other pairs that left (most
      // candidates away from their crossing) keep the start at the neighbourhood's edge, from
      // which they leave again at once (from the middle the paper's k = 1 case's iteration graph
      // took 10 to 17 % longer).
      const Definition& d = *definitions_[item.definition];
      const double limit = 0.5 + contact::SplineContactOptions{}.max_extension;
      const auto left_an_end = [&](int id, double xi) {
        const contact::SegmentBasis& b = segment_of(d, id);
        return std::abs(b.local(xi)) > limit && (b.begin() == 0.0 || b.closes_end());
      };
      if (left_an_end(item.pair.first, r.xi_A) || left_an_end(item.pair.second, r.xi_B))
        continue;
    }
    item.warm = static_cast<int>(next_committed_.size());
    Snapshot::Warm& warm =
        next_committed_.emplace_back(Snapshot::Warm{item.key(), r.xi_A, r.xi_B, r.active});
    const std::size_t w = static_cast<std::size_t>(&item - work_.data());
    if (any_friction_ && friction_[w].active) {
      const contact::SplineFrictionState& f = friction_[w];
      warm.anchor_A = f.history.xi_A;
      warm.anchor_B = f.history.xi_B;
      warm.friction = f.slipping ? 2 : 1;
      warm.slip = item.slip + f.slip_increment;
      dissipated_ += f.dissipation;
      const Twist& t = twist_[w];
      if (t.active) {
        warm.twist_anchor = t.anchor;
        warm.twist = t.slipping ? 2 : 1;
        warm.twist_slip = item.twist_slip + t.slip_increment;
        dissipated_ += t.dissipation;
      }
    } else if (any_friction_ && item.first_touch) {
      // Closed in this increment: anchored where it is, stuck.
      warm.anchor_A = item.history.xi_A;
      warm.anchor_B = item.history.xi_B;
      warm.friction = 1;
      warm.slip = 0;
      if (definitions_[item.definition]->torsional) {
        warm.twist_anchor = item.history.twist;
        warm.twist = 1;
        warm.twist_slip = 0;
      }
    }
  }
  std::swap(committed_, next_committed_);
  // The line contact's Gauss points: committed in the order of the work items, then sorted; a
  // point two pairs claimed keeps the first claim's history.
  std::vector<Snapshot::LineWarm> line;
  for (std::size_t l = 0; l < line_items_.size(); ++l) {
    const Work& item = work_[line_items_[l]];
    const Definition& d = *definitions_[item.definition];
    const LineWork& lw = line_work_[l];
    const contact::LineFrictionResult& f = line_friction_[l];
    for (int i = 0; i < contact::kMaxGaussPoints; ++i) {
      const std::uint16_t bit = static_cast<std::uint16_t>(1u << i);
      const Snapshot::LineKey key{item.definition, item.pair.first, i, d.spline[item.pair.second]};
      if (f.mask & bit) {
        const contact::LineFrictionPoint& p = f.points[i];
        line.push_back({key, p.history.xi_B, lw.slip[i] + p.slip_increment, p.slipping ? 2 : 1});
        dissipated_ += p.dissipation;
      } else if (lw.first_touch & bit) {
        line.push_back({key, lw.history[i].xi_B, 0.0, 1});
      }
    }
  }
  std::stable_sort(
      line.begin(), line.end(),
      [](const Snapshot::LineWarm& a, const Snapshot::LineWarm& b) { return a.key < b.key; });
  line.erase(std::unique(line.begin(), line.end(),
                         [](const Snapshot::LineWarm& a, const Snapshot::LineWarm& b) {
                           return a.key == b.key;
                         }),
             line.end());
  line_committed_ = std::move(line);
}

std::vector<ContactPoint> SplineContactSet::points() const {
  std::vector<ContactPoint> out;
  std::size_t next_line = 0; // line_items_ ascend with the work items
  for (const Work& w : work_) {
    if (!w.result.active)
      continue;
    const Definition& d = *definitions_[w.definition];
    ContactPoint& p = out.emplace_back();
    p.position = 0.5 * (w.result.point_A + w.result.point_B);
    p.normal = w.result.normal;
    p.gap = w.result.gap;
    p.force = w.result.force;
    p.definition = w.definition;
    p.body = {d.spline[w.pair.first], d.spline[w.pair.second]};
    p.segment = {d.segment[w.pair.first], d.segment[w.pair.second]};
    p.pair = {w.pair.first, w.pair.second};
    const std::size_t k = static_cast<std::size_t>(&w - work_.data());
    if (any_friction_ && friction_[k].active) {
      const contact::SplineFrictionState& f = friction_[k];
      p.tangential_force = f.force;
      p.friction = f.slipping ? 2 : 1;
      p.slip = w.slip + f.slip_increment;
      const Twist& t = twist_[k];
      if (t.active) {
        p.torque = t.torque;
        p.twist = t.slipping ? 2 : 1;
        p.twist_slip = w.twist_slip + t.slip_increment;
      }
    }
    // The line contact's Gauss points: their forces summed, slipping if one slips, the largest
    // accumulated slip.
    while (next_line < line_items_.size() && line_items_[next_line] < static_cast<int>(k))
      ++next_line;
    if (next_line < line_items_.size() && line_items_[next_line] == static_cast<int>(k)) {
      const contact::LineFrictionResult& f = line_friction_[next_line];
      for (int i = 0; i < contact::kMaxGaussPoints; ++i) {
        if (!(f.mask & (1u << i)))
          continue;
        const contact::LineFrictionPoint& q = f.points[i];
        p.tangential_force += q.force;
        p.friction = std::max(p.friction, q.slipping ? 2 : 1);
        p.slip = std::max(p.slip, line_work_[next_line].slip[i] + q.slip_increment);
      }
    }
  }
  return out;
}

SplineContactSet::Snapshot SplineContactSet::snapshot() const {
  Snapshot out;
  for (const auto& d : definitions_)
    out.search_boxes.push_back(d->searched);
  out.committed = committed_;
  out.line_committed = line_committed_;
  out.pairs.reserve(work_.size());
  for (const Work& w : work_) {
    const contact::SplineContactState& r = w.result;
    out.pairs.push_back({w.key(), r.status, r.degenerate, r.active, r.iterations, r.xi_A, r.xi_B,
                         r.distance, r.gap, r.penetration, r.penetration_rate, r.force, r.potential,
                         r.point_A, r.point_B, r.normal});
  }
  out.candidates_version = candidates_version_;
  out.dissipated = dissipated_;
  return out;
}

void SplineContactSet::restore(const Snapshot& snapshot) {
  if (snapshot.search_boxes.size() != definitions_.size())
    throw std::invalid_argument(
        fmt::format("contact restart: {} contact definitions saved, the model has {}",
                    snapshot.search_boxes.size(), definitions_.size()));
  // Searching the saved boxes again makes them the reference of the motion test and gives the
  // candidates of the saved search (sorted, independent of the tree).
  std::vector<Key> searched;
  for (std::size_t k = 0; k < definitions_.size(); ++k) {
    Definition& d = *definitions_[k];
    if (snapshot.search_boxes[k].size() != d.boxes.size())
      throw std::invalid_argument(fmt::format(
          "contact restart: definition '{}' has {} segments, the snapshot {} boxes",
          model_.spline_contacts[k].name, d.boxes.size(), snapshot.search_boxes[k].size()));
    d.searched = snapshot.search_boxes[k];
    d.search->update(d.searched, d.radius, true);
    for (const broadphase::CandidatePair& p : d.search->candidates())
      searched.push_back({static_cast<int>(k), p.first, p.second});
  }
  // Every saved pair is restored (the run's figures, points and snapshots as they stand:
  // Simulation::share_contact_pairs); the next search's work list keeps this process's own.
  check_saved_pairs(
      snapshot.pairs, searched, !owned_, static_cast<int>(definitions_.size()),
      [&](int k) { return static_cast<int>(definitions_[k]->spline.size()); }, "contact");
  std::vector<Work> work;
  work.reserve(snapshot.pairs.size());
  for (std::size_t w = 0; w < snapshot.pairs.size(); ++w) {
    const Snapshot::Pair& p = snapshot.pairs[w];
    work.push_back({p.key[0], {p.key[1], p.key[2]}, {}, {}, {}});
    contact::SplineContactState& r = work[w].result;
    r.status = p.status;
    r.degenerate = p.degenerate;
    r.active = p.active;
    r.iterations = p.iterations;
    r.xi_A = p.xi_A;
    r.xi_B = p.xi_B;
    r.distance = p.distance;
    r.gap = p.gap;
    r.penetration = p.penetration;
    r.penetration_rate = p.penetration_rate;
    r.force = p.force;
    r.potential = p.potential;
    r.point_A = p.point_A;
    r.point_B = p.point_B;
    r.normal = p.normal;
  }
  work_ = std::move(work);
  assembly_slots_.clear();
  for (const Snapshot::LineWarm& l : snapshot.line_committed) {
    const auto [k, segment, point, spline] = l.key;
    if (k < 0 || k >= static_cast<int>(definitions_.size()) || segment < 0 ||
        segment >= static_cast<int>(definitions_[k]->spline.size()) || point < 0 ||
        point >= definitions_[k]->all_angle.gauss_points || spline < 0 ||
        spline >= static_cast<int>(curves_.size()))
      throw std::invalid_argument(fmt::format(
          "contact restart: a line contact point's history ({}, {}, {}, {}) does not fit the model",
          k, segment, point, spline));
  }
  committed_ = snapshot.committed;
  line_committed_ = snapshot.line_committed;
  link_warm_starts(work_, committed_);
  candidates_version_ = snapshot.candidates_version;
  dissipated_ = snapshot.dissipated;
  // The friction results are not saved: the next evaluation computes them (summary without
  // them until then).
  if (any_friction_) {
    friction_.assign(work_.size(), {});
    twist_.assign(work_.size(), {});
  }
  line_items_.clear();
  line_work_.clear();
  line_friction_.clear();
  summarise();
  // A share of the pairs (set_owned): the next search's work list keeps this process's alone
  // (the summary above is the whole snapshot's, as saved).
  if (owned_)
    rebuild_work_ = true;
}

bool SplineContactSet::past_curve_end(const Definition& d, int id, double xi) const {
  const contact::SegmentBasis& b = segment_of(d, id);
  const int n = static_cast<int>(d.spline.size());
  if (xi < b.begin())
    return id == 0 || d.spline[id - 1] != d.spline[id];
  if (xi > b.end())
    return id + 1 >= n || d.spline[id + 1] != d.spline[id];
  return false;
}

void SplineContactSet::summarise() {
  summary_ = {};
  summary_.candidates = static_cast<int>(work_.size());
  summary_.searched = 0;
  for (const auto& d : definitions_)
    summary_.searched += static_cast<int>(d->search->candidates().size());
  // In parallel (scan_work); the listed items (active, out of range where a point was, with
  // friction) are then summed here in their order.
  // Active at the last converged increment; out of range there with the surfaces overlapping.
  const auto was_active = [&](const Work& item) {
    return item.warm >= 0 && static_cast<std::size_t>(item.warm) < committed_.size() &&
           committed_[static_cast<std::size_t>(item.warm)].active;
  };
  const auto left_its_range = [&](const Work& item) {
    const contact::SplineContactState& r = item.result;
    return r.status == contact::ProjectionStatus::OutOfRange && r.gap < 0 && was_active(item);
  };
  scan_work(work_.size(), scan_blocks_, scan_, [&](std::size_t w) {
    const Work& item = work_[w];
    ItemScan out = scan_result(item.result, was_active(item));
    out.listed = item.result.active || left_its_range(item) ||
                 (any_friction_ && w < friction_.size() && friction_[w].active);
    return out;
  });
  summary_.min_gap = scan_.min_gap;
  for (const int k : scan_.listed) {
    const Work& w = work_[static_cast<std::size_t>(k)];
    const auto& r = w.result;
    if (left_its_range(w)) {
      const Definition& d = *definitions_[w.definition];
      const bool past_a = past_curve_end(d, w.pair.first, r.xi_A);
      if (past_a || past_curve_end(d, w.pair.second, r.xi_B)) {
        if (summary_.off_end == 0) {
          const int a = d.spline[w.pair.first], b = d.spline[w.pair.second];
          summary_.off_end_yarns = past_a ? std::array<int, 2>{b, a} : std::array<int, 2>{a, b};
        }
        ++summary_.off_end;
      }
    }
    if (!r.active)
      continue;
    ++summary_.active;
    summary_.active_share += 1;
    summary_.active_set =
        fold_active_pair(summary_.active_set | 1, w.definition, w.pair.first, w.pair.second);
    summary_.max_penetration = std::max(summary_.max_penetration, r.penetration);
    summary_.max_force = std::max(summary_.max_force, r.force);
    summary_.potential += r.potential;
    summary_.total_force += r.force;
    if (r.degenerate && definitions_[w.definition]->friction)
      ++summary_.frictionless;
  }
  summary_.dissipation = dissipated_;
  if (!any_friction_)
    return;
  for (const int k : scan_.listed) {
    const std::size_t w = static_cast<std::size_t>(k);
    if (w >= friction_.size())
      break;
    const contact::SplineFrictionState& f = friction_[w];
    if (!f.active)
      continue;
    ++(f.slipping ? summary_.slip : summary_.stick);
    // A point that passes between stick and slip crosses a kink of the friction law as a pair
    // that opens or closes crosses the normal law's: the Newton iteration damps that step too.
    if (f.slipping)
      summary_.active_set = fold_active_pair(summary_.active_set, -1 - work_[w].definition,
                                             work_[w].pair.first, work_[w].pair.second);
    summary_.tangential_force += f.force.norm();
    // The tangential spring's elastic energy, |f|^2 / (2 s k) (s the all-angle contact's point
    // share, k the stick stiffness, > 0 where the force is not zero), is stored with the normal
    // one.
    if (f.stiffness > 0)
      summary_.potential += f.force.squaredNorm() / (2.0 * f.share * f.stiffness);
    summary_.dissipation += f.dissipation;
    const Twist& t = twist_[w];
    if (!t.active)
      continue;
    ++(t.slipping ? summary_.twist_slip : summary_.twist_stick);
    if (t.slipping) // a kink of the torsional law, as above
      summary_.active_set = fold_active_pair(summary_.active_set, -(1 << 20) - work_[w].definition,
                                             work_[w].pair.first, work_[w].pair.second);
    summary_.torque += std::abs(t.torque);
    summary_.potential += t.energy;
    summary_.dissipation += t.dissipation;
  }
  for (std::size_t l = 0; l < line_items_.size(); ++l) {
    const contact::LineFrictionResult& f = line_friction_[l];
    const Work& w = work_[line_items_[l]];
    for (int i = 0; i < contact::kMaxGaussPoints; ++i) {
      if (!(f.mask & (1u << i)))
        continue;
      const contact::LineFrictionPoint& p = f.points[i];
      ++(p.slipping ? summary_.slip : summary_.stick);
      if (p.slipping) // a kink of the friction law, as above: one entry per Gauss point
        summary_.active_set = fold_active_pair(
            summary_.active_set, -(2 << 20) - 16 * w.definition - i, w.pair.first, w.pair.second);
      summary_.tangential_force += p.force.norm();
      summary_.potential += p.energy;
      summary_.dissipation += p.dissipation;
    }
  }
}

double SplineContactSet::closing_limit(const Eigen::Matrix3Xd& du, const Eigen::Matrix3Xd* offset,
                                       double allowance) const {
  return smallest_limit(work_.size(), [&](std::size_t w) {
    const Work& item = work_[w];
    const contact::SplineContactState& r = item.result;
    constexpr double kNone = std::numeric_limits<double>::infinity();
    if (r.status != contact::ProjectionStatus::Converged || r.active)
      return kNone;
    const Definition& d = *definitions_[item.definition];
    const std::array<int, 6> n = nodes_of(d, item.pair);
    const Eigen::Vector3d na = segment_of(d, item.pair.first).values(r.xi_A);
    const Eigen::Vector3d nb = segment_of(d, item.pair.second).values(r.xi_B);
    // The motion of C_A(xi_A) - C_B(xi_B) under nodal translations u; dg = n . that.
    const auto relative = [&](const Eigen::Matrix3Xd& u) {
      Eigen::Vector3d m = Eigen::Vector3d::Zero();
      for (int k = 0; k < 3; ++k)
        m += na(k) * u.col(n[k]) - nb(k) * u.col(n[3 + k]);
      return m;
    };
    const double gap = offset ? r.gap + r.normal.dot(relative(*offset)) : r.gap;
    const double rate = r.normal.dot(relative(du));
    if (!(gap > 0) || !(rate < 0))
      return kNone;
    const double radius = std::min(d.radius[item.pair.first], d.radius[item.pair.second]);
    return (gap + allowance * radius) / -rate;
  });
}

} // namespace yarnsim
