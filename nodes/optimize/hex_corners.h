/// @file hex_corners.h
/// @brief Internal to the optimize stage: the corner frames of a VTK_HEXAHEDRON (hex_topology.h) and the regularised
/// determinant χ of the foldover-free energy (Garanzha et al. 2021), shared by the local sweeps
/// (optimize.cpp) and the global untangling (untangle_global.cpp).
#pragma once

#include <cmath>

#include "nodes/artefacts/hex_topology.h"

namespace polyhex::optimize_detail {

/// Corner c and its three edge neighbours, ordered so that the determinant is positive for a valid hex.
using hex_topology::kCorners;

/// χ(D, ε) = (D + sqrt(ε² + D²)) / 2: positive for every D when ε > 0, D for ε -> 0 and D > 0.
inline double chi(double d, double eps) { return 0.5 * (d + std::sqrt(eps * eps + d * d)); }

}  // namespace polyhex::optimize_detail
