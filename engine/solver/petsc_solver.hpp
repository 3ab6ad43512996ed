#pragma once
// The tangent factorised by the processes of an MPI run together, through PETSc (the build with
// YARNSIM_MPI): MUMPS by default, any direct or iterative PETSc solver by PETSc's options
// (PETSC_OPTIONS). docs/formulation.md, "Runs over MPI".

#include "engine/solver/linear_solver.hpp"

#include <memory>

namespace yarnsim {

/// Whether this build has PETSc (the `petsc` linear solver).
bool petsc_available();

/// The `petsc` linear solver. Each process owns a contiguous block of the rows of PETSc's
/// distributed matrix, in the equations' order, and receives the whole solution, the same bits on
/// every process. In a run (set_own_entries) each process holds only the sums of its own
/// elements and pairs and adds the entries it assembled into their owners' rows (PETSc's
/// MatSetValues with ADD_VALUES, off-process rows through its stash); given a whole tangent
/// (one process, the solver tests) each writes its rows straight into PETSc's arrays.
/// symmetric: LDL^T of the symmetric part (A + A^T) / 2 (PETSc's Cholesky: MUMPS with SYM = 2,
/// symmetric indefinite); otherwise LU of the full tangent. Collective: every process calls each
/// member at the same point. Throws std::invalid_argument where the build has no PETSc.
std::unique_ptr<LinearSolver> make_petsc_solver(bool symmetric);

} // namespace yarnsim
