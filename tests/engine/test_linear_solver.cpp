// The sparse solvers behind LinearSolver: each solves its system to round-off, and the GMRES
// solver on the symmetric part's LDL^T gives the full non-symmetric system's solution whether
// its Krylov iteration converges (a nearly symmetric matrix) or it falls back to the LU (a far
// from symmetric matrix, a singular symmetric part).
#include "beam_models.hpp"
#include "engine/solver/linear_solver.hpp"
#include "engine/solver/simulation.hpp"

#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace yarnsim {
namespace {

/// A banded n x n matrix S + skew K (structurally symmetric): S symmetric positive definite
/// (diagonally dominant), K antisymmetric with entries of size `skew` relative to S's.
SparseMatrix banded(int n, double skew, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Eigen::Triplet<double>> t;
  for (int i = 0; i < n; ++i) {
    t.emplace_back(i, i, 10.0 + u(rng));
    for (int k = 1; k <= 3 && i + k < n; ++k) {
      const double s = u(rng), a = skew * u(rng);
      t.emplace_back(i, i + k, s + a);
      t.emplace_back(i + k, i, s - a);
    }
  }
  SparseMatrix A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  return A;
}

double relative_residual(const SparseMatrix& A, const Eigen::VectorXd& x,
                         const Eigen::VectorXd& b) {
  return (b - A * x).norm() / b.norm();
}

Eigen::VectorXd solve_with(LinearSolverKind kind, const SparseMatrix& A, const Eigen::VectorXd& b) {
  auto solver = make_linear_solver(kind);
  solver->start_attempt();
  solver->analyze(A);
  solver->factorize(A);
  return solver->solve(b);
}

TEST(LinearSolver, EverySolverTakesAnEmptySystem) {
  // A model whose every DOF is prescribed has no equations. METIS divides by zero on an empty
  // graph (SIGFPE), so the ordering must not call it there.
  const SparseMatrix empty(0, 0);
  for (const LinearSolverKind kind :
       {LinearSolverKind::LU, LinearSolverKind::LDLTSymmetric, LinearSolverKind::LDLTGmres}) {
    const Eigen::VectorXd x = solve_with(kind, empty, Eigen::VectorXd(0));
    EXPECT_EQ(x.size(), 0);
  }
  if (mumps_available()) {
    EXPECT_EQ(solve_with(LinearSolverKind::MUMPS, empty, Eigen::VectorXd(0)).size(), 0);
  }
}

TEST(LinearSolver, LUAndLDLTGmresSolveTheFullNonSymmetricSystem) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  // Nearly symmetric (GMRES converges in a few iterations) and far from it (skew entries ten
  // times the symmetric ones: GMRES on the symmetric part's factor does not converge within its
  // limit, and the LU solves it).
  for (const double skew : {1e-3, 0.1, 10.0}) {
    const SparseMatrix A = banded(400, skew, rng);
    Eigen::VectorXd b(400);
    for (int i = 0; i < 400; ++i)
      b(i) = u(rng);
    const Eigen::VectorXd lu = solve_with(LinearSolverKind::LU, A, b);
    const Eigen::VectorXd gmres = solve_with(LinearSolverKind::LDLTGmres, A, b);
    EXPECT_LT(relative_residual(A, lu, b), 1e-13) << skew;
    EXPECT_LT(relative_residual(A, gmres, b), 1e-10) << skew;
    EXPECT_LT((gmres - lu).norm(), 1e-9 * lu.norm()) << skew;
    // The symmetric LDL^T solves the symmetric part, not A: with a skew part it misses A's
    // solution by about the skew's share.
    const Eigen::VectorXd ldlt = solve_with(LinearSolverKind::LDLTSymmetric, A, b);
    EXPECT_GT((ldlt - lu).norm(), 1e-2 * skew * lu.norm()) << skew;
  }
}

TEST(LinearSolver, LDLTGmresFallsBackToTheLUWhereTheSymmetricPartIsSingular) {
  // A rotation block [[0, 1], [-1, 0]] has a zero symmetric part: its LDL^T fails.
  std::vector<Eigen::Triplet<double>> t = {{0, 1, 1.0}, {1, 0, -1.0}, {2, 2, 3.0}};
  SparseMatrix A(3, 3);
  A.setFromTriplets(t.begin(), t.end());
  const Eigen::Vector3d b(1.0, 2.0, 3.0);
  const Eigen::VectorXd x = solve_with(LinearSolverKind::LDLTGmres, A, b);
  EXPECT_LT((x - Eigen::Vector3d(-2.0, 1.0, 1.0)).norm(), 1e-15);
}

TEST(LinearSolver, LDLTGmresKeepsSolvingAcrossIterationsAndAttempts) {
  // Within an attempt a GMRES failure switches to the LU; the next attempt tries GMRES again.
  // Either way every solve is the full system's.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto solver = make_linear_solver(LinearSolverKind::LDLTGmres);
  EXPECT_EQ(solver->name(), "ldlt-gmres");
  for (int attempt = 0; attempt < 2; ++attempt) {
    solver->start_attempt();
    for (const double skew : {1e-3, 10.0, 1e-3}) {
      const SparseMatrix A = banded(200, skew, rng);
      Eigen::VectorXd b(200);
      for (int i = 0; i < 200; ++i)
        b(i) = u(rng);
      solver->analyze(A);
      solver->factorize(A);
      EXPECT_LT(relative_residual(A, solver->solve(b), b), 1e-10) << attempt << " " << skew;
    }
  }
}

TEST(LinearSolver, EverySolverSolvesWithTheTangentItFactorised) {
  // Simulation::attempt assembles the next iterate's tangent into the same matrix and then
  // solves with the factorisation in hand: the simplified Newton corrections, -K(x_k)^-1
  // r(x_k+1), of its termination and monotonicity tests. Each solver's solve must read the
  // tangent it factorised, not the matrix's later values (ldlt-gmres's GMRES read them: its
  // "simplified" corrections were the next Newton corrections).
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<LinearSolverKind> kinds{LinearSolverKind::LU, LinearSolverKind::LDLTGmres};
  if (mumps_available())
    kinds.push_back(LinearSolverKind::MUMPS);
  for (const LinearSolverKind kind : kinds) {
    const SparseMatrix factorised = banded(200, 1e-3, rng);
    SparseMatrix A = factorised;
    Eigen::VectorXd b(200);
    for (int i = 0; i < 200; ++i)
      b(i) = u(rng);
    auto solver = make_linear_solver(kind, /*symmetric_tangent=*/false);
    solver->start_attempt();
    solver->analyze(A);
    solver->factorize(A);
    A.coeffs() *= 2; // the next iterate's tangent, assembled into the same pattern
    const Eigen::VectorXd x = solver->solve(b);
    EXPECT_LT(relative_residual(factorised, x, b), 1e-10) << solver->name();
  }
  // The symmetric LDL^T (symmetric tangents alone).
  const SparseMatrix factorised = banded(200, 0.0, rng);
  SparseMatrix A = factorised;
  const Eigen::VectorXd b = Eigen::VectorXd::Ones(200);
  auto ldlt = make_linear_solver(LinearSolverKind::LDLTSymmetric);
  ldlt->analyze(A);
  ldlt->factorize(A);
  A.coeffs() *= 2;
  EXPECT_LT(relative_residual(factorised, ldlt->solve(b), b), 1e-10);
}

/// An indefinite symmetric n x n matrix: the banded S with every fifth diagonal entry negative
/// (a tangent under compression or with a soft mode has negative pivots).
SparseMatrix indefinite(int n, std::mt19937& rng) {
  SparseMatrix A = banded(n, 0.0, rng);
  for (int i = 0; i < n; i += 5)
    A.coeffRef(i, i) = -A.coeffRef(i, i);
  return A;
}

TEST(LinearSolver, MumpsSolvesTheSymmetricPartAsLDLTDoes) {
  if (!mumps_available())
    GTEST_SKIP() << "this build has no MUMPS";
  std::mt19937 rng(11);
  const int n = 600;
  auto mumps = make_linear_solver(LinearSolverKind::MUMPS);
  EXPECT_EQ(mumps->name(), "mumps");
  // Indefinite symmetric, then nearly symmetric (MUMPS, as ldlt, solves the symmetric part), the
  // second factorisation on the first's analysis, then a new pattern analysed afresh.
  for (int round = 0; round < 3; ++round) {
    const SparseMatrix A =
        round == 0 ? indefinite(n, rng) : banded(round == 1 ? n : n + 7, 1e-3, rng);
    const SparseMatrix S = 0.5 * (A + SparseMatrix(A.transpose()));
    const Eigen::VectorXd b =
        Eigen::VectorXd::NullaryExpr(A.rows(), [&] { return 1.0 + rng() % 7; });
    if (round != 1)
      mumps->analyze(A);
    mumps->factorize(A);
    const Eigen::VectorXd x = mumps->solve(b);
    const Eigen::VectorXd reference = solve_with(LinearSolverKind::LDLTSymmetric, A, b);
    EXPECT_LT(relative_residual(S, x, b), 1e-12) << "round " << round;
    EXPECT_LT((x - reference).norm(), 1e-10 * reference.norm()) << "round " << round;
  }
  // A singular symmetric part is an error with MUMPS's code, not a wrong answer.
  SparseMatrix singular = banded(50, 0.0, rng);
  singular.coeffRef(7, 7) = 0.0;
  for (int k = 1; k <= 3; ++k) {
    singular.coeffRef(7, 7 + k) = singular.coeffRef(7 + k, 7) = 0.0;
    singular.coeffRef(7, 7 - k) = singular.coeffRef(7 - k, 7) = 0.0;
  }
  auto fresh = make_linear_solver(LinearSolverKind::MUMPS);
  fresh->analyze(singular);
  EXPECT_THROW(fresh->factorize(singular), LinearSolverError);
}

TEST(LinearSolver, MumpsFactorisesANonSymmetricTangentByLUAsUmfpackDoes) {
  // Asked for a tangent that is not symmetric (friction, applied moments), MUMPS factorises the
  // full matrix (LU), not its symmetric part: the solution is the full system's, as UMFPACK's.
  if (!mumps_available())
    GTEST_SKIP() << "this build has no MUMPS";
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto mumps = make_linear_solver(LinearSolverKind::MUMPS, /*symmetric_tangent=*/false);
  // Nearly symmetric, then far from it (skew entries ten times the symmetric ones) on the same
  // analysis, then a new pattern analysed afresh.
  for (int round = 0; round < 3; ++round) {
    const int n = round == 2 ? 607 : 600;
    const SparseMatrix A = banded(n, round == 0 ? 1e-3 : 10.0, rng);
    Eigen::VectorXd b(n);
    for (int i = 0; i < n; ++i)
      b(i) = u(rng);
    if (round != 1)
      mumps->analyze(A);
    mumps->factorize(A);
    const Eigen::VectorXd x = mumps->solve(b);
    const Eigen::VectorXd lu = solve_with(LinearSolverKind::LU, A, b);
    EXPECT_LT(relative_residual(A, x, b), 1e-13) << "round " << round;
    EXPECT_LT((x - lu).norm(), 1e-12 * lu.norm()) << "round " << round;
  }
  // A singular matrix is an error with MUMPS's code, not a wrong answer.
  SparseMatrix singular = banded(50, 1.0, rng);
  for (int k = 0; k < singular.outerSize(); ++k)
    for (SparseMatrix::InnerIterator it(singular, k); it; ++it)
      if (it.row() == 7)
        it.valueRef() = 0.0;
  auto fresh = make_linear_solver(LinearSolverKind::MUMPS, false);
  fresh->analyze(singular);
  EXPECT_THROW(fresh->factorize(singular), LinearSolverError);
}

TEST(LinearSolver, AutoTakesMumpsForLargeSymmetricModels) {
  // A clamped beam of m elements has 12 m free equations: 'auto' takes ldlt below
  // kMumpsEquations and mumps from there on (where this build has MUMPS).
  const Section s = test::stiffness_section(1e4, 1e4, 1.0, 1.0);
  const int first = (kMumpsEquations + 11) / 12; // the fewest elements with as many equations
  for (const int elements : {first - 1, first}) {
    Model m = test::straight_beam({0, 0, 0}, {1, 0, 0}, elements, s);
    m.constraints.push_back(test::clamp(1)); // "start"
    m.steps.push_back(test::static_step(1.0, 1.0));
    const Simulation sim(m);
    const bool large = sim.assembler().n_equations() >= kMumpsEquations;
    EXPECT_EQ(large, elements == first);
    EXPECT_EQ(sim.linear_solver_name(), large && mumps_available() ? "mumps" : "ldlt");
  }
}

TEST(LinearSolver, AutoTakesMumpsLUForTangentsFarFromSymmetric) {
  // A cantilever rolled by a follower end moment (a far from symmetric tangent): 'auto' takes
  // MUMPS's LU where this build has MUMPS, UMFPACK's otherwise, and either reaches lu's answer
  // in lu's iterations (the symmetric part alone would cost Newton its quadratic convergence).
  const Section s = test::stiffness_section(1e4, 1e4, 1.0, 1.0);
  Model m = test::straight_beam({0, 0, 0}, {1, 0, 0}, 20, s);
  m.constraints.push_back(test::clamp(1)); // "start"
  NodalLoad roll;
  roll.node_set = 2;                      // "end"
  roll.moment = {0, 0, std::numbers::pi}; // half a turn at t = 1
  roll.follower_moment = true;
  roll.factor = TimeTable::ramp(1.0);
  m.loads.push_back(roll);
  m.steps.push_back(test::static_step(1.0, 0.1));
  Simulation automatic(m);
  EXPECT_EQ(automatic.linear_solver_name(), mumps_available() ? "mumps" : "lu");
  SimulationOptions lu_options;
  lu_options.linear_solver = LinearSolverKind::LU;
  Simulation lu(m, lu_options);
  EXPECT_EQ(lu.linear_solver_name(), "lu");
  automatic.run();
  lu.run();
  const Eigen::Matrix3Xd &x = automatic.state().x_n, &reference = lu.state().x_n;
  EXPECT_LT((x - reference).norm(), 1e-10 * reference.norm());
  EXPECT_EQ(automatic.total_iterations(), lu.total_iterations());
  // Rolled: the tip has come back towards the clamp (a half circle of diameter 2 / pi).
  EXPECT_NEAR(x.col(40).x(), 0.0, 1e-6);
  EXPECT_NEAR(x.col(40).y(), 2.0 / std::numbers::pi, 1e-3);
}

/// The 5-point Laplacian of an m x m grid plus 0.1 on the diagonal, with extra symmetric
/// couplings (i, j) of value -0.05 (a contact pair coupled in the pattern).
SparseMatrix grid(int m, const std::vector<std::pair<int, int>>& extra) {
  std::vector<Eigen::Triplet<double>> t;
  const auto id = [m](int i, int j) { return i * m + j; };
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j) {
      t.emplace_back(id(i, j), id(i, j), 4.1);
      if (i + 1 < m) {
        t.emplace_back(id(i, j), id(i + 1, j), -1.0);
        t.emplace_back(id(i + 1, j), id(i, j), -1.0);
      }
      if (j + 1 < m) {
        t.emplace_back(id(i, j), id(i, j + 1), -1.0);
        t.emplace_back(id(i, j + 1), id(i, j), -1.0);
      }
    }
  for (const auto& [a, b] : extra) {
    t.emplace_back(a, b, -0.05);
    t.emplace_back(b, a, -0.05);
  }
  SparseMatrix A(m * m, m * m);
  A.setFromTriplets(t.begin(), t.end());
  return A;
}

TEST(LinearSolver, LDLTKeepsItsOrderingWhileTheFillAllows) {
  // A contact pair coupled or released changes the pattern; METIS was 70 % of each analysis.
  // The LDL^T keeps its ordering while the factor's fill stays within kOrderingFillGrowth of the
  // fill it had when computed, and orders afresh when the pattern outgrows it. Each system is
  // solved to round-off either way, and a solver given the kept ordering (a restart) makes the
  // same choice and the same bits.
  const int m = 40;
  const SparseMatrix A0 = grid(m, {});
  const SparseMatrix A1 = grid(m, {{0, m + 1}, {5 * m + 7, 6 * m + 8}}); // two diagonal pairs
  std::vector<std::pair<int, int>> far;
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> node(0, m * m - 1);
  for (int k = 0; k < 200; ++k) {
    const int a = node(rng), b = node(rng);
    if (a != b)
      far.emplace_back(a, b);
  }
  const SparseMatrix A2 = grid(m, far); // couplings across the whole grid
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(m * m, -1.0, 2.0);
  for (const LinearSolverKind kind :
       {LinearSolverKind::LDLTSymmetric, LinearSolverKind::LDLTGmres}) {
    auto solver = make_linear_solver(kind);
    solver->start_attempt();
    const auto solve = [&](LinearSolver& s, const SparseMatrix& A) {
      s.analyze(A);
      s.factorize(A);
      const Eigen::VectorXd x = s.solve(b);
      EXPECT_LT(relative_residual(A, x, b), 1e-13);
      return x;
    };
    solve(*solver, A0);
    const SolverOrdering first = solver->ordering();
    ASSERT_EQ(first.inverse_permutation.size(), static_cast<std::size_t>(m * m));
    EXPECT_GT(first.fill, 0.0);
    solve(*solver, A1);
    EXPECT_EQ(solver->ordering().inverse_permutation, first.inverse_permutation);
    EXPECT_EQ(solver->ordering().fill, first.fill);
    // A restart from the kept ordering: the same choice, the same bits.
    auto restarted = make_linear_solver(kind);
    restarted->start_attempt();
    restarted->set_ordering(solver->ordering());
    const Eigen::VectorXd x1 = solve(*solver, A1), x1_restarted = solve(*restarted, A1);
    EXPECT_EQ((x1 - x1_restarted).cwiseAbs().maxCoeff(), 0.0);
    // A fresh solver orders A1 afresh: another permutation.
    auto fresh = make_linear_solver(kind);
    fresh->start_attempt();
    solve(*fresh, A1);
    EXPECT_NE(fresh->ordering().inverse_permutation, first.inverse_permutation);
    // The far couplings fill the factor beyond the kept ordering's fill: METIS again.
    solve(*solver, A2);
    EXPECT_NE(solver->ordering().inverse_permutation, first.inverse_permutation);
  }
}

TEST(LinearSolver, NamesAreParsedAndUnknownOnesListTheChoices) {
  EXPECT_EQ(linear_solver_kind_from("mumps"), LinearSolverKind::MUMPS);
  EXPECT_EQ(linear_solver_kind_from("ldlt-gmres"), LinearSolverKind::LDLTGmres);
  EXPECT_EQ(linear_solver_kind_from("lu"), LinearSolverKind::LU);
  try {
    linear_solver_kind_from("gmres");
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'ldlt-gmres'"), std::string::npos) << e.what();
  }
}

} // namespace
} // namespace yarnsim
