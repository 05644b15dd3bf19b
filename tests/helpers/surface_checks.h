/// @file surface_checks.h
/// @brief Independent checks of closed triangle surfaces for the tests (own edge counting, no
/// trust in the generators): closedness, manifold edges and vertices, orientation, genus, volume.
#pragma once

#include "nodes/artefacts/meshes.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <set>
#include <utility>
#include <vector>

namespace polyhex::test {

struct SurfaceCheck {
  long open_edges = 0;            ///< undirected edges used by fewer than 2 triangles
  long nonmanifold_edges = 0;     ///< undirected edges used by more than 2 triangles
  long misoriented_edges = 0;     ///< directed edges used more than once (inconsistent orientation)
  long nonmanifold_vertices = 0;  ///< vertices whose triangle fan is not a single cycle
  long unused_vertices = 0;
  long degenerate = 0;         ///< triangles with area below 1e-12 diag^2 or a repeated index
  long components = 0;         ///< connected components (through shared vertices)
  long euler = 0;              ///< V - E + F
  double volume = 0;           ///< signed enclosed volume
  double min_angle_deg = 180;  ///< smallest triangle angle
  double diag = 0;             ///< bbox diagonal
  bool closed_manifold_oriented() const {
    return open_edges == 0 && nonmanifold_edges == 0 && misoriented_edges == 0 && nonmanifold_vertices == 0 &&
           unused_vertices == 0 && degenerate == 0;
  }
  long genus() const { return (2 * components - euler) / 2; }
};

inline SurfaceCheck check_surface(const RowMatrixX3d& V, const RowMatrixX3i& F) {
  SurfaceCheck c;
  const long nv = V.rows();
  c.diag = (V.colwise().maxCoeff() - V.colwise().minCoeff()).norm();
  std::map<std::pair<int, int>, int> directed;
  std::vector<std::vector<std::pair<int, int>>> link(nv);  // per vertex: opposite directed edges
  std::vector<int> parent(nv);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    int v[3] = {F(f, 0), F(f, 1), F(f, 2)};
    Eigen::Vector3d p[3];
    for (int k = 0; k < 3; ++k) p[k] = V.row(v[k]).transpose();
    double area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).norm();
    if (v[0] == v[1] || v[1] == v[2] || v[0] == v[2] || area < 1e-12 * c.diag * c.diag) ++c.degenerate;
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d e1 = p[(k + 1) % 3] - p[k], e2 = p[(k + 2) % 3] - p[k];
      double ang = std::atan2(e1.cross(e2).norm(), e1.dot(e2)) * 180 / M_PI;
      c.min_angle_deg = std::min(c.min_angle_deg, ang);
      ++directed[{v[k], v[(k + 1) % 3]}];
      link[v[k]].push_back({v[(k + 1) % 3], v[(k + 2) % 3]});
      parent[find(v[k])] = find(v[(k + 1) % 3]);
    }
    c.volume += p[0].dot(p[1].cross(p[2])) / 6.0;
  }
  std::map<std::pair<int, int>, int> undirected;
  for (auto& [e, n] : directed) {
    if (n > 1) ++c.misoriented_edges;
    undirected[{std::min(e.first, e.second), std::max(e.first, e.second)}] += n;
  }
  for (auto& [e, n] : undirected) {
    if (n < 2) ++c.open_edges;
    if (n > 2) ++c.nonmanifold_edges;
  }
  std::set<int> roots;
  for (long v = 0; v < nv; ++v) {
    if (link[v].empty()) {
      ++c.unused_vertices;
      continue;
    }
    roots.insert(find(static_cast<int>(v)));
    // The fan is one cycle when following next[] from any link vertex visits every link edge.
    std::map<int, int> next;
    bool ok = true;
    for (auto& [a, b] : link[v]) ok = ok && next.emplace(a, b).second;
    if (ok) {
      size_t steps = 0;
      int start = link[v][0].first, x = start;
      do {
        auto it = next.find(x);
        if (it == next.end()) {
          ok = false;
          break;
        }
        x = it->second;
        ++steps;
      } while (x != start && steps <= link[v].size());
      ok = ok && x == start && steps == link[v].size();
    }
    if (!ok) ++c.nonmanifold_vertices;
  }
  c.components = static_cast<long>(roots.size());
  c.euler = (nv - c.unused_vertices) - static_cast<long>(undirected.size()) + F.rows();
  return c;
}

inline SurfaceCheck check_surface(const SurfaceMesh& m) { return check_surface(m.V, m.F); }

/// A box [0,a]x[0,b]x[0,c] made of 12 outward triangles.
inline SurfaceMesh box12(double a, double b, double c, const std::string& source = "box12") {
  SurfaceMesh m;
  m.source = source;
  m.V.resize(8, 3);
  for (int i = 0; i < 8; ++i) m.V.row(i) << (i & 1 ? a : 0), (i & 2 ? b : 0), (i & 4 ? c : 0);
  m.F.resize(12, 3);
  m.F << 0, 2, 1, 1, 2, 3,  // z = 0, normal -z
      4, 5, 6, 5, 7, 6,     // z = c
      0, 1, 4, 1, 5, 4,     // y = 0
      2, 6, 3, 3, 6, 7,     // y = b
      0, 4, 2, 2, 4, 6,     // x = 0
      1, 3, 5, 3, 7, 5;     // x = a
  return m;
}

/// A closed cylinder of radius r and height z with n side segments (a prism, its side faces 2 r sin(pi / n) wide);
/// caps are fans around a centre vertex.
inline SurfaceMesh fan_cylinder(int n, double r = 1, double z = 2) {
  SurfaceMesh s;
  s.source = "cylinder";
  s.V.resize(2 * n + 2, 3);
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    s.V.row(i) << r * std::cos(a), r * std::sin(a), 0;
    s.V.row(n + i) << r * std::cos(a), r * std::sin(a), z;
  }
  s.V.row(2 * n) << 0, 0, 0;
  s.V.row(2 * n + 1) << 0, 0, z;
  s.F.resize(4 * n, 3);
  for (int i = 0; i < n; ++i) {
    const int j = (i + 1) % n;
    s.F.row(4 * i) << i, j, n + j;
    s.F.row(4 * i + 1) << i, n + j, n + i;
    s.F.row(4 * i + 2) << 2 * n, j, i;
    s.F.row(4 * i + 3) << 2 * n + 1, n + i, n + j;
  }
  return s;
}

}  // namespace polyhex::test
