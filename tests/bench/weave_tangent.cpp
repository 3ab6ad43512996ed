// The first half of the decision benchmark of issue "Beyond one machine" (item 1; the second is
// mumps_decision.cpp, an MPI program that cannot link the engine, whose sequential MUMPS brings a
// stand-in MPI library). Builds the tangent of an n x n weave of the paper's fabric (the biaxial
// k = 1 test after its first increment of 1 ms: every candidate pair in the pattern), times the
// engine's own solvers on it, `ldlt` (Eigen SimplicialLDLT on the METIS ordering) and `mumps`
// (sequential MUMPS LDL^T on the same ordering) where built, and writes the symmetric part's
// lower triangle, the right-hand side b = K 1 and `ldlt`'s solution to FILE for mumps_decision.
//   weave_tangent N FILE [repeats]
// Output, one line per solver (the fastest of `repeats` factorisations, default 3):
//   solver ranks n equations nonzeros(lower) analysis_s factorisation_s solve_s memory_MB
//   relative_residual relative_difference_to_ldlt
// memory: `ldlt` the factor's entries (values and row indices, 12 bytes each) plus its column
// pointers; `mumps` "-" (see mumps_decision for MUMPS's own figure).
#include "engine/solver/linear_solver.hpp"
#include "engine/solver/simulation.hpp"
#include "engine/textile/biaxial.hpp"
#include "engine/textile/weave.hpp"

#include <iostream> // Eigen/MetisSupport uses std::cerr without including it

#include <Eigen/MetisSupport>
#include <Eigen/SparseCholesky>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <string>

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
  SimulationOptions options;
  options.linear_solver = LinearSolverKind::LDLTSymmetric;
  Simulation sim(f.model, options);
  sim.run();
  return sim.assembler().matrix();
}

/// Times `kind` on K: analysis once, the fastest of `repeats` factorisations, one solve.
Eigen::VectorXd time_solver(yarnsim::LinearSolverKind kind, const yarnsim::SparseMatrix& K,
                            const Eigen::VectorXd& rhs, int repeats, double timings[3]) {
  auto solver = yarnsim::make_linear_solver(kind);
  Clock::time_point t0 = Clock::now();
  solver->analyze(K);
  timings[0] = seconds_since(t0);
  timings[1] = std::numeric_limits<double>::infinity();
  for (int r = 0; r < repeats; ++r) {
    t0 = Clock::now();
    solver->factorize(K);
    timings[1] = std::min(timings[1], seconds_since(t0));
  }
  t0 = Clock::now();
  Eigen::VectorXd x = solver->solve(rhs);
  timings[2] = seconds_since(t0);
  return x;
}

template <class T>
void write_array(std::ofstream& out, const T* data, std::int64_t count) {
  out.write(reinterpret_cast<const char*>(&count), sizeof count);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(count * sizeof(T)));
}

} // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: weave_tangent N FILE [repeats]\n");
    return 2;
  }
  const int n = std::atoi(argv[1]);
  const int repeats = argc > 3 ? std::max(1, std::atoi(argv[3])) : 3;
  const yarnsim::SparseMatrix K = weave_tangent(n);
  const yarnsim::SparseMatrix Kt = K.transpose();
  const yarnsim::SparseMatrix S = 0.5 * (K + Kt);
  yarnsim::SparseMatrix lower = S.triangularView<Eigen::Lower>();
  lower.makeCompressed();
  const Eigen::VectorXd rhs = K * Eigen::VectorXd::Ones(K.rows());

  double t[3];
  const Eigen::VectorXd x_ldlt =
      time_solver(yarnsim::LinearSolverKind::LDLTSymmetric, K, rhs, repeats, t);
  // The factor's size: an LDL^T of the same ordering, for its count only.
  Eigen::SimplicialLDLT<yarnsim::SparseMatrix, Eigen::Lower, Eigen::MetisOrdering<int>> probe;
  probe.analyzePattern(lower);
  probe.factorize(lower);
  const double factor_entries = static_cast<double>(probe.matrixL().nestedExpression().nonZeros());
  const double memory = (12.0 * factor_entries + 4.0 * K.rows()) / (1024.0 * 1024.0);
  std::printf("ldlt 1 %d %ld %ld %.4f %.4f %.4f %.1f %.3e 0\n", n, (long)K.rows(),
              (long)lower.nonZeros(), t[0], t[1], t[2], memory,
              (S * x_ldlt - rhs).norm() / rhs.norm());
  if (yarnsim::mumps_available()) {
    const Eigen::VectorXd x = time_solver(yarnsim::LinearSolverKind::MUMPS, K, rhs, repeats, t);
    std::printf("mumps-seq 1 %d %ld %ld %.4f %.4f %.4f - %.3e %.3e\n", n, (long)K.rows(),
                (long)lower.nonZeros(), t[0], t[1], t[2], (S * x - rhs).norm() / rhs.norm(),
                (x - x_ldlt).norm() / x_ldlt.norm());
  }
  std::fflush(stdout);

  std::ofstream out(argv[2], std::ios::binary);
  const std::int64_t rows = K.rows();
  out.write(reinterpret_cast<const char*>(&rows), sizeof rows);
  write_array(out, lower.outerIndexPtr(), rows + 1);
  write_array(out, lower.innerIndexPtr(), lower.nonZeros());
  write_array(out, lower.valuePtr(), lower.nonZeros());
  write_array(out, rhs.data(), rows);
  write_array(out, x_ldlt.data(), rows);
  if (!out) {
    std::fprintf(stderr, "weave_tangent: cannot write %s\n", argv[2]);
    return 1;
  }
  return 0;
}
