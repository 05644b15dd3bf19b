/// @file polycube_repair.cpp
/// @brief Local repairs of the problems the §5.1 splits leave: island cuts, corner patches, small and narrow charts.
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

/// How far a labelling is from a valid PolyCube: (number of problems, total neighbour deficit
/// sum_c max(0, 4 - #neighbours)); smaller is better, compared lexicographically.
std::pair<int, int> structure_score(const Surface& s, const State& st) {
  PolyCubeSegmentation r = make_result(s, st);
  int deficit = 0;
  for (auto& c : r.charts) deficit += std::max(0, 4 - int(c.neighbours.size()));
  return {int(r.problems.size()), deficit};
}

/// Extension of §5.1 (param split_islands). A chart C with fewer than four neighbours that borders a
/// chart R along a curve without corners (an island inside R, R a ring with two or more boundary
/// loops) cannot become a PolyCube face however its boundary is straightened: R must be cut.
/// Cut R along the cheapest path from C's boundary through R to a vertex of R's boundary touching a
/// chart C does not neighbour yet; the path cost is L (1.1 - Align) as in the wedge cuts, with Align
/// the alignment of each mesh edge with the axis a C-R PolyCube edge runs along (neither C's nor R's
/// axis). A separating chart of width h is inserted along it, its label by the §5.1 neighbour rule
/// (R twice, C, and the chart reached), or C's own label (C is extended across R). Of these cuts
/// over all of C's neighbours R, the one giving the best score (then the cheapest path) is kept if
/// it improves the structure. Repeated until no chart gains from a cut.
void split_islands(const Surface& s, const std::vector<Vec3>& normal, double h, int max_splits, State& st) {
  std::set<std::pair<int, int>> failed;  // (a triangle of C, a triangle of R) cuts that did not help
  while (st.splits_island < max_splits) {
    throw_if_interrupted();
    Structure S = analyse(s, st.label);
    std::vector<int> chart_label(S.n), rep(S.n);
    for (int t = 0; t < s.nf(); ++t) {
      chart_label[S.chart[t]] = st.label[t];
      rep[S.chart[t]] = t;
    }
    const auto before = structure_score(s, st);
    bool applied = false;
    for (int C = 0; C < S.n && !applied; ++C) {
      if (S.adj[C].size() >= 4) continue;
      // best candidate over C's neighbours R and the two labels: lowest score, then cheapest path
      std::tuple<std::pair<int, int>, double> best{before, kInf};
      State best_state;
      for (int R : S.adj[C]) {
        if (failed.count({rep[C], rep[R]})) continue;
        int t_axis = 3 - label_axis(chart_label[C]) - label_axis(chart_label[R]);
        if (label_axis(chart_label[C]) == label_axis(chart_label[R])) t_axis = -1;
        // sources: vertices between C and R only; targets: R's boundary vertices touching a chart
        // that is not C, R or a neighbour of C
        std::vector<double> dist(s.V->rows(), kInf);
        std::vector<int> pred(s.V->rows(), -1);
        using Item = std::pair<double, int>;
        std::priority_queue<Item, std::vector<Item>, std::greater<Item>> q;
        auto charts_at = [&](int v) {
          std::set<int> cs;
          for (int t : s.vert_tris[v]) cs.insert(S.chart[t]);
          return cs;
        };
        for (int v = 0; v < int(s.V->rows()); ++v) {
          if (s.vert_tris[v].empty()) continue;
          auto cs = charts_at(v);
          if (cs == std::set<int>{std::min(C, R), std::max(C, R)}) {
            dist[v] = 0;
            q.push({0.0, v});
          }
        }
        int target = -1;
        while (!q.empty()) {
          auto [d, u] = q.top();
          q.pop();
          if (d > dist[u]) continue;
          auto cs = charts_at(u);
          bool new_nbr = false;
          for (int c : cs)
            new_nbr = new_nbr || (c != C && c != R && !std::binary_search(S.adj[C].begin(), S.adj[C].end(), c));
          if (new_nbr) {
            target = u;
            break;
          }
          if (!cs.count(R) || (dist[u] > 0 && cs.size() > 1)) continue;  // walk through R's interior
          for (auto& [w, e] : s.vert_edges[u]) {
            if (S.chart[s.edges[e].t[0]] != R && S.chart[s.edges[e].t[1]] != R) continue;
            if (charts_at(w).count(C)) continue;
            Vec3 dv = s.pos(w) - s.pos(u);
            double len = dv.norm();
            double align = t_axis >= 0 && len > 0 ? std::abs(dv[t_axis]) / len : 1.0;
            double nd = d + len * (1.1 - align);
            if (nd < dist[w]) {
              dist[w] = nd;
              pred[w] = u;
              q.push({nd, w});
            }
          }
        }
        if (target < 0) {
          failed.insert({rep[C], rep[R]});
          continue;
        }
        std::vector<int> path;
        for (int v = target; v >= 0; v = pred[v]) path.push_back(v);
        std::vector<char> allowed(s.nf(), 0);
        for (int t = 0; t < s.nf(); ++t) allowed[t] = S.chart[t] == R;
        std::vector<int> band = grow_band(s, path, allowed, 0.5 * h);
        int E = chart_at(s, S.chart, target, {C, R});
        std::vector<int> nbr_labels = {chart_label[R], chart_label[R], chart_label[C]};
        if (E >= 0) nbr_labels.push_back(chart_label[E]);
        int rule = separating_label(nbr_labels, mean_normal(s, normal, band), true, -1);
        bool helps = false;
        for (int l : {rule, chart_label[C]}) {
          State trial = st;
          for (int t : band) {
            trial.label[t] = l;
            trial.band[t] = 1;
          }
          auto score = structure_score(s, trial);
          helps = helps || score < before;
          if (std::make_tuple(score, dist[target]) < best) {
            best = {score, dist[target]};
            best_state = std::move(trial);
          }
        }
        if (!helps) failed.insert({rep[C], rep[R]});
      }
      if (std::get<0>(best) < before) {
        st = std::move(best_state);
        ++st.splits_island;
        applied = true;
      }
    }
    if (!applied) return;
  }
}

/// Cheap local test of a relabelled patch before the global score: at every vertex of the patch,
/// no two opposite directions meet, a label change across a mesh edge is a change of axis, and the
/// label changes around the vertex number 0, 2 or 3 (inside a chart, on a chart edge, a corner).
bool locally_plausible(const Surface& s, const std::vector<int>& label, const std::vector<int>& patch) {
  for (int t : patch)
    for (int k = 0; k < 3; ++k) {
      int v = (*s.F)(t, k), changes = 0, seen = 0;
      for (auto& [w, e] : s.vert_edges[v]) {
        int a = label[s.edges[e].t[0]], b = label[s.edges[e].t[1]];
        seen |= (1 << a) | (1 << b);
        if (a == b) continue;
        if (label_axis(a) == label_axis(b)) return false;
        ++changes;
      }
      if (changes == 1 || changes > 3) return false;
      for (int l = 0; l < 6; l += 2)
        if ((seen >> l & 3) == 3) return false;
    }
  return true;
}

/// Extension of §5.1 (param repair_corners). A vertex where four or more chart edges meet, or where
/// charts of opposite directions touch only at the vertex (a saddle: +Z, -X, -Z, +X around it), is
/// not a PolyCube corner. A small patch around the vertex (the triangles within r of it, r = 0, h/2,
/// h, 2h) is given one direction, trying the directions in order of similarity to the patch's mean
/// normal (for a saddle the best one is on the third axis, and a chart of that label nearby absorbs
/// the patch); the first relabelling that is locally plausible (locally_plausible) and improves the
/// structure's score is kept. Repeated until no bad vertex gains.
void repair_corners(const Surface& s, const std::vector<Vec3>& normal, double h, int max_repairs, State& st) {
  std::set<int> failed;
  std::vector<char> all(s.nf(), 1);
  while (st.repaired_corners < max_repairs) {
    throw_if_interrupted();
    PolyCubeSegmentation r = make_result(s, st);
    if (r.valid) return;
    std::vector<int> bad;
    for (auto& c : r.corners)
      if ((c.valence != 3 || c.charts.size() != 3) && !failed.count(c.vertex)) bad.push_back(c.vertex);
    for (int v = 0; v < int(s.V->rows()); ++v) {
      if (failed.count(v) || s.vert_tris[v].empty()) continue;
      std::set<int> ls;
      for (int t : s.vert_tris[v]) ls.insert(st.label[t]);
      for (int l : ls)
        if ((l ^ 1) > l && ls.count(l ^ 1)) {
          bad.push_back(v);
          break;
        }
    }
    std::sort(bad.begin(), bad.end());
    bad.erase(std::unique(bad.begin(), bad.end()), bad.end());
    if (bad.empty()) return;
    const auto before = structure_score(s, st);
    bool applied = false;
    for (int v : bad) {
      for (double radius : {0.0, 0.5 * h, h, 2 * h}) {
        std::vector<int> patch = grow_band(s, {v}, all, radius);
        Vec3 n = mean_normal(s, normal, patch);
        std::array<int, 6> order = {0, 1, 2, 3, 4, 5};
        std::sort(order.begin(), order.end(), [&](int a, int b) { return label_dir(a).dot(n) > label_dir(b).dot(n); });
        for (int l : order) {
          State trial = st;
          for (int t : patch) trial.label[t] = l;
          if (locally_plausible(s, trial.label, patch) && structure_score(s, trial) < before) {
            st = std::move(trial);
            applied = true;
            break;
          }
        }
        if (applied) break;
      }
      if (applied) {
        ++st.repaired_corners;
        break;
      }
      failed.insert(v);
    }
    if (!applied) return;
  }
}

/// Removes the small charts (area below p.small_chart_area of the surface) that `bad` selects,
/// relabelling them by flood fill; repeats until none is selected. `straighten_first` straightens
/// before each round. Counts the removed charts in st.removed_small.
void remove_small_charts(const Surface& s, const std::vector<Vec3>& normal, const PolyCubeSegmentParams& p, State& st,
                         bool straighten_first,
                         const std::function<bool(const Structure&, int chart, int edges)>& bad) {
  for (int round = 0; round < 16; ++round) {
    throw_if_interrupted();
    if (straighten_first) straighten(s, st.label);
    Structure S = analyse(s, st.label);
    std::vector<int> edge_count(S.n, 0);
    std::vector<double> area(S.n, 0);
    for (auto& e : S.edges) {
      ++edge_count[e.chart_a];
      ++edge_count[e.chart_b];
    }
    for (int t = 0; t < s.nf(); ++t) area[S.chart[t]] += s.area[t];
    std::vector<char> remove(S.n, 0);
    int removed = 0;
    for (int c = 0; c < S.n; ++c)
      if (S.n > 1 && area[c] < p.small_chart_area * s.total_area && bad(S, c, edge_count[c])) {
        remove[c] = 1;
        ++removed;
      }
    if (removed == 0) return;
    st.removed_small += removed;
    for (int t = 0; t < s.nf(); ++t)
      if (remove[S.chart[t]]) st.label[t] = -1;
    flood_fill(s, normal, st.label);
  }
}

/// Last resort (beyond §5.1), on a structure still invalid after every repair: the small charts (area below
/// p.small_chart_area of the surface) that the problems name, smallest first, each removed alone by flood fill
/// from its neighbours and the corners repaired after it; the first that lowers the structure's score is kept,
/// and the search starts again. A chart of the opposite direction beside another, or a patch that makes a
/// 4-valent corner, is often a few hex faces the earlier steps left: the ones whose removal does not help are
/// left as they were.
void remove_failing_charts(const Surface& s, const std::vector<Vec3>& normal, const PolyCubeSegmentParams& p, double h,
                           State& st) {
  for (int round = 0; round < p.max_splits; ++round) {
    throw_if_interrupted();
    const PolyCubeSegmentation r = make_result(s, st);
    if (r.valid) return;
    std::vector<int> order;
    for (int c : r.failing_charts)
      if (r.charts[size_t(c)].area < p.small_chart_area * s.total_area) order.push_back(c);
    std::stable_sort(order.begin(), order.end(),
                     [&](int a, int b) { return r.charts[size_t(a)].area < r.charts[size_t(b)].area; });
    const auto before = structure_score(s, st);
    bool applied = false;
    for (int c : order) {
      State trial = st;
      for (int t = 0; t < s.nf(); ++t)
        if (r.chart[t] == c) trial.label[size_t(t)] = -1;
      flood_fill(s, normal, trial.label);
      if (p.repair_corners) repair_corners(s, normal, h, p.max_splits, trial);
      if (structure_score(s, trial) < before) {
        st = std::move(trial);
        ++st.removed_small;
        applied = true;
        break;
      }
    }
    if (!applied) return;
  }
}

}  // namespace

void clean_up(const Surface& s, const std::vector<Vec3>& normal, const PolyCubeSegmentParams& p, State& st) {
  remove_small_charts(s, normal, p, st, true,
                      [&](const Structure&, int, int edges) { return edges <= p.small_chart_edges; });
}

void remove_small_invalid(const Surface& s, const std::vector<Vec3>& normal, const PolyCubeSegmentParams& p,
                          State& st) {
  remove_small_charts(s, normal, p, st, false, [](const Structure& S, int c, int) { return S.adj[c].size() < 4; });
}

void repair(const Surface& s, const std::vector<Vec3>& normal, const PolyCubeSegmentParams& p, State& st) {
  const double h = p.hex_edge_length * s.diag;
  auto run = [&](State& x) {
    if (p.split_islands) split_islands(s, normal, h, p.max_splits, x);
    if (p.repair_corners) repair_corners(s, normal, h, p.max_splits, x);
  };
  State base = st;
  run(st);
  if (make_result(s, st).valid) return;
  if (p.final_cleanup) {
    remove_small_charts(s, normal, p, base, false, [](const Structure& S, int c, int) {
      for (int d : S.adj[c])
        if (label_axis(S.label[d]) == label_axis(S.label[c])) return true;
      return false;
    });
    run(base);
    if (structure_score(s, base) < structure_score(s, st)) st = std::move(base);
    if (make_result(s, st).valid) return;
  }
  // Last: opposite directions can meet along a curve again after the wedge cuts and the small-chart
  // removal (each relabels whole patches). Split there once more, as §5.1 does for multi-orientation
  // charts, and repair the corners the new band makes; kept only if it lowers the problem count.
  if (p.split_multi_orientation) {
    State trial = st;
    split_multi_orientation(s, normal, h, p.max_splits, trial);
    if (p.repair_corners) repair_corners(s, normal, h, p.max_splits, trial);
    if (structure_score(s, trial) < structure_score(s, st)) st = std::move(trial);
  }
  // The repairs themselves can leave small charts with fewer than 4 neighbours (a cut or a relabelled
  // patch that isolates a sliver): remove them once more, as final_cleanup did before the repairs.
  if (p.final_cleanup && !make_result(s, st).valid) {
    State trial = st;
    remove_small_invalid(s, normal, p, trial);
    if (p.repair_corners) repair_corners(s, normal, h, p.max_splits, trial);
    if (structure_score(s, trial) < structure_score(s, st)) st = std::move(trial);
  }
  if (p.final_cleanup) remove_failing_charts(s, normal, p, h, st);
}

namespace {

struct NarrowCharts {
  std::vector<std::pair<double, int>> charts;  // (area, chart), smallest first
  std::vector<std::vector<int>> tris;          // triangles of every chart
};

/// The charts of `label` whose vertices span less than `limit` along an axis of their plane and whose area
/// is below `max_area`, leaving out the separating charts of the splits (most of their triangles in `band`).
NarrowCharts narrow_charts(const Surface& s, const State& st, double limit, double max_area) {
  Structure S = analyse(s, st.label);
  std::vector<Vec3> lo(S.n, Vec3::Constant(kInf)), hi(S.n, Vec3::Constant(-kInf));
  std::vector<double> area(S.n, 0);
  std::vector<int> band(S.n, 0);
  NarrowCharts r;
  r.tris.resize(S.n);
  for (int t = 0; t < s.nf(); ++t) {
    const int c = S.chart[t];
    area[c] += s.area[t];
    band[c] += st.band[t] ? 1 : 0;
    r.tris[c].push_back(t);
    for (int k = 0; k < 3; ++k) {
      const Vec3 x = s.pos((*s.F)(t, k));
      lo[c] = lo[c].cwiseMin(x), hi[c] = hi[c].cwiseMax(x);
    }
  }
  for (int c = 0; c < S.n; ++c) {
    if (2 * band[c] > int(r.tris[c].size())) continue;
    const int a = label_axis(S.label[c]);
    double extent = kInf;
    for (int b = 0; b < 3; ++b)
      if (b != a) extent = std::min(extent, hi[c][b] - lo[c][b]);
    if (extent < limit && area[c] < max_area) r.charts.push_back({area[c], c});
  }
  std::sort(r.charts.begin(), r.charts.end());
  return r;
}

}  // namespace

void remove_narrow_charts(const Surface& s, const std::vector<Vec3>& normal, const PolyCubeSegmentParams& p,
                          State& st) {
  if (p.min_chart_extent <= 0 || p.narrow_chart_faces <= 0) return;
  if (!make_result(s, st).valid) return;  // every change below is kept only when valid
  const double h = p.hex_edge_length * s.diag, limit = p.min_chart_extent * h, max_area = p.narrow_chart_faces * h * h;
  for (int round = 0; round < 4; ++round) {
    throw_if_interrupted();
    NarrowCharts n = narrow_charts(s, st, limit, max_area);
    if (n.charts.empty()) return;
    bool changed = false;
    for (auto [area, c] : n.charts) {
      State trial = st;
      for (int t : n.tris[c]) trial.label[t] = -1;
      flood_fill(s, normal, trial.label);
      if (!make_result(s, trial).valid) continue;
      st = std::move(trial);
      ++st.removed_narrow;
      changed = true;
    }
    if (changed) continue;
    State trial = st;
    for (auto [area, c] : n.charts)
      for (int t : n.tris[c]) trial.label[t] = -1;
    flood_fill(s, normal, trial.label);
    repair(s, normal, p, trial);
    if (!make_result(s, trial).valid) return;
    const size_t left = narrow_charts(s, trial, limit, max_area).charts.size();
    if (left >= n.charts.size()) return;
    trial.removed_narrow += int(n.charts.size() - left);
    st = std::move(trial);
  }
}

}  // namespace polyhex::segment_detail
