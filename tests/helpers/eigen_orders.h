/// @file eigen_orders.h
/// @brief Whether this build rounds as the bit-for-bit tests of the lane forms assume (hex_corners.h,
/// hex_terms.h): Eigen's summation orders are those of its SSE2 packets, and no multiply-add is fused.
/// With wider packets (AVX) or fused multiply-adds the Eigen expressions round otherwise, and the tests
/// compare the lane forms with the scalar ones only.
#pragma once

namespace polyhex::test {

#if defined(__x86_64__) && !defined(__AVX__) && !defined(__FMA__)
inline constexpr bool kEigenOrders = true;
#else
inline constexpr bool kEigenOrders = false;
#endif

}  // namespace polyhex::test
