#include "nodes/polycube_segment/polycube_segment.h"

#include "nodes/algorithms/chart_order.h"
#include "nodes/algorithms/reference_length.h"
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

namespace polyhex {
namespace {

using Vec3 = Eigen::Vector3d;
constexpr double kInf = std::numeric_limits<double>::infinity();

struct MeshEdge {
  int v[2];
  int t[2];
};

/// Connectivity and geometry of a closed, manifold triangle surface.
struct Surface {
  const RowMatrixX3d* V = nullptr;
  const RowMatrixX3i* F = nullptr;
  std::vector<MeshEdge> edges;
  std::vector<std::array<int, 3>> tri_nbrs;                  // triangle across each edge
  std::vector<std::vector<int>> vert_tris;                   // triangles around each vertex
  std::vector<std::vector<std::pair<int, int>>> vert_edges;  // (other vertex, edge id)
  std::vector<Vec3> normal;                                  // unit triangle normals
  std::vector<double> area;
  double total_area = 0;
  double diag = 0;  // reference length of the used vertices (nodes/algorithms/reference_length.h)
  double mean_edge = 0;

  int nf() const { return int(F->rows()); }
  Vec3 pos(int v) const { return V->row(v).transpose(); }
  int other(int e, int v) const { return edges[e].v[0] == v ? edges[e].v[1] : edges[e].v[0]; }
};

Surface build_surface(const RowMatrixX3d& V, const RowMatrixX3i& F) {
  if (F.rows() == 0) throw InvalidInput("boundary surface is empty");
  Surface s;
  s.V = &V;
  s.F = &F;
  const int nf = int(F.rows()), nv = int(V.rows());
  struct Half {
    int a, b, t, k;
  };
  std::vector<Half> half;
  half.reserve(3 * size_t(nf));
  for (int t = 0; t < nf; ++t)
    for (int k = 0; k < 3; ++k) {
      int a = F(t, k), b = F(t, (k + 1) % 3);
      if (a < 0 || a >= nv || b < 0 || b >= nv)
        throw InvalidInput("triangle " + std::to_string(t) + " has a vertex index out of range (" + std::to_string(nv) +
                           " vertices)");
      half.push_back({std::min(a, b), std::max(a, b), t, k});
    }
  std::sort(half.begin(), half.end(), [](const Half& x, const Half& y) {
    return x.a != y.a ? x.a < y.a : x.b != y.b ? x.b < y.b : x.t < y.t;
  });
  s.tri_nbrs.assign(nf, {-1, -1, -1});
  s.vert_edges.assign(nv, {});
  for (size_t i = 0; i < half.size();) {
    size_t j = i;
    while (j < half.size() && half[j].a == half[i].a && half[j].b == half[i].b) ++j;
    if (j - i != 2)
      throw InvalidInput("boundary surface is not a closed 2-manifold: edge (" + std::to_string(half[i].a) + ", " +
                         std::to_string(half[i].b) + ") is used by " + std::to_string(j - i) + " triangle(s)");
    int e = int(s.edges.size());
    s.edges.push_back({{half[i].a, half[i].b}, {half[i].t, half[i + 1].t}});
    s.tri_nbrs[half[i].t][half[i].k] = half[i + 1].t;
    s.tri_nbrs[half[i + 1].t][half[i + 1].k] = half[i].t;
    s.vert_edges[half[i].a].push_back({half[i].b, e});
    s.vert_edges[half[i].b].push_back({half[i].a, e});
    i = j;
  }
  s.vert_tris.assign(nv, {});
  s.normal.resize(nf);
  s.area.resize(nf);
  for (int t = 0; t < nf; ++t) {
    Vec3 a = s.pos(F(t, 0)), b = s.pos(F(t, 1)), c = s.pos(F(t, 2));
    Vec3 n = (b - a).cross(c - a);
    s.area[t] = 0.5 * n.norm();
    s.normal[t] = s.area[t] > 0 ? Vec3(n.normalized()) : Vec3::Zero();
    s.total_area += s.area[t];
    for (int k = 0; k < 3; ++k) s.vert_tris[F(t, k)].push_back(t);
  }
  std::vector<int> used;  // the boundary's vertices
  for (int v = 0; v < nv; ++v)
    if (!s.vert_tris[size_t(v)].empty()) used.push_back(v);
  s.diag = reference_length(V(used, Eigen::all));
  double len = 0;
  for (auto& e : s.edges) len += (s.pos(e.v[0]) - s.pos(e.v[1])).norm();
  s.mean_edge = len / double(s.edges.size());
  return s;
}

// ---------------------------------------------------------------------------------------------
// Labels and charts

/// §5.1: triangle normals averaged `iterations` times with their edge neighbours (unit normals,
/// equal weights, so small triangles next to large ones keep their own say).
std::vector<Vec3> smoothed_normals(const Surface& s, int iterations) {
  std::vector<Vec3> n = s.normal;
  for (int it = 0; it < iterations; ++it) {
    std::vector<Vec3> m(n.size());
    for (int t = 0; t < s.nf(); ++t) {
      m[t] = n[t];
      for (int k = 0; k < 3; ++k) m[t] += n[s.tri_nbrs[t][k]];
      if (m[t].norm() > 0) m[t].normalize();
    }
    n.swap(m);
  }
  return n;
}

/// Connected components of equal labels (charts). \return number of charts
int label_components(const Surface& s, const std::vector<int>& label, std::vector<int>& chart) {
  chart.assign(s.nf(), -1);
  int n = 0;
  std::vector<int> stack;
  for (int t0 = 0; t0 < s.nf(); ++t0) {
    if (chart[t0] >= 0) continue;
    chart[t0] = n;
    stack.assign(1, t0);
    while (!stack.empty()) {
      int t = stack.back();
      stack.pop_back();
      for (int u : s.tri_nbrs[t])
        if (chart[u] < 0 && label[u] == label[t]) {
          chart[u] = n;
          stack.push_back(u);
        }
    }
    ++n;
  }
  return n;
}

/// Sorted neighbour charts of every chart (sharing a mesh edge).
std::vector<std::vector<int>> chart_adjacency(const Surface& s, const std::vector<int>& chart, int n) {
  std::vector<std::vector<int>> adj(n);
  for (auto& e : s.edges) {
    int a = chart[e.t[0]], b = chart[e.t[1]];
    if (a == b) continue;
    adj[a].push_back(b);
    adj[b].push_back(a);
  }
  for (auto& a : adj) {
    std::sort(a.begin(), a.end());
    a.erase(std::unique(a.begin(), a.end()), a.end());
  }
  return adj;
}

/// §5.1 straightening: a triangle with two neighbours of a common other label takes that label.
/// Each change raises the number of equally labelled neighbour pairs, so this terminates.
void straighten(const Surface& s, std::vector<int>& label) {
  for (bool changed = true; changed;) {
    changed = false;
    for (int t = 0; t < s.nf(); ++t) {
      const auto& nb = s.tri_nbrs[t];
      int l0 = label[nb[0]], l1 = label[nb[1]], l2 = label[nb[2]];
      int common = (l0 == l1 || l0 == l2) ? l0 : (l1 == l2 ? l1 : -1);
      if (common >= 0 && common != label[t]) {
        label[t] = common;
        changed = true;
      }
    }
  }
}

/// Relabels triangles with label -1 by flood fill from their labelled neighbours. The fill is
/// prioritised by fit: the unlabelled triangle whose smoothed normal is closest to a neighbour's
/// label takes it first, so labels grow along the geometry they fit.
void flood_fill(const Surface& s, const std::vector<Vec3>& normal, std::vector<int>& label) {
  using Item = std::tuple<double, int, int>;  // (fit, triangle, label)
  std::priority_queue<Item> q;
  auto offer = [&](int t) {
    for (int u : s.tri_nbrs[t])
      if (label[u] < 0) q.push({label_dir(label[t]).dot(normal[u]), u, label[t]});
  };
  for (int t = 0; t < s.nf(); ++t)
    if (label[t] >= 0) offer(t);
  while (!q.empty()) {
    auto [fit, t, l] = q.top();
    q.pop();
    if (label[t] >= 0) continue;
    label[t] = l;
    offer(t);
  }
  for (int t = 0; t < s.nf(); ++t)  // a whole component was removed: fall back to the normals
    if (label[t] < 0) label[t] = closest_label(normal[t]);
}

// ---------------------------------------------------------------------------------------------
// PolyCube edges and corners

struct Structure {
  int n = 0;                          // charts
  std::vector<int> chart;             // #F
  std::vector<std::vector<int>> adj;  // chart graph
  std::vector<PolyCubeEdge> edges;
  std::vector<PolyCubeCorner> corners;
  std::vector<int> degree;  // #V chart-boundary mesh edges per vertex
  std::vector<int> label;   // #charts direction label of each chart
};

Structure analyse(const Surface& s, const std::vector<int>& label) {
  Structure st;
  st.n = label_components(s, label, st.chart);
  st.adj = chart_adjacency(s, st.chart, st.n);
  st.label.resize(st.n);
  for (int t = 0; t < s.nf(); ++t) st.label[st.chart[t]] = label[t];
  const int nv = int(s.V->rows());
  std::vector<char> on_boundary(s.edges.size(), 0), visited(s.edges.size(), 0);
  st.degree.assign(nv, 0);
  for (size_t e = 0; e < s.edges.size(); ++e) {
    if (st.chart[s.edges[e].t[0]] == st.chart[s.edges[e].t[1]]) continue;
    on_boundary[e] = 1;
    ++st.degree[s.edges[e].v[0]];
    ++st.degree[s.edges[e].v[1]];
  }
  auto pair_of = [&](int e) {
    int a = st.chart[s.edges[e].t[0]], b = st.chart[s.edges[e].t[1]];
    return std::make_pair(std::min(a, b), std::max(a, b));
  };
  // Walks from vertex v along boundary edge e until a corner (degree != 2) or back to the start.
  auto walk = [&](int v, int e, bool closed) {
    PolyCubeEdge pe;
    std::tie(pe.chart_a, pe.chart_b) = pair_of(e);
    pe.closed = closed;
    pe.vertices.push_back(v);
    int cur = v;
    for (;;) {
      visited[e] = 1;
      int nxt = s.other(e, cur);
      if (closed && nxt == v) break;
      pe.vertices.push_back(nxt);
      if (st.degree[nxt] != 2) break;
      int ne = -1;
      for (auto& [w, f] : s.vert_edges[nxt])
        if (on_boundary[f] && f != e && !visited[f]) ne = f;
      if (ne < 0) break;
      cur = nxt;
      e = ne;
    }
    st.edges.push_back(std::move(pe));
  };
  for (int v = 0; v < nv; ++v) {
    if (st.degree[v] < 3) continue;
    PolyCubeCorner c;
    c.vertex = v;
    c.valence = st.degree[v];
    for (int t : s.vert_tris[v]) c.charts.push_back(st.chart[t]);
    std::sort(c.charts.begin(), c.charts.end());
    c.charts.erase(std::unique(c.charts.begin(), c.charts.end()), c.charts.end());
    st.corners.push_back(std::move(c));
    for (auto& [w, e] : s.vert_edges[v])
      if (on_boundary[e] && !visited[e]) walk(v, e, false);
  }
  for (size_t e = 0; e < s.edges.size(); ++e)
    if (on_boundary[e] && !visited[e]) walk(s.edges[e].v[0], int(e), true);
  return st;
}

// ---------------------------------------------------------------------------------------------
// Separating charts (§5.1)

/// Triangles of `allowed` within geodesic-ish distance `radius` (Dijkstra along mesh edges of
/// allowed triangles) of the `sources` curve: every allowed triangle touching a source vertex (so
/// the band separates the two sides of the curve) plus those whose mean vertex distance <= radius.
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

/// §5.1 axis rule for a separating chart from the labels of its (up to four) neighbours.
/// `two_pairs`: the multi-orientation rule (two pairs with the same axis -> the remaining axis,
/// else the unmatched neighbour whose direction is closest to the band normal); otherwise the wedge
/// rule (only two axes among the neighbours -> the remaining axis, else `wedge_label`).
/// The sign of a "remaining axis" comes from the band's mean normal.
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

/// The chart other than those in `exclude` with the most triangles at vertex v, or -1.
int chart_at(const Surface& s, const std::vector<int>& chart, int v, const std::vector<int>& exclude) {
  std::map<int, int> count;
  for (int t : s.vert_tris[v])
    if (std::find(exclude.begin(), exclude.end(), chart[t]) == exclude.end()) ++count[chart[t]];
  int best = -1;
  for (auto& [c, k] : count)
    if (best < 0 || k > count[best]) best = c;
  return best;
}

struct State {
  std::vector<int> label;  // #F
  std::vector<char> band;  // #F: inserted by a split
  int splits_multi = 0, splits_wedge = 0, splits_ramp = 0, splits_cycle = 0, splits_island = 0, repaired_corners = 0,
      removed_small = 0, removed_narrow = 0;
};

/// §5.1 multi-orientation charts: a chart touching a chart of the opposite direction along a
/// curve is split there by a separating chart of width h (the hex edge length).
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

// ---------------------------------------------------------------------------------------------
// Highly non-planar charts (§5.1)

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

void split_wedges(const Surface& s, const std::vector<Vec3>& normal, const PolyCubeSegmentParams& p, State& st) {
  const double h = p.hex_edge_length * s.diag, min_severity = p.wedge_min_severity * s.diag * s.diag;
  cut_repeatedly(
      s, normal, p, st, st.splits_wedge,
      [&](const Structure& S) {
        return find_extrema(s, S, st.label, p.edge_smoothing_iterations, p.extremum_depth * h);
      },
      [&](const Extremum& x) { return x.severity >= min_severity; });
}

/// A cut across chart `chart` at axis coordinate `level` (the chart's own axis), of severity `severity`.
struct LevelCut {
  int chart;
  double level, severity;
};

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

/// Ramps (extension of §5.1, polycube_segment.h): charts whose vertices span more than `extent`
/// along their own axis (2nd to 98th percentile of the deformed coordinate), cut across their middle
/// level (level_crossings, severity = the chart's span). `only`: when given, the charts to consider.
std::vector<Extremum> find_ramps(const Surface& s, const Structure& S, int smoothing, double extent, double h,
                                 const std::vector<char>* only = nullptr) {
  std::vector<std::vector<int>> verts(S.n);
  for (int t = 0; t < s.nf(); ++t)
    for (int v : (*s.F).row(t)) verts[S.chart[t]].push_back(v);
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
    if (xhi - xlo <= extent) continue;
    cuts.push_back({c, 0.5 * (xlo + xhi), xhi - xlo});
  }
  return level_crossings(s, S, smoothing, cuts, h);
}

void split_ramps(const Surface& s, const std::vector<Vec3>& normal, const PolyCubeSegmentParams& p, State& st) {
  const double h = p.hex_edge_length * s.diag;
  cut_repeatedly(
      s, normal, p, st, st.splits_ramp,
      [&](const Structure& S) { return find_ramps(s, S, p.edge_smoothing_iterations, p.ramp_extent * h, h); },
      [](const Extremum&) { return true; });
}

/// Same-axis chart pairs whose order evidence closes a cycle (chart_order.h), summed over the axes, for
/// the structure S; `cycle_charts`, when given, gets a flag per chart: on one of those cycles; `cuts`,
/// when given, the cuts that open them (cycle_cuts: per group, each of its charts at the group's level).
int order_cycles(const Surface& s, const Structure& S, const TetEdgeGraph& graph, double h,
                 std::vector<char>* cycle_charts, std::vector<LevelCut>* cuts = nullptr,
                 double* dropped_evidence = nullptr) {
  std::vector<std::vector<int>> vcharts(s.V->rows());
  for (int t = 0; t < s.nf(); ++t)
    for (int v : (*s.F).row(t)) {
      auto& cs = vcharts[v];
      if (std::find(cs.begin(), cs.end(), S.chart[t]) == cs.end()) cs.push_back(S.chart[t]);
    }
  if (cycle_charts) cycle_charts->assign(S.n, 0);
  if (cuts) cuts->clear();
  int total = 0;
  for (int a = 0; a < 3; ++a) {
    const AxisChartOrder order = chart_order_evidence(*s.V, graph, vcharts, S.label, S.adj, a, h);
    const OrderAcceptance acc = accept_orders(order.ordered, order.groups);
    total += int(acc.dropped.size());
    if (dropped_evidence)
      for (int i : acc.dropped) *dropped_evidence += order.ordered[i].evidence;
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
    if (cycle_charts)
      for (int c = 0; c < S.n; ++c)
        if (order.chart_group[c] >= 0 && on_cycle[order.chart_group[c]]) (*cycle_charts)[c] = 1;
  }
  return total;
}

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

void split_order_cycles(const Surface& s, const std::vector<Vec3>& normal, const PolyCubeSegmentParams& p,
                        const TetEdgeGraph& graph, State& st) {
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
    const int cycles = order_cycles(s, S, graph, h, &on_cycle, &cuts, &evidence);
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
      const int c2 = order_cycles(s, analyse(s, trial.label), graph, h, nullptr, nullptr, &ev);
      if (c2 > cycles || (c2 == cycles && ev > evidence - kMinEvidenceGain)) continue;
      st = std::move(trial);
      ++st.splits_cycle;
      applied = true;
      break;
    }
    if (!applied) return;
  }
}

// ---------------------------------------------------------------------------------------------
// Result and validity

std::string chart_name(const PolyCubeSegmentation& r, int c) {
  return "chart " + std::to_string(c) + " (" + label_name(r.charts[c].label) + ", " +
         std::to_string(r.charts[c].triangles) + " triangles)";
}

std::string id_list(const std::vector<int>& ids) {
  std::string out;
  for (int i : ids) out += (out.empty() ? "" : ", ") + std::to_string(i);
  return out;
}

/// Fills charts, edges, corners and the validity checks of §5.1.
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

// ---------------------------------------------------------------------------------------------
// Local repairs of problems the §5.1 splits leave (extensions, each accepted only when it improves
// the structure's score, so a valid structure is never touched)

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

/// §5.1 clean-up: straighten chart boundaries, remove small charts bounded by at most
/// p.small_chart_edges edges (their triangles are relabelled by flood fill), repeat until stable.
void clean_up(const Surface& s, const std::vector<Vec3>& normal, const PolyCubeSegmentParams& p, State& st) {
  remove_small_charts(s, normal, p, st, true,
                      [&](const Structure&, int, int edges) { return edges <= p.small_chart_edges; });
}

/// Extension of §5.1 (param final_cleanup): after the splits, small charts with fewer than 4
/// neighbours are removed by flood fill too.
void remove_small_invalid(const Surface& s, const std::vector<Vec3>& normal, const PolyCubeSegmentParams& p,
                          State& st) {
  remove_small_charts(s, normal, p, st, false, [](const Structure& S, int c, int) { return S.adj[c].size() < 4; });
}

/// The extensions after the splits: island cuts, then corner patches (as the params select). If
/// the result is still invalid and p.final_cleanup, the same from the input labelling with the
/// small charts beside a chart of their own axis removed by flood fill first (spurious charts the
/// clean-up's flood fill or the max_splits cap left); the better of the two is kept. If that is
/// still invalid, a second multi-orientation split (below).
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
}

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

/// Extension of §5.1 (params min_chart_extent, narrow_chart_faces): a chart whose vertices span less than
/// min_chart_extent hex edges along one of the two axes of its plane is narrower than the lattice
/// resolves: rounding can put the charts on either side on one plane, the chart collapses to a line or a
/// point, and the map squeezes its triangles and the volume under them (femur: 18 of 93 charts with no
/// area left, 0.05-0.9 hex edges wide, in a cluster at one end of the bone). On a valid structure such
/// charts of less than narrow_chart_faces hex faces are removed one at a time, smallest first, by flood
/// fill from their neighbours, each kept only if the structure stays valid; then, if narrow charts are
/// left (they hold the structure together, so none can go alone), all of them at once, followed by the
/// repairs (island cuts, corner patches), kept only if valid with fewer narrow charts. Separating charts
/// the splits inserted (width h by design) are left alone. Up to 4 rounds, as a removal can make a
/// neighbour narrow.
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

/// One full §5.1 run with a given number of normal-smoothing passes.
/// `graph`: the deformed mesh's tet edges (for the order cycles; only used with p.split_order_cycles).
PolyCubeSegmentation segment_once(const Surface& s, const PolyCubeSegmentParams& p, int smoothing,
                                  const TetEdgeGraph* graph) {
  throw_if_interrupted();
  std::vector<Vec3> normal = smoothed_normals(s, smoothing);
  State st;
  st.label.resize(s.nf());
  st.band.assign(s.nf(), 0);
  for (int t = 0; t < s.nf(); ++t) st.label[t] = closest_label(normal[t]);
  clean_up(s, normal, p, st);
  const double h = p.hex_edge_length * s.diag;
  if (p.split_multi_orientation) split_multi_orientation(s, normal, h, p.max_splits, st);
  if (p.split_wedges) split_wedges(s, normal, p, st);
  if (p.split_ramps) split_ramps(s, normal, p, st);
  if (p.split_order_cycles) split_order_cycles(s, normal, p, *graph, st);
  if (p.final_cleanup) remove_small_invalid(s, normal, p, st);
  repair(s, normal, p, st);
  remove_narrow_charts(s, normal, p, st);
  PolyCubeSegmentation r = make_result(s, st);
  r.order_cycles =
      p.split_order_cycles ? order_cycles(s, analyse(s, st.label), *graph, p.hex_edge_length * s.diag, nullptr) : -1;
  r.smoothing_iterations = smoothing;
  return r;
}

void check_labels(const RowMatrixX3i& F, const Eigen::VectorXi& label) {
  if (label.size() != F.rows())
    throw InvalidInput("labelling has " + std::to_string(label.size()) + " labels for " + std::to_string(F.rows()) +
                       " triangles");
  for (int t = 0; t < label.size(); ++t)
    if (label[t] < 0 || label[t] > 5)
      throw InvalidInput("triangle " + std::to_string(t) + " has label " + std::to_string(label[t]) +
                         ", expected 0..5");
}

}  // namespace

RowMatrixX3i boundary_triangles(const TetMesh& mesh) {
  const int nt = int(mesh.T.rows()), nv = int(mesh.V.rows());
  if (nt == 0) throw InvalidInput("tet mesh has no tetrahedra");
  // outward faces of a positively oriented tet (v1-v0)x(v2-v0).(v3-v0) > 0
  static const int face[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  struct Face {
    std::array<int, 3> key;
    std::array<int, 3> tri;
  };
  std::vector<Face> faces;
  faces.reserve(4 * size_t(nt));
  for (int t = 0; t < nt; ++t) {
    for (int k = 0; k < 4; ++k)
      if (mesh.T(t, k) < 0 || mesh.T(t, k) >= nv)
        throw InvalidInput("tet " + std::to_string(t) + " has vertex index " + std::to_string(mesh.T(t, k)) +
                           " out of range (" + std::to_string(nv) + " vertices)");
    for (auto& f : face) {
      Face x;
      x.tri = {mesh.T(t, f[0]), mesh.T(t, f[1]), mesh.T(t, f[2])};
      x.key = x.tri;
      std::sort(x.key.begin(), x.key.end());
      faces.push_back(x);
    }
  }
  std::sort(faces.begin(), faces.end(), [](const Face& a, const Face& b) { return a.key < b.key; });
  std::vector<std::array<int, 3>> out;
  for (size_t i = 0; i < faces.size();) {
    size_t j = i;
    while (j < faces.size() && faces[j].key == faces[i].key) ++j;
    if (j - i == 1) out.push_back(faces[i].tri);
    i = j;
  }
  RowMatrixX3i F(out.size(), 3);
  for (size_t i = 0; i < out.size(); ++i) F.row(i) << out[i][0], out[i][1], out[i][2];
  return F;
}

PolyCubeSegmentation segment_polycube(const TetMesh& deformed, const PolyCubeSegmentParams& p) {
  RowMatrixX3i F = boundary_triangles(deformed);
  Surface s = build_surface(deformed.V, F);
  std::unique_ptr<TetEdgeGraph> graph;  // the order cycles' evidence needs the tet edges (not built when off)
  if (p.split_order_cycles) graph = std::make_unique<TetEdgeGraph>(deformed.T, int(deformed.V.rows()));
  PolyCubeSegmentation best = segment_once(s, p, p.smoothing_iterations, graph.get());
  int smoothing = p.smoothing_iterations;
  for (int retry = 0; retry < p.fallback_retries && !best.valid; ++retry) {
    smoothing = std::max(1, 2 * smoothing);
    PolyCubeSegmentation r = segment_once(s, p, smoothing, graph.get());
    if (r.valid) {
      r.warnings.push_back("PolyCube structure invalid with " + std::to_string(p.smoothing_iterations) +
                           " normal smoothing passes (" + std::to_string(best.problems.size()) +
                           " problem(s), charts " + id_list(best.failing_charts) + "); fallback: valid with " +
                           std::to_string(smoothing) + " passes");
      best = std::move(r);
    }
  }
  best.source = deformed.source;
  return best;
}

int count_order_cycles(const TetMesh& deformed, const PolyCubeSegmentation& seg, double hex_edge_length) {
  if (seg.F.rows() == 0 || seg.label.size() != seg.F.rows())
    throw InvalidInput("count_order_cycles: the segmentation has no labelled triangles");
  Surface s = build_surface(deformed.V, seg.F);
  std::vector<int> label(seg.label.data(), seg.label.data() + seg.label.size());
  const TetEdgeGraph graph(deformed.T, int(deformed.V.rows()));
  return order_cycles(s, analyse(s, label), graph, hex_edge_length * s.diag, nullptr);
}

PolyCubeSegmentation analyse_polycube_labels(const RowMatrixX3d& V, const RowMatrixX3i& F,
                                             const Eigen::VectorXi& label) {
  check_labels(F, label);
  Surface s = build_surface(V, F);
  State st;
  st.label.assign(label.data(), label.data() + label.size());
  st.band.assign(s.nf(), 0);
  return make_result(s, st);
}

int clean_up_labels(const RowMatrixX3d& V, const RowMatrixX3i& F, Eigen::VectorXi& label,
                    const PolyCubeSegmentParams& p) {
  check_labels(F, label);
  Surface s = build_surface(V, F);
  State st;
  st.label.assign(label.data(), label.data() + label.size());
  clean_up(s, s.normal, p, st);
  label = Eigen::Map<const Eigen::VectorXi>(st.label.data(), s.nf());
  return st.removed_small;
}

std::pair<int, int> repair_polycube_labels(const RowMatrixX3d& V, const RowMatrixX3i& F, Eigen::VectorXi& label,
                                           const PolyCubeSegmentParams& p) {
  check_labels(F, label);
  Surface s = build_surface(V, F);
  State st;
  st.label.assign(label.data(), label.data() + label.size());
  st.band.assign(s.nf(), 0);
  repair(s, s.normal, p, st);
  label = Eigen::Map<const Eigen::VectorXi>(st.label.data(), s.nf());
  return {st.splits_island, st.repaired_corners};
}

void require_valid_polycube(const PolyCubeSegmentation& s) {
  if (s.valid) return;
  std::string msg = "invalid PolyCube structure (" + std::to_string(s.charts.size()) + " charts; failing charts " +
                    id_list(s.failing_charts) + "):";
  for (auto& p : s.problems) msg += "\n  " + p;
  throw InvalidInput(msg);
}

}  // namespace polyhex
