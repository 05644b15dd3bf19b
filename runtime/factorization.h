/// @file factorization.h
/// @brief A sparse Cholesky factorization around CHOLMOD (SuiteSparse C API): analyse once, factor
/// (numeric, as often as the values change), solve many right-hand sides — one column, several
/// columns in one multi-column solve, or columns in parallel (TBB, one CHOLMOD workspace per thread).
///
/// The iterative stages (paper §4: the quaternion Laplace and the Poisson system of Eq. 1 keep their
/// matrices across iterations) factor once and solve many times; the counts and times end up in the
/// node metrics through FactorizationStats.
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <nlohmann/json.hpp>

#include <memory>
#include <string>

namespace polyhex {

/// Counts and wall times of one or more factorizations. `solves` counts right-hand-side columns.
struct FactorizationStats {
  int analyses = 0;            ///< symbolic analyses (ordering + elimination tree)
  int factorizations = 0;      ///< numeric factorizations
  long solves = 0;             ///< right-hand-side columns solved
  long solve_calls = 0;        ///< calls of solve() (a multi-column solve is one call)
  double analyse_seconds = 0;  ///< wall time of the analyses
  double factor_seconds = 0;   ///< wall time of the numeric factorizations
  double solve_seconds = 0;    ///< wall time of the solves (parallel solves: wall time, not CPU time)

  FactorizationStats& operator+=(const FactorizationStats& o);
  /// Adds these figures to `metrics` (keys analyses, factorizations, solves, analyse_seconds,
  /// factor_seconds, solve_seconds): existing numeric values are summed, missing keys created.
  void merge_into(nlohmann::json& metrics) const;
};

/// How several right-hand-side columns are solved.
enum class SolveMode {
  MultiColumn,  ///< one cholmod_solve2 call on all columns (BLAS-3 supernodal kernels)
  Parallel      ///< tbb::parallel_for over columns, each thread with its own cholmod_common
};

/// Sparse symmetric positive definite LL^T factorization (CHOLMOD, supernodal).
///
/// The matrix is an `Eigen::SparseMatrix<double>` (column-major) holding the lower triangle or the
/// full symmetric matrix: only the lower triangle (row >= column) is read. Not copyable; movable.
class CholmodFactorization {
 public:
  CholmodFactorization();
  /// Analyse and factor `A`. \pre A square, symmetric (lower triangle or full), SPD
  /// \throw SolverError as analyse() and factor()
  explicit CholmodFactorization(const Eigen::SparseMatrix<double>& A);
  ~CholmodFactorization();
  CholmodFactorization(CholmodFactorization&&) noexcept;
  CholmodFactorization& operator=(CholmodFactorization&&) noexcept;
  CholmodFactorization(const CholmodFactorization&) = delete;
  CholmodFactorization& operator=(const CholmodFactorization&) = delete;

  /// Symbolic analysis (fill-reducing ordering, supernodes) of the pattern of A; drops any factor.
  /// \pre A square, n >= 1, lower triangle or full storage
  /// \throw SolverError when A is not square, empty, holds only an upper triangle, or CHOLMOD fails
  void analyse(const Eigen::SparseMatrix<double>& A);

  /// A new factorization holding a copy of this one's symbolic analysis, for a matrix with the same
  /// pattern (and storage); its factor() then needs no analysis (its stats count none).
  /// \throw SolverError when there is no analysis yet or CHOLMOD cannot copy it
  CholmodFactorization share_analysis() const;

  /// Numeric factorization of A, reusing the symbolic analysis (analyses first if there is none).
  /// \pre A has exactly the pattern (and storage) given to analyse()
  /// \throw SolverError when the pattern differs from the analysed one, A has a non-finite entry, or
  ///        A is not positive definite (the message gives the failing column)
  void factor(const Eigen::SparseMatrix<double>& A);

  /// Solve A x = b.  b  #n vector.  \throw SolverError when not factored, sizes differ, b not finite
  Eigen::VectorXd solve(const Eigen::VectorXd& b);
  /// Solve A X = B.  B  #n by k.  \throw SolverError as solve(b)
  Eigen::MatrixXd solve(const Eigen::MatrixXd& B, SolveMode mode = SolveMode::MultiColumn);

  bool factored() const;
  long rows() const;               ///< n, 0 before analyse()
  double factor_nonzeros() const;  ///< nnz(L) of the current analysis (0 before)
  bool supernodal() const;         ///< the analysis chose a supernodal factor
  std::string ordering() const;    ///< fill-reducing ordering chosen ("amd", "metis", ...)
  const FactorizationStats& stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Whether symbolic analyses (analyse()) on different threads run side by side. METIS, behind them, seeds
/// and draws from C's rand(); factorization.cpp gives the process a rand() with one state per thread, so
/// that they do not change each other's orderings. False where the link did not make that the process's
/// rand(): analyses then wait in turn, with the same results.
bool analyses_run_concurrently();

/// The OpenBLAS kernel set polyhex has OpenBLAS run on this CPU where the environment names one
/// (factorization.cpp): "SkylakeX" with AVX-512 (F, BW, DQ, VL, CD), "Haswell" with AVX2 and FMA only, nullptr on
/// an older CPU (OpenBLAS's own choice). Safe to call before constructors have run.
const char* blas_kernels_for_this_cpu();

}  // namespace polyhex
