#include "nodes/algorithms/hex_quality.h"

#include "nodes/algorithms/hex_corners.h"
#include "nodes/algorithms/triangle_tree.h"
#include "nodes/artefacts/hex_topology.h"
#include "runtime/errors.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace polyhex {

namespace {

using Vec3 = Eigen::Vector3d;
using RowMatrixX4iQ = Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor>;

using hex_topology::kCorners;
using hex_topology::kEdges;
using hex_topology::kFaces;
// The 5-tet split of a hex used for its volume.
constexpr int kVolumeTets[5][4] = {{0, 1, 3, 4}, {1, 2, 3, 6}, {1, 3, 4, 6}, {1, 4, 5, 6}, {3, 4, 6, 7}};

using optimize_detail::kLanes;
using optimize_detail::Lanes;

// det[a b c] / (|a| |b| |c|), 0 when a vector has (almost) no length, clamped to [-1, 1] (scaled_of).
double scaled(const Vec3& a, const Vec3& b, const Vec3& c) {
  const double x[3] = {a[0], a[1], a[2]}, y[3] = {b[0], b[1], b[2]}, z[3] = {c[0], c[1], c[2]};
  return optimize_detail::scaled_of(x, y, z);
}

std::array<Vec3, 8> corners(const HexMesh& m, Eigen::Index h) {
  std::array<Vec3, 8> p;
  for (int k = 0; k < 8; ++k) p[k] = m.V.row(m.H(h, k)).transpose();
  return p;
}

std::string mesh_name(const std::string& source, const char* fallback) {
  return source.empty() ? std::string(fallback) : source;
}

std::uint64_t edge_key(int a, int b) {
  if (a > b) std::swap(a, b);
  return (std::uint64_t(std::uint32_t(a)) << 32) | std::uint32_t(b);
}

// Topological figures of hexcheck.py `topology()`.
struct Topology {
  RowMatrixX4iQ boundary;       // #Q by 4
  std::vector<char> irregular;  // #V: 1 for an irregular vertex (0 for an unused one)
  double irregular_pct = 0, irregular_interior_pct = 0, irregular_boundary_pct = 0;
  long unused_vertices = 0, faces_shared_by_more_than_two = 0, nonmanifold_boundary_edges = 0;
};

// Faces used by exactly one hex, in (hex, face) order; counts faces used more than twice; the hex and local
// face of each. A face is matched with its copies among the faces whose smallest vertex is the same (a
// bucket per vertex, filled by a counting sort): linear, where sorting all 6 #H faces was the pad stage's
// largest cost.
RowMatrixX4iQ boundary_faces(const HexMesh& m, long* faces_over_two, std::vector<int>* hex_of_face = nullptr,
                             std::vector<int>* local_face = nullptr) {
  const Eigen::Index nh = m.H.rows();
  const size_t nf = size_t(nh) * 6;
  std::vector<std::array<int, 4>> key(nf);  // per face (6 hex + face) its sorted vertices
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, nh), [&](const tbb::blocked_range<Eigen::Index>& r) {
    for (Eigen::Index h = r.begin(); h < r.end(); ++h)
      for (int f = 0; f < 6; ++f) {
        std::array<int, 4>& k = key[size_t(h) * 6 + size_t(f)];
        for (int c = 0; c < 4; ++c) k[size_t(c)] = m.H(h, kFaces[f][c]);
        std::sort(k.begin(), k.end());
      }
  });
  // the faces by smallest vertex (its offset from the lowest index: any index is counted, even one a
  // malformed mesh holds outside its vertices), in id order within a bucket
  int low = 0, high = -1;
  for (const auto& k : key) low = std::min(low, k[0]), high = std::max(high, k[0]);
  const size_t nb = size_t(std::int64_t(high) - low + 1);
  std::vector<int> start(nb + 1, 0), bucket(nf);
  for (const auto& k : key) ++start[size_t(k[0] - low) + 1];
  for (size_t v = 0; v < nb; ++v) start[v + 1] += start[v];
  {
    std::vector<int> fill(start.begin(), start.end() - 1);
    for (size_t i = 0; i < nf; ++i) bucket[size_t(fill[size_t(key[i][0] - low)]++)] = int(i);
  }
  std::vector<char> single(nf, 0);
  std::vector<char> first_of_many(nf, 0);  // the lowest id of a face used more than twice
  tbb::parallel_for(size_t(0), nb, [&](size_t v) {
    for (int a = start[v]; a < start[v + 1]; ++a) {
      const int i = bucket[size_t(a)];
      int copies = 0;
      bool lowest = true;
      for (int b = start[v]; b < start[v + 1]; ++b) {
        const int j = bucket[size_t(b)];
        if (key[size_t(j)] != key[size_t(i)]) continue;
        ++copies;
        lowest = lowest && j >= i;
      }
      single[size_t(i)] = copies == 1;
      first_of_many[size_t(i)] = copies > 2 && lowest;
    }
  });
  std::vector<int> singles;
  long over_two = 0;
  for (size_t i = 0; i < nf; ++i) {
    if (single[i]) singles.push_back(int(i));
    over_two += first_of_many[i];
  }
  RowMatrixX4iQ q(Eigen::Index(singles.size()), 4);
  for (size_t i = 0; i < singles.size(); ++i)
    for (int k = 0; k < 4; ++k) q(Eigen::Index(i), k) = m.H(singles[i] / 6, kFaces[singles[i] % 6][k]);
  if (faces_over_two) *faces_over_two = over_two;
  if (hex_of_face) {
    hex_of_face->resize(singles.size());
    for (size_t i = 0; i < singles.size(); ++i) (*hex_of_face)[i] = singles[i] / 6;
  }
  if (local_face) {
    local_face->resize(singles.size());
    for (size_t i = 0; i < singles.size(); ++i) (*local_face)[i] = singles[i] % 6;
  }
  return q;
}

Topology topology(const HexMesh& m) {
  Topology t;
  const Eigen::Index nh = m.H.rows();
  const size_t nv = size_t(m.V.rows());
  t.boundary = boundary_faces(m, &t.faces_shared_by_more_than_two);

  // Edge valence: distinct edges (as vertex pairs) at each vertex.
  std::vector<std::uint64_t> edges(size_t(nh) * 12);
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, nh), [&](const tbb::blocked_range<Eigen::Index>& r) {
    for (Eigen::Index h = r.begin(); h < r.end(); ++h)
      for (int e = 0; e < 12; ++e) edges[size_t(h) * 12 + e] = edge_key(m.H(h, kEdges[e][0]), m.H(h, kEdges[e][1]));
  });
  tbb::parallel_sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  std::vector<int> valence(nv, 0);
  for (std::uint64_t e : edges) {
    ++valence[e >> 32];
    ++valence[e & 0xffffffffu];
  }

  std::vector<char> used(nv, 0), on_boundary(nv, 0);
  for (Eigen::Index i = 0; i < m.H.size(); ++i) used[m.H.data()[i]] = 1;
  std::vector<int> boundary_count(nv, 0);
  std::vector<std::uint64_t> bedges;
  bedges.reserve(size_t(t.boundary.rows()) * 4);
  for (Eigen::Index q = 0; q < t.boundary.rows(); ++q)
    for (int k = 0; k < 4; ++k) {
      const int v = t.boundary(q, k);
      on_boundary[v] = 1;
      ++boundary_count[v];
      bedges.push_back(edge_key(v, t.boundary(q, (k + 1) % 4)));
    }
  std::sort(bedges.begin(), bedges.end());
  for (size_t i = 0; i < bedges.size();) {
    size_t j = i + 1;
    while (j < bedges.size() && bedges[j] == bedges[i]) ++j;
    if (j - i != 2) ++t.nonmanifold_boundary_edges;
    i = j;
  }

  long n_used = 0, n_interior = 0, n_boundary = 0, irr_interior = 0, irr_boundary = 0;
  t.irregular.assign(nv, 0);
  for (size_t v = 0; v < nv; ++v) {
    if (!used[v]) {
      ++t.unused_vertices;
      continue;
    }
    ++n_used;
    if (on_boundary[v]) {
      ++n_boundary;
      t.irregular[v] = boundary_count[v] != 4;
      irr_boundary += t.irregular[v];
    } else {
      ++n_interior;
      t.irregular[v] = valence[v] != 6;
      irr_interior += t.irregular[v];
    }
  }
  t.irregular_pct = 100.0 * double(irr_interior + irr_boundary) / double(std::max(n_used, 1L));
  t.irregular_interior_pct = 100.0 * double(irr_interior) / double(std::max(n_interior, 1L));
  t.irregular_boundary_pct = 100.0 * double(irr_boundary) / double(std::max(n_boundary, 1L));
  return t;
}

void check_triangles(const RowMatrixX3d& V, const RowMatrixX3i& F, const std::string& name) {
  for (Eigen::Index i = 0; i < V.size(); ++i)
    if (!std::isfinite(V.data()[i]))
      throw InvalidInput(name + ": vertex " + std::to_string(i / 3) + " has a non-finite coordinate");
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      if (F(f, k) < 0 || F(f, k) >= V.rows())
        throw InvalidInput(name + ": triangle " + std::to_string(f) + ": vertex index " + std::to_string(F(f, k)) +
                           " out of range (" + std::to_string(V.rows()) + " vertices)");
}

// n points uniformly distributed by area on the triangles (hexcheck.py `sample()`).
std::vector<Vec3> sample_by_area(const RowMatrixX3d& V, const RowMatrixX3i& F, int n, std::mt19937_64& rng,
                                 const std::string& name) {
  std::vector<double> cum(size_t(F.rows()));
  double total = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Vec3 a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    total += 0.5 * (b - a).cross(c - a).norm();
    cum[size_t(f)] = total;
  }
  if (!(total > 0)) throw InvalidInput(name + ": the triangles have no area, nothing to sample");
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<Vec3> out(static_cast<size_t>(n));
  for (auto& p : out) {
    const double u = unit(rng) * total;
    const size_t f = std::min(size_t(std::upper_bound(cum.begin(), cum.end(), u) - cum.begin()), cum.size() - 1);
    const double s = std::sqrt(unit(rng)), r2 = unit(rng);
    const Vec3 a = V.row(F(Eigen::Index(f), 0)), b = V.row(F(Eigen::Index(f), 1)), c = V.row(F(Eigen::Index(f), 2));
    p = (1 - s) * a + s * (1 - r2) * b + s * r2 * c;
  }
  return out;
}

// Mean and max distance from the points to the tree, deterministic for any thread count.
std::pair<double, double> mean_max_distance(const std::vector<Vec3>& pts, const TriangleTree& tree) {
  std::vector<double> d(pts.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, pts.size(), 256), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) d[i] = tree.distance(pts[i]);
  });
  double sum = 0, mx = 0;
  for (double x : d) {
    sum += x;
    mx = std::max(mx, x);
  }
  return {sum / double(std::max<size_t>(d.size(), 1)), mx};
}

RowMatrixX3i quads_to_triangles(const RowMatrixX4iQ& q) {
  RowMatrixX3i t(2 * q.rows(), 3);
  for (Eigen::Index i = 0; i < q.rows(); ++i) {
    t.row(i) << q(i, 0), q(i, 1), q(i, 2);
    t.row(q.rows() + i) << q(i, 0), q(i, 2), q(i, 3);
  }
  return t;
}

/// The scaled Jacobians of the kLanes corners ks of hex p into terms[ks[l]], side by side in lanes.
void corner_terms(const std::array<Eigen::Vector3d, 8>& p, const int* ks, std::array<double, 9>& terms) {
  Lanes e[3][3];  // e[m][i]: coordinate i of the frame's edge m
  for (int l = 0; l < kLanes; ++l) {
    const auto& c = kCorners[ks[l]];
    for (int m = 0; m < 3; ++m)
      for (int i = 0; i < 3; ++i) e[m][i][l] = p[size_t(c[m + 1])][i] - p[size_t(c[0])][i];
  }
  const Lanes s = optimize_detail::scaled_of(e[0], e[1], e[2]);
  for (int l = 0; l < kLanes; ++l) terms[size_t(ks[l])] = s[l];
}

/// The centre term and the minima, from terms[0..7].
HexSJ finish_terms(const std::array<Eigen::Vector3d, 8>& p, std::array<double, 9>& terms) {
  double corner_min = 1.0;
  for (size_t k = 0; k < 8; ++k) corner_min = std::min(corner_min, terms[k]);
  // Principal axes at the centre (Verdict): the averaged edge directions of the three axes.
  const Vec3 xi = (p[1] + p[2] + p[5] + p[6]) - (p[0] + p[3] + p[4] + p[7]);
  const Vec3 eta = (p[2] + p[3] + p[6] + p[7]) - (p[0] + p[1] + p[4] + p[5]);
  const Vec3 zeta = (p[4] + p[5] + p[6] + p[7]) - (p[0] + p[1] + p[2] + p[3]);
  terms[8] = scaled(xi, eta, zeta);
  return HexSJ{std::min(corner_min, terms[8]), corner_min};
}

}  // namespace

static_assert(optimize_detail::kLanes == 4, "a hex's corners go four to a Lanes");

HexSJ hex_scaled_jacobian(const std::array<Eigen::Vector3d, 8>& p, std::array<double, 9>& terms) {
  static constexpr int kAll[8] = {0, 1, 2, 3, 4, 5, 6, 7};
  corner_terms(p, kAll, terms);
  corner_terms(p, kAll + 4, terms);
  return finish_terms(p, terms);
}

HexSJ hex_scaled_jacobian_moved(const std::array<Eigen::Vector3d, 8>& p, int j, const std::array<double, 9>& before,
                                std::array<double, 9>& terms) {
  terms = before;
  corner_terms(p, kCorners[j], terms);  // the corners whose frames use corner j: j and its 3 neighbours
  return finish_terms(p, terms);
}

HexSJ hex_scaled_jacobian(const std::array<Eigen::Vector3d, 8>& p) {
  std::array<double, 9> terms;
  return hex_scaled_jacobian(p, terms);
}

void hex_scaled_jacobians(const HexMesh& mesh, Eigen::VectorXd& sj, Eigen::VectorXd& corner_min) {
  const Eigen::Index nh = mesh.H.rows();
  sj.resize(nh);
  corner_min.resize(nh);
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, nh, 512), [&](const tbb::blocked_range<Eigen::Index>& r) {
    for (Eigen::Index h = r.begin(); h < r.end(); ++h) {
      const HexSJ s = hex_scaled_jacobian(corners(mesh, h));
      sj[h] = s.sj;
      corner_min[h] = s.corner_min;
    }
  });
}

Eigen::VectorXd hex_edge_ratios(const HexMesh& mesh) {
  const Eigen::Index nh = mesh.H.rows();
  Eigen::VectorXd ratio(nh);
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, nh, 1024), [&](const tbb::blocked_range<Eigen::Index>& r) {
    for (Eigen::Index h = r.begin(); h < r.end(); ++h) {
      const auto p = corners(mesh, h);
      double lo = std::numeric_limits<double>::infinity(), hi = 0;
      for (const auto& e : kEdges) {
        const double l = (p[e[1]] - p[e[0]]).norm();
        lo = std::min(lo, l);
        hi = std::max(hi, l);
      }
      ratio[h] = lo > 0 ? hi / lo : std::numeric_limits<double>::infinity();
    }
  });
  return ratio;
}

std::vector<char> irregular_vertices(const HexMesh& mesh) { return topology(mesh).irregular; }

double hex_mesh_volume(const HexMesh& mesh) {
  const Eigen::Index nh = mesh.H.rows();
  Eigen::VectorXd vol(nh);
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, nh, 1024), [&](const tbb::blocked_range<Eigen::Index>& r) {
    for (Eigen::Index h = r.begin(); h < r.end(); ++h) {
      const auto p = corners(mesh, h);
      double v = 0;
      for (const auto& t : kVolumeTets) v += (p[t[1]] - p[t[0]]).dot((p[t[2]] - p[t[0]]).cross(p[t[3]] - p[t[0]]));
      vol[h] = v / 6.0;
    }
  });
  return vol.sum();  // serial sum: the same figure for any thread count
}

Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor> hex_boundary_quads(const HexMesh& mesh,
                                                                          std::vector<int>* hex_of_quad,
                                                                          std::vector<int>* face_of_quad) {
  return boundary_faces(mesh, nullptr, hex_of_quad, face_of_quad);
}

void check_hex_mesh(const HexMesh& mesh) {
  const std::string name = mesh_name(mesh.source, "hex mesh");
  if (mesh.H.rows() == 0) throw InvalidInput(name + ": no hexahedra");
  for (Eigen::Index i = 0; i < mesh.V.size(); ++i)
    if (!std::isfinite(mesh.V.data()[i]))
      throw InvalidInput(name + ": vertex " + std::to_string(i / 3) + " has a non-finite coordinate");
  for (Eigen::Index h = 0; h < mesh.H.rows(); ++h)
    for (int k = 0; k < 8; ++k)
      if (mesh.H(h, k) < 0 || mesh.H(h, k) >= mesh.V.rows())
        throw InvalidInput(name + ": hex " + std::to_string(h) + ": vertex index " + std::to_string(mesh.H(h, k)) +
                           " out of range (" + std::to_string(mesh.V.rows()) + " vertices)");
}

SurfaceDistance sampled_surface_distance(const RowMatrixX3d& Va, const RowMatrixX3i& Fa, const RowMatrixX3d& Vb,
                                         const RowMatrixX3i& Fb, int samples, std::uint64_t seed) {
  if (samples < 1) throw InvalidInput("surface distance: samples = " + std::to_string(samples) + " must be >= 1");
  check_triangles(Va, Fa, "surface A");
  check_triangles(Vb, Fb, "surface B");
  std::mt19937_64 rng(seed);
  const std::vector<Vec3> pa = sample_by_area(Va, Fa, samples, rng, "surface A");
  const std::vector<Vec3> pb = sample_by_area(Vb, Fb, samples, rng, "surface B");
  SurfaceDistance d;
  const TriangleTree ta(Va, Fa), tb(Vb, Fb);
  std::tie(d.mean_ab, d.max_ab) = mean_max_distance(pa, tb);
  std::tie(d.mean_ba, d.max_ba) = mean_max_distance(pb, ta);
  return d;
}

namespace {

// How many triangles use each undirected edge: whether some edge has one (an open surface) and
// whether every edge has two (closed and manifold: the enclosed volume is defined).
struct EdgeUse {
  bool open = false, closed_manifold = true;
};
EdgeUse edge_use(const RowMatrixX3i& F) {
  std::vector<uint64_t> edges;
  edges.reserve(size_t(3 * F.rows()));
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = uint32_t(F(f, k)), b = uint32_t(F(f, (k + 1) % 3));
      edges.push_back((uint64_t(std::min(a, b)) << 32) | std::max(a, b));
    }
  std::sort(edges.begin(), edges.end());
  EdgeUse u;
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    u.open = u.open || j - i == 1;
    u.closed_manifold = u.closed_manifold && j - i == 2;
    i = j;
  }
  return u;
}

}  // namespace

HexQuality hex_quality(const HexMesh& mesh, const SurfaceMesh* surface, const QualityParams& p) {
  check_hex_mesh(mesh);
  if (p.samples < 1) throw InvalidInput("quality: samples = " + std::to_string(p.samples) + " must be >= 1");
  HexQuality q;
  q.hexes = long(mesh.H.rows());
  q.vertices = long(mesh.V.rows());
  hex_scaled_jacobians(mesh, q.sj, q.sj_corner);
  q.sj_min = q.sj.minCoeff();
  q.sj_avg = q.sj.mean();
  q.sj_corner_min = q.sj_corner.minCoeff();
  q.sj_corner_avg = q.sj_corner.mean();
  q.inverted = long((q.sj_corner.array() <= 0).count());
  q.sj_below_0_2 = long((q.sj.array() < 0.2).count());
  q.volume = hex_mesh_volume(mesh);

  Topology t = topology(mesh);
  q.irregular_pct = t.irregular_pct;
  q.irregular_interior_pct = t.irregular_interior_pct;
  q.irregular_boundary_pct = t.irregular_boundary_pct;
  q.unused_vertices = t.unused_vertices;
  q.faces_shared_by_more_than_two = t.faces_shared_by_more_than_two;
  q.nonmanifold_boundary_edges = t.nonmanifold_boundary_edges;
  q.boundary_quads = long(t.boundary.rows());
  if (!surface) return q;

  const std::string sname = mesh_name(surface->source, "surface");
  if (surface->F.rows() == 0) throw InvalidInput(sname + ": no triangles");
  check_triangles(surface->V, surface->F, sname);
  q.has_surface = true;
  q.bbox_diag = (surface->V.colwise().maxCoeff() - surface->V.colwise().minCoeff()).norm();
  double enclosed = 0;
  for (Eigen::Index f = 0; f < surface->F.rows(); ++f) {
    const Vec3 a = surface->V.row(surface->F(f, 0)), b = surface->V.row(surface->F(f, 1)),
               c = surface->V.row(surface->F(f, 2));
    enclosed += a.dot(b.cross(c));
  }
  enclosed = std::abs(enclosed / 6.0);
  const EdgeUse use = edge_use(surface->F);
  q.surface_closed = !use.open;
  if (use.closed_manifold) {
    if (!(enclosed > 0)) throw InvalidInput(sname + ": the surface encloses no volume");
    q.volume_ratio = std::abs(q.volume) / enclosed;
  }

  // hex boundary -> surface first, then surface -> hex boundary, as hexcheck.py samples them.
  const SurfaceDistance d =
      sampled_surface_distance(mesh.V, quads_to_triangles(t.boundary), surface->V, surface->F, p.samples, p.seed);
  if (q.surface_closed) {
    q.hausdorff_max = std::max(d.max_ab, d.max_ba) / q.bbox_diag;
    q.hausdorff_mean = (d.mean_ab + d.mean_ba) / 2.0 / q.bbox_diag;
  } else {
    q.hausdorff_max = d.max_ba / q.bbox_diag;
    q.hausdorff_mean = d.mean_ba / q.bbox_diag;
  }
  if (p.feature_angle > 0) {
    const double h = median_boundary_edge(mesh.V, t.boundary);
    if (h > 0) {
      const SurfaceCreases creases = find_creases(*surface, p.feature_angle, 1.5 * h, 0.5 * h);
      q.features = feature_fidelity(mesh.V, t.boundary, creases, p.feature_angle, h / 20);
      q.has_features = true;
      q.hex_edge = h / q.bbox_diag;
      for (double* x : {&q.features.curve_length, &q.features.curve_to_mesh_max, &q.features.mesh_to_curve_max,
                        &q.features.curve_to_mesh_mean})
        *x /= q.bbox_diag;
    }
  }
  return q;
}

}  // namespace polyhex
