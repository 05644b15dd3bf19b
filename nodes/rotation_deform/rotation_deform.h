/// @file rotation_deform.h
/// @brief Rotation-driven deformation (paper §4): the tet mesh is deformed, iteration by iteration,
/// so that its boundary normals align with ±X, ±Y, ±Z while the volume keeps its shape.
///
/// One iteration (§4.1, §4.2), on the current mesh with positions Ṽ:
///  1. boundary faces (faces used by one tet, oriented outward) and area-weighted vertex normals;
///  2. feature vertices: a boundary vertex is a feature when two of its incident boundary triangles
///     have normals more than `feature_angle` degrees apart (n_a · n_b < cos(feature_angle));
///  3. every other boundary vertex gets the minimal rotation taking its normal to the closest axis,
///     coherently oriented (coherent_quaternion) so q_w > 0;
///  4. one Laplace problem per quaternion component, boundary anchors as soft least-squares terms;
///  5. the field is normalised to unit quaternions ∇_i;
///  6. Eq. 1 is integrated for every vertex with one vertex pinned per connected component:
///     v_i - v_j ≈ ½(∇_i + ∇_j)(ṽ_i - ṽ_j).
/// The next iteration starts from the deformed positions.
///
/// Linear systems (designed so both matrices are constant for a whole run: 1 analysis + 1 numeric
/// factorization each, then only right-hand sides change):
///  - quaternion field: minimise Σ_edges |q_i - q_j|² + w² Σ_{boundary b} |q_b - a_b|², i.e.
///    (L + w² S) q = w² S a per component, L the uniform-weight graph Laplacian of the tet edges
///    (degree on the diagonal, -1 per edge), S the 0/1 diagonal of the boundary vertices. This
///    Dirichlet form (not the bi-Laplacian L^T L of stacked Laplace rows) has a 1-ring stencil, and
///    (L + w² S)^{-1} w² S is entrywise non-negative with unit row sums: every interior quaternion
///    is a convex combination of anchor quaternions, exactly the positive, convex weights §4.1 relies
///    on, so q_w > 0 everywhere and no interpolated quaternion is degenerate.
///  - Feature vertices change from iteration to iteration, but S does not: every boundary vertex
///    keeps its anchor row, and a feature vertex's anchor target (right-hand side only) is the
///    normalised mean of the targets of its non-feature boundary neighbours (propagated ring by ring
///    along the surface; identity if a surface component has no non-feature vertex). Its own,
///    unreliable normal (an average across a crease) so never drives the field, which is what
///    "excluded from the constraints" asks for, and the matrix stays the same.
///  - Eq. 1 multiplied by the degree N_i is L v = Σ_j ½(∇_i+∇_j)(ṽ_i-ṽ_j): the same graph Laplacian;
///    the pinned vertex's row and column are replaced by the identity (its value moved to the
///    right-hand side). L depends only on connectivity, so it is factored once.
///
/// Surface flattening (beyond the paper; `flatten` = β, default 1, 0 gives the paper's Eq. 1): in
/// the right-hand side of Eq. 1, the target vector e = ½(∇_i+∇_j)(ṽ_i-ṽ_j) of a surface edge whose
/// two end vertices are non-features with the same closest signed axis a loses the share β w of its
/// component along a: e ← e - β w (e·a) a. The edge (j, i) gets -e, so the system stays the
/// least-squares form of Eq. 1 and its matrix does not change (still factored once per run). Why:
/// the rotation field is the solution of a Laplace problem, smooth at the scale of a few tets, so
/// the paper's Eq. 1 rotates a bump of that size as a whole instead of flattening it; the per-edge
/// projection removes the bump's height where the labels already agree, and the volume follows in
/// the same solve. The axis comes from the vertex normal, exactly the axis its rotation targets.
/// w fades with the larger deviation of the two end normals from a: 1 up to `flatten_full_angle`
/// (30°), 0 from `flatten_max_angle` (50°), linear between. Where a normal lies near the bisector of
/// two axes its label is a coin toss, and flattening both sides towards their axes folds a smooth
/// curved transition into a crease: extra charts. Unweighted (w = 1 everywhere), the built-in
/// fandisk_like shape (throughput_200k) got 18 charts instead of 13 and its optimizer 1.6x the time
/// (min scaled Jacobian 0.605 against 0.698); with the fade, 13 charts, 0.690.
///
/// Measured (tets at edge length 0.02, 5 iterations; alignment after iteration 5 / inverted tets),
/// β = 0 (paper) -> default:
///   bunny        0.585 /  505  ->  0.787 /  467
///   fandisk      0.933 /   48  ->  0.972 /   35
///   rockerarm    0.775 /  943  ->  0.880 /  718
///   fertility    0.603 / 2126  ->  0.780 / 1802
///   bumpy_torus  0.530 / 1218  ->  0.725 / 1016
///   casting      0.883 /  402  ->  0.935 /  256
/// Unweighted β = 1 gave about the same alignment (bumpy_torus 0.741) with more charts on smooth CAD
/// surfaces; β = 0.5 lies between; rescaling the projected edge to its old length changed alignment by
/// < 0.005. The flattened bumps' volume goes: a few % more volume loss.
///
/// Variants of the paper's formulation measured before (β = 0) and rejected: each trades alignment
/// for several times more inverted tets, or does not raise alignment at all:
///  - anchor weight per vertex w² N_v (the balance of the paper's normalised Laplace row q_i - mean_j q_j
///    against a unit anchor row): bunny 0.681 / 3085, fertility 0.667 / 6639, bumpy_torus 0.649 / 11472;
///    alignment stops rising after iteration 4 on rockerarm, fertility, casting. Downstream
///    anchor_weight 2 made the final hexes worse (bunny sj_min -0.090 against -0.006 at 1, at the time).
///  - target axis chosen from normals smoothed over 3 or 10 surface rings: within ±0.005 of the raw
///    choice; rotating the smoothed normal is worse (bunny 0.557).
///  - features off (feature_angle 180): within 0.001.
///  - Eq. 1 on the input edges with accumulated rotations ∇_k ... ∇_1: lower alignment (bunny 0.561),
///    more inverted tets and volume loss; "each iteration starts from the previous deformed mesh" is kept.
/// The paper's formulation alone left the noisy organic models (bunny, fertility, bumpy_torus) at
/// 0.53-0.60: their surface detail is a few tets wide, below what a fold-free smooth rotation field
/// flattens; the flattening term acts exactly at that scale.
#pragma once

#include "nodes/artefacts/meshes.h"
#include "runtime/factorization.h"

#include <Eigen/Core>

#include <functional>
#include <string>
#include <vector>

namespace polyhex {

/// Parameters of rotation_deform (JSON keys are the field names).
struct RotationDeformParams {
  int iterations = 5;          ///< rotation-driven iterations (§4.2: 5), range [1, 50]
  double anchor_weight = 1.0;  ///< w, weight of the soft boundary anchors (§4.1: unit), (0, 1e6]
  double feature_angle =
      60.0;              ///< degrees: a vertex whose incident boundary normals differ by more is a feature, [0, 180]
  double flatten = 1.0;  ///< β of the surface flattening in Eq. 1 (0 = the paper's Eq. 1; see the file comment), [0, 1]
  double flatten_full_angle =
      30;  ///< degrees: edges whose end normals are within this of their axis get the full β, [0, 90]
  double flatten_max_angle =
      50;  ///< degrees: from this deviation on no flattening (linear between), (flatten_full_angle, 90]
  SolveMode solve_mode =
      SolveMode::MultiColumn;    ///< one 4- and one 3-column solve, or TBB over columns (runtime/factorization.h)
  bool save_iterations = false;  ///< the binding writes each iteration's mesh as <out>/<id>.iter<k>.vtk
};

/// Figures of one iteration, measured on its deformed mesh.
struct RotationIterationStats {
  double alignment = 0;       ///< area fraction of boundary triangles whose normal is within 15° of its closest axis
  int inverted_tets = 0;      ///< tets with non-positive signed volume
  double distortion = 0;      ///< mean conformal distortion ||F||_F ||F^-1||_F / 3 (1 = similarity) of the non-inverted
                              ///< tets, F relative to the run's input
  double distortion_max = 0;  ///< max of the same
  double volume_ratio = 0;    ///< total signed volume / input volume
  double min_quaternion_norm = 0;  ///< smallest |q| of the interpolated field before normalisation
  int feature_vertices = 0;        ///< boundary vertices classed as features this iteration
  double seconds = 0;              ///< wall time of the iteration
};

/// Output of rotation_deform.
struct RotationDeformResult {
  TetMesh mesh;                                    ///< deformed mesh: input connectivity and source, new positions
  std::vector<RotationIterationStats> iterations;  ///< one entry per iteration
  double input_alignment = 0;                      ///< alignment of the input mesh
  FactorizationStats factor_stats;                 ///< both systems together
  double assemble_seconds = 0;                     ///< topology (boundary, edges), matrices
  int boundary_vertices = 0;
  int boundary_faces = 0;
  int components = 0;  ///< connected components = pinned vertices
};

/// Called after every iteration k (1-based) with the deformed mesh and its figures.
using IterationCallback = std::function<void(int k, const TetMesh& deformed, const RotationIterationStats&)>;

/// Rotation-driven deformation of a tet mesh (paper §4), `params.iterations` times.
/// \pre tets.T indices in range, every vertex used by a tet, positive tets, finite positions
/// \throw InvalidInput for an empty mesh, an index out of range, an unused vertex or a non-finite
///        position; ConfigError for params out of range;
///        SolverError if a factorization fails; Interrupted after SIGINT/SIGTERM (runtime/cancel.h),
///        checked before each factorization and twice per iteration
RotationDeformResult rotation_deform(const TetMesh& tets, const RotationDeformParams& params,
                                     const IterationCallback& on_iteration = {});

// ---------------------------------------------------------------------------------------------
// Building blocks (public for tests)

/// Coherent orientation (§4.1): among the 24 proper cube symmetries P (signed permutations,
/// det +1), the one maximising trace(R P) (columns of R reordered and reflected), converted to a
/// quaternion (x, y, z, w) with w > 0 — the equivalent closest to the identity.
/// \pre R a rotation matrix
Eigen::Vector4d coherent_quaternion(const Eigen::Matrix3d& R);

/// Minimal rotation R (R n = a) taking unit normal n to the closest of ±X, ±Y, ±Z (§4.1).
/// \pre |n| = 1
Eigen::Matrix3d axis_aligning_rotation(const Eigen::Vector3d& n);

/// The same towards a given axis direction a (label_dir of a label whose direction is within 90° of n).
/// \pre |n| = 1, n.a > 0
Eigen::Matrix3d axis_aligning_rotation(const Eigen::Vector3d& n, const Eigen::Vector3d& a);

/// Boundary faces of a tet mesh: faces used by exactly one tet, oriented outward.
/// \return F  #F by 3  \pre T positively oriented, indices in [0, nV)
RowMatrixX3i boundary_faces(const RowMatrixX4i& T, int nV);

/// Area fraction of the triangles F whose normal is within `angle_deg` of its closest axis.
/// V  #V by 3, F  #F by 3. 0 when the total area is 0.
double axis_alignment(const RowMatrixX3d& V, const RowMatrixX3i& F, double angle_deg = 15.0);

}  // namespace polyhex
