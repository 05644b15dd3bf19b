/// @file cell_rings.h
/// @brief Vertex regions of a cell mesh (tets or hexes, one row of vertex indices per cell) grown by rings of
/// cells, and the cells at each vertex of a region: the free vertices of the untangling steps
/// (nodes/optimize/untangle_global.cpp for hexes, nodes/position_deform/untangle_map.cpp for the PolyCube map's tets).
#pragma once

#include <Eigen/Core>

#include <utility>
#include <vector>

namespace polyhex {

/// The vertices of the cells with `seed(c)` true, grown by `rings` rings: a cell with a vertex in the region
/// adds all its vertices, `rings` times.
/// \param C   #C by k vertex indices, each in [0, nv)
/// \return    nv flags
template <class Cells, class Seed>
std::vector<char> cell_ring_region(const Eigen::MatrixBase<Cells>& C, Eigen::Index nv, int rings, Seed&& seed) {
  std::vector<char> region(size_t(nv), 0);
  for (Eigen::Index c = 0; c < C.rows(); ++c)
    if (seed(c))
      for (Eigen::Index k = 0; k < C.cols(); ++k) region[size_t(C(c, k))] = 1;
  for (int r = 0; r < rings; ++r) {
    std::vector<char> grown = region;
    for (Eigen::Index c = 0; c < C.rows(); ++c) {
      bool touch = false;
      for (Eigen::Index k = 0; k < C.cols() && !touch; ++k) touch = region[size_t(C(c, k))];
      if (touch)
        for (Eigen::Index k = 0; k < C.cols(); ++k) grown[size_t(C(c, k))] = 1;
    }
    region.swap(grown);
  }
  return region;
}

/// Per free vertex, the (active cell, corner) pairs that use it, in active-cell order: corners[start[i] ..
/// start[i + 1]) for free vertex i.
struct CellIncidence {
  std::vector<int> start;                    ///< #free + 1
  std::vector<std::pair<int, int>> corners;  ///< (index into `active`, corner k)

  /// Σ cell_grad[a].row(k) over the (a, k) pairs of free vertex i: the vertex's gradient assembled from
  /// its cells' per-corner gradients (one k-by-3 matrix per active cell).
  template <class Grads>
  Eigen::Vector3d gather(size_t i, const Grads& cell_grad) const {
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    for (int c = start[i]; c < start[i + 1]; ++c)
      g += cell_grad[size_t(corners[size_t(c)].first)].row(corners[size_t(c)].second).transpose();
    return g;
  }

  /// Asks the cache for the rows gather(i, cell_grad) will read (a hint: no value changes).
  template <class Grads>
  void prefetch(size_t i, const Grads& cell_grad) const {
    for (int c = start[i]; c < start[i + 1]; ++c) {
      const auto& m = cell_grad[size_t(corners[size_t(c)].first)];
      const int k = corners[size_t(c)].second;
      __builtin_prefetch(&m(k, 0));
      __builtin_prefetch(&m(k, m.cols() - 1));
    }
  }
};

/// \param C       #C by k vertex indices
/// \param active  the cells that count, by index into C
/// \param slot    per vertex: its index among the free vertices, or -1
/// \param nfree   the number of free vertices
template <class Cells>
CellIncidence cell_incidence(const Eigen::MatrixBase<Cells>& C, const std::vector<int>& active,
                             const std::vector<int>& slot, size_t nfree) {
  std::vector<std::vector<std::pair<int, int>>> inc(nfree);
  for (size_t a = 0; a < active.size(); ++a)
    for (Eigen::Index k = 0; k < C.cols(); ++k) {
      const int s = slot[size_t(C(active[a], k))];
      if (s >= 0) inc[size_t(s)].push_back({int(a), int(k)});
    }
  CellIncidence r;
  r.start.assign(nfree + 1, 0);
  for (size_t i = 0; i < nfree; ++i) {
    r.start[i + 1] = r.start[i] + int(inc[i].size());
    r.corners.insert(r.corners.end(), inc[i].begin(), inc[i].end());
  }
  return r;
}

}  // namespace polyhex
