#pragma once
// The specimen of the bias extension test (Cao et al. 2008, ../shared/docs/shear-tests.md): a
// rectangle of H x W cut from a woven fabric with the yarns at +-45 degrees to its length, the
// pull direction. The weave's centre lines (weave.hpp: crossings at +-h/2, cubic Hermite between
// them) are rotated in-plane and trimmed to the rectangle; the node sets of the clamps and the
// free edges come with it.

#include "engine/textile/fabric.hpp"
#include "engine/textile/weave.hpp"

namespace yarnsim::textile {

/// What the specimen builder needs. Specimen frame: x across the specimen (width), y along it
/// (the pull direction), z normal to the fabric; the specimen is centred on the origin with its
/// mid-plane at z = 0.
struct BiasSpecimenParameters {
  /// The fabric: pattern, spacing_warp, spacing_weft, gap, a, b, contact_radius, material,
  /// reduce_lower_inertia, reduce_upper_inertia, shear_factor, elements_per_spacing, contact_law,
  /// contact. n_warp, n_weft, length_warp and length_weft are ignored: the rectangle decides which
  /// yarns there are and how long they are.
  WeaveParameters weave = paper_fabric();
  double height = 0; ///< H, m, at least 2 spacings: length along y (the pull direction)
  /// W, m, at least 2 spacings (the larger of spacing_warp and spacing_weft): along x. The bias
  /// extension's three zones need H / W >= 2 (the benchmark's specimens: 2 to 3); not enforced.
  double width = 0;
  /// Degrees, in (0, 90): the warp yarns run along (cos angle, sin angle) in the x-y plane, the
  /// weft yarns along (-sin angle, cos angle). 45 gives the bias extension specimen: the warp at
  /// 45 degrees clockwise from the pull (y), the weft at 45 degrees counter-clockwise from it.
  double angle = 45;
  /// m, >= 0 and < H / 2: the clamped zone at each end, |y| >= H/2 - clamp_length (node sets
  /// "clamp.bottom", "clamp.top"). 0: the clamps hold only the yarn ends on y = -+H/2.
  double clamp_length = 0;
};

/// Leftover between a yarn's outer crossing and the boundary, as a fraction of the spacing along
/// the yarn, below which the yarn ends at that crossing instead of running straight to the
/// boundary (no element shorter than this fraction of a spacing).
inline constexpr double kBiasShortEndFraction = 0.05;

/// Builds the bias extension specimen.
///
/// Grid: the weave in its own frame (warp yarns along u, spaced spacing_warp along v; weft yarns
/// along v, spaced spacing_weft along u) is rotated by `angle` (u = (cos, sin) angle, v = (-sin,
/// cos) angle) with a crossing at the specimen's centre: crossings at u = a spacing_weft,
/// v = b spacing_warp for integers a, b. The specimen is therefore symmetric under the half turn
/// about z for any angle; for angle = 45 and equal spacings its in-plane node positions are also
/// symmetric about x = 0 and about y = 0 (a mirror swaps warp and weft; for the plain weave it
/// maps the nodes onto themselves when z -> -z goes with it).
///
/// Yarns: every grid line that crosses the rectangle |x| <= W/2, |y| <= H/2 is a candidate yarn;
/// its crossings are the grid points inside the rectangle where it meets a kept yarn of the other
/// direction. Yarns with fewer than 2 crossings (stubs over a corner, whose whole length lies near
/// it) are dropped, repeatedly until every kept yarn has 2 or more; a crossing with a dropped yarn
/// is no crossing (the kept yarn gets no node and no undulation there). Warp yarns are named
/// warp<i>, i = 0, 1, ... in increasing v, weft yarns weft<j> in increasing u; the heights follow
/// the pattern by these indices (warp_height(weave, i, j), weft at the opposite height). Warp
/// yarns come first, then weft; a warp yarn runs in increasing u (from the left or bottom edge
/// to the right or top), a weft yarn in increasing v (from the bottom or right to the top or
/// left).
///
/// Profile: as build_weave: nodes at every crossing (warp and weft nodes at the same x, y bit
/// for bit), the cubic Hermite between neighbouring crossings with elements_per_spacing elements
/// per spacing, then straight at the outer crossing's height from the outer crossing to where the
/// centre line leaves the rectangle, with max(1, round(length / spacing elements_per_spacing))
/// equal elements; the end node lies exactly on the boundary (the boundary coordinate is set, not
/// computed). When that leftover is below kBiasShortEndFraction of the spacing along the yarn,
/// the yarn ends at its outer crossing instead (its end node within that distance of the boundary).
/// At 45 degrees with equal spacings every yarn end of one side has the same leftover (W = 20
/// spacings: 10 sqrt(2) spacings less whole ones, 0.14 spacing; one spacing more where a corner
/// stub was dropped), so the rule ends all the yarns of a side at their crossings or none.
///
/// Node sets, besides those of finish_fabric (which also adds the splines, the surfaces and the
/// "warp-weft" contact as build_weave): "clamp.bottom" (every node with y <= -H/2 + clamp_length,
/// and every yarn end trimmed at y = -H/2), "clamp.top" (y >= H/2 - clamp_length, and the yarn
/// ends trimmed at y = H/2), "edge.left" and "edge.right" (the yarn ends trimmed at x = -W/2 and
/// x = W/2). A yarn ending at its outer crossing belongs to the side its centre line leaves
/// through; an end at a corner belongs to both sides. Comparisons with a tolerance of 1e-9 of the
/// smaller spacing.
///
/// Throws std::invalid_argument (what was expected and what was found) for H or W below 2
/// spacings, angle outside (0, 90), clamp_length < 0 or 2 clamp_length >= H, fabric parameters
/// out of range (pattern entries other than 0 and 1, spacings, a, b <= 0, gap, contact_radius <
/// 0, elements_per_spacing < 1, the material), or a rectangle in which no warp and weft yarns
/// cross twice.
Fabric build_bias_specimen(const BiasSpecimenParameters& parameters);

} // namespace yarnsim::textile
