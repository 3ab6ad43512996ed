#include "engine/assembly/assembler.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <stdexcept>

#include "engine/model/model.hpp"

#include <algorithm>
#include <atomic>
#include <cassert>
#include <iterator>
#include <stdexcept>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

namespace yarnsim {

namespace {

/// The next pattern's Assembler::pattern_id, unique in the process.
std::uint64_t next_pattern_id() {
  static std::atomic<std::uint64_t> last{0};
  return ++last;
}

/// Greedy colouring of elements so that no two elements of a colour share a node.
std::vector<std::vector<int>> colour_elements(const std::vector<std::array<int, 3>>& conn,
                                              int n_nodes) {
  std::vector<std::uint64_t> used(n_nodes, 0); // colours used around each node
  std::vector<std::vector<int>> colours;
  for (int e = 0; e < static_cast<int>(conn.size()); ++e) {
    std::uint64_t taken = 0;
    for (int n : conn[e])
      taken |= used[n];
    int c = 0;
    while (taken & (std::uint64_t{1} << c))
      ++c;
    if (c >= 64)
      throw std::runtime_error("element colouring needs more than 64 colours");
    if (c >= static_cast<int>(colours.size()))
      colours.resize(c + 1);
    colours[c].push_back(e);
    for (int n : conn[e])
      used[n] |= std::uint64_t{1} << c;
  }
  return colours;
}

/// Index into valuePtr of entry (row, col), -1 if not in the pattern.
int slot_of(const SparseMatrix& m, int row, int col) {
  if (row < 0 || col < 0)
    return -1;
  const int* begin = m.innerIndexPtr() + m.outerIndexPtr()[col];
  const int* end = m.innerIndexPtr() + m.outerIndexPtr()[col + 1];
  const int* hit = std::lower_bound(begin, end, row);
  return (hit != end && *hit == row) ? static_cast<int>(hit - m.innerIndexPtr()) : -1;
}

/// Visits (column, row) of every free equation pair among `count` nodes' first `dofs` DOFs: an
/// element's, a node's or a contact coupling's block of the pattern.
template <class Visit>
void for_each_block_entry(const std::vector<int>& equation, const int* nodes, int count, int dofs,
                          Visit&& visit) {
  for (int a = 0; a < count; ++a)
    for (int i = 0; i < dofs; ++i) {
      const int col = equation[6 * nodes[a] + i];
      if (col < 0)
        continue;
      for (int b = 0; b < count; ++b)
        for (int j = 0; j < dofs; ++j) {
          const int row = equation[6 * nodes[b] + j];
          if (row >= 0)
            visit(col, row);
        }
    }
}

} // namespace

Assembler::Assembler(const Model& model, const std::vector<char>& constrained,
                     std::optional<NodePartition> share)
    : n_nodes_(static_cast<int>(model.nodes.size())), share_(share) {
  if (static_cast<int>(constrained.size()) != kDofsPerNode * n_nodes_)
    throw std::invalid_argument("Assembler: constraint mask has the wrong size");
  if (share_ && (share_->first < 0 || share_->last < share_->first || share_->last > n_nodes_))
    throw std::invalid_argument(fmt::format("Assembler: a share of nodes [{}, {}) of a model of {}",
                                            share_->first, share_->last, n_nodes_));
  equation_.assign(constrained.size(), -1);
  for (std::size_t d = 0; d < constrained.size(); ++d)
    if (!constrained[d])
      equation_[d] = n_equations_++;

  connectivity_.reserve(model.elements.size());
  reference_.reserve(model.elements.size());
  for (const BeamElement& el : model.elements) {
    Eigen::Matrix3d X;
    for (int i = 0; i < 3; ++i)
      X.col(i) = model.nodes[el.nodes[i]];
    connectivity_.push_back(el.nodes);
    reference_.push_back(make_beam_reference(X, el.reference_vector, model.sections[el.section]));
  }
  colours_ = colour_elements(connectivity_, n_nodes_);

  build_pattern();
}

void Assembler::build_pattern(bool keep_values) {
  ++pattern_version_;
  pattern_id_ = next_pattern_id();
  SparseMatrix old;
  if (keep_values)
    old.swap(matrix_); // Eigen 3.4's SparseMatrix has no move assignment: swap, not copy
  // Pattern: every element's 18 x 18 block, every node's 6 x 6 block and every contact
  // coupling's 6 nodes (translations, or all six DOFs), free equations only. Bucketed by column
  // (a counting pass, then a filling pass) and sorted and deduplicated column by column: a global
  // sort of the (column, row) pairs took 7.5 % of the paper's k = 1 run (docs/performance.md).
  // With a share, only its elements and nodes.
  auto for_each_entry = [&](auto&& visit) {
    for (std::size_t e = 0; e < connectivity_.size(); ++e)
      if (holds_element(static_cast<int>(e)))
        for_each_block_entry(equation_, connectivity_[e].data(), 3, 6, visit);
    for (int n = 0; n < n_nodes_; ++n)
      if (node_slot_index(n) >= 0)
        for_each_block_entry(equation_, &n, 1, 6, visit);
    for (const auto& c : couplings_)
      for_each_block_entry(equation_, c.nodes.data(), 6, c.rotations ? 6 : 3, visit);
  };
  std::vector<std::size_t> start(static_cast<std::size_t>(n_equations_) + 1, 0);
  for_each_entry([&](int col, int) { ++start[static_cast<std::size_t>(col) + 1]; });
  for (int c = 0; c < n_equations_; ++c)
    start[c + 1] += start[c];
  std::vector<int> rows(start.back());
  std::vector<std::size_t> next(start.begin(), start.end() - 1);
  for_each_entry([&](int col, int row) { rows[next[static_cast<std::size_t>(col)]++] = row; });
  // Each column sorted and deduplicated, compacted in place.
  std::size_t kept = 0;
  std::vector<int> column_end(static_cast<std::size_t>(n_equations_) + 1, 0);
  for (int c = 0; c < n_equations_; ++c) {
    const auto begin = rows.begin() + static_cast<std::ptrdiff_t>(start[c]);
    const auto end = rows.begin() + static_cast<std::ptrdiff_t>(start[c + 1]);
    std::sort(begin, end);
    const auto last = std::unique(begin, end);
    kept = static_cast<std::size_t>(std::copy(begin, last, rows.begin() + kept) - rows.begin());
    column_end[c + 1] = static_cast<int>(kept);
  }

  matrix_.resize(n_equations_, n_equations_);
  matrix_.resizeNonZeros(static_cast<Eigen::Index>(kept));
  std::copy(column_end.begin(), column_end.end(), matrix_.outerIndexPtr());
  std::copy(rows.begin(), rows.begin() + static_cast<std::ptrdiff_t>(kept),
            matrix_.innerIndexPtr());
  std::fill(matrix_.valuePtr(), matrix_.valuePtr() + kept, 0.0);
  if (keep_values) {
    // Column by column, the old rows are a subset of the new ones, both sorted: one merge.
    for (int c = 0; c < n_equations_; ++c) {
      Eigen::Index s = matrix_.outerIndexPtr()[c];
      for (Eigen::Index k = old.outerIndexPtr()[c]; k < old.outerIndexPtr()[c + 1]; ++k) {
        while (s < matrix_.outerIndexPtr()[c + 1] &&
               matrix_.innerIndexPtr()[s] < old.innerIndexPtr()[k])
          ++s;
        if (s == matrix_.outerIndexPtr()[c + 1] ||
            matrix_.innerIndexPtr()[s] != old.innerIndexPtr()[k])
          throw std::logic_error("Assembler::build_pattern: the new pattern lacks an old entry");
        matrix_.valuePtr()[s] = old.valuePtr()[k];
      }
    }
  }

  // Column-major like ElementMatrix, so the scatter reads both in memory order.
  element_slot_.assign(connectivity_.size(), -1);
  element_slots_.clear(); // keeps its storage for the next build (set_couplings)
  std::size_t held = 0;
  for (std::size_t e = 0; e < connectivity_.size(); ++e)
    held += holds_element(static_cast<int>(e)) ? 1 : 0;
  element_slots_.reserve(held);
  for (std::size_t e = 0; e < connectivity_.size(); ++e) {
    if (!holds_element(static_cast<int>(e)))
      continue;
    element_slot_[e] = static_cast<int>(element_slots_.size());
    auto& slots = element_slots_.emplace_back();
    for (int j = 0; j < 18; ++j)
      for (int i = 0; i < 18; ++i)
        slots[18 * j + i] = slot_of(matrix_, equation_[6 * connectivity_[e][i / 6] + i % 6],
                                    equation_[6 * connectivity_[e][j / 6] + j % 6]);
  }
  node_slots_.resize(share_ ? static_cast<std::size_t>(share_->last - share_->first)
                            : static_cast<std::size_t>(n_nodes_));
  for (int n = 0; n < n_nodes_; ++n) {
    const int k = node_slot_index(n);
    if (k < 0)
      continue;
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 6; ++j)
        node_slots_[static_cast<std::size_t>(k)][6 * i + j] =
            slot_of(matrix_, equation_[6 * n + i], equation_[6 * n + j]);
  }
}

void Assembler::set_share(const NodePartition& share) {
  if (!share_)
    throw std::logic_error("Assembler::set_share: built for the whole pattern");
  if (share.first < 0 || share.last < share.first || share.last > n_nodes_)
    throw std::invalid_argument(fmt::format("Assembler: a share of nodes [{}, {}) of a model of {}",
                                            share.first, share.last, n_nodes_));
  share_ = share;
  couplings_.clear();
  build_pattern();
}

void Assembler::zero_matrix() {
  // In parallel: at a million DOF the values take hundreds of MB, a serial fill would cap the
  // assembly's speed-up.
  double* values = matrix_.valuePtr();
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, matrix_.nonZeros(), 1 << 16),
                    [values](const tbb::blocked_range<Eigen::Index>& range) {
                      std::fill(values + range.begin(), values + range.end(), 0.0);
                    });
}

BeamNodalValues Assembler::nodal_values(const State& state, int e) const {
  BeamNodalValues v;
  for (int i = 0; i < 3; ++i) {
    v.x.col(i) = state.x.col(connectivity_[e][i]);
    v.alpha.col(i) = state.alpha.col(connectivity_[e][i]);
  }
  return v;
}

void Assembler::add_beams(const State& state, Eigen::VectorXd& residual, bool want_tangent,
                          const StiffnessDamping& damping,
                          const std::vector<Eigen::Matrix<double, 6, 2>>* stress,
                          const NodePartition* owned) {
  const bool damped = damping.b != 0.0 && damping.velocity != nullptr;
  const bool need_K = want_tangent || damped;
  double* values = matrix_.valuePtr();
  const double scale = 1.0 + (damped ? damping.b * damping.a4 : 0.0);
  // A pattern of a share holds only its elements: they are the ones assembled.
  if (share_ && owned && !(*owned == *share_))
    throw std::logic_error(fmt::format(
        "Assembler::add_beams: the elements of nodes [{}, {}) asked of a pattern of [{}, {})",
        owned->first, owned->last, share_->first, share_->last));
  if (share_)
    owned = &*share_;
  for (const std::vector<int>& colour : colours_) {
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, colour.size(), 32),
        [&](const tbb::blocked_range<std::size_t>& range) {
          ElementVector f;
          ElementMatrix K;
          for (std::size_t k = range.begin(); k != range.end(); ++k) {
            const int e = colour[k];
            if (owned && !owned->owns(connectivity_[e][0]))
              continue;
            const BeamNodalValues v = nodal_values(state, e);
            // The stress terms from `stress` where the tangent is wanted and no damping needs
            // the strains' own K first.
            const Eigen::Matrix<double, 6, 2>* s =
                stress && want_tangent && !damped ? &(*stress)[e] : nullptr;
            beam_internal_force(reference_[e], state.gauss[e], v, f, need_K ? &K : nullptr, s);
            if (damped) {
              ElementVector ve;
              for (int i = 0; i < 3; ++i)
                ve.segment<6>(6 * i) = damping.velocity->segment<6>(6 * connectivity_[e][i]);
              f += damping.b * (K * ve);
              if (stress && want_tangent) {
                ElementVector unused;
                beam_internal_force(reference_[e], state.gauss[e], v, unused, &K, &(*stress)[e]);
              }
            }
            for (int i = 0; i < 3; ++i)
              residual.segment<6>(6 * connectivity_[e][i]) += f.segment<6>(6 * i);
            if (!want_tangent)
              continue;
            const int* slots = element_slots_[static_cast<std::size_t>(element_slot_[e])].data();
            const double* Kv = K.data();
            for (int ij = 0; ij < 18 * 18; ++ij) {
              const int s = slots[ij];
              if (s >= 0)
                values[s] += scale * Kv[ij];
            }
          }
        });
  }
}

void Assembler::add_node_block(int node, int row_offset, int col_offset,
                               const Eigen::Matrix3d& block) {
  double* values = matrix_.valuePtr();
  const int k = node_slot_index(node);
  if (k < 0)
    throw std::logic_error(fmt::format("Assembler::add_node_block: node {} is not in the share "
                                       "[{}, {}) the pattern holds",
                                       node, share_->first, share_->last));
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const int s = node_slots_[static_cast<std::size_t>(k)][6 * (row_offset + i) + col_offset + j];
      if (s >= 0)
        values[s] += block(i, j);
    }
}

bool Assembler::ensure_couplings(std::vector<ContactCoupling> groups) {
  if (!std::is_sorted(groups.begin(), groups.end()))
    std::sort(groups.begin(), groups.end());
  groups.erase(std::unique(groups.begin(), groups.end()), groups.end());
  std::vector<ContactCoupling> unlisted;
  std::set_difference(groups.begin(), groups.end(), couplings_.begin(), couplings_.end(),
                      std::back_inserter(unlisted));
  if (unlisted.empty())
    return false;
  // Groups the pattern holds already (through the beams or other couplings) are listed too, so
  // that they are not looked up again; the pattern is the same with or without them.
  std::vector<ContactCoupling> merged;
  merged.reserve(couplings_.size() + unlisted.size());
  std::merge(couplings_.begin(), couplings_.end(), unlisted.begin(), unlisted.end(),
             std::back_inserter(merged));
  couplings_ = std::move(merged);
  return grow_pattern(unlisted);
}

bool Assembler::grow_pattern(const std::vector<ContactCoupling>& added) {
  // The entries (column, row) the pattern lacks, sorted and unique; the groups are looked up in
  // parallel, each thread's finds gathered and sorted (the same list on any thread count).
  tbb::enumerable_thread_specific<std::vector<std::pair<int, int>>> found;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, added.size(), 4),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      std::vector<std::pair<int, int>>& local = found.local();
                      for (std::size_t g = range.begin(); g != range.end(); ++g)
                        for_each_block_entry(equation_, added[g].nodes.data(), 6,
                                             added[g].rotations ? 6 : 3, [&](int col, int row) {
                                               if (slot_of(matrix_, row, col) < 0)
                                                 local.emplace_back(col, row);
                                             });
                    });
  std::vector<std::pair<int, int>> fresh;
  for (const auto& local : found)
    fresh.insert(fresh.end(), local.begin(), local.end());
  std::sort(fresh.begin(), fresh.end());
  fresh.erase(std::unique(fresh.begin(), fresh.end()), fresh.end());
  if (fresh.empty())
    return false;
  ++pattern_version_;
  pattern_id_ = next_pattern_id();
  // Column c of the grown pattern starts where the old one did, shifted by the fresh entries of
  // the columns before it; then every column is merged on its own, in parallel.
  // The old pattern goes to spare_ (a swap: Eigen 3.4's SparseMatrix has no move constructor,
  // and a copy of the matrix took most of a growth's time); the new one is written into the
  // storage spare_ held, which keeps a tenth more than it needs so that the next growths reuse
  // it instead of touching fresh pages.
  spare_.swap(matrix_);
  const SparseMatrix& old = spare_;
  const int* old_outer = old.outerIndexPtr();
  const int* old_inner = old.innerIndexPtr();
  const double* old_values = old.valuePtr();
  std::vector<int> fresh_start(static_cast<std::size_t>(n_equations_) + 1, 0);
  for (const auto& [col, row] : fresh)
    ++fresh_start[static_cast<std::size_t>(col) + 1];
  for (int c = 0; c < n_equations_; ++c)
    fresh_start[c + 1] += fresh_start[c];
  const auto size =
      static_cast<Eigen::Index>(old.nonZeros() + static_cast<Eigen::Index>(fresh.size()));
  matrix_.resize(n_equations_, n_equations_); // keeps the storage
  if (matrix_.data().allocatedSize() < size)
    matrix_.reserve(size + size / 10);
  matrix_.resizeNonZeros(size);
  int* outer = matrix_.outerIndexPtr();
  int* inner = matrix_.innerIndexPtr();
  double* values = matrix_.valuePtr();
  for (int c = 0; c <= n_equations_; ++c)
    outer[c] = old_outer[c] + fresh_start[c];
  std::vector<int>& moved = moved_; // old entry -> new entry
  moved.resize(static_cast<std::size_t>(old.nonZeros()));
  tbb::parallel_for(
      tbb::blocked_range<int>(0, n_equations_, 256), [&](const tbb::blocked_range<int>& range) {
        for (int c = range.begin(); c != range.end(); ++c) {
          int f = fresh_start[c], out = outer[c];
          for (int k = old_outer[c]; k < old_outer[c + 1]; ++k) {
            for (; f < fresh_start[c + 1] && fresh[f].second < old_inner[k]; ++f, ++out) {
              inner[out] = fresh[f].second;
              values[out] = 0.0;
            }
            inner[out] = old_inner[k];
            values[out] = old_values[k];
            moved[static_cast<std::size_t>(k)] = out++;
          }
          for (; f < fresh_start[c + 1]; ++f, ++out) {
            inner[out] = fresh[f].second;
            values[out] = 0.0;
          }
          assert(out == outer[c + 1]);
        }
      });
  tbb::parallel_for(std::size_t{0}, element_slots_.size(), [&](std::size_t e) {
    for (int& slot : element_slots_[e])
      if (slot >= 0)
        slot = moved[static_cast<std::size_t>(slot)];
  });
  tbb::parallel_for(std::size_t{0}, node_slots_.size(), [&](std::size_t i) {
    for (int& slot : node_slots_[i])
      if (slot >= 0)
        slot = moved[static_cast<std::size_t>(slot)];
  });
  return true;
}

std::vector<char> Assembler::own_entries(const NodePartition& owned,
                                         const std::vector<ContactCoupling>& couplings) const {
  if (share_ && !(owned == *share_))
    throw std::logic_error(fmt::format(
        "Assembler::own_entries: the entries of nodes [{}, {}) asked of a pattern of [{}, {})",
        owned.first, owned.last, share_->first, share_->last));
  std::vector<char> own(static_cast<std::size_t>(matrix_.nonZeros()), 0);
  const auto mark = [&own](const int* slots, int n) {
    for (int k = 0; k < n; ++k)
      if (slots[k] >= 0)
        own[static_cast<std::size_t>(slots[k])] = 1;
  };
  for (std::size_t e = 0; e < connectivity_.size(); ++e)
    if (owned.owns(connectivity_[e][0])) {
      const auto& slots = element_slots_[static_cast<std::size_t>(element_slot_[e])];
      mark(slots.data(), static_cast<int>(slots.size()));
    }
  for (int i = owned.first; i < owned.last; ++i)
    mark(node_slots_[static_cast<std::size_t>(node_slot_index(i))].data(), 36);
  std::array<int, 24 * 24> slots;
  for (const ContactCoupling& c : couplings) {
    if (c.rotations) {
      surface_pair_block_slots({c.nodes[0], c.nodes[1], c.nodes[2], c.nodes[3]}, slots.data());
      mark(slots.data(), 24 * 24);
    } else {
      translation_block_slots(c.nodes, slots.data());
      mark(slots.data(), 18 * 18);
    }
  }
  return own;
}

bool Assembler::set_couplings(std::vector<ContactCoupling> groups) {
  std::sort(groups.begin(), groups.end());
  groups.erase(std::unique(groups.begin(), groups.end()), groups.end());
  if (groups == couplings_)
    return false;
  couplings_ = std::move(groups);
  build_pattern();
  return true;
}

void Assembler::translation_block_slots(const std::array<int, 6>& nodes, int* slots) const {
  const int* inner = matrix_.innerIndexPtr();
  for (int b = 0; b < 6; ++b)
    for (int j = 0; j < 3; ++j) {
      const int col = equation_[6 * nodes[b] + j];
      const int column_end = col >= 0 ? matrix_.outerIndexPtr()[col + 1] : 0;
      for (int a = 0; a < 6; ++a) {
        // A node's free DOFs have ascending equations, held together in every column that holds
        // one of them (the pattern couples nodes, not DOFs): one search finds the first, the
        // others follow it.
        int s = -1;
        for (int i = 0; i < 3; ++i) {
          const int row = equation_[6 * nodes[a] + i];
          if (row < 0 || col < 0) {
            slots[18 * (3 * a + i) + 3 * b + j] = -1;
            continue;
          }
          s = s >= 0 && s + 1 < column_end && inner[s + 1] == row ? s + 1
                                                                  : slot_of(matrix_, row, col);
          if (s < 0)
            throw std::logic_error(fmt::format(
                "contact pair of nodes {} assembled without its coupling in the matrix pattern "
                "(ensure_couplings was not called with it)",
                fmt::join(nodes, ", ")));
          slots[18 * (3 * a + i) + 3 * b + j] = s;
        }
      }
    }
}

void Assembler::surface_pair_block_slots(const std::array<int, 4>& nodes, int* slots) const {
  // Global DOF of kernel index k: surface k / 12, then x_first, x_last, alpha_first, alpha_last.
  std::array<int, 24> dof;
  for (int k = 0; k < 24; ++k) {
    const int X = k / 12, r = k % 12;
    const int node = nodes[2 * X + (r % 6) / 3];
    dof[k] = 6 * node + (r < 6 ? 0 : 3) + r % 3;
  }
  for (int j = 0; j < 24; ++j) {
    const int col = equation_[dof[j]];
    for (int i = 0; i < 24; ++i) {
      const int row = equation_[dof[i]];
      const int s = row >= 0 && col >= 0 ? slot_of(matrix_, row, col) : -1;
      if (s < 0 && row >= 0 && col >= 0)
        throw std::logic_error(fmt::format(
            "surface contact pair of nodes {} assembled without its coupling in the matrix "
            "pattern (ensure_couplings was not called with it, with rotations)",
            fmt::join(nodes, ", ")));
      slots[24 * j + i] = s;
    }
  }
}

} // namespace yarnsim
