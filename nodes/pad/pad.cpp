// Padding layer (paper §6 inset). See pad.h.
#include "nodes/pad/pad.h"

#include "nodes/algorithms/hex_quality.h"
#include "nodes/algorithms/triangle_tree.h"
#include "runtime/cancel.h"
#include "runtime/errors.h"
#include "runtime/stopwatch.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <map>
#include <string>
#include <vector>

namespace polyhex {
namespace {

using Vec3 = Eigen::Vector3d;

std::array<Vec3, 8> hex_points(const RowMatrixX3d& V, const RowMatrixX8i& H, Eigen::Index h) {
  std::array<Vec3, 8> p;
  for (int k = 0; k < 8; ++k) p[size_t(k)] = V.row(H(h, k)).transpose();
  return p;
}

/// The hexes of m but those flagged, unused vertices dropped.
HexMesh without_hexes(const HexMesh& m, const std::vector<char>& drop) {
  std::vector<int> map(size_t(m.V.rows()), -1);
  int nv = 0, nh = 0;
  for (Eigen::Index h = 0; h < m.H.rows(); ++h)
    if (!drop[size_t(h)]) {
      ++nh;
      for (int k = 0; k < 8; ++k)
        if (map[size_t(m.H(h, k))] < 0) map[size_t(m.H(h, k))] = 0;
    }
  for (auto& x : map)
    if (x == 0) x = nv++;
  HexMesh out;
  out.source = m.source;
  out.V.resize(nv, 3);
  for (Eigen::Index v = 0; v < m.V.rows(); ++v)
    if (map[size_t(v)] >= 0) out.V.row(map[size_t(v)]) = m.V.row(v);
  out.H.resize(nh, 8);
  for (Eigen::Index h = 0, r = 0; h < m.H.rows(); ++h)
    if (!drop[size_t(h)]) {
      for (int k = 0; k < 8; ++k) out.H(r, k) = map[size_t(m.H(h, k))];
      ++r;
    }
  return out;
}

/// The boundary faces of a mesh (hex_boundary_quads): per face its 4 vertices (outward in its hex) and its
/// hex; per vertex the faces on it.
struct BoundaryFaces {
  std::vector<std::array<int, 4>> quad;
  std::vector<int> hex;
  std::vector<int> faces_of_hex;           ///< boundary faces per hex
  std::vector<std::vector<int>> faces_at;  ///< boundary faces per vertex
};

BoundaryFaces boundary_faces(const HexMesh& m) {
  BoundaryFaces b;
  const auto Q = hex_boundary_quads(m, &b.hex);
  b.quad.resize(size_t(Q.rows()));
  b.faces_of_hex.assign(size_t(m.H.rows()), 0);
  b.faces_at.resize(size_t(m.V.rows()));
  for (Eigen::Index q = 0; q < Q.rows(); ++q) {
    for (int k = 0; k < 4; ++k) {
      b.quad[size_t(q)][size_t(k)] = Q(q, k);
      b.faces_at[size_t(Q(q, k))].push_back(int(q));
    }
    ++b.faces_of_hex[size_t(b.hex[size_t(q)])];
  }
  return b;
}

/// The boundary edges (sorted vertex pairs) and the boundary faces on each.
std::map<std::pair<int, int>, std::vector<int>> boundary_edges(const BoundaryFaces& b) {
  std::map<std::pair<int, int>, std::vector<int>> edge_faces;
  for (size_t q = 0; q < b.quad.size(); ++q)
    for (int k = 0; k < 4; ++k) {
      const int a = b.quad[q][size_t(k)], c = b.quad[q][size_t((k + 1) % 4)];
      edge_faces[{std::min(a, c), std::max(a, c)}].push_back(int(q));
    }
  return edge_faces;
}

/// Boundary quads per vertex; returns the number of boundary edges not in exactly two boundary quads.
long boundary_valence(const HexMesh& m, std::vector<int>& valence) {
  const BoundaryFaces b = boundary_faces(m);
  valence.resize(b.faces_at.size());
  for (size_t v = 0; v < valence.size(); ++v) valence[v] = int(b.faces_at[v].size());
  long bad = 0;
  for (const auto& e : boundary_edges(b)) bad += e.second.size() != 2;
  return bad;
}

int find_root(std::vector<int>& parent, int x) {
  while (parent[size_t(x)] != x) x = parent[size_t(x)] = parent[size_t(parent[size_t(x)])];
  return x;
}

}  // namespace

BoundaryDefects find_boundary_defects(const HexMesh& m) {
  const BoundaryFaces b = boundary_faces(m);
  BoundaryDefects d;
  const auto edge_faces = boundary_edges(b);
  for (const auto& [e, faces] : edge_faces)
    if (faces.size() != 2) d.edges.push_back({e.first, e.second});
  // per vertex: its boundary faces joined into fans across its manifold edges
  std::vector<int> parent(b.quad.size());
  for (size_t v = 0; v < b.faces_at.size(); ++v) {
    const auto& fs = b.faces_at[v];
    if (fs.size() < 2) continue;
    for (int q : fs) parent[size_t(q)] = q;
    for (int q : fs)
      for (int k = 0; k < 4; ++k) {
        if (b.quad[size_t(q)][size_t(k)] != int(v)) continue;
        for (int s : {1, 3}) {  // the two edges of q at v
          const int w = b.quad[size_t(q)][size_t((k + s) % 4)];
          const auto& on = edge_faces.at({std::min(int(v), w), std::max(int(v), w)});
          if (on.size() == 2) parent[size_t(find_root(parent, on[0]))] = find_root(parent, on[1]);
        }
      }
    int fans = 0;
    for (int q : fs) fans += find_root(parent, q) == q;
    if (fans > 1) d.vertices.push_back(int(v));
  }
  return d;
}

NonmanifoldRepair remove_nonmanifold_boundary(const HexMesh& mesh) {
  NonmanifoldRepair out;
  HexMesh& cur = out.mesh;
  cur = mesh;
  long& gone = out.removed;
  BoundaryDefects d = find_boundary_defects(cur);
  out.edges = long(d.edges.size());
  out.vertices = long(d.vertices.size());
  for (int round = 0; round < 20 && !(d.edges.empty() && d.vertices.empty()); ++round) {
    throw_if_interrupted();
    const BoundaryFaces b = boundary_faces(cur);
    // per defect, the hex on it with the most boundary faces (the most exposed), then the lowest corner
    // scaled Jacobian, then the lowest index
    auto rank = [&](int h) {
      return std::make_pair(-b.faces_of_hex[size_t(h)], hex_scaled_jacobian(hex_points(cur.V, cur.H, h)).corner_min);
    };
    std::vector<char> drop(size_t(cur.H.rows()), 0);
    // the faces at vertex `at` for which on_defect holds
    auto choose = [&](int at, auto on_defect) {
      int best = -1;
      std::pair<int, double> best_rank;
      for (int q : b.faces_at[size_t(at)]) {
        if (!on_defect(b.quad[size_t(q)])) continue;
        const int h = b.hex[size_t(q)];
        const auto r = rank(h);
        if (best < 0 || r < best_rank || (r == best_rank && h < best)) best = h, best_rank = r;
      }
      if (best >= 0) drop[size_t(best)] = 1;
    };
    for (const auto& e : d.edges)
      choose(e[0], [&](const std::array<int, 4>& q) {
        for (int k = 0; k < 4; ++k) {
          const int a = q[size_t(k)], c = q[size_t((k + 1) % 4)];
          if ((a == e[0] && c == e[1]) || (a == e[1] && c == e[0])) return true;
        }
        return false;
      });
    for (int v : d.vertices) choose(v, [](const std::array<int, 4>&) { return true; });
    const long k = long(std::count(drop.begin(), drop.end(), 1));
    if (k == 0 || k == cur.H.rows()) break;
    cur = without_hexes(cur, drop);
    gone += k;
    d = find_boundary_defects(cur);
  }
  return out;
}

Peeled peel_boundary_hexes(const HexMesh& mesh, double max_sj, int rounds) {
  Peeled out;
  HexMesh& cur = out.mesh;
  cur = mesh;
  long& gone = out.removed;
  for (int round = 0; round < rounds; ++round) {
    throw_if_interrupted();
    const BoundaryFaces b = boundary_faces(cur);
    std::vector<char> drop(size_t(cur.H.rows()), 0);
    tbb::parallel_for(Eigen::Index(0), cur.H.rows(), [&](Eigen::Index h) {
      if (b.faces_of_hex[size_t(h)] > 0 && hex_scaled_jacobian(hex_points(cur.V, cur.H, h)).corner_min <= max_sj)
        drop[size_t(h)] = 1;
    });
    const long k = long(std::count(drop.begin(), drop.end(), 1));
    if (k == 0 || k == cur.H.rows()) break;
    cur = without_hexes(cur, drop);
    gone += k;
  }
  return out;
}

DoubletRepair remove_boundary_doublets(const HexMesh& mesh) {
  DoubletRepair out;
  HexMesh& cur = out.mesh;
  cur = mesh;
  long &found = out.doublets, &gone = out.removed;
  std::vector<int> valence;
  long bad = boundary_valence(cur, valence);  // non-manifold boundary edges: removals must not add any
  for (int round = 0; round < 5; ++round) {
    throw_if_interrupted();
    std::vector<char> doublet(size_t(cur.V.rows()), 0);
    long n = 0;
    for (size_t v = 0; v < valence.size(); ++v)
      if (valence[v] > 0 && valence[v] <= 2) doublet[v] = 1, ++n;
    if (round == 0) found = n;
    if (n == 0) break;
    // the candidate hexes of each doublet, preferred first: most boundary faces, then the lowest corner
    // scaled Jacobian, then the lowest index (boundary faces come in (hex, face) order)
    const BoundaryFaces bf = boundary_faces(cur);
    const std::vector<int>& bfaces = bf.faces_of_hex;
    struct Cand {
      int faces;
      double sj;
      int hex;
    };
    std::vector<std::vector<Cand>> cands(size_t(cur.V.rows()));
    for (size_t i = 0; i < bf.quad.size();) {
      const int h = bf.hex[i];
      std::vector<int> touched;
      for (; i < bf.quad.size() && bf.hex[i] == h; ++i)
        for (int v : bf.quad[i])
          if (doublet[size_t(v)]) touched.push_back(v);
      if (touched.empty()) continue;
      std::sort(touched.begin(), touched.end());
      touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
      const double sj = hex_scaled_jacobian(hex_points(cur.V, cur.H, h)).corner_min;
      for (int v : touched) cands[size_t(v)].push_back({bfaces[size_t(h)], sj, h});
    }
    for (auto& c : cands)
      std::sort(c.begin(), c.end(), [](const Cand& a, const Cand& b) {
        return a.faces != b.faces ? a.faces > b.faces : a.sj != b.sj ? a.sj < b.sj : a.hex < b.hex;
      });
    std::vector<char> drop(size_t(cur.H.rows()), 0);
    long k = 0;
    for (size_t v = 0; v < cands.size(); ++v)
      if (doublet[v] && !cands[v].empty() && !drop[size_t(cands[v][0].hex)]) drop[size_t(cands[v][0].hex)] = 1, ++k;
    if (k == 0 || k == cur.H.rows()) break;
    HexMesh next = without_hexes(cur, drop);
    std::vector<int> next_valence;
    long next_bad = boundary_valence(next, next_valence);
    if (next_bad > bad) {
      // together they make the boundary non-manifold: per doublet (in vertex order), the first of its
      // candidates whose removal, with those kept so far, does not (a preferred hex whose removal opens a
      // non-manifold edge can have a partner across the doublet whose removal does not)
      std::vector<char> ok(drop.size(), 0);
      k = 0;
      for (size_t v = 0; v < cands.size(); ++v) {
        if (!doublet[v]) continue;
        for (const Cand& c : cands[v]) {
          if (ok[size_t(c.hex)]) break;  // resolved by an earlier removal
          throw_if_interrupted();
          ok[size_t(c.hex)] = 1;
          if (boundary_valence(without_hexes(cur, ok), next_valence) <= bad) {
            ++k;
            break;
          }
          ok[size_t(c.hex)] = 0;
        }
      }
      if (k == 0) break;
      next = without_hexes(cur, ok);
      next_bad = boundary_valence(next, next_valence);
    }
    bad = next_bad;
    cur = std::move(next);
    valence.swap(next_valence);
    gone += k;
  }
  return out;
}

HexMesh pad_boundary(const HexMesh& input, const SurfaceMesh* surface, const PadParams& p, PadStats* stats) {
  const auto t0 = std::chrono::steady_clock::now();
  check_hex_mesh(input);
  PadStats st;
  HexMesh mesh = input;
  if (p.peel_rounds > 0) {
    Peeled r = peel_boundary_hexes(mesh, p.peel_sj, p.peel_rounds);
    st.peeled = r.removed;
    mesh = std::move(r.mesh);
  }
  if (p.repair_nonmanifold) {
    NonmanifoldRepair r = remove_nonmanifold_boundary(mesh);
    st.nonmanifold_edges = r.edges;
    st.nonmanifold_vertices = r.vertices;
    st.nonmanifold_removed = r.removed;
    mesh = std::move(r.mesh);
  }
  if (p.remove_doublets) {
    DoubletRepair r = remove_boundary_doublets(mesh);
    st.doublets = r.doublets;
    st.hexes_removed = r.removed;
    mesh = std::move(r.mesh);
  }
  {
    const BoundaryDefects left = find_boundary_defects(mesh);
    st.nonmanifold_left = long(left.edges.size() + left.vertices.size());
  }
  const auto Q = hex_boundary_quads(mesh);
  if (Q.rows() == 0)
    throw InvalidInput((mesh.source.empty() ? std::string("hex mesh") : mesh.source) + ": no boundary quads to pad");
  const Eigen::Index nv = mesh.V.rows(), nh = mesh.H.rows();

  std::vector<int> inner(size_t(nv), -1);
  int nb = 0;
  for (Eigen::Index q = 0; q < Q.rows(); ++q)
    for (int k = 0; k < 4; ++k)
      if (inner[size_t(Q(q, k))] < 0) inner[size_t(Q(q, k))] = int(nv) + nb++;

  HexMesh out;
  out.source = mesh.source;
  out.V.resize(nv + nb, 3);
  out.V.topRows(nv) = mesh.V;
  if (surface) {
    TriangleTree tree(surface->V, surface->F);
    tbb::parallel_for(Eigen::Index(0), nv, [&](Eigen::Index v) {
      if (inner[size_t(v)] >= 0) out.V.row(v) = tree.closest(mesh.V.row(v).transpose()).point.transpose();
    });
  }
  // averaged outward normal (area weighted) and mean boundary edge length of each boundary vertex
  std::vector<Vec3> normal(static_cast<size_t>(nb), Vec3::Zero());
  std::vector<double> edge(static_cast<size_t>(nb), 0.0);
  std::vector<int> edges(static_cast<size_t>(nb), 0);
  for (Eigen::Index q = 0; q < Q.rows(); ++q) {
    Vec3 c[4];
    for (int k = 0; k < 4; ++k) c[k] = out.V.row(Q(q, k)).transpose();
    const Vec3 n = 0.5 * (c[2] - c[0]).cross(c[3] - c[1]);
    for (int k = 0; k < 4; ++k) {
      const size_t b = size_t(inner[size_t(Q(q, k))] - nv);
      normal[b] += n;
      edge[b] += (c[(k + 1) % 4] - c[k]).norm() + (c[(k + 3) % 4] - c[k]).norm();
      edges[b] += 2;
    }
  }
  std::vector<Vec3> offset(static_cast<size_t>(nb));
  for (size_t b = 0; b < size_t(nb); ++b) {
    const double len = normal[b].norm();
    offset[b] = len > 0 ? Vec3(-normal[b] / len * p.thickness * edge[b] / std::max(edges[b], 1)) : Vec3::Zero();
  }
  for (Eigen::Index v = 0; v < nv; ++v)
    if (inner[size_t(v)] >= 0)
      out.V.row(inner[size_t(v)]) = out.V.row(v) + offset[size_t(inner[size_t(v)] - nv)].transpose();

  // hexes: the old ones on the inner copies, then one per boundary quad (inner quad at the bottom)
  out.H.resize(nh + Q.rows(), 8);
  for (Eigen::Index h = 0; h < nh; ++h)
    for (int k = 0; k < 8; ++k) {
      const int v = mesh.H(h, k);
      out.H(h, k) = inner[size_t(v)] >= 0 ? inner[size_t(v)] : v;
    }
  for (Eigen::Index q = 0; q < Q.rows(); ++q)
    for (int k = 0; k < 4; ++k) {
      out.H(nh + q, k) = inner[size_t(Q(q, k))];
      out.H(nh + q, k + 4) = Q(q, k);
    }

  // limit the offsets so that no hex that was valid, and no layer hex, inverts
  std::vector<char> was_inverted(size_t(out.H.rows()), 0);
  for (Eigen::Index h = 0; h < nh; ++h)
    was_inverted[size_t(h)] = hex_scaled_jacobian(hex_points(mesh.V, mesh.H, h)).corner_min <= 0;
  std::vector<double> scale(static_cast<size_t>(nb), 1.0);
  for (int round = 0; round <= p.max_halvings; ++round) {
    std::vector<char> shrink(static_cast<size_t>(nb), 0);
    bool any = false;
    for (Eigen::Index h = 0; h < out.H.rows(); ++h) {
      if (was_inverted[size_t(h)] || hex_scaled_jacobian(hex_points(out.V, out.H, h)).corner_min > 0) continue;
      for (int k = 0; k < 8; ++k)
        if (out.H(h, k) >= nv) shrink[size_t(out.H(h, k) - nv)] = 1, any = true;
    }
    if (!any || round == p.max_halvings) break;
    for (Eigen::Index v = 0; v < nv; ++v) {
      const int b = inner[size_t(v)] - int(nv);
      if (b < 0 || !shrink[size_t(b)]) continue;
      scale[size_t(b)] *= 0.5;
      out.V.row(nv + b) = out.V.row(v) + scale[size_t(b)] * offset[size_t(b)].transpose();
    }
  }
  for (double s : scale) st.limited += s < 1.0;
  Eigen::VectorXd sj, corner;
  hex_scaled_jacobians(out, sj, corner);
  st.inverted = long((corner.array() <= 0).count());
  st.hexes_added = long(Q.rows());
  st.vertices_added = nb;
  st.seconds = seconds_since(t0);
  if (stats) *stats = st;
  return out;
}

}  // namespace polyhex
