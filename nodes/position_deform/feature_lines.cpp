// Creases inside one chart that the PolyCube map can put on lattice lines. See feature_lines.h.
#include "nodes/position_deform/feature_lines.h"

#include "nodes/algorithms/features.h"
#include "nodes/algorithms/triangle_tree.h"

#include <algorithm>
#include <array>
#include <map>

namespace polyhex {

std::vector<FeatureLine> feature_lines(const RowMatrixX3d& X, const RowMatrixX3d& Vd, const PolyCubeSegmentation& seg,
                                       double angle_deg, double scale, double min_length, double tolerance) {
  SurfaceMesh surface;
  surface.V = X;
  surface.F = seg.F;
  // the chart of each edge's triangles: an edge inside one chart has both triangles in it
  std::map<std::array<int, 2>, std::array<int, 2>> edge_charts;
  for (Eigen::Index f = 0; f < seg.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = seg.F(f, k), b = seg.F(f, (k + 1) % 3);
      auto [it, fresh] = edge_charts.try_emplace({std::min(a, b), std::max(a, b)}, std::array<int, 2>{-1, -1});
      it->second[fresh ? 0 : 1] = seg.chart[f];
    }
  // per chart, its crease edges as a graph
  std::map<int, std::map<int, std::vector<int>>> graph;  // chart -> vertex -> neighbours
  for (const auto& e :
       crease_edges(flat_face_creases(surface, find_creases(surface, angle_deg, min_length, scale), 2 * scale))) {
    const auto it = edge_charts.find(e);
    if (it == edge_charts.end() || it->second[0] < 0 || it->second[0] != it->second[1]) continue;
    auto& g = graph[it->second[0]];
    g[e[0]].push_back(e[1]);
    g[e[1]].push_back(e[0]);
  }
  // the axes of every vertex's charts: an end on a chart of the line's axis keeps that chart's level
  std::vector<std::uint8_t> chart_axes(size_t(X.rows()), 0);
  for (Eigen::Index f = 0; f < seg.F.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      chart_axes[size_t(seg.F(f, k))] |= std::uint8_t(1 << label_axis(seg.charts[size_t(seg.chart[f])].label));
  std::vector<FeatureLine> out;
  for (auto& [chart, g] : graph) {
    const int a = label_axis(seg.charts[size_t(chart)].label);
    // its crease edges' chains, on local vertex ids in the order of the global ones
    std::vector<int> global;
    std::map<int, int> local;
    for (const auto& [v, nb] : g) local[v] = int(global.size()), global.push_back(v);
    std::vector<std::vector<int>> adj(global.size());
    for (const auto& [v, nb] : g)
      for (int w : nb) adj[size_t(local[v])].push_back(local[w]);
    for (EdgeChain& c : edge_chains(adj)) {
      for (int& v : c.verts) v = global[size_t(v)];
      const std::vector<int>& run = c.verts;
      double length = 0;
      for (size_t i = 1; i < run.size(); ++i) length += (X.row(run[i]) - X.row(run[i - 1])).norm();
      if (length < min_length) continue;
      // straight in the input: a curved crease would bend the map to a straight lattice line
      const Eigen::Vector3d first = X.row(run.front()).transpose(), last = X.row(run.back()).transpose();
      double bend = 0;
      for (int v : run) bend = std::max(bend, segment_distance(X.row(v).transpose(), first, last));
      if (bend > tolerance) continue;
      // the in-plane axis across which the run is straightest
      int best = -1;
      double spread = 0;
      for (int b = 0; b < 3; ++b) {
        if (b == a) continue;
        double lo = Vd(run[0], b), hi = lo;
        for (int v : run) lo = std::min(lo, Vd(v, b)), hi = std::max(hi, Vd(v, b));
        if (best < 0 || hi - lo < spread) best = b, spread = hi - lo;
      }
      if (spread > tolerance) continue;
      FeatureLine line{chart, best, {}, length};
      for (int v : run)
        if (!(chart_axes[size_t(v)] & (1 << best))) line.vertices.push_back(v);
      std::sort(line.vertices.begin(), line.vertices.end());
      line.vertices.erase(std::unique(line.vertices.begin(), line.vertices.end()), line.vertices.end());
      if (line.vertices.size() >= 2) out.push_back(std::move(line));
    }
  }
  return out;
}

}  // namespace polyhex
