#pragma once
// What the contact stage needs of the tangent it adds its pairs to: the couplings a pair asks the
// pattern to hold, and the slots of a pair's block in the matrix's stored values. The assembly
// stage (engine/assembly/assembler.hpp) implements ContactTarget, so the contact stage, which
// comes before the assembly on the data's path, does not include the assembler.

#include <array>
#include <compare>
#include <cstdint>

namespace yarnsim {

/// The nodes a contact pair couples in the tangent (unused slots repeat a node) and whether its
/// tangent has rotational terms: spline pairs act on the translations of their 6 control points
/// only, surface pairs on the translations and rotations of their 4 end nodes. Coupling only what
/// a pair uses keeps the matrix, and the factorisation's fill, at a quarter of the all-DOF
/// coupling for spline pairs.
struct ContactCoupling {
  std::array<int, 6> nodes{};
  bool rotations = false;
  auto operator<=>(const ContactCoupling&) const = default;
};

/// The tangent and residual a contact set adds its active pairs' terms to (ContactSet::assemble):
/// the matrix's stored values (compressed columns, one double per entry of the pattern) and where
/// a pair's block lies in them. The pattern must hold the pair's coupling (ContactCoupling).
class ContactTarget {
public:
  virtual ~ContactTarget() = default;
  /// Nodes of the model (the residual has 6 per node).
  virtual int n_nodes() const = 0;
  /// Names the current pattern: slots looked up in it stay valid while this is unchanged.
  virtual std::uint64_t pattern_id() const = 0;
  /// The matrix's stored values, indexed by the slots below.
  virtual double* tangent_values() = 0;
  /// A spline pair's 18 x 18 tangent over the translations of its 6 nodes: slots[18 r + c] is the
  /// index into tangent_values() of block entry (r, c), r = 3 a + i for node a's component i, or
  /// -1 where either DOF is constrained. Reads the pattern only: callable in parallel.
  virtual void translation_block_slots(const std::array<int, 6>& nodes, int* slots) const = 0;
  /// A surface pair's 24 x 24 tangent over the translations and rotations of its four end nodes,
  /// nodes = (A first, A last, B first, B last), in the kernel's order per surface: x_first,
  /// x_last, alpha_first, alpha_last (contact/surface_contact.hpp); slots[24 c + r] for block
  /// entry (r, c). Callable in parallel.
  virtual void surface_pair_block_slots(const std::array<int, 4>& nodes, int* slots) const = 0;

protected:
  ContactTarget() = default;
  ContactTarget(const ContactTarget&) = default;
  ContactTarget& operator=(const ContactTarget&) = default;
};

} // namespace yarnsim
