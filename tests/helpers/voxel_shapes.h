// Test fixtures: closed surfaces of unions of unit voxels (exactly axis-aligned PolyCubes with known
// charts), tet meshes of them, and the boundary-face checks shared by stage tests.
#pragma once

#include "nodes/artefacts/meshes.h"

#include <array>
#include <map>
#include <set>
#include <tuple>
#include <vector>

namespace polyhex::test {

/// Surface of a face-connected union of voxels [i,i+1]x[j,j+1]x[k,k+1] scaled by `scale`, two triangles per
/// exposed voxel face, outward oriented. Vertices are shared (the mesh is closed and manifold as long as
/// no two voxels touch only along an edge or at a corner).
inline SurfaceMesh voxel_surface(const std::vector<std::array<int, 3>>& voxels, double scale = 1.0) {
  std::set<std::array<int, 3>> occ(voxels.begin(), voxels.end());
  std::map<std::array<int, 3>, int> vid;
  std::vector<std::array<double, 3>> V;
  std::vector<std::array<int, 3>> F;
  auto vertex = [&](std::array<int, 3> p) {
    auto it = vid.find(p);
    if (it != vid.end()) return it->second;
    vid[p] = int(V.size());
    V.push_back({p[0] * scale, p[1] * scale, p[2] * scale});
    return int(V.size()) - 1;
  };
  for (auto& c : occ)
    for (int axis = 0; axis < 3; ++axis)
      for (int s = 0; s < 2; ++s) {
        std::array<int, 3> n = c;
        n[axis] += s ? 1 : -1;
        if (occ.count(n)) continue;
        int u = (axis + 1) % 3, w = (axis + 2) % 3;
        std::array<int, 3> q[4];
        for (int k = 0; k < 4; ++k) {
          q[k] = c;
          q[k][axis] += s;
          q[k][u] += (k == 1 || k == 2);
          q[k][w] += (k >= 2);
        }
        int a = vertex(q[0]), b = vertex(q[1]), cc = vertex(q[2]), d = vertex(q[3]);
        // (u, w, axis) is right-handed: CCW in the (u, w) plane faces +axis
        if (s)
          F.push_back({a, b, cc}), F.push_back({a, cc, d});
        else
          F.push_back({a, cc, b}), F.push_back({a, d, cc});
      }
  SurfaceMesh m;
  m.V.resize(Eigen::Index(V.size()), 3);
  for (size_t i = 0; i < V.size(); ++i) m.V.row(Eigen::Index(i)) << V[i][0], V[i][1], V[i][2];
  m.F.resize(Eigen::Index(F.size()), 3);
  for (size_t i = 0; i < F.size(); ++i) m.F.row(Eigen::Index(i)) << F[i][0], F[i][1], F[i][2];
  m.source = "voxels";
  return m;
}

inline std::vector<std::array<int, 3>> voxel_box(int nx, int ny, int nz) {
  std::vector<std::array<int, 3>> v;
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j)
      for (int k = 0; k < nz; ++k) v.push_back({i, j, k});
  return v;
}

}  // namespace polyhex::test
