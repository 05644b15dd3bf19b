/// @file incomplete_lut.h
/// @brief Eigen's incomplete LU with dual thresholding (Saad's ILUT), factored in less time, the factor
/// bit for bit the same.
///
/// Eigen::IncompleteLUT eliminates the lower part of each row in increasing column order and finds the next
/// column by a linear scan of the row's remaining entries, which fill-in makes long: quadratic per row. It
/// also finds a previous row's diagonal by walking its lower part. On the PolyCube map's mean value systems
/// (200k unknowns) those two walks were 60 % of the factorization (perf annotate). Here the next column
/// comes from a min-heap beside the same work arrays, swapped exactly as Eigen swaps them (so the rows keep
/// the order that decides which of equal magnitudes the partial sort keeps), and each row's diagonal
/// position is stored. Every arithmetic operation is Eigen's, in Eigen's order: the factor, and so every
/// solve, is identical (tests/nodes/algorithms/test_incomplete_lut.cpp compares them).
///
/// A drop-in preconditioner for Eigen's iterative solvers: Eigen::BiCGSTAB<A, FastIncompleteLUT>. The fill
/// -reducing ordering and the triangular solves are Eigen's own (inherited).
#pragma once

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCore>

#include <algorithm>
#include <cmath>
#include <functional>
#include <utility>
#include <vector>

namespace polyhex {

class FastIncompleteLUT : public Eigen::IncompleteLUT<double, int> {
 public:
  FastIncompleteLUT() = default;

  /// Ordering (Eigen's) then the factorization below; info() tells whether it succeeded.
  /// \pre amat is square
  template <typename MatrixType>
  FastIncompleteLUT& compute(const MatrixType& amat) {
    analyzePattern(amat);
    factorize(amat);
    return *this;
  }

  /// The factor of Eigen::IncompleteLUT::factorize (same drop tolerance, fill factor and pivot shift).
  /// \pre analyzePattern(amat) was called; amat is square
  template <typename MatrixType>
  void factorize(const MatrixType& amat);

  /// The factor, L (unit, below the diagonal) and U in one row-major matrix, each row's entries in the
  /// order they were kept (for the tests' comparison with Eigen's).
  const Eigen::SparseMatrix<double, Eigen::RowMajor, int>& factor() const { return m_lu; }
};

template <typename MatrixType>
void FastIncompleteLUT::factorize(const MatrixType& amat) {
  using Eigen::Index;
  const Index n = amat.cols();
  m_lu.resize(n, n);
  Eigen::SparseMatrix<double, Eigen::RowMajor, int> mat;
  mat = amat.twistedBy(m_Pinv);  // the fill-reducing permutation

  // The row being eliminated: values u, their columns ju, and jr = position of a column in u (-1: none).
  // The lower part sits at [0, sizel), the diagonal at ii, the upper part at [ii + 1, ii + sizeu).
  Eigen::VectorXd u = Eigen::VectorXd::Zero(n);
  Eigen::VectorXi ju = Eigen::VectorXi::Zero(n), jr = Eigen::VectorXi::Constant(n, -1);
  Index fill_in = (amat.nonZeros() * m_fillfactor) / n + 1;  // largest entries kept per row
  fill_in = std::min(fill_in, n);
  const Index nnzL = fill_in / 2, nnzU = nnzL;

  // The factor as it is built: per row its entries (L, then the diagonal, then U) and the diagonal's slot.
  std::vector<int> cols, row_start(size_t(n) + 1, 0), diag(size_t(n), 0);
  std::vector<double> vals;
  cols.reserve(size_t(n * (nnzL + nnzU + 1)));
  vals.reserve(cols.capacity());
  std::vector<int> heap;  // the lower part's columns not yet eliminated (a min-heap)

  for (Index ii = 0; ii < n; ++ii) {
    Index sizeu = 1, sizel = 0;
    ju(ii) = int(ii);
    u(ii) = 0;
    jr(ii) = int(ii);
    double rownorm = 0;
    for (typename decltype(mat)::InnerIterator it(mat, ii); it; ++it) {
      const Index k = it.index();
      Index pos;
      if (k < ii)
        pos = sizel++;
      else if (k == ii)
        pos = ii;
      else
        pos = ii + sizeu++;
      ju(pos) = int(k);
      u(pos) = it.value();
      if (k != ii) jr(k) = int(pos);
      rownorm += it.value() * it.value();
    }
    if (rownorm == 0) {
      m_info = Eigen::NumericalIssue;
      return;
    }
    rownorm = std::sqrt(rownorm);

    // Eliminate the previous rows, smallest column first.
    heap.assign(ju.data(), ju.data() + sizel);
    std::make_heap(heap.begin(), heap.end(), std::greater<int>());
    Index jj = 0, len = 0;
    while (jj < sizel) {
      std::pop_heap(heap.begin(), heap.end(), std::greater<int>());
      const int minrow = heap.back();
      heap.pop_back();
      const Index k = jr(minrow);
      if (k != jj) {  // bring it to jj, as Eigen's swap does
        const int j = ju(jj);
        std::swap(ju(jj), ju(k));
        jr(minrow) = int(jj);
        jr(j) = int(k);
        std::swap(u(jj), u(k));
      }
      jr(minrow) = -1;
      const size_t d = size_t(diag[size_t(minrow)]);
      const double fact = u(jj) / vals[d];
      if (std::abs(fact) <= m_droptol) {
        ++jj;
        continue;
      }
      for (size_t q = d + 1; q < size_t(row_start[size_t(minrow) + 1]); ++q) {
        const double prod = fact * vals[q];
        const int j = cols[q];
        const int jpos = jr(j);
        if (jpos == -1) {  // fill-in
          Index newpos;
          if (j >= ii) {
            newpos = ii + sizeu++;
          } else {
            newpos = sizel++;
            heap.push_back(j);
            std::push_heap(heap.begin(), heap.end(), std::greater<int>());
          }
          ju(newpos) = j;
          u(newpos) = -prod;
          jr(j) = int(newpos);
        } else {
          u(jpos) -= prod;
        }
      }
      u(len) = fact;  // the multiplier, stored in L
      ju(len) = minrow;
      ++len;
      ++jj;
    }
    for (Index k = 0; k < sizeu; ++k) jr(ju(ii + k)) = -1;

    // Keep the nnzL largest multipliers, the diagonal (shifted off zero) and the nnzU - 1 largest of U
    // above the drop tolerance, as Eigen does.
    sizel = len;
    len = std::min(sizel, nnzL);
    {
      auto ul = u.segment(0, sizel);
      auto jul = ju.segment(0, sizel);
      Eigen::internal::QuickSplit(ul, jul, len);
    }
    for (Index k = 0; k < len; ++k) cols.push_back(ju(k)), vals.push_back(u(k));
    if (u(ii) == 0) u(ii) = std::sqrt(m_droptol) * rownorm;
    diag[size_t(ii)] = int(cols.size());
    cols.push_back(int(ii));
    vals.push_back(u(ii));
    len = 0;
    for (Index k = 1; k < sizeu; ++k)
      if (std::abs(u(ii + k)) > m_droptol * rownorm) {
        ++len;
        u(ii + len) = u(ii + k);
        ju(ii + len) = ju(ii + k);
      }
    sizeu = len + 1;
    len = std::min(sizeu, nnzU);
    {
      auto uu = u.segment(ii + 1, sizeu - 1);
      auto juu = ju.segment(ii + 1, sizeu - 1);
      Eigen::internal::QuickSplit(uu, juu, len);
    }
    for (Index k = ii + 1; k < ii + len; ++k) cols.push_back(ju(k)), vals.push_back(u(k));
    row_start[size_t(ii) + 1] = int(cols.size());
  }

  m_lu.reserve(Index(cols.size()));
  for (Index ii = 0; ii < n; ++ii) {
    m_lu.startVec(ii);
    for (int q = row_start[size_t(ii)]; q < row_start[size_t(ii) + 1]; ++q)
      m_lu.insertBackByOuterInnerUnordered(ii, cols[size_t(q)]) = vals[size_t(q)];
  }
  m_lu.finalize();
  m_lu.makeCompressed();
  m_factorizationIsOk = true;
  m_info = Eigen::Success;
}

}  // namespace polyhex
