// [segment][shared]: the real pipeline (tetrahedralize -> rotation_deform -> polycube_segment) on
// ten fast models of ../shared/data/surfaces gives valid PolyCube structures (paper §5.1, "for all inputs
// tested, these two splitting rules have produced valid PolyCube structures").
#include "nodes/formats/surface_io.h"
#include "nodes/orient/orient.h"
#include "nodes/polycube_segment/polycube_segment.h"
#include "nodes/rotation_deform/rotation_deform.h"
#include "nodes/tetrahedralize/tetgen.h"
#include "tests/helpers/segment_fixtures.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <filesystem>

using namespace polyhex;

namespace {

double hex_edge(const TetMesh& m) {
  return PolyCubeSegmentParams{}.hex_edge_length * (m.V.colwise().maxCoeff() - m.V.colwise().minCoeff()).norm();
}

/// Largest span of a chart along its own axis (fixtures.h chart_span).
double max_chart_span(const TetMesh& m, const PolyCubeSegmentation& s) {
  double out = 0;
  for (size_t c = 0; c < s.charts.size(); ++c) out = std::max(out, test::chart_span(m, s, int(c)));
  return out;
}

/// The rotation-driven deformation of a shared model tetrahedralized at tet edge `edge`; false (and a
/// WARN) when ../shared is not there.
bool deformed_shared(const char* file, double edge, TetMesh& out) {
  const std::filesystem::path f = std::filesystem::path(POLYHEX_SHARED_DIR) / "data" / "surfaces" / file;
  if (!std::filesystem::exists(f)) {
    WARN("skipped: " << f << " missing");
    return false;
  }
  TetgenParams tp;
  tp.edge_length = edge;
  out = rotation_deform(tetrahedralize(read_surface(f), tp), RotationDeformParams{}).mesh;
  return true;
}

}  // namespace

TEST_CASE("shared surfaces: tetrahedralize, rotation_deform, polycube_segment give valid structures",
          "[segment][shared]") {
  const std::filesystem::path dir = std::filesystem::path(POLYHEX_SHARED_DIR) / "data" / "surfaces";
  if (!std::filesystem::is_directory(dir)) {
    WARN("skipped: " << dir << " missing");
    SUCCEED();
    return;
  }
  // The fast models (CAD and small scans); the whole folder takes minutes and is measured outside
  // the test suite (see the report of issue 4).
  const char* models[] = {"8-connected.stl",
                          "cuboid_screw_thread.stl",
                          "cuboid_torus_with_step.stl",
                          "cuboid_tray_with_step.stl",
                          "in-volume_knot.stl",
                          "in-volume_twist.stl",
                          "mambo_B0.obj",
                          "mambo_S3.off",
                          "fandisk.off",
                          "kitten.off"};
  std::vector<std::filesystem::path> files;
  for (const char* m : models) files.push_back(dir / m);
  TetgenParams tp;
  tp.edge_length = 0.06;  // coarse, so 28 models run in about a minute
  for (auto& f : files) {
    auto t0 = std::chrono::steady_clock::now();
    REQUIRE(std::filesystem::exists(f));
    TetMesh tets = tetrahedralize(read_surface(f), tp);
    TetMesh deformed = rotation_deform(tets, RotationDeformParams{}).mesh;
    PolyCubeSegmentation s = segment_polycube(deformed);
    double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    INFO(f.filename().string() << ": " << (s.problems.empty() ? "" : s.problems.front()));
    CHECK(s.valid);
    CHECK(s.charts.size() >= 6);
    CHECK(s.corners.size() >= 8);
    if (s.valid)
      for (auto& c : s.corners) CHECK(c.valence == 3);
    // the twisted bar's helical strips are ramps (polycube_segment.h): cut until every chart is flat
    if (f.filename() == "in-volume_twist.stl") {
      CHECK(s.splits_ramp > 0);
      CHECK(max_chart_span(deformed, s) <= PolyCubeSegmentParams{}.ramp_extent * hex_edge(deformed));
      // its order evidence contradicts itself (4 cycle-closing pairs at this tet size with the cuts off,
      // measured at 29978f4); the order-cycle cuts (on by default) leave fewer (1 at this coarse size, none at
      // the default configs' tet edge 0.02), and report what is left
      PolyCubeSegmentParams off;
      off.split_order_cycles = false;
      const PolyCubeSegmentation s0 = segment_polycube(deformed, off);
      CHECK(s0.splits_order_cycle == 0);
      CHECK(s0.order_cycles == -1);  // not measured when off
      const int before = count_order_cycles(deformed, s0, PolyCubeSegmentParams{}.hex_edge_length);
      CHECK(before > 0);
      CHECK(s.splits_order_cycle > 0);
      CHECK(s.order_cycles == count_order_cycles(deformed, s, PolyCubeSegmentParams{}.hex_edge_length));
      CHECK(s.order_cycles < before);
      CHECK(s.charts.size() > s0.charts.size());
    }
    WARN(f.filename().string() << ": " << tets.T.rows() << " tets, charts " << s.charts.size() << ", corners "
                               << s.corners.size() << ", edges " << s.edges.size() << ", splits multi/wedge/ramp "
                               << s.splits_multi_orientation << "/" << s.splits_wedge << "/" << s.splits_ramp
                               << ", order cycles cut/left " << s.splits_order_cycle << "/" << s.order_cycles
                               << ", removed small " << s.removed_small << ", smoothing " << s.smoothing_iterations
                               << ", valid " << s.valid << ", " << seconds << " s");
  }
}

// fertility at tet edge 0.03: after the wedge cuts and the small-chart removal, a +Y and a -Y chart met
// along a curve (invalid: "chart 10 (+Y) and chart 17 (-Y) are neighbours on the same axis"); the
// repair's second multi-orientation split separates them.
TEST_CASE("shared fertility: opposite charts that meet after the wedge cuts get a separating chart",
          "[segment][shared]") {
  TetMesh deformed;
  if (!deformed_shared("fertility.off", 0.03, deformed)) {
    SUCCEED();
    return;
  }
  const PolyCubeSegmentation s = segment_polycube(deformed);
  INFO((s.problems.empty() ? std::string("valid") : s.problems.front()));
  CHECK(s.valid);
  CHECK(s.splits_multi_orientation >= 2);
  for (auto& c : s.corners) CHECK(c.valence == 3);
}

// The screw thread: a square bar winding around a cuboid, its faces tilted by 7 degrees, so each of
// its Y faces is one chart climbing ~28 hex edges along Y (the rotation-driven deformation cannot
// flatten a helix). Before the ramp split its PolyCube map folded and 13 hexes stayed inverted. At the
// tet edge of configs/polycube.json (0.02; at 0.06 one tet spans the bar).
TEST_CASE("shared cuboid_screw_thread: the helical strips are cut into flat charts", "[segment][shared]") {
  TetMesh deformed;
  if (!deformed_shared("cuboid_screw_thread.stl", 0.02, deformed)) {
    SUCCEED();
    return;
  }
  PolyCubeSegmentParams p;
  p.split_ramps = false;
  const PolyCubeSegmentation before = segment_polycube(deformed, p);
  CHECK(max_chart_span(deformed, before) > 2 * p.ramp_extent * hex_edge(deformed));
  const PolyCubeSegmentation s = segment_polycube(deformed);
  INFO((s.problems.empty() ? std::string("valid") : s.problems.front()));
  CHECK(s.valid);
  CHECK(s.splits_ramp > 0);
  CHECK(s.charts.size() > before.charts.size());
  CHECK(max_chart_span(deformed, s) <= p.ramp_extent * hex_edge(deformed));
  for (auto& c : s.corners) CHECK(c.valence == 3);
}

// femur at tet edge 0.019: the repairs (island cuts, corner patches, the second multi-orientation
// split) left three small charts with 2 neighbours each (0.02-0.13 % of the area; at 58f59cb the structure
// was invalid with every fallback smoothing); they are now removed once more after the repairs.
TEST_CASE("shared femur: small charts the repairs leave with < 4 neighbours are removed", "[segment][shared]") {
  TetMesh deformed;
  if (!deformed_shared("femur.obj", 0.019, deformed)) {
    SUCCEED();
    return;
  }
  const PolyCubeSegmentation s = segment_polycube(deformed);
  INFO((s.problems.empty() ? std::string("valid") : s.problems.front()));
  CHECK(s.valid);
  CHECK(s.smoothing_iterations == PolyCubeSegmentParams{}.smoothing_iterations);  // no fallback needed
  for (auto& c : s.charts) CHECK(c.neighbours.size() >= 4);
  for (auto& c : s.corners) CHECK(c.valence == 3);
}

// femur turned by the fixed rotation of tools/make_results.py (rotation_of("femur")), meshed in the frame the
// orientation search runs first: the repairs left two charts of opposite directions side by side and a
// 4-valent corner where two small charts met (the structure invalid with every fallback smoothing and in every
// retry variant; the run then fell back on the input frame, 0.189 / 0.894 against the unturned 0.430 / 0.937).
// The small charts the problems name are now removed one at a time, each kept when the structure improves.
TEST_CASE("shared femur, turned: the small charts the last problems name are removed, the structure valid",
          "[segment][shared]") {
  const std::filesystem::path f = std::filesystem::path(POLYHEX_SHARED_DIR) / "data" / "surfaces" / "femur.obj";
  if (!std::filesystem::exists(f)) {
    WARN("skipped: " << f << " missing");
    SUCCEED();
    return;
  }
  Eigen::Matrix3d turn;
  turn << 0.36025166837703526, 0.5877574748179428, -0.7244031241147416, -0.14222302668918782, 0.8020715288186764,
      0.5800464406733634, 0.921949752487048, -0.1059358931340382, 0.37254025344244945;
  SurfaceMesh s = read_surface(f);
  s.V = s.V * turn.transpose();
  const Frames frames = orient_frames(s, OrientParams{});
  const FrameCandidate* first = frames.of_branch(1);
  REQUIRE(first != nullptr);
  CHECK(first->source != "input");  // the turned copy is meshed in a frame of its own
  TetMesh tets = tetrahedralize(s, TetgenParams{});
  tets.V = tets.V * first->R.transpose();
  const TetMesh deformed = rotation_deform(tets, RotationDeformParams{}).mesh;
  const PolyCubeSegmentation seg = segment_polycube(deformed, PolyCubeSegmentParams{}, &tets);
  INFO((seg.problems.empty() ? std::string("valid") : seg.problems.front()));
  CHECK(seg.valid);
  for (auto& c : seg.charts) CHECK(c.neighbours.size() >= 4);
  for (auto& c : seg.corners) CHECK(c.valence == 3);
}
