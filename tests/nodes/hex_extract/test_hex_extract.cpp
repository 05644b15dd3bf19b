// Hex extraction from PolyCube maps (§6): exact grids from exact PolyCubes, sheared inputs, the
// overlapping map of Fig. 9, named errors.
#include "nodes/algorithms/hex_quality.h"
#include "nodes/hex_extract/hex_extract.h"
#include "tests/helpers/voxel_maps.h"

#include <catch2/catch.hpp>

#include <set>

using namespace polyhex;

namespace {

/// Every vertex at a distinct position (no duplicated vertex).
long coincident_vertices(const HexMesh& m, double tol) {
  std::set<std::array<long, 3>> cells;
  long dup = 0;
  for (Eigen::Index v = 0; v < m.V.rows(); ++v) {
    std::array<long, 3> c;
    for (int a = 0; a < 3; ++a) c[size_t(a)] = std::lround(m.V(v, a) / tol);
    dup += !cells.insert(c).second;
  }
  return dup;
}

void check_exact_grid(const std::vector<std::array<int, 3>>& voxels, int per_voxel) {
  PolyCubeMap m = test::identity_map(voxels, per_voxel);
  REQUIRE(m.segmentation->valid);
  HexExtractStats st;
  HexMesh hm = extract_hexes(m, {}, &st);
  const long expected = long(voxels.size()) * per_voxel * per_voxel * per_voxel;
  CHECK(hm.H.rows() == expected);
  CHECK(st.hexes == expected);
  CHECK(st.inverted == 0);
  CHECK(st.unlocated == 0);
  CHECK(st.unused_vertices == 0);
  HexQuality q = hex_quality(hm, nullptr);
  CHECK(q.sj_min == Approx(1.0).margin(1e-9));
  CHECK(q.irregular_interior_pct == 0.0);
  CHECK(q.faces_shared_by_more_than_two == 0);
  CHECK(q.nonmanifold_boundary_edges == 0);
  CHECK(q.volume == Approx(double(voxels.size())).epsilon(1e-9));
  // every vertex on the lattice, each lattice point once
  const double h = m.edge_length;
  double off = 0;
  for (Eigen::Index i = 0; i < hm.V.size(); ++i)
    off = std::max(off, std::abs(hm.V.data()[i] / h - std::round(hm.V.data()[i] / h)));
  CHECK(off < 1e-9);
  CHECK(coincident_vertices(hm, 1e-6) == 0);
}

}  // namespace

TEST_CASE("exact PolyCube of a box gives exactly the grid", "[hex]") { check_exact_grid(test::voxel_box(3, 2, 2), 2); }

TEST_CASE("exact PolyCube of an L-block and a C-shape gives exactly the grid", "[hex]") {
  check_exact_grid({{0, 0, 0}, {1, 0, 0}, {0, 0, 1}}, 3);
  check_exact_grid({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0, 1, 0}, {0, 2, 0}, {1, 2, 0}, {2, 2, 0}}, 2);
}

TEST_CASE("a rotated and sheared input over an exact PolyCube gives the sheared grid, all positive", "[hex]") {
  PolyCubeMap m = test::identity_map({{0, 0, 0}, {1, 0, 0}, {0, 0, 1}}, 2);
  Eigen::Matrix3d A = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  S(0, 1) = 0.4;
  S(2, 0) = -0.3;
  auto moved = std::make_shared<TetMesh>(*m.input);
  moved->V = (m.input->V * (A * S).transpose()).eval();
  m.input = moved;
  HexExtractStats st;
  HexMesh hm = extract_hexes(m, {}, &st);
  CHECK(hm.H.rows() == 3 * 8);
  CHECK(st.inverted == 0);
  HexQuality q = hex_quality(hm, nullptr);
  CHECK(q.inverted == 0);
  CHECK(q.sj_min > 0.5);
  CHECK(q.volume == Approx(3.0 * (A * S).determinant()).epsilon(1e-9));
}

TEST_CASE("an overlapping map at a concave edge (Fig. 9) still gives a conforming, positive grid", "[hex]") {
  // L-block: x in [0,2], z in [0,1] plus x in [0,1], z in [1,2]; the concave edge is x = z = 1.
  PolyCubeMap m = test::identity_map({{0, 0, 0}, {1, 0, 0}, {0, 0, 1}}, 4, 0.05);
  const auto& T = m.input->T;
  const auto bf = boundary_triangles(*m.input);
  std::vector<char> on_boundary(size_t(m.U.rows()), 0);
  for (Eigen::Index f = 0; f < bf.rows(); ++f)
    for (int k = 0; k < 3; ++k) on_boundary[size_t(bf(f, k))] = 1;
  // push the interior vertices near the concave edge across it, into the empty quadrant
  int moved = 0;
  for (Eigen::Index v = 0; v < m.U.rows(); ++v) {
    const double dx = 1 - m.U(v, 0), dz = 1 - m.U(v, 2);
    if (on_boundary[size_t(v)] || dx < 0 || dz < 0 || std::hypot(dx, dz) > 0.3) continue;
    m.U(v, 0) += 0.45;
    m.U(v, 2) += 0.45;
    ++moved;
  }
  REQUIRE(moved > 0);
  int inverted_tets = 0;
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    Eigen::Vector3d p[4];
    for (int k = 0; k < 4; ++k) p[k] = m.U.row(T(t, k)).transpose();
    inverted_tets += (p[1] - p[0]).dot((p[2] - p[0]).cross(p[3] - p[0])) <= 0;
  }
  REQUIRE(inverted_tets > 0);
  HexExtractStats st;
  HexMesh hm = extract_hexes(m, {}, &st);
  CHECK(st.dropped_conflict > 0);
  CHECK(hm.H.rows() == 3 * 64);
  CHECK(st.unlocated == 0);
  CHECK(coincident_vertices(hm, 1e-6) == 0);
  HexQuality q = hex_quality(hm, nullptr);
  CHECK(q.inverted == 0);
  CHECK(q.faces_shared_by_more_than_two == 0);
  CHECK(q.nonmanifold_boundary_edges == 0);
  CHECK(q.irregular_interior_pct == 0.0);
}

TEST_CASE("bad PolyCube maps are named", "[hex]") {
  PolyCubeMap m = test::identity_map(test::voxel_box(1, 1, 1), 2, 0.2);
  PolyCubeMap bad = m;
  bad.edge_length = 0;
  REQUIRE_THROWS_WITH(extract_hexes(bad), Catch::Contains("edge length 0.000000 must be > 0"));
  bad = m;
  bad.U.conservativeResize(m.U.rows() - 1, 3);
  REQUIRE_THROWS_WITH(extract_hexes(bad), Catch::Contains("PolyCube positions for"));
  bad = m;
  bad.chart_plane[0] += 1;
  REQUIRE_THROWS_WITH(extract_hexes(bad), Catch::Contains("not on the chart plane"));
  bad = m;
  bad.segmentation = nullptr;
  REQUIRE_THROWS_WITH(extract_hexes(bad), Catch::Contains("no segmentation"));
}
