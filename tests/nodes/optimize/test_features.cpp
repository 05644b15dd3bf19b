// Surface creases and the boundary vertices that follow them (features.h), and the optimizer's crease candidate.
#include "nodes/algorithms/features.h"
#include "nodes/algorithms/hex_quality.h"
#include "nodes/optimize/optimize.h"
#include "runtime/errors.h"
#include "tests/helpers/surface_checks.h"
#include "tests/helpers/voxel_maps.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

using namespace polyhex;

namespace {

bool on_box_edge(const Eigen::Vector3d& x, double n) {
  int at = 0;
  for (int a = 0; a < 3; ++a) at += std::abs(x[a]) < 1e-12 || std::abs(x[a] - n) < 1e-12;
  return at >= 2;
}

}  // namespace

TEST_CASE("find_creases: a box has 12 open crease lines between 8 corners; a cylinder two closed rims", "[features]") {
  const SurfaceMesh box = test::voxel_surface(test::voxel_box(3, 3, 3));
  const SurfaceCreases c = find_creases(box, 40, 0.5);
  REQUIRE(c.lines.size() == 12);
  CHECK(c.corners.size() == 8);
  for (size_t l = 0; l < c.lines.size(); ++l) {
    CHECK_FALSE(c.closed[l]);
    CHECK(c.start_corner[l] >= 0);
    CHECK(c.end_corner[l] >= 0);
    CHECK(c.start_corner[l] != c.end_corner[l]);
    CHECK((c.lines[l].back() - c.lines[l].front()).norm() == Approx(3.0));
    for (const auto& p : c.lines[l]) CHECK(on_box_edge(p, 3));
  }
  for (const auto& p : c.corners) CHECK(((p.array().abs() < 1e-12) || ((p.array() - 3).abs() < 1e-12)).all());
  CHECK(find_creases(box, 95, 0.5).lines.empty());  // the box's dihedral angles are 90 degrees
  CHECK(find_creases(box, 40, 3.5).lines.empty());  // every line is 3 long

  const SurfaceCreases r = find_creases(test::fan_cylinder(24), 40, 0.5);  // side edges bend by 15 degrees only
  REQUIRE(r.lines.size() == 2);
  CHECK(r.corners.empty());
  for (size_t l = 0; l < 2; ++l) {
    CHECK(r.closed[l]);
    CHECK(r.lines[l].size() == 25);
    CHECK((r.lines[l].front() - r.lines[l].back()).norm() < 1e-12);
  }
  CHECK(find_creases(test::fan_cylinder(24), 10, 0.5).lines.size() > 2);  // now the side edges are sharp too

  SurfaceMesh bad = box;
  bad.F(0, 1) = int(bad.V.rows());
  CHECK_THROWS_AS(find_creases(bad, 40, 0.5), InvalidInput);
}

TEST_CASE("closest_on_line: the nearest point of a polyline and its segment's direction", "[features]") {
  const std::vector<Eigen::Vector3d> line{{0, 0, 0}, {1, 0, 0}, {1, 2, 0}};
  Eigen::Vector3d t;
  CHECK((closest_on_line(line, {0.3, 0.5, 1}, &t) - Eigen::Vector3d(0.3, 0, 0)).norm() < 1e-15);
  CHECK((t - Eigen::Vector3d(1, 0, 0)).norm() < 1e-15);
  CHECK((closest_on_line(line, {3, 1.5, 0}, &t) - Eigen::Vector3d(1, 1.5, 0)).norm() < 1e-15);
  CHECK((t - Eigen::Vector3d(0, 1, 0)).norm() < 1e-15);
  CHECK((closest_on_line(line, {-2, -1, 0}) - Eigen::Vector3d(0, 0, 0)).norm() < 1e-15);
}

TEST_CASE("snap_to_creases: the box edges' grid vertices follow the edges, the grid's corners the box's corners",
          "[features]") {
  const HexMesh g = test::grid_hex_mesh(3, 3, 3);
  const SurfaceMesh box = test::voxel_surface(test::voxel_box(3, 3, 3));
  const SurfaceCreases c = find_creases(box, 40, 1.5);
  const CreaseSnap s = snap_to_creases(g.V, hex_boundary_quads(g), c, 1.0);
  CHECK(s.lines_snapped == 12);
  CHECK(s.lines_skipped == 0);
  CHECK(s.vertices == 12 * 2 + 8);
  for (Eigen::Index v = 0; v < g.V.rows(); ++v) {
    const Eigen::Vector3d x = g.V.row(v).transpose();
    const bool snapped = s.line[size_t(v)] >= 0 || s.corner[size_t(v)] >= 0;
    CHECK(snapped == on_box_edge(x, 3));
    if (s.corner[size_t(v)] >= 0) CHECK((c.corners[size_t(s.corner[size_t(v)])] - x).norm() < 1e-12);
    if (s.line[size_t(v)] >= 0) CHECK((closest_on_line(c.lines[size_t(s.line[size_t(v)])], x) - x).norm() < 1e-12);
  }
  // a line no boundary vertex comes near is skipped
  SurfaceCreases far = c;
  for (auto& line : far.lines)
    for (auto& p : line) p += Eigen::Vector3d(10, 0, 0);
  for (auto& p : far.corners) p += Eigen::Vector3d(10, 0, 0);
  const CreaseSnap none = snap_to_creases(g.V, hex_boundary_quads(g), far, 1.0);
  CHECK(none.lines_snapped == 0);
  CHECK(none.lines_skipped == 12);
  CHECK(none.vertices == 0);
}

TEST_CASE("optimizer: a poor result is tried again with the boundary on the creases, and kept if better",
          "[features][optimize]") {
  const SurfaceMesh box = test::voxel_surface(test::voxel_box(3, 3, 3));
  const HexMesh clean = test::grid_hex_mesh(3, 3, 3);
  // an edge vertex slid up its face: on the surface, but its hexes are sheared
  HexMesh poor = clean;
  poor.V.row(1) << 1, 0, 0.7;
  OptimizeParams frozen;  // no phase runs: the candidates differ only by where their boundary is projected
  frozen.untangle_iterations = frozen.global_iterations = frozen.iterations = 0;
  frozen.element_iterations = frozen.smooth_iterations = frozen.shape_iterations = frozen.average_iterations = 0;
  frozen.minimum_iterations = 0;
  frozen.fallback_below_sj = 0.8;
  REQUIRE(hex_quality(poor, nullptr).inverted == 0);
  REQUIRE(hex_quality(poor, nullptr).sj_min < frozen.fallback_below_sj);
  OptimizeStats st;
  FallbackOutcome fb;
  HexMesh out = optimize_hexes_or_fallback(poor, nullptr, box, frozen, &st, &fb);
  CHECK(fb.creases_ran);
  CHECK(fb.creases_kept);
  CHECK(fb.creases_stats.crease_lines == 12);
  CHECK(fb.creases_stats.crease_lines_snapped == 12);
  CHECK(st.sj_min_after == Approx(1.0));
  CHECK((out.V - clean.V).norm() < 1e-12);
  CHECK(st.boundary_distance_max < 1e-12);
  // off: the poor mesh stays as it is
  frozen.feature_angle = 0;
  out = optimize_hexes_or_fallback(poor, nullptr, box, frozen, &st, &fb);
  CHECK_FALSE(fb.creases_ran);
  CHECK((out.V - poor.V).norm() < 1e-12);
  // a good first result: no second candidate
  frozen.feature_angle = 40;
  out = optimize_hexes_or_fallback(clean, nullptr, box, frozen, &st, &fb);
  CHECK_FALSE(fb.creases_ran);
  CHECK_FALSE(fb.creases_kept);
  // the default run (all phases) on the poor mesh ends on the creases too, or as good without them
  OptimizeStats full;
  out = optimize_hexes_or_fallback(poor, nullptr, box, OptimizeParams{}, &full, &fb);
  CHECK(full.inverted_after == 0);
  CHECK(full.sj_min_after > 0.9);
}

TEST_CASE("surface_patches: a box has six patches bounded by its sharp edges, one above 90 degrees", "[features]") {
  const SurfaceMesh box = test::voxel_surface(test::voxel_box(2, 3, 1));
  int n = 0;
  const Eigen::VectorXi patch = surface_patches(box, 40, &n);
  REQUIRE(n == 6);
  REQUIRE(patch.size() == box.F.rows());
  // every patch is one side of the box: all its triangles have the same normal
  std::vector<Eigen::Vector3d> normal(6, Eigen::Vector3d::Zero());
  for (Eigen::Index f = 0; f < box.F.rows(); ++f) {
    const Eigen::Vector3d a = box.V.row(box.F(f, 0)), b = box.V.row(box.F(f, 1)), c = box.V.row(box.F(f, 2));
    const Eigen::Vector3d nf = (b - a).cross(c - a).normalized();
    if (normal[size_t(patch[f])].isZero()) normal[size_t(patch[f])] = nf;
    CHECK((normal[size_t(patch[f])] - nf).norm() < 1e-12);
  }
  CHECK(sharp_edges(box, 40).size() == 4 * (2 + 3 + 1));  // the 12 box edges, in unit segments
  CHECK(sharp_edges(box, 95).empty());
  surface_patches(box, 95, &n);
  CHECK(n == 1);
}

TEST_CASE("creases_at_vertices: a box lattice's edge vertices follow the 12 lines, its corners stay", "[features]") {
  const HexMesh g = test::grid_hex_mesh(4, 3, 2);
  const SurfaceMesh s = test::boundary_surface(g);
  const SurfaceCreases c = find_creases(s, 40, 1.5, 0.5);
  REQUIRE(c.lines.size() == 12);
  const auto Q = hex_boundary_quads(g);
  const CreaseSnap snap = creases_at_vertices(g.V, Q, c, 0.05);
  long on_lines = 0, at_corners = 0;
  for (Eigen::Index v = 0; v < g.V.rows(); ++v) {
    const Eigen::Vector3d x = g.V.row(v).transpose();
    const int at = int(x[0] == 0 || x[0] == 4) + int(x[1] == 0 || x[1] == 3) + int(x[2] == 0 || x[2] == 2);
    CHECK((snap.corner[size_t(v)] >= 0) == (at == 3));
    CHECK((snap.line[size_t(v)] >= 0) == (at == 2));
    if (snap.line[size_t(v)] >= 0) {
      ++on_lines;
      CHECK((closest_on_line(c.lines[size_t(snap.line[size_t(v)])], x) - x).norm() < 1e-12);
    }
    if (snap.corner[size_t(v)] >= 0) {
      ++at_corners;
      CHECK((c.corners[size_t(snap.corner[size_t(v)])] - x).norm() < 1e-12);
    }
  }
  CHECK(on_lines == 4 * 3 + 4 * 2 + 4 * 1);
  CHECK(at_corners == 8);
  CHECK(snap.vertices == on_lines + at_corners);
  CHECK(snap.lines_snapped == 12);
}

TEST_CASE("creases_at_vertices: a lattice corner where the crease runs straight on leaves the vertex free",
          "[features]") {
  // three quads along a straight crease y = z = 0: the middle one's corner at the origin is 180 degrees (a
  // lattice corner where the crease runs on); the outer ones have an edge along the crease each
  RowMatrixX3d V(10, 3);
  V << -2, 0, 0, -1, 0, 0, -1, 1, 0, -2, 1, 0,  // 0-3: left quad, edge 0-1 on the crease
      0, 0, 0, 1, 0, 0, 0, 1, 0,                // 4: the flat corner, 5, 6
      2, 0, 0, 2, 1, 0, 1, 1, 0;                // 7-9: right quad, edge 5-7 on the crease
  Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor> Q(3, 4);
  Q << 0, 1, 2, 3, 1, 4, 5, 6, 5, 7, 8, 9;
  SurfaceCreases c;
  c.lines = {{Eigen::Vector3d(-3, 0, 0), Eigen::Vector3d(3, 0, 0)}};
  c.closed = {0};
  c.start_corner = c.end_corner = {-1};
  const CreaseSnap snap = creases_at_vertices(V, Q, c, 0.05);
  for (int v : {0, 1, 5, 7}) CHECK(snap.line[size_t(v)] == 0);
  CHECK(snap.line[4] == -1);                                        // the flat corner
  for (int v : {2, 3, 6, 8, 9}) CHECK(snap.line[size_t(v)] == -1);  // off the crease
  CHECK(snap.vertices == 4);
}

TEST_CASE("creases_at_vertices: a vertex where the lattice crosses a crease stays free", "[features]") {
  // a quad strip across the crease x = 0 (in the plane z = 0): vertices 1 and 4 lie on the crease, but their
  // boundary edges cross it (to x = -1 and x = 1), none runs along it
  RowMatrixX3d V(6, 3);
  V << -1, 0, 0, 0, 0, 0, 1, 0, 0, -1, 1, 0, 0, 1, 0, 1, 1, 0;
  Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor> Q(2, 4);
  Q << 0, 1, 4, 3, 1, 2, 5, 4;
  SurfaceCreases c;
  c.lines = {{Eigen::Vector3d(0, -1, 0), Eigen::Vector3d(0, 0.5, 0)}};  // through vertex 1 only
  c.closed = {0};
  c.start_corner = c.end_corner = {-1};
  CHECK(creases_at_vertices(V, Q, c, 0.05).vertices == 0);
  c.lines = {{Eigen::Vector3d(0, -1, 0), Eigen::Vector3d(0, 2, 0)}};  // through 1 and 4: edge 1-4 runs along it
  const CreaseSnap snap = creases_at_vertices(V, Q, c, 0.05);
  CHECK(snap.line[1] == 0);
  CHECK(snap.line[4] == 0);
  CHECK(snap.vertices == 2);
}

TEST_CASE("crease_faces: a box's lines bound its six planar faces; without one line two of them are one",
          "[features]") {
  const SurfaceMesh box = test::voxel_surface(test::voxel_box(4, 4, 4));
  const SurfaceCreases c = find_creases(box, 40, 0.5);
  const CreaseFaces faces = crease_faces(box, c);
  CHECK(faces.faces == 6);
  CHECK(std::count(faces.planar.begin(), faces.planar.end(), 1) == 6);
  SurfaceCreases cut = c;
  cut.lines.erase(cut.lines.begin());
  cut.vertices.erase(cut.vertices.begin());
  cut.closed.erase(cut.closed.begin());
  cut.start_corner.erase(cut.start_corner.begin());
  cut.end_corner.erase(cut.end_corner.begin());
  const CreaseFaces merged = crease_faces(box, cut);
  CHECK(merged.faces == 5);
  CHECK(std::count(merged.planar.begin(), merged.planar.end(), 1) == 4);
}

TEST_CASE("flat_face_creases: a box keeps its 12 lines; a sphere faceted at the hex scale keeps none", "[features]") {
  const SurfaceMesh box = test::voxel_surface(test::voxel_box(4, 4, 4));
  const std::vector<char> flat = flat_face_triangles(box, 1.0);
  CHECK(std::count(flat.begin(), flat.end(), 1) == Eigen::Index(flat.size()));
  const SurfaceCreases kept = flat_face_creases(box, find_creases(box, 40, 0.5), 1.0);
  CHECK(kept.lines.size() == 12);
  CHECK(kept.corners.size() == 8);
  const std::vector<char> small = flat_face_triangles(box, 2.01);  // a 4 x 4 face is less than 4 h^2
  CHECK(std::count(small.begin(), small.end(), 1) == 0);

  // an octagonal prism of radius 2.2 and height 1.6 at a hex edge h = 1 (surface split to triangles of about h / 4
  // by TetGen): its side faces (1.68 x 1.6 = 2.7 h^2) are too small to be flat faces, so the edges between them
  // (45 degrees) are no part's creases, as a scan's facets as large as a hex edge; its caps (13.7 h^2) are flat
  // faces, and their rims are kept
  TetgenParams tp;
  tp.edge_length = 0.06;
  const TetMesh tets = tetrahedralize(test::fan_cylinder(8, 2.2, 1.6), tp);
  SurfaceMesh prism;
  prism.V = tets.V;
  prism.F = boundary_triangles(tets);
  const SurfaceCreases lines = find_creases(prism, 40, 1.5, 0.5);
  REQUIRE(lines.lines.size() == 8 + 16);
  const SurfaceCreases rims = flat_face_creases(prism, lines, 1.0);
  CHECK(rims.lines.size() == 16);
  for (const auto& l : rims.lines)
    for (const auto& p : l)
      CHECK((std::abs(p.z()) < 1e-9 || std::abs(p.z() - 1.6) < 1e-9));  // TetGen's points to rounding
  // at a hex edge of 0.5 the side faces are flat faces too, and every line is kept
  CHECK(flat_face_creases(prism, lines, 0.5).lines.size() == 24);
}
