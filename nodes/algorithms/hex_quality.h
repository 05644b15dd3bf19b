/// @file hex_quality.h
/// @brief Quality of an all-hex mesh, optionally against the surface it should approximate.
///
/// Every figure has exactly the definition of `../shared/tools/hexcheck.py` (the independent
/// checker), so the report and the checker agree:
/// - scaled Jacobian (Verdict, Pebay et al. 2007): the minimum over the 8 corner Jacobians and the
///   centre (principal axes) Jacobian, each divided by the product of its three vector lengths and
///   clamped to [-1, 1]; a zero-length vector gives 0 (a degenerate hex is never perfect);
/// - inverted: a hex whose minimum corner scaled Jacobian is <= 0;
/// - irregular vertex: interior vertex with edge valence != 6, or boundary vertex with != 4
///   boundary quads;
/// - distances: symmetric surface-to-surface distances between the hex boundary (quads split
///   0-1-2 / 0-2-3) and the surface, from points sampled uniformly by area on both, relative to the
///   bounding-box diagonal of the surface. Here the distance of a sample is exact (AABB tree over
///   the triangles), where hexcheck approximates it from the 24 nearest triangle centroids.
#pragma once

#include "nodes/algorithms/feature_fidelity.h"
#include "nodes/artefacts/meshes.h"

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <vector>

namespace polyhex {

struct QualityParams {
  int samples = 100000;                  ///< points sampled on each of the two surfaces for the distances
  std::uint64_t seed = 1;                ///< seed of the sampler (fixed, so reports are reproducible)
  double feature_angle = kFeatureAngle;  ///< feature fidelity: creases and hex feature edges sharper than this
                                         ///< (degrees, features.h), 0 = not measured, [0, 179]
};

/// The figures of a hex mesh (keys of hexcheck.py in comments where the name differs).
struct HexQuality {
  long hexes = 0;
  long vertices = 0;
  long inverted = 0;                            ///< hexes with corner scaled Jacobian min <= 0
  double sj_min = 0, sj_avg = 0;                ///< scaled Jacobian with the centre term
  double sj_corner_min = 0, sj_corner_avg = 0;  ///< corners only
  long sj_below_0_2 = 0;                        ///< hexes with sj < 0.2
  double volume = 0;                            ///< signed volume, 5 tets per hex
  double irregular_pct = 0, irregular_interior_pct = 0, irregular_boundary_pct = 0;
  long unused_vertices = 0;
  long faces_shared_by_more_than_two = 0;  ///< distinct faces (as vertex sets) used by > 2 hexes
  long nonmanifold_boundary_edges = 0;     ///< boundary edges not in exactly two boundary quads
  long boundary_quads = 0;
  bool has_surface = false;   ///< the four figures below are set
  double bbox_diag = 0;       ///< bounding-box diagonal of the surface
  double hausdorff_mean = 0;  ///< (mean hex->surface + mean surface->hex) / 2 / bbox_diag
  double hausdorff_max = 0;   ///< max over both directions / bbox_diag
  double volume_ratio = 0;    ///< |volume| / |volume enclosed by the surface| (0 unless every edge of
                              ///< the surface is in exactly two triangles)
  /// The surface has no edge in just one triangle. Against an open surface (an input with holes,
  /// measured before its repair) the distances are one-sided, surface -> hex boundary: the hex
  /// boundary over a hole has no surface to be near.
  bool surface_closed = true;
  /// With a surface and feature_angle > 0: the hex edge the mesh was made at (median boundary edge), and
  /// the distances between the surface's crease lines and the hex boundary's edges (feature_fidelity.h),
  /// crease lines of at least 1.5 hex edges, sharp at half a hex edge (features.h sharp_edges); the hex
  /// edge and the distances relative to bbox_diag.
  bool has_features = false;
  double hex_edge = 0;
  FeatureFidelity features;
  Eigen::VectorXd sj;         ///< #H scaled Jacobian of every hex (centre term included)
  Eigen::VectorXd sj_corner;  ///< #H minimum corner scaled Jacobian of every hex
};

/// Scaled Jacobian of one hex.
struct HexSJ {
  double sj;          ///< min over the 8 corners and the centre term
  double corner_min;  ///< min over the 8 corners
};

/// Scaled Jacobian of one hex given its 8 corners in VTK_HEXAHEDRON order.
HexSJ hex_scaled_jacobian(const std::array<Eigen::Vector3d, 8>& p);

/// The same, and its 9 terms: terms[0..7] the corners (each in [-1, 1], 0 for a zero-length edge),
/// terms[8] the centre principal axes; sj is their minimum.
HexSJ hex_scaled_jacobian(const std::array<Eigen::Vector3d, 8>& p, std::array<double, 9>& terms);

/// The same after only corner j has moved: `before` holds the 9 terms of an earlier evaluation of this hex
/// at which its other 7 corners were where they are now. The 4 corner terms that do not involve corner j
/// (its 3 face-diagonal corners and the opposite one) are copied from it, the other 5 computed: the result
/// and `terms` are bit for bit those of the full evaluation. The optimizer's per-vertex descents use it.
/// \pre 0 <= j < 8
HexSJ hex_scaled_jacobian_moved(const std::array<Eigen::Vector3d, 8>& p, int j, const std::array<double, 9>& before,
                                std::array<double, 9>& terms);

/// Scaled Jacobian of every hex (in parallel).
/// \param sj         out: #H with the centre term  \param corner_min  out: #H corners only
/// \pre indices of mesh.H in range (see check_hex_mesh)
void hex_scaled_jacobians(const HexMesh& mesh, Eigen::VectorXd& sj, Eigen::VectorXd& corner_min);

/// Edge ratio of every hex (Verdict's hex edge ratio): its longest of the 12 edges over its shortest;
/// +inf when an edge has zero length.
/// \return #H, each >= 1   \pre indices of mesh.H in range
Eigen::VectorXd hex_edge_ratios(const HexMesh& mesh);

/// The irregular vertices, by the definition of HexQuality::irregular_pct (its numerator).
/// \return #V: 1 for an irregular vertex, 0 for a regular or unused one   \pre indices of mesh.H in range
std::vector<char> irregular_vertices(const HexMesh& mesh);

/// Signed volume of the mesh: each hex as the 5 tets (0,1,3,4) (1,2,3,6) (1,3,4,6) (1,4,5,6) (3,4,6,7).
/// \pre indices of mesh.H in range
double hex_mesh_volume(const HexMesh& mesh);

/// Boundary quads: hex faces (as vertex sets) used by exactly one hex, in the hex's own vertex
/// order, which faces outward for a positive hex. Rows in order of (hex, face).
/// \param hex_of_quad  out (optional): the hex of each row
/// \param face_of_quad  out (optional): its local face 0..5 in that hex (hex_topology::kFaces)
/// \return #Q by 4   \pre indices of mesh.H in range
Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor> hex_boundary_quads(const HexMesh& mesh,
                                                                          std::vector<int>* hex_of_quad = nullptr,
                                                                          std::vector<int>* face_of_quad = nullptr);

/// Checks that a hex mesh can be measured.
/// \throw InvalidInput when it has no hexes, an index is out of range or a coordinate is not finite
///        (the message names the mesh source, the hex or vertex and the value)
void check_hex_mesh(const HexMesh& mesh);

/// Sampled distances between two triangle sets, each sample's distance exact.
struct SurfaceDistance {
  double mean_ab = 0, max_ab = 0;  ///< from samples on A to B
  double mean_ba = 0, max_ba = 0;  ///< from samples on B to A
};
/// \param Va,Vb  #V by 3   \param Fa,Fb  #F by 3   \param samples  points on each of A and B
/// \throw InvalidInput when a set has no area, an index is out of range or samples < 1
SurfaceDistance sampled_surface_distance(const RowMatrixX3d& Va, const RowMatrixX3i& Fa, const RowMatrixX3d& Vb,
                                         const RowMatrixX3i& Fb, int samples, std::uint64_t seed);

/// All figures of the mesh, and with a surface the distance and volume figures.
/// \param surface  the input surface, or null
/// \throw InvalidInput from check_hex_mesh; when the surface has an index out of range, a non-finite
///        coordinate, no area, or is closed and manifold and encloses no volume; when p.samples < 1
HexQuality hex_quality(const HexMesh& mesh, const SurfaceMesh* surface, const QualityParams& p = {});

}  // namespace polyhex
