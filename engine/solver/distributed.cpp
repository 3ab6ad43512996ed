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

void share_blocks(double* data, const std::vector<int>& counts, const std::vector<int>& offsets) {
  if (size() == 1)
    return;
  MPI_Allgatherv(MPI_IN_PLACE, 0, MPI_DATATYPE_NULL, data, counts.data(), offsets.data(),
                 MPI_DOUBLE, MPI_COMM_WORLD);
}

namespace {
double reduced(double local, MPI_Op op) {
  if (size() == 1)
    return local;
  double all = local;
  MPI_Allreduce(&local, &all, 1, MPI_DOUBLE, op, MPI_COMM_WORLD);
  return all;
}
} // namespace

double largest(double local) {
  return reduced(local, MPI_MAX);
}

double smallest(double local) {
  return reduced(local, MPI_MIN);
}

std::vector<char> gather_bytes(const void* bytes, std::size_t n) {
  const char* begin = static_cast<const char*>(bytes);
  if (size() == 1)
    return std::vector<char>(begin, begin + n);
  // Counts in bytes as MPI ints: each process's share below 2 GiB.
  const int p = size();
  const int mine = static_cast<int>(n);
  std::vector<int> counts(static_cast<std::size_t>(p)), offsets(static_cast<std::size_t>(p), 0);
  MPI_Allgather(&mine, 1, MPI_INT, counts.data(), 1, MPI_INT, MPI_COMM_WORLD);
  long long total = 0;
  for (int r = 0; r < p; ++r) {
    offsets[r] = static_cast<int>(total);
    total += counts[r];
  }
  std::vector<char> out(static_cast<std::size_t>(total));
  MPI_Allgatherv(begin, mine, MPI_BYTE, out.data(), counts.data(), offsets.data(), MPI_BYTE,
                 MPI_COMM_WORLD);
  return out;
}

std::vector<char> gather_bytes_on_first(const void* bytes, std::size_t n) {
  const char* begin = static_cast<const char*>(bytes);
  if (size() == 1)
    return std::vector<char>(begin, begin + n);
  // Counts in bytes as MPI ints: each process's share below 2 GiB.
  const int p = size();
  const int mine = static_cast<int>(n);
  std::vector<int> counts(static_cast<std::size_t>(p)), offsets(static_cast<std::size_t>(p), 0);
  MPI_Gather(&mine, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
  long long total = 0;
  for (int r = 0; r < p; ++r) {
    offsets[r] = static_cast<int>(total);
    total += counts[r];
  }
  std::vector<char> out(rank() == 0 ? static_cast<std::size_t>(total) : 0);
  MPI_Gatherv(begin, mine, MPI_BYTE, out.data(), counts.data(), offsets.data(), MPI_BYTE, 0,
              MPI_COMM_WORLD);
  return out;
}

double from_first(double value) {
  if (size() > 1)
    MPI_Bcast(&value, 1, MPI_DOUBLE, 0, MPI_COMM_WORLD);
  return value;
}

std::string first_message(const std::string& local) {
  if (size() == 1)
    return local;
  // Each process's message with its length ahead; the first non-empty one in rank order.
  const std::vector<char> all = gather_bytes(local.data(), local.size());
  const int mine = static_cast<int>(local.size());
  std::vector<int> lengths(static_cast<std::size_t>(size()));
  MPI_Allgather(&mine, 1, MPI_INT, lengths.data(), 1, MPI_INT, MPI_COMM_WORLD);
  std::size_t at = 0;
  for (const int length : lengths) {
    if (length > 0)
      return std::string(all.data() + at, static_cast<std::size_t>(length));
    at += static_cast<std::size_t>(length);
  }
  return {};
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
void share_blocks(double*, const std::vector<int>&, const std::vector<int>&) {}
double largest(double local) {
  return local;
}
double smallest(double local) {
  return local;
}
std::vector<char> gather_bytes(const void* bytes, std::size_t n) {
  const char* begin = static_cast<const char*>(bytes);
  return std::vector<char>(begin, begin + n);
}
std::vector<char> gather_bytes_on_first(const void* bytes, std::size_t n) {
  return gather_bytes(bytes, n);
}
double from_first(double value) {
  return value;
}
std::string first_message(const std::string& local) {
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
