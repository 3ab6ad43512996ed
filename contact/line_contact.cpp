#include "contact/line_contact.hpp"

#include "contact/all_angle_jet.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>

// Derivatives. A Gauss point's projection v(x) onto B and the closest points (u_A, u_B)(x) of
// the point contact are implicit functions of the positions x, differentiated to second order
// by two Newton steps on jets from their converged values (projection_jet.hpp; for v, the same
// two steps on B's projection alone, below). Everything after that is explicit.

namespace yarnsim::contact {

namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

/// Half-width of the band around an interior knot (segments) in which ownership is decided by
/// the knot test (as in spline_contact.cpp).
constexpr double kKnotBand = 1e-8;

/// Projection of point a onto segment (x, b) extended: the u where C'(u) . (C(u) - a) = 0, a
/// local minimum of |C(u) - a|^2 / 2, by safeguarded Newton from the projection onto the chord.
struct PointProjection {
  bool converged = false;
  bool left = false; ///< an iterate went beyond the segment's neighbourhood (not this pair's)
  double u = 0.0;    ///< the solution, or the last iterate
};

PointProjection project_onto(const Vector3d& a, const Matrix3d& x, const SegmentBasis& b,
                             const SplineContactOptions& opt) {
  PointProjection out;
  const double limit = 0.5 + opt.max_extension;
  const Vector3d p0 = x * b.values_local(-0.5);
  const Vector3d chord = x * b.values_local(0.5) - p0;
  double u = std::clamp((a - p0).dot(chord) / chord.squaredNorm() - 0.5, -limit, limit);
  if (!std::isfinite(u))
    return out;
  const Vector3d c2 = x * b.second_local();
  double previous = 0.0;
  for (int it = 0; it < opt.max_iterations; ++it) {
    const Vector3d d = x * b.values_local(u) - a;
    const Vector3d c1 = x * b.first_local(u);
    const double q = c1.dot(d);
    const double h = c1.squaredNorm() + c2.dot(d);
    const double scale = c1.squaredNorm();
    out.u = u;
    if (!(scale > 0.0) || !std::isfinite(h))
      return out;
    const bool definite = h > 1e-3 * scale;
    double step = -q / (definite ? h : 1e-3 * scale + std::abs(h));
    if (definite && newton_step_converges(std::abs(step), previous, opt.step_tolerance)) {
      out.converged = true;
      out.u = u + step;
      return out;
    }
    const bool capped = std::abs(step) > 0.5;
    step = std::clamp(step, -0.5, 0.5);
    double t = 1.0;
    if (!definite || capped) {
      const double phi = 0.5 * d.squaredNorm();
      while (0.5 * (x * b.values_local(u + t * step) - a).squaredNorm() >
             phi + 1e-4 * t * q * step) {
        t *= 0.5;
        if (t < 1e-12)
          return out;
      }
    }
    previous = definite && !capped && t == 1.0 ? std::abs(step) : 0.0;
    u += t * step;
    out.u = u;
    if (std::abs(u) > limit) {
      out.left = true;
      return out;
    }
  }
  return out;
}

/// Whether B's segment owns the projection u of point a; see line_contact.
bool owns_projection(const Matrix3d& x, const SegmentBasis& b, double u, const Vector3d& a) {
  // q(knot) = C'(knot) . (C(knot) - a) up to a positive factor, from the shared control points
  // x0, x1 (knot point (x0 + x1) / 2, tangent along x1 - x0); q increases through the minimum,
  // so q(knot) > 0 puts the minimum below the knot.
  auto side = [&](int i) {
    const Vector3d x0 = x.col(i), x1 = x.col(i + 1);
    return (x1 - x0).dot(0.5 * (x0 + x1) - a);
  };
  if (b.begin() > 0.0 && std::abs(u + 0.5) < kKnotBand)
    return !(side(0) > 0.0);
  if (!b.closes_end() && std::abs(u - 0.5) < kKnotBand)
    return side(1) > 0.0;
  return b.owns(b.global(u));
}

double sine2_of(const Vector3d& t1, const Vector3d& t2) {
  return t1.cross(t2).squaredNorm() / (t1.squaredNorm() * t2.squaredNorm());
}

/// One Gauss point's term of the line potential, w |C_A'(u)| (1 - s) U(p) line_scale, as a jet
/// of the positions: A's point and tangent at the fixed Gauss point u, B's projection v by two
/// Newton steps from its converged value. Also returns the term's normal force.
template <int H>
JetT<H> gauss_point_term(const Matrix3d& control_A, const SegmentBasis& basis_A, double u,
                         double weight, const Matrix3d& control_B, const SegmentBasis& basis_B,
                         double v0, double reach, const InterfaceLaw& law,
                         const AllAngleOptions& all_angle, double& force) {
  using J = JetT<H>;
  const J fixed(u);
  const Jet3T<H> ja = jet_point(control_A, basis_A, 0, fixed);
  const Jet3T<H> jta = jet_tangent(control_A, basis_A, 0, fixed);
  const J v = point_projection_jet(ja, control_B, basis_B, v0);
  const Jet3T<H> g = ja - jet_point(control_B, basis_B, 3, v);
  const Jet3T<H> jtb = jet_tangent(control_B, basis_B, 3, v);
  const J p = J(reach) - sqrt(dot(g, g));
  const double scale = all_angle.line_scale;
  const double f = scale * law.force(p.v, 0.0);
  const J energy = apply(p, scale * law.potential(p.v), f, scale * law.stiffness(p.v, 0.0));
  const J length = sqrt(dot(jta, jta)); // |dC_A/du|: arc length per unit of u
  const J line_share = J(1.0) - share_jet(sine2_of(jta, jtb), all_angle);
  force = weight * length.v * line_share.v * f;
  return (weight * length) * (line_share * energy);
}

/// The point share s of the closest points (u_A, u_B) as a jet of the positions: two Newton
/// steps on r = [C_A'.g, -C_B'.g] from the converged values.
template <int H>
JetT<H> point_share_jet(const Matrix3d& control_A, const SegmentBasis& basis_A, double ua,
                        const Matrix3d& control_B, const SegmentBasis& basis_B, double ub,
                        const AllAngleOptions& all_angle) {
  JetT<H> jua, jub;
  closest_point_jets(control_A, basis_A, ua, control_B, basis_B, ub, jua, jub);
  return share_jet(
      sine2_of(jet_tangent(control_A, basis_A, 0, jua), jet_tangent(control_B, basis_B, 3, jub)),
      all_angle);
}

/// The rule of n points, computed (gauss_rule returns the tabulated ones).
GaussRule compute_gauss_rule(int n) {
  GaussRule rule;
  rule.n = std::clamp(n, 1, kMaxGaussPoints);
  n = rule.n;
  for (int i = 0; i < n; ++i) {
    double z = std::cos(std::numbers::pi * (i + 0.75) / (n + 0.5));
    double dp = 1.0;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1.0, p1 = z;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      if (n == 1) {
        p1 = z;
        p0 = 1.0;
      }
      dp = n * (z * p1 - p0) / (z * z - 1.0);
      const double dz = p1 / dp;
      z -= dz;
      if (std::abs(dz) < 1e-15)
        break;
    }
    rule.u[i] = 0.5 * z;
    rule.w[i] = 1.0 / ((1.0 - z * z) * dp * dp); // 2 / ((1 - z^2) P_n'^2), halved
  }
  return rule;
}

} // namespace

const GaussRule& gauss_rule(int n) {
  // Computed once for every n (thread-safe static initialisation): the line contact and its
  // friction ask for the rule at every pair of every Newton iteration.
  static const std::array<GaussRule, kMaxGaussPoints> rules = [] {
    std::array<GaussRule, kMaxGaussPoints> out{};
    for (int k = 1; k <= kMaxGaussPoints; ++k)
      out[k - 1] = compute_gauss_rule(k);
    return out;
  }();
  return rules[std::clamp(n, 1, kMaxGaussPoints) - 1];
}

double point_share(double sine2, const AllAngleOptions& options, double* ds, double* d2s) {
  const double lo = options.line_sine * options.line_sine;
  const double hi = options.point_sine * options.point_sine;
  const double q = (sine2 - lo) / (hi - lo);
  double s = 0.0, dq = 0.0, d2q = 0.0;
  if (q >= 1.0) {
    s = 1.0;
  } else if (q > 0.0) {
    s = q * q * q * (10.0 + q * (-15.0 + 6.0 * q));
    dq = 30.0 * q * q * (1.0 + q * (-2.0 + q));
    d2q = 60.0 * q * (1.0 + q * (-3.0 + 2.0 * q));
  }
  if (ds != nullptr)
    *ds = dq / (hi - lo);
  if (d2s != nullptr)
    *d2s = d2q / ((hi - lo) * (hi - lo));
  return s;
}

void line_contact(const Matrix3d& control_A, const SegmentBasis& basis_A, double radius_A,
                  const Matrix3d& control_B, const SegmentBasis& basis_B, double radius_B,
                  const InterfaceLaw& law, const AllAngleOptions& all_angle, LineContactResult& out,
                  const SplineContactOptions& options) {
  out.points = 0;
  out.mask = 0;
  out.owned = 0;
  out.failed = 0;
  out.min_gap = std::numeric_limits<double>::infinity();
  out.force = 0.0;
  out.potential = 0.0;
  out.gap = 0.0;
  out.residual.setZero();
  if (options.compute_tangent)
    out.tangent.setZero();
  const double reach = radius_A + radius_B;
  const double hi2 = all_angle.point_sine * all_angle.point_sine;
  const GaussRule& rule = gauss_rule(all_angle.gauss_points);
  double deepest = -std::numeric_limits<double>::infinity();
  for (int i = 0; i < rule.n; ++i) {
    const double ua = rule.u[i];
    const Vector3d a = control_A * basis_A.values_local(ua);
    const Vector3d ta = control_A * basis_A.first_local(ua);
    const PointProjection proj = project_onto(a, control_B, basis_B, options);
    if (!proj.converged) {
      // A failure counts only where it may hide contact: the last iterate in the segment's
      // range and within reach. Far from a segment, or beyond a curve's end (where the
      // extended polynomial of an end segment folds back), the point is not this pair's.
      if (!proj.left && std::abs(proj.u) <= 0.5 &&
          (control_B * basis_B.values_local(proj.u) - a).norm() < radius_A + radius_B)
        ++out.failed;
      continue;
    }
    if (!owns_projection(control_B, basis_B, proj.u, a))
      continue;
    const Vector3d b = control_B * basis_B.values_local(proj.u);
    const Vector3d tb = control_B * basis_B.first_local(proj.u);
    const double dist = (a - b).norm();
    if (!(dist > 1e-14 * tb.norm())) {
      ++out.failed; // the centre lines intersect: no normal
      continue;
    }
    ++out.owned;
    out.min_gap = std::min(out.min_gap, dist - reach);
    if (!(dist < reach + law.onset()) || !(sine2_of(ta, tb) < hi2))
      continue; // apart (the law acts from a gap of onset() on), or the point contact's alone
    double force = 0.0;
    if (options.compute_tangent) {
      const Jet e = gauss_point_term<18>(control_A, basis_A, ua, rule.w[i], control_B, basis_B,
                                         proj.u, reach, law, all_angle, force);
      out.potential += e.v;
      out.residual += e.g;
      out.tangent += e.h;
    } else {
      const JetT<0> e = gauss_point_term<0>(control_A, basis_A, ua, rule.w[i], control_B, basis_B,
                                            proj.u, reach, law, all_angle, force);
      out.potential += e.v;
      out.residual += e.g;
    }
    out.force += force;
    out.mask |= static_cast<std::uint16_t>(1u << i);
    out.u_B[i] = proj.u;
    ++out.points;
    if (reach - dist > deepest) {
      deepest = reach - dist;
      out.gap = dist - reach;
      out.point_A = a;
      out.point_B = b;
      out.normal = (a - b) / dist;
    }
  }
}

void all_angle_contact(const Matrix3d& control_A, const SegmentBasis& basis_A, double radius_A,
                       const Matrix3d& control_B, const SegmentBasis& basis_B, double radius_B,
                       const ProjectionStart& start, const InterfaceLaw& law,
                       const AllAngleOptions& all_angle, SplineContactResult& out,
                       const SplineContactOptions& options, SplineContactSensitivity* sensitivity,
                       const PairRates* rates) {
  if (sensitivity)
    sensitivity->valid = false;
  const Vector3d chord_a = control_A * (basis_A.values_local(0.5) - basis_A.values_local(-0.5));
  const Vector3d chord_b = control_B * (basis_B.values_local(0.5) - basis_B.values_local(-0.5));
  const double chord_sine2 = sine2_of(chord_a, chord_b);
  const double gate = 0.5 * all_angle.line_sine;
  // Point part.
  out.point_evaluated = chord_sine2 >= gate * gate;
  out.point_share = 0.0;
  out.line_points = 0;
  out.line_mask = 0;
  bool tangent_written = false;
  if (out.point_evaluated) {
    spline_contact(control_A, basis_A, radius_A, control_B, basis_B, radius_B, start, law, out,
                   options, rates, sensitivity);
    tangent_written = out.active && options.compute_tangent;
    // Between half the line angle and the line angle the point contact is ill-conditioned and
    // would carry no share: a failed projection there is not the step's fault.
    if (out.status == ProjectionStatus::NotConverged &&
        chord_sine2 < all_angle.line_sine * all_angle.line_sine)
      out.status = ProjectionStatus::OutOfRange;
  } else {
    out.status = ProjectionStatus::OutOfRange;
    out.degenerate = false;
    out.iterations = 0;
    out.xi_A = start.warm ? start.xi_A : basis_A.mid();
    out.xi_B = start.warm ? start.xi_B : basis_B.mid();
    out.active = out.point_active = false;
    out.force = out.point_force = out.potential = out.penetration_rate = 0.0;
    out.distance = out.gap = out.penetration = 0.0;
    out.point_A.setZero();
    out.point_B.setZero();
    out.normal.setZero();
    out.residual.setZero();
  }
  const bool owned =
      out.status == ProjectionStatus::Converged || out.status == ProjectionStatus::Jumped;
  if (out.point_evaluated && owned) {
    const double ua = basis_A.local(out.xi_A), ub = basis_B.local(out.xi_B);
    const double sine2 =
        sine2_of(control_A * basis_A.first_local(ua), control_B * basis_B.first_local(ub));
    out.point_share = point_share(sine2, all_angle);
    // The sensitivity describes the point part (its share's gradient in `share`), whatever the
    // line part holds; with no share there is no point part.
    if (sensitivity && out.point_share == 0.0)
      sensitivity->valid = false;
    if (out.point_share == 0.0) {
      // No share: a jump of this point moves no force.
      if (out.status == ProjectionStatus::Jumped)
        out.status = ProjectionStatus::Converged;
      out.active = out.point_active = false;
      out.force = out.point_force = out.potential = 0.0;
      out.residual.setZero();
      tangent_written = false;
    } else if (out.point_share < 1.0 && out.active) {
      // s(x) U(x), with U's gradient and Hessian the point contact's residual and tangent. With
      // damping the point force is f = f_el + f_damp and the blended force s r + U grad s: its
      // derivative holds grad s grad U^T, grad U the elastic part of r (r scaled by f_el / f).
      const double u = out.potential;
      if (options.compute_tangent) {
        const Jet s =
            point_share_jet<18>(control_A, basis_A, ua, control_B, basis_B, ub, all_angle);
        // grad U = -f_el kron(w, n), w = [N_A(u_A); -N_B(u_B)] (a regular point: the blend zone
        // lies far above the degenerate path's angle); without damping it is the residual.
        Eigen::Matrix<double, 18, 1> grad_u = out.residual;
        if (rates != nullptr) {
          const double f_el = law.force(out.penetration, 0.0);
          const Vector3d na = basis_A.values_local(ua), nb = basis_B.values_local(ub);
          for (int k = 0; k < 3; ++k) {
            grad_u.segment<3>(3 * k) = -f_el * na(k) * out.normal;
            grad_u.segment<3>(9 + 3 * k) = f_el * nb(k) * out.normal;
          }
        }
        out.tangent *= s.v;
        out.tangent.noalias() += s.g * grad_u.transpose();
        out.tangent.noalias() += out.residual * s.g.transpose();
        out.tangent += u * s.h;
        out.residual = s.v * out.residual + u * s.g;
        if (sensitivity && sensitivity->valid)
          sensitivity->share = s.g;
      } else {
        const JetT<0> s =
            point_share_jet<0>(control_A, basis_A, ua, control_B, basis_B, ub, all_angle);
        out.residual = s.v * out.residual + u * s.g;
        if (sensitivity && sensitivity->valid)
          sensitivity->share = s.g;
      }
      out.potential = out.point_share * u;
      out.force *= out.point_share;
    }
  }
  // Line part, where the chords are not clearly crossing (below twice the point angle, where
  // the line share is 0 unless the segments are strongly curved).
  const double line_gate = std::min(1.0, 2.0 * all_angle.point_sine);
  if (chord_sine2 >= line_gate * line_gate) {
    if (!tangent_written && options.compute_tangent && options.zero_unused_tangent)
      out.tangent.setZero();
    return;
  }
  LineContactResult line;
  line_contact(control_A, basis_A, radius_A, control_B, basis_B, radius_B, law, all_angle, line,
               options);
  out.line_points = line.points;
  out.line_mask = line.mask;
  out.line_u = line.u_B;
  // A Gauss point without a projection (or a normal) is a hole in the line contact: as for the
  // point contact, the stage vetoes the step if the pair is or was in contact.
  if (line.failed > 0)
    out.status = ProjectionStatus::NotConverged;
  if (line.owned > 0 && !out.active) {
    // The smallest gap this pair sees (the run's clearance report and summary): the line's,
    // where the point contact was not evaluated or is a neighbour's.
    const bool point_gap = out.status == ProjectionStatus::Converged;
    if (!point_gap && out.status != ProjectionStatus::NotConverged &&
        out.status != ProjectionStatus::Jumped)
      out.status = ProjectionStatus::Converged;
    if (!point_gap || line.min_gap < out.gap) {
      out.gap = line.min_gap;
      out.penetration = -line.min_gap;
      out.distance = line.min_gap + radius_A + radius_B;
    }
  }
  if (line.points == 0) {
    if (!tangent_written && options.compute_tangent && options.zero_unused_tangent)
      out.tangent.setZero();
    return;
  }
  if (!out.active) {
    out.gap = line.gap;
    out.penetration = -line.gap;
    out.distance = line.gap + radius_A + radius_B;
    out.point_A = line.point_A;
    out.point_B = line.point_B;
    out.normal = line.normal;
    if (out.status != ProjectionStatus::NotConverged && out.status != ProjectionStatus::Jumped)
      out.status = ProjectionStatus::Converged;
  }
  out.active = true;
  out.force += line.force;
  out.potential += line.potential;
  out.residual += line.residual;
  if (options.compute_tangent) {
    if (tangent_written)
      out.tangent += line.tangent;
    else
      out.tangent = line.tangent;
  }
}

} // namespace yarnsim::contact
