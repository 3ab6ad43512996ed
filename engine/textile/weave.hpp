#pragma once
// The textile builder: a woven fabric of warp and weft yarns from a weave pattern, as TexGen
// would make it for the paper's study (paper §4-5, formulation.md §1), directly as a Model.

#include "engine/textile/fabric.hpp"

#include <Eigen/Core>

namespace yarnsim::textile {

/// Plain weave: [[1, 0], [0, 1]].
Eigen::MatrixXi plain_pattern();
/// Twill: each warp yarn over `over` weft yarns then under `under`, shifted by one weft yarn from
/// one warp yarn to the next (2/2 twill: twill_pattern(2, 2)).
Eigen::MatrixXi twill_pattern(int over = 2, int under = 2);
/// Basket: a plain weave of groups of n warp and n weft yarns (2x2 basket: basket_pattern(2)).
Eigen::MatrixXi basket_pattern(int n = 2);

/// What the builder needs. Warp yarns run along x and are spaced along y; weft yarns run along
/// y and are spaced along x; the fabric is centred on the origin with its mid-plane at z = 0.
struct WeaveParameters {
  /// pattern(i, j) = 1 if warp yarn i is on top of weft yarn j at their crossing, 0 if below;
  /// repeated over the yarn counts (warp i uses row i mod rows, weft j column j mod cols).
  Eigen::MatrixXi pattern = plain_pattern();
  int n_warp = 6;
  int n_weft = 6;
  double spacing_warp = 0; ///< m, between neighbouring warp yarns (along y)
  double spacing_weft = 0; ///< m, between neighbouring weft yarns (along x)
  /// In-plane length of a warp yarn, m, at least (n_weft - 1) spacing_weft: the yarn runs
  /// straight beyond its outer crossings (paper: 40.90909 mm = 9 spacings).
  double length_warp = 0;
  double length_weft = 0; ///< m, at least (n_warp - 1) spacing_warp
  /// Out-of-plane gap between the yarn surfaces at a crossing, m (paper: 0.11364 mm): the centre
  /// lines are h = 2 b + gap apart there, at z = +-h/2.
  double gap = 0;
  double a = 0; ///< section semi-axis in the fabric plane (section axis 1), m
  double b = 0; ///< section semi-axis normal to the fabric (axis 2), m; a circle when a == b
  /// Radius of the circular section of the spline contact, m (paper: b); 0 means b.
  double contact_radius = 0;
  YarnMaterial material;
  double reduce_lower_inertia = 0.1; ///< factor on the lower moment of inertia (paper: 0.1)
  /// Factor on the upper moment of inertia (in-plane bending of a flat yarn; ellipse_yarn_section).
  double reduce_upper_inertia = 1.0;
  double shear_factor = 5.0 / 6.0; ///< kappa in GA = kappa G A
  /// 3-node elements per crossing interval (paper 4: 36 elements per yarn of 9 spacings); the
  /// straight ends get as many per spacing, at least one.
  int elements_per_spacing = 4;
  /// Normal law of the warp-weft contact (paper: linear, 1.5e6 N/m for the spline contact,
  /// 3.5e5 N/m for the surface contact).
  InterfaceLawParameters contact_law{1.5e6, 1.0, 0.0};
  /// Which contact joins warp and weft; each yarn gets both a spline and a surface.
  ContactFormulation contact = ContactFormulation::Spline;
};

/// The paper's fabric (formulation.md §1): 6 + 6 yarns, plain weave, spacing 4.54545 mm, length
/// 40.90909 mm, gap 0.11364 mm, a = 1.136364 mm, b = r = 0.2840909 mm, EA = 38000 N, nu = 0.2,
/// 2540 kg/m^3, lower inertia x 0.1, 4 elements per spacing, spline penalty 1.5e6 N/m.
WeaveParameters paper_fabric();

/// Centre-line height of warp yarn i at its crossing with weft yarn j, m: +h/2 on top, -h/2 below
/// (the weft yarn is at the opposite height).
double warp_height(const WeaveParameters& p, int i, int j);

/// Builds the fabric. The centre lines pass through the crossings at z = +-h/2 with zero slope and
/// follow a cubic Hermite z(s) = z0 + (z1 - z0)(3t^2 - 2t^3) between neighbouring crossings (the
/// curve of TexGen's Bezier interpolation with in-plane tangents at the crossings); beyond the
/// outer crossings they run straight at the outer crossing's height. Nodes, mid nodes included,
/// are equally spaced in the in-plane coordinate and lie on the curve; a node sits at every
/// crossing. One elliptical section, axis 1 (semi-axis a) in the fabric plane. Node sets,
/// splines and the "warp-weft" spline contact as listed at Fabric and finish_fabric. Warp yarns
/// come first, then weft; each runs from its minimum to its maximum coordinate.
/// Throws std::invalid_argument for inconsistent parameters.
Fabric build_weave(const WeaveParameters& parameters);

} // namespace yarnsim::textile
