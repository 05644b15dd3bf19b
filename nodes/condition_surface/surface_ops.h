/// @file surface_ops.h
/// @brief The library operations of the surface conditioning: CGAL Polygon Mesh Processing
/// (self-intersections, hole filling, isotropic remeshing with sharp edges kept), CGAL 3D Alpha
/// Wrapping, and the OpenVDB level-set remesh. Each takes and returns a SurfaceMesh; none knows
/// the conditioning policy (condition_surface.h).
#pragma once

#include "nodes/artefacts/meshes.h"

namespace polyhex {

/// Number of pairs of triangles that intersect other than along a shared vertex or edge (CGAL
/// PMP::self_intersections on the soup after merging duplicate points and dropping duplicate and
/// degenerate triangles, so those are not counted here). Triangles that only touch at a point count.
/// \pre every index of s.F in range, coordinates finite
long count_self_intersections(const SurfaceMesh& s);

/// Fills the holes of a triangle mesh whose boundary loops are at most `max_perimeter` long (CGAL
/// PMP::triangulate_refine_and_fair_hole; where fairing fails, the refined triangulation is kept).
/// \param filled  out: the number of holes filled
/// \pre s is an edge- and vertex-manifold triangle mesh (every edge in 1 or 2 triangles, consistently
///      oriented); s.F indices in range
/// \throw InvalidInput when s cannot be made a CGAL polygon mesh
SurfaceMesh fill_small_holes(const SurfaceMesh& s, double max_perimeter, int& filled);

/// The zero level set of the signed distance to the surface at voxel size `voxel` (OpenVDB
/// meshToVolume, then volumeToMesh, quads split in two): a closed, manifold surface that is the union
/// of what the input encloses, so self-intersections, overlaps, non-manifold edges and pinches
/// disappear. Detail below the voxel is lost.
/// \pre voxel > 0; s closed enough to have an inside (a surface with holes larger than a voxel leaks)
/// \throw InvalidInput when the level set is empty (the surface encloses nothing at this voxel size)
SurfaceMesh levelset_remesh(const SurfaceMesh& s, double voxel);

/// CGAL::alpha_wrap_3 of the triangles: a closed, 2-manifold, outward surface that wraps the input
/// at distance `offset` and does not enter holes or gaps narrower than about `alpha`.
/// \pre alpha > 0, offset > 0
SurfaceMesh alpha_wrap(const SurfaceMesh& s, double alpha, double offset);

/// CGAL PMP::isotropic_remeshing towards edges of length `target`, keeping the sharp edges (dihedral
/// angle above `feature_angle` degrees, PMP::detect_sharp_edges) as polylines (their vertices move
/// along them) and their corners fixed.
/// \param feature_edges  out: the number of sharp edges found in the input
/// \pre s is a closed, manifold, oriented triangle mesh; target > 0; iterations >= 1
/// \throw InvalidInput when s cannot be made a CGAL polygon mesh
SurfaceMesh isotropic_remesh(const SurfaceMesh& s, double target, double feature_angle, int iterations,
                             long& feature_edges);

}  // namespace polyhex
