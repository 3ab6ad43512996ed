#include "engine/solver/simulation.hpp"
#include "engine/contact/surface_contact_set.hpp"

#include "engine/beam/nodal_terms.hpp"
#include "engine/math/rotation.hpp"
#include "engine/solver/checkpoint.hpp"
#include "engine/solver/distributed.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <numbers>
#include <numeric>
#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/flow_graph.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tuple>

namespace yarnsim {

namespace {

/// Unwrapped rotation vector: the representative of rotation R closest to the previous value.
Eigen::Vector3d unwrap_rotation(const Eigen::Matrix3d& R, const Eigen::Vector3d& previous) {
  const Eigen::Vector3d v = rotation_vector(R);
  const double angle = v.norm();
  if (angle < 1e-12)
    return previous.norm() < std::numbers::pi ? v
                                              : previous; // identity: keep full turns as they were
  const Eigen::Vector3d e = v / angle;
  const double k = std::round((previous.dot(e) - angle) / (2 * std::numbers::pi));
  return (angle + 2 * std::numbers::pi * k) * e;
}

/// Smallest damping of a Newton correction before the attempt fails.
constexpr double kMinDamping = 1.0 / 256;

const char* dof_name(int c) {
  static const char* names[] = {"ux", "uy", "uz", "rx", "ry", "rz"};
  return names[c];
}

/// Where a node lies along the first spline (a fabric's yarn) that has it, for messages: " (on
/// spline 'weft95', control point 330 of 793)", or "" for a node on no spline. A scan over the
/// splines: for messages only.
std::string on_spline(const Model& model, int node) {
  for (const Spline& s : model.splines)
    for (std::size_t k = 0; k < s.nodes.size(); ++k)
      if (s.nodes[k] == node)
        return fmt::format(" (on spline '{}', control point {} of {})", s.name, k + 1,
                           s.nodes.size());
  return "";
}

} // namespace

Simulation::Simulation(const Model& model, SimulationOptions options)
    : model_(model), options_(options) {
  const int n = static_cast<int>(model.nodes.size());
  if (n == 0 || model.elements.empty())
    throw std::invalid_argument("the model has no nodes or no elements");
  if (model.steps.empty())
    throw std::invalid_argument("the model has no solution step");

  // Constraints and prescribed motions fix DOFs for the whole run.
  std::vector<char> constrained(kDofsPerNode * n, 0);
  for (const Constraint& c : model.constraints)
    for (int node : model.node_sets[c.node_set].nodes)
      for (int d = 0; d < 6; ++d)
        if (c.fixed[d])
          constrained[6 * node + d] = 1;
  for (const PrescribedMotion& p : model.prescribed)
    for (int node : model.node_sets[p.node_set].nodes) {
      for (int c = 0; c < 3; ++c)
        if (p.displacement[c]) {
          constrained[6 * node + c] = 1;
          prescribed_u_.push_back({node, c, &*p.displacement[c]});
        }
      if (p.rotation) {
        for (int c = 3; c < 6; ++c)
          constrained[6 * node + c] = 1;
        prescribed_r_.push_back({node, &*p.rotation});
      }
    }
  // Over several processes each assembles its share of the elements, the pairs and the nodes'
  // terms, and evaluate() sums them (partition.hpp).
  if (distributed::size() > 1) {
    shares_ = partition_all(model, distributed::size());
    partition_ = shares_[static_cast<std::size_t>(distributed::rank())];
  }
  const int n_equations =
      static_cast<int>(std::count(constrained.begin(), constrained.end(), char{0}));
  LinearSolverKind kind = options.linear_solver;
  const bool moments = std::any_of(model.loads.begin(), model.loads.end(),
                                   [](const NodalLoad& l) { return l.moment.squaredNorm() > 0; });
  // Friction (contact/friction.hpp) and applied moments make the tangent far from symmetric.
  // Surface contact near a node between elements carries a share of the force whose derivative
  // makes it a little non-symmetric (contact::SurfaceContactOptions::end_window).
  const bool far_from_symmetric = moments || has_friction(model);
  const bool symmetric_tangent = !far_from_symmetric && model.surface_contacts.empty();
  if (kind == LinearSolverKind::Auto) {
    // Far from symmetric: LU, MUMPS's where it is built (2.5 to 6.7 times UMFPACK's speed on the
    // examples, 1.6 times on a 48 x 48 weave: docs/performance.md, "MUMPS's LU for the
    // non-symmetric tangents"). A little non-symmetric: GMRES on the symmetric part's LDL^T
    // solves it, falling back to LU where the contact forces have made it too far from
    // symmetric (docs/performance.md, "The surface contact at scale"). Over several processes
    // they factorise together by MUMPS: LDL^T of a symmetric tangent, LU of the others
    // (docs/performance.md, "Runs over MPI").
    if (distributed::size() > 1)
      kind = mumps_available() ? LinearSolverKind::MUMPS : LinearSolverKind::PETSc;
    else if (far_from_symmetric)
      kind = mumps_available() ? LinearSolverKind::MUMPS : LinearSolverKind::LU;
    else if (!model.surface_contacts.empty())
      kind = LinearSolverKind::LDLTGmres;
    else if (mumps_available() && n_equations >= kMumpsEquations)
      kind = LinearSolverKind::MUMPS; // a large symmetric system: multifrontal beats simplicial
    else
      kind = LinearSolverKind::LDLTSymmetric;
  }
  solver_ = make_linear_solver(kind, symmetric_tangent);
  // A solver that sums the processes' own entries (MUMPS, PETSc) needs of each process only the
  // pattern of what it assembles; the others take the whole tangent, summed over the processes.
  assembler_ = std::make_unique<Assembler>(
      model, constrained,
      partition_ && solver_->sums_partial_tangents() ? partition_ : std::nullopt);
  contact_ = ContactStage::of(model);
  if (contact_ && partition_)
    contact_->set_partition(partition_);
  solver_name_ = solver_->name();

  // Reference triads, lumped mass and rotary inertia (1/6, 2/3, 1/6 of each element).
  Q0_.assign(n, Eigen::Matrix3d::Identity());
  std::vector<char> has_triad(n, 0);
  mass_ = Eigen::VectorXd::Zero(n);
  rotary_inertia_ = Eigen::Matrix3Xd::Zero(3, n);
  const double lump[3] = {1.0 / 6.0, 2.0 / 3.0, 1.0 / 6.0};
  const double xi_node[3] = {-1.0, 0.0, 1.0};
  double max_axial = 0, max_bending = 0, min_length = 1e300;
  Eigen::AlignedBox3d box;
  for (std::size_t e = 0; e < model.elements.size(); ++e) {
    const BeamElement& el = model.elements[e];
    const Section& s = model.sections[el.section];
    const double length = assembler_->references()[e].weight.sum();
    Eigen::Matrix3d X;
    for (int i = 0; i < 3; ++i)
      X.col(i) = model.nodes[el.nodes[i]];
    for (int i = 0; i < 3; ++i) {
      const int node = el.nodes[i];
      mass_(node) += s.rhoA * length * lump[i];
      rotary_inertia_.col(node) += s.rhoJ * length * lump[i];
      if (!has_triad[node]) {
        const double xi = xi_node[i];
        const Eigen::Vector3d dN(xi - 0.5, -2.0 * xi, xi + 0.5);
        Q0_[node] = triad_from(X * dN, el.reference_vector);
        has_triad[node] = 1;
      }
      box.extend(X.col(i));
    }
    max_axial = std::max({max_axial, s.EA, s.GA1, s.GA2});
    max_bending = std::max({max_bending, s.EI1, s.EI2, s.GJ});
    min_length = std::min(min_length, length);
  }
  // Round-off levels of the residual: strains come from differences of positions over an element,
  // so the noise grows with size / element length. Residuals below these count as zero.
  const double ratio = std::max(1.0, box.diagonal().norm() / min_length);
  // 64 machine epsilons: the force residual of a converged rod of length / radius 2e4 stagnates
  // at 3e-13 EA ratio (docs/performance.md, "Tolerances"); 1e-12 EA ratio, used before, lay
  // above every tolerance a user asks for on slender rods and overruled it without a word.
  const double floor_c = 64 * std::numeric_limits<double>::epsilon();
  floor_force_ = floor_c * max_axial * ratio;
  // Moments from rotation differences over an element. (The force noise acting over an element,
  // floor_force_ times its length, was counted here too; on that rod it lay 1e5 times above the
  // moment residual's stagnation level, 1e-10 N m, and overruled every moment tolerance.)
  // The triads' products carry more round-off than position differences: 16 times the force
  // floor's factor (the moment residual of that rod stagnates at 4e-11 to 1.1e-10 N m, 0.3 to
  // 0.8 of floor_c EI / h ratio).
  floor_moment_ = 16 * floor_c * max_bending / min_length * ratio;
  floor_length_ = 1e-12 * std::max(box.diagonal().norm(), min_length);
  // The smallest contact radius of any spline or surface in a contact: the step limit.
  max_contact_step_ = std::numeric_limits<double>::infinity();
  for (const SplineContactDefinition& c : model.spline_contacts)
    for (const std::vector<int>* group : {&c.group_a, &c.group_b})
      for (int s : *group)
        max_contact_step_ =
            std::min(max_contact_step_, c.radius > 0 ? c.radius : model.splines[s].radius);
  for (const SurfaceContactDefinition& c : model.surface_contacts)
    for (const std::vector<int>* group : {&c.group_a, &c.group_b})
      for (int s : *group)
        max_contact_step_ = std::min({max_contact_step_, model.surfaces[s].a, model.surfaces[s].b});
  if (!std::isfinite(max_contact_step_))
    max_contact_step_ = 0;
  min_length_ = min_length;
  equation_weight_.resize(assembler_->n_equations());
  for (int d = 0; d < kDofsPerNode * n; ++d)
    if (assembler_->equation(d) >= 0)
      equation_weight_(assembler_->equation(d)) = d % 6 < 3 ? 1.0 / min_length : 1.0;

  state_.x.resize(3, n);
  for (int i = 0; i < n; ++i)
    state_.x.col(i) = model.nodes[i];
  state_.x_n = state_.x;
  state_.alpha = Eigen::Matrix3Xd::Zero(3, n);
  state_.Q_n = Q0_;
  state_.v_n = state_.a_n = state_.W_n = state_.A_n = Eigen::Matrix3Xd::Zero(3, n);
  state_.rotation_n = Eigen::Matrix3Xd::Zero(3, n);
  state_.gauss.resize(model.elements.size());
  for (std::size_t e = 0; e < model.elements.size(); ++e)
    for (int g = 0; g < 2; ++g)
      state_.gauss[e][g] = GaussState{assembler_->references()[e].Q0[g], Eigen::Vector3d::Zero()};
  reactions_ = Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, n);
  load_n_ = external_loads(0.0);
  graph_ = std::make_unique<IterationGraph>(*this);
  if (contact_ && contact_->damped())
    for (std::size_t k = 0; k < model.steps.size(); ++k)
      if (model.steps[k].type == StepType::Explicit)
        throw std::invalid_argument(fmt::format(
            "step {} is explicit: contact damping (normal or tangential) is not available on "
            "the explicit path in this version",
            k + 1));
  if (contact_) {
    // The clearance each formulation sees before loading (the spline passes inside the
    // interior nodes, so it differs from the nominal gap between the yarn surfaces).
    // (Its veto is not looked at: the projections of the reference configuration serve its
    // clearance only.)
    agree_contact(contact_->evaluate(state_, false));
    gather_contact();
    initial_clearance_ = contact_->min_gap();
  }
}

Simulation::~Simulation() = default;

Eigen::Matrix<double, 6, Eigen::Dynamic> Simulation::external_loads(double t) const {
  Eigen::Matrix<double, 6, Eigen::Dynamic> loads =
      Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, state_.n_nodes());
  for (const NodalLoad& l : model_.loads) {
    const double f = l.factor.at(t);
    for (int node : model_.node_sets[l.node_set].nodes) {
      const Eigen::Vector3d force = reference_components(l, l.force, node);
      const Eigen::Vector3d moment = reference_components(l, l.moment, node);
      loads.col(node).head<3>() += f * force;
      if (!l.follower_moment)
        loads.col(node).tail<3>() += f * moment;
      else // current spatial direction of the follower moment
        loads.col(node).tail<3>() += f * (rodrigues_rotation<double>(state_.alpha.col(node)) *
                                          state_.Q_n[node] * Q0_[node].transpose() * moment);
    }
  }
  return loads;
}

Eigen::Vector3d Simulation::reference_components(const NodalLoad& load, const Eigen::Vector3d& v,
                                                 int node) const {
  return load.axes == LoadAxes::Section ? Eigen::Vector3d(Q0_[node] * v) : v;
}

void Simulation::apply_prescribed(double t_new) {
  for (const PrescribedDisplacement& p : prescribed_u_)
    state_.x(p.component, p.node) = model_.nodes[p.node](p.component) + p.table->at(t_new);
  for (const PrescribedRotation& p : prescribed_r_) {
    const Eigen::Vector3d theta((*p.tables)[0].at(t_new), (*p.tables)[1].at(t_new),
                                (*p.tables)[2].at(t_new));
    const Eigen::Matrix3d target = rotation_matrix(theta) * Q0_[p.node];
    state_.alpha.col(p.node) = rodrigues_of(target * state_.Q_n[p.node].transpose());
  }
}

/// The stages of one Newton iteration as a oneTBB flow graph, built once per simulation:
///
///   broad phase --> narrow phase ----+--> contact assembly (+ pattern growth)
///   zeroing ------> beam assembly ---+--> inertia terms (computed, not yet added)
///
/// The narrow phase and the beam assembly touch disjoint data (the beams write the matrix's
/// values, the pattern stays), so they run side by side, each with parallel loops inside; the
/// contact assembly waits for both, grows the pattern by the pairs the narrow phase found within
/// reach (keeping the beams' values) and adds the pairs in their order over the nodes, so the
/// sums are the same on any thread count. Beside it, whose pattern growth is serial, the nodes'
/// inertia terms are computed into inertia_; evaluate() adds them after the graph, so every entry
/// is summed in the same order as before (beams, contact, inertia).
struct Simulation::IterationGraph {
  tbb::flow::graph graph;
  tbb::flow::continue_node<tbb::flow::continue_msg> broad, clear, narrow, beams, contact_assembly,
      inertia;

  static double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }

  explicit IterationGraph(Simulation& s)
      : broad(graph,
              [&s](const tbb::flow::continue_msg&) {
                const auto t0 = std::chrono::steady_clock::now();
                if (s.contact_)
                  s.contact_->update_candidates(s.state_);
                s.stage_times_.broad_phase += seconds_since(t0);
              }),
        // The residual and the matrix are cleared beside the broad and the narrow phase, which
        // touch neither: the clearing is memory bound and took as long on two threads as on
        // one, ahead of both branches.
        clear(graph,
              [&s](const tbb::flow::continue_msg&) {
                const auto t0 = std::chrono::steady_clock::now();
                s.iteration_.residual->setZero();
                if (s.iteration_.want_tangent)
                  s.assembler_->zero_matrix();
                s.stage_times_.other_assembly += seconds_since(t0);
              }),
        narrow(graph,
               [&s](const tbb::flow::continue_msg&) {
                 const auto t0 = std::chrono::steady_clock::now();
                 if (s.contact_) {
                   s.iteration_.veto = s.contact_->project(
                       s.state_, s.iteration_.want_tangent,
                       s.iteration_.rates.velocity ? &s.iteration_.rates : nullptr);
                   // The couplings the pairs need, sorted here beside the beam assembly; the
                   // pattern grows (if it must) after it (contact_assembly).
                   s.iteration_.couplings.clear();
                   if (s.iteration_.want_tangent && s.iteration_.veto.empty() &&
                       !s.contact_->partitioned()) {
                     s.iteration_.couplings = s.contact_->couplings();
                     std::sort(s.iteration_.couplings.begin(), s.iteration_.couplings.end());
                   }
                 }
                 s.stage_times_.narrow_phase += seconds_since(t0);
               }),
        beams(graph,
              [&s](const tbb::flow::continue_msg&) {
                const auto t0 = std::chrono::steady_clock::now();
                Eigen::VectorXd& r = *s.iteration_.residual;
                s.assembler_->add_beams(s.state_, r, s.iteration_.want_tangent,
                                        s.iteration_.damping,
                                        s.mixed_.active ? &s.mixed_.resultants : nullptr,
                                        s.partition_ ? &*s.partition_ : nullptr);
                double f = 0, m = 0;
                for (int i = 0; i < s.state_.n_nodes(); ++i) {
                  f = std::max(f, r.segment<3>(6 * i).norm());
                  m = std::max(m, r.segment<3>(6 * i + 3).norm());
                }
                s.iteration_.ref_force = f;
                s.iteration_.ref_moment = m;
                s.stage_times_.beam_assembly += seconds_since(t0);
              }),
        contact_assembly(graph,
                         [&s](const tbb::flow::continue_msg&) {
                           const auto t0 = std::chrono::steady_clock::now();
                           // Over several processes after the graph (evaluate()): the couplings
                           // and vetoes are agreed first, by MPI calls of the main thread.
                           if (s.contact_ && s.iteration_.veto.empty() &&
                               !s.contact_->partitioned()) {
                             // The pairs the narrow phase found active or within reach must be in
                             // the pattern; a pattern that grows here keeps the beams' entries
                             // already assembled.
                             if (s.iteration_.want_tangent)
                               s.assembler_->ensure_couplings(std::move(s.iteration_.couplings));
                             s.contact_->assemble(*s.iteration_.residual, *s.assembler_,
                                                  s.iteration_.want_tangent);
                           }
                           s.stage_times_.other_assembly += seconds_since(t0);
                         }),
        inertia(graph, [&s](const tbb::flow::continue_msg&) {
          const auto t0 = std::chrono::steady_clock::now();
          if (s.iteration_.newmark != nullptr)
            s.compute_inertia(*s.iteration_.step, *s.iteration_.newmark, s.iteration_.want_tangent);
          // Not other_assembly: the contact assembly beside it adds to that (evaluate() does).
          s.inertia_.seconds = seconds_since(t0);
        }) {
    tbb::flow::make_edge(broad, narrow);
    tbb::flow::make_edge(clear, beams);
    tbb::flow::make_edge(narrow, contact_assembly);
    tbb::flow::make_edge(beams, contact_assembly);
    tbb::flow::make_edge(narrow, inertia);
    tbb::flow::make_edge(beams, inertia);
  }

  void run() {
    broad.try_put(tbb::flow::continue_msg());
    clear.try_put(tbb::flow::continue_msg());
    graph.wait_for_all();
  }
};

void Simulation::compute_inertia(const SolutionStep& step, const NewmarkCoefficients& nm,
                                 bool want_tangent) {
  const int n = state_.n_nodes();
  const double cm = step.rayleigh_mass;
  const double cz = step.rayleigh_out_of_plane;
  InertiaTerms& t = inertia_;
  t.force.resize(3, n);
  t.moment.resize(3, n);
  if (want_tangent) {
    t.force_tangent.resize(3, n);
    t.moment_tangent.resize(static_cast<std::size_t>(n));
  }
  // The largest force and moment are maxima: the same in any order.
  tbb::combinable<std::pair<double, double>> largest(
      [] { return std::pair<double, double>(0.0, 0.0); });
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 256), [&](const tbb::blocked_range<int>& range) {
    std::pair<double, double>& local = largest.local();
    for (int i = range.begin(); i != range.end(); ++i) {
      // Over several processes each adds its own nodes' terms (evaluate), and the largest force
      // and moment are taken over the processes there.
      if (partition_ && !partition_->owns(i))
        continue;
      const Eigen::Vector3d du = state_.x.col(i) - state_.x_n.col(i);
      const Eigen::Vector3d a = nm.a1 * du - nm.a2 * state_.v_n.col(i) - nm.a3 * state_.a_n.col(i);
      const Eigen::Vector3d v = nm.a4 * du + nm.a5 * state_.v_n.col(i) + nm.a6 * state_.a_n.col(i);
      Eigen::Vector3d f = mass_(i) * (a + cm * v);
      f.z() += mass_(i) * cz * v.z();
      t.force.col(i) = f;
      Eigen::Vector3d r;
      Eigen::Matrix3d K;
      rotary_inertia(rotary_inertia_.col(i), cm, nm,
                     {state_.Q_n[i], state_.W_n.col(i), state_.A_n.col(i)}, state_.alpha.col(i), r,
                     K);
      t.moment.col(i) = r;
      if (want_tangent) {
        t.force_tangent.col(i).setConstant(mass_(i) * (nm.a1 + cm * nm.a4));
        t.force_tangent(2, i) += mass_(i) * cz * nm.a4;
        t.moment_tangent[static_cast<std::size_t>(i)] = K;
      }
      local.first = std::max(local.first, f.norm());
      local.second = std::max(local.second, r.norm());
    }
  });
  t.largest_force = t.largest_moment = 0;
  largest.combine_each([&](const std::pair<double, double>& l) {
    t.largest_force = std::max(t.largest_force, l.first);
    t.largest_moment = std::max(t.largest_moment, l.second);
  });
}

Simulation::Evaluation Simulation::evaluate(const SolutionStep& step, const NewmarkCoefficients& nm,
                                            double t_new, bool want_tangent,
                                            Eigen::VectorXd& residual) {
  const int n = state_.n_nodes();
  const bool dynamic = step.type == StepType::Dynamic;
  // Damping velocities are an input of the beam assembly.
  StiffnessDamping damping;
  if (dynamic && step.rayleigh_stiffness != 0.0) {
    damping_velocity_.resize(6 * n);
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d du = state_.x.col(i) - state_.x_n.col(i);
      damping_velocity_.segment<3>(6 * i) =
          nm.a4 * du + nm.a5 * state_.v_n.col(i) + nm.a6 * state_.a_n.col(i);
      Eigen::Vector3d W, A;
      newmark_angular(nm, {state_.Q_n[i], state_.W_n.col(i), state_.A_n.col(i)},
                      state_.alpha.col(i), W, A);
      damping_velocity_.segment<3>(6 * i + 3) =
          rodrigues_rotation<double>(state_.alpha.col(i)) * state_.Q_n[i] * W;
    }
    damping = {step.rayleigh_stiffness, nm.a4, &damping_velocity_};
  }
  // Contact damping's velocities: Newmark's of the iterate, v = a4 (x - x_n) + a5 v_n + a6 a_n,
  // dv/dx = a4 (static steps have none: damping then acts on nothing).
  ContactRates rates;
  if (dynamic && contact_ && contact_->damped()) {
    contact_velocity_.resize(3, n);
    for (int i = 0; i < n; ++i)
      contact_velocity_.col(i) = nm.a4 * (state_.x.col(i) - state_.x_n.col(i)) +
                                 nm.a5 * state_.v_n.col(i) + nm.a6 * state_.a_n.col(i);
    rates = {&contact_velocity_, nm.a4};
    if (contact_->surface() != nullptr && contact_->surface()->damped()) {
      // The surface points turn with the nodes' sections: omega = Q(alpha) Q_n W, W Newmark's
      // material angular velocity of the iterate (as the Rayleigh damping's above).
      contact_angular_velocity_.resize(3, n);
      for (int i = 0; i < n; ++i) {
        Eigen::Vector3d W, A;
        newmark_angular(nm, {state_.Q_n[i], state_.W_n.col(i), state_.A_n.col(i)},
                        state_.alpha.col(i), W, A);
        contact_angular_velocity_.col(i) =
            rodrigues_rotation<double>(state_.alpha.col(i)) * state_.Q_n[i] * W;
      }
      rates.angular_velocity = &contact_angular_velocity_;
    }
  }
  // The iteration's task graph: (broad phase -> narrow phase) || (clearing -> beam assembly),
  // then the contact assembly beside the inertia terms.
  iteration_ = {&residual,
                damping,
                want_tangent,
                {},
                rates,
                {},
                0.0,
                0.0,
                dynamic ? &step : nullptr,
                dynamic ? &nm : nullptr};
  const auto graph_start = std::chrono::steady_clock::now();
  graph_->run();
  stage_times_.iteration_graph +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - graph_start).count();
  Evaluation out;
  if (contact_ && contact_->partitioned()) {
    // Over several processes each projected its own pairs: the vetoes and figures are agreed,
    // the pattern grows by this process's couplings where it holds its share alone, by every
    // process's otherwise (so the whole patterns stay the same), and each adds its pairs, after
    // the beams as in the graph.
    const auto t_agree = std::chrono::steady_clock::now();
    iteration_.veto = agree_contact(iteration_.veto);
    if (iteration_.veto.empty()) {
      if (want_tangent) {
        std::vector<ContactCoupling> mine = contact_->couplings();
        std::sort(mine.begin(), mine.end());
        mine.erase(std::unique(mine.begin(), mine.end()), mine.end());
        // This process's pairs' blocks, for the entries it hands the solver (own_entries).
        std::vector<ContactCoupling> merged;
        std::set_union(own_couplings_.begin(), own_couplings_.end(), mine.begin(), mine.end(),
                       std::back_inserter(merged));
        own_couplings_changed_ = own_couplings_changed_ || merged.size() != own_couplings_.size();
        own_couplings_ = std::move(merged);
        if (assembler_->share()) {
          assembler_->ensure_couplings(std::move(mine));
        } else {
          std::vector<ContactCoupling> couplings = distributed::gather(mine);
          std::sort(couplings.begin(), couplings.end());
          assembler_->ensure_couplings(std::move(couplings));
        }
      }
      contact_->assemble(residual, *assembler_, want_tangent);
    }
    stage_times_.other_assembly +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_agree).count();
  }
  out.veto = iteration_.veto;
  if (!out.veto.empty())
    return out;
  double ref_force = iteration_.ref_force, ref_moment = iteration_.ref_moment;
  if (contact_)
    ref_force = std::max(ref_force, contact_->max_force());
  stage_times_.other_assembly += inertia_.seconds;
  const auto t0 = std::chrono::steady_clock::now();

  // Inertia (lumped) and mass-proportional damping, computed in the graph: each node adds its
  // own residual entries and diagonal blocks, so the nodes run in parallel.
  if (dynamic) {
    tbb::parallel_for(
        tbb::blocked_range<int>(0, n, 256), [&](const tbb::blocked_range<int>& range) {
          for (int i = range.begin(); i != range.end(); ++i) {
            if (partition_ && !partition_->owns(i))
              continue;
            residual.segment<3>(6 * i) += inertia_.force.col(i);
            residual.segment<3>(6 * i + 3) += inertia_.moment.col(i);
            if (want_tangent) {
              assembler_->add_node_block(i, 0, 0, inertia_.force_tangent.col(i).asDiagonal());
              assembler_->add_node_block(i, 3, 3, inertia_.moment_tangent[i]);
            }
          }
        });
    ref_force = std::max(ref_force, inertia_.largest_force);
    ref_moment = std::max(ref_moment, inertia_.largest_moment);
  }

  // External loads: dead forces and dead or follower moments.
  for (const NodalLoad& l : model_.loads) {
    const double factor = l.factor.at(t_new);
    if (factor == 0.0)
      continue;
    for (int node : model_.node_sets[l.node_set].nodes) {
      ref_force = std::max(ref_force, std::abs(factor) * l.force.norm());
      if (partition_ && !partition_->owns(node))
        continue;
      residual.segment<3>(6 * node) -= factor * reference_components(l, l.force, node);
      if (l.moment.squaredNorm() == 0.0)
        continue;
      Eigen::Vector3d r;
      Eigen::Matrix3d K;
      applied_moment(factor * reference_components(l, l.moment, node), l.follower_moment,
                     state_.Q_n[node] * Q0_[node].transpose(), state_.alpha.col(node), r, K);
      residual.segment<3>(6 * node + 3) += r;
      if (want_tangent)
        assembler_->add_node_block(node, 3, 3, K);
      ref_moment = std::max(ref_moment, std::abs(factor) * l.moment.norm());
    }
  }
  // Over several processes each holds the sums of its share (partition.hpp): the residuals are
  // summed here, so every process has the whole; the matrices too, except where the solver sums
  // the processes' own entries itself (MUMPS: Assembler::own_entries). The beams' largest nodal
  // force is complete on the process owning the node's yarn.
  if (partition_) {
    distributed::sum(residual.data(), static_cast<std::size_t>(residual.size()));
    // MUMPS sums the processes' own entries itself (own_entries); other solvers take the whole.
    if (want_tangent && !solver_->sums_partial_tangents())
      distributed::sum(assembler_->matrix().valuePtr(),
                       static_cast<std::size_t>(assembler_->matrix().nonZeros()));
    ref_force = distributed::largest(ref_force);
    ref_moment = distributed::largest(ref_moment);
  }
  stage_times_.other_assembly +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // Forces and moments are compared on one scale: a moment M over the shortest element of
  // length h is worth a force M / h.
  out.ref_force = std::max(ref_force, ref_moment / min_length_);
  out.ref_moment = std::max(ref_moment, out.ref_force * min_length_);

  // Norms over the free equations; rhs = -residual there.
  const std::vector<int>& eq = assembler_->equations();
  rhs_.resize(assembler_->n_equations());
  double r_force = 0, r_moment = 0, worst = -1;
  for (int d = 0; d < 6 * n; ++d) {
    if (eq[d] < 0)
      continue;
    const double v = residual(d);
    if (!std::isfinite(v)) {
      out.veto = fmt::format("the residual is not finite at node {} DOF {}{}",
                             model_.node_label(d / 6), dof_name(d % 6), on_spline(model_, d / 6));
      return out;
    }
    rhs_(eq[d]) = -v;
    if (d % 6 < 3)
      r_force += v * v;
    else
      r_moment += v * v;
    const double scaled = std::abs(v) / (d % 6 < 3 ? std::max(out.ref_force, floor_force_)
                                                   : std::max(out.ref_moment, floor_moment_));
    if (scaled > worst) {
      worst = scaled;
      out.worst_dof = d;
    }
  }
  out.r_force = std::sqrt(r_force);
  out.r_moment = std::sqrt(r_moment);
  // Reference: the largest nodal force of any kind; a sum over nodes would grow with the mesh.
  out.relative = std::max(out.r_force / std::max(out.ref_force, floor_force_),
                          out.r_moment / std::max(out.ref_moment, floor_moment_));
  return out;
}

double Simulation::closing_limit(const Eigen::Matrix3Xd& du, const Eigen::Matrix3Xd* offset) const {
  const double limit = contact_->closing_limit(du, offset, options_.closing_allowance);
  return contact_->partitioned() ? distributed::smallest(limit) : limit;
}

std::pair<double, double> Simulation::largest_nodal_motion(const Eigen::VectorXd& delta) const {
  const int n = state_.n_nodes();
  const std::vector<int>& eq = assembler_->equations();
  return tbb::parallel_reduce(
      tbb::blocked_range<int>(0, n, 1024), std::pair<double, double>{0.0, 0.0},
      [&](const tbb::blocked_range<int>& range, std::pair<double, double> m) {
        for (int i = range.begin(); i != range.end(); ++i) {
          double translation = 0, rotation = 0;
          for (int c = 0; c < 3; ++c) {
            const int eu = eq[6 * i + c], ea = eq[6 * i + 3 + c];
            translation += eu >= 0 ? delta(eu) * delta(eu) : 0.0;
            rotation += ea >= 0 ? delta(ea) * delta(ea) : 0.0;
          }
          m.first = std::max(m.first, std::sqrt(translation));
          m.second = std::max(m.second, std::sqrt(rotation));
        }
        return m;
      },
      [](std::pair<double, double> a, std::pair<double, double> b) {
        return std::pair<double, double>{std::max(a.first, b.first), std::max(a.second, b.second)};
      });
}

Simulation::CorrectionLimit Simulation::limit_correction(const Eigen::VectorXd& delta,
                                                         double lambda, bool from_converged) {
  const int n = state_.n_nodes();
  const std::vector<int>& eq = assembler_->equations();
  const auto [du, da] = largest_nodal_motion(delta);
  // Step limit: no node moves by more than the smallest contact radius in one correction
  // (formulation.md "Solution"). A larger correction comes from a near-mechanism of the
  // tangent (a yarn turning about the line through its pinned ends, a floating yarn) and
  // would carry yarns through each other, beyond what the contact's linearisation at the
  // current candidates describes.
  if (options_.line_search && max_contact_step_ > 0 && lambda * du > max_contact_step_)
    lambda = max_contact_step_ / du;
  // The closing limit (formulation.md "Solution"): a pair open where the correction starts
  // penetrates at most closing_allowance times its smaller contact radius, to first order. A
  // correction from a tangent that lacks the pairs it closes would otherwise throw floating
  // yarns across the clearance, and the next one back (the active set cycling where many
  // crossings close in one increment). The contact's last evaluation is of the configuration
  // the correction starts from, except for the first correction solved at the converged state
  // (same active set): the predictor's motion from it is then the offset.
  if (options_.line_search && contact_ && options_.closing_allowance > 0) {
    correction_motion_.resize(3, n);
    tbb::parallel_for(tbb::blocked_range<int>(0, n, 1024), [&](const tbb::blocked_range<int>& r) {
      for (int i = r.begin(); i != r.end(); ++i)
        for (int c = 0; c < 3; ++c) {
          const int e = eq[6 * i + c];
          correction_motion_(c, i) = e >= 0 ? delta(e) : 0.0;
        }
    });
    if (from_converged)
      predictor_motion_ = state_.x - state_.x_n;
    const double closing =
        closing_limit(correction_motion_, from_converged ? &predictor_motion_ : nullptr);
    if (closing < lambda)
      return {closing, du, da, true};
  }
  return {lambda, du, da, false};
}

std::string Simulation::factorize_tangent() {
  auto tick = std::chrono::steady_clock::now();
  // Over several processes handing in their own entries, a process whose pairs need blocks it
  // did not assemble before, or whose pattern (of its share) changed, analyses again with the
  // others (a collective call): each pattern changes on its own.
  bool analyse = analysed_pattern_ != assembler_->pattern_version();
  if (partition_ && solver_->sums_partial_tangents()) {
    analyse = distributed::any(own_couplings_changed_ || analyse);
    own_couplings_changed_ = false;
  }
  try {
    if (analyse) {
      if (partition_ && solver_->sums_partial_tangents())
        solver_->set_own_entries(assembler_->own_entries(*partition_, own_couplings_));
      solver_->analyze(assembler_->matrix());
      analysed_pattern_ = assembler_->pattern_version();
    }
    auto now = std::chrono::steady_clock::now();
    stage_times_.convergence_check += std::chrono::duration<double>(now - tick).count();
    tick = now;
    solver_->factorize(assembler_->matrix());
  } catch (const LinearSolverError& e) {
    return e.what();
  }
  stage_times_.factorisation +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - tick).count();
  if (stop_requested())
    throw_interrupted();
  return {};
}

bool Simulation::chooses_predictor() const {
  return options_.kinematic_predictor && model_.biaxial;
}

void Simulation::choose_predictor(const SolutionStep& step, const NewmarkCoefficients& nm,
                                  double t_new, double dt, Eigen::VectorXd& residual,
                                  IncrementReport& report) {
  secant_chosen_ = secant_trial_ = false;
  report.secant_residual = report.ends_residual = std::numeric_limits<double>::quiet_NaN();
  report.secant_corrected = report.ends_corrected = std::numeric_limits<double>::quiet_NaN();
  report.secant_next_correction = report.ends_next_correction =
      std::numeric_limits<double>::quiet_NaN();
  if (!chooses_predictor() || step.secant_predictor || secant_step_ != step_)
    return;
  // A tension test: the last increment's motion, held short of closing crossings
  // (secant_reach_), where it leaves less than the ends' predictor (with friction the ends
  // alone, frictionless with the pulled yarns' stretch); the ends' otherwise
  // (docs/performance.md, "The predictor chosen by its residual", "The secant's rotations").
  // They are compared after the attempt's first correction where it comes from the converged
  // state's tangent (attempt(); "The predictor chosen after its first correction"), by their
  // residuals here otherwise.
  // Evaluations without the tangent; the points they anchor are dropped with them
  // (begin_attempt).
  secant_chosen_ = true;
  predict(t_new, dt);
  const Evaluation secant = evaluate(step, nm, t_new, false, residual);
  secant_chosen_ = false;
  if (secant.veto.empty()) {
    secant_at_predictor_ = secant;
    secant_rhs_ = rhs_;
    secant_active_set_ = contact_ ? contact_->summary().active_set : 0;
  }
  if (options_.line_search && options_.first_correction_from_converged_state) {
    // The choice is made after the first correction, as the attempt's first iteration makes it
    // (attempt()): it starts from the ends, whose residual it evaluates itself.
    secant_trial_ = secant.veto.empty();
    if (secant_trial_)
      report.secant_residual = secant.relative;
    if (contact_)
      contact_->begin_attempt();
    return;
  }
  predict(t_new, dt);
  const Evaluation ends = evaluate(step, nm, t_new, false, residual);
  secant_chosen_ = secant.veto.empty() && (!ends.veto.empty() || secant.relative < ends.relative);
  if (secant.veto.empty())
    report.secant_residual = secant.relative;
  if (ends.veto.empty())
    report.ends_residual = ends.relative;
  if (contact_)
    contact_->begin_attempt();
}

void Simulation::predict(double t_new, double dt) {
  // The converged state, then the prescribed values at t_new. (Carrying the last increment's
  // motion on helps some decks and costs others: docs/performance.md, "The secant predictor";
  // the steps that ask for it take it, and a tension test where it was chosen:
  // choose_predictor, attempt().)
  state_.x = state_.x_n;
  state_.alpha.setZero();
  // The secant predictor: the free translations move on by the last converged increment's
  // motion of this step, and the free rotations turn on by its rotations, scaled to this
  // increment's size (its first increment has none); the chosen one held short of closing
  // crossings (secant_reach_). Without the rotations the carried translations turn the yarns'
  // tangents away from their sections (shear strains: a relative residual of 19 where the
  // ends' predictor left 1.1 on the 24 x 24 weave; docs/performance.md, "The secant's
  // rotations").
  const SolutionStep& step = model_.steps[static_cast<std::size_t>(step_)];
  const bool carry = (step.secant_predictor || secant_chosen_) && secant_step_ == step_;
  if (carry) {
    const std::vector<int>& eq = assembler_->equations();
    const double ratio = dt / secant_dt_;
    // A step's own secant is not held (its reach is +infinity: commit).
    const double scale = std::min(ratio, secant_reach_);
    // Q = exp(skew(scale theta)) Q_n as Rodrigues parameters (rotation.hpp); the components of
    // prescribed DOFs are set by apply_prescribed below.
    for (int i = 0; i < state_.n_nodes(); ++i) {
      const Eigen::Vector3d alpha = rodrigues_of_vector(scale * secant_rotation_.col(i));
      for (int c = 0; c < 3; ++c) {
        if (eq[6 * i + c] >= 0)
          state_.x(c, i) += scale * secant_motion_(c, i);
        if (eq[6 * i + 3 + c] >= 0)
          state_.alpha(c, i) = alpha(c);
      }
    }
  }
  if (!options_.kinematic_predictor || carry) {
    apply_prescribed(t_new);
    return;
  }
  const std::vector<int>& eq = assembler_->equations();
  const auto free = [&eq](int i, int n_dofs) {
    for (int c = 0; c < n_dofs; ++c)
      if (eq[6 * i + c] < 0)
        return false;
    return true;
  };
  const double t0 = t_new - dt;
  if (model_.picture_frame) {
    // A picture frame's free nodes move with the frame's map over the increment (the trellis's
    // kinematics), their sections turning as the map turns their tangents: the predictor that
    // moved the yarn ends alone strained the elements next to them by 1e4 N and its first
    // corrections turned sections by radians (formulation.md "Solution").
    const PictureFrameTest& frame = *model_.picture_frame;
    Eigen::Matrix3d turn = Eigen::Matrix3d::Identity();
    turn.topLeftCorner<2, 2>() = frame.linear_map(t_new) * frame.linear_map(t0).inverse();
    for (int i = 0; i < state_.n_nodes(); ++i) {
      if (!free(i, 6))
        continue;
      const Eigen::Vector2d X = model_.nodes[i].head<2>();
      state_.x.col(i).head<2>() += frame.carried(t_new, X) - frame.carried(t0, X);
      // The rotation taking the tangent d to the map's (turn d) normalised, about d x d':
      // Rodrigues parameters 2 tan(theta / 2) e (rotation.hpp).
      const Eigen::Vector3d d = state_.Q_n[i].col(2);
      const Eigen::Vector3d d1 = (turn * d).normalized();
      const Eigen::Vector3d axis = d.cross(d1);
      const double sine = axis.norm();
      if (sine > 0)
        state_.alpha.col(i) = 2 * std::tan(0.5 * std::atan2(sine, d.dot(d1))) / sine * axis;
    }
  } else if (model_.biaxial && !has_friction(model_)) {
    // A tension test's pulled yarns stretch with their ends: each free node of a pulled yarn
    // moves along the yarn by (eps(t_new) - eps(t0)) times its in-plane distance from the yarn's
    // middle, as the ends do by their prescribed motions; the predictor of the ends alone put
    // the whole increment's stretch of a yarn into its end elements. Frictionless crossings let
    // the yarns slide along each other so; frictional ones hold them (the stretch would be a slip
    // at every crossing, measured: 299 -> 8 369 iterations on the k = 1 friction deck), and
    // there the predictor stays the ends' (docs/performance.md, "Tension tests' predictor").
    const BiaxialTest& test = *model_.biaxial;
    const std::size_t n_warp = test.warp_start.size();
    for (std::size_t k = 0; k < test.yarn_nodes.size(); ++k) {
      const std::vector<int>& yarn = test.yarn_nodes[k];
      const TimeTable& strain = k < n_warp ? test.strain_warp : test.strain_weft;
      const double stretch = strain.at(t_new) - strain.at(t0);
      if (stretch == 0 || yarn.size() < 2)
        continue;
      const Eigen::Vector2d a = model_.nodes[yarn.front()].head<2>();
      const Eigen::Vector2d b = model_.nodes[yarn.back()].head<2>();
      const Eigen::Vector2d along = (b - a).normalized(), middle = (a + b) / 2;
      for (const int i : yarn)
        if (free(i, 3))
          state_.x.col(i).head<2>() +=
              stretch * along.dot(model_.nodes[i].head<2>() - middle) * along;
    }
  }
  apply_prescribed(t_new);
}

void Simulation::move_along(const Eigen::VectorXd& delta, double s) {
  const std::vector<int>& eq = assembler_->equations();
  const int n = state_.n_nodes();
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 1024), [&](const tbb::blocked_range<int>& r) {
    for (int i = r.begin(); i != r.end(); ++i)
      for (int c = 0; c < 6; ++c) {
        const int e = eq[6 * i + c];
        if (e < 0)
          continue;
        if (c < 3)
          state_.x(c, i) += s * delta(e);
        else
          state_.alpha(c - 3, i) += s * delta(e);
      }
  });
  if (mixed_.active) {
    // x and alpha enter the Gauss points' x', alpha, alpha' linearly within the increment, so
    // the point lambda delta from the correction's start has the linearised strains
    // strain + lambda rate.
    mixed_.lambda += s;
    const std::vector<BeamReference>& refs = assembler_->references();
    tbb::parallel_for(std::size_t{0}, refs.size(), [&](std::size_t e) {
      if (assembles_element(e))
        mixed_.resultants[e] =
            beam_resultants_of_strains(refs[e], mixed_.strain[e] + mixed_.lambda * mixed_.rate[e]);
    });
  }
}

void Simulation::start_mixed_stresses(const Eigen::VectorXd& delta, bool from_converged) {
  const std::vector<int>& eq = assembler_->equations();
  const std::vector<BeamReference>& refs = assembler_->references();
  const std::size_t n_elements = refs.size();
  mixed_.strain.resize(n_elements);
  mixed_.rate.resize(n_elements);
  mixed_.resultants.resize(n_elements);
  tbb::parallel_for(std::size_t{0}, n_elements, [&](std::size_t e) {
    if (!assembles_element(e))
      return;
    const BeamNodalValues values = assembler_->nodal_values(state_, static_cast<int>(e));
    BeamNodalValues direction;
    const std::array<int, 3>& nodes = model_.elements[e].nodes;
    for (int j = 0; j < 3; ++j)
      for (int c = 0; c < 3; ++c) {
        const int eu = eq[6 * nodes[j] + c], ea = eq[6 * nodes[j] + 3 + c];
        direction.x(c, j) = eu >= 0 ? delta(eu) : 0.0;
        direction.alpha(c, j) = ea >= 0 ? delta(ea) : 0.0;
      }
    if (!from_converged) {
      beam_strains(refs[e], state_.gauss[e], values, direction, mixed_.strain[e], mixed_.rate[e]);
    } else {
      // The correction was solved with the converged state's tangent: its linear model runs
      // from the converged state u_n through the predictor u_p, so the strains are
      // eps(u_n) + B_n (u_p - u_n) + lambda B_n delta, not the predictor's own (the prescribed
      // motion alone strains the elements next to it: attempt()).
      BeamNodalValues converged, predictor_motion;
      for (int j = 0; j < 3; ++j) {
        converged.x.col(j) = state_.x_n.col(nodes[j]);
        predictor_motion.x.col(j) = values.x.col(j) - converged.x.col(j);
        predictor_motion.alpha.col(j) = values.alpha.col(j);
      }
      converged.alpha.setZero();
      Eigen::Matrix<double, 6, 2> strain_n, rate_p;
      beam_strains(refs[e], state_.gauss[e], converged, predictor_motion, strain_n, rate_p);
      beam_strains(refs[e], state_.gauss[e], converged, direction, strain_n, mixed_.rate[e]);
      mixed_.strain[e] = strain_n + rate_p;
    }
    mixed_.resultants[e] = beam_resultants_of_strains(refs[e], mixed_.strain[e]);
  });
  mixed_.lambda = 0;
  mixed_.active = true;
}

std::string Simulation::agree_contact(const std::string& veto) {
  if (!contact_ || !contact_->partitioned())
    return veto;
  const std::vector<ContactSummary> parts =
      distributed::gather(std::vector<ContactSummary>{contact_->local_summary()});
  contact_->agree(combine_summaries(parts));
  return distributed::first_message(veto);
}

void Simulation::share_contact_pairs() {
  // After a restore every process holds every pair and the same histories:
  // they are the run's figures, points and snapshots as they stand, and the friction dissipated
  // so far stays with the first process alone (the sum over the processes counts it once). The
  // work lists keep each process's own pairs from the next search on.
  contact_->agree(contact_->local_summary());
  contact_->set_gathered_points(contact_->local_points());
  if (distributed::rank() != 0)
    contact_->clear_dissipation();
  gathered_spline_.reset();
  gathered_surface_.reset();
  gathered_ = Gathered::everywhere;
  if (const SplineContactSet* spline = contact_->spline())
    gathered_spline_ = spline->snapshot();
  if (const SurfaceContactSet* surface = contact_->surface())
    gathered_surface_ = surface->snapshot();
}

void Simulation::gather_contact() {
  gathered_spline_.reset();
  gathered_surface_.reset();
  if (!contact_ || !contact_->partitioned())
    return;
  if (assembler_->share()) { // for the leader's checkpoints
    gathered_couplings_ = distributed::gather_on_first(assembler_->couplings());
    std::sort(gathered_couplings_.begin(), gathered_couplings_.end());
    gathered_couplings_.erase(std::unique(gathered_couplings_.begin(), gathered_couplings_.end()),
                              gathered_couplings_.end());
  }
  // The points, in the one-process order: by set (spline first), definition and pair.
  std::vector<ContactPoint> points = distributed::gather(contact_->local_points());
  std::sort(points.begin(), points.end(), [](const ContactPoint& a, const ContactPoint& b) {
    return std::tie(a.surface, a.definition, a.pair) < std::tie(b.surface, b.definition, b.pair);
  });
  contact_->set_gathered_points(std::move(points));
  gather_histories(false);
}

void Simulation::gather_histories(bool everywhere) {
  gathered_spline_.reset();
  gathered_surface_.reset();
  gathered_ = everywhere ? Gathered::everywhere : Gathered::on_first;
  // Only the leader writes checkpoints: the others receive nothing unless a new partition needs
  // every pair's history on every process (rebalance), which keeps the exchange at each commit
  // to one copy of the histories and not one per process.
  const bool here = everywhere || distributed::rank() == 0;
  const auto merged = [everywhere](const auto& local) {
    auto all = everywhere ? distributed::gather(local) : distributed::gather_on_first(local);
    std::sort(all.begin(), all.end(), [](const auto& a, const auto& b) { return a.key < b.key; });
    return all;
  };
  if (const SplineContactSet* spline = contact_->spline()) {
    SplineContactSet::Snapshot s = spline->snapshot();
    s.committed = merged(s.committed);
    s.line_committed = merged(s.line_committed);
    s.pairs = merged(s.pairs);
    distributed::sum(&s.dissipated, 1);
    if (here)
      gathered_spline_ = std::move(s);
  }
  if (const SurfaceContactSet* surface = contact_->surface()) {
    SurfaceContactSet::Snapshot s = surface->snapshot();
    s.committed = merged(s.committed);
    s.pairs = merged(s.pairs);
    distributed::sum(&s.dissipated, 1);
    s.summary = contact_->summary(); // the processes' (as one process saves its own)
    if (here)
      gathered_surface_ = std::move(s);
  }
}

bool Simulation::shares_factorisation() const {
  return solver_->sums_partial_tangents();
}

std::string Simulation::rebalance() {
  if (!partition_ || !contact_ || contact_->candidates_version() == balanced_version_)
    return {};
  balanced_version_ = contact_->candidates_version();
  const int n = state_.n_nodes();
  std::vector<double> load(static_cast<std::size_t>(n), 0.0);
  contact_->add_candidate_loads(load, kCandidateLoad);
  // Each process's search holds its own pairs (and those across its share's edge, which it
  // does not own): their loads summed are every pair's, the same on every process.
  distributed::sum(load.data(), load.size());
  std::vector<NodePartition> shares = partition_all(model_, distributed::size(), load);
  if (shares == shares_)
    return {};
  // The largest process's work (elements and candidates) over the mean.
  const auto imbalance = [&](const std::vector<NodePartition>& parts) {
    const std::vector<double> work = share_work(model_, parts, load);
    const double total = std::accumulate(work.begin(), work.end(), 0.0);
    return total > 0 ? *std::max_element(work.begin(), work.end()) * work.size() / total : 1.0;
  };
  // Moved where that lowers the largest share by a twentieth of the mean at least: a cut that
  // the candidates' ebb and flow moves by a yarn each way would repartition at each change.
  const double before = imbalance(shares_), after = imbalance(shares);
  if (!(after <= before - kRebalanceGain))
    return {};
  // Every process takes every pair's history of the commit just made (a restart's are on every
  // process already; a fresh run before its first commit has none to take), restores them, and
  // keeps its own from the next search on.
  if (gathered_ == Gathered::on_first)
    gather_histories(true);
  shares_ = std::move(shares);
  partition_ = shares_[static_cast<std::size_t>(distributed::rank())];
  contact_->set_partition(partition_);
  if (gathered_spline_)
    contact_->spline()->restore(*gathered_spline_);
  if (gathered_surface_)
    contact_->surface()->restore(*gathered_surface_);
  share_contact_pairs();
  own_couplings_.clear();
  own_couplings_changed_ = true;
  if (assembler_->share())
    assembler_->set_share(*partition_); // the new share's elements and nodes; pairs as they come
  return fmt::format("the work over the {} processes balanced again for {} contact candidates: "
                     "the largest share {:.2f} -> {:.2f} times the mean",
                     shares_.size(), contact_->summary().candidates, before, after);
}

void Simulation::prune_couplings() {
  std::vector<ContactCoupling> mine = contact_->couplings();
  // Over several processes every process's pairs, so that the whole patterns stay the same; a
  // pattern of a process's share, its own.
  const std::vector<ContactCoupling> needed =
      contact_->partitioned() && !assembler_->share() ? distributed::gather(mine) : mine;
  if (4 * assembler_->couplings().size() <= 5 * needed.size() + 64)
    return;
  assembler_->set_couplings(needed);
  if (contact_->partitioned()) { // the blocks this process now assembles (own_entries)
    std::sort(mine.begin(), mine.end());
    mine.erase(std::unique(mine.begin(), mine.end()), mine.end());
    own_couplings_ = std::move(mine);
    own_couplings_changed_ = true;
  }
}

double Simulation::scaled_norm(const Eigen::VectorXd& v) const {
  return v.cwiseProduct(equation_weight_).norm();
}

bool Simulation::stop_requested() const {
  // Over MPI every process stops at the same point, where any of them was asked to.
  return distributed::any(options_.stop_requested && options_.stop_requested->load());
}

void Simulation::throw_interrupted() const {
  throw Interrupted(
      fmt::format("interrupted at t = {:.6g} s after increment {}", state_.time, state_.increment));
}

std::string Simulation::attempt(const SolutionStep& step, double t_new, double dt,
                                IncrementReport& report) {
  const int n = state_.n_nodes();
  const NewmarkCoefficients nm(step.newmark_beta, step.newmark_gamma, dt);
  Eigen::VectorXd residual(6 * n);
  mixed_.active = false; // the first evaluation's tangent is the displacement-based one
  solver_->start_attempt();
  if (contact_) {
    contact_->set_time(t_new);
    contact_->begin_attempt();
  }
  // Where the increment moves prescribed DOFs, the first correction is solved with the tangent
  // of the converged state (at t_new's Newmark coefficients) where the predictor has the same
  // active contact pairs, not with the tangent at the predictor: moving the prescribed nodes
  // alone strains the elements next to them (an arm of a picture frame moves every yarn end
  // sideways), and the tangent there, with the large axial forces of those elements, is far from
  // the path's (corrections of radians in the nodes' rotations where the increment turns the
  // yarns by 1e-3 rad). The converged state's tangent is that of a stable equilibrium; its
  // correction is the linear response to the prescribed increment (the residual at the
  // predictor, to first order K_fp du_p). Where the predictor closes or opens contacts (pins
  // pushed into a slack yarn) that tangent lacks them and the predictor's is kept. It costs one
  // evaluation (two where the active sets differ) and no factorisation.
  choose_predictor(step, nm, t_new, dt, residual, report);
  predict(t_new, dt);
  bool first_from_converged = options_.line_search &&
                              options_.first_correction_from_converged_state &&
                              (state_.x != state_.x_n || state_.alpha.cwiseAbs().maxCoeff() > 0);

  report.residual_history.clear();
  report.energy_history.clear();
  Eigen::VectorXd delta; // the Newton correction in use, over the free equations
  double delta_norm = 0; // its scaled norm
  double lambda = 1;     // damping: the fraction of delta applied
  double last_du = 0;    // m, largest nodal translation of delta
  double last_da = 0;    // largest nodal Rodrigues increment of delta
  // Iterates reached by a correction the closing limit cut, with more active pairs than any
  // iterate of the attempt before, count apart from max_iterations
  // (SimulationOptions::closing_iterations_apart): crossings closing, each such iterate lets those
  // nearest close (traced on the 96 x 96 weave's toe: 7 to 17 per increment, then Newton
  // quadratic in 3 to 5; docs/performance.md, "The 96 x 96 weave's toe, traced"). A cut iterate
  // that closes nothing new (contacts opening and closing again: the frictional bias extension's
  // failed attempts) counts as any other. The attempt fails after max_iterations others or
  // kClosingIterationFactor times it in all.
  bool closing_cut = false; // the point evaluated next was reached by a correction the limit cut
  int closing_iterates = 0;
  int most_active = -1; // the most active pairs at an iterate of the attempt so far
  const int iteration_bound = options_.closing_iterations_apart
                                  ? kClosingIterationFactor * step.max_iterations
                                  : step.max_iterations;
  const auto lap_from = [](std::chrono::steady_clock::time_point& tick, double& total) {
    const auto now = std::chrono::steady_clock::now();
    total += std::chrono::duration<double>(now - tick).count();
    tick = now;
  };
  // Damped Newton (Deuflhard, Newton Methods for Nonlinear Problems, Springer 2004, sec. 3.3,
  // the monotonicity test of NLEQ-ERR on successive corrections): the point x + lambda delta is
  // kept when the next Newton correction is shorter than (1 - lambda / 4) |delta| in the scaled
  // norm (translations over the shortest element, rotations in rad). The test costs nothing when
  // it passes: the next correction is the next iteration's. It is affine covariant: a large
  // residual in a stiff mode (the axial force a bending step leaves in a slender rod) needs only
  // a small correction from the tangent that carries its geometric stiffness and passes, while
  // contacts that a step closes and the next opens again (corrections that do not shrink) fail.
  // Then the point moves back along delta to lambda' = max(min(lambda / 2, 1 / h), lambda / 10),
  // h = 2 |delta_next - (1 - lambda) delta| / (lambda^2 |delta|) the estimate of the problem's
  // nonlinearity along delta, and is evaluated there; a configuration the contact vetoes halves
  // lambda at once. After a damped step the next correction starts from min(1, 4 lambda).
  double next_lambda = 1;
  std::vector<double> moment_history; // N m, moment residual norm of each iteration
  // Each iteration's residual on the attempt's fixed scale (scaled_residual below), 1.
  std::vector<double> scaled_history;
  std::vector<std::array<int, 2>> contact_history; // active and slipping points of each iteration
  bool damping_gave_up = false;                    // no damping made the corrections contract
  std::uint64_t last_active_set = 0; // of the point the correction in use started from
  bool start_factorised = false; // the factorisation in hand is the tangent delta was solved with
  std::string last_veto;
  // The residual's norm at the point delta started from, in the references of the attempt's
  // first evaluation (force and moment residuals each over their reference).
  double residual_scale_force = 0, residual_scale_moment = 0;
  double start_residual = std::numeric_limits<double>::infinity();
  // The first correction where the predictors' trial chose it (below): solved, and limited
  // (lambda, and the largest nodal translation and rotation) where the contact's evaluation was
  // its start's.
  Eigen::VectorXd chosen_correction;
  CorrectionLimit chosen_limit{-1}; // none where lambda < 0
  for (int iter = 0; iter <= iteration_bound; ++iter) {
    if (stop_requested())
      throw_interrupted();
    const Evaluation ev = evaluate(step, nm, t_new, true, residual);
    if (contact_ && ev.veto.empty()) {
      const int active = contact_->summary().active;
      if (closing_cut && options_.closing_iterations_apart && active > most_active)
        ++closing_iterates;
      most_active = std::max(most_active, active);
    }
    closing_cut = false;
    // The test applies where the last step changed which contact pairs are active: there the
    // residual has a kink the tangent does not see, and full steps can cycle between two active
    // sets. Smooth steps are full Newton steps (quadratic convergence, and no test that a stiff
    // beam's path of large intermediate forces would fail).
    const bool can_damp = options_.line_search && delta.size() > 0;
    if (!ev.veto.empty()) {
      if (!can_damp)
        return ev.veto;
      last_veto = ev.veto;
      // Back along the correction from a configuration the contact cannot project.
      const double next = 0.5 * lambda;
      if (next < kMinDamping)
        return ev.veto;
      move_along(delta, next - lambda);
      lambda = next;
      continue;
    }
    const int worst_dof = ev.worst_dof;
    report.residual_history.push_back(ev.relative);
    if (residual_scale_force == 0) {
      residual_scale_force = std::max(ev.ref_force, floor_force_);
      residual_scale_moment = std::max(ev.ref_moment, floor_moment_);
    }
    double scaled_residual =
        std::hypot(ev.r_force / residual_scale_force, ev.r_moment / residual_scale_moment);
    const std::uint64_t active_set = contact_ ? contact_->summary().active_set : 0;
    scaled_history.push_back(scaled_residual);
    // Also where the residual has fallen by less than a fifth over two iterations: full steps are
    // cycling, e.g. between stick and slip of a point whose sliding reverses (the same
    // fingerprint on both sides of the cycle). On the attempt's fixed scale (scaled_residual),
    // or on the relative residual (stagnation_on_fixed_scale false): while crossings close, that
    // one's reference, the iterate's largest nodal force, is the out-of-balance force itself, so
    // it stayed near 4.94 on the frictional 6 x 6 weave's toe while the force residual fell
    // from 2 700 N to 780 N, and at 780 N the damping then backtracked as if it stagnated.
    const std::vector<double>& history =
        options_.stagnation_on_fixed_scale ? scaled_history : report.residual_history;
    const std::size_t h = history.size();
    const bool stagnating = h >= 3 && history[h - 1] > 0.8 * history[h - 3];
    // On the fixed scale also over the last iteration: a full step that kept the contact and
    // friction states and fell by less than a fifth is damped at once (the 96 x 96 weave's toe
    // stalled four full steps at 0.08 with its states unchanged: docs/performance.md).
    const bool stalled =
        options_.stagnation_on_fixed_scale && h >= 2 && history[h - 1] > 0.8 * history[h - 2];
    // Both are contact's: a model without contact takes full Newton steps (a slender rod's
    // residual stagnates on its path through large axial forces, and damping it there cost the
    // L / r = 1e5 roll-up 469 iterations against 324 undamped: docs/performance.md).
    const bool damping =
        can_damp && contact_ && (active_set != last_active_set || stagnating || stalled);

    // Converged: the residual within the tolerance of its reference (or at its round-off floor)
    // and the last correction, as applied, within the tolerance of the increment's motion.
    bool residual_ok = ev.r_force <= std::max(step.tol_force * ev.ref_force, floor_force_) &&
                       ev.r_moment <= std::max(step.tol_force * ev.ref_moment, floor_moment_);
    bool increment_ok = false;
    if (iter > 0) {
      double step_du = 0, step_da = 0;
      for (int i = 0; i < n; ++i) {
        step_du = std::max(step_du, (state_.x.col(i) - state_.x_n.col(i)).norm());
        step_da = std::max(step_da, state_.alpha.col(i).norm());
      }
      // A correction's largest nodal translation and rotation within the increment tolerance
      // of the increment's motion.
      const auto within_tolerance = [&](double du, double da) {
        return du <= step.tol_increment * std::max(step_du, floor_length_) &&
               da <= step.tol_increment * std::max(step_da, 1e-12);
      };
      increment_ok = within_tolerance(lambda * last_du, lambda * last_da);
      // The last correction, as applied, bounds the error of the point it started from; the
      // simplified Newton correction at the point reached, -K(x_k)^-1 r(x_k+1) with the
      // factorisation in hand, estimates the error of that point itself (Deuflhard, Newton
      // Methods for Nonlinear Problems, Springer 2004, sec. 3.3: NLEQ-ERR's termination
      // test). Where the residual passes and the step kept the active set (no
      // kink between the two points), the increment criterion is tested on it: one solve
      // instead of one more iteration, to the same tolerance.
      if (options_.simplified_correction_check && residual_ok && !increment_ok &&
          active_set == last_active_set) {
        auto tick = std::chrono::steady_clock::now();
        const Eigen::VectorXd simplified = solver_->solve(rhs_);
        lap_from(tick, stage_times_.solve);
        const auto [simplified_du, simplified_da] = largest_nodal_motion(simplified);
        increment_ok = simplified.allFinite() && within_tolerance(simplified_du, simplified_da);
      }
    }
    // A residual at round-off level cannot be improved: the last correction then only stirs
    // round-off (ill-conditioned stiff axial against soft bending modes). The force residual's
    // level is known (floor_force_); the moment residual's grows with the forces acting over the
    // elements, so it counts as at round-off where, with the forces at their floor, it has not
    // halved over the last two iterations (Newton, converging, would square it) and lies within
    // a thousand times its floor.
    moment_history.push_back(ev.r_moment);
    const std::size_t k = moment_history.size();
    const bool moment_stalled = ev.r_force <= floor_force_ && ev.r_moment <= 1e3 * floor_moment_ &&
                                k >= 3 && moment_history[k - 1] > 0.5 * moment_history[k - 3];
    bool at_floor = false;
    if (ev.r_force <= floor_force_ && (ev.r_moment <= floor_moment_ || moment_stalled)) {
      increment_ok = true;
      at_floor = !residual_ok || moment_stalled;
      residual_ok = true;
    }
    if (residual_ok && increment_ok) {
      report.iterations = iter;
      report.closing_iterations = closing_iterates;
      // Accepted at the round-off floor rather than within the tolerance asked.
      report.at_floor = at_floor && (ev.r_force > step.tol_force * ev.ref_force ||
                                     ev.r_moment > step.tol_force * ev.ref_moment);
      report.floor_relative = std::max(ev.r_force / std::max(ev.ref_force, floor_force_),
                                       ev.r_moment / std::max(ev.ref_moment, floor_moment_));
      // Reactions: residual at constrained DOFs; moments from r_alpha = Xi^T m.
      const std::vector<int>& eq = assembler_->equations();
      reactions_.setZero();
      for (int i = 0; i < n; ++i)
        for (int c = 0; c < 6; ++c)
          if (eq[6 * i + c] < 0)
            reactions_(c, i) = residual(6 * i + c);
      for (int i = 0; i < n; ++i)
        if (reactions_.col(i).tail<3>().squaredNorm() > 0)
          reactions_.col(i).tail<3>() = rodrigues_xi<double>(state_.alpha.col(i))
                                            .transpose()
                                            .partialPivLu()
                                            .solve(Eigen::Vector3d(reactions_.col(i).tail<3>()));
      return {};
    }
    if (iter - closing_iterates >= step.max_iterations || iter == iteration_bound)
      return fmt::format("no convergence in {} iterations{} (relative residual {:.3e}); worst: "
                         "node {} DOF {}{}",
                         iter,
                         closing_iterates > 0
                             ? fmt::format(", {} of them closing crossings", closing_iterates)
                             : std::string(),
                         ev.relative, model_.node_label(worst_dof >= 0 ? worst_dof / 6 : 0),
                         worst_dof >= 0 ? dof_name(worst_dof % 6) : "-",
                         worst_dof >= 0 ? on_spline(model_, worst_dof / 6) : "");
    // Stick and slip that Newton does not settle: with the same number of active pairs over the
    // last three iterates (the closings done; the pairs' fingerprint, active_set, changes also
    // where a point passes a knot to the next pair), the residual and the number of slipping points
    // both grew at each of the last two. Traced on the frictional 48 x 48 weave's toe, such
    // attempts went on growing to the iteration limit (docs/performance.md, "Stick and slip that do
    // not settle"); they are cut here and the step halved as at the limit. Abaqus's time
    // incrementation control cuts after 4 iterations where the residual grows twice running;
    // without the slip's growth, that also cuts frictionless weaves' toe increments that converge.
    if (contact_)
      contact_history.push_back({contact_->summary().active, contact_->summary().slip});
    if (options_.stick_slip_check && iter >= 4 && contact_history.size() >= 3) {
      const std::size_t m = contact_history.size();
      const std::vector<double>& r = report.residual_history;
      const std::size_t k = r.size();
      const auto& [a0, s0] = contact_history[m - 3];
      const auto& [a1, s1] = contact_history[m - 2];
      const auto& [a2, s2] = contact_history[m - 1];
      if (a0 == a1 && a1 == a2 && s0 < s1 && s1 < s2 && r[k - 3] < r[k - 2] && r[k - 2] < r[k - 1])
        return fmt::format("stick and slip not settling after {} iterations: the relative "
                           "residual grew twice running ({:.3e}, {:.3e}, {:.3e}) with the "
                           "slipping points ({}, {}, {} of {} active)",
                           iter, r[k - 3], r[k - 2], r[k - 1], s0, s1, s2, a2);
    }
    if (iter > 2 && ev.relative > 1e8 * report.residual_history.front())
      return fmt::format("Newton diverged (residual grew from {:.3e} to {:.3e}); worst: node {} "
                         "DOF {}{}",
                         report.residual_history.front(), ev.relative,
                         model_.node_label(worst_dof / 6), dof_name(worst_dof % 6),
                         on_spline(model_, worst_dof / 6));

    // The converged state's tangent for the first correction (above): evaluated there, kept
    // where its active set is the predictor's; the predictor is evaluated again otherwise. The
    // predictor is the converged state with the prescribed values at t_new, made again.
    bool from_converged = false; // the correction comes from the converged state's tangent
    if (first_from_converged) {
      first_from_converged = false;
      const Eigen::VectorXd rhs_at_predictor = rhs_;
      state_.x = state_.x_n;
      state_.alpha.setZero();
      const Evaluation at_converged = evaluate(step, nm, t_new, true, residual);
      const std::uint64_t converged_set = contact_ ? contact_->summary().active_set : 0;
      const bool same_contacts = at_converged.veto.empty() && converged_set == active_set;
      from_converged = same_contacts;
      predict(t_new, dt);
      if (secant_trial_) {
        report.ends_residual = ev.relative;
        if (!(same_contacts && secant_active_set_ == active_set)) {
          // A predictor's first correction would not come from the converged state's tangent:
          // the smaller residual at the predictors decides (choose_predictor), and where that
          // is the secant's the attempt starts again from it, its first correction from the
          // converged state's tangent where it has its contacts, from its own otherwise
          // (evaluated at once, not after the converged state again).
          secant_trial_ = false;
          if (secant_at_predictor_.relative < ev.relative) {
            secant_chosen_ = true;
            if (contact_)
              contact_->begin_attempt();
            predict(t_new, dt);
            report.residual_history.clear();
            moment_history.clear();
            scaled_history.clear();
            residual_scale_force = residual_scale_moment = 0;
            first_from_converged = at_converged.veto.empty() && secant_active_set_ == converged_set;
            --iter;
            continue;
          }
        }
      }
      if (!same_contacts) {
        const Evaluation again = evaluate(step, nm, t_new, true, residual);
        if (!again.veto.empty())
          return again.veto;
      }
      rhs_ = rhs_at_predictor;
      if (secant_trial_) {
        // A tension test's predictors compared after their first corrections
        // (choose_predictor; docs/performance.md, "The predictor chosen after its first
        // correction"): the held secant's and the ends' corrections, both from the converged
        // state's tangent (factorised once) and limited from its evaluation, each applied and
        // evaluated (without the tangent, the attempt's anchors dropped before each). The
        // shorter simplified Newton correction there (one more solve with that factorisation,
        // in the scaled norm: the corrected point's distance from the solution, to first
        // order) wins, and its correction is this iteration's. (The smaller residual chose the
        // secant on the uniaxial test whose next iterate then lost quadratic convergence:
        // docs/performance.md, "The secant's rotations".)
        if (std::string why = factorize_tangent(); !why.empty())
          return why;
        auto tick = std::chrono::steady_clock::now();
        Eigen::VectorXd ends_delta = solver_->solve(rhs_);
        Eigen::VectorXd secant_delta = solver_->solve(secant_rhs_);
        lap_from(tick, stage_times_.solve);
        const CorrectionLimit ends_limit = limit_correction(ends_delta, 1.0, true);
        secant_chosen_ = true;
        predict(t_new, dt);
        const CorrectionLimit secant_limit = limit_correction(secant_delta, 1.0, true);
        // The corrected point's relative residual and its simplified correction's scaled norm.
        const auto corrected = [&](bool secant, const Eigen::VectorXd& d, double l) {
          secant_chosen_ = secant;
          if (contact_)
            contact_->begin_attempt();
          predict(t_new, dt);
          if (options_.mixed_integration_point)
            start_mixed_stresses(d, true);
          move_along(d, l);
          const Evaluation e = evaluate(step, nm, t_new, false, residual);
          mixed_.active = false;
          constexpr double none = std::numeric_limits<double>::infinity();
          if (!e.veto.empty())
            return std::pair<double, double>{none, none};
          auto tick = std::chrono::steady_clock::now();
          const Eigen::VectorXd simplified = solver_->solve(rhs_);
          lap_from(tick, stage_times_.solve);
          return std::pair<double, double>{e.relative,
                                           simplified.allFinite() ? scaled_norm(simplified) : none};
        };
        std::tie(report.secant_corrected, report.secant_next_correction) =
            corrected(true, secant_delta, secant_limit.lambda);
        std::tie(report.ends_corrected, report.ends_next_correction) =
            corrected(false, ends_delta, ends_limit.lambda);
        secant_chosen_ = report.secant_next_correction < report.ends_next_correction;
        if (contact_)
          contact_->begin_attempt();
        predict(t_new, dt);
        if (secant_chosen_) {
          const Evaluation& at = secant_at_predictor_;
          rhs_ = secant_rhs_;
          report.residual_history.back() = at.relative;
          moment_history.back() = at.r_moment;
          scaled_residual =
              std::hypot(at.r_force / residual_scale_force, at.r_moment / residual_scale_moment);
          scaled_history.back() = scaled_residual;
        }
        chosen_correction = secant_chosen_ ? std::move(secant_delta) : std::move(ends_delta);
        chosen_limit = secant_chosen_ ? secant_limit : ends_limit;
      }
      secant_trial_ = false;
    }

    // The monotonicity test of the point reached along delta. Where the damping is on because
    // the step changed the active set (not because full steps stagnate), the point is also kept
    // where the residual fell as much as the test asks of the correction: a step that changes
    // contacts and takes the residual from 1e4 N to 10 N (a picture frame's increment) leaves a
    // next correction along the contacts it changed that need not be shorter, and moving back
    // towards the predictor's residual then cost the whole attempt. Stagnating full steps
    // (stick and slip cycling) keep the correction test alone: the residual test let them cycle
    // (the paper's k = 1 fabric with mu = 0.2: 287 against 462 iterations). judged: the point
    // x + lambda delta judged by a correction from it, 1 where it is kept, else the lambda to
    // move back to.
    // correction_norm: its scaled norm (infinite where it is not finite).
    const auto judged = [&](const Eigen::VectorXd& correction, double correction_norm) {
      if (correction_norm <= (1 - lambda / 4) * delta_norm ||
          (!stagnating && scaled_residual <= (1 - lambda / 4) * start_residual))
        return 1.0;
      const double h =
          std::isfinite(correction_norm)
              ? 2 * scaled_norm(correction - (1 - lambda) * delta) / (lambda * lambda * delta_norm)
              : std::numeric_limits<double>::infinity();
      return std::max(std::min(0.5 * lambda, 1 / h), 0.1 * lambda);
    };

    // Where a point moves back: along delta, and the next correction starts from min(1, 4 lambda).
    // Below kMinDamping the damping gives up for this attempt and Newton goes on with full steps
    // from the point reached (the iteration limit decides).
    const auto moved_back = [&](double back) {
      damping_gave_up = back < kMinDamping;
      if (back >= 1 || damping_gave_up)
        return false;
      move_along(delta, back - lambda);
      lambda = back;
      next_lambda = std::min(1.0, 4 * lambda);
      return true;
    };

    // The monotonicity test on the simplified correction (SimulationOptions::
    // simplified_monotonicity; NLEQ-ERR, Deuflhard 2004 sec. 3.3): where the damped step kept
    // the active set, the correction from the point reached with the tangent delta was solved
    // with (its factorisation still in hand: no rejected point factorised since), one solve where
    // the next correction costs a factorisation too. The same test and the same move back as the
    // next correction's below. Where the step changed the active set the tangent in hand lacks
    // the pairs it changed, and its simplified correction is no measure of the point
    // (docs/performance.md, "The simplified correction judges damped points").
    const bool simplified_test = options_.simplified_monotonicity && damping && !damping_gave_up &&
                                 chosen_correction.size() == 0 && start_factorised &&
                                 active_set == last_active_set;
    if (simplified_test) {
      auto tick = std::chrono::steady_clock::now();
      const Eigen::VectorXd simplified = solver_->solve(rhs_);
      lap_from(tick, stage_times_.solve);
      ++simplified_trials_;
      const double simplified_norm = simplified.allFinite()
                                         ? scaled_norm(simplified)
                                         : std::numeric_limits<double>::infinity();
      if (moved_back(judged(simplified, simplified_norm)))
        continue;
    }

    // Solve (the predictors' trial above solved the first correction already).
    Eigen::VectorXd next;
    if (chosen_correction.size() > 0) {
      next = std::move(chosen_correction);
      chosen_correction = Eigen::VectorXd();
    } else {
      if (std::string why = factorize_tangent(); !why.empty())
        return why;
      start_factorised = false;
      auto tick = std::chrono::steady_clock::now();
      next = solver_->solve(rhs_);
      lap_from(tick, stage_times_.solve);
    }
    if (!next.allFinite())
      return "the linear solve returned non-finite values";
    ++total_iterations_;
    const double next_norm = scaled_norm(next);

    // The next correction's test, where the simplified correction's did not judge the point.
    if (damping && !simplified_test && !damping_gave_up && moved_back(judged(next, next_norm)))
      continue;

    // Update with the new correction.
    last_active_set = active_set;
    start_factorised = true;
    start_residual = scaled_residual;
    delta = std::move(next);
    delta_norm = next_norm;
    report.energy_history.push_back(std::abs(delta.dot(rhs_)));
    lambda = options_.line_search && !damping_gave_up ? next_lambda : 1.0;
    next_lambda = 1;
    // The trial's limit where it chose the correction (from the contact's evaluation at its start).
    CorrectionLimit limit;
    if (chosen_limit.lambda >= 0) {
      limit = chosen_limit;
      limit.closing = limit.closing && limit.lambda < lambda;
      limit.lambda = std::min(lambda, limit.lambda);
      chosen_limit.lambda = -1;
    } else {
      limit = limit_correction(delta, lambda, from_converged);
    }
    lambda = limit.lambda;
    last_du = limit.du;
    last_da = limit.da;
    closing_cut = limit.closing;
    if (options_.mixed_integration_point)
      start_mixed_stresses(delta, from_converged);
    move_along(delta, lambda);
  }
  // The last iteration's iterate was vetoed and damped back (the loop's `continue`).
  return fmt::format("no convergence in {} iterations (the last iterates were vetoed: {})",
                     iteration_bound, last_veto);
}

void Simulation::commit(const SolutionStep& step, double dt, double t_new) {
  const int n = state_.n_nodes();
  const bool dynamic = step.type == StepType::Dynamic;
  const NewmarkCoefficients nm(step.newmark_beta, step.newmark_gamma, dt);

  // The nodes and elements are updated in parallel; the energies' terms are kept per node and
  // summed after, in node order, as one loop over the nodes would (the same bits on any thread
  // count). commit_terms_ (3 x n, J): external work, out-of-plane and mass-proportional damping.
  commit_terms_.setZero(3, n);

  // External work by the trapezoidal rule, with the loads before the nodes are updated.
  const Eigen::Matrix<double, 6, Eigen::Dynamic> load = external_loads(t_new);
  const std::vector<BeamReference>& refs = assembler_->references();
  if (step.secant_predictor || chooses_predictor()) {
    secant_motion_ = state_.x - state_.x_n;
    secant_rotation_.resize(3, n);
    for (int i = 0; i < n; ++i)
      secant_rotation_.col(i) = rotation_vector_of_rodrigues<double>(state_.alpha.col(i));
    secant_dt_ = dt;
    secant_step_ = step_;
    // The fraction of this motion at which the first open pair of the converged state (the
    // contact's last evaluation) would close past the closing allowance, to first order.
    secant_reach_ = std::numeric_limits<double>::infinity();
    if (contact_ && !step.secant_predictor)
      secant_reach_ = closing_limit(secant_motion_, nullptr);
  }
  tbb::parallel_for(std::size_t{0}, state_.gauss.size(), [&](std::size_t e) {
    state_.gauss[e] = beam_committed_history(refs[e], state_.gauss[e],
                                             assembler_->nodal_values(state_, static_cast<int>(e)));
  });
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 256), [&](const tbb::blocked_range<int>& range) {
    for (int i = range.begin(); i != range.end(); ++i) {
      const Eigen::Vector3d du = state_.x.col(i) - state_.x_n.col(i);
      const Eigen::Vector3d alpha = state_.alpha.col(i);
      const Eigen::Vector3d dtheta = rotation_vector_of_rodrigues<double>(alpha);
      commit_terms_(0, i) = 0.5 * (load.col(i) + load_n_.col(i)).head<3>().dot(du) +
                            0.5 * (load.col(i) + load_n_.col(i)).tail<3>().dot(dtheta);
      if (dynamic) {
        const Eigen::Vector3d a =
            nm.a1 * du - nm.a2 * state_.v_n.col(i) - nm.a3 * state_.a_n.col(i);
        const Eigen::Vector3d v =
            nm.a4 * du + nm.a5 * state_.v_n.col(i) + nm.a6 * state_.a_n.col(i);
        Eigen::Vector3d W, A;
        newmark_angular(nm, {state_.Q_n[i], state_.W_n.col(i), state_.A_n.col(i)}, alpha, W, A);
        // Energy dissipated by the mass-proportional damping c M, J: for translations the work
        // of the mean damping force over the increment, c m (v_n + v) / 2 . du, the quadrature
        // the external work uses (with the trapezoidal rule, beta = 1/4, the balance of the
        // discrete equations); for rotations its rate c W.J W (W the material angular
        // velocity, J the principal rotary inertias) by the trapezoidal rule. The
        // stiffness-proportional part is not counted. The out-of-plane damping's the same way,
        // on the z components alone.
        if (step.rayleigh_out_of_plane > 0)
          commit_terms_(1, i) =
              step.rayleigh_out_of_plane * 0.5 * mass_(i) * (state_.v_n(2, i) + v.z()) * du.z();
        if (step.rayleigh_mass > 0) {
          const Eigen::Vector3d& J = rotary_inertia_.col(i);
          const Eigen::Vector3d& W_n = state_.W_n.col(i);
          commit_terms_(2, i) =
              step.rayleigh_mass *
              (0.5 * mass_(i) * (state_.v_n.col(i) + v).dot(du) +
               0.5 * dt * (W_n.dot(J.cwiseProduct(W_n)) + W.dot(J.cwiseProduct(W))));
        }
        state_.v_n.col(i) = v;
        state_.a_n.col(i) = a;
        state_.W_n.col(i) = W;
        state_.A_n.col(i) = A;
      } else {
        state_.v_n.col(i).setZero();
        state_.a_n.col(i).setZero();
        state_.W_n.col(i).setZero();
        state_.A_n.col(i).setZero();
      }
      state_.Q_n[i] = orthonormalized(rodrigues_rotation<double>(alpha) * state_.Q_n[i]);
      state_.rotation_n.col(i) =
          unwrap_rotation(state_.Q_n[i] * Q0_[i].transpose(), state_.rotation_n.col(i));
    }
  });
  for (int i = 0; i < n; ++i)
    external_work_ += commit_terms_(0, i);
  if (dynamic)
    for (int i = 0; i < n; ++i) {
      if (step.rayleigh_out_of_plane > 0)
        damping_work_ += commit_terms_(1, i);
      if (step.rayleigh_mass > 0)
        damping_work_ += commit_terms_(2, i);
    }
  if (contact_) {
    contact_->commit();
    gather_contact(); // over several processes: the points and histories, for output
    // The pattern grows with every pair within reach an iteration meets, and attempts that
    // wandered (or failed) leave couplings the converged state does not need: with touching
    // yarns they grew the factor tenfold and each factorisation forty times slower
    // (docs/performance.md). Drop them when they are more than a quarter of what is needed.
    prune_couplings();
  }
  state_.x_n = state_.x;
  state_.alpha.setZero();
  state_.time = t_new;
  ++state_.increment;
  load_n_ = load;
}

std::string Simulation::off_end_text(const ContactSummary& s) const {
  if (s.off_end == 0)
    return {};
  const auto name = [&](int k) {
    return k >= 0 && k < static_cast<int>(model_.splines.size()) ? model_.splines[k].name
                                                                 : std::string("?");
  };
  return fmt::format("; {} contact point(s) that carried force in the last converged state have "
                     "passed the end of a yarn, closer to its continued centre line than the two "
                     "radii, and carry none now (the first: '{}' past the end of '{}'): a yarn "
                     "slid off the end of another",
                     s.off_end, name(s.off_end_yarns[0]), name(s.off_end_yarns[1]));
}

void Simulation::run(SimulationObserver* observer) {
  double t = state_.time;
  // A run continued from a checkpoint is balanced for the candidates it restored, as the run it
  // continues was after its last commit; a fresh run for those of its first configuration.
  if (const std::string balanced = rebalance(); !balanced.empty() && observer)
    observer->on_notice(*this, fmt::format("t = {:.6g} s: {}", t, balanced));
  // From the first step, or from where a checkpoint left off.
  for (; step_ < static_cast<int>(model_.steps.size()); ++step_, next_dt_ = 0) {
    const std::size_t s = step_;
    const SolutionStep& step = model_.steps[s];
    if (contact_)
      contact_->set_explicit_path(step.type == StepType::Explicit);
    if (step.type == StepType::Explicit) {
      run_explicit(static_cast<int>(s), observer);
      t = step.end_time;
      continue;
    }
    double dt = next_dt_ > 0 ? next_dt_ : std::min(step.dt_initial, step.dt_max);
    int failed = 0;
    while (t < step.end_time * (1 - 1e-12)) {
      if (stop_requested())
        throw_interrupted();
      // Land exactly on the end time; avoid a sliver of a last increment.
      double h = std::min(dt, step.end_time - t);
      if (step.end_time - (t + h) < 1e-3 * h)
        h = step.end_time - t;
      IncrementReport report;
      std::string why;
      try {
        why = attempt(step, t + h, h, report);
      } catch (const Interrupted&) {
        // The attempt in progress is dropped: the state is the last converged increment's.
        state_.x = state_.x_n;
        state_.alpha.setZero();
        throw;
      }
      if (!why.empty()) {
        if (contact_)
          why += off_end_text(contact_->summary());
        // Restore the converged state and halve; the candidates the failed attempt met go with it.
        state_.x = state_.x_n;
        state_.alpha.setZero();
        // The pattern keeps what the attempt coupled: the converged state's pairs are not
        // projected again here, and the next commit prunes it.
        if (contact_)
          contact_->update_candidates(state_);
        if (observer)
          observer->on_attempt_failed(*this, t + h, h, why);
        ++failed;
        dt = 0.5 * h;
        if (dt < step.dt_min * (1 - 1e-12))
          throw ConvergenceError(fmt::format(
              "step {} stopped at t = {:.6g} s: the time step {:.3e} s fell below the minimum "
              "{:.3e} s; last failure: {}",
              s + 1, t, dt, step.dt_min, why));
        continue;
      }
      commit(step, h, t + h);
      if (const std::string balanced = rebalance(); !balanced.empty() && observer)
        observer->on_notice(*this,
                            fmt::format("step {}, t = {:.6g} s: {}", s + 1, t + h, balanced));
      if (contact_ && !frictionless_reported_ && observer && contact_->summary().frictionless > 0) {
        frictionless_reported_ = true;
        observer->on_notice(
            *this,
            fmt::format("step {}, t = {:.6g} s: {} active contact point(s) of a contact with "
                        "friction lie on a degenerate path of the projection (the point contact "
                        "alone between nearly parallel segments, `line_contact = false`; or, "
                        "with surface contact, parallel axes, flat faces or ridges) and carry "
                        "no friction there; `line_contact = true` gives the spline contact "
                        "friction at every point (said once)",
                        s + 1, t + h, contact_->summary().frictionless));
      }
      if (contact_ && !off_end_reported_ && observer && contact_->summary().off_end > 0) {
        off_end_reported_ = true;
        observer->on_notice(*this, fmt::format("step {}, t = {:.6g} s{} (said once)", s + 1, t + h,
                                               off_end_text(contact_->summary())));
      }
      if (report.at_floor && !floor_reported_ && observer) {
        floor_reported_ = true;
        observer->on_notice(
            *this, fmt::format("step {}, t = {:.6g} s: the force tolerance {:.3g} asked is below "
                               "the round-off level of this model's residual (here {:.3g} "
                               "relative; floors {:.3g} N and {:.3g} N m, or a moment residual "
                               "that Newton no longer reduces); increments are accepted there "
                               "(said once)",
                               s + 1, t + h, step.tol_force, report.floor_relative, floor_force_,
                               floor_moment_));
      }
      t += h;
      report.step = static_cast<int>(s);
      report.increment = state_.increment;
      report.time = t;
      report.dt = h;
      report.failed_attempts = failed;
      failed = 0;
      // Grow after an easy increment; known before the observer, so that a checkpoint holds it.
      if (report.iterations <= std::max(2, step.max_iterations / 4))
        dt = std::min(1.5 * h, step.dt_max);
      else
        dt = h;
      next_dt_ = dt;
      if (observer)
        observer->on_increment(*this, report);
    }
    t = step.end_time;
  }
}

Eigen::Matrix<double, 6, Eigen::Dynamic> Simulation::section_resultants() const {
  const int ne = static_cast<int>(model_.elements.size());
  Eigen::Matrix<double, 6, Eigen::Dynamic> out(6, 2 * ne);
  for (int e = 0; e < ne; ++e)
    out.middleCols<2>(2 * e) = beam_section_resultants(assembler_->references()[e], state_.gauss[e],
                                                       assembler_->nodal_values(state_, e));
  return out;
}

double Simulation::kinetic_energy() const {
  double T = 0;
  for (int i = 0; i < state_.n_nodes(); ++i) {
    T += 0.5 * mass_(i) * state_.v_n.col(i).squaredNorm();
    T += 0.5 * state_.W_n.col(i).dot(rotary_inertia_.col(i).cwiseProduct(state_.W_n.col(i)));
  }
  return T;
}

double Simulation::strain_energy() const {
  double U = 0;
  for (int e = 0; e < static_cast<int>(model_.elements.size()); ++e)
    U += beam_strain_energy(assembler_->references()[e], state_.gauss[e],
                            assembler_->nodal_values(state_, e));
  return U;
}

Eigen::Vector3d Simulation::linear_momentum() const {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (int i = 0; i < state_.n_nodes(); ++i)
    p += mass_(i) * state_.v_n.col(i);
  return p;
}

Eigen::Vector3d Simulation::angular_momentum() const {
  Eigen::Vector3d L = Eigen::Vector3d::Zero();
  for (int i = 0; i < state_.n_nodes(); ++i) {
    L += state_.x_n.col(i).cross(mass_(i) * state_.v_n.col(i));
    L += state_.Q_n[i] * rotary_inertia_.col(i).cwiseProduct(state_.W_n.col(i));
  }
  return L;
}

std::string stage_times_report(const StageTimes& t, int iterations) {
  const double per = iterations > 0 ? 1e3 / iterations : 0.0;
  std::string out = fmt::format("stage times over {} Newton iterations (wall):\n", iterations);
  const auto row = [&](const char* name, double seconds) {
    out += fmt::format("  {:<40} {:9.3f} s {:9.3f} ms/iteration\n", name, seconds, per * seconds);
  };
  row("broad phase", t.broad_phase);
  row("narrow phase (contact kernels)", t.narrow_phase);
  row("beam assembly", t.beam_assembly);
  row("other assembly (contact, inertia, loads)", t.other_assembly);
  row("iteration graph (the above, in parallel)", t.iteration_graph);
  row("convergence check and symbolic analysis", t.convergence_check);
  row("factorisation", t.factorisation);
  row("solve", t.solve);
  const ExplicitStageTimes& e = t.explicit_path;
  if (e.increments == 0)
    return out;
  if (iterations == 0)
    out.clear();
  const double per_increment = 1e3 / static_cast<double>(e.increments);
  out += fmt::format("stage times over {} explicit increments (wall):\n", e.increments);
  const auto explicit_row = [&](const char* name, double seconds) {
    out += fmt::format("  {:<40} {:9.3f} s {:9.4f} ms/increment\n", name, seconds,
                       per_increment * seconds);
  };
  explicit_row("contact search (broad and narrow phase)", e.contact_search);
  explicit_row("beam forces", e.beam_forces);
  explicit_row("contact forces, loads, reactions", e.other_forces);
  explicit_row("sums over processes", e.sums);
  explicit_row("kicks, drift and commit", e.update);
  explicit_row("stable step and energy checks", e.stability);
  return out;
}

} // namespace yarnsim
