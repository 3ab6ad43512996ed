#pragma once
// The share of the assembly one process takes when a run is spread over several (MPI): a
// contiguous range of nodes, cut between whole yarns. The process assembles the beam elements
// whose first node it owns and its nodes' inertia and loads, and projects and assembles the
// contact pairs it owns (pair_owned_by, contact_set.hpp); the processes' residuals and matrices
// are then summed (Simulation::evaluate), so every element and pair is assembled once.

#include <vector>

namespace yarnsim {

struct Model;

/// The nodes [first, last) one process owns. The default owns every node (one process).
struct NodePartition {
  int first = 0;
  int last = 0;
  bool owns(int node) const { return node >= first && node < last; }
};

/// Process `rank` of `ranks`' nodes: the cuts fall where the elements whose first node lies
/// before them make rank / ranks of all elements, each moved on to the start of the next
/// connected body (a yarn of a fabric: its elements chain its nodes) where the node numbering
/// keeps bodies contiguous, so that a yarn's elements are assembled by one process. A process
/// may own no node (more processes than bodies). Throws std::invalid_argument for rank outside
/// [0, ranks).
NodePartition partition_nodes(const Model& model, int rank, int ranks);

/// Every process's range, in rank order (partition_nodes for each rank).
std::vector<NodePartition> partition_all(const Model& model, int ranks);

} // namespace yarnsim
