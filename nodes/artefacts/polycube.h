/// @file polycube.h
/// @brief The PolyCube structure extracted from the deformed tet mesh (paper §5.1): boundary
/// triangles with chart ids and direction labels, the chart graph, PolyCube edges and corners.
///
/// Direction labels: 0..5 = +X, -X, +Y, -Y, +Z, -Z (axis = label / 2, sign = + for even labels).
#pragma once

#include "nodes/artefacts/meshes.h"

#include <Eigen/Core>

#include <string>
#include <vector>

namespace polyhex {

/// Axis 0..2 of a direction label 0..5.
inline int label_axis(int label) { return label / 2; }
/// +1 or -1: the direction of a label along its axis.
inline int label_sign(int label) { return label % 2 == 0 ? 1 : -1; }
/// Unit vector of a direction label 0..5.
inline Eigen::Vector3d label_dir(int label) {
  Eigen::Vector3d d = Eigen::Vector3d::Zero();
  d[label_axis(label)] = label_sign(label);
  return d;
}
/// The direction label closest to n (ties: the lower label). \pre n != 0
inline int closest_label(const Eigen::Vector3d& n) {
  int best = 0;
  for (int l = 1; l < 6; ++l)
    if (label_dir(l).dot(n) > label_dir(best).dot(n)) best = l;
  return best;
}
/// "+X", "-X", "+Y", "-Y", "+Z", "-Z"; "?" outside 0..5.
inline const char* label_name(int label) {
  static const char* names[6] = {"+X", "-X", "+Y", "-Y", "+Z", "-Z"};
  return label >= 0 && label < 6 ? names[label] : "?";
}

/// One chart (PolyCube face).
struct PolyCubeChart {
  int label = -1;               ///< direction label 0..5
  int triangles = 0;            ///< number of boundary triangles
  double area = 0;              ///< area on the deformed surface
  std::vector<int> neighbours;  ///< sorted ids of the charts sharing a mesh edge with this one
  bool separating = false;      ///< most of its triangles were inserted by a split (§5.1)
};

/// One PolyCube edge: a maximal chain of mesh edges between two charts, from corner to corner
/// (or a closed loop without corners).
struct PolyCubeEdge {
  int chart_a = -1, chart_b = -1;  ///< the two charts, chart_a < chart_b
  std::vector<int> vertices;       ///< tet-mesh vertex ids along the chain; closed loops do not repeat the first
  bool closed = false;             ///< true for a loop without corners
};

/// One PolyCube corner: a surface vertex where three or more chart edges meet.
struct PolyCubeCorner {
  int vertex = -1;          ///< tet-mesh vertex id
  int valence = 0;          ///< number of chart-boundary mesh edges at the vertex (3 for a valid corner)
  std::vector<int> charts;  ///< sorted ids of the charts around the vertex
};

/// The PolyCube structure of a tet mesh's boundary.
struct PolyCubeSegmentation {
  RowMatrixX3i F;  ///< #F by 3 boundary triangles, indices into the tet mesh's V, outward (CCW seen from outside)
  Eigen::VectorXi chart;                ///< #F chart id of each boundary triangle
  Eigen::VectorXi label;                ///< #F direction label 0..5 of each boundary triangle (= its chart's label)
  std::vector<PolyCubeChart> charts;    ///< #charts
  std::vector<PolyCubeEdge> edges;      ///< PolyCube edges
  std::vector<PolyCubeCorner> corners;  ///< PolyCube corners
  int splits_multi_orientation = 0;     ///< separating charts inserted for multi-orientation charts
  int splits_wedge = 0;                 ///< separating charts inserted to cut highly non-planar charts
  int splits_ramp = 0;  ///< separating charts inserted to cut ramps (charts climbing along their axis, extension)
  int splits_order_cycle =
      0;                  ///< separating charts inserted to cut charts whose order evidence forms a cycle (extension)
  int order_cycles = -1;  ///< same-axis chart pairs whose order evidence still closes a cycle, and self bridges
                          ///< (chart_order.h); -1 = not measured (split_order_cycles off)
  int splits_island = 0;  ///< cuts of ring charts from the boundary of a chart they enclose (extension)
  int repaired_corners = 0;  ///< vertices relabelled to resolve 4-valent corners / opposite touches (extension)
  int removed_small = 0;     ///< small charts removed during clean-up
  int removed_narrow =
      0;  ///< charts narrower than min_chart_extent hex edges removed from a valid structure (extension)
  int smoothing_iterations = 0;       ///< normal smoothing passes the labelling used (may differ after a fallback)
  bool valid = false;                 ///< every validity check of §5.1 passed
  std::vector<std::string> problems;  ///< one line per failed check, naming the charts
  std::vector<int> failing_charts;    ///< sorted ids of the charts named in `problems`
  std::vector<std::string> warnings;  ///< fallbacks that were applied
  std::string source;                 ///< source of the tet mesh
};

template <class T>
struct ArtefactName;
template <>
struct ArtefactName<PolyCubeSegmentation> {
  static constexpr const char* value = "PolyCubeSegmentation";
};

}  // namespace polyhex
