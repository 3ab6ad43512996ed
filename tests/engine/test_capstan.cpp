// The capstan (issue "Friction between yarns", acceptance): a flexible yarn pulled over N fixed
// frictional pins that turn it by theta in all slips when the tension ratio reaches the exact
// discrete capstan law of N point contacts, which tends to exp(mu theta) as N grows.
//
// Derivation (one pin). Far from the pin the yarn is straight and moment-free: tension T_in
// along d1 arriving, T_out along d2 leaving, d1 to d2 turning by alpha towards the pin. The pin
// touches the centre line at one point with the force N n + F t, t the yarn's tangent there (the
// friction kernel acts along C_A'(xi_A), contact/friction.hpp) and n normal to it. Let t make the
// angle delta1 with d1 and delta2 = alpha - delta1 with d2. The yarn between two far points is
// in equilibrium: T_out d2 - T_in d1 + N n + F t = 0, i.e.
//   along t:  T_out cos delta2 - T_in cos delta1 + F = 0,
//   along n:  N = T_out sin delta2 + T_in sin delta1,
// and slipping towards the pulled end F = -mu N, so
//   q = T_out / T_in = (cos delta1 + mu sin delta1) / (cos delta2 - mu sin delta2).       (1)
// (a) A tangent on the bisector (delta1 = delta2 = alpha / 2) gives the sharp-corner law
//   q_b = (1 + mu tan(alpha / 2)) / (1 - mu tan(alpha / 2)).
// (b) The yarn is a rod, though: with any EI > 0 its bending moment is continuous at the point
//   force (the kernel applies no couple), and on each side it is a tensioned elastica whose first
//   integral EI kappa^2 / 2 = T (1 - cos psi) (psi the angle to that side's far direction, T that
//   side's constant tension) gives the moment at the contact, 2 sqrt(EI T) sin(psi / 2). So
//   sqrt(T_in) sin(delta1 / 2) = sqrt(T_out) sin(delta2 / 2):
//     tan(delta1 / 2) = sqrt(q) sin(alpha / 2) / (1 + sqrt(q) cos(alpha / 2)),
//   EI cancels: the tighter side bends less and the tangent leans towards it by about
//   mu alpha^2 / 8, however small EI is, as long as the bending layer l = sqrt(EI / T) is short
//   against the spans (and resolved by the mesh). (1) with this delta1, solved by a fixed point,
//   is the rod law q_r: the exact law of the model simulated here (a string is its EI -> 0 limit;
//   a bisecting tangent would need a yarn pre-kinked at each pin, which a sliding yarn is not).
// N pins turning alpha = theta / N each, the tensions multiply: T_end / T_start = q^N, and
//   ln q_b^N = mu theta + (1 + mu^2) mu theta^3 / (12 N^2) + O(N^-4),
//   ln q_r^N = mu theta - (1 + mu^2) mu theta^3 / (24 N^2) + O(N^-3),
// (from ln((1 + x) / (1 - x)) = 2x + 2x^3 / 3 and d ln q / d delta1 = -(1 + mu^2) alpha at the
// bisector, with delta1 - delta2 = mu alpha^2 / 4): both tend to exp(mu theta) as 1 / N^2, from
// either side, and differ from each other by (1 + mu^2) mu theta^3 / (8 N^2).
//
// The simulation tells them apart: at theta = pi, mu = 0.5 the sharp-corner law is 17 %, 3.9 %
// and 0.95 % above the rod law for N = 4, 8, 16; the simulated ratio follows the rod law within
// the errors of the mesh (see kTolerance below).
#include "beam_models.hpp"
#include "engine/input/read_deck.hpp"
#include "engine/solver/simulation.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <gtest/gtest.h>
#include <numbers>
#include <string>
#include <vector>

namespace yarnsim {
namespace {

using Eigen::Vector3d;

/// The capstan's dimensions (SI). The yarn is a stiffness section: EA high (strain below 2e-3 at
/// 20 N), GA = EA (shear kinks N / GA below 1e-3 rad), and EI = T0 l0^2 = 1.9e-7 N m^2, tiny
/// against T R^2 (EI / (T R^2) below 8e-5 at T >= 1 N: a string on the scale of the pins) but
/// not zero, so the stick phase and the contact's neighbourhood have a stiffness Newton can use.
/// The tensions at slip run from about 1 N to 21 N, so the bending layer l = sqrt(EI / T) runs
/// from 0.44 mm down to 0.1 mm: short against the spans between pins (R theta / N = 9.8 mm at
/// N = 16), long against the yarn-to-pin distance d = r + r_p = 0.1 mm times 2 sin(alpha / 4)
/// (0.04 mm at N = 4), below which the yarn's centre line would curve round the pin tighter than
/// the pin's axis is far (the closest point of the pin's axis then stops being a strict
/// minimum: the yarn would wrap the pin, a line contact, and the point projection fails).
struct CapstanParameters {
  int pins = 4;
  double theta = std::numbers::pi; ///< total turn, rad; the leads lie along y
  double mu = 0.5;
  double R = 0.05;   ///< m, radius of the pins' circle
  double r = 5e-5;   ///< m, yarn radius
  double r_p = 5e-5; ///< m, pin radius
  /// The stress-free yarn is the taut polygon with a fillet of radius rho = rho_factor l0 / alpha
  /// at each pin: its natural curvature is constant over a few layers l round the contact, as
  /// the rod law (b) assumes, and its slack is small.
  double rho_factor = 10;
  double lead = 0.05;       ///< m, each lead (start and end) from the first and last pins
  double T0 = 0.3;          ///< N, the scale of EI (below) and of the pre-tension
  double l0 = 8e-4;         ///< m, sqrt(EI / T0)
  double EA = 1e4;          ///< N
  double eps_n = 1e7;       ///< N/m: penetration below 2 um
  double eps_t = 1e6;       ///< N/m: stick below mu N / eps_t = 4 um
  double h_fine = 3.75e-5;  ///< m, elements within `zone` of a pin: l / 2.7 at 20 N
  double zone = 2.7e-3;     ///< m, 6 l at 1 N
  double h_coarse = 2e-3;   ///< m
  double grading = 0.25;    ///< growth of the element size per length beyond the zone
  double pull = 2e-4;       ///< m, of the end in step 2
  int pull_increments = 40; ///< 5 um each: the contact points move a fraction of a segment
  /// s, increments of step 1 (0 < t < 1); while the yarn is still slack some of them stall
  /// and are halved, fewer when they are small (0.03 for N = 16).
  double pretension_dt = 0.125;
};

/// A piece of the yarn's stress-free centre line: a line or a circular arc (in the xy plane).
struct Piece {
  bool arc = false;
  Vector3d a = Vector3d::Zero(), d = Vector3d::Zero(); ///< line: start, unit direction, m
  Vector3d c = Vector3d::Zero();                       ///< arc: centre, m
  double radius = 0, start_angle = 0;                  ///< arc: m, rad
  double length = 0;                                   ///< m
  Vector3d at(double s) const {
    if (!arc)
      return a + s * d;
    const double phi = start_angle + s / radius;
    return c + radius * Vector3d(std::cos(phi), std::sin(phi), 0);
  }
};

/// The capstan model: spline 0 the yarn (elements and nodes first), splines 1 to N the pins.
struct Capstan {
  Model model;
  int start = 0, end = 0;        ///< the yarn's end nodes: held, pulled
  std::vector<double> s_node;    ///< arc length of each yarn node along the stress-free yarn, m
  std::vector<double> s_contact; ///< arc length of each pin's contact (fillet midpoint), m
  double length = 0;             ///< of the stress-free yarn, m
  int yarn_elements = 0;
};

/// The in-plane normal to the left of direction d.
Vector3d left(const Vector3d& d) {
  return Vector3d(-d.y(), d.x(), 0);
}

/// A straight piece from `from` to `to`.
Piece line_piece(const Vector3d& from, const Vector3d& to) {
  Piece line;
  line.a = from;
  line.d = (to - from).normalized();
  line.length = (to - from).norm();
  return line;
}

/// The yarn over p.pins pins, the two steps (pins pushed out; the end pulled) and the contact.
Capstan capstan_model(const CapstanParameters& p) {
  const int N = p.pins;
  const double alpha = p.theta / N, d = p.r + p.r_p;
  const double rho = p.rho_factor * p.l0 / alpha;
  auto radial = [](double phi) { return Vector3d(std::cos(phi), std::sin(phi), 0); };
  // Corners of the taut polygon, with the fillets' midpoints touching the pins; the leads run
  // along y (theta = pi) from the ends at x = +X and -X, X = R_v cos(alpha / 2).
  const double Rv = p.R + d + rho * (1 / std::cos(alpha / 2) - 1);
  std::vector<Vector3d> corner;
  std::vector<Piece> pieces;
  Capstan cap;
  auto build = [&](double X) {
    corner.assign({Vector3d(X, Rv * std::sin(alpha / 2) - p.lead, 0)});
    for (int k = 0; k < N; ++k)
      corner.push_back(Rv * radial((k + 0.5) * alpha));
    corner.push_back(Vector3d(-X, Rv * std::sin(alpha / 2) - p.lead, 0));
    pieces.clear();
    cap.s_contact.clear();
    Vector3d from = corner[0];
    double s = 0;
    for (int k = 1; k <= N; ++k) {
      const Vector3d di = (corner[k] - corner[k - 1]).normalized();
      const Vector3d dn = (corner[k + 1] - corner[k]).normalized();
      const double beta = std::acos(std::clamp(di.dot(dn), -1.0, 1.0));
      const double t = rho * std::tan(beta / 2);
      const Vector3d A = corner[k] - t * di;
      const Piece line = line_piece(from, A);
      pieces.push_back(line);
      s += line.length;
      Piece arc;
      arc.arc = true;
      arc.c = A + rho * left(di);
      arc.radius = rho;
      const Vector3d v = A - arc.c;
      arc.start_angle = std::atan2(v.y(), v.x());
      arc.length = rho * beta;
      pieces.push_back(arc);
      cap.s_contact.push_back(s + arc.length / 2);
      s += arc.length;
      from = corner[k] + t * dn;
    }
    pieces.push_back(line_piece(from, corner[N + 1]));
    cap.length = s + pieces.back().length;
  };
  // The pins are pushed out radially (step 1) until the taut polygon through their contact
  // points (corners at radius R_c) is longer than the stress-free yarn by T0 L / EA: the yarn is
  // then taut at about T0 (less the layers' rounding, more the stick's uneven stretch).
  auto taut_length = [&](double Rc) {
    double L = (Rc * radial(alpha / 2) - corner.front()).norm() +
               (corner.back() - Rc * radial(p.theta - alpha / 2)).norm();
    for (int k = 0; k + 1 < N; ++k)
      L += 2 * Rc * std::sin(alpha / 2);
    return L;
  };
  build(Rv * std::cos(alpha / 2));
  double lo = p.R, hi = p.R + 10 * d + rho;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (taut_length(mid) < cap.length * (1 + p.T0 / p.EA) ? lo : hi) = mid;
  }
  const double Rc = lo;
  auto point = [&](double q) {
    for (const Piece& pc : pieces) {
      if (q <= pc.length)
        return pc.at(q);
      q -= pc.length;
    }
    return pieces.back().at(pieces.back().length);
  };
  // Element ends: fine within the zones, growing linearly beyond.
  std::vector<double> ends{0.0};
  while (true) {
    const double q = ends.back();
    double dist = 1e9;
    for (double sc : cap.s_contact)
      dist = std::min(dist, std::abs(q - sc));
    const double h = std::min(p.h_coarse, p.h_fine + p.grading * std::max(0.0, dist - p.zone));
    if (q + h >= cap.length - 0.3 * h) {
      ends.push_back(cap.length);
      break;
    }
    ends.push_back(q + h);
  }
  const double EI = p.T0 * p.l0 * p.l0;
  Model& m = cap.model;
  m.sections.push_back(test::stiffness_section(p.EA, p.EA, EI, EI));
  NodeSet yarn{"yarn", {}};
  for (std::size_t e = 0; e + 1 < ends.size(); ++e) {
    if (e == 0) {
      m.nodes.push_back(point(ends[0]));
      cap.s_node.push_back(ends[0]);
    }
    const double mid = 0.5 * (ends[e] + ends[e + 1]);
    m.nodes.push_back(point(mid));
    m.nodes.push_back(point(ends[e + 1]));
    cap.s_node.push_back(mid);
    cap.s_node.push_back(ends[e + 1]);
    const int n0 = static_cast<int>(2 * e);
    m.elements.push_back(BeamElement{{n0, n0 + 1, n0 + 2}, 0, Vector3d::UnitZ()});
  }
  cap.yarn_elements = static_cast<int>(m.elements.size());
  for (int i = 0; i < static_cast<int>(m.nodes.size()); ++i)
    yarn.nodes.push_back(i);
  cap.start = 0;
  cap.end = static_cast<int>(m.nodes.size()) - 1;
  m.node_sets = {yarn, NodeSet{"start", {cap.start}}, NodeSet{"end", {cap.end}}};
  m.splines.push_back(Spline{"yarn", yarn.nodes, p.r});
  // Pins along z, two elements each, their rotations held. They start a clearance c0 inside
  // the stress-free yarn's fillet midpoints and move out to R_c - d.
  const double c0 = 1e-6;
  const double push = Rc - d - (p.R - c0);
  NodeSet pins{"pins", {}};
  const double half = 4 * d;
  for (int k = 0; k < N; ++k) {
    const Vector3d e = radial((k + 0.5) * alpha);
    const Vector3d c = (p.R - c0) * e;
    const Model pin = test::straight_beam(c - half * Vector3d::UnitZ(),
                                          c + half * Vector3d::UnitZ(), 2, m.sections[0], e);
    const int offset = test::append_beam(m, pin);
    Spline spline{"pin" + std::to_string(k + 1), {}, p.r_p};
    NodeSet own{"pin" + std::to_string(k + 1), {}};
    for (int i = 0; i < 5; ++i) {
      spline.nodes.push_back(offset + i);
      pins.nodes.push_back(offset + i);
      own.nodes.push_back(offset + i);
    }
    m.splines.push_back(spline);
    m.node_sets.push_back(own);
    PrescribedMotion move;
    move.node_set = static_cast<int>(m.node_sets.size()) - 1;
    for (int i = 0; i < 3; ++i)
      move.displacement[i] = TimeTable{{0.0, 1.0}, {0.0, push * e[i]}};
    m.prescribed.push_back(move);
  }
  m.node_sets.push_back(pins);
  const int pin_set = static_cast<int>(m.node_sets.size()) - 1;
  // Planar yarn: z, and the rotations about x and y held; the ends' in-plane rotation held too.
  m.constraints.push_back(Constraint{0, {false, false, true, true, true, false}});
  m.constraints.push_back(Constraint{pin_set, {false, false, false, true, true, true}});
  m.constraints.push_back(Constraint{1, {false, false, false, false, false, true}});
  m.constraints.push_back(Constraint{2, {false, false, false, false, false, true}});
  // Step 1 (0 < t < 1): ends held, pins pushed out; step 2 (1 < t < 2): the start held, the
  // end pulled along its lead by `pull`.
  // The ends are held (start) and pulled (end) along the leads, which lie along y (theta = pi),
  // and are free across them: the leads stay parallel to y, so the yarn turns by theta exactly.
  PrescribedMotion start;
  start.node_set = 1;
  start.displacement[1] = TimeTable::constant(0.0);
  m.prescribed.push_back(start);
  PrescribedMotion pull;
  pull.node_set = 2;
  pull.displacement[1] = TimeTable{{0.0, 1.0, 2.0}, {0.0, 0.0, -p.pull}};
  m.prescribed.push_back(pull);
  SplineContactDefinition contact;
  contact.name = "capstan";
  contact.group_a = {0};
  contact.law = {p.eps_n, 1.0, 0.0};
  for (int k = 0; k < N; ++k)
    contact.group_b.push_back(k + 1);
  contact.line_contact = false;
  if (p.mu > 0)
    contact.friction = {p.mu, p.mu, p.eps_t};
  m.spline_contacts.push_back(contact);
  SolutionStep pretension = test::static_step(1.0, p.pretension_dt, 1e-10);
  pretension.max_iterations = 12;
  SolutionStep drag = test::static_step(2.0, 1.0 / p.pull_increments, 1e-10);
  m.steps = {pretension, drag};
  return cap;
}

/// Per-pin law (1) with the tangent at delta1 from the incoming direction.
double coulomb_ratio(double alpha, double mu, double delta1) {
  const double delta2 = alpha - delta1;
  return (std::cos(delta1) + mu * std::sin(delta1)) / (std::cos(delta2) - mu * std::sin(delta2));
}

/// Sharp-corner law (a): the tangent on the bisector.
double bisector_ratio(double alpha, double mu) {
  const double t = mu * std::tan(alpha / 2);
  return (1 + t) / (1 - t);
}

/// Rod law (b): delta1 from the continuity of the bending moment, by a fixed point (a
/// contraction: q moves delta1 by O(mu alpha^2)).
double rod_ratio(double alpha, double mu, double* delta1 = nullptr) {
  double q = bisector_ratio(alpha, mu), d1 = alpha / 2;
  for (int i = 0; i < 60; ++i) {
    const double s = std::sqrt(q);
    d1 = 2 * std::atan(s * std::sin(alpha / 2) / (1 + s * std::cos(alpha / 2)));
    q = coulomb_ratio(alpha, mu, d1);
  }
  if (delta1)
    *delta1 = d1;
  return q;
}

double signed_angle(const Vector3d& a, const Vector3d& b) {
  return std::atan2(a.x() * b.y() - a.y() * b.x(), a.dot(b));
}

/// Per increment of the pull: the end tensions (the reactions at the two ends, N) while every
/// contact slips.
class SlipRecorder final : public SimulationObserver {
public:
  explicit SlipRecorder(const Capstan& c) : cap_(c) {}
  void on_increment(const Simulation& sim, const IncrementReport& r) override {
    const ContactSummary cs = sim.contact()->summary();
    if (r.time <= 1 || cs.active == 0 || cs.slip != cs.active)
      return;
    const double start = sim.reactions().col(cap_.start).head<3>().norm();
    const double end = sim.reactions().col(cap_.end).head<3>().norm();
    ratios.push_back(end / start);
    active.push_back(cs.active);
  }
  std::vector<double> ratios;
  std::vector<int> active;

private:
  const Capstan& cap_;
};

/// Runs the capstan with `pins` pins and checks its ratio at slip against the rod law.
/// `pull`: of the end in step 2 (m), in increments of 5 um; every contact slips from about
/// 1.2e-4 m (N = 16) or 1.3e-4 m (N = 4) on.
void check_capstan(int pins, double pull, double tolerance) {
  CapstanParameters p;
  p.pins = pins;
  p.pull = pull;
  p.pull_increments = static_cast<int>(std::lround(pull / 5e-6));
  p.pretension_dt = pins > 8 ? 0.03 : 0.125;
  const Capstan cap = capstan_model(p);
  const auto t0 = std::chrono::steady_clock::now();
  Simulation sim(cap.model);
  SlipRecorder rec(cap);
  sim.run(&rec);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double alpha = p.theta / pins;
  double delta1_rod;
  const double rod = std::pow(rod_ratio(alpha, p.mu, &delta1_rod), pins);
  const double bisector = std::pow(bisector_ratio(alpha, p.mu), pins);
  const double exact = std::exp(p.mu * p.theta);
  // Every contact slips over the last part of the pull.
  ASSERT_GE(rec.ratios.size(), 8u) << "N = " << pins;
  double worst = 0;
  for (std::size_t k = 0; k < rec.ratios.size(); ++k) {
    EXPECT_EQ(rec.active[k], pins);
    worst = std::max(worst, std::abs(rec.ratios[k] / rod - 1));
    EXPECT_NEAR(rec.ratios[k] / rod, 1.0, tolerance) << "N = " << pins << ", increment " << k;
  }
  const double last = rec.ratios.back();
  std::printf("capstan N = %2d (%d yarn elements, %.1f s): T_end / T_start = %.6f at slip "
              "(%zu increments, worst error %.1e vs the rod law %.6f); sharp-corner law %.6f "
              "(%+.2e), exp(mu theta) = %.6f (rod law %+.2e, sim %+.2e)\n",
              pins, cap.yarn_elements, seconds, last, rec.ratios.size(), worst, rod, bisector,
              bisector / rod - 1, exact, rod / exact - 1, last / exact - 1);
  // The simulation tells the laws apart: the sharp-corner law is farther than 10 tolerances.
  EXPECT_GT(std::abs(bisector / rod - 1), 10 * tolerance);
  // Each pin: the tangent of the contact (the friction force's direction) against (b)'s, and
  // the tension ratio across it (section forces mid-span) against the rod law at the measured
  // turn. The spans: 0 the lead in, k between pins k and k + 1, N the lead out.
  std::vector<double> bounds{0.0};
  bounds.insert(bounds.end(), cap.s_contact.begin(), cap.s_contact.end());
  bounds.push_back(cap.length);
  const Eigen::Matrix3Xd& x = sim.state().x_n;
  auto node_near = [&](double s) {
    const auto it = std::lower_bound(cap.s_node.begin(), cap.s_node.end(), s);
    return static_cast<int>(std::min<std::ptrdiff_t>(
        it - cap.s_node.begin(), static_cast<std::ptrdiff_t>(cap.s_node.size()) - 1));
  };
  const auto resultants = sim.section_resultants();
  std::vector<Vector3d> direction;
  std::vector<double> tension;
  for (int k = 0; k <= pins; ++k) {
    const double a = bounds[k], b = bounds[k + 1];
    direction.push_back(
        (x.col(node_near(a + 0.6 * (b - a))) - x.col(node_near(a + 0.4 * (b - a)))).normalized());
    const int element = std::min(node_near(0.5 * (a + b)) / 2, cap.yarn_elements - 1);
    tension.push_back(resultants.col(2 * element).head<3>().norm());
  }
  const std::vector<ContactPoint> points = sim.contact()->points();
  for (int k = 0; k < pins; ++k) {
    const double turn = signed_angle(direction[k], direction[k + 1]);
    Vector3d t = Vector3d::Zero();
    for (const ContactPoint& c : points)
      if (c.body[1] == k + 1)
        t = -c.tangential_force.normalized(); // the friction on the yarn opposes its slip
    double expected_delta1;
    const double q_rod = rod_ratio(turn, p.mu, &expected_delta1);
    const double delta1 = signed_angle(direction[k], t);
    // A tangent off by e changes ln q by -(1 + mu^2) alpha e: the angle the ratio's tolerance
    // allows (a quarter of the lean for N = 16, a tenth for N = 4).
    EXPECT_NEAR(delta1, expected_delta1, tolerance / ((1 + p.mu * p.mu) * turn))
        << "N = " << pins << ", pin " << k + 1;
    EXPECT_NEAR(tension[k + 1] / tension[k] / q_rod, 1.0, tolerance)
        << "N = " << pins << ", pin " << k + 1;
  }
}

// Tolerances: in full slip the force at each point is exactly mu f_n along the yarn's tangent,
// so neither penalty enters (1) (eps_n and eps_t only move the contact points by microns); the
// error is that of the tangent at the contact, i.e. of the bending layer's discretisation by
// elements of h_fine (and of the spline through the nodes, which stands for the centre line),
// which makes the ratio oscillate as the contact points slide past the nodes. The worst error
// over the slipping increments, measured at N = 4: 3.2e-3, 1.7e-3, 5.9e-4 for h_fine = 75,
// 37.5, 18.75 um (about h^1.5); at h_fine = 37.5 um and EI / 2, EI, 2 EI: 2.5e-3, 1.7e-3,
// 8.4e-4 (N = 8: 4.3e-4, 2.7e-4, 2.0e-4, and 1.3e-4 at 4 EI). So it goes as (h / l)^1 to ^2:
// it is the mesh's, and it shrinks as EI grows; the rod law itself has no EI in it. (Below
// EI / 2 the layer at 20 N comes near the wrapping limit above.) It is smaller for more pins,
// each turning less: 2.7e-4 at N = 8, 3.7e-5 to 5.7e-5 at N = 16. The tolerances are about twice
// the measurements at h_fine = 37.5 um and EI = 1.9e-7 N m^2.
TEST(Capstan, FourPinsSlipAtTheRodLaw) {
  check_capstan(4, 2e-4, 3.5e-3);
}
TEST(Capstan, EightPinsSlipAtTheRodLaw) {
  check_capstan(8, 1.6e-4, 6e-4);
}
TEST(Capstan, SixteenPinsSlipAtTheRodLaw) {
  check_capstan(16, 1.2e-4, 1.5e-4);
}

TEST(Capstan, IncrementsStartFromTheConvergedStatesTangent) {
  // The pull moves the yarn's end alone: the first correction from the converged state's
  // tangent is the linear response of the taut yarn, sliding over its pins, to that motion
  // (simulation.cpp, Simulation::attempt); from the predictor's tangent it is a Newton step
  // from a yarn whose end element carries the whole pull. With the default (mixed integration
  // point) Newton, examples/capstan.toml measured 49 increments and 260 iterations against 150
  // and 707 with the option off (292 against 153 and 818 before damped points were judged by
  // their simplified correction).
  const Model m =
      read_deck(std::filesystem::path(YARNSIM_SOURCE_DIR) / "examples" / "capstan.toml");
  const auto run = [&](bool from_converged) {
    SimulationOptions options;
    options.first_correction_from_converged_state = from_converged;
    Simulation sim(m, options);
    struct Counter : SimulationObserver {
      int increments = 0;
      void on_increment(const Simulation&, const IncrementReport&) override { ++increments; }
    } counter;
    sim.run(&counter);
    std::printf("capstan, first correction from the %s: %d increments, %d Newton iterations\n",
                from_converged ? "converged state" : "predictor", counter.increments,
                sim.total_iterations());
    return std::pair<int, int>(counter.increments, sim.total_iterations());
  };
  const auto [increments, iterations] = run(true);
  const auto [increments_before, iterations_before] = run(false);
  EXPECT_LT(2 * increments, increments_before);
  EXPECT_LT(2 * iterations, iterations_before);
}

TEST(Capstan, DiscreteLawsTendToExpMuThetaAsOneOverNSquared) {
  const double mu = 0.5, theta = std::numbers::pi;
  const double c = (1 + mu * mu) * mu * std::pow(theta, 3);
  for (int n : {4, 8, 16, 64, 256}) {
    const double alpha = theta / n;
    const double rod = n * std::log(rod_ratio(alpha, mu)) - mu * theta;
    const double bisector = n * std::log(bisector_ratio(alpha, mu)) - mu * theta;
    std::printf("N = %3d: ln(q^N) - mu theta: rod law %+.4e (N^2 x %.5f), sharp corner %+.4e "
                "(N^2 x %.5f)\n",
                n, rod, rod * n * n / c, bisector, bisector * n * n / c);
    if (n >= 64) {
      EXPECT_NEAR(rod * n * n / c, -1.0 / 24, 0.02 / 24) << "N = " << n;
      EXPECT_NEAR(bisector * n * n / c, 1.0 / 12, 0.01 / 12) << "N = " << n;
    }
  }
  // (1) is the sharp-corner law on the bisector, and the rod law leans its tangent forwards.
  double delta1;
  rod_ratio(0.3, mu, &delta1);
  EXPECT_NEAR(coulomb_ratio(0.3, mu, 0.15), bisector_ratio(0.3, mu), 1e-15);
  EXPECT_GT(delta1, 0.15);
}

} // namespace
} // namespace yarnsim
