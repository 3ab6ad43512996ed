#pragma once
// Small programmatic models shared by the verification tests.
#include "engine/model/model.hpp"

#include <numbers>

namespace yarnsim::test {

/// A straight beam from `from` to `to` in n 3-node elements, with node sets "all", "start", "end".
inline Model straight_beam(const Eigen::Vector3d& from, const Eigen::Vector3d& to, int n,
                           const Section& section,
                           const Eigen::Vector3d& reference = Eigen::Vector3d::UnitY()) {
  Model m;
  m.sections.push_back(section);
  for (int i = 0; i <= 2 * n; ++i)
    m.nodes.push_back(from + (to - from) * (double(i) / (2 * n)));
  for (int e = 0; e < n; ++e)
    m.elements.push_back(BeamElement{{2 * e, 2 * e + 1, 2 * e + 2}, 0, reference});
  NodeSet all{"all", {}};
  for (int i = 0; i <= 2 * n; ++i)
    all.nodes.push_back(i);
  m.node_sets = {all, NodeSet{"start", {0}}, NodeSet{"end", {2 * n}}};
  return m;
}

/// Appends the nodes and elements of `beam` to `m` (elements keep their section index);
/// returns the index of beam's first node in m. Node sets and splines are the caller's.
inline int append_beam(Model& m, const Model& beam) {
  const int offset = static_cast<int>(m.nodes.size());
  m.nodes.insert(m.nodes.end(), beam.nodes.begin(), beam.nodes.end());
  for (BeamElement e : beam.elements) {
    for (int& k : e.nodes)
      k += offset;
    m.elements.push_back(e);
  }
  return offset;
}

inline Section stiffness_section(double EA, double GA, double EI, double GJ, double rhoA = 0,
                                 Eigen::Vector3d rhoJ = Eigen::Vector3d::Zero()) {
  Section s;
  s.EA = EA;
  s.GA1 = s.GA2 = GA;
  s.EI1 = s.EI2 = EI;
  s.GJ = GJ;
  s.rhoA = rhoA;
  s.rhoJ = rhoJ;
  return s;
}

inline Constraint clamp(int set) {
  return Constraint{set, {true, true, true, true, true, true}};
}

inline SolutionStep static_step(double end, double dt, double tol = 1e-10) {
  SolutionStep s;
  s.type = StepType::Static;
  s.end_time = end;
  s.dt_initial = dt;
  s.dt_max = dt;
  s.dt_min = dt * 1e-4;
  s.max_iterations = 30;
  s.tol_force = tol;
  s.tol_increment = tol;
  return s;
}

} // namespace yarnsim::test
