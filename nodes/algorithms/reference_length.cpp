#include "nodes/algorithms/reference_length.h"

#include "nodes/algorithms/rotations.h"
#include "runtime/errors.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/convex_hull_3.h>
#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <vector>

namespace polyhex {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;

/// Nelder–Mead on w -> f(exp(w) R0) from w = 0, simplex edge `step` rad: the lowest value and its rotation.
std::pair<double, Eigen::Matrix3d> nelder_mead(const RowMatrixX3d& P, const Eigen::Matrix3d& R0, double step) {
  auto f = [&](const Eigen::Vector3d& w) { return rotated_bbox_diagonal(P, turn(w, R0)); };
  std::array<Eigen::Vector3d, 4> x;
  std::array<double, 4> y;
  x[0].setZero();
  for (int k = 0; k < 3; ++k) x[k + 1] = step * Eigen::Vector3d::Unit(k);
  for (int k = 0; k < 4; ++k) y[k] = f(x[k]);
  for (int it = 0; it < 2000; ++it) {
    std::array<int, 4> o{0, 1, 2, 3};
    std::sort(o.begin(), o.end(), [&](int a, int b) { return y[a] < y[b]; });
    const int best = o[0], worst = o[3], second = o[2];
    double size = 0;
    for (int k = 1; k < 4; ++k) size = std::max(size, (x[o[k]] - x[best]).norm());
    if (size < 1e-10) break;
    Eigen::Vector3d c = (x[o[0]] + x[o[1]] + x[o[2]]) / 3;
    const Eigen::Vector3d xr = c + (c - x[worst]);
    const double yr = f(xr);
    if (yr < y[best]) {
      const Eigen::Vector3d xe = c + 2 * (c - x[worst]);
      const double ye = f(xe);
      if (ye < yr)
        x[worst] = xe, y[worst] = ye;
      else
        x[worst] = xr, y[worst] = yr;
    } else if (yr < y[second]) {
      x[worst] = xr, y[worst] = yr;
    } else {
      const Eigen::Vector3d xc =
          yr < y[worst] ? Eigen::Vector3d(c + 0.5 * (xr - c)) : Eigen::Vector3d(c + 0.5 * (x[worst] - c));
      const double yc = f(xc);
      if (yc < std::min(yr, y[worst])) {
        x[worst] = xc, y[worst] = yc;
      } else {
        for (int k = 1; k < 4; ++k) {
          x[o[k]] = x[best] + 0.5 * (x[o[k]] - x[best]);
          y[o[k]] = f(x[o[k]]);
        }
      }
    }
  }
  const int k = int(std::min_element(y.begin(), y.end()) - y.begin());
  return {y[k], turn(x[k], R0)};
}

}  // namespace

double rotated_bbox_diagonal(const RowMatrixX3d& V, const Eigen::Matrix3d& R) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(HUGE_VAL), hi = -lo;
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    const Eigen::Vector3d p = R * V.row(i).transpose();
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  return (hi - lo).norm();
}

double reference_length(const RowMatrixX3d& V) {
  if (V.rows() == 0) throw InvalidInput("reference length: no points");
  if (!V.allFinite()) throw InvalidInput("reference length: a coordinate is not finite");
  // Only the convex hull's vertices bound a box. extreme_points_3 needs a solid hull: flat or
  // collinear point sets keep all their points.
  RowMatrixX3d P = V;
  if (V.rows() > 4) {
    std::vector<K::Point_3> pts, hull;
    pts.reserve(size_t(V.rows()));
    for (Eigen::Index i = 0; i < V.rows(); ++i) pts.emplace_back(V(i, 0), V(i, 1), V(i, 2));
    bool solid = false;
    for (size_t i = 3; i < pts.size() && !solid; ++i)
      solid = CGAL::orientation(pts[0], pts[1], pts[2], pts[i]) != CGAL::COPLANAR;
    if (solid && !CGAL::collinear(pts[0], pts[1], pts[2])) {
      CGAL::extreme_points_3(pts, std::back_inserter(hull));
      P.resize(Eigen::Index(hull.size()), 3);
      for (size_t i = 0; i < hull.size(); ++i) P.row(Eigen::Index(i)) << hull[i].x(), hull[i].y(), hull[i].z();
    }
  }
  if (rotated_bbox_diagonal(P, Eigen::Matrix3d::Identity()) == 0) return 0;
  constexpr unsigned kSpread = 1024, kStarts = 8;
  std::vector<std::pair<double, unsigned>> scored;
  std::vector<Eigen::Matrix3d> rotations;
  rotations.reserve(kSpread + 1);
  rotations.push_back(Eigen::Matrix3d::Identity());
  for (unsigned i = 0; i < kSpread; ++i) rotations.push_back(spread_rotation(i));
  for (unsigned i = 0; i < rotations.size(); ++i) scored.push_back({rotated_bbox_diagonal(P, rotations[i]), i});
  std::partial_sort(scored.begin(), scored.begin() + kStarts, scored.end());
  double best = scored[0].first;
  std::vector<unsigned> starts{0};
  for (unsigned k = 0; k < kStarts; ++k)
    if (scored[k].second != 0) starts.push_back(scored[k].second);
  for (unsigned s : starts) {
    // A second pass from the first's end with a small simplex finishes a run that stalled on a kink.
    const auto first = nelder_mead(P, rotations[s], 0.1);
    best = std::min({best, first.first, nelder_mead(P, first.second, 0.01).first});
  }
  return best;
}

}  // namespace polyhex
