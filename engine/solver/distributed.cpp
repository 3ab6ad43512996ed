#include "engine/solver/distributed.hpp"

#include <algorithm>

#ifdef YARNSIM_HAVE_MPI
#include <mpi.h>
#endif

namespace yarnsim::distributed {

#ifdef YARNSIM_HAVE_MPI
namespace {
bool running() {
  int initialised = 0, finalised = 0;
  MPI_Initialized(&initialised);
  MPI_Finalized(&finalised);
  return initialised && !finalised;
}
} // namespace

int rank() {
  int r = 0;
  if (running())
    MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r;
}

int size() {
  int n = 1;
  if (running())
    MPI_Comm_size(MPI_COMM_WORLD, &n);
  return n;
}

bool any(bool local) {
  if (size() == 1)
    return local;
  int mine = local ? 1 : 0, all = 0;
  MPI_Allreduce(&mine, &all, 1, MPI_INT, MPI_LOR, MPI_COMM_WORLD);
  return all != 0;
}

void sum(double* data, std::size_t n) {
  if (size() == 1)
    return;
  // MPI counts are ints: in chunks below 2^31 values.
  constexpr std::size_t kChunk = std::size_t{1} << 30;
  for (std::size_t offset = 0; offset < n; offset += kChunk)
    MPI_Allreduce(MPI_IN_PLACE, data + offset, static_cast<int>(std::min(kChunk, n - offset)),
                  MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
}

double largest(double local) {
  if (size() == 1)
    return local;
  double all = local;
  MPI_Allreduce(&local, &all, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  return all;
}

int ranks_on_this_machine() {
  if (size() == 1)
    return 1;
  MPI_Comm node;
  MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
  int n = 1;
  MPI_Comm_size(node, &n);
  MPI_Comm_free(&node);
  return n;
}
#else
int rank() {
  return 0;
}
int size() {
  return 1;
}
bool any(bool local) {
  return local;
}
void sum(double*, std::size_t) {}
double largest(double local) {
  return local;
}
int ranks_on_this_machine() {
  return 1;
}
#endif

Share share(int n) {
  const int r = rank(), p = size();
  const auto first = [&](int k) { return static_cast<int>(static_cast<long long>(n) * k / p); };
  return {first(r), first(r + 1)};
}

} // namespace yarnsim::distributed
