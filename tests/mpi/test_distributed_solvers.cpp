// The linear solvers of an MPI run (the build with YARNSIM_MPI), run by ctest under mpirun on 1,
// 2 and 3 processes: every process holds the whole system and hands the solver its share; the
// solution must be the system's (an entry handed by two processes would be summed twice by
// MUMPS's distributed input, one handed by none would be missing: either fails the residual),
// the same bits on every process, and a singular system is refused on every process alike.
#include "engine/solver/distributed.hpp"
#include "engine/solver/linear_solver.hpp"

#include <gtest/gtest.h>
#include <mpi.h>
#include <petscsys.h>

#include <random>
#include <vector>

namespace yarnsim {
namespace {

/// A structurally symmetric n x n matrix S + K with a band and far couplings (a weave's
/// tangent: yarns along the band, contacts far from it): S symmetric and indefinite (diagonal
/// entries of both signs), K antisymmetric of relative size `skew`. The same on every process
/// (same seed).
SparseMatrix weave_like(int n, double skew) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<int> far(0, n - 1);
  std::vector<Eigen::Triplet<double>> t;
  const auto couple = [&](int i, int j) {
    const double s = u(rng), a = skew * u(rng);
    t.emplace_back(i, j, s + a);
    t.emplace_back(j, i, s - a);
  };
  for (int i = 0; i < n; ++i) {
    t.emplace_back(i, i, (i % 3 == 0 ? -1.0 : 1.0) * (12.0 + u(rng)));
    for (int k = 1; k <= 5 && i + k < n; ++k)
      couple(i, i + k);
    if (i % 4 == 0) { // a contact: a coupling far from the band
      const int j = far(rng);
      if (std::abs(j - i) > 5)
        couple(i, j);
    }
  }
  SparseMatrix A(n, n);
  A.setFromTriplets(t.begin(), t.end()); // duplicates summed: still structurally symmetric
  return A;
}

Eigen::VectorXd right_hand_side(int n) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd b(n);
  for (int i = 0; i < n; ++i)
    b(i) = u(rng);
  return b;
}

/// Whether x is bitwise the same on every process.
bool same_on_every_process(const Eigen::VectorXd& x) {
  std::vector<double> root(x.data(), x.data() + x.size());
  MPI_Bcast(root.data(), static_cast<int>(root.size()), MPI_DOUBLE, 0, MPI_COMM_WORLD);
  const bool same = std::equal(root.begin(), root.end(), x.data());
  return !distributed::any(!same);
}

struct Case {
  LinearSolverKind kind;
  bool symmetric; ///< the symmetric part's LDL^T (else LU of the full matrix)
};

class DistributedSolver : public ::testing::TestWithParam<Case> {};

TEST_P(DistributedSolver, SolvesTheWholeSystemAndGivesEveryProcessTheSameBits) {
  const Case c = GetParam();
  const int n = 2000;
  const SparseMatrix A = weave_like(n, c.symmetric ? 0.0 : 0.3);
  const Eigen::VectorXd b = right_hand_side(n);
  auto solver = make_linear_solver(c.kind, c.symmetric);
  solver->analyze(A);
  // Two factorisations of the same pattern with other values: the values are refreshed.
  solver->factorize(SparseMatrix(2.0 * A));
  const Eigen::VectorXd x2 = solver->solve(b);
  EXPECT_LT((b - 2.0 * (A * x2)).norm() / b.norm(), 1e-12);
  solver->factorize(A);
  const Eigen::VectorXd x = solver->solve(b);
  EXPECT_LT((b - A * x).norm() / b.norm(), 1e-12) << solver->name();
  EXPECT_TRUE(same_on_every_process(x));
  // A new pattern (more far couplings) is analysed afresh.
  SparseMatrix B = A;
  B.coeffRef(0, n - 1) = 0.5;
  B.coeffRef(n - 1, 0) = 0.5;
  B.makeCompressed();
  solver->analyze(B);
  solver->factorize(B);
  const Eigen::VectorXd y = solver->solve(b);
  EXPECT_LT((b - B * y).norm() / b.norm(), 1e-12);
  EXPECT_TRUE(same_on_every_process(y));
}

TEST_P(DistributedSolver, SumsTheProcessesOwnPatternsIntoTheWholeSystem) {
  // A run's processes each hold the pattern of what they assemble alone (Assembler::share):
  // the patterns differ, some entries are held by several processes (a node's block that two
  // processes' contact pairs add to), and a process may hold none. The solver sums them: the
  // solution must be the summed system's, the same bits on every process, and the ordering the
  // host computes from the gathered patterns must be agreed (a process that skipped the
  // gathering would hang the others).
  const Case c = GetParam();
  const int n = 1500;
  const SparseMatrix A = weave_like(n, c.symmetric ? 0.0 : 0.3);
  const int p = distributed::size(), r = distributed::rank();
  // Entries (i, j) and (j, i) go to process (min + 2 max) mod h (a pattern of node blocks is
  // structurally symmetric), h the processes holding entries (the last of three or more holds
  // none); the diagonal is split between all h.
  const int h = p >= 3 ? p - 1 : p;
  std::vector<Eigen::Triplet<double>> mine;
  for (int k = 0; k < A.outerSize(); ++k)
    for (SparseMatrix::InnerIterator it(A, k); it; ++it) {
      const int i = static_cast<int>(it.row()), j = static_cast<int>(it.col());
      if (i == j && r < h)
        mine.emplace_back(i, j, it.value() / h);
      else if (i != j && (std::min(i, j) + 2 * std::max(i, j)) % h == r && r < h)
        mine.emplace_back(i, j, it.value());
    }
  SparseMatrix P(n, n);
  P.setFromTriplets(mine.begin(), mine.end());
  P.makeCompressed();
  auto solver = make_linear_solver(c.kind, c.symmetric);
  ASSERT_EQ(solver->sums_partial_tangents(), p > 1);
  solver->set_own_entries(std::vector<char>(static_cast<std::size_t>(P.nonZeros()), 1));
  solver->analyze(P);
  solver->factorize(P);
  const Eigen::VectorXd b = right_hand_side(n);
  const Eigen::VectorXd x = solver->solve(b);
  EXPECT_LT((b - A * x).norm() / b.norm(), 1e-12) << solver->name();
  EXPECT_TRUE(same_on_every_process(x));
  // MUMPS's host orders the union of the gathered patterns: the whole system's, so the ordering
  // is the one a whole matrix gets, and so is the factor. The fill it decides by is that
  // factor's entries over the entries the processes hand in, summed over them (an entry two
  // processes hand in counts twice: LDL^T the lower triangle of each one's pattern, LU all of
  // it), the same on every process (each decides alone whether to order afresh, and they must
  // call MUMPS's analysis alike).
  if (c.kind == LinearSolverKind::MUMPS) {
    auto whole = make_linear_solver(c.kind, c.symmetric);
    whole->analyze(A);
    const SolverOrdering a = solver->ordering(), w = whole->ordering();
    if (r == 0) {
      EXPECT_EQ(a.inverse_permutation, w.inverse_permutation);
      EXPECT_GT(a.inverse_permutation.size(), 0u);
    }
    const auto handed_in = [&](const SparseMatrix& M) {
      double count = 0;
      for (int k = 0; k < M.outerSize(); ++k)
        for (SparseMatrix::InnerIterator it(M, k); it; ++it)
          count += !c.symmetric || it.row() >= it.col();
      return count;
    };
    double summed = handed_in(P);
    distributed::sum(&summed, 1);
    EXPECT_GT(a.fill, 0.0);
    EXPECT_NEAR(a.fill * summed, w.fill * handed_in(A), 1e-12 * w.fill * handed_in(A));
    EXPECT_EQ(distributed::largest(a.fill), distributed::smallest(a.fill));
  }
}

TEST_P(DistributedSolver, RefusesASingularSystemOnEveryProcess) {
  const Case c = GetParam();
  const int n = 300;
  SparseMatrix A = weave_like(n, 0.0);
  // Row and column 7 zero but for a zero diagonal: singular.
  for (int k = 0; k < A.outerSize(); ++k)
    for (SparseMatrix::InnerIterator it(A, k); it; ++it)
      if (it.row() == 7 || it.col() == 7)
        it.valueRef() = 0.0;
  auto solver = make_linear_solver(c.kind, c.symmetric);
  solver->analyze(A);
  bool refused = false;
  try {
    solver->factorize(A);
    refused = !solver->solve(right_hand_side(n)).allFinite();
  } catch (const LinearSolverError&) {
    refused = true;
  }
  EXPECT_TRUE(refused);
  EXPECT_FALSE(distributed::any(!refused)); // on every process alike
}

INSTANTIATE_TEST_SUITE_P(
    Mpi, DistributedSolver,
    ::testing::Values(Case{LinearSolverKind::MUMPS, true}, Case{LinearSolverKind::MUMPS, false},
                      Case{LinearSolverKind::PETSc, true}, Case{LinearSolverKind::PETSc, false}),
    [](const auto& info) {
      return std::string(info.param.kind == LinearSolverKind::MUMPS ? "Mumps" : "Petsc") +
             (info.param.symmetric ? "LDLT" : "LU");
    });

TEST(Distributed, AnyAgreesAcrossProcesses) {
  // true on the last process only: every process sees true.
  EXPECT_TRUE(distributed::any(distributed::rank() == distributed::size() - 1));
  EXPECT_FALSE(distributed::any(false));
}

} // namespace
} // namespace yarnsim

/// MPI and PETSc around the tests (as apps/yarnsim.cpp starts them); only rank 0 prints.
int main(int argc, char** argv) {
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  PetscOptionsSetValue(nullptr, "-no_signal_handler", nullptr);
  PetscInitializeNoArguments();
  PetscPushErrorHandler(PetscReturnErrorHandler, nullptr);
  ::testing::InitGoogleTest(&argc, argv);
  if (yarnsim::distributed::rank() != 0) {
    auto& listeners = ::testing::UnitTest::GetInstance()->listeners();
    delete listeners.Release(listeners.default_result_printer());
  }
  const int failed = RUN_ALL_TESTS();
  // A failure on any process fails the test on all.
  const bool any_failed = yarnsim::distributed::any(failed != 0);
  PetscFinalize();
  MPI_Finalize();
  return any_failed ? 1 : 0;
}
