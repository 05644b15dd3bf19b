// Position-driven deformation (§5.2): planarity, integer chart planes, chart order, analytic answers.
#include "graph/node.h"
#include "nodes/algorithms/reference_length.h"
#include "nodes/algorithms/shapes.h"
#include "nodes/polycube_segment/polycube_segment.h"
#include "nodes/position_deform/position_deform.h"
#include "nodes/rotation_deform/rotation_deform.h"
#include "nodes/tetrahedralize/tetgen.h"
#include "tests/helpers/io_checks.h"
#include "tests/helpers/voxel_shapes.h"

#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <oneapi/tbb/global_control.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <unistd.h>

using namespace polyhex;

namespace {

struct Run {
  std::shared_ptr<const TetMesh> tets;
  TetMesh deformed;
  std::shared_ptr<const PolyCubeSegmentation> seg;
  PolyCubeMap map;
  PositionDeformStats stats;
};

Run run_pipeline(const SurfaceMesh& s, double tet_edge, const PositionDeformParams& p, bool rotate = true) {
  Run r;
  TetgenParams tp;
  tp.edge_length = tet_edge;
  r.tets = std::make_shared<const TetMesh>(tetrahedralize(s, tp));
  r.deformed = rotate ? rotation_deform(*r.tets, RotationDeformParams{}).mesh : *r.tets;
  r.seg = std::make_shared<const PolyCubeSegmentation>(segment_polycube(r.deformed));
  REQUIRE(r.seg->valid);
  r.map = position_deform(r.tets, r.deformed, r.seg, p, &r.stats);
  return r;
}

double diag(const RowMatrixX3d& V) { return (V.colwise().maxCoeff() - V.colwise().minCoeff()).norm(); }

/// Every boundary triangle on its chart's plane, every plane an integer multiple of h.
void check_planes(const Run& r) {
  const double h = r.map.edge_length, d = diag(r.tets->V);
  for (Eigen::Index f = 0; f < r.seg->F.rows(); ++f) {
    int c = r.seg->chart[f], a = label_axis(r.seg->charts[c].label);
    for (int k = 0; k < 3; ++k) {
      double x = r.map.U(r.seg->F(f, k), a);
      REQUIRE(std::abs(x - r.map.chart_plane[c] * h) <= 1e-9 * d);
      REQUIRE(std::abs(x / h - std::round(x / h)) <= 1e-9 * d / h);
    }
  }
  CHECK(r.stats.flipped_after_rounding == 0);
  CHECK(r.stats.order_constraints_dropped == 0);
  CHECK(r.stats.planarity_error <= 1e-12);
}

/// The first chart with the given direction label, -1 if none.
int chart_with_label(const Run& r, int label) {
  for (size_t c = 0; c < r.seg->charts.size(); ++c)
    if (r.seg->charts[c].label == label) return int(c);
  return -1;
}

}  // namespace

TEST_CASE("an axis-aligned box maps onto itself: MVC Laplace has linear precision", "[position]") {
  // [0,1]^3 with h = 0.1: planes at 0 and 10 h are where the faces already are, so the harmonic map
  // with mean value weights (2D on the faces, 3D inside) must reproduce the identity.
  SurfaceMesh box = test::voxel_surface(test::voxel_box(1, 1, 1));
  PositionDeformParams p;
  p.edge_length = 0.1 / std::sqrt(3.0);
  Run r = run_pipeline(box, 0.08, p, /*rotate=*/false);
  CHECK(r.seg->charts.size() == 6);
  check_planes(r);
  CHECK(r.stats.inverted_tets == 0);
  double err = (r.map.U - r.tets->V).cwiseAbs().maxCoeff();
  CHECK(err < 1e-8);
  CHECK(r.stats.distortion == Approx(1.0).epsilon(1e-6));
  CHECK(r.stats.distortion_max == Approx(1.0).epsilon(1e-6));
  CHECK(r.stats.chart_coordinates_rounded_max_shift < 1e-6);
}

TEST_CASE("box and L-block after the rotation stage: planar integer charts, order kept", "[position]") {
  for (FinalSolve final_solve : {FinalSolve::mvc_laplace, FinalSolve::poisson}) {
    INFO(int(final_solve));
    PositionDeformParams p;
    p.edge_length = 0.05;
    p.final_solve = final_solve;
    SurfaceMesh box = test::voxel_surface(test::voxel_box(2, 1, 1), 0.5);
    Run r = run_pipeline(box, 0.06, p);
    CHECK(r.seg->charts.size() == 6);
    check_planes(r);
    CHECK(r.stats.inverted_tets == 0);
    for (int a = 0; a < 3; ++a)
      CHECK(r.map.chart_plane[chart_with_label(r, 2 * a)] > r.map.chart_plane[chart_with_label(r, 2 * a + 1)]);
    SurfaceMesh l = test::voxel_surface({{0, 0, 0}, {1, 0, 0}, {0, 0, 1}}, 0.5);
    Run rl = run_pipeline(l, 0.06, p);
    CHECK(rl.seg->charts.size() == 8);
    check_planes(rl);
  }
}

/// The signed volume of the tets T on the vertices V.
double tet_volume(const RowMatrixX3d& V, const RowMatrixX4i& T) {
  double v = 0;
  for (Eigen::Index t = 0; t < T.rows(); ++t) v += iotest::tet_volume(V, T.row(t));
  return v;
}

TEST_CASE("lattice_spacing input_volume: about input volume / h^3 lattice cells in any frame", "[position]") {
  // A torus: the Poisson step flattens its curved charts and loses a good part of its volume, more or less
  // with the frame. On the paper's spacing the lattice then has that much fewer cells than volume / h^3; scaled
  // by the cube root of the Poisson step's volume ratio it has about volume / h^3 in each frame.
  ShapeParams sp;
  sp.name = "torus";
  sp.resolution = 32;
  const SurfaceMesh torus = make_shape(sp);
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  SurfaceMesh turned = torus;
  turned.V = torus.V * turn.transpose();
  PositionDeformParams p;
  p.edge_length = 0.04;
  std::vector<double> cells;
  for (const SurfaceMesh* s : std::array<const SurfaceMesh*, 2>{&torus, &turned}) {
    p.lattice_spacing = LatticeSpacing::polycube;
    const Run paper = run_pipeline(*s, 0.05, p);
    const double h = p.edge_length * reference_length(paper.tets->V);
    const double v_in = tet_volume(paper.tets->V, paper.tets->T);
    CHECK(paper.map.edge_length == h);
    CHECK(paper.stats.lattice_spacing_ratio == 1.0);
    CHECK(paper.stats.poisson_volume_ratio < 0.9);  // what the option is for
    p.lattice_spacing = LatticeSpacing::input_volume;
    const Run r = run_pipeline(*s, 0.05, p);
    check_planes(r);
    CHECK(r.stats.poisson_volume_ratio == paper.stats.poisson_volume_ratio);  // the same Poisson step
    CHECK(r.stats.lattice_spacing_ratio == Approx(std::cbrt(r.stats.poisson_volume_ratio)).epsilon(1e-12));
    CHECK(r.map.edge_length == Approx(h * r.stats.lattice_spacing_ratio).epsilon(1e-12));
    CHECK(r.stats.volume_ratio == Approx(tet_volume(r.map.U, r.tets->T) / v_in).epsilon(1e-9));
    // the lattice's cells (the map's volume in lattice units) against the input's volume in hex edges
    const double n = tet_volume(r.map.U, r.tets->T) / std::pow(r.map.edge_length, 3);
    const double want = v_in / (h * h * h);
    INFO("cells " << n << ", volume / h^3 " << want << ", paper's spacing "
                  << tet_volume(paper.map.U, paper.tets->T) / (h * h * h));
    CHECK(std::abs(n / want - 1) < 0.1);
    CHECK(tet_volume(paper.map.U, paper.tets->T) / (h * h * h) < 0.9 * want);
    cells.push_back(n);
  }
  CHECK(std::abs(cells[1] / cells[0] - 1) < 0.1);
}

TEST_CASE("the map's untangling removes folds and keeps every chart on its integer plane", "[position][untangle]") {
  // The bent pipe's map folds at its bend (paper Figure 9); the untangling must leave fewer inverted tets
  // than the final solve and must not move the PolyCube.
  ShapeParams sp;
  sp.name = "bent_pipe";
  sp.resolution = 32;
  PositionDeformParams off;
  off.edge_length = 0.04;
  off.untangle_iterations = 0;
  PositionDeformParams on = off;
  on.untangle_iterations = 600;
  const SurfaceMesh s = make_shape(sp);
  Run a = run_pipeline(s, 0.04, off), b = run_pipeline(s, 0.04, on);
  REQUIRE(a.stats.inverted_tets > 0);
  // untangling off: "before" is what the final solve left, the same count
  CHECK(a.stats.untangle.inverted_before == a.stats.inverted_tets);
  CHECK(a.stats.untangle.inverted_after == a.stats.inverted_tets);
  CHECK(b.stats.untangle.inverted_before == a.stats.inverted_tets);
  CHECK(b.stats.inverted_tets < a.stats.inverted_tets / 2);
  CHECK(b.stats.untangle.lbfgs_iterations > 0);
  CHECK(b.stats.untangle.lbfgs_iterations <= 600);
  check_planes(b);
  CHECK(b.map.chart_plane == a.map.chart_plane);
}

TEST_CASE("a C-shape keeps the gap between its arms", "[position]") {
  // C in the xy-plane: arms at y in [0,1] and [2,3], joined at x in [0,1]; the gap y in [1,2], x in [1,3].
  SurfaceMesh c =
      test::voxel_surface({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0, 1, 0}, {0, 2, 0}, {1, 2, 0}, {2, 2, 0}}, 1.0);
  PositionDeformParams p;
  p.edge_length = 0.05;
  Run r = run_pipeline(c, 0.05, p);
  check_planes(r);
  // The +Y chart bounding the lower arm from above and the -Y chart bounding the upper arm from below
  // face each other across the gap: after the map the upper one must stay above, at least one h apart.
  double lower_top = -1e9, upper_bottom = 1e9;
  for (size_t ch = 0; ch < r.seg->charts.size(); ++ch) {
    // locate charts by the deformed centroid of their vertices
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    int n = 0;
    for (Eigen::Index f = 0; f < r.seg->F.rows(); ++f)
      if (r.seg->chart[f] == int(ch))
        for (int k = 0; k < 3; ++k) centre += r.tets->V.row(r.seg->F(f, k)).transpose(), ++n;
    centre /= n;
    double plane = r.map.chart_plane[ch] * r.map.edge_length;
    if (r.seg->charts[ch].label == 2 && centre.x() > 1.2 && centre.y() < 1.5) lower_top = plane;
    if (r.seg->charts[ch].label == 3 && centre.x() > 1.2 && centre.y() > 1.5) upper_bottom = plane;
  }
  REQUIRE(lower_top > -1e9);
  REQUIRE(upper_bottom < 1e9);
  CHECK(upper_bottom - lower_top >= r.map.edge_length * 0.999);
  CHECK(r.stats.flipped_after_rounding == 0);
}

TEST_CASE("conformal distortion: 1 for similarities, larger for a stretch, inf for an inversion", "[position]") {
  Eigen::Vector3d a(0, 0, 0), b(1, 0, 0), c(0, 1, 0), d(0, 0, 1);
  Eigen::Matrix3d R = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  CHECK(conformal_distortion(a, b, c, d, 2 * R * a, 2 * R * b, 2 * R * c, 2 * R * d) == Approx(1.0));
  Eigen::Vector3d s(2, 1, 1);
  double stretched =
      conformal_distortion(a, b, c, d, a.cwiseProduct(s), b.cwiseProduct(s), c.cwiseProduct(s), d.cwiseProduct(s));
  CHECK(stretched == Approx(std::sqrt(6.0) * std::sqrt(2.25) / 3.0));
  CHECK(std::isinf(conformal_distortion(a, b, c, d, a, c, b, d)));
}

TEST_CASE("bad inputs to position_deform are named", "[position]") {
  SurfaceMesh box = test::voxel_surface(test::voxel_box(1, 1, 1));
  TetgenParams tp;
  tp.edge_length = 0.2;
  auto tets = std::make_shared<const TetMesh>(tetrahedralize(box, tp));
  auto seg = std::make_shared<const PolyCubeSegmentation>(segment_polycube(*tets));
  TetMesh other = *tets;
  other.V.conservativeResize(other.V.rows() - 1, 3);
  REQUIRE_THROWS_WITH(position_deform(tets, other, seg, {}), Catch::Contains("must share connectivity"));
  // A mode that does not exist is refused by the binding, with the choices listed.
  const NodeSpec* spec = Registry::instance().find("position_deform/chart_planes");
  REQUIRE(spec != nullptr);
  REQUIRE_THROWS_WITH(spec->check_params(json{{"final_solve", "magic"}}, "polycube"),
                      Catch::Contains("not one of: mvc_laplace, poisson"));
  CHECK(spec->check_params(json{{"level_placement", "push_up"}}, "polycube")["level_placement"] == "push_up");
  CHECK(spec->check_params(json::object(), "polycube")["map_polish"] == "everywhere");
  // A unit cube (diagonal sqrt 3) at h = 0.001 sqrt 3 would give about 1.9e8 hexes: refused before any solve,
  // with the smallest edge length that fits (0.001 * cbrt(1.92e8 / 2e7) = 0.00213).
  PositionDeformParams tiny;
  tiny.edge_length = 0.001;
  REQUIRE_THROWS_WITH(position_deform(tets, *tets, seg, tiny),
                      Catch::Contains("refused: edge_length 0.001 would give about 1.92e+08 hexes") &&
                          Catch::Contains("use edge_length >= 0.00213"));
}

TEST_CASE("position_deform saver (--save-all) writes the PolyCube tet mesh and the PolyCube surface with chart ids",
          "[position]") {
  SurfaceMesh box = test::voxel_surface(test::voxel_box(2, 1, 1), 0.5);
  PositionDeformParams p;
  p.edge_length = 0.1;
  Run r = run_pipeline(box, 0.15, p);
  auto [ext, saver] = Registry::instance().saver(artefact_name<PolyCubeMap>());
  REQUIRE(saver);
  CHECK(ext == ".polycube.vtk");
  auto dir = std::filesystem::temp_directory_path() / ("polyhex_pm_save_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  saver(make_artefact(std::make_shared<const PolyCubeMap>(r.map)), dir / ("m" + ext));
  REQUIRE(std::filesystem::exists(dir / "m.polycube.vtk"));
  REQUIRE(std::filesystem::exists(dir / "m.polycube_surface.vtk"));
  std::ifstream in(dir / "m.polycube_surface.vtk");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  CHECK_THAT(text,
             Catch::Contains("CELL_DATA " + std::to_string(r.seg->F.rows())) && Catch::Contains("SCALARS chart int"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("the three axes solved in parallel give the bit-identical map of a one-thread run", "[position]") {
  // the axes' CHOLMOD analyses (METIS, one process-wide random state) must not interleave; with lattice_spacing
  // input_volume the three Poisson steps run side by side before any level is rounded
  const LatticeSpacing spacing = GENERATE(LatticeSpacing::polycube, LatticeSpacing::input_volume);
  PositionDeformParams p;
  p.edge_length = 0.05;
  p.lattice_spacing = spacing;
  SurfaceMesh l = test::voxel_surface({{0, 0, 0}, {1, 0, 0}, {0, 0, 1}, {0, 1, 0}}, 0.5);
  Run serial, parallel;
  {
    oneapi::tbb::global_control one(oneapi::tbb::global_control::max_allowed_parallelism, 1);
    serial = run_pipeline(l, 0.05, p);
  }
  parallel = run_pipeline(l, 0.05, p);
  REQUIRE(serial.tets->V == parallel.tets->V);
  REQUIRE(serial.map.U.rows() == parallel.map.U.rows());
#ifndef POLYHEX_SANITIZED
  CHECK(serial.map.U == parallel.map.U);  // exact, not approximate
#else
  // Under the sanitizer build (-O1, the sanitizers' allocator) the two maps differ in the last bits (3 of
  // 3 runs, below Catch's printed digits; not traced, possibly alignment-dependent kernels in the solvers);
  // the release build, which the determinism tests cover, is bit-identical.
  CHECK((serial.map.U - parallel.map.U).cwiseAbs().maxCoeff() <= 1e-12 * (serial.map.U.cwiseAbs().maxCoeff() + 1));
#endif
  CHECK(serial.map.chart_plane == parallel.map.chart_plane);
  CHECK(serial.map.edge_length == parallel.map.edge_length);
  CHECK(serial.stats.ordered_pairs == parallel.stats.ordered_pairs);
  CHECK(serial.stats.planarity_error == parallel.stats.planarity_error);
  check_planes(parallel);
}

TEST_CASE("the mean value Laplace solve: diagonal preconditioner, incomplete LU fallback, same map", "[position]") {
  // With final_jacobi_iterations > 0 the final solve tries BiCGSTAB with the diagonal preconditioner first
  // and falls back to the incomplete LU when its iteration cap is hit; both solve one system to a relative
  // residual of 1e-12, so the maps agree to far below the hex edge, and the fallback really runs when the
  // cap is too small.
  PositionDeformParams p;
  p.edge_length = 0.05;
  p.untangle_iterations = 0;  // compare the solves themselves
  SurfaceMesh l = test::voxel_surface({{0, 0, 0}, {1, 0, 0}, {0, 0, 1}}, 0.5);
  CHECK(p.final_jacobi_iterations == 0);  // the default solves with the incomplete LU (position_deform.h)
  p.final_jacobi_iterations = 3000;
  Run jac = run_pipeline(l, 0.05, p);
  CHECK(jac.stats.final_ilu_axes == 0);
  CHECK(jac.stats.final_iterations > 0);
  PositionDeformParams q = p;
  q.final_jacobi_iterations = 0;
  Run ilu = run_pipeline(l, 0.05, q);
  CHECK(ilu.stats.final_ilu_axes == 3);
  PositionDeformParams capped = p;
  capped.final_jacobi_iterations = 1;
  Run cap = run_pipeline(l, 0.05, capped);
  CHECK(cap.stats.final_ilu_axes == 3);
  const double h = jac.map.edge_length;
  REQUIRE(jac.map.U.rows() == ilu.map.U.rows());
  CHECK((jac.map.U - ilu.map.U).cwiseAbs().maxCoeff() < 1e-8 * h);
  CHECK((cap.map.U - ilu.map.U).cwiseAbs().maxCoeff() < 1e-8 * h);
  CHECK(jac.map.chart_plane == ilu.map.chart_plane);
  check_planes(jac);
}

TEST_CASE("the final solve above final_ilu_max starts with the diagonal preconditioner, the same planes and map",
          "[position]") {
  // A final system with more unknowns than final_ilu_max is solved by BiCGSTAB with the diagonal preconditioner
  // (up to 5,000 iterations) where the default at this size factors the incomplete LU at once: both to a
  // relative residual of 1e-12, so the planes are the same integers and the maps agree to far below the hex edge.
  PositionDeformParams p;
  p.edge_length = 0.05;
  p.untangle_iterations = 0;  // compare the solves themselves
  SurfaceMesh l = test::voxel_surface({{0, 0, 0}, {1, 0, 0}, {0, 0, 1}}, 0.5);
  Run ilu = run_pipeline(l, 0.05, p);
  CHECK(ilu.stats.final_ilu_axes == 3);  // below final_ilu_max
  PositionDeformParams q = p;
  q.final_ilu_max = 0;
  Run large = run_pipeline(l, 0.05, q);
  CHECK(large.stats.final_ilu_axes == 0);
  CHECK(large.stats.final_iterations > 0);
  CHECK(large.map.chart_plane == ilu.map.chart_plane);
  REQUIRE(large.map.U.rows() == ilu.map.U.rows());
  CHECK((large.map.U - ilu.map.U).cwiseAbs().maxCoeff() < 1e-8 * ilu.map.edge_length);
  check_planes(large);
  // an explicit final_jacobi_iterations is the cap at any size: 1 iteration, then the incomplete LU
  q.final_jacobi_iterations = 1;
  CHECK(run_pipeline(l, 0.05, q).stats.final_ilu_axes == 3);
}

TEST_CASE("the Poisson step above poisson_direct_max: conjugate gradients give the factorization's planes and map",
          "[position]") {
  // Both solve one system, the iterative one to a relative residual of 1e-11 with its translation (the eps
  // pull's eigenvalue) set exactly: the chart planes are the same integers, and the maps (the final solve
  // started from either) agree to far below the hex edge.
  PositionDeformParams p;
  p.edge_length = 0.05;
  p.untangle_iterations = 0;  // compare the solves themselves
  p.map_polish = MapPolish::region;
  SurfaceMesh l = test::voxel_surface({{0, 0, 0}, {1, 0, 0}, {0, 0, 1}}, 0.5);
  Run direct = run_pipeline(l, 0.05, p);
  CHECK(direct.stats.poisson_cg_axes == 0);  // the default: factored at this size
  PositionDeformParams q = p;
  q.poisson_direct_max = 0;
  Run cg = run_pipeline(l, 0.05, q);
  CHECK(cg.stats.poisson_cg_axes == 3);
  CHECK(cg.map.chart_plane == direct.map.chart_plane);
  REQUIRE(cg.map.U.rows() == direct.map.U.rows());
  CHECK((cg.map.U - direct.map.U).cwiseAbs().maxCoeff() < 1e-8 * direct.map.edge_length);
  check_planes(cg);
}

TEST_CASE("position_deform reports its phases in order through the progress callback", "[position][progress]") {
  Run r = run_pipeline(test::voxel_surface(test::voxel_box(3, 2, 2)), 0.2, PositionDeformParams{}, false);
  std::vector<std::pair<double, std::string>> calls;
  position_deform(r.tets, r.deformed, r.seg, PositionDeformParams{}, nullptr,
                  [&](double f, const std::string& what) { calls.emplace_back(f, what); });
  REQUIRE(calls.size() == 3);
  CHECK(calls[0] == std::make_pair(0.0, std::string("chart planes, Poisson and final solves")));
  CHECK(calls[1].second == "untangling the map");
  CHECK(calls[2].second == "distortion");
  CHECK(calls[0].first < calls[1].first);
  CHECK(calls[1].first < calls[2].first);
  CHECK(calls[2].first < 1);
}
