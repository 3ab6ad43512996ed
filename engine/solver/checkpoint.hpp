#pragma once
// What a run carries from one completed increment to the next beyond the model: enough for a
// restart to continue bit for bit where an earlier run stopped (`yarnsim run DECK --restart DIR`,
// docs/robustness.md). Simulation::checkpoint() takes one after an increment, the Simulation
// constructor that takes one puts it back (checkpoint.cpp); engine/output/checkpoint_file.* keep
// it in DIR/checkpoint.h5.

#include "engine/contact/spline_contact_set.hpp"
#include "engine/contact/surface_contact_set.hpp"
#include "engine/solver/linear_solver.hpp"
#include "engine/solver/simulation.hpp"
#include "engine/state/state.hpp"

#include <Eigen/Core>
#include <array>
#include <limits>
#include <optional>
#include <vector>

namespace yarnsim {

/// The central-difference integrator between two increments of an explicit step
/// (central_difference.cpp): half-step velocities, momenta, the forces at the committed state,
/// the mass scaling and the energy guard's sums.
struct ExplicitProgress {
  int step = 0;        ///< index of the explicit solution step
  double time = 0;     ///< s
  long count = 0;      ///< increments of this step so far (the stable step is estimated every N)
  double h_target = 0; ///< s, the step size in use
  double dt_min = 0;   ///< s
  ExplicitStatus status;
  std::vector<double> scale;                      ///< element mass factors, n_elements
  Eigen::Matrix3Xd force, moment;                 ///< net nodal force (N) and moment (N m)
  Eigen::Matrix<double, 6, Eigen::Dynamic> loads; ///< external loads at the committed time
  Eigen::Matrix3Xd v_half, omega_half;            ///< of the last step: m/s, rad/s (spatial)
  Eigen::Matrix3Xd pi;                            ///< spatial angular momentum, kg m^2/s
  double supplied_start = 0, supplied_max = 0, prescribed_start = 0, energy_floor = 0; ///< J
  double kick_work = 0;                                                                ///< J
};

/// The complete state of a Simulation after a completed increment.
struct SimulationCheckpoint {
  int step = 0;       ///< index of the solution step in progress (at its end: the last one done)
  double next_dt = 0; ///< s, the size the next implicit increment tries; 0: the step's initial
  /// The last converged increment (x = x_n and alpha = 0 between increments).
  State state;
  Eigen::Matrix<double, 6, Eigen::Dynamic> reactions;              ///< 6 x n_nodes, N and N m
  Eigen::Matrix<double, 6, Eigen::Dynamic> load_n;                 ///< external loads at state.time
  double external_work = 0, prescribed_work = 0, damping_work = 0; ///< J
  double energy_reference = 0;                                     ///< J
  int total_iterations = 0;
  /// Damped points judged by their simplified correction (Simulation::simplified_trials); 0
  /// where read from a checkpoint written before they were counted.
  int simplified_trials = 0;
  /// The secant predictor's last increment (SolutionStep::secant_predictor): every node's
  /// motion (3 x n_nodes, m) and rotation (3 x n_nodes, rotation vectors, rad; zero where read
  /// from a checkpoint written before the secant carried rotations), the increment's size (s)
  /// and its step's index; -1 and empty when no step of the run has used it yet.
  Eigen::Matrix3Xd secant_motion;
  Eigen::Matrix3Xd secant_rotation;
  double secant_dt = 0;
  int secant_step = -1;
  /// A frictional tension test's chosen secant is held to this fraction of the motion
  /// (Simulation::secant_reach_); +infinity: not held.
  double secant_reach = std::numeric_limits<double>::infinity();
  ExplicitStatus explicit_status;
  /// Over several processes: every process's first node, then the node count (the cuts of
  /// Simulation::rebalance); empty in a one-process run (and read from a checkpoint written
  /// before the partition was balanced: the elements' cuts).
  std::vector<int> partition_cuts;
  std::optional<ExplicitProgress> explicit_progress; ///< when stopped inside an explicit step
  std::optional<SplineContactSet::Snapshot> contact; ///< when the model has spline contact
  /// When the model has surface contact.
  std::optional<SurfaceContactSet::Snapshot> surface_contact;
  /// The contact couplings of the tangent's pattern (Assembler::couplings): restored with
  /// Assembler::set_couplings they rebuild the same pattern, hence the same ordering and
  /// factorisation.
  std::vector<ContactCoupling> pattern_groups;
  /// The linear solver's kept ordering (LinearSolver::ordering): a restart tries it first on
  /// its pattern, as the run straight through does.
  SolverOrdering ordering;
};

} // namespace yarnsim
