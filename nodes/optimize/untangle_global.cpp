// Global untangling by L-BFGS on the regularised Winslow energy. See untangle_global.h.
#include "nodes/optimize/untangle_global.h"
#include "nodes/optimize/hex_corners.h"
#include "nodes/artefacts/cell_rings.h"
#include "nodes/artefacts/hex_topology.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <vector>

#include "nodes/quality/quality.h"
#include "runtime/cancel.h"
#include "runtime/lbfgs.h"

namespace polyhex {
namespace {

using Vec3 = Eigen::Vector3d;
using Mat83 = Eigen::Matrix<double, 8, 3>;
using VecX = Eigen::VectorXd;

/// W[t] (8 by 3): the t-th Jacobian of a hex is J_t = P^T W[t], P the 8 by 3 corner positions
/// (VTK_HEXAHEDRON order); t < 8 the corners (edge vectors ordered for a positive determinant),
/// t = 8 the centre principal axes (Verdict), each a mean of four parallel edges.
std::array<Mat83, 9> make_weights() {
  using optimize_detail::kCorners;
  std::array<Mat83, 9> W;
  for (int t = 0; t < 8; ++t) {
    W[size_t(t)].setZero();
    for (int c = 0; c < 3; ++c) {
      W[size_t(t)](kCorners[t][c + 1], c) += 1;
      W[size_t(t)](kCorners[t][0], c) -= 1;
    }
  }
  // centre: X1 = (p1-p0)+(p2-p3)+(p5-p4)+(p6-p7), X2 = (p3-p0)+(p2-p1)+(p7-p4)+(p6-p5),
  //         X3 = (p4-p0)+(p5-p1)+(p6-p2)+(p7-p3), each over 4
  constexpr int kAxis[3][4][2] = {{{1, 0}, {2, 3}, {5, 4}, {6, 7}},
                                  {{3, 0}, {2, 1}, {7, 4}, {6, 5}},
                                  {{4, 0}, {5, 1}, {6, 2}, {7, 3}}};
  W[8].setZero();
  for (int c = 0; c < 3; ++c)
    for (const auto& e : kAxis[c]) {
      W[8](e[0], c) += 0.25;
      W[8](e[1], c) -= 0.25;
    }
  return W;
}

const std::array<Mat83, 9>& weights() {
  static const std::array<Mat83, 9> W = make_weights();
  return W;
}


using optimize_detail::winslow_term;

/// Energy of the hex with corners P (8 by 3, already over the scale) and its gradient G with respect to P.
double hex_energy(const Mat83& P, double eps, Mat83* G) {
  double e = 0;
  if (G) G->setZero();
  Eigen::Matrix3d dJ;
  for (const auto& W : weights()) {
    e += winslow_term(P.transpose() * W, eps, G ? &dJ : nullptr);
    if (G) *G += W * dJ.transpose();
  }
  return e;
}

/// The free vertices near the inverted hexes and the data of one global descent.
class GlobalUntangler {
 public:
  GlobalUntangler(RowMatrixX3d& V, const RowMatrixX8i& H, const std::vector<char>& on_surface,
                  const std::vector<char>& fixed, const TriangleTree& tree, const std::vector<Vec3>& normals,
                  const GlobalUntangleParams& p, GlobalUntangleStats& st)
      : V_(V), H_(H), on_surface_(on_surface), fixed_(fixed), tree_(tree), normals_(normals), p_(p), st_(st),
        t0_(std::chrono::steady_clock::now()) {}

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
  bool out_of_time() {
    if (p_.seconds > 0 && std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count() > p_.seconds)
      st_.time_budget_hit = true;
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
    const std::vector<char> region = cell_ring_region(H_, nv, p_.rings, [&](Eigen::Index h) { return inv[size_t(h)] != 0; });
    dof_.assign(size_t(nv), -1);
    ndof_ = 0;
    for (Eigen::Index v = 0; v < nv; ++v)
      if (region[size_t(v)] && !fixed_[size_t(v)]) {
        dof_[size_t(v)] = int(ndof_);
        ndof_ += on_surface_[size_t(v)] ? 2 : 3;
        free_.push_back(int(v));
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
      if (!on_surface_[size_t(v)]) continue;
      const Vec3 n = normals_[size_t(tree_.closest(base_[i]).triangle)];
      const Vec3 t1 = (std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).cross(n).normalized();
      frame_[i].col(0) = t1;
      frame_[i].col(1) = n.cross(t1);
    }
  }

  void apply(const VecX& x) {
    for (size_t i = 0; i < free_.size(); ++i) {
      const int v = free_[i], d = dof_[size_t(v)];
      const Vec3 pos = on_surface_[size_t(v)] ? Vec3(base_[i] + frame_[i] * x.segment<2>(d))
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

  /// Minimum normalised determinant over the 9 Jacobians of the active hexes.
  double min_det() const {
    std::vector<double> m(active_.size(), std::numeric_limits<double>::infinity());
    tbb::parallel_for(size_t(0), active_.size(), [&](size_t a) {
      Mat83 P;
      for (int k = 0; k < 8; ++k) P.row(k) = V_.row(H_(active_[a], k)) / scale_[a];
      for (const auto& W : weights()) m[a] = std::min(m[a], (P.transpose() * W).determinant());
    });
    return *std::min_element(m.begin(), m.end());
  }

  /// Energy at x (displacements of the free vertices) and, if g, its gradient.
  double energy(const VecX& x, double eps, VecX* g) {
    apply(x);
    tbb::parallel_for(size_t(0), active_.size(), [&](size_t a) {
      Mat83 P;
      for (int k = 0; k < 8; ++k) P.row(k) = V_.row(H_(active_[a], k)) / scale_[a];
      Mat83 G;
      hex_energy_[a] = hex_energy(P, eps, g ? &G : nullptr);
      if (g) hex_grad_[a] = G / scale_[a];
    });
    double e = 0;
    for (double he : hex_energy_) e += he;
    if (g) {
      g->setZero(ndof_);
      tbb::parallel_for(size_t(0), free_.size(), [&](size_t i) {
        const Vec3 gv = inc_.gather(i, hex_grad_);
        const int v = free_[i], d = dof_[size_t(v)];
        if (on_surface_[size_t(v)])
          g->segment<2>(d) = frame_[i].transpose() * gv;
        else
          g->segment<3>(d) = gv;
      });
    }
    return e;
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
  /// (checked every 5 iterations): the later phases improve the quality.
  bool lbfgs(VecX& x, double eps, bool stop_when_untangled, int iterations) {
    double mean_scale = 0;
    for (double s : scale_) mean_scale += s;
    mean_scale /= double(scale_.size());
    LbfgsOptions o;
    o.iterations = iterations;
    o.gradient_tol = 1e-10 / mean_scale;
    o.first_move = 0.1 * mean_scale;
    auto stop = [&](int done, const VecX& y, bool after_step) {
      if (!after_step) return out_of_time();
      return stop_when_untangled && done % 5 == 0 && untangled_at(y);
    };
    return lbfgs_minimize(x, [&](const VecX& y, VecX* g) { return energy(y, eps, g); }, o, stop, &st_.lbfgs_iterations) ==
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

  std::vector<int> dof_;       ///< #V first unknown of a free vertex, -1 otherwise
  Eigen::Index ndof_ = 0;
  std::vector<int> free_;      ///< free vertices
  std::vector<int> active_;    ///< hexes with a free vertex
  std::vector<int> active_index_;
  std::vector<double> scale_;  ///< per active hex: initial mean edge length
  CellIncidence inc_;          ///< per free vertex: (active hex, corner) pairs
  std::vector<Vec3> base_;
  std::vector<Eigen::Matrix<double, 3, 2>> frame_;
  std::vector<double> hex_energy_;
  std::vector<Mat83> hex_grad_;
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
                     const std::vector<char>& fixed, const TriangleTree& tree, const std::vector<Eigen::Vector3d>& normals,
                     const GlobalUntangleParams& p, GlobalUntangleStats* stats) {
  GlobalUntangleStats st;
  GlobalUntangler u(V, H, on_surface, fixed, tree, normals, p, st);
  const long left = u.run();
  if (stats) *stats = st;
  return left;
}

void smooth_region(RowMatrixX3d& V, const RowMatrixX8i& H, const std::vector<char>& on_surface,
                   const std::vector<char>& fixed, const TriangleTree& tree, const std::vector<Eigen::Vector3d>& normals,
                   const std::vector<char>& seeds, const GlobalUntangleParams& p, GlobalUntangleStats* stats) {
  GlobalUntangleStats st;
  GlobalUntangler u(V, H, on_surface, fixed, tree, normals, p, st);
  u.run_smooth(seeds);
  if (stats) *stats = st;
}

}  // namespace polyhex
