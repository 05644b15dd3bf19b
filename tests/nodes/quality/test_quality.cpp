#include "graph/node.h"
#include "nodes/algorithms/hex_quality.h"
#include "nodes/algorithms/triangle_tree.h"
#include "nodes/artefacts/hex_topology.h"
#include "nodes/quality/quality_json.h"
#include "tests/helpers/eigen_orders.h"
#include "tests/helpers/hex_fixtures.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <map>
#include <random>
#include <set>

using namespace polyhex;
using namespace polyhex::test;
using Catch::Matchers::Contains;

namespace {

// The unit cube's corners in VTK_HEXAHEDRON order.
RowMatrixX3d cube_corners() {
  RowMatrixX3d P(8, 3);
  P << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1;
  return P;
}

HexQuality measure(const HexMesh& m, const SurfaceMesh* s = nullptr, int samples = 20000) {
  QualityParams p;
  p.samples = samples;
  return hex_quality(m, s, p);
}

}  // namespace

TEST_CASE("quality: a unit cube hex is perfect but all its vertices are irregular", "[quality]") {
  const HexQuality q = measure(unit_cube_hex());
  CHECK(q.hexes == 1);
  CHECK(q.vertices == 8);
  CHECK(q.inverted == 0);
  CHECK(q.sj_min == 1.0);
  CHECK(q.sj_avg == 1.0);
  CHECK(q.sj_corner_min == 1.0);
  CHECK(q.sj_below_0_2 == 0);
  CHECK(q.volume == Approx(1.0).epsilon(1e-15));
  // hexcheck: a boundary vertex is irregular unless it has 4 boundary quads; a cube corner has 3.
  CHECK(q.irregular_pct == 100.0);
  CHECK(q.irregular_boundary_pct == 100.0);
  CHECK(q.irregular_interior_pct == 0.0);  // no interior vertex: 0 / max(0, 1)
  CHECK(q.boundary_quads == 6);
  CHECK(q.nonmanifold_boundary_edges == 0);
  CHECK(q.faces_shared_by_more_than_two == 0);
  CHECK(q.unused_vertices == 0);
  CHECK_FALSE(q.has_surface);
  REQUIRE(q.sj.size() == 1);
  CHECK(q.sj[0] == 1.0);
}

TEST_CASE("quality: a 3x3x3 grid has regular interior vertices, only its 8 corners are irregular", "[quality]") {
  const HexQuality q = measure(grid_hex_mesh(3, 3, 3));
  CHECK(q.hexes == 27);
  CHECK(q.vertices == 64);
  CHECK(q.sj_min == 1.0);
  CHECK(q.sj_avg == 1.0);
  CHECK(q.volume == Approx(27.0).epsilon(1e-14));
  CHECK(q.irregular_interior_pct == 0.0);
  CHECK(q.irregular_boundary_pct == Approx(100.0 * 8 / 56));
  CHECK(q.irregular_pct == Approx(12.5));
  CHECK(q.boundary_quads == 54);
  CHECK(q.nonmanifold_boundary_edges == 0);
  // The boundary quads face outward: their triangles enclose a positive volume of 27.
  const SurfaceMesh b = boundary_surface(grid_hex_mesh(3, 3, 3));
  double vol6 = 0;
  for (Eigen::Index f = 0; f < b.F.rows(); ++f)
    vol6 += b.V.row(b.F(f, 0)).dot(b.V.row(b.F(f, 1)).cross(b.V.row(b.F(f, 2))));
  CHECK(vol6 / 6 == Approx(27.0));
}

TEST_CASE("quality: irregular_vertices flags exactly what irregular_pct counts", "[quality]") {
  const HexMesh g = grid_hex_mesh(3, 3, 3);
  const std::vector<char> irr = irregular_vertices(g);
  REQUIRE(irr.size() == 64);
  // The 8 corners of the block (3 boundary quads each) and nothing else.
  std::set<int> flagged;
  for (int v = 0; v < 64; ++v)
    if (irr[size_t(v)]) flagged.insert(v);
  CHECK(flagged == std::set<int>{0, 3, 12, 15, 48, 51, 60, 63});
  // An unused vertex is not irregular; the share stays that of irregular_pct.
  HexMesh u = g;
  u.V.conservativeResize(65, 3);
  u.V.row(64) << 9, 9, 9;
  const std::vector<char> irr_u = irregular_vertices(u);
  CHECK(irr_u[64] == 0);
  CHECK(100.0 * double(std::count(irr_u.begin(), irr_u.end(), 1)) / 64 == Approx(measure(u).irregular_pct));
}

TEST_CASE("quality: the edge ratio of a hex is its longest edge over its shortest", "[quality]") {
  CHECK(hex_edge_ratios(unit_cube_hex())[0] == 1.0);
  RowMatrixX3d P = cube_corners();
  P.col(0) *= 3.0;  // a 3 x 1 x 1 box
  CHECK(hex_edge_ratios(one_hex(P))[0] == Approx(3.0).epsilon(1e-15));
  P.bottomRows(4).col(0).array() += 4.0;  // the top slides by 4: slanted edges of length sqrt(17)
  CHECK(hex_edge_ratios(one_hex(P))[0] == Approx(std::sqrt(17.0)).epsilon(1e-15));
  RowMatrixX3d D = cube_corners();
  D.row(1) = D.row(0);  // edge 0-1 collapsed
  CHECK(std::isinf(hex_edge_ratios(one_hex(D))[0]));
  const Eigen::VectorXd g = hex_edge_ratios(grid_hex_mesh(2, 3, 4, 0.5));
  CHECK(g.size() == 24);
  CHECK(g.maxCoeff() == Approx(1.0));
}

TEST_CASE("quality: a sheared hex has scaled Jacobian 1/sqrt(1+t^2)", "[quality]") {
  for (double t : {0.5, 1.0, 3.0}) {
    RowMatrixX3d P = cube_corners();
    P.bottomRows(4).col(0).array() += t;  // top face slides by t along x
    const HexQuality q = measure(one_hex(P));
    CHECK(q.sj_min == Approx(1.0 / std::sqrt(1 + t * t)).epsilon(1e-14));
    CHECK(q.sj_corner_min == Approx(1.0 / std::sqrt(1 + t * t)).epsilon(1e-14));
    CHECK(q.volume == Approx(1.0).epsilon(1e-14));  // shear keeps the volume
    CHECK(q.inverted == 0);
    CHECK(q.sj_below_0_2 == 0);
  }
  // t = 5: sj = 1/sqrt(26) < 0.2
  RowMatrixX3d P = cube_corners();
  P.bottomRows(4).col(0).array() += 5.0;
  CHECK(measure(one_hex(P)).sj_below_0_2 == 1);
}

TEST_CASE("quality: the centre term counts when it is the minimum", "[quality]") {
  // A distorted hex whose centre (principal axes) term is below every corner; values from hexcheck.py.
  RowMatrixX3d P(8, 3);
  P << -0.8, 0.1, 0.8, 1.2, 0.4, -0.5, 1.4, 0.7, 0.8, -0.6, 0.2, 0.5, -0.5, 0.7, 1.7, 0.4, 0.1, 0.4, 1.5, 0.7, 0.9,
      -0.4, 0.7, 1.6;
  std::array<Eigen::Vector3d, 8> p;
  for (int k = 0; k < 8; ++k) p[k] = P.row(k).transpose();
  const HexSJ s = hex_scaled_jacobian(p);
  CHECK(s.sj == Approx(0.1348323878859992).epsilon(1e-12));
  CHECK(s.corner_min == Approx(0.17107978455366013).epsilon(1e-12));
  const Eigen::Vector3d xi = (p[1] + p[2] + p[5] + p[6]) - (p[0] + p[3] + p[4] + p[7]);
  const Eigen::Vector3d eta = (p[2] + p[3] + p[6] + p[7]) - (p[0] + p[1] + p[4] + p[5]);
  const Eigen::Vector3d zeta = (p[4] + p[5] + p[6] + p[7]) - (p[0] + p[1] + p[2] + p[3]);
  CHECK(s.sj == Approx(xi.dot(eta.cross(zeta)) / (xi.norm() * eta.norm() * zeta.norm())).epsilon(1e-14));
  const HexQuality q = measure(one_hex(P));
  CHECK(q.sj_min == s.sj);
  CHECK(q.sj_corner_min == s.corner_min);
  CHECK(q.sj_below_0_2 == 1);
  CHECK(q.inverted == 0);
}

namespace {

/// hex_quality.cpp's scaled Jacobian of three vectors as Eigen expressions (as of 6c8d84e): the reference
/// for scaled_of's bits.
double eigen_scaled(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const double det = a.dot(b.cross(c));
  const double len2 = a.squaredNorm() * b.squaredNorm() * c.squaredNorm();
  const double len = len2 > 1e-290 && len2 < 1e290 ? std::sqrt(len2) : a.norm() * b.norm() * c.norm();
  const double s = len > 1e-300 ? det / len : 0.0;
  return std::clamp(s, -1.0, 1.0);
}

}  // namespace

TEST_CASE("quality: the 9 scaled Jacobian terms, four corners at a time in lanes, have the Eigen expressions' bits",
          "[quality]") {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> jitter(-0.6, 0.6);
  const RowMatrixX3d P = cube_corners();
  long differ = 0, clamped_or_zero = 0, inverted = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    // moved, folded, collapsed (a zero edge), and scaled to where the squared lengths' product under- or
    // overflows (the product of the norms then)
    const double scale = trial % 5 == 3 ? 1e-120 : trial % 5 == 4 ? 1e100 : 1.0;
    std::array<Eigen::Vector3d, 8> p;
    for (int k = 0; k < 8; ++k)
      p[size_t(k)] = scale * (P.row(k).transpose() + Eigen::Vector3d(jitter(rng), jitter(rng), jitter(rng)));
    if (trial % 7 == 0) p[1] = p[0];
    std::array<double, 9> terms;
    hex_scaled_jacobian(p, terms);
    for (size_t k = 0; k < 8; ++k) {
      const auto& c = hex_topology::kCorners[k];
      const double ref = eigen_scaled(p[size_t(c[1])] - p[size_t(c[0])], p[size_t(c[2])] - p[size_t(c[0])],
                                      p[size_t(c[3])] - p[size_t(c[0])]);
      differ += std::memcmp(&ref, &terms[k], sizeof ref) != 0;
      clamped_or_zero += ref == 0.0 || std::abs(ref) == 1.0;
      inverted += ref < 0;
    }
    const Eigen::Vector3d xi = (p[1] + p[2] + p[5] + p[6]) - (p[0] + p[3] + p[4] + p[7]);
    const Eigen::Vector3d eta = (p[2] + p[3] + p[6] + p[7]) - (p[0] + p[1] + p[4] + p[5]);
    const Eigen::Vector3d zeta = (p[4] + p[5] + p[6] + p[7]) - (p[0] + p[1] + p[2] + p[3]);
    const double ref = eigen_scaled(xi, eta, zeta);
    differ += std::memcmp(&ref, &terms[8], sizeof ref) != 0;
  }
  CHECK(clamped_or_zero > 1000);
  CHECK(inverted > 1000);
  if (test::kEigenOrders)
    CHECK(differ == 0);
  else
    WARN("not an SSE2-only x86-64 build: Eigen's summation orders differ, their bits not compared");
}

TEST_CASE("quality: the scaled Jacobian after one corner moved equals the full evaluation bit for bit", "[quality]") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.35, 0.35);
  const RowMatrixX3d P = cube_corners();
  int copied_total = 0;
  for (int trial = 0; trial < 200; ++trial) {
    std::array<Eigen::Vector3d, 8> p;
    for (int k = 0; k < 8; ++k) p[k] = P.row(k).transpose() + Eigen::Vector3d(jitter(rng), jitter(rng), jitter(rng));
    std::array<double, 9> before, full, moved;
    hex_scaled_jacobian(p, before);
    const int j = trial % 8;
    p[size_t(j)] += Eigen::Vector3d(jitter(rng), jitter(rng), jitter(rng));  // may invert corners
    const HexSJ a = hex_scaled_jacobian(p, full);
    const HexSJ b = hex_scaled_jacobian_moved(p, j, before, moved);
    CHECK(a.sj == b.sj);
    CHECK(a.corner_min == b.corner_min);
    CHECK(full == moved);
    // the 4 terms that do not involve corner j are taken from `before`: marked ones come back marked
    std::array<double, 9> marked;
    marked.fill(42.0);
    hex_scaled_jacobian_moved(p, j, marked, moved);
    int copied = 0;
    for (size_t k = 0; k < 9; ++k) copied += moved[k] == 42.0;
    CHECK(copied == 4);
    copied_total += copied;
  }
  CHECK(copied_total == 800);
}

TEST_CASE("quality: inverted hexes are counted and reported, not rejected", "[quality]") {
  SECTION("top and bottom swapped: every corner is -1") {
    RowMatrixX3d P = cube_corners();
    RowMatrixX3d Q(8, 3);
    Q.topRows(4) = P.bottomRows(4);
    Q.bottomRows(4) = P.topRows(4);
    const HexQuality q = measure(one_hex(Q));
    CHECK(q.inverted == 1);
    CHECK(q.sj_min == -1.0);
    CHECK(q.sj_corner_min == -1.0);
    CHECK(q.volume == Approx(-1.0));
    CHECK(q.sj_below_0_2 == 1);
  }
  SECTION("one corner pushed through the opposite one") {
    RowMatrixX3d P = cube_corners();
    P.row(6) << 0.3, 0.3, 0.3;
    const HexQuality q = measure(one_hex(P));
    CHECK(q.inverted == 1);
    CHECK(q.sj_corner_min < 0);
    CHECK(q.sj_min <= q.sj_corner_min);
  }
  SECTION("one inverted hex among good ones") {
    HexMesh g = grid_hex_mesh(3, 3, 3);
    g.V.row(21) << 2.2, 2.2, 2.2;  // interior vertex (1,1,1) pushed past (2,2,2)
    const HexQuality q = measure(g);
    CHECK(q.inverted >= 1);
    CHECK(q.inverted < 27);
    CHECK(q.sj_corner_min < 0);
  }
}

TEST_CASE("quality: a degenerate hex has scaled Jacobian 0, never 1", "[quality]") {
  SECTION("collapsed edge") {
    RowMatrixX3d P = cube_corners();
    P.row(1) = P.row(0);
    const HexQuality q = measure(one_hex(P));
    CHECK(q.sj_min == 0.0);
    CHECK(q.sj_corner_min == 0.0);
    CHECK(q.inverted == 1);  // corner min <= 0
  }
  SECTION("all corners at one point") {
    RowMatrixX3d P = RowMatrixX3d::Constant(8, 3, 0.5);
    std::array<Eigen::Vector3d, 8> p;
    for (auto& x : p) x = Eigen::Vector3d::Constant(0.5);
    const HexSJ s = hex_scaled_jacobian(p);
    CHECK(s.sj == 0.0);
    CHECK(s.corner_min == 0.0);
    CHECK(measure(one_hex(P)).sj_avg == 0.0);
  }
  SECTION("flattened hex (zero height)") {
    RowMatrixX3d P = cube_corners();
    P.bottomRows(4).col(2).setZero();
    const HexQuality q = measure(one_hex(P));
    CHECK(q.sj_min == 0.0);
    CHECK(q.volume == 0.0);
  }
}

TEST_CASE("quality: topology counts on a broken mesh", "[quality]") {
  HexMesh m = grid_hex_mesh(2, 1, 1);
  // add an unused vertex and the first hex twice more: its faces are then used 3 or 4 times
  m.V.conservativeResize(m.V.rows() + 1, 3);
  m.V.row(m.V.rows() - 1) << 10, 10, 10;
  m.H.conservativeResize(4, 8);
  m.H.row(2) = m.H.row(0);
  m.H.row(3) = m.H.row(0);
  const HexQuality q = measure(m);
  CHECK(q.unused_vertices == 1);
  CHECK(q.vertices == 13);
  CHECK(q.faces_shared_by_more_than_two == 6);  // all 6 faces of hex 0 (the shared one is used 4 times)
  CHECK(q.boundary_quads == 5);                 // the faces of hex 1 but the shared one
  CHECK(q.nonmanifold_boundary_edges == 4);     // the rim of the open box
}

TEST_CASE("quality: Hausdorff of a grid against its own boundary is 0, volume ratio 1", "[quality]") {
  const HexMesh g = grid_hex_mesh(3, 3, 3);
  const SurfaceMesh s = boundary_surface(g);
  const HexQuality q = measure(g, &s);
  REQUIRE(q.has_surface);
  CHECK(q.bbox_diag == Approx(3 * std::sqrt(3.0)));
  CHECK(q.hausdorff_max < 1e-12);
  CHECK(q.hausdorff_mean < 1e-12);
  CHECK(q.volume_ratio == Approx(1.0).epsilon(1e-14));
  const json j = to_json(q);
  CHECK(j.at("hausdorff_max").get<double>() == q.hausdorff_max);
  CHECK(j.size() == 20);
}

TEST_CASE("quality: Hausdorff against a shifted surface", "[quality]") {
  const double s = 0.3, diag = 3 * std::sqrt(3.0);
  const HexMesh g = grid_hex_mesh(3, 3, 3);
  SurfaceMesh shifted = boundary_surface(g);
  shifted.V.col(0).array() += s;
  const HexQuality q = measure(g, &shifted, 100000);
  // Max: points on the face x = 0 are exactly s from the shifted face x = s, nothing is farther.
  CHECK(q.hausdorff_max == Approx(s / diag).epsilon(1e-12));
  // Mean (both directions alike): face x=0 contributes s, face x=3 E[min(s, dist to square rim)],
  // the 4 side faces s^2/6 each, over the total area 54.
  const double rim = s - 2 * s * s / 3 + 4 * s * s * s / 27;
  const double mean = (9 * s + 9 * rim + 4 * 9 * s * s / 6) / 54;
  CHECK(q.hausdorff_mean == Approx(mean / diag).epsilon(0.01));
  CHECK(q.volume_ratio == Approx(1.0));
}

TEST_CASE("quality: the figures do not depend on the thread count or the run", "[quality]") {
  HexMesh g = grid_hex_mesh(6, 5, 4);
  perturb(g.V, 0.2, 7);
  SurfaceMesh s = boundary_surface(grid_hex_mesh(6, 5, 4));
  const json a = to_json(measure(g, &s, 5000)), b = to_json(measure(g, &s, 5000));
  CHECK(a == b);
}

TEST_CASE("quality: invalid meshes are rejected with the reason", "[quality]") {
  HexMesh m = unit_cube_hex();
  SECTION("no hexes") {
    m.H.resize(0, 8);
    CHECK_THROWS_MATCHES(measure(m), InvalidInput, Catch::Message("grid: no hexahedra"));
  }
  SECTION("index out of range") {
    m.H(0, 5) = 8;
    CHECK_THROWS_MATCHES(measure(m), InvalidInput,
                         Catch::Message("grid: hex 0: vertex index 8 out of range (8 vertices)"));
  }
  SECTION("NaN coordinate") {
    m.V(3, 1) = std::nan("");
    CHECK_THROWS_MATCHES(measure(m), InvalidInput, Catch::Message("grid: vertex 3 has a non-finite coordinate"));
  }
  SECTION("samples < 1") {
    QualityParams p;
    p.samples = 0;
    CHECK_THROWS_MATCHES(hex_quality(m, nullptr, p), InvalidInput, Catch::Message("quality: samples = 0 must be >= 1"));
  }
  SECTION("surface index out of range") {
    SurfaceMesh s = boundary_surface(m);
    s.source = "cube.obj";
    s.F(2, 1) = 99;
    CHECK_THROWS_MATCHES(measure(m, &s), InvalidInput,
                         Catch::Message("cube.obj: triangle 2: vertex index 99 out of range (8 vertices)"));
  }
  SECTION("surface without triangles") {
    SurfaceMesh s;
    s.V = m.V;
    s.source = "empty.obj";
    CHECK_THROWS_MATCHES(measure(m, &s), InvalidInput, Catch::Message("empty.obj: no triangles"));
  }
  SECTION("flat closed surface: a tetrahedron with its four corners in a plane") {
    SurfaceMesh s;
    s.V.resize(4, 3);
    s.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0;
    s.F.resize(4, 3);
    s.F << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
    s.source = "square.obj";
    CHECK_THROWS_MATCHES(measure(m, &s), InvalidInput, Catch::Message("square.obj: the surface encloses no volume"));
  }
  SECTION("flat open surface: measured one-sided, no volume ratio") {
    SurfaceMesh s;
    s.V.resize(4, 3);
    s.V << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0;
    s.F.resize(2, 3);
    s.F << 0, 1, 2, 0, 2, 3;
    s.source = "square.obj";
    const HexQuality q = measure(m, &s);
    CHECK_FALSE(q.surface_closed);
    CHECK(q.volume_ratio == 0);
  }
}

TEST_CASE("quality: the triangle tree finds the exact closest point", "[quality]") {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  RowMatrixX3d V(300, 3);
  for (Eigen::Index i = 0; i < V.size(); ++i) V.data()[i] = u(rng);
  RowMatrixX3i F(100, 3);
  for (int f = 0; f < 100; ++f) F.row(f) << 3 * f, 3 * f + 1, 3 * f + 2;
  V.row(3 * 7 + 1) = V.row(3 * 7);                             // triangle 7: a zero-length edge
  V.row(3 * 9 + 2) = 0.5 * (V.row(3 * 9) + V.row(3 * 9 + 1));  // triangle 9: collinear corners
  const TriangleTree tree(V, F);
  for (int k = 0; k < 500; ++k) {
    const Eigen::Vector3d p(2 * u(rng), 2 * u(rng), 2 * u(rng));
    double best = INFINITY;
    for (int f = 0; f < 100; ++f)
      best = std::min(best, (closest_point_on_triangle(p, V.row(F(f, 0)), V.row(F(f, 1)), V.row(F(f, 2))) - p).norm());
    const auto hit = tree.closest(p);
    CHECK(std::sqrt(hit.sq_distance) == best);
    CHECK((hit.point - p).norm() == Approx(best));
  }
  // Degenerate triangles: the closest point of a segment.
  const Eigen::Vector3d a(0, 0, 0), b(2, 0, 0);
  CHECK((closest_point_on_triangle(Eigen::Vector3d(1, 1, 0), a, b, Eigen::Vector3d(1, 0, 0)) - Eigen::Vector3d(1, 0, 0))
            .norm() < 1e-15);
  CHECK((closest_point_on_triangle(Eigen::Vector3d(3, 1, 0), a, a, b) - b).norm() < 1e-15);
  CHECK_THROWS_MATCHES(TriangleTree(V, RowMatrixX3i(0, 3)), InvalidInput,
                       Catch::Message("triangle tree: no triangles"));
}

TEST_CASE("quality node: a sink with hexcheck's keys as metrics", "[quality]") {
  const NodeSpec* spec = Registry::instance().find("quality");
  REQUIRE(spec != nullptr);
  CHECK(spec->output.empty());
  REQUIRE(spec->inputs.size() == 2);
  CHECK(spec->inputs[0].name == "mesh");
  CHECK(spec->inputs[0].artefact_type == "HexMesh");
  CHECK_FALSE(spec->inputs[0].optional);
  CHECK(spec->inputs[1].name == "surface");
  CHECK(spec->inputs[1].artefact_type == "SurfaceMesh");
  CHECK(spec->inputs[1].optional);
  CHECK_THROWS_MATCHES(spec->check_params(json{{"samples", 0}}, "q"), ConfigError,
                       Catch::Message("q: param `samples` = 0 is out of range [1.0, 100000000.0]"));

  const HexMesh g = grid_hex_mesh(3, 3, 3);
  SECTION("without a surface") {
    NodeContext ctx;
    ctx.id = "q";
    Inputs in;
    in.items = {make_artefact(HexMesh(g)), Artefact{}};
    const Artefact out = spec->run(spec->check_params(json::object(), "q"), in, ctx);
    CHECK_FALSE(out);
    std::set<std::string> keys;
    for (auto& [k, v] : ctx.metrics.items()) keys.insert(k);
    CHECK(keys == std::set<std::string>{"hexes", "vertices", "inverted", "sj_min", "sj_avg", "sj_corner_min",
                                        "sj_corner_avg", "sj_below_0_2", "volume", "irregular_pct",
                                        "irregular_interior_pct", "irregular_boundary_pct", "unused_vertices",
                                        "faces_shared_by_more_than_two", "nonmanifold_boundary_edges",
                                        "boundary_quads"});
    CHECK(ctx.metrics["hexes"] == 27);
    CHECK(ctx.warnings.empty());
  }
  SECTION("with a surface and an inverted hex") {
    HexMesh bad = g;
    bad.V.row(21) << 2.2, 2.2, 2.2;
    NodeContext ctx;
    Inputs in;
    in.items = {make_artefact(std::move(bad)), make_artefact(boundary_surface(g))};
    spec->run(json{{"samples", 1000}}, in, ctx);
    CHECK(ctx.metrics.contains("hausdorff_max"));
    CHECK(ctx.metrics.contains("volume_ratio"));
    CHECK(ctx.metrics["inverted"].get<long>() >= 1);
    REQUIRE(ctx.warnings.size() == 1);
    CHECK_THAT(ctx.warnings[0], Contains("of 27 hexes are inverted"));
  }
}

// Timing on a mesh of the size the paper produces; hidden ([.]): run it with "[quality-bench]".
TEST_CASE("quality: timing on 100k hexes and a 50k-triangle surface", "[.][quality-bench]") {
  HexMesh g = grid_hex_mesh(46, 46, 48, 1.0 / 46);
  perturb(g.V, 0.1 / 46, 1);
  const SurfaceMesh s = boundary_surface(grid_hex_mesh(65, 65, 65, 48.0 / 46 / 65));
  REQUIRE(g.H.rows() == 101568);
  REQUIRE(s.F.rows() == 50700);
  const auto t0 = std::chrono::steady_clock::now();
  const HexQuality q = measure(g, &s, 100000);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  WARN("hex_quality: " << q.hexes << " hexes, " << s.F.rows()
                       << " surface triangles, 100000 samples per side: " << seconds << " s");
  CHECK(q.inverted == 0);
  CHECK(q.hausdorff_max < 0.05);
}

TEST_CASE("boundary quads: a grid with hexes removed and one hex doubled, against counting each face's copies",
          "[quality]") {
  const HexMesh g = grid_hex_mesh(7, 6, 5);
  std::mt19937 rng(5);
  HexMesh m = g;
  std::vector<int> keep;
  for (Eigen::Index h = 0; h < g.H.rows(); ++h)
    if (rng() % 4 != 0) keep.push_back(int(h));
  keep.push_back(keep[keep.size() / 2]);  // a hex twice: its faces used 2 or 3 times
  m.H.resize(Eigen::Index(keep.size()), 8);
  for (size_t i = 0; i < keep.size(); ++i) m.H.row(Eigen::Index(i)) = g.H.row(keep[i]);
  // brute force: every face's sorted vertices, counted in a map
  std::map<std::array<int, 4>, int> count;
  auto key = [&](Eigen::Index h, int f) {
    std::array<int, 4> k;
    for (int c = 0; c < 4; ++c) k[size_t(c)] = m.H(h, hex_topology::kFaces[f][c]);
    std::sort(k.begin(), k.end());
    return k;
  };
  for (Eigen::Index h = 0; h < m.H.rows(); ++h)
    for (int f = 0; f < 6; ++f) ++count[key(h, f)];
  std::vector<int> hex_of, face_of;
  const auto Q = hex_boundary_quads(m, &hex_of, &face_of);
  std::vector<std::pair<int, int>> expected;
  for (Eigen::Index h = 0; h < m.H.rows(); ++h)
    for (int f = 0; f < 6; ++f)
      if (count[key(h, f)] == 1) expected.emplace_back(int(h), f);
  REQUIRE(size_t(Q.rows()) == expected.size());
  for (size_t i = 0; i < expected.size(); ++i) {
    CHECK(hex_of[i] == expected[i].first);
    CHECK(face_of[i] == expected[i].second);
    for (int c = 0; c < 4; ++c)
      CHECK(Q(Eigen::Index(i), c) == m.H(expected[i].first, hex_topology::kFaces[expected[i].second][c]));
  }
  long over_two = 0;
  for (const auto& [k, n] : count) over_two += n > 2;
  CHECK(over_two > 0);
  CHECK(hex_quality(m, nullptr).faces_shared_by_more_than_two == over_two);
}
