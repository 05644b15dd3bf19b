#include "nodes/position_deform/position_deform.h"

#include "nodes/algorithms/reference_length.h"
#include "nodes/polycube_segment/chart_order.h"

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

#include "runtime/cancel.h"
#include "runtime/errors.h"
#include "runtime/factorization.h"

namespace polyhex {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

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

PolyCubeMap position_deform(std::shared_ptr<const TetMesh> input_ptr, const TetMesh& deformed,
                            std::shared_ptr<const PolyCubeSegmentation> seg_ptr, const PositionDeformParams& p,
                            PositionDeformStats* stats_out, const ProgressFn& progress) {
  // The phases' shares of the bar: their times on the built-in shapes (the solves ~1/3, the untangling ~2/3).
  auto report = [&](double fraction, const char* what) {
    if (progress) progress(fraction, what);
  };
  const TetMesh& input = *input_ptr;
  const PolyCubeSegmentation& seg = *seg_ptr;
  const int nV = int(input.V.rows());
  if (deformed.V.rows() != nV || deformed.T.rows() != input.T.rows())
    throw InvalidInput(input.source + ": the deformed mesh has " + std::to_string(deformed.V.rows()) +
                       " vertices, the input " + std::to_string(nV) + ": they must share connectivity");
  if (p.final_solve != "mvc_laplace" && p.final_solve != "poisson")
    throw ConfigError("final_solve = \"" + p.final_solve + "\" is not one of: mvc_laplace, poisson");
  if (p.level_placement != "balanced" && p.level_placement != "push_up")
    throw ConfigError("level_placement = \"" + p.level_placement + "\" is not one of: balanced, push_up");
  if (p.map_polish != "region" && p.map_polish != "everywhere")
    throw ConfigError("map_polish = \"" + p.map_polish + "\" is not one of: region, everywhere");
  const int nC = int(seg.charts.size());
  if (seg.chart.size() != seg.F.rows()) throw InvalidInput(input.source + ": segmentation has no chart per triangle");
  for (Eigen::Index f = 0; f < seg.F.rows(); ++f) {
    if (seg.chart[f] < 0 || seg.chart[f] >= nC) throw InvalidInput(input.source + ": triangle " + std::to_string(f) + " has chart id out of range");
    for (int k = 0; k < 3; ++k)
      if (seg.F(f, k) < 0 || seg.F(f, k) >= nV) throw InvalidInput(input.source + ": segmentation triangle index out of range");
  }
  PositionDeformStats st;
  st.charts = nC;
  const RowMatrixX3d& Vd = deformed.V;
  const double diag = reference_length(input.V);
  const double h = p.edge_length * diag;
  const double min_d = 2.0 * h, sigma = 3.0 * min_d;
  {
    // Refuse a hex edge length the machine cannot afford before any work: the lattice gives about
    // volume / h³ hexes.
    double volume = 0;
    for (Eigen::Index t = 0; t < input.T.rows(); ++t) {
      const Eigen::Vector3d a = input.V.row(input.T(t, 0)), b = input.V.row(input.T(t, 1)),
                            c = input.V.row(input.T(t, 2)), d = input.V.row(input.T(t, 3));
      volume += std::abs((b - a).cross(c - a).dot(d - a)) / 6.0;
    }
    const double estimate = volume / (h * h * h);
    if (estimate > p.max_hexes) {
      char msg[320];
      std::snprintf(msg, sizeof msg,
                    ": refused: edge_length %g would give about %.3g hexes (volume / h^3), more than max_hexes = %.3g; "
                    "use edge_length >= %.3g or raise max_hexes",
                    p.edge_length, estimate, p.max_hexes, p.edge_length * std::cbrt(estimate / p.max_hexes));
      throw InvalidInput(input.source + msg);
    }
  }

  const TetEdgeGraph graph(input.T, nV);
  const auto& edges = graph.edges;

  // Charts of every vertex (boundary vertices only have any).
  std::vector<std::vector<int>> vcharts(nV);
  for (Eigen::Index f = 0; f < seg.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      auto& v = vcharts[seg.F(f, k)];
      int c = seg.chart[f];
      if (std::find(v.begin(), v.end(), c) == v.end()) v.push_back(c);
    }
  std::vector<int> chart_label(nC);
  std::vector<std::vector<int>> chart_neighbours(nC);
  for (int c = 0; c < nC; ++c) chart_label[c] = seg.charts[c].label, chart_neighbours[c] = seg.charts[c].neighbours;
  std::vector<int> chart_vertices(nC, 0);
  for (int v = 0; v < nV; ++v)
    for (int c : vcharts[v]) ++chart_vertices[c];

  PolyCubeMap out;
  out.input = input_ptr;
  out.segmentation = seg_ptr;
  out.edge_length = h;
  out.U.resize(nV, 3);
  out.chart_plane = Eigen::VectorXi::Zero(nC);

  // Surface MVC weights (2D, per incident triangle: tan(angle/2) / length), on the deformed surface.
  std::vector<std::map<int, double>> surf_w;
  if (p.final_solve == "mvc_laplace") {
    surf_w.resize(nV);
    for (Eigen::Index f = 0; f < seg.F.rows(); ++f)
      for (int k = 0; k < 3; ++k) {
        int i = seg.F(f, k), j = seg.F(f, (k + 1) % 3), l = seg.F(f, (k + 2) % 3);
        Eigen::Vector3d a = Vd.row(j) - Vd.row(i), b = Vd.row(l) - Vd.row(i);
        double la = a.norm(), lb = b.norm();
        if (la < 1e-300 || lb < 1e-300) continue;
        double ang = std::acos(std::clamp(a.dot(b) / (la * lb), -1.0, 1.0));
        double t = std::tan(ang / 2.0);
        surf_w[i][j] += t / la;
        surf_w[i][l] += t / lb;
      }
  }
  std::vector<char> on_boundary(nV, 0);
  for (Eigen::Index f = 0; f < seg.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) on_boundary[seg.F(f, k)] = 1;

  // Volume MVC weights (3D) of interior vertices, on the deformed mesh: rows of (i, j, w).
  std::vector<std::vector<std::pair<int, double>>> vol_w;
  if (p.final_solve == "mvc_laplace") {
    std::vector<std::vector<int>> vt(nV);
    for (Eigen::Index t = 0; t < input.T.rows(); ++t)
      for (int k = 0; k < 4; ++k) vt[input.T(t, k)].push_back(int(t));
    vol_w.resize(nV);
    static const int opp[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    oneapi::tbb::parallel_for(0, nV, [&](int i) {
      if (on_boundary[i]) return;
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
      vol_w[i].assign(w.begin(), w.end());
    });
  }

  // The three axes are independent (their own charts, Voronoi partition, Poisson and final systems):
  // solved in parallel (paper design: parallel per-component coordinate solves), each into its own
  // statistics, merged below in axis order.
  std::array<PositionDeformStats, 3> axis_stats{};
  auto solve_axis = [&](int a) {
    PositionDeformStats& st = axis_stats[size_t(a)];
    throw_if_interrupted();  // safe point: per axis
    // The order evidence of the a-charts (chart_order.h): groups of same-axis charts sharing a vertex
    // (one plane each), the Voronoi distance samples and the ordered pairs.
    std::vector<int> axis_charts;
    for (int c = 0; c < nC; ++c)
      if (label_axis(seg.charts[c].label) == a) axis_charts.push_back(c);
    if (axis_charts.empty())
      throw InvalidInput(input.source + ": the PolyCube structure has no chart on axis " + std::string(1, char('X' + a)));
    AxisChartOrder order = chart_order_evidence(Vd, graph, vcharts, chart_label, chart_neighbours, a, h);
    st.merged_same_axis_charts += order.merged_same_axis_charts;
    const int nG = order.groups;
    const std::vector<int>& chart_group = order.chart_group;
    const std::vector<int>& vgroup = order.vertex_group;
    const std::vector<int>& group_size = order.group_size;
    const std::vector<double>& group_mean = order.group_mean;
    const std::vector<OrderedPair>& ordered = order.ordered;
    struct DistancePair {
      int p, q;
      double delta, w;
    };
    std::vector<DistancePair> dpairs;
    for (auto& s : order.distance_samples) {
      double excess = std::max(std::abs(s.delta) - min_d, 0.0);
      double w = p.distance_weight * std::min(group_size[s.p], group_size[s.q]) * std::exp(-excess * excess / (sigma * sigma));
      if (w > 0) dpairs.push_back({s.p, s.q, s.delta, w});
    }
    st.distance_pairs += int(dpairs.size());
    st.ordered_pairs += int(ordered.size());

    // Poisson step: unknowns = free vertices, then groups.
    auto t0 = Clock::now();
    std::vector<int> var(nV);
    int nFree = 0;
    for (int v = 0; v < nV; ++v) var[v] = vgroup[v] < 0 ? nFree++ : -1;
    for (int v = 0; v < nV; ++v)
      if (vgroup[v] >= 0) var[v] = nFree + vgroup[v];
    const int n = nFree + nG;
    std::vector<Eigen::Triplet<double>> trip;
    trip.reserve(edges.size() * 3 + dpairs.size() * 3 + n);
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n);
    auto add_term = [&](int x, int y, double w, double target) {  // w ((y_y - y_x) - target)^2
      trip.emplace_back(x, x, w);
      trip.emplace_back(y, y, w);
      trip.emplace_back(std::max(x, y), std::min(x, y), -w);
      rhs[x] -= w * target;
      rhs[y] += w * target;
    };
    for (auto& [i, j] : edges)
      if (var[i] != var[j]) add_term(var[i], var[j], 1.0, Vd(j, a) - Vd(i, a));
    for (auto& d : dpairs) add_term(nFree + d.p, nFree + d.q, d.w, d.delta);
    // Tiny pull towards the deformed coordinates removes the translation null space.
    const double eps = 1e-8;
    for (int v = 0; v < nV; ++v)
      if (vgroup[v] < 0) trip.emplace_back(var[v], var[v], eps), rhs[var[v]] += eps * Vd(v, a);
    for (int g = 0; g < nG; ++g) trip.emplace_back(nFree + g, nFree + g, eps * group_size[g]), rhs[nFree + g] += eps * group_size[g] * group_mean[g];
    Eigen::SparseMatrix<double> A(n, n);
    A.setFromTriplets(trip.begin(), trip.end());
    throw_if_interrupted();
    CholmodFactorization chol(A);
    Eigen::VectorXd y = chol.solve(rhs);
    st.seconds_poisson += since(t0);

    // Rounding to the lattice, keeping ordered pairs apart (§5.2).
    std::vector<double> c(nG);
    std::vector<long> k(nG);
    for (int g = 0; g < nG; ++g) c[g] = y[nFree + g], k[g] = std::lround(c[g] / h);
    for (auto& o : ordered)
      if (o.sign * (c[o.q] - c[o.p]) <= 0) ++st.flipped_chart_orders;
    // The ordered pairs as a graph "lower -> upper". Pairs are taken by decreasing evidence and one that
    // would close a cycle (contradicting stronger evidence) is dropped; then the levels: the balanced
    // placement (chart_order.h), or every chart pushed up to at least one h above each chart below it, in
    // topological order (longest path from the rounded values). The per-pair nudging before both could
    // undo itself on conflicting pairs and leave orders swapped.
    {
      const OrderAcceptance acc = accept_orders(ordered, nG);
      st.order_constraints_dropped += int(acc.dropped.size());
      if (p.level_placement == "balanced") {
        std::vector<double> target(nG), weight(nG);
        for (int g = 0; g < nG; ++g) target[g] = c[g] / h, weight[g] = double(group_size[g]);
        k = place_levels(acc, target, weight);
      } else {
        push_levels(acc, k);
      }
    }
    for (auto& o : ordered)
      if (o.sign * (k[o.q] - k[o.p]) < 1) ++st.flipped_after_rounding;
    for (int g = 0; g < nG; ++g)
      st.chart_coordinates_rounded_max_shift = std::max(st.chart_coordinates_rounded_max_shift, std::abs(c[g] - k[g] * h) / h);
    for (int ch : axis_charts) out.chart_plane[ch] = int(k[chart_group[ch]]);

    // Final solve with the chart planes pinned.
    throw_if_interrupted();
    t0 = Clock::now();
    Eigen::VectorXd u(nV);
    for (int v = 0; v < nV; ++v)
      if (vgroup[v] >= 0) u[v] = k[vgroup[v]] * h;
    if (nFree > 0) {
      if (p.final_solve == "poisson") {
        // The same energy restricted to the free unknowns: the upper-left block of A, with the pinned
        // groups moved to the right-hand side.
        std::vector<Eigen::Triplet<double>> tf;
        Eigen::VectorXd b = rhs.head(nFree);
        for (int col = 0; col < A.outerSize(); ++col)
          for (Eigen::SparseMatrix<double>::InnerIterator it(A, col); it; ++it) {
            int r = int(it.row()), cc = int(it.col());
            if (r < nFree && cc < nFree) tf.emplace_back(r, cc, it.value());
            else if (r >= nFree && cc < nFree) b[cc] -= it.value() * k[r - nFree] * h;
            else if (cc >= nFree && r < nFree) b[r] -= it.value() * k[cc - nFree] * h;
          }
        Eigen::SparseMatrix<double> Af(nFree, nFree);
        Af.setFromTriplets(tf.begin(), tf.end());
        CholmodFactorization cf(Af);
        Eigen::VectorXd yf = cf.solve(b);
        for (int v = 0; v < nV; ++v)
          if (vgroup[v] < 0) u[v] = yf[var[v]];
      } else {
        std::vector<Eigen::Triplet<double>> tf;
        Eigen::VectorXd b = Eigen::VectorXd::Zero(nFree);
        for (int v = 0; v < nV; ++v) {
          if (vgroup[v] >= 0) continue;
          int r = var[v];
          double sum = 0;
          auto add = [&](int j, double w) {
            sum += w;
            if (vgroup[j] >= 0) b[r] += w * u[j];
            else tf.emplace_back(r, var[j], -w);
          };
          if (on_boundary[v])
            for (auto& [j, w] : surf_w[v]) add(j, w);
          else
            for (auto& [j, w] : vol_w[v]) add(j, w);
          if (std::abs(sum) < 1e-300)
            throw SolverError(input.source + ": vertex " + std::to_string(v) + " has zero mean value weights");
          tf.emplace_back(r, r, sum);
        }
        Eigen::SparseMatrix<double> Af(nFree, nFree);
        Af.setFromTriplets(tf.begin(), tf.end());
        Af.makeCompressed();
        // Non-symmetric (mean value weights are not symmetric): BiCGSTAB started from the Poisson step's
        // solution, which is already close. With `final_jacobi_iterations` > 0, first with the diagonal
        // preconditioner: no set-up cost. On the 200k benchmark it converges in 140-230 iterations, 0.2 s per
        // axis, where the incomplete LU (drop tolerance 1e-4, fill 10) spent 1.0-1.2 s on its factorization
        // alone for 8-10 iterations; over the 28 shared models the final solves take 35 s instead of 85 s (the
        // hand's and fertility's axes need 800-950 iterations, 1.6x the incomplete LU's time). A system they
        // do not solve gets the incomplete LU, from where they stopped. Not the default: both solve to a
        // relative residual of 1e-12, yet the map's untangling (600 L-BFGS iterations, stopped before it
        // converges) carries the last-bit differences into visibly different maps and meshes: over the 28
        // shared models, inverted hexes on 5 models (dragon -0.354 on an interior hex, carter and casting
        // -1e-4) against 2 with the incomplete LU. The downstream sensitivity is the problem to fix.
        Eigen::SparseMatrix<double, Eigen::RowMajor> Ar = Af;
        Eigen::VectorXd yf(nFree);
        for (int v = 0; v < nV; ++v)
          if (vgroup[v] < 0) yf[var[v]] = y[var[v]];
        constexpr double tol = 1e-12;
        bool done = false;
        if (p.final_jacobi_iterations > 0) {
          Eigen::BiCGSTAB<Eigen::SparseMatrix<double, Eigen::RowMajor>> jacobi;
          jacobi.setTolerance(tol);
          jacobi.setMaxIterations(p.final_jacobi_iterations);
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
          Eigen::BiCGSTAB<Eigen::SparseMatrix<double, Eigen::RowMajor>, Eigen::IncompleteLUT<double>> solver;
          solver.preconditioner().setDroptol(1e-4);
          solver.preconditioner().setFillfactor(10);
          solver.setTolerance(tol);
          solver.setMaxIterations(2000);
          solver.compute(Ar);
          if (solver.info() != Eigen::Success)
            throw SolverError(input.source + ": mean value Laplace system (axis " + std::string(1, char('X' + a)) +
                              ") could not be preconditioned");
          yf = solver.solveWithGuess(b, Eigen::VectorXd(yf));  // from where the diagonal one stopped
          st.final_iterations += int(solver.iterations());
          if (!yf.allFinite() || solver.error() > 1e-8)
            throw SolverError(input.source + ": mean value Laplace solve did not converge on axis " +
                              std::string(1, char('X' + a)) + " (relative residual " + std::to_string(solver.error()) + ")");
        }
        for (int v = 0; v < nV; ++v)
          if (vgroup[v] < 0) u[v] = yf[var[v]];
      }
    }
    out.U.col(a) = u;
    st.seconds_final += since(t0);
    // Planarity: exact by substitution; measured anyway.
    for (int v = 0; v < nV; ++v)
      if (vgroup[v] >= 0) st.planarity_error = std::max(st.planarity_error, std::abs(out.U(v, a) - k[vgroup[v]] * h) / diag);
  };
  report(0, "chart planes, Poisson and final solves");
  oneapi::tbb::parallel_for(0, 3, solve_axis);
  for (const PositionDeformStats& s : axis_stats) {
    st.merged_same_axis_charts += s.merged_same_axis_charts;
    st.distance_pairs += s.distance_pairs;
    st.ordered_pairs += s.ordered_pairs;
    st.flipped_chart_orders += s.flipped_chart_orders;
    st.order_constraints_dropped += s.order_constraints_dropped;
    st.flipped_after_rounding += s.flipped_after_rounding;
    st.final_iterations += s.final_iterations;
    st.final_ilu_axes += s.final_ilu_axes;
    st.chart_coordinates_rounded_max_shift = std::max(st.chart_coordinates_rounded_max_shift, s.chart_coordinates_rounded_max_shift);
    st.planarity_error = std::max(st.planarity_error, s.planarity_error);
    st.seconds_poisson += s.seconds_poisson;
    st.seconds_final += s.seconds_final;
  }

  // Untangling (untangle_map.h): a vertex keeps the coordinates of the chart planes it lies on.
  if (p.untangle_iterations > 0) {
    report(0.35, "untangling the map");
    std::vector<std::uint8_t> fixed_axes(size_t(nV), 0);
    for (Eigen::Index f = 0; f < seg.F.rows(); ++f) {
      const int a = label_axis(seg.charts[size_t(seg.chart[f])].label);
      for (int k = 0; k < 3; ++k) fixed_axes[size_t(seg.F(f, k))] |= std::uint8_t(1 << a);
    }
    MapUntangleParams up;
    up.max_iterations = p.untangle_iterations;
    up.rings = p.untangle_rings;
    up.seconds = p.untangle_seconds;
    up.polish_everywhere = p.map_polish == "everywhere";
    untangle_polycube_map(input.V, input.T, out.U, fixed_axes, up, &st.untangle);
  }

  report(0.97, "distortion");
  // Inverted tets and distortion of input -> PolyCube. A few near-degenerate tets have distortions of
  // 1e10 and more, so the mean says nothing: report the median, the 99th percentile and the max.
  std::vector<double> dist(size_t(input.T.rows()), -1.0);
  oneapi::tbb::parallel_for(Eigen::Index(0), input.T.rows(), [&](Eigen::Index t) {
    Eigen::Vector3d q[4], Q[4];
    for (int k = 0; k < 4; ++k) q[k] = input.V.row(input.T(t, k)), Q[k] = out.U.row(input.T(t, k));
    if ((Q[1] - Q[0]).cross(Q[2] - Q[0]).dot(Q[3] - Q[0]) > 0)
      dist[size_t(t)] = conformal_distortion(q[0], q[1], q[2], q[3], Q[0], Q[1], Q[2], Q[3]);
  });
  std::vector<double> ok;
  ok.reserve(dist.size());
  for (double d : dist)
    if (d < 0) ++st.inverted_tets;
    else if (std::isfinite(d)) ok.push_back(d);
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
  if (stats_out) *stats_out = st;
  return out;
}

}  // namespace polyhex
