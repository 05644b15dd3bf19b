// Hex mesh generation from a PolyCube map (paper §6). See hex_extract.h for the method.
#include "nodes/hex_extract/hex_extract.h"

#include "nodes/algorithms/hex_quality.h"
#include "runtime/cancel.h"
#include "runtime/errors.h"
#include "runtime/stopwatch.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace polyhex {
namespace {

using Vec3 = Eigen::Vector3d;
using Int3 = std::array<int, 3>;

enum Kind { kCorner = 0, kEdge = 1, kFacet = 2, kVolume = 3 };

constexpr std::int64_t kOff = std::int64_t(1) << 20;

std::uint64_t key_of(const Int3& q) {
  return (std::uint64_t(q[0] + kOff) << 42) | (std::uint64_t(q[1] + kOff) << 21) | std::uint64_t(q[2] + kOff);
}

// Lattice corner offsets of a hex in VTK_HEXAHEDRON order: bottom 0-1-2-3 (z = 0), top 4-5-6-7.
constexpr int kHexOffset[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                  {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};

/// A kept hex vertex.
struct LVertex {
  Int3 q;                     ///< lattice point
  Vec3 X;                     ///< position in the input
  int kind;                   ///< Kind
  int labels;                 ///< bit l set: lies on a chart with direction label l
  std::array<int, 4> anchor;  ///< input vertices of the simplex it lies in (-1 padded)
};

/// A candidate point in a simplex: lattice point, mapped position, orientation of the simplex in the
/// lattice (+1 / -1), how deep inside it is (min barycentric), the simplex.
struct Candidate {
  std::uint64_t key;
  Int3 q;
  Vec3 X;
  int sign;
  double depth;
  int simplex;
};

double orient(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) { return (b - a).dot((c - a).cross(d - a)); }

class Extractor {
 public:
  Extractor(const PolyCubeMap& map, const HexExtractParams& p, HexExtractStats& st)
      : map_(map), p_(p), st_(st), V_(map.input->V), T_(map.input->T), seg_(*map.segmentation) {
    h_ = map.edge_length;
    P_ = map.U / h_;
    dup_ = p.duplicate_distance * h_;
    delta_ = Vec3(1.0, 0.7071067811865476, 0.5773502691896258) * p.perturbation;
  }

  HexMesh run() {
    // safe points between the phases (and inside the long ones): nothing is shared outside
    throw_if_interrupted();
    place_corners();
    place_edges();
    throw_if_interrupted();
    place_facets();
    throw_if_interrupted();
    place_volume();
    throw_if_interrupted();
    return form_hexes();
  }

 private:
  // ------------------------------------------------------------------------------------------
  // vertex bookkeeping

  /// The index of a vertex at q mapped within dup_ of X, or -1.
  int duplicate_of(const Int3& q, const Vec3& X) const {
    auto it = at_.find(key_of(q));
    if (it == at_.end()) return -1;
    for (int v : it->second)
      if ((verts_[size_t(v)].X - X).norm() < dup_) return v;
    return -1;
  }

  void add_vertex(const Int3& q, const Vec3& X, int kind, int labels, std::array<int, 4> anchor) {
    if (duplicate_of(q, X) >= 0) {
      ++st_.dropped_duplicate;
      return;
    }
    at_[key_of(q)].push_back(int(verts_.size()));
    verts_.push_back(LVertex{q, X, kind, labels, anchor});
    long* count[4] = {&st_.corner_vertices, &st_.edge_vertices, &st_.facet_vertices, &st_.volume_vertices};
    ++*count[kind];
  }

  Vec3 P(int v) const { return P_.row(v).transpose(); }
  Vec3 X(int v) const { return V_.row(v).transpose(); }

  // ------------------------------------------------------------------------------------------
  // §6: corners, then edges, then facets, then volume

  void place_corners() {
    for (const auto& c : seg_.corners) {
      int labels = 0, axes = 0;
      for (int ch : c.charts) {
        const int l = seg_.charts[size_t(ch)].label;
        labels |= 1 << l;
        axes |= 1 << label_axis(l);
      }
      if (axes != 7) continue;  // not on three planes: its edges carry it
      const Vec3 pc = P(c.vertex);
      Int3 q;
      bool integer = true;
      for (int a = 0; a < 3; ++a) {
        q[size_t(a)] = int(std::lround(pc[a]));
        integer = integer && std::abs(pc[a] - q[size_t(a)]) < 1e-6;
      }
      if (integer) add_vertex(q, X(c.vertex), kCorner, labels, {c.vertex, -1, -1, -1});
    }
  }

  void place_edges() {
    for (const auto& e : seg_.edges) {
      const int la = seg_.charts[size_t(e.chart_a)].label, lb = seg_.charts[size_t(e.chart_b)].label;
      const int a1 = label_axis(la), a2 = label_axis(lb);
      if (a1 == a2 || e.vertices.size() < 2) continue;
      const int c = 3 - a1 - a2;
      const int labels = (1 << la) | (1 << lb);
      const size_t n = e.vertices.size(), segments = e.closed ? n : n - 1;
      for (size_t s = 0; s < segments; ++s) {
        const int u = e.vertices[s], w = e.vertices[(s + 1) % n];
        const Vec3 pu = P(u), pw = P(w);
        const double lo = std::min(pu[c], pw[c]), hi = std::max(pu[c], pw[c]);
        for (long k = long(std::ceil(lo - 1e-9)); k <= long(std::floor(hi + 1e-9)); ++k) {
          const double len = pw[c] - pu[c];
          const double t = std::abs(len) < 1e-12 ? 0.0 : std::clamp((double(k) - pu[c]) / len, 0.0, 1.0);
          Int3 q;
          q[size_t(a1)] = int(std::lround((1 - t) * pu[a1] + t * pw[a1]));
          q[size_t(a2)] = int(std::lround((1 - t) * pu[a2] + t * pw[a2]));
          q[size_t(c)] = int(k);
          std::array<int, 4> anchor{u, w, -1, -1};
          if (t < 1e-12) anchor = {u, -1, -1, -1};
          if (t > 1 - 1e-12) anchor = {w, -1, -1, -1};
          add_vertex(q, (1 - t) * X(u) + t * X(w), kEdge, labels, anchor);
        }
      }
    }
  }

  /// Clusters the candidates of one lattice point by mapped position; per cluster: degree <= 0 is a
  /// conflict, otherwise the deepest positive candidate is returned through `accept`.
  template <class Accept>
  void resolve(std::vector<Candidate>::iterator first, std::vector<Candidate>::iterator last, Accept accept) {
    // deepest positive candidates first, so they seed the clusters
    std::sort(first, last, [](const Candidate& a, const Candidate& b) {
      if (a.sign != b.sign) return a.sign > b.sign;
      if (a.depth != b.depth) return a.depth > b.depth;
      return a.simplex < b.simplex;  // a total order: equal depths resolve the same way every run
    });
    std::vector<char> taken(size_t(last - first), 0);
    for (auto seed = first; seed != last; ++seed) {
      if (taken[size_t(seed - first)]) continue;
      int degree = 0;
      for (auto it = seed; it != last; ++it)
        if (!taken[size_t(it - first)] && (it->X - seed->X).norm() < dup_) {
          taken[size_t(it - first)] = 1;
          degree += it->sign;
        }
      if (degree <= 0 || seed->sign < 0) {
        ++st_.dropped_conflict;
        continue;
      }
      accept(*seed);
    }
  }

  void place_facets() {
    const Eigen::Index nc = Eigen::Index(seg_.charts.size());
    if (map_.chart_plane.size() != nc)
      throw InvalidInput("PolyCube map: " + std::to_string(map_.chart_plane.size()) + " chart planes for " +
                         std::to_string(nc) + " charts");
    std::vector<std::vector<int>> tris(static_cast<size_t>(nc));
    for (Eigen::Index f = 0; f < seg_.F.rows(); ++f) tris[size_t(seg_.chart[f])].push_back(int(f));
    for (Eigen::Index c = 0; c < nc; ++c) {
      throw_if_interrupted();
      const int label = seg_.charts[size_t(c)].label, a = label_axis(label), s = label_sign(label);
      const int u = (a + 1) % 3, w = (a + 2) % 3;
      const int plane = map_.chart_plane[c];
      std::vector<Candidate> cand;
      for (int f : tris[size_t(c)]) {
        std::array<int, 3> vi = {seg_.F(f, 0), seg_.F(f, 1), seg_.F(f, 2)};
        Eigen::Vector2d p2[3];
        for (int k = 0; k < 3; ++k) {
          const Vec3 pk = P(vi[size_t(k)]);
          if (std::abs(pk[a] - plane) > 1e-6)
            throw InvalidInput("PolyCube map: vertex " + std::to_string(vi[size_t(k)]) + " of chart " +
                               std::to_string(c) + " (" + label_name(label) + ") is at " + std::to_string(pk[a]) +
                               " h, not on the chart plane " + std::to_string(plane) + " h");
          p2[k] = Eigen::Vector2d(pk[u], pk[w]);
        }
        auto cross2 = [](const Eigen::Vector2d& x, const Eigen::Vector2d& y) { return x.x() * y.y() - x.y() * y.x(); };
        const double area2 = cross2(p2[1] - p2[0], p2[2] - p2[0]);
        if (std::abs(area2) < 1e-14) continue;
        const int sign = (area2 > 0 ? 1 : -1) * s;  // CCW in (u, w) faces +a; the chart faces s·a
        const Eigen::Vector2d lo = p2[0].cwiseMin(p2[1]).cwiseMin(p2[2]), hi = p2[0].cwiseMax(p2[1]).cwiseMax(p2[2]);
        for (long i = long(std::ceil(lo.x() - 1e-6)); i <= long(std::floor(hi.x() + 1e-6)); ++i)
          for (long j = long(std::ceil(lo.y() - 1e-6)); j <= long(std::floor(hi.y() + 1e-6)); ++j) {
            const Eigen::Vector2d x(double(i) + delta_.x(), double(j) + delta_.y());
            const double b0 = cross2(p2[1] - x, p2[2] - x) / area2, b1 = cross2(p2[2] - x, p2[0] - x) / area2,
                         b2 = cross2(p2[0] - x, p2[1] - x) / area2;
            if (b0 < 0 || b1 < 0 || b2 < 0) continue;
            Candidate cd;
            cd.q[size_t(a)] = plane;
            cd.q[size_t(u)] = int(i);
            cd.q[size_t(w)] = int(j);
            cd.key = key_of(cd.q);
            // mapped position from the unperturbed point (the perturbation only breaks ties)
            const Eigen::Vector2d x0 = Eigen::Vector2d(double(i), double(j));
            const double c0 = cross2(p2[1] - x0, p2[2] - x0) / area2, c1 = cross2(p2[2] - x0, p2[0] - x0) / area2;
            cd.X = c0 * X(vi[0]) + c1 * X(vi[1]) + (1 - c0 - c1) * X(vi[2]);
            cd.sign = sign;
            cd.depth = std::min({b0, b1, b2});
            cd.simplex = f;
            cand.push_back(cd);
          }
      }
      for_each_point(cand, [&](const Candidate& cd) {
        const int f = cd.simplex;
        add_vertex(cd.q, cd.X, kFacet, 1 << label, {seg_.F(f, 0), seg_.F(f, 1), seg_.F(f, 2), -1});
      });
    }
  }

  /// Groups candidates by lattice point and resolves each group.
  template <class Accept>
  void for_each_point(std::vector<Candidate>& cand, Accept accept) {
    // (lattice point, simplex) is unique: the order, and so the resolution of each group, does not
    // depend on the order the (parallel) rasterisation produced the candidates in, nor on the sort's.
    tbb::parallel_sort(cand.begin(), cand.end(), [](const Candidate& a, const Candidate& b) {
      return a.key != b.key ? a.key < b.key : a.simplex < b.simplex;
    });
    for (size_t i = 0; i < cand.size();) {
      size_t j = i;
      while (j < cand.size() && cand[j].key == cand[i].key) ++j;
      resolve(cand.begin() + long(i), cand.begin() + long(j), accept);
      i = j;
    }
  }

  /// Every tet visits the lattice points (offset by `shift`) of its bounding box.
  std::vector<Candidate> rasterise(double shift) const {
    tbb::enumerable_thread_specific<std::vector<Candidate>> local;
    std::atomic<long> exploded{0};
    const Vec3 off = Vec3::Constant(shift) + delta_;
    tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, T_.rows(), 2048), [&](const auto& r) {
      throw_if_interrupted();
      auto& out = local.local();
      for (Eigen::Index t = r.begin(); t < r.end(); ++t) {
        const Vec3 p[4] = {P(T_(t, 0)), P(T_(t, 1)), P(T_(t, 2)), P(T_(t, 3))};
        const double vol = orient(p[0], p[1], p[2], p[3]);
        if (std::abs(vol) < 1e-14) continue;
        const Vec3 lo = p[0].cwiseMin(p[1]).cwiseMin(p[2]).cwiseMin(p[3]) - off;
        const Vec3 hi = p[0].cwiseMax(p[1]).cwiseMax(p[2]).cwiseMax(p[3]) - off;
        const Vec3 span = (hi - lo).array().floor() + 1;
        if (!(span.prod() <= kMaxLatticePointsPerTet)) {
          ++exploded;
          continue;
        }
        for (long i = long(std::ceil(lo.x())); i <= long(std::floor(hi.x())); ++i)
          for (long j = long(std::ceil(lo.y())); j <= long(std::floor(hi.y())); ++j)
            for (long k = long(std::ceil(lo.z())); k <= long(std::floor(hi.z())); ++k) {
              const Vec3 x = Vec3(double(i), double(j), double(k)) + off;
              const double b[4] = {orient(x, p[1], p[2], p[3]) / vol, orient(p[0], x, p[2], p[3]) / vol,
                                   orient(p[0], p[1], x, p[3]) / vol, orient(p[0], p[1], p[2], x) / vol};
              if (b[0] < 0 || b[1] < 0 || b[2] < 0 || b[3] < 0) continue;
              Candidate cd;
              cd.q = {int(i), int(j), int(k)};
              cd.key = key_of(cd.q);
              // mapped position from the unperturbed point (the perturbation only breaks ties)
              const Vec3 x0 = x - delta_;
              const double c[3] = {orient(x0, p[1], p[2], p[3]) / vol, orient(p[0], x0, p[2], p[3]) / vol,
                                   orient(p[0], p[1], x0, p[3]) / vol};
              cd.X =
                  c[0] * X(T_(t, 0)) + c[1] * X(T_(t, 1)) + c[2] * X(T_(t, 2)) + (1 - c[0] - c[1] - c[2]) * X(T_(t, 3));
              cd.sign = vol > 0 ? 1 : -1;
              cd.depth = std::min({b[0], b[1], b[2], b[3]});
              cd.simplex = int(t);
              out.push_back(cd);
            }
      }
    });
    std::vector<Candidate> all;
    for (auto& v : local) all.insert(all.end(), v.begin(), v.end());
    st_.exploded_tets = std::max(st_.exploded_tets, exploded.load());
    return all;
  }

  /// §6: a volume vertex next to a facet vertex, on the outer side of that facet's chart, conflicts
  /// with the PolyCube structure.
  bool outside_a_facet(const Int3& q, const Vec3& Xq) const {
    for (int b = 0; b < 3; ++b)
      for (int t : {1, -1}) {
        Int3 n = q;
        n[size_t(b)] -= t;
        auto it = at_.find(key_of(n));
        if (it == at_.end()) continue;
        const int label = 2 * b + (t > 0 ? 0 : 1);
        for (int v : it->second) {
          const LVertex& lv = verts_[size_t(v)];
          if (lv.kind == kFacet && lv.labels == (1 << label) && (lv.X - Xq).norm() < 2 * h_) return true;
        }
      }
    return false;
  }

  void place_volume() {
    std::vector<Candidate> cand = rasterise(0.0);
    for_each_point(cand, [&](const Candidate& cd) {
      if (duplicate_of(cd.q, cd.X) >= 0) {
        ++st_.dropped_duplicate;
        return;
      }
      if (outside_a_facet(cd.q, cd.X)) {
        ++st_.dropped_conflict;
        return;
      }
      add_vertex(cd.q, cd.X, kVolume, 0, {T_(cd.simplex, 0), T_(cd.simplex, 1), T_(cd.simplex, 2), T_(cd.simplex, 3)});
    });
  }

  // ------------------------------------------------------------------------------------------
  // hexes

  struct Centroid {
    Int3 q;   ///< lower corner of the unit cube
    Vec3 X;   ///< mapped centroid
    int tet;  ///< tet holding it
  };

  /// Face-adjacent tets: #T by 4, -1 on the boundary.
  std::vector<std::array<int, 4>> tet_neighbours() const {
    std::vector<std::array<int, 4>> nb(size_t(T_.rows()), {-1, -1, -1, -1});
    std::vector<std::pair<std::array<int, 3>, std::pair<int, int>>> faces;
    faces.reserve(size_t(T_.rows()) * 4);
    for (Eigen::Index t = 0; t < T_.rows(); ++t)
      for (int k = 0; k < 4; ++k) {
        std::array<int, 3> f;
        for (int m = 0, n = 0; m < 4; ++m)
          if (m != k) f[size_t(n++)] = T_(t, m);
        std::sort(f.begin(), f.end());
        faces.push_back({f, {int(t), k}});
      }
    std::sort(faces.begin(), faces.end());
    for (size_t i = 0; i + 1 < faces.size(); ++i)
      if (faces[i].first == faces[i + 1].first) {
        auto [t0, k0] = faces[i].second;
        auto [t1, k1] = faces[i + 1].second;
        nb[size_t(t0)][size_t(k0)] = t1;
        nb[size_t(t1)][size_t(k1)] = t0;
      }
    return nb;
  }

  HexMesh form_hexes() {
    std::vector<Centroid> centroids;
    {
      std::vector<Candidate> cand = rasterise(0.5);
      for_each_point(cand, [&](const Candidate& cd) { centroids.push_back(Centroid{cd.q, cd.X, cd.simplex}); });
    }
    st_.centroids = long(centroids.size());
    const auto nb = tet_neighbours();
    // each tet's box in the PolyCube (lower corner, upper corner), read by every search that reaches the tet
    std::vector<std::array<Vec3, 2>> box(size_t(T_.rows()));
    tbb::parallel_for(Eigen::Index(0), T_.rows(), [&](Eigen::Index t) {
      Vec3 tlo = P(T_(t, 0)), thi = tlo;
      for (int m = 1; m < 4; ++m) {
        tlo = tlo.cwiseMin(P(T_(t, m)));
        thi = thi.cwiseMax(P(T_(t, m)));
      }
      box[size_t(t)] = {tlo, thi};
    });

    struct Scratch {
      std::vector<int> tet_stamp, vert_stamp, queue;
      int stamp = 0;
    };
    tbb::enumerable_thread_specific<Scratch> scratch;
    std::vector<std::array<int, 8>> hex(centroids.size());
    std::vector<int> missing(centroids.size(), 0);
    tbb::parallel_for(size_t(0), centroids.size(), [&](size_t ci) {
      if (ci % 1024 == 0) throw_if_interrupted();
      Scratch& s = scratch.local();
      if (s.tet_stamp.empty()) {
        s.tet_stamp.assign(size_t(T_.rows()), 0);
        s.vert_stamp.assign(size_t(V_.rows()), 0);
      }
      const int stamp = ++s.stamp;
      const Centroid& c = centroids[ci];
      const double margin = p_.search_margin;
      const Vec3 lo = Vec3(c.q[0], c.q[1], c.q[2]) - Vec3::Constant(margin), hi = lo + Vec3::Constant(1 + 2 * margin);
      // breadth-first search over face-adjacent tets meeting the hex's unit cube (within the volume)
      s.queue.assign(1, c.tet);
      s.tet_stamp[size_t(c.tet)] = stamp;
      for (size_t head = 0; head < s.queue.size() && s.queue.size() < 20000; ++head) {
        const int t = s.queue[head];
        for (int k = 0; k < 4; ++k) s.vert_stamp[size_t(T_(t, k))] = stamp;
        for (int k = 0; k < 4; ++k) {
          const int n = nb[size_t(t)][size_t(k)];
          if (n < 0 || s.tet_stamp[size_t(n)] == stamp) continue;
          const auto& [tlo, thi] = box[size_t(n)];
          if ((tlo.array() > hi.array()).any() || (thi.array() < lo.array()).any()) continue;
          s.tet_stamp[size_t(n)] = stamp;
          s.queue.push_back(n);
        }
      }
      for (int k = 0; k < 8; ++k) {
        const Int3 q = {c.q[0] + kHexOffset[k][0], c.q[1] + kHexOffset[k][1], c.q[2] + kHexOffset[k][2]};
        int best = -1;
        double best_d = 0;
        auto it = at_.find(key_of(q));
        if (it != at_.end())
          for (int v : it->second) {
            const LVertex& lv = verts_[size_t(v)];
            bool reached = true;
            for (int a : lv.anchor) reached = reached && (a < 0 || s.vert_stamp[size_t(a)] == stamp);
            const double d = (lv.X - c.X).norm();
            if (reached && (best < 0 || d < best_d)) best = v, best_d = d;
          }
        hex[ci][size_t(k)] = best;
        if (best < 0) ++missing[ci];
      }
    });

    // keep complete, non-degenerate hexes, once each
    struct SortedCornersHash {
      size_t operator()(const std::array<int, 8>& c) const {
        std::uint64_t h = 0xcbf29ce484222325ULL;  // FNV-1a's, a word at a time
        for (int v : c) h = (h ^ std::uint32_t(v)) * 0x100000001b3ULL;
        return size_t(h);
      }
    };
    std::unordered_set<std::array<int, 8>, SortedCornersHash> seen;
    seen.reserve(hex.size());
    std::vector<std::array<int, 8>> kept;
    for (size_t ci = 0; ci < hex.size(); ++ci) {
      st_.unlocated += missing[ci];
      if (missing[ci] > 0) {
        ++st_.hexes_skipped;
        continue;
      }
      std::array<int, 8> sorted = hex[ci];
      std::sort(sorted.begin(), sorted.end());
      if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) {
        ++st_.hexes_skipped;
        continue;
      }
      if (!seen.insert(sorted).second) {
        ++st_.duplicate_hexes;
        continue;
      }
      kept.push_back(hex[ci]);
    }
    if (kept.empty())
      throw InvalidInput("PolyCube map of " + map_.input->source + ": no hex could be formed (" +
                         std::to_string(centroids.size()) + " centroids, h = " + std::to_string(h_) + ")");

    // compact: only the vertices the hexes use
    std::vector<int> index(verts_.size(), -1);
    HexMesh out;
    out.source = map_.input->source;
    out.H.resize(Eigen::Index(kept.size()), 8);
    int nv = 0;
    for (size_t i = 0; i < kept.size(); ++i)
      for (int k = 0; k < 8; ++k) {
        int& id = index[size_t(kept[i][size_t(k)])];
        if (id < 0) id = nv++;
        out.H(Eigen::Index(i), k) = id;
      }
    out.V.resize(nv, 3);
    for (size_t v = 0; v < verts_.size(); ++v)
      if (index[v] >= 0) out.V.row(index[v]) = verts_[v].X.transpose();
    st_.unused_vertices = long(verts_.size()) - nv;
    st_.hexes = long(kept.size());
    st_.vertices = nv;
    Eigen::VectorXd sj, corner;
    hex_scaled_jacobians(out, sj, corner);
    st_.inverted = long((corner.array() <= 0).count());
    return out;
  }

  const PolyCubeMap& map_;
  const HexExtractParams& p_;
  HexExtractStats& st_;
  const RowMatrixX3d& V_;
  const RowMatrixX4i& T_;
  const PolyCubeSegmentation& seg_;
  double h_ = 0, dup_ = 0;
  RowMatrixX3d P_;
  Vec3 delta_;
  std::vector<LVertex> verts_;
  std::unordered_map<std::uint64_t, std::vector<int>> at_;
};

void check_map(const PolyCubeMap& m) {
  if (!m.input) throw InvalidInput("PolyCube map: no input tet mesh");
  if (!m.segmentation) throw InvalidInput("PolyCube map of " + m.input->source + ": no segmentation");
  const std::string name = "PolyCube map of " + (m.input->source.empty() ? std::string("tet mesh") : m.input->source);
  if (!(m.edge_length > 0) || !std::isfinite(m.edge_length))
    throw InvalidInput(name + ": edge length " + std::to_string(m.edge_length) + " must be > 0");
  if (m.U.rows() != m.input->V.rows())
    throw InvalidInput(name + ": " + std::to_string(m.U.rows()) + " PolyCube positions for " +
                       std::to_string(m.input->V.rows()) + " vertices");
  if (m.input->T.rows() == 0) throw InvalidInput(name + ": no tets");
  if (!m.U.allFinite()) throw InvalidInput(name + ": a PolyCube position is not finite");
  const auto& s = *m.segmentation;
  if (s.chart.size() != s.F.rows())
    throw InvalidInput(name + ": segmentation has " + std::to_string(s.chart.size()) + " chart ids for " +
                       std::to_string(s.F.rows()) + " triangles");
  for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
    if (s.chart[f] < 0 || s.chart[f] >= Eigen::Index(s.charts.size()))
      throw InvalidInput(name + ": triangle " + std::to_string(f) + " has chart " + std::to_string(s.chart[f]) +
                         " out of range (" + std::to_string(s.charts.size()) + " charts)");
    for (int k = 0; k < 3; ++k)
      if (s.F(f, k) < 0 || s.F(f, k) >= m.U.rows())
        throw InvalidInput(name + ": triangle " + std::to_string(f) + " has vertex " + std::to_string(s.F(f, k)) +
                           " out of range (" + std::to_string(m.U.rows()) + " vertices)");
  }
  const double extent = (m.U.colwise().maxCoeff() - m.U.colwise().minCoeff()).maxCoeff() / m.edge_length;
  if (extent > double(kOff) / 2)
    throw InvalidInput(name + ": the PolyCube spans " + std::to_string(extent) + " hex edges, too many");
}

}  // namespace

HexMesh extract_hexes(const PolyCubeMap& map, const HexExtractParams& p, HexExtractStats* stats) {
  const auto t0 = std::chrono::steady_clock::now();
  check_map(map);
  HexExtractStats st;
  Extractor ex(map, p, st);
  HexMesh out = ex.run();
  st.seconds = seconds_since(t0);
  if (stats) *stats = st;
  return out;
}

}  // namespace polyhex
