// Feature fidelity (feature_fidelity.h), the scale test of sharp edges (features.h sharp_edges) and the
// quality node's feature figures, on shapes whose answers are known.
#include "nodes/algorithms/feature_fidelity.h"
#include "nodes/algorithms/features.h"
#include "nodes/algorithms/hex_quality.h"
#include "nodes/algorithms/shapes.h"
#include "nodes/quality/quality_json.h"
#include "tests/helpers/hex_fixtures.h"
#include "tests/helpers/surface_checks.h"
#include "tests/helpers/voxel_shapes.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <random>

using namespace polyhex;

namespace {

/// The 4 x 3 x 2 grid of unit cubes and its box [0,4]x[0,3]x[0,2] as 12 triangles.
struct BoxCase {
  HexMesh hexes = test::grid_hex_mesh(4, 3, 2);
  SurfaceMesh surface = test::box12(4, 3, 2);
};

FeatureFidelity fidelity(const HexMesh& m, const SurfaceMesh& s, double spacing = 0.05) {
  const auto Q = hex_boundary_quads(m);
  return feature_fidelity(m.V, Q, find_creases(s, kFeatureAngle, 1.5), kFeatureAngle, spacing);
}

}  // namespace

TEST_CASE("feature_fidelity: a box's hex grid has its 36 edges on the box's 12 creases", "[features]") {
  const BoxCase b;
  const FeatureFidelity f = fidelity(b.hexes, b.surface);
  CHECK(f.curves == 12);
  CHECK(f.curve_length == Approx(4 * (4 + 3 + 2)));
  CHECK(f.mesh_feature_edges == 4 * (4 + 3 + 2));
  CHECK(f.curve_to_mesh_max < 1e-12);
  CHECK(f.curve_to_mesh_mean < 1e-12);
  CHECK(f.mesh_to_curve_max < 1e-12);
  CHECK(median_boundary_edge(b.hexes.V, hex_boundary_quads(b.hexes)) == 1.0);
}

TEST_CASE("feature_fidelity: an edge of the hex boundary moved off its crease by d is d away, both ways",
          "[features]") {
  BoxCase b;
  const double d = 0.2;
  // the three inner vertices of the hex edge line y = z = 0 move into the box, d from the crease
  int moved = 0;
  for (Eigen::Index v = 0; v < b.hexes.V.rows(); ++v) {
    const Eigen::RowVector3d x = b.hexes.V.row(v);
    if (x[1] == 0 && x[2] == 0 && x[0] > 0 && x[0] < 4) {
      b.hexes.V(v, 1) = b.hexes.V(v, 2) = d / std::sqrt(2.0);
      ++moved;
    }
  }
  REQUIRE(moved == 3);
  const FeatureFidelity f = fidelity(b.hexes, b.surface);
  CHECK(f.curves == 12);
  CHECK(f.curve_to_mesh_max == Approx(d).margin(1e-12));
  CHECK(f.mesh_to_curve_max == Approx(d).margin(1e-12));
  // along the moved line: 0 at the two corners, d over [1, 3], linear between; over all 36 of crease length
  CHECK(f.curve_to_mesh_mean == Approx((2 * d + 2 * (d / 2)) / 36.0).margin(1e-3 * d));
}

TEST_CASE("feature_fidelity: a mesh without feature edges, and an input without creases", "[features]") {
  const BoxCase b;
  const auto Q = hex_boundary_quads(b.hexes);
  // at 179 degrees nothing is sharp: no line, no feature edge, no distance
  const FeatureFidelity none = feature_fidelity(b.hexes.V, Q, find_creases(b.surface, 179, 0), 179, 0.05);
  CHECK(none.curves == 0);
  CHECK(none.mesh_feature_edges == 0);
  CHECK(none.curve_to_mesh_max == 0);
  // the creases of a box against a hex mesh far away: the distance is exact there too (the grid's far search)
  HexMesh far = b.hexes;
  far.V.col(0).array() += 100.0;
  const FeatureFidelity f = fidelity(far, b.surface);
  CHECK(f.curve_to_mesh_max == Approx(100.0).epsilon(1e-9));
}

TEST_CASE("sharp_edges at a scale: a scan's faceting is not a crease, a box's edges still are", "[features]") {
  // a sphere of radius ~1 with its vertices moved radially at random by a fifth of an edge: many edges
  // turn by more than 40 degrees, none of them at the scale of a quarter of the radius
  ShapeParams sp;
  sp.name = "sphere";
  sp.resolution = 48;
  SurfaceMesh s = make_shape(sp);
  const Eigen::Vector3d c = s.V.colwise().mean().transpose();
  double edge = 0;
  for (int k = 0; k < 3; ++k) edge += (s.V.row(s.F(0, k)) - s.V.row(s.F(0, (k + 1) % 3))).norm() / 3;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.2 * edge, 0.2 * edge);
  for (Eigen::Index v = 0; v < s.V.rows(); ++v) {
    const Eigen::Vector3d x = s.V.row(v).transpose() - c;
    s.V.row(v) = (c + x * (1 + u(rng) / x.norm())).transpose();
  }
  const double radius = (s.V.rowwise() - c.transpose()).rowwise().norm().mean();
  CHECK(sharp_edges(s, kFeatureAngle).size() > 10);
  CHECK(sharp_edges(s, kFeatureAngle, 0.25 * radius).empty());
  CHECK(find_creases(s, kFeatureAngle, 0, 0.25 * radius).lines.empty());
  // a coarse sphere, its facets as large as the scale: sharp edges, but no sharper than the facets around them
  sp.resolution = 6;
  const SurfaceMesh coarse = make_shape(sp);
  double coarse_edge = 0;
  for (int k = 0; k < 3; ++k)
    coarse_edge += (coarse.V.row(coarse.F(0, k)) - coarse.V.row(coarse.F(0, (k + 1) % 3))).norm() / 3;
  CHECK_FALSE(sharp_edges(coarse, kFeatureAngle).empty());
  CHECK(sharp_edges(coarse, kFeatureAngle, coarse_edge).empty());
  // a finely tessellated box keeps its 12 edges at that scale
  const SurfaceMesh box = test::voxel_surface(test::voxel_box(6, 6, 6), 1.0 / 6);
  CHECK(sharp_edges(box, kFeatureAngle, 0.25).size() == sharp_edges(box, kFeatureAngle).size());
  const SurfaceCreases lines = find_creases(box, kFeatureAngle, 0.5, 0.25);
  CHECK(lines.lines.size() == 12);
  CHECK(lines.corners.size() == 8);
}

TEST_CASE("quality: feature figures of a hex grid against its box, relative to the bbox diagonal",
          "[features][quality]") {
  BoxCase b;
  QualityParams p;
  p.samples = 2000;
  HexQuality q = hex_quality(b.hexes, &b.surface, p);
  const double diag = std::sqrt(4.0 * 4 + 3 * 3 + 2 * 2);
  REQUIRE(q.has_features);
  CHECK(q.hex_edge == Approx(1.0 / diag));
  CHECK(q.features.curves == 12);
  CHECK(q.features.curve_length == Approx(36.0 / diag));
  nlohmann::json j = feature_json(q);
  CHECK_FALSE(to_json(q).contains("feature_curves"));  // hexcheck's keys alone
  CHECK(j.at("feature_curves") == 12);
  CHECK(j.at("feature_edges") == 36);
  CHECK(j.at("feature_curve_to_mesh_max").get<double>() < 1e-12);
  // off: no feature key at all
  p.feature_angle = 0;
  q = hex_quality(b.hexes, &b.surface, p);
  CHECK_FALSE(q.has_features);
  CHECK(feature_json(q).empty());
}
