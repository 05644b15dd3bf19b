/// @file untangle_global.h
/// @brief Global untangling of a hex mesh (paper §6 optimization, first phase): all free vertices near
/// the inverted hexes move at once, by L-BFGS on the regularised Winslow energy of the "foldover-free
/// maps" line of work (Garanzha, Kaporin, Kudryavtseva, Protais, Ray, Sokolov 2021, "Foldover-free maps
/// in 50 lines of code"), with their ε schedule.
///
/// Energy: Σ over the active hexes and their 9 Jacobians (8 corners and the centre principal axes, the
/// ones of the Verdict scaled Jacobian) of |J|_F² / (3 χ(det J, ε)^{2/3}), χ(D, ε) = (D + sqrt(ε² + D²)) / 2,
/// J over the hex's initial mean edge length. Finite for inverted Jacobians, so the minimiser walks out of
/// folds; ε shrinks as the minimum determinant grows, and the energy becomes a barrier as ε -> 0.
/// A local Gauss-Seidel descent moves one vertex at a time and stalls where several vertices must move
/// together (a hex folded against the surface, whose boundary quad is folded on it): the global descent
/// moves them together.
///
/// Untangling stops as soon as no hex is inverted, which leaves some barely valid; a last L-BFGS run at
/// ε -> 0 (the energy is then a barrier against inversion) spreads the distortion ("polish").
///
/// Boundary vertices kept on the surface move in the tangent plane of their closest surface triangle
/// (two unknowns each) and are projected back onto the surface after each L-BFGS run.
/// Deterministic: per-hex terms are computed in parallel into arrays and summed in a fixed order.
#pragma once

#include "nodes/algorithms/triangle_tree.h"
#include "nodes/artefacts/meshes.h"

#include <array>
#include <vector>

namespace polyhex {

struct GlobalUntangleParams {
  int outer_iterations = 40;   ///< ε updates (each followed by one L-BFGS run), [0, 1000]
  int lbfgs_iterations = 200;  ///< iterations of one L-BFGS run, [1, 100000]
  int rings = 3;               ///< free vertices: the inverted hexes' vertices grown by this many hex rings, [0, 50]
  int polish_iterations =
      100;             ///< once untangled: L-BFGS iterations at ε -> 0 (a barrier: no hex inverts), [0, 100000]
  double seconds = 0;  ///< wall-time budget, checked per L-BFGS iteration (the mesh so far is kept); 0 = none
};

struct GlobalUntangleStats {
  int outer = 0;              ///< ε updates done
  long lbfgs_iterations = 0;  ///< L-BFGS iterations, all runs
  long free_vertices = 0;
  long inverted_before = 0, inverted_after = 0;  ///< hexes with a corner scaled Jacobian <= 0
  bool time_budget_hit = false;                  ///< stopped at p.seconds
};

/// Untangles the hexes of H around its inverted ones by global L-BFGS descent (see the file comment).
/// \param V           #V by 3 positions, updated in place
/// \param H           #H by 8 hexes, VTK_HEXAHEDRON order, indices in range
/// \param on_surface  #V flags: 1 = the vertex stays on `tree`'s surface (tangent moves, projected)
/// \param fixed       #V flags: 1 = the vertex does not move
/// \param tree        the surface (closest points), used for on_surface vertices
/// \param normals     unit normal of every triangle of `tree`
/// \return the number of inverted hexes left
/// \pre on_surface.size() == fixed.size() == V.rows(); normals.size() == tree.triangles()
long untangle_global(RowMatrixX3d& V, const RowMatrixX8i& H, const std::vector<char>& on_surface,
                     const std::vector<char>& fixed, const TriangleTree& tree,
                     const std::vector<Eigen::Vector3d>& normals, const GlobalUntangleParams& p = {},
                     GlobalUntangleStats* stats = nullptr);

/// Smooths the hexes around `seeds` (#H flags): the seeds' vertices grown by p.rings rings move together by
/// L-BFGS on the same energy at ε -> 0, where it is a barrier against inversion (p.polish_iterations
/// iterations), surface vertices in their tangent planes and projected back; undone if the projection
/// inverts a hex. Nothing happens when a hex of the region is inverted.
/// \pre as untangle_global(); seeds.size() == H.rows()
void smooth_region(RowMatrixX3d& V, const RowMatrixX8i& H, const std::vector<char>& on_surface,
                   const std::vector<char>& fixed, const TriangleTree& tree,
                   const std::vector<Eigen::Vector3d>& normals, const std::vector<char>& seeds,
                   const GlobalUntangleParams& p, GlobalUntangleStats* stats = nullptr);

/// The ascent's own settings (raise_average).
struct AverageAscentParams {
  double barrier = 0.01;  ///< weight of the Winslow barrier, >= 0
  double tolerance =
      0;  ///< stop when 25 iterations raise the scaled Jacobian by less than this per hex of the region, >= 0
  double work = 1e12;  ///< iterations are also capped at work / the hexes of the region, > 0
};

/// Raises the average scaled Jacobian around `seeds` (#H flags): the seeds' vertices grown by p.rings rings
/// move together by L-BFGS (at most p.polish_iterations iterations and at most a.work / the hexes of the
/// region; it stops when 25 of them raise the sum of the region's scaled Jacobians, the measure the report
/// gives, by less than a.tolerance per hex: the energy below also pays for evening out a hex's 9 Jacobians
/// above its minimum, which the report does not see) on
/// Σ_h -soft_sj(h) + a.barrier · Σ_h E_h, soft_sj the soft minimum of the hex's 9 scaled Jacobians
/// (hex_soft_scaled_jacobian), E_h the Winslow energy at ε -> 0, a barrier against inversion (a hex must
/// pass a zero determinant to invert); surface vertices in their tangent planes, projected back. The
/// minimum scaled Jacobian may fall: the caller checks.
/// \return false (V unchanged) when the region is empty, has an inverted hex or the work cap allows no iteration
/// \pre as untangle_global(); seeds.size() == H.rows(); a's fields in their ranges
bool raise_average(RowMatrixX3d& V, const RowMatrixX8i& H, const std::vector<char>& on_surface,
                   const std::vector<char>& fixed, const TriangleTree& tree,
                   const std::vector<Eigen::Vector3d>& normals, const std::vector<char>& seeds,
                   const AverageAscentParams& a, const GlobalUntangleParams& p, GlobalUntangleStats* stats = nullptr);

/// The minimum ascent's own settings (raise_minimum).
struct MinimumAscentParams {
  double sharpness = 40;  ///< k of the exponentials, > 0
  double barrier = 0.01;  ///< weight of the Winslow barrier, >= 0
};

/// Raises the minimum scaled Jacobian around `seeds` (#H flags): the seeds' vertices grown by p.rings rings
/// move together by L-BFGS (p.polish_iterations iterations) on Σ_h exp(-k (soft_sj(h) - m)) + a.barrier Σ_h E_h,
/// a smooth maximum of the hexes' deficits (m the region's lowest soft scaled Jacobian at the start, soft_sj
/// and E_h as in raise_average); surface vertices in their tangent planes, projected back. The caller checks
/// that the minimum rose.
/// \param along  empty, or #V directions: a free surface vertex with a non-zero one moves along it only (one
///               unknown instead of two; a vertex beside a crease sliding parallel to it), then is projected
/// \return false (V unchanged) when the region is empty or has an inverted hex
/// \pre as untangle_global(); seeds.size() == H.rows(); a's fields in their ranges; along empty or of size V.rows()
bool raise_minimum(RowMatrixX3d& V, const RowMatrixX8i& H, const std::vector<char>& on_surface,
                   const std::vector<char>& fixed, const TriangleTree& tree,
                   const std::vector<Eigen::Vector3d>& normals, const std::vector<char>& seeds,
                   const MinimumAscentParams& a, const GlobalUntangleParams& p, GlobalUntangleStats* stats = nullptr,
                   const std::vector<Eigen::Vector3d>& along = {});

/// Soft minimum of the 9 scaled Jacobians (8 corners, centre) of one hex, s_min - log(Σ exp(-40 (s_t - s_min))) / 40,
/// within log(9) / 40 below the hex's scaled Jacobian, and, if grad, its gradient (8 by 3, row k = corner k).
/// \param p  8 corners, VTK_HEXAHEDRON order
double hex_soft_scaled_jacobian(const std::array<Eigen::Vector3d, 8>& p, Eigen::Matrix<double, 8, 3>* grad = nullptr);

/// The energy of one hex: Σ over its 9 Jacobians (8 corners, centre) of |J|_F² / (3 χ(det J, ε)^{2/3}),
/// J over `scale`; 9 for a cube of edge `scale` as ε -> 0.
/// \param p     8 corners, VTK_HEXAHEDRON order
/// \param grad  if not null, out: 8 by 3, the gradient with respect to the corners (row k = corner k)
double hex_untangle_energy(const std::array<Eigen::Vector3d, 8>& p, double scale, double eps,
                           Eigen::Matrix<double, 8, 3>* grad = nullptr);

}  // namespace polyhex
