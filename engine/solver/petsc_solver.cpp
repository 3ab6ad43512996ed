#include "engine/solver/petsc_solver.hpp"

#include <stdexcept>

#ifdef YARNSIM_HAVE_PETSC
#include "engine/solver/distributed.hpp"
#include "engine/solver/symmetric_part.hpp"

#include <algorithm>
#include <exception>
#include <fmt/format.h>
#include <petscksp.h>
// PetscObjectStateIncrease (developer level): the values written into the blocks directly.
#include <petsc/private/petscimpl.h>
#include <vector>
#endif

namespace yarnsim {

#ifdef YARNSIM_HAVE_PETSC
namespace {

/// A PETSc call's error as a LinearSolverError naming the call (the run's error handler returns
/// errors instead of printing them: apps/yarnsim.cpp).
void check(PetscErrorCode code, const char* call) {
  if (code == 0)
    return;
  const char* text = nullptr;
  PetscErrorMessage(code, &text, nullptr);
  throw LinearSolverError(
      fmt::format("PETSc: {} failed: {} (error {})", call, text ? text : "", int(code)));
}

class PetscSolver final : public LinearSolver {
public:
  explicit PetscSolver(bool symmetric) : symmetric_(symmetric) {
    // MUMPS's working space: 50 % over its analysis's estimate, as MumpsSolver asks (its
    // default, 20 %, runs out on indefinite tangents), unless PETSC_OPTIONS sets it.
    PetscBool set = PETSC_FALSE;
    check(PetscOptionsHasName(nullptr, nullptr, "-mat_mumps_icntl_14", &set),
          "PetscOptionsHasName");
    if (!set)
      check(PetscOptionsSetValue(nullptr, "-mat_mumps_icntl_14", "50"), "PetscOptionsSetValue");
  }
  ~PetscSolver() override {
    // Destroying PETSc's parallel objects is collective: skipped while this process unwinds
    // from a failure the others may not share (as ~MumpsSolver, linear_solver.cpp).
    if (distributed::size() > 1 && std::uncaught_exceptions() > 0)
      return;
    release();
  }
  PetscSolver(const PetscSolver&) = delete;
  PetscSolver& operator=(const PetscSolver&) = delete;

  /// A new pattern: PETSc's matrix, vectors and solver are made afresh. Given a whole tangent,
  /// the entries of this process's rows are found once, in the order of PETSc's arrays (diagonal
  /// block, then the off-diagonal block's columns in ascending order, both sorted within a row),
  /// so that a factorisation copies values without a search. Given this process's own entries
  /// (set_own_entries), their coordinates, in any row, are handed to PETSc once
  /// (MatSetPreallocationCOO), which sums the processes' values into the owners' rows at each
  /// factorisation (MatSetValuesCOO).
  void analyze(const SparseMatrix& A) override {
    release();
    if (symmetric_)
      sym_.analyze(A);
    const SparseMatrix& M = symmetric_ ? sym_.matrix() : A;
    const PetscInt n = static_cast<PetscInt>(M.rows());
    const distributed::Share rows = distributed::share(static_cast<int>(n));
    begin_ = rows.begin;
    end_ = rows.end;
    const PetscInt m = end_ - begin_;
    check(MatCreate(PETSC_COMM_WORLD, &matrix_), "MatCreate");
    check(MatSetSizes(matrix_, m, m, n, n), "MatSetSizes");
    check(MatSetType(matrix_, MATAIJ), "MatSetType");
    own_source_.clear();
    if (partial_)
      own_pattern(A, M);
    else
      whole_pattern(M);
    if (symmetric_) {
      check(MatSetOption(matrix_, MAT_SYMMETRIC, PETSC_TRUE), "MatSetOption");
      check(MatSetOption(matrix_, MAT_SYMMETRY_ETERNAL, PETSC_TRUE), "MatSetOption");
    }

    check(MatCreateVecs(matrix_, &x_, &b_), "MatCreateVecs");
    check(VecScatterCreateToAll(x_, &gather_, &x_all_), "VecScatterCreateToAll");
    check(KSPCreate(PETSC_COMM_WORLD, &ksp_), "KSPCreate");
    check(KSPSetOperators(ksp_, matrix_, matrix_), "KSPSetOperators");
    // A direct solve by default: MUMPS's LDL^T (Cholesky of a matrix not flagged positive
    // definite: SYM = 2) or LU. PETSc's options (PETSC_OPTIONS, e.g. "-pc_factor_mat_solver_type
    // superlu_dist" or "-ksp_type gmres -pc_type gamg") override it.
    check(KSPSetType(ksp_, KSPPREONLY), "KSPSetType");
    PC pc;
    check(KSPGetPC(ksp_, &pc), "KSPGetPC");
    check(PCSetType(pc, symmetric_ ? PCCHOLESKY : PCLU), "PCSetType");
    check(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS), "PCFactorSetMatSolverType");
    check(KSPSetFromOptions(ksp_), "KSPSetFromOptions");
  }

  void factorize(const SparseMatrix& A) override {
    if (symmetric_)
      sym_.update(A);
    const double* values = symmetric_ ? sym_.matrix().valuePtr() : A.valuePtr();
    if (partial_) {
      // Each process's own entries: PETSc sums them over the processes into the owners' rows.
      for (std::size_t i = 0; i < own_source_.size(); ++i)
        own_values_[i] = values[own_source_[i]];
      check(MatSetValuesCOO(matrix_, own_values_.data(), INSERT_VALUES), "MatSetValuesCOO");
    } else {
      fill(diagonal_block_, diagonal_source_, values);
      if (off_block_)
        fill(off_block_, off_source_, values);
      check(PetscObjectStateIncrease(reinterpret_cast<PetscObject>(matrix_)),
            "PetscObjectStateIncrease");
    }
    // The numeric factorisation here (PCSetUp sees the matrix's new state; KSPSolve then finds
    // it done), the symbolic one too after a new pattern.
    PC pc;
    check(KSPGetPC(ksp_, &pc), "KSPGetPC");
    check(KSPSetUp(ksp_), "KSPSetUp");
    check(PCSetUp(pc), "PCSetUp");
    PCFailedReason reason = PC_NOERROR;
    check(PCGetFailedReason(pc, &reason), "PCGetFailedReason");
    // MUMPS reports a failure to every process; agreed here all the same, since the caller
    // drops the attempt on every process or on none.
    if (distributed::any(reason != PC_NOERROR))
      throw LinearSolverError(fmt::format(
          "PETSc factorisation failed ({}): the tangent is singular, not finite, or the "
          "factorisation ran out of memory",
          reason != PC_NOERROR ? PCFailedReasons[reason] : "on another process"));
  }

  Eigen::VectorXd solve(const Eigen::VectorXd& b) override {
    PetscScalar* local = nullptr;
    check(VecGetArray(b_, &local), "VecGetArray");
    std::copy(b.data() + begin_, b.data() + end_, local);
    check(VecRestoreArray(b_, &local), "VecRestoreArray");
    check(KSPSolve(ksp_, b_, x_), "KSPSolve");
    KSPConvergedReason reason;
    check(KSPGetConvergedReason(ksp_, &reason), "KSPGetConvergedReason");
    Eigen::VectorXd x(b.size());
    if (reason < 0) { // the caller drops the attempt on a non-finite solution
      x.setConstant(std::numeric_limits<double>::quiet_NaN());
      return x;
    }
    // The whole solution on every process, the same bits on each.
    check(VecScatterBegin(gather_, x_, x_all_, INSERT_VALUES, SCATTER_FORWARD), "VecScatterBegin");
    check(VecScatterEnd(gather_, x_, x_all_, INSERT_VALUES, SCATTER_FORWARD), "VecScatterEnd");
    const PetscScalar* all = nullptr;
    check(VecGetArrayRead(x_all_, &all), "VecGetArrayRead");
    std::copy(all, all + b.size(), x.data());
    check(VecRestoreArrayRead(x_all_, &all), "VecRestoreArrayRead");
    return x;
  }

  std::string name() const override { return "petsc"; }
  bool sums_partial_tangents() const override { return distributed::size() > 1; }
  void set_own_entries(std::vector<char> own) override {
    own_ = std::move(own);
    partial_ = true;
  }

private:
  /// The pattern of a whole tangent M: this process's rows, preallocated and set (zeros), and
  /// the indices in M of PETSc's local arrays' entries.
  void whole_pattern(const SparseMatrix& M) {
    const PetscInt m = end_ - begin_;
    // This process's rows of the column-major M: (row, column, index into M's values).
    struct Entry {
      PetscInt row, col;
      int k;
    };
    std::vector<Entry> entries;
    for (int col = 0; col < M.outerSize(); ++col)
      for (int k = M.outerIndexPtr()[col]; k < M.outerIndexPtr()[col + 1]; ++k) {
        const int row = M.innerIndexPtr()[k];
        if (row >= begin_ && row < end_)
          entries.push_back({row, col, k});
      }
    std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
      return a.row != b.row ? a.row < b.row : a.col < b.col;
    });
    std::vector<PetscInt> diagonal(static_cast<std::size_t>(m), 0), off(diagonal);
    for (const Entry& e : entries)
      ++(e.col >= begin_ && e.col < end_ ? diagonal
                                         : off)[static_cast<std::size_t>(e.row - begin_)];
    check(MatSeqAIJSetPreallocation(matrix_, 0, diagonal.data()), "MatSeqAIJSetPreallocation");
    check(MatMPIAIJSetPreallocation(matrix_, 0, diagonal.data(), 0, off.data()),
          "MatMPIAIJSetPreallocation");
    check(MatSetOption(matrix_, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE), "MatSetOption");
    // The pattern, row by row (zeros); the values come with each factorisation.
    std::vector<PetscInt> cols;
    std::vector<PetscScalar> zeros;
    for (std::size_t a = 0; a < entries.size();) {
      std::size_t b = a;
      cols.clear();
      while (b < entries.size() && entries[b].row == entries[a].row)
        cols.push_back(entries[b++].col);
      zeros.assign(cols.size(), 0.0);
      const PetscInt row = entries[a].row;
      check(MatSetValues(matrix_, 1, &row, static_cast<PetscInt>(cols.size()), cols.data(),
                         zeros.data(), INSERT_VALUES),
            "MatSetValues");
      a = b;
    }
    check(MatAssemblyBegin(matrix_, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
    check(MatAssemblyEnd(matrix_, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");

    // PETSc's local arrays: one block (sequential AIJ) on one process; the diagonal and the
    // off-diagonal blocks on several, the latter's columns compressed in ascending order.
    diagonal_source_.clear();
    off_source_.clear();
    for (const Entry& e : entries)
      (e.col >= begin_ && e.col < end_ ? diagonal_source_ : off_source_).push_back(e.k);
    Mat diagonal_block = matrix_, off_block = nullptr;
    if (distributed::size() > 1)
      check(MatMPIAIJGetSeqAIJ(matrix_, &diagonal_block, &off_block, nullptr),
            "MatMPIAIJGetSeqAIJ");
    check_block(diagonal_block, diagonal_source_.size(), "diagonal");
    if (off_block)
      check_block(off_block, off_source_.size(), "off-diagonal");
    else if (!off_source_.empty())
      throw LinearSolverError("PETSc: a one-process matrix with entries off its diagonal block");
    diagonal_block_ = diagonal_block;
    off_block_ = off_block;
  }

  /// The pattern of the entries of M this process assembled (own_): for LDL^T those of the
  /// symmetric part whose entry or transpose it assembled, the symmetric part of its partial
  /// tangent being its share of the whole's. Their coordinates go to PETSc once; the matrix's
  /// pattern is their union over the processes.
  void own_pattern(const SparseMatrix& A, const SparseMatrix& M) {
    if (own_.size() != static_cast<std::size_t>(A.nonZeros()))
      throw std::logic_error(
          fmt::format("PETSc: {} own entries for a tangent of {}", own_.size(), A.nonZeros()));
    std::vector<PetscInt> coo_i, coo_j;
    for (int col = 0; col < M.outerSize(); ++col)
      for (int k = M.outerIndexPtr()[col]; k < M.outerIndexPtr()[col + 1]; ++k)
        if (own_[k] || (symmetric_ && own_[sym_.transpose(k)])) {
          coo_i.push_back(M.innerIndexPtr()[k]);
          coo_j.push_back(col);
          own_source_.push_back(k);
        }
    own_values_.resize(own_source_.size());
    check(MatSetPreallocationCOO(matrix_, static_cast<PetscCount>(coo_i.size()), coo_i.data(),
                                 coo_j.data()),
          "MatSetPreallocationCOO");
    diagonal_source_.clear();
    off_source_.clear();
    diagonal_block_ = off_block_ = nullptr;
  }

  /// The block's stored entries must be this process's entries that fall in it, one each.
  static void check_block(Mat block, std::size_t expected, const char* which) {
    MatInfo info;
    check(MatGetInfo(block, MAT_LOCAL, &info), "MatGetInfo");
    if (static_cast<std::size_t>(info.nz_used) != expected)
      throw LinearSolverError(fmt::format("PETSc: the {} block holds {} entries, expected {}",
                                          which, info.nz_used, expected));
  }
  static void fill(Mat block, const std::vector<int>& source, const double* values) {
    PetscScalar* a = nullptr;
    check(MatSeqAIJGetArray(block, &a), "MatSeqAIJGetArray");
    for (std::size_t i = 0; i < source.size(); ++i)
      a[i] = values[source[i]];
    check(MatSeqAIJRestoreArray(block, &a), "MatSeqAIJRestoreArray");
  }
  void release() {
    KSPDestroy(&ksp_);
    VecScatterDestroy(&gather_);
    VecDestroy(&x_all_);
    VecDestroy(&x_);
    VecDestroy(&b_);
    MatDestroy(&matrix_);
    diagonal_block_ = off_block_ = nullptr;
  }

  bool symmetric_;
  SymmetricPart sym_;
  PetscInt begin_ = 0, end_ = 0; ///< this process's rows [begin_, end_)
  Mat matrix_ = nullptr;
  Mat diagonal_block_ = nullptr, off_block_ = nullptr; ///< matrix_'s local blocks (not owned)
  std::vector<int> diagonal_source_, off_source_;      ///< per entry of a block: the index in M
  /// This process's own entries (set_own_entries, which sets partial_; they may be none), or,
  /// without partial_, the whole tangent; and for each of those of M it hands in
  /// (MatSetPreallocationCOO's order) its index in M and value.
  std::vector<char> own_;
  bool partial_ = false;
  std::vector<int> own_source_;
  std::vector<PetscScalar> own_values_;
  Vec b_ = nullptr, x_ = nullptr, x_all_ = nullptr;
  VecScatter gather_ = nullptr;
  KSP ksp_ = nullptr;
};

} // namespace

bool petsc_available() {
  return true;
}

std::unique_ptr<LinearSolver> make_petsc_solver(bool symmetric) {
  return std::make_unique<PetscSolver>(symmetric);
}
#else
bool petsc_available() {
  return false;
}

std::unique_ptr<LinearSolver> make_petsc_solver(bool) {
  throw std::invalid_argument("the linear solver 'petsc' is not available: this build of yarnsim "
                              "was made without MPI and PETSc (cmake -DYARNSIM_MPI=ON)");
}
#endif

} // namespace yarnsim
