/// @file features.h
/// @brief Sharp creases of the input surface and the hex mesh's boundary vertices that follow them (beyond
/// the paper: §6 projects every boundary vertex onto the closest surface point).
///
/// Closest-point projection does not know creases: a boundary quad that lies across a sharp crease keeps
/// two corners on each side, and the sweeps press the two corners of one side together on the crease line
/// (carter: pad hexes with outer quads 2.1 x 0.03 hex edges folded 100 degrees, scaled Jacobian 0). Here the
/// crease lines are found on the surface (dihedral angle above a threshold), and for each one the path of
/// hex boundary edges that runs closest to it is put on it: those vertices move along the crease only, and
/// the vertices at crease corners (three or more creases) stay at the corner. The hexes beside a crease then
/// have an edge on it instead of a face across it.
#pragma once

#include "nodes/artefacts/meshes.h"

#include <array>
#include <vector>

namespace polyhex {

/// The crease lines of a surface: polylines of surface edges whose two triangles' normals differ by more
/// than the threshold angle, split at crease corners (vertices with 1 or >= 3 crease edges).
struct SurfaceCreases {
  std::vector<std::vector<Eigen::Vector3d>> lines;  ///< polylines (>= 2 points); a closed loop repeats its first point
  std::vector<char> closed;                         ///< per line: a closed loop
  std::vector<int> start_corner, end_corner;        ///< per line: index into corners of its ends, -1 if none
  std::vector<Eigen::Vector3d> corners;             ///< crease vertices with >= 3 crease edges
  std::vector<std::vector<int>> vertices;           ///< per line: its surface vertex ids (as `lines`)
};

/// A part's faces: the surface between its crease lines.
struct CreaseFaces {
  Eigen::VectorXi patch;     ///< #F face of each triangle (triangles joined across edges on no line)
  int faces = 0;             ///< number of faces
  std::vector<char> planar;  ///< per face: its triangles' normals within kPlanarFace degrees of their mean
};

/// A face is planar when its triangles' normals lie within this many degrees of their area-weighted mean.
inline constexpr double kPlanarFace = 10.0;

/// The faces between the crease lines of a surface.
/// \pre creases from find_creases on this surface
CreaseFaces crease_faces(const SurfaceMesh& surface, const SurfaceCreases& creases);

/// The triangles on a flat face of a part: connected regions whose normals stay within kPlanarFace degrees of their
/// first (largest) triangle's, of at least kFlatFaceArea h^2 (a face a few hexes can sit on); grown from the
/// largest triangles first.
/// \param h  the hex edge, absolute, > 0
/// \return #F flags
std::vector<char> flat_face_triangles(const SurfaceMesh& surface, double h);

/// Area of a flat face, in hex faces (h^2).
inline constexpr double kFlatFaceArea = 4.0;

/// The crease lines that run along a flat face (flat_face_triangles): most of a line's edges have a triangle of
/// one on a side. A part's edges do (its planes, and the large near-flat pieces of its cylinders and twisted
/// faces); a scan's faceting that passes find_creases' scale test sits between facets as large as a hex edge that
/// turn by more than kPlanarFace from one to the next, and does not; nor does an edge between two strongly
/// curved faces. Corners are those the kept lines end at.
/// \pre creases from find_creases on this surface; h > 0
SurfaceCreases flat_face_creases(const SurfaceMesh& surface, const SurfaceCreases& creases, double h);

/// A chain of a graph's edges between two of its nodes (vertices with 1 or at least 3 edges), or a loop (its
/// first vertex repeated at its end).
struct EdgeChain {
  std::vector<int> verts;
  bool closed = false;
};

/// The chains of the graph `adj` (per vertex its neighbours, no edge twice): from each node in the order of
/// their ids, along each of its edges in `adj`'s order through vertices with two edges to the next node; then
/// the loops left. Every edge is on exactly one chain.
std::vector<EdgeChain> edge_chains(const std::vector<std::vector<int>>& adj);

/// The surface edges of the crease lines, (low, high) vertex pairs, sorted.
std::vector<std::array<int, 2>> crease_edges(const SurfaceCreases& creases);

/// The dihedral angle (degrees) above which the stages that follow sharp edges take an edge as one by default
/// (boundary groups, the optimizer's crease candidate, the quality node's feature fidelity).
inline constexpr double kFeatureAngle = 40.0;

/// The sharp edges of a surface: edges shared by exactly two triangles whose normals differ by more than
/// `angle_deg` (triangles of zero area make no sharp edge).
///
/// With `scale` > 0 the test also holds at that scale: the triangles within `scale` of the edge (their
/// centroids, reached over the surface from the edge's two triangles) are split by the edge's two sides, and
/// the area-weighted mean normals of the two sides must differ by more than `angle_deg` too, and by more than
/// three times the mean angle between a side's triangles and its mean normal (the edge turns more than the
/// surface does on either side of it). A part's edge passes: each side is a face. A scan's noise fails the
/// first test once `scale` spans a few facets, its faceting the second: where the facets are as large as
/// the scale, a scan turns about as much across each facet as across the edge. The stages take half a hex
/// edge. A chamfer or step narrower than `scale` fails the second test (its other edge lies on one side).
/// \return (low, high) vertex pairs, sorted
/// \throw InvalidInput when a triangle index is out of range
std::vector<std::array<int, 2>> sharp_edges(const SurfaceMesh& surface, double angle_deg, double scale = 0);

/// The patches of a surface bounded by its sharp edges (sharp_edges): triangles connected across edges
/// that are shared by two triangles and not sharp. A crease that does not close a region splits nothing.
/// \param patches  out (optional): the number of patches
/// \return #F patch id of each triangle, numbered 0.. in the order of each patch's lowest triangle
/// \throw InvalidInput when a triangle index is out of range
Eigen::VectorXi surface_patches(const SurfaceMesh& surface, double angle_deg, int* patches = nullptr);

/// Finds the creases of a closed surface.
/// \param angle_deg  a surface edge is sharp when its triangles' normals differ by more than this, (0, 180)
/// \param min_length  lines shorter than this are dropped (noise), >= 0
/// \param scale  > 0: the edges must be sharp at this scale as well (sharp_edges), and a line must be a part's
///               edge, not a scan's faceting: a smooth curve (at points 2 scale apart along it, it turns by
///               less than 20 degrees on average) with a steady dihedral angle (standard deviation below 10 degrees),
///               at least 6 scale long or running between two corners (a box's short edge), >= 0
/// \throw InvalidInput when a triangle index is out of range
SurfaceCreases find_creases(const SurfaceMesh& surface, double angle_deg, double min_length, double scale = 0);

/// Closest point of polyline `line` to x; `tangent` (optional) the unit direction of its segment (zero for a
/// zero-length one).
/// \pre line has at least one point
Eigen::Vector3d closest_on_line(const std::vector<Eigen::Vector3d>& line, const Eigen::Vector3d& x,
                                Eigen::Vector3d* tangent = nullptr);

/// Which boundary vertices of a hex mesh follow which crease.
struct CreaseSnap {
  std::vector<int> line;    ///< per hex vertex: the crease line it moves along, -1 if none
  std::vector<int> corner;  ///< per hex vertex: the crease corner it stays at, -1 if none
  int lines_snapped = 0;    ///< crease lines with a path of boundary edges
  int lines_skipped = 0;    ///< crease lines without an acceptable path (too far from every boundary edge path)
  long vertices = 0;        ///< hex vertices on a crease line or at a corner
};

/// For every crease line, the path of boundary edges of the hex mesh between the boundary vertices nearest
/// to its ends (Dijkstra over boundary edges within `reach` of the line, each edge's cost its length times
/// 1 + 8 times its ends' mean distance to the line over `reach`); accepted when every path vertex is within
/// `reach` of the line, the path is at most twice the line's length plus 2 `reach`, and it shares no vertex
/// with an earlier path except at a corner. Corners: the boundary vertex nearest to each crease corner,
/// within `reach`. Closed lines: two paths, to the vertex nearest the line's middle and back.
/// \param V  hex mesh vertices   \param Q  its boundary quads (quality.h hex_boundary_quads)
/// \param reach  how far a path vertex may be from its line (e.g. the hex edge length), > 0
/// \pre Q's indices are rows of V; creases from find_creases (lines of >= 2 points, corner indices in range)
/// Never throws beyond std::bad_alloc: a line without an acceptable path is counted in lines_skipped.
CreaseSnap snap_to_creases(const RowMatrixX3d& V, const Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor>& Q,
                           const SurfaceCreases& creases, double reach);

/// The boundary vertices of a hex mesh that already lie on the creases: within `tol` of a crease corner (it stays
/// there) or of a crease line (it moves along it). The lattice puts a hex vertex on a crease wherever the
/// PolyCube structure has a chart boundary or corner on it. A vertex where one of its boundary quads has a
/// lattice corner on a crease that runs on (the corner wider than 150 degrees, or than 120 with both of the
/// quad's edges there on the vertex's line) stays free: it must leave the crease to open that corner. So does a
/// vertex with no boundary edge along its line (to a vertex on it or at one of its corners): there the lattice
/// crosses the crease, and sliding along it would hold the vertex's quads across it.
/// \param V  hex mesh vertices   \param Q  its boundary quads   \param tol  >= 0
CreaseSnap creases_at_vertices(const RowMatrixX3d& V, const Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor>& Q,
                               const SurfaceCreases& creases, double tol);

}  // namespace polyhex
