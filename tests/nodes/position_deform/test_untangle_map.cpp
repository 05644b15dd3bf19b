// Untangling of the PolyCube map: folds undone, chart planes kept exactly, flat tets left alone.
#include "nodes/position_deform/untangle_map.h"

#include <Eigen/Dense>
#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <limits>
#include <map>

using namespace polyhex;

namespace {

/// The cube [0,n]^3 as a grid of unit cubes, each split into 6 tets along its main diagonal (Kuhn), all
/// positively oriented; fixed_axes marks the coordinates a boundary vertex keeps (the box's face planes).
struct Grid {
  RowMatrixX3d X;
  RowMatrixX4i T;
  std::vector<std::uint8_t> fixed;
  int n = 0;
  int id(int i, int j, int k) const { return (i * (n + 1) + j) * (n + 1) + k; }
};

Grid grid(int n) {
  Grid g;
  g.n = n;
  const int nv = (n + 1) * (n + 1) * (n + 1);
  g.X.resize(nv, 3);
  g.fixed.assign(size_t(nv), 0);
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j)
      for (int k = 0; k <= n; ++k) {
        const int v = g.id(i, j, k);
        g.X.row(v) << i, j, k;
        const int c[3] = {i, j, k};
        for (int a = 0; a < 3; ++a)
          if (c[a] == 0 || c[a] == n) g.fixed[size_t(v)] |= std::uint8_t(1 << a);
      }
  std::vector<std::array<int, 4>> tets;
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k)
        for (const auto& p : perms) {
          int c[3] = {i, j, k};
          std::array<int, 4> t;
          t[0] = g.id(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[p[s]];
            t[size_t(s + 1)] = g.id(c[0], c[1], c[2]);
          }
          const Eigen::Vector3d a = g.X.row(t[0]);
          const double vol = (Eigen::Vector3d(g.X.row(t[1])) - a)
                                 .dot((Eigen::Vector3d(g.X.row(t[2])) - a).cross(Eigen::Vector3d(g.X.row(t[3])) - a));
          if (vol < 0) std::swap(t[2], t[3]);
          tets.push_back(t);
        }
  g.T.resize(Eigen::Index(tets.size()), 4);
  for (size_t t = 0; t < tets.size(); ++t)
    for (int k = 0; k < 4; ++k) g.T(Eigen::Index(t), k) = tets[t][size_t(k)];
  return g;
}

long inverted(const RowMatrixX3d& U, const RowMatrixX4i& T) {
  long n = 0;
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    const Eigen::Vector3d a = U.row(T(t, 0));
    n += (Eigen::Vector3d(U.row(T(t, 1))) - a)
             .dot((Eigen::Vector3d(U.row(T(t, 2))) - a).cross(Eigen::Vector3d(U.row(T(t, 3))) - a)) <= 0;
  }
  return n;
}

/// Every boundary vertex keeps its fixed coordinates bit for bit.
void check_planes_kept(const Grid& g, const RowMatrixX3d& U0, const RowMatrixX3d& U) {
  for (Eigen::Index v = 0; v < U.rows(); ++v)
    for (int a = 0; a < 3; ++a)
      if (g.fixed[size_t(v)] >> a & 1) REQUIRE(U(v, a) == U0(v, a));
}

}  // namespace

TEST_CASE("an interior fold of the map is untangled, the box's planes do not move", "[position][untangle]") {
  Grid g = grid(4);
  RowMatrixX3d U = g.X;
  U.row(g.id(2, 2, 2)) += Eigen::RowVector3d(1.6, 0.4, -0.3);  // past its neighbours: a fold
  const RowMatrixX3d U0 = U;
  const long before = inverted(U, g.T);
  REQUIRE(before > 0);
  MapUntangleStats st;
  const long left = untangle_polycube_map(g.X, g.T, U, g.fixed, MapUntangleParams{}, &st);
  CHECK(left == 0);
  CHECK(inverted(U, g.T) == 0);
  CHECK(st.inverted_before == before);
  CHECK(st.flat == 0);
  CHECK(st.free_vertices > 1);
  check_planes_kept(g, U0, U);
}

TEST_CASE("a chart vertex folded in its plane slides back, keeping the plane", "[position][untangle]") {
  Grid g = grid(4);
  RowMatrixX3d U = g.X;
  const int v = g.id(0, 2, 2);  // on the plane x = 0, free in y and z
  U.row(v) += Eigen::RowVector3d(0, 1.5, 0.4);
  const RowMatrixX3d U0 = U;
  REQUIRE(inverted(U, g.T) > 0);
  const long left = untangle_polycube_map(g.X, g.T, U, g.fixed);
  CHECK(left == 0);
  CHECK(inverted(U, g.T) == 0);
  check_planes_kept(g, U0, U);
  CHECK(U(v, 0) == 0.0);
  CHECK(U(v, 1) < 3.0);  // it moved back between its neighbours
}

TEST_CASE("with no rounds the map is left as it is", "[position][untangle]") {
  Grid g = grid(3);
  RowMatrixX3d U = g.X;
  U.row(g.id(1, 1, 1)) += Eigen::RowVector3d(1.5, 0, 0);
  const RowMatrixX3d U0 = U;
  MapUntangleParams p;
  p.rounds = 0;
  MapUntangleStats st;
  const long left = untangle_polycube_map(g.X, g.T, U, g.fixed, p, &st);
  CHECK(left == inverted(U0, g.T));
  CHECK(left > 0);
  CHECK(U == U0);
  CHECK(st.lbfgs_iterations == 0);
}

TEST_CASE("a tet with its four vertices on one chart plane is flat: counted, left out, nothing moves for it",
          "[position][untangle]") {
  RowMatrixX3d X(4, 3);
  X << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  RowMatrixX4i T(1, 4);
  T << 0, 1, 2, 3;
  RowMatrixX3d U = X;
  U(3, 2) = 0;  // all four on the plane z = 0
  const std::vector<std::uint8_t> fixed(4, std::uint8_t(4));
  const RowMatrixX3d U0 = U;
  MapUntangleStats st;
  CHECK(untangle_polycube_map(X, T, U, fixed, MapUntangleParams{}, &st) == 1);
  CHECK(st.flat == 1);
  CHECK(st.free_vertices == 0);
  CHECK(U == U0);
}

namespace {
/// Mean over the tets of the conformal distortion |J|_F² / (3 det(J)^{2/3}) of the map X -> U (1 for a
/// similarity, more otherwise); +inf if a tet is inverted.
double mean_conformal_distortion(const RowMatrixX3d& X, const RowMatrixX3d& U, const RowMatrixX4i& T) {
  double sum = 0;
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    Eigen::Matrix3d D, E;
    for (int k = 0; k < 3; ++k) {
      D.col(k) = (X.row(T(t, k + 1)) - X.row(T(t, 0))).transpose();
      E.col(k) = (U.row(T(t, k + 1)) - U.row(T(t, 0))).transpose();
    }
    const Eigen::Matrix3d J = E * D.inverse();
    const double det = J.determinant();
    if (det <= 0) return std::numeric_limits<double>::infinity();
    sum += J.squaredNorm() / (3 * std::cbrt(det * det));
  }
  return sum / double(T.rows());
}
}  // namespace

TEST_CASE("polish_everywhere: a map without folds moves towards a conformal one, planes kept, none inverted",
          "[position][untangle]") {
  Grid g = grid(5);
  RowMatrixX3d U = g.X;
  // an interior bump along x, zero on the box's faces: a smooth, fold-free, non-conformal map
  const double pi = 3.14159265358979323846;
  for (Eigen::Index v = 0; v < U.rows(); ++v) {
    const double s = std::sin(pi * g.X(v, 0) / 5) * std::sin(pi * g.X(v, 1) / 5) * std::sin(pi * g.X(v, 2) / 5);
    U(v, 0) += 0.6 * s;
  }
  REQUIRE(inverted(U, g.T) == 0);
  const RowMatrixX3d U0 = U;
  const double before = mean_conformal_distortion(g.X, U, g.T);
  REQUIRE(before > 1.01);
  SECTION("the region polish has no region without folds: nothing moves") {
    MapUntangleStats st;
    CHECK(untangle_polycube_map(g.X, g.T, U, g.fixed, MapUntangleParams{}, &st) == 0);
    CHECK(U == U0);
    CHECK(st.polish_iterations == 0);
  }
  SECTION("everywhere: the whole map is polished") {
    MapUntangleParams p;
    p.polish_everywhere = true;
    MapUntangleStats st;
    CHECK(untangle_polycube_map(g.X, g.T, U, g.fixed, p, &st) == 0);
    CHECK(inverted(U, g.T) == 0);
    check_planes_kept(g, U0, U);
    CHECK(st.polish_iterations > 0);
    const double after = mean_conformal_distortion(g.X, U, g.T);
    // the identity is the conformal map with these planes: the bump must shrink most of the way
    CHECK(after < 1 + 0.25 * (before - 1));
  }
  SECTION(
      "preconditioned by the stiffness (its Cholesky or incomplete Cholesky factor): lower in 10 iterations "
      "than plain L-BFGS in 10, planes kept") {
    MapUntangleParams p;
    p.polish_everywhere = true;
    p.polish_iterations = 10;
    MapUntangleStats plain;
    RowMatrixX3d Up = U0;
    CHECK(untangle_polycube_map(g.X, g.T, Up, g.fixed, p, &plain) == 0);
    for (PolishPreconditioner kind : {PolishPreconditioner::cholesky, PolishPreconditioner::incomplete_cholesky}) {
      INFO("preconditioner " << int(kind));
      MapUntangleStats pre;
      RowMatrixX3d Uq = U0;
      p.polish_preconditioner = kind;
      CHECK(untangle_polycube_map(g.X, g.T, Uq, g.fixed, p, &pre) == 0);
      CHECK(inverted(Uq, g.T) == 0);
      check_planes_kept(g, U0, Uq);
      CHECK(pre.polish_energy_before == plain.polish_energy_before);
      REQUIRE(plain.polish_energy_after < plain.polish_energy_before);
      // the energy's floor is its value at the identity map (1 per tet); the preconditioned run gets
      // closer to it
      const double floor = double(g.T.rows());
      CHECK(pre.polish_energy_after - floor < 0.5 * (plain.polish_energy_after - floor));
      CHECK(mean_conformal_distortion(g.X, Uq, g.T) < mean_conformal_distortion(g.X, Up, g.T));
      CHECK(pre.polish_factor_seconds > 0);
      CHECK(plain.polish_factor_seconds == 0);
    }
  }
}

TEST_CASE("shrink: rounds after the first, on the tets still inverted, untangle a deep fold as the whole region does",
          "[position][untangle]") {
  for (bool shrink : {false, true}) {
    INFO("shrink " << shrink);
    Grid g = grid(8);
    RowMatrixX3d U = g.X;
    // two folds: a vertex pushed through three cells, another through one
    U.row(g.id(4, 4, 4)) += Eigen::RowVector3d(2.7, 1.9, -2.2);
    U.row(g.id(2, 6, 2)) += Eigen::RowVector3d(-1.4, 0.3, 0.2);
    const RowMatrixX3d U0 = U;
    REQUIRE(inverted(U, g.T) > 0);
    MapUntangleParams p;
    p.shrink = shrink;
    p.lbfgs_iterations = 2;  // short rounds: several are needed
    MapUntangleStats st;
    const long left = untangle_polycube_map(g.X, g.T, U, g.fixed, p, &st);
    CHECK(st.rounds > 1);
    CHECK(left == 0);
    CHECK(inverted(U, g.T) == 0);
    check_planes_kept(g, U0, U);
  }
}
