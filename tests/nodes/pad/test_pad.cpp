// Padding layer (§6 inset): counts, closed boundary, inner copies, offsets limited against inversion.
#include "nodes/algorithms/hex_quality.h"
#include "nodes/pad/pad.h"
#include "tests/helpers/voxel_maps.h"

#include <catch2/catch.hpp>

using namespace polyhex;

TEST_CASE("padding a 3x3x3 grid adds 54 hexes and keeps the boundary closed", "[pad]") {
  HexMesh g = test::grid_hex_mesh(3, 3, 3);
  SurfaceMesh s = test::voxel_surface(test::voxel_box(3, 3, 3));
  PadParams full;  // the whole layer (selective padding leaves a box's lattice alone: test_pad_selective.cpp)
  full.selective = false;
  for (bool with_surface : {false, true}) {
    PadStats st;
    HexMesh m = pad_boundary(g, with_surface ? &s : nullptr, full, &st);
    CHECK(st.hexes_added == 54);
    CHECK(st.vertices_added == 56);
    CHECK(m.H.rows() == 27 + 54);
    CHECK(m.V.rows() == 64 + 56);
    CHECK(st.inverted == 0);
    CHECK(st.limited == 0);
    HexQuality q = hex_quality(m, nullptr);
    CHECK(q.inverted == 0);
    CHECK(q.boundary_quads == 54);
    CHECK(q.nonmanifold_boundary_edges == 0);
    CHECK(q.faces_shared_by_more_than_two == 0);
    CHECK(q.unused_vertices == 0);
    CHECK(q.volume == Approx(27.0));
    // the outer layer stays where the boundary was
    CHECK((m.V.topRows(64) - g.V).cwiseAbs().maxCoeff() < 1e-12);
    // a face-centre-like vertex (1,1,0) gets its inner copy at (1,1,0.4)
    bool found = false;
    for (Eigen::Index v = 64; v < m.V.rows(); ++v)
      found = found || (m.V.row(v) - Eigen::RowVector3d(1, 1, 0.4)).norm() < 1e-12;
    CHECK(found);
  }
}

TEST_CASE("a thick padding of a single hex is limited so that nothing inverts", "[pad]") {
  HexMesh g = test::grid_hex_mesh(1, 1, 1);
  PadParams p;
  p.selective = false;
  p.thickness = 0.9;  // corners would cross the centre: (0,0,0) -> 0.52 (1,1,1)
  PadStats st;
  HexMesh m = pad_boundary(g, nullptr, p, &st);
  CHECK(m.H.rows() == 7);
  CHECK(st.limited == 8);
  CHECK(st.inverted == 0);
  CHECK(hex_quality(m, nullptr).inverted == 0);
}

TEST_CASE("padding an empty hex mesh is an error", "[pad]") {
  HexMesh empty;
  empty.source = "empty.vtk";
  REQUIRE_THROWS_WITH(pad_boundary(empty, nullptr), Catch::Contains("empty.vtk: no hexahedra"));
}
