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
/// Beyond the paper, the surface flattening (`flatten` = β; 0 gives the paper's Eq. 1) removes, in Eq. 1's
/// right-hand side, part of each surface edge's component along the axis its two end normals share. Both
/// matrices are constant for a whole run (factored once). The linear systems, the flattening and the
/// measurements behind them: docs/rotation_deform.md.
#pragma once

#include "nodes/artefacts/meshes.h"
#include "runtime/factorization.h"
#include "runtime/stat_fields.h"

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

  /// Report names (runtime/stat_fields.h): one array per field over the iterations.
  static constexpr auto fields() {
    using S = RotationIterationStats;
    return std::make_tuple(stat("alignment", &S::alignment), stat("inverted_tets", &S::inverted_tets),
                           stat("distortion", &S::distortion), stat("distortion_max", &S::distortion_max),
                           stat("volume_ratio", &S::volume_ratio), stat("min_quaternion_norm", &S::min_quaternion_norm),
                           stat("feature_vertices", &S::feature_vertices), stat("iteration_seconds", &S::seconds));
  }
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

  /// Report names (runtime/stat_fields.h); factor_stats reports itself (FactorizationStats::merge_into).
  static constexpr auto fields() {
    using S = RotationDeformResult;
    return std::make_tuple(stat("iterations", &S::iterations), stat("alignment_input", &S::input_alignment),
                           stat("assemble_seconds", &S::assemble_seconds),
                           stat("boundary_vertices", &S::boundary_vertices), stat("boundary_faces", &S::boundary_faces),
                           stat("components", &S::components));
  }
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
