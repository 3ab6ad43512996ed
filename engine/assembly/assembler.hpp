#pragma once
// Assembly of the beam elements into a residual over all DOFs and a tangent over the free
// equations, through a sparsity pattern built once. Elements are split into colours that share no
// node (even and odd elements along a yarn), so each colour is scattered in parallel without locks
// and every matrix entry is summed in the same order on any thread count.

#include "engine/assembly/sparse_matrix.hpp"
#include "engine/beam/beam_element.hpp"
#include "engine/contact/contact_target.hpp"
#include "engine/model/partition.hpp"
#include "engine/state/state.hpp"

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>
#include <vector>

namespace yarnsim {

struct Model;

/// Stiffness-proportional Rayleigh damping on the elements: f_d = b K_e v_e, tangent b a4 K_e.
struct StiffnessDamping {
  double b = 0;                              ///< s
  double a4 = 0;                             ///< Newmark d(velocity)/d(displacement), 1/s
  const Eigen::VectorXd* velocity = nullptr; ///< 6 n_nodes: v (m/s) and spatial omega (rad/s)
};

/// Implements ContactTarget: the contact stage adds its pairs' terms into this tangent.
class Assembler final : public ContactTarget {
public:
  /// constrained: per global DOF (6 n_nodes), true when its increment is prescribed. With
  /// `share` (one process's nodes in a run over several whose solver sums the processes' own
  /// entries, LinearSolver::sums_partial_tangents), the pattern holds only what that process
  /// assembles: the blocks of the elements whose first node it owns, of its nodes and of the
  /// contact couplings it is given; the element and node slots are kept for those alone. The
  /// matrix keeps the whole system's size and numbering, so the memory of the pattern and of
  /// the slots is the share's, not the model's (docs/performance.md, "A tangent pattern per
  /// process"). Without it, the whole pattern.
  Assembler(const Model& model, const std::vector<char>& constrained,
            std::optional<NodePartition> share = std::nullopt);

  int n_nodes() const override { return n_nodes_; }
  int n_equations() const { return n_equations_; }
  /// Equation of a global DOF (6 node + dof), -1 when constrained.
  int equation(int dof) const { return equation_[dof]; }
  const std::vector<int>& equations() const { return equation_; }
  const std::vector<BeamReference>& references() const { return reference_; }
  const std::vector<std::vector<int>>& colours() const { return colours_; }

  /// The process's share the pattern is limited to (constructor), or none: the whole pattern.
  const std::optional<NodePartition>& share() const { return share_; }
  /// Limits the pattern to another share (a run whose cuts moved: Simulation::rebalance): the
  /// pattern is built again for its elements and nodes with no contact coupling, the matrix
  /// zero. Throws std::logic_error where the Assembler was built without a share.
  void set_share(const NodePartition& share);

  /// The tangent over the free equations with the fixed pattern; setZero() keeps the pattern.
  SparseMatrix& matrix() { return matrix_; }
  const SparseMatrix& matrix() const { return matrix_; }
  void zero_matrix();

  /// Adds the beams' internal forces to residual (6 n_nodes) and, if want_tangent, their tangents
  /// to matrix(). Runs the colours in order, each in parallel. With `stress` (per element, the
  /// material section resultants at its Gauss points) the tangent's stress terms take those
  /// (the mixed integration point Newton, beam_internal_force); the forces, and the stiffness
  /// damping's K v, stay those of the current strains. With `owned`, only the elements whose
  /// first node it owns (a process's share of a run over several: partition.hpp).
  void add_beams(const State& state, Eigen::VectorXd& residual, bool want_tangent,
                 const StiffnessDamping& damping,
                 const std::vector<Eigen::Matrix<double, 6, 2>>* stress = nullptr,
                 const NodePartition* owned = nullptr);

  /// Adds a 3 x 3 block to the tangent at node rows/cols (offset 0: translations, 3: rotations).
  void add_node_block(int node, int row_offset, int col_offset, const Eigen::Matrix3d& block);

  /// Current nodal values of element e.
  BeamNodalValues nodal_values(const State& state, int e) const;

  /// Makes sure the pattern holds the blocks coupling the nodes of each group (translations, and
  /// rotations where the group asks for them); returns true when the pattern grew (the solver
  /// must analyse it again). The matrix keeps its values: a grown pattern holds the old entries
  /// where they were and zeros in the new ones, so a tangent half assembled (the beams') when a
  /// contact pair comes within reach is completed, not started again, and every entry is the
  /// same sum as if the pattern had held the coupling from the start. Cost: a merge of the sorted
  /// groups with couplings() and, for the groups not in it, a look-up of their entries.
  bool ensure_couplings(std::vector<ContactCoupling> groups);
  /// Makes the pattern hold exactly these contact couplings besides the beams': couplings no
  /// pair needs any more are dropped, so that the pattern (and the factorisation's fill) follows
  /// the contacts down as well as up. Zeroes the matrix when the pattern changes. Returns true
  /// when it changed.
  bool set_couplings(std::vector<ContactCoupling> groups);
  /// The contact couplings the pattern was asked to hold (ensure_couplings, set_couplings),
  /// sorted, without repeats; the pattern is a function of this list (a checkpoint restores it
  /// with set_couplings).
  const std::vector<ContactCoupling>& couplings() const { return couplings_; }
  /// Counts pattern rebuilds; a solver analyses again when it changes.
  int pattern_version() const { return pattern_version_; }
  /// Names the current pattern among every pattern any Assembler of the process has built (a
  /// process-wide counter): slots looked up in a pattern stay valid while this is unchanged.
  std::uint64_t pattern_id() const override { return pattern_id_; }
  /// matrix().valuePtr() (ContactTarget).
  double* tangent_values() override { return matrix_.valuePtr(); }

  /// Where a contact pair's 18 x 18 tangent over the translations of its 6 nodes goes: slots[18 r
  /// + c] is the index into matrix().valuePtr() of block entry (r, c), r = 3 a + i for node a's
  /// component i, or -1 where either DOF is constrained. The pattern must hold the coupling
  /// (ensure_couplings); throws std::logic_error naming the nodes if it does not. Reads the
  /// pattern only: pairs may be looked up in parallel and added in their order.
  void translation_block_slots(const std::array<int, 6>& nodes, int* slots) const override;

  /// The same for a surface contact pair's 24 x 24 tangent over the translations and rotations of
  /// its four end nodes, nodes = (A first, A last, B first, B last), in the kernel's order per
  /// surface: x_first, x_last, alpha_first, alpha_last (contact/surface_contact.hpp); slots[24 c
  /// + r] for block entry (r, c). The pattern must hold the coupling with rotations.
  void surface_pair_block_slots(const std::array<int, 4>& nodes, int* slots) const override;

  /// The matrix entries one process of a run over several may write (partition.hpp): those of
  /// the elements whose first node `owned` holds, of its nodes' blocks (inertia, loads) and of
  /// the blocks of `couplings` (its contact pairs'); 1 per entry of matrix().valuePtr(), else 0.
  /// With a share (constructor), `owned` must be it.
  std::vector<char> own_entries(const NodePartition& owned,
                                const std::vector<ContactCoupling>& couplings) const;

private:
  /// The pattern of the beams and couplings_, matrix() zero; with keep_values the entries of
  /// the old pattern (which the new one must hold) keep their values.
  void build_pattern(bool keep_values = false);
  /// The pattern grown by the entries of `added` it lacks, merged column by column into the old
  /// one (values kept, new entries 0) and the beams' and nodes' slots moved with their entries:
  /// the same pattern and slots as build_pattern(true) with `added` in couplings_, without
  /// visiting every element's block again. Returns whether the pattern grew (false: it held
  /// every entry already).
  bool grow_pattern(const std::vector<ContactCoupling>& added);

  /// The elements a pattern holds: those whose first node the share owns (all without one).
  bool holds_element(int e) const { return !share_ || share_->owns(connectivity_[e][0]); }
  /// The slots' index of node n (n less the share's first node), -1 when the share lacks it.
  int node_slot_index(int n) const {
    return !share_ ? n : share_->owns(n) ? n - share_->first : -1;
  }

  int n_nodes_ = 0;
  std::optional<NodePartition> share_; ///< see share()
  int pattern_version_ = 0;
  std::uint64_t pattern_id_ = 0;
  std::vector<ContactCoupling> couplings_; ///< see couplings()
  int n_equations_ = 0;
  std::vector<int> equation_;
  std::vector<std::array<int, 3>> connectivity_;
  std::vector<BeamReference> reference_;
  std::vector<std::vector<int>> colours_;
  SparseMatrix matrix_;
  /// grow_pattern's buffers, kept for their storage: the pattern before the growth, and where
  /// each of its entries went.
  SparseMatrix spare_;
  std::vector<int> moved_;
  /// Per element of the pattern (holds_element), in element order: value index of (i, j) at
  /// 18 j + i, or -1; element_slot_[e] is element e's row, -1 for those the pattern lacks.
  std::vector<std::array<int, 18 * 18>> element_slots_;
  std::vector<int> element_slot_;
  std::vector<std::array<int, 36>> node_slots_; ///< value index per node (i, j): node_slot_index
};

} // namespace yarnsim
