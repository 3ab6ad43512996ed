#include "engine/textile/fabric.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <numbers>
#include <stdexcept>

namespace yarnsim::textile {

Material YarnMaterial::resolve(double area, std::string name) const {
  if ((young > 0) == (EA > 0))
    throw std::invalid_argument(fmt::format(
        "yarn material: expected exactly one of E > 0 and EA > 0, found E = {}, EA = {}", young,
        EA));
  if (!(density > 0))
    throw std::invalid_argument(
        fmt::format("yarn material: expected a density > 0, found {}", density));
  if (!(area > 0))
    throw std::invalid_argument(fmt::format("yarn material: expected an area > 0, found {}", area));
  Material m;
  m.name = std::move(name);
  m.young = young > 0 ? young : EA / area;
  if (shear > 0) {
    m.shear = shear;
  } else {
    if (!(poisson > -1 && poisson <= 0.5))
      throw std::invalid_argument(
          fmt::format("yarn material: expected a Poisson ratio in (-1, 0.5], found {}", poisson));
    m.shear = m.young / (2 * (1 + poisson));
  }
  m.density = density;
  return m;
}

namespace {

void check_inertia_factors(double lower, double upper) {
  if (!(lower > 0 && upper > 0))
    throw std::invalid_argument(fmt::format(
        "yarn section: expected reduction factors > 0, found {} (lower inertia) and {} (upper)",
        lower, upper));
}

} // namespace

Section ellipse_yarn_section(std::string name, double a, double b, const YarnMaterial& material,
                             double reduce_lower_inertia, double shear_factor,
                             double reduce_upper_inertia) {
  if (!(a > 0 && b > 0))
    throw std::invalid_argument(
        fmt::format("yarn section: expected semi-axes > 0, found a = {}, b = {}", a, b));
  check_inertia_factors(reduce_lower_inertia, reduce_upper_inertia);
  const Material m = material.resolve(std::numbers::pi * a * b, name);
  // I1 = pi a b^3 / 4 about axis 1 is the lower one when b <= a.
  const double r1 = b <= a ? reduce_lower_inertia : reduce_upper_inertia;
  const double r2 = b <= a ? reduce_upper_inertia : reduce_lower_inertia;
  return section_from_shape(std::move(name), SectionShape::Ellipse, a, b, 2, m, r1, r2,
                            shear_factor);
}

Section outline_yarn_section(std::string name, const SectionOutline& outline,
                             const YarnMaterial& material, double reduce_lower_inertia,
                             double shear_factor, double reduce_upper_inertia) {
  const auto& p = outline.points;
  if (p.size() < 3)
    throw std::invalid_argument(
        fmt::format("yarn section: expected an outline of >= 3 points, found {}", p.size()));
  // Green's theorem over the polygon (p_i, p_i+1): area, first and second moments about the
  // origin, then shifted to the centroid.
  double A = 0, Sx = 0, Sy = 0, Ixx = 0, Iyy = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Eigen::Vector2d& u = p[i];
    const Eigen::Vector2d& v = p[(i + 1) % p.size()];
    const double c = u.x() * v.y() - v.x() * u.y();
    A += c / 2;
    Sx += (u.x() + v.x()) * c / 6;
    Sy += (u.y() + v.y()) * c / 6;
    Ixx += (u.y() * u.y() + u.y() * v.y() + v.y() * v.y()) * c / 12; // int y^2 dA
    Iyy += (u.x() * u.x() + u.x() * v.x() + v.x() * v.x()) * c / 12; // int x^2 dA
  }
  if (!(A > 0))
    throw std::invalid_argument(fmt::format(
        "yarn section: expected a counter-clockwise outline of area > 0, found area {}", A));
  const double cx = Sx / A;
  const double cy = Sy / A;
  const double I1 = Ixx - A * cy * cy; // about axis 1 (the width direction)
  const double I2 = Iyy - A * cx * cx;
  double xmin = p[0].x(), xmax = p[0].x(), ymin = p[0].y(), ymax = p[0].y();
  for (const auto& q : p) {
    xmin = std::min(xmin, q.x());
    xmax = std::max(xmax, q.x());
    ymin = std::min(ymin, q.y());
    ymax = std::max(ymax, q.y());
  }
  const Material m = material.resolve(A, name);
  check_inertia_factors(reduce_lower_inertia, reduce_upper_inertia);
  const double r1 = I1 <= I2 ? reduce_lower_inertia : reduce_upper_inertia;
  const double r2 = I1 <= I2 ? reduce_upper_inertia : reduce_lower_inertia;
  const double J = std::pow(A, 4) / (4 * std::numbers::pi * std::numbers::pi * (I1 + I2));
  Section s;
  s.name = std::move(name);
  s.shape = SectionShape::Ellipse;
  s.a = (xmax - xmin) / 2;
  s.b = (ymax - ymin) / 2;
  s.exponent = 2;
  s.EA = m.young * A;
  s.GA1 = s.GA2 = shear_factor * m.shear * A;
  s.EI1 = m.young * I1 * r1;
  s.EI2 = m.young * I2 * r2;
  s.GJ = m.shear * J;
  s.rhoA = m.density * A;
  s.rhoJ = m.density * Eigen::Vector3d(I1, I2, I1 + I2);
  return s;
}

int append_yarn(Fabric& fabric, bool warp, std::span<const Eigen::Vector3d> points, int section,
                const std::vector<Eigen::Vector3d>& up) {
  if (points.size() < 3 || points.size() % 2 == 0)
    throw std::invalid_argument(
        fmt::format("yarn: expected an odd number >= 3 of points (2 per element + 1), found {}",
                    points.size()));
  const int elements = static_cast<int>(points.size() - 1) / 2;
  if (up.size() != 1 && up.size() != static_cast<std::size_t>(elements))
    throw std::invalid_argument(fmt::format(
        "yarn: expected 1 or {} up vectors (one per element), found {}", elements, up.size()));
  Model& model = fabric.model;
  Yarn yarn;
  yarn.warp = warp;
  yarn.index = static_cast<int>(std::count_if(fabric.yarns.begin(), fabric.yarns.end(),
                                              [&](const Yarn& y) { return y.warp == warp; }));
  const int first = static_cast<int>(model.nodes.size());
  for (const Eigen::Vector3d& x : points) {
    yarn.nodes.push_back(static_cast<int>(model.nodes.size()));
    model.nodes.push_back(x);
  }
  for (int e = 0; e < elements; ++e) {
    BeamElement element;
    element.nodes = {first + 2 * e, first + 2 * e + 1, first + 2 * e + 2};
    element.section = section;
    const Eigen::Vector3d axis = points[2 * e + 2] - points[2 * e];
    const Eigen::Vector3d& u = up.size() == 1 ? up[0] : up[static_cast<std::size_t>(e)];
    const Eigen::Vector3d r = u.cross(axis);
    if (!(r.norm() > 1e-9 * axis.norm() * u.norm()))
      throw std::invalid_argument(
          fmt::format("yarn {}: element {} has zero length or an axis parallel to its up vector",
                      yarn.index, e));
    element.reference_vector = r.normalized();
    yarn.elements.push_back(static_cast<int>(model.elements.size()));
    model.elements.push_back(element);
  }
  fabric.yarns.push_back(std::move(yarn));
  return static_cast<int>(fabric.yarns.size()) - 1;
}

std::string yarn_name(const Yarn& yarn) {
  return fmt::format("{}{}", yarn.warp ? "warp" : "weft", yarn.index);
}

void finish_fabric(Fabric& fabric, std::span<const double> contact_radius,
                   const InterfaceLawParameters& law, ContactFormulation formulation) {
  if (contact_radius.size() != fabric.yarns.size())
    throw std::invalid_argument(fmt::format("fabric: expected {} contact radii (one per yarn), "
                                            "found {}",
                                            fabric.yarns.size(), contact_radius.size()));
  Model& model = fabric.model;
  auto add_set = [&](std::string name, std::vector<int> nodes) {
    std::sort(nodes.begin(), nodes.end());
    nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
    model.node_sets.push_back({std::move(name), std::move(nodes)});
  };
  for (const Yarn& y : fabric.yarns) {
    const std::string name = yarn_name(y);
    add_set(name, y.nodes);
    add_set(name + ".start", {y.nodes.front()});
    add_set(name + ".end", {y.nodes.back()});
  }
  for (bool warp : {true, false}) {
    std::vector<int> all, starts, ends;
    for (const Yarn& y : fabric.yarns) {
      if (y.warp != warp)
        continue;
      all.insert(all.end(), y.nodes.begin(), y.nodes.end());
      starts.push_back(y.nodes.front());
      ends.push_back(y.nodes.back());
    }
    const std::string dir = warp ? "warp" : "weft";
    add_set(dir, std::move(all));
    add_set(dir + ".start", std::move(starts));
    add_set(dir + ".end", std::move(ends));
  }

  SplineContactDefinition contact;
  contact.name = "warp-weft";
  contact.law = law;
  contact.self_contact = false;
  for (std::size_t k = 0; k < fabric.yarns.size(); ++k) {
    const Yarn& y = fabric.yarns[k];
    const int index = static_cast<int>(model.splines.size());
    // The section's in-plane width (axis 1 lies in the fabric plane): the footprint of the
    // torsional friction at its crossings.
    const Section& section = model.sections[model.elements[y.elements.front()].section];
    model.splines.push_back({yarn_name(y), y.nodes, contact_radius[k], 2 * section.a});
    (y.warp ? contact.group_a : contact.group_b).push_back(index);
    contact.margin = std::max(contact.margin, contact_radius[k]);
  }
  SurfaceContactDefinition surfaces{"warp-weft", {}, {}, law, 0.0};
  for (const Yarn& y : fabric.yarns) {
    const Section& section = model.sections[model.elements[y.elements.front()].section];
    Surface surface{yarn_name(y), y.elements, section.a,
                    section.shape == SectionShape::Circle ? section.a : section.b,
                    section.exponent};
    (y.warp ? surfaces.group_a : surfaces.group_b)
        .push_back(static_cast<int>(model.surfaces.size()));
    surfaces.margin = std::max(surfaces.margin, std::min(surface.a, surface.b));
    model.surfaces.push_back(std::move(surface));
  }
  if (contact.group_a.empty() || contact.group_b.empty())
    return;
  if (formulation == ContactFormulation::Spline)
    model.spline_contacts.push_back(std::move(contact));
  else
    model.surface_contacts.push_back(std::move(surfaces));
}

} // namespace yarnsim::textile
