#include "contact/spline_curve.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace yarnsim::contact {

namespace {

/// The three non-zero quadratic basis functions on knot span [t_j, t_j+1) at xi, by the
/// Cox-de Boor recursion (Piegl and Tiller, The NURBS Book, algorithm A2.2). They belong to
/// control points j-2, j-1, j. The recursion is a polynomial on the span, so it also serves
/// at the span's end and slightly beyond.
Eigen::Vector3d cox_de_boor(const std::vector<double>& t, int j, double xi) {
  double n[3] = {1.0, 0.0, 0.0};
  double left[3] = {0.0, 0.0, 0.0};
  double right[3] = {0.0, 0.0, 0.0};
  for (int degree = 1; degree <= 2; ++degree) {
    left[degree] = xi - t[j + 1 - degree];
    right[degree] = t[j + degree] - xi;
    double saved = 0.0;
    for (int r = 0; r < degree; ++r) {
      const double temp = n[r] / (right[r + 1] + left[degree - r]);
      n[r] = saved + right[r + 1] * temp;
      saved = left[degree - r] * temp;
    }
    n[degree] = saved;
  }
  return {n[0], n[1], n[2]};
}

} // namespace

SegmentBasis::SegmentBasis(double begin, double end, bool closes_end,
                           const Eigen::Matrix3d& coefficients)
    : begin_(begin), end_(end), closes_end_(closes_end), c_(coefficients) {
  if (!(end > begin)) {
    std::ostringstream message;
    message << "SegmentBasis: expected begin < end, found [" << begin << ", " << end << "]";
    throw std::invalid_argument(message.str());
  }
}

Aabb segment_box(const Eigen::Matrix3d& control_points, double margin) {
  const Eigen::Vector3d grow = Eigen::Vector3d::Constant(margin);
  return {control_points.rowwise().minCoeff() - grow, control_points.rowwise().maxCoeff() + grow};
}

SplineCurve::SplineCurve(int num_control_points) : n_(num_control_points) {
  if (n_ < 3) {
    std::ostringstream message;
    message << "SplineCurve: a quadratic B-spline needs at least 3 control points, found " << n_;
    throw std::invalid_argument(message.str());
  }
  const int m = n_ - 2; // segments
  knots_.resize(static_cast<std::size_t>(n_ + 3));
  for (int k = 0; k < n_ + 3; ++k) {
    const int step = std::min(std::max(k - 2, 0), m);
    knots_[static_cast<std::size_t>(k)] = step == m ? 1.0 : static_cast<double>(step) / m;
  }
  segments_.reserve(static_cast<std::size_t>(m));
  for (int i = 0; i < m; ++i) {
    const int j = i + 2; // knot span [t_j, t_j+1)
    const double begin = knots_[static_cast<std::size_t>(j)];
    const double end = knots_[static_cast<std::size_t>(j + 1)];
    const double mid = 0.5 * (begin + end);
    const double h = end - begin;
    // Sample the exact quadratic at u = -1/2, 0, 1/2 and read off its coefficients in u.
    const Eigen::Vector3d lo = cox_de_boor(knots_, j, begin);
    const Eigen::Vector3d ce = cox_de_boor(knots_, j, mid);
    const Eigen::Vector3d hi = cox_de_boor(knots_, j, mid + 0.5 * h);
    Eigen::Matrix3d c;
    c.col(0) = ce;
    c.col(1) = hi - lo;
    c.col(2) = 2.0 * (hi - 2.0 * ce + lo);
    segments_.emplace_back(begin, end, i == m - 1, c);
  }
}

const SegmentBasis& SplineCurve::segment(int i) const {
  assert(i >= 0 && i < num_segments());
  return segments_[static_cast<std::size_t>(i)];
}

int SplineCurve::segment_of(double xi) const {
  if (!(xi >= 0.0 && xi <= 1.0)) {
    return -1;
  }
  const int m = num_segments();
  int i = std::min(static_cast<int>(xi * m), m - 1);
  // The guess can be off by one where xi * m rounds across an integer: settle it on the stored
  // ranges so that segment_of agrees bit for bit with SegmentBasis::owns.
  while (i > 0 && xi < segments_[static_cast<std::size_t>(i)].begin()) {
    --i;
  }
  while (i < m - 1 && !segments_[static_cast<std::size_t>(i)].owns(xi)) {
    ++i;
  }
  assert(segments_[static_cast<std::size_t>(i)].owns(xi));
  return i;
}

Eigen::Matrix3d SplineCurve::control_points(const Eigen::Ref<const Eigen::Matrix3Xd>& positions,
                                            int i) const {
  assert(i >= 0 && i < num_segments());
  assert(positions.cols() == n_);
  return positions.middleCols<3>(i);
}

int SplineCurve::checked_segment(const Eigen::Ref<const Eigen::Matrix3Xd>& positions,
                                 double xi) const {
  if (positions.cols() != n_) {
    std::ostringstream message;
    message << "SplineCurve: expected positions with " << n_ << " columns, found "
            << positions.cols();
    throw std::invalid_argument(message.str());
  }
  const int i = segment_of(xi);
  if (i < 0) {
    std::ostringstream message;
    message << "SplineCurve: expected a parameter xi in [0, 1], found " << xi;
    throw std::invalid_argument(message.str());
  }
  return i;
}

Eigen::Vector3d SplineCurve::point(const Eigen::Ref<const Eigen::Matrix3Xd>& positions,
                                   double xi) const {
  const int i = checked_segment(positions, xi);
  return segment(i).point(positions.middleCols<3>(i), xi);
}

Eigen::Vector3d SplineCurve::first_derivative(const Eigen::Ref<const Eigen::Matrix3Xd>& positions,
                                              double xi) const {
  const int i = checked_segment(positions, xi);
  return segment(i).first_derivative(positions.middleCols<3>(i), xi);
}

Eigen::Vector3d SplineCurve::second_derivative(const Eigen::Ref<const Eigen::Matrix3Xd>& positions,
                                               double xi) const {
  const int i = checked_segment(positions, xi);
  return segment(i).second_derivative(positions.middleCols<3>(i), xi);
}

Aabb SplineCurve::box(const Eigen::Ref<const Eigen::Matrix3Xd>& positions, int i,
                      double margin) const {
  return segment_box(control_points(positions, i), margin);
}

} // namespace yarnsim::contact
