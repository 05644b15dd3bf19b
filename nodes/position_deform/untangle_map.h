/// @file untangle_map.h
/// @brief Untangling of the PolyCube map (after paper §5.2): the mean value Laplace solve leaves inverted
/// tets where the map folds (paper Figure 9, most at concave PolyCube edges). The lattice points that fall
/// in a fold are mapped back to the input by the wrong tet, which gives the hex stage tangled hexes that no
/// vertex placement of the hex mesh undoes. Here the PolyCube positions of the vertices around the inverted
/// tets move so that every tet is positive, without moving the PolyCube: a vertex keeps the coordinates of
/// the chart planes it lies on (a chart vertex slides in its plane, a vertex on a PolyCube edge along the
/// edge, a corner stays), so planarity and the chart planes stay exact.
///
/// Energy: Σ over the tets with a free vertex of v_t |J|_F² / (3 χ(det J, ε)^{2/3}), J the Jacobian of the
/// map from the input tet to the PolyCube tet, v_t the input tet's volume over the mean, χ(D, ε) = (D +
/// sqrt(ε² + D²)) / 2: the regularised conformal (Winslow) energy of "Foldover-free maps in 50 lines of
/// code" (Garanzha, Kaporin, Kudryavtseva, Protais, Ray, Sokolov 2021), minimised by L-BFGS with their ε
/// schedule. The paper's benchmark is exactly this problem: untangling tet maps with a fixed boundary.
/// A tet with its four vertices on one chart plane (a surface sliver of the tet mesh, flattened) stays flat
/// whatever moves: it is left out. Then L-BFGS at ε -> 0 (a barrier against inversion) lowers the distortion
/// of the region, the tets still inverted (when the budget ran out) frozen and left out: the rounds leave
/// the tets they turned round barely positive, and a barely positive tet maps a lattice cube to a flat hex.
/// Deterministic: per-tet terms are computed in parallel into arrays and summed in a fixed order.
#pragma once

#include "nodes/artefacts/meshes.h"
#include "runtime/stat_fields.h"

#include <cstdint>
#include <vector>

namespace polyhex {

/// How the polish's L-BFGS is preconditioned: not at all, by the stiffness's Cholesky factor, or by its
/// incomplete Cholesky factor.
enum class PolishPreconditioner { none, cholesky, incomplete_cholesky };

struct MapUntangleParams {
  int rounds = 30;             ///< ε updates (each followed by one L-BFGS run); 0 = no untangling, [0, 1000]
  int lbfgs_iterations = 200;  ///< iterations of one L-BFGS run, [1, 100000]
  long max_iterations = 600;   ///< L-BFGS iterations of all rounds together (the polish apart); 0 = no untangling
  int rings = 2;               ///< free vertices: the inverted tets' vertices grown by this many tet rings, [0, 50]
  /// Each round after the first works on the tets still inverted grown by `rings` rings, not on the first
  /// round's region: the first round turns most tets round, and the later ones cost a fraction of it. The
  /// region polish keeps the first round's region. Off by default: on the results table it raised the
  /// median minimum and the mean average but lowered four models' figures (docs/speed.md).
  bool shrink = false;
  int polish_iterations = 200;  ///< after the rounds: L-BFGS iterations at ε -> 0 on the region, [0, 100000]
  /// The polish's L-BFGS preconditioned by the energy's stiffness at its start (per axis a weighted Laplacian
  /// of the moving coordinates, the fixed ones its Dirichlet conditions): far fewer iterations for the same
  /// energy (docs/speed.md). `cholesky`: its CHOLMOD factorization (exact, costly to factor);
  /// `incomplete_cholesky`: Eigen's incomplete Cholesky of it (Lin and Moré's limited-memory factor: AMD order,
  /// diagonal scaling, the largest entries, as many per column as the matrix has; built in a fraction of the
  /// time, weaker per iteration).
  PolishPreconditioner polish_preconditioner = PolishPreconditioner::none;
  bool polish_everywhere = false;  ///< the polish moves every vertex that may move (not only the untangled region),
                                   ///< also when nothing was inverted: the map as a whole towards a conformal one
  double seconds = 0;              ///< wall-time cap, checked per L-BFGS iteration (the map so far is kept); 0 = none.
                                   ///< The iteration budget keeps runs deterministic; a cap that is hit does not
};

struct MapUntangleStats {
  long inverted_before = 0, inverted_after = 0;  ///< tets with signed PolyCube volume <= 0
  long flat = 0;  ///< of them, tets no move that keeps the PolyCube can open (4 vertices on a plane, 3 on an edge line)
  long free_vertices = 0;
  int rounds = 0;                                            ///< ε updates done
  long lbfgs_iterations = 0;                                 ///< L-BFGS iterations of the untangling rounds
  long polish_iterations = 0;                                ///< L-BFGS iterations of the polish
  double polish_energy_before = 0, polish_energy_after = 0;  ///< the polish's energy (ε -> 0) at its start and end
  double polish_factor_seconds = 0;  ///< with a polish_preconditioner: the stiffness's assembly and factorization
  bool time_budget_hit = false;
  double seconds = 0;

  /// Report names (runtime/stat_fields.h): as position_deform's metrics.
  static constexpr auto fields() {
    using S = MapUntangleStats;
    return std::make_tuple(stat("inverted_tets_before_untangle", &S::inverted_before, Combine::sum),
                           stat("inverted_tets_after_untangle", &S::inverted_after, Combine::sum),
                           stat("flat_tets", &S::flat, Combine::sum),
                           stat("untangle_free_vertices", &S::free_vertices, Combine::sum),
                           stat("untangle_rounds", &S::rounds, Combine::sum),
                           stat("untangle_lbfgs_iterations", &S::lbfgs_iterations, Combine::sum),
                           stat("untangle_polish_iterations", &S::polish_iterations, Combine::sum),
                           stat("untangle_polish_energy_before", &S::polish_energy_before, Combine::sum),
                           stat("untangle_polish_energy_after", &S::polish_energy_after, Combine::sum),
                           stat("seconds_polish_factor", &S::polish_factor_seconds, Combine::sum),
                           stat("untangle_time_budget_hit", &S::time_budget_hit, Combine::any),
                           stat("seconds_untangle", &S::seconds, Combine::sum));
  }
};

/// Moves the PolyCube positions U of the vertices near the inverted tets (see the file comment).
/// \param X           #V by 3 input (rest) positions; every tet positively oriented in X
/// \param T           #T by 4 tets
/// \param U           #V by 3 PolyCube positions, updated in place
/// \param fixed_axes  #V bit masks: bit a set = coordinate a of the vertex does not move (the axis of a
///                    chart the vertex lies on); 7 = the vertex stays
/// \return the number of inverted tets left (the flat ones included)
/// \pre X.rows() == U.rows() == fixed_axes.size(); T indexes X; tets of X have positive volume
/// \throw Interrupted (runtime/cancel.h) after SIGINT/SIGTERM, checked per L-BFGS iteration
/// \throw SolverError when the polish's preconditioner cannot be factored (its stiffness is shifted to be
///        positive definite, so only on non-finite positions)
long untangle_polycube_map(const RowMatrixX3d& X, const RowMatrixX4i& T, RowMatrixX3d& U,
                           const std::vector<std::uint8_t>& fixed_axes, const MapUntangleParams& p = {},
                           MapUntangleStats* stats = nullptr);

}  // namespace polyhex
