#include "nodes/algorithms/reference_length.h"
#include "nodes/algorithms/shapes.h"
#include "tests/helpers/rotations.h"

#include <catch2/catch.hpp>

#include <cmath>

using namespace polyhex;

TEST_CASE("reference length of an axis-aligned box is its diagonal, bit for bit", "[reference_length]") {
  const SurfaceMesh box = make_shape({"box", 8});
  const Eigen::Vector3d extent = box.V.colwise().maxCoeff() - box.V.colwise().minCoeff();
  CHECK(reference_length(box.V) == extent.norm());
}

TEST_CASE("reference length does not change when the shape turns", "[reference_length]") {
  for (const char* name : {"box", "l_block", "fandisk_like", "torus", "bent_pipe"}) {
    const SurfaceMesh s = make_shape({name, 32});
    const double L = reference_length(s.V);
    const double aabb = (s.V.colwise().maxCoeff() - s.V.colwise().minCoeff()).norm();
    INFO(name << ": reference " << L << ", axis-aligned diagonal " << aabb);
    CHECK(L <= aabb);
    for (unsigned seed : {1u, 2u, 3u, 4u}) {
      const Eigen::Matrix3d R = test::seeded_rotation(seed);
      const SurfaceMesh r = test::rotated(s, R);
      const double turned_aabb = (r.V.colwise().maxCoeff() - r.V.colwise().minCoeff()).norm();
      INFO("seed " << seed << ": turned axis-aligned diagonal " << turned_aabb);
      CHECK(std::abs(reference_length(r.V) - L) <= 1e-6 * L);
    }
  }
}

TEST_CASE("reference length of a box turned about one axis is the box's diagonal", "[reference_length]") {
  // A 4 x 2 x 1 box turned 30 degrees about z: its axis-aligned diagonal grows, the reference does not.
  RowMatrixX3d V(8, 3);
  for (int i = 0; i < 8; ++i) V.row(i) << 4.0 * (i & 1), 2.0 * ((i >> 1) & 1), 1.0 * ((i >> 2) & 1);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(M_PI / 6, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const RowMatrixX3d T = V * R.transpose();
  CHECK(rotated_bbox_diagonal(T, Eigen::Matrix3d::Identity()) > std::sqrt(21.0) * 1.05);
  CHECK(reference_length(T) == Approx(std::sqrt(21.0)).epsilon(1e-9));
}

TEST_CASE("reference length of degenerate point sets", "[reference_length]") {
  RowMatrixX3d one(1, 3);
  one << 1, 2, 3;
  CHECK(reference_length(one) == 0);
  RowMatrixX3d flat(6, 3);  // a 3 x 4 rectangle in a plane: its diagonal, 5
  flat << 0, 0, 0, 3, 0, 0, 0, 4, 0, 3, 4, 0, 1, 1, 0, 2, 3, 0;
  CHECK(reference_length(flat) == Approx(5.0).epsilon(1e-9));
  CHECK_THROWS(reference_length(RowMatrixX3d(0, 3)));
}
