// [segment] tests of the PolyCube structure extraction (paper §5.1) on generated tet meshes.
#include "graph/node.h"
#include "nodes/polycube_segment/polycube_segment.h"
#include "nodes/rotation_deform/rotation_deform.h"
#include "runtime/errors.h"
#include "tests/helpers/segment_fixtures.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <unistd.h>

using namespace polyhex;
using namespace polyhex::test;

namespace {

std::multiset<int> chart_labels(const PolyCubeSegmentation& s) {
  std::multiset<int> out;
  for (auto& c : s.charts) out.insert(c.label);
  return out;
}

/// The first chart with this label and an area below max_area, or -1.
int find_chart(const PolyCubeSegmentation& s, int label, double max_area = 1e300) {
  for (size_t c = 0; c < s.charts.size(); ++c)
    if (s.charts[c].label == label && s.charts[c].area < max_area) return int(c);
  return -1;
}

bool is_failing(const PolyCubeSegmentation& s, int c) {
  return std::count(s.failing_charts.begin(), s.failing_charts.end(), c) == 1;
}

/// Default params without the ramp split: the knife's and the fading step's sloped faces span more than
/// ramp_extent hex edges along their axes, so the extension would cut them too; these tests check the
/// §5.1 rules alone (the ramp test case checks the extension).
PolyCubeSegmentParams no_ramps() {
  PolyCubeSegmentParams p;
  p.split_ramps = false;
  return p;
}

/// Segmentation with one split kind switched off and no fallback.
PolyCubeSegmentation segment_without(const TetMesh& m, bool PolyCubeSegmentParams::*split) {
  PolyCubeSegmentParams p = no_ramps();
  p.*split = false;
  p.fallback_retries = 0;
  p.split_islands = false;  // the extensions would repair what the §5.1 step left
  p.repair_corners = false;
  return segment_polycube(m, p);
}

int count_separating(const PolyCubeSegmentation& s) {
  int n = 0;
  for (auto& c : s.charts) n += c.separating;
  return n;
}

double signed_volume(const RowMatrixX3d& V, const RowMatrixX3i& F) {
  double vol = 0;
  for (int t = 0; t < F.rows(); ++t) vol += V.row(F(t, 0)).dot(V.row(F(t, 1)).cross(V.row(F(t, 2)))) / 6;
  return vol;
}

/// Box [0,2]x[0,1]x[0,1] whose top carries a step of height 0.5 (1 - y) at x = 1, rising over 0.1
/// in x: a steep -X riser near y = 0 that flattens into the +Z top beyond y ~ 0.7. The riser is a
/// wedge pointing into the +Z top, which wraps around its tip (paper Figure 8).
TetMesh fading_step() {
  return voxel_tets(
      {40, 20, 5}, 0.05, [](int, int, int) { return true; },
      [](const Point& q) {
        Point p(q.x(), q.y(), 4 * q.z());
        double ramp = std::clamp((p.x() - 1.0) / 0.1, 0.0, 1.0);
        return Point(p.x(), p.y(), p.z() * (1 + 0.5 * ramp * (1 - p.y())));
      });
}

/// A knife: triangular prism, cross-section (0,-0.5), (2,0), (0,0.5) in (x,z), extruded over y in
/// [0,1]. Its +Z top and -Z bottom meet at the blade: one Z chart maps to both sides (Figure 7).
TetMesh knife() { return extruded_triangle_tets({0, -0.5}, {2, 0}, {0, 0.5}, 8, 1.0, 4); }

Eigen::Vector3d centroid(const TetMesh& m, const RowMatrixX3i& F, int t) {
  return (m.V.row(F(t, 0)) + m.V.row(F(t, 1)) + m.V.row(F(t, 2))).transpose() / 3;
}

/// The label of the closest axis to each triangle's normal (no smoothing).
Eigen::VectorXi face_labels(const TetMesh& m, const RowMatrixX3i& F) {
  Eigen::VectorXi label(F.rows());
  for (int t = 0; t < F.rows(); ++t) {
    Eigen::Vector3d a = m.V.row(F(t, 0)), b = m.V.row(F(t, 1)), c = m.V.row(F(t, 2));
    Eigen::Vector3d n = (b - a).cross(c - a);
    int axis;
    n.cwiseAbs().maxCoeff(&axis);
    label[t] = 2 * axis + (n[axis] > 0 ? 0 : 1);
  }
  return label;
}

}  // namespace

TEST_CASE("boundary_triangles of a voxel box are outward and complete", "[segment]") {
  TetMesh box = box_tets(1, 1, 1, 2);
  RowMatrixX3i F = boundary_triangles(box);
  CHECK(F.rows() == 6 * 4 * 2);
  CHECK(signed_volume(box.V, F) == Approx(1.0));
  TetMesh empty;
  CHECK_THROWS_WITH(boundary_triangles(empty), "tet mesh has no tetrahedra");
  TetMesh bad = box;
  bad.T(3, 2) = 999;
  CHECK_THROWS_AS(boundary_triangles(bad), InvalidInput);
  CHECK_THROWS_WITH(boundary_triangles(bad), Catch::Contains("tet 3 has vertex index 999 out of range"));
  // segment_polycube refuses it before its tet edge graph, built beside the boundary, reads an index
  bad.T(5, 0) = -4;
  PolyCubeSegmentParams p;
  REQUIRE(p.split_order_cycles);
  CHECK_THROWS_WITH(segment_polycube(bad, p), Catch::Contains("tet 3 has vertex index 999 out of range"));
  CHECK_THROWS_WITH(segment_polycube(empty, p), "tet mesh has no tetrahedra");
}

TEST_CASE("box: 6 charts, 8 corners, 12 edges, valid", "[segment]") {
  TetMesh box = box_tets(2, 1, 1, 4);
  PolyCubeSegmentation s = segment_polycube(box);
  CHECK(s.valid);
  CHECK(s.problems.empty());
  CHECK(s.charts.size() == 6);
  CHECK(s.corners.size() == 8);
  CHECK(s.edges.size() == 12);
  CHECK(chart_labels(s) == std::multiset<int>{0, 1, 2, 3, 4, 5});
  CHECK(s.splits_multi_orientation == 0);
  CHECK(s.splits_wedge == 0);
  CHECK(s.splits_ramp == 0);
  CHECK(s.removed_small == 0);
  for (auto& c : s.charts) CHECK(c.neighbours.size() == 4);
  for (auto& c : s.corners) CHECK(c.valence == 3);
  // every triangle has the label of the face it lies on
  CHECK(s.label == face_labels(box, s.F));
}

TEST_CASE("L-block: 8 charts, 12 corners, 18 edges, valid", "[segment]") {
  // cells of [0,2]x[0,1]x[0,2] without [1,2]x[0,1]x[1,2], 4 cells per unit
  TetMesh l = voxel_tets({8, 4, 8}, 0.25, [](int i, int, int k) { return !(i >= 4 && k >= 4); });
  PolyCubeSegmentation s = segment_polycube(l);
  CHECK(s.valid);
  CHECK(s.charts.size() == 8);
  CHECK(s.corners.size() == 12);
  CHECK(s.edges.size() == 18);
  CHECK(chart_labels(s) == std::multiset<int>{0, 0, 1, 2, 3, 4, 4, 5});
}

TEST_CASE("box rotated by 30 degrees, after rotation_deform: 6 charts", "[segment]") {
  Eigen::Matrix3d R = Eigen::AngleAxisd(30 * M_PI / 180, Eigen::Vector3d(0.3, 0.2, 1).normalized()).toRotationMatrix();
  TetMesh rotated = transformed(box_tets(1, 1, 1, 6), R);
  RotationDeformResult deformed = rotation_deform(rotated, RotationDeformParams{});
  PolyCubeSegmentation s = segment_polycube(deformed.mesh);
  CHECK(s.valid);
  CHECK(s.charts.size() == 6);
  CHECK(s.corners.size() == 8);
  CHECK(chart_labels(s) == std::multiset<int>{0, 1, 2, 3, 4, 5});
}

TEST_CASE("multi-orientation chart (Figure 7) gets exactly one separating chart", "[segment]") {
  TetMesh k = knife();
  SECTION("split") {
    PolyCubeSegmentation s = segment_polycube(k, no_ramps());
    CHECK(s.valid);
    CHECK(s.splits_multi_orientation == 1);
    CHECK(s.splits_wedge == 0);
    CHECK(s.charts.size() == 6);
    CHECK(s.corners.size() == 8);
    CHECK(count_separating(s) == 1);
    // two pairs of neighbours on the same axes (+-Z halves, +-Y ends): the remaining axis, +X by normal
    for (auto& c : s.charts)
      if (c.separating) CHECK(c.label == 0);
    CHECK(chart_labels(s) == std::multiset<int>{0, 1, 2, 3, 4, 5});
  }
  SECTION("without the split the structure is invalid and names the charts") {
    PolyCubeSegmentation s = segment_without(k, &PolyCubeSegmentParams::split_multi_orientation);
    CHECK_FALSE(s.valid);
    CHECK(s.charts.size() == 5);
    // the +Z and -Z charts are neighbours on the same axis; the caps have only 3 neighbours
    int top = find_chart(s, 4), bottom = find_chart(s, 5);
    REQUIRE(top >= 0);
    REQUIRE(bottom >= 0);
    CHECK(is_failing(s, top));
    CHECK(is_failing(s, bottom));
    std::string joined;
    for (auto& m : s.problems) joined += m + "\n";
    CHECK_THAT(joined, Catch::Contains("are neighbours on the same axis"));
    CHECK_THAT(joined, Catch::Contains("has 3 neighbour(s)"));
    CHECK_THROWS_AS(require_valid_polycube(s), InvalidInput);
  }
}

TEST_CASE("wedge (Figure 8): the concave chart gets the valid, cheapest cut", "[segment]") {
  TetMesh m = fading_step();
  SECTION("cut") {
    PolyCubeSegmentation s = segment_polycube(m, no_ramps());
    INFO(s.problems.size());
    CHECK(s.valid);
    CHECK(s.splits_wedge == 1);
    CHECK(s.splits_multi_orientation == 0);
    // the cut runs from the riser's tip along +Y to the back: the top splits into a low and a high
    // part and the riser (-X) now spans the whole depth: a stepped box, 8 charts
    CHECK(s.charts.size() == 8);
    CHECK(s.corners.size() == 12);
    CHECK(chart_labels(s) == std::multiset<int>{0, 1, 1, 2, 3, 4, 4, 5});
    for (auto& c : s.charts)
      if (c.label == 1 && c.area < 0.9) CHECK(c.neighbours.size() == 4);  // the riser
  }
  SECTION("without the wedge split the riser has two neighbours") {
    PolyCubeSegmentation s = segment_without(m, &PolyCubeSegmentParams::split_wedges);
    CHECK_FALSE(s.valid);
    CHECK(s.charts.size() == 7);
    int riser = find_chart(s, 1, 0.9);
    REQUIRE(riser >= 0);
    CHECK(s.charts[riser].neighbours.size() == 2);
    CHECK(s.failing_charts == std::vector<int>{riser});
    CHECK_THROWS_WITH(require_valid_polycube(s), Catch::Contains("chart " + std::to_string(riser) + " (-X, ") &&
                                                     Catch::Contains("has 2 neighbour(s)"));
  }
  SECTION("a severity cut-off above the wedge leaves it alone") {
    PolyCubeSegmentParams p = no_ramps();
    p.wedge_min_severity = 0.5;
    p.fallback_retries = 0;
    CHECK(segment_polycube(m, p).splits_wedge == 0);
  }
}

TEST_CASE("ramp: a bar whose top and bottom climb 1 over its length 4 is cut into a staircase", "[segment]") {
  // [0,4]x[0,0.4]x[0,0.4] sheared z += x / 4: the Z faces tilt by 14 degrees (labels stay +-Z) and span
  // ~24 hex edges (h = 1 % of the diagonal 4.26) along Z; no chart edge doubles back, so the wedge rule
  // does not see them
  TetMesh m = voxel_tets(
      {80, 8, 8}, 0.05, [](int, int, int) { return true; },
      [](const Point& q) { return Point(q.x(), q.y(), q.z() + 0.25 * q.x()); });
  const double h = 0.01 * (m.V.colwise().maxCoeff() - m.V.colwise().minCoeff()).norm();
  PolyCubeSegmentParams p;
  p.fallback_retries = 0;
  SECTION("split") {
    PolyCubeSegmentation s = segment_polycube(m, p);
    INFO(s.problems.size());
    CHECK(s.valid);
    CHECK(s.splits_ramp == 2);  // the top and the bottom, once each
    CHECK(s.splits_wedge == 0);
    // each Z face became two flat pieces joined by an X riser: 10 charts, a stepped bar
    CHECK(chart_labels(s) == std::multiset<int>{0, 1, 1, 0, 2, 3, 4, 4, 5, 5});
    for (size_t c = 0; c < s.charts.size(); ++c) {
      INFO("chart " << c << " label " << s.charts[c].label);
      CHECK(chart_span(m, s, int(c)) <= p.ramp_extent * h);
      CHECK(s.charts[c].neighbours.size() >= 4);
    }
    // the risers face the way the bar climbs: the top's riser -X (the high piece lies at larger x),
    // the bottom's +X
    int risers = 0;
    for (size_t c = 0; c < s.charts.size(); ++c) {
      if (s.charts[c].label / 2 != 0 || !s.charts[c].separating) continue;
      ++risers;
      double z = 0;
      int n = 0;
      for (int t = 0; t < s.F.rows(); ++t)
        if (s.chart[t] == int(c))
          for (int k = 0; k < 3; ++k, ++n) z += m.V(s.F(t, k), 2);
      bool top = z / n > 0.2 + 0.25 * 2;  // above the bar's axis at its middle
      CHECK(s.charts[c].label == (top ? 1 : 0));
      CHECK(s.charts[c].area < 0.2);
    }
    CHECK(risers == 2);
  }
  SECTION("without the ramp split: 6 valid charts, the Z ones far from flat") {
    p.split_ramps = false;
    PolyCubeSegmentation s = segment_polycube(m, p);
    CHECK(s.valid);
    CHECK(s.charts.size() == 6);
    CHECK(s.splits_ramp == 0);
    for (size_t c = 0; c < s.charts.size(); ++c)
      if (s.charts[c].label / 2 == 2) CHECK(chart_span(m, s, int(c)) > 0.9);
  }
  SECTION("a span threshold above the ramp leaves it alone") {
    p.ramp_extent = 30;
    CHECK(segment_polycube(m, p).splits_ramp == 0);
  }
}

TEST_CASE("narrow charts: a step lower than the lattice resolves is removed, a real one stays", "[segment]") {
  // [0,2]x[0,1]x[0,1] in cells of 0.1, plus a top layer over x < 1 whose thickness is `step`: a step
  // on the top face. h = 1 % of the diagonal (~0.0245); the riser runs the box's width (41 h), so at
  // step 0.01 its area is about 17 hex faces: a removal candidate only with narrow_chart_faces above that.
  auto stepped_box = [](double step) {
    return voxel_tets(
        {20, 10, 11}, 0.1, [](int i, int, int k) { return !(i >= 10 && k == 10); },
        [step](const Point& q) {
          return Point(q.x(), q.y(), q.z() <= 1.0 + 1e-9 ? q.z() : 1.0 + step * (q.z() - 1.0) / 0.1);
        });
  };
  PolyCubeSegmentParams p;
  p.fallback_retries = 0;
  SECTION("0.4 h: the riser goes, the two top pieces become one chart") {
    TetMesh m = stepped_box(0.01);
    p.min_chart_extent = 0;
    PolyCubeSegmentation kept = segment_polycube(m, p);
    REQUIRE(kept.valid);
    CHECK(kept.removed_narrow == 0);
    CHECK(chart_labels(kept) == std::multiset<int>{0, 0, 1, 2, 3, 4, 4, 5});  // the riser is a second +X chart
    p.min_chart_extent = 1.0;
    CHECK(segment_polycube(m, p).removed_narrow == 0);  // the default narrow_chart_faces (4): a long strip stays
    p.narrow_chart_faces = 20;
    PolyCubeSegmentation s = segment_polycube(m, p);
    CHECK(s.valid);
    CHECK(s.removed_narrow == 1);
    CHECK(chart_labels(s) == std::multiset<int>{0, 1, 2, 3, 4, 5});
    for (auto& c : s.charts) CHECK(c.neighbours.size() == 4);
  }
  SECTION("3 h: a step the lattice resolves is left alone") {
    p.narrow_chart_faces = 100;
    PolyCubeSegmentation s = segment_polycube(stepped_box(0.075), p);
    CHECK(s.valid);
    CHECK(s.removed_narrow == 0);
    CHECK(chart_labels(s) == std::multiset<int>{0, 0, 1, 2, 3, 4, 4, 5});
  }
}

TEST_CASE("hand-made invalid labelling is reported naming the charts", "[segment]") {
  TetMesh box = box_tets(1, 1, 1, 3);
  RowMatrixX3i F = boundary_triangles(box);
  Eigen::VectorXi label = face_labels(box, F);
  SECTION("the geometric labelling is valid") { CHECK(analyse_polycube_labels(box.V, F, label).valid); }
  SECTION("top face labelled +X: one chart touches -X") {
    for (int t = 0; t < F.rows(); ++t)
      if (label[t] == 4) label[t] = 0;
    PolyCubeSegmentation s = analyse_polycube_labels(box.V, F, label);
    CHECK_FALSE(s.valid);
    REQUIRE(s.charts.size() == 5);
    int px = find_chart(s, 0), mx = find_chart(s, 1);
    CHECK(is_failing(s, px));
    CHECK(is_failing(s, mx));
    std::string expect = "chart " + std::to_string(std::min(px, mx)) + " (";
    CHECK_THROWS_WITH(require_valid_polycube(s),
                      Catch::StartsWith("invalid PolyCube structure (5 charts; failing charts ") &&
                          Catch::Contains(expect) && Catch::Contains("are neighbours on the same axis"));
  }
  SECTION("a square in the middle of the top face labelled +X: a one-edge island") {
    for (int t = 0; t < F.rows(); ++t) {
      Eigen::Vector3d c = centroid(box, F, t);
      if (label[t] == 4 && std::abs(c.x() - 0.5) < 0.17 && std::abs(c.y() - 0.5) < 0.17) label[t] = 0;
    }
    PolyCubeSegmentation s = analyse_polycube_labels(box.V, F, label);
    CHECK_FALSE(s.valid);
    CHECK(s.charts.size() == 7);
    int island = -1;
    for (size_t c = 0; c < s.charts.size(); ++c)
      if (s.charts[c].label == 0 && s.charts[c].neighbours.size() == 1) island = int(c);
    REQUIRE(island >= 0);
    CHECK(s.failing_charts == std::vector<int>{island});
    CHECK(s.edges.size() == 13);  // 12 box edges + the closed loop around the island
  }
  SECTION("bad labels are rejected") {
    label[5] = 6;
    CHECK_THROWS_WITH(analyse_polycube_labels(box.V, F, label), "triangle 5 has label 6, expected 0..5");
    CHECK_THROWS_WITH(analyse_polycube_labels(box.V, F, label.head(3)), "labelling has 3 labels for 108 triangles");
  }
}

TEST_CASE("clean-up: straightening and removal of small charts bounded by at most two edges", "[segment]") {
  TetMesh box = box_tets(1, 1, 1, 12);
  RowMatrixX3i F = boundary_triangles(box);
  Eigen::VectorXi geometric = face_labels(box, F);
  // on the +Z face: a 4x4-cell island labelled +X (one edge) and a 4x2-cell strip labelled -X along
  // the -Y edge (two edges: with +Z and -Y); areas 0.0185 and 0.0093 of the surface
  Eigen::VectorXi label = geometric;
  for (int t = 0; t < F.rows(); ++t) {
    Eigen::Vector3d c = centroid(box, F, t);
    if (label[t] == 4 && std::abs(c.x() - 0.5) < 2.0 / 12 && std::abs(c.y() - 0.5) < 2.0 / 12) label[t] = 0;
    if (label[t] == 4 && c.y() < 2.0 / 12 && std::abs(c.x() - 0.25) < 2.0 / 12) label[t] = 1;
  }
  PolyCubeSegmentParams p;
  p.small_chart_area = 0.02;
  SECTION("both are removed by flood fill; the box's labelling comes back") {
    PolyCubeSegmentation before = analyse_polycube_labels(box.V, F, label);
    REQUIRE(before.charts.size() == 8);
    CHECK_FALSE(before.valid);
    Eigen::VectorXi cleaned = label;
    CHECK(clean_up_labels(box.V, F, cleaned, p) == 2);
    CHECK(cleaned == geometric);
    PolyCubeSegmentation s = analyse_polycube_labels(box.V, F, cleaned);
    CHECK(s.valid);
    CHECK(s.charts.size() == 6);
  }
  SECTION("charts above the area threshold, or with more edges than allowed, stay") {
    p.small_chart_area = 0.005;
    Eigen::VectorXi kept = label;
    CHECK(clean_up_labels(box.V, F, kept, p) == 0);
    CHECK(analyse_polycube_labels(box.V, F, kept).charts.size() == 8);
    p.small_chart_area = 0.02;
    p.small_chart_edges = 1;  // the strip has two edges: only the island goes
    kept = label;
    CHECK(clean_up_labels(box.V, F, kept, p) == 1);
    CHECK(analyse_polycube_labels(box.V, F, kept).charts.size() == 7);
  }
  SECTION("a triangle with two neighbours of another label is straightened") {
    Eigen::VectorXi label = geometric;
    // a +X triangle touching the top/+X edge, not at a corner
    int flipped = -1;
    for (int t = 0; t < F.rows() && flipped < 0; ++t) {
      Eigen::Vector3d c = centroid(box, F, t);
      if (label[t] == 0 && c.z() > 1 - 1.0 / 24 && std::abs(c.y() - 0.5) < 0.3) flipped = t;
    }
    REQUIRE(flipped >= 0);
    label = geometric;
    label[flipped] = 4;  // a +X triangle labelled +Z: a jag in the edge
    CHECK(clean_up_labels(box.V, F, label) == 0);
    CHECK(label == geometric);
  }
}

TEST_CASE("non-manifold boundary is rejected naming an edge", "[segment]") {
  // two cubes sharing only an edge
  TetMesh m = voxel_tets({2, 2, 1}, 1.0, [](int i, int j, int) { return i == j; });
  CHECK_THROWS_AS(segment_polycube(m), InvalidInput);
  CHECK_THROWS_WITH(segment_polycube(m),
                    Catch::Contains("not a closed 2-manifold: edge (") && Catch::Contains("is used by 4 triangle(s)"));
}

TEST_CASE("polycube_segment node: metrics, VTK output and failure", "[segment]") {
  const NodeSpec* spec = Registry::instance().find("polycube_segment");
  REQUIRE(spec != nullptr);
  CHECK(spec->output == "PolyCubeSegmentation");
  REQUIRE(spec->inputs.size() == 2);
  CHECK(spec->inputs[0].name == "deformed");
  CHECK(spec->inputs[1].name == "tets");  // optional: the input's creases
  auto dir = std::filesystem::temp_directory_path() / ("polyhex_segment_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  NodeContext ctx;
  ctx.id = "seg";
  ctx.out_dir = dir;
  Inputs in;
  in.items.push_back(make_artefact(box_tets(1, 1, 1, 3)));
  json params = spec->check_params(json{{"save_surface", true}}, "seg");
  Artefact out = spec->run(params, in, ctx);
  auto s = out.as<PolyCubeSegmentation>();
  CHECK(ctx.metrics["charts"] == 6);
  CHECK(ctx.metrics["corners"] == 8);
  CHECK(ctx.metrics["edges"] == 12);
  CHECK(ctx.metrics["valid"] == true);
  CHECK(ctx.metrics["splits_multi_orientation"] == 0);
  CHECK(ctx.metrics["splits_wedge"] == 0);
  CHECK(ctx.metrics["splits_island"] == 0);
  CHECK(ctx.metrics["repaired_corners"] == 0);
  CHECK(ctx.metrics["removed_small"] == 0);
  CHECK(ctx.metrics["failing_charts"].empty());
  std::ifstream vtk(dir / "seg.charts.vtk");
  REQUIRE(vtk.good());
  std::stringstream text;
  text << vtk.rdbuf();
  CHECK_THAT(text.str(), Catch::Contains("CELL_DATA 108"));
  CHECK_THAT(text.str(), Catch::Contains("chart"));
  CHECK_THAT(text.str(), Catch::Contains("axis"));

  // an invalid structure fails with InvalidInput naming the charts, unless allow_invalid
  Inputs bad;
  bad.items.push_back(make_artefact(fading_step()));
  NodeContext ctx2 = ctx;
  ctx2.metrics = json::object();
  json strict = spec->check_params(json{{"split_wedges", false},
                                        {"split_ramps", false},
                                        {"fallback_retries", 0},
                                        {"split_islands", false},
                                        {"repair_corners", false}},
                                   "seg");
  CHECK_THROWS_WITH(spec->run(strict, bad, ctx2), Catch::Contains("has 2 neighbour(s)"));
  NodeContext ctx3 = ctx2;
  ctx3.warnings.clear();
  json lenient = spec->check_params(json{{"split_wedges", false},
                                         {"split_ramps", false},
                                         {"fallback_retries", 0},
                                         {"split_islands", false},
                                         {"repair_corners", false},
                                         {"allow_invalid", true}},
                                    "seg");
  Artefact passed = spec->run(lenient, bad, ctx3);
  CHECK_FALSE(passed.as<PolyCubeSegmentation>()->valid);
  CHECK(ctx3.metrics["valid"] == false);
  CHECK(ctx3.metrics["failing_charts"].size() == 1);
  REQUIRE(ctx3.warnings.size() == 1);
  CHECK_THAT(ctx3.warnings[0], Catch::StartsWith("allow_invalid: passing on an invalid PolyCube structure"));
  CHECK_THROWS_AS(spec->check_params(json{{"hex_edge_length", 0}}, "seg"), ConfigError);
  std::filesystem::remove_all(dir);
}

TEST_CASE("flat ramps: a plane that climbs more than half the solid's depth behind it is cut, a deep one is not",
          "[segment]") {
  // a 1 x 0.5 slab whose flat top climbs 0.08 along x (4.6 degrees: labelled +Z, flat in the input): about 7
  // hex edges (h = 1 % of the diagonal), under ramp_extent (12) and over ramp_extent_planar (3)
  auto wedge = [](int layers, double thick) {
    return voxel_tets(
        {20, 10, layers}, 0.05, [](int, int, int) { return true; },
        [=](const Point& q) { return Point(q.x(), q.y(), q.z() / (0.05 * layers) * (thick + 0.08 * q.x())); });
  };
  auto tops = [](const PolyCubeSegmentation& s) {
    int n = 0;
    for (auto& c : s.charts) n += c.label == 4;
    return n;
  };
  PolyCubeSegmentParams p;
  p.fallback_retries = 0;
  SECTION("thin: 0.06 deep at its low end, so the climb is more than half the median depth (about 0.10)") {
    const TetMesh m = wedge(2, 0.06);
    const PolyCubeSegmentation s = segment_polycube(m, p, &m);  // the input's own tets: flat faces known
    CHECK(s.valid);
    CHECK(s.splits_ramp >= 1);
    CHECK(tops(s) >= 2);
    const PolyCubeSegmentation blind = segment_polycube(m, p);  // without the input: the 12 h rule alone
    CHECK(blind.splits_ramp == 0);
    CHECK(tops(blind) == 1);
  }
  SECTION("deep: 0.4 deep, the same climb is a fifth of the depth: one flat top") {
    const TetMesh m = wedge(8, 0.4);
    const PolyCubeSegmentation s = segment_polycube(m, p, &m);
    CHECK(s.valid);
    CHECK(s.splits_ramp == 0);
    CHECK(tops(s) == 1);
  }
}
