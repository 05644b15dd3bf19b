/// @file segment_surface.cpp
/// @brief The segmentation's surface: connectivity, labels and charts, PolyCube edges and corners.
#include "nodes/algorithms/chart_order.h"
#include "nodes/algorithms/features.h"
#include "nodes/algorithms/reference_length.h"
#include "nodes/polycube_segment/segment_internal.h"
#include "runtime/cancel.h"
#include "runtime/errors.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <queue>
#include <set>
#include <sstream>
#include <tuple>

namespace polyhex::segment_detail {

Surface build_surface(const RowMatrixX3d& V, const RowMatrixX3i& F) {
  if (F.rows() == 0) throw InvalidInput("boundary surface is empty");
  Surface s;
  s.V = &V;
  s.F = &F;
  const int nf = int(F.rows()), nv = int(V.rows());
  struct Half {
    int a, b, t, k;
  };
  std::vector<Half> half;
  half.reserve(3 * size_t(nf));
  for (int t = 0; t < nf; ++t)
    for (int k = 0; k < 3; ++k) {
      int a = F(t, k), b = F(t, (k + 1) % 3);
      if (a < 0 || a >= nv || b < 0 || b >= nv)
        throw InvalidInput("triangle " + std::to_string(t) + " has a vertex index out of range (" + std::to_string(nv) +
                           " vertices)");
      half.push_back({std::min(a, b), std::max(a, b), t, k});
    }
  std::sort(half.begin(), half.end(), [](const Half& x, const Half& y) {
    return x.a != y.a ? x.a < y.a : x.b != y.b ? x.b < y.b : x.t < y.t;
  });
  s.tri_nbrs.assign(nf, {-1, -1, -1});
  s.vert_edges.assign(nv, {});
  for (size_t i = 0; i < half.size();) {
    size_t j = i;
    while (j < half.size() && half[j].a == half[i].a && half[j].b == half[i].b) ++j;
    if (j - i != 2)
      throw InvalidInput("boundary surface is not a closed 2-manifold: edge (" + std::to_string(half[i].a) + ", " +
                         std::to_string(half[i].b) + ") is used by " + std::to_string(j - i) + " triangle(s)");
    int e = int(s.edges.size());
    s.edges.push_back({{half[i].a, half[i].b}, {half[i].t, half[i + 1].t}});
    s.tri_nbrs[half[i].t][half[i].k] = half[i + 1].t;
    s.tri_nbrs[half[i + 1].t][half[i + 1].k] = half[i].t;
    s.vert_edges[half[i].a].push_back({half[i].b, e});
    s.vert_edges[half[i].b].push_back({half[i].a, e});
    i = j;
  }
  s.vert_tris.assign(nv, {});
  s.normal.resize(nf);
  s.area.resize(nf);
  for (int t = 0; t < nf; ++t) {
    Vec3 a = s.pos(F(t, 0)), b = s.pos(F(t, 1)), c = s.pos(F(t, 2));
    Vec3 n = (b - a).cross(c - a);
    s.area[t] = 0.5 * n.norm();
    s.normal[t] = s.area[t] > 0 ? Vec3(n.normalized()) : Vec3::Zero();
    s.total_area += s.area[t];
    for (int k = 0; k < 3; ++k) s.vert_tris[F(t, k)].push_back(t);
  }
  std::vector<int> used;  // the boundary's vertices
  for (int v = 0; v < nv; ++v)
    if (!s.vert_tris[size_t(v)].empty()) used.push_back(v);
  s.diag = reference_length(V(used, Eigen::all));
  double len = 0;
  for (auto& e : s.edges) len += (s.pos(e.v[0]) - s.pos(e.v[1])).norm();
  s.mean_edge = len / double(s.edges.size());
  return s;
}

std::vector<Vec3> smoothed_normals(const Surface& s, int iterations, const std::vector<std::array<char, 3>>* crease) {
  std::vector<Vec3> n = s.normal;
  for (int it = 0; it < iterations; ++it) {
    std::vector<Vec3> m(n.size());
    for (int t = 0; t < s.nf(); ++t) {
      m[t] = n[t];
      for (int k = 0; k < 3; ++k)
        if (!crease || !(*crease)[size_t(t)][size_t(k)]) m[t] += n[s.tri_nbrs[t][k]];
      if (m[t].norm() > 0) m[t].normalize();
    }
    n.swap(m);
  }
  return n;
}

InputCreases input_creases(const Surface& s, const RowMatrixX3d& X, double h) {
  SurfaceMesh surface;
  surface.V = X;
  surface.F = *s.F;
  const SurfaceCreases all = find_creases(surface, kFeatureAngle, 1.5 * h, 0.5 * h);
  CreaseFaces faces = crease_faces(surface, all);
  InputCreases c;
  c.patch.assign(faces.patch.data(), faces.patch.data() + faces.patch.size());
  c.patches = faces.faces;
  c.planar = std::move(faces.planar);
  c.normal.resize(size_t(s.nf()));
  for (int t = 0; t < s.nf(); ++t) {
    const Vec3 a = X.row((*s.F)(t, 0)), b = X.row((*s.F)(t, 1)), d = X.row((*s.F)(t, 2));
    const Vec3 n = (b - a).cross(d - a);
    c.normal[size_t(t)] = n.norm() > 0 ? Vec3(n.normalized()) : Vec3::Zero();
  }
  // a barrier to the normals' smoothing is a crease along a flat face, not a scan's faceting
  const std::vector<std::array<int, 2>> part = crease_edges(flat_face_creases(surface, all, h));
  const int nf = s.nf();
  c.edge.assign(size_t(nf), {0, 0, 0});
  c.vertex.assign(size_t(s.V->rows()), 0);
  for (int t = 0; t < nf; ++t)
    for (int k = 0; k < 3; ++k) {
      const int a = (*s.F)(t, k), b = (*s.F)(t, (k + 1) % 3);
      const bool crease =
          std::binary_search(part.begin(), part.end(), std::array<int, 2>{std::min(a, b), std::max(a, b)});
      c.edge[size_t(t)][size_t(k)] = crease;
      if (crease) c.vertex[size_t(a)] = c.vertex[size_t(b)] = 1;
    }
  return c;
}

void label_planar_patches(const Surface& s, const std::vector<Vec3>& normal, const InputCreases& c, State& st) {
  std::vector<Vec3> mean(size_t(c.patches), Vec3::Zero());
  for (int t = 0; t < s.nf(); ++t) mean[size_t(c.patch[size_t(t)])] += s.area[size_t(t)] * normal[size_t(t)];
  for (int t = 0; t < s.nf(); ++t) {
    const int q = c.patch[size_t(t)];
    if (c.planar[size_t(q)] && mean[size_t(q)].norm() > 0) st.label[size_t(t)] = closest_label(mean[size_t(q)]);
  }
}

int label_components(const Surface& s, const std::vector<int>& label, std::vector<int>& chart) {
  chart.assign(s.nf(), -1);
  int n = 0;
  std::vector<int> stack;
  for (int t0 = 0; t0 < s.nf(); ++t0) {
    if (chart[t0] >= 0) continue;
    chart[t0] = n;
    stack.assign(1, t0);
    while (!stack.empty()) {
      int t = stack.back();
      stack.pop_back();
      for (int u : s.tri_nbrs[t])
        if (chart[u] < 0 && label[u] == label[t]) {
          chart[u] = n;
          stack.push_back(u);
        }
    }
    ++n;
  }
  return n;
}

std::vector<std::vector<int>> chart_adjacency(const Surface& s, const std::vector<int>& chart, int n) {
  std::vector<std::vector<int>> adj(n);
  for (auto& e : s.edges) {
    int a = chart[e.t[0]], b = chart[e.t[1]];
    if (a == b) continue;
    adj[a].push_back(b);
    adj[b].push_back(a);
  }
  for (auto& a : adj) {
    std::sort(a.begin(), a.end());
    a.erase(std::unique(a.begin(), a.end()), a.end());
  }
  return adj;
}

void straighten(const Surface& s, std::vector<int>& label) {
  for (bool changed = true; changed;) {
    changed = false;
    for (int t = 0; t < s.nf(); ++t) {
      const auto& nb = s.tri_nbrs[t];
      int l0 = label[nb[0]], l1 = label[nb[1]], l2 = label[nb[2]];
      int common = (l0 == l1 || l0 == l2) ? l0 : (l1 == l2 ? l1 : -1);
      if (common >= 0 && common != label[t]) {
        label[t] = common;
        changed = true;
      }
    }
  }
}

void flood_fill(const Surface& s, const std::vector<Vec3>& normal, std::vector<int>& label) {
  using Item = std::tuple<double, int, int>;  // (fit, triangle, label)
  std::priority_queue<Item> q;
  auto offer = [&](int t) {
    for (int u : s.tri_nbrs[t])
      if (label[u] < 0) q.push({label_dir(label[t]).dot(normal[u]), u, label[t]});
  };
  for (int t = 0; t < s.nf(); ++t)
    if (label[t] >= 0) offer(t);
  while (!q.empty()) {
    auto [fit, t, l] = q.top();
    q.pop();
    if (label[t] >= 0) continue;
    label[t] = l;
    offer(t);
  }
  for (int t = 0; t < s.nf(); ++t)  // a whole component was removed: fall back to the normals
    if (label[t] < 0) label[t] = closest_label(normal[t]);
}

Structure analyse(const Surface& s, const std::vector<int>& label) {
  Structure st;
  st.n = label_components(s, label, st.chart);
  st.adj = chart_adjacency(s, st.chart, st.n);
  st.label.resize(st.n);
  for (int t = 0; t < s.nf(); ++t) st.label[st.chart[t]] = label[t];
  const int nv = int(s.V->rows());
  std::vector<char> on_boundary(s.edges.size(), 0), visited(s.edges.size(), 0);
  st.degree.assign(nv, 0);
  for (size_t e = 0; e < s.edges.size(); ++e) {
    if (st.chart[s.edges[e].t[0]] == st.chart[s.edges[e].t[1]]) continue;
    on_boundary[e] = 1;
    ++st.degree[s.edges[e].v[0]];
    ++st.degree[s.edges[e].v[1]];
  }
  auto pair_of = [&](int e) {
    int a = st.chart[s.edges[e].t[0]], b = st.chart[s.edges[e].t[1]];
    return std::make_pair(std::min(a, b), std::max(a, b));
  };
  // Walks from vertex v along boundary edge e until a corner (degree != 2) or back to the start.
  auto walk = [&](int v, int e, bool closed) {
    PolyCubeEdge pe;
    std::tie(pe.chart_a, pe.chart_b) = pair_of(e);
    pe.closed = closed;
    pe.vertices.push_back(v);
    int cur = v;
    for (;;) {
      visited[e] = 1;
      int nxt = s.other(e, cur);
      if (closed && nxt == v) break;
      pe.vertices.push_back(nxt);
      if (st.degree[nxt] != 2) break;
      int ne = -1;
      for (auto& [w, f] : s.vert_edges[nxt])
        if (on_boundary[f] && f != e && !visited[f]) ne = f;
      if (ne < 0) break;
      cur = nxt;
      e = ne;
    }
    st.edges.push_back(std::move(pe));
  };
  for (int v = 0; v < nv; ++v) {
    if (st.degree[v] < 3) continue;
    PolyCubeCorner c;
    c.vertex = v;
    c.valence = st.degree[v];
    for (int t : s.vert_tris[v]) c.charts.push_back(st.chart[t]);
    std::sort(c.charts.begin(), c.charts.end());
    c.charts.erase(std::unique(c.charts.begin(), c.charts.end()), c.charts.end());
    st.corners.push_back(std::move(c));
    for (auto& [w, e] : s.vert_edges[v])
      if (on_boundary[e] && !visited[e]) walk(v, e, false);
  }
  for (size_t e = 0; e < s.edges.size(); ++e)
    if (on_boundary[e] && !visited[e]) walk(s.edges[e].v[0], int(e), true);
  return st;
}

}  // namespace polyhex::segment_detail
