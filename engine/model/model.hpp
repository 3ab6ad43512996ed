#pragma once
// The resolved model: everything a run needs, in SI units, with every cross-reference turned into
// an index. Built from a TOML deck (engine/model/deck.hpp) or programmatically (textile builder).

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>
#include <vector>

namespace yarnsim {

/// Piecewise-linear function of time given by (time, value) rows; constant beyond both ends.
struct TimeTable {
  std::vector<double> time;  ///< s, strictly increasing
  std::vector<double> value; ///< same length as time

  /// Value at time t (s).
  double at(double t) const;
  /// A table that is 0 at t = 0 and 1 at t = t_end, linear in between.
  static TimeTable ramp(double t_end);
  static TimeTable constant(double v);
};

/// Linear elastic isotropic material.
struct Material {
  std::string name;
  double young = 0;   ///< E, Pa
  double shear = 0;   ///< G, Pa
  double density = 0; ///< kg/m^3
};

/// Shape of a section used for stiffness and contact geometry.
enum class SectionShape { General, Circle, Ellipse, SuperEllipse };

/// Section stiffnesses in the section's principal frame (axes 1, 2 in the section plane, 3 along
/// the beam axis). Resultants n_r = diag(GA1, GA2, EA) eta, m_r = D_m kappa (formulation.md §2).
struct Section {
  std::string name;
  double EA = 0;   ///< N
  double GA1 = 0;  ///< N, shear along axis 1 (includes the shear factor)
  double GA2 = 0;  ///< N
  double EI1 = 0;  ///< N m^2, bending about axis 1
  double EI2 = 0;  ///< N m^2, bending about axis 2
  double EI12 = 0; ///< N m^2, product term
  double GJ = 0;   ///< N m^2, torsion
  double rhoA = 0; ///< kg/m, mass per length
  /// Rotary inertia per length in the section frame, kg m: diag(rho I1, rho I2, rho (I1 + I2)).
  Eigen::Vector3d rhoJ = Eigen::Vector3d::Zero();

  SectionShape shape = SectionShape::General;
  double a = 0;        ///< semi-axis along section axis 1, m (circle: radius)
  double b = 0;        ///< semi-axis along section axis 2, m
  double exponent = 2; ///< super-ellipse exponent m (2 = ellipse)
};

/// A 3-node beam element; nodes in order along the axis: first, middle, last.
struct BeamElement {
  std::array<int, 3> nodes{};
  int section = 0;
  /// Direction of section axis 1 in the reference configuration (projected normal to the axis).
  Eigen::Vector3d reference_vector = Eigen::Vector3d::UnitY();
};

struct NodeSet {
  std::string name;
  std::vector<int> nodes; ///< indices into Model::nodes, sorted, unique
};

/// Degrees of freedom of a node, in this order: translations then rotations.
enum Dof : int { Ux = 0, Uy, Uz, Rx, Ry, Rz };
inline constexpr int kDofsPerNode = 6;

/// DOFs held fixed (zero displacement increment) on every node of a set.
struct Constraint {
  int node_set = 0;
  std::array<bool, 6> fixed{};
};

/// Prescribed motion of every node of a set as time tables. Displacements per component (m,
/// relative to the reference position); a rotation as a total rotation vector (rad) applied to the
/// reference triad, all three components together. A prescribed component is also a constraint.
struct PrescribedMotion {
  int node_set = 0;
  std::array<std::optional<TimeTable>, 3> displacement;
  std::optional<std::array<TimeTable, 3>> rotation;
};

/// The axes a nodal load's components are given in.
enum class LoadAxes {
  Global, ///< x, y, z
  /// The node's section axes e1, e2, e3 in the reference configuration (e3 along the beam, e1
  /// from the element's reference vector): the columns of the node's reference triad, taken from
  /// the first element that holds the node.
  Section
};

/// Nodal load on every node of a set: force (N, dead) and moment (N m) times a time table, both
/// with components along `axes` in the reference configuration. A dead load keeps that
/// direction; a follower moment rotates with the node from it.
struct NodalLoad {
  int node_set = 0;
  Eigen::Vector3d force = Eigen::Vector3d::Zero();
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();
  bool follower_moment = false;
  TimeTable factor = TimeTable::constant(1.0);
  LoadAxes axes = LoadAxes::Global;
};

enum class StepType { Static, Dynamic, Explicit };

/// One solution step; time runs on from the end of the previous step.
struct SolutionStep {
  StepType type = StepType::Static;
  double end_time = 1; ///< s, absolute
  double dt_initial = 0.1;
  double dt_min = 1e-6;
  double dt_max = 0.1;
  int max_iterations = 20;
  double tol_force = 1e-4;     ///< residual norm relative to the reference load norm
  double tol_increment = 1e-4; ///< increment norm relative to the step's displacement scale
  double newmark_beta = 0.3;
  double newmark_gamma = 0.5;
  /// Implicit steps: each increment after the step's first starts from the converged state moved
  /// on by the last increment's motion of the free nodes' translations, scaled by the ratio of
  /// the increments (the secant predictor; formulation.md "Solution"), instead of the converged
  /// state alone. The bias extension's steps take it (its free yarns then start where the pull
  /// carries them: 9 times fewer iterations, docs/performance.md "The secant predictor").
  bool secant_predictor = false;
  double rayleigh_mass = 0;      ///< C = a M + b K: a, 1/s
  double rayleigh_stiffness = 0; ///< b, s
  /// 1/s: mass-proportional damping of the translations along z alone, c m v_z (dynamic steps;
  /// the fabric builder's normal): it holds yarns floating across a weave's clearance without
  /// resisting the in-plane motion of a shear test (formulation.md "Solution").
  double rayleigh_out_of_plane = 0;
  int output_every = 1; ///< write results every N completed increments
  // Explicit steps (central difference, engine/solver/central_difference.cpp).
  double safety_factor = 0.8; ///< step = safety_factor * critical step (2 / omega_max)
  double mass_scaling_dt = 0; ///< s; > 0: add element mass until the stable step reaches it
  int stable_dt_every = 100;  ///< increments between estimates of the stable step
  bool energy_monitor = true; ///< energy bookkeeping written to energy.csv
};

enum class MonitorType { Node, NodeSet, Element };

/// A quantity written to <name>.csv every completed increment.
struct Monitor {
  std::string name;
  MonitorType type = MonitorType::Node;
  int target = 0; ///< node index, node-set index or element index
};

/// A contact curve for the beam-to-beam spline contact (formulation.md §5): a quadratic B-spline
/// whose control points are all the structural nodes of a yarn in order, with a circular section.
struct Spline {
  std::string name;
  std::vector<int> nodes; ///< control points, in order along the yarn (at least 3)
  double radius = 0;      ///< m
  /// Width of the yarn's section across the contact (fabrics: 2 a, the in-plane semi-axis), m:
  /// the footprint of torsional friction at its crossings; 0: 2 radius.
  double width = 0;
};

/// Normal interface law: f = penalty p^exponent (+ damping * dp/dt while p > 0), p the
/// penetration (formulation.md §4).
struct InterfaceLawParameters {
  double penalty = 0;  ///< N/m (N/m^exponent for the power law)
  double exponent = 1; ///< 1: linear penalty
  double damping = 0;  ///< N s/m
  /// m; > 0: the linear penalty's quadratic regularisation over this gap before contact
  /// (contact::RegularisedPenalty); 0: none.
  double regularisation = 0;
};

/// Coulomb friction of a contact (contact/friction.hpp): a tangential penalty (elastic stick)
/// and a return mapping onto the cone |f_t| <= mu f_n, mu_static bounding a point that stuck in
/// the last increment, mu_kinetic one that slipped. Frictionless when both coefficients are 0.
struct FrictionParameters {
  double mu_static = 0;  ///< -
  double mu_kinetic = 0; ///< -, <= mu_static
  /// N/m, > 0 when there is friction with a constant tangential penalty; 0 with an elastic slip.
  double tangential_penalty = 0;
  /// c_t, N s/m: a dashpot on the tangential sliding velocity beside the Coulomb element
  /// (contact/friction.hpp); dynamic steps only (the velocities of the time integrator).
  double tangential_damping = 0;
  /// Torsional friction at crossings (contact/torsional_friction.hpp,
  /// contact/surface_torsional_friction.hpp): a friction torque about the normal, bounded by
  /// mu f_n rho, with the same coefficients.
  bool torsional = false;
  /// rho, m; 0: per pair, footprint_radius(w_A, w_B) of the two splines' widths
  /// (Spline::width, 2 radius where not given), or of the two surfaces' widths 2 a
  /// (Surface::a).
  double torsional_radius = 0;
  /// k_r, N m/rad; 0: tangential_penalty rho^2.
  double torsional_penalty = 0;
  /// gamma, m: the stick stiffness mu f_n / gamma of every point, in place of the constant
  /// tangential penalty (contact/friction.hpp, CoulombFriction); 0: the tangential penalty.
  double elastic_slip = 0;
  bool active() const { return mu_static > 0 || mu_kinetic > 0; }
};

/// Spline-to-spline contact between two groups of splines (indices into Model::splines).
struct SplineContactDefinition {
  std::string name;
  std::vector<int> group_a, group_b;
  InterfaceLawParameters law;
  bool self_contact = false; ///< pairs within a group: between its splines and within one
  /// With self_contact: false keeps only the pairs between different splines of a group (the
  /// fabric deck's warp-warp and weft-weft contacts), true also those of a spline with itself
  /// beyond neighbouring segments.
  bool within_spline = true;
  double margin = 0; ///< m, broad-phase box inflation beyond the radius; 0: the radius
  /// m; > 0: the contact radius of every spline of this contact instead of its own
  /// (Spline::radius). The fabric deck's warp-warp and weft-weft contacts take the section's
  /// in-plane semi-axis a: yarns of one direction touch side by side, across their width.
  double radius = 0;
  /// Compaction c(t), m, >= 0: the pairs touch when their centre lines are r_A + r_B + c(t)
  /// apart, as if each section had grown by c / 2 (the contact distance and gap of every pair;
  /// the splines' radii for everything else). A fabric test ramps it over a step of its own to
  /// close the crossings a woven gap leaves open and press the yarns on each other as weaving
  /// does (docs/shear-tests.md, "Compaction"); constant 0 by default.
  TimeTable compaction = TimeTable::constant(0.0);
  /// All-angle contact (contact/line_contact.hpp): line contact below line_angle, point contact
  /// above point_angle, blended between; false: point contact at every angle (with its
  /// degenerate near-parallel path).
  bool line_contact = true;
  double line_angle = 10;  ///< degrees, in (0, point_angle)
  double point_angle = 20; ///< degrees, in (line_angle, 90]
  /// N/m^2 for the linear law (the law per unit length is the law times line_penalty /
  /// penalty); 0: penalty / (r_A + r_B)
  double line_penalty = 0;
  int gauss_points = 5; ///< per slave segment, 1 to 10
  /// Coulomb friction, at point contacts (crossing yarns) only: not on the line contact or the
  /// degenerate path of nearly parallel yarns.
  FrictionParameters friction{};
};

/// A contact surface for the surface-to-surface contact (formulation.md §6, the paper's eqs. 1-3):
/// on each element of a chain, a super-elliptical cylinder between the element's end nodes,
/// carried by their positions and rotations, oriented by the section axes (semi-axis a along
/// axis 1, b along axis 2).
struct Surface {
  std::string name;
  /// Indices into Model::elements in order along the yarn; consecutive elements share a node
  /// (the last node of one is the first of the next).
  std::vector<int> elements;
  double a = 0;        ///< m, semi-axis along section axis 1
  double b = 0;        ///< m, semi-axis along section axis 2
  double exponent = 2; ///< super-ellipse exponent m (2: ellipse)
};

/// Surface-to-surface contact between two groups of surfaces (indices into Model::surfaces).
struct SurfaceContactDefinition {
  std::string name;
  std::vector<int> group_a, group_b;
  InterfaceLawParameters law;
  double margin = 0; ///< m, broad-phase box inflation beyond the section; 0: the smaller semi-axis
  /// Coulomb friction at the contact points (contact/surface_friction.hpp): the coefficients,
  /// the tangential penalty, tangential damping (dynamic steps) and torsional friction at the
  /// crossings (contact/surface_torsional_friction.hpp). The law's normal damping is refused.
  FrictionParameters friction{};
};

/// The two yarn directions of a woven fabric.
enum class FabricDirection { Warp, Weft };

/// A virtual biaxial tension test on a fabric (paper §5): which node sets hold the yarn ends, so
/// the run can write the force-strain curves (curves.csv). Warp yarns run along x, weft along y.
struct BiaxialTest {
  double strain_ratio = 1;   ///< k = eps_warp / eps_weft
  double max_strain = 0.015; ///< in the larger direction
  double loading_time = 1;   ///< s
  double length_warp = 0;    ///< in-plane length between the ends of a warp yarn, m
  double length_weft = 0;    ///< m
  /// Per yarn: node sets of its start (x or y minimum) and end node.
  std::vector<int> warp_start, warp_end, weft_start, weft_end;
  /// Per yarn (warp yarns, then weft, as above): its nodes in order along it (the crimp).
  std::vector<std::vector<int>> yarn_nodes;
  /// Set: a uniaxial tension test. Only this direction's yarn ends are pulled (by max_strain);
  /// the other direction's ends are free (no prescribed DOF) and strain_ratio has no meaning.
  std::optional<FabricDirection> uniaxial;
  /// The yarns' end-to-end strain eps(t) the ends are pulled by, per direction (0 for the free
  /// direction of a uniaxial test): each end moves by eps(t) L / 2 along its yarn.
  TimeTable strain_warp = TimeTable::constant(0.0);
  TimeTable strain_weft = TimeTable::constant(0.0);
};

/// A crossing of a warp and a weft yarn where a shear test measures the angle between the yarns:
/// per yarn the nodes before, at and after the crossing along it (tangent x[next] - x[prev]).
struct CrossingNodes {
  std::array<int, 3> warp{};
  std::array<int, 3> weft{};
};

/// A picture-frame shear test (docs/shear-tests.md): a rigid square frame of side L hinged at its
/// corners, the yarn ends held by its arms; the corner A stays, the opposite corner is pulled
/// along the diagonal. In the reference configuration the arms lie along x and y from A. At frame
/// shear angle gamma the arm along x turns by +gamma / 2 and the arm along y by -gamma / 2, and a
/// point X held by an arm is at A + X1 e1 + X2 e2 with (X1, X2) = X - A, e1 = (cos gamma/2,
/// sin gamma/2), e2 = (sin gamma/2, cos gamma/2).
struct PictureFrameTest {
  double side = 0;                                  ///< L, hinge to hinge, m, before pretension
  Eigen::Vector2d corner = Eigen::Vector2d::Zero(); ///< A, m
  TimeTable angle = TimeTable::constant(0.0);       ///< gamma(t), rad
  /// s(t) = 1 + the pretension strain: the frame first grows by s about its centre c (at
  /// gamma = 0), so a point held at X is at A' + s F(gamma) (X - A), A' = c + s (A - c).
  TimeTable stretch = TimeTable::constant(1.0);
  double shear_start = 0;         ///< s, when the frame angle starts to ramp (after the pretension)
  double max_angle = 0;           ///< rad
  bool clamped = false;           ///< the arms also turn the ends (rotation about z), else pinned
  std::vector<int> ends;          ///< the yarn end nodes the arms hold
  std::vector<bool> end_on_x_arm; ///< per end: on an arm along x (a weft end)
  std::vector<CrossingNodes> central; ///< crossings of the central region
  double central_region = 0.5;        ///< side of that region over L
  std::vector<CrossingNodes> all;     ///< every crossing: the local shear angle of the pictures
  double locking_angle = 0;           ///< rad, acos(w / p): neighbouring parallel yarns touch

  /// The frame's linear map at time t, s F(gamma): F = [e1 e2], e1 = (cos gamma/2, sin gamma/2),
  /// e2 = (sin gamma/2, cos gamma/2) (its arms' directions).
  Eigen::Matrix2d linear_map(double t) const;
  /// Where the frame carries a point of the fabric's plane at reference X at time t, m:
  /// A' + s F(gamma) (X - A), A' = c + s (A - c), c the frame's centre.
  Eigen::Vector2d carried(double t, const Eigen::Vector2d& X) const;
};

/// A bias extension test (docs/shear-tests.md): a specimen cut with its yarns at +-45 degrees to
/// y, centred on the origin, clamped over clamp_length at both ends; the bottom clamp holds its
/// nodes (all six DOFs), the top clamp moves them by d(t) along y (rotations held).
struct BiasExtensionTest {
  double height = 0;       ///< H, the free length between the clamps, m
  double width = 0;        ///< W, m
  double clamp_length = 0; ///< m, at each end (the specimen is H + 2 clamp_length long)
  TimeTable displacement = TimeTable::constant(0.0); ///< d(t) of the top clamp along y, m
  double pull_start = 0; ///< s, when d starts to ramp (after the compaction step, if any)
  double compaction = 0; ///< m, of the crossings (SplineContactDefinition::compaction)
  double max_angle = 0;  ///< rad, the central zone's ideal shear angle at the end of the step
  int bottom_clamp = -1; ///< node set held
  int top_clamp = -1;    ///< node set pulled
  /// Crossings of the central part of zone C, |x| + |y| <= central_region (H - W) / 2 in the
  /// reference (zone C, where the yarns run from free edge to free edge, is central_region = 1).
  std::vector<CrossingNodes> central;
  double central_region = 0.5;
  std::vector<CrossingNodes> all; ///< every crossing: the local shear angle of the pictures
  double locking_angle = 0;       ///< rad, acos(w / p): neighbouring parallel yarns touch
};

struct Model {
  std::string title;
  std::vector<Eigen::Vector3d> nodes; ///< reference positions, m
  std::vector<Material> materials;
  std::vector<Section> sections;
  std::vector<BeamElement> elements;
  std::vector<NodeSet> node_sets;
  std::vector<Constraint> constraints;
  std::vector<PrescribedMotion> prescribed;
  std::vector<NodalLoad> loads;
  std::vector<SolutionStep> steps;
  std::vector<Monitor> monitors;
  std::vector<Spline> splines;
  std::vector<SplineContactDefinition> spline_contacts;
  std::vector<Surface> surfaces;
  std::vector<SurfaceContactDefinition> surface_contacts;
  std::optional<BiaxialTest> biaxial;
  std::optional<PictureFrameTest> picture_frame;
  std::optional<BiasExtensionTest> bias_extension;
  /// Optional user labels of nodes (deck ids); empty means node i is labelled i + 1.
  std::vector<long> node_labels;

  long node_label(int i) const { return node_labels.empty() ? i + 1 : node_labels[i]; }
  int find_node_set(const std::string& name) const; ///< -1 when absent
};

/// Section stiffnesses from a shape and a material (formulation.md §1). Reduction factors
/// multiply the moments of inertia about axis 1 and axis 2 (the paper uses 0.1 on the lower one);
/// shear_factor is kappa in GA = kappa G A.
Section section_from_shape(std::string name, SectionShape shape, double a, double b,
                           double exponent, const Material& material, double reduce_I1,
                           double reduce_I2, double shear_factor);

/// Whether any contact of the model has friction.
inline bool has_friction(const Model& model) {
  for (const SplineContactDefinition& c : model.spline_contacts)
    if (c.friction.active())
      return true;
  for (const SurfaceContactDefinition& c : model.surface_contacts)
    if (c.friction.active())
      return true;
  return false;
}

/// Whether any contact of the model has torsional friction at its crossings.
inline bool has_torsional_friction(const Model& model) {
  for (const SplineContactDefinition& c : model.spline_contacts)
    if (c.friction.active() && c.friction.torsional)
      return true;
  for (const SurfaceContactDefinition& c : model.surface_contacts)
    if (c.friction.active() && c.friction.torsional)
      return true;
  return false;
}

} // namespace yarnsim
