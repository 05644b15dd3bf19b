#include "nodes/algorithms/features.h"

#include "nodes/algorithms/triangle_tree.h"
#include "runtime/errors.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <queue>
#include <string>
#include <unordered_map>

namespace polyhex {
namespace {

using Vec3 = Eigen::Vector3d;

double line_length(const std::vector<Vec3>& line) {
  double L = 0;
  for (size_t k = 1; k < line.size(); ++k) L += (line[k] - line[k - 1]).norm();
  return L;
}

/// A key of the undirected edge (a, b) of a surface with nv vertices.
long long edge_key(int a, int b, long long nv) { return (long long)std::min(a, b) * nv + std::max(a, b); }

/// Per triangle its normal times twice its area (the cross product of two of its edges).
std::vector<Vec3> area_normals(const SurfaceMesh& surface) {
  const auto& V = surface.V;
  const auto& F = surface.F;
  std::vector<Vec3> out(size_t(F.rows()));
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    out[size_t(f)] = (V.row(F(f, 1)) - V.row(F(f, 0))).cross(V.row(F(f, 2)) - V.row(F(f, 0))).transpose();
  return out;
}

/// Per triangle its unit normal (zero for a degenerate one), from area_normals.
std::vector<Vec3> unit_normals(const std::vector<Vec3>& area_normal) {
  std::vector<Vec3> out(area_normal.size(), Vec3::Zero());
  for (size_t f = 0; f < area_normal.size(); ++f)
    if (area_normal[f].norm() > 0) out[f] = area_normal[f].normalized();
  return out;
}

/// The point at arc length `s` along the line.
Vec3 point_at(const std::vector<Vec3>& line, double s) {
  for (size_t k = 1; k < line.size(); ++k) {
    const double l = (line[k] - line[k - 1]).norm();
    if (s <= l && l > 0) return line[k - 1] + (s / l) * (line[k] - line[k - 1]);
    s -= l;
  }
  return line.back();
}

}  // namespace

namespace {

/// An edge shared by exactly two triangles, with the angle test already done.
struct ManifoldEdge {
  int a, b;    ///< vertices, a < b
  int f0, f1;  ///< the two triangles
  bool sharp;  ///< their normals differ by more than the threshold angle
};

/// A sharp edge at a scale turns by more than this many times the mean deviation of the normals on either side.
constexpr double kSideRoughness = 3.0;

/// The scale test of sharp_edges for the sharp edges of `edges`: each keeps `sharp` only if the mean normals
/// of its two sides, over the triangles whose centroids lie within `scale` of it and beside it (not beyond
/// its ends), differ by more than the angle whose cosine is cos_max, and by more than kSideRoughness times
/// the sides' own spread. `area_normal`: per triangle its normal times twice its area.
void sharp_at_scale(const SurfaceMesh& surface, const std::vector<std::array<int, 3>>& half,
                    const std::vector<Vec3>& area_normal, double cos_max, double scale,
                    std::vector<ManifoldEdge>& edges) {
  const auto& V = surface.V;
  const auto& F = surface.F;
  const size_t nf = size_t(F.rows());
  // triangle adjacency across every edge (non-manifold ones included: the surface is what it is)
  std::vector<int> start(nf + 1, 0), adj;
  {
    std::vector<std::vector<int>> nb(nf);
    for (size_t i = 0; i < half.size();) {
      size_t j = i;
      while (j < half.size() && half[j][0] == half[i][0] && half[j][1] == half[i][1]) ++j;
      for (size_t u = i; u < j; ++u)
        for (size_t w = i; w < j; ++w)
          if (u != w) nb[size_t(half[u][2])].push_back(half[w][2]);
      i = j;
    }
    for (size_t f = 0; f < nf; ++f) start[f + 1] = start[f] + int(nb[f].size());
    for (auto& n : nb) adj.insert(adj.end(), n.begin(), n.end());
  }
  std::vector<Vec3> centroid(nf);
  for (size_t f = 0; f < nf; ++f)
    centroid[f] =
        (V.row(F(Eigen::Index(f), 0)) + V.row(F(Eigen::Index(f), 1)) + V.row(F(Eigen::Index(f), 2))).transpose() / 3.0;
  std::vector<size_t> sharp;
  for (size_t e = 0; e < edges.size(); ++e)
    if (edges[e].sharp) sharp.push_back(e);
  tbb::enumerable_thread_specific<std::vector<size_t>> stamps([&] { return std::vector<size_t>(nf, 0); });
  tbb::parallel_for(size_t(0), sharp.size(), [&](size_t i) {
    ManifoldEdge& e = edges[sharp[i]];
    std::vector<size_t>& seen = stamps.local();
    const size_t stamp = sharp[i] + 1;  // distinct per edge: no clearing between the edges a thread does
    const Vec3 a = V.row(e.a).transpose(), b = V.row(e.b).transpose();
    const Vec3 u = (b - a).normalized(), m = 0.5 * (a + b);
    auto across = [&](const Vec3& x) {  // the part of x - m across the edge
      const Vec3 r = x - m;
      return Vec3(r - r.dot(u) * u);
    };
    const Vec3 side = across(centroid[size_t(e.f0)]).normalized() - across(centroid[size_t(e.f1)]).normalized();
    Vec3 sum[2] = {Vec3::Zero(), Vec3::Zero()};
    std::vector<int> queue{e.f0, e.f1};
    std::vector<int> sides;
    seen[size_t(e.f0)] = seen[size_t(e.f1)] = stamp;
    const double len = (b - a).norm();
    for (size_t q = 0; q < queue.size(); ++q) {
      const int f = queue[q];
      // counted: the edge's two triangles, and those beside the edge, not beyond its ends (at a corner of a
      // part, beyond the end lies a third face)
      const double t = (centroid[size_t(f)] - a).dot(u) / len;
      const int s = f == e.f0                                    ? 0
                    : f == e.f1                                  ? 1
                    : t <= 1e-6 || t >= 1 - 1e-6                 ? -1
                    : across(centroid[size_t(f)]).dot(side) >= 0 ? 0
                                                                 : 1;
      if (s >= 0) sum[s] += area_normal[size_t(f)];
      sides.push_back(s);
      for (int k = start[size_t(f)]; k < start[size_t(f) + 1]; ++k) {
        const int g = adj[size_t(k)];
        if (seen[size_t(g)] == stamp) continue;
        seen[size_t(g)] = stamp;
        if (segment_distance(centroid[size_t(g)], a, b) <= scale) queue.push_back(g);
      }
    }
    const double n0 = sum[0].norm(), n1 = sum[1].norm();
    e.sharp = n0 > 0 && n1 > 0 && sum[0].dot(sum[1]) < cos_max * n0 * n1;
    if (!e.sharp) return;
    // ... and it turns more than the surface does on either side of it: kSideRoughness times the mean angle
    // between a side's triangles and that side's mean normal
    const double theta = std::acos(std::clamp(sum[0].dot(sum[1]) / (n0 * n1), -1.0, 1.0));
    double spread[2] = {0, 0}, area[2] = {0, 0};
    for (size_t q = 0; q < queue.size(); ++q) {
      const Vec3& an = area_normal[size_t(queue[q])];
      const double ar = an.norm();
      if (!(ar > 0)) continue;
      const int sd = sides[q];
      if (sd < 0) continue;
      spread[sd] += ar * std::acos(std::clamp(an.dot(sum[sd]) / (ar * (sd == 0 ? n0 : n1)), -1.0, 1.0));
      area[sd] += ar;
    }
    e.sharp = theta > kSideRoughness * std::max(spread[0] / area[0], spread[1] / area[1]);
  });
}

/// Every edge of `surface` shared by exactly two triangles, sorted by (a, b); `scale` as sharp_edges.
/// \throw InvalidInput when a triangle index is out of range
std::vector<ManifoldEdge> manifold_edges(const SurfaceMesh& surface, double angle_deg, double scale = 0) {
  const auto& V = surface.V;
  const auto& F = surface.F;
  const Eigen::Index nv = V.rows();
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      if (F(f, k) < 0 || F(f, k) >= nv)
        throw InvalidInput(surface.source + ": triangle " + std::to_string(f) + " has vertex index " +
                           std::to_string(F(f, k)) + " outside 0.." + std::to_string(nv - 1));
  const std::vector<Vec3> area_normal = area_normals(surface), normal = unit_normals(area_normal);
  // edges as (low, high, face), sorted: an interior manifold edge appears twice
  std::vector<std::array<int, 3>> half;
  half.reserve(size_t(F.rows()) * 3);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = F(f, k), b = F(f, (k + 1) % 3);
      half.push_back({std::min(a, b), std::max(a, b), int(f)});
    }
  std::sort(half.begin(), half.end());
  const double cos_max = std::cos(angle_deg * M_PI / 180.0);
  std::vector<ManifoldEdge> out;
  for (size_t i = 0; i < half.size();) {
    size_t j = i;
    while (j < half.size() && half[j][0] == half[i][0] && half[j][1] == half[i][1]) ++j;
    if (j - i == 2) {
      const Vec3& n0 = normal[size_t(half[i][2])];
      const Vec3& n1 = normal[size_t(half[i + 1][2])];
      const bool sharp = n0.squaredNorm() > 0 && n1.squaredNorm() > 0 && n0.dot(n1) < cos_max;
      out.push_back({half[i][0], half[i][1], half[i][2], half[i + 1][2], sharp});
    }
    i = j;
  }
  if (scale > 0) sharp_at_scale(surface, half, area_normal, cos_max, scale, out);
  return out;
}

/// The connected components of `nf` triangles joined across the edges for which `join(edge)` holds, numbered
/// 0.. in the order of each component's lowest triangle. \param count  out: the number of components
template <class Join>
Eigen::VectorXi join_triangles(int nf, const std::vector<ManifoldEdge>& edges, const Join& join, int& count) {
  std::vector<int> parent(static_cast<size_t>(nf));
  for (int f = 0; f < nf; ++f) parent[size_t(f)] = f;
  auto find = [&](int f) {
    while (parent[size_t(f)] != f) f = parent[size_t(f)] = parent[size_t(parent[size_t(f)])];
    return f;
  };
  for (const ManifoldEdge& e : edges)
    if (join(e)) {
      const int r0 = find(e.f0), r1 = find(e.f1);
      if (r0 != r1) parent[size_t(std::max(r0, r1))] = std::min(r0, r1);  // the root is the lowest triangle
    }
  Eigen::VectorXi component(nf);
  std::vector<int> id(static_cast<size_t>(nf), -1);
  count = 0;
  for (int f = 0; f < nf; ++f) {
    const int r = find(f);
    if (id[size_t(r)] < 0) id[size_t(r)] = count++;
    component[f] = id[size_t(r)];
  }
  return component;
}

}  // namespace

std::vector<std::array<int, 2>> sharp_edges(const SurfaceMesh& surface, double angle_deg, double scale) {
  std::vector<std::array<int, 2>> out;
  for (const ManifoldEdge& e : manifold_edges(surface, angle_deg, scale))
    if (e.sharp) out.push_back({e.a, e.b});
  return out;
}

Eigen::VectorXi surface_patches(const SurfaceMesh& surface, double angle_deg, int* patches) {
  int n = 0;
  Eigen::VectorXi patch = join_triangles(
      int(surface.F.rows()), manifold_edges(surface, angle_deg), [](const ManifoldEdge& e) { return !e.sharp; }, n);
  if (patches) *patches = n;
  return patch;
}

namespace {

/// A crease line at a scale is a part's edge, not a scan's faceting: a smooth curve (at points 2 scale apart
/// it turns by less than kEdgeTurn degrees on average) with a steady dihedral angle (standard deviation below
/// kEdgeSpread degrees), at least kEdgeLength x scale long (the stages take half a hex edge: three hex edges)
/// or running between two corners. A scan's creases zig-zag between its facets, short, at angles that come
/// and go.
constexpr double kEdgeLength = 6.0, kEdgeTurn = 20.0, kEdgeSpread = 10.0;

/// The shape of a crease line (kEdgeLength aside): a smooth curve at the scale (its points 2 scale apart
/// along it: a level set's staircase of voxels turns at every vertex, not at the scale) with a steady
/// dihedral angle.
bool part_edge_shape(const std::vector<int>& verts, const std::vector<Vec3>& line,
                     const std::unordered_map<long long, double>& dihedral, long long nv, double scale) {
  std::vector<Vec3> at{line.front()};  // points 2 scale apart along the line, and its end
  double run = 0;
  for (size_t k = 1; k < line.size(); ++k) {
    run += (line[k] - line[k - 1]).norm();
    if (run >= 2 * scale || k + 1 == line.size()) at.push_back(line[k]), run = 0;
  }
  double turn = 0;
  int turns = 0;
  for (size_t k = 1; k + 1 < at.size(); ++k) {
    const Vec3 a = at[k] - at[k - 1], b = at[k + 1] - at[k];
    if (a.norm() > 0 && b.norm() > 0)
      turn += std::acos(std::clamp(a.dot(b) / (a.norm() * b.norm()), -1.0, 1.0)) * 180.0 / M_PI, ++turns;
  }
  if (turns > 0 && turn / turns > kEdgeTurn) return false;
  double sum = 0, sq = 0;
  for (size_t k = 1; k < verts.size(); ++k) {
    const auto it = dihedral.find(edge_key(verts[k - 1], verts[k], nv));
    const double d = it == dihedral.end() ? 0.0 : it->second;
    sum += d, sq += d * d;
  }
  const double n = double(verts.size() - 1), mean = sum / n;
  return std::sqrt(std::max(sq / n - mean * mean, 0.0)) <= kEdgeSpread;
}

}  // namespace

std::vector<EdgeChain> edge_chains(const std::vector<std::vector<int>>& adj) {
  const long long nv = (long long)adj.size();
  auto is_node = [&](int v) { return adj[size_t(v)].size() != 2; };
  auto key = [&](int a, int b) { return edge_key(a, b, nv); };
  std::unordered_map<long long, char> visited;  // edges, keyed by (low, high)
  std::vector<EdgeChain> out;
  auto walk = [&](int start, int next) {
    EdgeChain r{{start}, false};
    int prev = start, cur = next;
    visited[key(prev, cur)] = 1;
    while (true) {
      r.verts.push_back(cur);
      if (cur == start) {
        r.closed = true;
        break;
      }
      if (is_node(cur)) break;
      int nxt = -1;
      for (int w : adj[size_t(cur)])
        if (w != prev && !visited.count(key(cur, w))) nxt = w;
      if (nxt < 0) break;
      visited[key(cur, nxt)] = 1;
      prev = cur, cur = nxt;
    }
    out.push_back(std::move(r));
  };
  for (int v = 0; v < int(nv); ++v)
    if (!adj[size_t(v)].empty() && is_node(v))
      for (int w : adj[size_t(v)])
        if (!visited.count(key(v, w))) walk(v, w);
  for (int v = 0; v < int(nv); ++v)  // what is left are loops of degree-2 vertices
    for (int w : adj[size_t(v)])
      if (!visited.count(key(v, w))) walk(v, w);
  return out;
}

SurfaceCreases find_creases(const SurfaceMesh& surface, double angle_deg, double min_length, double scale) {
  const auto& V = surface.V;
  const Eigen::Index nv = V.rows();
  auto key = [&](int a, int b) { return edge_key(a, b, nv); };
  const std::vector<ManifoldEdge> edges = manifold_edges(surface, angle_deg);
  std::vector<std::vector<int>> adj(static_cast<size_t>(nv));  // sharp-edge neighbours
  for (const ManifoldEdge& e : edges)
    if (e.sharp) adj[size_t(e.a)].push_back(e.b), adj[size_t(e.b)].push_back(e.a);
  if (scale > 0) {
    // The edges sharp at the scale, on the sharp edges' chains that are a part's edges: the chains are judged
    // whole (the scale test drops single edges along a level set's staircase, whose pieces would be short)
    std::unordered_map<long long, double> dihedral;  // of each sharp edge, degrees
    const std::vector<Vec3> normal = unit_normals(area_normals(surface));
    for (const ManifoldEdge& e : edges)
      if (e.sharp)
        dihedral[key(e.a, e.b)] =
            std::acos(std::clamp(normal[size_t(e.f0)].dot(normal[size_t(e.f1)]), -1.0, 1.0)) * 180.0 / M_PI;
    std::unordered_map<long long, char> part;  // sharp edges on chains that are a part's edges
    for (const EdgeChain& c : edge_chains(adj)) {
      std::vector<Vec3> line;
      for (int v : c.verts) line.push_back(V.row(v).transpose());
      const bool between_corners =
          !c.closed && adj[size_t(c.verts.front())].size() >= 3 && adj[size_t(c.verts.back())].size() >= 3;
      if (part_edge_shape(c.verts, line, dihedral, nv, scale) &&
          (line_length(line) >= kEdgeLength * scale || between_corners))
        for (size_t k = 1; k < c.verts.size(); ++k) part[key(c.verts[k - 1], c.verts[k])] = 1;
    }
    adj.assign(static_cast<size_t>(nv), {});
    for (const ManifoldEdge& e : manifold_edges(surface, angle_deg, scale))
      if (e.sharp && part.count(key(e.a, e.b))) adj[size_t(e.a)].push_back(e.b), adj[size_t(e.b)].push_back(e.a);
  }
  SurfaceCreases out;
  // a corner (>= 3 crease edges) enters out.corners when a kept line first ends at it
  std::vector<int> corner_index(static_cast<size_t>(nv), -1);
  auto corner_id = [&](int v) {
    if (adj[size_t(v)].size() < 3) return -1;
    if (corner_index[size_t(v)] < 0) {
      corner_index[size_t(v)] = int(out.corners.size());
      out.corners.push_back(V.row(v).transpose());
    }
    return corner_index[size_t(v)];
  };
  for (const EdgeChain& r : edge_chains(adj)) {
    std::vector<Vec3> line;
    for (int v : r.verts) line.push_back(V.row(v).transpose());
    if (line.size() < 2 || line_length(line) < min_length) continue;
    out.lines.push_back(std::move(line));
    out.vertices.push_back(r.verts);
    out.closed.push_back(r.closed);
    out.start_corner.push_back(r.closed ? -1 : corner_id(r.verts.front()));
    out.end_corner.push_back(r.closed ? -1 : corner_id(r.verts.back()));
  }
  return out;
}

CreaseFaces crease_faces(const SurfaceMesh& surface, const SurfaceCreases& creases) {
  const int nf = int(surface.F.rows());
  const std::vector<std::array<int, 2>> on_line = crease_edges(creases);  // (low, high), as ManifoldEdge's (a, b)
  CreaseFaces out;
  out.patch = join_triangles(
      nf, manifold_edges(surface, 90.0),
      [&](const ManifoldEdge& e) {
        return !std::binary_search(on_line.begin(), on_line.end(), std::array{e.a, e.b});
      },
      out.faces);
  const std::vector<Vec3> area_normal = area_normals(surface), normal = unit_normals(area_normal);
  std::vector<Vec3> mean(size_t(out.faces), Vec3::Zero());
  for (int f = 0; f < nf; ++f) mean[size_t(out.patch[f])] += area_normal[size_t(f)];
  for (auto& m : mean)
    if (m.norm() > 0) m.normalize();
  out.planar.assign(size_t(out.faces), 1);
  const double cos_max = std::cos(kPlanarFace * M_PI / 180.0);
  for (int f = 0; f < nf; ++f)
    if (normal[size_t(f)].dot(mean[size_t(out.patch[f])]) < cos_max) out.planar[size_t(out.patch[f])] = 0;
  return out;
}

std::vector<char> flat_face_triangles(const SurfaceMesh& surface, double h) {
  const int nf = int(surface.F.rows());
  const std::vector<Vec3> area_normal = area_normals(surface), normal = unit_normals(area_normal);
  std::vector<double> area(static_cast<size_t>(nf));
  for (int f = 0; f < nf; ++f) area[size_t(f)] = 0.5 * area_normal[size_t(f)].norm();
  std::vector<std::vector<int>> nbrs(static_cast<size_t>(nf));
  for (const ManifoldEdge& e : manifold_edges(surface, 90.0))
    nbrs[size_t(e.f0)].push_back(e.f1), nbrs[size_t(e.f1)].push_back(e.f0);
  std::vector<int> order(static_cast<size_t>(nf));
  for (int f = 0; f < nf; ++f) order[size_t(f)] = f;
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return area[size_t(a)] > area[size_t(b)]; });
  const double cos_max = std::cos(kPlanarFace * M_PI / 180.0);
  std::vector<int> region(static_cast<size_t>(nf), -1);
  std::vector<char> flat(static_cast<size_t>(nf), 0);
  std::vector<int> members, stack;
  int n = 0;
  for (int seed : order) {
    if (region[size_t(seed)] >= 0 || area[size_t(seed)] <= 0) continue;
    const Vec3 axis = normal[size_t(seed)];
    members.assign(1, seed);
    stack.assign(1, seed);
    region[size_t(seed)] = n;
    double total = 0;
    while (!stack.empty()) {
      const int f = stack.back();
      stack.pop_back();
      total += area[size_t(f)];
      for (int g : nbrs[size_t(f)])
        if (region[size_t(g)] < 0 && normal[size_t(g)].dot(axis) >= cos_max)
          region[size_t(g)] = n, stack.push_back(g), members.push_back(g);
    }
    if (total >= kFlatFaceArea * h * h)
      for (int f : members) flat[size_t(f)] = 1;
    ++n;
  }
  return flat;
}

SurfaceCreases flat_face_creases(const SurfaceMesh& surface, const SurfaceCreases& creases, double h) {
  const std::vector<char> flat = flat_face_triangles(surface, h);
  const Eigen::Index nv = surface.V.rows();
  std::unordered_map<long long, char> beside_flat;  // each edge: a triangle on a flat face beside it
  for (Eigen::Index f = 0; f < surface.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = surface.F(f, k), b = surface.F(f, (k + 1) % 3);
      beside_flat[edge_key(a, b, nv)] |= flat[size_t(f)];
    }
  SurfaceCreases out;
  std::vector<int> corner(creases.corners.size(), -1);
  auto keep_corner = [&](int c) {
    if (c < 0) return -1;
    if (corner[size_t(c)] < 0)
      corner[size_t(c)] = int(out.corners.size()), out.corners.push_back(creases.corners[size_t(c)]);
    return corner[size_t(c)];
  };
  for (size_t l = 0; l < creases.lines.size(); ++l) {
    const auto& vs = creases.vertices[l];
    size_t along = 0;
    for (size_t k = 1; k < vs.size(); ++k) {
      const auto it = beside_flat.find(edge_key(vs[k - 1], vs[k], nv));
      along += it != beside_flat.end() && it->second;
    }
    if (2 * along <= vs.size() - 1) continue;
    out.lines.push_back(creases.lines[l]);
    out.vertices.push_back(vs);
    out.closed.push_back(creases.closed[l]);
    out.start_corner.push_back(keep_corner(creases.start_corner[l]));
    out.end_corner.push_back(keep_corner(creases.end_corner[l]));
  }
  return out;
}

std::vector<std::array<int, 2>> crease_edges(const SurfaceCreases& creases) {
  std::vector<std::array<int, 2>> out;
  for (const auto& l : creases.vertices)
    for (size_t k = 1; k < l.size(); ++k) out.push_back({std::min(l[k - 1], l[k]), std::max(l[k - 1], l[k])});
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

Vec3 closest_on_line(const std::vector<Vec3>& line, const Vec3& x, Vec3* tangent) {
  double best = std::numeric_limits<double>::infinity();
  Vec3 out = line.front();
  for (size_t k = 1; k < line.size(); ++k) {
    const Vec3 p = closest_on_segment(x, line[k - 1], line[k]);
    const double e = (p - x).squaredNorm();
    if (e < best) {
      best = e, out = p;
      if (tangent) {
        const Vec3 d = line[k] - line[k - 1];
        const double dd = d.squaredNorm();
        *tangent = dd > 0 ? Vec3(d / std::sqrt(dd)) : Vec3::Zero();
      }
    }
  }
  return out;
}

namespace {

using QuadMatrix = Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor>;

/// snap_to_creases() as its steps: the boundary graph, the corners, then each crease line's path.
class CreaseSnapper {
 public:
  CreaseSnapper(const RowMatrixX3d& V, const QuadMatrix& Q, const SurfaceCreases& creases, double reach)
      : V_(V), Q_(Q), creases_(creases), reach_(reach), nv_(int(V.rows())) {}

  CreaseSnap run() {
    out_.line.assign(size_t(nv_), -1);
    out_.corner.assign(size_t(nv_), -1);
    boundary_graph();
    snap_corners();
    dist_.assign(size_t(nv_), std::numeric_limits<double>::infinity());
    cost_.resize(size_t(nv_));
    from_.assign(size_t(nv_), -1);
    blocked_.assign(size_t(nv_), 0);
    for (size_t l = 0; l < creases_.lines.size(); ++l) snap_line(l);
    for (int v = 0; v < nv_; ++v) out_.vertices += out_.line[size_t(v)] >= 0 || out_.corner[size_t(v)] >= 0;
    return std::move(out_);
  }

 private:
  Vec3 pos(int v) const { return Vec3(V_.row(v).transpose()); }

  /// The boundary vertices and their neighbours along boundary quad edges.
  void boundary_graph() {
    adj_.assign(size_t(nv_), {});
    std::vector<char> on_boundary(size_t(nv_), 0);
    for (Eigen::Index q = 0; q < Q_.rows(); ++q)
      for (int k = 0; k < 4; ++k) {
        const int a = Q_(q, k), b = Q_(q, (k + 1) % 4);
        on_boundary[size_t(a)] = 1;
        adj_[size_t(a)].push_back(b);
        adj_[size_t(b)].push_back(a);
      }
    for (int v = 0; v < nv_; ++v)
      if (on_boundary[size_t(v)]) {
        auto& a = adj_[size_t(v)];
        std::sort(a.begin(), a.end());
        a.erase(std::unique(a.begin(), a.end()), a.end());
        bverts_.push_back(v);
      }
  }

  /// The vertex of `among` nearest to `p` within reach (the last of equals), -1 if none.
  int nearest(const Vec3& p, const std::vector<int>& among) const {
    int best = -1;
    double bd = reach_ * reach_;
    for (int v : among) {
      const double d = (pos(v) - p).squaredNorm();
      if (d <= bd) bd = d, best = v;
    }
    return best;
  }

  /// Corners first: each takes its nearest boundary vertex within reach, unless another corner has it.
  void snap_corners() {
    corner_vertex_.assign(creases_.corners.size(), -1);
    for (size_t c = 0; c < creases_.corners.size(); ++c) {
      const int v = nearest(creases_.corners[c], bverts_);
      if (v >= 0 && out_.corner[size_t(v)] < 0) corner_vertex_[c] = v, out_.corner[size_t(v)] = int(c);
    }
  }

  /// The boundary vertices within reach of the line, with their distance to it in dist_.
  std::vector<int> near_line(const std::vector<Vec3>& line) {
    Eigen::AlignedBox3d box;
    for (const Vec3& p : line) box.extend(p);
    box.min().array() -= reach_;
    box.max().array() += reach_;
    std::vector<int> near;
    for (int v : bverts_) {
      if (!box.contains(pos(v))) continue;
      const double d = (closest_on_line(line, pos(v)) - pos(v)).norm();
      if (d <= reach_) near.push_back(v), dist_[size_t(v)] = d;
    }
    return near;
  }

  /// Dijkstra from s to t over `near`, avoiding blocked vertices; the path, empty if none.
  std::vector<int> path_between(int s, int t, const std::vector<int>& near) {
    std::vector<int> path;
    for (int v : near) cost_[size_t(v)] = std::numeric_limits<double>::infinity(), from_[size_t(v)] = -1;
    using QE = std::pair<double, int>;
    std::priority_queue<QE, std::vector<QE>, std::greater<QE>> pq;
    cost_[size_t(s)] = 0;
    pq.push({0.0, s});
    while (!pq.empty()) {
      auto [c, v] = pq.top();
      pq.pop();
      if (c > cost_[size_t(v)]) continue;
      if (v == t) break;
      for (int w : adj_[size_t(v)]) {
        if (!std::isfinite(dist_[size_t(w)]) || (blocked_[size_t(w)] && w != t)) continue;
        const double e = (pos(w) - pos(v)).norm() * (1.0 + 8.0 * 0.5 * (dist_[size_t(v)] + dist_[size_t(w)]) / reach_);
        if (c + e < cost_[size_t(w)]) cost_[size_t(w)] = c + e, from_[size_t(w)] = v, pq.push({c + e, w});
      }
    }
    if (!std::isfinite(cost_[size_t(t)])) return path;
    for (int v = t; v >= 0; v = from_[size_t(v)]) {
      path.push_back(v);
      if (v == s) break;
    }
    std::reverse(path.begin(), path.end());
    return path;
  }

  /// Line l's candidate path: between its end vertices (an open line, ends at its corners' vertices where they
  /// have one) or a loop through its start and middle (a closed line); empty if none.
  std::vector<int> candidate_path(size_t l, const std::vector<int>& near) {
    const auto& line = creases_.lines[l];
    if (near.size() < 2) return {};
    auto end_vertex = [&](int corner, const Vec3& p) {
      if (corner >= 0 && corner_vertex_[size_t(corner)] >= 0) return corner_vertex_[size_t(corner)];
      return nearest(p, near);
    };
    if (!creases_.closed[l]) {
      const int s = end_vertex(creases_.start_corner[l], line.front());
      const int t = end_vertex(creases_.end_corner[l], line.back());
      const bool ok = s >= 0 && t >= 0 && s != t && std::isfinite(dist_[size_t(s)]) && std::isfinite(dist_[size_t(t)]);
      return ok ? path_between(s, t, near) : std::vector<int>{};
    }
    const int s = nearest(line.front(), near), m = nearest(point_at(line, 0.5 * line_length(line)), near);
    if (s < 0 || m < 0 || s == m) return {};
    std::vector<int> path = path_between(s, m, near);
    for (size_t k = 1; k + 1 < path.size(); ++k) blocked_[size_t(path[k])] = 1;
    std::vector<int> back = path.empty() ? std::vector<int>{} : path_between(m, s, near);
    for (size_t k = 1; k + 1 < path.size(); ++k) blocked_[size_t(path[k])] = 0;
    if (back.size() < 2) return {};
    path.insert(path.end(), back.begin() + 1, back.end() - 1);
    return path;
  }

  /// The path's length, its claims, and no quad with three vertices on it (a staircase across quads).
  bool acceptable(size_t l, const std::vector<int>& path) const {
    if (path.size() < 2) return false;
    double len = 0;
    for (size_t k = 1; k < path.size(); ++k) len += (pos(path[k]) - pos(path[k - 1])).norm();
    if (len > 2.0 * line_length(creases_.lines[l]) + 2.0 * reach_) return false;
    for (size_t k = 0; k < path.size(); ++k) {
      const int v = path[size_t(k)];
      if (blocked_[size_t(v)]) return false;  // on an accepted line (blocked is set with out.line)
      const bool end = !creases_.closed[l] && (k == 0 || k + 1 == path.size());
      if (out_.corner[size_t(v)] >= 0 && !end) return false;
    }
    std::vector<char> on(size_t(nv_), 0);
    for (int v : path) on[size_t(v)] = 1;
    for (Eigen::Index q = 0; q < Q_.rows(); ++q)
      if (on[size_t(Q_(q, 0))] + on[size_t(Q_(q, 1))] + on[size_t(Q_(q, 2))] + on[size_t(Q_(q, 3))] >= 3) return false;
    return true;
  }

  void snap_line(size_t l) {
    const std::vector<int> near = near_line(creases_.lines[l]);
    const std::vector<int> path = candidate_path(l, near);
    const bool ok = acceptable(l, path);
    for (int v : near) dist_[size_t(v)] = std::numeric_limits<double>::infinity();
    if (!ok) {
      ++out_.lines_skipped;
      return;
    }
    ++out_.lines_snapped;
    for (int v : path)
      if (out_.corner[size_t(v)] < 0) out_.line[size_t(v)] = int(l), blocked_[size_t(v)] = 1;
  }

  const RowMatrixX3d& V_;
  const QuadMatrix& Q_;
  const SurfaceCreases& creases_;
  const double reach_;
  const int nv_;
  CreaseSnap out_;
  std::vector<std::vector<int>> adj_;
  std::vector<int> bverts_;
  std::vector<int> corner_vertex_;
  std::vector<double> dist_;  ///< distance to the current line, infinite off it
  std::vector<double> cost_;
  std::vector<int> from_;
  std::vector<char> blocked_;  ///< on an accepted line, or on the first half of the current loop
};

}  // namespace

CreaseSnap snap_to_creases(const RowMatrixX3d& V, const Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor>& Q,
                           const SurfaceCreases& creases, double reach) {
  return CreaseSnapper(V, Q, creases, reach).run();
}

namespace {
/// creases_at_vertices frees a vertex whose boundary quad's corner there is wider than 150 degrees, or wider than
/// 120 degrees with both its edges on the vertex's crease line.
const double kFlatCornerCos = std::cos(150.0 * M_PI / 180.0);
const double kWideCornerCos = std::cos(120.0 * M_PI / 180.0);
}  // namespace

CreaseSnap creases_at_vertices(const RowMatrixX3d& V, const Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor>& Q,
                               const SurfaceCreases& creases, double tol) {
  CreaseSnap out;
  out.line.assign(size_t(V.rows()), -1);
  out.corner.assign(size_t(V.rows()), -1);
  std::vector<char> on_boundary(size_t(V.rows()), 0);
  for (Eigen::Index q = 0; q < Q.rows(); ++q)
    for (int k = 0; k < 4; ++k) on_boundary[size_t(Q(q, k))] = 1;
  std::vector<Eigen::AlignedBox3d> boxes(creases.lines.size());
  for (size_t l = 0; l < creases.lines.size(); ++l) {
    for (const Vec3& p : creases.lines[l]) boxes[l].extend(p);
    boxes[l].min().array() -= tol;
    boxes[l].max().array() += tol;
  }
  for (Eigen::Index v = 0; v < V.rows(); ++v) {
    if (!on_boundary[size_t(v)]) continue;
    const Vec3 x = V.row(v).transpose();
    for (size_t c = 0; c < creases.corners.size() && out.corner[size_t(v)] < 0; ++c)
      if ((creases.corners[c] - x).norm() <= tol) out.corner[size_t(v)] = int(c);
    if (out.corner[size_t(v)] >= 0) continue;
    double best = tol;
    for (size_t l = 0; l < creases.lines.size(); ++l) {
      if (!boxes[l].contains(x)) continue;
      const double d = (closest_on_line(creases.lines[l], x) - x).norm();
      if (d <= best) best = d, out.line[size_t(v)] = int(l);
    }
  }
  // a boundary quad with a lattice corner where the crease runs on (a PolyCube corner on a smooth part of it):
  // nearly flat at the vertex, or wide with both its edges there on the vertex's line (sliding along the line
  // would flatten it); the vertex must leave the crease to open that corner
  const std::vector<int> line0 = out.line;
  for (Eigen::Index q = 0; q < Q.rows(); ++q)
    for (int k = 0; k < 4; ++k) {
      const int v = Q(q, k), u = Q(q, (k + 1) % 4), w = Q(q, (k + 3) % 4);
      if (out.line[size_t(v)] < 0 && out.corner[size_t(v)] < 0) continue;
      const Vec3 x = V.row(v).transpose(), a = V.row(u).transpose() - x, b = V.row(w).transpose() - x;
      if (!(a.norm() > 0 && b.norm() > 0)) continue;
      const double c = a.dot(b) / (a.norm() * b.norm());
      const bool along =
          line0[size_t(v)] >= 0 && line0[size_t(u)] == line0[size_t(v)] && line0[size_t(w)] == line0[size_t(v)];
      if (c < kFlatCornerCos || (along && c < kWideCornerCos)) out.line[size_t(v)] = out.corner[size_t(v)] = -1;
    }
  // a vertex where the lattice crosses a crease (no boundary edge of it along the crease) does not follow it:
  // kept on the line it would hold its quads across it
  std::vector<std::vector<int>> nbrs(size_t(V.rows()));
  for (Eigen::Index q = 0; q < Q.rows(); ++q)
    for (int k = 0; k < 4; ++k)
      nbrs[size_t(Q(q, k))].push_back(Q(q, (k + 1) % 4)), nbrs[size_t(Q(q, (k + 1) % 4))].push_back(Q(q, k));
  for (int pass = 0; pass < 2; ++pass) {
    const std::vector<int> line1 = out.line, corner1 = out.corner;
    for (Eigen::Index v = 0; v < V.rows(); ++v) {
      if (line1[size_t(v)] < 0 && corner1[size_t(v)] < 0) continue;
      bool along = false;
      for (int w : nbrs[size_t(v)]) {
        const int l = line1[size_t(v)], m = line1[size_t(w)];
        if (l >= 0)
          along = along || m == l ||
                  (corner1[size_t(w)] >= 0 && (creases.start_corner[size_t(l)] == corner1[size_t(w)] ||
                                               creases.end_corner[size_t(l)] == corner1[size_t(w)]));
        else if (m >= 0)
          along = along || creases.start_corner[size_t(m)] == corner1[size_t(v)] ||
                  creases.end_corner[size_t(m)] == corner1[size_t(v)];
      }
      if (!along) out.line[size_t(v)] = out.corner[size_t(v)] = -1;
    }
  }
  std::vector<char> used(creases.lines.size(), 0);  // lines with a vertex kept on them
  for (Eigen::Index v = 0; v < V.rows(); ++v)
    if (out.line[size_t(v)] >= 0) used[size_t(out.line[size_t(v)])] = 1;
  for (Eigen::Index v = 0; v < V.rows(); ++v) out.vertices += out.line[size_t(v)] >= 0 || out.corner[size_t(v)] >= 0;
  for (char u : used) out.lines_snapped += u;
  out.lines_skipped = int(creases.lines.size()) - out.lines_snapped;
  return out;
}

}  // namespace polyhex
