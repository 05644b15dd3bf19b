// Non-manifold boundary before padding: sheets of hexes touching along an edge or at a vertex only are
// found, the repair removes hexes until the boundary is manifold, a clean mesh is left alone.
#include "nodes/algorithms/hex_quality.h"
#include "nodes/pad/pad.h"
#include "tests/helpers/hex_fixtures.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <vector>

using namespace polyhex;

namespace {

/// The cells of an nx by ny by nz grid whose index (i + nx (j + ny k)) is listed.
HexMesh grid_cells(int nx, int ny, int nz, const std::vector<int>& cells) {
  const HexMesh g = test::grid_hex_mesh(nx, ny, nz);
  HexMesh m = g;
  m.H.resize(Eigen::Index(cells.size()), 8);
  for (size_t r = 0; r < cells.size(); ++r) m.H.row(Eigen::Index(r)) = g.H.row(cells[r]);
  return m;
}

bool has_vertex_at(const HexMesh& m, int v, double x, double y, double z) {
  return m.V(v, 0) == x && m.V(v, 1) == y && m.V(v, 2) == z;
}

}  // namespace

TEST_CASE("find_boundary_defects: two cubes sharing an edge only", "[pad]") {
  // cells (0,0,0) and (1,1,0) of a 2x2x1 grid: the edge x = y = 1 carries four boundary faces
  const HexMesh m = grid_cells(2, 2, 1, {0, 3});
  const BoundaryDefects d = find_boundary_defects(m);
  REQUIRE(d.edges.size() == 1);
  const auto e = d.edges[0];
  CHECK(has_vertex_at(m, e[0], 1, 1, 0));
  CHECK(has_vertex_at(m, e[1], 1, 1, 1));
  // its two end points have two fans each (one per cube)
  REQUIRE(d.vertices.size() == 2);
  CHECK(std::find(d.vertices.begin(), d.vertices.end(), e[0]) != d.vertices.end());
  CHECK(std::find(d.vertices.begin(), d.vertices.end(), e[1]) != d.vertices.end());
}

TEST_CASE("find_boundary_defects: two cubes sharing a vertex only", "[pad]") {
  // cells (0,0,0) and (1,1,1) of a 2x2x2 grid touch at (1,1,1): no bad edge, one bad vertex
  const HexMesh m = grid_cells(2, 2, 2, {0, 7});
  const BoundaryDefects d = find_boundary_defects(m);
  CHECK(d.edges.empty());
  REQUIRE(d.vertices.size() == 1);
  CHECK(has_vertex_at(m, d.vertices[0], 1, 1, 1));
}

TEST_CASE("find_boundary_defects: manifold meshes, concave ones included, have none", "[pad]") {
  for (const HexMesh& m : {test::grid_hex_mesh(3, 2, 2), grid_cells(2, 2, 1, {0, 1, 2}),  // L: concave edge
                           grid_cells(2, 2, 2, {0, 1, 2, 3, 4, 5, 6})}) {                 // cube less one corner cell
    const BoundaryDefects d = find_boundary_defects(m);
    CHECK(d.edges.empty());
    CHECK(d.vertices.empty());
  }
}

TEST_CASE("remove_nonmanifold_boundary removes one of the touching cubes and leaves a clean mesh alone", "[pad]") {
  for (const std::vector<int>& cells : {std::vector<int>{0, 3}, std::vector<int>{0, 7}}) {
    const HexMesh m = grid_cells(2, 2, cells[1] == 7 ? 2 : 1, cells);
    const NonmanifoldRepair repair = remove_nonmanifold_boundary(m);
    const HexMesh& r = repair.mesh;
    CHECK(repair.edges == (cells[1] == 3 ? 1 : 0));
    CHECK(repair.vertices == (cells[1] == 3 ? 2 : 1));
    CHECK(repair.removed == 1);
    CHECK(r.H.rows() == 1);
    CHECK(r.V.rows() == 8);  // unused vertices dropped
    const BoundaryDefects d = find_boundary_defects(r);
    CHECK(d.edges.empty());
    CHECK(d.vertices.empty());
  }
  const HexMesh g = grid_cells(2, 2, 1, {0, 1, 2});
  const NonmanifoldRepair clean = remove_nonmanifold_boundary(g);
  CHECK(clean.removed == 0);
  CHECK(clean.mesh.H == g.H);
}

TEST_CASE("pad_boundary repairs a non-manifold edge first: manifold result, no inverted hex", "[pad]") {
  // two columns of two cubes, (0,0,*) and (1,1,*) of a 2x2x2 grid, touching along the line x = y = 1
  const HexMesh m = grid_cells(2, 2, 2, {0, 3, 4, 7});
  REQUIRE(find_boundary_defects(m).edges.size() == 2);  // the column x = y = 1, two cells tall
  PadStats st;
  PadParams full;  // a layer everywhere (selective: on this blocky lattice, nowhere)
  full.selective = false;
  const HexMesh out = pad_boundary(m, nullptr, full, &st);
  CHECK(st.nonmanifold_edges == 2);
  CHECK(st.nonmanifold_removed >= 1);
  CHECK(st.nonmanifold_left == 0);
  CHECK(st.inverted == 0);
  const BoundaryDefects d = find_boundary_defects(out);
  CHECK(d.edges.empty());
  CHECK(d.vertices.empty());

  PadParams keep = full;
  keep.repair_nonmanifold = false;
  PadStats st2;
  pad_boundary(m, nullptr, keep, &st2);
  CHECK(st2.nonmanifold_removed == 0);
  CHECK(st2.nonmanifold_left > 0);  // reported, not silently passed
}

TEST_CASE("peel_boundary_hexes removes inverted boundary hexes only", "[pad]") {
  // 4x4x4 cubes; the corner vertex (4,4,4) pushed past (3,3,3) inverts the one corner hex; the centre
  // vertex (2,2,2) pushed away inverts interior hexes, which peeling must leave
  HexMesh m = test::grid_hex_mesh(4, 4, 4);
  auto id = [](int i, int j, int k) { return i + 5 * (j + 5 * k); };
  m.V.row(id(4, 4, 4)) << 2.8, 2.8, 2.8;
  m.V.row(id(2, 2, 2)) << 3.5, 2.0, 2.0;
  Eigen::VectorXd sj, corner;
  hex_scaled_jacobians(m, sj, corner);
  const long inverted = long((corner.array() <= 0).count());
  REQUIRE(inverted >= 2);  // the corner hex and some around the centre
  const Peeled peeled = peel_boundary_hexes(m, 0.0, 3);
  const HexMesh& r = peeled.mesh;
  CHECK(peeled.removed == 1);
  CHECK(r.H.rows() == 63);
  hex_scaled_jacobians(r, sj, corner);
  CHECK(long((corner.array() <= 0).count()) == inverted - 1);
  // a bar of cubes whose every hex is inverted: a round that would remove them all is skipped
  HexMesh bar = test::grid_hex_mesh(2, 1, 1);
  bar.V.col(0) *= -1.0;  // mirrored: every hex inverted
  const Peeled kept = peel_boundary_hexes(bar, 0.0, 3);
  CHECK(kept.removed == 0);
  CHECK(kept.mesh.H.rows() == 2);
}
