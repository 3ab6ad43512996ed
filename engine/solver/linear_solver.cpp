#include "engine/solver/linear_solver.hpp"
#include "engine/solver/distributed.hpp"
#include "engine/solver/petsc_solver.hpp"
#include "engine/solver/symmetric_part.hpp"

// Eigen's MetisSupport needs <iostream> before it (engineering-notes.md).
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <exception>
#include <iostream>

#include <Eigen/CholmodSupport>
#include <Eigen/MetisSupport>
#include <Eigen/SparseCholesky>
#include <Eigen/UmfPackSupport>
#include <fmt/format.h>
#ifdef YARNSIM_HAVE_MUMPS
#include <dmumps_c.h>
#endif
#ifdef YARNSIM_HAVE_MPI
#include <mpi.h>
#endif
#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
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

using Permutation = Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int>;

/// The ordering Eigen's SimplicialLDLT<..., MetisOrdering> computes for the symmetric matrix whose
/// lower triangle is `lower`: METIS on the full symmetric pattern. Returns the inverse
/// permutation (position -> variable), as Eigen's ordering does.
Permutation metis_inverse_permutation(const SparseMatrix& lower) {
  SparseMatrix full;
  full = lower.selfadjointView<Eigen::Lower>();
  Permutation inverse;
  Eigen::MetisOrdering<int> ordering;
  ordering(full, inverse);
  return inverse;
}

/// Eigen's SimplicialLDLT (natural order: the permutation is applied beforehand) with the
/// factor's nonzeros counted by its symbolic analysis.
class CountingLDLT
    : public Eigen::SimplicialLDLT<SparseMatrix, Eigen::Upper, Eigen::NaturalOrdering<int>> {
public:
  /// Nonzeros of L (strictly below the diagonal) the last analyzePattern found.
  Eigen::Index factor_nonzeros() const { return this->m_nonZerosPerCol.sum(); }
};

/// LDL^T of the symmetric part (Eigen SimplicialLDLT, METIS ordering). The METIS permutation and
/// the permuted upper triangle's pattern are made once per pattern, with the index of the
/// symmetric part's entry that fills each of its entries; a factorisation then gathers the values
/// into it and factors it in natural order. SimplicialLDLT with its own METIS ordering would
/// permute the whole matrix again at every factorisation (8 % of the paper's k = 1 run,
/// docs/performance.md). The arithmetic is the same: the same permutation, the same entries in
/// the same places.
///
/// A changed pattern (contact pairs coupled or released) keeps the last ordering while the
/// factor's fill stays within kOrderingFillGrowth of the fill it had when METIS computed it:
/// METIS took 70 % of each analysis, and the 24 x 24 weave's pattern changes 43 times
/// (docs/performance.md, "The ordering kept across contact patterns").
class SymmetricLDLTSolver final : public LinearSolver {
public:
  void analyze(const SparseMatrix& A) override {
    sym_.analyze(A);
    const auto matrix_nonzeros = static_cast<double>(sym_.matrix().nonZeros());
    if (fill_ > 0 && inverse_permutation_.size() == A.rows()) {
      permute();
      if (ldlt_.factor_nonzeros() <= kOrderingFillGrowth * fill_ * matrix_nonzeros)
        return;
    }
    inverse_permutation_ = metis_inverse_permutation(sym_.matrix());
    permute();
    fill_ = static_cast<double>(ldlt_.factor_nonzeros()) / matrix_nonzeros;
  }
  void factorize(const SparseMatrix& A) override {
    sym_.update(A);
    const double* s = sym_.matrix().valuePtr();
    double* p = permuted_.valuePtr();
    const int* source = source_.data();
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, source_.size(), 1 << 15),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                        for (std::size_t k = range.begin(); k < range.end(); ++k)
                          p[k] = s[source[k]];
                      });
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
  SolverOrdering ordering() const override {
    const int* p = inverse_permutation_.indices().data();
    return {std::vector<int>(p, p + inverse_permutation_.size()), fill_};
  }
  void set_ordering(const SolverOrdering& o) override {
    fill_ = o.fill;
    inverse_permutation_.indices() = Eigen::Map<const Eigen::VectorXi>(
        o.inverse_permutation.data(), static_cast<Eigen::Index>(o.inverse_permutation.size()));
  }

private:
  /// The permuted upper triangle of the symmetric part under inverse_permutation_, the source
  /// of each of its entries, and its symbolic analysis.
  void permute() {
    permutation_ = inverse_permutation_.inverse();
    // The permuted upper triangle with, as values, the index of the entry of the symmetric
    // part's lower triangle that lands there (exact in a double below 2^53 entries).
    SparseMatrix index = sym_.matrix();
    for (Eigen::Index k = 0; k < index.nonZeros(); ++k)
      index.valuePtr()[k] = static_cast<double>(k);
    permuted_.resize(index.rows(), index.cols());
    permuted_.selfadjointView<Eigen::Upper>() =
        index.selfadjointView<Eigen::Lower>().twistedBy(permutation_);
    source_.resize(static_cast<std::size_t>(permuted_.nonZeros()));
    for (Eigen::Index k = 0; k < permuted_.nonZeros(); ++k)
      source_[static_cast<std::size_t>(k)] = static_cast<int>(permuted_.valuePtr()[k]);
    ldlt_.analyzePattern(permuted_);
  }

  SymmetricPart sym_;
  Permutation permutation_, inverse_permutation_;
  /// Nonzeros of L over those of S when METIS computed inverse_permutation_; 0: none yet.
  double fill_ = 0;
  SparseMatrix permuted_;   ///< upper triangle of P S P^T, S the symmetric part
  std::vector<int> source_; ///< per entry of permuted_: the entry of S it takes
  CountingLDLT ldlt_;
};

#ifdef YARNSIM_HAVE_MUMPS
/// MUMPS, multifrontal, its fronts on the BLAS behind libblas.so.3, on the METIS ordering of the
/// symmetric part's pattern (the ordering SymmetricLDLTSolver uses), handed in (ICNTL(7) = 1).
/// - A symmetric tangent: LDL^T of the symmetric part (SYM = 2: symmetric, not necessarily
///   positive definite), from its lower triangle.
/// - Any other (friction, applied moments, surface contact): LU of the full tangent (SYM = 0,
///   threshold partial pivoting), from all its entries. docs/performance.md, "MUMPS's LU for
///   the non-symmetric tangents".
/// Analysed once per pattern; a factorisation gathers the entries into MUMPS's coordinate arrays.
/// - The oneTBB build: the sequential library, one process. docs/performance.md, "The
///   factorisation: MUMPS against today's LDL^T": 1.18 times faster than `ldlt` at 412 000
///   equations and 1.67 times at 912 000, equal at 62 000 and 235 000.
/// - The MPI build: every process of the run factorises together (distributed.hpp). Each holds
///   the whole tangent and hands MUMPS the entries of its share of the columns (distributed
///   input, ICNTL(18) = 3); the host (rank 0) orders, takes the right-hand side and gets the
///   solution, which it sends to the others: the same bits on every process. Collective.
class MumpsSolver final : public LinearSolver {
public:
  explicit MumpsSolver(bool symmetric) : symmetric_(symmetric) {
#ifdef YARNSIM_HAVE_MPI
    id_.comm_fortran = static_cast<MUMPS_INT>(MPI_Comm_c2f(MPI_COMM_WORLD));
#else
    id_.comm_fortran = kSequentialCommunicator;
#endif
    id_.par = 1;                 // the host works too
    id_.sym = symmetric ? 2 : 0; // symmetric indefinite, or general (LU)
    call(-1, "initialisation");
    icntl(1) = icntl(2) = icntl(3) = -1; // no messages
    icntl(4) = 0;
    icntl(7) = 1;   // the ordering given in perm_in
    icntl(14) = 50; // working space: 50 % over the analysis's estimate
#ifdef YARNSIM_HAVE_MPI
    icntl(18) = 3; // distributed assembled input: each process its share
#endif
  }
  ~MumpsSolver() override {
    // Over MPI the termination is collective. A process unwinding from a failure of its own
    // (the leader's files) would wait in it for the others forever, so it is skipped there;
    // the run then ends by MPI_Abort (apps/yarnsim.cpp).
    if (distributed::size() > 1 && std::uncaught_exceptions() > 0)
      return;
    id_.job = -2;
    dmumps_c(&id_);
  }
  MumpsSolver(const MumpsSolver&) = delete;
  MumpsSolver& operator=(const MumpsSolver&) = delete;

  void analyze(const SparseMatrix& A) override {
    // LDL^T takes the symmetric part's values; LU the tangent's own (the symmetric part's
    // pattern is then made only where METIS needs it, below).
    if (symmetric_)
      sym_.analyze(A);
    // This process's columns (all of them on one process, contiguous shares over MPI) of the
    // symmetric part's lower triangle, or of the full tangent; 1-based coordinates. Where each
    // process holds only its own partial sums (set_own_entries), it hands in the entries it
    // assembled, in every column, and MUMPS sums them: for LDL^T those of the lower triangle
    // whose entry or transpose it assembled (its symmetric part's share).
    const SparseMatrix& M = symmetric_ ? sym_.matrix() : A;
    const bool partial = partial_;
    if (partial && own_.size() != std::size_t(A.nonZeros()))
      throw std::logic_error(
          fmt::format("MUMPS: {} own entries for a tangent of {}", own_.size(), A.nonZeros()));
    const distributed::Share columns = partial
                                           ? distributed::Share{0, static_cast<int>(M.outerSize())}
                                           : distributed::share(static_cast<int>(M.outerSize()));
    irn_.clear();
    jcn_.clear();
    source_.clear();
    for (int col = columns.begin; col < columns.end; ++col)
      for (int k = M.outerIndexPtr()[col]; k < M.outerIndexPtr()[col + 1]; ++k) {
        if (symmetric_ && M.innerIndexPtr()[k] < col)
          continue;
        if (partial && !own_[k] && !(symmetric_ && own_[sym_.transpose(k)]))
          continue;
        irn_.push_back(M.innerIndexPtr()[k] + 1);
        jcn_.push_back(col + 1);
        source_.push_back(k);
      }
    values_.assign(source_.size(), 0.0);
    id_.n = static_cast<MUMPS_INT>(A.rows());
#ifdef YARNSIM_HAVE_MPI
    id_.nnz_loc = static_cast<MUMPS_INT8>(values_.size());
    id_.irn_loc = irn_.data();
    id_.jcn_loc = jcn_.data();
    id_.a_loc = values_.data();
#else
    id_.nnz = static_cast<MUMPS_INT8>(values_.size());
    id_.irn = irn_.data();
    id_.jcn = jcn_.data();
    id_.a = values_.data();
#endif
    // The entries handed in, all processes': the fill's denominator. Where each process hands
    // in its own entries it holds the pattern of its share alone (Assembler::share): the sum of
    // the processes' counts (an entry two processes hand in counts twice, at every analysis
    // alike), and the host gathers their structure (its union is the whole tangent's, or its
    // symmetric part's lower triangle) only where METIS orders afresh, below.
    const bool gathered = partial && distributed::size() > 1;
    double handed_in = symmetric_ ? 0.5 * static_cast<double>(M.nonZeros() + M.rows())
                                  : static_cast<double>(A.nonZeros());
    if (gathered) {
      handed_in = static_cast<double>(irn_.size());
      distributed::sum(&handed_in, 1);
    }
    // A changed pattern keeps the last ordering while the factor's estimated entries (MUMPS's
    // analysis, INFOG(20), the same on every process) stay within kOrderingFillGrowth of those
    // it had when METIS computed it, as SymmetricLDLTSolver does; METIS orders it afresh
    // otherwise. At 48 x 48 METIS takes about 1 s of each analysis.
    if (ordering_.fill > 0 && ordering_.inverse_permutation.size() == std::size_t(A.rows())) {
      analyse_with_ordering();
      if (factor_entries() <= kOrderingFillGrowth * ordering_.fill * handed_in)
        return;
    }
    std::vector<std::array<int, 2>> structure; // (column, row), 0-based: the host's
    if (gathered) {
      std::vector<std::array<int, 2>> mine(irn_.size());
      for (std::size_t k = 0; k < irn_.size(); ++k)
        mine[k] = {jcn_[k] - 1, irn_[k] - 1};
      structure = distributed::gather_on_first(mine);
    }
    if (distributed::rank() == 0) { // the host orders, on the symmetric part's pattern
      const Permutation inverse =
          gathered ? metis_inverse_permutation(lower_pattern(std::move(structure), A.rows()))
                   : metis_inverse_permutation(
                         symmetric_ ? M : SparseMatrix(A + SparseMatrix(A.transpose())));
      ordering_.inverse_permutation.assign(inverse.indices().data(),
                                           inverse.indices().data() + inverse.size());
    } else {
      ordering_.inverse_permutation.assign(static_cast<std::size_t>(A.rows()), 0);
    }
    analyse_with_ordering();
    ordering_.fill = factor_entries() / handed_in;
  }
  SolverOrdering ordering() const override {
    return ordering_;
  }
  void set_ordering(const SolverOrdering& o) override {
    ordering_ = o;
  }
  void factorize(const SparseMatrix& A) override {
    if (symmetric_)
      sym_.update(A);
    const double* s = symmetric_ ? sym_.matrix().valuePtr() : A.valuePtr();
    for (std::size_t k = 0; k < source_.size(); ++k)
      values_[k] = s[source_[k]];
    // Delayed pivots of an indefinite matrix can need more working space than the analysis
    // estimated (INFOG(1) = -8 or -9): doubled, up to three times, as MUMPS's guide advises.
    // INFOG is the same on every process, so they retry together.
    for (int retry = 0;; ++retry) {
      id_.job = 2;
      dmumps_c(&id_);
      const bool space = id_.infog[0] == -8 || id_.infog[0] == -9;
      if (!space || retry == 3)
        break;
      icntl(14) = 2 * icntl(14) + 20;
    }
    check("factorisation");
  }
  Eigen::VectorXd solve(const Eigen::VectorXd& b) override {
    Eigen::VectorXd x = b; // the host's right-hand side, overwritten by the solution
    id_.rhs = x.data();
    call(3, "solve");
#ifdef YARNSIM_HAVE_MPI
    if (distributed::size() > 1)
      MPI_Bcast(x.data(), static_cast<int>(x.size()), MPI_DOUBLE, 0, MPI_COMM_WORLD);
#endif
    return x;
  }
  std::string name() const override {
    return "mumps";
  }
  bool sums_partial_tangents() const override {
    return distributed::size() > 1;
  }
  void set_own_entries(std::vector<char> own) override {
    own_ = std::move(own);
    partial_ = true;
  }

private:
#ifndef YARNSIM_HAVE_MPI
  /// The stand-in MPI library of the sequential MUMPS takes this for MPI_COMM_WORLD.
  static constexpr MUMPS_INT kSequentialCommunicator = -987654;
#endif
  int& icntl(int i) {
    return id_.icntl[i - 1];
  }
  /// MUMPS's analysis on ordering_ (the host's perm_in: equation -> 1-based position).
  void analyse_with_ordering() {
    perm_in_.clear();
    if (distributed::rank() == 0) {
      perm_in_.resize(ordering_.inverse_permutation.size());
      for (std::size_t position = 0; position < perm_in_.size(); ++position)
        perm_in_[static_cast<std::size_t>(ordering_.inverse_permutation[position])] =
            static_cast<MUMPS_INT>(position + 1);
    }
    id_.perm_in = perm_in_.empty() ? nullptr : perm_in_.data();
    call(1, "analysis");
  }
  /// The lower triangle of the symmetric pattern of `structure` ((column, row) pairs, the
  /// entries the processes hand in, repeats included), n x n, for METIS: LDL^T's entries lie in
  /// it already; an LU entry and its transpose fall on one entry of it.
  SparseMatrix lower_pattern(std::vector<std::array<int, 2>> structure, Eigen::Index n) const {
    if (!symmetric_)
      for (auto& [col, row] : structure)
        if (row < col)
          std::swap(row, col);
    std::sort(structure.begin(), structure.end());
    structure.erase(std::unique(structure.begin(), structure.end()), structure.end());
    SparseMatrix lower(n, n);
    lower.resizeNonZeros(static_cast<Eigen::Index>(structure.size()));
    int* outer = lower.outerIndexPtr();
    std::fill(outer, outer + n + 1, 0);
    for (std::size_t k = 0; k < structure.size(); ++k) {
      ++outer[structure[k][0] + 1];
      lower.innerIndexPtr()[k] = structure[k][1];
    }
    for (Eigen::Index c = 0; c < n; ++c)
      outer[c + 1] += outer[c];
    std::fill(lower.valuePtr(), lower.valuePtr() + structure.size(), 1.0);
    return lower;
  }
  /// The factor's entries MUMPS's analysis estimates (INFOG(20); negative: millions).
  double factor_entries() const {
    const double e = id_.infog[19];
    return e < 0 ? -e * 1e6 : e;
  }
  void call(int job, const char* what) {
    id_.job = job;
    dmumps_c(&id_);
    check(what);
  }
  void check(const char* what) const {
    const int info = id_.infog[0], detail = id_.infog[1];
    if (info < 0)
      throw LinearSolverError(fmt::format("MUMPS {} failed (INFOG(1) = {}, INFOG(2) = {}){}", what,
                                          info, detail,
                                          info == -10                ? ": the tangent is singular"
                                          : info == -9 || info == -8 ? ": out of memory"
                                                                     : ""));
  }

  /// LDL^T of the symmetric part (SYM = 2), else LU of the full tangent (SYM = 0).
  bool symmetric_;
  DMUMPS_STRUC_C id_{};
  SymmetricPart sym_; ///< the tangent's symmetric part (LDL^T only)
  std::vector<MUMPS_INT> irn_, jcn_, perm_in_;
  /// Per entry handed in by this process: its index in S's values (LDL^T) or A's (LU).
  std::vector<int> source_;
  std::vector<double> values_; ///< those entries' values, MUMPS's `a` (or `a_loc`)
  /// The ordering in use (the host's; zeros on the others) and its fill: the factor's estimated
  /// entries over the entries handed in when METIS computed it; 0: none yet.
  SolverOrdering ordering_;
  /// Over several processes holding partial sums (partial_: set_own_entries was called): the
  /// entries of A this process assembled, which may be none (a process of no element or pair
  /// with a free DOF). Otherwise the whole tangent, shared by columns.
  std::vector<char> own_;
  bool partial_ = false;
};
#endif

/// GMRES's Krylov basis and Hessenberg matrix, kept by its caller between solves so that a
/// Newton iteration does not allocate them anew (n x (m + 1) doubles).
struct GmresWorkspace {
  Eigen::MatrixXd V, H;
  Eigen::VectorXd cs, sn, g;
};

/// Right-preconditioned GMRES(m), not restarted (Saad, Iterative Methods for Sparse Linear
/// Systems, 2nd ed., Algorithm 9.5; modified Gram-Schmidt, Givens rotations): x = M^-1 V y with
/// ||b - op(x)|| <= tolerance ||b||, checked with op itself at the end; false when not reached
/// in m = max_iterations. Serial and in a fixed order: the same on any thread count.
template <class Op, class Precondition>
bool gmres(const Op& op, const Precondition& precondition, const Eigen::VectorXd& b,
           Eigen::VectorXd& x, double tolerance, int max_iterations, GmresWorkspace& w) {
  const Eigen::Index n = b.size();
  const int m = max_iterations;
  const double b_norm = b.norm();
  x = Eigen::VectorXd::Zero(n);
  if (b_norm == 0)
    return true;
  if (!std::isfinite(b_norm))
    return false;
  const double target = tolerance * b_norm;
  Eigen::MatrixXd& V = w.V;
  Eigen::MatrixXd& H = w.H;
  V.resize(n, m + 1);
  H.setZero(m + 1, m);
  w.cs.resize(m);
  w.sn.resize(m);
  w.g.setZero(m + 1);
  Eigen::VectorXd &cs = w.cs, &sn = w.sn, &g = w.g;
  g(0) = b_norm;
  V.col(0) = b / b_norm;
  int j = 0;
  bool done = false;
  while (j < m && !done) {
    Eigen::VectorXd v = op(precondition(Eigen::VectorXd(V.col(j))));
    for (int i = 0; i <= j; ++i) {
      H(i, j) = v.dot(V.col(i));
      v -= H(i, j) * V.col(i);
    }
    H(j + 1, j) = v.norm();
    const bool breakdown = !(H(j + 1, j) > 0); // the Krylov space holds the solution
    if (!breakdown)
      V.col(j + 1) = v / H(j + 1, j);
    for (int i = 0; i < j; ++i) {
      const double t = cs(i) * H(i, j) + sn(i) * H(i + 1, j);
      H(i + 1, j) = -sn(i) * H(i, j) + cs(i) * H(i + 1, j);
      H(i, j) = t;
    }
    const double rho = std::hypot(H(j, j), H(j + 1, j));
    if (!(rho > 0))
      return false;
    cs(j) = H(j, j) / rho;
    sn(j) = H(j + 1, j) / rho;
    H(j, j) = rho;
    H(j + 1, j) = 0;
    g(j + 1) = -sn(j) * g(j);
    g(j) = cs(j) * g(j);
    ++j;
    done = std::abs(g(j)) <= target || breakdown;
  }
  const Eigen::VectorXd y = H.topLeftCorner(j, j).triangularView<Eigen::Upper>().solve(g.head(j));
  x = precondition(Eigen::VectorXd(V.leftCols(j) * y));
  const Eigen::VectorXd r = b - op(x);
  return r.allFinite() && r.norm() <= target;
}

/// The full (non-symmetric) tangent solved by GMRES, preconditioned on the right by the LDL^T of
/// its symmetric part: where the tangent is nearly symmetric (the surface contact's end windows)
/// the preconditioned operator is close to the identity and a few Krylov iterations give the
/// Newton correction of the full tangent, to a relative residual of kTolerance, for the price of
/// one LDL^T (a quarter of UMFPACK's LU on the paper's fabric) and a few solves and products.
/// Where GMRES does not get there in kMaxIterations, or the symmetric part is singular, that
/// system is solved by UMFPACK's LU (analysed on first use), and so are the rest of the Newton
/// attempt's: the non-symmetric part grows with the contact forces, and a failed GMRES costs
/// more than the LU. The choice is made afresh at each attempt, so a run continued from a
/// checkpoint makes the same choices as one straight through.
class LDLTGmresSolver final : public LinearSolver {
public:
  static constexpr double kTolerance = 1e-10;
  static constexpr int kMaxIterations = 20;

  void analyze(const SparseMatrix& A) override {
    ldlt_.analyze(A);
    lu_analysed_ = false;
  }
  void factorize(const SparseMatrix& A) override {
    // GMRES's operator is the factorised tangent itself, kept: the caller assembles the next
    // iterate's into A before it solves with this one (the simplified corrections of
    // Simulation::attempt solve with the tangent in hand, -K(x_k)^-1 r(x_k+1)).
    factorised_ = A;
    use_lu_ = lu_for_attempt_;
    if (!use_lu_) {
      try {
        ldlt_.factorize(factorised_);
        return;
      } catch (const LinearSolverError&) {
      }
    }
    factorize_lu();
  }
  Eigen::VectorXd solve(const Eigen::VectorXd& b) override {
    if (!use_lu_) {
      const SparseMatrix& A = factorised_;
      Eigen::VectorXd x;
      if (gmres([&](const Eigen::VectorXd& v) -> Eigen::VectorXd { return A * v; },
                [&](const Eigen::VectorXd& v) { return ldlt_.solve(v); }, b, x, kTolerance,
                kMaxIterations, workspace_))
        return x;
      lu_for_attempt_ = true;
      factorize_lu();
    }
    return lu_.solve(b);
  }
  void start_attempt() override { lu_for_attempt_ = false; }
  std::string name() const override { return "ldlt-gmres"; }
  SolverOrdering ordering() const override { return ldlt_.ordering(); }
  void set_ordering(const SolverOrdering& o) override { ldlt_.set_ordering(o); }

private:
  void factorize_lu() {
    if (!lu_analysed_) {
      lu_.analyze(factorised_);
      lu_analysed_ = true;
    }
    lu_.factorize(factorised_);
    use_lu_ = true;
  }

  SymmetricLDLTSolver ldlt_;
  UmfpackSolver lu_;
  GmresWorkspace workspace_;
  SparseMatrix factorised_; ///< the last factorised tangent (a copy: GMRES's operator)
  bool lu_analysed_ = false;
  bool use_lu_ = false;         ///< this system: LU
  bool lu_for_attempt_ = false; ///< GMRES failed in this attempt: LU until the next one
};

/// A system without equations (every DOF of the model prescribed) is solved here: METIS divides
/// by zero on an empty graph (SIGFPE) and UMFPACK reports an empty matrix as singular.
class EmptySystemGuard final : public LinearSolver {
public:
  explicit EmptySystemGuard(std::unique_ptr<LinearSolver> solver) : solver_(std::move(solver)) {}
  void analyze(const SparseMatrix& A) override {
    if (A.rows() > 0)
      solver_->analyze(A);
  }
  void factorize(const SparseMatrix& A) override {
    empty_ = A.rows() == 0;
    if (!empty_)
      solver_->factorize(A);
  }
  Eigen::VectorXd solve(const Eigen::VectorXd& b) override {
    return empty_ ? Eigen::VectorXd(0) : solver_->solve(b);
  }
  void start_attempt() override { solver_->start_attempt(); }
  std::string name() const override { return solver_->name(); }
  SolverOrdering ordering() const override { return solver_->ordering(); }
  void set_ordering(const SolverOrdering& o) override { solver_->set_ordering(o); }
  bool sums_partial_tangents() const override { return solver_->sums_partial_tangents(); }
  void set_own_entries(std::vector<char> own) override { solver_->set_own_entries(std::move(own)); }

private:
  std::unique_ptr<LinearSolver> solver_;
  bool empty_ = false;
};

std::unique_ptr<LinearSolver> make_solver(LinearSolverKind kind, bool symmetric_tangent) {
  if (kind == LinearSolverKind::PETSc)
    return make_petsc_solver(symmetric_tangent);
  if (kind == LinearSolverKind::LU)
    return std::make_unique<UmfpackSolver>();
  if (kind == LinearSolverKind::Cholmod)
    return std::make_unique<CholmodSolver>();
  if (kind == LinearSolverKind::LDLTGmres)
    return std::make_unique<LDLTGmresSolver>();
  if (kind == LinearSolverKind::MUMPS) {
#ifdef YARNSIM_HAVE_MUMPS
    return std::make_unique<MumpsSolver>(symmetric_tangent);
#else
    throw std::invalid_argument("the linear solver 'mumps' is not available: this build of "
                                "yarnsim was made without MUMPS (libmumps-seq-dev)");
#endif
  }
  return std::make_unique<SymmetricLDLTSolver>();
}

} // namespace

std::unique_ptr<LinearSolver> make_linear_solver(LinearSolverKind kind, bool symmetric_tangent) {
  if (kind == LinearSolverKind::Auto)
    throw std::invalid_argument("make_linear_solver: resolve 'auto' against the model first");
  return std::make_unique<EmptySystemGuard>(make_solver(kind, symmetric_tangent));
}

bool mumps_available() {
#ifdef YARNSIM_HAVE_MUMPS
  return true;
#else
  return false;
#endif
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
  if (name == "ldlt-gmres")
    return LinearSolverKind::LDLTGmres;
  if (name == "mumps")
    return LinearSolverKind::MUMPS;
  if (name == "petsc")
    return LinearSolverKind::PETSc;
  throw std::invalid_argument("unknown linear solver '" + name +
                              "' (expected 'auto', 'lu', 'ldlt', 'ldlt-gmres', 'mumps', "
                              "'cholmod' or 'petsc')");
}

} // namespace yarnsim
