// [triangle-tree] the ray query of the triangle tree against a box's exact answer and a brute-force search.
#include "nodes/algorithms/shapes.h"
#include "nodes/algorithms/triangle_tree.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <random>

using namespace polyhex;

TEST_CASE("triangle tree: a ray from a box's centre crosses its face at the half extent", "[triangle-tree]") {
  const SurfaceMesh box = make_shape({"box", 8});  // centred at the origin
  const Eigen::Vector3d half = 0.5 * (box.V.colwise().maxCoeff() - box.V.colwise().minCoeff()).transpose();
  const TriangleTree tree(box.V, box.F);
  for (int a = 0; a < 3; ++a)
    for (double sign : {-1.0, 1.0}) {
      Eigen::Vector3d d = Eigen::Vector3d::Zero();
      d[a] = 2 * sign;                                // t is in units of |d|
      const Eigen::Vector3d o(0.013, -0.021, 0.007);  // off the lattice's vertices and edges
      const auto [t, f] = tree.first_crossing(o, d, 0);
      INFO("axis " << a << " sign " << sign);
      CHECK(t * 2 == Approx(half[a] - sign * o[a]).epsilon(1e-12));
      REQUIRE(f >= 0);
      for (int k = 0; k < 3; ++k) CHECK(box.V(box.F(f, k), a) == Approx(sign * half[a]));
      // from the face itself, past it (t_min): nothing further out
      CHECK(std::isinf(tree.first_crossing(o + t * d, d, 1e-9).first));
    }
}

TEST_CASE("triangle tree: the first crossing is the nearest of all triangles the ray crosses", "[triangle-tree]") {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  const int n = 200;
  RowMatrixX3d V(3 * n, 3);
  for (Eigen::Index i = 0; i < V.size(); ++i) V.data()[i] = u(rng);
  RowMatrixX3i F(n, 3);
  for (int f = 0; f < n; ++f) F.row(f) << 3 * f, 3 * f + 1, 3 * f + 2;
  const TriangleTree tree(V, F);
  int crossed = 0;
  for (int k = 0; k < 400; ++k) {
    const Eigen::Vector3d o(u(rng), u(rng), u(rng)), d(u(rng), u(rng), u(rng));
    // brute force, another way: the ray meets each triangle's plane at t, inside when the three sub-triangles'
    // areas around that point have the triangle's orientation
    double best = INFINITY;
    int which = -1;
    for (int f = 0; f < n; ++f) {
      const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
      const Eigen::Vector3d nrm = (b - a).cross(c - a);
      const double t = nrm.dot(a - o) / nrm.dot(d);
      if (!(t > 0) || !(t < best)) continue;
      const Eigen::Vector3d p = o + t * d;
      if ((b - a).cross(p - a).dot(nrm) >= 0 && (c - b).cross(p - b).dot(nrm) >= 0 &&
          (a - c).cross(p - c).dot(nrm) >= 0)
        best = t, which = f;
    }
    const auto [t, f] = tree.first_crossing(o, d, 0);
    INFO("ray " << k);
    CHECK(f == which);
    if (which >= 0) {
      ++crossed;
      CHECK(t == Approx(best).epsilon(1e-10));
    } else {
      CHECK(std::isinf(t));
    }
  }
  CHECK(crossed > 50);  // the rays do cross the soup
}
