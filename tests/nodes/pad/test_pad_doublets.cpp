// Boundary doublets before padding: found, the worse hex removed, the boundary stays manifold.
#include "nodes/algorithms/hex_quality.h"
#include "nodes/pad/pad.h"
#include "tests/helpers/hex_fixtures.h"

#include <catch2/catch.hpp>

#include <array>
#include <map>
#include <vector>

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

/// Unit cubes at the given cells, VTK_HEXAHEDRON order, vertices shared by position; then the corner at
/// `slit` of every cube with y index >= 1 is replaced by a copy of it: the faces at the plane y = 1 that
/// touch `slit` are cut open up to the 2x2x2 block's centre (1, 1, 1), which becomes a doublet (its only
/// boundary quads are the two sides of the cut face), as lattice extraction leaves one where the
/// PolyCube map folds (carter).
HexMesh cubes_with_slit(const std::vector<std::array<int, 3>>& cells, const std::array<int, 3>& slit) {
  std::map<std::array<int, 3>, int> id;
  std::vector<std::array<int, 3>> pos;
  auto vid = [&](std::array<int, 3> p) {
    auto [it, added] = id.emplace(p, int(pos.size()));
    if (added) pos.push_back(p);
    return it->second;
  };
  std::vector<std::array<int, 8>> hexes;
  for (auto [i, j, k] : cells)
    hexes.push_back({vid({i, j, k}), vid({i + 1, j, k}), vid({i + 1, j + 1, k}), vid({i, j + 1, k}), vid({i, j, k + 1}),
                     vid({i + 1, j, k + 1}), vid({i + 1, j + 1, k + 1}), vid({i, j + 1, k + 1})});
  const int orig = id.at(slit), copy = int(pos.size());
  pos.push_back(slit);
  for (size_t h = 0; h < cells.size(); ++h)
    if (cells[h][1] >= 1)
      for (int& v : hexes[h])
        if (v == orig) v = copy;
  HexMesh m;
  m.V.resize(Eigen::Index(pos.size()), 3);
  for (size_t v = 0; v < pos.size(); ++v) m.V.row(Eigen::Index(v)) << pos[v][0], pos[v][1], pos[v][2];
  m.H.resize(Eigen::Index(hexes.size()), 8);
  for (size_t h = 0; h < hexes.size(); ++h)
    for (int c = 0; c < 8; ++c) m.H(Eigen::Index(h), c) = hexes[h][size_t(c)];
  return m;
}

}  // namespace

TEST_CASE("remove_boundary_doublets: when the preferred hex would open a non-manifold edge, its partner goes",
          "[pad]") {
  // a 2x2x2 block of cubes plus three, the face between cells (0,0,1) and (0,1,1) cut open at the corner
  // (0,1,2): both cells have 3 boundary faces and the same scaled Jacobian, so (0,0,1) (lower index) is
  // preferred, but without it the cells (-1,0,1) and (0,0,0) would touch along the edge (0,0,1)-(0,1,1)
  // only; without (0,1,1) the boundary stays manifold. Before trying the partner, nothing was removed
  // and the padded layer kept the doublet (two layer hexes with opposite determinants at it)
  std::vector<std::array<int, 3>> cells;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      for (int k = 0; k < 2; ++k) cells.push_back({i, j, k});
  for (std::array<int, 3> c : {std::array<int, 3>{-1, 0, 1}, {0, 1, 2}, {1, 1, 2}}) cells.push_back(c);
  const HexMesh m = cubes_with_slit(cells, {0, 1, 2});
  REQUIRE(find_boundary_defects(m).edges.empty());
  const DoubletRepair repair = remove_boundary_doublets(m);
  const HexMesh& r = repair.mesh;
  CHECK(repair.doublets == 1);
  CHECK(repair.removed == 1);
  REQUIRE(r.H.rows() == m.H.rows() - 1);
  CHECK(find_boundary_defects(r).edges.empty());
  CHECK(remove_boundary_doublets(r).doublets == 0);
  // the cube that went is cell (0,1,1): no remaining hex has its centre (0.5, 1.5, 1.5)
  for (Eigen::Index h = 0; h < r.H.rows(); ++h) {
    Eigen::RowVector3d c = Eigen::RowVector3d::Zero();
    for (int k = 0; k < 8; ++k) c += r.V.row(r.H(h, k)) / 8;
    CHECK((c - Eigen::RowVector3d(0.5, 1.5, 1.5)).norm() > 0.1);
  }
}

TEST_CASE("remove_boundary_doublets removes the hex wrapped around a doublet edge", "[pad]") {
  const HexMesh m = wrapped_pair();
  const DoubletRepair repair = remove_boundary_doublets(m);
  const HexMesh& r = repair.mesh;
  CHECK(repair.doublets == 2);
  CHECK(repair.removed == 1);
  REQUIRE(r.H.rows() == 1);
  CHECK(r.V.rows() == 8);  // p and q dropped
  CHECK(hex_quality(r, nullptr).inverted == 0);
  // padding the result gives one hex per boundary quad of the cube, none inverted (peeling off: the
  // wrapped hex is inverted, peeling alone would remove it)
  PadParams no_peel;
  no_peel.peel_rounds = 0;
  no_peel.selective = false;  // the whole layer: one hex per boundary quad
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
  const DoubletRepair repair = remove_boundary_doublets(g);
  const HexMesh& r = repair.mesh;
  CHECK(repair.doublets == 0);
  CHECK(repair.removed == 0);
  CHECK(r.V == g.V);
  CHECK(r.H == g.H);
}
