/// @file reference_length.h
/// @brief The reference length of a shape, the unit of every relative size (tet edge, hex edge, the
/// conditioning's bounds): the diagonal of its tightest bounding box over all orientations.
///
/// A size given as a fraction of the axis-aligned bounding-box diagonal changes when the shape turns
/// (a cube's diagonal grows by 15 % turned 45° about one axis), so the same model meshed in another frame
/// got another hex count. The smallest diagonal over all rotations depends on the shape alone, and for
/// a part modelled in its own frame (a box, most CAD parts) it is the axis-aligned diagonal itself. See
/// docs/orientation.md for why this one and not the principal-axes box or a length from volume and area.
#pragma once

#include "nodes/artefacts/meshes.h"

#include <Eigen/Core>

namespace polyhex {

/// Diagonal of the axis-aligned bounding box of the points `V` turned by `R` (x -> R x).
/// \pre V has at least one row
double rotated_bbox_diagonal(const RowMatrixX3d& V, const Eigen::Matrix3d& R);

/// The shape's reference length: min over rotations R of rotated_bbox_diagonal(V, R).
///
/// The minimum is searched on the vertices of the convex hull (CGAL extreme_points_3): 1,024 rotations
/// spread over SO(3), then Nelder–Mead in rotation-vector coordinates from the best eight and from the
/// input frame, to 1e-10 rad. Turning the input changes the result by rounding only (tests: below 1e-6
/// relative on boxes, parts and scans). Deterministic: the same points give the same value.
/// \param V  #V by 3 points (a surface's or a tet mesh's vertices; only its hull counts)
/// \pre V has at least one row and finite coordinates
/// \throw InvalidInput when V is empty or not finite
/// \return the reference length, 0 when all points coincide
double reference_length(const RowMatrixX3d& V);

}  // namespace polyhex
