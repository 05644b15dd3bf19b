#include "nodes/hex_from_tets/split.h"

#include "runtime/errors.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <array>
#include <cmath>
#include <string>
#include <vector>

namespace polyhex {

namespace {

// For tet corner c, the other three corners (a, b, d) in an order with (a-c)x(b-c).(d-c) > 0: each
// row with its corner is an even permutation of 0 1 2 3, so it keeps the tet's positive orientation.
constexpr int kCornerFrame[4][3] = {{1, 2, 3}, {0, 3, 2}, {3, 0, 1}, {2, 1, 0}};
// Local edges and faces of a tet.
constexpr int kTetEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
constexpr int kTetFaces[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};  // face f omits corner f

int local_edge(int i, int j) {
  if (i > j) std::swap(i, j);
  for (int e = 0; e < 6; ++e)
    if (kTetEdges[e][0] == i && kTetEdges[e][1] == j) return e;
  return -1;
}
// The local face through corners i, j, k is the one omitting the fourth corner.
int local_face(int i, int j, int k) { return 6 - i - j - k; }

// Gives every distinct key (sorted vertex tuple) an index; ids[r] = index of key r, returns the count.
template <size_t N>
int number_distinct(const std::vector<std::array<int, N>>& keys, std::vector<int>& ids) {
  std::vector<std::pair<std::array<int, N>, int>> order(keys.size());
  for (size_t r = 0; r < keys.size(); ++r) order[r] = {keys[r], int(r)};
  tbb::parallel_sort(order.begin(), order.end());
  ids.assign(keys.size(), -1);
  int n = -1;
  for (size_t i = 0; i < order.size(); ++i) {
    if (i == 0 || order[i].first != order[i - 1].first) ++n;
    ids[size_t(order[i].second)] = n;
  }
  return n + 1;
}

void check_tets(const TetMesh& m) {
  const std::string name = m.source.empty() ? std::string("tet mesh") : m.source;
  if (m.T.rows() == 0) throw InvalidInput(name + ": no tetrahedra");
  for (Eigen::Index i = 0; i < m.V.size(); ++i)
    if (!std::isfinite(m.V.data()[i]))
      throw InvalidInput(name + ": vertex " + std::to_string(i / 3) + " has a non-finite coordinate");
  for (Eigen::Index t = 0; t < m.T.rows(); ++t) {
    for (int k = 0; k < 4; ++k)
      if (m.T(t, k) < 0 || m.T(t, k) >= m.V.rows())
        throw InvalidInput(name + ": tet " + std::to_string(t) + ": vertex index " + std::to_string(m.T(t, k)) +
                           " out of range (" + std::to_string(m.V.rows()) + " vertices)");
    const Eigen::Vector3d p0 = m.V.row(m.T(t, 0));
    const double vol6 = (m.V.row(m.T(t, 1)).transpose() - p0)
                            .cross(m.V.row(m.T(t, 2)).transpose() - p0)
                            .dot(m.V.row(m.T(t, 3)).transpose() - p0);
    if (!(vol6 > 0))
      throw InvalidInput(name + ": tet " + std::to_string(t) + " is " + (vol6 < 0 ? "inverted" : "degenerate") +
                         " (6 x volume = " + std::to_string(vol6) + ")");
  }
}

}  // namespace

HexMesh split_tets_to_hexes(const TetMesh& tets) {
  check_tets(tets);
  const Eigen::Index nt = tets.T.rows(), nv = tets.V.rows();

  std::vector<std::array<int, 2>> edge_keys(size_t(nt) * 6);
  std::vector<std::array<int, 3>> face_keys(size_t(nt) * 4);
  for (Eigen::Index t = 0; t < nt; ++t) {
    for (int e = 0; e < 6; ++e) {
      std::array<int, 2> k{tets.T(t, kTetEdges[e][0]), tets.T(t, kTetEdges[e][1])};
      std::sort(k.begin(), k.end());
      edge_keys[size_t(t) * 6 + e] = k;
    }
    for (int f = 0; f < 4; ++f) {
      std::array<int, 3> k{tets.T(t, kTetFaces[f][0]), tets.T(t, kTetFaces[f][1]), tets.T(t, kTetFaces[f][2])};
      std::sort(k.begin(), k.end());
      face_keys[size_t(t) * 4 + f] = k;
    }
  }
  std::vector<int> edge_id, face_id;
  const int ne = number_distinct(edge_keys, edge_id);
  const int nf = number_distinct(face_keys, face_id);

  HexMesh out;
  out.source = tets.source;
  const Eigen::Index edge0 = nv, face0 = nv + ne, cell0 = nv + ne + nf;
  out.V.resize(cell0 + nt, 3);
  out.V.topRows(nv) = tets.V;
  // A shared edge or face gets the same point from each of its tets (same vertices, same formula
  // up to order of summation); the last writer wins, which is harmless.
  for (size_t r = 0; r < edge_keys.size(); ++r)
    out.V.row(edge0 + edge_id[r]) = 0.5 * (tets.V.row(edge_keys[r][0]) + tets.V.row(edge_keys[r][1]));
  for (size_t r = 0; r < face_keys.size(); ++r)
    out.V.row(face0 + face_id[r]) =
        (tets.V.row(face_keys[r][0]) + tets.V.row(face_keys[r][1]) + tets.V.row(face_keys[r][2])) / 3.0;

  out.H.resize(4 * nt, 8);
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, nt), [&](const tbb::blocked_range<Eigen::Index>& range) {
    for (Eigen::Index t = range.begin(); t < range.end(); ++t) {
      out.V.row(cell0 + t) = 0.25 * (tets.V.row(tets.T(t, 0)) + tets.V.row(tets.T(t, 1)) + tets.V.row(tets.T(t, 2)) +
                                     tets.V.row(tets.T(t, 3)));
      auto mid = [&](int i, int j) { return int(edge0) + edge_id[size_t(t) * 6 + size_t(local_edge(i, j))]; };
      auto centre = [&](int i, int j, int k) {
        return int(face0) + face_id[size_t(t) * 4 + size_t(local_face(i, j, k))];
      };
      for (int c = 0; c < 4; ++c) {
        const int a = kCornerFrame[c][0], b = kCornerFrame[c][1], d = kCornerFrame[c][2];
        // The unit cube at corner c: x along c->a, y along c->b, z along c->d (VTK_HEXAHEDRON order).
        out.H.row(4 * t + c) << tets.T(t, c), mid(c, a), centre(c, a, b), mid(c, b), mid(c, d), centre(c, a, d),
            int(cell0 + t), centre(c, b, d);
      }
    }
  });
  return out;
}

}  // namespace polyhex
