/// @file segment_splits.cpp
/// @brief The §5.1 splits (multi-orientation charts, wedges) and the ramp and order-cycle cuts.
#include "nodes/algorithms/chart_order.h"
#include "nodes/algorithms/reference_length.h"
#include "nodes/algorithms/triangle_tree.h"
#include "nodes/polycube_segment/segment_internal.h"
#include "runtime/cancel.h"
#include "runtime/errors.h"

#include <Eigen/Geometry>
#include <tbb/parallel_for.h>

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

std::vector<int> grow_band(const Surface& s, const std::vector<int>& sources, const std::vector<char>& allowed,
                           double radius) {
  std::vector<double> dist(s.V->rows(), kInf);
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> q;
  for (int v : sources) {
    dist[v] = 0;
    q.push({0.0, v});
  }
  while (!q.empty()) {
    auto [d, u] = q.top();
    q.pop();
    if (d > dist[u] || d > radius) continue;
    for (auto& [w, e] : s.vert_edges[u]) {
      if (!allowed[s.edges[e].t[0]] && !allowed[s.edges[e].t[1]]) continue;
      double nd = d + (s.pos(u) - s.pos(w)).norm();
      if (nd < dist[w]) {
        dist[w] = nd;
        q.push({nd, w});
      }
    }
  }
  std::vector<int> band;
  for (int t = 0; t < s.nf(); ++t) {
    if (!allowed[t]) continue;
    double d0 = dist[(*s.F)(t, 0)], d1 = dist[(*s.F)(t, 1)], d2 = dist[(*s.F)(t, 2)];
    if (d0 == 0 || d1 == 0 || d2 == 0 || (d0 + d1 + d2) / 3 <= radius) band.push_back(t);
  }
  return band;
}

int separating_label(const std::vector<int>& nbr_labels, const Vec3& normal, bool two_pairs, int wedge_label) {
  int count[3] = {0, 0, 0};
  for (int l : nbr_labels) ++count[label_axis(l)];
  int distinct = (count[0] > 0) + (count[1] > 0) + (count[2] > 0);
  bool use_remaining = two_pairs
                           ? (distinct == 2 && nbr_labels.size() == 4 && std::max({count[0], count[1], count[2]}) == 2)
                           : distinct == 2;
  if (use_remaining) {
    int r = count[0] == 0 ? 0 : count[1] == 0 ? 1 : 2;
    return 2 * r + (normal[r] >= 0 ? 0 : 1);
  }
  if (!two_pairs && wedge_label >= 0) return wedge_label;
  int best = -1;
  for (int l : nbr_labels)
    if (count[label_axis(l)] == 1 && (best < 0 || label_dir(l).dot(normal) > label_dir(best).dot(normal))) best = l;
  if (best >= 0) return best;
  for (int l = 0; l < 6; ++l)  // no unmatched neighbour: the best direction on an axis none of them uses
    if (count[label_axis(l)] == 0 && (best < 0 || label_dir(l).dot(normal) > label_dir(best).dot(normal))) best = l;
  return best >= 0 ? best : closest_label(normal);
}

Vec3 mean_normal(const Surface& s, const std::vector<Vec3>& normal, const std::vector<int>& tris) {
  Vec3 n = Vec3::Zero();
  for (int t : tris) n += s.area[t] * normal[t];
  return n;
}

int chart_at(const Surface& s, const std::vector<int>& chart, int v, const std::vector<int>& exclude) {
  std::map<int, int> count;
  for (int t : s.vert_tris[v])
    if (std::find(exclude.begin(), exclude.end(), chart[t]) == exclude.end()) ++count[chart[t]];
  int best = -1;
  for (auto& [c, k] : count)
    if (best < 0 || k > count[best]) best = c;
  return best;
}

void split_multi_orientation(const Surface& s, const std::vector<Vec3>& normal, double h, int max_splits, State& st) {
  std::set<std::vector<int>> tried;
  while (st.splits_multi < max_splits) {
    throw_if_interrupted();
    Structure S = analyse(s, st.label);
    // mesh edges between opposite-direction charts, grouped into curves by shared vertices
    std::vector<int> parent(s.V->rows());
    std::iota(parent.begin(), parent.end(), 0);
    std::function<int(int)> find = [&](int x) { return parent[x] == x ? x : parent[x] = find(parent[x]); };
    std::vector<int> opp_edges;
    for (size_t e = 0; e < s.edges.size(); ++e) {
      int a = S.chart[s.edges[e].t[0]], b = S.chart[s.edges[e].t[1]];
      if (a != b && (st.label[s.edges[e].t[0]] ^ 1) == st.label[s.edges[e].t[1]]) {
        opp_edges.push_back(int(e));
        parent[find(s.edges[e].v[0])] = find(s.edges[e].v[1]);
      }
    }
    if (opp_edges.empty()) return;
    std::map<int, std::vector<int>> curves;  // root -> edges
    for (int e : opp_edges) curves[find(s.edges[e].v[0])].push_back(e);
    bool applied = false;
    for (auto& [root, es] : curves) {
      std::vector<int> verts;
      std::map<int, int> curve_degree;
      for (int e : es)
        for (int v : s.edges[e].v) {
          verts.push_back(v);
          ++curve_degree[v];
        }
      std::sort(verts.begin(), verts.end());
      verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
      if (!tried.insert(verts).second) continue;
      int c1 = S.chart[s.edges[es[0]].t[0]], c2 = S.chart[s.edges[es[0]].t[1]];
      std::vector<char> allowed(s.nf(), 0);
      for (int t = 0; t < s.nf(); ++t) allowed[t] = S.chart[t] == c1 || S.chart[t] == c2;
      std::vector<int> band = grow_band(s, verts, allowed, 0.5 * h);
      if (band.empty()) continue;
      // the four neighbours: the two halves and the charts at the curve's ends
      std::vector<int> nbr_labels = {st.label[s.edges[es[0]].t[0]], st.label[s.edges[es[0]].t[1]]};
      for (auto& [v, d] : curve_degree) {
        if (d != 1) continue;
        int c = chart_at(s, S.chart, v, {c1, c2});
        if (c >= 0 && nbr_labels.size() < 4) {
          for (int t : s.vert_tris[v])
            if (S.chart[t] == c) {
              nbr_labels.push_back(st.label[t]);
              break;
            }
        }
      }
      int l = separating_label(nbr_labels, mean_normal(s, normal, band), true, -1);
      for (int t : band) {
        st.label[t] = l;
        st.band[t] = 1;
      }
      ++st.splits_multi;
      applied = true;
      break;  // the structure changed: recompute
    }
    if (!applied) return;
  }
}

namespace {

struct Extremum {
  int tip = -1;  // vertex at the wedge tip
  int chart_a = -1, chart_b = -1;
  double severity = 0;  // area of the triangle with the neighbouring extrema / endpoints
  double width = 0;     // 2D distance of the wedge endpoints in the plane of the two chart axes
  int cut_chart = -1;   // the chart to cut when known (a ramp), else the concave one of chart_a, chart_b
};

/// A smoothed copy of a PolyCube edge's vertex positions (`smoothing` passes of 3-point averaging,
/// endpoints fixed), so that the jaggedness of the triangle boundary does not count as a turn.
std::vector<Vec3> smoothed_edge(const Surface& s, const PolyCubeEdge& e, int smoothing) {
  const size_t n = e.vertices.size();
  std::vector<Vec3> p(n);
  for (size_t i = 0; i < n; ++i) p[i] = s.pos(e.vertices[i]);
  for (int it = 0; it < smoothing; ++it) {
    std::vector<Vec3> q = p;
    for (size_t i = 1; i + 1 < n; ++i) q[i] = (p[i - 1] + p[i] + p[i + 1]) / 3;
    p.swap(q);
  }
  return p;
}

/// Extrema of the smoothed chart edges: points where an edge doubles back along the direction it
/// should run in (the axis neither chart maps to), found with a hysteresis of `depth`.
std::vector<Extremum> find_extrema(const Surface& s, const Structure& S, const std::vector<int>& label, int smoothing,
                                   double depth) {
  std::vector<int> chart_label(S.n);
  for (int t = 0; t < s.nf(); ++t) chart_label[S.chart[t]] = label[t];
  std::vector<Extremum> out;
  for (auto& e : S.edges) {
    int ax_a = label_axis(chart_label[e.chart_a]), ax_b = label_axis(chart_label[e.chart_b]);
    if (e.closed || ax_a == ax_b || e.vertices.size() < 3) continue;
    int c = 3 - ax_a - ax_b;
    const size_t n = e.vertices.size();
    const std::vector<Vec3> p = smoothed_edge(s, e, smoothing);
    // zig-zag: confirm a candidate extremum once the edge has come back by `depth`
    std::vector<size_t> ext;
    int dir = 0;
    size_t cand = 0;
    for (size_t i = 1; i < n; ++i) {
      double x = p[i][c], xc = p[cand][c];
      if (dir == 0) {
        if (std::abs(x - p[0][c]) >= depth) {
          dir = x > p[0][c] ? 1 : -1;
          cand = i;
        }
      } else if (dir * (x - xc) > 0) {
        cand = i;
      } else if (dir * (xc - x) >= depth) {
        ext.push_back(cand);
        dir = -dir;
        cand = i;
      }
    }
    for (size_t j = 0; j < ext.size(); ++j) {
      size_t prev = j > 0 ? ext[j - 1] : 0, next = j + 1 < ext.size() ? ext[j + 1] : n - 1;
      Extremum x;
      x.tip = e.vertices[ext[j]];
      x.chart_a = e.chart_a;
      x.chart_b = e.chart_b;
      x.severity = 0.5 * (p[prev] - p[ext[j]]).cross(p[next] - p[ext[j]]).norm();
      Vec3 d = p[prev] - p[next];
      d[c] = 0;
      x.width = d.norm();
      out.push_back(x);
    }
  }
  return out;
}

/// Area of chart c within distance r of vertex v.
double area_near(const Surface& s, const std::vector<int>& chart, int v, double r, int c) {
  std::vector<char> all(s.nf(), 1);
  double a = 0;
  for (int t : grow_band(s, {v}, all, r))
    if (chart[t] == c) a += s.area[t];
  return a;
}

/// Tries the cuts of chart W from the tip of extremum x, cheapest first (§5.1: cost
/// alpha L (1.1 - Align)); applies the first valid one. \return true when a cut was applied.
bool cut_wedge(const Surface& s, const std::vector<Vec3>& normal, const Structure& S, const Extremum& x,
               const std::vector<Extremum>& all, const PolyCubeSegmentParams& p, State& st) {
  const int a = x.tip;
  double r = std::max(0.25 * x.width, 2 * s.mean_edge);
  bool a_concave = x.cut_chart >= 0 ? x.cut_chart == x.chart_a
                                    : area_near(s, S.chart, a, r, x.chart_a) >= area_near(s, S.chart, a, r, x.chart_b);
  const int W = a_concave ? x.chart_a : x.chart_b, R = a_concave ? x.chart_b : x.chart_a;
  int label_W = -1, label_R = -1;
  for (int t = 0; t < s.nf(); ++t) {
    if (S.chart[t] == W) label_W = st.label[t];
    if (S.chart[t] == R) label_R = st.label[t];
  }
  // vertex classes for chart W: 2 = interior (all triangles in W), 1 = on W's boundary, 0 = off W
  std::vector<char> cls(s.V->rows(), 0);
  for (int v = 0; v < int(s.V->rows()); ++v) {
    int in = 0;
    for (int t : s.vert_tris[v]) in += S.chart[t] == W;
    cls[v] = in == 0 ? 0 : in == int(s.vert_tris[v].size()) ? 2 : 1;
  }
  // §5.1: search from the tip through W for boundary vertices of W (Dijkstra: L is the path length)
  std::vector<double> dist(s.V->rows(), kInf);
  std::vector<int> pred(s.V->rows(), -1);
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> q;
  dist[a] = 0;
  q.push({0.0, a});
  std::vector<int> ends;
  while (!q.empty()) {
    auto [d, u] = q.top();
    q.pop();
    if (d > dist[u]) continue;
    if (u != a && cls[u] == 1) {
      ends.push_back(u);
      continue;
    }
    for (auto& [w, e] : s.vert_edges[u]) {
      if (cls[w] == 0 || (S.chart[s.edges[e].t[0]] != W && S.chart[s.edges[e].t[1]] != W)) continue;
      if (u == a && cls[w] == 1) continue;  // a cut runs through W, not along its boundary
      double nd = d + (s.pos(u) - s.pos(w)).norm();
      if (nd < dist[w]) {
        dist[w] = nd;
        pred[w] = u;
        q.push({nd, w});
      }
    }
  }
  const double band_width = 0.5 * x.width;
  struct Cand {
    double cost;
    int b;
  };
  std::vector<Cand> cands;
  for (int b : ends) {
    Vec3 d = s.pos(b) - s.pos(a);
    if (d.norm() < band_width) continue;  // would end inside its own separating chart
    double align = d.normalized().cwiseAbs().maxCoeff();
    double alpha = 1.0;
    for (auto& y : all)
      if (y.tip != a && cls[y.tip] != 0 && (s.pos(y.tip) - s.pos(b)).norm() <= std::max(band_width, s.mean_edge))
        alpha = 0.5;  // the cut resolves two extrema at once
    cands.push_back({alpha * dist[b] * (1.1 - align), b});
  }
  std::sort(cands.begin(), cands.end(), [](const Cand& u, const Cand& v) { return u.cost < v.cost; });
  std::vector<char> allowed(s.nf(), 0);
  for (int t = 0; t < s.nf(); ++t) allowed[t] = S.chart[t] == W;
  const int tests = std::min<int>(int(cands.size()), p.max_cut_candidates);
  for (int i = 0; i < tests; ++i) {
    std::vector<int> path;
    for (int v = cands[i].b; v >= 0; v = pred[v]) path.push_back(v);
    std::vector<int> band = grow_band(s, path, allowed, 0.5 * band_width);
    int E = chart_at(s, S.chart, cands[i].b, {W});
    std::vector<int> nbr_labels = {label_W, label_W, label_R};
    if (E >= 0)
      for (int t : s.vert_tris[cands[i].b])
        if (S.chart[t] == E) {
          nbr_labels.push_back(st.label[t]);
          break;
        }
    int l = separating_label(nbr_labels, mean_normal(s, normal, band), false, label_R);
    std::vector<int> trial = st.label;
    for (int t : band) trial[t] = l;
    std::vector<int> chart;
    int n = label_components(s, trial, chart);
    auto adj = chart_adjacency(s, chart, n);
    std::set<int> pieces, touched;
    std::vector<char> in_band(s.nf(), 0);
    for (int t : band) in_band[t] = 1;
    for (int t = 0; t < s.nf(); ++t) {
      if (S.chart[t] != W) continue;
      touched.insert(chart[t]);
      if (!in_band[t]) pieces.insert(chart[t]);
    }
    // §5.1 valid cut: W is split and no resulting chart has three or fewer neighbours (nor touches
    // its opposite direction)
    bool ok = pieces.size() >= 2;
    std::vector<int> chart_label(n);
    for (int t = 0; t < s.nf(); ++t) chart_label[chart[t]] = trial[t];
    for (int c : touched) {
      ok = ok && adj[c].size() >= 4;
      for (int d : adj[c]) ok = ok && label_axis(chart_label[d]) != label_axis(chart_label[c]);
    }
    if (!ok) continue;
    st.label.swap(trial);
    for (int t : band) st.band[t] = 1;
    return true;
  }
  return false;
}

/// The cut loop shared by wedges and ramps: analyse the structure, find the cut starts (`find`: all of
/// them, the cut's cost pairs starts among them), try those `eligible` and not failed before in
/// decreasing severity (§5.1), apply the first valid cut (cut_wedge) and count it; until none applies or
/// `count` reaches p.max_splits.
template <class Find, class Eligible>
void cut_repeatedly(const Surface& s, const std::vector<Vec3>& normal, const PolyCubeSegmentParams& p, State& st,
                    int& count, Find find, Eligible eligible) {
  std::set<int> failed_tips;
  while (count < p.max_splits) {
    throw_if_interrupted();
    Structure S = analyse(s, st.label);
    const std::vector<Extremum> all = find(S);
    std::vector<Extremum> todo;
    for (auto& x : all)
      if (eligible(x) && !failed_tips.count(x.tip)) todo.push_back(x);
    // stable: equal severities keep the order of the search (a ramp's crossings, edge by edge)
    std::stable_sort(todo.begin(), todo.end(),
                     [](const Extremum& u, const Extremum& v) { return u.severity > v.severity; });
    bool applied = false;
    for (auto& x : todo) {
      if (cut_wedge(s, normal, S, x, all, p, st)) {
        ++count;
        applied = true;
        break;
      }
      failed_tips.insert(x.tip);
    }
    if (!applied) return;
  }
}

}  // namespace

void split_wedges(const Surface& s, const std::vector<Vec3>& normal, const PolyCubeSegmentParams& p, State& st) {
  const double h = p.hex_edge_length * s.diag, min_severity = p.wedge_min_severity * s.diag * s.diag;
  cut_repeatedly(
      s, normal, p, st, st.splits_wedge,
      [&](const Structure& S) {
        return find_extrema(s, S, st.label, p.edge_smoothing_iterations, p.extremum_depth * h);
      },
      [&](const Extremum& x) { return x.severity >= min_severity; });
}

namespace {

/// Each crossing of a cut's level by one of its chart's smoothed edges is a cut start (an Extremum with
/// cut_chart set, the cut's severity, width 2h: a separating chart of width h). Edges first, then their
/// two sides, then the chart's cuts in the given order.
std::vector<Extremum> level_crossings(const Surface& s, const Structure& S, int smoothing,
                                      const std::vector<LevelCut>& cuts, double h) {
  std::vector<std::vector<const LevelCut*>> by_chart(S.n);
  for (auto& c : cuts) by_chart[c.chart].push_back(&c);
  std::vector<Extremum> out;
  for (auto& e : S.edges) {
    if (e.vertices.size() < 3 || (by_chart[e.chart_a].empty() && by_chart[e.chart_b].empty())) continue;
    const size_t n = e.vertices.size();
    const std::vector<Vec3> p = smoothed_edge(s, e, smoothing);
    for (int side = 0; side < 2; ++side) {
      const int c = side == 0 ? e.chart_a : e.chart_b, other = side == 0 ? e.chart_b : e.chart_a;
      const int ax = label_axis(S.label[c]);
      for (const LevelCut* cut : by_chart[c])
        for (size_t i = 0; i + 1 < n; ++i) {
          double u = p[i][ax] - cut->level, w = p[i + 1][ax] - cut->level;
          if ((u < 0) == (w < 0)) continue;
          Extremum x;
          x.tip = e.vertices[std::abs(u) <= std::abs(w) ? i : i + 1];
          x.chart_a = c;
          x.chart_b = other;
          x.cut_chart = c;
          x.severity = cut->severity;
          x.width = 2 * h;
          out.push_back(x);
        }
    }
  }
  return out;
}

/// A flat chart of the input is a ramp only when it climbs more than this share of the solid's depth
/// behind it: flattening it puts its low and its high end on one plane, so the map then stretches or
/// squeezes the solid behind it by more than half its depth.
constexpr double kRampDepthShare = 0.5;

/// Of a flat chart (98 % of its area with an input normal, creases->normal, within 20 degrees of its
/// direction): the area-weighted median depth of the solid behind it, along its axis into the solid (the first crossing
/// of the surface from each triangle's centroid).
double depth_behind(const Surface& s, const Structure& S, int c, const std::vector<int>& tris,
                    const TriangleTree& tree) {
  const int l = S.label[c], ax = label_axis(l);
  Vec3 inward = Vec3::Zero();
  inward[ax] = l % 2 == 0 ? -1 : 1;
  std::vector<std::pair<double, double>> depth;  // (depth, area)
  double total = 0;
  for (int t : tris) {
    const Vec3 o = (s.pos((*s.F)(t, 0)) + s.pos((*s.F)(t, 1)) + s.pos((*s.F)(t, 2))) / 3.0;
    depth.emplace_back(tree.first_crossing(o, inward, 1e-9 * s.diag).first, s.area[t]);
    total += s.area[t];
  }
  std::sort(depth.begin(), depth.end());
  double sum = 0;
  for (const auto& [d, a] : depth)
    if ((sum += a) >= 0.5 * total) return d;
  return depth.empty() ? kInf : depth.back().first;
}

/// Ramps (extension of §5.1, polycube_segment.h): charts whose vertices span more than `extent`
/// along their own axis (2nd to 98th percentile of the deformed coordinate), cut across their middle
/// level (level_crossings, severity = the chart's span). `only`: when given, the charts to consider.
/// With `creases` and `tree` (the surface's triangles), a flat chart of the input is a ramp from
/// `planar_extent` when it also climbs more than kRampDepthShare of the depth behind it.
std::vector<Extremum> find_ramps(const Surface& s, const Structure& S, int smoothing, double extent, double h,
                                 const std::vector<char>* only = nullptr, const InputCreases* creases = nullptr,
                                 const TriangleTree* tree = nullptr, double planar_extent = kInf) {
  std::vector<std::vector<int>> verts(S.n), tris(S.n);
  for (int t = 0; t < s.nf(); ++t) {
    tris[S.chart[t]].push_back(t);
    for (int v : (*s.F).row(t)) verts[S.chart[t]].push_back(v);
  }
  // per chart, its area and the part of it whose input normal is within 20 degrees of the chart's direction
  std::vector<double> area(S.n, 0.0), flat(S.n, 0.0);
  if (creases && tree)
    for (int t = 0; t < s.nf(); ++t) {
      const int l = S.label[S.chart[t]];
      const double along = creases->normal[size_t(t)][label_axis(l)] * (l % 2 == 0 ? 1 : -1);
      area[S.chart[t]] += s.area[t];
      if (along >= std::cos(20.0 * M_PI / 180)) flat[S.chart[t]] += s.area[t];
    }
  std::vector<LevelCut> cuts;
  for (int c = 0; c < S.n; ++c) {
    auto& vs = verts[c];
    std::sort(vs.begin(), vs.end());
    vs.erase(std::unique(vs.begin(), vs.end()), vs.end());
    if (vs.size() < 8 || (only && !(*only)[c])) continue;
    const int ax = label_axis(S.label[c]);
    std::vector<double> x(vs.size());
    for (size_t i = 0; i < vs.size(); ++i) x[i] = s.pos(vs[i])[ax];
    const size_t lo = size_t(0.02 * double(x.size())), hi = x.size() - 1 - lo;
    std::nth_element(x.begin(), x.begin() + lo, x.end());
    double xlo = x[lo];
    std::nth_element(x.begin(), x.begin() + hi, x.end());
    double xhi = x[hi];
    const double span = xhi - xlo;
    const bool ramp = span > extent || (tree && span > planar_extent && flat[c] >= 0.98 * area[c] &&
                                        span > kRampDepthShare * depth_behind(s, S, c, tris[c], *tree));
    if (ramp) cuts.push_back({c, 0.5 * (xlo + xhi), span});
  }
  return level_crossings(s, S, smoothing, cuts, h);
}

}  // namespace

void split_ramps(const Surface& s, const std::vector<Vec3>& normal, const PolyCubeSegmentParams& p,
                 const InputCreases* creases, State& st) {
  const double h = p.hex_edge_length * s.diag;
  const std::unique_ptr<TriangleTree> tree = creases ? std::make_unique<TriangleTree>(*s.V, *s.F) : nullptr;
  cut_repeatedly(
      s, normal, p, st, st.splits_ramp,
      [&](const Structure& S) {
        return find_ramps(s, S, p.edge_smoothing_iterations, p.ramp_extent * h, h, nullptr, creases, tree.get(),
                          p.ramp_extent_planar * h);
      },
      [](const Extremum&) { return true; });
}

int order_cycles(const Surface& s, const Structure& S, const TetEdgeGraph& graph, double h,
                 const std::vector<char>* crease_vertex, std::vector<char>* cycle_charts, std::vector<LevelCut>* cuts,
                 double* dropped_evidence) {
  std::vector<std::vector<int>> vcharts(s.V->rows());
  for (int t = 0; t < s.nf(); ++t)
    for (int v : (*s.F).row(t)) {
      auto& cs = vcharts[v];
      if (std::find(cs.begin(), cs.end(), S.chart[t]) == cs.end()) cs.push_back(S.chart[t]);
    }
  if (cycle_charts) cycle_charts->assign(S.n, 0);
  if (cuts) cuts->clear();
  int total = 0;
  std::array<AxisChartOrder, 3> orders;  // the three axes' evidence is independent: side by side
  tbb::parallel_for(0, 3, [&](int a) {
    orders[size_t(a)] = chart_order_evidence(*s.V, graph, vcharts, S.label, S.adj, a, h, crease_vertex);
  });
  for (int a = 0; a < 3; ++a) {
    const AxisChartOrder& order = orders[size_t(a)];
    const OrderAcceptance acc = accept_orders(order.ordered, order.groups);
    // A self bridge is a cycle of one group: it is cut between the chart's top and its foot.
    total += int(acc.dropped.size() + order.self_bridges.size());
    if (dropped_evidence) {
      for (int i : acc.dropped) *dropped_evidence += order.ordered[i].evidence;
      for (const AxisChartOrder::SelfBridge& sb : order.self_bridges) *dropped_evidence += (sb.top - sb.foot) / h;
    }
    if (!cycle_charts && !cuts) continue;
    std::vector<char> on_cycle(order.groups, 0);
    for (int i : acc.dropped) {
      const std::vector<int> cycle = order_cycle(acc, order.ordered[i]);
      for (int g : cycle) on_cycle[g] = 1;
      if (cuts)
        for (const CycleCut& cc : cycle_cuts(order, cycle, h))
          for (int c = 0; c < S.n; ++c)
            if (order.chart_group[c] == cc.group) cuts->push_back({c, cc.level, cc.excess});
    }
    for (const AxisChartOrder::SelfBridge& sb : order.self_bridges) {
      on_cycle[sb.group] = 1;
      if (cuts && sb.top - sb.foot >= h)
        for (int c = 0; c < S.n; ++c)
          if (order.chart_group[c] == sb.group) cuts->push_back({c, 0.5 * (sb.top + sb.foot), sb.top - sb.foot});
    }
    if (cycle_charts)
      for (int c = 0; c < S.n; ++c)
        if (order.chart_group[c] >= 0 && on_cycle[order.chart_group[c]]) (*cycle_charts)[c] = 1;
  }
  return total;
}

namespace {

/// Order cycles (extension of §5.1, polycube_segment.h): while the charts' order evidence contradicts
/// itself, cut one chart of a cycle across its axis. First the cuts the cycles ask for (cycle_cuts: a
/// chart whose part near the group below it sits higher than its part near the group above it, cut
/// between the two heights; largest difference first), then each chart on a cycle across its middle
/// level (the ramp cut, any span above the wedge rule's depth), the chart that spans most first. A cut is
/// kept only when it is valid and lowers the number of cycle-closing pairs, or keeps it and lowers their
/// summed evidence (hex edges) by kMinEvidenceGain: on a helix one cut rarely opens a cycle, it moves it
/// to the next chart with a smaller contradiction (the twisted bar: 9.5 -> 9.2 -> 7.5 -> ... -> 0.6 -> 0
/// hex edges over 9 cuts, where requiring fewer pairs stopped at 1 pair of 2.0 hex edges).
constexpr double kMinEvidenceGain = 0.1;

}  // namespace

void split_order_cycles(const Surface& s, const std::vector<Vec3>& normal, const PolyCubeSegmentParams& p,
                        const TetEdgeGraph& graph, const std::vector<char>* crease_vertex, State& st) {
  const double h = p.hex_edge_length * s.diag;
  auto by_severity = [](std::vector<Extremum> v) {
    std::stable_sort(v.begin(), v.end(), [](const Extremum& u, const Extremum& w) { return u.severity > w.severity; });
    return v;
  };
  while (st.splits_cycle < p.max_splits) {
    throw_if_interrupted();
    Structure S = analyse(s, st.label);
    std::vector<char> on_cycle;
    std::vector<LevelCut> cuts;
    double evidence = 0;
    const int cycles = order_cycles(s, S, graph, h, crease_vertex, &on_cycle, &cuts, &evidence);
    if (cycles == 0) return;
    const std::vector<Extremum> targeted = by_severity(level_crossings(s, S, p.edge_smoothing_iterations, cuts, h));
    const std::vector<Extremum> middle =
        by_severity(find_ramps(s, S, p.edge_smoothing_iterations, p.extremum_depth * h, h, &on_cycle));
    std::vector<Extremum> all = targeted;
    all.insert(all.end(), middle.begin(), middle.end());
    std::vector<Extremum> todo = all;
    if (int(todo.size()) > p.max_cut_candidates) todo.resize(size_t(p.max_cut_candidates));
    bool applied = false;
    for (auto& x : todo) {
      State trial = st;
      if (!cut_wedge(s, normal, S, x, all, p, trial)) continue;
      double ev = 0;
      const int c2 = order_cycles(s, analyse(s, trial.label), graph, h, crease_vertex, nullptr, nullptr, &ev);
      if (c2 > cycles || (c2 == cycles && ev > evidence - kMinEvidenceGain)) continue;
      st = std::move(trial);
      ++st.splits_cycle;
      applied = true;
      break;
    }
    if (!applied) return;
  }
}

}  // namespace polyhex::segment_detail
