// The decision benchmark of issue "Beyond one machine" (item 1): the factorisation and solve of
// the tangent of an n x n weave of the paper's fabric (the biaxial k = 1 test after its first
// increment of 1 ms: every candidate pair in the pattern) with today's solver, the LDL^T of the
// symmetric part (engine/solver/linear_solver.cpp, Eigen SimplicialLDLT on the METIS ordering),
// and with MUMPS's LDL^T of the same symmetric matrix (SYM = 2, symmetric indefinite) on the
// same METIS ordering handed in (ICNTL(7) = 1), analysed once, on the MPI ranks this program is
// started on (`mpirun -np 1 | 2 mumps_decision N`), its dense fronts on the BLAS behind
// libblas.so.3 (OpenBLAS on the project's machines, scripts/setup).
//
// Rank 0 builds the model, runs the first increment and assembles the tangent K (free
// equations); b = K 1 (so x = 1 is the exact solution of the symmetric system's neighbour;
// agreement is measured between the two solvers' x). Each factorisation is timed `repeats`
// times (default 3) and the fastest kept. Output, one line per solver:
//   solver ranks n equations nonzeros(lower) analysis_s factorisation_s solve_s memory_MB
//   relative_residual relative_difference_to_ldlt
// memory: LDL^T the factor's entries (values and row indices, 12 bytes each) plus its
// column pointers; MUMPS INFOG(22), the total memory its factorisation used over all ranks.
#include "engine/solver/linear_solver.hpp"
#include "engine/solver/simulation.hpp"
#include "engine/textile/biaxial.hpp"
#include "engine/textile/weave.hpp"

#include <iostream> // Eigen/MetisSupport uses std::cerr without including it

#include <Eigen/MetisSupport>
#include <Eigen/SparseCholesky>
#include <dmumps_c.h>
#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// The tangent of the n x n weave's biaxial k = 1 test after its first increment of 1 ms.
yarnsim::SparseMatrix weave_tangent(int n) {
  using namespace yarnsim;
  textile::WeaveParameters p = textile::paper_fabric();
  p.n_warp = p.n_weft = n;
  p.length_warp = (n + 3) * p.spacing_weft; // as scripts/bench's weaves
  p.length_weft = (n + 3) * p.spacing_warp;
  textile::Fabric f = textile::build_weave(p);
  textile::BiaxialParameters b;
  b.monitors = false;
  textile::add_biaxial_test(f, b);
  f.model.steps.back().end_time = 1e-3;
  f.model.steps.back().dt_initial = f.model.steps.back().dt_max = 1e-3;
  Simulation sim(f.model);
  sim.run();
  return sim.assembler().matrix();
}

// MUMPS's 1-based control arrays.
int& icntl(DMUMPS_STRUC_C& id, int i) {
  return id.icntl[i - 1];
}
int infog(const DMUMPS_STRUC_C& id, int i) {
  return id.infog[i - 1];
}

void mumps_call(DMUMPS_STRUC_C& id, int job, const char* what) {
  id.job = job;
  dmumps_c(&id);
  if (infog(id, 1) < 0) {
    std::fprintf(stderr, "MUMPS %s failed: INFOG(1) = %d, INFOG(2) = %d\n", what, infog(id, 1),
                 infog(id, 2));
    MPI_Abort(MPI_COMM_WORLD, 3);
  }
}

} // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  int rank = 0, ranks = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  if (argc < 2) {
    if (rank == 0)
      std::fprintf(stderr, "usage: mpirun -np R mumps_decision N [repeats]\n");
    MPI_Finalize();
    return 2;
  }
  const int n = std::atoi(argv[1]);
  const int repeats = argc > 2 ? std::max(1, std::atoi(argv[2])) : 3;

  // Rank 0: the matrix, the ordering, the LDL^T reference.
  yarnsim::SparseMatrix lower; // lower triangle of the symmetric part
  std::vector<int> irn, jcn, perm_in;
  std::vector<double> values;
  Eigen::VectorXd rhs, x_ldlt;
  if (rank == 0) {
    const yarnsim::SparseMatrix K = weave_tangent(n);
    const yarnsim::SparseMatrix Kt = K.transpose();
    const yarnsim::SparseMatrix S = 0.5 * (K + Kt);
    lower = S.triangularView<Eigen::Lower>();
    rhs = K * Eigen::VectorXd::Ones(K.rows());

    // Today's solver, timed the way a Newton run uses it.
    auto solver = yarnsim::make_linear_solver(yarnsim::LinearSolverKind::LDLTSymmetric);
    Clock::time_point t0 = Clock::now();
    solver->analyze(K);
    const double analysis = seconds_since(t0);
    double factorisation = std::numeric_limits<double>::infinity();
    for (int r = 0; r < repeats; ++r) {
      t0 = Clock::now();
      solver->factorize(K);
      factorisation = std::min(factorisation, seconds_since(t0));
    }
    t0 = Clock::now();
    x_ldlt = solver->solve(rhs);
    const double solve = seconds_since(t0);
    // The factor's size: an LDL^T of the same ordering, for its count only.
    Eigen::SimplicialLDLT<yarnsim::SparseMatrix, Eigen::Lower, Eigen::MetisOrdering<int>> probe;
    probe.analyzePattern(lower);
    probe.factorize(lower);
    const double factor_entries =
        static_cast<double>(probe.matrixL().nestedExpression().nonZeros());
    const double memory = (12.0 * factor_entries + 4.0 * K.rows()) / (1024.0 * 1024.0);
    const double residual = (S * x_ldlt - rhs).norm() / rhs.norm();
    std::printf("ldlt 1 %d %ld %ld %.4f %.4f %.4f %.1f %.3e 0\n", n, (long)K.rows(),
                (long)lower.nonZeros(), analysis, factorisation, solve, memory, residual);

    // The same METIS ordering for MUMPS: PERM_IN(i) = the position of variable i (1-based).
    yarnsim::SparseMatrix full;
    full = lower.selfadjointView<Eigen::Lower>();
    Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> inverse;
    Eigen::MetisOrdering<int> ordering;
    ordering(full, inverse);
    const Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> forward = inverse.inverse();
    perm_in.resize(static_cast<std::size_t>(K.rows()));
    for (Eigen::Index i = 0; i < K.rows(); ++i)
      perm_in[static_cast<std::size_t>(i)] = forward.indices()(i) + 1;
    for (Eigen::Index j = 0; j < lower.outerSize(); ++j)
      for (yarnsim::SparseMatrix::InnerIterator it(lower, j); it; ++it) {
        irn.push_back(static_cast<int>(it.row()) + 1);
        jcn.push_back(static_cast<int>(it.col()) + 1);
        values.push_back(it.value());
      }
  }

  DMUMPS_STRUC_C id{};
  id.comm_fortran = static_cast<MUMPS_INT>(MPI_Comm_c2f(MPI_COMM_WORLD));
  id.par = 1; // the host works too
  id.sym = 2; // symmetric, not necessarily positive definite: LDL^T
  mumps_call(id, -1, "initialisation");
  icntl(id, 1) = icntl(id, 2) = icntl(id, 3) = -1; // no messages
  icntl(id, 4) = 0;
  icntl(id, 7) = 1;   // the ordering given in PERM_IN
  icntl(id, 14) = 50; // working space: 50 % over the analysis's estimate
  if (rank == 0) {
    id.n = static_cast<MUMPS_INT>(lower.rows());
    id.nnz = static_cast<MUMPS_INT8>(values.size());
    id.irn = irn.data();
    id.jcn = jcn.data();
    id.a = values.data();
    id.perm_in = perm_in.data();
  }
  MPI_Barrier(MPI_COMM_WORLD);
  Clock::time_point t0 = Clock::now();
  mumps_call(id, 1, "analysis");
  const double analysis = seconds_since(t0);
  double factorisation = std::numeric_limits<double>::infinity();
  for (int r = 0; r < repeats; ++r) {
    MPI_Barrier(MPI_COMM_WORLD);
    t0 = Clock::now();
    mumps_call(id, 2, "factorisation");
    factorisation = std::min(factorisation, seconds_since(t0));
  }
  Eigen::VectorXd x;
  if (rank == 0) {
    x = rhs;
    id.rhs = x.data();
  }
  MPI_Barrier(MPI_COMM_WORLD);
  t0 = Clock::now();
  mumps_call(id, 3, "solve");
  const double solve = seconds_since(t0);
  if (rank == 0) {
    const yarnsim::SparseMatrix S = lower.selfadjointView<Eigen::Lower>();
    const double residual = (S * x - rhs).norm() / rhs.norm();
    const double difference = (x - x_ldlt).norm() / x_ldlt.norm();
    std::printf("mumps %d %d %ld %ld %.4f %.4f %.4f %d %.3e %.3e\n", ranks, n, (long)lower.rows(),
                (long)lower.nonZeros(), analysis, factorisation, solve, infog(id, 22), residual,
                difference);
  }
  mumps_call(id, -2, "termination");
  MPI_Finalize();
  return 0;
}
