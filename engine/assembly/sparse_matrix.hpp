#pragma once
// The tangent's storage: what assembly fills and the linear solvers (engine/solver/) factorise.

#include <Eigen/SparseCore>

namespace yarnsim {

/// Compressed sparse columns, values in double, indices in int (SuiteSparse's int interfaces,
/// which Eigen's UmfPackLU and CholmodSupernodalLLT call on this type).
using SparseMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

} // namespace yarnsim
