// Boundary groups of a hex mesh (nodes/boundary_groups): the whole boundary, one group per PolyCube chart
// and one per sharp-edge patch, checked on the exact PolyCube map of an L-shaped voxel block.
#include "nodes/algorithms/hex_quality.h"
#include "nodes/artefacts/boundary_groups.h"
#include "nodes/boundary_groups/boundary_groups.h"
#include "nodes/hex_extract/hex_extract.h"
#include "runtime/errors.h"
#include "tests/helpers/voxel_maps.h"

#include <catch2/catch.hpp>

#include <set>

using namespace polyhex;
using Catch::Matchers::Contains;

namespace {

const std::vector<std::array<int, 3>> kL = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};

std::set<std::array<int, 2>> as_set(const BoundaryGroup& g) { return {g.faces.begin(), g.faces.end()}; }

}  // namespace

TEST_CASE("boundary_groups: boundary, charts and patches of an L block's lattice hexes", "[boundary_groups]") {
  const PolyCubeMap map = test::identity_map(kL, 2);
  const HexMesh hexes = extract_hexes(map);
  REQUIRE(hexes.H.rows() == 3 * 8);
  const SurfaceMesh surface = test::voxel_surface(kL);
  BoundaryGroupsStats s;
  const HexMesh out = add_boundary_groups(hexes, &map, &surface, {}, &s);
  CHECK(out.V == hexes.V);
  CHECK(out.H == hexes.H);
  CHECK(boundary_groups_problem(out).empty());

  const long expected_faces = hex_boundary_quads(hexes).rows();
  CHECK(expected_faces ==
        4 * (3 + 3 + 8));  // L of three unit voxels: area 14 (top, bottom, sides), 4 faces per unit square
  CHECK(s.boundary_faces == expected_faces);
  const size_t charts = map.segmentation->charts.size();
  CHECK(charts == 8);  // the L's eight planar sides
  CHECK(s.chart_groups == 8);
  CHECK(s.surface_patches == 8);
  CHECK(s.patch_groups == 8);
  CHECK(s.facing_away == 0);
  REQUIRE(out.groups.size() == 1 + 8 + 8);
  CHECK(out.groups[0].name == "boundary");
  CHECK(out.groups[0].faces.size() == size_t(expected_faces));

  const double h = map.edge_length;
  long chart_faces = 0, patch_faces = 0;
  std::vector<std::set<std::array<int, 2>>> chart_sets, patch_sets;
  for (const BoundaryGroup& g : out.groups) {
    if (g.family == "chart") {
      CHECK(g.name == "chart_" + std::to_string(g.id));
      chart_faces += long(g.faces.size());
      chart_sets.push_back(as_set(g));
      // every vertex of the group lies on its chart's plane, every face points along its label
      const int label = map.segmentation->charts[size_t(g.id)].label;
      const double plane = map.chart_plane[g.id] * h;
      for (const auto& [hex, face] : g.faces) {
        const auto q = hex_face_vertices(out, hex, face);
        for (int v : q) CHECK(out.V(v, label_axis(label)) == Approx(plane).margin(1e-9));
        const Eigen::Vector3d a = out.V.row(q[0]), b = out.V.row(q[1]), c = out.V.row(q[2]), d = out.V.row(q[3]);
        CHECK((c - a).cross(d - b).normalized().dot(label_dir(label)) == Approx(1.0));
      }
    } else if (g.family == "patch") {
      CHECK(g.name == "patch_" + std::to_string(g.id));
      patch_faces += long(g.faces.size());
      patch_sets.push_back(as_set(g));
    }
  }
  // charts and patches each partition the boundary, and on the L every chart is a planar side = one patch
  CHECK(chart_faces == expected_faces);
  CHECK(patch_faces == expected_faces);
  for (const auto& c : chart_sets) CHECK(std::count(patch_sets.begin(), patch_sets.end(), c) == 1);

  SECTION("families can be left out") {
    BoundaryGroupsParams p;
    p.charts = false;
    p.feature_angle = 0;
    const HexMesh only = add_boundary_groups(hexes, nullptr, nullptr, p);
    REQUIRE(only.groups.size() == 1);
    CHECK(only.groups[0].family == "boundary");
    p.feature_angle = 100;  // the L's 90-degree edges are not sharp enough: one patch
    CHECK(add_boundary_groups(hexes, nullptr, &surface, p).groups.size() == 2);
  }
  SECTION("missing inputs and bad parameters are named") {
    CHECK_THROWS_WITH(add_boundary_groups(hexes, nullptr, &surface), Contains("connect `map`"));
    CHECK_THROWS_WITH(add_boundary_groups(hexes, &map, nullptr), Contains("connect `surface`"));
    BoundaryGroupsParams p;
    p.feature_angle = 0.5;
    CHECK_THROWS_WITH(add_boundary_groups(hexes, &map, &surface, p), Contains("feature_angle = 0.5"));
    CHECK_THROWS_AS(add_boundary_groups(HexMesh{}, &map, &surface), InvalidInput);
  }
}
