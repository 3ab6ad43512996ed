#pragma once
// The processes of an MPI run (`mpirun -np N yarnsim run DECK`, the build with YARNSIM_MPI; one
// process in the oneTBB build). Every process holds the whole model and takes the same steps in
// lockstep: their states are the same bits because the linear solver hands each of them the
// same solution (petsc_solver.hpp), so every decision of the Newton loop, the step control and
// the contact stage is taken alike without being communicated. Each assembles its share of the
// elements and pairs (engine/assembly/partition.hpp), summed here; what one process alone sees
// (a signal) is agreed here. docs/formulation.md, "Runs over MPI".

#include <cstddef>

namespace yarnsim::distributed {

/// This process's rank and the number of processes; 0 and 1 without MPI or before it starts.
int rank();
int size();

/// True on every process when `local` is true on any: a collective call, made by every process
/// at the same point of the run. `local` itself in a one-process run.
bool any(bool local);

/// This process's share of n equations (or columns): [begin, end), contiguous blocks in rank
/// order whose sizes differ by at most one; [0, n) in a one-process run.
struct Share {
  int begin, end;
};
Share share(int n);

/// Sums `data` (n values) over the processes in place: every process gets the same sums. A
/// collective call. Nothing to do in a one-process run.
void sum(double* data, std::size_t n);

/// The largest of `local` over the processes (collective); `local` in a one-process run.
double largest(double local);

/// Processes of this run on this machine (the node's share of the cores); 1 without MPI.
int ranks_on_this_machine();

} // namespace yarnsim::distributed
