// The whole chain tetrahedralize -> rotation_deform -> segment_polycube -> position_deform -> hex_extract
// -> pad -> optimize on built-in shapes and shared surfaces, measured with hex_quality (hexcheck figures).
#include "nodes/algorithms/hex_quality.h"
#include "nodes/algorithms/shapes.h"
#include "nodes/formats/surface_io.h"
#include "nodes/hex_extract/hex_extract.h"
#include "nodes/optimize/optimize.h"
#include "nodes/pad/pad.h"
#include "nodes/polycube_segment/polycube_segment.h"
#include "nodes/position_deform/position_deform.h"
#include "nodes/rotation_deform/rotation_deform.h"
#include "nodes/tetrahedralize/tetgen.h"

#include <catch2/catch.hpp>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>

using namespace polyhex;

namespace {

struct ChainResult {
  HexExtractStats extract;
  PadStats pad;
  OptimizeStats opt;
  HexQuality q;
  long tets = 0;
  double t_tet = 0, t_rot = 0, t_seg = 0, t_pos = 0;
  HexMesh mesh;
};

double since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// Runs the chain; h and the tet edge are fractions of the bbox diagonal.
ChainResult run_chain(const SurfaceMesh& s, double h, double tet_edge, double opt_budget = 30) {
  ChainResult r;
  auto t = std::chrono::steady_clock::now();
  TetgenParams tp;
  tp.edge_length = tet_edge;
  auto tets = std::make_shared<const TetMesh>(tetrahedralize(s, tp));
  r.tets = tets->T.rows();
  r.t_tet = since(t);
  t = std::chrono::steady_clock::now();
  TetMesh deformed = rotation_deform(*tets, RotationDeformParams{}).mesh;
  r.t_rot = since(t);
  t = std::chrono::steady_clock::now();
  PolyCubeSegmentParams sp;
  sp.hex_edge_length = h;
  sp.allow_invalid = true;
  auto seg = std::make_shared<const PolyCubeSegmentation>(segment_polycube(deformed, sp));
  r.t_seg = since(t);
  t = std::chrono::steady_clock::now();
  PositionDeformParams pp;
  pp.edge_length = h;
  PolyCubeMap map = position_deform(tets, deformed, seg, pp);
  r.t_pos = since(t);
  HexMesh hm = extract_hexes(map, {}, &r.extract);
  HexMesh padded = pad_boundary(hm, &s, {}, &r.pad);
  OptimizeParams op;
  op.time_budget = opt_budget;
  r.mesh = optimize_hexes(padded, s, op, &r.opt);
  QualityParams qp;
  qp.samples = 20000;
  r.q = hex_quality(r.mesh, &s, qp);
  return r;
}

std::string row(const std::string& name, const ChainResult& r) {
  char buf[600];
  std::snprintf(
      buf, sizeof buf,
      "%-16s tets %7ld | hexes %7ld inv %ld (extract inv %ld, unlocated %ld, skipped %ld) | SJ min %.3f avg %.3f "
      "(before opt %.3f/%.3f) | irr %.1f%% | haus mean %.2e max %.2e | t tet %.1f rot %.1f seg %.1f pos %.1f "
      "hex %.1f pad %.1f opt %.1f s",
      name.c_str(), r.tets, r.q.hexes, r.q.inverted, r.extract.inverted, r.extract.unlocated, r.extract.hexes_skipped,
      r.q.sj_min, r.q.sj_avg, r.opt.sj_min_before, r.opt.sj_avg_before, r.q.irregular_pct, r.q.hausdorff_mean,
      r.q.hausdorff_max, r.t_tet, r.t_rot, r.t_seg, r.t_pos, r.extract.seconds, r.pad.seconds, r.opt.seconds);
  return buf;
}

void check_result(const ChainResult& r) {
  CHECK(r.q.inverted == 0);
  CHECK(r.opt.inverted_after == 0);
  CHECK(r.q.sj_min > 0);
  CHECK(r.q.nonmanifold_boundary_edges == 0);
  CHECK(r.q.faces_shared_by_more_than_two == 0);
  CHECK(r.opt.boundary_distance_max < 1e-9);
}

}  // namespace

TEST_CASE("the whole chain on the built-in L-block gives a valid all-hex mesh", "[hex][optimize]") {
  ShapeParams sp;
  sp.name = "l_block";
  sp.resolution = 32;
  SurfaceMesh s = make_shape(sp);
  ChainResult r = run_chain(s, 0.04, 0.05, 10);
  WARN(row("l_block", r));
  check_result(r);
  CHECK(r.q.hexes > 100);
  CHECK(r.q.sj_avg > 0.8);
  CHECK(r.q.hausdorff_mean < 0.01);
}

TEST_CASE("chain figures on built-in shapes (bench, run on demand)", "[.hexbench]") {
  const char* env = std::getenv("POLYHEX_HEX_H");
  const double h = env ? std::atof(env) : 0.02;
  for (std::string name : {"l_block", "rod_with_holes", "fandisk_like"}) {
    ShapeParams sp;
    sp.name = name;
    SurfaceMesh s = make_shape(sp);
    ChainResult r = run_chain(s, h, 1.5 * h, 60);
    WARN(row(name, r));
    check_result(r);
  }
}

TEST_CASE("chain figures on shared surfaces", "[shared][hex_shared]") {
  const std::filesystem::path dir = std::filesystem::path(POLYHEX_SHARED_DIR) / "data" / "surfaces";
  if (!std::filesystem::exists(dir)) {
    WARN("no shared data at " << dir << ": skipped");
    SUCCEED();
    return;
  }
  const char* env = std::getenv("POLYHEX_HEX_H");
  const double h = env ? std::atof(env) : 0.02;
  for (std::string name : {"bunny.off", "fandisk.off", "rockerarm.obj"}) {
    SurfaceMesh s = read_surface(dir / name);
    ChainResult r = run_chain(s, h, 1.5 * h, 20);
    WARN(row(name, r));
    check_result(r);
  }
}
