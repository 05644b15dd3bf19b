// Hex optimization (§6): max-min SJ never lowers the minimum, untangling, boundary on the surface.
#include "graph/node.h"
#include "nodes/algorithms/hex_corners.h"
#include "nodes/algorithms/hex_quality.h"
#include "nodes/algorithms/shapes.h"
#include "nodes/algorithms/triangle_tree.h"
#include "nodes/optimize/optimize.h"
#include "tests/helpers/eigen_orders.h"
#include "tests/helpers/voxel_maps.h"

#include <catch2/catch.hpp>
#include <tbb/global_control.h>

#include <algorithm>
#include <cstring>
#include <random>

using namespace polyhex;

namespace {

/// Max distance of the boundary vertices from the surface, over its bbox diagonal.
double boundary_distance(const HexMesh& m, const SurfaceMesh& s) {
  TriangleTree tree(s.V, s.F);
  const auto Q = hex_boundary_quads(m);
  double d = 0;
  for (Eigen::Index q = 0; q < Q.rows(); ++q)
    for (int k = 0; k < 4; ++k) d = std::max(d, tree.distance(m.V.row(Q(q, k)).transpose()));
  return d / (s.V.colwise().maxCoeff() - s.V.colwise().minCoeff()).norm();
}

/// Every phase of the optimizer off: a test turns on the ones it checks.
OptimizeParams no_phases() {
  OptimizeParams p;
  p.untangle_iterations = 0;
  p.global_iterations = 0;
  p.iterations = 0;
  p.element_iterations = 0;
  p.smooth_iterations = 0;
  p.shape_iterations = 0;
  p.average_iterations = 0;
  p.minimum_iterations = 0;
  return p;
}

bool on_box_boundary(const Eigen::RowVector3d& x, double n) {
  return (x.array() < 1e-12).any() || (x.array() > n - 1e-12).any();
}

/// Turns every vertex of an n x n x n grid that `stays` does not hold about the box's vertical axis, by
/// turn(z) radians: a smooth, low-frequency distortion that one-vertex sweeps undo slowly.
template <class Turn, class Stays>
void swirl(HexMesh& g, int n, Turn turn, Stays stays) {
  for (Eigen::Index v = 0; v < g.V.rows(); ++v) {
    const Eigen::RowVector3d x = g.V.row(v);
    if (stays(x)) continue;
    const double cx = x[0] - n / 2.0, cy = x[1] - n / 2.0, t = turn(x[2]);
    g.V(v, 0) = n / 2.0 + std::cos(t) * cx - std::sin(t) * cy;
    g.V(v, 1) = n / 2.0 + std::sin(t) * cx + std::cos(t) * cy;
  }
}

}  // namespace

TEST_CASE("the Winslow energy of a cube is 8 at any scale and grows with distortion", "[optimize]") {
  HexMesh g = test::grid_hex_mesh(1, 1, 1, 2.0);
  std::array<Eigen::Vector3d, 8> p;
  for (int k = 0; k < 8; ++k) p[size_t(k)] = g.V.row(g.H(0, k)).transpose();
  CHECK(hex_winslow_energy(p, 2.0, 1e-9) == Approx(8.0).epsilon(1e-6));
  CHECK(hex_winslow_energy(p, 1.0, 1e-9) == Approx(8.0).epsilon(1e-6));
  p[6] += Eigen::Vector3d(0.5, 0.3, -0.2);
  CHECK(hex_winslow_energy(p, 2.0, 1e-9) > 8.01);
}

TEST_CASE("optimize: the 8 corner Winslow terms, four at a time in lanes, have the Eigen expressions' bits",
          "[optimize]") {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> jitter(-0.6, 0.6);
  long differ = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    std::array<Eigen::Vector3d, 8> p;
    for (int k = 0; k < 8; ++k)
      p[size_t(k)] =
          Eigen::Vector3d(k == 1 || k == 2 || k == 5 || k == 6, k == 2 || k == 3 || k == 6 || k == 7, k >= 4) +
          Eigen::Vector3d(jitter(rng), jitter(rng), jitter(rng));
    const double scale = 0.3 + 0.0001 * trial, eps = trial % 3 ? 1e-10 : 0.2;
    std::array<double, 8> terms;
    const double e = hex_winslow_energy(p, scale, eps, terms);
    double sum = 0;
    for (size_t k = 0; k < 8; ++k) {  // optimize.cpp's winslow_corner as of 6c8d84e
      const auto& c = hex_topology::kCorners[k];
      Eigen::Matrix3d J;
      for (int col = 0; col < 3; ++col) J.col(col) = (p[size_t(c[size_t(col) + 1])] - p[size_t(c[0])]) / scale;
      const double ref = optimize_detail::winslow_term(J, eps, nullptr, optimize_detail::CubeRoot::fast);
      differ += std::memcmp(&ref, &terms[k], sizeof ref) != 0;
      sum += ref;
    }
    differ += std::memcmp(&sum, &e, sizeof e) != 0;
  }
  if (test::kEigenOrders)
    CHECK(differ == 0);
  else
    WARN("not an SSE2-only x86-64 build: Eigen's summation orders differ, their bits not compared");
}

TEST_CASE("optimize: the Winslow energy after one corner moved equals the full evaluation bit for bit", "[optimize]") {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> jitter(-0.3, 0.3);
  int copied_total = 0;
  for (int trial = 0; trial < 200; ++trial) {
    std::array<Eigen::Vector3d, 8> p;
    for (int k = 0; k < 8; ++k)
      p[size_t(k)] = Eigen::Vector3d(k & 1 ? 1 : 0, k & 2 ? 1 : 0, k & 4 ? 1 : 0) +
                     Eigen::Vector3d(jitter(rng), jitter(rng), jitter(rng));
    std::swap(p[2], p[3]);  // VTK order: 0 1 2 3 around the bottom face
    std::swap(p[6], p[7]);
    const double scale = 0.5 + 0.01 * trial, eps = trial % 2 ? 1e-6 : 0.3;
    std::array<double, 8> before, full, moved;
    hex_winslow_energy(p, scale, eps, before);
    const int j = trial % 8;
    p[size_t(j)] += Eigen::Vector3d(jitter(rng), jitter(rng), jitter(rng));
    const double a = hex_winslow_energy(p, scale, eps, full);
    CHECK(a == hex_winslow_energy(p, scale, eps));
    CHECK(hex_winslow_energy_moved(p, j, scale, eps, before, moved) == a);
    CHECK(moved == full);
    std::array<double, 8> marked;  // the 4 terms without corner j come from `before`
    marked.fill(-7.0);
    hex_winslow_energy_moved(p, j, scale, eps, marked, moved);
    const int copied = int(std::count(moved.begin(), moved.end(), -7.0));
    CHECK(copied == 4);
    copied_total += copied;
  }
  CHECK(copied_total == 800);
}

TEST_CASE("optimizing a perturbed grid raises the minimum scaled Jacobian and keeps the boundary", "[optimize]") {
  const int n = 4;
  HexMesh g = test::grid_hex_mesh(n, n, n);
  SurfaceMesh s = test::voxel_surface(test::voxel_box(n, n, n));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  for (Eigen::Index v = 0; v < g.V.rows(); ++v) {
    const bool b = on_box_boundary(g.V.row(v), n);
    for (int a = 0; a < 3; ++a) {
      // boundary vertices slide within their face(s) only, so they stay on the surface
      const bool fixed = b && (g.V(v, a) < 1e-12 || g.V(v, a) > n - 1e-12);
      if (!fixed) g.V(v, a) += u(rng);
    }
  }
  HexQuality before = hex_quality(g, nullptr);
  REQUIRE(before.inverted == 0);
  OptimizeStats st;
  HexMesh m = optimize_hexes(g, s, {}, &st);
  HexQuality after = hex_quality(m, nullptr);
  CHECK(st.sj_min_before == Approx(before.sj_min));
  CHECK(after.sj_min == Approx(st.sj_min_after));
  CHECK(after.sj_min > before.sj_min + 0.05);
  CHECK(after.sj_avg > before.sj_avg);
  CHECK(after.inverted == 0);
  CHECK(st.inverted_after == 0);
  CHECK(st.moves > 0);
  CHECK(boundary_distance(m, s) < 1e-9);
  CHECK(st.boundary_distance_max < 1e-9);
  CHECK(m.H == g.H);
}

TEST_CASE("optimization never lowers the minimum of an already perfect grid", "[optimize]") {
  HexMesh g = test::grid_hex_mesh(3, 3, 3);
  SurfaceMesh s = test::voxel_surface(test::voxel_box(3, 3, 3));
  OptimizeStats st;
  HexMesh m = optimize_hexes(g, s, {}, &st);
  CHECK(st.sj_min_after >= st.sj_min_before - 1e-12);
  CHECK(st.sj_min_after == Approx(1.0));
  CHECK((m.V - g.V).cwiseAbs().maxCoeff() < 1e-9);
}

TEST_CASE("an inverted hex gets untangled", "[optimize]") {
  HexMesh g = test::grid_hex_mesh(3, 3, 3);
  SurfaceMesh s = test::voxel_surface(test::voxel_box(3, 3, 3));
  // interior vertex (1,1,1) pushed past its opposite neighbours: the hexes around it fold
  const int v = (1 * 4 + 1) * 4 + 1;
  REQUIRE(g.V.row(v) == Eigen::RowVector3d(1, 1, 1));
  g.V.row(v) << 2.4, 2.3, 2.2;
  REQUIRE(hex_quality(g, nullptr).inverted > 0);
  OptimizeStats st;
  HexMesh m = optimize_hexes(g, s, {}, &st);
  CHECK(st.inverted_before > 0);
  CHECK(st.untangle_sweeps > 0);
  CHECK(st.inverted_after == 0);
  HexQuality q = hex_quality(m, nullptr);
  CHECK(q.inverted == 0);
  CHECK(q.sj_min > 0.3);
  CHECK(boundary_distance(m, s) < 1e-9);
}

TEST_CASE("optimize names a bad surface", "[optimize]") {
  HexMesh g = test::grid_hex_mesh(1, 1, 1);
  SurfaceMesh empty;
  REQUIRE_THROWS_WITH(optimize_hexes(g, empty), Catch::Contains("no triangles"));
}

TEST_CASE("the optimize node never hands out an inverted hex silently", "[optimize]") {
  // no sweep allowed: the inverted hexes stay, and the node says so in its metrics and warnings
  const NodeSpec* spec = Registry::instance().find("optimize/sj");
  REQUIRE(spec != nullptr);
  REQUIRE(spec->inputs.size() == 3);
  CHECK(spec->inputs[0].name == "hexes");
  CHECK(spec->inputs[1].name == "surface");
  CHECK_FALSE(spec->inputs[1].optional);
  CHECK(spec->inputs[2].name == "fallback");
  CHECK(spec->inputs[2].optional);
  HexMesh g = test::grid_hex_mesh(3, 3, 3);
  g.V.row((1 * 4 + 1) * 4 + 1) << 2.4, 2.3, 2.2;
  Inputs in;
  in.items = {make_artefact(g), make_artefact(test::voxel_surface(test::voxel_box(3, 3, 3)))};
  NodeContext ctx;
  ctx.id = "opt";
  json params = spec->check_params(json{{"untangle_iterations", 0},
                                        {"global_iterations", 0},
                                        {"iterations", 0},
                                        {"element_iterations", 0},
                                        {"shape_iterations", 0},
                                        {"release_boundary", false}},
                                   "opt");
  Artefact out = spec->run(params, in, ctx);
  CHECK(out.as<HexMesh>()->H.rows() == 27);
  CHECK(ctx.metrics["inverted"].get<long>() > 0);
  REQUIRE(ctx.warnings.size() == 1);
  CHECK_THAT(ctx.warnings[0], Catch::Contains("hexes are still inverted after optimization"));
  REQUIRE_THROWS_WITH(spec->check_params(json{{"target_sj", 2.0}}, "opt"), Catch::Contains("out of range"));
}

TEST_CASE("boundary vertices are released from the surface only for hexes still inverted", "[optimize]") {
  // An interior vertex pushed through its neighbours: untangling moves interior vertices only as far as
  // needed and the boundary stays on the surface, so the last-resort release must not trigger.
  HexMesh g = test::grid_hex_mesh(3, 3, 3);
  g.V.row((1 * 4 + 1) * 4 + 1) << 2.4, 2.3, 2.2;
  OptimizeStats st;
  optimize_hexes(g, test::voxel_surface(test::voxel_box(3, 3, 3)), OptimizeParams{}, &st);
  CHECK(st.inverted_before > 0);
  CHECK(st.inverted_after == 0);
  CHECK(st.released_vertices == 0);
  CHECK(st.boundary_distance_max < 1e-9);
  // The global descent alone (no sweeps) untangles it too, without releasing the boundary.
  OptimizeParams global_only = no_phases();
  global_only.global_iterations = OptimizeParams{}.global_iterations;
  OptimizeStats st3;
  optimize_hexes(g, test::voxel_surface(test::voxel_box(3, 3, 3)), global_only, &st3);
  CHECK(st3.inverted_after_global == 0);
  CHECK(st3.inverted_after == 0);
  CHECK(st3.global_outer > 0);
  CHECK(st3.released_vertices == 0);
  CHECK(st3.boundary_distance_max < 1e-9);
  // With no untangling sweep allowed the release marks the boundary corners of the inverted hexes.
  const OptimizeParams none = no_phases();
  OptimizeStats st2;
  optimize_hexes(g, test::voxel_surface(test::voxel_box(3, 3, 3)), none, &st2);
  CHECK(st2.released_vertices > 0);
  CHECK(st2.inverted_after > 0);
}

TEST_CASE("released boundary vertices go back onto the surface once the hexes around them are untangled",
          "[optimize]") {
  // Two vertices pushed through their neighbours, one untangling sweep on the surface: it leaves hexes
  // inverted, the release frees their boundary corners and the next sweep untangles them off the surface
  // (0.04 of the diagonal away without the return). Once the max-min phase has moved the neighbours, every
  // released vertex goes back.
  const SurfaceMesh s = test::voxel_surface(test::voxel_box(3, 3, 3));
  HexMesh g = test::grid_hex_mesh(3, 3, 3);
  g.V.row((1 * 4 + 1) * 4 + 1) << 2.4, 2.3, 2.6;
  g.V.row((2 * 4 + 1) * 4 + 1) << 1.1, 1.2, 2.1;
  OptimizeParams p;
  p.global_iterations = 0;
  p.untangle_iterations = 1;
  OptimizeStats st;
  const HexMesh out = optimize_hexes(g, s, p, &st);
  CHECK(st.inverted_after == 0);
  CHECK(st.released_vertices > 0);
  CHECK(st.returned_vertices == st.released_vertices);
  CHECK(st.boundary_distance_max < 1e-9);
  CHECK(boundary_distance(out, s) < 1e-9);
  CHECK(hex_quality(out, nullptr).sj_min > 0.9);
}

TEST_CASE("the global untangling is a fallback: tried only when local moves leave inverted hexes, kept only if better",
          "[optimize]") {
  HexMesh g = test::grid_hex_mesh(3, 3, 3);
  g.V.row((1 * 4 + 1) * 4 + 1) << 2.4, 2.3, 2.2;
  const SurfaceMesh s = test::voxel_surface(test::voxel_box(3, 3, 3));
  // local sweeps succeed: the global way is not tried, and the result is the local-only result exactly
  OptimizeStats st, st_local;
  OptimizeParams local_only;
  local_only.global_iterations = 0;
  const HexMesh a = optimize_hexes(g, s, {}, &st);
  const HexMesh b = optimize_hexes(g, s, local_only, &st_local);
  CHECK(st.inverted_before > 0);
  CHECK(st.optimize_ways == 1);
  CHECK_FALSE(st.global_kept);
  CHECK(st.inverted_after_global == -1);
  CHECK(st.inverted_after == 0);
  CHECK(a.V == b.V);
  // local sweeps not allowed to untangle: the local way ends inverted, the global way is tried and kept
  OptimizeParams p = no_phases();
  p.global_iterations = OptimizeParams{}.global_iterations;
  const OptimizeParams q = no_phases();
  OptimizeStats sg, sl;
  optimize_hexes(g, s, p, &sg);
  optimize_hexes(g, s, q, &sl);
  CHECK(sl.inverted_after > 0);
  CHECK(sl.released_vertices > 0);
  CHECK(sg.optimize_ways == 2);
  CHECK(sg.global_kept);
  CHECK(sg.inverted_after == 0);
  CHECK(sg.released_vertices == 0);  // the statistics are the kept way's
  CHECK(sg.sj_min_after > 0);
}

TEST_CASE("whole-hex moves separate two vertices pressed together and keep the boundary on the surface", "[optimize]") {
  HexMesh g = test::grid_hex_mesh(3, 3, 3);
  const SurfaceMesh s = test::voxel_surface(test::voxel_box(3, 3, 3));
  // the centre hex's edge (1,1,1)-(2,1,1) squeezed to a tenth of its length and pushed aside; nothing inverts
  const int a = (1 * 4 + 1) * 4 + 1, b = (1 * 4 + 1) * 4 + 2;
  REQUIRE(g.V.row(b) == Eigen::RowVector3d(2, 1, 1));
  g.V.row(a) << 1.45, 1.4, 1.3;
  g.V.row(b) << 1.55, 1.4, 1.3;
  const HexQuality q0 = hex_quality(g, nullptr);
  REQUIRE(q0.inverted == 0);
  REQUIRE(q0.sj_min < 0.5);
  OptimizeParams only = no_phases();  // whole-hex moves alone: no other phase may move a vertex
  only.element_iterations = 3;
  OptimizeStats st;
  const HexMesh m = optimize_hexes(g, s, only, &st);
  const HexQuality q1 = hex_quality(m, nullptr);
  CHECK(st.element_moves > 0);
  CHECK(q1.inverted == 0);
  CHECK(q1.sj_min > q0.sj_min + 0.1);
  CHECK((m.V.row(b) - m.V.row(a)).norm() > 0.3);
  CHECK(boundary_distance(m, s) < 1e-9);
  // an undistorted grid offers nothing to improve: no whole-hex move is kept
  OptimizeStats st2;
  const HexMesh same =
      optimize_hexes(test::grid_hex_mesh(2, 2, 2), test::voxel_surface(test::voxel_box(2, 2, 2)), only, &st2);
  CHECK(st2.element_moves == 0);
  CHECK(same.V == test::grid_hex_mesh(2, 2, 2).V);
}

TEST_CASE("the fallback mesh is optimized only when hexes stay inverted, and kept only if better", "[optimize]") {
  const SurfaceMesh s = test::voxel_surface(test::voxel_box(3, 3, 3));
  HexMesh tangled = test::grid_hex_mesh(3, 3, 3);
  tangled.V.row((1 * 4 + 1) * 4 + 1) << 2.4, 2.3, 2.2;
  const HexMesh clean = test::grid_hex_mesh(3, 3, 3);
  OptimizeParams frozen = no_phases();  // nothing moves: the tangled mesh stays tangled
  frozen.release_boundary = false;
  OptimizeStats st;
  FallbackOutcome fb;
  HexMesh out = optimize_hexes_or_fallback(tangled, &clean, s, frozen, &st, &fb);
  CHECK(fb.ran);
  CHECK(fb.kept);
  CHECK(fb.stats.inverted_after == 0);
  CHECK(fb.stats.seconds >= 0);
  CHECK(st.inverted_after == 0);
  CHECK(hex_quality(out, nullptr).inverted == 0);
  CHECK(out.V == clean.V);
  // a clean first result above fallback_below_sj: the fallback is not run
  OptimizeStats st2;
  fb.ran = fb.kept = true;  // overwritten
  out = optimize_hexes_or_fallback(clean, &tangled, s, frozen, &st2, &fb);
  CHECK_FALSE(fb.ran);
  CHECK_FALSE(fb.kept);
  // a valid but poor first result (minimum below fallback_below_sj): the fallback runs and wins if better
  HexMesh poor = clean;
  for (double t : {0.45, 0.4, 0.35, 0.3, 0.25, 0.2}) {  // squeezed along the diagonal, not inverted
    poor.V.row((1 * 4 + 1) * 4 + 1) << 1 + t, 1 + t, 1 + t;
    if (hex_quality(poor, nullptr).inverted == 0) break;
  }
  REQUIRE(hex_quality(poor, nullptr).inverted == 0);
  REQUIRE(hex_quality(poor, nullptr).sj_min < frozen.fallback_below_sj);
  out = optimize_hexes_or_fallback(poor, &clean, s, frozen, &st2, &fb);
  CHECK(fb.ran);
  CHECK(fb.kept);
  CHECK(out.V == clean.V);
  OptimizeParams never = frozen;
  never.fallback_below_sj = 0;
  out = optimize_hexes_or_fallback(poor, &clean, s, never, &st2, &fb);
  CHECK_FALSE(fb.ran);
  CHECK_FALSE(fb.kept);
  CHECK(out.V == poor.V);
  // a worse fallback runs but is not kept
  out = optimize_hexes_or_fallback(tangled, &tangled, s, frozen, &st2, &fb);
  CHECK(fb.ran);
  CHECK_FALSE(fb.kept);
  CHECK(st2.inverted_after > 0);
  // better_result: fewer inverted first, then the higher minimum
  OptimizeStats a, b;
  a.inverted_after = 1, a.sj_min_after = 0.9;
  b.inverted_after = 0, b.sj_min_after = -0.1;
  CHECK(better_result(b, a));
  CHECK_FALSE(better_result(a, b));
  a.inverted_after = 0;
  CHECK(better_result(a, b));
  CHECK(better_result(a, b));
}

TEST_CASE("the crease and fallback candidates run side by side: the same choice and mesh on 1 or 2 threads",
          "[optimize]") {
  const SurfaceMesh box = test::voxel_surface(test::voxel_box(3, 3, 3));
  const HexMesh clean = test::grid_hex_mesh(3, 3, 3);
  HexMesh poor = clean;  // an edge vertex slid up its face: on the surface, its hexes sheared
  poor.V.row(1) << 1, 0, 0.7;
  HexMesh fallback = clean;  // an interior vertex off its place
  fallback.V.row((1 * 4 + 1) * 4 + 1) += Eigen::RowVector3d(0.3, -0.2, 0.25);
  // frozen: the crease candidate snaps the boundary onto the box's edges (the clean grid, SJ 1) and the
  // fallback stays as it is; both run, and the crease candidate, first in order, is kept
  OptimizeParams frozen = no_phases();
  frozen.fallback_below_sj = 0.8;
  OptimizeStats st;
  FallbackOutcome fb;
  HexMesh out = optimize_hexes_or_fallback(poor, &fallback, box, frozen, &st, &fb);
  CHECK(fb.ran);
  CHECK(fb.creases_ran);
  CHECK(fb.creases_kept);
  CHECK_FALSE(fb.kept);
  CHECK(fb.stats.sj_min_after < 1.0);
  CHECK((out.V - clean.V).norm() < 1e-12);
  // every phase, the first result held poor: all three candidates do their work, on 2 threads and on 1
  OptimizeParams all;
  all.fallback_below_sj = 1.0;
  OptimizeStats st2, st1;
  FallbackOutcome fb2, fb1;
  const HexMesh two = optimize_hexes_or_fallback(poor, &fallback, box, all, &st2, &fb2);
  HexMesh one;
  {
    tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
    one = optimize_hexes_or_fallback(poor, &fallback, box, all, &st1, &fb1);
  }
  CHECK(fb2.ran);
  CHECK(fb2.creases_ran);
  CHECK(one.V == two.V);  // bit for bit
  CHECK(fb1.kept == fb2.kept);
  CHECK(fb1.creases_kept == fb2.creases_kept);
  CHECK(fb1.stats.sj_min_after == fb2.stats.sj_min_after);
  CHECK(fb1.creases_stats.sj_min_after == fb2.creases_stats.sj_min_after);
  CHECK(st1.sj_min_after == st2.sj_min_after);
}

TEST_CASE("the shape sweeps raise the average and stop once a pair of them gains less than shape_tolerance",
          "[optimize]") {
  const int n = 4;
  HexMesh g = test::grid_hex_mesh(n, n, n);
  const SurfaceMesh s = test::voxel_surface(test::voxel_box(n, n, n));
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-0.25, 0.25);
  for (Eigen::Index v = 0; v < g.V.rows(); ++v)
    if (!on_box_boundary(g.V.row(v), n))
      for (int a = 0; a < 3; ++a) g.V(v, a) += u(rng);
  OptimizeParams p = no_phases();
  p.shape_iterations = 40;
  p.shape_tolerance = 1.0;  // no pair of sweeps gains a whole unit: stop after the first pair
  OptimizeStats one;
  optimize_hexes(g, s, p, &one);
  CHECK(one.shape_sweeps == 2);
  CHECK(one.sj_avg_after > one.sj_avg_before);
  p.shape_tolerance = 0.0;  // only a pair that gains nothing stops them
  OptimizeStats many;
  optimize_hexes(g, s, p, &many);
  CHECK(many.shape_sweeps > 2);
  CHECK(many.sj_avg_after > one.sj_avg_after);
  CHECK(many.sj_min_after >= many.sj_min_before);
  CHECK(many.inverted_after == 0);
}

TEST_CASE("the average ascent raises the average beyond the sweeps alone, keeps the minimum and the boundary",
          "[optimize]") {
  // the interior of a 6x6x6 grid swirled about the z axis: a smooth distortion the one-vertex sweeps
  // undo slowly
  const int n = 6;
  HexMesh g = test::grid_hex_mesh(n, n, n);
  const SurfaceMesh s = test::voxel_surface(test::voxel_box(n, n, n));
  swirl(
      g, n, [&](double z) { return 0.25 * std::sin(M_PI * z / n); },
      [&](const Eigen::RowVector3d& x) { return on_box_boundary(x, n); });
  OptimizeParams p = no_phases();
  p.shape_iterations = 2;  // one pair of sweeps: what the ascent adds to them, not what 30 pairs reach anyway
  p.shape_tolerance = 0.0;
  OptimizeStats off;
  optimize_hexes(g, s, p, &off);
  CHECK(off.average_kept == 0);
  p.average_iterations = 300;
  p.average_below_sj = 0.99;
  OptimizeStats on;
  const HexMesh out = optimize_hexes(g, s, p, &on);
  CHECK(on.average_kept == 1);
  CHECK(on.average_gain > 0.01);
  CHECK(on.sj_avg_after > off.sj_avg_after + 0.02);
  CHECK(on.sj_min_after >= on.sj_min_before);
  CHECK(on.inverted_after == 0);
  CHECK(boundary_distance(out, s) < 1e-9);
  // a region of no hex (every hex above average_below_sj): nothing is tried
  p.average_below_sj = 0.0;
  OptimizeStats none;
  optimize_hexes(g, s, p, &none);
  CHECK(none.average_kept == 0);
  CHECK(none.sj_avg_after == Approx(off.sj_avg_after).epsilon(1e-12));
}

TEST_CASE("the minimum ascent raises the minimum after the max-min sweeps, boundary vertices sliding on the surface",
          "[optimize]") {
  // a 6x6x6 grid swirled about the z axis, its bottom and top faces' vertices too (in their planes): the
  // worst hexes lie along the sides, where one-vertex moves stall
  const int n = 6;
  HexMesh g = test::grid_hex_mesh(n, n, n);
  const SurfaceMesh s = test::voxel_surface(test::voxel_box(n, n, n));
  swirl(
      g, n, [&](double z) { return 0.15 + 0.1 * std::sin(M_PI * z / n); },
      [&](const Eigen::RowVector3d& x) {  // the sides stay
        return (x.head<2>().array() < 1e-12).any() || (x.head<2>().array() > n - 1e-12).any();
      });
  REQUIRE(hex_quality(g, nullptr).inverted == 0);
  OptimizeParams p = no_phases();
  p.iterations = 1;    // one max-min sweep and its follow-up over the worst hexes
  p.target_sj = 0.95;  // they, and the ascent, work on the hexes below this
  OptimizeStats off;
  const HexMesh a = optimize_hexes(g, s, p, &off);
  REQUIRE(off.inverted_after == 0);
  REQUIRE(off.sj_min_after < p.target_sj - 0.1);  // the ascent's region: poor hexes near the minimum
  CHECK(off.minimum_rounds == 0);
  p.minimum_iterations = 200;
  OptimizeStats on;
  const HexMesh b = optimize_hexes(g, s, p, &on);
  CHECK(on.minimum_kept >= 1);
  CHECK(on.minimum_rounds <= p.minimum_rounds);
  CHECK(on.sj_min_after > off.sj_min_after + 0.05);
  CHECK(on.minimum_gain == Approx(on.sj_min_after - off.sj_min_after).margin(1e-12));
  CHECK(on.inverted_after == 0);
  CHECK(boundary_distance(a, s) < 1e-9);
  CHECK(boundary_distance(b, s) < 1e-9);
  // the box's edges are creases: their vertices stay
  for (Eigen::Index v = 0; v < g.V.rows(); ++v) {
    const Eigen::RowVector3d x = g.V.row(v);
    int on_faces = 0;
    for (int i = 0; i < 3; ++i) on_faces += x[i] < 1e-12 || x[i] > n - 1e-12;
    if (on_faces >= 2) CHECK(b.V.row(v) == a.V.row(v));
  }
}

TEST_CASE("the minimum ascent slides a boundary vertex near a crease parallel to it, never off its distance to it",
          "[optimize]") {
  // a 6x6x6 grid; the bottom vertex at (3, 1, 0) pushed to (3.3, 0.45, 0), 0.45 hex edges from the box's edge
  // y = z = 0 (a crease): sliding freely the ascent would pull it off that distance, fixed it cannot help its
  // hexes; sliding along the crease it goes back to x = 3 and keeps its distance
  const int n = 6;
  HexMesh g = test::grid_hex_mesh(n, n, n);
  const SurfaceMesh s = test::voxel_surface(test::voxel_box(n, n, n));
  const Eigen::Index c = (0 * (n + 1) + 1) * (n + 1) + 3;
  REQUIRE((g.V.row(c) - Eigen::RowVector3d(3, 1, 0)).norm() < 1e-12);
  g.V.row(c) << 3.3, 0.45, 0.0;
  const HexQuality q0 = hex_quality(g, nullptr);
  REQUIRE(q0.inverted == 0);
  OptimizeParams p = no_phases();
  p.minimum_iterations = 200;
  p.target_sj = 0.95;
  OptimizeStats st;
  const HexMesh b = optimize_hexes(g, s, p, &st);
  REQUIRE(st.crease_lines == 12);
  CHECK(st.minimum_kept >= 1);
  CHECK(st.minimum_slid >= 1);
  CHECK(std::abs(b.V(c, 0) - 3) < 0.1);
  CHECK(std::abs(b.V(c, 1) - 0.45) < 1e-9);
  CHECK(std::abs(b.V(c, 2)) < 1e-9);
  CHECK(st.inverted_after == 0);
  CHECK(st.sj_min_after > q0.sj_min + 0.05);
  CHECK(boundary_distance(b, s) < 1e-9);
}

TEST_CASE("optimize reports its phases in order through the progress callback", "[optimize][progress]") {
  const int n = 3;
  HexMesh g = test::grid_hex_mesh(n, n, n);
  g.V.row(21) += Eigen::RowVector3d(0.3, -0.2, 0.25);  // an interior vertex off its place
  const SurfaceMesh s = test::voxel_surface(test::voxel_box(n, n, n));
  std::vector<std::pair<double, std::string>> calls;
  OptimizeStats st;
  optimize_hexes_or_fallback(g, nullptr, s, {}, &st, nullptr,
                             [&](double f, const std::string& what) { calls.emplace_back(f, what); });
  REQUIRE(calls.size() == 2);  // a good result: no second candidate
  CHECK(calls[0].second == "untangling, max-min");
  CHECK(calls[1].second == "shape improvement");
  CHECK(calls[0].first == 0);
  CHECK(calls[1].first > calls[0].first);
  CHECK(calls[1].first < 1);
}

TEST_CASE("a released vertex its hexes hold off the surface goes back with its neighbours re-placed around it",
          "[optimize]") {
  // Two vertices of a 4^3 grid pushed through the bottom face, one untangling sweep on the surface, no later
  // phase: the release untangles the hexes off the surface and the neighbours stay where that put them.
  // Alone (return_rings 0) one released vertex cannot go back without lowering the minimum; with the
  // vertices within two rings taking max-min steps around it, it goes back, and the minimum does not fall.
  const SurfaceMesh s = test::voxel_surface(test::voxel_box(4, 4, 4));
  HexMesh g = test::grid_hex_mesh(4, 4, 4);
  auto id = [](int i, int j, int k) { return (k * 5 + j) * 5 + i; };
  g.V.row(id(2, 2, 1)) << 2.2, 2.1, -0.6;
  g.V.row(id(2, 1, 1)) << 2.0, 1.2, -0.3;
  OptimizeParams p = no_phases();
  p.untangle_iterations = 1;
  p.return_rings = 0;
  OptimizeStats alone;
  const HexMesh a = optimize_hexes(g, s, p, &alone);
  REQUIRE(alone.released_vertices > 0);
  CHECK(alone.returned_vertices < alone.released_vertices);
  CHECK(boundary_distance(a, s) > 1e-3);
  p.return_rings = 2;
  OptimizeStats st;
  const HexMesh b = optimize_hexes(g, s, p, &st);
  CHECK(st.inverted_after == 0);
  CHECK(st.released_vertices == alone.released_vertices);
  CHECK(st.returned_vertices == st.released_vertices);
  CHECK(st.returned_with_neighbours >= 1);
  CHECK(boundary_distance(b, s) < 1e-9);
  CHECK(hex_quality(b, nullptr).sj_min >= hex_quality(a, nullptr).sj_min);
  // sequential, in index order: the same mesh on one thread
  HexMesh c;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    c = optimize_hexes(g, s, p, nullptr);
  }
  CHECK(c.V == b.V);
}

TEST_CASE("the sweeps skip only steps that would fail again: the same mesh bit for bit as repeating every step",
          "[optimize]") {
  // A grid in a ball: its boundary projected onto the sphere squeezes the hexes at the cube's corners, where
  // the max-min sweeps stall on the same vertices. Interior vertices perturbed, then two pushed through their
  // neighbours with one untangling sweep or none (boundary vertices released, then returned): the untangling,
  // the release and return, the whole-hex moves and the region smoothing move vertices between the max-min
  // sweeps, so a skip that missed any of their changes would give another mesh.
  const int n = 6;
  const SurfaceMesh ball = make_shape({"sphere", 24});  // unit diameter, centred at the origin
  HexMesh g = test::grid_hex_mesh(n, n, n);
  g.V = (g.V.array() / n - 0.5) * 0.62;  // the cube's corners 0.54 from the centre, on the sphere 0.5
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-0.02, 0.02);
  const auto at = [&](int x, int y, int z) { return Eigen::Index((z * (n + 1) + y) * (n + 1) + x); };
  for (int z = 1; z < n; ++z)
    for (int y = 1; y < n; ++y)
      for (int x = 1; x < n; ++x)
        for (int a = 0; a < 3; ++a) g.V(at(x, y, z), a) += u(rng);
  for (const int untangle : {200, 1, 0}) {
    HexMesh start = g;
    if (untangle <= 1) {
      start.V.row(at(1, 1, 1)) = g.V.row(at(2, 2, 2));
      start.V.row(at(4, 3, 1)) = g.V.row(at(3, 3, 2));
    }
    OptimizeParams p;
    p.untangle_iterations = untangle;
    p.global_iterations = 0;
    OptimizeParams every = p;
    every.skip_failed_steps = false;
    OptimizeStats skip_st, every_st;
    const HexMesh a = optimize_hexes(start, ball, p, &skip_st);
    const HexMesh b = optimize_hexes(start, ball, every, &every_st);
    INFO("untangling sweeps " << untangle);
    CHECK(skip_st.steps_skipped > 0);
    CHECK(every_st.steps_skipped == 0);
    CHECK(a.V == b.V);  // bit for bit
    CHECK(skip_st.moves == every_st.moves);
    CHECK(skip_st.maxmin_sweeps == every_st.maxmin_sweeps);
    CHECK(skip_st.shape_sweeps == every_st.shape_sweeps);
    CHECK(skip_st.sj_min_after == every_st.sj_min_after);
    CHECK(skip_st.inverted_after == 0);
    if (untangle == 0) CHECK(skip_st.returned_vertices > 0);  // released, and back on the sphere
    CHECK(skip_st.average_seconds > 0);  // the average ascent ran, and its time is a part of the shape phase's
    CHECK(skip_st.average_seconds <= skip_st.shape_seconds);
  }
}
