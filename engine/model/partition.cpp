#include "engine/model/partition.hpp"

#include "engine/model/model.hpp"

#include <cmath>
#include <fmt/format.h>
#include <numeric>
#include <stdexcept>

namespace yarnsim {
namespace {

/// Each node's work: the elements whose first node it is, plus load[node] (checked).
std::vector<double> node_work(const Model& model, std::span<const double> load) {
  const std::size_t n = model.nodes.size();
  if (!load.empty() && load.size() != n)
    throw std::invalid_argument(fmt::format(
        "partition: expected a load for each of the {} nodes, found {}", n, load.size()));
  for (std::size_t i = 0; i < load.size(); ++i)
    if (!(std::isfinite(load[i]) && load[i] >= 0))
      throw std::invalid_argument(
          fmt::format("partition: expected a finite load >= 0, found {} at node {}", load[i], i));
  std::vector<double> work(load.begin(), load.end());
  work.resize(n, 0.0);
  for (const auto& e : model.elements)
    work[static_cast<std::size_t>(e.nodes[0])] += 1.0;
  return work;
}

} // namespace

std::vector<double> share_work(const Model& model, std::span<const NodePartition> parts,
                               std::span<const double> load) {
  const std::vector<double> work = node_work(model, load);
  std::vector<double> out;
  for (const NodePartition& p : parts)
    out.push_back(std::accumulate(work.begin() + p.first, work.begin() + p.last, 0.0));
  return out;
}

std::vector<NodePartition> partition_all(const Model& model, int ranks,
                                         std::span<const double> load) {
  if (ranks < 1)
    throw std::invalid_argument(
        fmt::format("partition: expected at least one process, found {}", ranks));
  const int n = static_cast<int>(model.nodes.size());
  // The bodies: nodes joined by elements (union-find, each root the smallest node).
  std::vector<int> root(static_cast<std::size_t>(n));
  std::iota(root.begin(), root.end(), 0);
  const auto find = [&root](int i) {
    while (root[i] != i)
      i = root[i] = root[root[i]];
    return i;
  };
  // The work of the nodes before each node (node_work), for the balance.
  const std::vector<double> work = node_work(model, load);
  std::vector<double> first_of(static_cast<std::size_t>(n) + 1, 0.0);
  std::partial_sum(work.begin(), work.end(), first_of.begin() + 1);
  for (const auto& e : model.elements) {
    for (int a : e.nodes) {
      const int ra = find(a), rb = find(e.nodes[0]);
      if (ra != rb)
        root[std::max(ra, rb)] = std::min(ra, rb);
    }
  }
  // A cut at node c splits no body when every node before c is in a body whose nodes all lie
  // before c: c starts a new body and no earlier body reaches past it.
  std::vector<int> last_of_body(static_cast<std::size_t>(n), -1);
  for (int i = 0; i < n; ++i)
    last_of_body[find(i)] = i;
  std::vector<char> clean(static_cast<std::size_t>(n) + 1, 0);
  clean[0] = clean[n] = 1;
  int reach = -1; // the furthest node of the bodies met so far
  for (int c = 0; c < n; ++c) {
    reach = std::max(reach, last_of_body[find(c)]);
    clean[c + 1] = reach == c;
  }
  const double total = first_of[n];
  std::vector<int> cut(static_cast<std::size_t>(ranks) + 1, n);
  cut[0] = 0;
  for (int r = 1; r < ranks; ++r) {
    const double target = std::floor(total * r / ranks); // elements alone: as integers
    const int at = static_cast<int>(std::lower_bound(first_of.begin(), first_of.end(), target) -
                                    first_of.begin());
    // The clean cut nearest the target: the first at or after it, or the last before it where
    // that is nearer (a heavy yarn then goes to the next process rather than this one).
    int c = std::clamp(at, cut[r - 1], n);
    while (c < n && !clean[c])
      ++c;
    int before = std::clamp(at, cut[r - 1], n);
    while (before > cut[r - 1] && !clean[before])
      --before;
    if (target - first_of[before] < first_of[c] - target) // cut[r - 1] is clean
      c = before;
    cut[r] = c;
  }
  std::vector<NodePartition> out(static_cast<std::size_t>(ranks));
  for (int r = 0; r < ranks; ++r)
    out[r] = {cut[r], cut[r + 1]};
  return out;
}

NodePartition partition_nodes(const Model& model, int rank, int ranks) {
  if (rank < 0 || rank >= ranks)
    throw std::invalid_argument(
        fmt::format("partition: expected a process in [0, {}), found {}", ranks, rank));
  return partition_all(model, ranks)[static_cast<std::size_t>(rank)];
}

} // namespace yarnsim
