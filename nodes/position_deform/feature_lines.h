/// @file feature_lines.h
/// @brief Creases of the input that run inside one chart of the PolyCube structure (beyond the paper, whose
/// third limitation is that sharp edges may be rounded): where a crease is no chart boundary (a 45 degree
/// chamfer takes one of its two neighbours' labels, so one of its edges lies inside a chart), the map can still
/// put it on a lattice line. A crease that runs straight along one axis of its chart's plane in the deformed
/// mesh gets its vertices' other in-plane coordinate pinned at one integer level (position_deform.h step 4);
/// the lattice's facet points on that level then lie on the crease's edges, and the hex boundary has edges on
/// the crease.
#pragma once

#include "nodes/artefacts/polycube.h"

#include <vector>

namespace polyhex {

/// A crease run inside one chart that can be a lattice line.
struct FeatureLine {
  int chart = -1;             ///< the chart it runs in
  int axis = -1;              ///< the coordinate its vertices share: an axis of the chart's plane, across the line
  std::vector<int> vertices;  ///< tet-mesh vertex ids, those on a chart of `axis` (its ends) left out
  double length = 0;          ///< on the input surface
};

/// The creases of a segmented surface (those along a flat face, features.h flat_face_creases) that run inside one
/// chart (both triangles of each edge in the chart),
/// joined into runs (split where three or more such edges meet), that can be lattice lines: at least
/// `min_length` long, straight in the input (within `tolerance` of the segment between its ends) and in the
/// deformed mesh along an axis of the chart's plane (within `tolerance` across it).
/// \param X    tet-mesh vertices (the input; creases are measured here)
/// \param Vd   the deformed vertices (rotation stage; straightness is measured here)
/// \param seg  the structure; its triangles index X
/// \param angle_deg, scale  the crease test (features.h sharp_edges)
/// \pre X.rows() == Vd.rows(); seg's triangles index X and its chart ids are valid
std::vector<FeatureLine> feature_lines(const RowMatrixX3d& X, const RowMatrixX3d& Vd, const PolyCubeSegmentation& seg,
                                       double angle_deg, double scale, double min_length, double tolerance);

}  // namespace polyhex
