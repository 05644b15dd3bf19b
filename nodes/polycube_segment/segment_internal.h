/// @file segment_internal.h
/// @brief The segmentation's own parts, shared by its files and by nothing else: the surface's connectivity,
/// the labelling state and the steps segment_polycube() runs (docs/polycube_segment.md tells the method).
/// segment_surface.cpp: the surface, labels and charts, PolyCube edges and corners; segment_splits.cpp: the
/// §5.1 splits and the ramp and order-cycle cuts; segment_result.cpp: the result and its validity;
/// polycube_repair.cpp: the local repairs.
#pragma once

#include "nodes/algorithms/chart_order.h"
#include "nodes/polycube_segment/polycube_segment.h"

#include <Eigen/Core>

#include <array>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace polyhex::segment_detail {

using Vec3 = Eigen::Vector3d;

constexpr double kInf = std::numeric_limits<double>::infinity();

struct MeshEdge {
  int v[2];
  int t[2];
};

/// Connectivity and geometry of a closed, manifold triangle surface.
struct Surface {
  const RowMatrixX3d* V = nullptr;
  const RowMatrixX3i* F = nullptr;
  std::vector<MeshEdge> edges;
  std::vector<std::array<int, 3>> tri_nbrs;                  // triangle across each edge
  std::vector<std::vector<int>> vert_tris;                   // triangles around each vertex
  std::vector<std::vector<std::pair<int, int>>> vert_edges;  // (other vertex, edge id)
  std::vector<Vec3> normal;                                  // unit triangle normals
  std::vector<double> area;
  double total_area = 0;
  double diag = 0;  // reference length of the used vertices (nodes/algorithms/reference_length.h)
  double mean_edge = 0;

  int nf() const { return int(F->rows()); }
  Vec3 pos(int v) const { return V->row(v).transpose(); }
  int other(int e, int v) const { return edges[e].v[0] == v ? edges[e].v[1] : edges[e].v[0]; }
};

Surface build_surface(const RowMatrixX3d& V, const RowMatrixX3i& F);

/// §5.1: triangle normals averaged `iterations` times with their edge neighbours (unit normals,
/// equal weights, so small triangles next to large ones keep their own say). With `crease` (#F by 3: the
/// triangle's edge k is a crease of the input), not across creases: each side of a crease keeps its own.
std::vector<Vec3> smoothed_normals(const Surface& s, int iterations,
                                   const std::vector<std::array<char, 3>>* crease = nullptr);

/// The input's creases on the segmented surface (beyond §5.1, issue 23): per triangle which of its edges are
/// creases of the input (sharp at half a hex edge and along a flat face, features.h flat_face_creases), and the
/// faces between all its creases (crease_faces).
struct InputCreases {
  std::vector<std::array<char, 3>> edge;  ///< #F by 3: edge k of triangle t (vertices k, k+1) is a crease
  std::vector<char> vertex;               ///< per vertex of the surface: on one of those creases
  std::vector<int> patch;                 ///< #F: the input's face (crease_faces, features.h)
  int patches = 0;
  std::vector<char> planar;  ///< per patch: the input's normals within kPlanarFace degrees of their mean
  std::vector<Vec3> normal;  ///< #F: the input's unit normal
};

/// The creases of the input tet mesh's boundary (same triangles as the segmented surface).
/// \param X  the input's vertices (the deformed surface's rest positions)  \param h  the hex edge, absolute
InputCreases input_creases(const Surface& s, const RowMatrixX3d& X, double h);

/// Connected components of equal labels (charts). \return number of charts
int label_components(const Surface& s, const std::vector<int>& label, std::vector<int>& chart);

/// Sorted neighbour charts of every chart (sharing a mesh edge).
std::vector<std::vector<int>> chart_adjacency(const Surface& s, const std::vector<int>& chart, int n);

/// §5.1 straightening: a triangle with two neighbours of a common other label takes that label.
/// Each change raises the number of equally labelled neighbour pairs, so this terminates.
void straighten(const Surface& s, std::vector<int>& label);

/// Relabels triangles with label -1 by flood fill from their labelled neighbours. The fill is
/// prioritised by fit: the unlabelled triangle whose smoothed normal is closest to a neighbour's
/// label takes it first, so labels grow along the geometry they fit.
void flood_fill(const Surface& s, const std::vector<Vec3>& normal, std::vector<int>& label);

struct Structure {
  int n = 0;                          // charts
  std::vector<int> chart;             // #F
  std::vector<std::vector<int>> adj;  // chart graph
  std::vector<PolyCubeEdge> edges;
  std::vector<PolyCubeCorner> corners;
  std::vector<int> degree;  // #V chart-boundary mesh edges per vertex
  std::vector<int> label;   // #charts direction label of each chart
};

Structure analyse(const Surface& s, const std::vector<int>& label);

/// Triangles of `allowed` within geodesic-ish distance `radius` (Dijkstra along mesh edges of
/// allowed triangles) of the `sources` curve: every allowed triangle touching a source vertex (so
/// the band separates the two sides of the curve) plus those whose mean vertex distance <= radius.
std::vector<int> grow_band(const Surface& s, const std::vector<int>& sources, const std::vector<char>& allowed,
                           double radius);

/// §5.1 axis rule for a separating chart from the labels of its (up to four) neighbours.
/// `two_pairs`: the multi-orientation rule (two pairs with the same axis -> the remaining axis,
/// else the unmatched neighbour whose direction is closest to the band normal); otherwise the wedge
/// rule (only two axes among the neighbours -> the remaining axis, else `wedge_label`).
/// The sign of a "remaining axis" comes from the band's mean normal.
int separating_label(const std::vector<int>& nbr_labels, const Vec3& normal, bool two_pairs, int wedge_label);

Vec3 mean_normal(const Surface& s, const std::vector<Vec3>& normal, const std::vector<int>& tris);

/// The chart other than those in `exclude` with the most triangles at vertex v, or -1.
int chart_at(const Surface& s, const std::vector<int>& chart, int v, const std::vector<int>& exclude);

struct State {
  std::vector<int> label;  // #F
  std::vector<char> band;  // #F: inserted by a split
  int splits_multi = 0, splits_wedge = 0, splits_ramp = 0, splits_cycle = 0, splits_island = 0, repaired_corners = 0,
      removed_small = 0, removed_narrow = 0;
};

/// Gives every planar patch of the input one label: the one closest to the area-weighted mean of its smoothed
/// (deformed) normals. A planar face of a part is one PolyCube face, its creases chart boundaries (or lines
/// inside a chart, feature_lines.h); normals near a tie (a 45 degree chamfer) no longer split it.
void label_planar_patches(const Surface& s, const std::vector<Vec3>& normal, const InputCreases& c, State& st);

/// §5.1 multi-orientation charts: a chart touching a chart of the opposite direction along a
/// curve is split there by a separating chart of width h (the hex edge length).
void split_multi_orientation(const Surface& s, const std::vector<Vec3>& normal, double h, int max_splits, State& st);

void split_wedges(const Surface& s, const std::vector<Vec3>& normal, const PolyCubeSegmentParams& p, State& st);

/// A cut across chart `chart` at axis coordinate `level` (the chart's own axis), of severity `severity`.
struct LevelCut {
  int chart;
  double level, severity;
};

/// Ramps; with `creases`, a flat chart of the input (98 % of its area with an input normal within 20 degrees
/// of its direction) is a ramp from p.ramp_extent_planar hex edges when it also climbs more than half the
/// solid's depth behind it.
void split_ramps(const Surface& s, const std::vector<Vec3>& normal, const PolyCubeSegmentParams& p,
                 const InputCreases* creases, State& st);

/// Same-axis chart pairs whose order evidence closes a cycle (chart_order.h), and self bridges along the
/// input's creases (`crease_vertex`, per vertex of the surface: on one; none looked for without it), summed
/// over the axes, for the structure S; `cycle_charts`, when given, gets a flag per chart: on one of those
/// cycles; `cuts`, when given, the cuts that open them (cycle_cuts: per group, each of its charts at the
/// group's level; a self bridge's group between its top and its foot).
int order_cycles(const Surface& s, const Structure& S, const TetEdgeGraph& graph, double h,
                 const std::vector<char>* crease_vertex, std::vector<char>* cycle_charts,
                 std::vector<LevelCut>* cuts = nullptr, double* dropped_evidence = nullptr);

void split_order_cycles(const Surface& s, const std::vector<Vec3>& normal, const PolyCubeSegmentParams& p,
                        const TetEdgeGraph& graph, const std::vector<char>* crease_vertex, State& st);

std::string id_list(const std::vector<int>& ids);

/// Fills charts, edges, corners and the validity checks of §5.1.
PolyCubeSegmentation make_result(const Surface& s, const State& st);

/// §5.1 clean-up: straighten chart boundaries, remove small charts bounded by at most
/// p.small_chart_edges edges (their triangles are relabelled by flood fill), repeat until stable.
void clean_up(const Surface& s, const std::vector<Vec3>& normal, const PolyCubeSegmentParams& p, State& st);

/// Extension of §5.1 (param final_cleanup): after the splits, small charts with fewer than 4
/// neighbours are removed by flood fill too.
void remove_small_invalid(const Surface& s, const std::vector<Vec3>& normal, const PolyCubeSegmentParams& p, State& st);

/// The extensions after the splits: island cuts, then corner patches (as the params select). If
/// the result is still invalid and p.final_cleanup, the same from the input labelling with the
/// small charts beside a chart of their own axis removed by flood fill first (spurious charts the
/// clean-up's flood fill or the max_splits cap left); the better of the two is kept. If that is
/// still invalid, a second multi-orientation split (below).
void repair(const Surface& s, const std::vector<Vec3>& normal, const PolyCubeSegmentParams& p, State& st);

/// Extension of §5.1 (params min_chart_extent, narrow_chart_faces): a chart whose vertices span less than
/// min_chart_extent hex edges along one of the two axes of its plane is narrower than the lattice
/// resolves: rounding can put the charts on either side on one plane, the chart collapses to a line or a
/// point, and the map squeezes its triangles and the volume under them (femur: 18 of 93 charts with no
/// area left, 0.05-0.9 hex edges wide, in a cluster at one end of the bone). On a valid structure such
/// charts of less than narrow_chart_faces hex faces are removed one at a time, smallest first, by flood
/// fill from their neighbours, each kept only if the structure stays valid; then, if narrow charts are
/// left (they hold the structure together, so none can go alone), all of them at once, followed by the
/// repairs (island cuts, corner patches), kept only if valid with fewer narrow charts. Separating charts
/// the splits inserted (width h by design) are left alone. Up to 4 rounds, as a removal can make a
/// neighbour narrow.
void remove_narrow_charts(const Surface& s, const std::vector<Vec3>& normal, const PolyCubeSegmentParams& p, State& st);

}  // namespace polyhex::segment_detail
