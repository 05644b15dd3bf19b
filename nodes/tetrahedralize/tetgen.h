/// @file tetgen.h
/// @brief Isotropic tetrahedral meshing of a closed surface with TetGen 1.5 (the paper's input is a
/// tet mesh of 100k-200k tets, Gregson et al. 2011 §7).
#pragma once

#include "nodes/artefacts/meshes.h"
#include "runtime/stat_fields.h"

namespace polyhex {

struct TetgenParams {
  double edge_length =
      0.02;  ///< target tet edge length, fraction of the input's reference length (nodes/algorithms/reference_length.h)
  double radius_edge = 1.5;    ///< quality bound on circumradius / shortest edge (TetGen -q<ratio>)
  double min_dihedral = 10.0;  ///< dihedral angle bound in degrees (TetGen -q<ratio>/<angle>)
  bool refine_surface = true;  ///< false keeps the input surface triangles untouched (TetGen -Y)
  int max_tets = 20000000;     ///< refuse up front when the estimated tet count exceeds this (see estimate_tets)
};

/// The size of a tet mesh before it is made, to refuse requests far beyond the machine.
struct TetEstimate {
  double volume = 0;            ///< volume enclosed by the surface (|signed volume|)
  double reference_length = 0;  ///< the surface's reference length (nodes/algorithms/reference_length.h)
  double h = 0;                 ///< absolute target edge: edge_length x reference length
  double tets = 0;              ///< estimated tet count: 1.5 x volume / volume of a regular tet of edge h
  double bytes = 0;             ///< estimated peak memory of the TetGen run: tets x kTetgenBytesPerTet
};

/// Peak memory of a TetGen run per output tet, rounded up from a measurement (1.5M tets of a box:
/// +240 MB of peak RSS over 0.2M tets, 185 bytes per tet).
constexpr double kTetgenBytesPerTet = 250.0;

/// Figures describing a tet mesh, for the report.
struct TetgenStats {
  long tets = 0;
  long vertices = 0;
  double target_edge = 0;       ///< h, absolute target edge length (edge_length x reference length)
  double edge_min = 0;          ///< shortest edge / h
  double edge_max = 0;          ///< longest edge / h
  double edge_mean = 0;         ///< mean edge / h (each edge counted once)
  double min_dihedral_deg = 0;  ///< smallest dihedral angle over all tets, degrees
  double max_radius_edge = 0;   ///< largest circumradius / shortest edge over all tets
  double seconds = 0;           ///< wall time of the whole call
  double estimated_tets = 0;    ///< estimate_tets(...).tets made before the run (the count TetGen gives is
                                ///< 0.9-1.2 times this on a box, up to 3.5 times on surfaces finer than h)
  int aborted_attempts = 0;     ///< runs of TetGen that failed an internal check (assertion) before the one kept,
                                ///< each followed by one in a turned frame (tetgen.cpp)

  /// Report names (runtime/stat_fields.h).
  static constexpr auto fields() {
    using S = TetgenStats;
    return std::make_tuple(stat("tets", &S::tets), stat("estimated_tets", &S::estimated_tets),
                           stat("vertices", &S::vertices), stat("target_edge", &S::target_edge),
                           stat("edge_min_rel", &S::edge_min), stat("edge_max_rel", &S::edge_max),
                           stat("edge_mean_rel", &S::edge_mean), stat("min_dihedral_deg", &S::min_dihedral_deg),
                           stat("max_radius_edge", &S::max_radius_edge), stat("seconds", &S::seconds),
                           stat("aborted_attempts", &S::aborted_attempts));
  }
};

/// Tetrahedralizes the solid bounded by a closed surface with TetGen (flags `pq<ratio>/<angle>a<vol>zQ`,
/// plus `Y` when refine_surface is false). h = edge_length x the surface's reference length
/// (its tightest bounding-box diagonal over all orientations, so that a turned copy gets the same tets); the volume
/// bound is 1.5 times that of a regular tet of edge h (1.5 x 0.118 h^3), which puts the mean interior edge at about h.
/// Long thin input triangles (coarse CAD tessellations) are split by TetGen's own boundary refinement (-q without -Y),
/// which gives isotropic tets there; with refine_surface = false they are kept and the tets along them are as thin as
/// they are. Near a surface finer than h the tets follow the surface size (TetGen grades from the boundary inwards).
/// TetGen runs are serialised (its geometric predicates keep input-dependent global state).
/// Nothing is printed (TetGen's -Q). Debian's TetGen keeps its internal assert()s: an input that
/// trips one aborts the process, which no wrapper in-process can catch (not seen with these flags
/// on the shared surfaces, girl.off included).
///
/// Scale: TetGen runs on coordinates moved to the bounding-box centre and divided by the box diagonal,
/// and the result is mapped back (input vertices get their exact input coordinates back), so a model
/// scaled by 1e-9 or 1e9 or far from the origin gives the same tets as at unit scale (up to rounding).
/// Size: before TetGen runs, the tet count is estimated (estimate_tets); a request above
/// `max_tets`, or whose estimated memory exceeds the machine's physical memory, is refused.
///
/// \param surface  closed, outward-oriented triangle surface, V #V by 3, F #F by 3
/// \param p        params; edge_length in (0, 0.5]
/// \param stats    optional, filled with the figures of the result
/// \return tets T #T by 4, all positively oriented, every vertex used; source = surface.source
/// \pre surface does not intersect itself (else TetGen's own check refuses it, code 3)
/// \throw InvalidInput for an empty or malformed surface (index out of range, non-finite
///        coordinates, all vertices at one point), an open, non-manifold or degenerate one (the
///        surface reader's check, check_and_repair_surface), a non-positive edge_length, an estimated size above
///        max_tets or the machine's memory (the message gives the estimate and the smallest edge_length
///        that fits), and for every TetGen failure: the message names
///        surface.source and the cause (self-intersection, tiny feature, nearly touching facets,
///        out of memory, internal error) with TetGen's code, or its failed internal check (an assertion,
///        which would abort the process: caught, and TetGen tried again in up to 2 fixed turned frames,
///        stats->aborted_attempts; the error when every frame failed).
TetMesh tetrahedralize(const SurfaceMesh& surface, const TetgenParams& p, TetgenStats* stats = nullptr);

/// Estimates the tet count of tetrahedralize(surface, {edge_length}) from the enclosed volume.
/// \pre surface as for tetrahedralize (closed, finite coordinates); edge_length > 0
TetEstimate estimate_tets(const SurfaceMesh& surface, double edge_length);

/// Quality figures of a tet mesh against the target edge h (every field of TetgenStats but seconds).
/// \pre T indexes rows of V; h > 0
TetgenStats tet_stats(const TetMesh& mesh, double h);

}  // namespace polyhex
