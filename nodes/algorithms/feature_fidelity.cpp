// Feature fidelity of a hex mesh's boundary: distances between crease lines and boundary edges. See
// feature_fidelity.h.
#include "nodes/algorithms/feature_fidelity.h"

#include "nodes/algorithms/triangle_tree.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

namespace polyhex {
namespace {

using Vec3 = Eigen::Vector3d;
using Segment = std::pair<Vec3, Vec3>;

/// Exact distance from a point to the nearest of a set of segments: a uniform grid of cells, each listing the
/// segments whose bounding boxes overlap it, searched in growing shells of cells around the query until no
/// nearer segment can lie further out.
class SegmentGrid {
 public:
  SegmentGrid(std::vector<Segment> segs, double cell) : segs_(std::move(segs)) {
    if (segs_.empty()) return;
    lo_ = hi_ = segs_[0].first;
    for (const auto& s : segs_) {
      lo_ = lo_.cwiseMin(s.first).cwiseMin(s.second);
      hi_ = hi_.cwiseMax(s.first).cwiseMax(s.second);
    }
    // no more cells than about 8 per segment: a long thin set would otherwise make a huge empty grid
    const Vec3 ext = (hi_ - lo_).cwiseMax(1e-300);
    cell_ = std::max(cell, std::cbrt(ext.prod() / (8.0 * double(segs_.size()))));
    cell_ = std::max(cell_, ext.maxCoeff() / 1024.0);
    for (int a = 0; a < 3; ++a) n_[size_t(a)] = std::max(1, int(std::ceil(ext[a] / cell_)));
    std::vector<std::vector<int>> bins(size_t(n_[0]) * size_t(n_[1]) * size_t(n_[2]));
    for (size_t i = 0; i < segs_.size(); ++i) {
      const auto c0 = index(segs_[i].first.cwiseMin(segs_[i].second));
      const auto c1 = index(segs_[i].first.cwiseMax(segs_[i].second));
      for (int z = c0[2]; z <= c1[2]; ++z)
        for (int y = c0[1]; y <= c1[1]; ++y)
          for (int x = c0[0]; x <= c1[0]; ++x) bins[flat(x, y, z)].push_back(int(i));
    }
    start_.assign(bins.size() + 1, 0);
    for (size_t b = 0; b < bins.size(); ++b) start_[b + 1] = start_[b] + int(bins[b].size());
    for (auto& b : bins) items_.insert(items_.end(), b.begin(), b.end());
  }

  bool empty() const { return segs_.empty(); }

  double distance(const Vec3& p) const {
    if (segs_.empty()) return std::numeric_limits<double>::infinity();
    // the query's cell, unclamped (it may lie outside the grid)
    std::array<int, 3> c;
    for (int a = 0; a < 3; ++a) c[size_t(a)] = int(std::floor((p[a] - lo_[a]) / cell_));
    int reach = 0;  // shells beyond which no cell of the grid lies
    for (int a = 0; a < 3; ++a)
      reach = std::max({reach, std::abs(c[size_t(a)]), std::abs(c[size_t(a)] - n_[size_t(a)] + 1)});
    double best = std::numeric_limits<double>::infinity();
    for (int r = 0; r <= reach; ++r) {
      // a segment first met in shell r + 1 or later is at least r cells away
      if (best <= double(r - 1) * cell_) break;
      if (r > 24) {  // far from every segment: look at all of them
        for (const auto& s : segs_) best = std::min(best, segment_distance(p, s.first, s.second));
        break;
      }
      visit_shell(c, r, [&](size_t bin) {
        for (int k = start_[bin]; k < start_[bin + 1]; ++k) {
          const Segment& s = segs_[size_t(items_[size_t(k)])];
          best = std::min(best, segment_distance(p, s.first, s.second));
        }
      });
    }
    return best;
  }

 private:
  std::array<int, 3> index(const Vec3& x) const {
    std::array<int, 3> c;
    for (int a = 0; a < 3; ++a)
      c[size_t(a)] = std::clamp(int(std::floor((x[a] - lo_[a]) / cell_)), 0, n_[size_t(a)] - 1);
    return c;
  }
  size_t flat(int x, int y, int z) const { return (size_t(z) * size_t(n_[1]) + size_t(y)) * size_t(n_[0]) + size_t(x); }

  /// Calls f(bin) for the grid's cells at Chebyshev distance exactly r from cell c.
  template <class F>
  void visit_shell(const std::array<int, 3>& c, int r, F&& f) const {
    auto in = [&](int v, int a) { return v >= 0 && v < n_[size_t(a)]; };
    for (int z = c[2] - r; z <= c[2] + r; ++z) {
      if (!in(z, 2)) continue;
      for (int y = c[1] - r; y <= c[1] + r; ++y) {
        if (!in(y, 1)) continue;
        const bool face = std::abs(z - c[2]) == r || std::abs(y - c[1]) == r;
        for (int x = c[0] - r; x <= c[0] + r; x += (face || r == 0) ? 1 : 2 * r)
          if (in(x, 0)) f(flat(x, y, z));
      }
    }
  }

  std::vector<Segment> segs_;
  Vec3 lo_ = Vec3::Zero(), hi_ = Vec3::Zero();
  double cell_ = 1;
  std::array<int, 3> n_{1, 1, 1};
  std::vector<int> start_, items_;
};

/// Points `spacing` apart along a segment, its ends included.
template <class F>
void sample(const Segment& s, double spacing, F&& f) {
  const double L = (s.second - s.first).norm();
  const int n = std::max(1, int(std::ceil(L / spacing)));
  for (int k = 0; k <= n; ++k) f(s.first + (double(k) / n) * (s.second - s.first));
}

/// The max (first) and the length-weighted mean (second) of the distance to `grid` over the segments.
std::pair<double, double> max_mean_distance(const std::vector<Segment>& segs, const SegmentGrid& grid, double spacing) {
  std::vector<double> mx(segs.size(), 0.0), integral(segs.size(), 0.0);
  tbb::parallel_for(size_t(0), segs.size(), [&](size_t i) {
    std::vector<double> d;
    sample(segs[i], spacing, [&](const Vec3& x) { d.push_back(grid.distance(x)); });
    const double L = (segs[i].second - segs[i].first).norm();
    for (size_t k = 0; k < d.size(); ++k) {
      mx[i] = std::max(mx[i], d[k]);
      if (k > 0) integral[i] += 0.5 * (d[k] + d[k - 1]) * L / double(d.size() - 1);  // trapezoids
    }
  });
  double m = 0, sum = 0, len = 0;  // in a fixed order: the same figures for any thread count
  for (size_t i = 0; i < segs.size(); ++i) {
    m = std::max(m, mx[i]);
    sum += integral[i];
    len += (segs[i].second - segs[i].first).norm();
  }
  return {m, len > 0 ? sum / len : 0.0};
}

}  // namespace

double median_boundary_edge(const RowMatrixX3d& V, const BoundaryQuads& Q) {
  if (Q.rows() == 0) return 0;
  std::vector<double> len;
  len.reserve(size_t(Q.rows()));
  for (Eigen::Index q = 0; q < Q.rows(); ++q) len.push_back((V.row(Q(q, 0)) - V.row(Q(q, 1))).norm());
  std::nth_element(len.begin(), len.begin() + long(len.size() / 2), len.end());
  return len[len.size() / 2];
}

FeatureFidelity feature_fidelity(const RowMatrixX3d& V, const BoundaryQuads& Q, const SurfaceCreases& creases,
                                 double angle_deg, double spacing) {
  FeatureFidelity out;
  out.curves = int(creases.lines.size());
  std::vector<Segment> curve;
  for (const auto& line : creases.lines)
    for (size_t k = 1; k < line.size(); ++k) {
      curve.emplace_back(line[k - 1], line[k]);
      out.curve_length += (line[k] - line[k - 1]).norm();
    }
  // the boundary edges (each once) and, for those in exactly two quads, the angle between the quads' normals
  struct Use {
    int a, b, quad;
  };
  std::vector<Use> uses;
  uses.reserve(size_t(Q.rows()) * 4);
  for (Eigen::Index q = 0; q < Q.rows(); ++q)
    for (int k = 0; k < 4; ++k) {
      const int a = Q(q, k), b = Q(q, (k + 1) % 4);
      uses.push_back({std::min(a, b), std::max(a, b), int(q)});
    }
  std::sort(uses.begin(), uses.end(), [](const Use& x, const Use& y) {
    return x.a != y.a ? x.a < y.a : x.b != y.b ? x.b < y.b : x.quad < y.quad;
  });
  auto normal = [&](int q) {  // a quad's normal: the cross product of its diagonals
    const Vec3 d0 = (V.row(Q(q, 2)) - V.row(Q(q, 0))).transpose(), d1 = (V.row(Q(q, 3)) - V.row(Q(q, 1))).transpose();
    return Vec3(d0.cross(d1));
  };
  const double cos_max = std::cos(angle_deg * M_PI / 180.0);
  std::vector<Segment> boundary, feature;
  for (size_t i = 0; i < uses.size();) {
    size_t j = i;
    while (j < uses.size() && uses[j].a == uses[i].a && uses[j].b == uses[i].b) ++j;
    const Segment s{V.row(uses[i].a).transpose(), V.row(uses[i].b).transpose()};
    boundary.push_back(s);
    if (j - i == 2) {
      const Vec3 n0 = normal(uses[i].quad), n1 = normal(uses[i + 1].quad);
      const double l0 = n0.norm(), l1 = n1.norm();
      if (l0 > 0 && l1 > 0 && n0.dot(n1) < cos_max * l0 * l1) feature.push_back(s);
    }
    i = j;
  }
  out.mesh_feature_edges = long(feature.size());
  if (curve.empty()) return out;
  const SegmentGrid to_mesh(boundary, 2 * spacing), to_curve(curve, 2 * spacing);
  if (!to_mesh.empty())
    std::tie(out.curve_to_mesh_max, out.curve_to_mesh_mean) = max_mean_distance(curve, to_mesh, spacing);
  out.mesh_to_curve_max = max_mean_distance(feature, to_curve, spacing).first;
  return out;
}

}  // namespace polyhex
