/// @file cell_rings.h
/// @brief Vertex regions of a cell mesh (tets or hexes, one row of vertex indices per cell) grown by rings of
/// cells: the free vertices of the untangling steps (nodes/optimize/untangle_global.cpp for hexes,
/// nodes/position_deform/untangle_map.cpp for the PolyCube map's tets).
#pragma once

#include <Eigen/Core>

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

}  // namespace polyhex
