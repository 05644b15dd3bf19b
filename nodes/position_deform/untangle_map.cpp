// Untangling of the PolyCube map by L-BFGS on the regularised Winslow energy. See untangle_map.h.
#include "nodes/position_deform/untangle_map.h"

#include "nodes/algorithms/hex_corners.h"
#include "nodes/artefacts/cell_rings.h"
#include "runtime/errors.h"
#include "runtime/factorization.h"
#include "runtime/lbfgs.h"
#include "runtime/stopwatch.h"

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCore>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <memory>
#include <type_traits>

namespace polyhex {
namespace {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Mat43 = Eigen::Matrix<double, 4, 3>;
using VecX = Eigen::VectorXd;
using optimize_detail::for_lanes;
using optimize_detail::kLanes;
using optimize_detail::lane;
using optimize_detail::Lanes;
using optimize_detail::libm_cbrt;
using optimize_detail::tet_winslow_term;

/// Tets whose input volume is below this fraction of the mean do not set ε (see min_det()).
constexpr double kSliverWeight = 0.3;
/// Floor of a tet's weight (its input volume over the mean) in the energy.
constexpr double kMinWeight = 0.1;

class MapUntangler {
 public:
  MapUntangler(const RowMatrixX3d& X, const RowMatrixX4i& T, RowMatrixX3d& U, const std::vector<std::uint8_t>& fixed,
               const MapUntangleParams& p, MapUntangleStats& st)
      : X_(X), T_(T), U_(U), fixed_(fixed), p_(p), st_(st), t0_(std::chrono::steady_clock::now()) {}

  long run() {
    const Eigen::Index nt = T_.rows();
    std::vector<char> inv(size_t(nt), 0);
    // 0 = positive, 1 = inverted, 2 = flat and inverted, 3 = flat with a rounding-positive volume
    tbb::parallel_for(Eigen::Index(0), nt, [&](Eigen::Index t) {
      const bool neg = volume6(t) <= 0;
      inv[size_t(t)] = flat(t) ? (neg ? 2 : 3) : (neg ? 1 : 0);
    });
    st_.inverted_before = std::count(inv.begin(), inv.end(), 1) + std::count(inv.begin(), inv.end(), 2);
    st_.flat = std::count(inv.begin(), inv.end(), 2);
    st_.inverted_after = st_.inverted_before;
    if (st_.inverted_before == 0 || p_.rounds == 0 || p_.max_iterations <= 0) {
      if (p_.polish_everywhere) polish(inv);
      return st_.inverted_after;
    }
    select(inv);
    if (free_.empty()) {
      if (p_.polish_everywhere) polish(inv);
      return st_.inverted_after;
    }
    first_region_.assign(size_t(U_.rows()), 0);
    for (int v : free_) first_region_[size_t(v)] = 1;

    st_.inverted_after = count_inverted() + st_.flat;  // as the rounds count (tets with a free vertex)
    double mindet = min_det();
    double eps = std::sqrt(1e-12 + 0.04 * std::min(mindet, 0.0) * std::min(mindet, 0.0));
    bool untangled = false;
    for (int r = 0; r < p_.rounds && st_.lbfgs_iterations < p_.max_iterations && !out_of_time(); ++r) {
      ++st_.rounds;
      set_base();
      VecX x = VecX::Zero(ndof_);
      const double e_prev = energy(x, eps, nullptr);
      auto stop = [&](int done, const VecX& y, bool after_step) {
        if (!after_step) return out_of_time();
        if (done % 5 != 0) return false;
        apply(y);
        return count_inverted() == 0;
      };
      const int iterations = int(std::min<long>(p_.lbfgs_iterations, p_.max_iterations - st_.lbfgs_iterations));
      untangled = lbfgs_minimize(
                      x, [&](const VecX& y, VecX* g, double up_to) { return energy(y, eps, g, up_to); },
                      options(iterations), stop, &st_.lbfgs_iterations) == LbfgsEnd::Stopped &&
                  !st_.time_budget_hit;
      apply(x);
      const long before_round = st_.inverted_after;
      st_.inverted_after = count_inverted() + st_.flat;
      if (untangled || st_.inverted_after == st_.flat) break;
      // a round that turns no tet round will not be followed by one that does: what is left is stuck (its
      // vertices pinned by the chart planes) or a sliver the schedule ignores, and ε is at its floor. A round
      // that left more inverted than it found is undone (femur: 15,920 -> 16,612 kept before).
      if (st_.inverted_after > before_round) {
        apply(VecX::Zero(ndof_));
        st_.inverted_after = before_round;
      }
      if (st_.inverted_after >= before_round) break;
      set_base();
      const double e = energy(VecX::Zero(ndof_), eps, nullptr);
      mindet = min_det();
      eps = optimize_detail::next_eps(eps, e, e_prev, mindet);
      if (p_.shrink) {  // the next round works around the tets still inverted (ε from this round's region)
        std::vector<char> now(inv);
        tbb::parallel_for(Eigen::Index(0), nt, [&](Eigen::Index t) {
          if (now[size_t(t)] < 2) now[size_t(t)] = volume6(t) <= 0 ? 1 : 0;
        });
        select(now);
        if (free_.empty()) break;  // what is left has no vertex that may move
      }
    }
    polish(inv);
    return st_.inverted_after;
  }

 private:
  /// L-BFGS at ε -> 0 on the untangled region, or with polish_everywhere on every vertex that may move.
  void polish(const std::vector<char>& inv) {
    if (p_.polish_iterations > 0 && !out_of_time()) {
      // At ε -> 0 the energy is a barrier: no tet inverts; kept only if that holds numerically. The
      // untangling leaves the tets it turned round barely positive; the polish spreads that. Tets still
      // inverted keep their vertices where they are and leave the energy (the barrier would be infinite).
      // Tets within a millionth of the mean volume of turning over are frozen too: the barrier's gradient
      // there is so steep that no step the line search tries keeps them positive (femur: the polish ended
      // after 1 iteration, leaving tets of distortion 1e15).
      const double cut = 1e-6 * mean_volume6(inv);
      if (p_.polish_everywhere) {
        std::vector<char> region(size_t(U_.rows()), 1), skip(size_t(T_.rows()), 0);
        for (Eigen::Index t = 0; t < T_.rows(); ++t)
          if (inv[size_t(t)] >= 2) {
            skip[size_t(t)] = 1;
          } else if (volume6(t) <= cut) {
            skip[size_t(t)] = 1;
            for (int k = 0; k < 4; ++k) region[size_t(T_(t, k))] = 0;
          }
        build(region, skip);
        if (free_.empty()) return;
      } else if (st_.inverted_after > st_.flat) {
        std::vector<char> region = first_region_, skip(size_t(T_.rows()), 0);
        if (p_.shrink) build(region, skip);  // the active tets of the first round's region
        for (int t : active_)
          if (volume6(t) <= cut) {
            skip[size_t(t)] = 1;
            for (int k = 0; k < 4; ++k) region[size_t(T_(t, k))] = 0;
          }
        for (Eigen::Index t = 0; t < T_.rows(); ++t)
          if (inv[size_t(t)] >= 2) skip[size_t(t)] = 1;
        build(region, skip);
      }
      set_base();
      // The regularised barrier is finite (about |J|² / ε^{2/3} at det 0), so a tet shrinking as a whole can
      // still turn over: the state is checked every 5 iterations and the polish ends at the last valid one.
      VecX x = VecX::Zero(ndof_), good = x;
      st_.polish_energy_before += energy(x, 1e-10, nullptr);
      auto stop = [&](int done, const VecX& y, bool after_step) {
        if (!after_step) return out_of_time();
        if (done % 5 != 0) return false;
        apply(y);
        if (count_inverted() > 0) return true;
        good = y;
        return false;
      };
      if (lbfgs_minimize(
              x, [&](const VecX& y, VecX* g, double accept_up_to) { return energy(y, 1e-10, g, accept_up_to); },
              polish_options(), stop, &st_.polish_iterations) != LbfgsEnd::Stopped) {
        apply(x);
        if (count_inverted() == 0) good = x;
      }
      st_.polish_energy_after += energy(good, 1e-10, nullptr);  // leaves the map at `good`
    }
  }

  /// The polish's options; with a polish_preconditioner, the stiffness is factored here.
  LbfgsOptions polish_options() {
    LbfgsOptions o = options(p_.polish_iterations);
    if (p_.polish_preconditioner == PolishPreconditioner::none || ndof_ == 0) return o;
    const auto t0 = std::chrono::steady_clock::now();
    if (p_.polish_preconditioner == PolishPreconditioner::cholesky) {
      auto factor = std::make_shared<CholmodFactorization>(stiffness());
      o.precondition = [factor](VecX& d) { d = factor->solve(d); };
    } else {
      using Incomplete = Eigen::IncompleteCholesky<double, Eigen::Lower, Eigen::AMDOrdering<int>>;
      auto factor = std::make_shared<Incomplete>(stiffness());
      if (factor->info() != Eigen::Success) throw SolverError("map polish: the stiffness's incomplete Cholesky failed");
      o.precondition = [factor](VecX& d) { d = factor->solve(d); };
    }
    st_.polish_factor_seconds += seconds_since(t0);
    return o;
  }

  /// The energy's stiffness at the current map: per axis, Σ over the active tets of v_t 2 ∇φ_i·∇φ_j /
  /// (3 det J^{2/3}) between the unknowns of that axis (∇φ the hat functions' gradients on the input tet):
  /// the Hessian of the |J|² part at fixed determinants, a weighted Laplacian; the fixed axes of a vertex
  /// are its Dirichlet conditions.
  Eigen::SparseMatrix<double> stiffness() const {
    std::vector<Eigen::Triplet<double>> trip;
    trip.reserve(active_.size() * 30);
    auto unknown = [&](int v, int axis) {
      const int d = dof_[size_t(v)];
      if (d < 0) return -1;
      const auto& ax = axes_[size_t(slot_[size_t(v)])];
      for (int j = 0; j < 3 && ax[size_t(j)] >= 0; ++j)
        if (ax[size_t(j)] == axis) return d + j;
      return -1;
    };
    for (size_t a = 0; a < active_.size(); ++a) {
      const double det = jacobian(a).determinant();
      if (!(det > 0)) continue;
      const double c = weight_[a] * 2.0 / (3.0 * libm_cbrt(det * det));
      const Mat3& R = rinv_[a];
      std::array<Vec3, 4> grad;
      grad[0] = -R.colwise().sum().transpose();
      for (int k = 1; k < 4; ++k) grad[size_t(k)] = R.row(k - 1).transpose();
      for (int axis = 0; axis < 3; ++axis)
        for (int k = 0; k < 4; ++k) {
          const int i = unknown(T_(active_[a], k), axis);
          if (i < 0) continue;
          for (int l = 0; l < 4; ++l) {
            const int j = unknown(T_(active_[a], l), axis);
            if (j >= 0 && j <= i) trip.emplace_back(i, j, c * grad[size_t(k)].dot(grad[size_t(l)]));
          }
        }
    }
    Eigen::SparseMatrix<double> M(ndof_, ndof_);
    M.setFromTriplets(trip.begin(), trip.end());
    double mean = 0;
    for (Eigen::Index i = 0; i < ndof_; ++i) mean += M.coeff(i, i);
    mean /= double(std::max<Eigen::Index>(ndof_, 1));
    for (Eigen::Index i = 0; i < ndof_; ++i) {  // a small shift keeps it positive definite; an empty row gets the mean
      const double d = M.coeff(i, i);
      M.coeffRef(i, i) += 1e-6 * mean + (d > 0 ? 0.0 : mean);
    }
    return M;
  }

  LbfgsOptions options(int iterations) const {
    LbfgsOptions o;
    o.iterations = iterations;
    o.gradient_tol = 1e-10 / mean_edge_;
    o.first_move = 0.1 * mean_edge_;
    o.max_halvings = 12;  // a step 4096 times below the first trial moves nothing: the round has stalled
    return o;
  }

  bool out_of_time() {
    if (p_.seconds > 0 && seconds_since(t0_) > p_.seconds) st_.time_budget_hit = true;
    return st_.time_budget_hit;
  }

  /// Mean of 6 × the PolyCube volume over the tets that are not flat (inv < 2).
  double mean_volume6(const std::vector<char>& inv) const {
    double sum = 0;
    long n = 0;
    for (Eigen::Index t = 0; t < T_.rows(); ++t)
      if (inv[size_t(t)] < 2) sum += volume6(t), ++n;
    return n > 0 ? std::max(sum / double(n), 0.0) : 0.0;
  }

  /// 6 × the signed volume of tet t in the PolyCube domain.
  double volume6(Eigen::Index t) const {
    const Vec3 a = U_.row(T_(t, 0)).transpose();
    return (Vec3(U_.row(T_(t, 1)).transpose()) - a)
        .dot((Vec3(U_.row(T_(t, 2)).transpose()) - a).cross(Vec3(U_.row(T_(t, 3)).transpose()) - a));
  }

  /// True if no move that keeps the PolyCube gives t a volume: its four vertices on one chart plane, or
  /// three of them on one PolyCube edge line (two fixed coordinates equal). Such a tet is left out of the
  /// energy (its computed volume is rounding noise of either sign).
  bool flat(Eigen::Index t) const {
    auto on_common = [&](std::initializer_list<int> ks, int need) {  // `need` shared fixed axes, equal values
      int common = 7;
      for (int k : ks) common &= fixed_[size_t(T_(t, k))];
      int n = 0;
      for (int a = 0; a < 3; ++a)
        if (common >> a & 1) {
          bool same = true;
          for (int k : ks) same = same && U_(T_(t, k), a) == U_(T_(t, *ks.begin()), a);
          n += same;
        }
      return n >= need;
    };
    return on_common({0, 1, 2, 3}, 1) || on_common({0, 1, 2}, 2) || on_common({0, 1, 3}, 2) ||
           on_common({0, 2, 3}, 2) || on_common({1, 2, 3}, 2);
  }

  /// Inverted active tets (the flat ones are not active).
  long count_inverted() const {
    std::vector<char> inv(active_.size());
    tbb::parallel_for(size_t(0), active_.size(), [&](size_t a) { inv[a] = volume6(active_[a]) <= 0; });
    return long(std::count(inv.begin(), inv.end(), 1));
  }

  /// Free vertices: those of the inverted tets grown by p_.rings rings, with a coordinate that may move;
  /// active tets: those with a free vertex.
  void select(const std::vector<char>& inv) {
    const Eigen::Index nv = U_.rows(), nt = T_.rows();
    const std::vector<char> region =
        cell_ring_region(T_, nv, p_.rings, [&](Eigen::Index t) { return inv[size_t(t)] == 1; });
    std::vector<char> skip(size_t(nt), 0);
    for (Eigen::Index t = 0; t < nt; ++t) skip[size_t(t)] = inv[size_t(t)] >= 2;
    build(region, skip);
  }

  /// Free vertices: those of `region` with a coordinate that may move; active tets: those with a free
  /// vertex, `skip` ones left out.
  void build(const std::vector<char>& region, const std::vector<char>& skip) {
    const Eigen::Index nv = U_.rows(), nt = T_.rows();
    free_.clear();
    axes_.clear();
    active_.clear();
    rinv_.clear();
    weight_.clear();
    ndof_ = 0;
    dof_.assign(size_t(nv), -1);
    for (Eigen::Index v = 0; v < nv; ++v)
      if (region[size_t(v)] && (fixed_[size_t(v)] & 7) != 7) {
        dof_[size_t(v)] = int(ndof_);
        std::array<int, 3> ax{-1, -1, -1};
        int n = 0;
        for (int a = 0; a < 3; ++a)
          if (!(fixed_[size_t(v)] >> a & 1)) ax[size_t(n++)] = a;
        axes_.push_back(ax);
        ndof_ += n;
        free_.push_back(int(v));
      }
    st_.free_vertices = std::max(st_.free_vertices, long(free_.size()));
    slot_.assign(size_t(nv), -1);
    for (size_t i = 0; i < free_.size(); ++i) slot_[size_t(free_[i])] = int(i);
    double vol_sum = 0, edge_sum = 0;
    for (Eigen::Index t = 0; t < nt; ++t) {
      bool any = false;
      for (int k = 0; k < 4 && !any; ++k) any = slot_[size_t(T_(t, k))] >= 0;
      if (!any || skip[size_t(t)]) continue;
      active_.push_back(int(t));
      Mat3 D;
      for (int k = 0; k < 3; ++k) D.col(k) = (X_.row(T_(t, k + 1)) - X_.row(T_(t, 0))).transpose();
      const double vol = D.determinant();
      rinv_.push_back(vol > 0 ? Mat3(D.inverse()) : Mat3::Zero());
      weight_.push_back(std::max(vol, 0.0));
      vol_sum += std::max(vol, 0.0);
      for (int k = 0; k < 3; ++k) edge_sum += D.col(k).norm();
    }
    const double mean_vol = active_.empty() ? 1.0 : vol_sum / double(active_.size());
    // weights floored: a sliver's tiny weight would make its barrier too weak to keep it from inverting
    for (double& w : weight_) w = mean_vol > 0 ? std::max(w / mean_vol, kMinWeight) : 1.0;
    mean_edge_ = active_.empty() || edge_sum <= 0 ? 1.0 : edge_sum / (3.0 * double(active_.size()));
    inc_ = cell_incidence(T_, active_, slot_, free_.size());  // by tet index: a fixed order
    tet_energy_.assign(active_.size(), 0.0);
    tet_grad_.assign(active_.size(), Mat43::Zero());
  }

  void set_base() {
    base_.resize(free_.size());
    for (size_t i = 0; i < free_.size(); ++i) base_[i] = U_.row(free_[i]).transpose();
  }

  void apply(const VecX& x) {
    tbb::parallel_for(size_t(0), free_.size(), [&](size_t i) {
      const int v = free_[i], d = dof_[size_t(v)];
      Vec3 pos = base_[i];
      for (int j = 0; j < 3 && axes_[i][size_t(j)] >= 0; ++j) pos[axes_[i][size_t(j)]] += x[d + j];
      U_.row(v) = pos.transpose();
    });
  }

  Mat3 jacobian(size_t a) const {
    const int t = active_[a];
    Mat3 D;
    for (int k = 0; k < 3; ++k) D.col(k) = (U_.row(T_(t, k + 1)) - U_.row(T_(t, 0))).transpose();
    return D * rinv_[a];
  }

  /// The determinant the ε schedule follows: the median of the negative determinants of the active tets that
  /// are not input slivers, or their minimum when none is negative. Garanzha et al. follow the minimum; on a
  /// PolyCube map a few tets with determinants of -10 (a sliver's can be -25) keep ε so large that the
  /// barrier no longer acts on the thousands of mildly inverted ones: on fertility 600 iterations leave
  /// 4,500 of its 5,100 inverted tets with the minimum, 430 with the median.
  double min_det() const {
    std::vector<double> m(active_.size());
    tbb::parallel_for(size_t(0), active_.size(), [&](size_t a) {
      m[a] = weight_[a] >= kSliverWeight ? jacobian(a).determinant() : std::numeric_limits<double>::infinity();
    });
    if (m.empty()) return 1.0;
    const long neg = std::count_if(m.begin(), m.end(), [](double d) { return d <= 0; });
    if (neg > 0) {
      auto it = m.begin() + std::ptrdiff_t(neg / 2);
      std::nth_element(m.begin(), it, m.end());
      return *it;
    }
    return *std::min_element(m.begin(), m.end());
  }

  /// The energy at base + x (the map moved there) and, if g, its gradient. With a finite `accept_up_to` (the
  /// line search's trials, runtime/lbfgs.h), +inf as soon as one tet's term is above it (the terms are
  /// positive, so their sum in any order is at least its largest term), and no gradient when the sum is.
  double energy(const VecX& x, double eps, VecX* g, double accept_up_to = kNoBound) {
    apply(x);
    if (accept_up_to < kNoBound) {
      if (!terms_up_to(eps, accept_up_to, g != nullptr)) return kNoBound;
    } else {
      tbb::parallel_for(tbb::blocked_range<size_t>(0, active_.size(), 256),
                        [&](const tbb::blocked_range<size_t>& r) { terms(r.begin(), r.end(), eps, g != nullptr); });
    }
    double e = 0;
    for (double te : tet_energy_) e += te;
    if (g && !(e > accept_up_to)) {  // above the bound: rejected, no gradient needed
      g->setZero(ndof_);
      tbb::parallel_for(tbb::blocked_range<size_t>(0, free_.size(), 1024), [&](const tbb::blocked_range<size_t>& r) {
        constexpr size_t kAhead = 4;  // the gather waits on memory: the rows of a vertex 4 ahead are fetched
        for (size_t i = r.begin(); i < r.end(); ++i) {
          if (i + kAhead < r.end()) inc_.prefetch(i + kAhead, tet_grad_);
          const Vec3 gv = inc_.gather(i, tet_grad_);
          const int d = dof_[size_t(free_[i])];
          for (int j = 0; j < 3 && axes_[i][size_t(j)] >= 0; ++j) (*g)[d + j] = gv[axes_[i][size_t(j)]];
        }
      });
    }
    return e;
  }

  /// The tets' energy terms (and, if grad, their gradients) into tet_energy_, in blocks taken in index order
  /// by every thread: false (and the rest left undone) once a term is above `bound` or not a number. Which
  /// blocks were done before a `false` varies with the threads; a `true` has done them all. On the bench
  /// workload 298 of the map's 807 trials are rejected.
  bool terms_up_to(double eps, double bound, bool grad) {
    constexpr size_t kBlock = 1024;
    const size_t n = active_.size(), blocks = (n + kBlock - 1) / kBlock;
    std::atomic<size_t> next{0};
    std::atomic<bool> over{false};
    const int workers = std::max(1, tbb::this_task_arena::max_concurrency());
    tbb::parallel_for(
        0, workers,
        [&](int) {
          for (size_t b; !over.load(std::memory_order_relaxed) && (b = next.fetch_add(1)) < blocks;) {
            const size_t begin = b * kBlock, end = std::min(n, begin + kBlock);
            terms(begin, end, eps, grad);
            for (size_t a = begin; a < end; ++a)
              if (!(tet_energy_[a] <= bound)) over.store(true, std::memory_order_relaxed);
          }
        },
        tbb::simple_partitioner());
    return !over.load();
  }

  /// The terms of active tets [begin, end) into tet_energy_ and, if grad, their gradients into tet_grad_:
  /// kLanes tets at a time, the rest one by one (the same bits either way).
  void terms(size_t begin, size_t end, double eps, bool grad) {
    for_lanes(begin, end, [&](auto v, size_t a) { terms_of<decltype(v)>(a, eps, grad); });
  }

  template <class V>
  void terms_of(size_t a, double eps, bool grad) {
    constexpr int W = std::is_same_v<V, double> ? 1 : kLanes;
    V D[3][3], R[3][3], G[4][3], w;
    for (int l = 0; l < W; ++l) {
      const int t = active_[a + size_t(l)];
      const double* u0 = U_.row(T_(t, 0)).data();
      for (int k = 0; k < 3; ++k) {
        const double* uk = U_.row(T_(t, k + 1)).data();
        for (int i = 0; i < 3; ++i) lane(D[i][k], l) = uk[i] - u0[i];
      }
      const Mat3& r = rinv_[a + size_t(l)];
      for (int k = 0; k < 3; ++k)
        for (int j = 0; j < 3; ++j) lane(R[k][j], l) = r(k, j);
      lane(w, l) = weight_[a + size_t(l)];
    }
    V e = tet_winslow_term(D, R, w, eps, grad ? G : nullptr);
    for (int l = 0; l < W; ++l) {
      tet_energy_[a + size_t(l)] = lane(e, l);
      if (grad)
        for (int k = 0; k < 4; ++k)
          for (int i = 0; i < 3; ++i) tet_grad_[a + size_t(l)](k, i) = lane(G[k][i], l);
    }
  }

  static constexpr double kNoBound = std::numeric_limits<double>::infinity();

  const RowMatrixX3d& X_;
  const RowMatrixX4i& T_;
  RowMatrixX3d& U_;
  const std::vector<std::uint8_t>& fixed_;
  const MapUntangleParams& p_;
  MapUntangleStats& st_;
  std::chrono::steady_clock::time_point t0_;

  std::vector<int> dof_;  ///< #V first unknown of a free vertex, -1 otherwise
  Eigen::Index ndof_ = 0;
  std::vector<int> free_;                 ///< free vertices
  std::vector<std::array<int, 3>> axes_;  ///< per free vertex: its moving axes, -1 padded
  std::vector<int> active_;               ///< tets with a free vertex
  std::vector<Mat3> rinv_;                ///< per active tet: inverse of its input edge matrix
  std::vector<double> weight_;            ///< per active tet: input volume over the mean
  double mean_edge_ = 1;
  CellIncidence inc_;  ///< per free vertex: (active tet, corner) pairs
  std::vector<Vec3> base_;
  std::vector<double> tet_energy_;
  std::vector<Mat43> tet_grad_;
  std::vector<int> slot_;           ///< #V index in free_, -1 for a vertex that does not move
  std::vector<char> first_region_;  ///< #V: the first round's free vertices (the region polish's region)
};

}  // namespace

long untangle_polycube_map(const RowMatrixX3d& X, const RowMatrixX4i& T, RowMatrixX3d& U,
                           const std::vector<std::uint8_t>& fixed_axes, const MapUntangleParams& p,
                           MapUntangleStats* stats) {
  MapUntangleStats local;
  MapUntangleStats& st = stats ? *stats : local;
  st = MapUntangleStats{};
  const auto t0 = std::chrono::steady_clock::now();
  MapUntangler u(X, T, U, fixed_axes, p, st);
  const long left = u.run();
  st.seconds = seconds_since(t0);
  return left;
}

}  // namespace polyhex
