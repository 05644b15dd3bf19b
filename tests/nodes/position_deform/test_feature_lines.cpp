// Creases inside a chart put on lattice lines by the PolyCube map (feature_lines.h, position_deform step 4).
#include "nodes/algorithms/shapes.h"
#include "nodes/polycube_segment/polycube_segment.h"
#include "nodes/position_deform/feature_lines.h"
#include "nodes/position_deform/position_deform.h"
#include "nodes/tetrahedralize/tetgen.h"

#include <catch2/catch.hpp>

#include <cmath>

using namespace polyhex;

namespace {

/// The chamfered box's tets and its exact structure: every boundary triangle labelled by its own normal, the
/// 45 degree chamfer (normal (1, 0, 1) / sqrt 2) with +X, so that its crease with the +X side (x = 1, z = 0.25)
/// lies inside the +X chart.
struct Chamfered {
  std::shared_ptr<const TetMesh> tets;
  std::shared_ptr<const PolyCubeSegmentation> seg;
};

Chamfered chamfered_box() {
  TetgenParams tp;
  tp.edge_length = 0.06;
  Chamfered c;
  c.tets = std::make_shared<const TetMesh>(tetrahedralize(make_shape({"chamfered_box", 20}), tp));
  const RowMatrixX3i F = boundary_triangles(*c.tets);
  Eigen::VectorXi label(F.rows());
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = c.tets->V.row(F(f, 0)), b = c.tets->V.row(F(f, 1)), d = c.tets->V.row(F(f, 2));
    // the chamfer's tie broken towards +X for every triangle (rounding would split it between +X and +Z)
    label[f] = closest_label((b - a).cross(d - a).normalized() + Eigen::Vector3d(1e-6, 0, 0));
  }
  c.seg = std::make_shared<const PolyCubeSegmentation>(analyse_polycube_labels(c.tets->V, F, label));
  return c;
}

bool on_inner_crease(const Eigen::Vector3d& x) { return std::abs(x.x() - 1) < 1e-9 && std::abs(x.z() - 0.25) < 1e-9; }

}  // namespace

TEST_CASE("feature_lines: the chamfer's crease inside the +X chart is one line across z", "[position_deform]") {
  const Chamfered c = chamfered_box();
  REQUIRE(c.seg->valid);
  const auto lines = feature_lines(c.tets->V, c.tets->V, *c.seg, 40, 0.025, 0.075, 0.025);
  REQUIRE(lines.size() == 1);
  const FeatureLine& line = lines[0];
  CHECK(c.seg->charts[size_t(line.chart)].label == 0);  // +X
  CHECK(line.axis == 2);
  CHECK(line.length == Approx(0.6).epsilon(1e-9));
  for (int v : line.vertices) CHECK(on_inner_crease(c.tets->V.row(v).transpose()));
  // its ends lie on the y = 0 and y = 0.6 charts (axis Y), not on a Z chart: every crease vertex is in the line
  long crease_vertices = 0;
  for (Eigen::Index v = 0; v < c.tets->V.rows(); ++v) crease_vertices += on_inner_crease(c.tets->V.row(v).transpose());
  CHECK(long(line.vertices.size()) == crease_vertices);
}

TEST_CASE("position_deform: the chamfer's inner crease lands on one lattice level, the chart boundary on another",
          "[position_deform]") {
  const Chamfered c = chamfered_box();
  PositionDeformParams p;
  p.edge_length = 0.07;  // h = 0.07 of the reference length: 0.25 is no multiple of it
  PositionDeformStats st;
  const PolyCubeMap m = position_deform(c.tets, *c.tets, c.seg, p, &st);
  CHECK(st.feature_lines == 1);
  CHECK(st.feature_lines_pinned == 1);
  const double h = m.edge_length;
  double level = std::numeric_limits<double>::quiet_NaN();
  for (Eigen::Index v = 0; v < c.tets->V.rows(); ++v) {
    if (!on_inner_crease(c.tets->V.row(v).transpose())) continue;
    if (std::isnan(level)) level = m.U(v, 2);
    CHECK(m.U(v, 2) == level);  // one level, exactly
  }
  REQUIRE(std::isfinite(level));
  CHECK(std::abs(level / h - std::round(level / h)) < 1e-9);  // a lattice level
  // off: the crease is free and bends with the map
  p.feature_lines = false;
  PositionDeformStats off;
  const PolyCubeMap n = position_deform(c.tets, *c.tets, c.seg, p, &off);
  CHECK(off.feature_lines == 0);
  double lo = 1e9, hi = -1e9;
  for (Eigen::Index v = 0; v < c.tets->V.rows(); ++v)
    if (on_inner_crease(c.tets->V.row(v).transpose())) lo = std::min(lo, n.U(v, 2)), hi = std::max(hi, n.U(v, 2));
  CHECK(hi - lo > 1e-6 * h);
}
