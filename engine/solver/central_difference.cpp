// The explicit path (formulation.md §3): central difference with the lumped translational mass and
// the lumped rotary inertia of Simulation, no tangent and no Newton iteration.
//
// Written in velocity-Verlet form, so velocities, energies and reactions are known at the end of
// every increment; the positions are those of the classical leapfrog. With f = f_ext - f_int -
// f_contact per node and h the step:
//   v_{n+1/2} = v_n + h/2 f_n/m, x_{n+1} = x_n + h v_{n+1/2}, v_{n+1} = v_{n+1/2} + h/2 f_{n+1}/m.
// Rotations follow each node's spatial angular momentum pi = Q J W (J the material rotary inertia,
// W the material angular velocity): Euler's equations J W' + W x J W = Q^T m are pi' = m, with m
// = m_ext - m_int the spatial moment, so
//   pi_{n+1/2} = pi_n + h/2 m_n,  Q_{n+1} = exp(h omega) Q_n,  pi_{n+1} = pi_{n+1/2} + h/2 m_{n+1},
// where omega, the spatial angular velocity of the step, carries pi_{n+1/2} through the midpoint
// triad Q_{n+1/2} = exp(h/2 omega) Q_n: Q_{n+1/2} J Q_{n+1/2}^T omega = pi_{n+1/2} (a fixed point
// per node). The update is symmetric in time, and linear and angular momentum change by h sum f and
// h sum (x x f + m), which vanish for the internal and contact forces: without loads both momenta
// are conserved to round-off.
//
// The internal moments come from the beam residual conjugate to the Rodrigues parameters alpha,
// r_alpha = Xi(alpha)^T m: every force evaluation is at a committed state with alpha = 0, where
// Xi = I and r_alpha = m. The Gauss-point histories are committed with alpha = the Rodrigues
// parameters of the step's rotation increment exp(h omega), as Simulation::commit does.
//
// Stable step: omega_max^2 of the assembled system is at most the largest element value
// lambda_max(M_e^-1 K_e), M_e the element's share of the lumped mass and rotary inertia (1/6, 2/3,
// 1/6) (Irons' element eigenvalue bound; Flanagan and Belytschko 1981), which covers the axial,
// shear, bending, torsion and rotary modes of the 3-node element, plus a contact term
// eps (1/m_A + 1/m_B) (Weyl's inequality); critical step 2 / omega_max, reduced by stiffness
// damping to (2 / omega)(sqrt(1 + xi^2) - xi), xi = b omega / 2 (Belytschko, Liu and Moran,
// "Nonlinear finite elements for continua and structures", §6.2).
//
// Mass scaling to a target step multiplies each element's mass and rotary inertia by the factor
// that brings its lambda_max down to what the target leaves after the contact term (which itself
// falls as the nodes get heavier), so the whole estimate, contact included, reaches the target.

#include "engine/solver/simulation.hpp"

#include "contact/torsional_friction.hpp"
#include "engine/math/rotation.hpp"
#include "engine/solver/checkpoint.hpp"
#include "engine/solver/distributed.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <numbers>
#include <string>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <vector>

namespace yarnsim {

namespace {

constexpr double kLump[3] = {1.0 / 6.0, 2.0 / 3.0, 1.0 / 6.0};

/// omega with [I omega]_c = pi_c on the free components c and omega_c = 0 on the others, for the
/// spatial inertia I = Q diag(J) Q^T.
Eigen::Vector3d solve_free(const Eigen::Matrix3d& Q, const Eigen::Vector3d& J,
                           const Eigen::Vector3d& pi, const std::array<bool, 3>& free) {
  if (free[0] && free[1] && free[2])
    return Q * (Q.transpose() * pi).cwiseQuotient(J);
  Eigen::Matrix3d I = Q * J.asDiagonal() * Q.transpose();
  Eigen::Vector3d b = pi;
  for (int c = 0; c < 3; ++c)
    if (!free[c]) {
      I.row(c).setZero();
      I.col(c).setZero();
      I(c, c) = 1;
      b(c) = 0;
    }
  return I.ldlt().solve(b);
}

/// v rotated by the rotation vector theta (Rodrigues' formula; 1 - cos a as 2 sin^2(a/2)).
Eigen::Vector3d rotated(const Eigen::Vector3d& v, const Eigen::Vector3d& theta) {
  const double a = theta.norm();
  if (a < 1e-300)
    return v;
  const Eigen::Vector3d k = theta / a;
  const double s = std::sin(0.5 * a);
  return v + std::sin(a) * k.cross(v) + (2 * s * s) * k.cross(k.cross(v));
}

/// The spatial angular velocity omega of a step h that carries the spatial angular momentum pi
/// through the midpoint triad exp(h/2 omega) Q_n. Fixed-point iteration (its rate is about
/// h |omega|) from omega; false when it does not converge.
bool midpoint_angular_velocity(const Eigen::Matrix3d& Q_n, const Eigen::Vector3d& J,
                               const Eigen::Vector3d& pi, const std::array<bool, 3>& free, double h,
                               Eigen::Vector3d& omega) {
  if (!free[0] && !free[1] && !free[2]) {
    omega.setZero();
    return true;
  }
  if (free[0] && free[1] && free[2]) {
    // R = exp(h/2 omega) leaves omega fixed, so (R Q_n) J (R Q_n)^T omega = R (Q_n J Q_n^T) omega
    // and the fixed point is omega = Q_n J^-1 Q_n^T R(omega)^T pi: one rotation of a vector per
    // iteration instead of a rotation matrix and a triad product.
    for (int it = 0; it < 50; ++it) {
      const Eigen::Vector3d next =
          Q_n * (Q_n.transpose() * rotated(pi, -0.5 * h * omega)).cwiseQuotient(J);
      const double change = (next - omega).norm();
      omega = next;
      if (!std::isfinite(change))
        return false;
      if (change <= 1e-14 * omega.norm())
        return true;
    }
    return false;
  }
  for (int it = 0; it < 50; ++it) {
    const Eigen::Vector3d next = solve_free(rotation_matrix(0.5 * h * omega) * Q_n, J, pi, free);
    const double change = (next - omega).norm();
    omega = next;
    if (!std::isfinite(change))
      return false;
    if (change <= 1e-14 * omega.norm())
      return true;
  }
  return false;
}

/// Unwrapped rotation vector: the representative of R closest to the previous value (as
/// Simulation::commit keeps it).
Eigen::Vector3d unwrap_rotation(const Eigen::Matrix3d& R, const Eigen::Vector3d& previous) {
  const Eigen::Vector3d v = rotation_vector(R);
  const double angle = v.norm();
  if (angle < 1e-12)
    return previous.norm() < std::numbers::pi ? v : previous;
  const Eigen::Vector3d e = v / angle;
  const double k = std::round((previous.dot(e) - angle) / (2 * std::numbers::pi));
  return (angle + 2 * std::numbers::pi * k) * e;
}

/// One step of Bjorck's iteration towards the nearest rotation, Q (3 I - Q^T Q) / 2: applied at
/// every increment it holds a triad orthonormal to round-off at a fraction of an SVD's cost.
Eigen::Matrix3d polished(const Eigen::Matrix3d& Q) {
  return 0.5 * Q * (3 * Eigen::Matrix3d::Identity() - Q.transpose() * Q);
}

/// The Gauss-point histories after the increment with nodal values v is accepted: the update of
/// beam_committed_history (Pimenta's curvature update kappa_n <- Xi(alpha) alpha' + Q(alpha)
/// kappa_n, Q_n <- Q(alpha) Q_n, alpha and alpha' interpolated at the Gauss point), with the triad
/// held orthonormal by one Bjorck step per increment instead of an SVD: an explicit step's
/// rotation increments are small, so the drift it corrects is of round-off size.
void committed_history(const BeamReference& ref, const BeamNodalValues& v,
                       std::array<GaussState, 2>& history) {
  for (int g = 0; g < 2; ++g) {
    const Eigen::Vector3d alpha = v.alpha * ref.shape.col(g);
    const Eigen::Vector3d dalpha = v.alpha * ref.shape_derivative.col(g);
    const Eigen::Matrix3d Qa = rodrigues_rotation<double>(alpha);
    GaussState& h = history[g];
    h.kappa_n = rodrigues_xi<double>(alpha) * dalpha + Qa * h.kappa_n;
    h.Q_n = polished(Qa * h.Q_n);
  }
}

/// The torsional law of a crossing of two yarns of width w (m) under `friction`'s settings.
contact::TorsionalFriction torsional_law(const FrictionParameters& friction, double w) {
  return contact::torsional_law(friction.mu_static, friction.mu_kinetic,
                                friction.tangential_penalty, friction.torsional_radius,
                                friction.torsional_penalty, w, w);
}

/// Adds the wall time since `tick` to `total` (s) and moves `tick` to now.
void lap(std::chrono::steady_clock::time_point& tick, double& total) {
  const auto now = std::chrono::steady_clock::now();
  total += std::chrono::duration<double>(now - tick).count();
  tick = now;
}

/// Rate (1/s) and second rate (1/s^2) of a prescribed table at t by central differences over h.
double table_rate(const TimeTable& table, double t, double h) {
  return (table.at(t + h) - table.at(t - h)) / (2 * h);
}
double table_second_rate(const TimeTable& table, double t, double h) {
  return (table.at(t + h) - 2 * table.at(t) + table.at(t - h)) / (h * h);
}

} // namespace

/// Central-difference integration of one explicit step of a Simulation (see the top of the file).
class CentralDifference {
public:
  /// Stability of `step` at the simulation's current state with element mass factors `scale`
  /// (>= 1) and the nodal masses they give; omega2 receives each element's lambda_max (1/s^2).
  /// w2_contact receives the contact term of omega_max^2 (1/s^2).
  static ExplicitStatus estimate(const Simulation& sim, const SolutionStep& step,
                                 const std::vector<double>& scale, const Eigen::VectorXd& mass,
                                 std::vector<double>* omega2 = nullptr,
                                 double* w2_contact = nullptr);
  /// Element mass factors that bring every element's omega^2 down to omega2_budget (1/s^2),
  /// from the unscaled element values omega2.
  static std::vector<double> mass_scaling(double omega2_budget, const std::vector<double>& omega2);
  /// Lumped nodal mass and material rotary inertia with element mass factors.
  static void scaled_masses(const Simulation& sim, const std::vector<double>& scale,
                            Eigen::VectorXd& mass, Eigen::Matrix3Xd& rotary);
  /// Mass scaling to the step's mass_scaling_dt: element factors `scale` (all 1 without one),
  /// the masses they give and the stability with them, from the unscaled element values omega2
  /// and stability `plain`. The whole stable step, contact included, reaches the target: the
  /// elements' share of omega_t^2 = (2 safety / target)^2 is what the contact term leaves.
  static ExplicitStatus scale_to_target(const Simulation& sim, const SolutionStep& step,
                                        const ExplicitStatus& plain,
                                        const std::vector<double>& omega2,
                                        std::vector<double>& scale, Eigen::VectorXd& mass,
                                        Eigen::Matrix3Xd& rotary);
  /// Stability of `step` with the mass scaling it asks for, not applied to the simulation.
  static ExplicitStatus stability(const Simulation& sim, const SolutionStep& step);

  CentralDifference(Simulation& sim, int step_index);
  /// Integrates the step to its end time, or from where Simulation's checkpoint left it. Throws
  /// std::invalid_argument when the requested step exceeds the stable limit, ConvergenceError
  /// when the run cannot go on, Interrupted.
  void run(SimulationObserver* observer);
  /// What the next increment needs, for a checkpoint (between increments).
  ExplicitProgress progress() const;

private:
  /// Mass scaling, stable step, forces and energy balance at the start of the step, for a
  /// requested step dt.
  void start(double dt);
  /// Takes the place of start() when the run goes on from a checkpoint.
  void resume(const ExplicitProgress& p);
  void advance(double h, double t_new);
  /// Accepts the increment to t_new: work of the loads, Gauss-point histories with the rotation
  /// increments, triads, contact warm starts (Simulation::commit's bookkeeping, in parallel and
  /// with a cheaper re-orthonormalisation of the triads).
  void commit(double t_new);
  /// Forces and moments at the committed state at time t (alpha = 0), and the reactions; h is
  /// the step used for the prescribed tables' rates.
  void evaluate_forces(double t, double h);
  [[noreturn]] void fail(const std::string& why) const;
  /// Stops the run when the energy grows beyond what the loads and prescribed motions supplied.
  void check_energy(double energy, const char* what);
  /// Fails the run when the energy balance error exceeds kBalanceTolerance of the energy
  /// supplied (or dissipated, if more).
  void check_balance(const EnergyBalance& e) const;
  static constexpr double kBalanceTolerance = 0.05;
  /// Adds node_work_ to kick_work_ in node order.
  void collect_kick_work();
  /// Over several processes, each integrates its own nodes and commits its own elements'
  /// histories (partition.hpp): the owners' values of `fields` (each a column-major array of
  /// `width` values per node) on every process, an all-gather. Nothing on one process.
  void share_nodes(std::initializer_list<std::pair<double*, int>> fields);
  /// What the increments leave on the owners alone (triads, velocities, accelerations, rotation
  /// vectors, angular momenta and the Gauss-point histories), on every process: before output,
  /// checkpoints and energy balances, and at the step's end. Collective; nothing on one process.
  void share_state();
  /// The nodes, elements and exchange blocks of this process's share (Simulation::partition_,
  /// shares_): at the start, and where a balance moved the cuts (between increments, with the
  /// state whole on every process: share_state).
  void take_share();
  /// The kinetic energy of the state (J), and over several processes the sums of the
  /// processes' increments of the energy accumulators since `before` (kick work, damping,
  /// prescribed and external work, each counted over a process's own nodes).
  double settle_energies(const std::array<double, 4>& before);

  Simulation& sim_;
  const SolutionStep& step_;
  int index_;
  int n_;
  std::vector<const TimeTable*> prescribed_u_; ///< per translational DOF (3 node + c), or null
  std::vector<char> prescribed_r_;             ///< per node: rotation prescribed
  std::vector<double> scale_;                  ///< element mass factors
  ExplicitStatus status_;
  double dt_min_ = 0;
  double time_ = 0;
  // Net spatial force (N) and moment (N m) per node at the committed state, and the loads alone.
  Eigen::Matrix3Xd force_, moment_;
  Eigen::Matrix<double, 6, Eigen::Dynamic> loads_;
  Eigen::Matrix3Xd v_half_, omega_half_, pi_half_;     ///< of the step in progress
  Eigen::Matrix3Xd pi_;                                ///< spatial angular momentum, committed
  Eigen::VectorXd residual_, damped_, velocity_;       ///< 6 n_nodes
  Eigen::Matrix<double, 6, Eigen::Dynamic> increment_; ///< DOF increments of the step
  /// Per node: 1 no convergence, 2 too fast (doubles: shared with the positions, share_nodes).
  std::vector<double> bad_;
  // Energy guard. The work of the loads is taken as the velocity-Verlet kicks do it, h/2 f .
  // (v_before + v_after) / 2 per half kick, which is what the kinetic energy at whole steps
  // receives (the trapezoidal external_work lags it by the half kick still to come).
  double supplied_start_ = 0, supplied_max_ = 0, prescribed_start_ = 0, energy_floor_ = 0;
  double kick_work_ = 0;
  std::vector<double> node_work_; ///< per node, of the half kick in progress
  /// Per node, the change of the kinetic energy of its prescribed translations and rotations in
  /// the second half kick (J): the work that accelerated them.
  std::vector<double> prescribed_kinetic_;
  /// m a of each prescribed translation in the last evaluation (N; zero elsewhere): the part of
  /// the reactions whose work is counted as prescribed_kinetic_.
  Eigen::Matrix<double, 6, Eigen::Dynamic> inertia_;
  double h_target_ = 0; ///< s, the step size in use
  long count_ = 0;      ///< increments of this step
  double kinetic_ = 0;  ///< J, kinetic energy after the last increment
  // Over several processes: the nodes this process integrates [first_, last_), its own (every
  // node on one process), every process's range (empty on one process) and the elements whose
  // histories it commits (its own; all on one process).
  int first_ = 0, last_ = 0;
  std::vector<NodePartition> shares_;
  std::vector<int> own_elements_;
  std::vector<double> exchange_;      ///< packed node values of share_nodes
  std::vector<int> counts_, offsets_; ///< per process, its block of exchange_ (doubles)
  /// Whether every process holds the whole state: at the step's start, and after share_state()
  /// until the next increment.
  bool state_shared_ = true;
  /// Whether the processes' contact pairs read other processes' triads (the surface contact's
  /// sections), which are then shared at every increment; else only with share_state.
  bool triads_each_increment_ = false;
};

ExplicitStatus CentralDifference::estimate(const Simulation& sim, const SolutionStep& step,
                                           const std::vector<double>& scale,
                                           const Eigen::VectorXd& mass,
                                           std::vector<double>* omega2_out,
                                           double* w2_contact_out) {
  const Model& model = sim.model_;
  const State& state = sim.state_;
  const Assembler& assembler = *sim.assembler_;
  const int ne = static_cast<int>(model.elements.size());
  // Over several processes each takes its own elements (those whose nodes it owns) and the sum
  // of the processes' values, one non-zero per element, is exact.
  const NodePartition* owned = sim.partition_ ? &*sim.partition_ : nullptr;
  std::vector<double> omega2(ne, 0.0);
  tbb::parallel_for(tbb::blocked_range<int>(0, ne, 16), [&](const tbb::blocked_range<int>& r) {
    ElementVector f;
    ElementMatrix K, D;
    for (int e = r.begin(); e != r.end(); ++e) {
      const BeamElement& el = model.elements[e];
      if (owned && !owned->owns(el.nodes[0]))
        continue;
      const Section& sec = model.sections[el.section];
      const BeamReference& ref = assembler.references()[e];
      beam_internal_force(ref, state.gauss[e], assembler.nodal_values(state, e), f, &K);
      // D = M_e^(-1/2): the element's share of each node's mass, rotary inertia in the node's
      // material frame. Constrained DOFs do not move: their rows and columns of K drop out.
      const double length = ref.weight.sum();
      D.setZero();
      for (int i = 0; i < 3; ++i) {
        const int node = el.nodes[i];
        double m = scale[e] * sec.rhoA * length * kLump[i];
        if (!(m > 0))
          m = mass(node); // a massless section: the node's mass from its other elements
        if (m > 0)
          D.block<3, 3>(6 * i, 6 * i) = Eigen::Matrix3d::Identity() / std::sqrt(m);
        const Eigen::Vector3d J = scale[e] * sec.rhoJ * length * kLump[i];
        Eigen::Vector3d inv_sqrt;
        for (int c = 0; c < 3; ++c)
          inv_sqrt(c) = J(c) > 0 ? 1 / std::sqrt(J(c)) : 0.0;
        const Eigen::Matrix3d& Q = state.Q_n[node];
        D.block<3, 3>(6 * i + 3, 6 * i + 3) = Q * inv_sqrt.asDiagonal() * Q.transpose();
        for (int c = 0; c < 6; ++c)
          if (assembler.equation(6 * node + c) < 0) {
            K.row(6 * i + c).setZero();
            K.col(6 * i + c).setZero();
          }
      }
      ElementMatrix A = D * K * D;
      A = 0.5 * (A + A.transpose()).eval();
      const Eigen::SelfAdjointEigenSolver<ElementMatrix> eig(A, Eigen::EigenvaluesOnly);
      omega2[e] = std::max(0.0, eig.eigenvalues().maxCoeff());
    }
  });
  if (owned)
    distributed::sum(omega2.data(), omega2.size());

  ExplicitStatus status;
  double w2_beam = 0;
  int worst = -1;
  for (int e = 0; e < ne; ++e)
    if (omega2[e] > w2_beam) {
      w2_beam = omega2[e];
      worst = e;
    }

  // Contact: each definition's law stiffness (linear: eps; power law: its slope at twice the
  // deepest penetration, at least a tenth of the smallest radius) between the lightest moving
  // nodes of its two sides. Over all pairs the definition could make, not only the current
  // candidates, so a contact that closes between two estimates is covered.
  double w2_contact = 0;
  std::string contact_name;
  if (sim.contact_) {
    // Lightest moving node of a group of splines, and the group's smallest radius (m).
    auto lightest = [&](const std::vector<int>& splines, double& radius) {
      double m = std::numeric_limits<double>::infinity();
      for (int c : splines) {
        radius = std::min(radius, model.splines[c].radius);
        for (int node : model.splines[c].nodes) {
          bool moves = false;
          for (int k = 0; k < 3; ++k)
            moves = moves || assembler.equation(6 * node + k) >= 0;
          if (moves && mass(node) > 0)
            m = std::min(m, mass(node));
        }
      }
      return m;
    };
    // Friction adds the tangential penalty in the contact plane (the point's stiffness is
    // k_n n n^T + eps_t (I - n n^T), of largest eigenvalue max(k_n, eps_t)) and the torsional
    // penalty k_r on the crossing angle, which a control point turns by up to |dx| / h for a
    // segment of chord h: k_r / h^2 more (Weyl's inequality again).
    auto consider = [&](const std::string& name, const InterfaceLawParameters& law,
                        const FrictionParameters& friction, double m_a, double m_b, double r_min,
                        double torsion_per_m2) {
      if (friction.elastic_slip > 0)
        throw std::invalid_argument(fmt::format(
            "contact '{}': elastic_slip is not available on the explicit path (its stable step "
            "needs a constant stick stiffness: give a tangential_penalty)",
            name));
      const double p = std::max(2 * sim.contact_->max_penetration(), 0.1 * r_min);
      double k = law.penalty * law.exponent * std::pow(p, law.exponent - 1);
      if (friction.active())
        k = std::max(k, friction.tangential_penalty) + torsion_per_m2;
      const double w2 = k * (1 / m_a + 1 / m_b);
      if (w2 > w2_contact) {
        w2_contact = w2;
        contact_name = name;
      }
    };
    for (const SplineContactDefinition& def : model.spline_contacts) {
      double r_min = std::numeric_limits<double>::infinity();
      double m_a = lightest(def.group_a, r_min);
      double m_b = lightest(def.group_b, r_min);
      if (def.self_contact) // pairs within a group too
        m_a = m_b = std::min(m_a, m_b);
      if (def.radius > 0) // the definition's radius stands for its splines'
        r_min = def.radius;
      double torsion = 0; // k_r / h^2 over the shortest segment chord h, N/m
      if (def.friction.active() && def.friction.torsional) {
        double h = std::numeric_limits<double>::infinity(), w = 0;
        for (const std::vector<int>* group : {&def.group_a, &def.group_b})
          for (int c : *group) {
            const Spline& spline = model.splines[c];
            w = std::max(w, spline.width > 0 ? spline.width : 2 * spline.radius);
            for (std::size_t k = 1; k < spline.nodes.size(); ++k)
              h = std::min(
                  h, (model.nodes[spline.nodes[k]] - model.nodes[spline.nodes[k - 1]]).norm());
          }
        // The contact set's law for the widest pair (the largest rho and k_r).
        const double k_r = torsional_law(def.friction, w).k_r();
        if (h > 0 && std::isfinite(h))
          torsion = k_r / (h * h);
      }
      consider(def.name, def.law, def.friction, m_a, m_b, r_min, torsion);
    }
    // Surfaces: the contact force also acts at up to the section's reach from the axis, which
    // twists the end nodes about the yarn axis (rotary inertia J_3 = rho (I1 + I2) per length,
    // lumped): each side adds the larger of 1/m and reach^2 / J_3 of its moving end nodes.
    for (const SurfaceContactDefinition& def : model.surface_contacts) {
      double r_min = std::numeric_limits<double>::infinity();
      double flexibility[2] = {0, 0}; // 1/kg per side
      for (int side = 0; side < 2; ++side)
        for (int s : side == 0 ? def.group_a : def.group_b) {
          const Surface& surface = model.surfaces[s];
          const double reach = std::max(surface.a, surface.b);
          r_min = std::min(r_min, std::min(surface.a, surface.b));
          for (int e : surface.elements)
            for (int node : {model.elements[e].nodes[0], model.elements[e].nodes[2]}) {
              bool moves = false;
              for (int k = 0; k < 6; ++k)
                moves = moves || assembler.equation(6 * node + k) >= 0;
              if (!moves || !(mass(node) > 0))
                continue;
              const double J3 = sim.rotary_inertia_(2, node);
              flexibility[side] =
                  std::max({flexibility[side], 1 / mass(node), J3 > 0 ? reach * reach / J3 : 0.0});
            }
        }
      // Torsional friction: k_r on the crossing angle, which a node turns by up to |dx| / h
      // (h the shortest element) or a section by its rotation (a force at the reach).
      double torsion = 0;
      if (def.friction.active() && def.friction.torsional) {
        double h = std::numeric_limits<double>::infinity(), w = 0, reach = 0;
        for (const std::vector<int>* group : {&def.group_a, &def.group_b})
          for (int g : *group) {
            const Surface& surface = model.surfaces[g];
            w = std::max(w, 2 * surface.a);
            reach = std::max({reach, surface.a, surface.b});
            for (int e : surface.elements)
              h = std::min(h, (model.nodes[model.elements[e].nodes[2]] -
                               model.nodes[model.elements[e].nodes[0]])
                                  .norm());
          }
        const double k_r = torsional_law(def.friction, w).k_r();
        const double lever = std::min(h, reach);
        if (lever > 0 && std::isfinite(lever))
          torsion = k_r / (lever * lever);
      }
      if (flexibility[0] > 0 && flexibility[1] > 0)
        consider(def.name, def.law, def.friction, 1 / flexibility[0], 1 / flexibility[1], r_min,
                 torsion);
    }
  }

  const double omega = std::sqrt(w2_beam + w2_contact);
  status.critical_dt = omega > 0 ? 2 / omega : std::numeric_limits<double>::infinity();
  if (step.rayleigh_stiffness > 0 && omega > 0) {
    const double xi = 0.5 * step.rayleigh_stiffness * omega;
    status.critical_dt *= std::sqrt(1 + xi * xi) - xi;
  }
  status.stable_dt = step.safety_factor * status.critical_dt;
  status.limited_by = w2_contact > w2_beam ? fmt::format("contact '{}'", contact_name)
                      : worst >= 0         ? fmt::format("element {}", worst + 1)
                                           : std::string("nothing");
  if (omega2_out)
    *omega2_out = std::move(omega2);
  if (w2_contact_out)
    *w2_contact_out = w2_contact;
  return status;
}

std::vector<double> CentralDifference::mass_scaling(double omega2_budget,
                                                    const std::vector<double>& omega2) {
  // An element's omega^2 falls by the factor its mass and rotary inertia are multiplied by.
  std::vector<double> scale(omega2.size(), 1.0);
  for (std::size_t e = 0; e < omega2.size(); ++e)
    scale[e] = std::max(1.0, omega2[e] / omega2_budget);
  return scale;
}

ExplicitStatus CentralDifference::scale_to_target(const Simulation& sim, const SolutionStep& step,
                                                  const ExplicitStatus& plain,
                                                  const std::vector<double>& omega2,
                                                  std::vector<double>& scale, Eigen::VectorXd& mass,
                                                  Eigen::Matrix3Xd& rotary) {
  scale.assign(omega2.size(), 1.0);
  mass = sim.mass_;
  rotary = sim.rotary_inertia_;
  const double target = step.mass_scaling_dt;
  if (!(target > 0) || plain.stable_dt >= target)
    return plain;
  // safety * 2 / omega >= target once omega^2 <= omega_t^2. First the elements alone; then, as
  // long as the contact term (which falls as the nodes get heavier) keeps the whole below the
  // target, the elements get what it leaves, at least a quarter.
  // With stiffness damping b the critical step is (2 / omega)(sqrt(1 + xi^2) - xi), xi =
  // b omega / 2 (estimate()), which equals h = target / safety where omega^2 = 1 / (h^2 / 4 +
  // b h / 2): the budget falls with b, else the scaled step would stay below the target.
  const double b = step.rayleigh_stiffness;
  const double h = target / step.safety_factor;
  const double omega_t2 =
      b > 0 ? 1 / (0.25 * h * h + 0.5 * b * h) : std::pow(2 * step.safety_factor / target, 2);
  double budget = omega_t2;
  ExplicitStatus status = plain;
  for (int pass = 0; pass < 4; ++pass) {
    scale = mass_scaling(budget, omega2);
    scaled_masses(sim, scale, mass, rotary);
    double w2_contact = 0;
    status = estimate(sim, step, scale, mass, nullptr, &w2_contact);
    if (status.stable_dt >= target * (1 - 1e-12) || w2_contact <= 0)
      break;
    budget = std::min(budget, std::max(omega_t2 - w2_contact, 0.25 * omega_t2));
  }
  status.added_mass = mass.sum() - sim.mass_.sum();
  status.added_mass_percent = 100 * status.added_mass / sim.mass_.sum();
  status.added_rotary_percent =
      100 * (rotary.sum() - sim.rotary_inertia_.sum()) / sim.rotary_inertia_.sum();
  return status;
}

void CentralDifference::scaled_masses(const Simulation& sim, const std::vector<double>& scale,
                                      Eigen::VectorXd& mass, Eigen::Matrix3Xd& rotary) {
  const Model& model = sim.model_;
  mass = Eigen::VectorXd::Zero(sim.state_.n_nodes());
  rotary = Eigen::Matrix3Xd::Zero(3, sim.state_.n_nodes());
  // Same order of summation as the Simulation's constructor.
  for (std::size_t e = 0; e < model.elements.size(); ++e) {
    const BeamElement& el = model.elements[e];
    const Section& s = model.sections[el.section];
    const double length = sim.assembler_->references()[e].weight.sum();
    for (int i = 0; i < 3; ++i) {
      mass(el.nodes[i]) += scale[e] * (s.rhoA * length * kLump[i]);
      rotary.col(el.nodes[i]) += scale[e] * (s.rhoJ * length * kLump[i]);
    }
  }
}

ExplicitStatus CentralDifference::stability(const Simulation& sim, const SolutionStep& step) {
  const std::vector<double> ones(sim.model_.elements.size(), 1.0);
  std::vector<double> omega2, scale;
  const ExplicitStatus plain = estimate(sim, step, ones, sim.mass_, &omega2);
  Eigen::VectorXd mass;
  Eigen::Matrix3Xd rotary;
  return scale_to_target(sim, step, plain, omega2, scale, mass, rotary);
}

CentralDifference::CentralDifference(Simulation& sim, int step_index)
    : sim_(sim), step_(sim.model_.steps[step_index]), index_(step_index), n_(sim.state_.n_nodes()) {
  prescribed_u_.assign(3 * n_, nullptr);
  for (const Simulation::PrescribedDisplacement& p : sim.prescribed_u_)
    prescribed_u_[3 * p.node + p.component] = p.table;
  prescribed_r_.assign(n_, 0);
  for (const Simulation::PrescribedRotation& p : sim.prescribed_r_)
    prescribed_r_[p.node] = 1;
  force_ = moment_ = v_half_ = omega_half_ = pi_half_ = pi_ = Eigen::Matrix3Xd::Zero(3, n_);
  residual_ = damped_ = velocity_ = Eigen::VectorXd::Zero(6 * n_);
  increment_ = inertia_ = Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, n_);
  bad_.assign(n_, 0.0);
  node_work_.assign(n_, 0.0);
  prescribed_kinetic_.assign(n_, 0.0);
  triads_each_increment_ = sim.partition_ && sim.contact_ && sim.contact_->reads_triads();
  take_share();
}

void CentralDifference::take_share() {
  first_ = 0;
  last_ = n_;
  if (sim_.partition_) {
    first_ = sim_.partition_->first;
    last_ = sim_.partition_->last;
    shares_ = sim_.shares_;
    counts_.resize(shares_.size());
    offsets_.resize(shares_.size());
  }
  own_elements_.clear();
  for (int e = 0; e < static_cast<int>(sim_.model_.elements.size()); ++e)
    if (!sim_.partition_ || sim_.partition_->owns(sim_.model_.elements[e].nodes[0]))
      own_elements_.push_back(e);
}

void CentralDifference::share_nodes(std::initializer_list<std::pair<double*, int>> fields) {
  if (shares_.empty())
    return;
  int width = 0;
  for (const auto& f : fields)
    width += f.second;
  exchange_.resize(static_cast<std::size_t>(width) * n_);
  const auto pack = [&](int i, bool in) {
    double* slot = exchange_.data() + static_cast<std::size_t>(width) * i;
    for (const auto& [data, w] : fields) {
      double* column = data + static_cast<std::size_t>(w) * i;
      if (in)
        std::copy(column, column + w, slot);
      else
        std::copy(slot, slot + w, column);
      slot += w;
    }
  };
  for (int i = first_; i < last_; ++i)
    pack(i, true);
  for (std::size_t r = 0; r < shares_.size(); ++r) {
    counts_[r] = width * (shares_[r].last - shares_[r].first);
    offsets_[r] = width * shares_[r].first;
  }
  distributed::share_blocks(exchange_.data(), counts_, offsets_);
  for (int i = 0; i < n_; ++i)
    if (i < first_ || i >= last_)
      pack(i, false);
}

void CentralDifference::share_state() {
  if (shares_.empty() || state_shared_)
    return;
  state_shared_ = true;
  State& st = sim_.state_;
  share_nodes({{st.Q_n.data()->data(), 9},
               {st.v_n.data(), 3},
               {st.W_n.data(), 3},
               {st.a_n.data(), 3},
               {st.A_n.data(), 3},
               {st.rotation_n.data(), 3},
               {pi_.data(), 3},
               {v_half_.data(), 3},
               {omega_half_.data(), 3}});
  struct History {
    int element;
    std::array<GaussState, 2> gauss;
  };
  std::vector<History> own;
  own.reserve(own_elements_.size());
  for (int e : own_elements_)
    own.push_back({e, st.gauss[e]});
  for (const History& h : distributed::gather(own))
    st.gauss[h.element] = h.gauss;
}

double CentralDifference::settle_energies(const std::array<double, 4>& before) {
  const State& st = sim_.state_;
  if (shares_.empty())
    return sim_.kinetic_energy();
  // Each accumulator's increment over this process's nodes, the kinetic energies of its nodes.
  double sums[5] = {kick_work_ - before[0], sim_.damping_work_ - before[1],
                    sim_.prescribed_work_ - before[2], sim_.external_work_ - before[3], 0};
  for (int i = first_; i < last_; ++i) {
    const Eigen::Vector3d W = st.W_n.col(i);
    sums[4] += 0.5 * sim_.mass_(i) * st.v_n.col(i).squaredNorm() +
               0.5 * W.dot(sim_.rotary_inertia_.col(i).cwiseProduct(W));
  }
  distributed::sum(sums, 5);
  kick_work_ = before[0] + sums[0];
  sim_.damping_work_ = before[1] + sums[1];
  sim_.prescribed_work_ = before[2] + sums[2];
  sim_.external_work_ = before[3] + sums[3];
  return sums[4];
}

void CentralDifference::collect_kick_work() {
  for (double w : node_work_)
    kick_work_ += w;
}

void CentralDifference::fail(const std::string& why) const {
  throw ConvergenceError(fmt::format("step {} (explicit) stopped at t = {:.6g} s: {}; time step "
                                     "{:.4g} s, estimated stable limit {:.4g} s (set by {})",
                                     index_ + 1, time_, why, status_.dt, status_.stable_dt,
                                     status_.limited_by));
}

void CentralDifference::check_energy(double energy, const char* what) {
  // The energy a stable run holds stays within what was put in (its measure at whole steps
  // oscillates by up to (omega h / 2)^2 of the highest mode's share); an unstable one grows
  // geometrically.
  // (The kinetic energy that prescribed motions give their nodes is in the prescribed work.)
  const double supplied = supplied_start_ + kick_work_ + sim_.prescribed_work_ - prescribed_start_;
  supplied_max_ = std::max(supplied_max_, supplied);
  if (!std::isfinite(energy))
    fail(fmt::format("the {} energy is not finite: the integration is unstable", what));
  if (energy > 3 * supplied_max_ + energy_floor_)
    fail(fmt::format("the {} energy grew without bound ({:.4g} J against at most {:.4g} J supplied "
                     "by the loads and prescribed motions): the integration is unstable",
                     what, energy, supplied_max_));
}

void CentralDifference::check_balance(const EnergyBalance& e) const {
  // The balance error (energy held and dissipated, less the work put in) of a stable run with
  // forces that are potential or dissipative is the integrator's, a small fraction of the work
  // (docs/verification.md). Forces that are neither can feed a mode: the penalty friction's point
  // forces on a fabric rang in stick-slip while their slips "dissipated" more than the loads
  // supplied, until this path took the forces conjugate to the slips (docs/formulation.md,
  // "Friction on the explicit path"). Such a run is stopped, not carried on with an energy it
  // invented.
  const double supplied = std::max(supplied_max_, e.friction + e.damping);
  if (std::abs(e.error) > kBalanceTolerance * supplied + energy_floor_)
    fail(fmt::format("the energy balance is off by {:.4g} J, {:.3g} % of the {:.4g} J supplied "
                     "(kinetic {:.4g} J, strain {:.4g} J, contact {:.4g} J, dissipated by friction "
                     "{:.4g} J and by damping {:.4g} J): forces that neither store nor dissipate "
                     "energy are driving the motion{}",
                     e.error, 100 * std::abs(e.error) / supplied, supplied, e.kinetic, e.internal,
                     e.contact, e.friction, e.damping,
                     e.friction > 0 ? "; with friction, see docs/formulation.md, \"Friction on "
                                      "the explicit path\" (a lower tangential_penalty)"
                                    : ""));
}

void CentralDifference::evaluate_forces(double t, double h) {
  State& st = sim_.state_;
  const Assembler& assembler = *sim_.assembler_;
  ExplicitStageTimes& times = sim_.stage_times_.explicit_path;
  auto tick = std::chrono::steady_clock::now();
  // Over several processes each adds its own elements' and contact pairs' forces, and the sums
  // below give every process the whole of them: the nodes are then updated alike everywhere.
  const NodePartition* owned = sim_.partition_ ? &*sim_.partition_ : nullptr;
  residual_.setZero();
  sim_.assembler_->add_beams(st, residual_, false, {}, nullptr, owned);
  const double b = step_.rayleigh_stiffness;
  if (b > 0) {
    // Stiffness-proportional damping b K v with the velocity of the step just taken (lagged by
    // half a step, as explicit codes do).
    for (int i = 0; i < n_; ++i) {
      velocity_.segment<3>(6 * i) = v_half_.col(i);
      velocity_.segment<3>(6 * i + 3) = omega_half_.col(i);
    }
    damped_.setZero();
    sim_.assembler_->add_beams(st, damped_, false, StiffnessDamping{b, 0.0, &velocity_}, nullptr,
                               owned);
    damped_ -= residual_;
  }
  lap(tick, times.beam_forces);
  if (sim_.contact_)
    sim_.contact_->assemble(residual_, *sim_.assembler_, false);
  lap(tick, times.other_forces);
  if (owned) {
    distributed::sum(residual_.data(), residual_.size());
    if (b > 0)
      distributed::sum(damped_.data(), damped_.size());
    lap(tick, times.sums);
  }
  if (b > 0) {
    // Over several processes, this process's nodes: their velocities alone are current.
    const int from = 6 * first_, count = 6 * (last_ - first_);
    sim_.damping_work_ += h * damped_.segment(from, count).dot(velocity_.segment(from, count));
    residual_ += damped_;
  }
  loads_ = sim_.external_loads(t);
  for (int i = 0; i < n_; ++i) {
    force_.col(i) = loads_.col(i).head<3>() - residual_.segment<3>(6 * i);
    moment_.col(i) = loads_.col(i).tail<3>() - residual_.segment<3>(6 * i + 3);
  }
  // Reactions at constrained DOFs: internal minus external plus inertia of the prescribed
  // motion (rotary inertia of prescribed rotations left out), as the implicit path's residual.
  sim_.reactions_.setZero();
  for (int i = 0; i < n_; ++i)
    for (int c = 0; c < 6; ++c) {
      if (assembler.equation(6 * i + c) >= 0)
        continue;
      double r = -(c < 3 ? force_(c, i) : moment_(c - 3, i));
      inertia_(c, i) = 0;
      if (c < 3 && prescribed_u_[3 * i + c]) {
        inertia_(c, i) = sim_.mass_(i) * table_second_rate(*prescribed_u_[3 * i + c], t, h);
        r += inertia_(c, i) +
             sim_.mass_(i) * step_.rayleigh_mass * table_rate(*prescribed_u_[3 * i + c], t, h);
      }
      sim_.reactions_(c, i) = r;
    }
  lap(tick, times.other_forces);
}

void CentralDifference::advance(double h, double t_new) {
  State& st = sim_.state_;
  const Assembler& assembler = *sim_.assembler_;
  const double cm = step_.rayleigh_mass;
  const double keep = 1 - 0.5 * cm * h; // mass-proportional damping, first half of the step
  ExplicitStageTimes& times = sim_.stage_times_.explicit_path;
  auto tick = std::chrono::steady_clock::now();
  const std::array<double, 4> before{kick_work_, sim_.damping_work_, sim_.prescribed_work_,
                                     sim_.external_work_};

  // Half kick and drift: velocities and angular momenta to the middle of the step, positions and
  // rotation increments to its end. Over several processes each integrates its own nodes and
  // shares their positions and rotation increments (every process's contact pairs need them).
  state_shared_ = false;
  std::fill(bad_.begin(), bad_.end(), 0.0);
  tbb::parallel_for(
      tbb::blocked_range<int>(first_, last_, 256), [&](const tbb::blocked_range<int>& r) {
        for (int i = r.begin(); i != r.end(); ++i) {
          double work = 0;
          for (int c = 0; c < 3; ++c) {
            if (assembler.equation(6 * i + c) >= 0) {
              v_half_(c, i) = keep * st.v_n(c, i) + 0.5 * h * force_(c, i) / sim_.mass_(i);
              st.x(c, i) = st.x_n(c, i) + h * v_half_(c, i);
              work += 0.25 * h * loads_(c, i) * (st.v_n(c, i) + v_half_(c, i));
            } else {
              st.x(c, i) = st.x_n(c, i); // fixed, or set by the prescribed motion below
            }
          }
          node_work_[i] = work;
          if (prescribed_r_[i])
            continue;
          const std::array<bool, 3> free{assembler.equation(6 * i + 3) >= 0,
                                         assembler.equation(6 * i + 4) >= 0,
                                         assembler.equation(6 * i + 5) >= 0};
          const Eigen::Vector3d omega_n = st.Q_n[i] * st.W_n.col(i);
          pi_half_.col(i) = keep * pi_.col(i) + 0.5 * h * moment_.col(i);
          Eigen::Vector3d omega = omega_half_.col(i);
          if (!midpoint_angular_velocity(st.Q_n[i], sim_.rotary_inertia_.col(i), pi_half_.col(i),
                                         free, h, omega)) {
            bad_[i] = 1;
            continue;
          }
          omega_half_.col(i) = omega;
          for (int c = 0; c < 3; ++c)
            if (free[c])
              node_work_[i] += 0.25 * h * loads_(3 + c, i) * (omega_n(c) + omega(c));
          const Eigen::Vector3d phi = h * omega;
          if (phi.norm() > 1.0) {
            bad_[i] = 2;
            continue;
          }
          st.alpha.col(i) = rodrigues_of_vector(phi);
        }
      });
  collect_kick_work();
  if (!shares_.empty()) {
    lap(tick, times.update);
    share_nodes({{st.x.data(), 3}, {st.alpha.data(), 3}, {bad_.data(), 1}});
    lap(tick, times.sums);
  }
  for (int i = 0; i < n_; ++i)
    if (bad_[i])
      fail(fmt::format("node {} {}", sim_.model_.node_label(i),
                       bad_[i] == 1 ? "spins too fast for its midpoint rotation to converge"
                                    : "turns by more than 1 rad in one increment"));
  sim_.apply_prescribed(t_new);
  for (int i = first_; i < last_; ++i) {
    for (int c = 0; c < 3; ++c)
      if (assembler.equation(6 * i + c) < 0)
        v_half_(c, i) = (st.x(c, i) - st.x_n(c, i)) / h;
    if (prescribed_r_[i])
      omega_half_.col(i) = rotation_vector_of_rodrigues<double>(st.alpha.col(i)) / h;
    increment_.col(i).head<3>() = st.x.col(i) - st.x_n.col(i);
    increment_.col(i).tail<3>() = rotation_vector_of_rodrigues<double>(st.alpha.col(i));
  }
  if (cm > 0)
    for (int i = first_; i < last_; ++i)
      sim_.damping_work_ +=
          h * cm *
          (sim_.mass_(i) * v_half_.col(i).squaredNorm() + omega_half_.col(i).dot(pi_half_.col(i)));

  lap(tick, times.update);
  // Contact at the new positions, then the increment is committed: Gauss-point histories with the
  // rotation increments, triads, the work of the loads.
  if (sim_.contact_) {
    sim_.contact_->set_time(t_new);
    std::string veto = sim_.contact_->evaluate(st, false);
    lap(tick, times.contact_search);
    if (sim_.partition_) {
      veto = sim_.agree_contact(veto);
      lap(tick, times.sums);
    }
    if (!veto.empty())
      fail(veto);
  }
  // Work of the reactions over the increment, trapezoidal rule, without the inertia of the
  // prescribed motions: the work that accelerates a prescribed DOF's mass is the change of its
  // kinetic energy, counted exactly after the second half kick. (The table's second rate, a
  // difference quotient, misses a kink of the table between its samples: a pull started at a
  // velocity would bring kinetic energy that no work paid for.)
  double work = 0;
  for (int i = first_; i < last_; ++i)
    for (int c = 0; c < 6; ++c)
      if (assembler.equation(6 * i + c) < 0)
        work += 0.5 * (sim_.reactions_(c, i) - inertia_(c, i)) * increment_(c, i);
  commit(t_new);
  time_ = t_new;
  lap(tick, times.update);
  if (triads_each_increment_) {
    share_nodes({{st.Q_n.data()->data(), 9}}); // the triads the owners committed
    lap(tick, times.sums);
  }
  evaluate_forces(t_new, h);
  tick = std::chrono::steady_clock::now();
  for (int i = first_; i < last_; ++i)
    for (int c = 0; c < 6; ++c)
      if (assembler.equation(6 * i + c) < 0)
        work += 0.5 * (sim_.reactions_(c, i) - inertia_(c, i)) * increment_(c, i);
  sim_.prescribed_work_ += work;

  // Second half kick.
  const double damp = 1 + 0.5 * cm * h;
  tbb::parallel_for(
      tbb::blocked_range<int>(first_, last_, 256), [&](const tbb::blocked_range<int>& r) {
        for (int i = r.begin(); i != r.end(); ++i) {
          const double m = sim_.mass_(i);
          node_work_[i] = 0;
          prescribed_kinetic_[i] = 0;
          for (int c = 0; c < 3; ++c) {
            if (assembler.equation(6 * i + c) >= 0) {
              st.v_n(c, i) = (v_half_(c, i) + 0.5 * h * force_(c, i) / m) / damp;
              st.a_n(c, i) = force_(c, i) / m;
              node_work_[i] += 0.25 * h * loads_(c, i) * (v_half_(c, i) + st.v_n(c, i));
            } else if (const TimeTable* table = prescribed_u_[3 * i + c]) {
              const double v_old = st.v_n(c, i);
              st.v_n(c, i) = table_rate(*table, t_new, h);
              st.a_n(c, i) = table_second_rate(*table, t_new, h);
              prescribed_kinetic_[i] += 0.5 * m * (st.v_n(c, i) * st.v_n(c, i) - v_old * v_old);
            }
          }
          const Eigen::Matrix3d& Q = st.Q_n[i];
          const Eigen::Vector3d J = sim_.rotary_inertia_.col(i);
          if (prescribed_r_[i]) {
            // The reactions leave the rotary inertia of a prescribed rotation out
            // (evaluate_forces): the work that turned it is the change of its kinetic energy,
            // counted with the prescribed translations'.
            const Eigen::Vector3d W_old = st.W_n.col(i);
            st.W_n.col(i) = Q.transpose() * omega_half_.col(i);
            const Eigen::Vector3d W = st.W_n.col(i);
            prescribed_kinetic_[i] +=
                0.5 * (W.dot(J.cwiseProduct(W)) - W_old.dot(J.cwiseProduct(W_old)));
            pi_.col(i) = Q * J.cwiseProduct(st.W_n.col(i));
            continue;
          }
          const std::array<bool, 3> free{assembler.equation(6 * i + 3) >= 0,
                                         assembler.equation(6 * i + 4) >= 0,
                                         assembler.equation(6 * i + 5) >= 0};
          const Eigen::Vector3d pi = (pi_half_.col(i) + 0.5 * h * moment_.col(i)) / damp;
          const Eigen::Vector3d omega = solve_free(Q, J, pi, free);
          st.W_n.col(i) = Q.transpose() * omega;
          for (int c = 0; c < 3; ++c)
            if (free[c])
              node_work_[i] += 0.25 * h * loads_(3 + c, i) * (omega_half_(c, i) + omega(c));
          if (free[0] && free[1] && free[2]) {
            pi_.col(i) = pi; // kept as integrated: the angular momentum balance stays exact
            // Euler's equations for the material angular acceleration (for a following Newmark
            // step).
            const Eigen::Vector3d W = st.W_n.col(i);
            st.A_n.col(i) =
                (Q.transpose() * moment_.col(i) - W.cross(J.cwiseProduct(W))).cwiseQuotient(J);
          } else {
            pi_.col(i) = Q * J.cwiseProduct(st.W_n.col(i));
            for (int c = 0; c < 3; ++c)
              if (free[c])
                pi_(c, i) = pi(c);
          }
        }
      });
  collect_kick_work();
  for (double k : prescribed_kinetic_) // in node order: the same sum on any thread count
    sim_.prescribed_work_ += k;
  lap(tick, times.update);
  kinetic_ = settle_energies(before);
  lap(tick, shares_.empty() ? times.update : times.sums);
}

void CentralDifference::commit(double t_new) {
  State& st = sim_.state_;
  const Assembler& assembler = *sim_.assembler_;
  // Work of the loads by the trapezoidal rule, with the loads before the triads are updated.
  const Eigen::Matrix<double, 6, Eigen::Dynamic> load = sim_.external_loads(t_new);
  for (int i = first_; i < last_; ++i)
    sim_.external_work_ += 0.5 * (load.col(i) + sim_.load_n_.col(i)).dot(increment_.col(i));
  const int ne = static_cast<int>(own_elements_.size());
  tbb::parallel_for(tbb::blocked_range<int>(0, ne, 32), [&](const tbb::blocked_range<int>& r) {
    for (int k = r.begin(); k != r.end(); ++k) {
      const int e = own_elements_[k];
      committed_history(assembler.references()[e], assembler.nodal_values(st, e), st.gauss[e]);
    }
  });
  tbb::parallel_for(
      tbb::blocked_range<int>(first_, last_, 256), [&](const tbb::blocked_range<int>& r) {
        for (int i = r.begin(); i != r.end(); ++i) {
          st.Q_n[i] = polished(rodrigues_rotation<double>(st.alpha.col(i)) * st.Q_n[i]);
          st.rotation_n.col(i) =
              unwrap_rotation(st.Q_n[i] * sim_.Q0_[i].transpose(), st.rotation_n.col(i));
        }
      });
  if (sim_.contact_)
    sim_.contact_->commit();
  st.x_n = st.x;
  st.alpha.setZero();
  st.time = t_new;
  ++st.increment;
  sim_.load_n_ = load;
}

void CentralDifference::run(SimulationObserver* observer) {
  State& st = sim_.state_;
  const Assembler& assembler = *sim_.assembler_;
  const double dt = step_.dt_initial;
  if (!(step_.safety_factor > 0))
    throw std::invalid_argument(
        fmt::format("step {} (explicit): expected a safety factor > 0, found {}", index_ + 1,
                    step_.safety_factor));
  if (!(dt > 0))
    throw std::invalid_argument(
        fmt::format("step {} (explicit): expected a time step dt > 0, found {}", index_ + 1, dt));
  for (int i = 0; i < n_; ++i) {
    bool moves = false, turns = false;
    for (int c = 0; c < 3; ++c) {
      moves = moves || assembler.equation(6 * i + c) >= 0;
      turns = turns || assembler.equation(6 * i + 3 + c) >= 0;
    }
    if (moves && !(sim_.mass_(i) > 0))
      throw std::invalid_argument(fmt::format(
          "step {} (explicit): node {} moves freely but has no mass (rhoA of its sections)",
          index_ + 1, sim_.model_.node_label(i)));
    if (turns && !(sim_.rotary_inertia_.col(i).array() > 0).all())
      throw std::invalid_argument(fmt::format(
          "step {} (explicit): node {} turns freely but its rotary inertia is [{}, {}, {}] kg "
          "m^2; explicit steps need rhoJ > 0 in every component",
          index_ + 1, sim_.model_.node_label(i), sim_.rotary_inertia_(0, i),
          sim_.rotary_inertia_(1, i), sim_.rotary_inertia_(2, i)));
  }

  // Mass scaling holds for this step only: the model's masses come back at its end.
  struct RestoreMass {
    Simulation& sim;
    Eigen::VectorXd mass;
    Eigen::Matrix3Xd rotary;
    ~RestoreMass() {
      sim.mass_ = std::move(mass);
      sim.rotary_inertia_ = std::move(rotary);
    }
  } restore{sim_, sim_.mass_, sim_.rotary_inertia_};

  if (sim_.resume_explicit_ && sim_.resume_explicit_->step == index_) {
    resume(*sim_.resume_explicit_);
    sim_.resume_explicit_.reset();
  } else {
    start(dt);
  }
  // Checkpoints read the integrator's state between increments.
  struct Running {
    Simulation& sim;
    ~Running() { sim.explicit_ = nullptr; }
  } running{sim_};
  sim_.explicit_ = this;

  const int every = std::max(1, step_.stable_dt_every);
  const int output_every = std::max(1, step_.output_every);
  while (time_ < step_.end_time * (1 - 1e-12)) {
    if (sim_.stop_requested())
      throw Interrupted(
          fmt::format("interrupted at t = {:.6g} s after increment {}", time_, st.increment));
    if (count_ > 0 && count_ % every == 0) {
      auto tick = std::chrono::steady_clock::now();
      share_state();
      const ExplicitStatus now = estimate(sim_, step_, scale_, sim_.mass_);
      status_.critical_dt = now.critical_dt;
      status_.stable_dt = now.stable_dt;
      status_.limited_by = now.limited_by;
      if (status_.stable_dt < dt_min_)
        fail(fmt::format("the stable time step {:.4g} s fell below the minimum {:.4g} s",
                         status_.stable_dt, dt_min_));
      h_target_ = std::min(dt, status_.stable_dt);
      // One evaluation of the energies (the strain energy is a pass over the elements) for both.
      const EnergyBalance e = sim_.energy_balance();
      check_energy(e.kinetic + e.internal + e.contact, "total");
      check_balance(e);
      lap(tick, sim_.stage_times_.explicit_path.stability);
    }
    // Land exactly on the end time; avoid a sliver of a last increment.
    double h = std::min(h_target_, step_.end_time - time_);
    if (step_.end_time - (time_ + h) < 1e-3 * h)
      h = step_.end_time - time_;
    status_.dt = h;
    advance(h, time_ + h);
    ++sim_.stage_times_.explicit_path.increments;
    ++count_;
    ++status_.increments;
    sim_.explicit_status_ = status_;
    check_energy(kinetic_, "kinetic");

    const bool last = time_ >= step_.end_time * (1 - 1e-12);
    if (st.increment % output_every == 0 || last) {
      // Over several processes the whole state, points and histories for output and
      // checkpoints: collective, so at the output increments whether or not this process has
      // an observer.
      share_state();
      if (sim_.contact_)
        sim_.gather_contact();
      // Where the contact candidates changed since the last balance, the cuts move if that
      // balances the work (Simulation::rebalance, as after an implicit increment's commit; the
      // state and the pairs' histories are whole on every process here). Before the output, so
      // that a checkpoint holds the cuts the next increment runs on.
      if (const std::string balanced = sim_.rebalance(); !balanced.empty()) {
        take_share();
        if (observer)
          observer->on_notice(
              sim_, fmt::format("step {}, t = {:.6g} s: {}", index_ + 1, time_, balanced));
      }
      if (observer) {
        IncrementReport report;
        report.step = index_;
        report.increment = st.increment;
        report.time = time_;
        report.dt = h;
        observer->on_increment(sim_, report);
      }
    }
  }
  share_state(); // the state as one process holds it, for the steps after this one
  time_ = step_.end_time;
}

void CentralDifference::start(double dt) {
  State& st = sim_.state_;
  time_ = st.time;
  st.x = st.x_n;
  st.alpha.setZero();
  if (sim_.contact_) {
    sim_.contact_->set_time(time_);
    const std::string veto = sim_.agree_contact(sim_.contact_->evaluate(st, false));
    if (!veto.empty())
      fail(veto);
  }
  scale_.assign(sim_.model_.elements.size(), 1.0);
  std::vector<double> omega2;
  const ExplicitStatus plain = estimate(sim_, step_, scale_, sim_.mass_, &omega2);
  Eigen::VectorXd mass;
  Eigen::Matrix3Xd rotary;
  status_ = scale_to_target(sim_, step_, plain, omega2, scale_, mass, rotary);
  sim_.mass_ = std::move(mass);
  sim_.rotary_inertia_ = std::move(rotary);
  status_.dt = std::min(dt, status_.stable_dt);
  status_.increments = sim_.explicit_status_.increments;
  sim_.explicit_status_ = status_;
  if (dt > status_.stable_dt * (1 + 1e-9))
    throw std::invalid_argument(fmt::format(
        "step {} (explicit): the requested time step dt = {:.6g} s exceeds the stable limit "
        "{:.6g} s (safety factor {} x critical step {:.6g} s, set by {}){}; lower dt or ask for "
        "mass scaling (mass_scaling_dt)",
        index_ + 1, dt, status_.stable_dt, step_.safety_factor, status_.critical_dt,
        status_.limited_by,
        status_.added_mass > 0 ? fmt::format(" after mass scaling added {:.4g} kg ({:.3g} %)",
                                             status_.added_mass, status_.added_mass_percent)
                               : std::string()));
  // A model that deforms or comes into contact may lower the limit: the step then follows it,
  // down to dt_min (at most dt / 1000).
  dt_min_ = std::min(step_.dt_min, 1e-3 * dt);

  // Forces, angular momenta and the energy balance at the start.
  v_half_ = st.v_n;
  for (int i = 0; i < n_; ++i) {
    pi_.col(i) = st.Q_n[i] * sim_.rotary_inertia_.col(i).cwiseProduct(st.W_n.col(i));
    omega_half_.col(i) = st.Q_n[i] * st.W_n.col(i);
  }
  const double damping_before = sim_.damping_work_;
  evaluate_forces(time_, dt);
  sim_.damping_work_ = damping_before;
  supplied_start_ = sim_.kinetic_energy() + sim_.strain_energy() + sim_.contact_energy();
  supplied_max_ = supplied_start_;
  prescribed_start_ = sim_.prescribed_work_;
  sim_.energy_reference_ = supplied_start_ + sim_.damping_work_ - sim_.external_work_ -
                           sim_.prescribed_work_ +
                           (sim_.contact_ ? sim_.contact_->summary().dissipation : 0.0);
  energy_floor_ = sim_.floor_force_ * sim_.min_length_;

  h_target_ = status_.dt;
  count_ = 0;
}

void CentralDifference::resume(const ExplicitProgress& p) {
  if (static_cast<long>(p.scale.size()) != static_cast<long>(sim_.model_.elements.size()) ||
      p.force.cols() != n_ || p.moment.cols() != n_ || p.loads.cols() != n_ ||
      p.v_half.cols() != n_ || p.omega_half.cols() != n_ || p.pi.cols() != n_)
    throw std::invalid_argument(fmt::format(
        "step {} (explicit): the checkpoint's integrator state does not fit the model ({} "
        "elements, {} nodes)",
        index_ + 1, sim_.model_.elements.size(), n_));
  time_ = p.time;
  count_ = p.count;
  h_target_ = p.h_target;
  dt_min_ = p.dt_min;
  status_ = p.status;
  scale_ = p.scale;
  if (std::any_of(scale_.begin(), scale_.end(), [](double s) { return s > 1; }))
    scaled_masses(sim_, scale_, sim_.mass_, sim_.rotary_inertia_);
  force_ = p.force;
  moment_ = p.moment;
  loads_ = p.loads;
  v_half_ = p.v_half;
  omega_half_ = p.omega_half;
  pi_ = p.pi;
  supplied_start_ = p.supplied_start;
  supplied_max_ = p.supplied_max;
  prescribed_start_ = p.prescribed_start;
  energy_floor_ = p.energy_floor;
  kick_work_ = p.kick_work;
  // The inertia part of the restored reactions, as the evaluation at p.time after the step of
  // status_.dt wrote it in the run that saved the checkpoint: the first increment's reaction
  // work leaves it out.
  for (int i = 0; i < n_; ++i)
    for (int c = 0; c < 3; ++c) {
      const TimeTable* table = prescribed_u_[3 * i + c];
      inertia_(c, i) = table ? sim_.mass_(i) * table_second_rate(*table, time_, status_.dt) : 0.0;
    }
}

ExplicitProgress CentralDifference::progress() const {
  ExplicitProgress p;
  p.step = index_;
  p.time = time_;
  p.count = count_;
  p.h_target = h_target_;
  p.dt_min = dt_min_;
  p.status = status_;
  p.scale = scale_;
  p.force = force_;
  p.moment = moment_;
  p.loads = loads_;
  p.v_half = v_half_;
  p.omega_half = omega_half_;
  p.pi = pi_;
  p.supplied_start = supplied_start_;
  p.supplied_max = supplied_max_;
  p.prescribed_start = prescribed_start_;
  p.energy_floor = energy_floor_;
  p.kick_work = kick_work_;
  return p;
}

void Simulation::run_explicit(int step_index, SimulationObserver* observer) {
  CentralDifference(*this, step_index).run(observer);
}

ExplicitProgress Simulation::explicit_progress() const {
  return explicit_->progress();
}

ExplicitStatus Simulation::explicit_stability(const SolutionStep& step) const {
  return CentralDifference::stability(*this, step);
}

EnergyBalance Simulation::energy_balance() const {
  EnergyBalance e;
  e.kinetic = kinetic_energy();
  e.internal = strain_energy();
  e.contact = contact_energy();
  e.external_work = external_work_;
  e.prescribed_work = prescribed_work_;
  e.damping = damping_work_;
  e.friction = contact_ ? contact_->summary().dissipation : 0.0;
  e.error = e.kinetic + e.internal + e.contact + e.damping + e.friction - e.external_work -
            e.prescribed_work - energy_reference_;
  return e;
}

} // namespace yarnsim
