// Selective padding: a layer only where the lattice turns otherwise than the surface, ending on convex
// creases, the parts that meet on one padded in turn.
#include "nodes/algorithms/hex_quality.h"
#include "nodes/pad/pad.h"
#include "tests/helpers/hex_fixtures.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <functional>

using namespace polyhex;

namespace {

/// A grid mesh of n^3 unit cubes (n even) whose boundary vertex at the middle of each face listed in `bumps`
/// (0: z = n, 1: y = 0) is pulled out by one cube edge: the four quads round it tilt by 45 degrees.
HexMesh bumped_grid(int n, std::initializer_list<int> bumps) {
  HexMesh g = test::grid_hex_mesh(n, n, n);
  const int m = n / 2;
  for (Eigen::Index v = 0; v < g.V.rows(); ++v) {
    const Eigen::RowVector3d p = g.V.row(v);
    for (int b : bumps) {
      if (b == 0 && p.x() == m && p.y() == m && p.z() == n) g.V(v, 2) += 1;
      if (b == 1 && p.x() == m && p.y() == 0 && p.z() == m) g.V(v, 1) -= 1;
    }
  }
  return g;
}

long padded_count(const std::vector<char>& pad) { return long(std::count(pad.begin(), pad.end(), 1)); }

double min_sj(const HexMesh& m, const std::function<bool(const Eigen::Vector3d&)>& where) {
  Eigen::VectorXd sj, corner;
  hex_scaled_jacobians(m, sj, corner);
  double lo = 1;
  for (Eigen::Index h = 0; h < m.H.rows(); ++h) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int k = 0; k < 8; ++k) c += m.V.row(m.H(h, k)).transpose() / 8.0;
    if (where(c)) lo = std::min(lo, sj[h]);
  }
  return lo;
}

}  // namespace

TEST_CASE("selective padding: a box's lattice needs no layer", "[pad]") {
  const HexMesh g = test::grid_hex_mesh(4, 3, 2);
  const SurfaceMesh s = test::boundary_surface(g);
  const auto Q = hex_boundary_quads(g);
  REQUIRE(Q.rows() == 52);
  CHECK(padded_count(select_padded_quads(g, Q, 30.0)) == 0);
  PadStats st;
  const HexMesh m = pad_boundary(g, &s, {}, &st);
  CHECK(m.H.rows() == 24);
  CHECK(st.layers == 0);
  CHECK(st.unpadded == 52);
  CHECK(st.hexes_added == 0);
  CHECK((m.V - g.V).cwiseAbs().maxCoeff() < 1e-12);
}

TEST_CASE("selective padding: a lattice on a smooth surface gets the whole layer, as full padding", "[pad]") {
  // a 6^3 grid mapped onto a ball: the cube's edges lie where the sphere is smooth (the lattice turns by 90
  // degrees there, the surface by about 15), and no edge is a crease the layer could end on
  HexMesh g = test::grid_hex_mesh(6, 6, 6);
  for (Eigen::Index v = 0; v < g.V.rows(); ++v) {
    const Eigen::Vector3d q = (g.V.row(v).transpose() - Eigen::Vector3d::Constant(3.0)) / 3.0;
    if (q.norm() > 0)
      g.V.row(v) = (Eigen::Vector3d::Constant(3.0) + 3.0 * q * (q.cwiseAbs().maxCoeff() / q.norm())).transpose();
  }
  const SurfaceMesh s = test::boundary_surface(g);
  const auto Q = hex_boundary_quads(g);
  CHECK(padded_count(select_padded_quads(g, Q, 30.0)) == Q.rows());
  PadParams full;
  full.selective = false;
  PadStats sel, all;
  const HexMesh a = pad_boundary(g, &s, {}, &sel), b = pad_boundary(g, &s, full, &all);
  CHECK(sel.layers == 1);
  CHECK(sel.hexes_added == Q.rows());
  CHECK(a.H == b.H);
  CHECK(a.V == b.V);
}

TEST_CASE("selective padding: the layer ends on a convex crease, where its hexes stay boxes", "[pad]") {
  // a bump in the middle of the top face: its four tilted quads need the layer, which spreads over the flat
  // top (it cannot end where the surface is flat) and ends on the top's four convex edges
  const HexMesh g = bumped_grid(6, {0});
  const SurfaceMesh s = test::boundary_surface(g);
  const auto Q = hex_boundary_quads(g);
  const auto pad = select_padded_quads(g, Q, 30.0);
  CHECK(padded_count(pad) == 36);
  for (Eigen::Index q = 0; q < Q.rows(); ++q) {
    double zmin = 1e9;
    for (int k = 0; k < 4; ++k) zmin = std::min(zmin, g.V(Q(q, k), 2));
    CHECK(bool(pad[size_t(q)]) == (zmin >= 6.0));  // the top's quads, and no other
  }
  PadStats st;
  const HexMesh m = pad_boundary(g, &s, {}, &st);
  CHECK(st.layers == 1);
  CHECK(st.hexes_added == 36);
  CHECK(st.layer_ends == 24);  // the top's rim
  CHECK(st.inverted == 0);
  // the rim's inner copies lie on the sides, 0.4 below the rim (a strip of the boundary)
  long on_sides = 0;
  for (Eigen::Index v = g.V.rows(); v < m.V.rows(); ++v) {
    const Eigen::RowVector3d p = m.V.row(v);
    const bool side = p.x() == 0 || p.x() == 6 || p.y() == 0 || p.y() == 6;
    if (side) {
      ++on_sides;
      CHECK(p.z() == Approx(5.6).margin(1e-12));
    }
  }
  CHECK(on_sides == 24);
  // away from the bump every hex is a box: the layer's at the rim too
  CHECK(min_sj(m, [](const Eigen::Vector3d& c) { return (c.head<2>() - Eigen::Vector2d(3, 3)).norm() > 2.3; }) > 0.999);
  HexQuality q = hex_quality(m, nullptr);
  CHECK(q.nonmanifold_boundary_edges == 0);
  CHECK(q.volume == Approx(hex_quality(g, nullptr).volume));
}

TEST_CASE("selective padding: two parts meeting on a convex crease are padded in turn", "[pad]") {
  // bumps on the top and on the front: each face is a part whose layer ends on its rim; they share the
  // top-front edge, so the top is padded first and the front (with the top layer's strip) after it
  const HexMesh g = bumped_grid(6, {0, 1});
  const SurfaceMesh s = test::boundary_surface(g);
  PadStats st;
  const HexMesh m = pad_boundary(g, &s, {}, &st);
  CHECK(st.layers == 2);
  CHECK(st.hexes_added == 36 + 36 + 6);
  CHECK(st.inverted == 0);
  // along the shared edge the hexes are near boxes (the second layer is a little thinner over the first's
  // strip), not sheared round it by one layer (0.71)
  CHECK(min_sj(m, [](const Eigen::Vector3d& c) { return c.y() < 1 && c.z() > 5 && c.x() > 1 && c.x() < 5; }) > 0.99);
  CHECK(hex_quality(m, nullptr).nonmanifold_boundary_edges == 0);
}

TEST_CASE("selective padding, split_parts false: the two parts in one layer, sheared round their edge", "[pad]") {
  const HexMesh g = bumped_grid(6, {0, 1});
  const SurfaceMesh s = test::boundary_surface(g);
  PadParams p;
  p.split_parts = false;
  PadStats st;
  const HexMesh m = pad_boundary(g, &s, p, &st);
  CHECK(st.layers == 1);
  CHECK(st.hexes_added == 36 + 36);  // no quad padded twice
  CHECK(st.inverted == 0);
  // along the shared edge one layer turns round it: its hexes there are sheared (0.71 on a straight edge), not
  // the near boxes of two layers in turn (above, > 0.99)
  const double sheared =
      min_sj(m, [](const Eigen::Vector3d& c) { return c.y() < 1 && c.z() > 5 && c.x() > 1 && c.x() < 5; });
  CHECK(sheared > 0.5);  // 0.58: the bumps tilt the edge's middle
  CHECK(sheared < 0.8);
  CHECK(hex_quality(m, nullptr).nonmanifold_boundary_edges == 0);
  CHECK(hex_quality(m, nullptr).volume == Approx(hex_quality(g, nullptr).volume));
}

TEST_CASE("selective padding: every quad on a non-manifold edge is padded", "[pad]") {
  // cells (0,0,0) and (1,1,0) of a 2x2x1 grid touch along the edge x = y = 1 only: four boundary quads
  // on it. Every other edge is a box's convex edge, where the layer is not needed.
  const HexMesh g = test::grid_hex_mesh(2, 2, 1);
  HexMesh m = g;
  m.H.resize(2, 8);
  m.H.row(0) = g.H.row(0);
  m.H.row(1) = g.H.row(3);
  const auto Q = hex_boundary_quads(m);
  REQUIRE(Q.rows() == 12);
  const std::vector<char> pad = select_padded_quads(m, Q, 30.0);
  auto on_edge = [&](Eigen::Index q) {
    int n = 0;
    for (int k = 0; k < 4; ++k) n += m.V(Q(q, k), 0) == 1 && m.V(Q(q, k), 1) == 1;
    return n == 2;
  };
  int on = 0;
  for (Eigen::Index q = 0; q < Q.rows(); ++q)
    if (on_edge(q)) {
      ++on;
      CHECK(pad[size_t(q)] == 1);
    }
  CHECK(on == 4);
}
