/// @file hex_fixtures.h
/// @brief Generated meshes for the quality and split tests: hex grids, structured tet boxes,
/// perturbations.
#pragma once

#include "nodes/algorithms/hex_quality.h"
#include "nodes/artefacts/meshes.h"

#include <Eigen/Geometry>

#include <random>
#include <string>

namespace polyhex::test {

/// nx by ny by nz cubes of side h with the lower corner at the origin, VTK_HEXAHEDRON order.
inline HexMesh grid_hex_mesh(int nx, int ny, int nz, double h = 1.0) {
  HexMesh m;
  auto id = [&](int i, int j, int k) { return i + (nx + 1) * (j + (ny + 1) * k); };
  m.V.resize((nx + 1) * (ny + 1) * (nz + 1), 3);
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) m.V.row(id(i, j, k)) << i * h, j * h, k * h;
  m.H.resize(nx * ny * nz, 8);
  int r = 0;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        m.H.row(r++) << id(i, j, k), id(i + 1, j, k), id(i + 1, j + 1, k), id(i, j + 1, k), id(i, j, k + 1),
            id(i + 1, j, k + 1), id(i + 1, j + 1, k + 1), id(i, j + 1, k + 1);
  m.source = "grid";
  return m;
}

/// The single hex with the given corners (VTK_HEXAHEDRON order).
inline HexMesh one_hex(const RowMatrixX3d& corners8) {
  HexMesh m;
  m.V = corners8;
  m.H.resize(1, 8);
  m.H << 0, 1, 2, 3, 4, 5, 6, 7;
  return m;
}

inline HexMesh unit_cube_hex() { return grid_hex_mesh(1, 1, 1); }

/// nx by ny by nz cubes of side h, each cut into 6 tets around its main diagonal (Kuhn split, conforming),
/// every tet positively oriented.
inline TetMesh box_tet_mesh(int nx, int ny, int nz, double h = 1.0) {
  const HexMesh g = grid_hex_mesh(nx, ny, nz, h);
  TetMesh t;
  t.V = g.V;
  t.T.resize(6 * g.H.rows(), 4);
  // Cube corner with offset bits (x, y, z) -> position in the VTK hex row.
  const int vtk_of_bits[8] = {0, 1, 3, 2, 4, 5, 7, 6};
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  int r = 0;
  for (Eigen::Index h8 = 0; h8 < g.H.rows(); ++h8)
    for (const auto& p : perms) {
      int bits = 0, tet[4];
      tet[0] = g.H(h8, vtk_of_bits[0]);
      for (int s = 0; s < 3; ++s) {
        bits |= 1 << p[s];
        tet[s + 1] = g.H(h8, vtk_of_bits[bits]);
      }
      const Eigen::Vector3d a = t.V.row(tet[0]), b = t.V.row(tet[1]), c = t.V.row(tet[2]), d = t.V.row(tet[3]);
      if ((b - a).cross(c - a).dot(d - a) < 0) std::swap(tet[2], tet[3]);
      t.T.row(r++) << tet[0], tet[1], tet[2], tet[3];
    }
  t.source = "box";
  return t;
}

/// Moves every vertex by a uniform random offset in [-amplitude, amplitude]^3 (fixed seed).
inline void perturb(RowMatrixX3d& V, double amplitude, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-amplitude, amplitude);
  for (Eigen::Index i = 0; i < V.size(); ++i) V.data()[i] += u(rng);
}

/// The boundary of a hex mesh as a triangle surface (each boundary quad split 0-1-2 / 0-2-3).
inline SurfaceMesh boundary_surface(const HexMesh& m) {
  const auto Q = hex_boundary_quads(m);
  SurfaceMesh s;
  s.V = m.V;
  s.F.resize(2 * Q.rows(), 3);
  for (Eigen::Index i = 0; i < Q.rows(); ++i) {
    s.F.row(2 * i) << Q(i, 0), Q(i, 1), Q(i, 2);
    s.F.row(2 * i + 1) << Q(i, 0), Q(i, 2), Q(i, 3);
  }
  s.source = "boundary";
  return s;
}

}  // namespace polyhex::test
