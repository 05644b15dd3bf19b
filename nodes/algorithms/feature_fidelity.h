/// @file feature_fidelity.h
/// @brief How well a hex mesh keeps the feature curves of its input (beyond the paper, whose third
/// limitation is that "sharp edges may be rounded"): the distances between the input's crease lines
/// (features.h find_creases) and the hex mesh's boundary edges, both ways. The Hausdorff distance of the
/// whole boundary hides a rounded edge (a strip a hex wide), these figures do not.
#pragma once

#include "nodes/algorithms/features.h"
#include "nodes/artefacts/meshes.h"

namespace polyhex {

/// The boundary quads of a hex mesh (hex_quality.h hex_boundary_quads).
using BoundaryQuads = Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor>;

/// The median length of the first edge of the boundary quads: the hex edge length a mesh was made at (0 for
/// no quad). \pre Q indexes V
double median_boundary_edge(const RowMatrixX3d& V, const BoundaryQuads& Q);

struct FeatureFidelity {
  int curves = 0;                 ///< crease lines of the input
  double curve_length = 0;        ///< their total length
  long mesh_feature_edges = 0;    ///< boundary edges of the hex mesh whose two quads' normals differ by more than
                                  ///< the angle (edges in exactly two boundary quads)
  double curve_to_mesh_max = 0;   ///< max over the crease lines of the distance to the nearest boundary edge of the
                                  ///< hex mesh (0 without a line)
  double mesh_to_curve_max = 0;   ///< max over the hex mesh's feature edges of the distance to the nearest crease
                                  ///< line (0 without a feature edge; meaningless without a line: see `curves`)
  double curve_to_mesh_mean = 0;  ///< mean over the crease lines (per unit length) of the same distance
};

/// Feature fidelity of a hex mesh's boundary against its input's crease lines. Distances are exact at
/// points `spacing` apart along every line and feature edge (and at their ends); the distance to a set of
/// segments is 1-Lipschitz along a line, so the maxima are within spacing / 2 of the exact ones.
/// \param V, Q       the hex mesh's vertices and boundary quads
/// \param creases    the input's crease lines (find_creases)
/// \param angle_deg  a boundary edge of the hex mesh is a feature edge above this dihedral angle, (0, 180)
/// \param spacing    > 0
/// \pre Q indexes V
FeatureFidelity feature_fidelity(const RowMatrixX3d& V, const BoundaryQuads& Q, const SurfaceCreases& creases,
                                 double angle_deg, double spacing);

}  // namespace polyhex
