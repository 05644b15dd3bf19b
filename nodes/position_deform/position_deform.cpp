#include "nodes/position_deform/position_deform.h"

#include "nodes/algorithms/chart_order.h"
#include "nodes/algorithms/features.h"
#include "nodes/algorithms/incomplete_lut.h"
#include "nodes/algorithms/reference_length.h"
#include "nodes/position_deform/feature_lines.h"
#include "runtime/cancel.h"
#include "runtime/errors.h"
#include "runtime/factorization.h"
#include "runtime/stopwatch.h"
#include "runtime/two_phase.h"

#include <Eigen/Dense>
#include <Eigen/IterativeLinearSolvers>
#include <oneapi/tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>

namespace polyhex {

namespace {

using Clock = std::chrono::steady_clock;

/// A crease inside a chart becomes a feature line when it is at least this many hex edges long: a short
/// straight run is as likely a scan's faceting (femur keeps a dozen such lines of 2-5 hex edges), and a line
/// pinned through a chart where the part has no edge only costs the map.
constexpr double kFeatureLineLength = 4.0;
/// A feature line given room between its flanks stays free within this many hex edges of another feature line.
constexpr double kCrossingFree = 2.0;
/// lattice_spacing input_volume: the Poisson step's volume ratio is taken within [this, 1 / this], so that a map
/// that has folded onto itself (a ratio near 0 or negative) cannot ask for a lattice of more than 8 times the
/// cells of the requested size.
constexpr double kMinVolumeRatio = 0.125;

/// Mean value coordinates of point x w.r.t. the triangle (p1,p2,p3) of a closed star polyhedron around x
/// (Ju, Schaefer, Warren 2005, as used by [FKR05] for the 3D Laplacian). Adds to w[0..2].
void mvc_triangle(const Eigen::Vector3d& x, const Eigen::Vector3d* p, double* w) {
  Eigen::Vector3d u[3];
  double d[3];
  for (int i = 0; i < 3; ++i) {
    d[i] = (p[i] - x).norm();
    if (d[i] < 1e-300) return;
    u[i] = (p[i] - x) / d[i];
  }
  double theta[3], c[3], s[3];
  for (int i = 0; i < 3; ++i) {
    double l = (u[(i + 1) % 3] - u[(i + 2) % 3]).norm();
    theta[i] = 2.0 * std::asin(std::min(1.0, l / 2.0));
  }
  double h = (theta[0] + theta[1] + theta[2]) / 2.0;
  if (M_PI - h < 1e-12) return;  // x on the triangle: cannot happen for an interior vertex of a valid star
  double det = u[0].dot(u[1].cross(u[2]));
  double sg = det < 0 ? -1.0 : 1.0;
  for (int i = 0; i < 3; ++i) {
    double den = std::sin(theta[(i + 1) % 3]) * std::sin(theta[(i + 2) % 3]);
    if (std::abs(den) < 1e-300) return;
    c[i] = 2.0 * std::sin(h) * std::sin(h - theta[i]) / den - 1.0;
    c[i] = std::clamp(c[i], -1.0, 1.0);
    s[i] = sg * std::sqrt(1.0 - c[i] * c[i]);
    if (std::abs(s[i]) < 1e-12) return;  // x in the plane of the triangle, outside it: no contribution
  }
  for (int i = 0; i < 3; ++i) {
    int ip = (i + 1) % 3, im = (i + 2) % 3;
    w[i] += (theta[i] - c[ip] * theta[im] - c[im] * theta[ip]) / (d[i] * std::sin(theta[ip]) * s[im]);
  }
}

}  // namespace

double conformal_distortion(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                            const Eigen::Vector3d& d, const Eigen::Vector3d& A, const Eigen::Vector3d& B,
                            const Eigen::Vector3d& C, const Eigen::Vector3d& D) {
  Eigen::Matrix3d E0, E1;
  E0 << b - a, c - a, d - a;
  E1 << B - A, C - A, D - A;
  double d0 = E0.determinant(), d1 = E1.determinant();
  if (!(d0 > 0) || !(d1 > 0)) return std::numeric_limits<double>::infinity();
  Eigen::Matrix3d J = E1 * E0.inverse();
  return J.norm() * J.inverse().norm() / 3.0;
}

namespace {

/// The inputs and sizes every axis of the solve shares.
struct AxisInputs {
  const TetMesh& input;
  const RowMatrixX3d& Vd;  ///< the deformed mesh (rotation stage)
  const PolyCubeSegmentation& seg;
  const PositionDeformParams& p;
  const TetEdgeGraph& graph;
  std::vector<std::vector<int>> vcharts;           ///< per vertex its charts (boundary vertices only have any)
  std::vector<int> chart_label;                    ///< per chart its label
  std::vector<std::vector<int>> chart_neighbours;  ///< per chart its neighbours
  std::vector<char> on_boundary;                   ///< per vertex: on the segmented surface
  /// Mean value weights on the deformed mesh (final_solve "mvc_laplace"): surface (2D) weights of the
  /// boundary vertices, volume (3D) weights of the others.
  std::vector<std::map<int, double>> surf_w;
  std::vector<std::vector<std::pair<int, double>>> vol_w;
  std::vector<FeatureLine> lines;  ///< creases inside a chart to put on lattice lines (feature_lines.h)
  double diag = 0, h = 0, min_d = 0, sigma = 0;
  double lattice = 0;  ///< the lattice spacing on the PolyCube (step 3 of the header): h or h scaled to the volume
};

/// \throw InvalidInput for a deformed mesh of other connectivity or a malformed segmentation
void check_inputs(const TetMesh& input, const TetMesh& deformed, const PolyCubeSegmentation& seg) {
  const int nV = int(input.V.rows());
  if (deformed.V.rows() != nV || deformed.T.rows() != input.T.rows())
    throw InvalidInput(input.source + ": the deformed mesh has " + std::to_string(deformed.V.rows()) +
                       " vertices, the input " + std::to_string(nV) + ": they must share connectivity");
  const int nC = int(seg.charts.size());
  if (seg.chart.size() != seg.F.rows()) throw InvalidInput(input.source + ": segmentation has no chart per triangle");
  for (Eigen::Index f = 0; f < seg.F.rows(); ++f) {
    if (seg.chart[f] < 0 || seg.chart[f] >= nC)
      throw InvalidInput(input.source + ": triangle " + std::to_string(f) + " has chart id out of range");
    for (int k = 0; k < 3; ++k)
      if (seg.F(f, k) < 0 || seg.F(f, k) >= nV)
        throw InvalidInput(input.source + ": segmentation triangle index out of range");
  }
}

/// The signed volume of tets T on the vertices V, summed in tet order (the same sum for any thread count).
double signed_volume(const RowMatrixX3d& V, const RowMatrixX4i& T) {
  double volume = 0;
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    const Eigen::Vector3d a = V.row(T(t, 0)), b = V.row(T(t, 1)), c = V.row(T(t, 2)), d = V.row(T(t, 3));
    volume += (b - a).cross(c - a).dot(d - a) / 6.0;
  }
  return volume;
}

/// Refuses a hex edge length the machine cannot afford before any work: the lattice gives about
/// volume / h³ hexes. \throw InvalidInput above p.max_hexes
void check_budget(double volume, const std::string& source, const PositionDeformParams& p, double h) {
  const double estimate = volume / (h * h * h);
  if (estimate > p.max_hexes) {
    char msg[320];
    std::snprintf(msg, sizeof msg,
                  ": refused: edge_length %g would give about %.3g hexes (volume / h^3), more than max_hexes = %.3g; "
                  "use edge_length >= %.3g or raise max_hexes",
                  p.edge_length, estimate, p.max_hexes, p.edge_length * std::cbrt(estimate / p.max_hexes));
    throw InvalidInput(source + msg);
  }
}

/// The charts of every vertex, their labels and neighbours, and the boundary vertices.
void chart_incidence(AxisInputs& in) {
  const PolyCubeSegmentation& seg = in.seg;
  const int nV = int(in.input.V.rows()), nC = int(seg.charts.size());
  in.vcharts.assign(size_t(nV), {});
  for (Eigen::Index f = 0; f < seg.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      auto& v = in.vcharts[seg.F(f, k)];
      int c = seg.chart[f];
      if (std::find(v.begin(), v.end(), c) == v.end()) v.push_back(c);
    }
  in.chart_label.resize(size_t(nC));
  in.chart_neighbours.resize(size_t(nC));
  for (int c = 0; c < nC; ++c)
    in.chart_label[c] = seg.charts[c].label, in.chart_neighbours[c] = seg.charts[c].neighbours;
  in.on_boundary.assign(size_t(nV), 0);
  for (Eigen::Index f = 0; f < seg.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) in.on_boundary[seg.F(f, k)] = 1;
}

/// The mean value weights of the final solve "mvc_laplace", on the deformed mesh: per boundary vertex
/// the 2D weights of its triangles (tan(angle/2) / length), per interior vertex the 3D weights of its
/// star (mvc_triangle).
void mvc_weights(AxisInputs& in) {
  const PolyCubeSegmentation& seg = in.seg;
  const TetMesh& input = in.input;
  const RowMatrixX3d& Vd = in.Vd;
  const int nV = int(input.V.rows());
  in.surf_w.resize(size_t(nV));
  for (Eigen::Index f = 0; f < seg.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      int i = seg.F(f, k), j = seg.F(f, (k + 1) % 3), l = seg.F(f, (k + 2) % 3);
      Eigen::Vector3d a = Vd.row(j) - Vd.row(i), b = Vd.row(l) - Vd.row(i);
      double la = a.norm(), lb = b.norm();
      if (la < 1e-300 || lb < 1e-300) continue;
      double ang = std::acos(std::clamp(a.dot(b) / (la * lb), -1.0, 1.0));
      double t = std::tan(ang / 2.0);
      in.surf_w[i][j] += t / la;
      in.surf_w[i][l] += t / lb;
    }
  std::vector<std::vector<int>> vt(nV);
  for (Eigen::Index t = 0; t < input.T.rows(); ++t)
    for (int k = 0; k < 4; ++k) vt[input.T(t, k)].push_back(int(t));
  in.vol_w.resize(size_t(nV));
  static const int opp[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  oneapi::tbb::parallel_for(0, nV, [&](int i) {
    if (in.on_boundary[i]) return;
    std::map<int, double> w;
    Eigen::Vector3d x = Vd.row(i).transpose();
    for (int t : vt[i]) {
      int k = 0;
      while (input.T(t, k) != i) ++k;
      Eigen::Vector3d P[3];
      int id[3];
      for (int m = 0; m < 3; ++m) {
        id[m] = input.T(t, opp[k][m]);
        P[m] = Vd.row(id[m]).transpose();
      }
      double ww[3] = {0, 0, 0};
      mvc_triangle(x, P, ww);
      for (int m = 0; m < 3; ++m) w[id[m]] += ww[m];
    }
    in.vol_w[i].assign(w.begin(), w.end());
  });
}

struct DistancePair {
  int p, q;
  double delta, w;
};

/// The distance-preservation constraints of §5.2 (step 2 of the header) from the order evidence.
std::vector<DistancePair> distance_pairs(const AxisChartOrder& order, const AxisInputs& in) {
  std::vector<DistancePair> dpairs;
  for (auto& s : order.distance_samples) {
    double excess = std::max(std::abs(s.delta) - in.min_d, 0.0);
    double w = in.p.distance_weight * std::min(order.group_size[s.p], order.group_size[s.q]) *
               std::exp(-excess * excess / (in.sigma * in.sigma));
    if (w > 0) dpairs.push_back({s.p, s.q, s.delta, w});
  }
  return dpairs;
}

/// The Poisson step of one axis (step 1): unknowns = the free vertices, then the chart groups.
struct PoissonStep {
  std::vector<int> var;  ///< per vertex its unknown
  int nFree = 0;         ///< free vertices (the first unknowns)
  Eigen::SparseMatrix<double> A;
  Eigen::VectorXd rhs, y;  ///< the system's right-hand side and solution
  bool iterative = false;  ///< solved by conjugate gradients (poisson_direct_max)
};

PoissonStep poisson_step(const AxisInputs& in, const AxisChartOrder& order, const std::vector<DistancePair>& dpairs,
                         int a) {
  const RowMatrixX3d& Vd = in.Vd;
  const int nV = int(in.input.V.rows()), nG = order.groups;
  const std::vector<int>& vgroup = order.vertex_group;
  PoissonStep ps;
  std::vector<int>& var = ps.var;
  var.resize(size_t(nV));
  int& nFree = ps.nFree;
  for (int v = 0; v < nV; ++v) var[v] = vgroup[v] < 0 ? nFree++ : -1;
  for (int v = 0; v < nV; ++v)
    if (vgroup[v] >= 0) var[v] = nFree + vgroup[v];
  const int n = nFree + nG;
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(in.graph.edges.size() * 3 + dpairs.size() * 3 + n);
  Eigen::VectorXd& rhs = ps.rhs;
  rhs = Eigen::VectorXd::Zero(n);
  auto add_term = [&](int x, int y, double w, double target) {  // w ((y_y - y_x) - target)^2
    trip.emplace_back(x, x, w);
    trip.emplace_back(y, y, w);
    trip.emplace_back(std::max(x, y), std::min(x, y), -w);
    rhs[x] -= w * target;
    rhs[y] += w * target;
  };
  for (auto& [i, j] : in.graph.edges)
    if (var[i] != var[j]) add_term(var[i], var[j], 1.0, Vd(j, a) - Vd(i, a));
  for (auto& d : dpairs) add_term(nFree + d.p, nFree + d.q, d.w, d.delta);
  // Tiny pull towards the deformed coordinates removes the translation null space: per unknown its weight
  // (eps, times the group's size for a chart group) and target (the deformed coordinate, the group's mean).
  const double eps = 1e-8;
  Eigen::VectorXd pull_w(n), pull_t(n);
  for (int v = 0; v < nV; ++v)
    if (vgroup[v] < 0) pull_w[var[v]] = eps, pull_t[var[v]] = Vd(v, a);
  for (int g = 0; g < nG; ++g) pull_w[nFree + g] = eps * order.group_size[g], pull_t[nFree + g] = order.group_mean[g];
  for (int i = 0; i < n; ++i) trip.emplace_back(i, i, pull_w[i]), rhs[i] += pull_w[i] * pull_t[i];
  ps.A.resize(n, n);
  ps.A.setFromTriplets(trip.begin(), trip.end());
  throw_if_interrupted();
  if (n > in.p.poisson_direct_max) {
    // Conjugate gradients on the lower triangle, preconditioned by an incomplete Cholesky factor. The eps pull
    // is the only thing that fixes the translation (eigenvalue ~eps), which a relative tolerance need not resolve:
    // summing the rows of A y = rhs gives it exactly (the edge and distance terms sum to zero), Σ w y = Σ w t
    // over the pulls' weights w and targets t, so the solution is shifted to satisfy it.
    Eigen::ConjugateGradient<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::IncompleteCholesky<double, Eigen::Lower>>
        cg;
    cg.setTolerance(1e-11);
    cg.setMaxIterations(20000);
    cg.compute(ps.A);
    if (cg.info() == Eigen::Success) {
      ps.y = cg.solve(rhs);
      if (cg.info() == Eigen::Success && ps.y.allFinite()) {
        double wsum = 0, wt = 0, wy = 0;
        for (int i = 0; i < n; ++i) wsum += pull_w[i], wt += pull_w[i] * pull_t[i], wy += pull_w[i] * ps.y[i];
        ps.y.array() += (wt - wy) / wsum;
        ps.iterative = true;
        return ps;
      }
    }
    // not converged: the factorization below
  }
  CholmodFactorization chol(ps.A);
  ps.y = chol.solve(rhs);
  return ps;
}

/// The two a-charts beside a feature line of axis a that stand on either side of it facing each other: the walls of
/// a V-shaped slot whose bottom the line is (+a below, -a above). Rounded one level apart, they leave no lattice
/// line between them for the crease. (The faces of a thin fin, -a below and +a above, were tried too: carter's
/// ribs and girl's fingers, 1.3-5 hex edges thick, got room and every figure fell, docs/features.md.)
struct LineFlanks {
  int lo = -1, hi = -1;     ///< their chart groups, below and above the line (-1: the line has no such pair)
  std::vector<int> charts;  ///< the a-charts within two edges of the line's vertices
};

/// Per feature line of axis a (in.lines), the mean of its vertices' Poisson values (NaN for the other lines).
std::vector<double> line_means(int a, const AxisInputs& in, const PoissonStep& ps) {
  std::vector<double> out(in.lines.size(), std::numeric_limits<double>::quiet_NaN());
  for (size_t i = 0; i < in.lines.size(); ++i) {
    const FeatureLine& line = in.lines[i];
    if (line.axis != a || line.vertices.empty()) continue;
    double sum = 0;
    for (int v : line.vertices) sum += ps.y[ps.var[size_t(v)]];
    out[i] = sum / double(line.vertices.size());
  }
  return out;
}

/// Per feature line (in.lines), its flanks on axis a from the Poisson step's values: among the a-charts within
/// two edges of its vertices, the nearest below the mean of its vertices (mean, line_means) and the nearest above,
/// if they are a slot's walls (+a below, -a above). (The line's chart may border other a-charts far from the line:
/// a slot's floor that runs on past a crossing slot.)
std::vector<LineFlanks> line_flanks(int a, const AxisInputs& in, const AxisChartOrder& order, const PoissonStep& ps,
                                    const std::vector<double>& mean) {
  std::vector<LineFlanks> out(in.lines.size());
  if (!in.p.feature_line_room) return out;
  for (size_t i = 0; i < in.lines.size(); ++i) {
    const FeatureLine& line = in.lines[i];
    if (line.axis != a || line.vertices.empty()) continue;
    // the a-charts within two edges of at least half of the line's vertices (one near its end only may belong
    // to a crossing feature)
    std::map<int, int> count;
    std::vector<int> ring;
    for (int v0 : line.vertices) {
      ring.assign(1, v0);
      for (size_t x = 0, to = 1, r = 0; r < 2; ++r, to = ring.size())
        for (; x < to; ++x)
          for (int e = in.graph.start[size_t(ring[x])]; e < in.graph.start[size_t(ring[x]) + 1]; ++e)
            ring.push_back(in.graph.nbr[size_t(e)]);
      std::vector<int> near;
      for (int v : ring)
        for (int ch : in.vcharts[size_t(v)])
          if (label_axis(in.chart_label[size_t(ch)]) == a) near.push_back(ch);
      std::sort(near.begin(), near.end());
      near.erase(std::unique(near.begin(), near.end()), near.end());
      for (int ch : near) ++count[ch];
    }
    std::vector<int>& charts = out[i].charts;
    for (const auto& [ch, n] : count)
      if (2 * n >= int(line.vertices.size())) charts.push_back(ch);
    double below = -std::numeric_limits<double>::infinity(), above = std::numeric_limits<double>::infinity();
    int lo = -1, hi = -1, lo_sign = 0, hi_sign = 0;
    for (int ch : charts) {
      const int g = order.chart_group[size_t(ch)];
      const double c = ps.y[ps.nFree + g];
      if (c < mean[i] && c > below) below = c, lo = g, lo_sign = label_sign(in.chart_label[size_t(ch)]);
      if (c > mean[i] && c < above) above = c, hi = g, hi_sign = label_sign(in.chart_label[size_t(ch)]);
    }
    if (lo >= 0 && hi >= 0 && lo != hi && lo_sign == 1 && hi_sign == -1) out[i].lo = lo, out[i].hi = hi;
  }
  return out;
}

/// Rounding to the lattice, keeping ordered pairs apart (step 3, §5.2): the integer level of every chart
/// group. The ordered pairs as a graph "lower -> upper": pairs are taken by decreasing evidence and one
/// that would close a cycle (contradicting stronger evidence) is dropped; then the levels: the balanced
/// placement (chart_order.h), or every chart pushed up to at least one h above each chart below it, in
/// topological order (longest path from the rounded values). The per-pair nudging before both could
/// undo itself on conflicting pairs and leave orders swapped.
std::vector<long> chart_levels(const AxisChartOrder& order, const PoissonStep& ps, const AxisInputs& in,
                               const std::vector<LineFlanks>& flanks, PositionDeformStats& st) {
  const int nG = order.groups;
  const double h = in.lattice;
  std::vector<double> c(nG);
  std::vector<long> k(nG);
  for (int g = 0; g < nG; ++g) c[g] = ps.y[ps.nFree + g], k[g] = std::lround(c[g] / h);
  for (auto& o : order.ordered)
    if (o.sign * (c[o.q] - c[o.p]) <= 0) ++st.flipped_chart_orders;
  OrderAcceptance acc = accept_orders(order.ordered, nG);
  // a feature line between a slot's two walls (line_flanks) gets a level between them: they go 2 levels apart
  for (const LineFlanks& f : flanks) {
    if (f.lo < 0) continue;
    const auto& up = acc.up[size_t(f.lo)];
    const auto it = std::find(up.begin(), up.end(), f.hi);
    if (it == up.end()) continue;  // no accepted order between them to widen
    acc.gap[size_t(f.lo)][size_t(it - up.begin())] = 2;
    ++st.feature_lines_given_room;
  }
  st.order_constraints_dropped += int(acc.dropped.size());
  if (in.p.level_placement == LevelPlacement::balanced) {
    std::vector<double> target(nG), weight(nG);
    for (int g = 0; g < nG; ++g) target[g] = c[g] / h, weight[g] = double(order.group_size[g]);
    k = place_levels(acc, target, weight);
  } else {
    push_levels(acc, k);
  }
  for (auto& o : order.ordered)
    if (o.sign * (k[o.q] - k[o.p]) < 1) ++st.flipped_after_rounding;
  for (int g = 0; g < nG; ++g)
    st.chart_coordinates_rounded_max_shift =
        std::max(st.chart_coordinates_rounded_max_shift, std::abs(c[g] - k[g] * h) / h);
  return k;
}

/// Final solve "poisson": step 1's energy restricted to the free unknowns (the upper-left block of A),
/// with the pinned groups moved to the right-hand side. Writes the free vertices of u.
void final_poisson(const PoissonStep& ps, const std::vector<long>& k, const AxisInputs& in,
                   const std::vector<int>& vgroup, const std::vector<double>& pin, Eigen::VectorXd& u) {
  const int nFree = ps.nFree, nV = int(u.size());
  const double h = in.lattice;
  std::vector<Eigen::Triplet<double>> tf;
  Eigen::VectorXd b = ps.rhs.head(nFree);
  for (int col = 0; col < ps.A.outerSize(); ++col)
    for (Eigen::SparseMatrix<double>::InnerIterator it(ps.A, col); it; ++it) {
      int r = int(it.row()), cc = int(it.col());
      if (r < nFree && cc < nFree)
        tf.emplace_back(r, cc, it.value());
      else if (r >= nFree && cc < nFree)
        b[cc] -= it.value() * k[r - nFree] * h;
      else if (cc >= nFree && r < nFree)
        b[r] -= it.value() * k[cc - nFree] * h;
    }
  // pinned free vertices (feature lines): a stiff spring to their level, then set exactly
  double stiff = 0;
  for (const auto& t : tf) stiff = std::max(stiff, std::abs(t.value()));
  stiff *= 1e8;
  for (int v = 0; v < nV; ++v)
    if (vgroup[v] < 0 && std::isfinite(pin[size_t(v)]))
      tf.emplace_back(ps.var[v], ps.var[v], stiff), b[ps.var[v]] += stiff * pin[size_t(v)];
  Eigen::SparseMatrix<double> Af(nFree, nFree);
  Af.setFromTriplets(tf.begin(), tf.end());
  CholmodFactorization cf(Af);
  Eigen::VectorXd yf = cf.solve(b);
  for (int v = 0; v < nV; ++v)
    if (vgroup[v] < 0) u[v] = std::isfinite(pin[size_t(v)]) ? pin[size_t(v)] : yf[ps.var[v]];
}

/// Final solve "mvc_laplace" (the paper): the mean value Laplace equation with the chart planes pinned.
/// It is not symmetric, so BiCGSTAB, started from the Poisson step's solution, which is already close;
/// with `final_jacobi_iterations` > 0, or above `final_ilu_max` unknowns, first with the diagonal preconditioner
/// (no set-up cost), then, where that does not converge, with the incomplete LU from where it stopped (the
/// header's final_jacobi_iterations says why the diagonal one is not the default at the table's sizes). Writes
/// the free vertices of u.
/// \throw SolverError for a vertex with zero weights, a system that cannot be preconditioned or a
///        solve that does not converge
void final_mvc(const PoissonStep& ps, const AxisInputs& in, const std::vector<int>& vgroup,
               const std::vector<double>& pin, int a, Eigen::VectorXd& u, PositionDeformStats& st) {
  const int nFree = ps.nFree, nV = int(u.size());
  const std::vector<int>& var = ps.var;
  std::vector<Eigen::Triplet<double>> tf;
  Eigen::VectorXd b = Eigen::VectorXd::Zero(nFree);
  for (int v = 0; v < nV; ++v) {
    if (vgroup[v] >= 0) continue;
    int r = var[v];
    if (std::isfinite(pin[size_t(v)])) {  // a feature line's vertex: its level
      tf.emplace_back(r, r, 1.0);
      b[r] = pin[size_t(v)];
      continue;
    }
    double sum = 0;
    auto add = [&](int j, double w) {
      sum += w;
      if (vgroup[j] >= 0)
        b[r] += w * u[j];
      else
        tf.emplace_back(r, var[j], -w);
    };
    if (in.on_boundary[v])
      for (auto& [j, w] : in.surf_w[v]) add(j, w);
    else
      for (auto& [j, w] : in.vol_w[v]) add(j, w);
    if (std::abs(sum) < 1e-300)
      throw SolverError(in.input.source + ": vertex " + std::to_string(v) + " has zero mean value weights");
    tf.emplace_back(r, r, sum);
  }
  Eigen::SparseMatrix<double> Af(nFree, nFree);
  Af.setFromTriplets(tf.begin(), tf.end());
  Af.makeCompressed();
  Eigen::SparseMatrix<double, Eigen::RowMajor> Ar = Af;
  Eigen::VectorXd yf(nFree);
  for (int v = 0; v < nV; ++v)
    if (vgroup[v] < 0) yf[var[v]] = std::isfinite(pin[size_t(v)]) ? pin[size_t(v)] : ps.y[var[v]];
  constexpr double tol = 1e-12;
  constexpr int kLargeJacobiIterations = 5000;  // above final_ilu_max (392 per axis at 350k unknowns)
  const int jacobi_iterations = in.p.final_jacobi_iterations > 0 ? in.p.final_jacobi_iterations
                                : nFree > in.p.final_ilu_max     ? kLargeJacobiIterations
                                                                 : 0;
  bool done = false;
  if (jacobi_iterations > 0) {
    Eigen::BiCGSTAB<Eigen::SparseMatrix<double, Eigen::RowMajor>> jacobi;
    jacobi.setTolerance(tol);
    jacobi.setMaxIterations(jacobi_iterations);
    jacobi.compute(Ar);
    Eigen::VectorXd x = jacobi.solveWithGuess(b, yf);
    st.final_iterations += int(jacobi.iterations());
    if (x.allFinite()) {
      yf = x;
      done = jacobi.info() == Eigen::Success && jacobi.error() <= tol;
    }
  }
  if (!done) {
    ++st.final_ilu_axes;
    Eigen::BiCGSTAB<Eigen::SparseMatrix<double, Eigen::RowMajor>, FastIncompleteLUT> solver;  // Eigen's factor, faster
    solver.preconditioner().setDroptol(1e-4);
    solver.preconditioner().setFillfactor(10);
    solver.setTolerance(tol);
    solver.setMaxIterations(2000);
    solver.compute(Ar);
    if (solver.info() != Eigen::Success)
      throw SolverError(in.input.source + ": mean value Laplace system (axis " + std::string(1, char('X' + a)) +
                        ") could not be preconditioned");
    yf = solver.solveWithGuess(b, Eigen::VectorXd(yf));  // from where the diagonal one stopped
    st.final_iterations += int(solver.iterations());
    if (!yf.allFinite() || solver.error() > 1e-8)
      throw SolverError(in.input.source + ": mean value Laplace solve did not converge on axis " +
                        std::string(1, char('X' + a)) + " (relative residual " + std::to_string(solver.error()) + ")");
  }
  for (int v = 0; v < nV; ++v)
    if (vgroup[v] < 0) u[v] = yf[var[v]];
}

/// The levels of the feature lines across axis a (feature_lines.h): the rounded mean of their vertices'
/// Poisson values, unless that is the level of an a-chart beside the line's chart (the line would lie on the
/// chart's edge). A line whose flanks were given room (line_flanks, chart_levels) takes a level strictly between
/// them, clear of the a-charts near it, and its vertices within kCrossingFree hex edges of another line stay free.
/// `mean`: per line its vertices' mean Poisson value (line_means). Returns per vertex its pinned value (NaN: free)
/// and appends the pinned vertices.
std::vector<double> feature_line_pins(int a, const AxisInputs& in, const AxisChartOrder& order,
                                      const std::vector<double>& mean, const std::vector<long>& k,
                                      const std::vector<LineFlanks>& flanks, std::vector<int>& pinned,
                                      PositionDeformStats& st) {
  std::vector<double> pin(in.input.V.rows(), std::numeric_limits<double>::quiet_NaN());
  for (size_t i = 0; i < in.lines.size(); ++i) {
    const FeatureLine& line = in.lines[i];
    if (line.axis != a || line.vertices.empty()) continue;
    long level = std::lround(mean[i] / in.lattice);
    const LineFlanks& f = flanks[i];
    const bool room = f.lo >= 0 && k[size_t(f.hi)] - k[size_t(f.lo)] >= 2;
    bool clash = false;
    if (room) {  // between its flanks, clear of the a-charts near it
      level = std::clamp(level, k[size_t(f.lo)] + 1, k[size_t(f.hi)] - 1);
      for (int ch : f.charts) clash = clash || k[size_t(order.chart_group[size_t(ch)])] == level;
    } else {
      for (int nb : in.chart_neighbours[size_t(line.chart)])
        clash = clash || (label_axis(in.chart_label[size_t(nb)]) == a && k[order.chart_group[nb]] == level);
    }
    if (clash) continue;
    for (int v : line.vertices) {
      // a line given room stays free within kCrossingFree hex edges of another line: where two slots cross, both
      // bottoms pinned up to the crossing leave its hexes no room (8-connected: 0.316 against 0.612 so)
      bool near_other = false;
      for (size_t j = 0; room && j < in.lines.size() && !near_other; ++j)
        for (size_t x = 0; j != i && x < in.lines[j].vertices.size() && !near_other; ++x)
          near_other = (in.input.V.row(v) - in.input.V.row(in.lines[j].vertices[x])).norm() < kCrossingFree * in.h;
      if (!near_other) pin[size_t(v)] = double(level) * in.lattice, pinned.push_back(v);
    }
    ++st.feature_lines_pinned;
  }
  return pin;
}

/// One axis a of §5.2 (steps 1-4 of the header) gives the a-coordinate of the map, out.U.col(a), and the
/// planes of the a-charts, out.chart_plane. The three axes are independent (their own charts, Voronoi
/// partition, Poisson and final systems), each into its own statistics, and run in two phases
/// (runtime/two_phase.h): steps 1-3 (axis_levels), then the final solve (axis_final). This is what the
/// first phase hands to the second.
struct AxisLevels {
  AxisChartOrder order;
  PoissonStep ps;
  std::vector<long> k;      ///< per chart group its plane's level
  std::vector<double> pin;  ///< per vertex: the feature line level it is pinned to (NaN: free)
};

/// Steps 1-2 of axis a: the order evidence and the Poisson step.
AxisLevels axis_poisson(int a, const AxisInputs& in, PositionDeformStats& st) {
  throw_if_interrupted();  // safe point: per axis
  const int nC = int(in.seg.charts.size());
  const double h = in.h;
  // The order evidence of the a-charts (chart_order.h): groups of same-axis charts sharing a vertex
  // (one plane each), the Voronoi distance samples and the ordered pairs.
  std::vector<int> axis_charts;
  for (int c = 0; c < nC; ++c)
    if (label_axis(in.seg.charts[c].label) == a) axis_charts.push_back(c);
  if (axis_charts.empty())
    throw InvalidInput(in.input.source + ": the PolyCube structure has no chart on axis " +
                       std::string(1, char('X' + a)));
  AxisLevels lv;
  lv.order = chart_order_evidence(in.Vd, in.graph, in.vcharts, in.chart_label, in.chart_neighbours, a, h);
  st.merged_same_axis_charts += lv.order.merged_same_axis_charts;
  const std::vector<DistancePair> dpairs = distance_pairs(lv.order, in);
  st.distance_pairs += int(dpairs.size());
  st.ordered_pairs += int(lv.order.ordered.size());

  const auto t0 = Clock::now();
  lv.ps = poisson_step(in, lv.order, dpairs, a);
  st.poisson_cg_axes += lv.ps.iterative ? 1 : 0;
  st.seconds_poisson += seconds_since(t0);
  return lv;
}

/// Step 3 of axis a, at the lattice spacing in.lattice: the chart planes (written to out.chart_plane for the
/// a-charts) and the feature lines' levels, into lv.
void axis_levels(int a, const AxisInputs& in, AxisLevels& lv, PolyCubeMap& out, PositionDeformStats& st,
                 std::vector<int>& pinned) {
  const std::vector<double> mean = line_means(a, in, lv.ps);
  const std::vector<LineFlanks> flanks = line_flanks(a, in, lv.order, lv.ps, mean);
  lv.k = chart_levels(lv.order, lv.ps, in, flanks, st);
  for (int ch = 0; ch < int(in.seg.charts.size()); ++ch)
    if (label_axis(in.seg.charts[size_t(ch)].label) == a)
      out.chart_plane[ch] = int(lv.k[size_t(lv.order.chart_group[size_t(ch)])]);
  lv.pin = feature_line_pins(a, in, lv.order, mean, lv.k, flanks, pinned, st);
}

/// Step 4 of axis a: the final solve with the chart planes pinned, into out.U.col(a).
void axis_final(int a, const AxisInputs& in, const AxisLevels& lv, PolyCubeMap& out, PositionDeformStats& st) {
  throw_if_interrupted();
  const auto t0 = Clock::now();
  const int nV = int(in.input.V.rows());
  const std::vector<int>& vgroup = lv.order.vertex_group;
  Eigen::VectorXd u(nV);
  for (int v = 0; v < nV; ++v)
    if (vgroup[v] >= 0) u[v] = lv.k[vgroup[v]] * in.lattice;
  if (lv.ps.nFree > 0) {
    if (in.p.final_solve == FinalSolve::poisson)
      final_poisson(lv.ps, lv.k, in, vgroup, lv.pin, u);
    else
      final_mvc(lv.ps, in, vgroup, lv.pin, a, u, st);
  }
  out.U.col(a) = u;
  st.seconds_final += seconds_since(t0);
  // Planarity: exact by substitution; measured anyway.
  for (int v = 0; v < nV; ++v)
    if (vgroup[v] >= 0)
      st.planarity_error = std::max(st.planarity_error, std::abs(out.U(v, a) - lv.k[vgroup[v]] * in.lattice) / in.diag);
}

/// The per-axis statistics merged into st, in axis order, by their declared rules.
void merge_axes(const std::array<PositionDeformStats, 3>& axis_stats, PositionDeformStats& st) {
  for (const PositionDeformStats& s : axis_stats) merge_stats(st, s);
}

/// Untangling (step 5, untangle_map.h): a vertex keeps the coordinates of the chart planes it lies on.
void untangle(const TetMesh& input, const PolyCubeSegmentation& seg, const PositionDeformParams& p,
              const std::array<std::vector<int>, 3>& pinned, RowMatrixX3d& U, PositionDeformStats& st) {
  std::vector<std::uint8_t> fixed_axes(size_t(input.V.rows()), 0);
  for (Eigen::Index f = 0; f < seg.F.rows(); ++f) {
    const int a = label_axis(seg.charts[size_t(seg.chart[f])].label);
    for (int k = 0; k < 3; ++k) fixed_axes[size_t(seg.F(f, k))] |= std::uint8_t(1 << a);
  }
  for (int a = 0; a < 3; ++a)  // and the feature lines' levels
    for (int v : pinned[size_t(a)]) fixed_axes[size_t(v)] |= std::uint8_t(1 << a);
  MapUntangleParams up;
  up.max_iterations = p.untangle_iterations;
  up.rings = p.untangle_rings;
  up.shrink = p.untangle_shrink;
  up.seconds = p.untangle_seconds;
  up.polish_everywhere = p.map_polish == MapPolish::everywhere;
  up.polish_iterations = p.map_polish_iterations;
  up.polish_preconditioner = p.map_polish_preconditioner;
  untangle_polycube_map(input.V, input.T, U, fixed_axes, up, &st.untangle);
}

/// Inverted tets and distortion of input -> PolyCube. A few near-degenerate tets have distortions of
/// 1e10 and more, so the mean says nothing: the median, the 99th percentile and the max.
void measure_distortion(const TetMesh& input, const RowMatrixX3d& U, const PositionDeformParams& p,
                        PositionDeformStats& st) {
  std::vector<double> dist(size_t(input.T.rows()), -1.0);
  oneapi::tbb::parallel_for(Eigen::Index(0), input.T.rows(), [&](Eigen::Index t) {
    Eigen::Vector3d q[4], Q[4];
    for (int k = 0; k < 4; ++k) q[k] = input.V.row(input.T(t, k)), Q[k] = U.row(input.T(t, k));
    if ((Q[1] - Q[0]).cross(Q[2] - Q[0]).dot(Q[3] - Q[0]) > 0)
      dist[size_t(t)] = conformal_distortion(q[0], q[1], q[2], q[3], Q[0], Q[1], Q[2], Q[3]);
  });
  std::vector<double> ok;
  ok.reserve(dist.size());
  for (double d : dist)
    if (d < 0)
      ++st.inverted_tets;
    else if (std::isfinite(d))
      ok.push_back(d);
  if (p.untangle_iterations == 0)  // no untangling: the final solve's folds are the map's
    st.untangle.inverted_before = st.untangle.inverted_after = st.inverted_tets;
  if (!ok.empty()) {
    auto at = [&](double f) {
      auto it = ok.begin() + std::ptrdiff_t(f * double(ok.size() - 1));
      std::nth_element(ok.begin(), it, ok.end());
      return *it;
    };
    st.distortion = at(0.5);
    st.distortion_p99 = at(0.99);
    st.distortion_max = *std::max_element(ok.begin(), ok.end());
  }
}

}  // namespace

PolyCubeMap position_deform(std::shared_ptr<const TetMesh> input_ptr, const TetMesh& deformed,
                            std::shared_ptr<const PolyCubeSegmentation> seg_ptr, const PositionDeformParams& p,
                            PositionDeformStats* stats_out, const ProgressFn& progress) {
  // The phases' shares of the bar: their times on the built-in shapes (the solves ~1/3, the untangling ~2/3).
  auto report = [&](double fraction, const char* what) {
    if (progress) progress(fraction, what);
  };
  const TetMesh& input = *input_ptr;
  const PolyCubeSegmentation& seg = *seg_ptr;
  check_inputs(input, deformed, seg);
  PositionDeformStats st;
  st.charts = int(seg.charts.size());
  const double diag = reference_length(input.V);
  const double h = p.edge_length * diag;
  const double input_volume = signed_volume(input.V, input.T);
  check_budget(input_volume, input.source, p, h);
  const TetEdgeGraph graph(input.T, int(input.V.rows()));
  AxisInputs in{input, deformed.V, seg, p, graph, {}, {}, {}, {}, {}, {}, {}};
  in.diag = diag;
  in.h = h;
  in.min_d = 2.0 * h;
  in.sigma = 3.0 * in.min_d;
  chart_incidence(in);
  if (p.final_solve == FinalSolve::mvc_laplace) mvc_weights(in);
  if (p.feature_lines) {
    in.lines = feature_lines(input.V, deformed.V, seg, kFeatureAngle, 0.5 * h, kFeatureLineLength * h, 0.5 * h);
    st.feature_lines = int(in.lines.size());
  }

  PolyCubeMap out;
  out.input = input_ptr;
  out.segmentation = seg_ptr;
  out.U.resize(input.V.rows(), 3);
  out.chart_plane = Eigen::VectorXi::Zero(st.charts);
  report(0, "chart planes, Poisson and final solves");
  std::array<PositionDeformStats, 3> axis_stats{};
  std::array<std::vector<int>, 3> pinned;  // per axis: the feature lines' vertices pinned on it
  std::array<AxisLevels, 3> levels;
  RowMatrixX3d poisson_U(input.V.rows(), 3);  // the Poisson step's map, for its volume
  auto poisson = [&](int a) {
    AxisLevels& lv = levels[size_t(a)];
    lv = axis_poisson(a, in, axis_stats[size_t(a)]);
    for (Eigen::Index v = 0; v < input.V.rows(); ++v) poisson_U(v, a) = lv.ps.y[lv.ps.var[size_t(v)]];
  };
  auto levels_and_final = [&](int a) {
    axis_levels(a, in, levels[size_t(a)], out, axis_stats[size_t(a)], pinned[size_t(a)]);
    axis_final(a, in, levels[size_t(a)], out, axis_stats[size_t(a)]);
    levels[size_t(a)] = AxisLevels{};  // its systems are no longer needed
  };
  const bool by_volume = p.lattice_spacing == LatticeSpacing::input_volume;
  if (by_volume) {  // the spacing needs the three axes' Poisson steps first
    oneapi::tbb::parallel_for(0, 3, poisson);
  } else {
    in.lattice = h;  // known before the Poisson steps: the axes' phases overlap
    parallel_two_phase(3, poisson, levels_and_final);
  }
  st.poisson_volume_ratio = signed_volume(poisson_U, input.T) / input_volume;
  if (by_volume) {
    in.lattice = h * std::cbrt(std::clamp(st.poisson_volume_ratio, kMinVolumeRatio, 1.0 / kMinVolumeRatio));
    oneapi::tbb::parallel_for(0, 3, levels_and_final);
  }
  st.lattice_spacing_ratio = in.lattice / h;
  out.edge_length = in.lattice;
  merge_axes(axis_stats, st);
  if (p.untangle_iterations > 0) {
    report(0.35, "untangling the map");
    untangle(input, seg, p, pinned, out.U, st);
  }
  report(0.97, "distortion");
  measure_distortion(input, out.U, p, st);
  st.volume_ratio = signed_volume(out.U, input.T) / input_volume;
  if (stats_out) *stats_out = st;
  return out;
}

}  // namespace polyhex
