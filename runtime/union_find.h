/// @file union_find.h
/// @brief Disjoint sets over 0..n-1 with path halving (no ranks): the connected pieces of a mesh
/// (fans around a vertex, components, boundary loops).
#pragma once

#include <cstddef>
#include <numeric>
#include <vector>

namespace polyhex {

struct UnionFind {
  std::vector<int> parent;
  explicit UnionFind(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  /// The representative of x's set.  \pre 0 <= x < n
  int find(int x) {
    while (parent[std::size_t(x)] != x) x = parent[std::size_t(x)] = parent[std::size_t(parent[std::size_t(x)])];
    return x;
  }
  /// Joins the sets of a and b; the representative becomes b's.  \pre 0 <= a, b < n
  void unite(int a, int b) { parent[std::size_t(find(a))] = find(b); }
};

}  // namespace polyhex
