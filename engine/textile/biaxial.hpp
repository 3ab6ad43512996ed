#pragma once
// The virtual biaxial tension test of the paper's study (§5): every yarn end is pulled outward
// along its yarn, rotations free, with strain ratio k = eps_warp / eps_weft.

#include "engine/textile/fabric.hpp"
#include "engine/textile/loading.hpp"

#include <optional>
#include <utility>
#include <vector>

namespace yarnsim::textile {

/// The biaxial test: its loading step (loading.hpp) and strains.
struct BiaxialParameters : LoadingParameters {
  double strain_ratio = 1;   ///< k = eps_warp / eps_weft, > 0 (paper: 1, 2, 0.5)
  double max_strain = 0.015; ///< nominal strain in the more strained direction, in (0, 1)
  /// Add node-set monitors "warp_ends" (node set "warp.end") and "weft_ends" ("weft.end"):
  /// the summed reactions at the yarn ends of each direction.
  bool monitors = true;
  /// Set: a uniaxial tension test instead. Only this direction's yarn ends are pulled, by
  /// max_strain (strain_ratio is not used); the other direction's ends are free.
  std::optional<FabricDirection> uniaxial;
};

/// (eps_warp, eps_weft) for k and the larger strain: k >= 1 gives (max, max / k), k < 1 gives
/// (k max, max). Throws std::invalid_argument for k <= 0 or max_strain outside (0, 1).
std::pair<double, double> biaxial_strains(double strain_ratio, double max_strain);

/// Adds the biaxial test to a fabric: one solution step of `loading_time` starting where the
/// model's last step ends; at both ends of every yarn a prescribed displacement along the yarn's
/// in-plane end-to-end direction d (unit), ramped from 0, so that the end-to-end in-plane
/// distance L of the yarn grows by strain L (start moves by -strain L / 2 d, end by
/// +strain L / 2 d), along `ramp`; the other two displacement components are held at 0 and
/// rotations are free. A uniaxial test pulls one direction's yarns so and leaves the other's ends
/// free (no prescribed DOF: the yarns hang on their crossings). An explicit step takes its time
/// step, mass scaling and output cadence from `explicit_`. Fills Model::biaxial (per-yarn end node
/// sets, lengths of the first warp and weft yarn, k, max strain) and, if asked, the end monitors.
/// Throws std::invalid_argument for bad parameters, a fabric without warp or weft yarns, or missing
/// yarn node sets (finish_fabric adds them).
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
  /// Crimp of each direction, the yarns' mean of (length of the centre line through the yarn's
  /// nodes) / (in-plane distance between its ends) - 1, -: the waviness the crossings give the
  /// yarns; pulling a direction takes its crimp out and puts it into the other (crimp
  /// interchange).
  double crimp_warp = 0, crimp_weft = 0;
};

/// The reading of model.biaxial (which must be set) at positions x (3 x n_nodes, m) with the
/// reactions at the prescribed DOFs (6 x n_nodes, forces first, N).
BiaxialReading read_biaxial(const Model& model, const Eigen::Matrix3Xd& x,
                            const Eigen::Matrix<double, 6, Eigen::Dynamic>& reactions);

} // namespace yarnsim::textile
