/// @file triangle_tree.h
/// @brief Exact closest-point queries against a fixed set of triangles, through an AABB tree.
///
/// Used by the quality node for surface-to-surface distances; usable by any stage that needs the
/// nearest point of a surface (projection, distance constraints).
#pragma once

#include "nodes/artefacts/meshes.h"

#include <Eigen/Core>

#include <utility>
#include <vector>

namespace polyhex {

/// Closest point on the segment [a, b] to p (a when the segment has zero length).
Eigen::Vector3d closest_on_segment(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b);
/// Distance from p to the segment [a, b]: |closest_on_segment(p, a, b) - p|.
inline double segment_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return (closest_on_segment(p, a, b) - p).norm();
}

/// Closest point on the triangle (a, b, c) to p (Ericson, Real-Time Collision Detection, 5.1.5).
/// Degenerate triangles (zero area, zero-length edges) are handled as the union of their edges.
Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                          const Eigen::Vector3d& c);

/// A bounding-volume hierarchy of axis-aligned boxes over triangles, built once (median split on
/// the longest axis of the centroid bounds), queried concurrently (queries are const).
class TriangleTree {
 public:
  /// Builds the tree over the triangles F of V (a copy of the coordinates is kept).
  /// \param V  #V by 3 positions   \param F  #F by 3 triangles
  /// \throw InvalidInput when F is empty or an index is out of range
  TriangleTree(const RowMatrixX3d& V, const RowMatrixX3i& F);

  struct Hit {
    double sq_distance;     ///< squared distance to the closest point
    int triangle;           ///< row of F holding the closest point
    Eigen::Vector3d point;  ///< the closest point
  };
  /// The exact closest point of the triangle set to p.
  Hit closest(const Eigen::Vector3d& p) const;
  /// Euclidean distance from p to the triangle set.
  double distance(const Eigen::Vector3d& p) const;
  /// The first crossing of the ray o + t d (t > t_min) with a triangle: its t (in units of |d|) and the
  /// triangle (Moller-Trumbore; a ray in a triangle's plane does not cross it). {infinity, -1} when it
  /// crosses none.
  /// \pre d is not zero
  std::pair<double, int> first_crossing(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min) const;
  int triangles() const { return int(a_.size()); }

 private:
  struct Node {
    Eigen::Vector3d lo, hi;     ///< bounding box of the triangles below
    int left = -1, right = -1;  ///< children; -1 for a leaf
    int begin = 0, end = 0;     ///< triangle range [begin, end) in tree order, for a leaf
  };
  int build(int begin, int end, const std::vector<Eigen::Vector3d>& centroid);
  static double box_sq_distance(const Node& n, const Eigen::Vector3d& p);

  std::vector<Node> nodes_;
  std::vector<int> id_;                     ///< tree order -> row of F
  std::vector<Eigen::Vector3d> a_, b_, c_;  ///< corners in tree order
};

}  // namespace polyhex
