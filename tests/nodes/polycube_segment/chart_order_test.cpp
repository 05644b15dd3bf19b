// [chart-order] the order evidence of same-axis charts (chart_order.h) and the structure extraction's
// order-cycle cuts (polycube_segment.h) on generated meshes.
#include <catch2/catch.hpp>

#include <cmath>

#include "nodes/polycube_segment/chart_order.h"
#include "nodes/polycube_segment/polycube_segment.h"
#include "tests/nodes/polycube_segment/fixtures.h"

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
