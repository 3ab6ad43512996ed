#pragma once
// The processes of an MPI run (`mpirun -np N yarnsim run DECK`, the build with YARNSIM_MPI; one
// process in the oneTBB build). Every process holds the whole model and takes the same steps in
// lockstep: their states are the same bits because the linear solver hands each of them the
// same solution (petsc_solver.hpp), so every decision of the Newton loop, the step control and
// the contact stage is taken alike without being communicated. Each assembles its share of the
// elements and pairs (engine/model/partition.hpp), summed here; what one process alone sees
// (a signal) is agreed here. docs/formulation.md, "Runs over MPI".

#include <cstddef>
#include <cstring>
#include <string>
#include <vector>

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

/// Process r's block of `data`, the counts[r] values from offsets[r] (one entry per process,
/// blocks that do not overlap), from process r to every process: an all-gather in place
/// (collective). Nothing to do in a one-process run.
void share_blocks(double* data, const std::vector<int>& counts, const std::vector<int>& offsets);

/// The largest of `local` over the processes (collective); `local` in a one-process run.
double largest(double local);
/// The smallest of `local` over the processes (collective); `local` in a one-process run.
double smallest(double local);

/// Every process's `bytes` (n of them), concatenated in rank order, on every process
/// (collective); a copy of them in a one-process run.
std::vector<char> gather_bytes(const void* bytes, std::size_t n);

/// Every process's `local` values, concatenated in rank order, on every process (collective).
/// T is copied as bytes: plain values and fixed-size Eigen objects.
template <class T>
std::vector<T> gather(const std::vector<T>& local) {
  const std::vector<char> bytes = gather_bytes(local.data(), local.size() * sizeof(T));
  std::vector<T> out(bytes.size() / sizeof(T));
  if (!bytes.empty())
    std::memcpy(static_cast<void*>(out.data()), bytes.data(), bytes.size());
  return out;
}

/// Every process's `n` elements of `element_size` bytes concatenated in rank order on the first
/// process (rank 0), written where `resize(out, total)` says (it makes room for `total`
/// elements in `out` and returns where they go; called on the first process alone); nothing on
/// the others (collective). A copy of them in a one-process run. Counted in elements: each
/// process's share and the host's total below 2^31 of them.
void gather_on_first_bytes(const void* elements, std::size_t n, std::size_t element_size,
                           void* (*resize)(void* out, std::size_t total), void* out);

/// gather() to the first process alone: the others get an empty vector (collective). Received
/// straight into the vector (no copy of the host's whole).
template <class T>
std::vector<T> gather_on_first(const std::vector<T>& local) {
  std::vector<T> out;
  gather_on_first_bytes(
      local.data(), local.size(), sizeof(T),
      [](void* v, std::size_t total) -> void* {
        auto& o = *static_cast<std::vector<T>*>(v);
        o.resize(total);
        return o.data();
      },
      &out);
  return out;
}

/// The message of the lowest-ranked process whose `local` is not empty, on every process
/// (collective); empty when every process's is. `local` in a one-process run.
std::string first_message(const std::string& local);

/// Processes of this run on this machine (the node's share of the cores); 1 without MPI.
int ranks_on_this_machine();

} // namespace yarnsim::distributed
