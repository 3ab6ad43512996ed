#include "engine/solver/distributed.hpp"

#include <algorithm>
#include <cstring>
#include <fmt/format.h>
#include <limits>
#include <stdexcept>
#include <tuple>
#include <utility>

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

namespace {
/// Each process's block start, in rank order, for blocks of `counts` units (an MPI int each), and
/// their total. Throws std::overflow_error where the starts leave MPI's int.
std::pair<std::vector<int>, long long> block_starts(const std::vector<int>& counts,
                                                    const char* what) {
  std::vector<int> offsets(counts.size(), 0);
  long long total = 0;
  for (std::size_t r = 0; r < counts.size(); ++r) {
    if (total > std::numeric_limits<int>::max())
      throw std::overflow_error(fmt::format("{}: {} units gathered from {} processes exceed an "
                                            "MPI int's count",
                                            what, total, counts.size()));
    offsets[r] = static_cast<int>(total);
    total += counts[r];
  }
  return {std::move(offsets), total};
}
} // namespace

std::vector<char> gather_bytes(const void* bytes, std::size_t n) {
  const char* begin = static_cast<const char*>(bytes);
  if (size() == 1)
    return std::vector<char>(begin, begin + n);
  // Counts in bytes as MPI ints: each process's share below 2 GiB.
  const int mine = static_cast<int>(n);
  std::vector<int> counts(static_cast<std::size_t>(size()));
  MPI_Allgather(&mine, 1, MPI_INT, counts.data(), 1, MPI_INT, MPI_COMM_WORLD);
  const auto [offsets, total] = block_starts(counts, "gather");
  std::vector<char> out(static_cast<std::size_t>(total));
  MPI_Allgatherv(begin, mine, MPI_BYTE, out.data(), counts.data(), offsets.data(), MPI_BYTE,
                 MPI_COMM_WORLD);
  return out;
}

void gather_on_first_bytes(const void* elements, std::size_t n, std::size_t element_size,
                           void* (*resize)(void* out, std::size_t total), void* out) {
  if (size() == 1) {
    if (n > 0)
      std::memcpy(resize(out, n), elements, n * element_size);
    return;
  }
  // Counted in elements (an MPI type of element_size bytes): the host's total may pass 2 GiB.
  MPI_Datatype element;
  MPI_Type_contiguous(static_cast<int>(element_size), MPI_BYTE, &element);
  MPI_Type_commit(&element);
  const int mine = static_cast<int>(n);
  std::vector<int> counts(static_cast<std::size_t>(size()));
  MPI_Gather(&mine, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
  std::vector<int> offsets(counts.size(), 0);
  void* into = nullptr;
  if (rank() == 0) { // only the host's counts are filled
    long long total = 0;
    std::tie(offsets, total) = block_starts(counts, "gather on the first process");
    into = resize(out, static_cast<std::size_t>(total));
  }
  MPI_Gatherv(elements, mine, element, into, counts.data(), offsets.data(), element, 0,
              MPI_COMM_WORLD);
  MPI_Type_free(&element);
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
void gather_on_first_bytes(const void* elements, std::size_t n, std::size_t element_size,
                           void* (*resize)(void* out, std::size_t total), void* out) {
  if (n > 0)
    std::memcpy(resize(out, n), elements, n * element_size);
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
