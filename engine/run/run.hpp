#pragma once
// A run from a resolved model to its output folder: results.h5 and results.xdmf, one CSV per
// monitor, a progress line on the terminal, and the reason the run ended recorded in the results.

#include "engine/contact/spline_contact_set.hpp"
#include "engine/model/model.hpp"
#include "engine/solver/linear_solver.hpp"

#include <atomic>
#include <filesystem>
#include <string>

namespace yarnsim {

struct RunOptions {
  std::filesystem::path output_dir; ///< created if missing
  std::string deck_text;            ///< stored verbatim in the results
  std::string deck_path;
  int threads = 1; ///< recorded in the results (the caller limits TBB)
  LinearSolverKind linear_solver = LinearSolverKind::Auto;
  bool progress = true; ///< progress line on stderr
  const std::atomic<bool>* stop_requested = nullptr;
};

struct RunSummary {
  int increments = 0;
  int iterations = 0;
  double wall_seconds = 0;
  Eigen::Matrix3Xd final_positions;         ///< 3 x n_nodes, m
  std::vector<ContactPoint> final_contacts; ///< active contact points at the end
  std::string linear_solver;
};

/// Runs every step of the model. Throws ConvergenceError (exit 3), Interrupted (exit 130) or any
/// other exception (exit 1) after recording why in results.h5; every completed increment is
/// already on disk.
RunSummary run_model(const Model& model, const RunOptions& options);

} // namespace yarnsim
