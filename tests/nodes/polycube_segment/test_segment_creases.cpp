// [segment][features] The segmentation follows the input's creases (follow_creases, issue 23): a part's planar
// faces each take one label, and the creases along flat faces (features.h flat_face_creases) hold the normals'
// smoothing back, not a scan's faceting.
#include "nodes/algorithms/features.h"
#include "nodes/algorithms/shapes.h"
#include "nodes/polycube_segment/polycube_segment.h"
#include "nodes/polycube_segment/segment_internal.h"
#include "nodes/tetrahedralize/tetgen.h"
#include "tests/helpers/segment_fixtures.h"
#include "tests/helpers/surface_checks.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

using namespace polyhex;
using namespace polyhex::test;
using namespace polyhex::segment_detail;

namespace {

/// The part's faces: boundary triangles grouped by their normal (rounded to 1e-3).
std::map<std::array<long, 3>, std::set<int>> labels_by_normal(const TetMesh& m, const PolyCubeSegmentation& seg) {
  std::map<std::array<long, 3>, std::set<int>> out;
  for (int t = 0; t < int(seg.F.rows()); ++t) {
    const Eigen::Vector3d a = m.V.row(seg.F(t, 0)), b = m.V.row(seg.F(t, 1)), c = m.V.row(seg.F(t, 2));
    const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
    out[{std::lround(n.x() * 1e3), std::lround(n.y() * 1e3), std::lround(n.z() * 1e3)}].insert(seg.label(t));
  }
  return out;
}

}  // namespace

TEST_CASE("chamfered box: each planar face, the 45 degree chamfer too, is one label", "[segment][features]") {
  const SurfaceMesh surface = make_shape({"chamfered_box", 40});
  TetgenParams tp;
  tp.edge_length = 0.03;
  const TetMesh tets = tetrahedralize(surface, tp);
  PolyCubeSegmentParams p;
  p.hex_edge_length = 0.03;
  const PolyCubeSegmentation seg = segment_polycube(tets, p, &tets);
  REQUIRE(seg.valid);
  const auto faces = labels_by_normal(tets, seg);
  CHECK(faces.size() == 7);  // 6 box sides and the chamfer
  for (const auto& [normal, labels] : faces) {
    INFO("face normal (1e-3) " << normal[0] << " " << normal[1] << " " << normal[2]);
    CHECK(labels.size() == 1);
  }
}

TEST_CASE("input_creases: the patches are the faces between all creases; a crease along flat faces is a barrier",
          "[segment][features]") {
  // A slab 1 x 1 x 0.25 whose top carries a tent along y = 0.5 (ridge turning 90 degrees, feet 45) from x = 0 to
  // x = 0.5, fading to flat by x = 0.6: its three creases start on the side x = 0 and end inside the top.
  const auto fade = [](double x) {
    const double u = std::clamp((x - 0.5) / 0.1, 0.0, 1.0);
    return 1 - u * u * (3 - 2 * u);
  };
  const TetMesh m = voxel_tets(
      {32, 32, 8}, 1.0 / 32, [](int, int, int) { return true; },
      [&](const Point& q) {
        const double tent = fade(q.x()) * std::max(0.0, 0.25 - std::abs(q.y() - 0.5));
        return Point(q.x(), q.y(), q.z() * (1 + tent / 0.25));
      });
  const RowMatrixX3i F = boundary_triangles(m);
  const Surface s = build_surface(m.V, F);
  const double h = 1.0 / 32;
  const auto on_ridge = [&](int a, int b) {
    return std::abs(m.V(a, 1) - 0.5) < 1e-9 && std::abs(m.V(b, 1) - 0.5) < 1e-9 && m.V(a, 2) > 0.3 && m.V(b, 2) > 0.3;
  };
  const InputCreases c = input_creases(s, m.V, h);
  CHECK(c.patches == 6);  // the tent's creases end inside the top: it is one face with the tent
  int planar = 0;
  for (char q : c.planar) planar += q;
  CHECK(planar == 5);  // the top (with its tent) is not planar, the others are
  // the tent's sides are flat faces at the hex's scale: its ridge holds the smoothing back
  int ridge_barriers = 0;
  for (int t = 0; t < s.nf(); ++t)
    for (int k = 0; k < 3; ++k)
      if (c.edge[size_t(t)][size_t(k)]) ridge_barriers += on_ridge(F(t, k), F(t, (k + 1) % 3));
  CHECK(ridge_barriers >= 2 * 10);
}

TEST_CASE("input_creases: the edges between faces narrower than the hex's scale are no barrier",
          "[segment][features]") {
  // an octagonal prism of radius 2.2 and height 1.6 at h = 1: side faces of 2.7 h^2 (as a scan's facets as large as
  // a hex edge), caps of 13.7 h^2 (features.h flat_face_creases)
  TetgenParams tp;
  tp.edge_length = 0.06;
  const TetMesh m = tetrahedralize(fan_cylinder(8, 2.2, 1.6), tp);
  const RowMatrixX3i F = boundary_triangles(m);
  const Surface s = build_surface(m.V, F);
  const InputCreases c = input_creases(s, m.V, 1.0);
  int rim = 0, side = 0;
  for (int t = 0; t < s.nf(); ++t)
    for (int k = 0; k < 3; ++k)
      if (c.edge[size_t(t)][size_t(k)]) {
        const int a = F(t, k), b = F(t, (k + 1) % 3);
        const auto at = [&](double z) { return std::abs(m.V(a, 2) - z) < 1e-9 && std::abs(m.V(b, 2) - z) < 1e-9; };
        (at(0) || at(1.6) ? rim : side) += 1;
      }
  CHECK(side == 0);
  CHECK(rim >= 2 * 16);  // each rim edge (TetGen may split them) seen from both triangles
}
