#include "nodes/algorithms/chart_order.h"

#include "nodes/artefacts/polycube.h"

#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <numeric>
#include <queue>
#include <stdexcept>
#include <string>
#include <tuple>

namespace polyhex {

namespace {

struct UnionFind {
  std::vector<int> p;
  explicit UnionFind(int n) : p(n) { std::iota(p.begin(), p.end(), 0); }
  int find(int x) { return p[x] == x ? x : p[x] = find(p[x]); }
  bool unite(int a, int b) {
    a = find(a), b = find(b);
    if (a == b) return false;
    p[std::max(a, b)] = std::min(a, b);
    return true;
  }
};

}  // namespace

TetEdgeGraph::TetEdgeGraph(const RowMatrixX4i& T, int vertices) : start(size_t(vertices) + 1, 0) {
  std::vector<uint64_t> keys;
  keys.reserve(size_t(T.rows()) * 6);
  static const int E[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  for (Eigen::Index t = 0; t < T.rows(); ++t)
    for (auto& e : E) {
      uint64_t a = uint32_t(T(t, e[0])), b = uint32_t(T(t, e[1]));
      if (a > b) std::swap(a, b);
      keys.push_back(a << 32 | b);
    }
  tbb::parallel_sort(keys.begin(), keys.end());  // plain integers: one sorted order, whoever sorts them
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  edges.resize(keys.size());
  for (size_t k = 0; k < keys.size(); ++k) edges[k] = {int(keys[k] >> 32), int(keys[k] & 0xffffffffu)};
  nbr.resize(edges.size() * 2);
  for (auto& [a, b] : edges) ++start[size_t(a) + 1], ++start[size_t(b) + 1];
  for (int i = 0; i < vertices; ++i) start[size_t(i) + 1] += start[size_t(i)];
  std::vector<int> fill(start.begin(), start.end() - 1);
  for (auto& [a, b] : edges) nbr[fill[a]++] = b, nbr[fill[b]++] = a;
}

AxisChartOrder chart_order_evidence(const RowMatrixX3d& V, const TetEdgeGraph& graph,
                                    const std::vector<std::vector<int>>& vertex_charts,
                                    const std::vector<int>& chart_label,
                                    const std::vector<std::vector<int>>& chart_neighbours, int a, double h,
                                    const std::vector<char>* crease_vertex) {
  const int nV = int(V.rows()), nC = int(chart_label.size());
  AxisChartOrder r;
  // Same-axis charts sharing a vertex are forced onto one plane (groups).
  std::vector<int> axis_charts;
  for (int c = 0; c < nC; ++c)
    if (label_axis(chart_label[c]) == a) axis_charts.push_back(c);
  UnionFind uf(nC);
  std::vector<int>& vgroup = r.vertex_group;
  vgroup.assign(nV, -1);  // first: the representative a-chart of a vertex
  for (int v = 0; v < nV; ++v)
    for (int c : vertex_charts[v])
      if (label_axis(chart_label[c]) == a) {
        if (vgroup[v] >= 0 && uf.unite(vgroup[v], c)) ++r.merged_same_axis_charts;
        vgroup[v] = c;
      }
  std::vector<int> group_index(nC, -1);
  int nG = 0;
  for (int c : axis_charts)
    if (uf.find(c) == c) group_index[c] = nG++;
  r.groups = nG;
  r.chart_group.assign(nC, -1);
  for (int c : axis_charts) r.chart_group[c] = group_index[uf.find(c)];
  for (int v = 0; v < nV; ++v)
    if (vgroup[v] >= 0) vgroup[v] = r.chart_group[vgroup[v]];
  r.group_size.assign(nG, 0);
  r.group_mean.assign(nG, 0.0);
  for (int v = 0; v < nV; ++v)
    if (vgroup[v] >= 0) ++r.group_size[vgroup[v]], r.group_mean[vgroup[v]] += V(v, a);
  for (int g = 0; g < nG; ++g) r.group_mean[g] /= std::max(1, r.group_size[g]);

  // §5.2 approximate Voronoi partition of the volume by a-chart group (multi-source Dijkstra).
  std::vector<double> dist(nV, std::numeric_limits<double>::infinity());
  std::vector<int> src(nV, -1);
  using QE = std::pair<double, int>;
  std::priority_queue<QE, std::vector<QE>, std::greater<QE>> pq;
  for (int v = 0; v < nV; ++v)
    if (vgroup[v] >= 0) dist[v] = 0, src[v] = v, pq.push({0.0, v});
  while (!pq.empty()) {
    auto [dv, v] = pq.top();
    pq.pop();
    if (dv > dist[v]) continue;
    for (int k = graph.start[v]; k < graph.start[v + 1]; ++k) {
      int u = graph.nbr[k];
      double du = dv + (V.row(u) - V.row(v)).norm();
      if (du < dist[u]) dist[u] = du, src[u] = src[v], pq.push({du, u});
    }
  }
  struct Sums {
    double at_p = 0, at_q = 0;
    int count = 0;
  };
  std::map<std::pair<int, int>, Sums> samples;  // (p<q) -> sums of the closest vertices' coordinates
  for (auto& [i, j] : graph.edges) {
    if (src[i] < 0 || src[j] < 0) continue;
    int gi = vgroup[src[i]], gj = vgroup[src[j]];
    if (gi == gj) continue;
    double zi = V(src[i], a), zj = V(src[j], a);
    if (gi > gj) std::swap(gi, gj), std::swap(zi, zj);
    auto& s = samples[{gi, gj}];
    s.at_p += zi;
    s.at_q += zj;
    s.count += 1;
  }
  for (auto& [key, s] : samples) {
    const double p_at = s.at_p / s.count, q_at = s.at_q / s.count, delta = q_at - p_at;
    r.distance_samples.push_back({key.first, key.second, delta, p_at, q_at});
    if (std::abs(delta) > 0.5 * h)
      r.ordered.push_back({key.first, key.second, delta > 0 ? 1 : -1, std::abs(delta) / h});
  }
  // Bridged pairs: two a-groups bordering one chart of another axis are its two ends along a.
  for (int b = 0; b < nC; ++b) {
    if (label_axis(chart_label[b]) == a) continue;
    std::vector<int> gs;
    for (int c : chart_neighbours[b])
      if (r.chart_group[c] >= 0) gs.push_back(r.chart_group[c]);
    std::sort(gs.begin(), gs.end());
    gs.erase(std::unique(gs.begin(), gs.end()), gs.end());
    for (size_t x = 0; x < gs.size(); ++x)
      for (size_t y = x + 1; y < gs.size(); ++y) {
        double diff = r.group_mean[gs[y]] - r.group_mean[gs[x]];
        if (std::abs(diff) > 0.5 * h) r.ordered.push_back({gs[x], gs[y], diff > 0 ? 1 : -1, std::abs(diff) / h});
      }
  }
  // Self bridges, along the input's creases: per crease vertex of a group on a chart b of another axis, the
  // other vertices of b next to it (over tet edges) lie lower on average (the vertex is on b's top) or higher
  // (on its foot). Vertices on the group as well count: a wall one triangle high has no vertex on it alone.
  if (crease_vertex) {
    struct Ends {
      double top = 0, foot = 0;                // sums of the a-coordinates
      int tops = 0, feet = 0;                  // vertices
      double top_length = 0, foot_length = 0;  // along tet edges joining two vertices of the same end
    };
    // keyed by (group, chart, the label of the group's charts at the vertex): a step has the same face (its
    // floor) on its top and at its foot; a group of opposite faces sharing a vertex is no step
    std::map<std::tuple<int, int, int>, Ends> ends;
    std::vector<std::vector<std::tuple<int, int, bool>>> ends_at(static_cast<size_t>(nV));  // (chart, label, top)
    const double side_eps = 0.05 * h;
    for (int v = 0; v < nV; ++v) {
      if (vgroup[v] < 0 || !(*crease_vertex)[size_t(v)]) continue;
      int g_label = -1;
      for (int c : vertex_charts[v])
        if (label_axis(chart_label[c]) == a) g_label = g_label < 0 || g_label == chart_label[c] ? chart_label[c] : -2;
      if (g_label < 0) continue;  // on two opposite faces of the group
      for (int b : vertex_charts[v]) {
        if (label_axis(chart_label[b]) == a) continue;
        double side = 0;
        int n = 0;
        for (int k = graph.start[v]; k < graph.start[v + 1]; ++k) {
          const int u = graph.nbr[k];
          const auto& cu = vertex_charts[u];
          if (std::find(cu.begin(), cu.end(), b) != cu.end()) side += V(u, a) - V(v, a), ++n;
        }
        if (n == 0 || std::abs(side / n) < side_eps) continue;
        Ends& e = ends[{vgroup[v], b, g_label}];
        const bool top = side < 0;
        if (top)
          e.top += V(v, a), ++e.tops;
        else
          e.foot += V(v, a), ++e.feet;
        ends_at[size_t(v)].emplace_back(b, g_label, top);
      }
    }
    for (auto& [i, j] : graph.edges)
      for (auto& [b, l, top] : ends_at[size_t(i)])
        for (auto& [b2, l2, top2] : ends_at[size_t(j)])
          if (b == b2 && l == l2 && top == top2 && vgroup[i] == vgroup[j]) {
            Ends& e = ends[{vgroup[i], b, l}];
            (top ? e.top_length : e.foot_length) += (V.row(i) - V.row(j)).norm();
          }
    for (auto& [key, e] : ends) {
      if (e.top_length < kSelfBridgeLength * h || e.foot_length < kSelfBridgeLength * h) continue;
      const double top = e.top / e.tops, foot = e.foot / e.feet;
      if (top - foot > 0.5 * h) r.self_bridges.push_back({std::get<0>(key), std::get<1>(key), top, foot});
    }
    std::sort(r.self_bridges.begin(), r.self_bridges.end(),
              [](const auto& x, const auto& y) { return std::tie(x.group, x.chart) < std::tie(y.group, y.chart); });
  }
  // A pair measured by the distance constraints comes first and wins over a bridged one.
  auto& o = r.ordered;
  std::stable_sort(o.begin(), o.end(), [](auto& x, auto& y) { return std::tie(x.p, x.q) < std::tie(y.p, y.q); });
  o.erase(std::unique(o.begin(), o.end(), [](auto& x, auto& y) { return x.p == y.p && x.q == y.q; }), o.end());
  return r;
}

OrderAcceptance accept_orders(const std::vector<OrderedPair>& ordered, int nG) {
  OrderAcceptance r;
  r.up.resize(nG);
  std::vector<int> idx(ordered.size());
  std::iota(idx.begin(), idx.end(), 0);
  std::stable_sort(idx.begin(), idx.end(), [&](int x, int y) { return ordered[x].evidence > ordered[y].evidence; });
  std::vector<char> seen(nG, 0);
  std::vector<int> stack, touched;
  auto reaches = [&](int from, int to) {
    for (int x : touched) seen[x] = 0;
    touched.assign(1, from);
    stack.assign(1, from);
    seen[from] = 1;
    while (!stack.empty()) {
      int x = stack.back();
      stack.pop_back();
      if (x == to) return true;
      for (int y : r.up[x])
        if (!seen[y]) seen[y] = 1, touched.push_back(y), stack.push_back(y);
    }
    return false;
  };
  for (int i : idx) {
    const OrderedPair& o = ordered[i];
    int lo = o.sign > 0 ? o.p : o.q, hi = o.sign > 0 ? o.q : o.p;
    if (reaches(hi, lo)) {
      r.dropped.push_back(i);
      continue;
    }
    r.up[lo].push_back(hi);
  }
  r.gap.resize(nG);
  for (int g = 0; g < nG; ++g) r.gap[g].assign(r.up[g].size(), 1);
  return r;
}

std::vector<long> place_levels(const OrderAcceptance& acc, const std::vector<double>& target,
                               const std::vector<double>& weight, int max_sweeps) {
  const int nG = int(acc.up.size());
  if (int(target.size()) != nG || int(weight.size()) != nG)
    throw std::invalid_argument("place_levels: " + std::to_string(nG) + " groups, " + std::to_string(target.size()) +
                                " targets, " + std::to_string(weight.size()) + " weights");
  for (double w : weight)
    if (!(w > 0)) throw std::invalid_argument("place_levels: a group weight is not positive");
  struct Order {
    int lo, hi;
    double lambda, inv_mass, gap;
  };
  std::vector<Order> orders;
  for (int lo = 0; lo < nG; ++lo)
    for (size_t j = 0; j < acc.up[lo].size(); ++j)
      orders.push_back({lo, acc.up[lo][j], 0.0, 1.0 / (1.0 / weight[lo] + 1.0 / weight[acc.up[lo][j]]),
                        acc.gap.empty() ? 1.0 : double(acc.gap[lo][j])});
  // x = t + W^-1 A^T λ; each step raises one multiplier by the amount that makes its order hold exactly
  // (or lowers it towards 0 where the order holds with room), which keeps λ >= 0: dual coordinate ascent.
  std::vector<double> x = target;
  for (int sweep = 0; sweep < max_sweeps && !orders.empty(); ++sweep) {
    double change = 0;
    for (Order& o : orders) {
      const double violation = o.gap - (x[o.hi] - x[o.lo]);
      const double lambda = std::max(0.0, o.lambda + violation * o.inv_mass);
      const double d = lambda - o.lambda;
      if (d == 0) continue;
      o.lambda = lambda;
      x[o.hi] += d / weight[o.hi];
      x[o.lo] -= d / weight[o.lo];
      change = std::max(change, std::abs(d) * (1.0 / weight[o.hi] + 1.0 / weight[o.lo]));
    }
    if (change < 1e-10) break;
  }
  std::vector<long> k(nG);
  for (int g = 0; g < nG; ++g) k[g] = std::lround(x[g]);
  push_levels(acc, k);  // safeguard, when the ascent stopped at its sweep cap
  return k;
}

void push_levels(const OrderAcceptance& acc, std::vector<long>& k) {
  const int nG = int(acc.up.size());
  if (int(k.size()) != nG)
    throw std::invalid_argument("push_levels: " + std::to_string(nG) + " groups, " + std::to_string(k.size()) +
                                " levels");
  std::vector<int> indeg(nG, 0), queue;
  for (int g = 0; g < nG; ++g)
    for (int y : acc.up[g]) ++indeg[y];
  for (int g = 0; g < nG; ++g)
    if (indeg[g] == 0) queue.push_back(g);
  for (size_t head = 0; head < queue.size(); ++head) {
    const int g = queue[head];
    for (size_t j = 0; j < acc.up[g].size(); ++j) {
      const int y = acc.up[g][j];
      k[y] = std::max(k[y], k[g] + (acc.gap.empty() ? 1 : acc.gap[g][j]));
      if (--indeg[y] == 0) queue.push_back(y);
    }
  }
  if (int(queue.size()) != nG) throw std::invalid_argument("push_levels: the accepted orders contain a cycle");
}

std::vector<int> order_cycle(const OrderAcceptance& acc, const OrderedPair& o) {
  const int lo = o.sign > 0 ? o.p : o.q, hi = o.sign > 0 ? o.q : o.p, nG = int(acc.up.size());
  std::vector<int> pred(nG, -2);
  std::vector<int> queue{hi};
  pred[hi] = -1;
  for (size_t head = 0; head < queue.size(); ++head) {
    int x = queue[head];
    if (x == lo) break;
    for (int y : acc.up[x])
      if (pred[y] == -2) pred[y] = x, queue.push_back(y);
  }
  std::vector<int> path;
  if (pred[lo] == -2) return path;
  for (int x = lo; x != -1; x = pred[x]) path.push_back(x);
  std::reverse(path.begin(), path.end());
  return path;
}

std::vector<CycleCut> cycle_cuts(const AxisChartOrder& order, const std::vector<int>& cycle, double min_excess) {
  // g's height where its region meets group o's (the pair's mean closest-vertex coordinate on g's side)
  auto height = [&](int g, int o, double& z) {
    const std::pair<int, int> key{std::min(g, o), std::max(g, o)};
    auto it = std::lower_bound(
        order.distance_samples.begin(), order.distance_samples.end(), key,
        [](const AxisChartOrder::Sample& x, const std::pair<int, int>& k) { return std::make_pair(x.p, x.q) < k; });
    if (it == order.distance_samples.end() || it->p != key.first || it->q != key.second) return false;
    z = g == it->p ? it->p_at : it->q_at;
    return true;
  };
  std::vector<CycleCut> out;
  const size_t n = cycle.size();
  if (n < 2) return out;
  for (size_t i = 0; i < n; ++i) {
    const int g = cycle[i], below = cycle[(i + n - 1) % n], above = cycle[(i + 1) % n];
    double z_below = 0, z_above = 0;
    if (!height(g, below, z_below) || !height(g, above, z_above)) continue;
    if (z_below - z_above >= min_excess) out.push_back({g, 0.5 * (z_below + z_above), z_below - z_above});
  }
  return out;
}

}  // namespace polyhex
