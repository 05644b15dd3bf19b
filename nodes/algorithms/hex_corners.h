/// @file hex_corners.h
/// @brief Internal to the optimize stage: the corner frames of a VTK_HEXAHEDRON (hex_topology.h) and the regularised
/// determinant χ of the foldover-free energy (Garanzha et al. 2021), shared by the local sweeps
/// (optimize.cpp) and the global untangling (untangle_global.cpp), and the regularised Winslow term that the
/// global untangling and the PolyCube map's untangling (nodes/position_deform/untangle_map.cpp) minimise, and
/// the scaled Jacobian of three vectors (hex_quality.cpp's corner and centre terms). The hot ones are written
/// for `double` and for `Lanes` (four side by side) with the bits of the Eigen expressions they replaced.
#pragma once

#include "nodes/artefacts/hex_topology.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace polyhex::optimize_detail {

/// Corner c and its three edge neighbours, ordered so that the determinant is positive for a valid hex.
using hex_topology::kCorners;

/// χ(D, ε) = (D + sqrt(ε² + D²)) / 2: positive for every D when ε > 0, D for ε -> 0 and D > 0.
inline double chi(double d, double eps) { return 0.5 * (d + std::sqrt(eps * eps + d * d)); }

/// ε update of Garanzha et al. 2021 after a descent at ε took the energy from e_prev to e and left
/// `det` as the determinant the schedule follows: shrink with the achieved relative decrease.
inline double next_eps(double eps, double e, double e_prev, double det) {
  const double sigma = std::max(1.0 - e / e_prev, 0.1);
  const double mu = (1.0 - sigma) * chi(det, eps);
  return det < mu ? 2.0 * std::sqrt(mu * (mu - det)) : 1e-10;
}

/// x^(1/3): a first guess from the exponent bits (the exponent divided by 3) refined by two Halley steps
/// (cubic convergence: 2^-5 -> 2^-15 -> 2^-45) and one Newton step; within a few ulps of std::cbrt
/// (5.8e-16 relative measured over 1e-6..3e6) and 2-3 times faster. std::cbrt with its frexp and ldexp was
/// a fifth of the hex optimizer's profile (the Winslow terms of the sweeps and of the ascent's barrier).
/// Zero, subnormal, negative and non-finite x go to std::cbrt.
inline double fast_cbrt(double x) {
  if (!(x >= std::numeric_limits<double>::min()) || !(x <= std::numeric_limits<double>::max())) return std::cbrt(x);
  std::uint64_t bits;
  std::memcpy(&bits, &x, sizeof bits);
  bits = bits / 3 + 0x2a9f7893782da1ceULL;
  double y;
  std::memcpy(&y, &bits, sizeof y);
  for (int k = 0; k < 2; ++k) {
    const double y3 = y * y * y;
    y *= (y3 + 2.0 * x) / (2.0 * y3 + x);
  }
  return y - (y * y * y - x) / (3.0 * y * y);
}

/// Lanes of doubles, as GCC and Clang's vector extensions give them: arithmetic is lane by lane, each
/// operation IEEE's as on one double (no lane sees another), so a computation written once for `double`
/// and for Lanes gives every lane the bits of the scalar one. On x86-64 a Lanes is two SSE2 registers.
using Lanes = double __attribute__((vector_size(32)));
/// The 64-bit integers of a Lanes' bits (a cast between the two reinterprets them).
using LaneBits = long long __attribute__((vector_size(32)));
constexpr int kLanes = int(sizeof(Lanes) / sizeof(double));

/// Items [begin, end) kLanes at a time, then the rest one by one: f(Lanes{}, i) for i = begin, begin +
/// kLanes, ... while kLanes items remain, then f(0.0, i) (a double) for each item left. f dispatches on
/// the first argument's type, a computation written once for both (the same bits either way). Called by
/// for_lanes through one of the two loops below, which inline f and all it calls.
template <class F>
inline void for_lanes_inlined(std::size_t begin, std::size_t end, F& f) {
  std::size_t i = begin;
  for (; i + kLanes <= end; i += kLanes) f(Lanes{}, i);
  for (; i < end; ++i) f(0.0, i);
}

#if defined(__GNUC__) && defined(__x86_64__)
/// The lane loop for x86-64's baseline (SSE2), f and its callees inlined: the code for_lanes runs on a CPU
/// without AVX2.
template <class F>
__attribute__((flatten)) void for_lanes_baseline(std::size_t begin, std::size_t end, F& f) {
  for_lanes_inlined(begin, end, f);
}

/// The same loop compiled for AVX2 (f and its callees inlined into it, so they are compiled for AVX2 too): a
/// Lanes is one 256-bit register instead of two SSE2 ones. AVX2 brings no fused multiply-add (that is the
/// separate FMA extension, left off) and Eigen's packets stay SSE2's (chosen by the build's macros, not the
/// function's target), so every operation and its order is the baseline's: the same bits, and the same
/// meshes on either kind of CPU (tests/nodes/algorithms/test_lanes_isa.cpp compares them). The PolyCube
/// map's untangling and the optimizer's global untangling and average ascent run through it: 12 % off the
/// bench's total (docs/CHANGELOG.md).
template <class F>
__attribute__((target("avx2"), flatten)) void for_lanes_avx2(std::size_t begin, std::size_t end, F& f) {
  for_lanes_inlined(begin, end, f);
}

/// True if the CPU running this has AVX2 (asked once).
inline bool cpu_has_avx2() {
  static const bool has = __builtin_cpu_supports("avx2");
  return has;
}
#endif

/// for_lanes_inlined, in the AVX2 loop on a CPU that has it (x86-64 with GCC or Clang), else in the
/// baseline's.
template <class F>
inline void for_lanes(std::size_t begin, std::size_t end, F&& f) {
#if defined(__GNUC__) && defined(__x86_64__)
  if (cpu_has_avx2())
    for_lanes_avx2(begin, end, f);
  else
    for_lanes_baseline(begin, end, f);
#else
  for_lanes_inlined(begin, end, f);
#endif
}

/// The mantissa part of libm_cbrt (below): m^(1/3) for m in [0.5, 1), a degree-6 polynomial and one Halley
/// step, times f (2^((e mod 3)/3)). For double and for Lanes.
template <class V>
inline V libm_cbrt_mantissa(V m, V f) {
  const V u = (0.354895765043919860 +
               ((1.50819193781584896 +
                 ((-2.11499494167371287 +
                   ((2.44693122563534430 +
                     ((-1.83469277483613086 + (0.784932344976639262 - 0.145263899385486377 * m) * m) * m)) *
                    m)) *
                  m)) *
                m));
  const V t2 = u * u * u;
  return u * (t2 + 2.0 * m) / (2.0 * t2 + m) * f;
}

/// 2^((e mod 3)/3) for e mod 3 in -2..2 (C's remainder), libm_cbrt's factor.
inline double libm_cbrt_factor(long long e_mod_3) {
  constexpr double kCbrt2 = 1.2599210498948731648, kSqrCbrt2 = 1.5874010519681994748;
  constexpr double kFactor[5] = {1.0 / kSqrCbrt2, 1.0 / kCbrt2, 1.0, kCbrt2, kSqrCbrt2};
  return kFactor[2 + e_mod_3];
}

/// x^(1/3) with the arithmetic of GNU libm's cbrt (glibc's sysdeps/ieee754/dbl-64/s_cbrt.c, the same since
/// 1997): |x| = m 2^e with m in [0.5, 1); a degree-6 polynomial in m, one Halley step, times 2^((e mod 3)/3)
/// and 2^(e div 3). The same operations in the same order give the same bits as std::cbrt on Debian's libm
/// (tests/nodes/algorithms/test_cube_root.cpp compares them), without its calls to frexp and ldexp, which
/// with the call itself were a tenth of the PolyCube map's untangling profile. Zero, subnormal and
/// non-finite x go to std::cbrt.
inline double libm_cbrt(double x) {
  std::uint64_t bits;
  std::memcpy(&bits, &x, sizeof bits);
  const int biased = int(bits >> 52 & 0x7ff);
  if (biased == 0 || biased == 0x7ff) return std::cbrt(x);
  const int e = biased - 1022;  // |x| = m 2^e
  const std::uint64_t mbits = (bits & 0x000fffffffffffffULL) | (std::uint64_t(1022) << 52);
  double m;
  std::memcpy(&m, &mbits, sizeof m);
  const double y = libm_cbrt_mantissa(m, libm_cbrt_factor(e % 3));
  // times 2^(e / 3) (|e / 3| <= 341: a normal power of two, and an exact product)
  const std::uint64_t pbits = std::uint64_t(1023 + e / 3) << 52;
  double p;
  std::memcpy(&p, &pbits, sizeof p);
  return (x > 0 ? y : -y) * p;
}

/// libm_cbrt of every lane: the same bits as libm_cbrt lane by lane.
inline Lanes libm_cbrt(Lanes x) {
  const LaneBits bits = (LaneBits)x;
  const LaneBits biased = (bits >> 52) & 0x7ff;
  const LaneBits e = biased - 1022;
  const Lanes m = (Lanes)((bits & 0x000fffffffffffffLL) | (1022LL << 52));
  Lanes f;
  for (int l = 0; l < kLanes; ++l) f[l] = libm_cbrt_factor(e[l] % 3);
  const Lanes y = libm_cbrt_mantissa(m, f);
  const Lanes p = (Lanes)((1023 + e / 3) << 52);
  Lanes r = (Lanes)((LaneBits)y ^ (bits & (1LL << 63))) * p;  // y with x's sign, times 2^(e div 3)
  for (int l = 0; l < kLanes; ++l)
    if (biased[l] == 0 || biased[l] == 0x7ff) r[l] = std::cbrt(x[l]);
  return r;
}

/// fast_cbrt of every lane: the same bits as fast_cbrt lane by lane.
inline Lanes fast_cbrt(Lanes x) {
  using LaneWords = unsigned long long __attribute__((vector_size(32)));
  Lanes y = (Lanes)((LaneWords)x / 3 + 0x2a9f7893782da1ceULL);
  for (int k = 0; k < 2; ++k) {
    const Lanes y3 = y * y * y;
    y *= (y3 + 2.0 * x) / (2.0 * y3 + x);
  }
  y = y - (y * y * y - x) / (3.0 * y * y);
  for (int l = 0; l < kLanes; ++l)
    if (!(x[l] >= std::numeric_limits<double>::min()) || !(x[l] <= std::numeric_limits<double>::max()))
      y[l] = std::cbrt(x[l]);
  return y;
}

/// mask ? a : b, lane by lane for Lanes (mask a lane comparison's result).
inline double lane_select(bool mask, double a, double b) { return mask ? a : b; }
inline Lanes lane_select(decltype(Lanes{} < Lanes{}) mask, Lanes a, Lanes b) { return mask ? a : b; }

/// How winslow_term takes the cube root: the PolyCube map's untangling keeps libm's bits (libm_cbrt; its
/// output feeds every later stage, which a last-bit change would perturb); the hex optimizer takes fast_cbrt.
enum class CubeRoot { exact, fast };

/// The square root, lane by lane for Lanes: IEEE's correctly rounded one either way (on x86-64 two SSE2
/// sqrtpd, without the scalar std::sqrt's check and call for a negative argument, which dominated the
/// sweeps' corner terms: 16 such square roots per four corners).
inline double lane_sqrt(double x) { return std::sqrt(x); }
inline Lanes lane_sqrt(Lanes x) {
#if defined(__SSE2__)
  __m128d half[2];
  std::memcpy(half, &x, sizeof x);
  half[0] = _mm_sqrt_pd(half[0]);
  half[1] = _mm_sqrt_pd(half[1]);
  std::memcpy(&x, half, sizeof x);
#else
  for (int l = 0; l < kLanes; ++l) x[l] = std::sqrt(x[l]);
#endif
  return x;
}

/// x · y of 3-vectors in Eigen 3.4's order for a Vector3d dot product or squared norm: (x0 y0 + x1 y1) + x2 y2.
template <class V>
inline V dot3(const V (&x)[3], const V (&y)[3]) {
  return (x[0] * y[0] + x[1] * y[1]) + x[2] * y[2];
}

/// r = x × y, Eigen's formula for Vector3d::cross.
template <class V>
inline void cross3(const V (&x)[3], const V (&y)[3], V (&r)[3]) {
  r[0] = x[1] * y[2] - x[2] * y[1];
  r[1] = x[2] * y[0] - x[0] * y[2];
  r[2] = x[0] * y[1] - x[1] * y[0];
}

/// det[a b c] / (|a| |b| |c|) of three vectors (a[i] their coordinates), 0 when one has (almost) no
/// length, clamped to [-1, 1]: the scaled Jacobian of a corner frame or of the centre axes (hex_quality.h),
/// for double or Lanes. One square root of the product of the squared lengths instead of three (the
/// optimizer evaluates this nine times per hex per trial move); the product of the norms where that
/// product would under- or overflow. The operations are those of the Eigen Vector3d expressions it
/// replaced, in their order (a dot or squared norm (x0 y0 + x1 y1) + x2 y2, Eigen's cross product):
/// tests/nodes/quality/test_quality.cpp compares the bits.
template <class V>
inline V scaled_of(const V (&a)[3], const V (&b)[3], const V (&c)[3]) {
  V bc[3];
  cross3(b, c, bc);
  const V det = dot3(a, bc);
  const V na = dot3(a, a), nb = dot3(b, b), nc = dot3(c, c);
  const V len2 = na * nb * nc;
  V len;
  if constexpr (std::is_same_v<V, double>)
    len = len2 > 1e-290 && len2 < 1e290 ? std::sqrt(len2) : std::sqrt(na) * std::sqrt(nb) * std::sqrt(nc);
  else {
    len = lane_sqrt(len2);
    for (int l = 0; l < kLanes; ++l)  // rare: the product of the norms where len2 under- or overflows
      if (!(len2[l] > 1e-290 && len2[l] < 1e290)) len[l] = std::sqrt(na[l]) * std::sqrt(nb[l]) * std::sqrt(nc[l]);
  }
  const V s = lane_select(len > 1e-300, det / len, V{});
  return lane_select(s < -1.0, V{} - 1.0, lane_select(1.0 < s, V{} + 1.0, s));  // std::clamp(s, -1, 1)
}

/// winslow_term (below) on J[row][col], for double or Lanes. Its operations
/// are those Eigen 3.4 performs for winslow_term's expressions on x86-64 (SSE2), in the same order:
/// squaredNorm sums the column-major entries as two interleaved pairs of pairs, then the last; the
/// determinant is Eigen's cofactor expansion along the first row. [winslow] tests compare the bits.
template <class V>
inline V winslow_term_of(const V (&J)[3][3], double eps, std::common_type_t<V> (*dJ)[3],
                         CubeRoot root = CubeRoot::exact) {
  auto minor = [&](int a, int b, int c) { return J[0][a] * (J[1][b] * J[2][c] - J[1][c] * J[2][b]); };
  const V D = (minor(0, 1, 2) - minor(1, 0, 2)) + minor(2, 0, 1);
  const V r = lane_sqrt(eps * eps + D * D);
  const V c = 0.5 * (D + r);  // chi(D, eps)
  const V c23 = root == CubeRoot::fast ? fast_cbrt(c * c) : libm_cbrt(c * c);
  const V n2 = ((J[0][0] * J[0][0] + J[2][0] * J[2][0]) + (J[1][1] * J[1][1] + J[0][2] * J[0][2]) +
                ((J[1][0] * J[1][0] + J[0][1] * J[0][1]) + (J[2][1] * J[2][1] + J[1][2] * J[1][2]))) +
               J[2][2] * J[2][2];
  if (dJ) {
    const V dchi = 0.5 * (1.0 + D / r);
    const V s1 = 2.0 / (3.0 * c23), s2 = (2.0 / 9.0) * n2 / (c23 * c) * dchi;
    for (int j = 0; j < 3; ++j) {  // d det / dJ: column j is the cross product of the next two columns
      const int p = (j + 1) % 3, q = (j + 2) % 3;
      dJ[0][j] = s1 * J[0][j] - s2 * (J[1][p] * J[2][q] - J[2][p] * J[1][q]);
      dJ[1][j] = s1 * J[1][j] - s2 * (J[2][p] * J[0][q] - J[0][p] * J[2][q]);
      dJ[2][j] = s1 * J[2][j] - s2 * (J[0][p] * J[1][q] - J[1][p] * J[0][q]);
    }
  }
  return n2 / (3.0 * c23);
}

/// |J|_F² / (3 χ(det J, ε)^{2/3}) (1 for a rotation as ε -> 0) and, if dJ, its gradient with respect to J.
/// As Eigen expressions (the optimizer's form: Eigen's packets make its gradient twice as fast as
/// winslow_term_of's for one J); winslow_term_of is the same arithmetic written out for lanes, and [winslow]
/// tests hold the two to the same bits.
inline double winslow_term(const Eigen::Matrix3d& J, double eps, Eigen::Matrix3d* dJ, CubeRoot root = CubeRoot::exact) {
  const double D = J.determinant();
  const double c = chi(D, eps);
  const double c23 = root == CubeRoot::fast ? fast_cbrt(c * c) : libm_cbrt(c * c);
  const double n2 = J.squaredNorm();
  if (dJ) {
    Eigen::Matrix3d cof;  // d det / dJ
    cof.col(0) = J.col(1).cross(J.col(2));
    cof.col(1) = J.col(2).cross(J.col(0));
    cof.col(2) = J.col(0).cross(J.col(1));
    const double dchi = 0.5 * (1.0 + D / std::sqrt(eps * eps + D * D));
    *dJ = (2.0 / (3.0 * c23)) * J - (2.0 / 9.0) * n2 / (c23 * c) * dchi * cof;
  }
  return n2 / (3.0 * c23);
}

/// Lane l of v (v itself for a double).
template <class V>
inline double& lane(V& v, int l) {
  if constexpr (std::is_same_v<V, double>)
    return v;
  else
    return reinterpret_cast<double*>(&v)[l];
}

/// One tet's term of the PolyCube map's energy (nodes/position_deform/untangle_map.cpp), w winslow_term(D R,
/// ε), and if G its gradient with respect to the tet's corners (G[k] of corner k); D the PolyCube edge
/// vectors as columns, R the inverse of the input's. For double, or for Lanes of tets side by side. The
/// products take Eigen 3.4's order for Matrix3d products on x86-64 (SSE2): rows 0 and 1 as one packet,
/// (a0 b0 + a1 b1) + a2 b2, and row 2 alone, a0 b0 + (a1 b1 + a2 b2); so the bits are those of the Eigen
/// expressions this replaced ([winslow] tests compare them).
template <class V>
inline V tet_winslow_term(const V (&D)[3][3], const V (&R)[3][3], V w, double eps, std::common_type_t<V> (*G)[3]) {
  auto dot = [](int row, V a0, V a1, V a2, V b0, V b1, V b2) {
    return row < 2 ? (a0 * b0 + a1 * b1) + a2 * b2 : a0 * b0 + (a1 * b1 + a2 * b2);
  };
  V J[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) J[i][j] = dot(i, D[i][0], D[i][1], D[i][2], R[0][j], R[1][j], R[2][j]);
  if (!G) return w * winslow_term_of(J, eps, nullptr);
  V dJ[3][3];
  const V term = w * winslow_term_of(J, eps, dJ);
  V wdJ[3][3], dD[3][3];  // d term / d D = w dJ R^T
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) wdJ[i][j] = w * dJ[i][j];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) dD[i][j] = dot(i, wdJ[i][0], wdJ[i][1], wdJ[i][2], R[j][0], R[j][1], R[j][2]);
  for (int i = 0; i < 3; ++i) {
    G[0][i] = -(dD[i][0] + (dD[i][1] + dD[i][2]));
    for (int k = 0; k < 3; ++k) G[k + 1][i] = dD[i][k];
  }
  return term;
}

}  // namespace polyhex::optimize_detail
