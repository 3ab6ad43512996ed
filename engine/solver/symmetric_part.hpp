#pragma once
// The symmetric part of a tangent, for the solvers that factorise it (linear_solver.cpp, and the
// distributed one, petsc_solver.cpp).

#include "engine/solver/linear_solver.hpp"

#include <algorithm>
#include <atomic>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <vector>

namespace yarnsim {

/// The symmetric part (A + A^T) / 2 of a structurally symmetric matrix, refreshed in place: the
/// transpose of each entry is found once per pattern.
class SymmetricPart {
public:
  const SparseMatrix& matrix() const { return sym_; }
  /// The index of entry k's transpose among the analysed matrix's values.
  int transpose(Eigen::Index k) const { return transpose_index_[static_cast<std::size_t>(k)]; }
  /// The columns are independent: in parallel (the same map on any thread count).
  void analyze(const SparseMatrix& A) {
    sym_ = A;
    transpose_index_.assign(A.nonZeros(), -1);
    std::atomic<bool> symmetric = true;
    tbb::parallel_for(tbb::blocked_range<int>(0, static_cast<int>(A.outerSize()), 1024),
                      [&](const tbb::blocked_range<int>& columns) {
                        for (int col = columns.begin(); col < columns.end(); ++col)
                          for (int k = A.outerIndexPtr()[col]; k < A.outerIndexPtr()[col + 1];
                               ++k) {
                            const int row = A.innerIndexPtr()[k];
                            const int* begin = A.innerIndexPtr() + A.outerIndexPtr()[row];
                            const int* end = A.innerIndexPtr() + A.outerIndexPtr()[row + 1];
                            const int* hit = std::lower_bound(begin, end, col);
                            if (hit == end || *hit != col)
                              symmetric = false;
                            else
                              transpose_index_[k] = static_cast<int>(hit - A.innerIndexPtr());
                          }
                      });
    if (!symmetric)
      throw LinearSolverError("the matrix pattern is not structurally symmetric");
  }
  /// Entry by entry (memory bound, in parallel: each entry the same on any thread count).
  void update(const SparseMatrix& A) {
    const double* a = A.valuePtr();
    double* s = sym_.valuePtr();
    const int* t = transpose_index_.data();
    tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, A.nonZeros(), 1 << 15),
                      [&](const tbb::blocked_range<Eigen::Index>& range) {
                        for (Eigen::Index k = range.begin(); k < range.end(); ++k)
                          s[k] = 0.5 * (a[k] + a[t[k]]);
                      });
  }

private:
  SparseMatrix sym_;
  std::vector<int> transpose_index_;
};

} // namespace yarnsim
