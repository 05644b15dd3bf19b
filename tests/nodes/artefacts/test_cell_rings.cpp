// [cell-rings] CellIncidence: a free vertex's pairs in active-cell order, the slot of each (cell, corner),
// and the sum of per-pair rows, which must give the bits of adding each cell's gradient row in that order.
#include "nodes/artefacts/cell_rings.h"

#include <catch2/catch.hpp>

#include <cstring>
#include <random>

using namespace polyhex;

TEST_CASE("cell incidence: slots point at each free corner's pair, sums add a vertex's rows in cell order",
          "[cell-rings]") {
  // a strip of 6 tets over 9 vertices; vertices 2, 4, 5 and 7 free; cells 1 and 4 not active
  Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor> T(6, 4);
  T << 0, 1, 2, 3, 1, 2, 3, 4, 2, 3, 4, 5, 3, 4, 5, 6, 4, 5, 6, 7, 5, 6, 7, 8;
  const std::vector<int> active = {0, 2, 3, 5};
  std::vector<int> slot(9, -1);
  slot[2] = 0, slot[4] = 1, slot[5] = 2, slot[7] = 3;
  const CellIncidence inc = cell_incidence(T, active, slot, 4);

  // vertex 4 (free 1) is in active cells 2 (corner 2) and 3 (corner 1): pairs (1, 2), (2, 1)
  REQUIRE(inc.start == std::vector<int>{0, 2, 4, 7, 8});
  CHECK(inc.corners[2] == std::pair<int, int>{1, 2});
  CHECK(inc.corners[3] == std::pair<int, int>{2, 1});
  const auto slots = inc.slots<4>(active.size());
  for (size_t a = 0; a < active.size(); ++a)
    for (int k = 0; k < 4; ++k) {
      const int s = slots[a][size_t(k)];
      if (slot[size_t(T(active[a], k))] < 0) {
        CHECK(s == -1);
      } else {
        REQUIRE(s >= 0);
        CHECK(inc.corners[size_t(s)] == std::pair<int, int>{int(a), k});
      }
    }

  // random per-cell gradients: the rows' sums have the bits of Eigen adding the cells' rows in order
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1e3, 1e3);
  std::vector<Eigen::Matrix<double, 4, 3>> grad(active.size());
  CellIncidence::Rows rows(inc.corners.size());
  for (size_t a = 0; a < active.size(); ++a)
    for (int k = 0; k < 4; ++k)
      for (int j = 0; j < 3; ++j) {
        grad[a](k, j) = u(rng) * (j == 1 ? 1e-9 : 1.0);  // magnitudes apart: the order shows in the bits
        if (slots[a][size_t(k)] >= 0) rows[size_t(slots[a][size_t(k)])][size_t(j)] = grad[a](k, j);
      }
  for (size_t i = 0; i < 4; ++i) {
    Eigen::Vector3d ref = Eigen::Vector3d::Zero();
    for (int c = inc.start[i]; c < inc.start[i + 1]; ++c)
      ref += grad[size_t(inc.corners[size_t(c)].first)].row(inc.corners[size_t(c)].second).transpose();
    const Eigen::Vector3d got = inc.sum(i, rows);
    CHECK(std::memcmp(ref.data(), got.data(), sizeof(double) * 3) == 0);
  }
}
