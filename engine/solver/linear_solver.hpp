#pragma once
// Sparse direct solvers behind one interface: the pattern is analysed (fill-reducing METIS
// ordering) once and refactorised while it does not change (engineering-notes.md, "Sparse direct
// solvers"); the LDL^T keeps its ordering across pattern changes while the fill allows.

#include "engine/assembly/sparse_matrix.hpp"

#include <Eigen/SparseCore>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace yarnsim {

/// The factorisation failed (singular or non-finite matrix).
class LinearSolverError : public std::runtime_error {
  using std::runtime_error::runtime_error;
};

enum class LinearSolverKind {
  /// LU where the model has applied moments or friction (their tangents are far from
  /// symmetric: MUMPS's where built, else UMFPACK's), LDLTGmres where it has surface contact,
  /// LDLTSymmetric otherwise (MUMPS's from kMumpsEquations on); MUMPS over several processes:
  /// see docs/performance.md for the figures behind the choice.
  Auto,
  LU,            ///< LU of the full (non-symmetric) tangent, UMFPACK (SuiteSparse)
  LDLTSymmetric, ///< LDL^T of the symmetric part (A + A^T) / 2, Eigen SimplicialLDLT + METIS
  /// Supernodal LL^T of the symmetric part, CHOLMOD + METIS; an iteration whose tangent is not
  /// positive definite falls back to LDLTSymmetric.
  Cholmod,
  /// The full tangent by GMRES preconditioned with the LDL^T of its symmetric part, to a
  /// relative residual of 1e-10; LU where that does not converge in 20 iterations, and for the
  /// rest of that Newton attempt.
  LDLTGmres,
  /// MUMPS (sequential, multifrontal) on the same METIS ordering: LDL^T of the symmetric part
  /// where the tangent is symmetric, LU of the full tangent otherwise (make_linear_solver's
  /// symmetric_tangent). `auto`'s choice for `ldlt`'s models from kMumpsEquations equations on
  /// and for `lu`'s models at any size, where MUMPS is built.
  MUMPS,
  /// The tangent factorised by the processes of an MPI run together, through PETSc (MUMPS by
  /// default: LDL^T of the symmetric part, or LU where the tangent is far from symmetric), or
  /// any solver PETSc's options name. The build with YARNSIM_MPI (petsc_solver.hpp).
  PETSc
};

/// Free equations from which `auto` takes MUMPS instead of `ldlt` (docs/performance.md, "The
/// factorisation: MUMPS against today's LDL^T": the engine's `mumps` factorises 1.04 times
/// faster than `ldlt` at 235 000 equations, 1.18 at 412 000, 1.67 at 912 000; 1.3 near 515 000).
inline constexpr int kMumpsEquations = 500000;

/// Whether this build has MUMPS (the `mumps` linear solver).
bool mumps_available();

/// A fill-reducing ordering kept across pattern changes (SymmetricLDLT): the inverse
/// permutation (position -> equation) and the factor's fill, nonzeros of L over those of the
/// matrix, of the pattern it was computed for. Empty where the solver keeps none.
struct SolverOrdering {
  std::vector<int> inverse_permutation;
  double fill = 0;
};

/// A kept ordering serves a changed pattern while its factor's fill stays within this factor of
/// the fill it had when computed; METIS orders the pattern afresh otherwise (docs/performance.md,
/// "The ordering kept across contact patterns").
inline constexpr double kOrderingFillGrowth = 1.02;

class LinearSolver {
public:
  virtual ~LinearSolver() = default;
  /// Symbolic analysis of A's pattern; call again only when the pattern changes.
  virtual void analyze(const SparseMatrix& A) = 0;
  /// Numeric factorisation of A (same pattern as analysed). Throws LinearSolverError.
  virtual void factorize(const SparseMatrix& A) = 0;
  /// x = A^-1 b with the last factorisation.
  virtual Eigen::VectorXd solve(const Eigen::VectorXd& b) = 0;
  /// A new Newton attempt starts: a solver that keeps a factorisation across iterations makes
  /// the next one afresh.
  virtual void start_attempt() {}
  virtual std::string name() const = 0;
  /// The ordering in use (a checkpoint keeps it, so a restart makes the same choices).
  virtual SolverOrdering ordering() const { return {}; }
  /// Continue from this ordering: the next analysis tries it first.
  virtual void set_ordering(const SolverOrdering&) {}
  /// Over several processes, whether each process hands the solver only the tangent entries it
  /// assembled itself (its partial sums; MUMPS's distributed input sums the duplicates) instead
  /// of the whole tangent summed beforehand (Simulation::evaluate).
  virtual bool sums_partial_tangents() const { return false; }
  /// The entries this process assembles (1 per entry of the tangent's values, 0 where it adds
  /// nothing: Assembler::own_entries), for the next analysis; with sums_partial_tangents().
  virtual void set_own_entries(std::vector<char> /*own*/) {}
};

/// symmetric_tangent: the kinds that choose between the symmetric part and the full tangent
/// (MUMPS, PETSc) take the symmetric part; else the full tangent.
std::unique_ptr<LinearSolver> make_linear_solver(LinearSolverKind kind,
                                                 bool symmetric_tangent = true);
/// "auto", "lu", "ldlt", "ldlt-gmres", "mumps", "cholmod" or "petsc". Throws std::invalid_argument
/// for any other name.
LinearSolverKind linear_solver_kind_from(const std::string& name);

} // namespace yarnsim
