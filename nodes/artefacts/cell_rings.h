/// @file cell_rings.h
/// @brief Vertex regions of a cell mesh (tets or hexes, one row of vertex indices per cell) grown by rings of
/// cells, and the cells at each vertex of a region: the free vertices of the untangling steps
/// (nodes/optimize/untangle_global.cpp for hexes, nodes/position_deform/untangle_map.cpp for the PolyCube map's tets).
#pragma once

#include <Eigen/Core>

#include <array>
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
/// start[i + 1]) for free vertex i. A descent assembles a free vertex's gradient from its cells' per-corner
/// gradients: each cell writes the row of each free corner to that pair's slot of a Rows (one 3-vector
/// per pair, `slots` says where), and sum() adds a vertex's rows in pair order, streaming through memory
/// instead of reading each cell's gradient at random.
struct CellIncidence {
  using Rows = std::vector<std::array<double, 3>>;

  std::vector<int> start;                    ///< #free + 1
  std::vector<std::pair<int, int>> corners;  ///< (index into `active`, corner k)

  /// Per active cell and corner k < K: the index of its pair in `corners`, or -1 (the corner's vertex is
  /// not free).
  template <int K>
  std::vector<std::array<int, K>> slots(size_t active_cells) const {
    std::array<int, K> none;
    none.fill(-1);
    std::vector<std::array<int, K>> r(active_cells, none);
    for (size_t c = 0; c < corners.size(); ++c) r[size_t(corners[c].first)][size_t(corners[c].second)] = int(c);
    return r;
  }

  /// Σ rows[c] over free vertex i's pairs, in their order, from zero.
  Eigen::Vector3d sum(size_t i, const Rows& rows) const {
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    for (int c = start[i]; c < start[i + 1]; ++c)
      for (int j = 0; j < 3; ++j) g[j] += rows[size_t(c)][size_t(j)];
    return g;
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
