#pragma once
// The in-plane shear tests of a fabric (docs/shear-tests.md; Cao et al., Composites Part A 39
// (2008) 1037): the picture frame on a square fabric whose yarns run along the arms, and the
// measured shear angle both tests read on the yarns. Angles in degrees at the interface (the
// benchmark's), radians inside; lengths in m, forces in N.

#include "engine/textile/fabric.hpp"
#include "engine/textile/loading.hpp"
#include "engine/textile/specimen.hpp"

#include <Eigen/Core>
#include <functional>
#include <vector>

namespace yarnsim::textile {

/// The crossings of the fabric's warp and weft yarns whose reference in-plane position satisfies
/// `inside`: a node of each yarn at the same (x, y) to 1e-9 of the first element's length (the
/// weave builder puts a node of both yarns at every crossing). Ordered by warp yarn, then along
/// it.
std::vector<CrossingNodes>
find_crossings(const Fabric& fabric, const std::function<bool(const Eigen::Vector2d&)>& inside);

/// The shear angle measured on the yarns at positions x (3 x n_nodes, m): per crossing
/// 90 degrees less the in-plane angle from the warp's tangent to the weft's (the tangents
/// x[next] - x[prev] along each yarn), positive where the angle between them closes.
struct MeasuredShear {
  double mean = 0;   ///< degrees, over the crossings
  double spread = 0; ///< degrees, their standard deviation
  double min = 0, max = 0;
};
MeasuredShear measure_shear(const std::vector<CrossingNodes>& crossings, const Eigen::Matrix3Xd& x);

/// The picture frame test: its loading step, the frame's final shear angle and how the arms hold
/// the yarn ends.
struct PictureFrameParameters : LoadingParameters {
  /// No mass-proportional damping unless the deck asks: the frame moves the yarns through large
  /// rigid rotations, which it would resist (on the paper's frame to 30 degrees,
  /// kStabilisingDamping dissipates 0.0017 J against 1.4e-5 J stored). A dynamic frame damps
  /// the out-of-plane translations alone by default (rayleigh_out_of_plane < 0: loading.hpp).
  PictureFrameParameters() {
    rayleigh_mass = 0;
    rayleigh_out_of_plane = -1;
  }
  double max_angle = 50; ///< degrees, the frame's shear angle at the end of the step, in (0, 90)
  /// The arms turn the yarn ends with them (a clamped fabric) instead of letting them turn
  /// (pinned).
  bool clamped = false;
  /// Side of the central region where the shear angle is measured, over the frame's side, (0, 1].
  double central_region = 0.5;
  /// Strain [0, 0.1) by which the frame first grows about its centre at gamma = 0, in a step of
  /// its own (pretension_time, along `ramp`), before the shear: it closes the crossings of a
  /// fabric woven with a gap, whose yarns otherwise hang free between the arms (no contact, no
  /// stiffness across the fabric). 0: no such step.
  double pretension = 0.003;
  double pretension_time = 0; ///< s; 0: loading_time / 5
};

/// Adds the picture frame to a fabric whose warp yarns run along x and weft yarns along y with
/// their ends on the sides of one square (the woven builder's fabric with length_warp =
/// length_weft): the frame's side L is the yarns' end-to-end length, its fixed corner A the
/// square's (x min, y min) corner. With a pretension, a first step stretches the frame about its
/// centre; then one step of the loading time in which the frame angle ramps along the
/// ramp from 0 to max_angle; every yarn end is held by its arm (PictureFrameTest: the end's
/// position is a tabulated function of time, 400 intervals; z held at 0; rotations free, or
/// turned with the arm, (0, 0, -+gamma/2), when clamped). Fills Model::picture_frame with the
/// central crossings and the locking angle acos(w / p) of the yarn widths and spacings. Throws
/// std::invalid_argument for bad parameters or a fabric whose ends do not lie on a square.
void add_picture_frame_test(Fabric& fabric, const PictureFrameParameters& parameters);

/// One point of a picture frame's curves.
struct PictureFrameReading {
  double displacement = 0;           ///< d, the crosshead's travel along the diagonal, m
  double force = 0;                  ///< F, the crosshead force, N
  double frame_angle = 0;            ///< gamma of the frame, degrees
  MeasuredShear measured;            ///< on the yarns of the central region
  double shear_force = 0;            ///< F_s = F / (2 cos theta), N
  double normalised_shear_force = 0; ///< F_s / L (the fabric fills the frame), N/m
  double side = 0;                   ///< L s(t), the frame's side with its pretension, m
};

/// The reading of model.picture_frame (which must be set) at time t (s), positions x
/// (3 x n_nodes, m) and the reactions at the prescribed DOFs (6 x n_nodes, forces first, N). The
/// crosshead force is the frame's virtual work: F = sum over the ends of R . dx/dd (+ M_z
/// dphi/dd when clamped), the frame being a rigid mechanism of one degree of freedom.
PictureFrameReading read_picture_frame(const Model& model, double time, const Eigen::Matrix3Xd& x,
                                       const Eigen::Matrix<double, 6, Eigen::Dynamic>& reactions);

/// The bias extension test: its loading step and how far it goes. The specimen (its H, W and
/// clamp length) is BiasSpecimenParameters'.
struct BiasExtensionParameters : LoadingParameters {
  /// No mass-proportional damping unless the deck asks, as for the picture frame: the
  /// specimen's zones turn and translate as rigid bodies. Out of plane as the picture frame.
  /// Newmark with numerical dissipation of the high frequencies by default (gamma = 0.6, beta =
  /// (gamma + 1/2)^2 / 4 = 0.3025; the paper's beta = 0.3, gamma = 0.5 has none): most of the
  /// specimen's yarns end free on its sides, and with yarns that bend in the plane as a fibre
  /// bundle does (docs/verification.md, "Bias extension") the free ends' fast modes grew without
  /// it (the kinetic energy from 1e-7 J to 25 J in 0.04 s, then no convergence at 19.6 degrees).
  /// The secant predictor (SolutionStep::secant_predictor): without it each increment of the
  /// pull started from the clamp's motion alone and took 10 iterations on average.
  BiasExtensionParameters() {
    rayleigh_mass = 0;
    rayleigh_out_of_plane = -1;
    newmark_gamma = 0.6;
    newmark_beta = 0.3025;
    secant_predictor = true;
  }
  /// Degrees, in (0, 90): the ideal shear angle of the central zone at the end of the step; the
  /// top clamp travels d(max_angle) (docs/shear-tests.md), ramped along `ramp`.
  double max_angle = 40;
  /// Where the shear angle is measured: the crossings with |x| + |y| <= central_region (H - W) / 2
  /// (H the free length), in (0, 1]; 1 is the whole of zone C.
  double central_region = 0.5;
  /// m, >= 0: the compaction of the crossings (SplineContactDefinition::compaction of the
  /// "warp-weft" contact), ramped from 0 in a step of its own (compaction_time, along `ramp`, the
  /// clamps held) before the pull and held after it. Most yarns of the specimen end free on its
  /// sides: only their crossings hold them, and a woven gap leaves those open (the fabric would
  /// come apart). 0: no such step.
  double compaction = 0;
  double compaction_time = 0; ///< s; 0: loading_time / 5
};

/// Adds the bias extension test to a specimen of build_bias_specimen(specimen) (its node sets
/// "clamp.bottom" and "clamp.top"): with a compaction, a first step in which the "warp-weft"
/// contact's compaction ramps to its value (spline contact only), then one step of the loading
/// time in which the bottom clamp holds its nodes (displacements and rotations 0) and the top clamp
/// moves its nodes by d(t) along y, rotations held, d from 0 to
/// bias_extension_displacement(max_angle, H - 2 clamp_length, W). Fills Model::bias_extension.
/// Throws std::invalid_argument for bad parameters, a free length H - 2 clamp_length below 2 W (the
/// benchmark's three zones and its energy method need H / W >= 2), a specimen not at 45 degrees, no
/// crossing in the central region, or a compaction without a spline contact "warp-weft".
void add_bias_extension_test(Fabric& fabric, const BiasSpecimenParameters& specimen,
                             const BiasExtensionParameters& parameters);

/// One point of a bias extension's curves (the benchmark's normalised force needs the whole
/// curve: bias_extension_normalised_force of shear_kinematics.hpp).
struct BiasExtensionReading {
  double displacement = 0; ///< d, the top clamp's travel, m
  double force = 0;        ///< F, the pull: the top clamp's reactions along y, summed, N
  double ideal_angle = 0;  ///< gamma of the central zone by the ideal kinematics, degrees
  MeasuredShear measured;  ///< on the yarns of the central region
};

/// The reading of model.bias_extension (which must be set) at time t (s), positions x
/// (3 x n_nodes, m) and the reactions at the prescribed DOFs (6 x n_nodes, forces first, N).
BiasExtensionReading read_bias_extension(const Model& model, double time, const Eigen::Matrix3Xd& x,
                                         const Eigen::Matrix<double, 6, Eigen::Dynamic>& reactions);

/// The local shear angle at each crossing at positions x (3 x n_nodes, m), degrees, in the order
/// of `crossings`: 90 less the in-plane angle from the warp's tangent to the weft's, as
/// measure_shear computes it per crossing (whose mean is the mean of these). The deformed
/// specimen's pictures of yarnsim study colour the crossings by it.
std::vector<double> local_shear(const std::vector<CrossingNodes>& crossings,
                                const Eigen::Matrix3Xd& x);

} // namespace yarnsim::textile
