// tetrahedralize/tetgen: the size estimate and the refusal of requests far beyond the machine, and
// scale invariance (a model scaled by 1e-9 or 1e9 gives the same tets as at unit scale).
#include "graph/node.h"
#include "nodes/algorithms/shapes.h"
#include "nodes/tetrahedralize/tetgen.h"
#include "runtime/errors.h"

#include <catch2/catch.hpp>

#include <chrono>
#include <cmath>
#include <unistd.h>

using namespace polyhex;
using Catch::Matchers::Contains;

namespace {

SurfaceMesh scaled(const SurfaceMesh& s, double k) {
  SurfaceMesh m = s;
  m.V *= k;
  return m;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

TEST_CASE("tetgen: the tet estimate is the right order of magnitude", "[tetgen][badinput]") {
  const SurfaceMesh box = make_shape({"box", 8});
  for (double e : {0.1, 0.05}) {
    TetgenParams p;
    p.edge_length = e;
    TetgenStats st;
    tetrahedralize(box, p, &st);
    const TetEstimate est = estimate_tets(box, e);
    INFO("edge_length " << e << ": " << st.tets << " tets, estimate " << est.tets);
    CHECK(st.estimated_tets == est.tets);
    CHECK(double(st.tets) / est.tets > 0.8);
    CHECK(double(st.tets) / est.tets < 1.5);
    CHECK(est.bytes == Approx(est.tets * kTetgenBytesPerTet));
    CHECK(est.h == Approx(e * (box.V.colwise().maxCoeff() - box.V.colwise().minCoeff()).norm()));
  }
  // The estimate scales as volume / h^3: a model twice as large has the same estimate.
  CHECK(estimate_tets(scaled(box, 2.0), 0.05).tets == Approx(estimate_tets(box, 0.05).tets).epsilon(1e-12));
  CHECK(estimate_tets(scaled(box, 2.0), 0.05).volume == Approx(8 * estimate_tets(box, 0.05).volume).epsilon(1e-12));
}

TEST_CASE("tetgen: a request far beyond max_tets is refused up front with the estimate", "[tetgen][badinput]") {
  SurfaceMesh box = make_shape({"box", 8});
  box.source = "box.obj";
  TetgenParams p;
  p.edge_length = 0.002;  // the smallest the node accepts: about 1e8 tets for a box
  const TetEstimate est = estimate_tets(box, p.edge_length);
  REQUIRE(est.tets > 5e7);
  const auto t0 = std::chrono::steady_clock::now();
  REQUIRE_THROWS_AS(tetrahedralize(box, p), InvalidInput);
  REQUIRE_THROWS_WITH(tetrahedralize(box, p),
                      Catch::StartsWith("box.obj: refused: edge_length 0.002") && Contains("would give about") &&
                          Contains("more than max_tets = 20000000") && Contains("use edge_length >= "));
  CHECK(seconds_since(t0) < 1.0);  // refused, not attempted
  // The suggested edge_length fits under the limit.
  try {
    tetrahedralize(box, p);
  } catch (const InvalidInput& e) {
    const std::string msg = e.what();
    const double suggested = std::stod(msg.substr(msg.find("edge_length >= ") + 15));
    CHECK(estimate_tets(box, suggested).tets <= double(p.max_tets));
    CHECK(estimate_tets(box, suggested).tets > 0.9 * double(p.max_tets));
  }
  // A lower max_tets refuses a small request the default accepts.
  TetgenParams small;
  small.edge_length = 0.1;
  small.max_tets = 10;
  CHECK_THROWS_WITH(tetrahedralize(box, small), Contains("more than max_tets = 10"));
}

TEST_CASE("tetgen: a request beyond the machine's memory is refused even under max_tets", "[tetgen][badinput]") {
  SurfaceMesh box = make_shape({"box", 8});
  box.source = "box.obj";
  const double memory = double(::sysconf(_SC_PHYS_PAGES)) * double(::sysconf(_SC_PAGE_SIZE));
  // An edge_length whose estimate needs 4 times the machine's memory.
  const double target = 4 * memory / kTetgenBytesPerTet;
  TetgenParams p;
  p.edge_length = 0.05 * std::cbrt(estimate_tets(box, 0.05).tets / target);
  p.max_tets = 2000000000;
  if (target > 1.9e9) {
    WARN("skipped: this machine's memory (" << memory / 1e9 << " GB) needs more than max_tets tets to exceed");
    SUCCEED();
    return;
  }
  CHECK_THROWS_WITH(tetrahedralize(box, p), Contains("box.obj: refused") && Contains("GB where the machine has") &&
                                                !Contains("more than max_tets"));
}

TEST_CASE("tetgen: all vertices at one point or an overflowing box are refused", "[tetgen][badinput]") {
  SurfaceMesh s = make_shape({"box", 8});
  s.source = "point.obj";
  s.V.setConstant(0.5);
  CHECK_THROWS_WITH(tetrahedralize(s, TetgenParams{}),
                    "point.obj: all vertices are at one point (bounding-box diagonal 0)");
  SurfaceMesh big = make_shape({"box", 8});
  big.source = "big.obj";
  big.V *= 1e300;
  CHECK_THROWS_WITH(tetrahedralize(big, TetgenParams{}), Contains("big.obj: coordinates too large"));
}

TEST_CASE("tetgen: 1e-9 and 1e9 scaled models give the unit model's tets", "[tetgen][badinput]") {
  const SurfaceMesh unit = make_shape({"l_block", 16});
  TetgenParams p;
  p.edge_length = 0.08;
  const TetMesh ref = tetrahedralize(unit, p);
  SECTION("power-of-two scales: the same tets, coordinates exactly scaled") {
    for (double k : {std::ldexp(1.0, -30), std::ldexp(1.0, 30)}) {
      const TetMesh m = tetrahedralize(scaled(unit, k), p);
      CHECK(m.T == ref.T);
      CHECK(m.V == ref.V * k);
    }
  }
  SECTION("decimal scales: the same tets, coordinates scaled up to rounding") {
    for (double k : {1e-9, 1e9}) {
      INFO("scale " << k);
      const TetMesh m = tetrahedralize(scaled(unit, k), p);
      REQUIRE(m.T.rows() == ref.T.rows());
      CHECK(m.T == ref.T);
      CHECK((m.V / k - ref.V).cwiseAbs().maxCoeff() < 1e-12);
    }
  }
  SECTION("input vertices keep their exact coordinates") {
    const SurfaceMesh tiny = scaled(unit, 1e-9);
    const TetMesh m = tetrahedralize(tiny, p);
    long found = 0;
    for (Eigen::Index i = 0; i < tiny.V.rows(); ++i)
      for (Eigen::Index j = 0; j < m.V.rows(); ++j)
        if (m.V.row(j) == tiny.V.row(i)) {
          ++found;
          break;
        }
    CHECK(found == tiny.V.rows());
  }
}

TEST_CASE("tetrahedralize/tetgen node: max_tets param and estimated_tets metric", "[tetgen][badinput]") {
  const NodeSpec* spec = Registry::instance().find("tetrahedralize/tetgen");
  REQUIRE(spec != nullptr);
  CHECK(spec->check_params(json::object(), "tets")["max_tets"] == 20000000);
  CHECK_THROWS_WITH(spec->check_params(json{{"max_tets", 0}}, "tets"), Contains("out of range"));
  CHECK_THROWS_WITH(spec->check_params(json{{"max_tets", 1.5}}, "tets"), Contains("must be an integer"));
  NodeContext ctx;
  ctx.id = "tets";
  Inputs in;
  in.items.push_back(make_artefact(make_shape({"box", 8})));
  spec->run(json{{"edge_length", 0.1}}, in, ctx);
  CHECK(ctx.metrics["estimated_tets"].get<double>() == Approx(estimate_tets(make_shape({"box", 8}), 0.1).tets));
}
