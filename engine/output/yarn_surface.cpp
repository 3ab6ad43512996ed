#include "engine/output/yarn_surface.hpp"

#include "contact/spline_curve.hpp"
#include "engine/math/rotation.hpp"

#include <Eigen/Geometry>

#include <array>
#include <cmath>
#include <limits>
#include <numbers>

namespace yarnsim::output {
namespace {

/// (cos, sin) of the ring's angles: the super-ellipse |y1|^m + |y2|^m = 1 of unit semi-axes at
/// theta_k = 2 pi k / K, y = (sgn(cos) |cos|^(2/m), sgn(sin) |sin|^(2/m)) (m = 2: the circle).
Eigen::Vector2d unit_section_point(int k, double exponent) {
  const double theta = 2.0 * std::numbers::pi * k / kRingPoints;
  const double c = std::cos(theta), s = std::sin(theta);
  const double p = 2.0 / exponent;
  return {std::copysign(std::pow(std::abs(c), p), c), std::copysign(std::pow(std::abs(s), p), s)};
}

/// The ring's unit section points for one exponent, made again only where the exponent changes
/// (a fabric's yarns share a few): the pow and sincos per point and output step were 3 % of the
/// paper's k = 1 run's samples (docs/performance.md).
class UnitRing {
public:
  const std::array<Eigen::Vector2d, kRingPoints>& of(double exponent) {
    if (exponent != exponent_) {
      for (int k = 0; k < kRingPoints; ++k)
        ring_[static_cast<std::size_t>(k)] = unit_section_point(k, exponent);
      exponent_ = exponent;
    }
    return ring_;
  }

private:
  double exponent_ = std::numeric_limits<double>::quiet_NaN(); // none yet: NaN equals nothing
  std::array<Eigen::Vector2d, kRingPoints> ring_{};
};

void append_point(std::vector<float>& out, const Eigen::Vector3d& x) {
  out.push_back(static_cast<float>(x.x()));
  out.push_back(static_cast<float>(x.y()));
  out.push_back(static_cast<float>(x.z()));
}

/// Quads joining ring `first` to ring `second` (each `points` points, starting at point indices
/// first * points and second * points).
void append_ring_quads(std::vector<std::array<int, 4>>& quads, int first, int second, int points) {
  for (int k = 0; k < points; ++k) {
    const int next = (k + 1) % points;
    quads.push_back(
        {first * points + k, first * points + next, second * points + next, second * points + k});
  }
}

int tube_circles(const ContactTube& tube) {
  return (static_cast<int>(tube.nodes.size()) - 2) * kTubeSamplesPerSegment + 1;
}

} // namespace

std::vector<std::array<int, 4>> surface_quads(const std::vector<std::array<int, 3>>& elements) {
  std::vector<std::array<int, 4>> quads;
  quads.reserve(2 * kRingPoints * elements.size());
  for (const auto& [first, middle, last] : elements) {
    append_ring_quads(quads, first, middle, kRingPoints);
    append_ring_quads(quads, middle, last, kRingPoints);
  }
  return quads;
}

std::vector<float> surface_points(const Eigen::Matrix3Xd& positions,
                                  const Eigen::Matrix3Xd& rotations,
                                  const std::vector<Eigen::Matrix3d>& reference_triads,
                                  const std::vector<NodeSection>& sections) {
  std::vector<float> out;
  out.reserve(3 * kRingPoints * static_cast<std::size_t>(positions.cols()));
  UnitRing unit;
  for (Eigen::Index i = 0; i < positions.cols(); ++i) {
    const Eigen::Matrix3d Q = rotation_matrix(rotations.col(i)) * reference_triads[i];
    const NodeSection& s = sections[i];
    const std::array<Eigen::Vector2d, kRingPoints>& ring = unit.of(s.exponent);
    for (const Eigen::Vector2d& y : ring)
      append_point(out, positions.col(i) + s.a * y.x() * Q.col(0) + s.b * y.y() * Q.col(1));
  }
  return out;
}

int tube_point_count(const ContactTube& tube) {
  return tube_circles(tube) * kTubePoints;
}

std::vector<std::array<int, 4>> tube_quads(const std::vector<ContactTube>& tubes) {
  std::vector<std::array<int, 4>> quads;
  int circle = 0;
  for (const ContactTube& tube : tubes) {
    const int circles = tube_circles(tube);
    for (int j = 0; j + 1 < circles; ++j)
      append_ring_quads(quads, circle + j, circle + j + 1, kTubePoints);
    circle += circles;
  }
  return quads;
}

std::vector<float> tube_points(const Eigen::Matrix3Xd& positions,
                               const std::vector<ContactTube>& tubes) {
  std::vector<float> out;
  // (cos, sin) of the circles' angles, once.
  std::array<Eigen::Vector2d, kTubePoints> circle;
  for (int k = 0; k < kTubePoints; ++k) {
    const double theta = 2.0 * std::numbers::pi * k / kTubePoints;
    circle[static_cast<std::size_t>(k)] = {std::cos(theta), std::sin(theta)};
  }
  for (const ContactTube& tube : tubes) {
    const int n = static_cast<int>(tube.nodes.size());
    Eigen::Matrix3Xd control(3, n);
    for (int k = 0; k < n; ++k)
      control.col(k) = positions.col(tube.nodes[k]);
    const contact::SplineCurve curve(n);
    const int circles = tube_circles(tube);
    // A frame carried along the curve by projection onto each new normal plane (a discrete
    // parallel transport, so the tube does not twist where the curve does not): d1 starts normal
    // to the first tangent, away from its largest component.
    Eigen::Vector3d d1 = Eigen::Vector3d::Zero();
    for (int j = 0; j < circles; ++j) {
      const double xi = static_cast<double>(j) / (circles - 1);
      const Eigen::Vector3d centre = curve.point(control, xi);
      const Eigen::Vector3d t = curve.first_derivative(control, xi).normalized();
      if (j == 0) {
        Eigen::Index largest = 0;
        t.cwiseAbs().maxCoeff(&largest);
        d1 = Eigen::Vector3d::Unit((largest + 1) % 3);
      }
      d1 = (d1 - d1.dot(t) * t).normalized();
      const Eigen::Vector3d d2 = t.cross(d1);
      for (const Eigen::Vector2d& cs : circle)
        append_point(out, centre + tube.radius * (cs.x() * d1 + cs.y() * d2));
    }
  }
  return out;
}

} // namespace yarnsim::output
