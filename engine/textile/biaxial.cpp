#include "engine/textile/biaxial.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <stdexcept>

namespace yarnsim::textile {

std::pair<double, double> biaxial_strains(double k, double max_strain) {
  if (!(k > 0) || !std::isfinite(k))
    throw std::invalid_argument(fmt::format("biaxial: expected a strain ratio > 0, found {}", k));
  if (!(max_strain > 0 && max_strain < 1))
    throw std::invalid_argument(
        fmt::format("biaxial: expected a maximum strain in (0, 1), found {}", max_strain));
  return k >= 1 ? std::pair{max_strain, max_strain / k} : std::pair{k * max_strain, max_strain};
}

namespace {

/// The node set `name`; `test` ("biaxial", "uniaxial") starts the message when it is missing.
int require_set(const Model& model, const std::string& name, const char* test) {
  const int s = model.find_node_set(name);
  if (s < 0)
    throw std::invalid_argument(fmt::format("{}: the fabric has no node set '{}'", test, name));
  return s;
}

} // namespace

void add_biaxial_test(Fabric& fabric, const BiaxialParameters& p) {
  const auto [eps_warp, eps_weft] =
      p.uniaxial ? std::pair{p.uniaxial == FabricDirection::Warp ? p.max_strain : 0.0,
                             p.uniaxial == FabricDirection::Weft ? p.max_strain : 0.0}
                 : biaxial_strains(p.strain_ratio, p.max_strain);
  if (p.uniaxial && !(p.max_strain > 0 && p.max_strain < 1))
    throw std::invalid_argument(
        fmt::format("uniaxial: expected a maximum strain in (0, 1), found {}", p.max_strain));
  const double T = p.loading_time;
  Model& model = fabric.model;
  const double t0 = model.steps.empty() ? 0.0 : model.steps.back().end_time;
  const char* name = p.uniaxial ? "uniaxial" : "biaxial";
  const SolutionStep step = loading_step(p, t0, name);

  BiaxialTest test;
  test.strain_ratio = p.uniaxial ? 0.0 : p.strain_ratio;
  test.uniaxial = p.uniaxial;
  test.max_strain = p.max_strain;
  test.loading_time = T;
  test.strain_warp = ramp_table(t0, t0 + T, eps_warp, p.ramp);
  test.strain_weft = ramp_table(t0, t0 + T, eps_weft, p.ramp);
  bool have_warp = false, have_weft = false;
  for (const Yarn& y : fabric.yarns) {
    const std::string yarn = yarn_name(y);
    const int start_set = require_set(model, yarn + ".start", name);
    const int end_set = require_set(model, yarn + ".end", name);
    const Eigen::Vector3d a = model.nodes[static_cast<std::size_t>(y.nodes.front())];
    const Eigen::Vector3d b = model.nodes[static_cast<std::size_t>(y.nodes.back())];
    Eigen::Vector3d d(b.x() - a.x(), b.y() - a.y(), 0.0);
    const double L = d.norm();
    if (!(L > 0))
      throw std::invalid_argument(
          fmt::format("{}: yarn {} has its ends at the same in-plane point", name, yarn));
    d /= L;
    const double eps = y.warp ? eps_warp : eps_weft;
    const double half = eps * L / 2;
    const bool free = p.uniaxial && (*p.uniaxial == FabricDirection::Warp) != y.warp;
    for (auto [set, sign] : {std::pair{start_set, -1.0}, std::pair{end_set, 1.0}}) {
      if (free)
        break;
      PrescribedMotion motion;
      motion.node_set = set;
      for (int c = 0; c < 3; ++c)
        motion.displacement[static_cast<std::size_t>(c)] =
            ramp_table(t0, t0 + T, sign * half * d(c), p.ramp);
      model.prescribed.push_back(std::move(motion));
    }
    if (y.warp) {
      if (!have_warp)
        test.length_warp = L;
      have_warp = true;
      test.warp_start.push_back(start_set);
      test.warp_end.push_back(end_set);
    } else {
      if (!have_weft)
        test.length_weft = L;
      have_weft = true;
      test.weft_start.push_back(start_set);
      test.weft_end.push_back(end_set);
    }
  }
  if (!have_warp || !have_weft)
    throw std::invalid_argument(
        fmt::format("{}: expected warp and weft yarns, found only one direction", name));
  // The yarns' nodes, warp yarns first (the order of the node sets above).
  for (const bool warp : {true, false})
    for (const Yarn& y : fabric.yarns)
      if (y.warp == warp)
        test.yarn_nodes.push_back(y.nodes);
  model.steps.push_back(step);
  model.biaxial = std::move(test);
  if (p.monitors) {
    model.monitors.push_back(
        {"warp_ends", MonitorType::NodeSet, require_set(model, "warp.end", name)});
    model.monitors.push_back(
        {"weft_ends", MonitorType::NodeSet, require_set(model, "weft.end", name)});
  }
}

BiaxialReading read_biaxial(const Model& model, const Eigen::Matrix3Xd& x,
                            const Eigen::Matrix<double, 6, Eigen::Dynamic>& reactions) {
  const BiaxialTest& test = *model.biaxial;
  BiaxialReading out;
  double strain[2] = {0, 0}, force[2] = {0, 0};
  for (int dir = 0; dir < 2; ++dir) {
    const auto& starts = dir == 0 ? test.warp_start : test.weft_start;
    const auto& ends = dir == 0 ? test.warp_end : test.weft_end;
    for (std::size_t i = 0; i < starts.size(); ++i) {
      const int a = model.node_sets[starts[i]].nodes.front();
      const int b = model.node_sets[ends[i]].nodes.front();
      const Eigen::Vector2d d0 = (model.nodes[b] - model.nodes[a]).head<2>();
      const Eigen::Vector2d d = (x.col(b) - x.col(a)).head<2>();
      // Each yarn over its own length: the yarns of a TexGen fabric need not be equally long
      // (a woven deck's are, to the last bit, so its strains are those of test.length_warp).
      strain[dir] += (d.norm() - d0.norm()) / d0.norm() / starts.size();
      const Eigen::Vector3d axis(d0.x() / d0.norm(), d0.y() / d0.norm(), 0.0);
      const double f =
          0.5 * (reactions.col(b).head<3>().dot(axis) - reactions.col(a).head<3>().dot(axis));
      force[dir] += f;
      out.yarn_forces.push_back(f);
    }
  }
  // Crimp: centre-line length over in-plane end-to-end distance, less 1, per direction.
  const std::size_t n_warp = test.warp_start.size();
  double crimp[2] = {0, 0};
  for (std::size_t i = 0; i < test.yarn_nodes.size(); ++i) {
    const std::vector<int>& nodes = test.yarn_nodes[i];
    double length = 0;
    for (std::size_t k = 1; k < nodes.size(); ++k)
      length += (x.col(nodes[k]) - x.col(nodes[k - 1])).norm();
    const double chord = (x.col(nodes.back()) - x.col(nodes.front())).head<2>().norm();
    const int dir = i < n_warp ? 0 : 1;
    crimp[dir] += (length / chord - 1) /
                  static_cast<double>(dir == 0 ? n_warp : test.yarn_nodes.size() - n_warp);
  }
  out.crimp_warp = crimp[0];
  out.crimp_weft = crimp[1];
  out.strain_warp = strain[0];
  out.strain_weft = strain[1];
  out.force_warp = force[0];
  out.force_weft = force[1];
  return out;
}

} // namespace yarnsim::textile
