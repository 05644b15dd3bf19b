#include "graph/node.h"
#include "nodes/algorithms/shapes.h"
#include "runtime/errors.h"
#include "tests/helpers/surface_checks.h"

#include <catch2/catch.hpp>

#include <chrono>
#include <cmath>
#include <map>

using namespace polyhex;
using namespace polyhex::test;

namespace {
const std::map<std::string, long> kGenus = {
    {"sphere", 0},        {"torus", 1},         {"bumpy_torus", 1},       {"rod_with_holes", 2},
    {"l_block", 0},       {"bent_pipe", 1},     {"fandisk_like", 0},      {"box", 0},
    {"sharp_l_block", 0}, {"chamfered_box", 0}, {"filleted_cylinder", 0}, {"stepped_ring", 1}};
}

TEST_CASE("shape_names lists every shape once, and each has a known genus", "[shapes]") {
  auto names = shape_names();
  REQUIRE(names.size() == kGenus.size());
  for (auto& n : names) CHECK(kGenus.count(n) == 1);
}

TEST_CASE("every built-in shape is closed, manifold, outward, non-degenerate, with its genus", "[shapes]") {
  for (const auto& name : shape_names()) {
    SECTION(name) {
      ShapeParams p;
      p.name = name;
      auto t0 = std::chrono::steady_clock::now();
      SurfaceMesh m = make_shape(p);
      double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      INFO(name << ": " << m.V.rows() << " vertices, " << m.F.rows() << " triangles, " << seconds << " s");
      auto c = check_surface(m);
      CHECK(m.source == "shapes:" + name);
      CHECK(c.open_edges == 0);
      CHECK(c.nonmanifold_edges == 0);
      CHECK(c.misoriented_edges == 0);
      CHECK(c.nonmanifold_vertices == 0);
      CHECK(c.unused_vertices == 0);
      CHECK(c.degenerate == 0);
      CHECK(c.min_angle_deg > 10.0);  // short dual-contouring edges are collapsed
      CHECK(c.components == 1);
      CHECK(c.genus() == kGenus.at(name));
      CHECK(c.volume > 0);
      CHECK(c.diag > 0.8);
      CHECK(c.diag < 2.5);
      CHECK(m.F.rows() < 30000);
      CHECK(seconds < 2.0);  // < 1 s measured; slack for a loaded shared machine
    }
  }
}

TEST_CASE("CSG shapes keep their topology at a coarse and a fine resolution", "[shapes]") {
  for (int res : {32, 128}) {
    for (const auto& name : {"rod_with_holes", "l_block", "bent_pipe", "fandisk_like"}) {
      ShapeParams p{name, res};
      auto c = check_surface(make_shape(p));
      INFO(name << " at resolution " << res);
      CHECK(c.closed_manifold_oriented());
      CHECK(c.components == 1);
      CHECK(c.genus() == kGenus.at(name));
    }
  }
}

TEST_CASE("sphere, torus and box enclose their analytic volumes", "[shapes]") {
  const double pi = M_PI;
  CHECK(check_surface(make_shape({"sphere", 64})).volume == Approx(4.0 / 3.0 * pi * 0.125).epsilon(0.01));
  CHECK(check_surface(make_shape({"torus", 64})).volume == Approx(2 * pi * pi * 0.5 * 0.2 * 0.2).epsilon(0.01));
  CHECK(check_surface(make_shape({"box", 16})).volume == Approx(1.0 * 0.6 * 0.4).epsilon(1e-12));
  // Finer sampling converges: the error at 128 is well below the error at 32.
  double exact = 4.0 / 3.0 * pi * 0.125;
  double e32 = std::abs(check_surface(make_shape({"sphere", 32})).volume - exact);
  double e128 = std::abs(check_surface(make_shape({"sphere", 128})).volume - exact);
  CHECK(e128 < e32 / 8);
}

TEST_CASE("CSG shape volumes match their constructions within voxel error", "[shapes]") {
  // l_block: 1 x 0.5 x 0.3 foot + 0.3 x 0.5 x 0.5 upright above it.
  CHECK(check_surface(make_shape({"l_block", 128})).volume == Approx(0.15 + 0.075).epsilon(0.02));
  // rod_with_holes: stadium (0.9 x 0.4 rectangle + disc r 0.2) x 0.2 thick, minus two r 0.1 holes.
  double rod = (0.9 * 0.4 + M_PI * 0.04 - 2 * M_PI * 0.01) * 0.2;
  CHECK(check_surface(make_shape({"rod_with_holes", 128})).volume == Approx(rod).epsilon(0.02));
}

TEST_CASE("unknown shape name is an InvalidInput that lists the valid names", "[shapes]") {
  ShapeParams p{"teapot", 64};
  CHECK_THROWS_AS(make_shape(p), InvalidInput);
  CHECK_THROWS_WITH(make_shape(p), Catch::Contains("`teapot`") && Catch::Contains("sphere, torus, bumpy_torus") &&
                                       Catch::Contains("fandisk_like, box"));
}

TEST_CASE("shapes node: registered, validates params, reports metrics", "[shapes]") {
  const NodeSpec* spec = Registry::instance().find("shapes");
  REQUIRE(spec != nullptr);
  CHECK(spec->inputs.empty());
  CHECK(spec->output == "SurfaceMesh");
  CHECK_THROWS_WITH(spec->check_params(json{{"name", "teapot"}}, "s"), Catch::Contains("is not one of"));
  CHECK_THROWS_WITH(spec->check_params(json{{"resolution", 4}}, "s"), Catch::Contains("out of range [8"));
  CHECK(spec->check_params(json::object(), "s") == json{{"name", "fandisk_like"}, {"resolution", 64}});
  NodeContext ctx;
  ctx.id = "s";
  Artefact a = spec->run(json{{"name", "torus"}, {"resolution", 16}}, Inputs{}, ctx);
  auto m = a.as<SurfaceMesh>();
  CHECK(m->F.rows() == 16 * 8 * 2);
  CHECK(ctx.metrics["faces"] == 256);
  CHECK(ctx.metrics["vertices"] == 128);
}
