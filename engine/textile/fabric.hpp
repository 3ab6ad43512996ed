#pragma once
// A fabric: a Model whose beams are yarns, plus which nodes make each yarn. Shared by the weave
// builder (weave.hpp) and the TexGen reader (texgen.hpp): yarn material and sections, appending a
// yarn's node chain and elements, and the node sets, splines and spline contact of a fabric.

#include "engine/model/model.hpp"

#include <Eigen/Core>
#include <span>
#include <string>
#include <vector>

namespace yarnsim::textile {

/// A yarn of a fabric. Warp yarns run along x, weft yarns along y (paper §5).
struct Yarn {
  bool warp = true;
  int index = 0;             ///< 0-based within its direction: names "warp<index>", "weft<index>"
  std::vector<int> nodes;    ///< indices into Model::nodes, in order along the yarn (start to end)
  std::vector<int> elements; ///< indices into Model::elements, in order along the yarn
};

/// Which contact formulation joins the warp and the weft (paper §5: both are studied).
enum class ContactFormulation {
  Spline, ///< beam-to-beam contact of C1 quadratic splines with circular sections
  Surface ///< surface-to-surface contact of the elements' elliptical cylinders
};

/// A model built from yarns. Node sets per yarn: "warp<i>" (all its nodes), "warp<i>.start",
/// "warp<i>.end", the same for weft; "warp", "weft" (all nodes of a direction) and "warp.start",
/// "warp.end", "weft.start", "weft.end" (the ends of all yarns of a direction).
struct Fabric {
  Model model;
  std::vector<Yarn> yarns;
};

/// The yarn material, given by E or by EA (the study gives EA, formulation.md §1).
struct YarnMaterial {
  double young = 0;     ///< E, Pa; give exactly one of young and EA
  double EA = 0;        ///< N; then E = EA / A with A the section's area
  double poisson = 0.2; ///< nu: G = E / (2 (1 + nu)), unless shear is given
  double shear = 0;     ///< G, Pa; 0: from poisson
  double density = 0;   ///< kg/m^3, > 0

  /// The material for a section of `area` (m^2). Throws std::invalid_argument when neither or
  /// both of young and EA are given, or a value is out of range.
  Material resolve(double area, std::string name) const;
};

/// Shape of a yarn cross-section as a closed polygon in the section plane, (width, height)
/// coordinates: width along section axis 1 (in the fabric plane), height along axis 2.
struct SectionOutline {
  std::vector<Eigen::Vector2d> points; ///< counter-clockwise, m
};

/// Section of an elliptical yarn of semi-axes a (section axis 1) and b (axis 2). The lower
/// moment of inertia is multiplied by `reduce_lower_inertia` (the paper's 0.1 for the low bending
/// stiffness of a yarn of loose fibres): the one about axis 1 when b <= a (also for a circle),
/// else the one about axis 2; the upper one by `reduce_upper_inertia`. A bundle of fibres that
/// slide on each other bends far more easily than a solid of its section, and more so across
/// its width: the solid's upper inertia of a flat yarn (a / b = 7) is 49 times its lower one.
/// Throws std::invalid_argument unless a, b > 0 and both factors > 0.
Section ellipse_yarn_section(std::string name, double a, double b, const YarnMaterial& material,
                             double reduce_lower_inertia, double shear_factor = 5.0 / 6.0,
                             double reduce_upper_inertia = 1.0);

/// Section of a yarn of any outline (lenticular, power ellipse, rectangle): area and moments of
/// inertia about the centroid from the polygon, torsion from Saint-Venant's J = A^4 / (4 pi^2 Ip)
/// as section_from_shape. The contact geometry is the ellipse of the outline's half width and
/// half height (shape Ellipse, a and b): only the stiffness follows the outline.
Section outline_yarn_section(std::string name, const SectionOutline& outline,
                             const YarnMaterial& material, double reduce_lower_inertia,
                             double shear_factor = 5.0 / 6.0, double reduce_upper_inertia = 1.0);

/// Appends a yarn to `fabric`: nodes at `points` (2 n + 1 positions, m, along the centre line,
/// mid nodes included), n 3-node elements of `section`, each with section axis 1 along
/// up x (last - first node), i.e. in the fabric plane for up = z. Returns the new yarn's index in
/// fabric.yarns. Throws std::invalid_argument for an even number of points (< 3) or an element
/// whose axis is parallel to `up` or of zero length.
int append_yarn(Fabric& fabric, bool warp, std::span<const Eigen::Vector3d> points, int section,
                const std::vector<Eigen::Vector3d>& up);

/// Adds the node sets listed at Fabric, one Spline per yarn (all its nodes, radius
/// `contact_radius[y]` for yarn y), one Surface per yarn (its elements, the semi-axes of their
/// section's contact ellipse) and, when both directions have yarns, the contact "warp-weft"
/// between the warp and the weft yarns with `law`: spline contact (no self contact, broad-phase
/// margin the largest radius) or surface contact (margin the larger semi-axis).
void finish_fabric(Fabric& fabric, std::span<const double> contact_radius,
                   const InterfaceLawParameters& law,
                   ContactFormulation formulation = ContactFormulation::Spline);

/// "warp<i>" or "weft<i>".
std::string yarn_name(const Yarn& yarn);

} // namespace yarnsim::textile
