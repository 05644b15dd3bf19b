/// @file position_deform.h
/// @brief Position-driven deformation (paper §5.2): flatten every chart of the PolyCube structure onto an
/// axis-aligned plane at an integer multiple of the hex edge length, keeping the ordering and distance of
/// nearby same-axis charts, and compute the volumetric PolyCube map.
///
/// Per axis a (the three axes are independent):
///  1. Poisson step. Unknowns: the a-coordinate of every vertex not on an a-chart, plus one coordinate per
///     a-chart (vertices of a chart are substituted by their chart's unknown, so planarity is exact).
///     Energy: Σ_edges ((u_i − u_j) − (d_i − d_j))² over the tet edges (uniform weights; d = the deformed
///     mesh of the rotation stage, i.e. Eq. 1 with the gradients of the last iteration absorbed in d),
///     plus Σ_pairs w_pq ((c_q − c_p) − δ_pq)² for the distance-preservation constraints.
///  2. Distance constraints (§5.2): a multi-source Dijkstra over the tet edges from the chart vertices
///     (approximate Voronoi partition of the volume by chart; every vertex stores its closest chart
///     vertex). Every tet edge joining the regions of two a-charts p, q gives a sample of their axis
///     distance δ = d_a(closest of q) − d_a(closest of p); samples are averaged per pair.
///     Weight: w = s · exp(−max(|δ| − min_d, 0)² / σ²), min_d = 2h, σ = 3 min_d. The paper prints the
///     exponent without its minus sign; a weight that grows with distance would contradict its "sharp
///     falloff", so we read it as the usual Gaussian. s = `distance_weight` × (vertices of the smaller of
///     the two charts), so that the constraint is as stiff as the chart it holds.
///  3. Chart coordinates are rounded to integer levels of the lattice spacing: h (`lattice_spacing` "polycube",
///     the paper), or h times the cube root of the Poisson step's volume over the input's ("input_volume"), so
///     that the lattice has about input volume / h³ cells in any frame. The Poisson step loses volume where it
///     flattens curved charts (0.43-0.78 of the input on organic models, 0.88-1.0 on most CAD parts), and how
///     much depends on the frame: on the paper's spacing two frames of one model can give hex counts 25-40 %
///     apart, and an organic model's hexes are 1.1-1.3 h across (docs/position_deform.md). Rounding must not
///     swap or merge two same-axis charts that are ordered (a distance pair, or the two ends of a chart of
///     another axis that joins them): such pairs are kept at least one level apart, in their original order; a
///     pair contradicting stronger evidence is dropped. `level_placement` "balanced" (default): the levels that
///     move the charts least (weighted by their vertex counts) while every order holds, then rounded
///     (chart_order.h place_levels); "push_up": rounded, then each chart pushed up to one level above the charts
///     below it (a longest-path pass), which lets a stack of small charts carry the shift upwards. The configs
///     retry with push_up (tools/cli_run.h); docs/position_deform.md has the measurements.
///  4. Final solve with the rounded chart coordinates pinned, and (beyond the paper, `feature_lines`) the
///     creases that run inside a chart straight along an axis of its plane at the rounded mean of their
///     other in-plane coordinate, so that the lattice has a line on them (feature_lines.h): `final_solve` =
///     "mvc_laplace" (the paper: a Laplace equation discretised with mean value coordinates, 2D on the surface, 3D in
///     the volume, weights computed on the deformed mesh) or "poisson" (step 1's energy with the charts pinned, which
///     keeps more of the deformed shape).
///  5. Beyond the paper: the folds of the map (inverted tets) are untangled with the chart planes kept
///     (untangle_map.h), so that the hex stage maps every lattice point through a positive tet. Then
///     (`map_polish` "everywhere", default) the whole map descends the Winslow energy at ε -> 0 (a barrier:
///     no tet turns over) for 200 L-BFGS iterations: every tet towards a similarity of its input tet, and a
///     lattice cube mapped back through a near-similarity is a near-cube, what the scaled Jacobian measures.
///     The paper's MVC Laplace solve is harmonic per coordinate, not conformal. "region" polishes only the
///     untangled region. See docs/position_deform.md.
#pragma once

#include "nodes/artefacts/polycube_map.h"
#include "nodes/position_deform/untangle_map.h"
#include "runtime/progress.h"

#include <memory>
#include <string>

namespace polyhex {

/// The final solve with the chart planes pinned (step 4).
enum class FinalSolve { mvc_laplace, poisson };
/// The chart levels (step 3).
enum class LevelPlacement { balanced, push_up };
/// What the polish after the untangling covers (step 5).
enum class MapPolish { region, everywhere };
/// What the lattice's spacing is measured against (step 3).
enum class LatticeSpacing { polycube, input_volume };

struct PositionDeformParams {
  double edge_length = 0.01;  ///< hex edge length h, fraction of the input's reference length
                              ///< (nodes/algorithms/reference_length.h) (§6: 1 %), [1e-4, 0.5]
  LatticeSpacing lattice_spacing =
      LatticeSpacing::polycube;  ///< the lattice spacing on the PolyCube: h (polycube, the paper) or h scaled by the
                                 ///< cube root of the Poisson step's volume ratio (input_volume: about input
                                 ///< volume / h³ lattice cells whatever the frame; step 3)
  double distance_weight = 1.0;  ///< scale s of the distance-preservation constraints (0 disables them), [0, 1e6]
  FinalSolve final_solve = FinalSolve::mvc_laplace;  ///< mvc_laplace (§5.2) or poisson
  LevelPlacement level_placement =
      LevelPlacement::balanced;     ///< chart levels: balanced (chart_order.h place_levels) or push_up
  int poisson_direct_max = 150000;  ///< the Poisson step's system is factored (CHOLMOD) up to this many unknowns and
                                    ///< solved by conjugate gradients (incomplete Cholesky) above: a factorization's
                                    ///< cost grows as n^2 on a 3D mesh (docs/speed.md, size scaling), [0, 2e9]
  int final_jacobi_iterations = 0;  ///< mvc_laplace: BiCGSTAB iterations with the diagonal preconditioner before the
                                    ///< incomplete LU takes over (0 = incomplete LU at once, or above final_ilu_max
                                    ///< 5,000), [0, 1e6]. Faster, but off by default: the meshes change
                                    ///< (docs/position_deform.md)
  int final_ilu_max = 150000;  ///< mvc_laplace: a final system with more unknowns than this starts with the diagonal
                               ///< preconditioner (up to final_jacobi_iterations, or 5,000, iterations; then the
                               ///< incomplete LU from there): the incomplete LU's factorization grows faster than the
                               ///< iterations (docs/speed.md, size scaling; every mesh of the results table is below
                               ///< it), [0, 2e9]
  int untangle_iterations =
      600;                 ///< L-BFGS iterations of the map's untangling (untangle_map.h); 0 = keep the folds, [0, 1e6]
  int untangle_rings = 2;  ///< the untangling moves the inverted tets' vertices grown by this many rings, [0, 50]
  bool untangle_shrink = false;  ///< rounds after the first move only the tets still inverted grown by untangle_rings
                                 ///< rings (untangle_map.h MapUntangleParams::shrink): the untangling a third
                                 ///< faster; off by default, the table's figures move both ways (docs/speed.md)
  double untangle_seconds =
      0;  ///< wall-time cap of the untangling (0 = none; a cap that is hit makes runs load-dependent), [0, 3600]
  MapPolish map_polish =
      MapPolish::everywhere;  ///< after the untangling, L-BFGS at ε -> 0 on the Winslow energy of the whole map
                              ///< (everywhere: every tet towards a similarity) or of the untangled region only (region)
  int map_polish_iterations = 200;  ///< L-BFGS iterations of that polish (0 = none), [0, 100000]
  PolishPreconditioner map_polish_preconditioner =
      PolishPreconditioner::none;  ///< JSON none (plain L-BFGS), laplacian (the stiffness's Cholesky factor) or
                                   ///< incomplete_laplacian (its incomplete Cholesky factor; untangle_map.h)
  double max_hexes = 2e7;     ///< refuse up front when the hex count estimate (volume / h³) exceeds this, [1e3, 2e9]
  bool feature_lines = true;  ///< creases inside a chart, straight along an axis of its plane, go onto lattice lines
                              ///< (feature_lines.h; step 4)
  bool feature_line_room = false;  ///< a feature line between two charts of its axis that face each other (a
                                   ///< V-shaped slot's bottom between its walls) gets a level between them: their
                                   ///< order asks for 2 levels instead of 1 (step 3). Off by default: a slot's bottom
                                   ///< then has two hexes around it, each spanning about half of 337 degrees
                                   ///< (8-connected turned: 0.644 -> 0.195; docs/features.md)
};

struct PositionDeformStats {
  int charts = 0;
  int distance_pairs = 0;             ///< same-axis chart pairs with a distance constraint
  int ordered_pairs = 0;              ///< pairs whose order rounding must keep (distance pairs + bridged pairs)
  int flipped_chart_orders = 0;       ///< ordered pairs whose order the Poisson step swapped (before the rounding fix)
  int flipped_after_rounding = 0;     ///< ordered pairs still swapped or merged after the rounding fix (should be 0)
  int order_constraints_dropped = 0;  ///< ordered pairs dropped because they contradict stronger evidence (a cycle)
  int merged_same_axis_charts = 0;    ///< same-axis charts sharing a vertex, forced onto one plane
  double chart_coordinates_rounded_max_shift = 0;  ///< max |c − k h| / h over charts
  int inverted_tets = 0;      ///< tets of the PolyCube map with signed volume <= 0 (after the untangling)
  MapUntangleStats untangle;  ///< the untangling's figures; inverted_before = as the final solve leaves
                              ///< them (concave edges, Fig. 9). Off: both counts = inverted_tets, the rest 0
  double distortion =
      0;  ///< median conformal distortion ||J||_F ||J^-1||_F / 3 (input -> PolyCube) of non-inverted tets
  double distortion_p99 = 0;  ///< its 99th percentile
  double distortion_max = 0;
  double poisson_volume_ratio =
      0;  ///< the Poisson step's map (charts flattened, before rounding): volume / the input's
  double lattice_spacing_ratio = 0;  ///< the lattice spacing on the PolyCube / h (1 for lattice_spacing polycube)
  double volume_ratio = 0;           ///< the PolyCube map's volume / the input's (signed: folds count negative)
  double planarity_error = 0;    ///< max distance of a chart vertex from its plane / bbox diagonal (0 by construction)
  int feature_lines = 0;         ///< creases inside a chart that can be lattice lines (feature_lines.h)
  int feature_lines_pinned = 0;  ///< ... pinned at a level (not on the level of a chart beside theirs)
  int feature_lines_given_room = 0;  ///< ... whose flanking charts were put 2 levels apart (feature_line_room)
  int final_iterations = 0;          ///< BiCGSTAB iterations of the mvc_laplace final solves (three axes)
  int final_ilu_axes = 0;            ///< axes whose final solve used the incomplete LU preconditioner
  int poisson_cg_axes = 0;           ///< axes whose Poisson step was solved by conjugate gradients (poisson_direct_max)
  double seconds_poisson = 0, seconds_final = 0;  ///< summed over the three axes (which run in parallel)

  /// Report names, and how the three axes' figures merge (runtime/stat_fields.h).
  static constexpr auto fields() {
    using S = PositionDeformStats;
    return std::make_tuple(
        stat("charts", &S::charts), stat("distance_pairs", &S::distance_pairs, Combine::sum),
        stat("ordered_pairs", &S::ordered_pairs, Combine::sum),
        stat("flipped_chart_orders", &S::flipped_chart_orders, Combine::sum),
        stat("flipped_after_rounding", &S::flipped_after_rounding, Combine::sum),
        stat("order_constraints_dropped", &S::order_constraints_dropped, Combine::sum),
        stat("merged_same_axis_charts", &S::merged_same_axis_charts, Combine::sum),
        stat("chart_coordinates_rounded_max_shift", &S::chart_coordinates_rounded_max_shift, Combine::max),
        stat("inverted_tets", &S::inverted_tets), stat("untangle", &S::untangle), stat("distortion", &S::distortion),
        stat("distortion_p99", &S::distortion_p99), stat("distortion_max", &S::distortion_max),
        stat("poisson_volume_ratio", &S::poisson_volume_ratio),
        stat("lattice_spacing_ratio", &S::lattice_spacing_ratio), stat("volume_ratio", &S::volume_ratio),
        stat("planarity_error", &S::planarity_error, Combine::max), stat("feature_lines", &S::feature_lines),
        stat("feature_lines_pinned", &S::feature_lines_pinned, Combine::sum),
        stat("feature_lines_given_room", &S::feature_lines_given_room, Combine::sum),
        stat("final_iterations", &S::final_iterations, Combine::sum),
        stat("final_ilu_axes", &S::final_ilu_axes, Combine::sum),
        stat("poisson_cg_axes", &S::poisson_cg_axes, Combine::sum),
        stat("seconds_poisson", &S::seconds_poisson, Combine::sum),
        stat("seconds_final", &S::seconds_final, Combine::sum));
  }
};

/// \param input      the input tet mesh (rest positions), positively oriented
/// \param deformed   rotation-driven deformation of `input` (same connectivity)
/// \param seg        PolyCube structure of the deformed boundary (§5.1); its triangles index input.V
/// \pre deformed.V.rows() == input.V.rows(), seg.F indexes input.V, seg.chart in [0, #charts)
/// \throw InvalidInput when sizes disagree or the structure has no chart on some axis, or when the
///        input's volume / h³ (the hex count the lattice would give) exceeds p.max_hexes;
///        SolverError when a linear solve fails;
///        Interrupted after SIGINT/SIGTERM (runtime/cancel.h), checked per axis and before each solve
/// \param progress  told the phase (chart planes and solves, untangling, distortion); may be empty
PolyCubeMap position_deform(std::shared_ptr<const TetMesh> input, const TetMesh& deformed,
                            std::shared_ptr<const PolyCubeSegmentation> seg, const PositionDeformParams& p,
                            PositionDeformStats* stats = nullptr, const ProgressFn& progress = {});

/// Conformal distortion ||J||_F ||J^-1||_F / 3 of the affine map taking tet (a,b,c,d) to (A,B,C,D);
/// 1 for a similarity; +inf when either tet is degenerate or the map inverts.
double conformal_distortion(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                            const Eigen::Vector3d& d, const Eigen::Vector3d& A, const Eigen::Vector3d& B,
                            const Eigen::Vector3d& C, const Eigen::Vector3d& D);

}  // namespace polyhex
