// Global untangling (§6 optimization): the energy, its gradient, and untangling a folded grid.
#include "nodes/algorithms/hex_corners.h"
#include "nodes/algorithms/hex_quality.h"
#include "nodes/optimize/untangle_global.h"
#include "tests/helpers/voxel_maps.h"

#include <catch2/catch.hpp>

using namespace polyhex;

namespace {

std::array<Eigen::Vector3d, 8> hex_corners(const HexMesh& m, Eigen::Index h) {
  std::array<Eigen::Vector3d, 8> p;
  for (int k = 0; k < 8; ++k) p[size_t(k)] = m.V.row(m.H(h, k)).transpose();
  return p;
}

/// Flags the hexes of g whose scaled Jacobian is below `below`.
std::vector<char> hexes_near_minimum(const HexMesh& g, double below) {
  Eigen::VectorXd sj, corner_min;
  hex_scaled_jacobians(g, sj, corner_min);
  std::vector<char> seeds(size_t(g.H.rows()), 0);
  for (size_t h = 0; h < seeds.size(); ++h) seeds[h] = sj[Eigen::Index(h)] < below;
  return seeds;
}

/// An ascent over the seeds and one ring around them, 200 iterations.
GlobalUntangleParams one_ring_ascent() {
  GlobalUntangleParams p;
  p.rings = 1;
  p.polish_iterations = 200;
  return p;
}

/// An n x n x n grid of unit cubes whose boundary vertices are fixed and none is on the surface (the box's
/// surface only backs the tree the descents take).
struct FixedBoundaryGrid {
  int n;
  HexMesh g;
  SurfaceMesh s;
  TriangleTree tree;
  std::vector<Eigen::Vector3d> normals;
  std::vector<char> on_surface, fixed;
  explicit FixedBoundaryGrid(int n_)
      : n(n_),
        g(test::grid_hex_mesh(n, n, n)),
        s(test::voxel_surface(test::voxel_box(n, n, n))),
        tree(s.V, s.F),
        normals(size_t(s.F.rows()), Eigen::Vector3d::UnitZ()),
        on_surface(size_t(g.V.rows()), 0),
        fixed(size_t(g.V.rows()), 0) {
    for (Eigen::Index v = 0; v < g.V.rows(); ++v)
      fixed[size_t(v)] = (g.V.row(v).array() < 1e-12).any() || (g.V.row(v).array() > n - 1e-12).any();
  }
};

/// A 4x4x4 grid of unit cubes and its box surface: the surface's tree and triangle normals, and
/// which vertices are on it.
struct BoxGrid {
  static constexpr int n = 4;
  HexMesh g = test::grid_hex_mesh(n, n, n);
  SurfaceMesh s = test::voxel_surface(test::voxel_box(n, n, n));
  TriangleTree tree{s.V, s.F};
  std::vector<Eigen::Vector3d> normals;
  std::vector<char> on_surface, fixed;
  BoxGrid() : normals(size_t(s.F.rows())), on_surface(size_t(g.V.rows()), 0), fixed(size_t(g.V.rows()), 0) {
    for (Eigen::Index f = 0; f < s.F.rows(); ++f)
      normals[size_t(f)] = (s.V.row(s.F(f, 1)) - s.V.row(s.F(f, 0)))
                               .cross(s.V.row(s.F(f, 2)) - s.V.row(s.F(f, 0)))
                               .normalized()
                               .transpose();
    const auto Q = hex_boundary_quads(g);
    for (Eigen::Index q = 0; q < Q.rows(); ++q)
      for (int k = 0; k < 4; ++k) on_surface[size_t(Q(q, k))] = 1;
  }
  Eigen::Index vertex_at(const Eigen::RowVector3d& x) const {
    for (Eigen::Index v = 0; v < g.V.rows(); ++v)
      if ((g.V.row(v) - x).norm() < 1e-12) return v;
    return -1;
  }
};

}  // namespace

TEST_CASE("untangle energy: 9 for a cube at any scale, gradient zero there and equal to finite differences",
          "[quality-opt]") {
  HexMesh g = test::grid_hex_mesh(1, 1, 1, 2.0);
  auto p = hex_corners(g, 0);
  Eigen::Matrix<double, 8, 3> G;
  CHECK(hex_untangle_energy(p, 2.0, 1e-12, &G) == Approx(9.0).epsilon(1e-9));
  CHECK(G.norm() < 1e-9);
  CHECK(hex_untangle_energy(p, 0.5, 1e-12) == Approx(9.0).epsilon(1e-9));
  // a folded hex: corner 6 pushed through the opposite corner; ε keeps the energy finite
  p[6] = Eigen::Vector3d(-0.5, -0.3, -0.2);
  const double eps = 0.3;
  const double e = hex_untangle_energy(p, 2.0, eps, &G);
  REQUIRE(std::isfinite(e));
  CHECK(e > 9.0);
  for (int k = 0; k < 8; ++k)
    for (int a = 0; a < 3; ++a) {
      auto q = p;
      const double d = 1e-6;
      q[size_t(k)][a] += d;
      const double ep = hex_untangle_energy(q, 2.0, eps);
      q[size_t(k)][a] -= 2 * d;
      const double em = hex_untangle_energy(q, 2.0, eps);
      CHECK(G(k, a) == Approx((ep - em) / (2 * d)).margin(1e-5 * std::max(1.0, std::abs(G(k, a)))));
    }
}

TEST_CASE("untangle_global unfolds a grid with an interior vertex pushed through its neighbours", "[quality-opt]") {
  BoxGrid b;
  [[maybe_unused]] auto& [g, surface, tree, normals, on_surface, fixed] = b;
  // the vertex at (2, 2, 2) moved 1.6 edges along x: its hexes on the +x side fold
  const Eigen::Index centre = b.vertex_at({2, 2, 2});
  REQUIRE(centre >= 0);
  g.V(centre, 0) += 1.6;
  REQUIRE(hex_quality(g, nullptr).inverted >= 4);
  // a spent time budget: nothing moves, and the stats say why
  {
    RowMatrixX3d V = g.V;
    GlobalUntangleParams none;
    none.seconds = 1e-12;
    GlobalUntangleStats st0;
    CHECK(untangle_global(V, g.H, on_surface, fixed, tree, normals, none, &st0) >= 4);
    CHECK(st0.time_budget_hit);
    CHECK(st0.lbfgs_iterations == 0);
    CHECK(V == g.V);
  }
  GlobalUntangleStats st;
  const long left = untangle_global(g.V, g.H, on_surface, fixed, tree, normals, {}, &st);
  CHECK_FALSE(st.time_budget_hit);
  CHECK(left == 0);
  CHECK(st.inverted_before >= 4);
  CHECK(st.inverted_after == 0);
  CHECK(hex_quality(g, nullptr).inverted == 0);
  CHECK(st.free_vertices > 8);
  // boundary vertices stayed on the box surface
  for (Eigen::Index v = 0; v < g.V.rows(); ++v)
    if (on_surface[size_t(v)]) CHECK(tree.distance(g.V.row(v).transpose()) < 1e-9);
}

TEST_CASE("untangle_global leaves an untangled mesh and fixed vertices alone", "[quality-opt]") {
  HexMesh g = test::grid_hex_mesh(2, 2, 2);
  SurfaceMesh s = test::voxel_surface(test::voxel_box(2, 2, 2));
  TriangleTree tree(s.V, s.F);
  std::vector<Eigen::Vector3d> normals(size_t(s.F.rows()), Eigen::Vector3d::UnitZ());
  const RowMatrixX3d before = g.V;
  std::vector<char> on_surface(size_t(g.V.rows()), 0), fixed(size_t(g.V.rows()), 0);
  GlobalUntangleStats st;
  CHECK(untangle_global(g.V, g.H, on_surface, fixed, tree, normals, {}, &st) == 0);
  CHECK(st.outer == 0);
  CHECK(g.V == before);
  // every vertex fixed: nothing can move, the fold stays
  g.V(13, 0) += 1.6;  // the centre vertex of the 3x3x3 vertex grid
  REQUIRE(hex_quality(g, nullptr).inverted > 0);
  fixed.assign(size_t(g.V.rows()), 1);
  const RowMatrixX3d folded = g.V;
  CHECK(untangle_global(g.V, g.H, on_surface, fixed, tree, normals, {}, &st) > 0);
  CHECK(st.free_vertices == 0);
  CHECK(g.V == folded);
}

TEST_CASE("smooth_region evens out a squeezed patch, keeps the surface and needs an untangled region",
          "[quality-opt]") {
  BoxGrid b;
  [[maybe_unused]] auto& [g, surface, tree, normals, on_surface, fixed] = b;
  // a boundary vertex of the z = 0 face slid along the face towards its neighbour: squeezed, not inverted
  const Eigen::Index v = b.vertex_at({2, 2, 0});
  REQUIRE(v >= 0);
  g.V.row(v) << 2.45, 2.35, 0;
  const HexQuality q0 = hex_quality(g, nullptr);
  REQUIRE(q0.inverted == 0);
  REQUIRE(q0.sj_min < 0.6);
  std::vector<char> seeds(size_t(g.H.rows()), 0);
  for (Eigen::Index h = 0; h < g.H.rows(); ++h)
    seeds[size_t(h)] = hex_scaled_jacobian(hex_corners(g, h)).sj < q0.sj_min + 0.05;
  RowMatrixX3d V = g.V;
  GlobalUntangleStats st;
  smooth_region(V, g.H, on_surface, fixed, tree, normals, seeds, {}, &st);
  HexMesh m = g;
  m.V = V;
  const HexQuality q1 = hex_quality(m, nullptr);
  CHECK(st.lbfgs_iterations > 0);
  CHECK(q1.inverted == 0);
  CHECK(q1.sj_min > q0.sj_min + 0.15);
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (on_surface[size_t(i)]) CHECK(tree.distance(V.row(i).transpose()) < 1e-9);
  // an inverted hex in the region: nothing moves
  RowMatrixX3d W = g.V;
  W(v, 2) = 1.5;  // pushed through the hexes above it
  HexMesh bad = g;
  bad.V = W;
  REQUIRE(hex_quality(bad, nullptr).inverted > 0);
  GlobalUntangleStats st2;
  std::vector<char> off_surface(size_t(g.V.rows()), 0);
  smooth_region(W, g.H, off_surface, fixed, tree, normals, seeds, {}, &st2);
  CHECK(st2.lbfgs_iterations == 0);
  CHECK(W == bad.V);
}

TEST_CASE("soft scaled Jacobian: 1 - log(9)/40 on a cube, at most log(9)/40 under the true one, exact gradient",
          "[quality-opt]") {
  HexMesh g = test::grid_hex_mesh(1, 1, 1, 2.0);
  auto p = hex_corners(g, 0);
  Eigen::Matrix<double, 8, 3> G;
  const double slack = std::log(9.0) / 40.0;
  CHECK(hex_soft_scaled_jacobian(p, &G) == Approx(1.0 - slack).epsilon(1e-12));
  CHECK(G.norm() < 1e-12);  // every scaled Jacobian is at its maximum
  // sheared and squeezed: one corner far below the others
  p[6] += Eigen::Vector3d(0.7, -0.4, -0.9);
  p[1] += Eigen::Vector3d(0.2, 0.3, 0.1);
  const double sj = hex_scaled_jacobian(p).sj;
  REQUIRE(sj > 0.1);
  REQUIRE(sj < 0.9);
  const double soft = hex_soft_scaled_jacobian(p, &G);
  CHECK(soft <= sj + 1e-12);
  CHECK(soft >= sj - slack - 1e-12);
  for (int k = 0; k < 8; ++k)
    for (int a = 0; a < 3; ++a) {
      auto q = p;
      const double d = 1e-6;
      q[size_t(k)][a] += d;
      const double sp = hex_soft_scaled_jacobian(q);
      q[size_t(k)][a] -= 2 * d;
      const double sm = hex_soft_scaled_jacobian(q);
      CHECK(G(k, a) == Approx((sp - sm) / (2 * d)).margin(1e-6));
    }
}

TEST_CASE("raise_average lifts the average of a swirled grid, keeps fixed vertices, inverts nothing; declines a fold",
          "[quality-opt]") {
  // a 6x6x6 grid whose interior is swirled about the z axis (a smooth, low-frequency distortion that
  // one-vertex sweeps undo slowly); its boundary is fixed
  FixedBoundaryGrid b(6);
  const int n = b.n;
  HexMesh& g = b.g;
  const TriangleTree& tree = b.tree;
  const std::vector<Eigen::Vector3d>& normals = b.normals;
  const std::vector<char>&on_surface = b.on_surface, &fixed = b.fixed;
  for (Eigen::Index v = 0; v < g.V.rows(); ++v) {
    const Eigen::RowVector3d x = g.V.row(v);
    if (fixed[size_t(v)]) continue;
    const double cx = x[0] - n / 2.0, cy = x[1] - n / 2.0;
    const double t = 0.25 * std::sin(M_PI * x[2] / n);  // radians, largest mid-height
    g.V(v, 0) = n / 2.0 + std::cos(t) * cx - std::sin(t) * cy;
    g.V(v, 1) = n / 2.0 + std::sin(t) * cx + std::cos(t) * cy;
  }
  const HexQuality q0 = hex_quality(g, nullptr);
  REQUIRE(q0.inverted == 0);
  REQUIRE(q0.sj_avg < 0.95);
  std::vector<char> seeds(size_t(g.H.rows()), 1);
  RowMatrixX3d V = g.V;
  GlobalUntangleParams p;
  p.rings = 0;
  p.polish_iterations = 300;
  GlobalUntangleStats st;
  REQUIRE(raise_average(V, g.H, on_surface, fixed, tree, normals, seeds, {0.01, 0.0}, p, &st));
  HexMesh m = g;
  m.V = V;
  const HexQuality q1 = hex_quality(m, nullptr);
  CHECK(st.lbfgs_iterations > 0);
  CHECK(q1.inverted == 0);
  CHECK(q1.sj_avg > q0.sj_avg + 0.02);
  CHECK(q1.sj_min > q0.sj_min - std::log(9.0) / 40.0);  // the floor holds the soft minimum
  for (Eigen::Index v = 0; v < V.rows(); ++v)
    if (fixed[size_t(v)]) CHECK(V.row(v) == g.V.row(v));
  // a tolerance no 25 iterations can meet stops it at the first check
  RowMatrixX3d W = g.V;
  GlobalUntangleStats st1;
  REQUIRE(raise_average(W, g.H, on_surface, fixed, tree, normals, seeds, {0.01, 1e6}, p, &st1));
  CHECK(st1.lbfgs_iterations == 25);
  // an inverted hex in the region: nothing moves
  RowMatrixX3d F = g.V;
  const Eigen::Index c = 3 * 49 + 3 * 7 + 3;  // the vertex at (3, 3, 3) of the 7x7x7 vertex grid
  REQUIRE((g.V.row(c) - Eigen::RowVector3d(3, 3, 3)).norm() < 1e-9);
  F(c, 0) += 1.6;
  HexMesh folded = g;
  folded.V = F;
  REQUIRE(hex_quality(folded, nullptr).inverted > 0);
  GlobalUntangleStats st2;
  CHECK_FALSE(raise_average(F, g.H, on_surface, fixed, tree, normals, seeds, {0.01, 0.0}, p, &st2));
  CHECK(F == folded.V);
}

TEST_CASE("raise_minimum lifts the worst hex of a grid with a squeezed vertex, keeps fixed vertices; declines a fold",
          "[quality-opt]") {
  // a 5x5x5 grid, its boundary fixed; the interior vertex at (2, 2, 2) pushed towards (3, 3, 2)
  FixedBoundaryGrid b(5);
  HexMesh& g = b.g;
  const TriangleTree& tree = b.tree;
  const std::vector<Eigen::Vector3d>& normals = b.normals;
  const std::vector<char>&on_surface = b.on_surface, &fixed = b.fixed;
  const Eigen::Index c = 2 * 36 + 2 * 6 + 2;  // (2, 2, 2) in the 6x6x6 vertex grid
  REQUIRE((g.V.row(c) - Eigen::RowVector3d(2, 2, 2)).norm() < 1e-12);
  g.V.row(c) += Eigen::RowVector3d(0.45, 0.45, 0.0);
  const HexQuality q0 = hex_quality(g, nullptr);
  REQUIRE(q0.inverted == 0);
  REQUIRE(q0.sj_min < 0.5);
  const std::vector<char> seeds = hexes_near_minimum(g, q0.sj_min + 0.1);
  const GlobalUntangleParams p = one_ring_ascent();
  RowMatrixX3d V = g.V;
  GlobalUntangleStats st;
  REQUIRE(raise_minimum(V, g.H, on_surface, fixed, tree, normals, seeds, {}, p, &st));
  HexMesh m = g;
  m.V = V;
  const HexQuality q1 = hex_quality(m, nullptr);
  CHECK(st.lbfgs_iterations > 0);
  CHECK(q1.inverted == 0);
  CHECK(q1.sj_min > 0.95);  // the grid's own position is the optimum: every hex a cube
  for (Eigen::Index v = 0; v < V.rows(); ++v)
    if (fixed[size_t(v)]) CHECK(V.row(v) == g.V.row(v));
  // an inverted hex in the region: nothing moves
  RowMatrixX3d F = g.V;
  F(c, 0) += 1.6;
  HexMesh folded = g;
  folded.V = F;
  REQUIRE(hex_quality(folded, nullptr).inverted > 0);
  CHECK_FALSE(raise_minimum(F, g.H, on_surface, fixed, tree, normals, seeds, {}, p));
  CHECK(F == folded.V);
}

TEST_CASE("raise_minimum moves a surface vertex given a direction along it only, and on the surface", "[quality-opt]") {
  // a 5x5x5 grid, its boundary fixed but for the inner vertices of the bottom face, which stay on the surface;
  // the bottom vertex at (2, 2, 0) pushed to (2.45, 2.45, 0)
  FixedBoundaryGrid b(5);
  HexMesh& g = b.g;
  std::vector<char> on_surface = b.on_surface, fixed = b.fixed;
  for (Eigen::Index v = 0; v < g.V.rows(); ++v) {
    const Eigen::RowVector3d x = g.V.row(v);
    if (std::abs(x.z()) < 1e-12 && x.x() > 1e-12 && x.x() < 5 - 1e-12 && x.y() > 1e-12 && x.y() < 5 - 1e-12)
      on_surface[size_t(v)] = 1, fixed[size_t(v)] = 0;
  }
  const Eigen::Index c = 2 * 6 + 2;  // (2, 2, 0) in the 6x6x6 vertex grid
  REQUIRE((g.V.row(c) - Eigen::RowVector3d(2, 2, 0)).norm() < 1e-12);
  g.V.row(c) += Eigen::RowVector3d(0.45, 0.45, 0.0);
  const HexQuality q0 = hex_quality(g, nullptr);
  REQUIRE(q0.inverted == 0);
  const std::vector<char> seeds = hexes_near_minimum(g, q0.sj_min + 0.1);
  const GlobalUntangleParams p = one_ring_ascent();
  // with no direction the vertex goes back towards (2, 2, 0) in both tangent coordinates
  RowMatrixX3d free_v = g.V;
  REQUIRE(raise_minimum(free_v, g.H, on_surface, fixed, b.tree, b.normals, seeds, {}, p));
  CHECK(std::abs(free_v(c, 0) - 2) < 0.1);
  CHECK(std::abs(free_v(c, 1) - 2) < 0.1);
  CHECK(std::abs(free_v(c, 2)) < 1e-12);
  // along x: only x moves (back towards 2), y and z stay
  std::vector<Eigen::Vector3d> along(size_t(g.V.rows()), Eigen::Vector3d::Zero());
  along[size_t(c)] = Eigen::Vector3d(2, 0, 0);  // any length
  RowMatrixX3d slid = g.V;
  REQUIRE(raise_minimum(slid, g.H, on_surface, fixed, b.tree, b.normals, seeds, {}, p, nullptr, along));
  CHECK(slid(c, 0) < 2.45 - 0.2);
  CHECK(std::abs(slid(c, 1) - 2.45) < 1e-12);
  CHECK(std::abs(slid(c, 2)) < 1e-12);
  HexMesh m = g;
  m.V = slid;
  const HexQuality q1 = hex_quality(m, nullptr);
  CHECK(q1.inverted == 0);
  CHECK(q1.sj_min > q0.sj_min);
  // the other free bottom vertices (no direction) moved in the plane, and fixed ones not at all
  for (Eigen::Index v = 0; v < g.V.rows(); ++v) {
    if (fixed[size_t(v)]) CHECK(slid.row(v) == g.V.row(v));
    if (on_surface[size_t(v)]) CHECK(std::abs(slid(v, 2)) < 1e-12);
  }
}

TEST_CASE(
    "fast_cbrt: within 4 ulps of std::cbrt on normal positives, std::cbrt's answer elsewhere; the Winslow "
    "term agrees either way",
    "[quality-opt]") {
  using optimize_detail::fast_cbrt;
  // 25 decades, 2000 points per decade, irregular mantissas
  double worst = 0;
  for (int e = -12; e < 13; ++e)
    for (int k = 0; k < 2000; ++k) {
      const double t = 0.7548776662466927 * k;
      const double x = (1.0 + 9.0 * (t - std::floor(t))) * std::pow(10.0, e);
      const double a = std::cbrt(x), b = fast_cbrt(x);
      worst = std::max(worst, std::abs(a - b) / a);
    }
  CHECK(worst <= 4 * std::numeric_limits<double>::epsilon());
  CHECK(fast_cbrt(27.0) == Approx(3.0).epsilon(1e-15));
  CHECK(fast_cbrt(0.0) == 0.0);
  CHECK(fast_cbrt(-8.0) == -2.0);
  const double sub = std::numeric_limits<double>::denorm_min() * 1000;
  CHECK(fast_cbrt(sub) == std::cbrt(sub));
  CHECK(std::isinf(fast_cbrt(std::numeric_limits<double>::infinity())));
  CHECK(std::isnan(fast_cbrt(std::numeric_limits<double>::quiet_NaN())));
  // the energy term with either root: same value and gradient to rounding, also for an inverted J
  for (double d : {0.7, -0.3}) {
    Eigen::Matrix3d J;
    J << 1.1, 0.2, -0.1, 0.05, 0.9, 0.3, 0.0, -0.2, d;
    Eigen::Matrix3d ga, gb;
    const double a = optimize_detail::winslow_term(J, 0.05, &ga),
                 b = optimize_detail::winslow_term(J, 0.05, &gb, optimize_detail::CubeRoot::fast);
    CHECK(b == Approx(a).epsilon(1e-14));
    CHECK((ga - gb).norm() <= 1e-13 * ga.norm());
  }
}
