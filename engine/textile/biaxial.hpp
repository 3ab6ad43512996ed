#pragma once
// The virtual biaxial tension test of the paper's study (§5): every yarn end is pulled outward
// along its yarn, rotations free, with strain ratio k = eps_warp / eps_weft.

#include "engine/textile/fabric.hpp"

#include <utility>
#include <vector>

namespace yarnsim::textile {

/// Shape of the end displacement's ramp from 0 to its final value over the loading time.
enum class BiaxialRamp {
  Linear, ///< u = u_T t / T: the paper's; the ends start moving with a jump in velocity
  /// u = u_T s(t / T), s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5 (quintic smooth step: zero velocity
  /// and acceleration at both ends), tabulated at 400 equal intervals. Excites fewer stress waves
  /// on the explicit path; the peak rate is 15/8 of the linear one.
  Smooth,
};

/// Settings of the explicit path (central difference, mass scaling) of the biaxial step.
struct BiaxialExplicit {
  /// s; the mass-scaling target step. 0: no mass scaling (then dt must be given and below the
  /// stable limit, ~8.4e-8 s on the paper's fabric). Negative: loading_time / 50 000, what the
  /// paper's k = 1 case needs to stay within 5 % of the implicit curve past the toe
  /// (docs/verification.md).
  double mass_scaling_dt = -1;
  double dt = 0;              ///< s; 0: mass_scaling_dt
  double safety_factor = 0.8; ///< stable step = safety_factor x 2 / omega_max
  int stable_dt_every = 100;  ///< increments between estimates of the stable step
  int output_every = 0;       ///< 0: about 200 outputs over the step
  bool energy_monitor = true; ///< energy.csv
};

struct BiaxialParameters {
  double strain_ratio = 1;   ///< k = eps_warp / eps_weft, > 0 (paper: 1, 2, 0.5)
  double max_strain = 0.015; ///< nominal strain in the more strained direction, in (0, 1)
  double loading_time = 1;   ///< s, duration of the ramp from zero strain
  /// Dynamic (Newmark, the paper's), Static, or Explicit (central difference with `explicit_`).
  StepType type = StepType::Dynamic;
  BiaxialRamp ramp = BiaxialRamp::Linear;
  double dt = 0;     ///< s; 0: loading_time / 100
  double dt_min = 0; ///< s; 0: loading_time * 1e-6
  double dt_max = 0; ///< s; 0: loading_time / 50
  int max_iterations = 20;
  double tol_force = 1e-4;
  double tol_increment = 1e-4;
  double newmark_beta = 0.3;  ///< the paper's
  double newmark_gamma = 0.5; ///< the paper's
  int output_every = 1;       ///< implicit steps
  BiaxialExplicit explicit_;  ///< explicit steps
  /// Add node-set monitors "warp_ends" (node set "warp.end") and "weft_ends" ("weft.end"):
  /// the summed reactions at the yarn ends of each direction.
  bool monitors = true;
};

/// (eps_warp, eps_weft) for k and the larger strain: k >= 1 gives (max, max / k), k < 1 gives
/// (k max, max). Throws std::invalid_argument for k <= 0 or max_strain outside (0, 1).
std::pair<double, double> biaxial_strains(double strain_ratio, double max_strain);

/// Adds the biaxial test to a fabric: one solution step of `loading_time` starting where the
/// model's last step ends; at both ends of every yarn a prescribed displacement along the yarn's
/// in-plane end-to-end direction d (unit), ramped from 0, so that the end-to-end in-plane
/// distance L of the yarn grows by strain L (start moves by -strain L / 2 d, end by
/// +strain L / 2 d), along `ramp`; the other two displacement components are held at 0 and
/// rotations are free. An explicit step takes its time step, mass scaling and output cadence from
/// `explicit_`. Fills Model::biaxial (per-yarn end node sets, lengths of the first warp and weft
/// yarn, k, max strain) and, if asked, the end monitors. Throws std::invalid_argument for bad
/// parameters, a fabric without warp or weft yarns, or missing yarn node sets (finish_fabric adds
/// them).
void add_biaxial_test(Fabric& fabric, const BiaxialParameters& parameters);

/// One point of a biaxial test's force-strain curves (paper §5, Fig. 3).
struct BiaxialReading {
  /// Mean strain of the warp (weft) yarns: change of the in-plane distance between a yarn's two
  /// end nodes over that distance in the reference configuration, -.
  double strain_warp = 0, strain_weft = 0;
  /// Total force along each direction, positive in tension: per yarn the mean of the pulls at its
  /// two ends along its reference in-plane end-to-end direction, summed over the yarns, N.
  double force_warp = 0, force_weft = 0;
  std::vector<double> yarn_forces; ///< per yarn, warp yarns then weft yarns, N
};

/// The reading of model.biaxial (which must be set) at positions x (3 x n_nodes, m) with the
/// reactions at the prescribed DOFs (6 x n_nodes, forces first, N).
BiaxialReading read_biaxial(const Model& model, const Eigen::Matrix3Xd& x,
                            const Eigen::Matrix<double, 6, Eigen::Dynamic>& reactions);

} // namespace yarnsim::textile
