// Hex mesh optimization (paper §6): untangle, max-min scaled Jacobian, shape improvement. See optimize.h.
#include "nodes/optimize/optimize.h"

#include "nodes/algorithms/feature_fidelity.h"
#include "nodes/algorithms/features.h"
#include "nodes/algorithms/hex_corners.h"
#include "nodes/algorithms/hex_quality.h"
#include "nodes/algorithms/triangle_tree.h"
#include "nodes/artefacts/cell_rings.h"
#include "nodes/artefacts/hex_topology.h"
#include "nodes/optimize/untangle_global.h"
#include "runtime/cancel.h"
#include "runtime/errors.h"
#include "runtime/stopwatch.h"

#include <Eigen/SVD>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <deque>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace polyhex {
namespace {

using Vec3 = Eigen::Vector3d;
using Clock = std::chrono::steady_clock;

/// Adds the seconds of its lifetime to `total`.
struct PhaseTimer {
  double& total;
  Clock::time_point t0 = Clock::now();
  ~PhaseTimer() { total += seconds_since(t0); }
};

using optimize_detail::chi;
using optimize_detail::kCorners;

/// Normalised corner determinants of a hex (edge vectors over `scale`).
double min_corner_det(const std::array<Vec3, 8>& p, double scale) {
  double m = std::numeric_limits<double>::infinity();
  for (const auto& c : kCorners) {
    const Vec3 a = (p[size_t(c[1])] - p[size_t(c[0])]) / scale, b = (p[size_t(c[2])] - p[size_t(c[0])]) / scale,
               d = (p[size_t(c[3])] - p[size_t(c[0])]) / scale;
    m = std::min(m, a.dot(b.cross(d)));
  }
  return m;
}

/// A crease vertex freed under a padding layer (free_padded_creases) stays within this many hex edges of its
/// crease line, twice as many of its corner (where three layer hexes share one inner copy: 0.58 kept there).
constexpr double kLeash = 0.25;
/// ... and is freed only where its boundary quads turn by more than 75 degrees: kept on a crease that turns by
/// t, the layer's hexes there are sheared to a scaled Jacobian of about cos(t / 2), 0.79 at 75 degrees.
const double kPaddedSharpCos = std::cos(75.0 * M_PI / 180.0);
/// A boundary vertex within this many hex edges of a crease lies on it (creases_at_vertices): the lattice
/// puts vertices on a crease exactly, or within a layer's curvature where a layer ends beside it.
constexpr double kOnCrease = 0.05;
/// Rounds of return_released: a vertex halted half way may go on once its neighbours have followed.
constexpr int kReturnRounds = 10;
/// Max-min passes over a released vertex's neighbours when it goes back with them (return_with_neighbours).
constexpr int kReturnSweeps = 8;

class Optimizer {
 public:
  /// Which boundary vertices stay on the surface's creases: none, those the lattice put on them
  /// (creases_at_vertices), or paths of boundary edges nearest to them (snap_to_creases, the crease candidate).
  enum class Creases { none, at_vertices, paths };

  Optimizer(const HexMesh& mesh, const SurfaceMesh& surface, const OptimizeParams& p, Creases creases,
            OptimizeStats& st)
      : p_(p), st_(st), V_(mesh.V), H_(mesh.H), tree_(surface.V, surface.F), t0_(Clock::now()) {
    normals_.resize(size_t(surface.F.rows()));
    for (Eigen::Index f = 0; f < surface.F.rows(); ++f) {
      const Vec3 a = surface.V.row(surface.F(f, 0)).transpose(), b = surface.V.row(surface.F(f, 1)).transpose(),
                 c = surface.V.row(surface.F(f, 2)).transpose();
      const Vec3 n = (b - a).cross(c - a);
      normals_[size_t(f)] = n.norm() > 0 ? Vec3(n.normalized()) : Vec3::Zero();
    }
    diag_ = (surface.V.colwise().maxCoeff() - surface.V.colwise().minCoeff()).norm();
    build_incidence();
    colour();
    const auto Q = hex_boundary_quads(mesh);
    boundary_.assign(size_t(V_.rows()), 0);
    for (Eigen::Index q = 0; q < Q.rows(); ++q)
      for (int k = 0; k < 4; ++k) boundary_[size_t(Q(q, k))] = 1;
    for (Eigen::Index v = 0; v < V_.rows(); ++v)
      if (boundary_[size_t(v)]) V_.row(v) = tree_.closest(V_.row(v).transpose()).point.transpose();
    released_.assign(size_t(V_.rows()), 0);
    if (creases != Creases::none && p_.feature_angle > 0 && p_.move_boundary && Q.rows() > 0) {
      const double h = median_boundary_edge(V_, Q);  // the hex edge length
      if (creases == Creases::at_vertices) {
        creases_ = flat_face_creases(surface, find_creases(surface, p_.feature_angle, 1.5 * h, 0.5 * h), h);
        snap_ = creases_at_vertices(V_, Q, creases_, kOnCrease * h);
        free_padded_creases(Q, h);
      } else {
        creases_ = find_creases(surface, p_.feature_angle, 1.5 * h);
        snap_ = snap_to_creases(V_, Q, creases_, h);
      }
      if (!creases_.lines.empty() && p_.minimum_iterations > 0) patch_ = crease_faces(surface, creases_).patch;
      crease_h_ = h;
      st_.crease_lines = int(creases_.lines.size());
      st_.crease_lines_snapped = snap_.lines_snapped;
      st_.crease_vertices = snap_.vertices;
      for (Eigen::Index v = 0; v < V_.rows(); ++v)
        if (on_crease(int(v))) V_.row(v) = project(int(v), V_.row(v).transpose()).transpose();
    }
  }

  HexMesh run(const std::string& source) {
    improve();
    return finish(source);
  }

  /// Phases (a) to (b''): untangling, max-min, whole-hex moves, region smoothing.
  void improve() {
    released_.assign(size_t(V_.rows()), 0);
    cap_.clear();
    // local sweeps first: cheap, they untangle most hexes with little motion
    untangle();
    if (p_.global_iterations > 0 && count_inverted() > 0) {
      // Two ways on from here, tried in turn from the same state: (1) local only (the boundary release
      // and sweeps again); (2) only if (1) leaves inverted hexes: the global descent for the folds that
      // need several vertices to move together, then the same. The global descent moves every vertex
      // within `global_rings` of a fold, which can end in a worse minimum where the local way alone
      // succeeds (fandisk: 0.364 local, 0.003 global), so it is the fallback; the way with fewer inverted
      // hexes (then the higher minimum scaled Jacobian) goes on to max-min and shape improvement.
      const RowMatrixX3d V0 = V_;
      const std::vector<char> released0 = released_;
      const OptimizeStats st0 = st_;
      release_and_untangle();
      const long inverted_local = count_inverted();
      if (inverted_local > 0 && !out_of_time()) {
        const RowMatrixX3d V1 = V_;
        const std::vector<char> released1 = released_;
        const OptimizeStats st1 = st_;
        const double sj_local = sj_min();
        V_ = V0;
        released_ = released0;
        st_ = st0;
        global_untangle();
        st_.inverted_after_global = count_inverted();
        untangle();
        release_and_untangle();
        const long inverted_global = count_inverted();
        const long moves = st_.moves + st1.moves - st0.moves;  // the work of both ways is counted
        const int iterations = st_.iterations + st1.iterations - st0.iterations;
        const bool budget = st_.time_budget_hit;
        if (inverted_global > inverted_local || (inverted_global == inverted_local && sj_min() < sj_local)) {
          V_ = V1;
          released_ = released1;
          st_ = st1;
        } else {
          st_.global_kept = true;
        }
        st_.optimize_ways = 2;
        st_.moves = moves;
        st_.iterations = iterations;
        st_.time_budget_hit = budget;
      }
    } else {
      release_and_untangle();
    }
    maxmin();
    for (int round = 0; round < p_.element_iterations && !out_of_time(); ++round) {
      ++st_.element_sweeps;
      const long moved = elements();
      st_.element_moves += moved;
      if (moved == 0) break;
      maxmin();
    }
    smooth_worst();
    if (return_released()) maxmin();
  }

  /// Phase (c), the shape improvement, and the result.
  HexMesh finish(const std::string& source) {
    shape();
    return_released();
    raise_min();
    HexMesh out;
    out.V = V_;
    out.H = H_;
    out.source = source;
    st_.boundary_distance_max = departure();
    return out;
  }

  /// Inverted hexes and the minimum scaled Jacobian of the current positions.
  long inverted_now() const { return count_inverted(); }
  double min_now() const { return sj_min(); }

 private:
  /// Last resort: a hex squeezed against the surface (typically at a sharp or concave feature the
  /// lattice does not follow) may be impossible to untangle with its boundary corners on the surface.
  /// A solver rejects an inverted hex but accepts a boundary vertex slightly off the surface, so the
  /// boundary vertices of the hexes still inverted may leave it (boundary_distance_max reports how far),
  /// then the untangling sweeps run again. Once untangled, return_released brings them back.
  /// (A cap of half a hex edge on how far they may go, tried on 2026-12-03, left the cuboid screw thread's
  /// crease candidate inverted at -0.65 where the uncapped release untangles it: docs/optimize.md.)
  void release_and_untangle() {
    if (!p_.release_boundary || count_inverted() == 0) return;
    const auto q = all_quality();
    for (Eigen::Index h = 0; h < H_.rows(); ++h)
      if (q[size_t(h)].corner_min <= 0)
        for (int k = 0; k < 8; ++k)
          if (boundary_[size_t(H_(h, k))] && !released_[size_t(H_(h, k))])
            released_[size_t(H_(h, k))] = 1, ++st_.released_vertices;
    untangle();
  }

  /// The largest distance of a boundary vertex from the surface / the bbox diagonal.
  double departure() const {
    double d = 0;
    for (Eigen::Index v = 0; v < V_.rows(); ++v)
      if (boundary_[size_t(v)]) d = std::max(d, tree_.distance(V_.row(v).transpose()) / diag_);
    return d;
  }

  /// Released boundary vertices go back onto the surface (onto their crease, if the lattice put them on one)
  /// as far as their hexes allow: the untangling released them while their neighbours were folded, and the
  /// phases after it have moved those neighbours. Per vertex, in index order, in rounds until none moves: the
  /// whole way back (it is then no longer released), else half or a quarter of it; a position is kept if no
  /// hex of the vertex is inverted there (that was not) and their minimum scaled Jacobian stays at least the
  /// mesh's, so the minimum never falls. From then on a released vertex's moves never take it farther from
  /// the surface than it is (cap_, project). Returns whether a vertex moved, fully or in part.
  bool return_released() {
    if (std::find(released_.begin(), released_.end(), 1) == released_.end()) return false;
    const double floor = sj_min();
    cap_.assign(size_t(V_.rows()), std::numeric_limits<double>::infinity());
    bool moved = false;
    for (int round = 0; round < kReturnRounds; ++round) {
      bool any = false;
      for (size_t v = 0; v < released_.size(); ++v) {
        if (!released_[v]) continue;
        const Vec3 x0 = V_.row(Eigen::Index(v)).transpose();
        released_[v] = 0;  // project() as for a vertex on the surface
        const Vec3 target = project(int(v), x0);
        released_[v] = 1;
        const Local l0 = local(int(v));
        for (const double t : {1.0, 0.5, 0.25}) {
          V_.row(Eigen::Index(v)) = (x0 + t * (target - x0)).transpose();
          const Local l = local(int(v));
          if (l.inverted <= l0.inverted && l.sj_min >= std::min(floor, l0.sj_min)) {
            any = moved = true;
            if (t == 1.0) released_[v] = 0, ++st_.returned_vertices;
            break;
          }
          V_.row(Eigen::Index(v)) = x0.transpose();
        }
      }
      if (!any) break;
    }
    if (p_.return_rings > 0)
      for (size_t v = 0; v < released_.size() && !out_of_time(); ++v)
        if (released_[v] && return_with_neighbours(int(v), floor)) moved = true;
    for (size_t v = 0; v < released_.size(); ++v)
      if (released_[v]) cap_[v] = tree_.distance(V_.row(Eigen::Index(v)).transpose());
    return moved;
  }

  /// A released vertex its hexes hold off the surface: alone it cannot go back without lowering the minimum
  /// or inverting a hex, but its neighbours, fixed while it tries, were placed around its released position.
  /// It goes back the whole way (then half of it), and the movable vertices within p_.return_rings rings of
  /// hexes around it (but other released ones) take max-min steps (kReturnSweeps passes, in index order); the
  /// result is kept if no hex around the moved vertices is inverted that was not and their minimum scaled
  /// Jacobian stays at least `floor` (the mesh's minimum when the return began), else every vertex goes back
  /// to where it was. Sequential, in index order: the same result for any thread count.
  bool return_with_neighbours(int v, double floor) {
    // the rings, then the hexes whose measures the moves can change
    std::vector<int> ring{v};
    std::vector<char> in(size_t(V_.rows()), 0);
    in[size_t(v)] = 1;
    for (int r = 0, first = 0; r < p_.return_rings; ++r) {
      const int last = int(ring.size());
      for (int i = first; i < last; ++i)
        for (int k = start_[size_t(ring[size_t(i)])]; k < start_[size_t(ring[size_t(i)]) + 1]; ++k)
          for (int c = 0; c < 8; ++c) {
            const int w = H_(inc_[size_t(k)], c);
            if (!in[size_t(w)]) in[size_t(w)] = 1, ring.push_back(w);
          }
      first = last;
    }
    const std::vector<int> hexes = hexes_around(ring.data(), ring.size());
    int inverted0 = 0;
    min_sj(hexes, inverted0);
    // the other released vertices stay: a max-min step would take them farther from the surface
    std::vector<int> sweep_set;
    for (size_t i = 1; i < ring.size(); ++i)
      if (!released_[size_t(ring[i])]) sweep_set.push_back(ring[i]);
    std::sort(sweep_set.begin(), sweep_set.end());
    std::vector<Vec3> saved(ring.size());
    for (size_t i = 0; i < ring.size(); ++i) saved[i] = V_.row(ring[i]).transpose();
    const Vec3 x0 = saved[0];
    released_[size_t(v)] = 0;  // project() as for a vertex on the surface
    const Vec3 target = project(v, x0);
    for (const double t : {1.0, 0.5}) {
      released_[size_t(v)] = t == 1.0 ? 0 : 1;  // on the surface, it slides on it with the others
      V_.row(v) = (x0 + t * (target - x0)).transpose();
      for (int pass = 0; pass < kReturnSweeps; ++pass) {
        bool any = false;
        if (t == 1.0 && movable(v)) any = maxmin_step(v) || any;
        for (int w : sweep_set)
          if (movable(w)) any = maxmin_step(w) || any;
        if (!any) break;
      }
      int inverted = 0;
      const double m = min_sj(hexes, inverted);
      if (inverted <= inverted0 && m >= floor) {
        if (t == 1.0) ++st_.returned_vertices, ++st_.returned_with_neighbours;
        return true;
      }
      for (size_t i = 0; i < ring.size(); ++i) V_.row(ring[i]) = saved[i].transpose();
    }
    released_[size_t(v)] = 1;
    return false;
  }

  /// The hexes around the n vertices vs, sorted, each once.
  std::vector<int> hexes_around(const int* vs, size_t n) const {
    std::vector<int> hexes;
    for (size_t j = 0; j < n; ++j)
      for (int i = start_[size_t(vs[j])]; i < start_[size_t(vs[j]) + 1]; ++i) hexes.push_back(inc_[size_t(i)]);
    std::sort(hexes.begin(), hexes.end());
    hexes.erase(std::unique(hexes.begin(), hexes.end()), hexes.end());
    return hexes;
  }

  /// The minimum scaled Jacobian of the given hexes; `inverted` gets how many have a corner at or below 0.
  double min_sj(const std::vector<int>& hexes, int& inverted) const {
    double m = 1;
    inverted = 0;
    for (int h : hexes) {
      const HexSJ x = hex_scaled_jacobian(points(h));
      m = std::min(m, x.sj);
      inverted += x.corner_min <= 0;
    }
    return m;
  }

  double sj_min() const {
    double m = 1;
    for (const HexSJ& q : all_quality()) m = std::min(m, q.sj);
    return m;
  }

  // ------------------------------------------------------------------------------------------
  // structure

  void build_incidence() {
    const Eigen::Index nv = V_.rows();
    start_.assign(size_t(nv) + 1, 0);
    for (Eigen::Index h = 0; h < H_.rows(); ++h)
      for (int k = 0; k < 8; ++k) ++start_[size_t(H_(h, k)) + 1];
    for (size_t i = 0; i < size_t(nv); ++i) start_[i + 1] += start_[i];
    inc_.resize(size_t(start_.back()));
    std::vector<int> fill(start_.begin(), start_.end() - 1);
    corner_.resize(inc_.size());
    for (Eigen::Index h = 0; h < H_.rows(); ++h)
      for (int k = 0; k < 8; ++k) {
        const int v = H_(h, k);
        const bool repeated = std::count(H_.row(h).data(), H_.row(h).data() + 8, v) > 1;
        corner_[size_t(fill[size_t(v)])] = repeated ? -1 : k;
        inc_[size_t(fill[size_t(v)]++)] = int(h);
      }
    // edge neighbours, and the local edge length
    nbr_.assign(size_t(nv), {});
    using hex_topology::kEdges;
    for (Eigen::Index h = 0; h < H_.rows(); ++h)
      for (const auto& e : kEdges) {
        nbr_[size_t(H_(h, e[0]))].push_back(H_(h, e[1]));
        nbr_[size_t(H_(h, e[1]))].push_back(H_(h, e[0]));
      }
    scale_.assign(size_t(nv), 1.0);
    for (size_t v = 0; v < size_t(nv); ++v) {
      auto& n = nbr_[v];
      std::sort(n.begin(), n.end());
      n.erase(std::unique(n.begin(), n.end()), n.end());
      double s = 0;
      for (int w : n) s += (V_.row(w) - V_.row(Eigen::Index(v))).norm();
      if (!n.empty() && s > 0) scale_[v] = s / double(n.size());
    }
  }

  /// Greedy colouring: two vertices of one hex never share a colour.
  void colour() {
    const size_t nv = size_t(V_.rows());
    std::vector<int> col(nv, -1);
    std::vector<int> used;
    int ncol = 0;
    for (size_t v = 0; v < nv; ++v) {
      if (start_[v] == start_[v + 1]) continue;  // unused vertex
      used.assign(size_t(ncol) + 1, 0);
      for (int i = start_[v]; i < start_[v + 1]; ++i)
        for (int k = 0; k < 8; ++k) {
          const int c = col[size_t(H_(inc_[size_t(i)], k))];
          if (c >= 0) used[size_t(c)] = 1;
        }
      int c = 0;
      while (used[size_t(c)]) ++c;
      col[v] = c;
      ncol = std::max(ncol, c + 1);
    }
    classes_.assign(size_t(ncol), {});
    for (size_t v = 0; v < nv; ++v)
      if (col[v] >= 0) classes_[size_t(col[v])].push_back(int(v));
    st_.colours = ncol;
  }

  std::array<Vec3, 8> points(int h) const {
    std::array<Vec3, 8> p;
    for (int k = 0; k < 8; ++k) p[size_t(k)] = V_.row(H_(h, k)).transpose();
    return p;
  }

  // ------------------------------------------------------------------------------------------
  // local measures of vertex v (at its current position)

  struct Local {
    double sj_min;  ///< min scaled Jacobian (centre term included) of the incident hexes
    double sj_sum;
    int inverted;  ///< incident hexes with a corner scaled Jacobian <= 0
  };
  /// The 9 scaled-Jacobian terms of each hex around a vertex at a full evaluation (`local` with `fill`):
  /// while only that vertex moves, the evaluations that are given them recompute the 5 terms of each hex
  /// that it changes (hex_scaled_jacobian_moved), with the same figures bit for bit.
  using Terms = std::vector<std::array<double, 9>>;

  /// Scaled Jacobian of the hex of incidence slot i of vertex v (i from start_[v]): in full, or from
  /// `base` (the terms of slot i - start_[v]) after only v has moved; `terms` gets its 9 terms.
  HexSJ incident_sj(int v, int i, const Terms* base, std::array<double, 9>& terms) const {
    const auto p = points(inc_[size_t(i)]);
    const int j = corner_[size_t(i)];
    if (!base || j < 0) return hex_scaled_jacobian(p, terms);
    return hex_scaled_jacobian_moved(p, j, (*base)[size_t(i - start_[size_t(v)])], terms);
  }

  /// Local measures, in full (`fill`, if given, gets the terms for later evaluations) or from `base`.
  Local local(int v, Terms* fill = nullptr, const Terms* base = nullptr) const {
    Local l{1.0, 0.0, 0};
    if (fill) fill->resize(size_t(start_[size_t(v) + 1] - start_[size_t(v)]));
    std::array<double, 9> ht;
    for (int i = start_[size_t(v)]; i < start_[size_t(v) + 1]; ++i) {
      const HexSJ s = incident_sj(v, i, base, ht);
      if (fill) (*fill)[size_t(i - start_[size_t(v)])] = ht;
      l.sj_min = std::min(l.sj_min, s.sj);
      l.sj_sum += s.sj;
      l.inverted += s.corner_min <= 0;
    }
    return l;
  }
  /// The 8 Winslow terms of each hex around a vertex, as Terms for the scaled Jacobian.
  using WinslowTerms = std::vector<std::array<double, 8>>;

  /// Winslow energy of the hexes around v at ε, in full (`fill`, if given, gets the terms) or from `base`
  /// (the terms of a full evaluation at the same ε) after only v has moved.
  double energy(int v, double eps, WinslowTerms* fill = nullptr, const WinslowTerms* base = nullptr) const {
    const int first = start_[size_t(v)];
    if (fill) fill->resize(size_t(start_[size_t(v) + 1] - first));
    std::array<double, 8> t;
    double e = 0;
    for (int i = first; i < start_[size_t(v) + 1]; ++i) {
      const auto p = points(inc_[size_t(i)]);
      const int j = corner_[size_t(i)];
      e += base && j >= 0 ? hex_winslow_energy_moved(p, j, scale_[size_t(v)], eps, (*base)[size_t(i - first)], t)
                          : hex_winslow_energy(p, scale_[size_t(v)], eps, t);
      if (fill) (*fill)[size_t(i - first)] = t;
    }
    return e;
  }
  /// energy(v, eps) as descend()'s objective: its first call (at the start position) keeps the terms in
  /// `base`, the later ones recompute only those that v changes.
  auto winslow_objective(int v, double eps, WinslowTerms& base) const {
    return [this, v, eps, &base, first = true]() mutable {
      if (!first) return energy(v, eps, nullptr, &base);
      first = false;
      return energy(v, eps, &base);
    };
  }
  /// Soft minimum of the corner and centre scaled Jacobians of the hexes around v, negated (to be
  /// minimised); `l` gets the local measures of the same evaluation. `base`: as `local`'s.
  double soft_min(int v, Local& l, const Terms& base) const {
    constexpr double beta = 40.0;
    l = Local{1.0, 0.0, 0};
    std::array<double, 72> terms;  // 9 per hex; a vertex in more than 8 hexes uses the vector below
    std::vector<double> more;
    const int n = start_[size_t(v) + 1] - start_[size_t(v)];
    double* t = n <= 8 ? terms.data() : (more.resize(size_t(9 * n)), more.data());
    std::array<double, 9> ht;
    for (int i = 0; i < n; ++i) {
      const HexSJ s = incident_sj(v, start_[size_t(v)] + i, &base, ht);
      std::copy(ht.begin(), ht.end(), t + 9 * i);
      l.sj_min = std::min(l.sj_min, s.sj);
      l.sj_sum += s.sj;
      l.inverted += s.corner_min <= 0;
    }
    const double m = std::min(l.sj_min, 1.0);
    double sum = 0;
    for (int i = 0; i < 9 * n; ++i) sum += std::exp(-beta * (t[i] - m));
    return -(m - std::log(sum) / beta);
  }

  // ------------------------------------------------------------------------------------------
  // one vertex: descent on `objective` (minimised), accepted by `accept(before)`

  /// A boundary vertex kept on the input surface (not released by the last-resort untangling).
  bool on_surface(int v) const { return boundary_[size_t(v)] && !released_[size_t(v)]; }
  /// A boundary vertex kept on a crease line or at a crease corner (features.h), not released.
  bool on_crease(int v) const {
    return !snap_.line.empty() && (snap_.line[size_t(v)] >= 0 || snap_.corner[size_t(v)] >= 0) && on_surface(v);
  }
  Vec3 project(int v, const Vec3& x) const {
    if (!on_surface(v)) {
      if (!boundary_[size_t(v)] || cap_.empty()) return x;
      // a released vertex after return_released: no farther from the surface than it went back to
      const Vec3 y = tree_.closest(x).point;
      const double d = (x - y).norm();
      return d <= cap_[size_t(v)] ? x : Vec3(y + (cap_[size_t(v)] / d) * (x - y));
    }
    if (on_crease(v)) {
      if (snap_.corner[size_t(v)] >= 0) return creases_.corners[size_t(snap_.corner[size_t(v)])];
      return closest_on_line(creases_.lines[size_t(snap_.line[size_t(v)])], x);
    }
    const Vec3 y = tree_.closest(x).point;
    if (leash_line_.empty() || (leash_line_[size_t(v)] < 0 && leash_corner_[size_t(v)] < 0)) return y;
    // a freed crease vertex stays within leash_ of its line or corner
    const Vec3 anchor = leash_corner_[size_t(v)] >= 0
                            ? creases_.corners[size_t(leash_corner_[size_t(v)])]
                            : closest_on_line(creases_.lines[size_t(leash_line_[size_t(v)])], y);
    const double d = (y - anchor).norm(), leash = leash_corner_[size_t(v)] >= 0 ? 2 * leash_ : leash_;
    return d <= leash ? y : tree_.closest(anchor + (leash / d) * (y - anchor)).point;
  }

  /// A crease vertex whose every hex has one boundary face at it lies under a padding layer on both sides of
  /// the crease: the layer's hexes share one inner copy there, so kept on the crease they stay sheared at 45
  /// degrees (scaled Jacobian 0.71 along the crease, 0.58 at a corner). Where the crease turns by more than 75
  /// degrees such vertices may round it a little: they move on the surface within kLeash hex edges of it.
  /// Where the layer ends on the crease (pad.h), the hexes are boxes and the vertices stay on it.
  void free_padded_creases(const BoundaryQuads& Q, double h) {
    // per vertex: its boundary quads, and the least cosine between two of their normals (how sharp it is)
    std::vector<int> quads(size_t(V_.rows()), 0);
    std::vector<std::vector<Vec3>> normals(size_t(V_.rows()));
    for (Eigen::Index q = 0; q < Q.rows(); ++q) {
      const Vec3 n = (V_.row(Q(q, 2)) - V_.row(Q(q, 0))).cross(V_.row(Q(q, 3)) - V_.row(Q(q, 1))).transpose();
      for (int k = 0; k < 4; ++k) {
        ++quads[size_t(Q(q, k))];
        if (n.norm() > 0) normals[size_t(Q(q, k))].push_back(n.normalized());
      }
    }
    auto sharp = [&](size_t v) {
      for (size_t i = 0; i < normals[v].size(); ++i)
        for (size_t j = i + 1; j < normals[v].size(); ++j)
          if (normals[v][i].dot(normals[v][j]) < kPaddedSharpCos) return true;
      return false;
    };
    leash_ = kLeash * h;
    leash_line_.assign(size_t(V_.rows()), -1);
    leash_corner_.assign(size_t(V_.rows()), -1);
    for (size_t v = 0; v < size_t(V_.rows()); ++v)
      if ((snap_.line[v] >= 0 || snap_.corner[v] >= 0) && quads[v] == start_[v + 1] - start_[v] && sharp(v)) {
        leash_line_[v] = snap_.line[v];
        leash_corner_[v] = snap_.corner[v];
        snap_.line[v] = snap_.corner[v] = -1;
        --snap_.vertices;
      }
  }

  /// Moves vertex v to decrease f; `ok()` judges the trial position (V_ holds it). Returns true if moved.
  /// f's first call is at v's start position (winslow_objective relies on it).
  template <class F, class Ok>
  bool descend(int v, F f, Ok ok, double first_step, const Vec3* extra = nullptr) {
    const Vec3 x0 = V_.row(v).transpose();
    const double h = scale_[size_t(v)];
    const double f0 = f();
    Vec3 g;
    const double d = 1e-4 * h;
    for (int a = 0; a < 3; ++a) {
      V_(v, a) = x0[a] + d;
      const double fp = f();
      V_(v, a) = x0[a] - d;
      const double fm = f();
      V_(v, a) = x0[a];
      g[a] = (fp - fm) / (2 * d);
    }
    Vec3 normal = Vec3::Zero();
    if (on_crease(v)) {  // along the crease line only
      Vec3 t = Vec3::Zero();
      if (snap_.line[size_t(v)] >= 0) closest_on_line(creases_.lines[size_t(snap_.line[size_t(v)])], x0, &t);
      g = g.dot(t) * t;
    } else if (on_surface(v)) {
      normal = normals_[size_t(tree_.closest(x0).triangle)];
      g -= g.dot(normal) * normal;
    }
    auto trial = [&](const Vec3& x) {
      V_.row(v) = project(v, x).transpose();
      if (f() < f0 - 1e-12 * std::max(1.0, std::abs(f0)) && ok()) return true;
      V_.row(v) = x0.transpose();
      return false;
    };
    if (extra && trial(*extra)) return true;
    const double gn = g.norm();
    if (!(gn > 0) || !std::isfinite(gn)) return false;
    const Vec3 dir = -g / gn;
    double step = std::min(first_step * h, f0 > 0 ? 2.0 * f0 / gn : first_step * h);
    step = std::max(step, 1e-3 * h);
    for (int k = 0; k < 12; ++k, step *= 0.5)
      if (trial(x0 + step * dir)) return true;
    return false;
  }

 private:
  bool out_of_time() {
    if (elapsed() > p_.time_budget) st_.time_budget_hit = true;
    return st_.time_budget_hit;
  }

  double elapsed() const { return seconds_since(t0_); }

  bool movable(int v) const {
    if (!snap_.corner.empty() && snap_.corner[size_t(v)] >= 0 && on_surface(v)) return false;  // at a crease corner
    return p_.move_boundary || !boundary_[size_t(v)];
  }

  /// The inputs shared by the global descents (untangle_global.h): which vertices stay on the surface and
  /// which do not move (`keep_boundary`: no boundary vertex moves), the rings and the time left.
  GlobalUntangleParams descent_setup(bool keep_boundary, std::vector<char>& surf, std::vector<char>& fixed) const {
    surf.assign(size_t(V_.rows()), 0);
    fixed.assign(size_t(V_.rows()), 0);
    for (size_t v = 0; v < size_t(V_.rows()); ++v) {
      surf[v] = on_surface(int(v));
      // crease vertices stay in the global descents, which move boundary vertices in tangent planes
      fixed[v] = !movable(int(v)) || (keep_boundary && boundary_[v]) || on_crease(int(v));
    }
    GlobalUntangleParams gp;
    gp.rings = p_.global_rings;
    gp.seconds = std::max(p_.time_budget - elapsed(), 1e-3);
    return gp;
  }

  /// Marks every vertex whose position or own state differs from what the last remembering sweep saw as
  /// changed (a new tick): moves by any phase count (the untangling, whole-hex moves, region descents,
  /// returns), not only a sweep's steps.
  void note_changes() {
    const size_t nv = size_t(V_.rows());
    auto cap_state = [&](size_t v) { return cap_.empty() ? -1.0 : cap_[v]; };
    if (seen_V_.rows() != V_.rows()) {
      seen_V_ = V_;
      seen_released_ = released_;
      seen_cap_.resize(nv);
      for (size_t v = 0; v < nv; ++v) seen_cap_[v] = cap_state(v);
      changed_.assign(nv, 0);
      failed_.assign(nv, -1);
      return;
    }
    const long t = ++tick_;
    tbb::parallel_for(size_t(0), nv, [&](size_t v) {
      const auto i = Eigen::Index(v);
      if (seen_V_(i, 0) != V_(i, 0) || seen_V_(i, 1) != V_(i, 1) || seen_V_(i, 2) != V_(i, 2) ||
          seen_released_[v] != released_[v] || seen_cap_[v] != cap_state(v)) {
        seen_V_.row(i) = V_.row(i);
        seen_released_[v] = released_[v];
        seen_cap_[v] = cap_state(v);
        changed_[v] = t;
      }
    });
  }

  /// True if v's last max-min step failed and nothing of its hexes has changed since: a step is a function of
  /// the positions of the vertices of v's hexes and of v's own state (released_, cap_), so the same step would
  /// compute the same trials and fail again.
  bool would_fail_again(int v) const {
    const long f = failed_[size_t(v)];
    if (f < 0) return false;
    for (int i = start_[size_t(v)]; i < start_[size_t(v) + 1]; ++i)
      for (int k = 0; k < 8; ++k)
        if (changed_[size_t(H_(inc_[size_t(i)], k))] >= f) return false;
    return true;
  }

  /// One Gauss-Seidel sweep over the selected vertices, colour by colour, in parallel within a colour. With
  /// `maxmin` (its steps are maxmin_step) and skip_failed_steps, a vertex whose last step failed and around
  /// which nothing has changed since is skipped (would_fail_again): the same moves, bit for bit, without the
  /// repeated work at equilibrium (the worst-only sweeps revisit the same few hundred vertices until the
  /// minimum stalls for 5 sweeps; 46 % of the bench's max-min steps). The shape sweeps move nearly every
  /// vertex they select, so there is nothing to remember.
  template <class Step>
  long sweep(const std::vector<char>& selected, Step step, bool maxmin = false) {
    std::atomic<long> moved{0}, skipped{0};
    const bool remember = maxmin && p_.skip_failed_steps;
    if (remember) note_changes();
    for (const auto& cls : classes_) {
      throw_if_interrupted();
      if (out_of_time()) break;
      const long t = ++tick_;  // vertices of one colour share no hex: none sees another's step of this tick
      tbb::parallel_for(size_t(0), cls.size(), [&](size_t i) {
        const int v = cls[i];
        if (!selected[size_t(v)] || !movable(v)) return;
        if (!remember) {
          if (step(v)) ++moved;
          return;
        }
        if (would_fail_again(v)) {
          ++skipped;
          return;
        }
        if (step(v)) {  // v is among its hexes' vertices: its own change ends the memory of a failure
          ++moved;
          changed_[size_t(v)] = t;
          seen_V_.row(v) = V_.row(v);
        } else {
          failed_[size_t(v)] = t;
        }
      });
    }
    st_.moves += moved;
    st_.steps_skipped += skipped;
    return moved;
  }

  /// Scaled Jacobian of every hex at the current positions (in parallel; one slot per hex, so the
  /// same figures for any thread count).
  std::vector<HexSJ> all_quality() const {
    std::vector<HexSJ> q(size_t(H_.rows()));
    tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, H_.rows(), 512),
                      [&](const tbb::blocked_range<Eigen::Index>& r) {
                        for (Eigen::Index h = r.begin(); h < r.end(); ++h)
                          q[size_t(h)] = hex_scaled_jacobian(points(int(h)));
                      });
    return q;
  }

  /// The seeds of a descent around the worst hexes: the hexes whose SJ is below min(gmin + band, cap), with
  /// gmin the global minimum, which it sets. Empty when a hex is inverted: the barriers need an untangled mesh.
  std::vector<char> seeds_near_minimum(double band, double cap, double& gmin) const {
    const auto q = all_quality();
    gmin = 1;
    for (const HexSJ& x : q) {
      if (x.corner_min <= 0) return {};
      gmin = std::min(gmin, x.sj);
    }
    std::vector<char> seeds(q.size(), 0);
    for (size_t h = 0; h < q.size(); ++h) seeds[h] = q[h].sj < std::min(gmin + band, cap);
    return seeds;
  }

  /// Recomputes q[h] (hex_scaled_jacobian, as all_quality) and, if given, det[h] (min_corner_det) for the
  /// hexes incident to the vertices with `moved` set: in a sweep only selected vertices move. With every
  /// vertex set it is the full computation. \pre q, det sized #hexes
  void refresh_quality(std::vector<HexSJ>& q, const std::vector<char>& moved,
                       std::vector<double>* det = nullptr) const {
    std::vector<char> dirty(size_t(H_.rows()), 0);
    for (size_t v = 0; v < moved.size(); ++v)
      if (moved[v])
        for (int i = start_[v]; i < start_[v + 1]; ++i) dirty[size_t(inc_[size_t(i)])] = 1;
    std::vector<int> list;
    for (size_t h = 0; h < dirty.size(); ++h)
      if (dirty[h]) list.push_back(int(h));
    tbb::parallel_for(tbb::blocked_range<size_t>(0, list.size(), 256), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t i = r.begin(); i < r.end(); ++i) {
        const auto p = points(list[i]);
        q[size_t(list[i])] = hex_scaled_jacobian(p);
        if (det) (*det)[size_t(list[i])] = min_corner_det(p, scale_[size_t(H_(list[i], 0))]);
      }
    });
  }

  long count_inverted(double* det_min = nullptr) const {
    std::vector<double> dmin(det_min ? size_t(H_.rows()) : 0);
    std::vector<char> inv(size_t(H_.rows()));
    tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, H_.rows(), 512),
                      [&](const tbb::blocked_range<Eigen::Index>& r) {
                        for (Eigen::Index h = r.begin(); h < r.end(); ++h) {
                          const auto p = points(int(h));
                          inv[size_t(h)] = hex_scaled_jacobian(p).corner_min <= 0;
                          if (det_min) dmin[size_t(h)] = min_corner_det(p, scale_[size_t(H_(h, 0))]);
                        }
                      });
    if (det_min)
      *det_min = dmin.empty() ? std::numeric_limits<double>::infinity() : *std::min_element(dmin.begin(), dmin.end());
    return long(std::count(inv.begin(), inv.end(), 1));
  }

  // (a) untangling: all free vertices near the inverted hexes at once (L-BFGS), then vertex by vertex
  /// Kept only if it lowers the number of inverted hexes (a failed global descent spreads distortion).
  void global_untangle() {
    PhaseTimer timer{st_.global_seconds};
    if (p_.global_iterations <= 0 || out_of_time()) return;
    const long before = count_inverted();
    if (before == 0) return;
    const RowMatrixX3d keep = V_;
    std::vector<char> surf, fixed;
    GlobalUntangleParams gp = descent_setup(false, surf, fixed);
    gp.outer_iterations = p_.global_iterations;
    GlobalUntangleStats gs;
    untangle_global(V_, H_, surf, fixed, tree_, normals_, gp, &gs);
    if (count_inverted() >= before) V_ = keep;
    st_.global_outer += gs.outer;
    st_.global_lbfgs_iterations += gs.lbfgs_iterations;
    st_.global_free_vertices += gs.free_vertices;
    if (gs.time_budget_hit) st_.time_budget_hit = true;
  }

  void untangle() {
    PhaseTimer timer{st_.untangle_seconds};
    long best = std::numeric_limits<long>::max();
    // qualities and corner determinants kept up to date incrementally: all hexes first, then those of the
    // vertices the previous sweep selected (refresh_quality)
    std::vector<HexSJ> q(size_t(H_.rows()));
    std::vector<double> det(size_t(H_.rows()));
    std::vector<char> sel(size_t(V_.rows()), 1);
    for (int it = 0, stall = 0; it < p_.untangle_iterations && !out_of_time(); ++it) {
      throw_if_interrupted();
      refresh_quality(q, sel, &det);
      const long n = long(std::count_if(q.begin(), q.end(), [](const HexSJ& x) { return x.corner_min <= 0; }));
      const double dmin =
          det.empty() ? std::numeric_limits<double>::infinity() : *std::min_element(det.begin(), det.end());
      if (n == 0) return;
      // stalled: the count has not improved for 20 sweeps (the global descent takes over)
      if (n < best)
        best = n, stall = 0;
      else if (++stall >= 20)
        return;
      const double eps = std::sqrt(1e-8 + 0.04 * std::min(dmin, 0.0) * std::min(dmin, 0.0));
      // vertices of inverted hexes and of the hexes around them
      std::fill(sel.begin(), sel.end(), 0);
      for (Eigen::Index h = 0; h < H_.rows(); ++h)
        if (q[size_t(h)].corner_min <= 0)
          for (int k = 0; k < 8; ++k) {
            const int v = H_(h, k);
            for (int i = start_[size_t(v)]; i < start_[size_t(v) + 1]; ++i)
              for (int m = 0; m < 8; ++m) sel[size_t(H_(inc_[size_t(i)], m))] = 1;
          }
      ++st_.untangle_sweeps;
      ++st_.iterations;
      sweep(sel, [&](int v) {
        Terms base;
        WinslowTerms wbase;
        const int inv0 = local(v, &base).inverted;
        return descend(
            v, winslow_objective(v, eps, wbase), [&] { return local(v, nullptr, &base).inverted <= inv0; }, 0.5);
      });
    }
  }

  // (b) per-vertex max-min scaled Jacobian
  /// Sweeps over the vertices of hexes below `target_sj` until the global minimum stalls, then sweeps over
  /// those of the worst hexes only (below the minimum + 0.15: cheap sweeps, so many of them) until it
  /// stalls for 5 sweeps in a row.
  void maxmin() {
    PhaseTimer timer{st_.maxmin_seconds};
    double prev = -2;
    bool worst_only = false;
    // Hex qualities, kept up to date incrementally: all hexes first, then only those of the vertices the
    // previous sweep selected (the worst-only sweeps select a few hundred vertices of 100k+ hexes).
    std::vector<HexSJ> q(size_t(H_.rows()));
    std::vector<char> sel(size_t(V_.rows()), 1);
    for (int it = 0, stall = 0; it < 4 * p_.iterations && !out_of_time(); ++it) {
      refresh_quality(q, sel);
      std::fill(sel.begin(), sel.end(), 0);
      double gmin = 1;
      for (const HexSJ& x : q) gmin = std::min(gmin, x.sj);
      if (!worst_only && ((gmin <= prev + 1e-5 && it > 2) || it >= p_.iterations)) worst_only = true, stall = 0;
      if (worst_only) {
        stall = gmin <= prev + 1e-5 ? stall + 1 : 0;
        if (stall >= 5) break;
      }
      const double below = worst_only ? std::min(p_.target_sj, gmin + 0.15) : p_.target_sj;
      for (Eigen::Index h = 0; h < H_.rows(); ++h)
        if (q[size_t(h)].sj < below)
          for (int k = 0; k < 8; ++k) sel[size_t(H_(h, k))] = 1;
      prev = std::max(prev, gmin);
      ++st_.maxmin_sweeps;
      ++st_.iterations;
      const long moved = sweep(
          sel, [&](int v) { return maxmin_step(v); }, true);
      if (moved == 0) {
        if (worst_only) break;
        worst_only = true, stall = 0;
      }
    }
  }

  /// One max-min step of vertex v: a descent on the soft minimum of its hexes' scaled Jacobians, kept only if
  /// their minimum rises and none inverts; interior vertices also try the average of their edge neighbours.
  bool maxmin_step(int v) {
    Terms base;
    const Local l0 = local(v, &base);
    // candidate: the average of the edge neighbours (interior vertices)
    Vec3 avg = Vec3::Zero();
    for (int w : nbr_[size_t(v)]) avg += V_.row(w).transpose();
    avg /= double(std::max<size_t>(nbr_[size_t(v)].size(), 1));
    // descend() judges a trial position right after evaluating the objective there: `ok` reads the
    // local measures of that same evaluation
    Local last{};
    auto ok = [&] { return last.inverted <= l0.inverted && last.sj_min > l0.sj_min + 1e-9; };
    return descend(
        v, [&] { return soft_min(v, last, base); }, ok, 0.2, boundary_[size_t(v)] ? nullptr : &avg);
  }

  // (b') element moves: the vertices of one poor hex move together towards the cube that best fits it
  // (least-squares similarity fit, Kabsch): two boundary vertices pressed together, or a hex squeezed
  // between two others, need several vertices to move at once, which (b) cannot do. Sequential, worst hex
  // first; a move is kept only if it raises the minimum scaled Jacobian of every hex around the moved
  // vertices taken together and inverts none.
  long elements() {
    PhaseTimer timer{st_.element_seconds};
    std::vector<std::pair<double, int>> poor;
    const auto q = all_quality();
    for (Eigen::Index h = 0; h < H_.rows(); ++h) {
      const double s = q[size_t(h)].sj;
      if (s < p_.target_sj) poor.emplace_back(s, int(h));
    }
    std::sort(poor.begin(), poor.end());
    static const std::array<Vec3, 8> ref = {Vec3(-.5, -.5, -.5), Vec3(.5, -.5, -.5), Vec3(.5, .5, -.5),
                                            Vec3(-.5, .5, -.5),  Vec3(-.5, -.5, .5), Vec3(.5, -.5, .5),
                                            Vec3(.5, .5, .5),    Vec3(-.5, .5, .5)};
    long moved = 0;
    for (const auto& [s0, h] : poor) {
      throw_if_interrupted();
      if (out_of_time()) break;
      const std::vector<int> region = hexes_around(H_.row(h).data(), 8);
      int inv0 = 0;
      const double m0 = min_sj(region, inv0);
      const std::array<Vec3, 8> P = points(h);
      Vec3 t = Vec3::Zero();
      for (const auto& x : P) t += x;
      t /= 8.0;
      Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
      for (int k = 0; k < 8; ++k) M += (P[size_t(k)] - t) * ref[size_t(k)].transpose();
      const Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
      Eigen::Vector3d d(1, 1, (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1 : 1);
      const Eigen::Matrix3d R = svd.matrixU() * d.asDiagonal() * svd.matrixV().transpose();
      const double scale = svd.singularValues().dot(d) / 6.0;  // sum of |ref|^2 = 8 * 3/4
      if (!(scale > 0)) continue;
      for (double lambda : {1.0, 0.5, 0.25}) {
        for (int k = 0; k < 8; ++k) {
          const int v = H_(h, k);
          if (!movable(v)) continue;
          const Vec3 c = scale * (R * ref[size_t(k)]) + t;
          V_.row(v) = project(v, P[size_t(k)] + lambda * (c - P[size_t(k)])).transpose();
        }
        int inv1 = 0;
        const double m1 = min_sj(region, inv1);
        if (inv1 <= inv0 && m1 > m0 + 1e-6) {
          ++moved;
          break;
        }
        for (int k = 0; k < 8; ++k) V_.row(H_(h, k)) = P[size_t(k)].transpose();
      }
    }
    st_.moves += moved;
    return moved;
  }

  // (b'') region smoothing: the interior vertices of the worst hexes and `global_rings` rings around them
  // move together by L-BFGS on the barrier Winslow energy (untangle_global.h smooth_region), then
  // max-min; kept only if the global minimum rises. For a patch of poor hexes where neither one vertex
  // nor one hex can move alone. Boundary vertices stay: the energy slid them across creases.
  void smooth_worst() {
    PhaseTimer timer{st_.smooth_seconds};
    for (int round = 0; round < p_.smooth_iterations && !out_of_time(); ++round) {
      // the shape improvement (the average) comes after: never spend more than half the budget before it
      if (elapsed() > 0.5 * p_.time_budget) break;
      double gmin = 1;
      const std::vector<char> seeds = seeds_near_minimum(0.05, HUGE_VAL, gmin);
      if (seeds.empty()) return;
      std::vector<char> surf, fixed;
      // the surface stays: sliding boundary vertices cut creases
      GlobalUntangleParams gp = descent_setup(true, surf, fixed);
      gp.polish_iterations = 200;
      const RowMatrixX3d keep = V_;
      GlobalUntangleStats gs;
      smooth_region(V_, H_, surf, fixed, tree_, normals_, seeds, gp, &gs);
      ++st_.smooth_rounds;
      maxmin();
      if (count_inverted() > 0 || sj_min() <= gmin + 1e-6) {
        V_ = keep;
        break;
      }
      ++st_.smooth_kept;
    }
  }

  /// Boundary vertices near a crease in the minimum ascent's reach (raise_min).
  struct NearCrease {
    std::vector<char> fixed;      ///< #V: `fixed`, and every surface vertex within half a hex edge of a crease
    std::vector<Vec3> along;      ///< #V: the direction a vertex may slide in (zero: none)
    std::vector<double> to_line;  ///< #V: a sliding vertex's distance to its line at the start
    std::vector<int> line;        ///< #V: its line, -1 if none
    long slides = 0;              ///< vertices that may slide

    /// `fixed` but for the vertices that may slide.
    std::vector<char> fixed_unless_sliding() const {
      std::vector<char> f = fixed;
      for (size_t v = 0; v < f.size(); ++v) f[v] = f[v] && along[v].isZero();
      return f;
    }
  };

  /// The surface vertices in `reach` within half a hex edge of a crease line stay (the ascent would slide
  /// them off it and leave the crease with no vertex); those near exactly one line, not near a crease corner,
  /// may slide parallel to it (its tangent there, in the vertex's tangent plane) where the line does not
  /// leave that plane steeply.
  NearCrease near_crease_slides(const std::vector<char>& fixed, const std::vector<char>& reach,
                                const std::vector<char>& surf) const {
    constexpr double kSteep = 0.5;  // the line's tangent keeps at least this much of its length in the plane
    const double near = 0.5 * crease_h_;
    NearCrease c;
    c.fixed = fixed;
    c.along.assign(fixed.size(), Vec3::Zero());
    c.to_line.assign(fixed.size(), 0.0);
    c.line.assign(fixed.size(), -1);
    tbb::parallel_for(size_t(0), fixed.size(), [&](size_t v) {
      if (fixed[v] || !reach[v] || !surf[v]) return;
      const Vec3 x = V_.row(Eigen::Index(v)).transpose();
      int lines = 0, which = -1;
      Vec3 tangent = Vec3::Zero();
      double d = 0;
      for (size_t l = 0; l < creases_.lines.size(); ++l) {
        Vec3 t;
        const double dl = (closest_on_line(creases_.lines[l], x, &t) - x).norm();
        if (dl >= near) continue;
        if (++lines == 1) which = int(l), tangent = t, d = dl;
      }
      if (lines == 0) return;
      c.fixed[v] = 1;
      if (lines > 1) return;
      for (const Vec3& k : creases_.corners)
        if ((k - x).norm() < near) return;
      const Vec3 n = normals_[size_t(tree_.closest(x).triangle)];
      const Vec3 in_plane = tangent - tangent.dot(n) * n;
      if (in_plane.norm() < kSteep) return;
      c.along[v] = in_plane.normalized();
      c.to_line[v] = d;
      c.line[v] = which;
    });
    for (const Vec3& a : c.along) c.slides += !a.isZero();
    return c;
  }

  /// A boundary vertex that slid across a crease (onto another face of the part) would cut it: it goes back
  /// to `keep`.
  void put_back_across_crease(const std::vector<char>& surf, const RowMatrixX3d& keep) {
    if (patch_.size() == 0) return;
    tbb::parallel_for(Eigen::Index(0), V_.rows(), [&](Eigen::Index v) {
      if (!surf[size_t(v)] || V_.row(v) == keep.row(v)) return;
      const int before = patch_[tree_.closest(keep.row(v).transpose()).triangle];
      if (patch_[tree_.closest(V_.row(v).transpose()).triangle] != before) V_.row(v) = keep.row(v);
    });
  }

  /// A sliding vertex that ended more than 0.05 hex edges farther from its crease line than it started
  /// (the projection bent its slide away) goes back to `keep`.
  void put_back_off_crease(const NearCrease& c, const RowMatrixX3d& keep) {
    tbb::parallel_for(Eigen::Index(0), V_.rows(), [&](Eigen::Index v) {
      const int l = c.line[size_t(v)];
      if (l < 0) return;
      const Vec3 x = V_.row(v).transpose();
      if ((closest_on_line(creases_.lines[size_t(l)], x) - x).norm() > c.to_line[size_t(v)] + 0.05 * crease_h_)
        V_.row(v) = keep.row(v);
    });
  }

  /// (d) the minimum ascent (raise_minimum) around the worst hexes, boundary vertices sliding on the surface
  /// (those within half a hex edge of a crease stay, or slide parallel to it); a round is kept only if it
  /// inverts nothing and raises the minimum.
  void raise_min() {
    PhaseTimer timer{st_.minimum_seconds};
    for (int round = 0; round < p_.minimum_rounds && p_.minimum_iterations > 0 && !out_of_time(); ++round) {
      // the poor hexes (as the max-min sweeps count them) near the minimum
      double gmin = 1;
      const std::vector<char> seeds = seeds_near_minimum(p_.minimum_band, p_.target_sj, gmin);
      if (seeds.empty()) return;
      std::vector<char> surf, fixed;
      GlobalUntangleParams gp = descent_setup(!p_.move_boundary, surf, fixed);
      // released vertices no farther off the surface, freed crease vertices (on a leash) no farther from it
      const std::vector<char> reach =
          cell_ring_region(H_, V_.rows(), p_.minimum_rings, [&](Eigen::Index h) { return seeds[size_t(h)] != 0; });
      tbb::parallel_for(size_t(0), fixed.size(), [&](size_t v) {
        fixed[v] |= released_[v] || (!leash_line_.empty() && (leash_line_[v] >= 0 || leash_corner_[v] >= 0));
      });
      // boundary vertices within half a hex edge of a crease stay, or slide parallel to it: sliding freely, the
      // ascent would move them off it and leave the crease with no vertex (the part's edge rounded)
      const NearCrease near = near_crease_slides(fixed, reach, surf);
      gp.rings = p_.minimum_rings;
      gp.polish_iterations = p_.minimum_iterations;
      const RowMatrixX3d keep = V_;
      ++st_.minimum_rounds;
      // one ascent from V_ = keep: the minimum it reaches (-1 with an inverted hex), or -2 when it did not run
      // (V_ left at keep)
      auto ascend = [&](bool slide) {
        static const std::vector<Vec3> kNone;
        if (!raise_minimum(V_, H_, surf, slide ? near.fixed_unless_sliding() : near.fixed, tree_, normals_, seeds,
                           MinimumAscentParams{}, gp, nullptr, slide ? near.along : kNone))
          return -2.0;
        put_back_across_crease(surf, keep);
        if (slide) put_back_off_crease(near, keep);
        return count_inverted() > 0 ? -1.0 : sj_min();
      };
      // with the near-crease vertices fixed, then (where any may slide) sliding, from the same start: the
      // higher minimum is kept, the fixed one on a tie
      double now = ascend(false);
      bool slid_kept = false;
      if (near.slides > 0) {
        const RowMatrixX3d fixed_result = V_;
        V_ = keep;
        const double slid = ascend(true);
        if (slid > now)
          now = slid, slid_kept = true;
        else
          V_ = fixed_result;
      }
      if (now == -2.0) return;
      if (now <= gmin + 1e-6) {
        V_ = keep;
        return;
      }
      // the shape sweeps again over the moved vertices and a ring around them: the ascent pays no heed to the
      // hexes above the minimum, the sweeps give them back their shape and never lower a local minimum
      std::vector<char> moved(size_t(V_.rows()), 0);
      for (Eigen::Index v = 0; v < V_.rows(); ++v) moved[size_t(v)] = V_.row(v) != keep.row(v);
      const std::vector<char> region =
          cell_ring_region(H_, V_.rows(), 1, [&](Eigen::Index h) { return has_flagged_vertex(h, moved); });
      shape_sweeps(&region);
      ++st_.minimum_kept;
      st_.minimum_slid += slid_kept;
      st_.minimum_gain += sj_min() - gmin;
    }
  }

  /// (c0) the global average ascent (raise_average), kept only if it inverts nothing, keeps the minimum and
  /// raises the average. Boundary vertices stay: the sweeps of (c) slide them (tangent moves across a crease
  /// cut it, as in smooth_worst).
  void average_global() {
    constexpr int kRevertRounds = 10;
    PhaseTimer timer{st_.average_seconds};
    if (p_.average_iterations <= 0 || out_of_time()) return;
    const auto q = all_quality();
    double min0 = 1, sum0 = 0;
    std::vector<char> seeds(size_t(H_.rows()), 0), surf, fixed;
    for (size_t h = 0; h < q.size(); ++h) {
      if (q[h].corner_min <= 0) return;  // the barrier needs an untangled mesh
      min0 = std::min(min0, q[h].sj);
      sum0 += q[h].sj;
      seeds[h] = q[h].sj < p_.average_below_sj;
    }
    GlobalUntangleParams gp = descent_setup(true, surf, fixed);
    gp.rings = p_.average_rings;
    gp.polish_iterations = p_.average_iterations;
    const AverageAscentParams a{p_.average_barrier, p_.average_tolerance, p_.average_work};
    const RowMatrixX3d keep = V_;
    if (!raise_average(V_, H_, surf, fixed, tree_, normals_, seeds, a, gp)) return;
    // true when a hex is inverted or below the old minimum, with their flags in `below`
    std::vector<char> below(size_t(H_.rows()), 0);
    auto fell = [&] {
      const auto now = all_quality();
      bool any = false;
      for (size_t h = 0; h < now.size(); ++h) any |= (below[h] = now[h].corner_min <= 0 || now[h].sj < min0);
      return any;
    };
    if (fell()) {
      if (count_inverted() == 0) maxmin();
      // still below: put back the vertices of the hexes below the old minimum and one ring around them,
      // adding to the set put back until none is below (a hex half put back can fall in its turn); all of
      // them if that does not do
      std::vector<char> back(size_t(V_.rows()), 0);
      for (int round = 0; round < kRevertRounds && fell(); ++round) {
        const auto ring = cell_ring_region(H_, V_.rows(), 1, [&](Eigen::Index h) { return below[size_t(h)] != 0; });
        for (size_t v = 0; v < back.size(); ++v)
          if (back[v] |= ring[v]) V_.row(Eigen::Index(v)) = keep.row(Eigen::Index(v));
      }
      if (fell()) {
        V_ = keep;
        return;
      }
    }
    double sum = 0;
    for (const HexSJ& x : all_quality()) sum += x.sj;
    if (sum <= sum0) {
      V_ = keep;
      return;
    }
    st_.average_kept = 1;
    st_.average_gain = (sum - sum0) / double(H_.rows());
  }

  // (c) global shape improvement: coordinate descent of the Winslow energy of the whole mesh, then of
  // the sum of the scaled Jacobians (the average the quality report measures); a move never lowers the
  // local minimum nor the local sum of the scaled Jacobians
  void shape() {
    PhaseTimer timer{st_.shape_seconds};  // the average ascent included
    average_global();
    shape_sweeps(nullptr);
  }

  /// True if a vertex of hex h is flagged in `flags` (#V).
  bool has_flagged_vertex(Eigen::Index h, const std::vector<char>& flags) const {
    for (int k = 0; k < 8; ++k)
      if (flags[size_t(H_(h, k))]) return true;
    return false;
  }

  /// The sweeps of (c), over the vertices of the hexes below shape_target_sj (and among them only those
  /// flagged in `only`, if given).
  void shape_sweeps(const std::vector<char>* only) {
    // the hexes whose average decides convergence: all, or those with a vertex in `only` (a region's gain
    // measured over the whole mesh would look converged after one pair of sweeps)
    std::vector<char> counted(size_t(H_.rows()), 1);
    if (only)
      for (Eigen::Index h = 0; h < H_.rows(); ++h) counted[size_t(h)] = has_flagged_vertex(h, *only);
    double last_avg = -2;
    for (int it = 0; it < p_.shape_iterations && !out_of_time(); ++it) {
      // vertices of hexes below shape_target_sj (a regular grid interior needs no work)
      std::vector<char> all(size_t(V_.rows()), 0);
      const auto q = all_quality();
      if (it % 2 == 0) {  // converged: a pair of sweeps (Winslow, sum of SJ) raised the average too little
        double sum = 0;
        long n = 0;
        for (size_t h = 0; h < q.size(); ++h)
          if (counted[h]) {
            sum += q[h].sj;
            ++n;
          }
        const double avg = n > 0 ? sum / double(n) : 0.0;
        if (avg - last_avg < p_.shape_tolerance) break;
        last_avg = avg;
      }
      for (Eigen::Index h = 0; h < H_.rows(); ++h)
        if (q[size_t(h)].sj < p_.shape_target_sj)
          for (int k = 0; k < 8; ++k) all[size_t(H_(h, k))] = 1;
      if (only)
        for (size_t v = 0; v < all.size(); ++v) all[v] &= (*only)[v];
      ++st_.shape_sweeps;
      ++st_.iterations;
      const bool winslow = it % 2 == 0;
      const long moved = sweep(all, [&](int v) {
        Terms base;
        const Local l0 = local(v, &base);
        auto better = [&](const Local& l) {
          return l.inverted <= l0.inverted && l.sj_min >= l0.sj_min && l.sj_sum >= l0.sj_sum;
        };
        if (winslow) {
          WinslowTerms wbase;
          return descend(
              v, winslow_objective(v, 1e-6, wbase), [&] { return better(local(v, nullptr, &base)); }, 0.2);
        }
        // as in maxmin: `ok` reads the local measures of the objective's evaluation at the same position
        Local last{};
        return descend(
            v,
            [&] {
              last = local(v, nullptr, &base);
              return -last.sj_sum;
            },
            [&] { return better(last); }, 0.2);
      });
      if (moved == 0 && !winslow) break;
    }
  }

  const OptimizeParams& p_;
  OptimizeStats& st_;
  RowMatrixX3d V_;
  const RowMatrixX8i& H_;
  TriangleTree tree_;
  Clock::time_point t0_;
  double diag_ = 1;
  std::vector<int> start_, inc_;
  std::vector<int> corner_;  ///< per incidence slot: the vertex's corner in the hex (-1: it is there twice)
  std::vector<std::vector<int>> nbr_;
  std::vector<double> scale_;
  std::vector<std::vector<int>> classes_;
  std::vector<char> boundary_;
  std::vector<char> released_;  ///< boundary vertices allowed off the surface (last-resort untangling)
  std::vector<double> cap_;     ///< after return_released: per released vertex, how far from the surface it may be
  SurfaceCreases creases_;      ///< the surface's sharp creases (feature_angle > 0)
  Eigen::VectorXi patch_;       ///< per surface triangle: its face between the creases (empty without creases
                                ///< or without the minimum ascent)
  double crease_h_ = 0;         ///< the hex edge the creases were found at
  CreaseSnap snap_;             ///< boundary vertices on them (empty vectors when off)
  std::vector<int> leash_line_, leash_corner_;  ///< per vertex: the crease line / corner a freed crease vertex
                                                ///< stays near, -1 none (free_padded_creases; empty when off)
  double leash_ = 0;                            ///< how near: kLeash hex edges
  std::vector<Vec3> normals_;
  // sweep()'s memory of failed steps (would_fail_again)
  long tick_ = 0;              ///< counts colour classes swept and note_changes calls
  std::vector<long> changed_;  ///< per vertex: the tick of its last change
  std::vector<long> failed_;   ///< per vertex: the tick of its last failed max-min step, -1 none
  RowMatrixX3d seen_V_;        ///< what note_changes compares against
  std::vector<char> seen_released_;
  std::vector<double> seen_cap_;
};

void summarise(const HexMesh& m, double& sj_min, double& sj_avg, long& inverted) {
  Eigen::VectorXd sj, corner;
  hex_scaled_jacobians(m, sj, corner);
  sj_min = sj.minCoeff();
  sj_avg = sj.mean();
  inverted = long((corner.array() <= 0).count());
}

}  // namespace

namespace {

/// The Winslow terms (fast cube root) of the kLanes corners ks of hex p, its edges over `scale`, into
/// terms[ks[l]], side by side in lanes.
void winslow_corners(const std::array<Eigen::Vector3d, 8>& p, const int* ks, double scale, double eps,
                     std::array<double, 8>& terms) {
  using optimize_detail::Lanes;
  Lanes J[3][3];
  for (int l = 0; l < optimize_detail::kLanes; ++l) {
    const auto& c = kCorners[ks[l]];
    for (int col = 0; col < 3; ++col)
      for (int i = 0; i < 3; ++i) J[i][col][l] = (p[size_t(c[col + 1])][i] - p[size_t(c[0])][i]) / scale;
  }
  const Lanes e = optimize_detail::winslow_term_of(J, eps, nullptr, optimize_detail::CubeRoot::fast);
  for (int l = 0; l < optimize_detail::kLanes; ++l) terms[size_t(ks[l])] = e[l];
}

double sum_of(const std::array<double, 8>& terms) {
  double e = 0;
  for (double t : terms) e += t;
  return e;
}

}  // namespace

double hex_winslow_energy(const std::array<Eigen::Vector3d, 8>& p, double scale, double eps) {
  std::array<double, 8> terms;
  return hex_winslow_energy(p, scale, eps, terms);
}

double hex_winslow_energy(const std::array<Eigen::Vector3d, 8>& p, double scale, double eps,
                          std::array<double, 8>& terms) {
  static_assert(optimize_detail::kLanes == 4, "a hex's corners go four to a Lanes");
  static constexpr int kAll[8] = {0, 1, 2, 3, 4, 5, 6, 7};
  winslow_corners(p, kAll, scale, eps, terms);
  winslow_corners(p, kAll + 4, scale, eps, terms);
  return sum_of(terms);
}

double hex_winslow_energy_moved(const std::array<Eigen::Vector3d, 8>& p, int j, double scale, double eps,
                                const std::array<double, 8>& before, std::array<double, 8>& terms) {
  terms = before;
  winslow_corners(p, kCorners[j], scale, eps, terms);  // the corners whose frames use corner j
  return sum_of(terms);
}

HexMesh optimize_hexes(const HexMesh& mesh, const SurfaceMesh& surface, const OptimizeParams& p, OptimizeStats* stats) {
  return optimize_hexes_or_fallback(mesh, nullptr, surface, p, stats);
}

bool better_result(const OptimizeStats& a, const OptimizeStats& b) {
  if (a.inverted_after != b.inverted_after) return a.inverted_after < b.inverted_after;
  return a.sj_min_after > b.sj_min_after;
}

HexMesh optimize_hexes_or_fallback(const HexMesh& mesh, const HexMesh* fallback, const SurfaceMesh& surface,
                                   const OptimizeParams& p, OptimizeStats* stats, FallbackOutcome* outcome,
                                   const ProgressFn& progress) {
  // The phases' shares of the bar: the shape improvement takes about 2/3 of the stage on the built-in
  // shapes, a second or third candidate as long as the first's untangling and max-min.
  auto report = [&](double fraction, const char* what) {
    if (progress) progress(fraction, what);
  };
  // Every candidate goes through (a)-(b''); the shape improvement (c), which never lowers the minimum nor
  // un-inverts, runs on the best one only. The first is the mesh with its boundary on the surface, the
  // vertices the lattice put on the creases kept there (keep_creases); if its result is poor, the same mesh
  // with paths of boundary edges put on the crease lines (feature_angle), then the fallback mesh.
  const auto t0 = Clock::now();
  check_hex_mesh(mesh);
  struct Candidate {
    const HexMesh* mesh = nullptr;
    OptimizeStats st;  // the Optimizer keeps a reference: candidates live in a deque
    std::unique_ptr<Optimizer> opt;
    double seconds = 0;  // its own time (its shape pass included if kept)
  };
  std::deque<Candidate> cands;
  auto prepare = [&](Candidate& c, const HexMesh& m, Optimizer::Creases creases) {
    const auto tc = Clock::now();
    check_hex_mesh(m);
    c.mesh = &m;
    summarise(m, c.st.sj_min_before, c.st.sj_avg_before, c.st.inverted_before);
    c.opt = std::make_unique<Optimizer>(m, surface, p, creases, c.st);
    c.seconds = seconds_since(tc);
  };
  auto improve = [&](Candidate& c) {
    const auto tc = Clock::now();
    c.opt->improve();
    c.st.inverted_after = c.opt->inverted_now();
    c.st.sj_min_after = c.opt->min_now();
    c.seconds += seconds_since(tc);
  };
  const auto first = p.keep_creases ? Optimizer::Creases::at_vertices : Optimizer::Creases::none;
  report(0, "untangling, max-min");
  prepare(cands.emplace_back(), mesh, first);
  improve(cands[0]);
  const bool poor = cands[0].st.inverted_after > 0 || cands[0].st.sj_min_after < p.fallback_below_sj;
  // The crease and fallback candidates are independent: they run side by side (each is deterministic on its
  // own, and the choice below reads them in this order, so the result does not depend on the threads).
  // Their slots are made first: a deque's elements stay where they are as it grows.
  Candidate* creases = poor && p.feature_angle > 0 && p.move_boundary ? &cands.emplace_back() : nullptr;
  Candidate* fb = poor && fallback ? &cands.emplace_back() : nullptr;
  auto run_creases = [&] {
    prepare(*creases, mesh, Optimizer::Creases::paths);
    if (creases->st.crease_lines_snapped > 0)
      improve(*creases);
    else
      creases->opt.reset();  // no crease line to follow: the same as the first
  };
  auto run_fallback = [&] {
    prepare(*fb, *fallback, first);
    improve(*fb);
  };
  if (creases || fb)
    report(0.2, creases && fb ? "candidates with crease lines, fallback"
                : creases     ? "candidate with crease lines"
                              : "fallback candidate");
  if (creases && fb)
    tbb::parallel_invoke(run_creases, run_fallback);
  else if (creases)
    run_creases();
  else if (fb)
    run_fallback();
  Candidate* best = &cands[0];
  for (Candidate& c : cands)
    if (c.opt && better_result(c.st, best->st)) best = &c;
  const auto tf = Clock::now();
  report(0.33, "shape improvement");
  HexMesh out = best->opt->finish(best->mesh->source);
  summarise(out, best->st.sj_min_after, best->st.sj_avg_after, best->st.inverted_after);
  best->seconds += seconds_since(tf);
  best->st.seconds = seconds_since(t0);  // the whole stage
  if (stats) *stats = best->st;
  if (outcome) {
    *outcome = FallbackOutcome{};
    outcome->ran = fb != nullptr;
    outcome->kept = fb != nullptr && best == fb;
    if (fb) outcome->stats = fb->st, outcome->stats.seconds = fb->seconds;
    outcome->creases_ran = creases != nullptr && creases->opt != nullptr;
    outcome->creases_kept = creases != nullptr && best == creases;
    if (outcome->creases_ran) outcome->creases_stats = creases->st, outcome->creases_stats.seconds = creases->seconds;
  }
  return out;
}

}  // namespace polyhex
