// Global untangling by L-BFGS on the regularised Winslow energy. See untangle_global.h.
#include "nodes/optimize/untangle_global.h"

#include "nodes/algorithms/hex_corners.h"
#include "nodes/algorithms/hex_quality.h"
#include "nodes/artefacts/cell_rings.h"
#include "nodes/artefacts/hex_topology.h"
#include "nodes/optimize/hex_terms.h"
#include "runtime/cancel.h"
#include "runtime/lbfgs.h"
#include "runtime/stopwatch.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <vector>

namespace polyhex {
namespace {

using Vec3 = Eigen::Vector3d;
using Mat83 = Eigen::Matrix<double, 8, 3>;
using VecX = Eigen::VectorXd;

using optimize_detail::for_lanes;
using optimize_detail::kLanes;
using optimize_detail::lane;
using optimize_detail::Lanes;

/// A hex's corners P[corner][coordinate] from an 8 x 3 matrix.
void corners_of(const Mat83& P, double (&out)[8][3]) {
  for (int k = 0; k < 8; ++k)
    for (int i = 0; i < 3; ++i) out[k][i] = P(k, i);
}

/// An 8 x 3 matrix from G[corner][coordinate].
void matrix_of(const double (&G)[8][3], Mat83& out) {
  for (int k = 0; k < 8; ++k)
    for (int i = 0; i < 3; ++i) out(k, i) = G[k][i];
}

/// Energy of the hex with corners P (8 by 3, already over the scale) and its gradient G with respect to P
/// (optimize_detail::hex_energy_of).
double hex_energy(const Mat83& P, double eps, Mat83* G) {
  double p[8][3], g[8][3];
  corners_of(P, p);
  const double e = optimize_detail::hex_energy_of(p, eps, G ? g : nullptr);
  if (G) matrix_of(g, *G);
  return e;
}

/// Soft-minimum scaled Jacobian of the hex with corners P (8 by 3) over its 9 Jacobians and, if G, its
/// gradient with respect to P (optimize_detail::hex_soft_sj_of).
double hex_soft_sj(const Mat83& P, Mat83* G) {
  double p[8][3], g[8][3];
  corners_of(P, p);
  const double s = optimize_detail::hex_soft_sj_of(p, G ? g : nullptr);
  if (G) matrix_of(g, *G);
  return s;
}

/// The free vertices near the inverted hexes and the data of one global descent.
class GlobalUntangler {
 public:
  GlobalUntangler(RowMatrixX3d& V, const RowMatrixX8i& H, const std::vector<char>& on_surface,
                  const std::vector<char>& fixed, const TriangleTree& tree, const std::vector<Vec3>& normals,
                  const GlobalUntangleParams& p, GlobalUntangleStats& st)
      : V_(V),
        H_(H),
        on_surface_(on_surface),
        fixed_(fixed),
        tree_(tree),
        normals_(normals),
        p_(p),
        st_(st),
        t0_(std::chrono::steady_clock::now()) {}

  /// Average scaled Jacobian ascent around the seed hexes (see raise_average()); returns false (nothing
  /// moved) when the region is empty, has an inverted hex or the work cap allows no iteration.
  bool run_average(const std::vector<char>& seeds, const AverageAscentParams& a) {
    select(seeds, V_.rows(), H_.rows());
    if (free_.empty() || count_inverted() > 0) return false;
    const int iterations = int(std::min(double(p_.polish_iterations), a.work / double(active_.size())));
    if (iterations < 1) return false;
    average_ = true;
    quality_barrier_ = a.barrier;
    // the floor: the lowest soft scaled Jacobian of the region now; a hex going below it pays a steep
    // quadratic penalty, so that the ascent does not trade the worst hexes for the average. The soft
    // minimum lies up to log(9) / β under the true one, so the worst hexes may still lose a little: the
    // caller repairs that (max-min sweeps) or undoes the ascent. (A floor on each of the 9 Jacobians at the
    // true minimum holds the minimum exactly but leaves the region stiff: bunny's average rose 0.902 ->
    // 0.915 instead of 0.927, femur's 0.851 -> 0.898 instead of 0.907.)
    floor_ = lowest_soft_sj();
    set_base();
    VecX x = VecX::Zero(ndof_);
    lbfgs(x, 1e-10, false, iterations, a.tolerance);
    apply(x);
    project();
    return true;
  }

  /// Minimum scaled Jacobian ascent around the seed hexes (see raise_minimum()); returns false (nothing
  /// moved) when the region is empty or has an inverted hex.
  bool run_minimum(const std::vector<char>& seeds, const MinimumAscentParams& a, const std::vector<Vec3>& along) {
    along_ = &along;
    select(seeds, V_.rows(), H_.rows());
    if (free_.empty() || count_inverted() > 0) return false;
    minimum_ = true;
    quality_barrier_ = a.barrier;
    sharpness_ = a.sharpness;
    floor_ = lowest_soft_sj();  // the reference of the exponentials
    set_base();
    VecX x = VecX::Zero(ndof_);
    lbfgs(x, 1e-10, false, p_.polish_iterations);
    apply(x);
    project();
    return true;
  }

  /// The lowest soft scaled Jacobian of the active hexes.
  double lowest_soft_sj() const {
    double m = std::numeric_limits<double>::infinity();
    for (int h : active_) {
      Mat83 P;
      for (int k = 0; k < 8; ++k) P.row(k) = V_.row(H_(h, k));
      m = std::min(m, hex_soft_sj(P, nullptr));
    }
    return m;
  }

  /// Smoothing of an untangled region: L-BFGS at ε -> 0 around the seed hexes (see smooth_region()).
  void run_smooth(const std::vector<char>& seeds) {
    select(seeds, V_.rows(), H_.rows());
    if (free_.empty() || count_inverted() > 0) return;
    polish();
  }

  long run() {
    const Eigen::Index nv = V_.rows(), nh = H_.rows();
    std::vector<char> inv(size_t(nh), 0);
    tbb::parallel_for(Eigen::Index(0), nh, [&](Eigen::Index h) { inv[size_t(h)] = inverted(h); });
    st_.inverted_before = std::count(inv.begin(), inv.end(), 1);
    st_.inverted_after = st_.inverted_before;
    if (st_.inverted_before == 0 || p_.outer_iterations == 0) return st_.inverted_after;
    select(inv, nv, nh);
    if (free_.empty()) return st_.inverted_after;

    double mindet = min_det();
    double eps = std::sqrt(1e-12 + 0.04 * std::min(mindet, 0.0) * std::min(mindet, 0.0));
    for (int it = 0; it < p_.outer_iterations && !out_of_time(); ++it) {
      throw_if_interrupted();
      ++st_.outer;
      set_base();
      VecX x = VecX::Zero(ndof_);
      const double e_prev = energy(x, eps, nullptr);
      const bool untangled = lbfgs(x, eps, true, p_.lbfgs_iterations);
      apply(x);
      project();
      st_.inverted_after = count_inverted();
      if (untangled || st_.inverted_after == 0) break;
      set_base();
      const double e = energy(VecX::Zero(ndof_), eps, nullptr);
      mindet = min_det();
      eps = optimize_detail::next_eps(eps, e, e_prev, mindet);
    }
    if (st_.inverted_after == 0) polish();
    return st_.inverted_after;
  }

 private:
  /// True if surface vertex v slides along a given direction (raise_minimum's `along`).
  bool on_line(int v) const {
    return along_ != nullptr && !along_->empty() && on_surface_[size_t(v)] && !(*along_)[size_t(v)].isZero();
  }

  bool out_of_time() {
    if (p_.seconds > 0 && seconds_since(t0_) > p_.seconds) st_.time_budget_hit = true;
    return st_.time_budget_hit;
  }

  /// L-BFGS at ε -> 0 from an untangled mesh; undone if the projection onto the surface inverts a hex.
  void polish() {
    if (p_.polish_iterations <= 0) return;
    set_base();
    const std::vector<Vec3> keep = base_;
    VecX x = VecX::Zero(ndof_);
    lbfgs(x, 1e-10, false, p_.polish_iterations);
    apply(x);
    project();
    if (count_inverted() == 0) return;
    for (size_t i = 0; i < free_.size(); ++i) V_.row(free_[i]) = keep[i].transpose();
  }

  std::array<Vec3, 8> points(Eigen::Index h) const {
    std::array<Vec3, 8> q;
    for (int k = 0; k < 8; ++k) q[size_t(k)] = V_.row(H_(h, k)).transpose();
    return q;
  }
  bool inverted(Eigen::Index h) const { return hex_scaled_jacobian(points(h)).corner_min <= 0; }

  long count_inverted() const {
    std::vector<char> inv(active_.size());
    tbb::parallel_for(size_t(0), active_.size(), [&](size_t a) { inv[a] = inverted(active_[a]); });
    return long(std::count(inv.begin(), inv.end(), 1));
  }

  /// Free vertices: those of the inverted hexes grown by p_.rings rings; active hexes: those with a free vertex.
  void select(const std::vector<char>& inv, Eigen::Index nv, Eigen::Index nh) {
    const std::vector<char> region =
        cell_ring_region(H_, nv, p_.rings, [&](Eigen::Index h) { return inv[size_t(h)] != 0; });
    dof_.assign(size_t(nv), -1);
    ndof_ = 0;
    for (Eigen::Index v = 0; v < nv; ++v)
      if (region[size_t(v)] && !fixed_[size_t(v)]) {
        dof_[size_t(v)] = int(ndof_);
        const int n = on_line(v) ? 1 : on_surface_[size_t(v)] ? 2 : 3;
        ndof_ += n;
        free_.push_back(int(v));
        unknowns_.push_back(std::uint8_t(n));
      }
    st_.free_vertices = long(free_.size());
    active_index_.assign(size_t(nh), -1);
    for (Eigen::Index h = 0; h < nh; ++h) {
      bool any = false;
      for (int k = 0; k < 8 && !any; ++k) any = dof_[size_t(H_(h, k))] >= 0;
      if (!any) continue;
      active_index_[size_t(h)] = int(active_.size());
      active_.push_back(int(h));
      // the hex's mean edge length: the unit of its Jacobians
      using hex_topology::kEdges;
      double s = 0;
      for (const auto& e : kEdges) s += (V_.row(H_(h, e[0])) - V_.row(H_(h, e[1]))).norm();
      scale_.push_back(s > 0 ? s / 12.0 : 1.0);
    }
    // incident active hexes of each free vertex (fixed order: by hex index)
    std::vector<int> slot(size_t(nv), -1);
    for (size_t i = 0; i < free_.size(); ++i) slot[size_t(free_[i])] = int(i);
    inc_ = cell_incidence(H_, active_, slot, free_.size());
    hex_energy_.assign(active_.size(), 0.0);
    hex_grad_.assign(active_.size(), Mat83::Zero());
  }

  /// Base positions and tangent frames of the free vertices (x = 0 is the current mesh).
  void set_base() {
    base_.resize(free_.size());
    frame_.resize(free_.size());
    for (size_t i = 0; i < free_.size(); ++i) {
      const int v = free_[i];
      base_[i] = V_.row(v).transpose();
      if (unknowns_[i] == 3) continue;
      if (unknowns_[i] == 1) {  // one unknown: the slide along the given direction
        frame_[i].col(0) = (*along_)[size_t(v)].normalized();
        frame_[i].col(1).setZero();
        continue;
      }
      const Vec3 n = normals_[size_t(tree_.closest(base_[i]).triangle)];
      const Vec3 t1 = (std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).cross(n).normalized();
      frame_[i].col(0) = t1;
      frame_[i].col(1) = n.cross(t1);
    }
  }

  void apply(const VecX& x) {
    for (size_t i = 0; i < free_.size(); ++i) {
      const int v = free_[i], d = dof_[size_t(v)];
      const Vec3 pos = unknowns_[i] == 1   ? Vec3(base_[i] + frame_[i].col(0) * x[d])
                       : unknowns_[i] == 2 ? Vec3(base_[i] + frame_[i] * x.segment<2>(d))
                                           : Vec3(base_[i] + x.segment<3>(d));
      V_.row(v) = pos.transpose();
    }
  }

  void project() {
    tbb::parallel_for(size_t(0), free_.size(), [&](size_t i) {
      const int v = free_[i];
      if (on_surface_[size_t(v)]) V_.row(v) = tree_.closest(V_.row(v).transpose()).point.transpose();
    });
  }

  /// Sum of the scaled Jacobians (Verdict, quality.h) of the active hexes at V_.
  double active_sj_sum() const {
    std::vector<double> v(active_.size());
    tbb::parallel_for(size_t(0), active_.size(), [&](size_t a) {
      std::array<Vec3, 8> p;
      for (int k = 0; k < 8; ++k) p[size_t(k)] = V_.row(H_(active_[a], k)).transpose();
      v[a] = hex_scaled_jacobian(p).sj;
    });
    double s = 0;
    for (double x : v) s += x;
    return s;
  }

  /// Minimum normalised determinant over the 9 Jacobians of the active hexes.
  double min_det() const {
    std::vector<double> m(active_.size(), std::numeric_limits<double>::infinity());
    tbb::parallel_for(size_t(0), active_.size(), [&](size_t a) {
      double P[8][3], J[3][3];
      for (int k = 0; k < 8; ++k)
        for (int i = 0; i < 3; ++i) P[k][i] = V_(H_(active_[a], k), i) / scale_[a];
      for (int t = 0; t < 9; ++t) {
        optimize_detail::hex_jacobian_of(P, t, J);
        m[a] = std::min(
            m[a], Eigen::Matrix3d{{J[0][0], J[0][1], J[0][2]}, {J[1][0], J[1][1], J[1][2]}, {J[2][0], J[2][1], J[2][2]}}
                      .determinant());
      }
    });
    return *std::min_element(m.begin(), m.end());
  }

  /// Energy at x (displacements of the free vertices) and, if g, its gradient.
  double energy(const VecX& x, double eps, VecX* g) {
    apply(x);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, active_.size(), 64), [&](const tbb::blocked_range<size_t>& r) {
      for_lanes(r.begin(), r.end(), [&](auto v, size_t a) { terms_of<decltype(v)>(a, eps, g != nullptr); });
    });
    double e = 0;
    for (double he : hex_energy_) e += he;
    if (g) {
      g->setZero(ndof_);
      tbb::parallel_for(size_t(0), free_.size(), [&](size_t i) {
        const Vec3 gv = inc_.gather(i, hex_grad_);
        const int v = free_[i], d = dof_[size_t(v)];
        if (unknowns_[i] == 1)
          (*g)[d] = frame_[i].col(0).dot(gv);
        else if (unknowns_[i] == 2)
          g->segment<2>(d) = frame_[i].transpose() * gv;
        else
          g->segment<3>(d) = gv;
      });
    }
    return e;
  }

  /// The energy terms of active hexes [a, a + W) into hex_energy_ and, if grad, their gradients into
  /// hex_grad_: W = kLanes hexes side by side for Lanes, one for double (the same bits either way).
  template <class V>
  void terms_of(size_t a, double eps, bool grad) {
    constexpr int W = std::is_same_v<V, double> ? 1 : kLanes;
    V P[8][3], G[8][3];
    for (int l = 0; l < W; ++l) {
      const Eigen::Index h = active_[a + size_t(l)];
      for (int k = 0; k < 8; ++k)
        for (int i = 0; i < 3; ++i) lane(P[k][i], l) = V_(H_(h, k), i) / scale_[a + size_t(l)];
    }
    V e;
    if (minimum_ || average_) {
      const V sj = optimize_detail::hex_soft_sj_of(P, grad ? G : nullptr);
      V f;             // d e / d sj
      if (minimum_) {  // raise_minimum: Σ exp(-k (soft SJ - floor))
        const V arg = -sharpness_ * (sj - floor_);
        if constexpr (std::is_same_v<V, double>)
          e = std::exp(arg);
        else
          for (int l = 0; l < kLanes; ++l) e[l] = std::exp(arg[l]);
        f = -sharpness_ * e;
      } else {  // raise_average: -soft SJ, the floor's penalty
        constexpr double kFloorPenalty = 1e3;
        const V gap = floor_ - sj;
        const V below = optimize_detail::lane_select(gap < 0.0, V{}, gap);  // std::max(gap, 0.0)
        e = -sj + kFloorPenalty * below * below;
        f = -(1.0 + 2.0 * kFloorPenalty * below);
      }
      if (grad)
        for (int k = 0; k < 8; ++k)
          for (int i = 0; i < 3; ++i) G[k][i] *= f;
      if (quality_barrier_ > 0) {  // the Winslow barrier
        V Gb[8][3];
        e += quality_barrier_ * optimize_detail::hex_energy_of(P, eps, grad ? Gb : nullptr);
        if (grad)
          for (int k = 0; k < 8; ++k)
            for (int i = 0; i < 3; ++i) G[k][i] += quality_barrier_ * Gb[k][i];
      }
    } else {
      e = optimize_detail::hex_energy_of(P, eps, grad ? G : nullptr);
    }
    for (int l = 0; l < W; ++l) {
      hex_energy_[a + size_t(l)] = lane(e, l);
      if (grad)
        for (int k = 0; k < 8; ++k)
          for (int i = 0; i < 3; ++i) hex_grad_[a + size_t(l)](k, i) = lane(G[k][i], l) / scale_[a + size_t(l)];
    }
  }

  /// True if the mesh at x, its surface vertices projected, has no inverted active hex (V_ is left at x).
  bool untangled_at(const VecX& x) {
    apply(x);
    project();
    const bool ok = count_inverted() == 0;
    apply(x);
    return ok;
  }

  /// L-BFGS (runtime/lbfgs.h) from x. Stops early, returning true, when the mesh (projected) is untangled
  /// (checked every 5 iterations): the later phases improve the quality. With `progress` >= 0 it also stops
  /// when 25 iterations gain less than `progress` per active hex: of the energy, or for raise_average of the
  /// active hexes' scaled Jacobians.
  bool lbfgs(VecX& x, double eps, bool stop_when_untangled, int iterations, double progress = -1) {
    constexpr int kProgressCheck = 25;
    double mean_scale = 0;
    for (double s : scale_) mean_scale += s;
    mean_scale /= double(scale_.size());
    LbfgsOptions o;
    o.iterations = iterations;
    o.gradient_tol = 1e-10 / mean_scale;
    o.first_move = 0.1 * mean_scale;
    auto measure = [&](const VecX& y) {
      if (!average_) return energy(y, eps, nullptr);
      apply(y);
      return -active_sj_sum();
    };
    double e_last = progress >= 0 ? measure(x) : 0.0;
    auto stop = [&](int done, const VecX& y, bool after_step) {
      if (!after_step) return out_of_time();
      if (progress >= 0 && done % kProgressCheck == 0) {
        const double e = measure(y);
        const bool slow = e_last - e < progress * double(active_.size());
        e_last = e;
        if (slow) return true;
      }
      return stop_when_untangled && done % 5 == 0 && untangled_at(y);
    };
    return lbfgs_minimize(
               x, [&](const VecX& y, VecX* g) { return energy(y, eps, g); }, o, stop, &st_.lbfgs_iterations) ==
               LbfgsEnd::Stopped &&
           !st_.time_budget_hit;
  }

  RowMatrixX3d& V_;
  const RowMatrixX8i& H_;
  const std::vector<char>& on_surface_;
  const std::vector<char>& fixed_;
  const TriangleTree& tree_;
  const std::vector<Vec3>& normals_;
  const GlobalUntangleParams& p_;
  GlobalUntangleStats& st_;
  std::chrono::steady_clock::time_point t0_;

  std::vector<int> dof_;  ///< #V first unknown of a free vertex, -1 otherwise
  Eigen::Index ndof_ = 0;
  std::vector<int> free_;               ///< free vertices
  std::vector<std::uint8_t> unknowns_;  ///< per free vertex: 1 (slides along its line), 2 (on the surface) or 3
  std::vector<int> active_;             ///< hexes with a free vertex
  std::vector<int> active_index_;
  std::vector<double> scale_;  ///< per active hex: initial mean edge length
  CellIncidence inc_;          ///< per free vertex: (active hex, corner) pairs
  std::vector<Vec3> base_;
  std::vector<Eigen::Matrix<double, 3, 2>> frame_;
  std::vector<double> hex_energy_;
  std::vector<Mat83> hex_grad_;
  const std::vector<Vec3>* along_ = nullptr;  ///< raise_minimum: per vertex, a direction to slide along (or zero)
  bool average_ = false;                      ///< the energy is raise_average's
  bool minimum_ = false;                      ///< the energy is raise_minimum's
  double sharpness_ = 0;                      ///< raise_minimum: k of the exponentials
  double quality_barrier_ = 0;                ///< raise_average: the barrier's weight
  double floor_ = 0;                          ///< raise_average: soft scaled Jacobian under which a hex is penalised
};

}  // namespace

double hex_untangle_energy(const std::array<Eigen::Vector3d, 8>& p, double scale, double eps,
                           Eigen::Matrix<double, 8, 3>* grad) {
  Mat83 P;
  for (int k = 0; k < 8; ++k) P.row(k) = p[size_t(k)].transpose() / scale;
  const double e = hex_energy(P, eps, grad);
  if (grad) *grad /= scale;
  return e;
}

long untangle_global(RowMatrixX3d& V, const RowMatrixX8i& H, const std::vector<char>& on_surface,
                     const std::vector<char>& fixed, const TriangleTree& tree,
                     const std::vector<Eigen::Vector3d>& normals, const GlobalUntangleParams& p,
                     GlobalUntangleStats* stats) {
  GlobalUntangleStats st;
  GlobalUntangler u(V, H, on_surface, fixed, tree, normals, p, st);
  const long left = u.run();
  if (stats) *stats = st;
  return left;
}

bool raise_minimum(RowMatrixX3d& V, const RowMatrixX8i& H, const std::vector<char>& on_surface,
                   const std::vector<char>& fixed, const TriangleTree& tree,
                   const std::vector<Eigen::Vector3d>& normals, const std::vector<char>& seeds,
                   const MinimumAscentParams& a, const GlobalUntangleParams& p, GlobalUntangleStats* stats,
                   const std::vector<Eigen::Vector3d>& along) {
  GlobalUntangleStats st;
  GlobalUntangler u(V, H, on_surface, fixed, tree, normals, p, st);
  const bool ran = u.run_minimum(seeds, a, along);
  if (stats) *stats = st;
  return ran;
}

bool raise_average(RowMatrixX3d& V, const RowMatrixX8i& H, const std::vector<char>& on_surface,
                   const std::vector<char>& fixed, const TriangleTree& tree,
                   const std::vector<Eigen::Vector3d>& normals, const std::vector<char>& seeds,
                   const AverageAscentParams& a, const GlobalUntangleParams& p, GlobalUntangleStats* stats) {
  GlobalUntangleStats st;
  GlobalUntangler u(V, H, on_surface, fixed, tree, normals, p, st);
  const bool ran = u.run_average(seeds, a);
  if (stats) *stats = st;
  return ran;
}

double hex_soft_scaled_jacobian(const std::array<Eigen::Vector3d, 8>& p, Eigen::Matrix<double, 8, 3>* grad) {
  Mat83 P;
  for (int k = 0; k < 8; ++k) P.row(k) = p[size_t(k)].transpose();
  return hex_soft_sj(P, grad);
}

void smooth_region(RowMatrixX3d& V, const RowMatrixX8i& H, const std::vector<char>& on_surface,
                   const std::vector<char>& fixed, const TriangleTree& tree,
                   const std::vector<Eigen::Vector3d>& normals, const std::vector<char>& seeds,
                   const GlobalUntangleParams& p, GlobalUntangleStats* stats) {
  GlobalUntangleStats st;
  GlobalUntangler u(V, H, on_surface, fixed, tree, normals, p, st);
  u.run_smooth(seeds);
  if (stats) *stats = st;
}

}  // namespace polyhex
