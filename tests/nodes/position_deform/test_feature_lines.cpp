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

namespace {

/// A block 1 x 0.6 x 0.5 (x, y, z) with a V-shaped slot cut along y from its top: walls from x = 0.45 and 0.55
/// at z = 0.5 down to the bottom edge x = 0.5, z = 0.25 (they meet at 22.6 degrees). Labelled as the
/// segmentation labels such a slot after the rotation stage has rounded its bottom: every triangle by its own
/// normal, but those on the walls below z = 0.32 +Z, a floor chart with the bottom edge inside it.
Chamfered v_slot_block() {
  SurfaceMesh s;
  s.source = "v_slot_block";
  const double P[7][2] = {{0, 0}, {1, 0}, {1, 0.5}, {0.55, 0.5}, {0.5, 0.25}, {0.45, 0.5}, {0, 0.5}};  // (x, z)
  s.V.resize(14, 3);
  for (int i = 0; i < 7; ++i) {
    s.V.row(i) << P[i][0], 0.0, P[i][1];
    s.V.row(7 + i) << P[i][0], 0.6, P[i][1];
  }
  std::vector<Eigen::RowVector3i> F;
  // the caps, fans from the slot's bottom vertex (the outline is star-shaped from it): y = 0 faces -y
  for (int i : {5, 6, 0, 1, 2}) {
    const int j = i == 6 ? 0 : i + 1;
    F.emplace_back(4, j, i);
    F.emplace_back(11, 7 + i, 7 + j);
  }
  for (int i = 0; i < 7; ++i) {  // the sides
    const int j = (i + 1) % 7;
    F.emplace_back(i, j, 7 + j);
    F.emplace_back(i, 7 + j, 7 + i);
  }
  s.F.resize(Eigen::Index(F.size()), 3);
  for (size_t f = 0; f < F.size(); ++f) s.F.row(Eigen::Index(f)) = F[f];
  TetgenParams tp;
  tp.edge_length = 0.05;
  Chamfered c;
  c.tets = std::make_shared<const TetMesh>(tetrahedralize(s, tp));
  const RowMatrixX3i B = boundary_triangles(*c.tets);
  Eigen::VectorXi label(B.rows());
  for (Eigen::Index f = 0; f < B.rows(); ++f) {
    const Eigen::Vector3d a = c.tets->V.row(B(f, 0)), b = c.tets->V.row(B(f, 1)), d = c.tets->V.row(B(f, 2));
    const Eigen::Vector3d n = (b - a).cross(d - a).normalized(), m = (a + b + d) / 3;
    const bool wall = std::abs(n.x()) > 0.9 && m.x() > 0.4 && m.x() < 0.6;
    label[f] = wall && m.z() < 0.32 ? 4 : closest_label(n);
  }
  c.seg = std::make_shared<const PolyCubeSegmentation>(analyse_polycube_labels(c.tets->V, B, label));
  return c;
}

bool on_slot_bottom(const Eigen::Vector3d& x) { return std::abs(x.x() - 0.5) < 1e-9 && std::abs(x.z() - 0.25) < 1e-9; }

}  // namespace

TEST_CASE("position_deform: a V-slot's bottom edge gets a lattice level between its walls, put 2 levels apart",
          "[position_deform]") {
  const Chamfered c = v_slot_block();
  REQUIRE(c.seg->valid);
  PositionDeformParams p;
  p.edge_length = 0.07;
  p.feature_line_room = true;
  PositionDeformStats st;
  const PolyCubeMap m = position_deform(c.tets, *c.tets, c.seg, p, &st);
  REQUIRE(st.feature_lines == 1);
  CHECK(st.feature_lines_given_room == 1);
  CHECK(st.feature_lines_pinned == 1);
  const double h = m.edge_length;
  // the walls' planes (the +X and -X charts between x = 0.4 and 0.6) and the bottom edge's level
  long wall_lo = 1000000, wall_hi = -1000000;
  for (size_t ch = 0; ch < c.seg->charts.size(); ++ch) {
    const int label = c.seg->charts[ch].label;
    if (label != 0 && label != 1) continue;
    double x = 0;
    int n = 0;
    for (Eigen::Index f = 0; f < c.seg->F.rows(); ++f)
      if (c.seg->chart[size_t(f)] == int(ch)) x += c.tets->V(c.seg->F(f, 0), 0), ++n;
    if (n == 0 || x / n < 0.4 || x / n > 0.6) continue;  // the block's own sides
    (label == 0 ? wall_lo : wall_hi) = m.chart_plane[Eigen::Index(ch)];
  }
  CHECK(wall_hi - wall_lo == 2);  // the rounded coordinates (0.45 h^-1 ... 0.55 h^-1) would give 1
  long edge_level = -1;
  for (Eigen::Index v = 0; v < c.tets->V.rows(); ++v) {
    if (!on_slot_bottom(c.tets->V.row(v).transpose())) continue;
    const double k = m.U(v, 0) / h;
    if (edge_level < 0) edge_level = std::lround(k);
    CHECK(std::abs(k - double(edge_level)) < 1e-9);  // on one lattice level, exactly
  }
  CHECK(edge_level == wall_lo + 1);
  // without room (the default) the walls stand 1 level apart and the edge has no level of its own between them
  p.feature_line_room = false;
  PositionDeformStats off;
  position_deform(c.tets, *c.tets, c.seg, p, &off);
  CHECK(off.feature_lines_given_room == 0);
  CHECK(off.feature_lines_pinned == 0);
}
