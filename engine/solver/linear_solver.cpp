#include "engine/solver/linear_solver.hpp"

// Eigen's MetisSupport needs <iostream> before it (engineering-notes.md).
#include <iostream>

#include <Eigen/MetisSupport>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseLU>
#include <Eigen/UmfPackSupport>
#include <vector>

namespace yarnsim {

namespace {

/// UMFPACK: symbolic analysis (column ordering) once per pattern, numeric LU per iteration.
class UmfpackSolver final : public LinearSolver {
public:
  UmfpackSolver() {
    // AMD/COLAMD: on the paper's fabric (5 256 DOF) the k = 1 case took 3.5-4.2 s with it against
    // 4.9-5.9 s with UMFPACK's METIS ordering.
    lu_.umfpackControl()(UMFPACK_ORDERING) = UMFPACK_ORDERING_AMD;
  }
  void analyze(const SparseMatrix& A) override { lu_.analyzePattern(A); }
  void factorize(const SparseMatrix& A) override {
    lu_.factorize(A);
    if (lu_.info() != Eigen::Success)
      throw LinearSolverError("UMFPACK LU factorisation failed (singular or non-finite tangent)");
  }
  Eigen::VectorXd solve(const Eigen::VectorXd& b) override { return lu_.solve(b); }
  std::string name() const override { return "lu"; }

private:
  Eigen::UmfPackLU<SparseMatrix> lu_;
};

class SparseLUSolver final : public LinearSolver {
public:
  void analyze(const SparseMatrix& A) override { lu_.analyzePattern(A); }
  void factorize(const SparseMatrix& A) override {
    lu_.factorize(A);
    if (lu_.info() != Eigen::Success)
      throw LinearSolverError("sparse LU factorisation failed: " + lu_.lastErrorMessage());
  }
  Eigen::VectorXd solve(const Eigen::VectorXd& b) override { return lu_.solve(b); }
  std::string name() const override { return "eigen-lu"; }

private:
  Eigen::SparseLU<SparseMatrix, Eigen::MetisOrdering<int>> lu_;
};

/// LDL^T of the symmetric part. The tangent's pattern is structurally symmetric, so the symmetric
/// part shares it; the transpose of each entry is found once per pattern.
class SymmetricLDLTSolver final : public LinearSolver {
public:
  void analyze(const SparseMatrix& A) override {
    sym_ = A;
    transpose_index_.assign(A.nonZeros(), -1);
    for (int col = 0; col < A.outerSize(); ++col)
      for (int k = A.outerIndexPtr()[col]; k < A.outerIndexPtr()[col + 1]; ++k) {
        const int row = A.innerIndexPtr()[k];
        const int* begin = A.innerIndexPtr() + A.outerIndexPtr()[row];
        const int* end = A.innerIndexPtr() + A.outerIndexPtr()[row + 1];
        const int* hit = std::lower_bound(begin, end, col);
        if (hit == end || *hit != col)
          throw LinearSolverError("ldlt: the matrix pattern is not structurally symmetric");
        transpose_index_[k] = static_cast<int>(hit - A.innerIndexPtr());
      }
    ldlt_.analyzePattern(sym_);
  }
  void factorize(const SparseMatrix& A) override {
    const double* a = A.valuePtr();
    double* s = sym_.valuePtr();
    for (Eigen::Index k = 0; k < A.nonZeros(); ++k)
      s[k] = 0.5 * (a[k] + a[transpose_index_[k]]);
    ldlt_.factorize(sym_);
    if (ldlt_.info() != Eigen::Success)
      throw LinearSolverError("sparse LDLT factorisation failed (singular tangent)");
  }
  Eigen::VectorXd solve(const Eigen::VectorXd& b) override { return ldlt_.solve(b); }
  std::string name() const override { return "ldlt"; }

private:
  SparseMatrix sym_;
  std::vector<int> transpose_index_;
  Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower, Eigen::MetisOrdering<int>> ldlt_;
};

} // namespace

std::unique_ptr<LinearSolver> make_linear_solver(LinearSolverKind kind) {
  if (kind == LinearSolverKind::Auto)
    throw std::invalid_argument("make_linear_solver: resolve 'auto' against the model first");
  if (kind == LinearSolverKind::LU)
    return std::make_unique<UmfpackSolver>();
  if (kind == LinearSolverKind::EigenLU)
    return std::make_unique<SparseLUSolver>();
  return std::make_unique<SymmetricLDLTSolver>();
}

LinearSolverKind linear_solver_kind_from(const std::string& name) {
  if (name == "auto")
    return LinearSolverKind::Auto;
  if (name == "lu")
    return LinearSolverKind::LU;
  if (name == "ldlt")
    return LinearSolverKind::LDLTSymmetric;
  if (name == "eigen-lu")
    return LinearSolverKind::EigenLU;
  throw std::invalid_argument("unknown linear solver '" + name +
                              "' (expected 'auto', 'lu', 'ldlt' or 'eigen-lu')");
}

} // namespace yarnsim
