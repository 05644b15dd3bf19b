/// @file optimize.h
/// @brief Hex mesh optimization (paper §6): untangling, per-vertex max-min scaled Jacobian repositioning,
/// then a global shape improvement; connectivity unchanged, boundary vertices kept on the input surface.
///
/// The paper used Mesquite; here every phase is a nonlinear Gauss-Seidel sweep over graph-coloured vertices or
/// an L-BFGS descent over a region: (a) untangling (regularised Winslow energy, locally then globally), (b)
/// max-min scaled Jacobian repositioning, (b') whole-hex moves towards the best-fit cube, (b'') region
/// smoothing, (c0) a global ascent of the average, (c) shape improvement, and, an option, (d) an ascent of the
/// minimum around the worst hexes, boundary vertices sliding, then (c)'s sweeps over what it moved. A move is
/// accepted only if it does not lower the minimum scaled Jacobian of the vertex's hexes and inverts none of
/// them; boundary vertices move in the surface's tangent plane and are projected back onto it. When the first
/// result is poor, a second candidate keeps the boundary vertices on the surface's creases (features.h). Each
/// phase, its stopping rule and why: docs/optimize.md.
#pragma once

#include "nodes/algorithms/features.h"
#include "nodes/artefacts/meshes.h"
#include "runtime/progress.h"
#include "runtime/stat_fields.h"

#include <array>

namespace polyhex {

struct OptimizeParams {
  int global_iterations = 15;  ///< ε updates of the global L-BFGS untangling (untangle_global.h), 0 = off, [0, 1000]
  int global_rings = 3;  ///< global untangling frees the inverted hexes' vertices grown by this many rings, [0, 50]
  int untangle_iterations = 200;  ///< max untangling sweeps, [0, 10000]
  int iterations = 30;  ///< max max-min sweeps over all poor hexes (then up to 3x as many over the worst), [0, 10000]
  int element_iterations = 5;  ///< rounds of whole-hex moves (each followed by max-min sweeps), [0, 1000]
  int smooth_iterations =
      5;  ///< rounds of region smoothing around the worst hexes (kept while the minimum rises), [0, 1000]
  int shape_iterations = 30;  ///< max global shape-improvement sweeps, [0, 10000]
  int average_iterations =
      300;  ///< L-BFGS iterations of the global average ascent before the shape sweeps, 0 = off, [0, 100000]
  double average_work = 4e6;  ///< the ascent's iterations are also capped at this / the hexes of its region (bounded
                              ///< cost on big meshes), [0, 1e12]
  double average_barrier = 0.01;  ///< weight of the Winslow barrier in the ascent's energy (0: none; the result is
                                  ///< checked either way), [0, 1]
  double average_below_sj =
      0.9;                ///< the ascent moves the interior vertices of hexes below this scaled Jacobian, [0, 1]
  int average_rings = 1;  ///< ... grown by this many rings of hexes, [0, 50]
  double average_tolerance =
      1e-3;  ///< the ascent stops when 25 iterations raise the scaled Jacobian of its region by less per hex, [0, 1]
  int minimum_iterations = 200;  ///< L-BFGS iterations of each round of the last phase, the minimum ascent around
                                 ///< the worst hexes (boundary vertices sliding), 0 = off, [0, 100000]
  int minimum_rounds = 3;        ///< its rounds, kept while the minimum scaled Jacobian rises, [0, 100]
  int minimum_rings = 2;         ///< its region: the hexes within minimum_band of the minimum grown by this many rings,
                                 ///< [0, 50]
  double minimum_band = 0.05;    ///< ... (and below target_sj), [0, 1]
  double shape_tolerance = 3e-4;  ///< the shape sweeps stop when a pair of them raises the average SJ by less, [0, 1]
  double target_sj = 0.8;         ///< max-min sweeps touch vertices with an incident hex below this SJ, [0, 1]
  double shape_target_sj = 0.99;  ///< shape sweeps touch vertices with an incident hex below this SJ, [0, 1]
  double time_budget = 3600.0;    ///< seconds for the whole stage (checked between colour classes), [0, 1e6]: a safety
                                  ///< net, far above any run measured, since a budget that is hit makes the mesh depend
                                  ///< on the machine's load; the sweeps' own caps bound the work
  bool move_boundary = true;      ///< boundary vertices may slide on the surface
  bool release_boundary =
      true;  ///< last resort: boundary corners of hexes still inverted after untangling may leave the surface;
             ///< once untangled they go back as far as their hexes allow without lowering the minimum
  int return_rings = 0;  ///< a released vertex that cannot go back alone goes back with its neighbours within this
                         ///< many rings of hexes re-placed around it (max-min steps), 0 = alone, [0, 10]; an
                         ///< option: 2 brings the boundary closer to the surface but lowered averages on the
                         ///< results table (docs/optimize.md)
  double feature_angle =
      kFeatureAngle;  ///< degrees: an edge of the surface sharper than this is a crease (features.h), 0 = no
                      ///< crease handling; if the first result is poor (fallback_below_sj), a second candidate puts
                      ///< paths of boundary edges on the crease lines, [0, 179]
  bool keep_creases = true;        ///< boundary vertices the lattice put on a crease of the surface (sharper than
                                   ///< feature_angle at half a hex edge, along a flat face: features.h
                                   ///< flat_face_creases) slide along it, those at its corners stay
                                   ///< (features.h creases_at_vertices; under a padding layer on both sides of the
                                   ///< crease they stay within a quarter hex edge of it instead)
  double fallback_below_sj = 0.5;  ///< with a fallback mesh: also optimize it when the first result's minimum scaled
                                   ///< Jacobian is below this, [0, 1]
  bool skip_failed_steps = true;   ///< the max-min sweeps skip a vertex whose last step failed while nothing of its
                                   ///< hexes has moved since: it would fail again, so the mesh is the same bit for
                                   ///< bit, faster (false: every step is repeated)
};

struct OptimizeStats {
  double sj_min_before = 0, sj_avg_before = 0;
  double sj_min_after = 0, sj_avg_after = 0;
  long inverted_before = 0, inverted_after = 0;  ///< hexes with corner scaled Jacobian <= 0
  int untangle_sweeps = 0, maxmin_sweeps = 0, shape_sweeps = 0;
  int average_kept = 0;                      ///< 1 when the global average ascent was kept
  double average_gain = 0;                   ///< the average scaled Jacobian it added (with its max-min repair)
  int element_sweeps = 0;                    ///< rounds of whole-hex moves
  long element_moves = 0;                    ///< accepted whole-hex moves
  int smooth_rounds = 0, smooth_kept = 0;    ///< region smoothing rounds tried / kept
  int minimum_rounds = 0, minimum_kept = 0;  ///< minimum ascent rounds tried / kept
  int minimum_slid = 0;                      ///< ... of those kept, rounds whose near-crease vertices slid
  double minimum_gain = 0;                   ///< the minimum scaled Jacobian it added
  int global_outer = 0;                      ///< ε updates of the global untangling
  long global_lbfgs_iterations = 0;          ///< its L-BFGS iterations
  long global_free_vertices = 0;             ///< vertices it moved (all runs)
  long inverted_after_global = -1;           ///< inverted hexes after the global untangling (-1: not run)
  int optimize_ways = 1;     ///< 2 when the local way left inverted hexes and the global way was tried too
  bool global_kept = false;  ///< the result is the global way's (fewer inverted hexes or a higher minimum)
  int iterations = 0;        ///< all sweeps
  long moves = 0;            ///< accepted vertex moves
  long steps_skipped = 0;    ///< vertex steps the sweeps skipped as certain to fail again (skip_failed_steps)
  int colours = 0;
  double boundary_distance_max = 0;  ///< max distance of a boundary vertex from the surface / bbox diagonal
  bool time_budget_hit = false;
  long released_vertices = 0;         ///< boundary vertices released from the surface to untangle (release_boundary)
  long returned_vertices = 0;         ///< ... of them, those that went back onto it once untangled
  long returned_with_neighbours = 0;  ///< ... of those, the ones whose neighbours moved with them (return_rings)
  int crease_lines = 0;               ///< crease lines of the surface at feature_angle (at least 1.5 hex edges long)
  int crease_lines_snapped = 0;       ///< ... with boundary vertices kept on them
  long crease_vertices = 0;           ///< boundary vertices kept on a crease line or at a crease corner
  double seconds = 0;
  double untangle_seconds = 0, global_seconds = 0, maxmin_seconds = 0, element_seconds = 0, smooth_seconds = 0,
         shape_seconds = 0, minimum_seconds = 0;  ///< per phase (a phase that calls another counts its time too)
  double average_seconds = 0;                     ///< the global average ascent (c0), a part of shape_seconds

  /// Report names (runtime/stat_fields.h). The crease_* figures are the kept candidate's, reported by the
  /// binding (optimize_node.cpp).
  static constexpr auto fields() {
    using S = OptimizeStats;
    return std::make_tuple(
        stat("sj_min_before", &S::sj_min_before), stat("sj_avg_before", &S::sj_avg_before),
        stat("inverted_before", &S::inverted_before), stat("sj_min", &S::sj_min_after),
        stat("sj_avg", &S::sj_avg_after), stat("inverted", &S::inverted_after), stat("global_outer", &S::global_outer),
        stat("global_lbfgs_iterations", &S::global_lbfgs_iterations),
        stat("inverted_after_global", &S::inverted_after_global),
        stat("global_free_vertices", &S::global_free_vertices), stat("optimize_ways", &S::optimize_ways),
        stat("global_kept", &S::global_kept), stat("untangle_sweeps", &S::untangle_sweeps),
        stat("maxmin_sweeps", &S::maxmin_sweeps), stat("shape_sweeps", &S::shape_sweeps),
        stat("average_kept", &S::average_kept), stat("average_gain", &S::average_gain),
        stat("element_sweeps", &S::element_sweeps), stat("element_moves", &S::element_moves),
        stat("smooth_rounds", &S::smooth_rounds), stat("smooth_kept", &S::smooth_kept),
        stat("minimum_rounds", &S::minimum_rounds), stat("minimum_kept", &S::minimum_kept),
        stat("minimum_slid", &S::minimum_slid), stat("minimum_gain", &S::minimum_gain),
        stat("iterations", &S::iterations), stat("moves", &S::moves), stat("steps_skipped", &S::steps_skipped),
        stat("colours", &S::colours), stat("boundary_distance_max", &S::boundary_distance_max),
        stat("released_vertices", &S::released_vertices), stat("returned_vertices", &S::returned_vertices),
        stat("returned_with_neighbours", &S::returned_with_neighbours), stat("time_budget_hit", &S::time_budget_hit),
        stat("seconds", &S::seconds), stat("phase_seconds.untangle", &S::untangle_seconds),
        stat("phase_seconds.global", &S::global_seconds), stat("phase_seconds.maxmin", &S::maxmin_seconds),
        stat("phase_seconds.element", &S::element_seconds), stat("phase_seconds.smooth", &S::smooth_seconds),
        stat("phase_seconds.shape", &S::shape_seconds), stat("phase_seconds.average", &S::average_seconds),
        stat("phase_seconds.minimum", &S::minimum_seconds));
  }
};

/// Optimizes vertex positions of a hex mesh (connectivity unchanged).
/// \param mesh     hex mesh, VTK_HEXAHEDRON order
/// \param surface  the input surface: boundary vertices are projected onto it (first of all) and stay on it
/// \return the mesh with new positions; check stats->inverted_after: it may be > 0 if untangling failed
/// \throw InvalidInput when the mesh fails check_hex_mesh or the surface has no triangles / bad indices
HexMesh optimize_hexes(const HexMesh& mesh, const SurfaceMesh& surface, const OptimizeParams& p = {},
                       OptimizeStats* stats = nullptr);

/// Whether optimization result a is better than b: fewer inverted hexes, then a higher minimum scaled Jacobian.
bool better_result(const OptimizeStats& a, const OptimizeStats& b);

/// What happened to the fallback candidate of optimize_hexes_or_fallback.
struct FallbackOutcome {
  bool ran = false;             ///< the fallback was optimized (the first result had inverted hexes or a low minimum)
  bool kept = false;            ///< its result was returned
  OptimizeStats stats;          ///< its figures if it ran (after-figures before the shape phase unless kept);
                                ///< seconds = its own time, its shape pass included if kept
  bool creases_ran = false;     ///< the mesh was optimized again with crease lines (feature_angle)
  bool creases_kept = false;    ///< that result was returned
  OptimizeStats creases_stats;  ///< its figures if it ran, as `stats`
};

/// Optimizes `mesh`; if the result is poor (inverted hexes, or a minimum scaled Jacobian below
/// p.fallback_below_sj), also the same mesh with its boundary on the surface's creases (p.feature_angle > 0
/// and the surface has a crease line that a path of boundary edges follows), then the fallback mesh if one is
/// given (the same core padded another way, e.g. with its inverted boundary hexes peeled: pad.h
/// peel_boundary_hexes), and returns the best result (better_result; the first on a tie). Every candidate
/// goes through the untangling and max-min phases, each with the full time budget; the shape improvement,
/// which never lowers the minimum, runs on the best one only.
/// \param stats  the kept result's figures, seconds = the whole call
/// \param fallback  null, or a second candidate for the same shape
/// \param outcome  out: whether the crease candidate and the fallback ran and were kept, and their figures
/// \param progress  told the phase (each candidate's untangling and max-min, the shape improvement); may be empty
/// \throw as optimize_hexes
HexMesh optimize_hexes_or_fallback(const HexMesh& mesh, const HexMesh* fallback, const SurfaceMesh& surface,
                                   const OptimizeParams& p, OptimizeStats* stats, FallbackOutcome* outcome = nullptr,
                                   const ProgressFn& progress = {});

/// Regularised Winslow energy of one hex: Σ over its 8 corners of |J|_F² / (3 χ(det J, ε)^{2/3}), J the
/// corner's edge vectors divided by `scale`; 8 for a cube of edge `scale` as ε -> 0.
/// \param p  8 corners in VTK_HEXAHEDRON order
double hex_winslow_energy(const std::array<Eigen::Vector3d, 8>& p, double scale, double eps);
/// The same, and its 8 corner terms (summed in corner order).
double hex_winslow_energy(const std::array<Eigen::Vector3d, 8>& p, double scale, double eps,
                          std::array<double, 8>& terms);
/// The same after only corner j has moved: `before` holds the terms of an evaluation at the same scale and
/// ε with the other 7 corners where they are now; the 4 corner terms that do not use corner j
/// (those outside hex_topology::kCorners[j]) are taken from it. Equal to the full evaluation bit for bit.
/// \pre 0 <= j < 8
double hex_winslow_energy_moved(const std::array<Eigen::Vector3d, 8>& p, int j, double scale, double eps,
                                const std::array<double, 8>& before, std::array<double, 8>& terms);

}  // namespace polyhex
