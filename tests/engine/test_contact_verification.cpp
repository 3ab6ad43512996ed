// Spline contact in the engine: the crossing-beams case of shared/docs/verification.md
// (F_c = P / (2 + k / eps)), and a yarn pulled along another across many segment boundaries.
#include "beam_models.hpp"
#include "engine/solver/simulation.hpp"

#include <gtest/gtest.h>
#include <cmath>
#include <cstdio>
#include <numbers>

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
  Model bottom = test::straight_beam({0, -L / 2, 0}, {0, L / 2, 0}, n_el, s, Eigen::Vector3d::UnitX());
  Model m = top;
  const int offset = static_cast<int>(m.nodes.size());
  m.nodes.insert(m.nodes.end(), bottom.nodes.begin(), bottom.nodes.end());
  for (BeamElement e : bottom.elements) {
    for (int& k : e.nodes)
      k += offset;
    m.elements.push_back(e);
  }
  const int last = 2 * n_el;
  // One end of each beam is held in all translations, the other slides along the beam axis, so
  // no membrane force stiffens the beams (the closed form is for the linear beam).
  m.node_sets = {NodeSet{"fixed_ends", {0, offset}}, NodeSet{"top_mid", {n_el}},
                 NodeSet{"top_start", {0}},         NodeSet{"bottom_start", {offset}},
                 NodeSet{"top_end", {last}},        NodeSet{"bottom_end", {offset + last}}};
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
  m.spline_contacts.push_back(SplineContactDefinition{"cross", {0}, {1}, {eps, 1.0, 0.0}, false, 0});
  SolutionStep step = test::static_step(1.0, 0.25, 1e-10);
  step.tol_increment = 1e-8;
  m.steps.push_back(step);
  return {m, n_el};
}

double contact_force(const Simulation& sim) {
  double f = 0;
  for (const ContactPoint& p : sim.spline_contact()->points())
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
                eps, got, expected, 100 * (got / expected - 1), sim.spline_contact()->active());
    EXPECT_NEAR(got, expected, 0.005 * expected) << "eps " << eps;
  }
}

TEST(ContactVerification, CrossingBeamsClampedMatchTheClosedForm) {
  const double EI = 1e9 * std::numbers::pi * 1e-8 / 4, k = 192 * EI, eps = 1e5;
  Crossing c = crossing_beams(eps, true, 32);
  Simulation sim(c.model);
  sim.run();
  const double expected = 1.0 / (2 + k / eps);
  const double got = contact_force(sim);
  std::printf("clamped-clamped, eps %.0e: F_c %.6f (closed form %.6f, %+.3f %%)\n", eps, got,
              expected, 100 * (got / expected - 1));
  EXPECT_NEAR(got, expected, 0.005 * expected);
}

} // namespace
} // namespace yarnsim
