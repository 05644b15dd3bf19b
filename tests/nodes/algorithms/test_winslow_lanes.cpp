// [winslow] the Winslow terms of hex_corners.h written out for double and for Lanes: the lanes give the
// scalar bits, and both give the bits of winslow_term's Eigen expressions and of the map's per-tet term as
// untangle_map.cpp computed it with Eigen before (the meshes depend on them: a last-bit change moves every
// map and mesh downstream).
#include "nodes/algorithms/hex_corners.h"
#include "tests/helpers/eigen_orders.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>

using namespace polyhex::optimize_detail;

namespace {

using Mat3 = Eigen::Matrix3d;
using Mat43 = Eigen::Matrix<double, 4, 3>;

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

/// The map's per-tet term and gradient as untangle_map.cpp computed them with Eigen (0ca9dca).
double eigen_tet_term(const Mat3& D, const Mat3& R, double w, double eps, Mat43& G) {
  Mat3 dJ;
  const double e = w * winslow_term(D * R, eps, &dJ);
  const Mat3 dD = w * dJ * R.transpose();
  G.row(0) = -dD.rowwise().sum().transpose();
  for (int k = 0; k < 3; ++k) G.row(k + 1) = dD.col(k).transpose();
  return e;
}

using polyhex::test::kEigenOrders;

}  // namespace

/// Lanes of random doubles over the whole range (normal and subnormal, both signs) through `lanes` and each
/// lane through `one`: how many lanes differ in a bit.
template <class F, class G>
long lane_differences(unsigned seed, F lanes, G one) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> mant(-1.0, 1.0);
  std::uniform_int_distribution<int> expo(-1070, 1020);
  long differ = 0;
  for (int n = 0; n < 250000; ++n) {
    Lanes x;
    for (int l = 0; l < kLanes; ++l) x[l] = std::ldexp(mant(rng), expo(rng));
    const Lanes y = lanes(x);
    for (int l = 0; l < kLanes; ++l) differ += !same_bits(y[l], one(double(x[l])));
  }
  return differ;
}

TEST_CASE("libm_cbrt of Lanes: libm_cbrt's bits lane by lane, special values included", "[winslow][cube-root]") {
  CHECK(lane_differences(
            5, [](Lanes x) { return libm_cbrt(x); }, [](double x) { return libm_cbrt(x); }) == 0);
  const double inf = std::numeric_limits<double>::infinity();
  const Lanes special = {0.0, -std::numeric_limits<double>::denorm_min(), -inf, 27.0};
  const Lanes y = libm_cbrt(special);
  CHECK(same_bits(y[0], 0.0));
  CHECK(same_bits(y[1], libm_cbrt(-std::numeric_limits<double>::denorm_min())));
  CHECK(y[2] == -inf);
  CHECK(same_bits(y[3], libm_cbrt(27.0)));  // not std::cbrt(27.0): the compiler folds that, correctly rounded
  CHECK(std::isnan(libm_cbrt(Lanes{std::nan(""), 1, 1, 1})[0]));
}

TEST_CASE("fast_cbrt of Lanes: fast_cbrt's bits lane by lane, special values included", "[winslow][cube-root]") {
  CHECK(lane_differences(
            7, [](Lanes x) { return fast_cbrt(x); }, [](double x) { return fast_cbrt(x); }) == 0);
  const double inf = std::numeric_limits<double>::infinity();
  const Lanes y = fast_cbrt(Lanes{0.0, -8.0, inf, 27.0});
  CHECK(same_bits(y[0], 0.0));
  CHECK(same_bits(y[1], fast_cbrt(-8.0)));
  CHECK(y[2] == inf);
  CHECK(y[3] == Approx(3.0).epsilon(1e-15));
}

TEST_CASE("winslow_term and the map's tet term: the same bits for double, for Lanes and as Eigen expressions",
          "[winslow]") {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  long term_differ = 0, grad_differ = 0, eigen_differ = 0, tet_differ = 0, inverted = 0;
  const int n = 200000;
  for (int t = 0; t < n; ++t) {
    // near-rotations (a polished map), large distortions and inverted tets, at the polish's ε and larger
    Mat3 D, R;
    const double spread = t % 4 == 0 ? 1.0 : 0.2;
    for (int k = 0; k < 9; ++k)
      D(k % 3, k / 3) = (k % 4 == 0 ? 1.0 : 0.0) + spread * u(rng), R(k % 3, k / 3) = 3 * u(rng);
    const double eps = t % 3 == 0 ? 1e-10 : std::abs(u(rng)), w = 0.1 + std::abs(u(rng));
    inverted += (D * R).determinant() < 0;

    // winslow_term_of for one double against winslow_term's Eigen expressions, both cube roots
    const Mat3 J = D * R;
    double Ja[3][3], ga[3][3];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) Ja[i][j] = J(i, j);
    for (CubeRoot root : {CubeRoot::exact, CubeRoot::fast}) {
      Mat3 g;
      const double a = winslow_term_of(Ja, eps, ga, root), b = winslow_term(J, eps, &g, root);
      bool same = same_bits(a, b) && same_bits(winslow_term_of(Ja, eps, nullptr, root), b);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) same = same && same_bits(ga[i][j], g(i, j));
      eigen_differ += !same;
    }

    // the tet term: double, Lanes (this tet in every lane) and Eigen's
    double Dd[3][3], Rd[3][3], Gd[4][3];
    Lanes Dl[3][3], Rl[3][3], Gl[4][3];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        Dd[i][j] = D(i, j), Rd[i][j] = R(i, j);
        for (int l = 0; l < kLanes; ++l) Dl[i][j][l] = D(i, j), Rl[i][j][l] = R(i, j);
      }
    Lanes wl;
    for (int l = 0; l < kLanes; ++l) wl[l] = w;
    const double ed = tet_winslow_term(Dd, Rd, w, eps, Gd);
    const Lanes el = tet_winslow_term(Dl, Rl, wl, eps, Gl);
    const double en = tet_winslow_term(Dd, Rd, w, eps, nullptr);
    term_differ += !same_bits(ed, en);
    for (int l = 0; l < kLanes; ++l) {
      term_differ += !same_bits(el[l], ed);
      for (int k = 0; k < 4; ++k)
        for (int i = 0; i < 3; ++i) grad_differ += !same_bits(Gl[k][i][l], Gd[k][i]);
    }
    Mat43 Ge;
    const double ee = eigen_tet_term(D, R, w, eps, Ge);
    bool same = same_bits(ee, ed);
    for (int k = 0; k < 4; ++k)
      for (int i = 0; i < 3; ++i) same = same && same_bits(Ge(k, i), Gd[k][i]);
    tet_differ += !same;
  }
  CHECK(inverted > n / 10);  // the barrier's side is exercised
  CHECK(term_differ == 0);
  CHECK(grad_differ == 0);
  if (kEigenOrders) {
    CHECK(eigen_differ == 0);
    CHECK(tet_differ == 0);
  } else {
    WARN("not an SSE2-only x86-64 build: Eigen's summation orders differ, their bits not compared");
  }
}
