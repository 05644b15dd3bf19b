// [segment]: the extensions of §5.1 that repair what the splits leave (island cuts of ring charts,
// patches at 4-valent corners), on hand-made labellings of a voxel box with known answers.
#include "nodes/polycube_segment/polycube_segment.h"
#include "tests/helpers/voxel_shapes.h"

#include <catch2/catch.hpp>

#include <string>

using namespace polyhex;
using namespace polyhex::test;

namespace {

/// Labels of a voxel surface from its exact (axis-aligned) triangle normals.
Eigen::VectorXi normal_labels(const SurfaceMesh& m) {
  Eigen::VectorXi label(m.F.rows());
  for (int t = 0; t < m.F.rows(); ++t) {
    Eigen::Vector3d a = m.V.row(m.F(t, 0)), b = m.V.row(m.F(t, 1)), c = m.V.row(m.F(t, 2));
    Eigen::Vector3d n = (b - a).cross(c - a);
    int axis = 0;
    n.cwiseAbs().maxCoeff(&axis);
    label[t] = 2 * axis + (n[axis] > 0 ? 0 : 1);
  }
  return label;
}

Eigen::Vector3d centroid(const SurfaceMesh& m, int t) {
  return (m.V.row(m.F(t, 0)) + m.V.row(m.F(t, 1)) + m.V.row(m.F(t, 2))).transpose() / 3.0;
}

std::string joined(const PolyCubeSegmentation& s) {
  std::string out;
  for (auto& p : s.problems) out += p + "\n";
  return out;
}

}  // namespace

TEST_CASE("island inside a ring chart: two cuts along the edge axis make it a face", "[segment]") {
  // 6x6x6 box; on its +Y face a 2x2 square in the middle is labelled +X: an island with one
  // neighbour inside the +Y chart, which becomes a ring (two boundary loops)
  SurfaceMesh box = voxel_surface(voxel_box(6, 6, 6));
  Eigen::VectorXi label = normal_labels(box);
  for (int t = 0; t < box.F.rows(); ++t) {
    Eigen::Vector3d c = centroid(box, t);
    if (label[t] == 2 && c.x() > 2 && c.x() < 4 && c.z() > 2 && c.z() < 4) label[t] = 0;
  }
  PolyCubeSegmentation before = analyse_polycube_labels(box.V, box.F, label);
  REQUIRE_FALSE(before.valid);
  CHECK(before.charts.size() == 7);
  CHECK_THAT(joined(before), Catch::Contains("(+X, 8 triangles) has 1 neighbour(s)"));

  SECTION("repaired") {
    auto [islands, corners] = repair_polycube_labels(box.V, box.F, label);
    // the cheapest paths run along Z (the axis of a +X/+Y PolyCube edge) to the -Z and +Z faces;
    // the neighbour rule (+Y twice, +X, +-Z: the unmatched +X closest to the band normal... tied,
    // first) gives +X: the island becomes a strip across the +Y face, which splits in two
    CHECK(islands == 2);
    CHECK(corners == 0);
    PolyCubeSegmentation after = analyse_polycube_labels(box.V, box.F, label);
    INFO(joined(after));
    CHECK(after.valid);
    CHECK(after.charts.size() == 8);
    CHECK(after.corners.size() == 12);
    int strip = -1;
    for (size_t c = 0; c < after.charts.size(); ++c)
      if (after.charts[c].label == 0 && after.charts[c].neighbours.size() == 4 && after.charts[c].triangles < 6 * 6 * 2)
        strip = int(c);
    REQUIRE(strip >= 0);
    // the strip runs the whole depth of the +Y face in z, from the -Z face to the +Z face
    std::set<int> nbr_labels;
    for (int d : after.charts[strip].neighbours) nbr_labels.insert(after.charts[d].label);
    CHECK(nbr_labels == std::set<int>{2, 4, 5});
  }
  SECTION("switched off: unchanged") {
    PolyCubeSegmentParams p;
    p.split_islands = false;
    p.repair_corners = false;
    Eigen::VectorXi copy = label;
    CHECK(repair_polycube_labels(box.V, box.F, copy, p) == std::pair<int, int>{0, 0});
    CHECK(copy == label);
  }
}

TEST_CASE("saddle: opposite directions touching at one vertex get a patch of the third axis", "[segment]") {
  // 6x6x6 box; its +Y face is cut into quadrants around the vertex (3, 6, 3), labelled -X, -Z, +X,
  // +Z in turn (each one differs from the box faces it touches): a 4-valent corner where -X meets
  // +X and -Z meets +Z only at that vertex
  SurfaceMesh box = voxel_surface(voxel_box(6, 6, 6));
  Eigen::VectorXi label = normal_labels(box);
  for (int t = 0; t < box.F.rows(); ++t) {
    if (label[t] != 2) continue;
    Eigen::Vector3d c = centroid(box, t);
    bool px = c.x() > 3, pz = c.z() > 3;
    label[t] = px && pz ? 1 : !px && pz ? 5 : !px ? 0 : 4;
  }
  PolyCubeSegmentation before = analyse_polycube_labels(box.V, box.F, label);
  REQUIRE_FALSE(before.valid);
  CHECK_THAT(joined(before), Catch::Contains("of the opposite direction at vertex"));
  CHECK_THAT(joined(before), Catch::Contains("has valence 4"));
  const Eigen::VectorXi label0 = label;
  PolyCubeSegmentParams no_resplit;  // the corner repair alone (without the last-resort multi-orientation split)
  no_resplit.split_multi_orientation = false;
  auto [islands, corners] = repair_polycube_labels(box.V, box.F, label, no_resplit);
  // one patch at the saddle vertex; the problems of the quadrants touching box faces of their own
  // axis (e.g. -X quadrant beside the +X face) are not corner problems and stay
  CHECK(islands == 0);
  CHECK(corners == 1);
  PolyCubeSegmentation after = analyse_polycube_labels(box.V, box.F, label);
  INFO(joined(after));
  // exactly the two opposite-direction touches and the 4-valent corner are gone
  CHECK(after.problems.size() == before.problems.size() - 3);
  CHECK_THAT(joined(after), !Catch::Contains("of the opposite direction at vertex"));
  CHECK_THAT(joined(after), !Catch::Contains("has valence 4"));
  // the triangles at the saddle vertex took +Y, the label closest to their normal on the third axis
  int centre = -1;
  for (int v = 0; v < box.V.rows(); ++v)
    if ((box.V.row(v) - Eigen::RowVector3d(3, 6, 3)).norm() < 1e-12) centre = v;
  REQUIRE(centre >= 0);
  for (int t = 0; t < box.F.rows(); ++t)
    for (int k = 0; k < 3; ++k)
      if (box.F(t, k) == centre) CHECK(label[t] == 2);
  // with the defaults, the last resort separates each quadrant from the box face of the opposite
  // direction it meets along an edge (a multi-orientation split): the labelling becomes valid
  Eigen::VectorXi full = label0;
  repair_polycube_labels(box.V, box.F, full);
  INFO(joined(analyse_polycube_labels(box.V, box.F, full)));
  CHECK(analyse_polycube_labels(box.V, box.F, full).valid);
}

TEST_CASE("small chart beside a chart of its own axis is removed, the box restored", "[segment]") {
  // 6x6x6 box; one unit square in the middle of the +Y face labelled -Y: a chart of area 1 (below
  // 0.01 x 216, above 0.001 x 216) with one neighbour, on its own axis
  SurfaceMesh box = voxel_surface(voxel_box(6, 6, 6));
  const Eigen::VectorXi exact = normal_labels(box);
  Eigen::VectorXi label = exact;
  for (int t = 0; t < box.F.rows(); ++t) {
    Eigen::Vector3d c = centroid(box, t);
    if (label[t] == 2 && c.x() > 2 && c.x() < 3 && c.z() > 2 && c.z() < 3) label[t] = 3;
  }
  PolyCubeSegmentation before = analyse_polycube_labels(box.V, box.F, label);
  CHECK_THAT(joined(before), Catch::Contains("are neighbours on the same axis"));
  PolyCubeSegmentParams p;
  p.small_chart_area = 0.01;
  SECTION("removed") {
    repair_polycube_labels(box.V, box.F, label, p);
    CHECK(label == exact);
    CHECK(analyse_polycube_labels(box.V, box.F, label).valid);
  }
  SECTION("not small: left to the other repairs, still invalid without the multi-orientation split") {
    p.small_chart_area = 1e-3;
    p.split_multi_orientation = false;
    repair_polycube_labels(box.V, box.F, label, p);
    CHECK_FALSE(analyse_polycube_labels(box.V, box.F, label).valid);
  }
  SECTION("not small: the last-resort multi-orientation split rings it with a separating chart") {
    p.small_chart_area = 1e-3;
    repair_polycube_labels(box.V, box.F, label, p);
    PolyCubeSegmentation after = analyse_polycube_labels(box.V, box.F, label);
    INFO(joined(after));
    CHECK(after.valid);
    // the -Y square stays (it is not small): a ring of another axis now parts it from the +Y face
    int minus_y = 0;
    for (int t = 0; t < box.F.rows(); ++t) minus_y += label[t] == 3;
    CHECK(minus_y > 0);
  }
}

TEST_CASE("repairs leave a valid labelling unchanged", "[segment]") {
  SurfaceMesh box = voxel_surface(voxel_box(2, 3, 4));
  Eigen::VectorXi label = normal_labels(box), copy = label;
  CHECK(repair_polycube_labels(box.V, box.F, copy) == std::pair<int, int>{0, 0});
  CHECK(copy == label);
  Eigen::VectorXi wrong = label;
  wrong[0] = 7;
  CHECK_THROWS_WITH(repair_polycube_labels(box.V, box.F, wrong), "triangle 0 has label 7, expected 0..5");
}
