// Padding layer (paper §6 inset). See pad.h.
#include "nodes/pad/pad.h"

#include "nodes/algorithms/hex_quality.h"
#include "nodes/algorithms/triangle_tree.h"
#include "nodes/artefacts/hex_topology.h"
#include "runtime/cancel.h"
#include "runtime/errors.h"
#include "runtime/stopwatch.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace polyhex {
namespace {

using Vec3 = Eigen::Vector3d;
using BoundaryQuadMatrix = Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor>;

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

namespace {

/// One boundary edge of the quad mesh: its vertices, its two quads (-1 if not two), the hexes it is an edge of.
struct BoundaryEdge {
  int a, b;
  int q0 = -1, q1 = -1;
  int quads = 0, hexes = 0;
};

/// The boundary edges of Q, sorted by (a, b), with their quads and the number of hexes on each.
std::vector<BoundaryEdge> quad_edges(const HexMesh& mesh, const BoundaryQuadMatrix& Q) {
  std::vector<BoundaryEdge> e;
  e.reserve(size_t(Q.rows()) * 4);
  for (Eigen::Index q = 0; q < Q.rows(); ++q)
    for (int k = 0; k < 4; ++k) {
      const int a = Q(q, k), b = Q(q, (k + 1) % 4);
      e.push_back({std::min(a, b), std::max(a, b), int(q), -1, 1, 0});
    }
  auto less = [](const BoundaryEdge& x, const BoundaryEdge& y) { return x.a != y.a ? x.a < y.a : x.b < y.b; };
  std::sort(e.begin(), e.end(),
            [&](const BoundaryEdge& x, const BoundaryEdge& y) { return less(x, y) || (!less(y, x) && x.q0 < y.q0); });
  std::vector<BoundaryEdge> out;
  for (size_t i = 0; i < e.size();) {
    size_t j = i;
    while (j < e.size() && e[j].a == e[i].a && e[j].b == e[i].b) ++j;
    BoundaryEdge m = e[i];
    m.quads = int(j - i);
    m.q1 = m.quads == 2 ? e[i + 1].q0 : -1;
    if (m.quads != 2) m.q0 = -1;
    out.push_back(m);
    i = j;
  }
  for (Eigen::Index h = 0; h < mesh.H.rows(); ++h)
    for (const auto& k : hex_topology::kEdges) {
      const int a = mesh.H(h, k[0]), b = mesh.H(h, k[1]);
      const BoundaryEdge key{std::min(a, b), std::max(a, b)};
      auto it = std::lower_bound(out.begin(), out.end(), key, less);
      if (it != out.end() && it->a == key.a && it->b == key.b) ++it->hexes;
    }
  return out;
}

}  // namespace

namespace {

/// Selective padding's view of a mesh's boundary (select_padded_quads): which quads need the layer, where the
/// layer may end, and how the quads hang together.
class LayerPlan {
 public:
  LayerPlan(const HexMesh& mesh, const BoundaryQuadMatrix& Q, double tolerance_deg)
      : mesh_(mesh), Q_(Q), edges_(quad_edges(mesh, Q)) {
    at_.resize(size_t(mesh.V.rows()));
    for (size_t i = 0; i < edges_.size(); ++i) {
      at_[size_t(edges_[i].a)].push_back(int(i));
      at_[size_t(edges_[i].b)].push_back(int(i));
    }
    quads_at_.resize(size_t(mesh.V.rows()));
    for (Eigen::Index q = 0; q < Q.rows(); ++q)
      for (int k = 0; k < 4; ++k) quads_at_[size_t(Q(q, k))].push_back(int(q));
    classify(tolerance_deg);
  }

  /// The quads on edges whose lattice and surface turns differ by more than the tolerance (or not manifold).
  const std::vector<char>& seeds() const { return seed_; }

  /// The boundary edges (quad_edges).
  const std::vector<BoundaryEdge>& edges() const { return edges_; }

  /// Grows `pad` until the layer ends only on edges where it may, and every vertex with padded and unpadded
  /// quads has its padded ones as one fan between two such edges.
  void close(std::vector<char>& pad) const {
    for (bool changed = true; changed;) {
      changed = false;
      for (size_t i = 0; i < edges_.size(); ++i) {
        const BoundaryEdge& e = edges_[i];
        if (e.quads != 2 || pad[size_t(e.q0)] == pad[size_t(e.q1)] || may_end_[i]) continue;
        pad[size_t(e.q0)] = pad[size_t(e.q1)] = 1;
        changed = true;
      }
      for (size_t v = 0; v < at_.size(); ++v) {
        int padded = 0, ends = 0;
        for (int q : quads_at_[v]) padded += pad[size_t(q)];
        if (padded == 0 || padded == int(quads_at_[v].size())) continue;
        for (int i : at_[v]) ends += border(pad, size_t(i));
        if (ends == 2) continue;
        for (int q : quads_at_[v]) pad[size_t(q)] = 1;
        changed = true;
      }
    }
  }

  /// Of the padded quads, the parts (joined across edges where the layer may not end) that share no vertex
  /// with an earlier part, closed again: one layer whose every end is a convex crease. Padded in turn, two
  /// parts that meet on a convex crease each end on it, and the hexes there stay boxes instead of being
  /// sheared by a layer round the crease (0.71; 0.58 at a corner).
  std::vector<char> first_layer(const std::vector<char>& pad) const {
    const size_t nq = pad.size();
    std::vector<int> part(nq, -1);
    std::vector<int> stack;
    int parts = 0;
    for (size_t q0 = 0; q0 < nq; ++q0) {
      if (!pad[q0] || part[q0] >= 0) continue;
      part[q0] = parts;
      stack.assign(1, int(q0));
      while (!stack.empty()) {
        const int q = stack.back();
        stack.pop_back();
        for (int k = 0; k < 4; ++k)
          for (int i : at_[size_t(Q_(q, k))]) {
            const BoundaryEdge& e = edges_[size_t(i)];
            if (may_end_[size_t(i)] || e.quads != 2 || (e.q0 != q && e.q1 != q)) continue;
            const int r = e.q0 == q ? e.q1 : e.q0;
            if (pad[size_t(r)] && part[size_t(r)] < 0) part[size_t(r)] = parts, stack.push_back(r);
          }
      }
      ++parts;
    }
    std::vector<char> chosen(size_t(parts), 0), blocked(size_t(parts), 0);
    for (int c = 0; c < parts; ++c) {  // parts in order of their lowest quad
      if (blocked[size_t(c)]) continue;
      chosen[size_t(c)] = 1;
      for (size_t q = 0; q < nq; ++q) {
        if (part[q] != c) continue;
        for (int k = 0; k < 4; ++k)
          for (int r : quads_at_[size_t(Q_(Eigen::Index(q), k))])
            if (part[size_t(r)] >= 0 && part[size_t(r)] != c) blocked[size_t(part[size_t(r)])] = 1;
      }
    }
    std::vector<char> out(nq, 0);
    for (size_t q = 0; q < nq; ++q) out[q] = part[q] >= 0 && chosen[size_t(part[q])];
    close(out);
    return out;
  }

 private:
  /// Edge i has exactly one padded quad.
  bool border(const std::vector<char>& pad, size_t i) const {
    const BoundaryEdge& e = edges_[i];
    return e.quads == 2 && pad[size_t(e.q0)] != pad[size_t(e.q1)];
  }

  Vec3 point(int v) const { return Vec3(mesh_.V.row(v).transpose()); }

  /// Per edge: the lattice turns by +90 (one hex on the edge), 0 (two) or -90 degrees (three), the surface by
  /// the signed angle between its quads' normals. Both quads of an edge whose turns differ by more than the
  /// tolerance are seeds; the layer may end on an edge that is convex at about 90 degrees in both.
  void classify(double tolerance_deg) {
    const size_t nq = size_t(Q_.rows());
    seed_.assign(nq, 0);
    std::vector<Vec3> normal(nq), centroid(nq);
    for (size_t q = 0; q < nq; ++q) {
      const auto r = Eigen::Index(q);
      const Vec3 c0 = point(Q_(r, 0)), c1 = point(Q_(r, 1)), c2 = point(Q_(r, 2)), c3 = point(Q_(r, 3));
      const Vec3 n = (c2 - c0).cross(c3 - c1);
      normal[q] = n.norm() > 0 ? Vec3(n.normalized()) : Vec3::Zero();
      centroid[q] = 0.25 * (c0 + c1 + c2 + c3);
    }
    may_end_.assign(edges_.size(), 0);
    for (size_t i = 0; i < edges_.size(); ++i) {
      const BoundaryEdge& e = edges_[i];
      const bool manifold = e.quads == 2 && e.hexes >= 1 && e.hexes <= 3 && !normal[size_t(e.q0)].isZero() &&
                            !normal[size_t(e.q1)].isZero();
      if (!manifold) {  // every quad on it: those at its first vertex that have it as a side
        for (const int q : quads_at_[size_t(e.a)])
          for (int k = 0; k < 4; ++k) {
            const int a = Q_(q, k), b = Q_(q, (k + 1) % 4);
            if (std::min(a, b) == e.a && std::max(a, b) == e.b) seed_[size_t(q)] = 1;
          }
        continue;
      }
      const Vec3& n0 = normal[size_t(e.q0)];
      const double angle = std::acos(std::clamp(n0.dot(normal[size_t(e.q1)]), -1.0, 1.0)) * 180.0 / M_PI;
      const bool convex = (centroid[size_t(e.q1)] - 0.5 * (point(e.a) + point(e.b))).dot(n0) < 0;
      const double surface_turn = convex ? angle : -angle, lattice_turn = 90.0 * (2 - e.hexes);
      if (std::abs(surface_turn - lattice_turn) > tolerance_deg)
        seed_[size_t(e.q0)] = seed_[size_t(e.q1)] = 1;
      else
        may_end_[i] = e.hexes == 1;
    }
  }

  const HexMesh& mesh_;
  const BoundaryQuadMatrix& Q_;
  std::vector<BoundaryEdge> edges_;
  std::vector<char> seed_, may_end_;
  std::vector<std::vector<int>> at_, quads_at_;  ///< per vertex: its boundary edges, its boundary quads
};

}  // namespace

std::vector<char> select_padded_quads(const HexMesh& mesh, const BoundaryQuadMatrix& Q, double tolerance_deg) {
  const LayerPlan plan(mesh, Q, tolerance_deg);
  std::vector<char> pad = plan.seeds();
  plan.close(pad);
  return pad;
}

namespace {

/// One layer: a hex on each padded quad of Q (the boundary quads of `mesh`), its inner quad on new copies of the
/// quad's vertices, which the old hexes take (pad_boundary). `layer_hex` (per hex of the result, 1 for a layer
/// hex) is extended by the new hexes. `thin_ends` (optional) gets the vertices where the layer ends whose
/// offset had to be cut below a quarter to keep the hexes there from inverting. `q_edges` (optional): Q's
/// quad_edges, where the caller has them (computed here when the layer has ends and they are not given).
HexMesh extrude_layer(const HexMesh& mesh, const BoundaryQuadMatrix& Q, const std::vector<char>& padded,
                      const TriangleTree* tree, const PadParams& p, PadStats& st, std::vector<char>& layer_hex,
                      std::vector<int>* thin_ends = nullptr, const std::vector<BoundaryEdge>* q_edges = nullptr) {
  const Eigen::Index nv = mesh.V.rows(), nh = mesh.H.rows();
  const Eigen::Index layer = Eigen::Index(std::count(padded.begin(), padded.end(), 1));

  std::vector<int> inner(size_t(nv), -1);
  std::vector<char> on_boundary(size_t(nv), 0);
  int nb = 0;
  for (Eigen::Index q = 0; q < Q.rows(); ++q)
    for (int k = 0; k < 4; ++k) {
      on_boundary[size_t(Q(q, k))] = 1;
      if (padded[size_t(q)] && inner[size_t(Q(q, k))] < 0) inner[size_t(Q(q, k))] = int(nv) + nb++;
    }

  HexMesh out;
  out.source = mesh.source;
  out.V.resize(nv + nb, 3);
  out.V.topRows(nv) = mesh.V;
  if (tree) {
    tbb::parallel_for(Eigen::Index(0), nv, [&](Eigen::Index v) {
      if (on_boundary[size_t(v)]) out.V.row(v) = tree->closest(mesh.V.row(v).transpose()).point.transpose();
    });
  }
  // averaged outward normal (area weighted) over the padded quads and mean boundary edge length of each
  // boundary vertex with an inner copy; where the layer ends (a vertex with unpadded quads too), the offset
  // runs along the unpadded side: along its edges between two unpadded quads, or its one quad's diagonal
  std::vector<Vec3> normal(static_cast<size_t>(nb), Vec3::Zero()), along(static_cast<size_t>(nb), Vec3::Zero());
  std::vector<double> edge(static_cast<size_t>(nb), 0.0);
  std::vector<int> edges(static_cast<size_t>(nb), 0);
  std::vector<char> ends(static_cast<size_t>(nb), 0);
  for (Eigen::Index q = 0; q < Q.rows(); ++q) {
    Vec3 c[4];
    for (int k = 0; k < 4; ++k) c[k] = out.V.row(Q(q, k)).transpose();
    const Vec3 n = 0.5 * (c[2] - c[0]).cross(c[3] - c[1]);
    for (int k = 0; k < 4; ++k) {
      if (inner[size_t(Q(q, k))] < 0) continue;
      const size_t b = size_t(inner[size_t(Q(q, k))] - nv);
      if (!padded[size_t(q)]) {
        ends[b] = 1;
        continue;
      }
      normal[b] += n;
      edge[b] += (c[(k + 1) % 4] - c[k]).norm() + (c[(k + 3) % 4] - c[k]).norm();
      edges[b] += 2;
    }
  }
  if (layer < Q.rows()) {
    std::vector<BoundaryEdge> own;
    const std::vector<BoundaryEdge>& bedges = q_edges ? *q_edges : (own = quad_edges(mesh, Q));
    // the layer's end through a vertex: its first end edge's direction minus its second's (length 2 where the
    // end runs straight through the vertex, about 1.4 where it turns by 90 degrees)
    std::vector<Vec3> end_tangent(static_cast<size_t>(nb), Vec3::Zero());
    for (const BoundaryEdge& e : bedges)
      if (e.quads == 2 && padded[size_t(e.q0)] != padded[size_t(e.q1)])
        for (auto [v, w] : {std::pair{e.a, e.b}, std::pair{e.b, e.a}})
          if (inner[size_t(v)] >= 0) {
            const size_t b = size_t(inner[size_t(v)] - nv);
            const Vec3 d = (out.V.row(w) - out.V.row(v)).transpose().normalized();
            end_tangent[b] = end_tangent[b].isZero() ? d : Vec3(end_tangent[b] - d);  // first minus second
          }
    // edges between two unpadded quads, from a vertex where the layer ends, across the end (their part along
    // the end removed: where the lattice is sheared they run slanted to it)
    for (const BoundaryEdge& e : bedges)
      if (e.quads == 2 && !padded[size_t(e.q0)] && !padded[size_t(e.q1)])
        for (auto [v, w] : {std::pair{e.a, e.b}, std::pair{e.b, e.a}})
          if (inner[size_t(v)] >= 0) {
            const size_t b = size_t(inner[size_t(v)] - nv);
            Vec3 d = (out.V.row(w) - out.V.row(v)).transpose().normalized();
            const double t = end_tangent[b].norm();
            if (t > 0.5) d -= d.dot(end_tangent[b] / t) * (end_tangent[b] / t);
            along[b] += d;
          }
    for (Eigen::Index q = 0; q < Q.rows(); ++q)  // a vertex whose unpadded side is one quad: its diagonal
      for (int k = 0; k < 4; ++k) {
        const int v = Q(q, k);
        if (padded[size_t(q)] || inner[size_t(v)] < 0) continue;
        const size_t b = size_t(inner[size_t(v)] - nv);
        if (along[b].isZero()) along[b] = (out.V.row(Q(q, (k + 2) % 4)) - out.V.row(v)).transpose().normalized();
      }
  }
  std::vector<Vec3> offset(static_cast<size_t>(nb));
  for (size_t b = 0; b < size_t(nb); ++b) {
    const Vec3 dir = ends[b] ? along[b] : Vec3(-normal[b]);
    const double len = dir.norm();
    offset[b] = len > 0 ? Vec3(dir / len * p.thickness * edge[b] / std::max(edges[b], 1)) : Vec3::Zero();
    st.layer_ends += ends[b];
  }
  // the inner copy of vertex v at `fraction` of its offset (on the surface where the layer ends)
  auto place = [&](Eigen::Index v, double fraction) {
    const size_t b = size_t(inner[size_t(v)] - nv);
    Vec3 x = out.V.row(v).transpose() + fraction * offset[b];
    if (ends[b] && tree) x = tree->closest(x).point;
    out.V.row(inner[size_t(v)]) = x.transpose();
  };
  for (Eigen::Index v = 0; v < nv; ++v)
    if (inner[size_t(v)] >= 0) place(v, 1.0);

  // hexes: the old ones on the inner copies, then one per padded boundary quad (inner quad at the bottom)
  out.H.resize(nh + layer, 8);
  for (Eigen::Index h = 0; h < nh; ++h)
    for (int k = 0; k < 8; ++k) {
      const int v = mesh.H(h, k);
      out.H(h, k) = inner[size_t(v)] >= 0 ? inner[size_t(v)] : v;
    }
  for (Eigen::Index q = 0, r = nh; q < Q.rows(); ++q) {
    if (!padded[size_t(q)]) continue;
    for (int k = 0; k < 4; ++k) {
      out.H(r, k) = inner[size_t(Q(q, k))];
      out.H(r, k + 4) = Q(q, k);
    }
    ++r;
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
      place(v, scale[size_t(b)]);
    }
  }
  for (double s : scale) st.limited += s < 1.0;
  if (thin_ends)
    for (Eigen::Index v = 0; v < nv; ++v)
      if (inner[size_t(v)] >= 0 && ends[size_t(inner[size_t(v)] - nv)] && scale[size_t(inner[size_t(v)] - nv)] < 0.25)
        thin_ends->push_back(int(v));
  st.hexes_added += long(layer);
  st.vertices_added += nb;
  layer_hex.resize(size_t(out.H.rows()), 1);
  return out;
}

/// Selective padding stops after this many layers: the last one takes every quad that still needs one.
constexpr int kMaxLayers = 4;
/// A layer whose ends had to be cut thin is made again, grown round them, at most this many times.
constexpr int kEndRetries = 3;

}  // namespace

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
  std::unique_ptr<TriangleTree> tree;
  if (surface) tree = std::make_unique<TriangleTree>(surface->V, surface->F);
  std::vector<char> layer_hex(size_t(mesh.H.rows()), 0);
  if (!p.selective) {
    mesh = extrude_layer(mesh, Q, std::vector<char>(size_t(Q.rows()), 1), tree.get(), p, st, layer_hex);
    st.layers = 1;
  } else {
    for (int round = 0; round < kMaxLayers; ++round) {
      std::vector<int> owner;
      const auto B = hex_boundary_quads(mesh, &owner);
      const LayerPlan plan(mesh, B, p.turn_tolerance);
      std::vector<char> pad = plan.seeds();
      for (size_t q = 0; q < pad.size(); ++q)  // a quad on a layer hex has had its layer
        pad[q] = pad[q] && !layer_hex[size_t(owner[q])];
      plan.close(pad);
      if (std::find(pad.begin(), pad.end(), 1) == pad.end()) break;
      if (p.split_parts && round + 1 < kMaxLayers) pad = plan.first_layer(pad);
      // where the lattice is sheared along the end, the end's inner copies cannot slide along the other side
      // without turning its hexes over: the layer takes the quads round such a vertex too, and is made again
      for (int attempt = 0;; ++attempt) {
        PadStats trial = st;
        std::vector<char> trial_hex = layer_hex;
        std::vector<int> thin;
        HexMesh next = extrude_layer(mesh, B, pad, tree.get(), p, trial, trial_hex, &thin, &plan.edges());
        if (thin.empty() || attempt == kEndRetries) {
          mesh = std::move(next), st = trial, layer_hex = std::move(trial_hex);
          break;
        }
        for (Eigen::Index q = 0; q < B.rows(); ++q)
          for (int k = 0; k < 4; ++k)
            if (std::binary_search(thin.begin(), thin.end(), B(q, k))) pad[size_t(q)] = 1;
        plan.close(pad);
      }
      ++st.layers;
    }
    if (st.layers == 0 && tree)  // no layer: the boundary vertices still go onto the surface
      for (Eigen::Index q = 0; q < Q.rows(); ++q)
        for (int k = 0; k < 4; ++k)
          mesh.V.row(Q(q, k)) = tree->closest(mesh.V.row(Q(q, k)).transpose()).point.transpose();
  }
  std::vector<int> owner;
  const auto R = hex_boundary_quads(mesh, &owner);
  for (Eigen::Index q = 0; q < R.rows(); ++q) st.unpadded += !layer_hex[size_t(owner[size_t(q)])];
  Eigen::VectorXd sj, corner;
  hex_scaled_jacobians(mesh, sj, corner);
  st.inverted = long((corner.array() <= 0).count());
  st.seconds = seconds_since(t0);
  if (stats) *stats = st;
  return mesh;
}

}  // namespace polyhex
