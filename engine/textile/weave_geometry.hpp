#pragma once
// What the woven builders share (build_weave, weave.hpp; build_bias_specimen, specimen.hpp): the
// checks of the yarn's parameters, its section, and the crimped centre line of one yarn.

#include "engine/textile/weave.hpp"

#include <string_view>
#include <vector>

namespace yarnsim::textile {

/// Throws std::invalid_argument ("<what>: expected ...") unless the pattern holds only 0 and 1,
/// the spacings, a and b are > 0, gap and contact_radius >= 0 (all finite) and
/// elements_per_spacing >= 1. The counts and lengths are the caller's.
void check_yarn_parameters(const WeaveParameters& p, std::string_view what);

/// Adds the yarn's material and its elliptical section "yarn" (ellipse_yarn_section of a, b and
/// the inertia and shear factors) to the model: section 0 of a fresh model.
void add_yarn_section(Model& model, const WeaveParameters& p);

/// A point of a yarn's centre line: in-plane coordinate s along the yarn, m, and height z, m.
struct ProfilePoint {
  double s;
  double z;
};

/// The centre line of one yarn as 2 m + 1 points (element ends and mid nodes): straight at the
/// first crossing's height from s_start to the first crossing (no such part when s_start is the
/// first crossing), the cubic Hermite z0 + (z1 - z0)(3t^2 - 2t^3) (zero slope at both crossings)
/// between neighbouring crossings with per_spacing elements per spacing (points at s0 + t k
/// spacing, k the interval's spacings), straight from the last crossing to s_end. A straight part
/// has max(1, round(length / spacing x per_spacing)) elements. `crossings` (increasing) and `z`
/// give the crossings; a crossing's point has exactly the coordinate given, and so do s_start and
/// s_end.
std::vector<ProfilePoint> crimped_profile(double s_start, double s_end,
                                          const std::vector<double>& crossings,
                                          const std::vector<double>& z, double spacing,
                                          int per_spacing);

} // namespace yarnsim::textile
