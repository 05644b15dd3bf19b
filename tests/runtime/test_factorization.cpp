// Tests of the CHOLMOD factorization helper (runtime/factorization.h).
#include "runtime/errors.h"
#include "runtime/factorization.h"

#include <Eigen/SparseCore>
#include <catch2/catch.hpp>

#include <thread>
#include <vector>

using polyhex::CholmodFactorization;
using polyhex::SolveMode;
using polyhex::SolverError;

namespace {

// Expects a SolverError whose message matches `matcher` (Catch2 v2 has no type+message matcher).
#define CHECK_SOLVER_ERROR(expr, matcher) \
  do {                                    \
    CHECK_THROWS_AS(expr, SolverError);   \
    CHECK_THROWS_WITH(expr, matcher);     \
  } while (0)

/// 7-point Laplacian of an m^3 grid plus `shift` * identity; lower triangle only, or full.
Eigen::SparseMatrix<double> laplacian3d(int m, double shift, bool full) {
  auto id = [m](int x, int y, int z) { return (z * m + y) * m + x; };
  std::vector<Eigen::Triplet<double>> t;
  for (int z = 0; z < m; ++z)
    for (int y = 0; y < m; ++y)
      for (int x = 0; x < m; ++x) {
        int i = id(x, y, z), deg = 0;
        const int nb[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
        for (auto& d : nb) {
          int X = x + d[0], Y = y + d[1], Z = z + d[2];
          if (X < m && Y < m && Z < m) {
            int j = id(X, Y, Z);
            t.emplace_back(j, i, -1.0);  // j > i: lower triangle
            if (full) t.emplace_back(i, j, -1.0);
          }
        }
        for (int s = -1; s <= 1; s += 2) {
          deg += (x + s >= 0 && x + s < m) + (y + s >= 0 && y + s < m) + (z + s >= 0 && z + s < m);
        }
        t.emplace_back(i, i, deg + shift);
      }
  Eigen::SparseMatrix<double> A(m * m * m, m * m * m);
  A.setFromTriplets(t.begin(), t.end());
  return A;
}

Eigen::SparseMatrix<double> full_of(const Eigen::SparseMatrix<double>& lower) {
  Eigen::SparseMatrix<double> A = lower.selfadjointView<Eigen::Lower>();
  return A;
}

}  // namespace

TEST_CASE("cholmod: 3D Laplacian + identity solves to residual < 1e-10", "[cholmod]") {
  auto A = laplacian3d(12, 1.0, false);
  auto Afull = full_of(A);
  CholmodFactorization f(A);
  CHECK(f.factored());
  CHECK(f.rows() == 12 * 12 * 12);
  CHECK(f.supernodal());
  Eigen::VectorXd b = Eigen::VectorXd::Random(A.rows());
  Eigen::VectorXd x = f.solve(b);
  CHECK((Afull * x - b).norm() / b.norm() < 1e-10);

  SECTION("full storage gives the same answer as lower storage") {
    CholmodFactorization g(Afull);
    Eigen::VectorXd y = g.solve(b);
    CHECK((x - y).cwiseAbs().maxCoeff() < 1e-12);
  }
}

TEST_CASE("cholmod: multi-column == per-column == parallel, and counts", "[cholmod]") {
  auto A = laplacian3d(10, 0.5, false);
  auto Afull = full_of(A);
  CholmodFactorization f;
  f.analyse(A);
  CHECK_FALSE(f.factored());
  CHECK(f.stats().analyses == 1);
  CHECK(f.stats().factorizations == 0);
  f.factor(A);
  Eigen::MatrixXd B = Eigen::MatrixXd::Random(A.rows(), 4);
  Eigen::MatrixXd Xm = f.solve(B, SolveMode::MultiColumn);
  Eigen::MatrixXd Xp = f.solve(B, SolveMode::Parallel);
  Eigen::MatrixXd Xc(A.rows(), 4);
  for (int c = 0; c < 4; ++c) Xc.col(c) = f.solve(Eigen::VectorXd(B.col(c)));
  CHECK((Afull * Xm - B).norm() / B.norm() < 1e-10);
  CHECK((Xm - Xc).cwiseAbs().maxCoeff() < 1e-13);
  CHECK((Xm - Xp).cwiseAbs().maxCoeff() < 1e-13);

  // Refactor with new values on the same pattern: no new analysis.
  Eigen::SparseMatrix<double> A2 = A;
  A2.diagonal().array() += 2.0;
  f.factor(A2);
  Eigen::MatrixXd X2 = f.solve(B, SolveMode::Parallel);
  CHECK((full_of(A2) * X2 - B).norm() / B.norm() < 1e-10);

  // A second factorization sharing the analysis solves a different matrix of the same pattern.
  CholmodFactorization g = f.share_analysis();
  g.factor(A);
  CHECK(g.stats().analyses == 0);
  CHECK(g.stats().factorizations == 1);
  CHECK((g.solve(B) - Xm).cwiseAbs().maxCoeff() < 1e-12);
  CHECK_SOLVER_ERROR(CholmodFactorization().share_analysis(), Catch::Contains("no analysis to share"));

  const auto& s = f.stats();
  CHECK(s.analyses == 1);
  CHECK(s.factorizations == 2);
  CHECK(s.solves == 4 + 4 + 4 + 4);
  CHECK(s.solve_calls == 1 + 1 + 4 + 1);
  CHECK(s.factor_seconds > 0);
  CHECK(s.solve_seconds > 0);

  nlohmann::json m = {{"factorizations", 1}, {"solves", 3}};
  s.merge_into(m);
  CHECK(m["factorizations"].get<int>() == 3);
  CHECK(m["solves"].get<int>() == 19);
  CHECK(m["analyses"].get<int>() == 1);
  CHECK(m["factor_seconds"].get<double>() == Approx(s.factor_seconds));
}

TEST_CASE("cholmod: failures throw SolverError with a clear message", "[cholmod]") {
  SECTION("indefinite matrix") {
    auto A = laplacian3d(5, 1.0, false);
    A.coeffRef(30, 30) = -4.0;
    CholmodFactorization f;
    CHECK_SOLVER_ERROR(f.factor(A), Catch::Contains("not positive definite"));
    CHECK_FALSE(f.factored());
    CHECK(f.stats().factorizations == 0);
    CHECK_SOLVER_ERROR(f.solve(Eigen::VectorXd(Eigen::VectorXd::Ones(125))), Catch::Contains("no valid factorization"));
  }
  SECTION("singular Laplacian (no shift)") {
    auto A = laplacian3d(4, 0.0, false);
    CHECK_THROWS_AS(CholmodFactorization(A), SolverError);
  }
  SECTION("wrong right-hand-side size") {
    CholmodFactorization f(laplacian3d(3, 1.0, false));
    CHECK_SOLVER_ERROR(f.solve(Eigen::VectorXd(Eigen::VectorXd::Ones(5))),
                       Catch::Equals("Cholesky solve: right-hand side has 5 rows, matrix has 27"));
  }
  SECTION("non-finite right-hand side") {
    CholmodFactorization f(laplacian3d(3, 1.0, false));
    Eigen::VectorXd b = Eigen::VectorXd::Ones(27);
    b[4] = std::nan("");
    CHECK_SOLVER_ERROR(f.solve(b), Catch::Contains("entry 4"));
  }
  SECTION("non-square, upper-only, changed pattern") {
    Eigen::SparseMatrix<double> R(3, 4);
    CholmodFactorization f;
    CHECK_SOLVER_ERROR(f.analyse(R), Catch::Equals("Cholesky analysis: matrix is 3 by 4, not square"));
    Eigen::SparseMatrix<double> U =
        Eigen::SparseMatrix<double>(full_of(laplacian3d(3, 1.0, false)).triangularView<Eigen::Upper>());
    CHECK_SOLVER_ERROR(f.analyse(U), Catch::Contains("only its upper triangle"));
    f.analyse(laplacian3d(3, 1.0, false));
    CHECK_SOLVER_ERROR(f.factor(laplacian3d(3, 1.0, true)), Catch::Contains("pattern differs"));
  }
}

TEST_CASE("cholmod: analyses side by side order as analyses one at a time", "[cholmod]") {
  // METIS's orderings depend on its random draws: were the threads' draws interleaved, some solutions would
  // differ from the one-at-a-time ones in their last bits (they did with glibc's shared rand()).
  REQUIRE(polyhex::analyses_run_concurrently());
  constexpr int kMatrices = 4;
  std::vector<Eigen::SparseMatrix<double>> A;
  std::vector<Eigen::VectorXd> b, alone(kMatrices);
  for (int i = 0; i < kMatrices; ++i) {
    A.push_back(laplacian3d(16 + i, 0.1 * (i + 1), false));
    b.push_back(Eigen::VectorXd::LinSpaced(A.back().rows(), -1.0, 1.0 + i));
  }
  for (int i = 0; i < kMatrices; ++i) alone[size_t(i)] = CholmodFactorization(A[size_t(i)]).solve(b[size_t(i)]);
  for (int round = 0; round < 5; ++round) {
    std::vector<Eigen::VectorXd> together(kMatrices);
    std::vector<std::thread> threads;
    for (int i = 0; i < kMatrices; ++i)
      threads.emplace_back([&, i] { together[size_t(i)] = CholmodFactorization(A[size_t(i)]).solve(b[size_t(i)]); });
    for (std::thread& t : threads) t.join();
    for (int i = 0; i < kMatrices; ++i) CHECK((together[size_t(i)].array() == alone[size_t(i)].array()).all());
  }
}
