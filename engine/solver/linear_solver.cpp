#include "engine/solver/linear_solver.hpp"

// Eigen's MetisSupport needs <iostream> before it (engineering-notes.md).
#include <iostream>

#include <Eigen/CholmodSupport>
#include <Eigen/MetisSupport>
#include <Eigen/SparseCholesky>
#include <Eigen/UmfPackSupport>
#include <tbb/global_control.h>
#include <vector>

// OpenBLAS, behind CHOLMOD's supernodes, keeps its own thread pool (engineering-notes.md); weak:
// absent with another BLAS.
extern "C" void openblas_set_num_threads(int) __attribute__((weak));

namespace yarnsim {

namespace {

/// OpenBLAS threads for the dense kernels of one factorisation: the run's limit (--threads)
/// while it lasts, one outside it, so that OpenBLAS's pool and oneTBB's workers never spin at
/// once. A no-op with another BLAS (the reference one runs on the calling thread).
class BlasThreads {
public:
  BlasThreads() {
    if (openblas_set_num_threads)
      openblas_set_num_threads(static_cast<int>(
          tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)));
  }
  ~BlasThreads() {
    if (openblas_set_num_threads)
      openblas_set_num_threads(1);
  }
  BlasThreads(const BlasThreads&) = delete;
  BlasThreads& operator=(const BlasThreads&) = delete;
};

/// UMFPACK: symbolic analysis (column ordering) once per pattern, numeric LU per iteration. Its
/// fronts go through the BLAS: with Debian's reference BLAS dgemm took 38 % of the surface k = 1
/// case, with OpenBLAS (libopenblas0-pthread, scripts/setup) the case needs 43 % less CPU
/// (docs/performance.md). OpenBLAS runs on one thread here: on two its dgemm rounds differently
/// (the surface k = 1 case then differs between --threads 1 and 2 from the first increment), and
/// the fronts of these tangents are too small to gain from it.
class UmfpackSolver final : public LinearSolver {
public:
  UmfpackSolver() {
    // AMD/COLAMD: on the paper's fabric (5 256 DOF) the k = 1 case took 3.5-4.2 s with it against
    // 4.9-5.9 s with UMFPACK's METIS ordering.
    lu_.umfpackControl()(UMFPACK_ORDERING) = UMFPACK_ORDERING_AMD;
    // No iterative refinement: Newton's next iteration corrects what the factorisation's
    // round-off leaves, and the default two steps took 3.6 of the 4.3 ms of each solve on the
    // surface k = 1 case (5 184 equations).
    lu_.umfpackControl()(UMFPACK_IRSTEP) = 0;
  }
  void analyze(const SparseMatrix& A) override { lu_.analyzePattern(A); }
  void factorize(const SparseMatrix& A) override {
    if (openblas_set_num_threads)
      openblas_set_num_threads(1);
    lu_.factorize(A);
    if (lu_.info() != Eigen::Success)
      throw LinearSolverError("UMFPACK LU factorisation failed (singular or non-finite tangent)");
  }
  Eigen::VectorXd solve(const Eigen::VectorXd& b) override { return lu_.solve(b); }
  std::string name() const override { return "lu"; }

private:
  Eigen::UmfPackLU<SparseMatrix> lu_;
};

/// The symmetric part (A + A^T) / 2 of a structurally symmetric matrix, refreshed in place: the
/// transpose of each entry is found once per pattern.
class SymmetricPart {
public:
  const SparseMatrix& matrix() const { return sym_; }
  void analyze(const SparseMatrix& A) {
    sym_ = A;
    transpose_index_.assign(A.nonZeros(), -1);
    for (int col = 0; col < A.outerSize(); ++col)
      for (int k = A.outerIndexPtr()[col]; k < A.outerIndexPtr()[col + 1]; ++k) {
        const int row = A.innerIndexPtr()[k];
        const int* begin = A.innerIndexPtr() + A.outerIndexPtr()[row];
        const int* end = A.innerIndexPtr() + A.outerIndexPtr()[row + 1];
        const int* hit = std::lower_bound(begin, end, col);
        if (hit == end || *hit != col)
          throw LinearSolverError("the matrix pattern is not structurally symmetric");
        transpose_index_[k] = static_cast<int>(hit - A.innerIndexPtr());
      }
  }
  void update(const SparseMatrix& A) {
    const double* a = A.valuePtr();
    double* s = sym_.valuePtr();
    for (Eigen::Index k = 0; k < A.nonZeros(); ++k)
      s[k] = 0.5 * (a[k] + a[transpose_index_[k]]);
  }

private:
  SparseMatrix sym_;
  std::vector<int> transpose_index_;
};

/// Supernodal Cholesky LL^T of the symmetric part (CHOLMOD, METIS ordering): dense BLAS kernels
/// on the supernodes of the fill. CHOLMOD has no supernodal LDL^T, so an indefinite tangent fails
/// the LL^T; that iteration then falls back to SimplicialLDLT (analysed on first use).
class CholmodSolver final : public LinearSolver {
public:
  CholmodSolver() {
    cholmod_common& c = llt_.cholmod();
    c.nmethods = 1;
    c.method[0].ordering = CHOLMOD_METIS;
    c.postorder = 1;
    c.quick_return_if_not_posdef = 1;
    c.print = 0; // an indefinite tangent is expected now and then: no warning on stderr
  }
  void analyze(const SparseMatrix& A) override {
    sym_.analyze(A);
    llt_.analyzePattern(sym_.matrix());
    ldlt_analysed_ = false;
  }
  void factorize(const SparseMatrix& A) override {
    sym_.update(A);
    {
      // BLAS threads within the run's limit: the top separators of a large fabric are dense
      // blocks of thousands of rows.
      const BlasThreads threads;
      llt_.factorize(sym_.matrix());
    }
    use_ldlt_ = llt_.info() != Eigen::Success;
    if (!use_ldlt_)
      return;
    if (!ldlt_analysed_) {
      ldlt_.analyzePattern(sym_.matrix());
      ldlt_analysed_ = true;
    }
    ldlt_.factorize(sym_.matrix());
    if (ldlt_.info() != Eigen::Success)
      throw LinearSolverError("sparse LDLT factorisation failed (singular tangent)");
  }
  Eigen::VectorXd solve(const Eigen::VectorXd& b) override {
    return use_ldlt_ ? Eigen::VectorXd(ldlt_.solve(b)) : Eigen::VectorXd(llt_.solve(b));
  }
  std::string name() const override { return "cholmod"; }

private:
  SymmetricPart sym_;
  Eigen::CholmodSupernodalLLT<SparseMatrix, Eigen::Lower> llt_;
  Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower, Eigen::MetisOrdering<int>> ldlt_;
  bool ldlt_analysed_ = false;
  bool use_ldlt_ = false;
};

/// LDL^T of the symmetric part (Eigen SimplicialLDLT, METIS ordering). The METIS permutation and
/// the permuted upper triangle's pattern are made once per pattern, with the index of the
/// symmetric part's entry that fills each of its entries; a factorisation then gathers the values
/// into it and factors it in natural order. SimplicialLDLT with its own METIS ordering would
/// permute the whole matrix again at every factorisation (8 % of the paper's k = 1 run,
/// docs/performance.md). The arithmetic is the same: the same permutation, the same entries in
/// the same places.
class SymmetricLDLTSolver final : public LinearSolver {
public:
  void analyze(const SparseMatrix& A) override {
    sym_.analyze(A);
    // The ordering Eigen's SimplicialLDLT<..., MetisOrdering> computes: on the full symmetric
    // pattern; it returns the inverse permutation.
    {
      SparseMatrix full;
      full = sym_.matrix().selfadjointView<Eigen::Lower>();
      Eigen::MetisOrdering<int> ordering;
      ordering(full, inverse_permutation_);
    }
    permutation_ = inverse_permutation_.inverse();
    // The permuted upper triangle with, as values, the index of the entry of the symmetric
    // part's lower triangle that lands there (exact in a double below 2^53 entries).
    SparseMatrix index = sym_.matrix();
    for (Eigen::Index k = 0; k < index.nonZeros(); ++k)
      index.valuePtr()[k] = static_cast<double>(k);
    permuted_.resize(A.rows(), A.cols());
    permuted_.selfadjointView<Eigen::Upper>() =
        index.selfadjointView<Eigen::Lower>().twistedBy(permutation_);
    source_.resize(static_cast<std::size_t>(permuted_.nonZeros()));
    for (Eigen::Index k = 0; k < permuted_.nonZeros(); ++k)
      source_[static_cast<std::size_t>(k)] = static_cast<int>(permuted_.valuePtr()[k]);
    ldlt_.analyzePattern(permuted_);
  }
  void factorize(const SparseMatrix& A) override {
    sym_.update(A);
    const double* s = sym_.matrix().valuePtr();
    double* p = permuted_.valuePtr();
    for (std::size_t k = 0; k < source_.size(); ++k)
      p[k] = s[source_[k]];
    ldlt_.factorize(permuted_);
    if (ldlt_.info() != Eigen::Success)
      throw LinearSolverError("sparse LDLT factorisation failed (singular tangent)");
  }
  Eigen::VectorXd solve(const Eigen::VectorXd& b) override {
    const Eigen::VectorXd permuted_b = permutation_ * b;
    const Eigen::VectorXd y = ldlt_.solve(permuted_b);
    return inverse_permutation_ * y;
  }
  std::string name() const override { return "ldlt"; }

private:
  SymmetricPart sym_;
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> permutation_, inverse_permutation_;
  SparseMatrix permuted_;   ///< upper triangle of P S P^T, S the symmetric part
  std::vector<int> source_; ///< per entry of permuted_: the entry of S it takes
  Eigen::SimplicialLDLT<SparseMatrix, Eigen::Upper, Eigen::NaturalOrdering<int>> ldlt_;
};

} // namespace

std::unique_ptr<LinearSolver> make_linear_solver(LinearSolverKind kind) {
  if (kind == LinearSolverKind::Auto)
    throw std::invalid_argument("make_linear_solver: resolve 'auto' against the model first");
  if (kind == LinearSolverKind::LU)
    return std::make_unique<UmfpackSolver>();
  if (kind == LinearSolverKind::Cholmod)
    return std::make_unique<CholmodSolver>();
  return std::make_unique<SymmetricLDLTSolver>();
}

LinearSolverKind linear_solver_kind_from(const std::string& name) {
  if (name == "auto")
    return LinearSolverKind::Auto;
  if (name == "lu")
    return LinearSolverKind::LU;
  if (name == "ldlt")
    return LinearSolverKind::LDLTSymmetric;
  if (name == "cholmod")
    return LinearSolverKind::Cholmod;
  throw std::invalid_argument("unknown linear solver '" + name +
                              "' (expected 'auto', 'lu', 'ldlt' or 'cholmod')");
}

} // namespace yarnsim
