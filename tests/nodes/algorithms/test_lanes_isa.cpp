// [lanes-isa] for_lanes runs its kernels in a loop compiled for AVX2 when the CPU has it and in one compiled
// for x86-64's baseline (SSE2) otherwise: the two must give the same bits, or a mesh would depend on the CPU
// it was made on. The kernels that run through it: the PolyCube map's tet term (untangle_map.cpp) and the
// optimizer's hex energy and soft scaled Jacobian (untangle_global.cpp), with exp and log.
#include "nodes/algorithms/hex_corners.h"
#include "nodes/optimize/hex_terms.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

using namespace polyhex::optimize_detail;

namespace {

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

/// Per item: the energy then the gradient's entries.
using Results = std::vector<std::vector<double>>;

/// Random tets (near-rotations, large distortions, inverted) as D (edges) and R (inverse input edges).
struct Tets {
  std::vector<double> D, R, w;  // 9, 9, 1 per tet
};

Tets random_tets(size_t n) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Tets t;
  for (size_t i = 0; i < n; ++i) {
    const double spread = i % 4 == 0 ? 1.0 : 0.2;
    for (int k = 0; k < 9; ++k) {
      t.D.push_back((k % 4 == 0 ? 1.0 : 0.0) + spread * u(rng));
      t.R.push_back(3 * u(rng));
    }
    t.w.push_back(0.1 + std::abs(u(rng)));
  }
  return t;
}

/// Random hexes around the unit cube (some folded), 24 coordinates each.
std::vector<double> random_hexes(size_t n) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  std::vector<double> P;
  for (size_t h = 0; h < n; ++h) {
    const double spread = h % 3 == 0 ? 0.9 : 0.2;
    for (int k = 0; k < 8; ++k)
      for (int i = 0; i < 3; ++i)
        P.push_back(double((i == 0 && (k == 1 || k == 2 || k == 5 || k == 6)) ||
                           (i == 1 && (k == 2 || k == 3 || k == 6 || k == 7)) || (i == 2 && k >= 4)) +
                    spread * u(rng));
  }
  return P;
}

/// The kernels as untangle_map.cpp and untangle_global.cpp write them: a lambda taking a Lanes or a double
/// and the first item's index, which `loop` runs over [0, n).
template <class Loop>
Results tet_terms(const Tets& t, double eps, Loop loop) {
  const size_t n = t.w.size();
  Results out(n, std::vector<double>(13));
  auto f = [&](auto v, size_t a) {
    using V = decltype(v);
    constexpr int W = std::is_same_v<V, double> ? 1 : kLanes;
    V D[3][3], R[3][3], G[4][3], w;
    for (int l = 0; l < W; ++l) {
      for (int k = 0; k < 9; ++k) {
        lane(D[k / 3][k % 3], l) = t.D[9 * (a + size_t(l)) + size_t(k)];
        lane(R[k / 3][k % 3], l) = t.R[9 * (a + size_t(l)) + size_t(k)];
      }
      lane(w, l) = t.w[a + size_t(l)];
    }
    V e = tet_winslow_term(D, R, w, eps, G);
    for (int l = 0; l < W; ++l) {
      out[a + size_t(l)][0] = lane(e, l);
      for (int k = 0; k < 12; ++k) out[a + size_t(l)][size_t(k) + 1] = lane(G[k / 3][k % 3], l);
    }
  };
  loop(size_t(0), n, f);
  return out;
}

template <class Loop>
Results hex_terms(const std::vector<double>& P, double eps, Loop loop) {
  const size_t n = P.size() / 24;
  Results out(n, std::vector<double>(50));
  auto f = [&](auto v, size_t a) {
    using V = decltype(v);
    constexpr int W = std::is_same_v<V, double> ? 1 : kLanes;
    V X[8][3], G[8][3], S[8][3];
    for (int l = 0; l < W; ++l)
      for (int k = 0; k < 24; ++k) lane(X[k / 3][k % 3], l) = P[24 * (a + size_t(l)) + size_t(k)];
    V e = hex_energy_of(X, eps, G);
    V s = hex_soft_sj_of(X, S);
    for (int l = 0; l < W; ++l) {
      auto& o = out[a + size_t(l)];
      o[0] = lane(e, l);
      o[1] = lane(s, l);
      for (int k = 0; k < 24; ++k) {
        o[size_t(k) + 2] = lane(G[k / 3][k % 3], l);
        o[size_t(k) + 26] = lane(S[k / 3][k % 3], l);
      }
    }
  };
  loop(size_t(0), n, f);
  return out;
}

long differences(const Results& a, const Results& b) {
  long d = 0;
  for (size_t i = 0; i < a.size(); ++i)
    for (size_t k = 0; k < a[i].size(); ++k) d += !same_bits(a[i][k], b[i][k]);
  return d;
}

}  // namespace

#if defined(__GNUC__) && defined(__x86_64__)
TEST_CASE("for_lanes: the AVX2 loop and the baseline loop give the kernels' bits alike", "[lanes-isa]") {
  if (!cpu_has_avx2()) {
    WARN("this CPU has no AVX2: for_lanes runs the baseline loop only, nothing to compare");
    return;
  }
  auto baseline = [](size_t b, size_t e, auto& f) { for_lanes_baseline(b, e, f); };
  auto avx2 = [](size_t b, size_t e, auto& f) { for_lanes_avx2(b, e, f); };
  auto one_by_one = [](size_t b, size_t e, auto& f) {
    for (size_t i = b; i < e; ++i) f(0.0, i);
  };
  const Tets tets = random_tets(40003);  // not a multiple of kLanes: the scalar tail runs too
  auto det = [](const double* M) {
    return Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(M).determinant();
  };
  long inverted = 0;  // det(D R) < 0
  for (size_t i = 0; i < tets.w.size(); ++i) inverted += det(&tets.D[9 * i]) * det(&tets.R[9 * i]) < 0;
  CHECK(inverted > 4000);  // the barrier's side is exercised
  for (double eps : {1e-10, 0.3}) {
    const Results a = tet_terms(tets, eps, baseline), b = tet_terms(tets, eps, avx2);
    CHECK(differences(a, b) == 0);
    CHECK(differences(a, tet_terms(tets, eps, one_by_one)) == 0);  // and the lanes give each item's own bits
  }
  const std::vector<double> hexes = random_hexes(20001);
  const Results a = hex_terms(hexes, 1e-6, baseline), b = hex_terms(hexes, 1e-6, avx2);
  long folded = 0;
  for (const auto& r : a) folded += r[1] < 0;
  CHECK(folded > 200);  // soft scaled Jacobians below zero: exp of large arguments
  CHECK(differences(a, b) == 0);
  CHECK(differences(a, hex_terms(hexes, 1e-6, one_by_one)) == 0);
}
#endif
