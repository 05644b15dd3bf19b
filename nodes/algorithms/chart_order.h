/// @file chart_order.h
/// @brief The order of same-axis charts as the deformed mesh shows it (paper §5.2's distance-preservation
/// constraints and the ordering the rounding keeps). Shared by the PolyCube map (position_deform.h), which
/// keeps these orders, and the structure extraction (polycube_segment.h), which cuts charts whose orders
/// contradict each other, so that the map can keep them all.
///
/// Per axis a: same-axis charts sharing a vertex form one group (they must lie on one plane). A
/// multi-source Dijkstra over the tet edges from the group vertices partitions the volume (approximate
/// Voronoi partition, §5.2); every tet edge joining the regions of two groups p < q samples their axis
/// distance d_a(closest vertex of q) − d_a(closest vertex of p), averaged per pair (the distance pairs).
/// Besides, two groups bordering one chart of another axis are that chart's two ends along a (bridged
/// pairs, ordered by the groups' mean coordinates). A pair separated by more than h/2 is ordered, with
/// evidence |separation| / h; a distance pair wins over a bridged one of the same two groups.
///
/// The evidence can contradict itself (a cycle p < q < r < p) where charts are far from planar: no plane
/// per group then keeps every order. accept_orders takes the pairs by decreasing evidence and drops each
/// one that would close a cycle.
///
/// The shortest such contradiction is one group alone (self bridges): a group that borders one chart of
/// another axis along that chart's top and along its foot with charts of the same label (a step's floor on
/// both), the foot lower by more than h/2. A plane per group gives that chart no height there: the map
/// flattens it. A cuboid ring whose top climbs by ramps and drops back by one step wall is one: its top is
/// one chart, on the wall's top and at its foot. They are looked for along the input's creases only (a
/// part's step: top and foot each at least kSelfBridgeLength hex edges of crease): on a smooth surface the
/// test also finds a group on both ends of a curved chart, mostly with one end under 1.5 hex edges long,
/// and cutting those lowered the minimum scaled Jacobian of the organic models (docs/polycube_segment.md).
#pragma once

#include "nodes/artefacts/meshes.h"

#include <utility>
#include <vector>

namespace polyhex {

/// The unique edges of a tet mesh and their adjacency (CSR).
struct TetEdgeGraph {
  std::vector<std::pair<int, int>> edges;  ///< (i, j), i < j, sorted
  std::vector<int> start, nbr;             ///< neighbours of v: nbr[start[v] .. start[v+1])
  /// \pre every index of T is in [0, vertices)
  TetEdgeGraph(const RowMatrixX4i& T, int vertices);
};

/// An ordering requirement between two same-axis chart groups p < q: sign * (k_q − k_p) >= 1.
struct OrderedPair {
  int p = 0, q = 0;
  int sign = 1;
  double evidence = 0;  ///< |separation| / h that the order was read from (stronger evidence wins a conflict)
};

struct AxisChartOrder {
  int groups = 0;
  int merged_same_axis_charts = 0;  ///< unions made (same-axis charts sharing a vertex)
  std::vector<int> chart_group;     ///< per chart: its group, -1 for charts of the other axes
  std::vector<int> vertex_group;    ///< per vertex: the group of its a-chart, -1 if none
  std::vector<int> group_size;      ///< vertices per group
  std::vector<double> group_mean;   ///< mean a-coordinate of a group's vertices
  struct Sample {
    int p, q;                   ///< groups, p < q
    double delta;               ///< mean axis distance (closest vertex of q minus closest vertex of p)
    double p_at = 0, q_at = 0;  ///< mean axis coordinate of p's / q's closest vertices over the samples
                                ///< (where along a, on each group, the two regions meet; delta = q_at − p_at)
  };
  std::vector<Sample> distance_samples;  ///< sorted by (p, q)
  std::vector<OrderedPair> ordered;      ///< unique by (p, q), sorted by (p, q)
  /// A group on both ends of a chart of another axis: at the chart's top (the chart's vertices next to
  /// the group's lie lower along a on average) and at its foot (they lie higher).
  struct SelfBridge {
    int group = -1, chart = -1;
    double top = 0, foot = 0;  ///< mean a-coordinate of the group's vertices on the chart's top / foot
  };
  std::vector<SelfBridge> self_bridges;  ///< those with top - foot > h/2, sorted by (group, chart)
};

/// Length, in hex edges, of crease that a self bridge's top and its foot each need.
constexpr double kSelfBridgeLength = 3.0;

/// The order evidence of the charts of axis `axis`.
/// \param V               #V by 3 deformed vertex positions
/// \param graph           the tet edges of the mesh V belongs to
/// \param vertex_charts   per vertex the charts it lies on (boundary vertices only have any)
/// \param chart_label     per chart its direction label 0..5
/// \param chart_neighbours per chart its neighbouring charts
/// \param h               hex edge length (the order threshold is h / 2)
/// \param crease_vertex   per vertex: on a crease of the input; without it no self bridges are looked for
/// \pre vertex_charts.size() == V.rows() == graph.start.size() - 1, chart ids in [0, chart_label.size()),
///      chart_neighbours.size() == chart_label.size(), 0 <= axis < 3, h > 0, crease_vertex (when given)
///      of size V.rows()
AxisChartOrder chart_order_evidence(const RowMatrixX3d& V, const TetEdgeGraph& graph,
                                    const std::vector<std::vector<int>>& vertex_charts,
                                    const std::vector<int>& chart_label,
                                    const std::vector<std::vector<int>>& chart_neighbours, int axis, double h,
                                    const std::vector<char>* crease_vertex = nullptr);

struct OrderAcceptance {
  std::vector<std::vector<int>> up;   ///< accepted orders as a graph: lower group -> upper groups
  std::vector<std::vector<int>> gap;  ///< per entry of up: the least level difference it asks for (1; the map
                                      ///< sets 2 where a feature line needs a level between the two groups)
  std::vector<int> dropped;           ///< indices into the ordered pairs of those dropped (each closed a cycle)
};

/// Accepts the ordered pairs by decreasing evidence (stable), dropping each that would close a cycle.
/// \pre every pair's groups are in [0, groups)
OrderAcceptance accept_orders(const std::vector<OrderedPair>& ordered, int groups);

/// Integer levels (in hex edges) for the groups that keep every accepted order at least one level apart (its
/// `gap`, 1 or more) and move the groups as little as they must: the weighted least-squares placement
///   min Σ_g w_g (x_g − t_g)²  subject to  x_hi − x_lo ≥ gap for every accepted order lo -> hi,
/// solved by dual coordinate ascent (Hildreth's method: one multiplier per order, each step projects onto
/// one constraint; exact for this convex quadratic program), then rounded to the nearest integers (rounding
/// is monotone and the gaps are integers, so every gap holds after it) and, as a safeguard when the ascent
/// stopped at its sweep cap, pushed up along the accepted orders (longest path) until each holds.
/// Why not only the push: pushing every group up to one level above the groups below it keeps the lowest
/// groups in place and lets a stack of small, nearly level charts carry the shift upwards: on femur a chain
/// of ten charts of 12-176 vertices, read from orders of 0.5-1 hex edges, pushed a chart 5.2 hex edges and a
/// chart of 1,252 vertices 1.9 from where the Poisson step put them; the placement spreads the shift over the
/// chain by the groups' weights, so large charts barely move.
/// \param accepted  the accepted orders (accept_orders: acyclic)
/// \param target    per group its level before rounding (coordinate / h)
/// \param weight    per group its weight (> 0; the vertex count: a chart's stiffness in the map)
/// \param max_sweeps cap on the ascent's sweeps over the orders
/// \pre target.size() == weight.size() == accepted.up.size(), every weight > 0, the accepted graph acyclic
/// \throw std::invalid_argument on mismatched sizes, a weight <= 0 or a cycle in the accepted orders
std::vector<long> place_levels(const OrderAcceptance& accepted, const std::vector<double>& target,
                               const std::vector<double>& weight, int max_sweeps = 20000);

/// Pushes every group up to at least its order's gap (1 or more) above each group below it in the accepted
/// orders, in topological order (a longest-path pass from the given levels): afterwards every accepted order
/// holds.
/// \pre k.size() == accepted.up.size()
/// \throw std::invalid_argument on a size mismatch or a cycle in the accepted orders
void push_levels(const OrderAcceptance& accepted, std::vector<long>& k);

/// The groups of the cycle a dropped pair closes: a path from its upper to its lower group in the
/// accepted graph (both ends included); empty when there is none.
std::vector<int> order_cycle(const OrderAcceptance& accepted, const OrderedPair& dropped);

/// Where a cycle can be cut: a group g on it must lie above the group b below it on the cycle and below
/// the group t above it. When g's vertices closest to b sit higher along the axis than g's vertices
/// closest to t (distance samples: g is tilted, or stepped, between the two places), no one plane of g
/// keeps both orders; cut across g between the two heights, its part near b and its part near t each
/// get their own plane and the cycle opens there. One cut per such group, at the middle of the two
/// heights, `excess` = their difference.
struct CycleCut {
  int group = -1;
  double level = 0;   ///< axis coordinate to cut g at
  double excess = 0;  ///< height of g near b minus height of g near t (> 0)
};

/// The cuts of `cycle` (order_cycle of `dropped`: lowest first, the dropped pair closing it) whose excess is
/// at least min_excess; a group met by a bridged pair (no distance samples) on either side is skipped.
/// \pre every group of cycle in [0, order.groups), order.distance_samples sorted by (p, q)
std::vector<CycleCut> cycle_cuts(const AxisChartOrder& order, const std::vector<int>& cycle, double min_excess);

}  // namespace polyhex
