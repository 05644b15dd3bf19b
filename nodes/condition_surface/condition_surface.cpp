#include "nodes/condition_surface/condition_surface.h"

#include "nodes/algorithms/hex_quality.h"
#include "nodes/algorithms/reference_length.h"
#include "nodes/condition_surface/surface_ops.h"
#include "nodes/formats/surface_io.h"
#include "runtime/cancel.h"
#include "runtime/errors.h"
#include "runtime/union_find.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <numeric>
#include <optional>
#include <set>

namespace polyhex {
namespace {

using Vec3 = Eigen::Vector3d;

Vec3 corner(const SurfaceMesh& s, Eigen::Index f, int k) { return s.V.row(s.F(f, k)).transpose(); }

bool zero_area(const SurfaceMesh& s, Eigen::Index f) {
  const Vec3 p0 = corner(s, f, 0), p1 = corner(s, f, 1), p2 = corner(s, f, 2);
  const double e = std::max({(p1 - p0).squaredNorm(), (p2 - p1).squaredNorm(), (p0 - p2).squaredNorm()});
  // The same test as the surface reader's: zero area up to rounding.
  return (p1 - p0).cross(p2 - p0).norm() <= 1e-12 * e;
}

bool repeated_index(const SurfaceMesh& s, Eigen::Index f) {
  return s.F(f, 0) == s.F(f, 1) || s.F(f, 1) == s.F(f, 2) || s.F(f, 0) == s.F(f, 2);
}

// The edge structure of a triangle set: which triangles count (not degenerate, not a duplicate),
// their undirected edges, the manifold neighbours, the fans around each vertex and a consistent
// orientation where one exists.
struct Topology {
  std::vector<char> used;  // #F: the triangle takes part (not degenerate, first of its duplicates)
  long degenerate = 0, duplicates = 0;
  long boundary_edges = 0, nonmanifold_edges = 0;
  std::vector<std::pair<int, int>> boundary;  // boundary edges (vertex pairs)
  std::vector<int> nb;                        // #F*3: opposite half-edge across a manifold edge, -1 otherwise
  std::vector<int> fan;                       // #F*3: fan id of every corner (union over manifold edges)
  std::vector<char> flip;                     // #F: flip to orient consistently
  bool orientable = true;
  long components = 0;

  explicit Topology(const SurfaceMesh& s) {
    const Eigen::Index nf = s.F.rows();
    used.assign(size_t(nf), 1);
    std::vector<std::array<int, 4>> keys;  // sorted vertices + face, for duplicates
    keys.reserve(size_t(nf));
    for (Eigen::Index f = 0; f < nf; ++f) {
      if (repeated_index(s, f) || zero_area(s, f)) {
        used[size_t(f)] = 0;
        ++degenerate;
        continue;
      }
      std::array<int, 4> k = {s.F(f, 0), s.F(f, 1), s.F(f, 2), int(f)};
      std::sort(k.begin(), k.begin() + 3);
      keys.push_back(k);
    }
    std::sort(keys.begin(), keys.end());
    for (size_t i = 1; i < keys.size(); ++i)
      if (std::equal(keys[i].begin(), keys[i].begin() + 3, keys[i - 1].begin())) {
        used[size_t(keys[i][3])] = 0;
        ++duplicates;
      }

    struct HalfEdge {
      uint64_t key;
      int he;
    };
    std::vector<HalfEdge> h;
    h.reserve(size_t(3 * nf));
    for (Eigen::Index f = 0; f < nf; ++f) {
      if (!used[size_t(f)]) continue;
      for (int k = 0; k < 3; ++k) {
        const uint32_t a = uint32_t(s.F(f, k)), b = uint32_t(s.F(f, (k + 1) % 3));
        h.push_back({(uint64_t(std::min(a, b)) << 32) | std::max(a, b), int(3 * f + k)});
      }
    }
    std::sort(h.begin(), h.end(),
              [](const HalfEdge& x, const HalfEdge& y) { return x.key != y.key ? x.key < y.key : x.he < y.he; });
    nb.assign(size_t(3 * nf), -1);
    UnionFind faces{size_t(nf)};
    for (size_t i = 0; i < h.size();) {
      // the run of half-edges on one edge; their triangles are connected
      size_t j = i + 1;
      for (; j < h.size() && h[j].key == h[i].key; ++j) faces.unite(h[i].he / 3, h[j].he / 3);
      if (j - i == 1) {
        ++boundary_edges;
        boundary.emplace_back(int(h[i].key >> 32), int(h[i].key & 0xffffffffu));
      } else if (j - i == 2) {
        nb[size_t(h[i].he)] = h[i + 1].he;
        nb[size_t(h[i + 1].he)] = h[i].he;
      } else {
        ++nonmanifold_edges;
      }
      i = j;
    }
    std::set<int> roots;
    for (Eigen::Index f = 0; f < nf; ++f)
      if (used[size_t(f)]) roots.insert(faces.find(int(f)));
    components = long(roots.size());

    // Fans: corners of two triangles that share a manifold edge are joined at both edge ends.
    UnionFind corners{size_t(3 * nf)};
    for (Eigen::Index he = 0; he < 3 * nf; ++he) {
      const int o = nb[size_t(he)];
      if (o < he) continue;
      const int f1 = int(he / 3), k1 = int(he % 3), f2 = o / 3, k2 = o % 3;
      const bool same = s.F(f1, k1) == s.F(f2, k2);
      corners.unite(3 * f1 + k1, 3 * f2 + (same ? k2 : (k2 + 1) % 3));
      corners.unite(3 * f1 + (k1 + 1) % 3, 3 * f2 + (same ? (k2 + 1) % 3 : k2));
    }
    fan.assign(size_t(3 * nf), -1);
    for (Eigen::Index c = 0; c < 3 * nf; ++c)
      if (used[size_t(c / 3)]) fan[size_t(c)] = corners.find(int(c));

    // Consistent orientation over the manifold edges (BFS, flips differ across an edge that both
    // triangles run the same way).
    flip.assign(size_t(nf), 0);
    std::vector<char> seen(size_t(nf), 0);
    std::vector<int> queue;
    for (Eigen::Index seed = 0; seed < nf; ++seed) {
      if (seen[size_t(seed)] || !used[size_t(seed)]) continue;
      seen[size_t(seed)] = 1;
      queue.assign(1, int(seed));
      for (size_t q = 0; q < queue.size(); ++q) {
        const int f = queue[q];
        for (int k = 0; k < 3; ++k) {
          const int o = nb[size_t(3 * f + k)];
          if (o < 0) continue;
          const int g = o / 3;
          const bool same = s.F(f, k) == s.F(g, o % 3);
          const char want = char(flip[size_t(f)] ^ (same ? 1 : 0));
          if (!seen[size_t(g)]) {
            seen[size_t(g)] = 1;
            flip[size_t(g)] = want;
            queue.push_back(g);
          } else if (flip[size_t(g)] != want) {
            orientable = false;
          }
        }
      }
    }
  }

  // Vertices whose corners lie in more than one fan: vertex -> its fan ids.
  std::vector<std::vector<int>> pinches(const SurfaceMesh& s) const {
    std::vector<std::vector<int>> out(size_t(s.V.rows()));
    for (size_t c = 0; c < fan.size(); ++c) {
      if (fan[c] < 0) continue;
      auto& list = out[size_t(s.F(Eigen::Index(c / 3), int(c % 3)))];
      if (std::find(list.begin(), list.end(), fan[c]) == list.end()) list.push_back(fan[c]);
    }
    return out;
  }
};

std::string count_text(long n, const char* one, const char* many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

std::string fixed(double x, int digits = 2) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, x);
  return buf;
}

// The surface without the triangles that do not take part, with unused vertices dropped.
SurfaceMesh compact(const SurfaceMesh& s, const std::vector<char>& keep) {
  std::vector<int> map(size_t(s.V.rows()), -1);
  long nf = 0;
  for (Eigen::Index f = 0; f < s.F.rows(); ++f)
    if (keep[size_t(f)]) {
      ++nf;
      for (int k = 0; k < 3; ++k) map[size_t(s.F(f, k))] = 0;
    }
  int nv = 0;
  for (int& m : map)
    if (m == 0) m = nv++;
  SurfaceMesh out;
  out.source = s.source;
  out.V.resize(nv, 3);
  for (size_t v = 0; v < map.size(); ++v)
    if (map[v] >= 0) out.V.row(map[v]) = s.V.row(Eigen::Index(v));
  out.F.resize(nf, 3);
  Eigen::Index r = 0;
  for (Eigen::Index f = 0; f < s.F.rows(); ++f)
    if (keep[size_t(f)]) {
      for (int k = 0; k < 3; ++k) out.F(r, k) = map[size_t(s.F(f, k))];
      ++r;
    }
  return out;
}

// Collapses the shortest edge of every zero-area triangle (a needle's short edge, a cap's vertex onto
// an end of the edge it lies on), until none is left or `rounds` passes.
long collapse_degenerate(SurfaceMesh& s, int rounds) {
  long collapsed = 0;
  for (int round = 0; round < rounds; ++round) {
    UnionFind uf(size_t(s.V.rows()));
    bool any = false;
    std::vector<char> touched(size_t(s.V.rows()), 0);
    for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
      if (repeated_index(s, f) || !zero_area(s, f)) continue;
      int best = 0;
      double len = INFINITY;
      for (int k = 0; k < 3; ++k) {
        const double l = (corner(s, f, k) - corner(s, f, (k + 1) % 3)).squaredNorm();
        if (l < len) len = l, best = k;
      }
      const int a = s.F(f, best), b = s.F(f, (best + 1) % 3);
      if (touched[size_t(a)] || touched[size_t(b)]) continue;  // one collapse per vertex and round
      touched[size_t(a)] = touched[size_t(b)] = 1;
      uf.unite(b, a);
      ++collapsed;
      any = true;
    }
    if (!any) break;
    for (Eigen::Index i = 0; i < s.F.size(); ++i) s.F.data()[i] = uf.find(s.F.data()[i]);
  }
  return collapsed;
}

// One vertex per fan at every pinch point, each copy moved a tenth of the way to the centroid of
// its fan's other vertices (into its own solid), so the parts that met at the point come apart.
int split_pinches(SurfaceMesh& s, const Topology& topo) {
  const auto fans = topo.pinches(s);
  int split = 0;
  std::vector<std::pair<int, int>> new_vertex;  // (old vertex, fan) for each copy
  std::vector<int> copy_of_corner(size_t(3 * s.F.rows()), -1);
  for (size_t c = 0; c < topo.fan.size(); ++c) {
    if (topo.fan[c] < 0) continue;
    const int v = s.F(Eigen::Index(c / 3), int(c % 3));
    const auto& list = fans[size_t(v)];
    if (list.size() < 2) continue;
    const size_t which = size_t(std::find(list.begin(), list.end(), topo.fan[c]) - list.begin());
    if (which == 0) continue;  // the first fan keeps the vertex
    auto it = std::find(new_vertex.begin(), new_vertex.end(), std::make_pair(v, topo.fan[c]));
    if (it == new_vertex.end()) {
      new_vertex.emplace_back(v, topo.fan[c]);
      it = new_vertex.end() - 1;
    }
    copy_of_corner[c] = int(s.V.rows()) + int(it - new_vertex.begin());
  }
  for (const auto& list : fans) split += list.size() > 1 ? 1 : 0;
  if (split == 0) return 0;
  const Eigen::Index nv0 = s.V.rows();
  RowMatrixX3d V(nv0 + Eigen::Index(new_vertex.size()), 3);
  V.topRows(nv0) = s.V;
  for (size_t i = 0; i < new_vertex.size(); ++i) V.row(nv0 + Eigen::Index(i)) = s.V.row(new_vertex[i].first);
  // Centroid of each fan's ring, for every (vertex, fan) at a pinch; the first fan moves too.
  std::vector<Vec3> ring_sum(size_t(V.rows()), Vec3::Zero());
  std::vector<int> ring_n(size_t(V.rows()), 0);
  for (size_t c = 0; c < topo.fan.size(); ++c) {
    if (topo.fan[c] < 0) continue;
    const Eigen::Index f = Eigen::Index(c / 3);
    const int k = int(c % 3), v = s.F(f, k);
    if (fans[size_t(v)].size() < 2) continue;
    const int target = copy_of_corner[c] >= 0 ? copy_of_corner[c] : v;
    for (int d = 1; d <= 2; ++d) {
      ring_sum[size_t(target)] += corner(s, f, (k + d) % 3);
      ++ring_n[size_t(target)];
    }
  }
  for (size_t c = 0; c < copy_of_corner.size(); ++c)
    if (copy_of_corner[c] >= 0) s.F(Eigen::Index(c / 3), int(c % 3)) = copy_of_corner[c];
  for (Eigen::Index v = 0; v < V.rows(); ++v)
    if (ring_n[size_t(v)] > 0) {
      const Vec3 centre = ring_sum[size_t(v)] / ring_n[size_t(v)];
      V.row(v) += 0.1 * (centre.transpose() - V.row(v));
    }
  s.V = std::move(V);
  return split;
}

const char* repair_name(SurfaceRepair r) {
  switch (r) {
    case SurfaceRepair::local:
      return "local";
    case SurfaceRepair::levelset:
      return "levelset";
    case SurfaceRepair::alpha_wrap:
      return "alpha_wrap";
    default:
      return "auto";
  }
}

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + v[i];
  return s;
}

// The local repair: degenerate and duplicate triangles, pinch points, small holes, orientation.
// Returns the surface (possibly still defective: the caller diagnoses it).
SurfaceMesh local_repair(const SurfaceMesh& s, double max_hole, ConditionReport& report) {
  SurfaceMesh m = s;
  collapse_degenerate(m, 8);
  {
    const Topology t(m);
    m = compact(m, t.used);  // degenerate (repeated index after the collapses) and duplicate triangles
  }
  Topology t(m);
  if (t.nonmanifold_edges > 0 || !t.orientable) return m;
  report.pinches_split = split_pinches(m, t);
  if (report.pinches_split > 0) t = Topology(m);
  if (t.boundary_edges > 0) {
    for (Eigen::Index f = 0; f < m.F.rows(); ++f)
      if (t.flip[size_t(f)]) std::swap(m.F(f, 1), m.F(f, 2));
    m = fill_small_holes(m, max_hole, report.holes_filled);
  }
  return m;
}

}  // namespace

bool SurfaceDiagnosis::defective() const { return !defects().empty(); }

std::vector<std::string> SurfaceDiagnosis::defects() const {
  std::vector<std::string> d;
  if (boundary_loops > 0)
    d.push_back(count_text(boundary_loops, "open boundary loop", "open boundary loops") + " (" +
                count_text(boundary_edges, "edge", "edges") + ", the longest " + std::to_string(longest_loop_edges) +
                " edges, " + fixed(longest_loop_length) + " hex edges long)");
  if (nonmanifold_edges > 0) d.push_back(count_text(nonmanifold_edges, "non-manifold edge", "non-manifold edges"));
  if (nonmanifold_vertices > 0)
    d.push_back(count_text(nonmanifold_vertices, "pinch vertex", "pinch vertices") + " (non-manifold)");
  if (duplicate_faces > 0) d.push_back(count_text(duplicate_faces, "duplicate triangle", "duplicate triangles"));
  if (degenerate_faces > 0) d.push_back(count_text(degenerate_faces, "degenerate triangle", "degenerate triangles"));
  if (self_intersections > 0)
    d.push_back(count_text(self_intersections, "self-intersecting triangle pair", "self-intersecting triangle pairs"));
  if (!orientable) d.push_back("not orientable");
  if (boundary_loops == 0 && nonmanifold_edges == 0 && orientable && !(volume > 1e-9))
    d.push_back("encloses no volume");
  return d;
}

SurfaceDiagnosis diagnose_surface(const SurfaceMesh& s, double hex_edge, double tet_edge) {
  SurfaceDiagnosis d;
  d.vertices = s.V.rows();
  d.faces = s.F.rows();
  const Topology t(s);
  d.degenerate_faces = t.degenerate;
  d.duplicate_faces = t.duplicates;
  d.boundary_edges = t.boundary_edges;
  d.nonmanifold_edges = t.nonmanifold_edges;
  d.orientable = t.orientable;
  d.components = t.components;
  for (const auto& fans : t.pinches(s)) d.nonmanifold_vertices += fans.size() > 1 ? 1 : 0;

  // Boundary loops: connected sets of boundary edges.
  if (!t.boundary.empty()) {
    UnionFind uf(size_t(s.V.rows()));
    for (auto [a, b] : t.boundary) uf.unite(a, b);
    std::vector<long> edges(size_t(s.V.rows()), 0);
    std::vector<double> length(size_t(s.V.rows()), 0);
    for (auto [a, b] : t.boundary) {
      const int r = uf.find(a);
      ++edges[size_t(r)];
      length[size_t(r)] += (s.V.row(a) - s.V.row(b)).norm();
    }
    for (size_t r = 0; r < edges.size(); ++r)
      if (edges[r] > 0) {
        ++d.boundary_loops;
        if (length[r] > d.longest_loop_length * hex_edge) {
          d.longest_loop_length = length[r] / hex_edge;
          d.longest_loop_edges = edges[r];
        }
      }
  }

  // Area, slivers, the tessellation ratio, the oriented volume.
  double area = 0, forced = 0, vol = 0;
  const Eigen::RowVector3d c = s.V.rows() ? Eigen::RowVector3d(s.V.colwise().mean()) : Eigen::RowVector3d::Zero();
  for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
    if (!t.used[size_t(f)]) continue;
    const Vec3 p0 = corner(s, f, 0), p1 = corner(s, f, 1), p2 = corner(s, f, 2);
    const double a = 0.5 * (p1 - p0).cross(p2 - p0).norm();
    const double l0 = (p1 - p0).norm(), l1 = (p2 - p1).norm(), l2 = (p0 - p2).norm();
    const double longest = std::max({l0, l1, l2});
    const double altitude = std::min(2 * a / longest, tet_edge);
    area += a;
    forced += a / (altitude * altitude);
    // smallest angle, opposite the shortest edge: sin = 2a / (product of the two other edges)
    const double shortest = std::min({l0, l1, l2});
    const double others = l0 * l1 * l2 / shortest;
    if (2 * a / others < std::sin(M_PI / 180)) ++d.sliver_faces;
    Vec3 q0 = p0 - c.transpose(), q1 = p1 - c.transpose(), q2 = p2 - c.transpose();
    if (t.flip[size_t(f)]) std::swap(q1, q2);
    vol += q0.dot(q1.cross(q2)) / 6.0;
  }
  d.area = area / (hex_edge * hex_edge);
  // A tessellation at the tet size forces area / (sqrt(3)/4 h^2) triangles of 1/sqrt(3) each.
  d.tessellation_ratio = area > 0 ? std::sqrt(forced / (4.0 * area / (3.0 * tet_edge * tet_edge))) : 0;
  const Eigen::RowVector3d ext =
      s.V.rows() ? Eigen::RowVector3d(s.V.colwise().maxCoeff() - s.V.colwise().minCoeff()) : Eigen::RowVector3d::Zero();
  const double box = ext.prod();
  d.volume = box > 0 ? std::abs(vol) / box : 0;
  d.thickness = area > 0 ? 4 * std::abs(vol) / area / hex_edge : 0;
  if (t.nonmanifold_edges == 0 && t.boundary_edges == 0 && t.degenerate == 0 && t.duplicates == 0 &&
      d.nonmanifold_vertices == 0)
    d.self_intersections = count_self_intersections(s);
  else
    d.self_intersections = count_self_intersections(compact(s, t.used));
  return d;
}

namespace {

/// Whether the surface is remeshed to size.
bool too_fine(const ConditionParams& p, const SurfaceDiagnosis& d) {
  return p.remesh == RemeshWhen::always ||
         (p.remesh == RemeshWhen::finer && d.tessellation_ratio > p.remesh_finer_than);
}

/// One conditioning run: the input, its sizes, the surface being repaired (m) and what was done to it.
class Conditioner {
 public:
  Conditioner(const SurfaceMesh& s, SurfaceRepair repair, const ConditionParams& p, ConditionReport& report,
              double diag)
      : s_(s),
        name_(s.source),
        repair_(repair),
        p_(p),
        report_(report),
        H_(p.hex_edge_length * diag),
        T_(p.edge_length * diag),
        m_(s) {}

  /// The conditioned surface for a defective or too finely tessellated input (condition_surface's
  /// steps after the diagnosis). \throw InvalidInput as condition_surface documents
  SurfaceMesh run(const std::vector<std::string>& defects) {
    if (!defects.empty()) repair_defects(defects);
    // A wrap is remeshed too: its triangles follow the wrapping, not the size the tets need.
    if (!report_.remeshed && (defects.empty() || report_.repair == "alpha_wrap" || too_fine(p_, *current_)) &&
        !remesh_to_size())
      report_.warnings.push_back(name_ +
                                 ": remeshing to size leaves crossing triangles down to half the tet "
                                 "edge: the surface keeps its own tessellation");
    report_.output = current_ ? *current_ : report_.input;  // no diagnosis: m is still the input
    if (report_.output.defective())
      throw InvalidInput(
          name_ + ": " + (defects.empty() ? std::string("remeshing to size") : join(defects) + ": " + how_) +
          (report_.remeshed ? " and remeshing to size" : "") + " leaves " + join(report_.output.defects()));
    SurfaceReadReport oriented;
    check_and_repair_surface(m_, name_, oriented);
    check_thickness(defects);
    report_cost(defects);
    return std::move(m_);
  }

 private:
  /// Remeshing to size. Triangles of the tet size can cross where two parts of the surface come closer
  /// than that (a level set's narrow gaps, thin plates): then finer targets, down to half. Returns
  /// false, leaving m as it was, when every target leaves a defect.
  bool remesh_to_size() {
    for (double target = T_; target > T_ / 2.1; target /= std::sqrt(2.0)) {
      SurfaceMesh r = isotropic_remesh(m_, target, p_.feature_angle, p_.remesh_iterations, report_.feature_edges);
      throw_if_interrupted();
      SurfaceDiagnosis d = diagnose_surface(r, H_, T_);
      if (!d.defective()) {
        current_ = std::move(d);
        report_.remesh_edge = target / T_;
        report_.remeshed = true;
        m_ = std::move(r);
        return true;
      }
    }
    return false;
  }

  /// One repair of the input; true when it leaves a clean surface. A level set is remeshed at once (its
  /// output is at voxel size and may carry zero-area triangles).
  bool attempt(SurfaceRepair r) {
    report_.repair = repair_name(r);
    report_.remeshed = false;
    current_.reset();
    try {
      if (r == SurfaceRepair::local) {
        m_ = local_repair(s_, p_.max_hole_perimeter * H_, report_);
        how_ = "local repair (" + std::to_string(report_.input.degenerate_faces + report_.input.duplicate_faces) +
               " degenerate or duplicate triangles removed, " + std::to_string(report_.pinches_split) +
               " pinch vertices split, " + std::to_string(report_.holes_filled) + " holes filled)";
      } else if (r == SurfaceRepair::levelset) {
        m_ = levelset_remesh(s_, p_.voxel * H_);
        how_ = "OpenVDB level set at voxel " + fixed(p_.voxel) + " hex edges";
        if (!remesh_to_size()) {
          how_ += ": remeshing it to size leaves crossing triangles down to half the tet edge";
          return false;
        }
      } else {
        m_ = alpha_wrap(s_, p_.alpha * H_, p_.offset * H_);
        how_ = "CGAL alpha wrap (alpha " + fixed(p_.alpha) + ", offset " + fixed(p_.offset) + " hex edges)";
      }
    } catch (const InvalidInput& e) {
      how_ = e.what();
      return false;
    }
    throw_if_interrupted();
    if (!current_) current_ = diagnose_surface(m_, H_, T_);  // the level set's remesh diagnosed it already
    return !current_->defective();
  }

  /// The repairs of the variant in turn (auto: local, then the level set for a closed input, then the
  /// alpha wrap, which also takes what the level set could not mend: it cannot leave crossings) until
  /// one leaves a clean surface. \throw InvalidInput when none does
  void repair_defects(const std::vector<std::string>& defects) {
    std::vector<SurfaceRepair> order = {repair_};
    if (repair_ == SurfaceRepair::automatic) {
      order = {SurfaceRepair::local, SurfaceRepair::alpha_wrap};
      if (report_.input.boundary_edges == 0) order.insert(order.begin() + 1, SurfaceRepair::levelset);
    }
    std::vector<std::string> failed;
    bool clean = false;
    for (SurfaceRepair r : order) {
      if ((clean = attempt(r))) break;
      failed.push_back(report_.repair + ": " +
                       (current_ && current_->defective() ? "leaves " + join(current_->defects()) : how_));
    }
    if (!clean)
      throw InvalidInput(name_ + ": " + join(defects) + "; no repair leaves a clean surface (" + join(failed) + ")" +
                         (repair_ == SurfaceRepair::automatic ? "" : "; variant condition_surface/auto tries more"));
    for (const std::string& f : failed) report_.warnings.push_back(name_ + ": tried " + f);
  }

  /// \throw InvalidInput when the result encloses a solid thinner than min_thickness hex edges
  void check_thickness(const std::vector<std::string>& defects) const {
    const double thickness = report_.output.thickness;
    if (thickness < p_.min_thickness)
      throw InvalidInput(name_ + ": " +
                         (defects.empty() ? std::string("the surface") : "the " + report_.repair + " repair") +
                         " encloses a solid thinner than a hex edge (4 volume / area = " + fixed(thickness, 3) +
                         " hex edges, min_thickness " + fixed(p_.min_thickness) + "): nothing to mesh with hexes");
  }

  /// How far the result strays from the input, bounded (nothing made up far from it) and reported as
  /// the warning's cost. The other way is reported only: a union drops the parts of the input inside
  /// it, and the local repair's fills are bounded by max_hole_perimeter instead.
  /// \throw InvalidInput beyond max_deviation
  void report_cost(const std::vector<std::string>& defects) {
    const SurfaceDistance dist = sampled_surface_distance(s_.V, s_.F, m_.V, m_.F, 20000, 1);
    report_.deviation_from_original = dist.max_ab / H_;
    report_.deviation_to_original = dist.max_ba / H_;
    if (report_.repair != "local" && report_.deviation_to_original > p_.max_deviation)
      throw InvalidInput(name_ + ": the " + (defects.empty() ? std::string("remeshed") : report_.repair + " repaired") +
                         " surface strays " + fixed(report_.deviation_to_original) +
                         " hex edges from the original, more than max_deviation " + fixed(p_.max_deviation));
    const std::string cost = "the result is within " + fixed(report_.deviation_to_original) +
                             " hex edges of the original (mean " + fixed(dist.mean_ba / H_, 3) +
                             "), the original within " + fixed(report_.deviation_from_original) +
                             " of the result (mean " + fixed(dist.mean_ab / H_, 3) + "); " +
                             std::to_string(s_.F.rows()) + " -> " + std::to_string(m_.F.rows()) + " triangles";
    if (!defects.empty())
      report_.warnings.push_back(
          name_ + ": " + join(defects) + ": repaired by " + how_ +
          (report_.remeshed ? ", then remeshed to " + fixed(report_.remesh_edge) + " tet edges" : "") + ": " + cost);
    else
      report_.warnings.push_back(name_ + ": tessellation " + fixed(report_.input.tessellation_ratio, 1) +
                                 " times finer than the tet size: remeshed to " + fixed(report_.remesh_edge) +
                                 " tet edges (CGAL isotropic remeshing, " + std::to_string(report_.feature_edges) +
                                 " sharp edges kept): " + cost);
  }

  const SurfaceMesh& s_;
  const std::string& name_;
  const SurfaceRepair repair_;
  const ConditionParams& p_;
  ConditionReport& report_;
  const double H_, T_;  ///< hex and tet edge, absolute
  SurfaceMesh m_;       ///< the surface as repaired so far
  std::string how_;     ///< what the last repair did, or why it failed
  /// The diagnosis of m_ as it stands, when it has one (each runs CGAL's self-intersection test: once
  /// per mesh).
  std::optional<SurfaceDiagnosis> current_;
};

}  // namespace

SurfaceMesh condition_surface(const SurfaceMesh& s, SurfaceRepair repair, const ConditionParams& p,
                              ConditionReport& report) {
  report = ConditionReport{};
  const std::string& name = s.source;
  if (s.F.rows() == 0) throw InvalidInput(name + ": no triangles");
  if (s.V.rows() == 0) throw InvalidInput(name + ": no vertices");
  const double diag = reference_length(s.V);
  if (!(diag > 0)) throw InvalidInput(name + ": all vertices at one point");
  report.input = diagnose_surface(s, p.hex_edge_length * diag, p.edge_length * diag);
  throw_if_interrupted();
  const std::vector<std::string> defects = report.input.defects();
  if (defects.empty() && !too_fine(p, report.input)) {
    report.output = report.input;
    return s;
  }
  if (!defects.empty() && p.policy == DefectPolicy::strict)
    throw InvalidInput(name + ": " + join(defects) + "; refused by policy `strict` (policy `auto` repairs it)");
  report.passed_through = false;
  return Conditioner(s, repair, p, report, diag).run(defects);
}

}  // namespace polyhex
