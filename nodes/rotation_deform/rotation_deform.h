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
/// Measured limits (edge length 0.02, 5 iterations; alignment after iteration 5 / inverted tets):
/// the target of alignment >= 0.7 on every model is NOT met by this (paper) formulation
/// with unit anchors: bunny 0.583 / 488, fandisk 0.935 / 82, rockerarm 0.778 / 1085,
/// fertility 0.602 / 2103, bumpy_torus 0.530 / 1217, casting 0.884 / 455. Variants measured and
/// rejected (kept out of the code because none reaches 0.7 everywhere without several times more
/// inverted tets):
///  - anchor weight per vertex w² N_v (the balance of the paper's normalised Laplace row q_i - mean_j q_j
///    against a unit anchor row): bunny 0.681 / 3085, fandisk 0.943 / 374, rockerarm 0.817 / 4617,
///    fertility 0.667 / 6639, bumpy_torus 0.649 / 11472, casting 0.915 / 1659; alignment stops rising
///    after iteration 4 on rockerarm, fertility, casting. w² = N_v / 4 lies between (bunny 0.653 / 1138,
///    fertility 0.654 / 3808, bumpy_torus 0.612 / 4292): alignment and inversions trade along one curve,
///    so `anchor_weight` is the alignment-strength knob and stays at the paper's 1. Downstream
///    (configs/polycube.json) anchor_weight 2 gives bunny alignment 0.671 but final hex sj_min -0.090 /
///    sj_avg 0.928 against -0.006 / 0.931 at 1 (fandisk -0.054 / 0.951 against -0.004 / 0.959).
///  - Inverted tets are boundary slivers: of bunny's 488 (fertility 2103) after iteration 5, 476 (1865)
///    touch the boundary and 328 (584) are among the 5 % worst-shaped input tets.
///  - target axis chosen from normals smoothed over 3 or 10 surface rings (rotation still from the raw
///    normal): within ±0.005 of the raw choice on all six models; the axis choice is not what limits.
///    Rotating the smoothed normal (a smooth field that leaves bumps unflattened) is worse
///    (bunny 0.557, fertility 0.528 with w² N_v).
///  - features off (feature_angle 180): bunny 0.584, fertility 0.602, bumpy_torus 0.530: the feature
///    rule does not limit either.
///  - Eq. 1 on the input edges with accumulated rotations ∇_total = ∇_k ... ∇_1 (instead of this
///    iteration's rotations on the previous mesh): lower alignment (bunny 0.561) and more inverted
///    tets (fertility 3360, bumpy_torus 1708), more volume loss (fertility 0.73): the paper's
///    "each iteration starts from the previous deformed mesh" is kept.
/// The models below 0.7 (bunny, fertility, bumpy_torus) carry surface detail (fur-like noise, bumps)
/// at a scale of a few tets: a rotation field smooth enough to integrate without folding does not
/// flatten it, and the 15° per-triangle measure counts it as unaligned.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "nodes/artefacts/meshes.h"
#include "runtime/factorization.h"

namespace polyhex {

/// Parameters of rotation_deform (JSON keys are the field names).
struct RotationDeformParams {
  int iterations = 5;            ///< rotation-driven iterations (§4.2: 5), range [1, 50]
  double anchor_weight = 1.0;    ///< w, weight of the soft boundary anchors (§4.1: unit), (0, 1e6]
  double feature_angle = 60.0;   ///< degrees: a vertex whose incident boundary normals differ by more is a feature, [0, 180]
  std::string solve_mode = "multi_column";  ///< "multi_column" (one 4- and one 3-column solve) or "parallel" (TBB over columns)
  bool save_iterations = false;  ///< the binding writes each iteration's mesh as <out>/<id>.iter<k>.vtk
};

/// Figures of one iteration, measured on its deformed mesh.
struct RotationIterationStats {
  double alignment = 0;          ///< area fraction of boundary triangles whose normal is within 15° of its closest axis
  int inverted_tets = 0;         ///< tets with non-positive signed volume
  double distortion = 0;         ///< mean conformal distortion ||F||_F ||F^-1||_F / 3 (1 = similarity) of the non-inverted tets, F relative to the run's input
  double distortion_max = 0;     ///< max of the same
  double volume_ratio = 0;       ///< total signed volume / input volume
  double min_quaternion_norm = 0;///< smallest |q| of the interpolated field before normalisation
  int feature_vertices = 0;      ///< boundary vertices classed as features this iteration
  double seconds = 0;            ///< wall time of the iteration
};

/// Output of rotation_deform.
struct RotationDeformResult {
  TetMesh mesh;                              ///< deformed mesh: input connectivity and source, new positions
  std::vector<RotationIterationStats> iterations;  ///< one entry per iteration
  double input_alignment = 0;                ///< alignment of the input mesh
  FactorizationStats factor_stats;           ///< both systems together
  double assemble_seconds = 0;               ///< topology (boundary, edges), matrices
  int boundary_vertices = 0;
  int boundary_faces = 0;
  int components = 0;                        ///< connected components = pinned vertices
};

/// Called after every iteration k (1-based) with the deformed mesh and its figures.
using IterationCallback = std::function<void(int k, const TetMesh& deformed, const RotationIterationStats&)>;

/// Rotation-driven deformation of a tet mesh (paper §4), `params.iterations` times.
/// \pre tets.T indices in range, every vertex used by a tet, positive tets, finite positions
/// \throw InvalidInput for an empty mesh, an index out of range, an unused vertex or a non-finite
///        position; ConfigError for params out of range or an unknown solve_mode;
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

/// Boundary faces of a tet mesh: faces used by exactly one tet, oriented outward.
/// \return F  #F by 3  \pre T positively oriented, indices in [0, nV)
RowMatrixX3i boundary_faces(const RowMatrixX4i& T, int nV);

/// Area fraction of the triangles F whose normal is within `angle_deg` of its closest axis.
/// V  #V by 3, F  #F by 3. 0 when the total area is 0.
double axis_alignment(const RowMatrixX3d& V, const RowMatrixX3i& F, double angle_deg = 15.0);

}  // namespace polyhex
