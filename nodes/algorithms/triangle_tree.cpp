#include "nodes/algorithms/triangle_tree.h"

#include "runtime/errors.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>

namespace polyhex {

Eigen::Vector3d closest_on_segment(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double len2 = ab.squaredNorm();
  if (!(len2 > 0)) return a;
  const double t = std::clamp((p - a).dot(ab) / len2, 0.0, 1.0);
  return a + t * ab;
}

namespace {

Eigen::Vector3d closest_on_edges(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                 const Eigen::Vector3d& c) {
  Eigen::Vector3d best = closest_on_segment(p, a, b);
  for (const Eigen::Vector3d& q : {closest_on_segment(p, b, c), closest_on_segment(p, c, a)})
    if ((q - p).squaredNorm() < (best - p).squaredNorm()) best = q;
  return best;
}

constexpr int kLeafSize = 4;

}  // namespace

Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                          const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a;
  // A triangle without area has no interior region: its closest point lies on an edge, and the
  // barycentric divisions below would divide by zero.
  const double area2 = ab.cross(ac).squaredNorm();
  if (!(area2 > 1e-24 * ab.squaredNorm() * ac.squaredNorm())) return closest_on_edges(p, a, b, c);

  const Eigen::Vector3d ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + (d1 / (d1 - d3)) * ab;
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

TriangleTree::TriangleTree(const RowMatrixX3d& V, const RowMatrixX3i& F) {
  const int nf = int(F.rows()), nv = int(V.rows());
  if (nf == 0) throw InvalidInput("triangle tree: no triangles");
  for (int f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k)
      if (F(f, k) < 0 || F(f, k) >= nv)
        throw InvalidInput("triangle " + std::to_string(f) + ": vertex index " + std::to_string(F(f, k)) +
                           " out of range (" + std::to_string(nv) + " vertices)");
  std::vector<Eigen::Vector3d> centroid(nf);
  a_.resize(nf);
  b_.resize(nf);
  c_.resize(nf);
  id_.resize(nf);
  std::iota(id_.begin(), id_.end(), 0);
  for (int f = 0; f < nf; ++f) {
    a_[f] = V.row(F(f, 0)).transpose();
    b_[f] = V.row(F(f, 1)).transpose();
    c_[f] = V.row(F(f, 2)).transpose();
    centroid[f] = (a_[f] + b_[f] + c_[f]) / 3.0;
  }
  nodes_.reserve(2 * (nf / kLeafSize + 1));
  build(0, nf, centroid);
  // Store the corners in tree order so that a leaf reads contiguous memory.
  std::vector<Eigen::Vector3d> a(nf), b(nf), c(nf);
  for (int i = 0; i < nf; ++i) {
    a[i] = a_[id_[i]];
    b[i] = b_[id_[i]];
    c[i] = c_[id_[i]];
  }
  a_.swap(a);
  b_.swap(b);
  c_.swap(c);
}

// Builds the subtree over triangles [begin, end) of id_ and returns its node index.
int TriangleTree::build(int begin, int end, const std::vector<Eigen::Vector3d>& centroid) {
  const int self = int(nodes_.size());
  nodes_.emplace_back();
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  Eigen::Vector3d clo = lo, chi = hi;
  for (int i = begin; i < end; ++i) {
    const int f = id_[i];
    lo = lo.cwiseMin(a_[f]).cwiseMin(b_[f]).cwiseMin(c_[f]);
    hi = hi.cwiseMax(a_[f]).cwiseMax(b_[f]).cwiseMax(c_[f]);
    clo = clo.cwiseMin(centroid[f]);
    chi = chi.cwiseMax(centroid[f]);
  }
  nodes_[self].lo = lo;
  nodes_[self].hi = hi;
  nodes_[self].begin = begin;
  nodes_[self].end = end;
  if (end - begin <= kLeafSize) return self;
  int axis;
  (chi - clo).maxCoeff(&axis);
  const int mid = begin + (end - begin) / 2;
  std::nth_element(id_.begin() + begin, id_.begin() + mid, id_.begin() + end,
                   [&](int x, int y) { return centroid[x][axis] < centroid[y][axis]; });
  const int left = build(begin, mid, centroid);
  const int right = build(mid, end, centroid);
  nodes_[self].left = left;  // nodes_ may have reallocated: index, do not hold references
  nodes_[self].right = right;
  return self;
}

double TriangleTree::box_sq_distance(const Node& n, const Eigen::Vector3d& p) {
  const Eigen::Vector3d d = (n.lo - p).cwiseMax(p - n.hi).cwiseMax(0.0);
  return d.squaredNorm();
}

TriangleTree::Hit TriangleTree::closest(const Eigen::Vector3d& p) const {
  Hit best{std::numeric_limits<double>::infinity(), -1, Eigen::Vector3d::Zero()};
  // Depth-first, nearer child first, pruning boxes farther than the best hit so far.
  int stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& n = nodes_[stack[--top]];
    if (box_sq_distance(n, p) >= best.sq_distance) continue;
    if (n.left < 0) {
      for (int i = n.begin; i < n.end; ++i) {
        const Eigen::Vector3d q = closest_point_on_triangle(p, a_[i], b_[i], c_[i]);
        const double d2 = (q - p).squaredNorm();
        if (d2 < best.sq_distance) best = Hit{d2, id_[i], q};
      }
      continue;
    }
    const double dl = box_sq_distance(nodes_[n.left], p), dr = box_sq_distance(nodes_[n.right], p);
    if (dl <= dr) {
      if (dr < best.sq_distance) stack[top++] = n.right;
      if (dl < best.sq_distance) stack[top++] = n.left;
    } else {
      if (dl < best.sq_distance) stack[top++] = n.left;
      if (dr < best.sq_distance) stack[top++] = n.right;
    }
  }
  return best;
}

double TriangleTree::distance(const Eigen::Vector3d& p) const { return std::sqrt(closest(p).sq_distance); }

std::pair<double, int> TriangleTree::first_crossing(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                                                    double t_min) const {
  double best = std::numeric_limits<double>::infinity();
  int hit = -1;
  const Eigen::Vector3d inv = d.cwiseInverse();  // +-inf on a zero component: the slabs below stay exact
  // the ray's parameter interval inside a node's box (slab test), empty when it misses or lies beyond `best`
  const auto enters = [&](const Node& n) {
    double lo = t_min, hi = best;
    for (int k = 0; k < 3; ++k) {
      if (d[k] == 0) {
        if (o[k] < n.lo[k] || o[k] > n.hi[k]) return false;
        continue;
      }
      double t0 = (n.lo[k] - o[k]) * inv[k], t1 = (n.hi[k] - o[k]) * inv[k];
      if (t0 > t1) std::swap(t0, t1);
      lo = std::max(lo, t0);
      hi = std::min(hi, t1);
    }
    return lo <= hi;
  };
  int stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& n = nodes_[stack[--top]];
    if (!enters(n)) continue;
    if (n.left >= 0) {
      stack[top++] = n.right;
      stack[top++] = n.left;
      continue;
    }
    for (int i = n.begin; i < n.end; ++i) {
      const Eigen::Vector3d e1 = b_[i] - a_[i], e2 = c_[i] - a_[i], p = d.cross(e2);
      const double det = e1.dot(p);
      if (!(std::abs(det) > 1e-300)) continue;
      const Eigen::Vector3d s = o - a_[i], q = s.cross(e1);
      const double u = s.dot(p) / det, v = d.dot(q) / det, t = e2.dot(q) / det;
      if (u < 0 || v < 0 || u + v > 1 || !(t > t_min) || !(t < best)) continue;
      best = t;
      hit = id_[i];
    }
  }
  return {best, hit};
}

}  // namespace polyhex
