/// @file hex_corners.h
/// @brief Internal to the optimize stage: the corner frames of a VTK_HEXAHEDRON and the regularised
/// determinant χ of the foldover-free energy (Garanzha et al. 2021), shared by the local sweeps
/// (optimize.cpp) and the global untangling (untangle_global.cpp).
#pragma once

#include <cmath>

namespace polyhex::optimize_detail {

/// Corner c and its three edge neighbours, ordered so that the determinant is positive for a valid hex.
inline constexpr int kCorner[8][4] = {{0, 1, 3, 4}, {1, 2, 0, 5}, {2, 3, 1, 6}, {3, 0, 2, 7},
                                      {4, 7, 5, 0}, {5, 4, 6, 1}, {6, 5, 7, 2}, {7, 6, 4, 3}};

/// χ(D, ε) = (D + sqrt(ε² + D²)) / 2: positive for every D when ε > 0, D for ε -> 0 and D > 0.
inline double chi(double d, double eps) { return 0.5 * (d + std::sqrt(eps * eps + d * d)); }

}  // namespace polyhex::optimize_detail
