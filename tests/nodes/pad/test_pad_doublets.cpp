// Boundary doublets before padding: found, the worse hex removed, the boundary stays manifold.
#include <catch2/catch.hpp>

#include "nodes/pad/pad.h"
#include "nodes/quality/quality.h"
#include "tests/nodes/quality/hex_fixtures.h"

using namespace polyhex;

namespace {

/// A unit cube A and a hex B wrapped around its edge 2-6: B = (p, 1, 2, 3, q, 5, 6, 7) shares A's faces
/// (1, 2, 6, 5) and (2, 3, 7, 6), so vertices 2 and 6 are in only two boundary quads (doublets).
HexMesh wrapped_pair() {
  HexMesh m = test::grid_hex_mesh(1, 1, 1);
  m.V.conservativeResize(10, 3);
  m.V.row(8) << 2, 2, 0;
  m.V.row(9) << 2, 2, 1;
  m.H.conservativeResize(2, 8);
  m.H.row(1) << 8, m.H(0, 1), m.H(0, 2), m.H(0, 3), 9, m.H(0, 5), m.H(0, 6), m.H(0, 7);
  return m;
}

}  // namespace

TEST_CASE("remove_boundary_doublets removes the hex wrapped around a doublet edge", "[pad]") {
  const HexMesh m = wrapped_pair();
  long doublets = -1, removed = -1;
  const HexMesh r = remove_boundary_doublets(m, &doublets, &removed);
  CHECK(doublets == 2);
  CHECK(removed == 1);
  REQUIRE(r.H.rows() == 1);
  CHECK(r.V.rows() == 8);  // p and q dropped
  CHECK(hex_quality(r, nullptr).inverted == 0);
  // padding the result gives one hex per boundary quad of the cube, none inverted (peeling off: the
  // wrapped hex is inverted, peeling alone would remove it)
  PadParams no_peel;
  no_peel.peel_rounds = 0;
  PadStats st;
  const HexMesh padded = pad_boundary(m, nullptr, no_peel, &st);
  CHECK(st.doublets == 2);
  CHECK(st.hexes_removed == 1);
  CHECK(padded.H.rows() == 1 + 6);
  CHECK(st.inverted == 0);
  // off: the pair is padded as it is
  PadParams keep = no_peel;
  keep.remove_doublets = false;
  PadStats st2;
  CHECK(pad_boundary(m, nullptr, keep, &st2).H.rows() == 2 + 8);
  CHECK(st2.doublets == 0);
}

TEST_CASE("remove_boundary_doublets leaves a mesh without doublets unchanged", "[pad]") {
  const HexMesh g = test::grid_hex_mesh(3, 2, 2);
  long doublets = -1, removed = -1;
  const HexMesh r = remove_boundary_doublets(g, &doublets, &removed);
  CHECK(doublets == 0);
  CHECK(removed == 0);
  CHECK(r.V == g.V);
  CHECK(r.H == g.H);
}
