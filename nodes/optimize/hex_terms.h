/// @file hex_terms.h
/// @brief Internal to the optimize stage: a hex's nine Jacobians and the two per-hex functions of the
/// global untangling and average ascent (untangle_global.cpp) built on them, the Winslow energy and the soft
/// minimum of the scaled Jacobians, with their gradients. Written once for `double` and for `Lanes` (hexes
/// side by side, hex_corners.h): each lane's operations are IEEE's as on one double, and their order is the
/// one Eigen 3.4 took for the Matrix expressions these replaced (tests/nodes/optimize/test_hex_terms.cpp
/// keeps those expressions and compares the bits), so a hex gets the same numbers alone or in a lane.
#pragma once

#include "nodes/algorithms/hex_corners.h"

#include <cmath>
#include <limits>
#include <type_traits>

namespace polyhex::optimize_detail {

/// The centre principal axes (Verdict): X1 = (p1-p0)+(p2-p3)+(p5-p4)+(p6-p7), X2 = (p3-p0)+(p2-p1)+(p7-p4)+(p6-p5),
/// X3 = (p4-p0)+(p5-p1)+(p6-p2)+(p7-p3), each over 4.
inline constexpr int kCentreAxis[3][4][2] = {
    {{1, 0}, {2, 3}, {5, 4}, {6, 7}}, {{3, 0}, {2, 1}, {7, 4}, {6, 5}}, {{4, 0}, {5, 1}, {6, 2}, {7, 3}}};

/// J[row][col], the t-th Jacobian of the hex with corners P[corner][coordinate] (VTK_HEXAHEDRON order):
/// t < 8 corner t's edge vectors (kCorners: a positive determinant for a valid hex), t = 8 the centre axes.
template <class V>
inline void hex_jacobian_of(const V (&P)[8][3], int t, V (&J)[3][3]) {
  if (t < 8) {
    for (int c = 0; c < 3; ++c)
      for (int i = 0; i < 3; ++i) J[i][c] = P[kCorners[t][c + 1]][i] - P[kCorners[t][0]][i];
    return;
  }
  for (int c = 0; c < 3; ++c) {
    V x[3] = {V{}, V{}, V{}};
    for (const auto& e : kCentreAxis[c])
      for (int i = 0; i < 3; ++i) x[i] += P[e[0]][i] - P[e[1]][i];
    for (int i = 0; i < 3; ++i) J[i][c] = 0.25 * x[i];
  }
}

/// G += the gradient with respect to the corners of a function of J_t whose gradient is dJ (J_t is linear
/// in the corners).
template <class V>
inline void hex_scatter_of(V (*G)[3], int t, const V (&dJ)[3][3]) {
  if (t < 8) {
    for (int c = 0; c < 3; ++c)
      for (int i = 0; i < 3; ++i) {
        G[kCorners[t][c + 1]][i] += dJ[i][c];
        G[kCorners[t][0]][i] -= dJ[i][c];
      }
    return;
  }
  for (int c = 0; c < 3; ++c)
    for (const auto& e : kCentreAxis[c])
      for (int i = 0; i < 3; ++i) {
        G[e[0]][i] += 0.25 * dJ[i][c];
        G[e[1]][i] -= 0.25 * dJ[i][c];
      }
}

/// The Winslow energy Σ_t winslow_term(J_t, ε) of the hex with corners P (already over the hex's scale),
/// with the fast cube root, and, if G, its gradient with respect to P.
template <class V>
inline V hex_energy_of(const V (&P)[8][3], double eps, std::common_type_t<V> (*G)[3]) {
  V e{};
  if (G)
    for (int k = 0; k < 8; ++k)
      for (int i = 0; i < 3; ++i) G[k][i] = V{};
  V J[3][3], dJ[3][3];
  for (int t = 0; t < 9; ++t) {
    hex_jacobian_of(P, t, J);
    e += winslow_term_of(J, eps, G ? dJ : nullptr, CubeRoot::fast);
    if (G) hex_scatter_of(G, t, dJ);
  }
  return e;
}

/// Soft minimum of the hex's 9 scaled Jacobians, m = s_min - log(Σ_t exp(-β (s_t - s_min))) / β (<= the
/// hex's scaled Jacobian, within log(9) / β), and, if G, its gradient with respect to P.
/// s_t = det J_t / (|c0| |c1| |c2|), c the columns of J_t; a Jacobian with a zero column gives s_t = 0 and
/// no gradient.
template <class V>
inline V hex_soft_sj_of(const V (&P)[8][3], std::common_type_t<V> (*G)[3]) {
  constexpr double beta = 40.0;
  V s[9], ds[9][3][3];
  V smin = V{} + std::numeric_limits<double>::infinity();
  for (int t = 0; t < 9; ++t) {
    V J[3][3];
    hex_jacobian_of(P, t, J);
    const V c[3][3] = {{J[0][0], J[1][0], J[2][0]}, {J[0][1], J[1][1], J[2][1]}, {J[0][2], J[1][2], J[2][2]}};
    V len[3];
    for (int k = 0; k < 3; ++k) len[k] = lane_sqrt(dot3(c[k], c[k]));
    const V L = len[0] * len[1] * len[2];
    V x[3][3];  // d det / d column k: the cross product of the next two columns
    cross3(c[1], c[2], x[0]);
    cross3(c[2], c[0], x[1]);
    cross3(c[0], c[1], x[2]);
    const V st = dot3(c[0], x[0]) / L;
    const auto good = L > 0.0;  // a bool, or a lane mask
    s[t] = lane_select(good, st, V{});
    if (G)
      for (int k = 0; k < 3; ++k)
        for (int i = 0; i < 3; ++i)
          ds[t][i][k] = lane_select(good, x[k][i] / L - st * c[k][i] / (len[k] * len[k]), V{});
    smin = lane_select(s[t] < smin, s[t], smin);  // std::min(smin, s_t)
  }
  V sum{}, w[9];
  for (int t = 0; t < 9; ++t) {
    const V arg = -beta * (s[t] - smin);
    if constexpr (std::is_same_v<V, double>)
      w[t] = std::exp(arg);
    else
      for (int l = 0; l < kLanes; ++l) w[t][l] = std::exp(arg[l]);
    sum += w[t];
  }
  if (G) {
    for (int k = 0; k < 8; ++k)
      for (int i = 0; i < 3; ++i) G[k][i] = V{};
    for (int t = 0; t < 9; ++t) {
      const V f = w[t] / sum;
      V dJ[3][3];
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) dJ[i][j] = f * ds[t][i][j];
      hex_scatter_of(G, t, dJ);
    }
  }
  V logsum;
  if constexpr (std::is_same_v<V, double>)
    logsum = std::log(sum);
  else
    for (int l = 0; l < kLanes; ++l) logsum[l] = std::log(sum[l]);
  return smin - logsum / beta;
}

}  // namespace polyhex::optimize_detail
