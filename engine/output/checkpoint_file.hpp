#pragma once
// DIR/checkpoint.h5: the state of a run after its last completed increment, rewritten after each
// one (to checkpoint.h5.tmp, then renamed over the old file, so a reader finds either the old or
// the new checkpoint whole), for `yarnsim run DECK --restart DIR` (docs/robustness.md).
//
// Layout (arrays node-major, shape (rows, columns), float64 unless noted):
//   /            attributes format ("yarnsim checkpoint 1"), version, deck_hash, increment, time
//                (s), step, next_dt (s), results_steps (int32: steps of results.h5 written with
//                it), the work sums (J), total_iterations, explicit_*
//                (ExplicitStatus)
//   /outputs     one int32 attribute per CSV file of the run: its rows written with it
//   /state       x_n, v_n, a_n, W_n, A_n, rotation_n (n_nodes, 3); Q_n (n_nodes, 9), each triad
//                column-major; gauss_Q (2 n_elements, 9), gauss_kappa (2 n_elements, 3);
//                reactions, load_n (n_nodes, 6); where a step took the secant predictor:
//                secant_motion (n_nodes, 3), m, secant_rotation (n_nodes, 3), rotation
//                vectors, rad, attributes secant_dt (s) and secant_step
//   /pattern     groups (n, 7) int32: a coupling's 6 nodes, then 1 with rotations, else 0
//                (SimulationCheckpoint::pattern_groups); ordering (n_equations, 1) int32 and
//                attribute ordering_fill: the LDL^T's kept ordering (absent: none)
//   /contact     with spline contact: attributes candidates_version, definitions;
//                boxes_<k> (n_segments, 6): min then max corner of definition k's last search;
//                committed_keys (n, 3) int32, committed (n, 3): xi_A, xi_B, active;
//                committed_friction (n, 4): anchor_A, anchor_B, slip, state (0 none, 1 stick,
//                2 slip) and attribute friction_dissipated; committed_twist (n, 3): twist anchor,
//                twist slip, state; line_committed_keys (m, 4) int32: definition, slave segment,
//                Gauss point, master spline, line_committed (m, 3): anchor, slip, state (the
//                line contact's friction; absent in older files: none); pair_keys (n, 3) int32,
//                pair_flags (n, 4) int32: status, degenerate, active, iterations; pair_values
//                (n, 17): xi_A, xi_B, distance, gap, penetration, penetration_rate, force,
//                potential, point_A, point_B, normal
//   /surface_contact  with surface contact: attributes candidates_version, definitions,
//                summary_* (the last evaluation's ContactSummary); boxes_<k> as /contact;
//                committed_keys (n, 3) int32, committed (n, 5): zeta_A, theta_A, zeta_B, theta_B,
//                active; pair_keys (n, 3) int32, pair_flags (n, 4) int32: status, degeneration,
//                active, iterations; pair_values (n, 22): zeta_A, theta_A, zeta_B, theta_B, gap,
//                penetration, penetration_rate, force, potential, share, share_A, share_B,
//                factor, point_A, point_B, normal
//   /explicit    inside an explicit step: ExplicitProgress (scalars as attributes)
// Every double is stored as is, so a restart reads back the very bits of the run.

#include "engine/model/model.hpp"
#include "engine/solver/checkpoint.hpp"

#include <cstdint>
#include <filesystem>
#include <map>
#include <stdexcept>
#include <string>
#include <string_view>

namespace yarnsim::output {

/// A restart that cannot be done: no checkpoint, another deck, files that do not match (exit 2).
class RestartError : public std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// What the output folder held when the checkpoint was taken.
struct CheckpointOutputs {
  int results_steps = 0;                ///< /steps groups of results.h5
  std::map<std::string, long> csv_rows; ///< data rows per CSV file name (no header)
  std::string deck_hash;                ///< deck_fingerprint() of the run's deck
};

/// A fingerprint of the deck text and of the model it resolved to (nodes, elements), so that a
/// deck whose text or referenced geometry files changed is told apart: 16 hexadecimal digits.
std::string deck_fingerprint(std::string_view deck_text, const Model& model);

inline constexpr const char* kCheckpointName = "checkpoint.h5";

/// Writes dir/checkpoint.h5 atomically (checkpoint.h5.tmp, then rename). Throws
/// std::runtime_error when it cannot be written.
void write_checkpoint(const std::filesystem::path& dir, const SimulationCheckpoint& checkpoint,
                      const CheckpointOutputs& outputs);

/// Reads dir/checkpoint.h5. Throws RestartError when it is missing or not a checkpoint of this
/// format, std::runtime_error when it cannot be read.
struct StoredCheckpoint {
  SimulationCheckpoint simulation;
  CheckpointOutputs outputs;
};
StoredCheckpoint read_checkpoint(const std::filesystem::path& dir);

} // namespace yarnsim::output
