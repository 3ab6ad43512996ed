#include "engine/model/model.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace yarnsim {

double TimeTable::at(double t) const {
  if (time.empty())
    return 0.0;
  if (t <= time.front())
    return value.front();
  if (t >= time.back())
    return value.back();
  const auto hi = std::upper_bound(time.begin(), time.end(), t);
  const auto i = static_cast<std::size_t>(hi - time.begin());
  const double w = (t - time[i - 1]) / (time[i] - time[i - 1]);
  return (1.0 - w) * value[i - 1] + w * value[i];
}

TimeTable TimeTable::ramp(double t_end) {
  return TimeTable{{0.0, t_end}, {0.0, 1.0}};
}

TimeTable TimeTable::constant(double v) {
  return TimeTable{{0.0}, {v}};
}

int Model::find_node_set(const std::string& name) const {
  for (std::size_t i = 0; i < node_sets.size(); ++i)
    if (node_sets[i].name == name)
      return static_cast<int>(i);
  return -1;
}

Section section_from_shape(std::string name, SectionShape shape, double a, double b,
                           double exponent, const Material& material, double reduce_I1,
                           double reduce_I2, double shear_factor) {
  if (shape == SectionShape::Circle) {
    b = a;
    exponent = 2;
  } else if (shape == SectionShape::Ellipse) {
    exponent = 2;
  }
  const double m = exponent;
  // Super-ellipse |x/a|^m + |y/b|^m <= 1 (x along axis 1, y along axis 2):
  // A = 4ab G(1+1/m)^2 / G(1+2/m); I1 = int y^2 dA = 4/3 a b^3 G(1+1/m) G(1+3/m) / G(1+4/m).
  const double g1 = std::tgamma(1 + 1 / m);
  const double area = 4 * a * b * g1 * g1 / std::tgamma(1 + 2 / m);
  const double c3 = 4.0 / 3.0 * g1 * std::tgamma(1 + 3 / m) / std::tgamma(1 + 4 / m);
  const double I1 = c3 * a * b * b * b; // about axis 1
  const double I2 = c3 * b * a * a * a; // about axis 2
  // Saint-Venant's approximation J = A^4 / (4 pi^2 Ip), exact for the ellipse.
  const double J = std::pow(area, 4) / (4 * std::numbers::pi * std::numbers::pi * (I1 + I2));

  Section s;
  s.name = std::move(name);
  s.shape = shape;
  s.a = a;
  s.b = b;
  s.exponent = exponent;
  s.EA = material.young * area;
  s.GA1 = s.GA2 = shear_factor * material.shear * area;
  s.EI1 = material.young * I1 * reduce_I1;
  s.EI2 = material.young * I2 * reduce_I2;
  s.EI12 = 0;
  s.GJ = material.shear * J;
  s.rhoA = material.density * area;
  s.rhoJ = material.density * Eigen::Vector3d(I1, I2, I1 + I2);
  return s;
}

Eigen::Matrix2d PictureFrameTest::linear_map(double t) const {
  const double gamma = angle.at(t);
  const double c = std::cos(gamma / 2), s = std::sin(gamma / 2);
  Eigen::Matrix2d F;
  F << c, s, s, c;
  return stretch.at(t) * F;
}

Eigen::Vector2d PictureFrameTest::carried(double t, const Eigen::Vector2d& X) const {
  const Eigen::Vector2d centre = corner + Eigen::Vector2d(side / 2, side / 2);
  return centre + stretch.at(t) * (corner - centre) + linear_map(t) * (X - corner);
}

} // namespace yarnsim
