/// @file segment_result.cpp
/// @brief The segmentation's result: charts, edges and corners, and what makes the structure invalid.
#include "nodes/algorithms/chart_order.h"
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

namespace {

std::string chart_name(const PolyCubeSegmentation& r, int c) {
  return "chart " + std::to_string(c) + " (" + label_name(r.charts[c].label) + ", " +
         std::to_string(r.charts[c].triangles) + " triangles)";
}

}  // namespace

std::string id_list(const std::vector<int>& ids) {
  std::string out;
  for (int i : ids) out += (out.empty() ? "" : ", ") + std::to_string(i);
  return out;
}

PolyCubeSegmentation make_result(const Surface& s, const State& st) {
  PolyCubeSegmentation r;
  r.F = *s.F;
  Structure S = analyse(s, st.label);
  r.chart = Eigen::Map<const Eigen::VectorXi>(S.chart.data(), s.nf());
  r.label = Eigen::Map<const Eigen::VectorXi>(st.label.data(), s.nf());
  r.charts.resize(S.n);
  std::vector<int> band_count(S.n, 0);
  for (int t = 0; t < s.nf(); ++t) {
    auto& c = r.charts[S.chart[t]];
    c.label = st.label[t];
    ++c.triangles;
    c.area += s.area[t];
    band_count[S.chart[t]] += st.band.empty() ? 0 : st.band[t];
  }
  for (int c = 0; c < S.n; ++c) {
    r.charts[c].neighbours = S.adj[c];
    r.charts[c].separating = 2 * band_count[c] > r.charts[c].triangles;
  }
  r.edges = S.edges;
  r.corners = S.corners;
  r.splits_multi_orientation = st.splits_multi;
  r.splits_wedge = st.splits_wedge;
  r.splits_ramp = st.splits_ramp;
  r.splits_order_cycle = st.splits_cycle;
  r.splits_island = st.splits_island;
  r.repaired_corners = st.repaired_corners;
  r.removed_small = st.removed_small;
  r.removed_narrow = st.removed_narrow;

  std::set<int> failing;
  auto fail = [&](const std::string& msg, std::initializer_list<int> ids) {
    r.problems.push_back(msg);
    failing.insert(ids.begin(), ids.end());
  };
  for (int c = 0; c < S.n; ++c) {
    if (S.adj[c].size() < 4)
      fail(chart_name(r, c) + " has " + std::to_string(S.adj[c].size()) + " neighbour(s) (" + id_list(S.adj[c]) +
               "); a PolyCube face needs at least 4",
           {c});
    for (int d : S.adj[c])
      if (d > c && label_axis(r.charts[d].label) == label_axis(r.charts[c].label))
        fail(chart_name(r, c) + " and " + chart_name(r, d) + " are neighbours on the same axis", {c, d});
  }
  // opposite directions touching at a vertex only
  std::set<std::pair<int, int>> seen;
  for (int v = 0; v < int(s.V->rows()); ++v) {
    std::set<int> cs;
    for (int t : s.vert_tris[v]) cs.insert(S.chart[t]);
    for (int c : cs)
      for (int d : cs)
        if (c < d && (r.charts[c].label ^ 1) == r.charts[d].label &&
            !std::binary_search(S.adj[c].begin(), S.adj[c].end(), d) && seen.insert({c, d}).second)
          fail(chart_name(r, c) + " touches " + chart_name(r, d) + " of the opposite direction at vertex " +
                   std::to_string(v),
               {c, d});
  }
  for (auto& c : r.corners)
    if (c.valence != 3 || c.charts.size() != 3) {
      r.problems.push_back("corner at vertex " + std::to_string(c.vertex) + " has valence " +
                           std::to_string(c.valence) + " (charts " + id_list(c.charts) + "); PolyCube corners need 3");
      failing.insert(c.charts.begin(), c.charts.end());
    }
  // chart graph connected on every connected component of the surface
  std::vector<int> comp(s.nf(), -1);
  int ncomp = 0;
  for (int t0 = 0; t0 < s.nf(); ++t0) {
    if (comp[t0] >= 0) continue;
    std::vector<int> stack{t0};
    comp[t0] = ncomp;
    while (!stack.empty()) {
      int t = stack.back();
      stack.pop_back();
      for (int u : s.tri_nbrs[t])
        if (comp[u] < 0) {
          comp[u] = ncomp;
          stack.push_back(u);
        }
    }
    ++ncomp;
  }
  std::vector<std::set<int>> comp_charts(ncomp);
  for (int t = 0; t < s.nf(); ++t) comp_charts[comp[t]].insert(S.chart[t]);
  for (int k = 0; k < ncomp; ++k) {
    std::set<int> reached{*comp_charts[k].begin()};
    std::vector<int> stack{*comp_charts[k].begin()};
    while (!stack.empty()) {
      int c = stack.back();
      stack.pop_back();
      for (int d : S.adj[c])
        if (reached.insert(d).second) stack.push_back(d);
    }
    if (reached.size() != comp_charts[k].size()) {
      std::vector<int> missing;
      for (int c : comp_charts[k])
        if (!reached.count(c)) missing.push_back(c);
      r.problems.push_back("surface component " + std::to_string(k) + ": chart graph is not connected (charts " +
                           id_list(missing) + " unreachable)");
      failing.insert(missing.begin(), missing.end());
    }
  }
  r.failing_charts.assign(failing.begin(), failing.end());
  r.valid = r.problems.empty();
  return r;
}

}  // namespace polyhex::segment_detail
