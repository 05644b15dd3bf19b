// [chart-order] the order evidence of same-axis charts (chart_order.h) and the structure extraction's
// order-cycle cuts (polycube_segment.h) on generated meshes.
#include "nodes/algorithms/chart_order.h"
#include "nodes/algorithms/shapes.h"
#include "nodes/polycube_segment/polycube_segment.h"
#include "nodes/polycube_segment/segment_internal.h"
#include "nodes/tetrahedralize/tetgen.h"
#include "tests/helpers/segment_fixtures.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <stdexcept>

using namespace polyhex;
using namespace polyhex::test;

namespace {

/// The structure of m's boundary labelled by each triangle's dominant normal direction.
PolyCubeSegmentation geometric_structure(const TetMesh& m) {
  RowMatrixX3i F = boundary_triangles(m);
  Eigen::VectorXi label(F.rows());
  for (int t = 0; t < F.rows(); ++t) {
    Eigen::Vector3d a = m.V.row(F(t, 0)), b = m.V.row(F(t, 1)), c = m.V.row(F(t, 2));
    Eigen::Vector3d n = (b - a).cross(c - a);
    int ax = 0;
    n.cwiseAbs().maxCoeff(&ax);
    label[t] = 2 * ax + (n[ax] < 0 ? 1 : 0);
  }
  return analyse_polycube_labels(m.V, F, label);
}

struct Evidence {
  std::vector<std::vector<int>> vertex_charts;
  std::vector<int> chart_label;
  std::vector<std::vector<int>> chart_neighbours;
};

Evidence evidence_inputs(const TetMesh& m, const PolyCubeSegmentation& s) {
  Evidence e;
  e.vertex_charts.resize(size_t(m.V.rows()));
  for (int t = 0; t < s.F.rows(); ++t)
    for (int k = 0; k < 3; ++k) {
      auto& cs = e.vertex_charts[size_t(s.F(t, k))];
      if (std::find(cs.begin(), cs.end(), s.chart[t]) == cs.end()) cs.push_back(s.chart[t]);
    }
  for (auto& c : s.charts) e.chart_label.push_back(c.label), e.chart_neighbours.push_back(c.neighbours);
  return e;
}

}  // namespace

TEST_CASE("accept_orders drops the weakest pair of a cycle and order_cycle names the cycle", "[chart-order]") {
  // groups 0 < 1 (evidence 3), 1 < 2 (2), 2 < 0 (1): a cycle; 3 < 1 (5) is consistent with all
  std::vector<OrderedPair> pairs = {{0, 1, 1, 3.0}, {1, 2, 1, 2.0}, {0, 2, -1, 1.0}, {1, 3, -1, 5.0}};
  OrderAcceptance acc = accept_orders(pairs, 4);
  REQUIRE(acc.dropped == std::vector<int>{2});
  // the dropped pair says 2 below 0; the accepted path runs from 0 up to 2 through 1
  CHECK(order_cycle(acc, pairs[2]) == std::vector<int>{0, 1, 2});
  CHECK(acc.up[3] == std::vector<int>{1});
  SECTION("the same three with the evidence reversed drop the other end") {
    pairs[0].evidence = 1.0, pairs[2].evidence = 3.0;
    OrderAcceptance b = accept_orders(pairs, 4);
    REQUIRE(b.dropped == std::vector<int>{0});
    // 1 below 0 is dropped; the accepted path from 1 up: 1 < 2 < 0
    CHECK(order_cycle(b, pairs[0]) == std::vector<int>{1, 2, 0});
  }
  SECTION("without the contradicting pair nothing is dropped") {
    pairs.erase(pairs.begin() + 2);
    CHECK(accept_orders(pairs, 4).dropped.empty());
  }
}

namespace {
/// Accepted orders from a list of "lower < upper" pairs (all with the same evidence, none dropped).
OrderAcceptance chain_orders(const std::vector<std::pair<int, int>>& below, int groups) {
  std::vector<OrderedPair> pairs;
  for (auto [lo, hi] : below) pairs.push_back({lo, hi, 1, 1.0});
  OrderAcceptance acc = accept_orders(pairs, groups);
  REQUIRE(acc.dropped.empty());
  return acc;
}
}  // namespace

TEST_CASE("place_levels keeps every order one level apart and moves the groups least", "[chart-order]") {
  SECTION("a stack of five equal groups at one level spreads both ways, not only up") {
    OrderAcceptance acc = chain_orders({{0, 1}, {1, 2}, {2, 3}, {3, 4}}, 5);
    std::vector<long> k = place_levels(acc, {0.1, 0.1, 0.1, 0.1, 0.1}, {1, 1, 1, 1, 1});
    CHECK(k == std::vector<long>{-2, -1, 0, 1, 2});  // the push alone gives 0..4: a shift of 4
  }
  SECTION("a heavy group stays where it is and the light ones below it make room") {
    // three light groups (weight 1) below a heavy one (1000), all at level 0
    OrderAcceptance acc = chain_orders({{0, 1}, {1, 2}, {2, 3}}, 4);
    std::vector<long> k = place_levels(acc, {0, 0, 0, 0}, {1, 1, 1, 1000});
    CHECK(k == std::vector<long>{-3, -2, -1, 0});
  }
  SECTION("two groups: the weighted least-squares answer, rounded") {
    // x = t + (-λ/3, λ) with x_1 - x_0 = 1: λ = 0.6, x = (-0.2, 0.8)
    OrderAcceptance acc = chain_orders({{0, 1}}, 2);
    CHECK(place_levels(acc, {0.0, 0.2}, {3, 1}) == std::vector<long>{0, 1});
    // the other way round, the light group is the lower one: x = (-0.6, 0.4) -> (-1, 0)
    CHECK(place_levels(acc, {0.0, 0.2}, {1, 3}) == std::vector<long>{-1, 0});
  }
  SECTION("an order that asks for 2 levels gets them, in the placement and in the push") {
    OrderAcceptance acc = chain_orders({{0, 1}, {1, 2}}, 3);
    REQUIRE(acc.gap[0] == std::vector<int>{1});  // accept_orders asks for 1 level per order
    acc.gap[0][0] = 2;                           // 0 -> 1 asks for 2
    // x = t + (-λ/3, λ) on 0 -> 1 with x_1 - x_0 = 2: λ = 1.35, (-0.05, 1.95) from (0.4, 0.6); 1 -> 2 holds
    CHECK(place_levels(acc, {0.4, 0.6, 3.4}, {3, 1, 1}) == std::vector<long>{0, 2, 3});
    std::vector<long> k{0, 0, 0};
    push_levels(acc, k);
    CHECK(k == std::vector<long>{0, 2, 3});
  }
  SECTION("orders that hold with room leave the plain rounding") {
    OrderAcceptance acc = chain_orders({{0, 1}, {1, 2}}, 3);
    CHECK(place_levels(acc, {0.3, 2.4, 5.6}, {1, 1, 1}) == std::vector<long>{0, 2, 6});
  }
  SECTION("random acyclic orders all hold, and no group moves further than the push would move one") {
    std::uint32_t seed = 12345;
    auto rnd = [&] { return (seed = seed * 1664525u + 1013904223u) / 4294967296.0; };
    for (int trial = 0; trial < 20; ++trial) {
      const int n = 12;
      std::vector<std::pair<int, int>> below;
      for (int i = 0; i < n; ++i)
        for (int j = i + 1; j < n; ++j)
          if (rnd() < 0.25) below.push_back({i, j});  // i < j: acyclic
      OrderAcceptance acc = chain_orders(below, n);
      std::vector<double> t(n), w(n);
      for (int g = 0; g < n; ++g) t[g] = 4 * rnd(), w[g] = 1 + 99 * rnd();
      std::vector<long> k = place_levels(acc, t, w);
      for (auto [lo, hi] : below) CHECK(k[hi] >= k[lo] + 1);
      // the push from the rounded targets (the old placement)
      std::vector<long> push(n);
      for (int g = 0; g < n; ++g) push[g] = std::lround(t[g]);
      for (int g = 0; g < n; ++g)  // groups are in topological order
        for (int hi : acc.up[g]) push[hi] = std::max(push[hi], push[g] + 1);
      double cost = 0, cost_push = 0;
      for (int g = 0; g < n; ++g)
        cost += w[g] * (k[g] - t[g]) * (k[g] - t[g]), cost_push += w[g] * (push[g] - t[g]) * (push[g] - t[g]);
      CHECK(cost <= cost_push + 1e-9 + 0.25 * std::accumulate(w.begin(), w.end(), 0.0));  // up to the rounding's share
    }
  }
  SECTION("a cycle, mismatched sizes and a weight that is not positive are refused") {
    OrderAcceptance cyc;
    cyc.up = {{1}, {0}};
    CHECK_THROWS_AS(place_levels(cyc, {0, 0}, {1, 1}), std::invalid_argument);
    OrderAcceptance acc = chain_orders({{0, 1}}, 2);
    CHECK_THROWS_AS(place_levels(acc, {0}, {1, 1}), std::invalid_argument);
    CHECK_THROWS_AS(place_levels(acc, {0, 0}, {1, 0}), std::invalid_argument);
  }
}

TEST_CASE("chart_order_evidence on a box: the X charts' distance is the box's length", "[chart-order]") {
  // [0,2]x[0,1]x[0,1]: per axis two groups, ordered -face below +face by the box's extent
  TetMesh m = box_tets(2, 1, 1, 4);
  PolyCubeSegmentation s = geometric_structure(m);
  REQUIRE(s.valid);
  REQUIRE(s.charts.size() == 6);
  Evidence e = evidence_inputs(m, s);
  const TetEdgeGraph graph(m.T, int(m.V.rows()));
  const double h = 0.1;
  for (int a = 0; a < 3; ++a) {
    INFO("axis " << a);
    AxisChartOrder o = chart_order_evidence(m.V, graph, e.vertex_charts, e.chart_label, e.chart_neighbours, a, h);
    const double extent = a == 0 ? 2.0 : 1.0;
    REQUIRE(o.groups == 2);
    CHECK(o.merged_same_axis_charts == 0);
    // group of the +face (label 2a) and of the -face (2a + 1)
    int plus = -1, minus = -1;
    for (size_t c = 0; c < s.charts.size(); ++c) {
      if (s.charts[c].label == 2 * a) plus = o.chart_group[c];
      if (s.charts[c].label == 2 * a + 1) minus = o.chart_group[c];
    }
    REQUIRE(plus >= 0);
    REQUIRE(minus >= 0);
    CHECK(o.group_mean[size_t(plus)] == Approx(extent).margin(1e-12));
    CHECK(o.group_mean[size_t(minus)] == Approx(0).margin(1e-12));
    // the Voronoi regions meet in the middle: one distance sample, exactly the extent
    REQUIRE(o.distance_samples.size() == 1);
    const double delta = o.distance_samples[0].p == minus ? o.distance_samples[0].delta : -o.distance_samples[0].delta;
    CHECK(delta == Approx(extent).margin(1e-12));
    // where the regions meet, on each group: the planes themselves (the faces are flat)
    const auto& smp = o.distance_samples[0];
    CHECK((smp.p == minus ? smp.p_at : smp.q_at) == Approx(0).margin(1e-12));
    CHECK((smp.p == minus ? smp.q_at : smp.p_at) == Approx(extent).margin(1e-12));
    CHECK(smp.q_at - smp.p_at == Approx(smp.delta).margin(1e-12));
    // one ordered pair (the distance pair; the four bridging charts say the same): - below +
    REQUIRE(o.ordered.size() == 1);
    const OrderedPair& op = o.ordered[0];
    CHECK(op.sign * (op.p == minus ? 1 : -1) == 1);
    CHECK(op.evidence == Approx(extent / h));
    CHECK(accept_orders(o.ordered, o.groups).dropped.empty());
    // vertices of the faces carry their group, interior ones none
    for (int v = 0; v < m.V.rows(); ++v) {
      const double x = m.V(v, a);
      const int want = x == 0 ? minus : x == extent ? plus : -1;
      if (o.vertex_group[size_t(v)] != want) FAIL("vertex " << v << " group " << o.vertex_group[size_t(v)]);
    }
  }
}

TEST_CASE("cycle_cuts: a group whose part near the group below sits above its part near the group above is cut between",
          "[chart-order]") {
  // a helical stair of three groups along a: 0 < 1 (1's region meets 0's at 1's height 3),
  // 1 < 2, 2 < 0 (dropped). Heights (g at its interface with o) chosen so that only group 2 is tilted the
  // wrong way: near 1 (below it) at 9, near 0 (above it) at 2.
  AxisChartOrder o;
  o.groups = 3;
  auto add = [&](int g, double g_at, int other, double other_at) {
    AxisChartOrder::Sample smp{std::min(g, other), std::max(g, other), 0};
    smp.p_at = g < other ? g_at : other_at;
    smp.q_at = g < other ? other_at : g_at;
    smp.delta = smp.q_at - smp.p_at;
    o.distance_samples.push_back(smp);
  };
  add(0, 1.0, 1, 3.0);  // 0 at 1 below 1 at 3
  add(1, 5.0, 2, 9.0);  // 1 at 5 below 2 at 9
  add(2, 2.0, 0, 0.5);  // 2 at 2 "below" 0 at 0.5: the contradiction
  std::sort(o.distance_samples.begin(), o.distance_samples.end(),
            [](const auto& x, const auto& y) { return std::make_pair(x.p, x.q) < std::make_pair(y.p, y.q); });
  const std::vector<int> cycle{0, 1, 2};  // 0 < 1 < 2, and the dropped pair 2 < 0 closes it
  // group 0: near 2 (below) at 0.5, near 1 (above) at 1: fine; group 1: near 0 at 3, near 2 at 5: fine;
  // group 2: near 1 (below) at 9, near 0 (above) at 2: excess 7, cut at 5.5
  std::vector<CycleCut> cuts = cycle_cuts(o, cycle, 0.5);
  REQUIRE(cuts.size() == 1);
  CHECK(cuts[0].group == 2);
  CHECK(cuts[0].level == Approx(5.5));
  CHECK(cuts[0].excess == Approx(7.0));
  SECTION("a smaller difference than min_excess is not a cut") { CHECK(cycle_cuts(o, cycle, 7.5).empty()); }
  SECTION("a group met by a bridged pair (no samples) is skipped") {
    o.distance_samples.erase(o.distance_samples.begin() + 1);  // (1, 2)
    CHECK(cycle_cuts(o, cycle, 0.5).empty());
  }
  SECTION("group 2 tilted the other way (its part near 0 the higher) asks for no cut") {
    for (auto& smp : o.distance_samples)
      if (smp.p == 0 && smp.q == 2) smp.q_at = 9.5, smp.delta = smp.q_at - smp.p_at;
    CHECK(cycle_cuts(o, cycle, 0.5).empty());
  }
}

TEST_CASE("self bridges: a ring's top, on a step wall's top and at its foot, is one group the wall has no height in",
          "[chart-order]") {
  // stepped_ring: its top climbs from y = 0.3 to 0.4 around the ring and drops by a wall 0.1 high (-Z, at
  // z = 0.5): the top is one +Y chart, on the wall's top edge (y = 0.4) and along its foot (y = 0.3)
  const SurfaceMesh surface = make_shape({"stepped_ring", 24});
  TetgenParams tp;
  tp.edge_length = 0.05;
  const TetMesh m = tetrahedralize(surface, tp);
  // labels by the dominant normal (not a valid structure: the wall has three neighbours; the order evidence
  // needs none)
  const PolyCubeSegmentation s = geometric_structure(m);
  Evidence e = evidence_inputs(m, s);
  const TetEdgeGraph graph(m.T, int(m.V.rows()));
  const double h = 0.02;
  // the crease vertices, as the structure extraction finds them (the input's creases along flat faces)
  const segment_detail::Surface surf = segment_detail::build_surface(m.V, s.F);
  const std::vector<char> crease = segment_detail::input_creases(surf, m.V, h).vertex;
  for (int a = 0; a < 3; ++a) {
    INFO("axis " << a);
    CHECK(chart_order_evidence(m.V, graph, e.vertex_charts, e.chart_label, e.chart_neighbours, a, h)
              .self_bridges.empty());  // looked for along creases only
    AxisChartOrder o =
        chart_order_evidence(m.V, graph, e.vertex_charts, e.chart_label, e.chart_neighbours, a, h, &crease);
    if (a != 1) {
      CHECK(o.self_bridges.empty());
      continue;
    }
    REQUIRE(o.self_bridges.size() == 1);
    const auto& sb = o.self_bridges[0];
    CHECK(s.charts[size_t(sb.chart)].label == 5);  // the wall, facing -Z
    int top_chart = -1;
    for (size_t c = 0; c < s.charts.size(); ++c)
      if (o.chart_group[c] == sb.group) top_chart = int(c);
    REQUIRE(top_chart >= 0);
    CHECK(s.charts[size_t(top_chart)].label == 2);
    CHECK(sb.top == Approx(0.4).margin(1e-9));  // the wall's top edge and its foot, exactly
    CHECK(sb.foot == Approx(0.3).margin(1e-9));
  }
  SECTION("the structure extraction cuts the top between the two heights: no order cycle is left") {
    PolyCubeSegmentParams p;
    p.hex_edge_length = h / m.V.colwise().maxCoeff().norm();      // about h; the order tests need only h < 0.05
    const PolyCubeSegmentation cut = segment_polycube(m, p, &m);  // the undeformed tets: the input's creases
    REQUIRE(cut.valid);
    CHECK(cut.splits_order_cycle >= 1);
    CHECK(cut.order_cycles == 0);
    int tops = 0;
    for (auto& c : cut.charts) tops += c.label == 2;
    CHECK(tops >= 2);  // the high part and the low part of the top, each on its own plane
    p.split_order_cycles = false;
    const PolyCubeSegmentation whole = segment_polycube(m, p, &m);
    REQUIRE(whole.valid);
    int whole_tops = 0;
    for (auto& c : whole.charts) whole_tops += c.label == 2;
    CHECK(whole_tops == 1);
  }
}
