#pragma once
// The implicit path: for each solution step, increments of adaptive size, each solved by
// Newton-Raphson on the residual r = f_int + f_inertia - f_ext over the free equations
// (formulation.md §3). Static steps drop the inertia; dynamic steps use Newmark on translations and
// Simo and Vu-Quoc's material form on rotations.

#include "engine/assembly/assembler.hpp"
#include "engine/contact/contact_stage.hpp"
#include "engine/contact/spline_contact_set.hpp"
#include "engine/contact/surface_contact_set.hpp"
#include "engine/model/model.hpp"
#include "engine/model/partition.hpp"
#include "engine/solver/linear_solver.hpp"
#include "engine/state/state.hpp"

#include <array>
#include <atomic>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace yarnsim {

struct SimulationCheckpoint; // checkpoint.hpp
struct NewmarkCoefficients;  // engine/beam/nodal_terms.hpp
struct ExplicitProgress;
class CentralDifference; // central_difference.cpp

/// The step size fell below the step's minimum: the run cannot go on (exit code 3).
class ConvergenceError : public std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// The run was asked to stop (SIGINT or SIGTERM) and stopped after a completed increment.
class Interrupted : public std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// What one converged increment took.
struct IncrementReport {
  int step = 0;       ///< index of the solution step
  int increment = 0;  ///< converged increments since the start of the run
  double time = 0;    ///< s, at the end of the increment
  double dt = 0;      ///< s
  int iterations = 0; ///< Newton iterations of the converged attempt
  /// Of them, iterates reached by a correction the closing limit cut while crossings closed,
  /// counted apart from max_iterations (SimulationOptions::closing_iterations_apart).
  int closing_iterations = 0;
  int failed_attempts = 0; ///< attempts halved before this one converged
  /// max(force, moment) residual relative to its reference, before each solve and at the end.
  std::vector<double> residual_history;
  /// |delta . r| of each Newton correction (J): the energy norm, insensitive to the scaling
  /// between stiff axial and soft bending modes.
  std::vector<double> energy_history;
  /// Accepted with a residual within its round-off floor but not within the tolerance asked.
  bool at_floor = false;
  double floor_relative = 0; ///< the floor relative to the residual's reference
  /// A tension test's predictors (Simulation::choose_predictor) in the converged attempt: the
  /// relative residual at the last increment's motion (held short of closing crossings) and at
  /// the ends' (with friction the ends alone, frictionless with the pulled yarns' stretch). NaN
  /// where none was chosen (another model, a step's first increment).
  double secant_residual = std::numeric_limits<double>::quiet_NaN();
  double ends_residual = std::numeric_limits<double>::quiet_NaN();
  /// The relative residuals after each predictor's first correction, solved with the converged
  /// state's tangent where both predictors have its active set, and the scaled norms
  /// (Simulation::scaled_norm) of the simplified Newton corrections there (that tangent's
  /// factorisation again): the predictor whose simplified correction is the shorter is chosen,
  /// its corrected point the attempt's first iterate. NaN where they were not compared: the
  /// smaller of the two residuals above then decides.
  double secant_corrected = std::numeric_limits<double>::quiet_NaN();
  double ends_corrected = std::numeric_limits<double>::quiet_NaN();
  double secant_next_correction = std::numeric_limits<double>::quiet_NaN();
  double ends_next_correction = std::numeric_limits<double>::quiet_NaN();
};

class SimulationObserver {
public:
  virtual ~SimulationObserver() = default;
  virtual void on_increment(const class Simulation&, const IncrementReport&) {}
  /// An attempt failed and the step is halved; why says what failed.
  virtual void on_attempt_failed(const class Simulation&, double /*time*/, double /*dt*/,
                                 const std::string& /*why*/) {}
  /// Something the user should know that does not stop the run (a tolerance that round-off
  /// makes unreachable), said once.
  virtual void on_notice(const class Simulation&, const std::string& /*what*/) {}
};

/// Wall time of the explicit path's stages, s, over its increments (yarnsim run --timings).
struct ExplicitStageTimes {
  long increments = 0;
  double contact_search = 0; ///< broad phase and projections at each increment's new positions
  double beam_forces = 0;    ///< the elements' internal forces (and stiffness damping)
  double other_forces = 0;   ///< contact forces, loads and reactions
  double sums = 0;           ///< over MPI processes: forces, contact figures and vetoes
  double update = 0;         ///< half kicks and drift, commit of histories, triads, pairs
  double stability = 0;      ///< the stable step's estimate and the energy checks
};

/// Wall time spent in each stage of the Newton iterations since the start of the run, s.
struct StageTimes {
  /// The explicit steps' stages (the fields below are the Newton iterations').
  ExplicitStageTimes explicit_path;
  double broad_phase = 0;       ///< contact candidates: box refit and search
  double narrow_phase = 0;      ///< closest-point projections and pair kernels (beside the beams)
  double beam_assembly = 0;     ///< beam residual and tangent into the matrix
  double other_assembly = 0;    ///< zeroing, pattern growth; contact, inertia and load terms
  double convergence_check = 0; ///< norms, and the symbolic analysis when the pattern changed
  double factorisation = 0;
  double solve = 0;
  /// The iteration's task graph from start to join (broad phase, narrow phase beside the beam
  /// assembly, contact assembly beside the inertia terms): the wall time of its parallel part,
  /// within which the stages above overlap on several threads.
  double iteration_graph = 0;
};

/// A table of the stage times, s and ms per Newton iteration, for `yarnsim run --timings`, and
/// one of the explicit increments' stages where explicit steps ran.
std::string stage_times_report(const StageTimes& times, int iterations);

/// Energies of the last completed increment, J. The work of prescribed motions (reactions) is
/// counted in explicit steps only; the energy dissipated by damping in explicit steps and, for
/// the mass-proportional part, in dynamic (Newmark) steps.
struct EnergyBalance {
  double kinetic = 0;
  double internal = 0; ///< strain energy of the beams
  double contact = 0;
  double external_work = 0;   ///< work of the nodal loads since the start of the run
  double prescribed_work = 0; ///< work of the reactions at prescribed DOFs
  double damping = 0;         ///< dissipated by Rayleigh damping
  double friction = 0;        ///< dissipated by friction since the start of the run
  /// kinetic + internal + contact + damping + friction - works, less its value at the start of
  /// the last explicit step: zero for an exact integrator.
  double error = 0;
};

/// Stability estimate of the explicit path (central_difference.cpp).
struct ExplicitStatus {
  double critical_dt = 0;          ///< s, 2 / omega_max (less with stiffness damping)
  double stable_dt = 0;            ///< s, safety_factor * critical_dt
  std::string limited_by;          ///< "element 12", "contact 'name'"
  double dt = 0;                   ///< s, the step in use
  double added_mass = 0;           ///< kg, by mass scaling
  double added_mass_percent = 0;   ///< of the model's translational mass
  double added_rotary_percent = 0; ///< of the model's rotary inertia (trace)
  long increments = 0;             ///< explicit increments completed
};

struct SimulationOptions {
  LinearSolverKind linear_solver = LinearSolverKind::Auto;
  /// Set from a signal handler; checked between Newton iterations and between their stages
  /// (the attempt in progress is dropped) and between explicit increments.
  const std::atomic<bool>* stop_requested = nullptr;
  /// Line search on each Newton correction (Simulation::attempt).
  bool line_search = true;
  /// Where an increment moves prescribed DOFs, its first Newton correction is solved with the
  /// tangent of the converged state (Simulation::attempt); false: with the tangent at the
  /// predictor, as without a line search.
  bool first_correction_from_converged_state = true;
  /// The mixed integration point Newton (formulation.md "Solution"): the beams' tangent takes
  /// the section resultants of the strains linearised along the correction in use instead of
  /// those of the current strains; false: the displacement-based Newton.
  bool mixed_integration_point = true;
  /// The predictor moves the free nodes with the test's kinematics (Simulation::predict): a
  /// picture frame's map, a frictionless tension test's yarns stretched with their ends;
  /// false: the converged state with the prescribed values alone.
  bool kinematic_predictor = true;
  /// The closing limit of a Newton correction (formulation.md "Solution"): a contact pair open
  /// where the correction starts may penetrate, to first order, at most this fraction of the
  /// smaller contact radius of the pair (spline: the contact radii; surface: the sections'
  /// semi-axes) in one correction; the correction is scaled down to the fraction where the first
  /// pair reaches it. 0: off. With `line_search` only.
  double closing_allowance = 0.02;
  /// Where the residual is within its tolerance but the last correction, as applied, is not
  /// within the increment tolerance, the increment criterion is tested on the simplified Newton
  /// correction at the point reached (one solve with the last factorisation: Simulation::attempt,
  /// formulation.md "Solution"), where the last step kept the active set; false: one more
  /// iteration decides.
  bool simplified_correction_check = true;
  /// An attempt whose friction states do not settle is cut (Simulation::attempt): where, with
  /// the same number of active contact pairs over the last three iterates, the residual and the
  /// number of slipping points both grew at each of the last two, from the fourth iteration on;
  /// false: such an attempt runs to the iteration limit.
  bool stick_slip_check = true;
  /// Iterates reached by a correction the closing limit cut, each with more active contact pairs
  /// than any iterate of the attempt before it (crossings closing, the tangent lacking them),
  /// count apart from the Newton iterations that `max_iterations` bounds, under a
  /// bound of their own: an attempt fails after `max_iterations` others or after
  /// kClosingIterationFactor times `max_iterations` in all (Simulation::attempt; as Abaqus counts
  /// severe discontinuity iterations apart from equilibrium iterations). false: every iterate
  /// counts toward `max_iterations`.
  bool closing_iterations_apart = true;
  /// Full Newton steps count as stagnating, and the line search's damping acts on them, where
  /// the residual on the attempt's fixed scale (its first iterate's reference force and moment)
  /// fell by less than a fifth over the last iteration or the last two (Simulation::attempt).
  /// false: where the relative residual, whose reference is the iterate's own largest nodal
  /// force, fell by less than a fifth over the last two iterations (before 2026-12-07). That
  /// reference moves with the residual while an increment's crossings close: the test saw
  /// stagnation where the force residual fell (and the damping backtracked), and full steps
  /// that stalled with unchanged contact states went on for two iterations before it acted
  /// (docs/performance.md, "Stagnation on the attempt's fixed scale").
  bool stagnation_on_fixed_scale = true;
  /// The line search's monotonicity test reads, at a damped point whose step kept the active set,
  /// the simplified Newton correction -K(x_k)^-1 r(x_k + lambda delta) with the factorisation in
  /// hand (NLEQ-ERR's test, Deuflhard 2004 sec. 3.3): a rejected point costs a solve, not a
  /// factorisation (Simulation::attempt). false: the next Newton correction there, as at points
  /// whose step changed the active set (a factorisation and a solve; free where it passes).
  bool simplified_monotonicity = true;
};

/// The bound on all iterates of an attempt, in multiples of `max_iterations`, where the closing
/// limit's iterates count apart (SimulationOptions::closing_iterations_apart).
inline constexpr int kClosingIterationFactor = 3;

class Simulation {
public:
  Simulation(const Model& model, SimulationOptions options = {});
  /// Continues a run of the same model from a checkpoint taken after one of its increments
  /// (checkpoint.cpp): run() then goes on bit for bit as the earlier run would have. Throws
  /// std::invalid_argument when the checkpoint does not fit the model.
  Simulation(const Model& model, SimulationOptions options, const SimulationCheckpoint& from);
  /// The simulation keeps a reference to its model, which must outlive it: a temporary would be
  /// gone after the constructor (tables of prescribed motions read from freed memory).
  Simulation(Model&&, SimulationOptions = {}) = delete;
  Simulation(Model&&, SimulationOptions, const SimulationCheckpoint&) = delete;
  ~Simulation();

  /// Everything the run carries to its next increment; taken between increments (from
  /// SimulationObserver::on_increment).
  SimulationCheckpoint checkpoint() const;

  /// Runs every solution step to its end time. Throws ConvergenceError or Interrupted.
  void run(SimulationObserver* observer = nullptr);

  const Model& model() const { return model_; }
  const State& state() const { return state_; }
  const Assembler& assembler() const { return *assembler_; }
  /// The contact stage (spline and surface contacts), or null when the model has no contact.
  const ContactStage* contact() const { return contact_.get(); }
  int total_iterations() const { return total_iterations_; }
  /// Damped points judged by their simplified correction (a solve, no factorisation), all
  /// attempts': evaluated points besides the Newton iterations.
  int simplified_trials() const { return simplified_trials_; }
  const std::string& linear_solver_name() const { return solver_name_; }
  /// Whether the linear solver shares the factorisation out over the processes of a run over
  /// several (mumps, petsc: each hands in its own entries); lu, ldlt and ldlt-gmres factorise
  /// the whole tangent on every process.
  bool shares_factorisation() const;
  const StageTimes& stage_times() const { return stage_times_; }

  /// Reactions at constrained DOFs of the last converged increment, 6 x n_nodes (N, N m).
  const Eigen::Matrix<double, 6, Eigen::Dynamic>& reactions() const { return reactions_; }
  /// Section resultants (forces N, moments N m) at the Gauss points, 6 x (2 n_elements).
  Eigen::Matrix<double, 6, Eigen::Dynamic> section_resultants() const;
  /// Kinetic energy of the last converged increment, J.
  double kinetic_energy() const;
  /// Strain energy of the last converged increment, J.
  double strain_energy() const;
  /// Smallest gap of the contact in the initial configuration (the clearance the formulation
  /// sees: the spline contact's effective gap differs from the nominal surface gap), m; NaN
  /// without contact.
  double initial_contact_clearance() const { return initial_clearance_; }
  /// Elastic energy stored in the contacts of the last converged increment, J.
  double contact_energy() const { return contact_ ? contact_->potential() : 0.0; }
  /// Work of the external loads up to the last converged increment (trapezoidal rule), J.
  double external_work() const { return external_work_; }
  /// Total linear momentum (kg m/s) and angular momentum about the origin (kg m^2/s).
  Eigen::Vector3d linear_momentum() const;
  Eigen::Vector3d angular_momentum() const;
  /// Lumped nodal mass (kg) and material rotary inertia (kg m^2).
  const Eigen::VectorXd& nodal_mass() const { return mass_; }
  /// Reference nodal triads Q0 (columns: section axes 1, 2 and the beam axis); a node's current
  /// triad is exp(theta) Q0, theta its total rotation vector.
  const std::vector<Eigen::Matrix3d>& reference_triads() const { return Q0_; }
  /// All energies of the last converged increment.
  EnergyBalance energy_balance() const;
  /// Stable step of explicit step `step` at the current state, with the mass scaling it asks
  /// for (not applied to the simulation).
  ExplicitStatus explicit_stability(const SolutionStep& step) const;
  /// The last stability estimate and mass scaling of the explicit path.
  const ExplicitStatus& explicit_status() const { return explicit_status_; }

private:
  struct PrescribedDisplacement {
    int node, component;
    const TimeTable* table;
  };
  struct PrescribedRotation {
    int node;
    const std::array<TimeTable, 3>* tables;
  };

  /// "" when `s.off_end` is 0; else "; N contact point(s) ... have passed the end of a yarn ...",
  /// naming the first point's yarns: what a failed attempt's reason and the notice after an
  /// increment add.
  std::string off_end_text(const ContactSummary& s) const;
  /// Tries one increment from the converged state to time t_new. Returns an empty string on
  /// success, otherwise why it failed (the state is then restored).
  std::string attempt(const SolutionStep& step, double t_new, double dt, IncrementReport& report);
  /// Residual, norms and references of one evaluation at the current configuration.
  struct Evaluation {
    std::string veto;      ///< why the contact stage or the norms reject the configuration
    double ref_force = 0;  ///< N, largest nodal force of any kind
    double ref_moment = 0; ///< N m
    double r_force = 0;    ///< N, Euclidean norm of the force residual over the free equations
    double r_moment = 0;   ///< N m
    double relative = 0;   ///< max of the two relative to their references
    int worst_dof = -1;    ///< global DOF with the largest scaled residual
  };
  /// Evaluates the residual (6 n_nodes, into residual; rhs_ = its negative over the free
  /// equations) and, if want_tangent, the tangent into the assembler's matrix.
  /// The nodes' inertia and mass damping terms of a dynamic step into inertia_ (a graph node).
  void compute_inertia(const SolutionStep& step, const NewmarkCoefficients& nm, bool want_tangent);
  Evaluation evaluate(const SolutionStep& step, const NewmarkCoefficients& nm, double t_new,
                      bool want_tangent, Eigen::VectorXd& residual);
  /// Moves the free DOFs by s delta (delta over the free equations).
  void move_along(const Eigen::VectorXd& delta, double s);
  /// Norm of a vector over the free equations, translations over the shortest element (m / m)
  /// and rotations (rad): the damped Newton's measure of corrections.
  double scaled_norm(const Eigen::VectorXd& v) const;
  /// Drops the pattern's contact couplings that the last evaluation's pairs do not need
  /// (ContactSet::couplings) when they are more than a quarter of those needed.
  void prune_couplings();
  /// Over several processes (ContactStage::partitioned()): the veto of the lowest-ranked process
  /// that has one, and the processes' combined contact figures (ContactStage::agree); `veto`
  /// itself otherwise. Collective: every process calls it after each projection.
  std::string agree_contact(const std::string& veto);
  /// Over several processes: the contact points (for output) and histories (for checkpoints)
  /// of the last converged state, gathered from the processes: the points on every process, the
  /// histories on the first (the leader, which writes the checkpoints) alone. Collective, after
  /// each commit of an implicit step and before each explicit increment's output.
  void gather_contact();
  /// The processes' pairs' histories and last results, each list sorted by its key as one
  /// process keeps it, into gathered_spline_ and gathered_surface_: on every process
  /// (`everywhere`) or on the first alone (the others' reset). Collective.
  void gather_histories(bool everywhere);
  /// Over several processes, where every process holds every pair (after a restore) and each is
  /// to keep its own from now on: the run's contact figures, points and snapshots as every
  /// process holds them.
  void share_contact_pairs();
  bool stop_requested() const;
  [[noreturn]] void throw_interrupted() const;
  void commit(const SolutionStep& step, double dt, double t_new);
  /// Runs explicit step `step_index` to its end time (central_difference.cpp).
  void run_explicit(int step_index, SimulationObserver* observer);
  friend class CentralDifference;
  /// The explicit integrator's state while an explicit step runs (central_difference.cpp).
  ExplicitProgress explicit_progress() const;
  void apply_prescribed(double t_new);
  /// The predictor of an increment from t_new - dt to t_new: the converged state, moved on by the
  /// last increment's motion and rotations where the step asks (SolutionStep::secant_predictor)
  /// or a tension test chose them (choose_predictor), or else with a picture frame's map or a
  /// frictionless tension test's stretch of its pulled yarns where the model has one
  /// (SimulationOptions::kinematic_predictor), then the prescribed values at t_new.
  void predict(double t_new, double dt);
  /// A tension test (SimulationOptions::kinematic_predictor, a biaxial or uniaxial test): its
  /// predictor is chosen per attempt by choose_predictor, the held secant against the ends'.
  bool chooses_predictor() const;
  /// The closing limit (ContactStage::closing_limit at SimulationOptions::closing_allowance) of
  /// the nodal translations du (3 x n_nodes, m) from the contact's last evaluation moved by
  /// offset, over every process (the smallest); needs contact.
  double closing_limit(const Eigen::Matrix3Xd& du, const Eigen::Matrix3Xd* offset) const;
  /// Sets secant_chosen_ for the attempt to t_new: in a tension test whose step has a last
  /// increment, whether the secant predictor (held to secant_reach_) leaves a smaller relative
  /// residual than the ends' (with friction the ends alone, frictionless with the stretch of
  /// the pulled yarns); false otherwise. Evaluates both (no tangent).
  /// The two residuals go to the report (IncrementReport::secant_residual, ends_residual).
  /// Where the attempt's first correction is solved with the converged state's tangent
  /// (SimulationOptions), the secant's evaluation is kept for the choice after that correction
  /// (secant_trial_, attempt()) and the attempt starts from the ends.
  void choose_predictor(const SolutionStep& step, const NewmarkCoefficients& nm, double t_new,
                        double dt, Eigen::VectorXd& residual, IncrementReport& report);
  /// The largest nodal translation (m) and Rodrigues increment of a correction over the free
  /// equations (maxima: the same on any thread count).
  std::pair<double, double> largest_nodal_motion(const Eigen::VectorXd& delta) const;
  /// Over several processes, where the contact candidates changed since the last balance: the
  /// cuts made again over the elements and the candidate pairs each node owns (partition_all
  /// with their load, kCandidateLoad each). Where that lowers the largest process's share of
  /// the work by kRebalanceGain of the mean at least, every process takes the histories
  /// of every pair (the commit's, gathered then on every process) and keeps its new share of the
  /// pairs from the next search on. Between increments: after an implicit commit, at a restart,
  /// and at an explicit step's output increments (CentralDifference::run, which then takes its
  /// new share of the nodes); returns a description of the change for the user, or nothing.
  std::string rebalance();
  /// The fraction of a correction to apply and what bounds it (Simulation::limit_correction).
  struct CorrectionLimit {
    double lambda = 1;    // the fraction of the correction to apply
    double du = 0;        // m, the correction's largest nodal translation (whole)
    double da = 0;        // its largest nodal Rodrigues increment (whole)
    bool closing = false; // the closing limit cut the fraction below the others' bounds
  };
  /// The fraction of a Newton correction delta (over the free equations) to apply, at most
  /// lambda: the step limit (max_contact_step_) and the closing limit of its nodal translations
  /// from the contact's last evaluation, moved by the predictor's motion from the converged
  /// state where from_converged (formulation.md "Solution"); with the line search only. Also
  /// delta's largest nodal translation and Rodrigues increment, and whether the closing limit
  /// was the bound that acted.
  CorrectionLimit limit_correction(const Eigen::VectorXd& delta, double lambda,
                                   bool from_converged);
  /// Analyses the tangent's pattern where it changed since the last analysis (collectively over
  /// several processes handing in their own entries) and factorises the assembler's matrix, then
  /// looks at the stop request (throws Interrupted). Returns the solver's message where it
  /// failed, "" otherwise.
  std::string factorize_tangent();
  /// External force (N) and moment (N m) per node at time t, 6 x n_nodes.
  Eigen::Matrix<double, 6, Eigen::Dynamic> external_loads(double t) const;
  /// A force or moment v of the load at node, given along load.axes, as global components in
  /// the reference configuration (section axes: rotated by the node's reference triad).
  Eigen::Vector3d reference_components(const NodalLoad& load, const Eigen::Vector3d& v,
                                       int node) const;

  const Model& model_;
  SimulationOptions options_;
  std::unique_ptr<Assembler> assembler_;
  std::unique_ptr<LinearSolver> solver_;
  std::unique_ptr<ContactStage> contact_;
  std::string solver_name_;
  State state_;
  std::vector<Eigen::Matrix3d> Q0_; ///< reference nodal triads
  Eigen::VectorXd mass_;            ///< per node, kg
  Eigen::Matrix3Xd rotary_inertia_; ///< per node, material diag, kg m^2
  std::vector<PrescribedDisplacement> prescribed_u_;
  std::vector<PrescribedRotation> prescribed_r_;
  Eigen::Matrix<double, 6, Eigen::Dynamic> reactions_;
  double floor_force_ = 0, floor_moment_ = 0, floor_length_ = 0;
  double min_length_ = 1; ///< shortest element, m
  /// m: the largest translation one Newton correction may apply at a node, the smallest contact
  /// radius of the model's contacts; 0 without contact (no limit).
  double max_contact_step_ = 0;
  double external_work_ = 0;
  double prescribed_work_ = 0, damping_work_ = 0; ///< J, explicit steps
  double energy_reference_ = 0; ///< J, balance at the start of the last explicit step
  ExplicitStatus explicit_status_;
  Eigen::Matrix<double, 6, Eigen::Dynamic> load_n_; ///< external loads at the last converged time
  bool floor_reported_ = false;                     ///< the round-off floor notice was given
  bool frictionless_reported_ = false; ///< the notice of points without friction was given
  bool off_end_reported_ = false;      ///< the notice of points past a yarn's end was given
  Eigen::VectorXd damping_velocity_;   ///< 6 n_nodes, stiffness damping's velocities
  Eigen::Matrix3Xd contact_velocity_;  ///< 3 x n_nodes, m/s: the iterate's, for contact damping
  /// 3 x n_nodes, rad/s: the iterate's spatial angular velocities, for surface contact damping.
  Eigen::Matrix3Xd contact_angular_velocity_;
  Eigen::VectorXd rhs_; ///< minus the residual over the free equations
  /// The closing limit's buffers (attempt), kept for their capacity: the correction's nodal
  /// translations and the predictor's motion from the converged state (3 x n_nodes, m).
  Eigen::Matrix3Xd correction_motion_, predictor_motion_;
  /// The secant predictor's (SolutionStep::secant_predictor, or chosen: choose_predictor): the
  /// last converged increment's motion of every node (3 x n, m) and its rotations (3 x n,
  /// rotation vectors in rad: Q_n = exp(skew(theta)) Q_n-1), its size (s) and its step's index
  /// (-1: none yet).
  Eigen::Matrix3Xd secant_motion_;
  Eigen::Matrix3Xd secant_rotation_;
  double secant_dt_ = 0;
  int secant_step_ = -1;
  /// The chosen secant's reach: the fraction of secant_motion_ at which the first contact pair
  /// open in the converged state would penetrate by the closing allowance (closing_limit at the
  /// commit; +infinity where none closes). The predictor moves by min(dt / secant_dt_, it).
  double secant_reach_ = std::numeric_limits<double>::infinity();
  bool secant_chosen_ = false; ///< this attempt's predictor carries the secant (choose_predictor)
  /// The secant predictor's evaluation kept for the choice after the first correction
  /// (choose_predictor, attempt()): pending, its residual's figures, its right-hand side (minus
  /// the residual over the free equations) and its contacts' active set.
  bool secant_trial_ = false;
  Evaluation secant_at_predictor_;
  Eigen::VectorXd secant_rhs_;
  std::uint64_t secant_active_set_ = 0;
  /// commit()'s per-node energy terms (3 x n_nodes, J), kept for their capacity.
  Eigen::Matrix3Xd commit_terms_;
  Eigen::VectorXd equation_weight_; ///< per free equation: 1 / shortest element (m^-1) or 1
  int total_iterations_ = 0;
  int simplified_trials_ = 0; ///< damped points judged by their simplified correction
  StageTimes stage_times_;
  /// This process's share of the assembly over several processes (partition.hpp); none (every
  /// element, pair and node) in a one-process run. `shares_`: every process's, in rank order.
  std::optional<NodePartition> partition_;
  /// Whether this process assembles element e (its first node is this process's: the beams'
  /// assembly, Assembler::add_beams); every element on one process. Its mixed stresses are
  /// computed here alone.
  bool assembles_element(std::size_t e) const {
    return !partition_ || partition_->owns(model_.elements[e].nodes[0]);
  }
  std::vector<NodePartition> shares_;
  /// The contact candidates' version the partition was last balanced for (rebalance).
  int balanced_version_ = -1;
  /// A contact candidate pair's work in the partition's balance, in elements' worth: a pair's
  /// projection per iteration against an element's residual and tangent (the 24 x 24 weave, one
  /// thread: 14 ms for 21 500 candidates against 13 ms for 5 184 elements, 0.26); on the
  /// explicit path a candidate's contact search against an element's forces, kicks and commit
  /// (0.20 against 0.95 us, 0.21: docs/performance.md, "The explicit path balanced again").
  static constexpr double kCandidateLoad = 0.25;
  /// The least gain of a new partition, in the largest share over the mean (rebalance).
  static constexpr double kRebalanceGain = 0.05;
  /// Over several processes: the couplings of this process's pairs since the pattern was last
  /// rebuilt (the blocks it assembles: Assembler::own_entries), and whether they grew since the
  /// last analysis.
  std::vector<ContactCoupling> own_couplings_;
  bool own_couplings_changed_ = false;
  /// The processes' contact snapshots of the last commit (gather_contact), for checkpoint().
  std::optional<SplineContactSet::Snapshot> gathered_spline_;
  std::optional<SurfaceContactSet::Snapshot> gathered_surface_;
  /// Where they are: nowhere yet (a fresh run before its first commit), on the first process
  /// alone (gather_contact), or on every process (share_contact_pairs, a rebalance's gathering).
  enum class Gathered { nowhere, on_first, everywhere };
  Gathered gathered_ = Gathered::nowhere;
  /// Over several processes with a pattern per process (Assembler::share): every process's
  /// contact couplings, gathered with the histories on the first process alone (empty on the
  /// others), for the leader's checkpoints.
  std::vector<ContactCoupling> gathered_couplings_;
  double initial_clearance_ = std::numeric_limits<double>::quiet_NaN();

  struct IterationGraph;
  /// Inputs and outputs of the iteration graph's nodes for the iteration in progress.
  struct IterationData {
    Eigen::VectorXd* residual = nullptr; ///< 6 n_nodes
    StiffnessDamping damping;
    bool want_tangent = true;
    std::string veto;   ///< why the contact stage vetoes the configuration
    ContactRates rates; ///< contact damping's velocities (velocity null: none)
    /// The couplings the narrow phase's pairs need, sorted (Assembler::ensure_couplings).
    std::vector<ContactCoupling> couplings;
    double ref_force = 0;  ///< largest nodal internal force, N
    double ref_moment = 0; ///< largest nodal internal moment, N m
    /// A dynamic step's inertia and mass damping (null in static steps): the step and its
    /// Newmark coefficients, read by the graph's inertia node.
    const SolutionStep* step = nullptr;
    const NewmarkCoefficients* newmark = nullptr;
  };
  IterationData iteration_;
  /// The lumped inertia and mass-proportional damping of every node (IterationGraph's inertia
  /// node), added to the residual and the tangent after the graph: translational force (N) and
  /// diagonal of its tangent (N/m), rotary moment (N m) and its tangent (N m/rad), 3 x n_nodes
  /// each and one 3 x 3 per node; the largest force and moment.
  struct InertiaTerms {
    Eigen::Matrix3Xd force, force_tangent, moment;
    std::vector<Eigen::Matrix3d> moment_tangent;
    double largest_force = 0, largest_moment = 0;
    double seconds = 0; ///< wall time of the graph node that computed them, s
  };
  InertiaTerms inertia_;
  /// The mixed integration point Newton's stresses (SimulationOptions::mixed_integration_point):
  /// per element, the material strains at the Gauss points (rows 0-2 Gamma, 3-5 K) where the
  /// correction in use started, their derivative along it, and the resultants C (strain + lambda
  /// rate) at the point lambda reached along it, which the beams' tangent takes.
  struct MixedStresses {
    bool active = false; ///< false: the tangent takes the current strains' resultants
    double lambda = 0;   ///< the fraction of the correction applied
    std::vector<Eigen::Matrix<double, 6, 2>> strain, rate, resultants;
  };
  MixedStresses mixed_;
  /// Starts the mixed stresses of a correction `delta` (over the free equations) from the
  /// current state (lambda 0); from_converged: delta was solved with the converged state's
  /// tangent (attempt()), whose linear model the strains then follow.
  void start_mixed_stresses(const Eigen::VectorXd& delta, bool from_converged);
  std::unique_ptr<IterationGraph> graph_; ///< last: built on the members above
  int analysed_pattern_ = -1;             ///< pattern version the solver analysed

  // Where run() starts or goes on, and what a checkpoint needs besides (checkpoint.cpp).
  int step_ = 0;       ///< solution step in progress
  double next_dt_ = 0; ///< s, size of the next implicit increment; 0: the step's initial size
  const CentralDifference* explicit_ = nullptr;       ///< the explicit step running, if any
  std::unique_ptr<ExplicitProgress> resume_explicit_; ///< explicit step to continue, if any
};

} // namespace yarnsim
