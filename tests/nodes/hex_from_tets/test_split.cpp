#include "graph/node.h"
#include "nodes/algorithms/hex_quality.h"
#include "nodes/hex_from_tets/split.h"
#include "tests/helpers/hex_fixtures.h"

#include <catch2/catch.hpp>

#include <array>
#include <set>

using namespace polyhex;
using namespace polyhex::test;

namespace {

TetMesh one_tet() {
  TetMesh t;
  t.V.resize(4, 3);
  t.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  t.T.resize(1, 4);
  t.T << 0, 1, 2, 3;
  t.source = "tet";
  return t;
}

double tet_volume(const TetMesh& t) {
  double v = 0;
  for (Eigen::Index i = 0; i < t.T.rows(); ++i) {
    const Eigen::Vector3d a = t.V.row(t.T(i, 0));
    v += (t.V.row(t.T(i, 1)).transpose() - a)
             .cross(t.V.row(t.T(i, 2)).transpose() - a)
             .dot(t.V.row(t.T(i, 3)).transpose() - a);
  }
  return v / 6;
}

// Distinct edges and faces of a tet mesh, counted independently of the split.
std::pair<size_t, size_t> edges_and_faces(const TetMesh& t) {
  std::set<std::array<int, 2>> e;
  std::set<std::array<int, 3>> f;
  for (Eigen::Index i = 0; i < t.T.rows(); ++i)
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) {
        e.insert({std::min(t.T(i, a), t.T(i, b)), std::max(t.T(i, a), t.T(i, b))});
        for (int c = b + 1; c < 4; ++c) {
          std::array<int, 3> k{t.T(i, a), t.T(i, b), t.T(i, c)};
          std::sort(k.begin(), k.end());
          f.insert(k);
        }
      }
  return {e.size(), f.size()};
}

void check_valid_conforming(const HexMesh& h, double volume) {
  const HexQuality q = hex_quality(h, nullptr, {});
  CHECK(q.inverted == 0);
  CHECK(q.sj_corner_min > 0);
  CHECK(q.sj_min > 0);
  CHECK(q.volume == Approx(volume).epsilon(1e-12));
  CHECK(q.faces_shared_by_more_than_two == 0);
  CHECK(q.nonmanifold_boundary_edges == 0);
  CHECK(q.unused_vertices == 0);
}

}  // namespace

TEST_CASE("split: one tet gives 4 valid hexes and 15 vertices", "[split]") {
  const TetMesh t = one_tet();
  const HexMesh h = split_tets_to_hexes(t);
  CHECK(h.H.rows() == 4);
  CHECK(h.V.rows() == 15);  // 4 corners + 6 edge midpoints + 4 face centres + 1 centroid
  CHECK(h.source == "tet");
  check_valid_conforming(h, 1.0 / 6);
  const HexQuality q = hex_quality(h, nullptr, {});
  CHECK(q.boundary_quads == 12);  // each tet face is covered by 3 quads
  CHECK(q.volume == Approx(1.0 / 6).epsilon(1e-15));
  // Hex c starts at tet corner c and has the centroid at position 6.
  for (int c = 0; c < 4; ++c) {
    CHECK(h.H(c, 0) == c);
    CHECK(h.V.row(h.H(c, 6)).isApprox(Eigen::RowVector3d(0.25, 0.25, 0.25)));
  }
  // The boundary of the split is the tet's boundary: distance 0 to it.
  SurfaceMesh s;
  s.V = t.V;
  s.F.resize(4, 3);
  s.F << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
  QualityParams p;
  p.samples = 5000;
  const HexQuality qs = hex_quality(h, &s, p);
  CHECK(qs.hausdorff_max < 1e-12);
  CHECK(qs.volume_ratio == Approx(1.0).epsilon(1e-14));
}

TEST_CASE("split: a structured box gives 4 hexes per tet, conforming, volume preserved", "[split]") {
  const TetMesh t = box_tet_mesh(4, 3, 2);
  REQUIRE(t.T.rows() == 144);
  REQUIRE(tet_volume(t) == Approx(24.0));
  const HexMesh h = split_tets_to_hexes(t);
  CHECK(h.H.rows() == 4 * 144);
  const auto [ne, nf] = edges_and_faces(t);
  CHECK(size_t(h.V.rows()) == size_t(t.V.rows()) + ne + nf + size_t(t.T.rows()));
  check_valid_conforming(h, 24.0);
  // 52 boundary squares, 2 triangles each, 3 quads per triangle
  CHECK(hex_quality(h, nullptr, {}).boundary_quads == 3 * 2 * 52);
}

TEST_CASE("split: a perturbed box keeps valid hexes and the exact volume", "[split]") {
  TetMesh t = box_tet_mesh(5, 5, 5, 0.2);
  perturb(t.V, 0.03, 11);
  const HexMesh h = split_tets_to_hexes(t);
  CHECK(h.H.rows() == 4 * t.T.rows());
  check_valid_conforming(h, tet_volume(t));
}

TEST_CASE("split: invalid tet meshes are rejected with the reason", "[split]") {
  TetMesh t = one_tet();
  SECTION("inverted tet") {
    t.T << 0, 2, 1, 3;
    CHECK_THROWS_MATCHES(split_tets_to_hexes(t), InvalidInput,
                         Catch::Message("tet: tet 0 is inverted (6 x volume = -1.000000)"));
  }
  SECTION("degenerate tet") {
    t.V.row(3) << 1, 1, 0;
    CHECK_THROWS_MATCHES(split_tets_to_hexes(t), InvalidInput,
                         Catch::Message("tet: tet 0 is degenerate (6 x volume = 0.000000)"));
  }
  SECTION("index out of range") {
    t.T(0, 2) = -1;
    CHECK_THROWS_MATCHES(split_tets_to_hexes(t), InvalidInput,
                         Catch::Message("tet: tet 0: vertex index -1 out of range (4 vertices)"));
  }
  SECTION("no tets") {
    t.T.resize(0, 4);
    CHECK_THROWS_MATCHES(split_tets_to_hexes(t), InvalidInput, Catch::Message("tet: no tetrahedra"));
  }
  SECTION("infinite coordinate") {
    t.V(2, 0) = INFINITY;
    CHECK_THROWS_MATCHES(split_tets_to_hexes(t), InvalidInput,
                         Catch::Message("tet: vertex 2 has a non-finite coordinate"));
  }
}

TEST_CASE("split node: hex_from_tets/split is the baseline, TetMesh in, HexMesh out", "[split]") {
  const NodeSpec* spec = Registry::instance().find("hex_from_tets/split");
  REQUIRE(spec != nullptr);
  CHECK(spec->output == "HexMesh");
  REQUIRE(spec->inputs.size() == 1);
  CHECK(spec->inputs[0].name == "tets");
  CHECK(spec->inputs[0].artefact_type == "TetMesh");
  CHECK(spec->doc.find("BASELINE") != std::string::npos);
  CHECK(spec->params.empty());
  CHECK_THROWS_AS(spec->check_params(json{{"levels", 2}}, "split"), ConfigError);

  NodeContext ctx;
  Inputs in;
  in.items = {make_artefact(box_tet_mesh(2, 2, 2))};
  const Artefact out = spec->run(json::object(), in, ctx);
  REQUIRE(out.type == "HexMesh");
  CHECK(out.as<HexMesh>()->H.rows() == 4 * 48);
  CHECK(ctx.metrics["hexes"] == 4 * 48);
  CHECK(ctx.metrics["vertices"] == out.as<HexMesh>()->V.rows());
}
