#include "contact/spline_contact.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>

// Notation (formulation.md §5). The kernel works in each segment's local variable
// u = (xi - mid) / h (the range is u in [-1/2, 1/2]); every quantity below except the reported xi
// is invariant to that choice. With x the 18 positions [x_A0 x_A1 x_A2 x_B0 x_B1 x_B2]:
//   g = C_A - C_B = sum_k w_k x_k,        w = [N_A(u_A); -N_B(u_B)]
//   g_a = dg/du_A = sum_k wa_k x_k,       wa = [N_A'(u_A); 0]
//   g_b = dg/du_B = sum_k wb_k x_k,       wb = [0; -N_B'(u_B)]
//   Phi = |g|^2 / 2, r = dPhi/dc = [g_a.g, g_b.g] (eq. 11), H = dr/dc, D = dr/dx (2 x 18)
//   dPhi/dx = G^T g = kron(w, g), d2Phi/dx2 = kron(w w^T, I3).
// The distance as a function of the positions alone, psi(x) = |g(c(x), x)|, has the gradient
// and Hessian that give the residual and tangent; with c(x) the minimiser of Phi,
// d2Phi*/dx2 = kron(w w^T, I) - D^T H^-1 D (implicit differentiation, dc/dx = -H^-1 D), and
// psi = sqrt(2 Phi*) gives grad psi = grad Phi* / psi, hess psi = (hess Phi* - grad psi
// grad psi^T) / psi.

namespace yarnsim::contact {

namespace {

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Vec18 = Eigen::Matrix<double, 18, 1>;
using Mat18 = Eigen::Matrix<double, 18, 18>;
using Eigen::Matrix3d;
using Eigen::Vector3d;

/// Half-width of the band around an interior knot (segments) in which ownership is decided by
/// the knot test rather than by comparing xi with the knot.
constexpr double kKnotBand = 1e-8;
/// A Hessian eigenvalue below this fraction of the largest counts as not positive.
constexpr double kDefinite = 1e-10;
/// Added to the magnitude of a curvature that is not positive, as a fraction of the local
/// curvature scale.
constexpr double kShift = 1e-3;
/// Largest step per iteration, segments.
constexpr double kMaxStep = 1.0;
/// Positive-definite Newton steps shorter than this (segments) skip the line search: the
/// quadratic model is then accurate, and near the solution rounding in Phi would make the
/// Armijo test fail spuriously.
constexpr double kTrustedStep = 1e-3;

/// kron(w, v): block k of the result is w_k v.
Vec18 kron(const Vec6& w, const Vector3d& v) {
  Vec18 out;
  for (int k = 0; k < 6; ++k) {
    out.segment<3>(3 * k) = w(k) * v;
  }
  return out;
}

/// K += s kron(a b^T, M).
void add_kron(Mat18& k, const Vec6& a, const Vec6& b, const Matrix3d& m, double s) {
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 6; ++j) {
      k.block<3, 3>(3 * i, 3 * j) += (s * a(i) * b(j)) * m;
    }
  }
}

/// Round-off level of a component r = g_u . g of Phi's gradient (m^2 per unit u): g = C_A - C_B
/// is a difference of points of coordinates up to X = max |x| (metres), computed with basis
/// values that sum to one, so it carries an error of a few eps X; g_u, from basis derivatives
/// `dn`, one of eps X |dn|_1. The floor is 8 times the sum of the two products.
double gradient_floor(const Matrix3d& xa, const Matrix3d& xb, const Vector3d& gu, const Vector3d& g,
                      const Vector3d& dn) {
  const double x = std::max(xa.cwiseAbs().maxCoeff(), xb.cwiseAbs().maxCoeff());
  constexpr double eps = std::numeric_limits<double>::epsilon();
  return 8 * eps * x * (4 * gu.norm() + dn.lpNorm<1>() * g.norm());
}

/// Phi and its derivatives in c = (u_A, u_B) at one point.
struct Local {
  Vector3d na, dna, nb, dnb; // basis values and u-derivatives
  Vector3d g, ga, gb;
  Eigen::Vector2d r;
  Eigen::Matrix2d h;
};

/// Phi's derivatives at (u_A, u_B); gaa = C_A'' and gbb = -C_B'' are constant on a segment.
Local evaluate(const Matrix3d& xa, const SegmentBasis& ba, const Matrix3d& xb,
               const SegmentBasis& bb, double ua, double ub, const Vector3d& gaa,
               const Vector3d& gbb) {
  Local e;
  e.na = ba.values_local(ua);
  e.dna = ba.first_local(ua);
  e.nb = bb.values_local(ub);
  e.dnb = bb.first_local(ub);
  e.g = xa * e.na - xb * e.nb;
  e.ga = xa * e.dna;
  e.gb = -(xb * e.dnb);
  e.r << e.ga.dot(e.g), e.gb.dot(e.g);
  e.h(0, 0) = e.ga.squaredNorm() + gaa.dot(e.g);
  e.h(0, 1) = e.ga.dot(e.gb);
  e.h(1, 0) = e.h(0, 1);
  e.h(1, 1) = e.gb.squaredNorm() + gbb.dot(e.g);
  return e;
}

Local evaluate(const Matrix3d& xa, const SegmentBasis& ba, const Matrix3d& xb,
               const SegmentBasis& bb, double ua, double ub) {
  return evaluate(xa, ba, xb, bb, ua, ub, xa * ba.second_local(), -(xb * bb.second_local()));
}

double half_squared_distance(const Matrix3d& xa, const SegmentBasis& ba, const Matrix3d& xb,
                             const SegmentBasis& bb, double ua, double ub) {
  return 0.5 * (xa * ba.values_local(ua) - xb * bb.values_local(ub)).squaredNorm();
}

struct Solve {
  bool converged = false;
  bool left = false; // an iterate went beyond the segment's neighbourhood
  int iterations = 0;
  double ua = 0.0;
  double ub = 0.0;
};

/// First local minimiser in (0, t_end] of phi(t) = |g0 + t g1 + t^2 g2|^2 / 2, the half squared
/// distance along a search direction (exact, as the curves are quadratic in u), given that
/// phi'(0) = g0.g1 < 0; t_end if phi decreases on the whole interval. phi' is the cubic
/// c0 + c1 t + c2 t^2 + c3 t^3; it is monotone between the roots of phi'', so the first sign
/// change is bracketed and bisected.
double first_minimum_on_ray(const Vector3d& g0, const Vector3d& g1, const Vector3d& g2,
                            double t_end = 1.0) {
  const double c0 = g0.dot(g1);
  const double c1 = g1.squaredNorm() + 2.0 * g0.dot(g2);
  const double c2 = 3.0 * g1.dot(g2);
  const double c3 = 2.0 * g2.squaredNorm();
  auto slope = [&](double t) { return c0 + t * (c1 + t * (c2 + t * c3)); };
  // Ends of the monotone pieces of phi' in (0, t_end): roots of c1 + 2 c2 t + 3 c3 t^2.
  double ends[3] = {t_end, t_end, t_end};
  int n = 0;
  if (c3 > 0.0) {
    const double disc = c2 * c2 - 3.0 * c1 * c3;
    if (disc > 0.0) {
      const double root = std::sqrt(disc);
      for (const double t : {(-c2 - root) / (3.0 * c3), (-c2 + root) / (3.0 * c3)}) {
        if (t > 0.0 && t < t_end) {
          ends[n++] = t;
        }
      }
    }
  } else if (c2 != 0.0) {
    const double t = -c1 / (2.0 * c2);
    if (t > 0.0 && t < t_end) {
      ends[n++] = t;
    }
  }
  double lo = 0.0;
  for (int i = 0; i <= n; ++i) {
    double hi = ends[i];
    if (slope(hi) >= 0.0) {
      for (int k = 0; k < 60 && hi - lo > 1e-15; ++k) {
        const double mid = 0.5 * (lo + hi);
        (slope(mid) < 0.0 ? lo : hi) = mid;
      }
      return hi;
    }
    lo = hi;
  }
  return t_end;
}

/// Safeguarded Newton for min |g|^2 / 2 over (u_A, u_B) on the extended polynomials.
Solve newton_pair(const Matrix3d& xa, const SegmentBasis& ba, const Matrix3d& xb,
                  const SegmentBasis& bb, double ua, double ub, const SplineContactOptions& opt) {
  Solve s;
  const double limit = 0.5 + opt.max_extension;
  double previous = 0.0; // length of the previous step if it was a full Newton step
  const Vector3d gaa = xa * ba.second_local();
  const Vector3d gbb = -(xb * bb.second_local());
  for (int it = 0; it < opt.max_iterations; ++it) {
    s.iterations = it + 1;
    const Local e = evaluate(xa, ba, xb, bb, ua, ub, gaa, gbb);
    const double phi = 0.5 * e.g.squaredNorm();
    const double a = e.h(0, 0);
    const double b = e.h(0, 1);
    const double c = e.h(1, 1);
    const double radius = std::sqrt(0.25 * (a - c) * (a - c) + b * b);
    const double lmin = 0.5 * (a + c) - radius;
    const double lmax = 0.5 * (a + c) + radius;
    const double scale = std::max(std::abs(lmin), std::abs(lmax));
    if (!(scale > 0.0) || !std::isfinite(scale)) {
      break;
    }
    const bool definite = lmin > kDefinite * scale;
    Eigen::Vector2d step;
    if (definite) {
      const double det = a * c - b * b;
      step << -(c * e.r(0) - b * e.r(1)) / det, -(a * e.r(1) - b * e.r(0)) / det;
    } else {
      // Eigenvalue modification (Nocedal & Wright, Numerical Optimization, 2nd ed., §3.4), as
      // project_point does in one dimension: in the eigenbasis of H a curvature that is not
      // positive is replaced by its magnitude plus kShift * scale. Shifting the whole of H so
      // that its least eigenvalue becomes kShift * scale would make the step along that
      // eigenvector up to 1 / kShift times longer than the curvature warrants; capped, it would
      // be a jump of a whole segment along the eigenvector with the gradient's well-conditioned
      // component lost, which from the midpoints can skip a nearby in-range minimum and settle
      // in one beyond the range (OutOfRange: a contact lost).
      const double theta = 0.5 * std::atan2(2.0 * b, a - c);
      const Eigen::Vector2d vmax(std::cos(theta), std::sin(theta)); // eigenvector of lmax
      const Eigen::Vector2d vmin(-vmax(1), vmax(0));                // eigenvector of lmin
      auto modified = [&](double l) {
        return l > kDefinite * scale ? l : std::abs(l) + kShift * scale;
      };
      step = -(vmax.dot(e.r) / modified(lmax)) * vmax - (vmin.dot(e.r) / modified(lmin)) * vmin;
    }
    double length = step.norm();
    // Converged also where the gradient is at its round-off level (gradient_floor): there no
    // step can be trusted, and on an ill-conditioned pair (a yarn bent around another to nearly
    // their distance, H's eigenvalues 1e-2 apart and less) the step it gives stays above the
    // tolerance, the same length at every iteration.
    const double floor_a = gradient_floor(xa, xb, e.ga, e.g, ba.first_local(ua));
    const double floor_b = gradient_floor(xa, xb, e.gb, e.g, bb.first_local(ub));
    if (definite && (newton_step_converges(length, previous, opt.step_tolerance) ||
                     (std::abs(e.r(0)) <= floor_a && std::abs(e.r(1)) <= floor_b))) {
      s.converged = true;
      s.ua = ua + step(0);
      s.ub = ub + step(1);
      return s;
    }
    const bool capped = length > kMaxStep;
    if (capped) {
      step *= kMaxStep / length;
      length = kMaxStep;
    }
    // A capped or modified step follows no trusted model over its whole length, and with the
    // Armijo test alone it may cross the valley of the nearest minimum and land in another one
    // (beyond a range): it starts instead at the first minimum of Phi along its direction.
    // A modified step may go further than its length: along an eigenvector of H with next to no
    // curvature (two crimped yarns pressed together at a shallow crossing angle, where the
    // distance varies by 1e-9 m over a fifth of a segment along the valley between them) the
    // modified curvature is kShift * scale, not the valley's, and steps of that length crept
    // along the valley for the whole iteration limit. The ray is searched up to a segment's
    // length; the first minimum on it is still the nearest.
    double t = 1.0;
    if ((capped || !definite) && e.r.dot(step) < 0.0) {
      const double t_end = capped ? 1.0 : kMaxStep / length;
      t = first_minimum_on_ray(e.g, step(0) * e.ga + step(1) * e.gb,
                               0.5 * (step(0) * step(0) * gaa + step(1) * step(1) * gbb), t_end);
    }
    if (!(definite && length < kTrustedStep)) {
      const double slope = e.r.dot(step);
      while (half_squared_distance(xa, ba, xb, bb, ua + t * step(0), ub + t * step(1)) >
             phi + 1e-4 * t * slope) {
        t *= 0.5;
        if (t < 1e-12) {
          s.ua = ua;
          s.ub = ub;
          return s;
        }
      }
    }
    previous = definite && !capped && t == 1.0 ? length : 0.0;
    ua += t * step(0);
    ub += t * step(1);
    if (std::abs(ua) > limit || std::abs(ub) > limit) {
      s.left = true;
      break;
    }
  }
  s.ua = ua;
  s.ub = ub;
  return s;
}

/// Safeguarded Newton for the projection of point p onto segment (x, b) extended: the u
/// minimising |C(u) - p|^2 / 2.
Solve project_point(const Vector3d& p, const Matrix3d& x, const SegmentBasis& b, double u,
                    const SplineContactOptions& opt) {
  Solve s;
  const double limit = 0.5 + opt.max_extension;
  double previous = 0.0;
  const Vector3d c2 = x * b.second_local();
  for (int it = 0; it < opt.max_iterations; ++it) {
    s.iterations = it + 1;
    const Vector3d d = x * b.values_local(u) - p;
    const Vector3d c1 = x * b.first_local(u);
    const double r = c1.dot(d);
    const double h = c1.squaredNorm() + c2.dot(d);
    const double scale = std::max(c1.squaredNorm(), std::abs(h));
    if (!(scale > 0.0) || !std::isfinite(scale)) {
      break;
    }
    const bool definite = h > kDefinite * scale;
    double step = -r / (definite ? h : kShift * scale + std::abs(h));
    const Matrix3d px = Matrix3d::Constant(p.cwiseAbs().maxCoeff()); // p's scale, for the floor
    if (definite && (newton_step_converges(std::abs(step), previous, opt.step_tolerance) ||
                     std::abs(r) <= gradient_floor(x, px, c1, d, b.first_local(u)))) {
      s.converged = true;
      s.ua = u + step;
      return s;
    }
    const bool capped = std::abs(step) > kMaxStep;
    step = std::clamp(step, -kMaxStep, kMaxStep);
    double t = 1.0;
    if (!(definite && std::abs(step) < kTrustedStep)) {
      const double phi = 0.5 * d.squaredNorm();
      while (0.5 * (x * b.values_local(u + t * step) - p).squaredNorm() >
             phi + 1e-4 * t * r * step) {
        t *= 0.5;
        if (t < 1e-12) {
          s.ua = u;
          return s;
        }
      }
    }
    previous = definite && !capped && t == 1.0 ? std::abs(step) : 0.0;
    u += t * step;
    if (std::abs(u) > limit) {
      s.left = true;
      break;
    }
  }
  s.ua = u;
  return s;
}

/// The degenerate path's fixed coordinate: the midpoint of the overlap of the two segments
/// along A's chord. t_j = ((C_B(end j) - C_A(begin)) . e) / (e . e), e = C_A(end) - C_A(begin),
/// is B's end j measured along A's chord (0 and 1 at A's ends); the overlap is
/// [max(0, min t), min(1, max t)] and u_A its midpoint. Each t_j = alpha / beta with
/// alpha = w_j . e, beta = e . e, w_j = W_j x, e = E x linear in the positions, so its gradient
/// and Hessian are explicit.
struct Overlap {
  double u = 0.0;
  double t[2] = {0.0, 0.0};
  Vec6 omega[2]; // w_j = sum_k omega_jk x_k
  Vector3d w[2];
  Vec6 eta; // e = sum_k eta_k x_k
  Vector3d e;
  double beta = 0.0;
  int lo = -1; // index j of the end setting the overlap's lower bound, -1 if A's begin does
  int hi = -1; // index j of the end setting the upper bound, -1 if A's end does
};

Overlap overlap_midpoint(const Matrix3d& xa, const SegmentBasis& ba, const Matrix3d& xb,
                         const SegmentBasis& bb) {
  Overlap o;
  const Vector3d na0 = ba.values_local(-0.5);
  const Vector3d na1 = ba.values_local(0.5);
  const Vector3d p0 = xa * na0;
  o.e = xa * (na1 - na0);
  o.eta << na1 - na0, Vector3d::Zero();
  o.beta = o.e.squaredNorm();
  for (int j = 0; j < 2; ++j) {
    const Vector3d nb = bb.values_local(j == 0 ? -0.5 : 0.5);
    o.w[j] = xb * nb - p0;
    o.omega[j] << -na0, nb;
    o.t[j] = o.w[j].dot(o.e) / o.beta;
  }
  const int jmin = o.t[0] <= o.t[1] ? 0 : 1;
  const int jmax = 1 - jmin;
  double lower = 0.0;
  double upper = 1.0;
  if (o.t[jmin] > 0.0) {
    lower = o.t[jmin];
    o.lo = jmin;
  }
  if (o.t[jmax] < 1.0) {
    upper = o.t[jmax];
    o.hi = jmax;
  }
  o.u = 0.5 * (lower + upper) - 0.5;
  return o;
}

/// Gradient and Hessian of the overlap midpoint u_A with respect to the 18 positions.
void overlap_derivatives(const Overlap& o, Vec18& grad, Mat18& hess) {
  grad.setZero();
  hess.setZero();
  const Vec18 grad_beta = 2.0 * kron(o.eta, o.e);
  const Matrix3d identity = Matrix3d::Identity();
  for (const int j : {o.lo, o.hi}) {
    if (j < 0) {
      continue;
    }
    const double t = o.t[j];
    const Vec18 grad_t = (kron(o.omega[j], o.e) + kron(o.eta, o.w[j]) - t * grad_beta) / o.beta;
    Mat18 hess_t = -(grad_beta * grad_t.transpose() + grad_t * grad_beta.transpose());
    add_kron(hess_t, o.omega[j], o.eta, identity, 1.0);
    add_kron(hess_t, o.eta, o.omega[j], identity, 1.0);
    add_kron(hess_t, o.eta, o.eta, identity, -2.0 * t);
    grad += 0.5 * grad_t;
    hess += (0.5 / o.beta) * hess_t;
  }
}

/// Which side of an interior knot owns a contact there: the sign of dr/dxi at the knot, from
/// the knot point P (midpoint of the two shared control points x0, x1), the tangent direction
/// x1 - x0 and the projection of P onto the other segment started at its midpoint. The two
/// pairs sharing the knot evaluate it from the same numbers in the same order, so they agree
/// bit for bit. Positive: the minimum lies below the knot.
double knot_side(const Vector3d& x0, const Vector3d& x1, const Matrix3d& other,
                 const SegmentBasis& other_basis, const SplineContactOptions& opt) {
  const Vector3d p = 0.5 * (x0 + x1);
  const Solve s = project_point(p, other, other_basis, 0.0, opt);
  const Vector3d q = other * other_basis.values_local(s.ua);
  return (x1 - x0).dot(p - q);
}

/// Whether segment (x, b) owns local coordinate u of a regular solution; see knot_side.
bool owns_coordinate(const Matrix3d& x, const SegmentBasis& b, double u, const Matrix3d& other,
                     const SegmentBasis& other_basis, const SplineContactOptions& opt) {
  if (b.begin() > 0.0 && std::abs(u + 0.5) < kKnotBand) {
    return !(knot_side(x.col(0), x.col(1), other, other_basis, opt) > 0.0);
  }
  if (!b.closes_end() && std::abs(u - 0.5) < kKnotBand) {
    return knot_side(x.col(1), x.col(2), other, other_basis, opt) > 0.0;
  }
  return b.owns(b.global(u));
}

double clamped_start(const SegmentBasis& b, double xi, bool warm, double limit) {
  const double u = warm ? b.local(xi) : 0.0;
  return std::isfinite(u) ? std::clamp(u, -limit, limit) : 0.0;
}

struct LocalProjection {
  ProjectionResult result;
  double ua = 0.0;
  double ub = 0.0;
  Overlap overlap; // valid on the degenerate path
};

LocalProjection project(const Matrix3d& xa, const SegmentBasis& ba, const Matrix3d& xb,
                        const SegmentBasis& bb, const ProjectionStart& start,
                        const SplineContactOptions& opt);

/// Whether a cold start (from the geometry alone) converges to the point (ua, ub) that a warm
/// start reached after moving more than `jump_fraction`: then the move is the contact point's
/// own, fast but continuous (a crossing at a fabric's edge slides half a segment along the weft
/// in one increment as the weft's overhang straightens), and the point stands; otherwise the
/// warm start has left the contact it followed for another critical point (Jumped).
bool cold_start_agrees(const Matrix3d& xa, const SegmentBasis& ba, const Matrix3d& xb,
                       const SegmentBasis& bb, double ua, double ub,
                       const SplineContactOptions& opt) {
  const LocalProjection cold = project(xa, ba, xb, bb, ProjectionStart{}, opt);
  const double tolerance = 1e-6; // local segment coordinates
  return cold.result.status == ProjectionStatus::Converged && std::abs(cold.ua - ua) < tolerance &&
         std::abs(cold.ub - ub) < tolerance;
}

LocalProjection project(const Matrix3d& xa, const SegmentBasis& ba, const Matrix3d& xb,
                        const SegmentBasis& bb, const ProjectionStart& start,
                        const SplineContactOptions& opt) {
  LocalProjection out;
  ProjectionResult& res = out.result;
  const double limit = 0.5 + opt.max_extension;
  const double ua0 = clamped_start(ba, start.xi_A, start.warm, limit);
  const double ub0 = clamped_start(bb, start.xi_B, start.warm, limit);

  const Vector3d chord_a = xa * (ba.values_local(0.5) - ba.values_local(-0.5));
  const Vector3d chord_b = xb * (bb.values_local(0.5) - bb.values_local(-0.5));
  const double la = chord_a.squaredNorm();
  const double lb = chord_b.squaredNorm();
  if (!(la > 0.0 && lb > 0.0) || !std::isfinite(la) || !std::isfinite(lb)) {
    res.status = ProjectionStatus::NotConverged; // a collapsed segment has no direction
    res.xi_A = ba.global(ua0);
    res.xi_B = bb.global(ub0);
    return out;
  }
  const double sine2 = chord_a.cross(chord_b).squaredNorm() / (la * lb);
  Solve s;
  bool owned = false;
  if (sine2 < opt.parallel_sine * opt.parallel_sine) {
    res.degenerate = true;
    out.overlap = overlap_midpoint(xa, ba, xb, bb);
    s = project_point(xa * ba.values_local(out.overlap.u), xb, bb, ub0, opt);
    s.ub = s.ua;
    s.ua = out.overlap.u;
    owned = s.converged && ba.owns(ba.global(s.ua)) && bb.owns(bb.global(s.ub));
  } else {
    s = newton_pair(xa, ba, xb, bb, ua0, ub0, opt);
    owned = s.converged && owns_coordinate(xa, ba, s.ua, xb, bb, opt) &&
            owns_coordinate(xb, bb, s.ub, xa, ba, opt);
  }
  out.ua = s.ua;
  out.ub = s.ub;
  res.iterations = s.iterations;
  res.xi_A = ba.global(s.ua);
  res.xi_B = bb.global(s.ub);
  if (!s.converged) {
    res.status = s.left ? ProjectionStatus::OutOfRange : ProjectionStatus::NotConverged;
  } else if (!owned) {
    res.status = ProjectionStatus::OutOfRange;
  } else if (start.warm &&
             (std::abs(s.ua - ua0) > opt.jump_fraction ||
              std::abs(s.ub - ub0) > opt.jump_fraction) &&
             !cold_start_agrees(xa, ba, xb, bb, s.ua, s.ub, opt)) {
    res.status = ProjectionStatus::Jumped;
  } else {
    res.status = ProjectionStatus::Converged;
  }
  return out;
}

} // namespace

ProjectionResult closest_point_projection(const Matrix3d& control_A, const SegmentBasis& basis_A,
                                          const Matrix3d& control_B, const SegmentBasis& basis_B,
                                          const ProjectionStart& start,
                                          const SplineContactOptions& options) {
  return project(control_A, basis_A, control_B, basis_B, start, options).result;
}

namespace {

/// (hess psi) v for the damping's d(dp/dt)/dx, hess psi = (kron(w w^T, I) - D^T H^-1 D - grad psi
/// grad psi^T) / |g| (the file's header): ha, hb are the rows of H^-1 D, da, db those of D.
Vec18 hessian_psi_times(const Vec6& w, const Vec18& velocity, const Vec18& ha, const Vec18& hb,
                        const Vec18& da, const Vec18& db, const Vec18& grad_psi, double dist) {
  Vector3d wv = Vector3d::Zero();
  for (int k = 0; k < 6; ++k) {
    wv += w(k) * velocity.segment<3>(3 * k);
  }
  return (kron(w, wv) - ha * da.dot(velocity) - hb * db.dot(velocity) -
          grad_psi * grad_psi.dot(velocity)) /
         dist;
}

/// dxi/dx = -H^-1 D and df/dx of a regular point contact (SplineContactSensitivity), from the
/// quantities of fill_contact: the positions' weights w, grad psi = d|g|/dx, the 18 velocities,
/// |g|, the law's f_p and f_pdot and dv/dx (`vpd`). Computes H^-1 D apart from the tangent, so
/// that the contact's own results are computed exactly as without it.
void write_sensitivity(const Local& e, const SegmentBasis& basis_A, const SegmentBasis& basis_B,
                       const Vec6& w, const Vec18& grad_psi, const Vec18& velocity, double dist,
                       double fp, double fv, double vpd, SplineContactSensitivity& out) {
  Vec6 wa;
  wa << e.dna, Vector3d::Zero();
  Vec6 wb;
  wb << Vector3d::Zero(), -e.dnb;
  const Vec18 da = kron(wa, e.g) + kron(w, e.ga);
  const Vec18 db = kron(wb, e.g) + kron(w, e.gb);
  const double det = e.h(0, 0) * e.h(1, 1) - e.h(0, 1) * e.h(0, 1);
  const Vec18 ha = (e.h(1, 1) * da - e.h(0, 1) * db) / det; // H^-1 D, row by row (local u)
  const Vec18 hb = (e.h(0, 0) * db - e.h(0, 1) * da) / det;
  out.parameters.row(0) = -basis_A.length() * ha.transpose(); // dxi = h du
  out.parameters.row(1) = -basis_B.length() * hb.transpose();
  out.force = -fp * grad_psi;
  if (fv != 0.0) {
    // d(dp/dt)/dx = -(hess psi v + dv/dx grad psi).
    const Vec18 hess_psi_v = hessian_psi_times(w, velocity, ha, hb, da, db, grad_psi, dist);
    out.force -= fv * (hess_psi_v + vpd * grad_psi);
  }
  out.share.setZero();
  out.valid = true;
}

/// The body of spline_contact; returns whether it wrote the tangent.
bool fill_contact(const Matrix3d& control_A, const SegmentBasis& basis_A, double radius_A,
                  const Matrix3d& control_B, const SegmentBasis& basis_B, double radius_B,
                  const ProjectionStart& start, const InterfaceLaw& law, SplineContactResult& out,
                  const SplineContactOptions& options, const PairRates* rates,
                  SplineContactSensitivity* sensitivity) {
  if (sensitivity != nullptr) {
    sensitivity->valid = false;
  }
  const LocalProjection lp = project(control_A, basis_A, control_B, basis_B, start, options);
  out.status = lp.result.status;
  out.degenerate = lp.result.degenerate;
  out.iterations = lp.result.iterations;
  out.xi_A = lp.result.xi_A;
  out.xi_B = lp.result.xi_B;
  out.active = false;
  out.point_active = false;
  out.penetration_rate = 0.0;
  out.force = 0.0;
  out.point_force = 0.0;
  out.potential = 0.0;
  out.residual.setZero();

  const Local e = evaluate(control_A, basis_A, control_B, basis_B, lp.ua, lp.ub);
  out.point_A = control_A * e.na;
  out.point_B = control_B * e.nb;
  out.distance = e.g.norm();
  out.gap = out.distance - (radius_A + radius_B);
  out.penetration = -out.gap;
  out.normal.setZero();

  const bool owned =
      out.status == ProjectionStatus::Converged || out.status == ProjectionStatus::Jumped;
  if (!owned) {
    return false;
  }
  if (!(out.distance > 1e-14 * (e.ga.norm() + e.gb.norm()))) {
    out.status = ProjectionStatus::NotConverged; // centre lines intersect: no normal
    return false;
  }
  const double dist = out.distance;
  out.normal = e.g / dist;
  const double p = out.penetration;
  if (!(p > -law.onset())) { // apart (the law acts from a gap of onset() on)
    return false;
  }

  // grad psi = grad Phi* / |g|; on the degenerate path Phi* also changes through u_A(x).
  Vec6 w;
  w << e.na, -e.nb;
  Vec18 grad_psi = kron(w, out.normal);
  Vec18 grad_xi;
  Mat18 hess_xi;
  if (out.degenerate) {
    overlap_derivatives(lp.overlap, grad_xi, hess_xi);
    grad_psi += (e.r(0) / dist) * grad_xi;
  }

  Vec18 velocity = Vec18::Zero();
  if (rates != nullptr) {
    for (int k = 0; k < 3; ++k) {
      velocity.segment<3>(3 * k) = rates->velocity_A.col(k);
      velocity.segment<3>(9 + 3 * k) = rates->velocity_B.col(k);
    }
    out.penetration_rate = -grad_psi.dot(velocity);
  }
  const double pdot = out.penetration_rate;
  out.force = law.force(p, pdot);
  out.point_force = out.force;
  out.potential = law.potential(p);
  out.active = true;
  out.point_active = true;
  out.residual = -out.force * grad_psi;
  if (sensitivity != nullptr && !out.degenerate) {
    write_sensitivity(e, basis_A, basis_B, w, grad_psi, velocity, dist, law.stiffness(p, pdot),
                      rates != nullptr ? law.damping(p, pdot) : 0.0,
                      rates != nullptr ? rates->velocity_per_displacement : 0.0, *sensitivity);
  }
  if (!options.compute_tangent) {
    return false;
  }

  // Hessian of Phi*(x), then of psi; residual = -f grad psi with f = f(p, pdot), p = R - psi,
  // pdot = -grad psi . v, v = v(x), so
  // tangent = f_p grad psi grad psi^T - f hess psi - f_pdot grad psi grad pdot^T.
  Vec6 wa;
  wa << e.dna, Vector3d::Zero();
  Vec6 wb;
  wb << Vector3d::Zero(), -e.dnb;
  const Vec18 da = kron(wa, e.g) + kron(w, e.ga);
  const Vec18 db = kron(wb, e.g) + kron(w, e.gb);
  const double f = out.force;
  const double fp = law.stiffness(p, pdot);
  const double fv = rates != nullptr ? law.damping(p, pdot) : 0.0;
  if (!out.degenerate) {
    // hess psi = (kron(w w^T, I) - D^T H^-1 D - grad psi grad psi^T) / |g|, assembled straight
    // into the tangent: a rank-1 term, a rank-2 term and the 108 non-zeros of the Kronecker
    // product.
    const double det = e.h(0, 0) * e.h(1, 1) - e.h(0, 1) * e.h(0, 1);
    const double i00 = e.h(1, 1) / det;
    const double i01 = -e.h(0, 1) / det;
    const double i11 = e.h(0, 0) / det;
    const double c = f / dist;
    const Vec18 ha = i00 * da + i01 * db; // H^-1 D, row by row
    const Vec18 hb = i01 * da + i11 * db;
    out.tangent.noalias() = (fp + c) * grad_psi * grad_psi.transpose();
    out.tangent.noalias() += (c * ha) * da.transpose();
    out.tangent.noalias() += (c * hb) * db.transpose();
    for (int j = 0; j < 6; ++j) {
      for (int i = 0; i < 6; ++i) {
        const double v = c * w(i) * w(j);
        for (int d = 0; d < 3; ++d) {
          out.tangent(3 * i + d, 3 * j + d) -= v;
        }
      }
    }
    if (fv != 0.0) {
      const Vec18 hess_psi_v = hessian_psi_times(w, velocity, ha, hb, da, db, grad_psi, dist);
      const Vec18 grad_pdot = -(hess_psi_v + rates->velocity_per_displacement * grad_psi);
      out.tangent.noalias() -= (fv * grad_psi) * grad_pdot.transpose();
    }
    return true;
  }

  // Degenerate path: u_B minimises Phi at fixed u_A(x). The reduced function Phi~(u_A, x) has
  // Phi~_xx = G^T G - D_B D_B^T / H_BB, Phi~_xu = D_A - D_B H_AB / H_BB,
  // Phi~_uu = H_AA - H_AB^2 / H_BB, Phi~_u = r_A, and Phi*(x) = Phi~(u_A(x), x).
  Mat18 hess_psi = Mat18::Zero();
  add_kron(hess_psi, w, w, Matrix3d::Identity(), 1.0);
  const double hbb = e.h(1, 1);
  const Vec18 phi_xu = da - (e.h(0, 1) / hbb) * db;
  const double phi_uu = e.h(0, 0) - e.h(0, 1) * e.h(0, 1) / hbb;
  hess_psi.noalias() -= (1.0 / hbb) * db * db.transpose();
  hess_psi.noalias() += phi_xu * grad_xi.transpose();
  hess_psi.noalias() += grad_xi * phi_xu.transpose();
  hess_psi.noalias() += phi_uu * grad_xi * grad_xi.transpose();
  hess_psi += e.r(0) * hess_xi;
  hess_psi.noalias() -= grad_psi * grad_psi.transpose();
  hess_psi /= dist;
  out.tangent.noalias() = fp * grad_psi * grad_psi.transpose();
  out.tangent.noalias() -= f * hess_psi;
  if (fv != 0.0) {
    const Vec18 grad_pdot = -(hess_psi * velocity + rates->velocity_per_displacement * grad_psi);
    out.tangent.noalias() -= (fv * grad_psi) * grad_pdot.transpose();
  }
  return true;
}

} // namespace

void spline_contact(const Matrix3d& control_A, const SegmentBasis& basis_A, double radius_A,
                    const Matrix3d& control_B, const SegmentBasis& basis_B, double radius_B,
                    const ProjectionStart& start, const InterfaceLaw& law, SplineContactResult& out,
                    const SplineContactOptions& options, const PairRates* rates,
                    SplineContactSensitivity* sensitivity) {
  if (!fill_contact(control_A, basis_A, radius_A, control_B, basis_B, radius_B, start, law, out,
                    options, rates, sensitivity) &&
      options.zero_unused_tangent)
    out.tangent.setZero();
}

SplineContactResult spline_contact(const Matrix3d& control_A, const SegmentBasis& basis_A,
                                   double radius_A, const Matrix3d& control_B,
                                   const SegmentBasis& basis_B, double radius_B,
                                   const ProjectionStart& start, const InterfaceLaw& law,
                                   const SplineContactOptions& options, const PairRates* rates,
                                   SplineContactSensitivity* sensitivity) {
  SplineContactResult out;
  spline_contact(control_A, basis_A, radius_A, control_B, basis_B, radius_B, start, law, out,
                 options, rates, sensitivity);
  return out;
}

const char* to_string(ProjectionStatus status) {
  switch (status) {
  case ProjectionStatus::Converged:
    return "converged";
  case ProjectionStatus::OutOfRange:
    return "out of range";
  case ProjectionStatus::NotConverged:
    return "not converged";
  case ProjectionStatus::Jumped:
    return "jumped";
  }
  return "unknown";
}

} // namespace yarnsim::contact
