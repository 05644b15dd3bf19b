// [hex-terms] the per-hex Winslow energy and soft minimum scaled Jacobian of hex_terms.h, written out for
// double and for Lanes: four hexes in lanes give each hex's bits alone, and both give the bits of the Eigen
// expressions untangle_global.cpp computed them with before (6c8d84e, kept here as the reference: the
// optimizer's meshes depend on every last bit).
#include "nodes/optimize/hex_terms.h"
#include "tests/helpers/eigen_orders.h"

#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>

using namespace polyhex::optimize_detail;

namespace {

using Vec3 = Eigen::Vector3d;
using Mat83 = Eigen::Matrix<double, 8, 3>;

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// ---- the reference: untangle_global.cpp's Eigen forms as of 6c8d84e
Eigen::Matrix3d ref_jacobian(const Mat83& P, size_t t) {
  Eigen::Matrix3d J;
  if (t < 8) {
    for (int c = 0; c < 3; ++c) J.col(c) = (P.row(kCorners[t][c + 1]) - P.row(kCorners[t][0])).transpose();
  } else {
    for (int c = 0; c < 3; ++c) {
      Vec3 x = Vec3::Zero();
      for (const auto& e : kCentreAxis[c]) x += (P.row(e[0]) - P.row(e[1])).transpose();
      J.col(c) = 0.25 * x;
    }
  }
  return J;
}
void ref_scatter(Mat83& G, size_t t, const Eigen::Matrix3d& dJ) {
  if (t < 8) {
    for (int c = 0; c < 3; ++c) {
      G.row(kCorners[t][c + 1]) += dJ.col(c).transpose();
      G.row(kCorners[t][0]) -= dJ.col(c).transpose();
    }
  } else {
    for (int c = 0; c < 3; ++c)
      for (const auto& e : kCentreAxis[c]) {
        G.row(e[0]) += 0.25 * dJ.col(c).transpose();
        G.row(e[1]) -= 0.25 * dJ.col(c).transpose();
      }
  }
}
double ref_hex_energy(const Mat83& P, double eps, Mat83* G) {
  double e = 0;
  if (G) G->setZero();
  Eigen::Matrix3d dJ;
  for (size_t t = 0; t < 9; ++t) {
    e += winslow_term(ref_jacobian(P, t), eps, G ? &dJ : nullptr, CubeRoot::fast);
    if (G) ref_scatter(*G, t, dJ);
  }
  return e;
}
double ref_hex_soft_sj(const Mat83& P, Mat83* G) {
  constexpr double beta = 40.0;
  std::array<double, 9> s;
  std::array<Eigen::Matrix3d, 9> ds;
  double smin = std::numeric_limits<double>::infinity();
  for (size_t t = 0; t < 9; ++t) {
    const Eigen::Matrix3d J = ref_jacobian(P, t);
    const double l0 = J.col(0).norm(), l1 = J.col(1).norm(), l2 = J.col(2).norm();
    const double L = l0 * l1 * l2;
    if (!(L > 0)) {
      s[t] = 0;
      ds[t].setZero();
    } else {
      const Vec3 x01 = J.col(0).cross(J.col(1)), x12 = J.col(1).cross(J.col(2)), x20 = J.col(2).cross(J.col(0));
      s[t] = J.col(0).dot(x12) / L;
      ds[t].col(0) = x12 / L - s[t] * J.col(0) / (l0 * l0);
      ds[t].col(1) = x20 / L - s[t] * J.col(1) / (l1 * l1);
      ds[t].col(2) = x01 / L - s[t] * J.col(2) / (l2 * l2);
    }
    smin = std::min(smin, s[t]);
  }
  double sum = 0;
  std::array<double, 9> w;
  for (size_t t = 0; t < 9; ++t) sum += (w[t] = std::exp(-beta * (s[t] - smin)));
  if (G) {
    G->setZero();
    for (size_t t = 0; t < 9; ++t) ref_scatter(*G, t, (w[t] / sum) * ds[t]);
  }
  return smin - std::log(sum) / beta;
}

using polyhex::test::kEigenOrders;

/// A hex of the kinds the optimizer sees: a unit cube's corners moved a little (most), a lot (folded,
/// inverted corners), with an edge collapsed (a zero column: s_t = 0), or a whole hex flat.
Mat83 random_hex(std::mt19937_64& rng, int kind) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Mat83 P;
  const double spread = kind == 0 ? 0.1 : kind == 1 ? 0.6 : 0.2, scale = 0.3 + 2 * std::abs(u(rng));
  for (int k = 0; k < 8; ++k)
    for (int i = 0; i < 3; ++i)
      P(k, i) = scale *
                (double((k == 1 || k == 2 || k == 5 || k == 6) && i == 0) +
                 double((k == 2 || k == 3 || k == 6 || k == 7) && i == 1) + double(k >= 4 && i == 2) + spread * u(rng));
  if (kind == 2) P.row(1) = P.row(0);  // corner 0's and corner 1's frames have a zero column
  if (kind == 3) P.col(2).setConstant(0.5);
  return P;
}

}  // namespace

TEST_CASE("hex energy and soft scaled Jacobian: the same bits for double, for Lanes and as Eigen expressions",
          "[hex-terms]") {
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  long lane_differ = 0, eigen_differ = 0, zero_columns = 0, folded = 0;
  const int n = 40000;
  for (int h = 0; h < n; h += kLanes) {
    Mat83 P[kLanes];
    double eps[kLanes];
    double Pd[kLanes][8][3];
    Lanes Pl[8][3];
    for (int l = 0; l < kLanes; ++l) {
      P[l] = random_hex(rng, (h / kLanes + l) % 7 < 3 ? 0 : (h / kLanes + l) % 7 < 5 ? 1 : (h / kLanes + l) % 7 - 3);
      eps[l] = (h / kLanes) % 3 == 0 ? 1e-10 : u(rng);
      for (int k = 0; k < 8; ++k)
        for (int i = 0; i < 3; ++i) Pd[l][k][i] = Pl[k][i][l] = P[l](k, i);
    }
    // the lanes' energy takes one ε for all: each lane is compared at the first hex's
    for (bool grad : {false, true}) {
      Lanes Gl[8][3], Gs[8][3];
      const Lanes el = hex_energy_of(Pl, eps[0], grad ? Gl : nullptr);
      const Lanes sl = hex_soft_sj_of(Pl, grad ? Gs : nullptr);
      for (int l = 0; l < kLanes; ++l) {
        double Gd[8][3], Gsd[8][3];
        const double ed = hex_energy_of(Pd[l], eps[0], grad ? Gd : nullptr);
        const double sd = hex_soft_sj_of(Pd[l], grad ? Gsd : nullptr);
        bool same = same_bits(el[l], ed) && same_bits(sl[l], sd);
        for (int k = 0; k < 8 && grad; ++k)
          for (int i = 0; i < 3; ++i)
            same = same && same_bits(Gl[k][i][l], Gd[k][i]) && same_bits(Gs[k][i][l], Gsd[k][i]);
        lane_differ += !same;

        Mat83 Ge, Gse;
        const double ee = ref_hex_energy(P[l], eps[0], grad ? &Ge : nullptr);
        const double se = ref_hex_soft_sj(P[l], grad ? &Gse : nullptr);
        same = same_bits(ee, ed) && same_bits(se, sd);
        for (int k = 0; k < 8 && grad; ++k)
          for (int i = 0; i < 3; ++i) same = same && same_bits(Ge(k, i), Gd[k][i]) && same_bits(Gse(k, i), Gsd[k][i]);
        eigen_differ += !same;
        if (!grad) {
          zero_columns += ref_jacobian(P[l], 0).col(0).norm() == 0;
          folded += se < 0;
        }
      }
    }
  }
  CHECK(zero_columns > n / 20);  // the s_t = 0 branch is exercised
  CHECK(folded > n / 20);        // and hexes with an inverted Jacobian
  CHECK(lane_differ == 0);
  if (kEigenOrders) {
    CHECK(eigen_differ == 0);
  } else {
    WARN("not an SSE2-only x86-64 build: Eigen's summation orders differ, their bits not compared");
  }
}
