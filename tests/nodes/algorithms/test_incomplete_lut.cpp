// [incomplete-lut] the fast ILUT against Eigen's IncompleteLUT: the same factor, entry for entry and bit for
// bit, and so the same BiCGSTAB solution.
#include "nodes/algorithms/incomplete_lut.h"

#include <catch2/catch.hpp>

#include <cstring>
#include <random>
#include <vector>

using namespace polyhex;

namespace {

/// Eigen's own factorization, its factor made visible.
struct EigenIncompleteLUT : Eigen::IncompleteLUT<double, int> {
  const Eigen::SparseMatrix<double, Eigen::RowMajor, int>& factor() const { return m_lu; }
};

/// A mean-value-like system on an n^3 grid with its 26 neighbours: random positive weights, not symmetric,
/// the diagonal their sum, the grid's boundary rows moved to the right-hand side (an M-matrix as the map's).
Eigen::SparseMatrix<double, Eigen::RowMajor> grid_system(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> weight(0.05, 1.0);
  auto id = [n](int i, int j, int k) { return (i * n + j) * n + k; };
  std::vector<Eigen::Triplet<double>> t;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k) {
        double sum = 0;
        for (int di = -1; di <= 1; ++di)
          for (int dj = -1; dj <= 1; ++dj)
            for (int dk = -1; dk <= 1; ++dk) {
              if (di == 0 && dj == 0 && dk == 0) continue;
              const double w = weight(rng);
              sum += w;
              const int a = i + di, b = j + dj, c = k + dk;
              if (a >= 0 && a < n && b >= 0 && b < n && c >= 0 && c < n) t.emplace_back(id(i, j, k), id(a, b, c), -w);
            }
        t.emplace_back(id(i, j, k), id(i, j, k), sum);
      }
  Eigen::SparseMatrix<double, Eigen::RowMajor> A(n * n * n, n * n * n);
  A.setFromTriplets(t.begin(), t.end());
  A.makeCompressed();
  return A;
}

bool same_bits(const double* a, const double* b, Eigen::Index n) {
  return std::memcmp(a, b, size_t(n) * sizeof(double)) == 0;
}

}  // namespace

TEST_CASE("fast ILUT: Eigen's factor, entry for entry, at the map's settings and with heavy dropping",
          "[incomplete-lut]") {
  const Eigen::SparseMatrix<double, Eigen::RowMajor> A = grid_system(11, 7);
  struct Setting {
    double droptol;
    int fill;
  };
  for (const Setting s : {Setting{1e-4, 10}, Setting{1e-2, 2}, Setting{0.0, 40}}) {
    INFO("droptol " << s.droptol << ", fill factor " << s.fill);
    EigenIncompleteLUT eigen;
    FastIncompleteLUT fast;
    for (auto* p : {static_cast<Eigen::IncompleteLUT<double, int>*>(&eigen),
                    static_cast<Eigen::IncompleteLUT<double, int>*>(&fast)}) {
      p->setDroptol(s.droptol);
      p->setFillfactor(s.fill);
    }
    eigen.compute(A);
    fast.compute(A);
    REQUIRE(eigen.info() == Eigen::Success);
    REQUIRE(fast.info() == Eigen::Success);
    const auto& E = eigen.factor();
    const auto& F = fast.factor();
    REQUIRE(E.nonZeros() == F.nonZeros());
    CHECK(E.nonZeros() > 2 * A.nonZeros() / 3);  // fill-in was there to select from
    CHECK(std::equal(E.outerIndexPtr(), E.outerIndexPtr() + E.outerSize() + 1, F.outerIndexPtr()));
    CHECK(std::equal(E.innerIndexPtr(), E.innerIndexPtr() + E.nonZeros(), F.innerIndexPtr()));
    CHECK(same_bits(E.valuePtr(), F.valuePtr(), E.nonZeros()));
  }
}

TEST_CASE("fast ILUT: BiCGSTAB preconditioned by it gives Eigen's solution bit for bit", "[incomplete-lut]") {
  const Eigen::SparseMatrix<double, Eigen::RowMajor> A = grid_system(14, 11);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> value(-1, 1);
  Eigen::VectorXd b(A.rows());
  for (Eigen::Index i = 0; i < b.size(); ++i) b[i] = value(rng);
  Eigen::BiCGSTAB<Eigen::SparseMatrix<double, Eigen::RowMajor>, Eigen::IncompleteLUT<double>> eigen;
  Eigen::BiCGSTAB<Eigen::SparseMatrix<double, Eigen::RowMajor>, FastIncompleteLUT> fast;
  for (auto* s : {&eigen.preconditioner(), static_cast<Eigen::IncompleteLUT<double>*>(&fast.preconditioner())}) {
    s->setDroptol(1e-4);
    s->setFillfactor(10);
  }
  eigen.setTolerance(1e-12);
  fast.setTolerance(1e-12);
  eigen.compute(A);
  fast.compute(A);
  const Eigen::VectorXd xe = eigen.solve(b), xf = fast.solve(b);
  CHECK(eigen.iterations() == fast.iterations());
  CHECK((A * xf - b).norm() <= 1e-10 * b.norm());
  CHECK(same_bits(xe.data(), xf.data(), xe.size()));
}
