// Sharp edges kept (issue 23), end to end with the default config: the built-in exact solids' creases on hex
// edges, their corners on hex vertices, and the boundary within a fraction of a hex edge of the surface.
#include "nodes/algorithms/features.h"
#include "nodes/algorithms/hex_quality.h"
#include "nodes/algorithms/shapes.h"
#include "nodes/algorithms/triangle_tree.h"
#include "nodes/formats/hexmesh_io.h"
#include "tests/helpers/cli.h"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <functional>
#include <vector>

using json = nlohmann::json;
namespace fs = std::filesystem;
using namespace polyhex;

namespace {

struct Meshed {
  json quality;  ///< the quality node's metrics
  HexMesh mesh;
  double h = 0;  ///< the hex edge, absolute (the quality node's median boundary edge)
};

/// Meshes `input` (a built-in `shape:NAME` or a file) with the default config; `tag` names the output folder.
Meshed mesh_input(const std::string& input, const std::string& tag, double hex_edge, const std::string& extra = "") {
  const fs::path out = test::fresh_dir("sharp_" + tag);
  const auto r = test::run_polyhex("run " + std::string(POLYHEX_SOURCE_DIR) + "/configs/default.json -i " + input +
                                   " --hex-edge " + std::to_string(hex_edge) + " --threads 2 --no-cache --out " +
                                   out.string() + (extra.empty() ? "" : " " + extra));
  INFO(r.out);
  REQUIRE(r.code == 0);
  Meshed m;
  m.quality = json::parse(test::read_text(out / "report.json"))["nodes"]["quality"]["metrics"];
  m.mesh = read_hexmesh(out / "hex.vtk");
  m.h = m.quality["hex_edge"].get<double>() * m.quality["bbox_diag"].get<double>();
  return m;
}

Meshed mesh_shape(const std::string& shape, double hex_edge, const std::string& extra = "") {
  return mesh_input("shape:" + shape, shape, hex_edge, extra);
}

/// The largest distance from the points of the polyline a -> b (every h / 100) where `keep` holds to the hex
/// mesh's boundary edges.
double line_to_edges(const HexMesh& m, const Eigen::Vector3d& a, const Eigen::Vector3d& b, double h,
                     const std::function<bool(const Eigen::Vector3d&)>& keep = {}) {
  const auto Q = hex_boundary_quads(m);
  double worst = 0;
  const int n = std::max(1, int(std::ceil((b - a).norm() / (h / 100))));
  for (int i = 0; i <= n; ++i) {
    const Eigen::Vector3d p = a + (double(i) / n) * (b - a);
    if (keep && !keep(p)) continue;
    double best = 1e300;
    for (Eigen::Index q = 0; q < Q.rows(); ++q)
      for (int k = 0; k < 4; ++k)
        best =
            std::min(best, segment_distance(p, m.V.row(Q(q, k)).transpose(), m.V.row(Q(q, (k + 1) % 4)).transpose()));
    worst = std::max(worst, best);
  }
  return worst;
}

}  // namespace

TEST_CASE("sharp features: an L-block at h = 0.05 keeps every crease on hex edges, Hausdorff max <= 0.3 h",
          "[features][cli]") {
  const Meshed m = mesh_shape("sharp_l_block", 0.05);
  CHECK(m.quality["inverted"] == 0);
  CHECK(m.quality["hausdorff_max"].get<double>() <= 0.3 * m.quality["hex_edge"].get<double>());
  // its 18 creases (feature_fidelity: the input's crease lines to the nearest boundary edge)
  CHECK(m.quality["feature_curves"] == 18);
  CHECK(m.quality["feature_curve_to_mesh_max"].get<double>() * m.quality["bbox_diag"].get<double>() <= 1e-3 * m.h);
}

TEST_CASE("sharp features: a box's 45 degree chamfer keeps both its creases on hex edges", "[features][cli]") {
  const Meshed m = mesh_shape("chamfered_box", 0.04);
  CHECK(m.quality["inverted"] == 0);
  // the chamfer's creases run along y at (x, z) = (0.85, 0.4) (a chart boundary of the PolyCube) and (1, 0.25)
  // (inside the chart that takes the chamfer: a lattice line of the map, feature_lines.h); away from their
  // ends, where the lattice shears round the chamfer's corners, they lie on hex edges
  auto middle = [&](const Eigen::Vector3d& p) { return p.y() > m.h && p.y() < 0.6 - m.h; };
  CHECK(line_to_edges(m.mesh, {0.85, 0, 0.4}, {0.85, 0.6, 0.4}, m.h, middle) <= 1e-3 * m.h);
  CHECK(line_to_edges(m.mesh, {1, 0, 0.25}, {1, 0.6, 0.25}, m.h, middle) <= 1e-3 * m.h);
  CHECK(m.quality["hausdorff_max"].get<double>() <= 0.5 * m.quality["hex_edge"].get<double>());
}

TEST_CASE("sharp features: a filleted cylinder's sharp rim is on hex edges, its fillet smooth", "[features][cli]") {
  const Meshed m = mesh_shape("filleted_cylinder", 0.03);
  CHECK(m.quality["inverted"] == 0);
  // the rim (radius R = 0.3 at z = 0.5) is the only crease: the fillet has none
  CHECK(m.quality["feature_curves"].get<int>() >= 1);
  // hex vertices on the rim (within 1e-3 h of the input's rim polygon), their edges chords of it: every point
  // of the rim is within a chord's sagitta L^2 / (8 R) of the boundary edges (L the longest chord), plus 1e-3 h
  const double R = 0.3;
  const SurfaceCreases rim = find_creases(make_shape({"filleted_cylinder", 64}), kFeatureAngle, 0);
  REQUIRE(rim.lines.size() == 1);
  auto on_rim = [&](const Eigen::Vector3d& x) { return (closest_on_line(rim.lines[0], x) - x).norm() <= 1e-3 * m.h; };
  const auto Q = hex_boundary_quads(m.mesh);
  double longest = 0;
  long rim_vertices = 0;
  std::vector<char> seen(size_t(m.mesh.V.rows()), 0);
  for (Eigen::Index q = 0; q < Q.rows(); ++q)
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector3d a = m.mesh.V.row(Q(q, k)).transpose(), b = m.mesh.V.row(Q(q, (k + 1) % 4)).transpose();
      if (on_rim(a) && !seen[size_t(Q(q, k))]) seen[size_t(Q(q, k))] = 1, ++rim_vertices;
      if (on_rim(a) && on_rim(b)) longest = std::max(longest, (b - a).norm());
    }
  CHECK(rim_vertices >= long(2 * M_PI * R / (1.5 * m.h)));
  // ... but at the top chart's four corners: the PolyCube puts a lattice corner where the rim runs on, and the
  // quad there must leave it (creases_at_vertices); at most 2 h of rim each, within a quarter hex edge
  const double bound = longest * longest / (8 * R) + 1e-3 * m.h;
  double off = 0, worst = 0;
  const auto& line = rim.lines[0];
  for (size_t i = 1; i < line.size(); ++i) {  // the rim's length farther than the bound, h / 20 at a time
    const double len = (line[i] - line[i - 1]).norm();
    const int n = int(std::ceil(len / (m.h / 20)));
    for (int k = 0; k < n; ++k) {
      const Eigen::Vector3d p = line[i - 1] + ((k + 0.5) / n) * (line[i] - line[i - 1]);
      const double d = line_to_edges(m.mesh, p, p, m.h);
      worst = std::max(worst, d);
      if (d > bound) off += len / n;
    }
  }
  CHECK(off <= 4 * 2 * m.h);
  CHECK(worst <= 0.25 * m.h);
  // the fillet is smooth: no hex feature edge far from the rim (mesh -> curve within a hex edge)
  CHECK(m.quality["feature_mesh_to_curve_max"].get<double>() * m.quality["bbox_diag"].get<double>() <= m.h);
}

TEST_CASE("sharp features: a ring whose top climbs and drops by a step keeps the step wall, Hausdorff max <= 0.5 h",
          "[features][cli]") {
  // stepped_ring's top is one smooth face on the step's top and at its foot: one plane for it flattens the wall
  // (chart_order.h, self bridges) and the mesh ramps over the step; the structure extraction cuts the top
  // between the two heights instead
  const Meshed m = mesh_shape("stepped_ring", 0.025);
  CHECK(m.quality["inverted"] == 0);
  CHECK(m.quality["hausdorff_max"].get<double>() <= 0.5 * m.quality["hex_edge"].get<double>());
  // the step's top edge (y = 0.4) and its foot (y = 0.3) along z = 0.5, away from the ends, near hex edges
  // (0.25 h at this size on 2026-12-03)
  auto middle = [&](const Eigen::Vector3d& p) { return p.x() > m.h && p.x() < 1.0 / 3 - m.h; };
  CHECK(line_to_edges(m.mesh, {0, 0.4, 0.5}, {1.0 / 3, 0.4, 0.5}, m.h, middle) <= 0.3 * m.h);
  CHECK(line_to_edges(m.mesh, {0, 0.3, 0.5}, {1.0 / 3, 0.3, 0.5}, m.h, middle) <= 0.3 * m.h);
  // without the order-cycle cuts the step is flattened: the hex boundary stands about a hex edge off it
  const Meshed flat = mesh_shape("stepped_ring", 0.025, "--set segment.split_order_cycles=false");
  CHECK(flat.quality["hausdorff_max"].get<double>() > 0.8 * flat.quality["hex_edge"].get<double>());
}

TEST_CASE("sharp features: a V-shaped slot's bottom is reached with polycube.feature_line_room, filled without",
          "[features][cli]") {
  // a block 1 x 0.6 x 0.5 with a slot cut along y from its top, walls from x = 0.45 / 0.55 at z = 0.5 down to the
  // bottom edge x = 0.5, z = 0.25 (they meet at 22.6 degrees), narrower than a hex edge for its last 3 h
  const fs::path dir = test::fresh_dir("sharp_v_slot_input");
  {
    const double P[7][2] = {{0, 0}, {1, 0}, {1, 0.5}, {0.55, 0.5}, {0.5, 0.25}, {0.45, 0.5}, {0, 0.5}};  // (x, z)
    std::string obj;
    for (double y : {0.0, 0.6})
      for (const auto& p : P)
        obj += "v " + std::to_string(p[0]) + " " + std::to_string(y) + " " + std::to_string(p[1]) + "\n";
    auto f = [&](int a, int b, int c) {
      obj += "f " + std::to_string(a + 1) + " " + std::to_string(b + 1) + " " + std::to_string(c + 1) + "\n";
    };
    for (int i : {5, 6, 0, 1, 2}) {  // the caps, fans from the slot's bottom vertex
      const int j = i == 6 ? 0 : i + 1;
      f(4, j, i);
      f(11, 7 + i, 7 + j);
    }
    for (int i = 0; i < 7; ++i) {
      const int j = (i + 1) % 7;
      f(i, j, 7 + j);
      f(i, 7 + j, 7 + i);
    }
    std::ofstream(dir / "v_slot.obj") << obj;
  }
  const std::string input = (dir / "v_slot.obj").string();
  const Meshed room = mesh_input(input, "v_slot_room", 0.02, "--set polycube.feature_line_room=true");
  CHECK(room.quality["inverted"] == 0);
  CHECK(room.quality["sj_min"].get<double>() > 0.5);  // 0.633 on 2026-12-07
  // the bottom edge, away from the ends, near the hex boundary's edges (0.24 h Hausdorff max on 2026-12-07)
  auto middle = [&](const Eigen::Vector3d& p) { return p.y() > room.h && p.y() < 0.6 - room.h; };
  CHECK(line_to_edges(room.mesh, {0.5, 0, 0.25}, {0.5, 0.6, 0.25}, room.h, middle) <= 0.5 * room.h);
  CHECK(room.quality["hausdorff_max"].get<double>() <= 0.5 * room.quality["hex_edge"].get<double>());
  // the default fills the slot's bottom: the boundary bridges it about 2 hex edges above the edge
  const Meshed filled = mesh_input(input, "v_slot_default", 0.02);
  CHECK(filled.quality["inverted"] == 0);
  CHECK(filled.quality["hausdorff_max"].get<double>() > filled.quality["hex_edge"].get<double>());
}
