/// @file hex_corners.h
/// @brief Internal to the optimize stage: the corner frames of a VTK_HEXAHEDRON (hex_topology.h) and the regularised
/// determinant χ of the foldover-free energy (Garanzha et al. 2021), shared by the local sweeps
/// (optimize.cpp) and the global untangling (untangle_global.cpp), and the regularised Winslow term that the
/// global untangling and the PolyCube map's untangling (nodes/position_deform/untangle_map.cpp) minimise.
#pragma once

#include "nodes/artefacts/hex_topology.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

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
  constexpr double kCbrt2 = 1.2599210498948731648, kSqrCbrt2 = 1.5874010519681994748;
  constexpr double kFactor[5] = {1.0 / kSqrCbrt2, 1.0 / kCbrt2, 1.0, kCbrt2, kSqrCbrt2};
  const double u = (0.354895765043919860 +
                    ((1.50819193781584896 +
                      ((-2.11499494167371287 +
                        ((2.44693122563534430 +
                          ((-1.83469277483613086 + (0.784932344976639262 - 0.145263899385486377 * m) * m) * m)) *
                         m)) *
                       m)) *
                     m));
  const double t2 = u * u * u;
  const double y = u * (t2 + 2.0 * m) / (2.0 * t2 + m) * kFactor[2 + e % 3];
  // times 2^(e / 3) (|e / 3| <= 341: a normal power of two, and an exact product)
  const std::uint64_t pbits = std::uint64_t(1023 + e / 3) << 52;
  double p;
  std::memcpy(&p, &pbits, sizeof p);
  return (x > 0 ? y : -y) * p;
}

/// How winslow_term takes the cube root: the PolyCube map's untangling keeps libm's bits (libm_cbrt; its
/// output feeds every later stage, which a last-bit change would perturb); the hex optimizer takes fast_cbrt.
enum class CubeRoot { exact, fast };

/// |J|_F² / (3 χ(det J, ε)^{2/3}) (1 for a rotation as ε -> 0) and, if dJ, its gradient with respect to J.
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

}  // namespace polyhex::optimize_detail
