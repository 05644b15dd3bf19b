/// @file polycube_segment.h
/// @brief PolyCube structure extraction (paper §5.1): label boundary triangles by their smoothed
/// normals, group them into charts, clean up, split multi-orientation and highly non-planar charts,
/// and check that the result is a valid PolyCube structure.
///
/// Extensions beyond §5.1, for problems its two splitting rules leave on real models (measured on the
/// 28 shared models, TetGen edge 0.03: 6 invalid without them, 0 with them). Both run only on an
/// invalid structure and keep a change only when it lowers (problems, neighbour deficit):
/// - island cuts (split_islands): a chart enclosed by another (the outer one a ring with two or more
///   boundary loops, e.g. a +X patch inside a +Y region on casting) has one neighbour and no
///   straightening can give it four; the ring is cut along the cheapest axis-aligned path from the
///   island to the ring's other boundary, as a PolyCube edge between the two charts would run.
/// - corner patches (repair_corners): a saddle vertex (+Z, -X, -Z, +X around it: opposite directions
///   touching at one vertex, a 4-valent corner; conjoined_twins, encrusted_cube, bimba) is no PolyCube
///   corner; a small patch around it relabelled to the third axis splits it into valence-3 corners.
///   The same search also resolves the remaining same-axis neighbours on femur and carter.
/// - ramps (split_ramps): a chart whose deformed vertices span more than `ramp_extent` hex edges along
///   its own axis (2nd to 98th percentile) is cut across at its middle level, by the §5.1 wedge cut (a
///   separating chart of width h, the cheapest axis-aligned path through the chart, half price when it
///   joins two crossings of that level) from a point where one of its edges crosses the level. The
///   rotation-driven deformation cannot make a helical strip (a screw thread, a twisted bar) planar:
///   it stays a ramp whose labels all agree, its edges never double back, so the wedge rule does not
///   see it, and enforcing one plane on it folds the map. Cut, it becomes a staircase of charts, each
///   flat, as a PolyCube of a helix must be. Runs on valid structures too (a ramp is valid but flattens
///   badly); a cut is applied only when every chart it makes has >= 4 neighbours and none of its own axis.
/// - order cycles (split_order_cycles): the order of nearby same-axis charts in the deformed mesh
///   (chart_order.h: the §5.2 Voronoi distance samples and the charts bridged by a chart of another axis)
///   can contradict itself, p below q below r below p, where charts are far from planar (the twisted
///   bar: 7 such pairs; femur: 1). No plane per chart keeps every order then, and the PolyCube map
///   swaps the weakest. While there are such cycles, a chart on one is cut across its axis: first where
///   the cycle asks (chart_order.h cycle_cuts: a chart whose part near the chart below it on the cycle
///   sits higher than its part near the chart above it, cut between the two heights), then across its
///   middle level (any chart spanning more than extremum_depth hex edges), by the ramp cut above, up to
///   max_cut_candidates starts; a cut is kept only when valid and when it lowers the number of
///   cycle-closing pairs or, keeping it, their summed evidence (on a helix a cut mostly moves the cycle
///   to the next chart with a smaller contradiction). What is left is reported (order_cycles; -1 when
///   off). Measured (configs/polycube.json, tet edge 0.02): the twist's map keeps no cycle instead of 7
///   (9 cuts; 534 -> 90 inverted tets, distortion 1.093 -> 1.048), femur none instead of 1 (2 cuts);
///   the other shared models have none. Femur's hex mesh rose (minimum 0.304 -> 0.365, average 0.924 ->
///   0.928); the twist's fell (0.188 -> 0.005: padding hexes whose boundary quads fold across the bar's
///   sharp helical edges), which the default configs' retry catches by a variant without these cuts.
/// - narrow charts (min_chart_extent, narrow_chart_faces): a chart narrower than a hex edge along an axis
///   of its plane is likely to collapse when the map rounds the charts around it onto one plane (for
///   extent e hex edges, with probability about 1 - e), leaving its triangles and the volume under them
///   squeezed flat; femur kept 18 charts with no area left in the PolyCube, all below 3 hex faces. On a
///   valid structure such charts smaller than narrow_chart_faces hex faces are removed (remove_narrow_charts
///   in the .cpp: one at a time, else all at once with the repairs, kept only when valid). Longer strips are
///   left: they are the splits' separating charts or real thin features (fertility's two strips 0.9 hex edges
///   wide, 9-13 hex faces: removing them lowered its minimum scaled Jacobian in both map variants).
/// - small same-axis charts (with final_cleanup): a small chart beside a chart of its own axis is
///   spurious; if the structure is still invalid, it is removed by flood fill before the two repairs
///   above and the better result kept (carter at edge 0.04). The repairs can themselves leave small
///   charts with < 4 neighbours (femur at tet edge 0.019: three, 0.02-0.13 % of the area, invalid with
///   every fallback smoothing): if the structure is still invalid, they are removed once more and the
///   result kept when its score is better.
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
  bool split_order_cycles =
      true;             ///< cut charts whose same-axis order evidence forms a cycle (extension of §5.1, below)
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
/// \pre p.hex_edge_length > 0
/// \throw InvalidInput when the boundary is empty or not a closed 2-manifold (names an edge)
/// \throw Interrupted after SIGINT/SIGTERM (runtime/cancel.h), checked between the repair passes
PolyCubeSegmentation segment_polycube(const TetMesh& deformed, const PolyCubeSegmentParams& p = {});

/// Same-axis chart pairs of `seg` whose order evidence on `deformed` closes a cycle (chart_order.h),
/// at hex edge hex_edge_length × the boundary's reference length: what split_order_cycles reduces.
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
