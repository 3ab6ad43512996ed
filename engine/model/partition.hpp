#pragma once
// The share of the model one process takes when a run is spread over several (MPI): a
// contiguous range of nodes, cut between whole yarns. The process assembles the beam elements
// whose first node it owns and its nodes' inertia and loads, and projects and assembles the
// contact pairs it owns (pair_owner_node, contact_set.hpp); the processes' residuals and matrices
// are then summed (Simulation::evaluate), so every element and pair is assembled once.

#include <span>
#include <vector>

namespace yarnsim {

struct Model;

/// The nodes [first, last) one process owns. The default owns every node (one process).
struct NodePartition {
  int first = 0;
  int last = 0;
  bool owns(int node) const { return node >= first && node < last; }
  bool operator==(const NodePartition&) const = default;
};

/// Process `rank` of `ranks`' nodes: each cut falls where the elements whose first node lies
/// before it make rank / ranks of all elements, moved to the nearer start of a connected body
/// (a yarn of a fabric: its elements chain its nodes; the following one where both are as near)
/// where the node numbering keeps bodies contiguous, so that a yarn's elements are assembled by
/// one process. A process may own no node (more processes than bodies). Throws
/// std::invalid_argument for rank outside [0, ranks).
NodePartition partition_nodes(const Model& model, int rank, int ranks);

/// Every process's range, in rank order (partition_nodes for each rank). With `load` (one value
/// per node, or empty), a node's share of the work is the elements whose first node it is plus
/// load[node] (in elements' worth: the contact pairs it owns, Simulation::rebalance), and the
/// cuts balance that. Throws std::invalid_argument for ranks < 1 or a load of another size, or
/// not finite and >= 0.
std::vector<NodePartition> partition_all(const Model& model, int ranks,
                                         std::span<const double> load = {});

/// Each process's work under `parts` (in rank order), as partition_all counts it: the elements
/// whose first node it owns plus the loads of its nodes. Throws as partition_all for a bad load.
std::vector<double> share_work(const Model& model, std::span<const NodePartition> parts,
                               std::span<const double> load = {});

} // namespace yarnsim
