// Helpers of the mesh I/O tests: temporary folders, fixture paths, independent mesh checks.
#pragma once

#include "nodes/artefacts/meshes.h"
#include "tests/helpers/cli.h"

#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <utility>

namespace polyhex::iotest {

inline std::filesystem::path fixture(const std::string& name) {
  return std::filesystem::path(POLYHEX_SOURCE_DIR) / "tests" / "fixtures" / "io" / name;
}

/// A fresh folder under the system temp dir (polyhex_io_test_PID_N), removed with its content at the end
/// of the scope: the shared one of tests/helpers/cli.h.
struct TempDir : polyhex::test::TempDir {
  TempDir() : polyhex::test::TempDir("io_test") {}
};

/// Writes `content` verbatim (binary) and returns the path.
inline std::filesystem::path write_text(const std::filesystem::path& p, const std::string& content) {
  std::ofstream out(p, std::ios::binary);
  out << content;
  return p;
}

/// Signed volume enclosed by a triangle surface.
inline double signed_volume(const SurfaceMesh& m) {
  double v = 0;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    Eigen::Vector3d a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
    v += a.dot(b.cross(c)) / 6.0;
  }
  return v;
}

/// Number of directed edges used more than once (0 for a consistently oriented closed surface) and
/// number of directed edges whose reverse is missing (0 for a closed one).
inline std::pair<int, int> orientation_defects(const SurfaceMesh& m) {
  std::map<std::pair<int, int>, int> count;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) ++count[{m.F(f, k), m.F(f, (k + 1) % 3)}];
  int repeated = 0, unmatched = 0;
  for (auto& [e, n] : count) {
    repeated += n > 1;
    unmatched += count.count({e.second, e.first}) == 0;
  }
  return {repeated, unmatched};
}

inline double tet_volume(const RowMatrixX3d& V, const Eigen::RowVector4i& t) {
  Eigen::Vector3d a = V.row(t[0]), b = V.row(t[1]), c = V.row(t[2]), d = V.row(t[3]);
  return (b - a).cross(c - a).dot(d - a) / 6.0;
}

/// The 5 vertices and 2 positive tets of the two-tet fixtures (total volume 1/2).
inline TetMesh two_tets() {
  TetMesh m;
  m.V.resize(5, 3);
  m.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1;
  m.T.resize(2, 4);
  m.T << 0, 1, 2, 3, 1, 2, 3, 4;
  return m;
}

/// An n x n x n grid of unit-spaced hexes (VTK order), with a slight shear so coordinates are not
/// all integers.
inline HexMesh hex_grid(int n) {
  HexMesh m;
  const int s = n + 1;
  m.V.resize(s * s * s, 3);
  for (int k = 0; k < s; ++k)
    for (int j = 0; j < s; ++j)
      for (int i = 0; i < s; ++i) m.V.row((k * s + j) * s + i) << i + 0.1 * k / 3.0, j * 1.0, k * 0.7;
  m.H.resize(n * n * n, 8);
  int h = 0;
  auto id = [s](int i, int j, int k) { return (k * s + j) * s + i; };
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        m.H.row(h++) << id(i, j, k), id(i + 1, j, k), id(i + 1, j + 1, k), id(i, j + 1, k), id(i, j, k + 1),
            id(i + 1, j, k + 1), id(i + 1, j + 1, k + 1), id(i, j + 1, k + 1);
  return m;
}

/// hex_grid(n) with boundary groups: `boundary` (every boundary face) and `side_<f>` (family "side", id f)
/// for local face f = 0..5 of hex_topology::kFaces, which for this grid's vertex order is one side of it:
/// 0 z = min, 1 z = max, 2 y = min, 3 x = max, 4 y = max, 5 x = min. All six local faces are used.
inline HexMesh hex_grid_with_side_groups(int n) {
  HexMesh m = hex_grid(n);
  m.source = "grid";
  BoundaryGroup all{"boundary", "boundary", 0, {}};
  std::vector<BoundaryGroup> side(6);
  for (int f = 0; f < 6; ++f) side[size_t(f)] = {"side_" + std::to_string(f), "side", f, {}};
  for (int h = 0; h < n * n * n; ++h) {
    const int i = h % n, j = (h / n) % n, k = h / (n * n);
    const bool on[6] = {k == 0, k == n - 1, j == 0, i == n - 1, j == n - 1, i == 0};
    for (int f = 0; f < 6; ++f)
      if (on[f]) {
        all.faces.push_back({h, f});
        side[size_t(f)].faces.push_back({h, f});
      }
  }
  m.groups.push_back(all);
  for (auto& g : side) m.groups.push_back(g);
  return m;
}

/// The hex grid split into 6 positive tets per hex (Kuhn subdivision along the 0-6 diagonal).
inline TetMesh tet_grid(int n) {
  HexMesh h = hex_grid(n);
  TetMesh t;
  t.V = h.V;
  t.T.resize(6 * h.H.rows(), 4);
  static const int kuhn[6][4] = {{0, 1, 2, 6}, {0, 2, 3, 6}, {0, 3, 7, 6}, {0, 7, 4, 6}, {0, 4, 5, 6}, {0, 5, 1, 6}};
  for (Eigen::Index e = 0; e < h.H.rows(); ++e)
    for (int q = 0; q < 6; ++q)
      for (int k = 0; k < 4; ++k) t.T(6 * e + q, k) = h.H(e, kuhn[q][k]);
  return t;
}

}  // namespace polyhex::iotest
