#pragma once
// A run from a resolved model to its output folder: results.h5 and results.xdmf, one CSV per
// monitor, checkpoint.h5 for a restart, a progress line on the terminal, and the reason the run
// ended recorded in the results. The files are written by a serial writer thread while the solver
// goes on with the next increment (engine/output/serial_writer.hpp).

#include "engine/contact/spline_contact_set.hpp"
#include "engine/model/model.hpp"
#include "engine/solver/linear_solver.hpp"
#include "engine/solver/simulation.hpp"

#include <atomic>
#include <filesystem>
#include <string>

namespace yarnsim {

struct RunSummary {
  int increments = 0;
  int iterations = 0;
  /// Damped points judged by their simplified correction (a solve without a factorisation):
  /// evaluated points besides the Newton iterations (Simulation::simplified_trials).
  int simplified_trials = 0;
  double wall_seconds = 0;
  Eigen::Matrix3Xd final_positions;         ///< 3 x n_nodes, m
  std::vector<ContactPoint> final_contacts; ///< active contact points at the end
  std::string linear_solver;
  /// J: energy dissipated by Rayleigh damping (simulation.hpp EnergyBalance::damping) and the
  /// strain and contact energy stored at the end.
  double damping_dissipation = 0;
  double stored_energy = 0;
  StageTimes stage_times; ///< wall time per stage of the Newton iterations, s
};

struct RunOptions {
  std::filesystem::path output_dir; ///< created if missing
  std::string deck_text;            ///< stored verbatim in the results
  std::string deck_path;
  int threads = 1; ///< recorded in the results (the caller limits TBB)
  LinearSolverKind linear_solver = LinearSolverKind::Auto;
  bool progress = true; ///< progress line on stderr
  const std::atomic<bool>* stop_requested = nullptr;
  /// Output folder of an earlier run of the same deck to continue from its checkpoint (after its
  /// last completed increment); empty: start from the beginning.
  std::filesystem::path restart_from;
  /// > 0: stop (as interrupted) after the first increment written at or beyond this one, counted
  /// from the start of the run, before its end.
  int stop_after = 0;
  /// Where the run stops early (interrupted, no convergence, any error), what it had done so
  /// far is written here before the exception leaves run_model: `--timings` of a stopped run.
  RunSummary* summary_on_stop = nullptr;
};

/// Runs every step of the model, or the rest of them from options.restart_from. Throws
/// output::RestartError (exit 2) when that restart cannot be made, ConvergenceError (exit 3),
/// Interrupted (exit 130) or any other exception (exit 1) after recording why in results.h5;
/// every completed increment is then on disk, with the checkpoint taken after it.
RunSummary run_model(const Model& model, const RunOptions& options);

/// A follower's share of an MPI run (distributed.hpp): the same steps as run_model on the
/// leader (rank 0), in lockstep with it, writing nothing (options.output_dir and progress are
/// not used; a restart reads options.restart_from). Throws as run_model, at the same point.
RunSummary follow_model(const Model& model, const RunOptions& options);

} // namespace yarnsim
