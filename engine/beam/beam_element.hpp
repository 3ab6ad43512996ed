#pragma once
// Geometrically exact (Simo-Reissner) 3-node beam element: quadratic Lagrange shape functions,
// two Gauss points (reduced integration), 6 DOF per node (displacement u and the Rodrigues
// parameters alpha of the rotation increment since the last converged step), updated-Lagrangian
// rotations as in Giraffe's Beam_1 (formulation.md §2).
//
// At a Gauss point, with Q = Q(alpha) Q_n the section rotation and kappa_n the spatial curvature of
// the last converged step (Pimenta's curvature update kappa = Xi(alpha) alpha' + Q(alpha) kappa_n):
//   Gamma = Q^T x' - Gamma_0                        material strain (shear 1, shear 2, axial)
//   K     = Q^T kappa = Q_n^T (Xi(alpha)^T alpha' + kappa_n)   material curvature change
// with Q(alpha)^T Xi(alpha) = Xi(alpha)^T. The strain energy per reference length is
//   e = 1/2 Gamma . C_N Gamma + 1/2 K . C_M K,  C_N = diag(GA1, GA2, EA),  C_M = [EI1 EI12 0; EI12
//   EI2 0; 0 0 GJ]
// The element residual is its gradient with respect to (u_i, alpha_i) and the tangent its Hessian,
// which is symmetric because alpha enters additively within a step. A rigid motion leaves Gamma and
// K unchanged, so it produces no internal force.

#include "engine/state/gauss_state.hpp"

#include <Eigen/Core>
#include <array>

namespace yarnsim {

struct Section;

/// Element DOF vector layout: node 0 (u, alpha), node 1 (u, alpha), node 2 (u, alpha).
using ElementVector = Eigen::Matrix<double, 18, 1>;
using ElementMatrix = Eigen::Matrix<double, 18, 18>;

/// Constants of one element, fixed at construction from the reference geometry.
struct BeamReference {
  /// N_i at the two Gauss points: shape(i, g).
  Eigen::Matrix<double, 3, 2> shape;
  /// dN_i/dS at the two Gauss points, 1/m (S: reference arc length).
  Eigen::Matrix<double, 3, 2> shape_derivative;
  /// Gauss weight times dS/dxi, m.
  Eigen::Vector2d weight;
  /// Section stiffnesses, material frame.
  Eigen::Matrix3d C_N, C_M;
  /// Reference strain Q_0^T X' at each Gauss point (material frame; (0, 0, 1) for a straight beam).
  std::array<Eigen::Vector3d, 2> gamma0;
  /// Reference section rotation at each Gauss point.
  std::array<Eigen::Matrix3d, 2> Q0;
};

/// Current nodal values of one element.
struct BeamNodalValues {
  Eigen::Matrix3d x;     ///< current positions, columns = nodes, m
  Eigen::Matrix3d alpha; ///< Rodrigues parameters of the step's rotation increment, columns = nodes
};

/// Builds the element constants. X: reference node positions (columns: first, middle, last), m;
/// reference_vector: section axis 1 direction. Throws std::invalid_argument on a degenerate
/// element.
BeamReference make_beam_reference(const Eigen::Matrix3d& X, const Eigen::Vector3d& reference_vector,
                                  const Section& section);

/// Internal force vector (gradient of the strain energy), 18 entries, N and N m conjugate to
/// (u, alpha). If tangent is non-null it receives the consistent tangent (Hessian), 18 x 18:
///   K = sum_g W (B^T C B + G(n, m)),  G the stress terms, linear in the section resultants.
/// With `stress` (material resultants at the Gauss points, as beam_section_resultants) G takes
/// those instead of the current strains' C (Gamma; K): the tangent of the mixed integration
/// point Newton (Magisano, Leonetti and Garcea, "How to improve efficiency and robustness of the
/// Newton method in geometrically non-linear structural problem discretized via displacement-based
/// finite elements", Comput. Methods Appl. Mech. Engrg. 313 (2017) 986; formulation.md
/// "Solution"). The force is the displacement-based one either way.
void beam_internal_force(const BeamReference& ref, const std::array<GaussState, 2>& history,
                         const BeamNodalValues& values, ElementVector& force,
                         ElementMatrix* tangent,
                         const Eigen::Matrix<double, 6, 2>* stress = nullptr);

/// Material strains at the two Gauss points (rows 0-2 Gamma, rows 3-5 K, columns the Gauss
/// points) of `values`, and in `rate` their derivative along the nodal increment `direction`
/// (x: translations, m; alpha: Rodrigues increments): the linearised strain increment B direction.
void beam_strains(const BeamReference& ref, const std::array<GaussState, 2>& history,
                  const BeamNodalValues& values, const BeamNodalValues& direction,
                  Eigen::Matrix<double, 6, 2>& strain, Eigen::Matrix<double, 6, 2>& rate);

/// Section resultants (rows 0-2 forces N, rows 3-5 moments N m) of material strains laid out as
/// beam_strains'.
Eigen::Matrix<double, 6, 2> beam_resultants_of_strains(const BeamReference& ref,
                                                       const Eigen::Matrix<double, 6, 2>& strain);

/// Strain energy of the element, J.
double beam_strain_energy(const BeamReference& ref, const std::array<GaussState, 2>& history,
                          const BeamNodalValues& values);

/// Section resultants in the material frame at the two Gauss points: rows 0-2 forces (N),
/// rows 3-5 moments (N m), columns = Gauss points.
Eigen::Matrix<double, 6, 2> beam_section_resultants(const BeamReference& ref,
                                                    const std::array<GaussState, 2>& history,
                                                    const BeamNodalValues& values);

/// The Gauss point history after the current values are accepted as converged.
std::array<GaussState, 2> beam_committed_history(const BeamReference& ref,
                                                 const std::array<GaussState, 2>& history,
                                                 const BeamNodalValues& values);

} // namespace yarnsim
