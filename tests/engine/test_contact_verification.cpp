// Contact in the engine: the crossing-beams case of shared/docs/verification.md
// (F_c = P / (2 + k / eps)) with the spline contact (circular sections) and the surface contact
// (elliptical sections), and a yarn pulled along another across many segment boundaries.
#include "beam_models.hpp"
#include "engine/contact/contact_stage.hpp"
#include "engine/contact/spline_contact_set.hpp"
#include "engine/input/read_deck.hpp"
#include "engine/solver/simulation.hpp"
#include "notices.hpp"

#include <cmath>
#include <cstdio>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <numbers>
#include <string>
#include <vector>

namespace yarnsim {
namespace {

struct Crossing {
  Model model;
  int top_mid = 0;
};

/// Two identical beams of length L crossing at right angles at mid-span, touching (centre-line
/// distance 2 r); top beam along x, bottom along y; P pushes the top beam's mid node down.
Crossing crossing_beams(double eps, bool clamped, int n_el) {
  const double E = 1e9, radius = 0.01, L = 1.0, P = 1.0;
  const double A = std::numbers::pi * radius * radius;
  const double I = std::numbers::pi * std::pow(radius, 4) / 4;
  Section s = test::stiffness_section(E * A, 1e3 * E * A, E * I, E * I);
  Model top = test::straight_beam({-L / 2, 0, 2 * radius}, {L / 2, 0, 2 * radius}, n_el, s);
  Model bottom =
      test::straight_beam({0, -L / 2, 0}, {0, L / 2, 0}, n_el, s, Eigen::Vector3d::UnitX());
  Model m = top;
  const int offset = test::append_beam(m, bottom);
  const int last = 2 * n_el;
  // One end of each beam is held in all translations, the other slides along the beam axis, so
  // no membrane force stiffens the beams (the closed form is for the linear beam).
  m.node_sets = {NodeSet{"fixed_ends", {0, offset}}, NodeSet{"top_mid", {n_el}},
                 NodeSet{"top_start", {0}},          NodeSet{"bottom_start", {offset}},
                 NodeSet{"top_end", {last}},         NodeSet{"bottom_end", {offset + last}}};
  const bool r = clamped; // bending rotations held too when clamped
  m.constraints.push_back(Constraint{0, {true, true, true, false, false, false}});
  m.constraints.push_back(Constraint{4, {false, true, true, false, false, false}}); // slides in x
  m.constraints.push_back(Constraint{5, {true, false, true, false, false, false}}); // slides in y
  // Top beam along x bends about y, bottom beam along y about x; spin about the own axis is
  // fixed at one end.
  m.constraints.push_back(Constraint{2, {false, false, false, true, r, r}});
  m.constraints.push_back(Constraint{3, {false, false, false, r, true, r}});
  m.constraints.push_back(Constraint{4, {false, false, false, r, r, r}});
  m.constraints.push_back(Constraint{5, {false, false, false, r, r, r}});
  m.loads.push_back(NodalLoad{1, Eigen::Vector3d(0, 0, -P), Eigen::Vector3d::Zero(), false,
                              TimeTable::ramp(1.0)});
  Spline a{"top", {}, radius}, b{"bottom", {}, radius};
  for (int i = 0; i <= last; ++i) {
    a.nodes.push_back(i);
    b.nodes.push_back(offset + i);
  }
  m.splines = {a, b};
  m.spline_contacts.push_back(
      SplineContactDefinition{"cross", {0}, {1}, {eps, 1.0, 0.0}, false, 0});
  SolutionStep step = test::static_step(1.0, 0.25, 1e-10);
  step.tol_increment = 1e-8;
  m.steps.push_back(step);
  return {m, n_el};
}

double contact_force(const Simulation& sim) {
  double f = 0;
  for (const ContactPoint& p : sim.contact()->points())
    f += p.force;
  return f;
}

TEST(ContactVerification, CrossingBeamsSimplySupportedMatchTheClosedForm) {
  const double EI = 1e9 * std::numbers::pi * 1e-8 / 4, k = 48 * EI;
  for (const double eps : {1e3, 1e4, 1e5, 1e6}) {
    Crossing c = crossing_beams(eps, false, 32);
    Simulation sim(c.model);
    sim.run();
    const double expected = 1.0 / (2 + k / eps);
    const double got = contact_force(sim);
    std::printf("simply supported, eps %.0e: F_c %.6f (closed form %.6f, %+.3f %%), %d point(s)\n",
                eps, got, expected, 100 * (got / expected - 1), sim.contact()->active());
    EXPECT_NEAR(got, expected, 0.005 * expected) << "eps " << eps;
  }
}

TEST(ContactVerification, CrossingBeamsClampedMatchTheClosedForm) {
  const double EI = 1e9 * std::numbers::pi * 1e-8 / 4, k = 192 * EI;
  for (const double eps : {1e3, 1e4, 1e5, 1e6}) {
    Crossing c = crossing_beams(eps, true, 32);
    Simulation sim(c.model);
    sim.run();
    const double expected = 1.0 / (2 + k / eps);
    const double got = contact_force(sim);
    std::printf("clamped-clamped, eps %.0e: F_c %.6f (closed form %.6f, %+.3f %%)\n", eps, got,
                expected, 100 * (got / expected - 1));
    EXPECT_NEAR(got, expected, 0.005 * expected) << "eps " << eps;
  }
}

/// The crossing beams with elliptical sections (semi-axes a in the beams' plane, b vertical:
/// flat sides facing) and the surface-to-surface contact. Bending under the vertical load is about
/// section axis 1, EI1 = E pi a b^3 / 4.
Crossing elliptical_crossing_beams(double eps, int n_el, double a, double b) {
  const double E = 1e9;
  const double A = std::numbers::pi * a * b;
  Section s = test::stiffness_section(E * A, 1e3 * E * A, 0, 1e3 * E * A * a * a);
  s.EI1 = E * std::numbers::pi * a * b * b * b / 4;
  s.EI2 = E * std::numbers::pi * a * a * a * b / 4;
  s.shape = SectionShape::Ellipse;
  s.a = a;
  s.b = b;
  Crossing c = crossing_beams(eps, false, n_el);
  Model& m = c.model;
  m.sections = {s};
  // Centre lines 2 b apart: the flat sides touch.
  for (int i = 0; i <= 2 * n_el; ++i)
    m.nodes[i].z() = 2 * b;
  m.splines.clear();
  m.spline_contacts.clear();
  Surface top{"top", {}, a, b, 2.0}, bottom{"bottom", {}, a, b, 2.0};
  for (int e = 0; e < n_el; ++e) {
    top.elements.push_back(e);
    bottom.elements.push_back(n_el + e);
  }
  m.surfaces = {top, bottom};
  m.surface_contacts.push_back(SurfaceContactDefinition{"cross", {0}, {1}, {eps, 1.0, 0.0}, 0});
  return c;
}

TEST(ContactVerification, EllipticalCrossingBeamsWithSurfaceContactMatchTheClosedForm) {
  const double a = 0.02, b = 0.01;
  const double EI = 1e9 * std::numbers::pi * a * b * b * b / 4, k = 48 * EI;
  for (const double eps : {1e3, 1e4, 1e5, 1e6}) {
    for (const int n_el : {33, 32}) { // the contact on a shared node, and mid-element
      Crossing c = elliptical_crossing_beams(eps, n_el, a, b);
      Simulation sim(c.model);
      sim.run();
      const double expected = 1.0 / (2 + k / eps);
      const double got = contact_force(sim);
      const auto points = sim.contact()->points();
      std::printf("ellipses, %d elements, eps %.0e: F_c %.6f (closed form %.6f, %+.3f %%), %d "
                  "point(s), %d iterations\n",
                  n_el, eps, got, expected, 100 * (got / expected - 1), sim.contact()->active(),
                  sim.total_iterations());
      EXPECT_NEAR(got, expected, 0.005 * expected) << "eps " << eps << ", " << n_el << " elements";
      // One contact. With an even number of elements both beams have a node at the crossing:
      // the pairs of the two elements on either side of each node share it (their points are
      // all reported, each with its share of the force).
      EXPECT_EQ(sim.contact()->active(), 1) << "eps " << eps;
      ASSERT_GE(points.size(), 1u);
      ASSERT_LE(points.size(), n_el % 2 == 0 ? 4u : 1u);
      for (const ContactPoint& point : points) {
        // Where geometry puts it: at the crossing of the axes; the normal is vertical (from the
        // bottom beam B to the top beam A). Each beam slides at one end, so its mid-span moves
        // along its axis by about half its shortening, w^2 / L ~ 1e-6 m here.
        EXPECT_NEAR(point.position.x(), 0.0, 1e-5);
        EXPECT_NEAR(point.position.y(), 0.0, 1e-5);
        // Height: the bottom beam's top (b) less its deflection F_c / k and half the
        // penetration.
        EXPECT_NEAR(point.position.z(), b - got / k - 0.5 * got / eps, 1e-5);
        // The normal tilts with the slope of the surface it belongs to (below 1e-3 here).
        EXPECT_NEAR(point.normal.z(), 1.0, 1e-3);
        EXPECT_NEAR(-point.gap, expected / eps, 0.005 * expected / eps);
      }
    }
  }
}

} // namespace
} // namespace yarnsim

namespace yarnsim {
namespace {

/// A rigid wavy rail A (all nodes held) along x, z_A = a sin(pi x); a short beam B along y
/// pressed onto it and pulled along x across many of A's segments.
TEST(ContactVerification, SlidingAcrossSegmentBoundariesKeepsTheForceContinuous) {
  const double r = 0.01, amp = 0.002, delta = 0.002;
  auto rail_z = [&](double x) { return amp * std::sin(std::numbers::pi * x); };
  Section s = test::stiffness_section(1e7, 1e7, 10.0, 10.0);
  const int nA = 32;
  Model m = test::straight_beam({-1, 0, 0}, {1, 0, 0}, nA, s);
  for (auto& p : m.nodes)
    p.z() = rail_z(p.x());
  const double x0 = -0.3;
  Model b = test::straight_beam({x0, -0.1, 2 * r + rail_z(x0)}, {x0, 0.1, 2 * r + rail_z(x0)}, 4, s,
                                Eigen::Vector3d::UnitX());
  const int offset = test::append_beam(m, b);
  m.node_sets = {NodeSet{"rail", {}}, NodeSet{"b_ends", {offset, offset + 8}},
                 NodeSet{"b_start", {offset}}};
  for (int i = 0; i < offset; ++i)
    m.node_sets[0].nodes.push_back(i);
  m.constraints.push_back(test::clamp(0));
  m.constraints.push_back(Constraint{2, {false, false, false, false, true, false}}); // spin
  // B's ends: pushed down by delta, then pulled along x by 0.6 following the rail's height.
  const double travel = 0.6;
  TimeTable ux, uy{{0.0}, {0.0}}, uz;
  for (int k = 0; k <= 200; ++k) {
    const double t = k / 200.0;
    const double push = std::min(1.0, 10 * t);          // t in [0, 0.1]: press
    const double move = std::max(0.0, (t - 0.1) / 0.9); // then slide
    ux.time.push_back(t);
    ux.value.push_back(travel * move);
    uz.time.push_back(t);
    uz.value.push_back(-delta * push + rail_z(x0 + travel * move) - rail_z(x0));
  }
  PrescribedMotion pm;
  pm.node_set = 1;
  pm.displacement = {ux, uy, uz};
  m.prescribed.push_back(pm);
  Spline sa{"rail", {}, r}, sb{"b", {}, r};
  for (int i = 0; i < offset; ++i)
    sa.nodes.push_back(i);
  for (int i = 0; i <= 8; ++i)
    sb.nodes.push_back(offset + i);
  m.splines = {sa, sb};
  m.spline_contacts.push_back(
      SplineContactDefinition{"slide", {0}, {1}, {1e5, 1.0, 0.0}, false, 0});
  m.steps.push_back(test::static_step(1.0, 0.002, 1e-9));
  m.steps.back().tol_increment = 1e-7;

  struct ForceRecorder : SimulationObserver {
    std::vector<double> t, f;
    std::vector<int> active;
    void on_increment(const Simulation& s, const IncrementReport& r) override {
      t.push_back(r.time);
      f.push_back(s.contact()->total_force());
      active.push_back(s.contact()->active());
    }
  } rec;
  Simulation sim(m);
  sim.run(&rec);
  // Past the pressing phase the force varies smoothly with the rail's slope: no increment may
  // change it by more than 1 %, whether or not the point changed segment.
  double worst = 0, mean = 0;
  int n = 0, segment_changes = 0;
  for (std::size_t k = 1; k < rec.t.size(); ++k) {
    if (rec.t[k - 1] < 0.12)
      continue;
    worst = std::max(worst, std::abs(rec.f[k] - rec.f[k - 1]) / rec.f[k - 1]);
    mean += rec.f[k];
    ++n;
    EXPECT_EQ(rec.active[k], 1) << "t = " << rec.t[k];
  }
  // The rail's node spacing is 1/32: the contact point crosses about 0.6 * 32 segment ends.
  segment_changes = static_cast<int>(travel * nA);
  std::printf("sliding: mean force %.4f N over %d increments, %d segment changes, largest change "
              "per increment %.3f %%\n",
              mean / n, n, segment_changes, 100 * worst);
  EXPECT_LT(worst, 0.01);
}

/// The hand-over at a knot (SplineContactSet::project, formulation.md §5). A straight beam A
/// along x whose first element (0 to 0.25 m) has its middle node at 0.15 m, not 0.125: its
/// spline's first segment, x(s) = 0.125 (2.4 s - 0.8 s^2) for s in [0, 1], ends at the knot
/// x = 0.2 m; its polynomial, extended, turns back at s = 1.5 (x = 0.225 m) and heads back
/// towards the knot, as a yarn's first segment's does a little later (at s = 2 for equally
/// spaced nodes: the 96 x 96 weave's edge crossings, at the crossing yarns' first segments).
/// B (2 elements) crosses A at x = `cross`, its axis `depth` below the two contact radii
/// `radius` (a penetration; negative: open).
Model knot_crossing(double cross, double depth, double radius = 0.01) {
  const double kRadius = radius;
  Section s = test::stiffness_section(1e7, 1e7, 10.0, 10.0);
  Model m = test::straight_beam({0, 0, 0}, {1, 0, 0}, 4, s);
  m.nodes[1].x() = 0.15;
  const Model b =
      test::straight_beam({cross, -0.1, 2 * kRadius - depth}, {cross, 0.1, 2 * kRadius - depth}, 2,
                          s, Eigen::Vector3d::UnitX());
  const int offset = test::append_beam(m, b);
  Spline sa{"A", {}, kRadius}, sb{"B", {}, kRadius};
  for (int i = 0; i < offset; ++i)
    sa.nodes.push_back(i);
  for (int i = offset; i < offset + 5; ++i)
    sb.nodes.push_back(i);
  m.splines = {sa, sb};
  m.spline_contacts.push_back(
      SplineContactDefinition{"cross", {0}, {1}, {1e5, 1.0, 0.0}, false, 0});
  m.node_sets = {NodeSet{"A_start", {0}}};
  m.constraints.push_back(test::clamp(0));
  m.steps.push_back(test::static_step(1.0, 1.0, 1e-9));
  return m;
}

/// The committed warm starts of the pairs of A's first segment (the definition's first ids)
/// moved past its turning point, to s = 1.9 (A's spline has 9 control points, 7 segments of
/// 1 / 7 in xi). Returns how many.
int plant_past_the_turn(SplineContactSet& set) {
  SplineContactSet::Snapshot snap = set.snapshot();
  int planted = 0;
  for (SplineContactSet::Snapshot::Warm& w : snap.committed)
    if (w.key[1] == 0) {
      w.xi_A = 1.9 / 7.0;
      ++planted;
    }
  set.restore(snap);
  return planted;
}

TEST(ContactVerification, APointInTheNeighbouringSegmentIsHandedToItWhereItsOwnStartFoundNone) {
  // B pressed 0.1 mm into A at x = 0.19 m, just before the knot, and at 0.125 m, past the
  // middle of the first segment (more than half a segment from the second's range; contact
  // radii of 0.05 m, so that the second segment's box, from the middle node at 0.15 m, reaches
  // it). The second segment's pair finds the contact point before its range (out of range,
  // penetrating). The first segment's pair, warm-started past its turning point, descends away
  // from the knot and leaves its neighbourhood: out of range too. Without the hand-over no pair
  // owns the contact and its force is lost (at 0.125 m too, 1.34 segments before the second's
  // middle, where the hand-over reached half a segment only, as at the 96 x 96 weave's edge); with
  // it the first segment's pair is projected again from the second's point and owns it, with the
  // force of a fresh projection.
  constexpr double kPenetration = 1e-4, kPenalty = 1e5;
  for (const auto& [cross, radius] : {std::pair{0.19, 0.01}, std::pair{0.125, 0.05}}) {
    SCOPED_TRACE(cross);
    const Model m = knot_crossing(cross, kPenetration, radius);
    const Simulation sim(m);
    const State& state = sim.state();
    // A fresh projection: one pair, on A's first segment, carries eps times the penetration.
    const std::unique_ptr<ContactStage> stage = ContactStage::of(m);
    stage->update_candidates(state);
    ASSERT_EQ(stage->evaluate(state, false), "");
    ASSERT_EQ(stage->active(), 1);
    const std::vector<ContactPoint> fresh = stage->points();
    ASSERT_EQ(fresh.size(), 1u);
    EXPECT_EQ(fresh[0].segment[0], 0);
    EXPECT_NEAR(fresh[0].force, kPenalty * kPenetration, 1e-9 * kPenalty * kPenetration);
    stage->commit();

    ASSERT_GE(plant_past_the_turn(*stage->spline()), 1);
    ASSERT_EQ(stage->project(state, false), "");
    const std::vector<ContactPoint> handed = stage->points();
    ASSERT_EQ(handed.size(), 1u) << "no pair owns the contact point";
    EXPECT_EQ(handed[0].segment[0], 0);
    EXPECT_EQ(handed[0].segment[1], fresh[0].segment[1]);
    EXPECT_NEAR(handed[0].force, fresh[0].force, 1e-12 * fresh[0].force);
    EXPECT_NEAR((handed[0].position - fresh[0].position).norm(), 0.0, 1e-12);
  }
}

TEST(ContactVerification, AProjectionThatLeftItsSegmentIsNotWarmStartedFromThere) {
  // B 0.1 mm above A at x = 0.19 m (open: nothing hands a point over). The first segment's
  // pair, warm-started past its turning point, leaves its neighbourhood. Committed as it is,
  // that point would start it outside again at every evaluation, and it would never find the
  // crossing (performance.md, "The hand-over at a knot, completed"): the commit leaves that
  // pair no warm start, and it starts from the segments' middles.
  const Model m = knot_crossing(0.19, -1e-4);
  const Simulation sim(m);
  const State& state = sim.state();
  const std::unique_ptr<ContactStage> stage = ContactStage::of(m);
  stage->update_candidates(state);
  ASSERT_EQ(stage->evaluate(state, false), "");
  ASSERT_EQ(stage->active(), 0);
  stage->commit();
  SplineContactSet& set = *stage->spline();
  ASSERT_GE(plant_past_the_turn(set), 1);
  ASSERT_EQ(stage->project(state, false), "");
  const std::vector<SplineContactSet::Snapshot::Pair> pairs = set.snapshot().pairs;
  int left = 0;
  for (const SplineContactSet::Snapshot::Pair& p : pairs)
    if (p.key[1] == 0) {
      EXPECT_EQ(p.status, contact::ProjectionStatus::OutOfRange);
      EXPECT_GT(p.xi_A, 2.0 / 7.0) << "past the first segment's neighbourhood (s = 2)";
      ++left;
    }
  ASSERT_GE(left, 1);
  stage->commit();
  for (const SplineContactSet::Snapshot::Warm& w : set.snapshot().committed)
    EXPECT_NE(w.key[1], 0) << "a warm start where the projection left: xi_A = " << w.xi_A;
}

} // namespace
} // namespace yarnsim

namespace yarnsim {
namespace {

/// Beam B falls onto a simply supported crossing beam A under a constant downward load (Newmark
/// beta 0.3, gamma 0.5, the paper's scheme): B must bounce or rest on A, never pass through it,
/// and the total energy T + U + U_contact - W_external must not grow.
TEST(ContactVerification, DroppedBeamDoesNotPassThroughAndGainsNoEnergy) {
  const double r = 0.01, gap = 0.005;
  const double E = 1e9, A = std::numbers::pi * r * r, I = std::numbers::pi * std::pow(r, 4) / 4;
  const double rho = 1000;
  Section s = test::stiffness_section(E * A, E * A, E * I, E * I, rho * A,
                                      Eigen::Vector3d(rho * I, rho * I, 2 * rho * I));
  Model m = test::straight_beam({-0.5, 0, 0}, {0.5, 0, 0}, 16, s);
  Model b = test::straight_beam({0, -0.3, 2 * r + gap}, {0, 0.3, 2 * r + gap}, 8, s,
                                Eigen::Vector3d::UnitX());
  const int offset = test::append_beam(m, b);
  NodeSet fallers{"b", {}};
  for (int i = offset; i < static_cast<int>(m.nodes.size()); ++i)
    fallers.nodes.push_back(i);
  m.node_sets = {NodeSet{"a_ends", {0, 32}}, NodeSet{"a_start", {0}}, fallers};
  m.constraints.push_back(Constraint{0, {true, true, true, false, false, false}});
  m.constraints.push_back(Constraint{1, {false, false, false, true, false, false}});
  // Gravity-like dead load on B: 5 g on its lumped nodal masses (about rho A L / n_nodes each).
  const double node_weight = 5 * 9.81 * rho * A * 0.6 / 17;
  m.loads.push_back(NodalLoad{2, Eigen::Vector3d(0, 0, -node_weight), Eigen::Vector3d::Zero(),
                              false, TimeTable::constant(1.0)});
  Spline sa{"a", {}, r}, sb{"b", {}, r};
  for (int i = 0; i < offset; ++i)
    sa.nodes.push_back(i);
  for (int i = offset; i < static_cast<int>(m.nodes.size()); ++i)
    sb.nodes.push_back(i);
  m.splines = {sa, sb};
  m.spline_contacts.push_back(SplineContactDefinition{"drop", {0}, {1}, {1e5, 1.0, 0.0}, false, 0});
  SolutionStep step;
  step.type = StepType::Dynamic;
  step.newmark_beta = 0.3;
  step.newmark_gamma = 0.5;
  step.end_time = 0.2;
  step.dt_initial = step.dt_max = 1e-4; // the documented step for this impact
  step.dt_min = 1e-7;
  step.tol_force = 1e-8;
  step.tol_increment = 1e-8;
  m.steps.push_back(step);

  struct Recorder : SimulationObserver {
    int a_mid, b_mid;
    double worst_gap = 1e9, worst_energy = -1e9, max_work = 0;
    int contact_increments = 0;
    void on_increment(const Simulation& s, const IncrementReport&) override {
      const double dz = s.state().x_n(2, b_mid) - s.state().x_n(2, a_mid);
      worst_gap = std::min(worst_gap, dz);
      const double e =
          s.kinetic_energy() + s.strain_energy() + s.contact_energy() - s.external_work();
      worst_energy = std::max(worst_energy, e);
      max_work = std::max(max_work, s.external_work());
      contact_increments += s.contact()->active() > 0;
    }
  } rec;
  rec.a_mid = 16;
  rec.b_mid = offset + 8;
  Simulation sim(m);
  sim.run(&rec);
  std::printf("drop: %d increments in contact, smallest centre-line distance %.5f m (2r = %.3f), "
              "largest energy gain %.3e J of %.3e J work\n",
              rec.contact_increments, rec.worst_gap, 2 * r, rec.worst_energy, rec.max_work);
  EXPECT_GT(rec.contact_increments, 10);
  EXPECT_GT(rec.worst_gap, r);                      // never through the other beam's centre line
  EXPECT_LT(rec.worst_energy, 1e-3 * rec.max_work); // no energy created
}

/// A rod "top" along y pressed 2 mm into a rod "bottom" along x that ends at x = 0 (both of
/// radius 10 mm), then moved by `travel` along +x: past the bottom's end when travel > 0.1 m. The
/// top is prescribed, the bottom clamped at both ends; frictionless spline contact.
Model slide_off_the_end(double travel) {
  return read_deck_string(fmt::format(R"(
[[materials]]
name = "rod"
E = 1e9
nu = 0.3
density = 1000.0
[[sections]]
name = "rod"
shape = "circle"
radius = 0.01
material = "rod"
[[lines]]
name = "bottom"
from = [-0.5, 0.0, 0.0]
to = [0.0, 0.0, 0.0]
elements = 10
section = "rod"
reference_vector = [0.0, 1.0, 0.0]
[[lines]]
name = "top"
from = [-0.1, -0.5, 0.02]
to = [-0.1, 0.5, 0.02]
elements = 10
section = "rod"
reference_vector = [1.0, 0.0, 0.0]
[[node_sets]]
name = "ends"
nodes = [1, 21]
[[constraints]]
node_set = "ends"
dofs = "all"
[[constraints]]
node_set = "top"
dofs = "rotations"
[[prescribed]]
node_set = "top"
displacement = {{ x = [[0.0, 0.0], [0.2, 0.0], [1.0, {}]], y = [[0.0, 0.0]], z = [[0.0, 0.0], [0.2, -2e-3], [1.0, -2e-3]] }}
[[splines]]
name = "bottom"
node_set = "bottom"
radius = 0.01
[[splines]]
name = "top"
node_set = "top"
radius = 0.01
[[contacts]]
name = "crossing"
type = "spline"
between = ["bottom", "top"]
law = "linear"
penalty = 1e5
[[steps]]
type = "static"
end_time = 1.0
dt = 0.05
)",
                                      travel),
                          "slide.toml");
}

using test::Notices;

TEST(ContactVerification, AYarnThatSlidesOffTheEndOfAnotherIsSaidOnce) {
  // The crossing carries the press until it reaches the bottom's end (x = 0 at t = 0.47 s); one
  // increment later its point lies past that end, within the radii of the end polynomial's
  // extension, and no pair carries it: the run says so once, naming both yarns (issue 14: the
  // 96 x 96 weave's edge yarns slid off the ends of the wefts and the run halved to a stall
  // without saying why; a failed attempt's reason says it too).
  const Model model_past = slide_off_the_end(0.3);
  Simulation past(model_past);
  Notices said_past;
  past.run(&said_past);
  ASSERT_EQ(said_past.said.size(), 1u);
  const std::string& what = said_past.said.front();
  std::printf("%s\n", what.c_str());
  EXPECT_NE(what.find("1 contact point(s) that carried force in the last converged state have "
                      "passed the end of a yarn"),
            std::string::npos)
      << what;
  EXPECT_NE(what.find("'top' past the end of 'bottom'"), std::string::npos) << what;
  const double t = std::stod(what.substr(what.find("t = ") + 4));
  EXPECT_GT(t, 0.46);
  EXPECT_LT(t, 0.55);
  // Stopped short of the end, the same crossing says nothing.
  const Model model_short = slide_off_the_end(0.09);
  Simulation short_of_it(model_short);
  Notices said_short;
  short_of_it.run(&said_short);
  EXPECT_TRUE(said_short.said.empty()) << said_short.said.front();
  EXPECT_EQ(short_of_it.contact()->summary().active, 1);
}

} // namespace
} // namespace yarnsim
