// Generated tet meshes with known PolyCube structures, for the [segment] tests.
#pragma once

#include "nodes/artefacts/meshes.h"
#include "nodes/artefacts/polycube.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <functional>
#include <set>
#include <vector>

namespace polyhex::test {

using Point = Eigen::Vector3d;
using PointMap = std::function<Point(const Point&)>;

/// Flips tets with negative volume and drops unused vertices.
inline TetMesh finish_tets(const std::vector<Point>& pts, std::vector<std::array<int, 4>> tets,
                           const std::string& name) {
  std::vector<int> remap(pts.size(), -1);
  int n = 0;
  for (auto& t : tets) {
    const Point &a = pts[t[0]], &b = pts[t[1]], &c = pts[t[2]], &d = pts[t[3]];
    if ((b - a).cross(c - a).dot(d - a) < 0) std::swap(t[2], t[3]);
    for (int v : t)
      if (remap[v] < 0) remap[v] = n++;
  }
  TetMesh m;
  m.source = name;
  m.V.resize(n, 3);
  for (size_t v = 0; v < pts.size(); ++v)
    if (remap[v] >= 0) m.V.row(remap[v]) = pts[v].transpose();
  m.T.resize(tets.size(), 4);
  for (size_t i = 0; i < tets.size(); ++i)
    for (int k = 0; k < 4; ++k) m.T(i, k) = remap[tets[i][k]];
  return m;
}

/// Voxel cells (i,j,k) in [0,n)^3 with keep(i,j,k), each split into 6 tets (Freudenthal, conforming);
/// vertex (i,j,k) sits at map(cell_size * (i,j,k)).
inline TetMesh voxel_tets(std::array<int, 3> n, double cell_size, const std::function<bool(int, int, int)>& keep,
                          const PointMap& map = {}, const std::string& name = "voxels") {
  auto id = [&](int i, int j, int k) { return (i * (n[1] + 1) + j) * (n[2] + 1) + k; };
  std::vector<Point> pts((n[0] + 1) * (n[1] + 1) * (n[2] + 1));
  for (int i = 0; i <= n[0]; ++i)
    for (int j = 0; j <= n[1]; ++j)
      for (int k = 0; k <= n[2]; ++k) {
        Point p = cell_size * Point(i, j, k);
        pts[id(i, j, k)] = map ? map(p) : p;
      }
  std::vector<std::array<int, 4>> tets;
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int i = 0; i < n[0]; ++i)
    for (int j = 0; j < n[1]; ++j)
      for (int k = 0; k < n[2]; ++k) {
        if (!keep(i, j, k)) continue;
        for (auto& pm : perms) {
          std::array<int, 3> c = {i, j, k};
          std::array<int, 4> t;
          t[0] = id(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[pm[s]];
            t[s + 1] = id(c[0], c[1], c[2]);
          }
          tets.push_back(t);
        }
      }
  return finish_tets(pts, tets, name);
}

/// A box of cells^3 voxels per unit, size (sx, sy, sz) in units.
inline TetMesh box_tets(int sx, int sy, int sz, int cells, const PointMap& map = {}) {
  return voxel_tets(
      {sx * cells, sy * cells, sz * cells}, 1.0 / cells, [](int, int, int) { return true; }, map, "box");
}

/// A triangle P0 P1 P2 in the (x, z) plane, split into n^2 triangles, extruded along y over [0, width]
/// in `layers` layers; each prism split into 3 tets by the vertex-order rule (conforming).
inline TetMesh extruded_triangle_tets(const Eigen::Vector2d& P0, const Eigen::Vector2d& P1, const Eigen::Vector2d& P2,
                                      int n, double width, int layers) {
  std::vector<Eigen::Vector2d> q;
  std::vector<std::vector<int>> idx(n + 1);
  for (int i = 0; i <= n; ++i)
    for (int j = 0; i + j <= n; ++j) {
      idx[i].push_back(int(q.size()));
      q.push_back(P0 + (P1 - P0) * double(i) / n + (P2 - P0) * double(j) / n);
    }
  std::vector<std::array<int, 3>> tri;
  for (int i = 0; i < n; ++i)
    for (int j = 0; i + j < n; ++j) {
      tri.push_back({idx[i][j], idx[i + 1][j], idx[i][j + 1]});
      if (i + j + 1 < n) tri.push_back({idx[i + 1][j], idx[i + 1][j + 1], idx[i][j + 1]});
    }
  const int nq = int(q.size());
  std::vector<Point> pts;
  for (int l = 0; l <= layers; ++l)
    for (auto& p : q) pts.push_back(Point(p[0], width * l / layers, p[1]));
  std::vector<std::array<int, 4>> tets;
  for (int l = 0; l < layers; ++l)
    for (auto t : tri) {
      std::sort(t.begin(), t.end());
      int a = t[0] + l * nq, b = t[1] + l * nq, c = t[2] + l * nq;
      int A = a + nq, B = b + nq, C = c + nq;
      tets.push_back({a, b, c, A});
      tets.push_back({b, c, A, B});
      tets.push_back({c, A, B, C});
    }
  return finish_tets(pts, tets, "extruded_triangle");
}

inline TetMesh transformed(TetMesh m, const Eigen::Matrix3d& R) {
  for (int v = 0; v < m.V.rows(); ++v) m.V.row(v) = (R * m.V.row(v).transpose()).transpose();
  return m;
}

/// Span (2nd to 98th percentile) of chart c's vertices along its own axis, in the positions of m (the
/// mesh the segmentation was made on): what polycube_segment's ramp rule measures.
inline double chart_span(const TetMesh& m, const PolyCubeSegmentation& s, int c) {
  std::set<int> vs;
  for (int t = 0; t < s.F.rows(); ++t)
    if (s.chart[t] == c)
      for (int k = 0; k < 3; ++k) vs.insert(s.F(t, k));
  std::vector<double> x;
  for (int v : vs) x.push_back(m.V(v, label_axis(s.charts[size_t(c)].label)));
  std::sort(x.begin(), x.end());
  const size_t lo = size_t(0.02 * double(x.size()));
  return x[x.size() - 1 - lo] - x[lo];
}

}  // namespace polyhex::test
