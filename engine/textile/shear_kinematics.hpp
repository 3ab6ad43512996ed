#pragma once
// Kinematics and normalisations of the in-plane shear tests of woven fabrics, as the
// international benchmark defines them (Cao et al., "Characterization of mechanical behavior of
// woven fabrics: experimental methods and benchmark results", Composites Part A 39 (2008)
// 1037-1053; summarised in ../shared/docs/shear-tests.md). Angles in radians here (the benchmark
// writes degrees), lengths in metres, forces in newtons.

#include <span>
#include <vector>

namespace yarnsim::textile {

/// Picture frame of side L (hinge to hinge), pulled along its diagonal by d (m): the shear angle
/// gamma = pi/2 - 2 theta, cos(theta) = (sqrt(2) L + d) / (2 L) (theta the half-angle at the
/// moving corner). Throws std::invalid_argument for L <= 0 or d outside [-sqrt(2) L, (2 -
/// sqrt(2)) L] (the frame folded flat either way).
double picture_frame_angle(double d, double L);
/// The inverse: d(gamma) = 2 L cos(pi/4 - gamma/2) - sqrt(2) L.
double picture_frame_displacement(double gamma, double L);
/// Shear force of the fabric from the crosshead force F (N, the empty frame's force already
/// removed) at shear angle gamma: F_s = F / (2 cos(theta)), theta = pi/4 - gamma/2.
double picture_frame_shear_force(double F, double gamma);
/// Normalised shear force F_s L_frame / L_fabric^2 (N/m): F_s / L when the fabric fills the
/// frame.
double picture_frame_normalised_force(double F, double gamma, double L_frame, double L_fabric);

/// Bias extension of an H x W specimen (yarns at +-45 degrees, H / W >= 2 for the three zones)
/// pulled by d: the ideal shear angle of the central zone C,
/// gamma = pi/2 - 2 acos((H - W + d) / (sqrt(2) (H - W))). Throws std::invalid_argument unless
/// H > W > 0 and 0 <= d <= (sqrt(2) - 1) (H - W) (gamma reaches 90 degrees there).
double bias_extension_angle(double d, double H, double W);
/// The inverse: d(gamma) = sqrt(2) (H - W) cos(pi/4 - gamma/2) - (H - W).
double bias_extension_displacement(double gamma, double H, double W);

/// Whether a bias extension specimen's free length H (m) holds the test's three zones, H >= 2 W
/// (W its width, m), to round-off (1e-12 relative): the benchmark's H / W = 2 from a height and
/// two clamp lengths (0.21 - 2 x 0.005 = 0.19999999999999998 m for W = 0.1 m) passes. The deck,
/// the test's set-up and the energy method below all ask this.
inline bool bias_extension_zones_fit(double H, double W) {
  return W > 0 && H >= 2 * W * (1 - 1e-12);
}

/// Normalised shear force F_sh(gamma) of a bias extension test by the benchmark's energy method
/// (Cao 2008, eq. 18): from the power balance F d' = C_s(gamma) A_C gamma' + C_s(gamma/2) A_B
/// gamma'/2, A_C = (2 H W - 3 W^2)/2, A_B = W^2, C_s = F_sh cos(gamma):
///   F_sh(gamma) = [(H/W - 1) F (cos(gamma/2) - sin(gamma/2)) - W F_sh(gamma/2) cos(gamma/2)]
///                 / [(2 H - 3 W) cos(gamma)],
/// evaluated at the samples (gamma_i increasing from >= 0, F_i the pulling force there) by
/// marching: F_sh(gamma_i / 2) is interpolated linearly in the values already computed, starting
/// from F_sh(0) = F(0) / (2 W) (the formula's fixed point at gamma = 0); where gamma_i / 2 lies
/// above the last computed sample the interpolation runs to the unknown F_sh(gamma_i), and the
/// formula, linear in it, is solved for it. Returns F_sh at every sample, N/m. Throws
/// std::invalid_argument unless bias_extension_zones_fit(H, W) (zone C exists: 2 H - 3 W > 0),
/// the lengths agree and gamma increases.
std::vector<double> bias_extension_normalised_force(std::span<const double> gamma,
                                                    std::span<const double> F, double H, double W);

/// The shear angle at which neighbouring parallel yarns of width w (m) and spacing p (m) start
/// to touch: acos(w / p) (rad). Throws std::invalid_argument unless 0 < w < p.
double locking_angle(double w, double p);

} // namespace yarnsim::textile
