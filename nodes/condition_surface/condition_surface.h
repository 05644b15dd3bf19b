/// @file condition_surface.h
/// @brief Surface conditioning before meshing: a diagnosis of the input triangles, a repair chosen
/// for the defects found, and a remesh to the size the tets need.
///
/// Between the surface input and the tet mesher. An input with no defect whose tessellation the tet
/// size can use passes through unchanged, bit for bit. Otherwise:
/// - `local`: removes duplicate and degenerate triangles, splits pinch vertices (one copy per fan,
///   each moved a little into its own solid), fills holes whose perimeter is at most
///   `max_hole_perimeter` hex edges (CGAL PMP), orients; the geometry elsewhere is left alone;
/// - `levelset`: the OpenVDB level set of the surface at a voxel well below the hex edge, meshed
///   back: for closed surfaces with self-intersections, overlaps, non-manifold edges and pinches;
/// - `alpha_wrap`: CGAL 3D Alpha Wrapping: for open surfaces, large holes and triangle soups;
/// - `auto` (the variant of the default configs): `local` where it leaves a clean surface, else
///   `levelset` where the surface has no open boundary, else `alpha_wrap`.
/// Every repair is checked by diagnosing its result again, and costed: the sampled distances between
/// the repaired surface and the original, in hex edges. Remeshing to size (CGAL isotropic remeshing,
/// sharp edges kept) applies when the tessellation is much finer than the tet size, and always
/// after a level set (whose output is at voxel size); where triangles of the tet size would cross
/// (two parts of the surface closer than that), a finer target is used, down to half; a wrap is always remeshed (its
/// triangles follow the wrapping, not the size).
#pragma once

#include "nodes/artefacts/meshes.h"

#include <string>
#include <vector>

namespace polyhex {

/// What is wrong with a triangle surface, and how fine it is. Counts of zero mean none.
struct SurfaceDiagnosis {
  long vertices = 0, faces = 0;
  long boundary_edges = 0;         ///< edges in exactly one triangle
  long boundary_loops = 0;         ///< open boundary loops
  long longest_loop_edges = 0;     ///< edges of the longest loop
  double longest_loop_length = 0;  ///< its length, in hex edges
  long nonmanifold_edges = 0;      ///< edges in more than two triangles
  long nonmanifold_vertices = 0;   ///< vertices whose triangles form more than one fan (pinch points)
  long duplicate_faces = 0;        ///< triangles on the same three vertices as an earlier one
  long degenerate_faces = 0;       ///< repeated vertex or zero area
  long sliver_faces = 0;           ///< smallest angle below 1 degree (not a defect: reported)
  long self_intersections = 0;     ///< pairs of triangles that cross (count_self_intersections)
  bool orientable = true;          ///< the manifold part admits a consistent orientation
  long components = 0;             ///< connected through shared edges
  double volume = 0;               ///< enclosed volume of the consistently oriented surface, fraction of
                                   ///< its bounding box's volume (meaningful only when closed)
  double area = 0;                 ///< total area, in hex edges squared
  double thickness = 0;            ///< 4 volume / area, in hex edges: the diameter of a rod, twice a
                                   ///< plate's thickness (meaningful only when closed)
  /// How much finer the input is than the tet size asks: sqrt of the triangles the input forces on
  /// the tet mesher (each triangle's area over the square of its smallest altitude, capped at the
  /// tet edge) over those a tessellation at the tet size gives: 1 at the tet size, k for edges k
  /// times shorter, below 1 for coarser input; a sliver counts as the small triangles it forces.
  double tessellation_ratio = 0;

  /// True when the tet mesher cannot take the surface as it is.
  bool defective() const;
  /// One phrase per defect ("3 open boundary loops (longest 12 edges)"), empty when none.
  std::vector<std::string> defects() const;
};

/// The repair the variant asks for.
enum class SurfaceRepair { automatic, local, levelset, alpha_wrap };

/// What a defect gets: a repair with a warning (JSON "auto"), or a refusal ("strict").
enum class DefectPolicy { repair, strict };
/// When the surface is remeshed to the tet size: when it is finer than remesh_finer_than (JSON "auto"),
/// never, always.
enum class RemeshWhen { finer, never, always };

struct ConditionParams {
  DefectPolicy policy = DefectPolicy::repair;  ///< repair defects, with a warning, or refuse any defect
  RemeshWhen remesh = RemeshWhen::finer;       ///< finer: when tessellation_ratio > remesh_finer_than; never; always
  double edge_length = 0.02;                   ///< tet edge, fraction of the reference length (as tetrahedralize's)
  double hex_edge_length = 0.01;               ///< hex edge, fraction of the reference length (costs, voxel, bounds)
  double remesh_finer_than = 4.0;              ///< remesh when the tessellation is this many times finer than the tets
  double feature_angle = 35;                   ///< degrees: sharp edges kept by the remeshing
  int remesh_iterations = 3;                   ///< isotropic remeshing iterations
  double voxel = 0.25;                         ///< level-set voxel, in hex edges
  double alpha = 2.0;                          ///< alpha-wrap ball, in hex edges: gaps narrower than this are closed
  double offset = 0.1;                         ///< alpha-wrap offset from the input, in hex edges
  double max_hole_perimeter = 50;              ///< local repair fills holes up to this perimeter, in hex edges
  double max_deviation = 2.0;                  ///< refuse a level set, wrap or remesh whose surface strays farther than
                                               ///< this from the original, in hex edges
  double min_thickness = 1.0;                  ///< refuse a result thinner than this (4 volume / area), in hex edges
};

/// What condition_surface did.
struct ConditionReport {
  SurfaceDiagnosis input;       ///< the original's diagnosis
  SurfaceDiagnosis output;      ///< the result's (equal to input when passed through)
  std::string repair = "none";  ///< none | local | levelset | alpha_wrap
  bool remeshed = false;
  double remesh_edge = 0;      ///< the remeshing's edge, in tet edges: 1, or finer where the first
                               ///< target left crossing triangles (down to 1/2)
  bool passed_through = true;  ///< the output is the input, bit for bit
  long feature_edges = 0;      ///< sharp edges the remeshing kept
  int holes_filled = 0, pinches_split = 0;
  /// Sampled maximum distances between the result and the original, in hex edges: from the original
  /// to the result (large where a union drops inner parts of the input) and back (how far the
  /// result strays from the input: bounded by max_deviation).
  double deviation_from_original = 0, deviation_to_original = 0;
  std::vector<std::string> warnings;
};

/// Diagnoses a triangle surface.
/// \param hex_edge  hex edge, absolute (for the loop lengths and the area)
/// \param tet_edge  tet edge, absolute (for the tessellation ratio)
/// \pre every index of s.F in [0, s.V.rows()), coordinates finite
SurfaceDiagnosis diagnose_surface(const SurfaceMesh& s, double hex_edge, double tet_edge);

/// Conditions a surface for the tet mesher (see the file comment).
/// \pre every index of s.F in range, coordinates finite; 0 < hex_edge_length, edge_length
/// \throw InvalidInput naming s.source: policy strict and a defect; a defect no repair of the variant
///        removes; a result straying farther than max_deviation from the original, thinner than min_thickness,
///        or enclosing no volume (a single triangle, three faces of a tetrahedron wrapped flat)
SurfaceMesh condition_surface(const SurfaceMesh& s, SurfaceRepair repair, const ConditionParams& p,
                              ConditionReport& report);

}  // namespace polyhex
