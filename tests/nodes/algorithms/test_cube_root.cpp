// [cube-root] the cube roots of hex_corners.h: libm_cbrt gives std::cbrt's bits (the map's untangling
// depends on them), fast_cbrt is within a few ulps.
#include "nodes/algorithms/hex_corners.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>

using namespace polyhex::optimize_detail;

namespace {
bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }
}  // namespace

TEST_CASE("libm_cbrt: std::cbrt's bits over the whole normal range, both signs", "[cube-root]") {
  std::mt19937_64 rng(17);
  long differ = 0, tried = 0;
  // random bit patterns (every exponent), then values spread log-uniformly where the map's determinants lie
  for (int i = 0; i < 2000000; ++i, ++tried) {
    std::uint64_t b = rng();
    double x;
    std::memcpy(&x, &b, sizeof x);
    if (!std::isfinite(x)) continue;
    differ += !same_bits(libm_cbrt(x), std::cbrt(x));
  }
  std::uniform_real_distribution<double> exponent(-30, 30);
  for (int i = 0; i < 2000000; ++i, ++tried) {
    const double x = std::exp2(exponent(rng)) * (i % 2 ? 1 : -1);
    differ += !same_bits(libm_cbrt(x), std::cbrt(x));
  }
  INFO(differ << " of " << tried << " differ");
  CHECK(differ == 0);
  // exact cubes and the ends of the range
  for (double x : {1.0, 8.0, 27.0, 0.125, 1e-300, 1e300, std::numeric_limits<double>::min(),
                   std::numeric_limits<double>::max(), -64.0})
    CHECK(same_bits(libm_cbrt(x), std::cbrt(x)));
  // what goes to std::cbrt: zeros, subnormals, infinities, NaN
  CHECK(same_bits(libm_cbrt(0.0), 0.0));
  CHECK(same_bits(libm_cbrt(-0.0), -0.0));
  CHECK(same_bits(libm_cbrt(std::numeric_limits<double>::denorm_min()),
                  std::cbrt(std::numeric_limits<double>::denorm_min())));
  CHECK(libm_cbrt(std::numeric_limits<double>::infinity()) == std::numeric_limits<double>::infinity());
  CHECK(std::isnan(libm_cbrt(std::numeric_limits<double>::quiet_NaN())));
}

TEST_CASE("fast_cbrt: within 1e-15 relative of std::cbrt", "[cube-root]") {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> exponent(-20, 20);
  double worst = 0;
  for (int i = 0; i < 200000; ++i) {
    const double x = std::exp2(exponent(rng));
    worst = std::max(worst, std::abs(fast_cbrt(x) - std::cbrt(x)) / std::cbrt(x));
  }
  CHECK(worst < 1e-15);
}
