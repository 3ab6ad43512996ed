// The second half of the decision benchmark of issue "Beyond one machine" (item 1): MUMPS's LDL^T
// (SYM = 2, symmetric indefinite) of the tangent weave_tangent.cpp wrote (the symmetric part's
// lower triangle of an n x n weave's tangent, b and `ldlt`'s solution), on the METIS ordering
// `ldlt` uses, handed in (ICNTL(7) = 1), analysed once, on the MPI ranks this program is started
// on (`mpirun -np 1 | 2 mumps_decision N FILE`), its fronts on the BLAS behind libblas.so.3
// (OpenBLAS on the project's machines, scripts/setup). It does not link the engine: the engine's
// sequential MUMPS brings a stand-in MPI library that would clash with OpenMPI here.
// Output, one line:
//   mumps ranks n equations nonzeros(lower) analysis_s factorisation_s solve_s memory_MB
//   relative_residual relative_difference_to_ldlt
// memory: INFOG(22), the total memory MUMPS's factorisation used over all ranks. The fastest of
// `repeats` factorisations (default 3).
#include <iostream> // Eigen/MetisSupport uses std::cerr without including it

#include <Eigen/MetisSupport>
#include <Eigen/SparseCore>
#include <dmumps_c.h>
#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

using SparseMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

template <class T>
std::vector<T> read_array(std::ifstream& in) {
  std::int64_t count = 0;
  in.read(reinterpret_cast<char*>(&count), sizeof count);
  std::vector<T> out(static_cast<std::size_t>(in && count > 0 ? count : 0));
  in.read(reinterpret_cast<char*>(out.data()),
          static_cast<std::streamsize>(out.size() * sizeof(T)));
  return out;
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
  if (argc < 3) {
    if (rank == 0)
      std::fprintf(stderr, "usage: mpirun -np R mumps_decision N FILE [repeats]\n");
    MPI_Finalize();
    return 2;
  }
  const int n = std::atoi(argv[1]);
  const int repeats = argc > 3 ? std::max(1, std::atoi(argv[3])) : 3;

  // Rank 0: the matrix weave_tangent wrote, and the METIS ordering `ldlt` uses.
  SparseMatrix lower; // lower triangle of the symmetric part
  std::vector<int> irn, jcn, perm_in;
  std::vector<double> values;
  Eigen::VectorXd rhs, x_ldlt;
  if (rank == 0) {
    std::ifstream in(argv[2], std::ios::binary);
    std::int64_t rows = 0;
    in.read(reinterpret_cast<char*>(&rows), sizeof rows);
    const std::vector<int> outer = read_array<int>(in), inner = read_array<int>(in);
    const std::vector<double> entries = read_array<double>(in), b = read_array<double>(in),
                              x = read_array<double>(in);
    if (!in || rows <= 0 || outer.size() != static_cast<std::size_t>(rows + 1) ||
        b.size() != static_cast<std::size_t>(rows) || x.size() != b.size()) {
      std::fprintf(stderr, "mumps_decision: %s is not a tangent written by weave_tangent\n",
                   argv[2]);
      MPI_Abort(MPI_COMM_WORLD, 2);
    }
    lower = Eigen::Map<const SparseMatrix>(rows, rows, static_cast<Eigen::Index>(entries.size()),
                                           outer.data(), inner.data(), entries.data());
    rhs = Eigen::Map<const Eigen::VectorXd>(b.data(), rows);
    x_ldlt = Eigen::Map<const Eigen::VectorXd>(x.data(), rows);
    // PERM_IN(i) = the position of variable i (1-based) in the ordering Eigen's
    // SimplicialLDLT<..., MetisOrdering> (and so `ldlt`) computes on the full pattern.
    SparseMatrix full;
    full = lower.selfadjointView<Eigen::Lower>();
    Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> inverse;
    Eigen::MetisOrdering<int> ordering;
    ordering(full, inverse);
    const Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> forward = inverse.inverse();
    perm_in.resize(static_cast<std::size_t>(rows));
    for (Eigen::Index i = 0; i < rows; ++i)
      perm_in[static_cast<std::size_t>(i)] = forward.indices()(i) + 1;
    for (Eigen::Index j = 0; j < lower.outerSize(); ++j)
      for (SparseMatrix::InnerIterator it(lower, j); it; ++it) {
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
    const SparseMatrix S = lower.selfadjointView<Eigen::Lower>();
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
