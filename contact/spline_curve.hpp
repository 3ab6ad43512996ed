#pragma once

#include <Eigen/Core>

#include <vector>

namespace yarnsim::contact {

/// The three quadratic B-spline basis functions that are non-zero on one segment, stored as
/// polynomials of the global parameter xi so that values and derivatives cost a few flops and
/// stay valid (as the polynomial's extension) outside the segment's range.
///
/// For conditioning they are kept in the local variable u = (xi - mid) / h, mid and h the
/// segment's centre and length in xi: N_k(xi) = c(k,0) + c(k,1) u + c(k,2) u^2. Every function
/// taking `xi` returns derivatives with respect to the global xi; the `_local` functions work in u
/// (the segment's range is u in [-1/2, 1/2]).
class SegmentBasis {
public:
  /// `coefficients` row k = [c0, c1, c2] of basis k in u; `closes_end` is true for the last
  /// segment of a curve, whose range includes its end (xi = 1).
  SegmentBasis(double begin, double end, bool closes_end, const Eigen::Matrix3d& coefficients);

  /// Parameter range [begin, end) (closed at end for the last segment).
  double begin() const { return begin_; }
  double end() const { return end_; }
  double length() const { return end_ - begin_; }
  double mid() const { return 0.5 * (begin_ + end_); }
  bool closes_end() const { return closes_end_; }
  const Eigen::Matrix3d& coefficients() const { return c_; }

  /// Local variable u = (xi - mid) / h and its inverse.
  double local(double xi) const { return (xi - mid()) / length(); }
  double global(double u) const { return mid() + length() * u; }

  /// Whether this segment owns parameter xi: begin <= xi < end, or <= end for the last segment.
  /// Every xi in [0, 1] is owned by exactly one segment of a curve.
  bool owns(double xi) const { return xi >= begin_ && (xi < end_ || (closes_end_ && xi == end_)); }

  /// Basis values, first and second derivatives with respect to u.
  Eigen::Vector3d values_local(double u) const {
    return c_.col(0) + u * (c_.col(1) + u * c_.col(2));
  }
  Eigen::Vector3d first_local(double u) const { return c_.col(1) + 2.0 * u * c_.col(2); }
  Eigen::Vector3d second_local() const { return 2.0 * c_.col(2); }

  /// Basis values, first and second derivatives with respect to xi.
  Eigen::Vector3d values(double xi) const { return values_local(local(xi)); }
  Eigen::Vector3d first(double xi) const { return first_local(local(xi)) / length(); }
  Eigen::Vector3d second(double /*xi*/) const { return second_local() / (length() * length()); }

  /// Curve point, tangent dC/dxi and dC^2/dxi^2 from the segment's control points
  /// (`control_points` columns, metres).
  Eigen::Vector3d point(const Eigen::Matrix3d& control_points, double xi) const {
    return control_points * values(xi);
  }
  Eigen::Vector3d first_derivative(const Eigen::Matrix3d& control_points, double xi) const {
    return control_points * first(xi);
  }
  Eigen::Vector3d second_derivative(const Eigen::Matrix3d& control_points, double xi) const {
    return control_points * second(xi);
  }

private:
  double begin_;
  double end_;
  bool closes_end_;
  Eigen::Matrix3d c_;
};

/// Axis-aligned box, metres.
struct Aabb {
  Eigen::Vector3d min;
  Eigen::Vector3d max;
};

/// Box of a segment's three control points (`control_points` columns, metres), grown by `margin`
/// on every side. A B-spline segment lies in the convex hull of its control points, so the box
/// holds the whole segment; Giraffe inflates it by 4 r for the broad phase (formulation.md §5).
Aabb segment_box(const Eigen::Matrix3d& control_points, double margin = 0.0);

/// A quadratic B-spline on n >= 3 control points (the structural nodes of one yarn, mid nodes
/// included) with the open uniform knot vector [0,0,0, 1/(n-2), ..., (n-3)/(n-2), 1,1,1]
/// (formulation.md §5). It has n-2 segments; segment i uses control points i, i+1, i+2 over
/// [knot(i+2), knot(i+3)]. The curve is C1, interpolates only its first and last control point,
/// and holds topology only: positions are passed in, so one object serves every configuration.
class SplineCurve {
public:
  /// Throws std::invalid_argument for n < 3.
  explicit SplineCurve(int num_control_points);

  int num_control_points() const { return n_; }
  int num_segments() const { return n_ - 2; }

  /// The n + 3 knots.
  const std::vector<double>& knots() const { return knots_; }

  /// Segment i's basis and range; i in [0, num_segments()), checked by assert.
  const SegmentBasis& segment(int i) const;

  /// The segment owning xi (half-open ranges, the last one closed at 1), or -1 for xi outside
  /// [0, 1] or NaN.
  int segment_of(double xi) const;

  /// Columns i, i+1, i+2 of `positions` (3 x n, metres): segment i's control points.
  Eigen::Matrix3d control_points(const Eigen::Ref<const Eigen::Matrix3Xd>& positions, int i) const;

  /// Curve point and derivatives with respect to xi at xi in [0, 1] (`positions` 3 x n, metres).
  /// Throws std::invalid_argument for xi outside [0, 1] or a positions matrix of the wrong size.
  Eigen::Vector3d point(const Eigen::Ref<const Eigen::Matrix3Xd>& positions, double xi) const;
  Eigen::Vector3d first_derivative(const Eigen::Ref<const Eigen::Matrix3Xd>& positions,
                                   double xi) const;
  Eigen::Vector3d second_derivative(const Eigen::Ref<const Eigen::Matrix3Xd>& positions,
                                    double xi) const;

  /// segment_box of segment i.
  Aabb box(const Eigen::Ref<const Eigen::Matrix3Xd>& positions, int i, double margin = 0.0) const;

private:
  int checked_segment(const Eigen::Ref<const Eigen::Matrix3Xd>& positions, double xi) const;

  int n_;
  std::vector<double> knots_;
  std::vector<SegmentBasis> segments_;
};

} // namespace yarnsim::contact
