#pragma once
// The virtual biaxial tension test of the paper's study (§5): every yarn end is pulled outward
// along its yarn, rotations free, with strain ratio k = eps_warp / eps_weft.

#include "engine/textile/fabric.hpp"

#include <utility>

namespace yarnsim::textile {

struct BiaxialParameters {
  double strain_ratio = 1;           ///< k = eps_warp / eps_weft, > 0 (paper: 1, 2, 0.5)
  double max_strain = 0.015;         ///< nominal strain in the more strained direction, in (0, 1)
  double loading_time = 1;           ///< s, duration of the linear ramp from zero strain
  StepType type = StepType::Dynamic; ///< Dynamic (the paper's) or Static
  double dt = 0;                     ///< s; 0: loading_time / 100
  double dt_min = 0;                 ///< s; 0: loading_time * 1e-6
  double dt_max = 0;                 ///< s; 0: loading_time / 50
  int max_iterations = 20;
  double tol_force = 1e-4;
  double tol_increment = 1e-4;
  double newmark_beta = 0.3;  ///< the paper's
  double newmark_gamma = 0.5; ///< the paper's
  int output_every = 1;
  /// Add node-set monitors "warp_ends" (node set "warp.end") and "weft_ends" ("weft.end"):
  /// the summed reactions at the yarn ends of each direction.
  bool monitors = true;
};

/// (eps_warp, eps_weft) for k and the larger strain: k >= 1 gives (max, max / k), k < 1 gives
/// (k max, max). Throws std::invalid_argument for k <= 0 or max_strain outside (0, 1).
std::pair<double, double> biaxial_strains(double strain_ratio, double max_strain);

/// Adds the biaxial test to a fabric: one solution step of `loading_time` starting where the
/// model's last step ends; at both ends of every yarn a prescribed displacement along the yarn's
/// in-plane end-to-end direction d (unit), ramped linearly from 0, so that the end-to-end in-plane
/// distance L of the yarn grows by strain L (start moves by -strain L / 2 d, end by
/// +strain L / 2 d); the other two displacement components are held at 0 and rotations are free.
/// Fills Model::biaxial (per-yarn end node sets, lengths of the first warp and weft yarn, k, max
/// strain) and, if asked, the end monitors. Throws std::invalid_argument for bad parameters, a
/// fabric without warp or weft yarns, or missing yarn node sets (finish_fabric adds them).
void add_biaxial_test(Fabric& fabric, const BiaxialParameters& parameters);

} // namespace yarnsim::textile
