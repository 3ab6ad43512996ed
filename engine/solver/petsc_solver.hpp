#pragma once
// The tangent factorised by the processes of an MPI run together, through PETSc (the build with
// YARNSIM_MPI): MUMPS by default, any direct or iterative PETSc solver by PETSc's options
// (PETSC_OPTIONS). docs/formulation.md, "Runs over MPI".

#include "engine/solver/linear_solver.hpp"

#include <memory>

namespace yarnsim {

/// Whether this build has PETSc (the `petsc` linear solver).
bool petsc_available();

/// The `petsc` linear solver. Every process holds the whole tangent (the model is replicated,
/// distributed.hpp); each hands PETSc its share of the rows, contiguous blocks of the equations
/// in their order, and receives the whole solution, the same bits on every process.
/// symmetric: LDL^T of the symmetric part (A + A^T) / 2 (PETSc's Cholesky: MUMPS with SYM = 2,
/// symmetric indefinite); otherwise LU of the full tangent. Collective: every process calls each
/// member at the same point. Throws std::invalid_argument where the build has no PETSc.
std::unique_ptr<LinearSolver> make_petsc_solver(bool symmetric);

} // namespace yarnsim
