/// @file polycube_segment.h
/// @brief PolyCube structure extraction (paper §5.1): label boundary triangles by their smoothed
/// normals, group them into charts, clean up, split multi-orientation and highly non-planar charts,
/// and check that the result is a valid PolyCube structure.
///
/// The extensions beyond §5.1 (island cuts, corner patches, ramps, order cycles, narrow and small
/// charts), why each is there and what it measured: docs/polycube_segment.md.
#pragma once

#include "nodes/artefacts/meshes.h"
#include "nodes/artefacts/polycube.h"

#include <filesystem>
#include <utility>

namespace polyhex {

struct PolyCubeSegmentParams {
  int smoothing_iterations = 3;  ///< passes of area-weighted normal averaging over edge neighbours before labelling
  double hex_edge_length =
      0.01;  ///< target hex edge, fraction of the reference length (nodes/algorithms/reference_length.h): width of
             ///< multi-orientation separating charts (§5.1)
  double small_chart_area =
      0.005;  ///< a chart bounded by <= small_chart_edges edges is removed below this fraction of the surface area
  int small_chart_edges = 2;  ///< charts bounded by at most this many PolyCube edges are removal candidates (§5.1: two)
  bool split_multi_orientation = true;  ///< split charts touching their opposite direction by a separating chart
  bool split_wedges = true;             ///< cut highly non-planar charts at wedge tips
  int edge_smoothing_iterations = 10;   ///< Laplacian passes on copies of the chart edges before the extremum search
  double extremum_depth = 2.0;          ///< an edge doubles back only when it returns by this many hex edge lengths
  double wedge_min_severity =
      1e-3;  ///< wedges whose triangle area is below this fraction of the reference length^2 are left alone
  int max_cut_candidates = 200;  ///< cut candidates tested per wedge, cheapest first
  bool split_ramps = true;       ///< cut charts that climb far along their own axis (extension of §5.1, below)
  double ramp_extent = 12.0;  ///< a chart is a ramp when its vertices span more than this many hex edges along its axis
  double ramp_extent_planar = 3.0;  ///< the same for a flat chart of the input (98 % of its area within 20
                                    ///< degrees of its direction; with the input tets) that also climbs more
                                    ///< than half the solid's depth behind it
  bool split_order_cycles =
      true;  ///< cut charts whose same-axis order evidence forms a cycle, or that sit on both ends of a step wall
             ///< along the input's creases (chart_order.h self bridges; extension of §5.1, below)
  int max_splits = 32;  ///< upper bound on separating charts of each kind
  bool final_cleanup =
      true;  ///< after the splits, remove small charts with < 4 neighbours by flood fill (extension of §5.1)
  bool split_islands =
      true;  ///< cut a ring chart from the boundary of a chart with < 4 neighbours it encloses (extension of §5.1)
  bool repair_corners =
      true;  ///< relabel a small patch at a 4-valent corner / opposite-direction touch point (extension of §5.1)
  double min_chart_extent = 1.0;    ///< on a valid structure, remove charts narrower than this many hex edges ...
  double narrow_chart_faces = 4.0;  ///< ... and smaller than this many hex faces (h²) where it stays valid (extension
                                    ///< of §5.1, below); either 0 = off, [0, 100] each
  int fallback_retries = 2;    ///< if invalid, retry with doubled smoothing this many times (reported as a warning)
  bool follow_creases = true;  ///< with the input tets: normals are not smoothed across the input's creases (sharp at
                               ///< half a hex edge, along a flat face: features.h flat_face_creases), and each planar
                               ///< face between creases takes one label (beyond §5.1)
  bool allow_invalid = false;  ///< pass an invalid structure on with a warning instead of failing
  bool save_surface = false;   ///< write <id>.charts.vtk (also written with --save-all)
};

/// The boundary triangles of a tet mesh (faces used by exactly one tet), outward oriented.
/// \param mesh  V #V by 3, T #T by 4 positively oriented
/// \return #F by 3 triangles, indices into mesh.V
/// \throw InvalidInput when the mesh has no tets or a tet index is out of range
RowMatrixX3i boundary_triangles(const TetMesh& mesh);

/// §5.1: the PolyCube structure of the deformed tet mesh. Never throws for an invalid structure:
/// the result says `valid` and lists the problems (see require_valid_polycube). When the first
/// labelling is invalid it retries with doubled smoothing up to p.fallback_retries times; a retry
/// that succeeds is reported in `warnings`.
/// \param deformed  the output of rotation_deform (same connectivity as the input tet mesh)
/// \param input     the input tet mesh (optional): its boundary's creases guide the labels (follow_creases), so
///                  that a part's edges become chart boundaries where an axis can carry them
/// \pre p.hex_edge_length > 0
/// \throw InvalidInput when the boundary is empty or not a closed 2-manifold (names an edge), or the input's
///        sizes are not the deformed mesh's
/// \throw Interrupted after SIGINT/SIGTERM (runtime/cancel.h), checked between the repair passes
PolyCubeSegmentation segment_polycube(const TetMesh& deformed, const PolyCubeSegmentParams& p = {},
                                      const TetMesh* input = nullptr);

/// Same-axis chart pairs of `seg` whose order evidence on `deformed` closes a cycle (chart_order.h),
/// at hex edge hex_edge_length × the boundary's reference length: what split_order_cycles reduces, but
/// for self bridges (they need the input's creases, which this does not take).
/// \pre seg was made on deformed (its triangles index deformed.V), hex_edge_length > 0
/// \throw InvalidInput when seg has no labelled triangles or a triangle index is out of range
int count_order_cycles(const TetMesh& deformed, const PolyCubeSegmentation& seg, double hex_edge_length);

/// Charts, edges, corners and validity of a given labelling, without clean-up or splits.
/// \param V      #V by 3 vertex positions
/// \param F      #F by 3 closed, outward surface triangles
/// \param label  #F direction labels 0..5
/// \throw InvalidInput when sizes disagree, a label is outside 0..5 or the surface is not closed
PolyCubeSegmentation analyse_polycube_labels(const RowMatrixX3d& V, const RowMatrixX3i& F,
                                             const Eigen::VectorXi& label);

/// §5.1 clean-up of a labelling: straighten chart boundaries (a triangle with two neighbours of a
/// common other label takes it), remove small charts (area < p.small_chart_area of the surface)
/// bounded by at most p.small_chart_edges PolyCube edges by flood fill from their neighbours; repeat.
/// \param label  #F labels 0..5, changed in place
/// \return number of charts removed
/// \throw InvalidInput as analyse_polycube_labels
int clean_up_labels(const RowMatrixX3d& V, const RowMatrixX3i& F, Eigen::VectorXi& label,
                    const PolyCubeSegmentParams& p = {});

/// Extensions of §5.1 on a given labelling (the steps segment_polycube runs after the splits when
/// p.split_islands / p.repair_corners): cut ring charts from the boundary of an enclosed chart with
/// fewer than 4 neighbours, then relabel small patches at 4-valent corners and at vertices where
/// opposite directions touch. Every change is kept only when it lowers (problems, neighbour
/// deficit), so a valid labelling is returned unchanged. If still invalid (and p.final_cleanup), the
/// same is tried after removing small charts (area < p.small_chart_area of the surface) that border a
/// chart of their own axis by flood fill; the better result is kept. If that is still invalid (and
/// p.split_multi_orientation), a last multi-orientation split parts charts of opposite directions
/// that meet along a curve, kept only if it lowers the problem count. Normals are the unsmoothed
/// triangle normals.
/// \param label  #F labels 0..5, changed in place
/// \return {island cuts, repaired corners}
/// \throw InvalidInput as analyse_polycube_labels
std::pair<int, int> repair_polycube_labels(const RowMatrixX3d& V, const RowMatrixX3i& F, Eigen::VectorXi& label,
                                           const PolyCubeSegmentParams& p = {});

/// \throw InvalidInput listing the problems and naming the failing charts when !s.valid
void require_valid_polycube(const PolyCubeSegmentation& s);

}  // namespace polyhex
