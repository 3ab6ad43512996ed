#pragma once
// The yarns as they are and as the contact sees them, for drawing: quad meshes written beside the
// centre lines in results.h5 / results.xdmf.
//
// - Yarn surface: at every node a ring of kRingPoints points on the node's section (ellipse or
//   super-ellipse |y1 / a|^m + |y2 / b|^m = 1, semi-axis a along section axis 1, b along axis 2),
//   placed with the node's current triad Q = exp(theta) Q0 (theta the node's total rotation
//   vector, Q0 its reference triad, columns: section axes 1, 2 and the beam axis); consecutive
//   rings of each element's two segments (first-middle, middle-last) joined by quads. This is
//   the surface the surface-to-surface contact sees (it uses the same nodal triads and sections,
//   formulation.md §6) and the section the beam's stiffness assumes.
// - Spline contact tube: a spline's centre line (the quadratic B-spline on its nodes,
//   formulation.md §5) sampled kTubeSamplesPerSegment times per segment, a circle of the contact
//   radius around it (a parallel-transported frame), quads between consecutive circles.
//
// Points are float32: drawing needs no more, and the surface then costs about as much per node
// and step as the centre-line arrays (12 x 3 x 4 B = 144 B).

#include <Eigen/Core>

#include <array>
#include <vector>

namespace yarnsim::output {

inline constexpr int kRingPoints = 12;           ///< points around a yarn's section
inline constexpr int kTubePoints = 8;            ///< points around a spline contact tube
inline constexpr int kTubeSamplesPerSegment = 2; ///< circles per spline segment

/// The section drawn at a node.
struct NodeSection {
  double a = 0;        ///< m, semi-axis along section axis 1
  double b = 0;        ///< m, semi-axis along section axis 2
  double exponent = 2; ///< super-ellipse exponent m (2: ellipse); > 0
};

/// A spline contact's centre line: its control points (nodes, in order) and contact radius.
struct ContactTube {
  std::vector<int> nodes; ///< at least 3
  double radius = 0;      ///< m
};

/// The quads of the yarn surface: ring k of node i is points kRingPoints i .. kRingPoints i + 11.
/// `elements`: 3-node beams (first, middle, last). Quads (4 point indices each, counter-clockwise
/// seen from outside when the section's axes 1, 2 and the element's direction are right-handed).
std::vector<std::array<int, 4>> surface_quads(const std::vector<std::array<int, 3>>& elements);

/// The ring points of every node: kRingPoints x n_nodes points, node-major, as float32 rows
/// (x, y, z). positions, rotations: 3 x n_nodes (m, rad); reference_triads, sections: n_nodes.
std::vector<float> surface_points(const Eigen::Matrix3Xd& positions,
                                  const Eigen::Matrix3Xd& rotations,
                                  const std::vector<Eigen::Matrix3d>& reference_triads,
                                  const std::vector<NodeSection>& sections);

/// Number of points of a tube's mesh.
int tube_point_count(const ContactTube& tube);

/// The quads of all tubes, points numbered tube after tube (circle after circle, kTubePoints
/// each).
std::vector<std::array<int, 4>> tube_quads(const std::vector<ContactTube>& tubes);

/// The tubes' points (float32 rows x, y, z) at `positions` (3 x n_nodes, m).
std::vector<float> tube_points(const Eigen::Matrix3Xd& positions,
                               const std::vector<ContactTube>& tubes);

} // namespace yarnsim::output
