#include "nodes/rotation_deform/rotation_deform.h"

#include "nodes/artefacts/polycube.h"
#include "runtime/cancel.h"
#include "runtime/errors.h"
#include "runtime/stopwatch.h"

#include <Eigen/Geometry>
#include <Eigen/SparseCore>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <numeric>

namespace polyhex {

namespace {

using Clock = std::chrono::steady_clock;

constexpr double kPi = 3.14159265358979323846;

/// Faces of a positive tet (v0..v3) listed so that their normals point out of the tet.
constexpr int kOutwardFaces[4][3] = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}};

template <class F>
void parallel_range(int n, F&& body) {
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 512), [&](const tbb::blocked_range<int>& r) {
    for (int i = r.begin(); i < r.end(); ++i) body(i);
  });
}

/// A parallel reduction whose result does not depend on the number of threads or their scheduling:
/// the range is split into the same chunks and joined in the same order every time (floating-point
/// sums are not associative, so tbb::combinable / parallel_reduce would give thread-dependent bits).
/// `body(i, acc)` adds item i to acc; `join(a, b)` returns a followed by b.
template <class T, class F, class J>
T deterministic_reduce(int n, T identity, F&& body, J&& join) {
  return tbb::parallel_deterministic_reduce(
      tbb::blocked_range<int>(0, n, 512), identity,
      [&](const tbb::blocked_range<int>& r, T acc) {
        for (int i = r.begin(); i < r.end(); ++i) body(i, acc);
        return acc;
      },
      join);
}

/// Compressed rows: row r is items[offsets[r] .. offsets[r+1]).
struct Csr {
  std::vector<int> offsets, items;
  int size(int r) const { return offsets[r + 1] - offsets[r]; }
  const int* begin(int r) const { return items.data() + offsets[r]; }
  const int* end(int r) const { return items.data() + offsets[r + 1]; }
};

/// Builds a Csr from (row, item) pairs given by `for_each(emit)`, rows in [0, rows).
template <class ForEach>
Csr build_csr(int rows, ForEach&& for_each) {
  Csr c;
  c.offsets.assign(rows + 1, 0);
  for_each([&](int r, int) { ++c.offsets[r + 1]; });
  std::partial_sum(c.offsets.begin(), c.offsets.end(), c.offsets.begin());
  c.items.resize(c.offsets.back());
  std::vector<int> fill(c.offsets.begin(), c.offsets.end() - 1);
  for_each([&](int r, int item) { c.items[fill[r]++] = item; });
  return c;
}

/// Everything that depends on connectivity only: computed once per run.
struct Topology {
  int nV = 0;
  Csr vertex_tets;           // vertex -> incident tets
  Csr neighbours;            // vertex -> adjacent vertices (tet edges), sorted
  RowMatrixX3i F;            // boundary faces, outward
  std::vector<int> bverts;   // boundary vertices, sorted
  std::vector<int> bindex;   // vertex -> index into bverts, -1 inside
  Csr bvert_faces;           // boundary vertex index -> incident boundary faces
  Csr bvert_neighbours;      // boundary vertex index -> boundary vertex indices sharing a boundary edge
  std::vector<int> pins;     // one pinned vertex per connected component
  std::vector<char> pinned;  // per vertex
};

bool tet_has(const RowMatrixX4i& T, int t, int v) {
  return T(t, 0) == v || T(t, 1) == v || T(t, 2) == v || T(t, 3) == v;
}

Csr vertex_tet_csr(const RowMatrixX4i& T, int nV) {
  return build_csr(nV, [&](auto emit) {
    for (int t = 0; t < T.rows(); ++t)
      for (int k = 0; k < 4; ++k) emit(T(t, k), t);
  });
}

/// True when a tet other than t holds the vertices a, b, c: intersect the sorted tet lists of a and b,
/// check c on the (few) tets around the edge ab.
bool face_shared(const RowMatrixX4i& T, const Csr& vt, int t, int a, int b, int c) {
  const int *p = vt.begin(a), *pe = vt.end(a), *q = vt.begin(b), *qe = vt.end(b);
  while (p != pe && q != qe) {
    if (*p < *q) {
      ++p;
    } else if (*q < *p) {
      ++q;
    } else {
      if (*p != t && tet_has(T, *p, c)) return true;
      ++p, ++q;
    }
  }
  return false;
}

RowMatrixX3i boundary_faces_from(const RowMatrixX4i& T, const Csr& vt) {
  const int nT = static_cast<int>(T.rows());
  std::vector<char> is_boundary(4 * static_cast<size_t>(nT), 0);
  parallel_range(nT, [&](int t) {
    for (int f = 0; f < 4; ++f)
      is_boundary[4 * size_t(t) + f] =
          !face_shared(T, vt, t, T(t, kOutwardFaces[f][0]), T(t, kOutwardFaces[f][1]), T(t, kOutwardFaces[f][2]));
  });
  const long count = std::count(is_boundary.begin(), is_boundary.end(), 1);
  RowMatrixX3i F(count, 3);
  long row = 0;
  for (int t = 0; t < nT; ++t)
    for (int f = 0; f < 4; ++f)
      if (is_boundary[4 * size_t(t) + f]) {
        for (int k = 0; k < 3; ++k) F(row, k) = T(t, kOutwardFaces[f][k]);
        ++row;
      }
  return F;
}

/// vertex -> sorted unique neighbours (tet edges). One pass: each vertex gathers the other vertices
/// of its tets into a slot of 3 x (its tet count), sorts and dedupes it in place; then compaction.
Csr neighbour_csr(const RowMatrixX4i& T, const Csr& vt, int nV) {
  std::vector<int> slot(nV + 1, 0), size(nV);
  for (int v = 0; v < nV; ++v) slot[v + 1] = slot[v] + 3 * vt.size(v);
  std::vector<int> buf(slot.back());
  parallel_range(nV, [&](int v) {
    int* out = buf.data() + slot[v];
    int k = 0;
    for (const int* t = vt.begin(v); t != vt.end(v); ++t)
      for (int c = 0; c < 4; ++c)
        if (T(*t, c) != v) out[k++] = T(*t, c);
    std::sort(out, out + k);
    size[v] = static_cast<int>(std::unique(out, out + k) - out);
  });
  Csr c;
  c.offsets.assign(nV + 1, 0);
  for (int v = 0; v < nV; ++v) c.offsets[v + 1] = c.offsets[v] + size[v];
  c.items.resize(c.offsets.back());
  parallel_range(nV, [&](int v) {
    std::copy(buf.begin() + slot[v], buf.begin() + slot[v] + size[v], c.items.begin() + c.offsets[v]);
  });
  return c;
}

int find_root(std::vector<int>& parent, int v) {
  while (parent[v] != v) v = parent[v] = parent[parent[v]];
  return v;
}

/// One pin per connected component: the vertex nearest to the component's vertex centroid.
std::vector<int> component_pins(const RowMatrixX3d& V, const RowMatrixX4i& T) {
  const int nV = static_cast<int>(V.rows());
  std::vector<int> parent(nV);
  std::iota(parent.begin(), parent.end(), 0);
  for (int t = 0; t < T.rows(); ++t)
    for (int k = 1; k < 4; ++k) {
      int a = find_root(parent, T(t, 0)), b = find_root(parent, T(t, k));
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  std::vector<int> comp(nV), roots;
  for (int v = 0; v < nV; ++v) {
    comp[v] = find_root(parent, v);
    if (comp[v] == v) roots.push_back(v);
  }
  std::vector<int> slot(nV, -1);
  for (size_t r = 0; r < roots.size(); ++r) slot[roots[r]] = static_cast<int>(r);
  std::vector<Eigen::Vector3d> centroid(roots.size(), Eigen::Vector3d::Zero());
  std::vector<int> count(roots.size(), 0);
  for (int v = 0; v < nV; ++v) {
    centroid[slot[comp[v]]] += V.row(v).transpose();
    ++count[slot[comp[v]]];
  }
  std::vector<int> pins(roots.size(), -1);
  std::vector<double> best(roots.size(), std::numeric_limits<double>::infinity());
  for (int v = 0; v < nV; ++v) {
    const int s = slot[comp[v]];
    const double d = (V.row(v).transpose() - centroid[s] / count[s]).squaredNorm();
    if (d < best[s]) best[s] = d, pins[s] = v;
  }
  return pins;
}

Topology build_topology(const TetMesh& m) {
  Topology top;
  top.nV = static_cast<int>(m.V.rows());
  top.vertex_tets = vertex_tet_csr(m.T, top.nV);
  for (int v = 0; v < top.nV; ++v)
    if (top.vertex_tets.size(v) == 0)
      throw InvalidInput(m.source + ": vertex " + std::to_string(v) + " is used by no tet");
  top.neighbours = neighbour_csr(m.T, top.vertex_tets, top.nV);
  top.F = boundary_faces_from(m.T, top.vertex_tets);
  top.bindex.assign(top.nV, -1);
  for (int f = 0; f < top.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) top.bindex[top.F(f, k)] = 0;
  for (int v = 0; v < top.nV; ++v)
    if (top.bindex[v] == 0) {
      top.bindex[v] = static_cast<int>(top.bverts.size());
      top.bverts.push_back(v);
    }
  const int nB = static_cast<int>(top.bverts.size());
  top.bvert_faces = build_csr(nB, [&](auto emit) {
    for (int f = 0; f < top.F.rows(); ++f)
      for (int k = 0; k < 3; ++k) emit(top.bindex[top.F(f, k)], f);
  });
  // Each boundary edge appears in two faces (once per direction): emit a -> b per directed edge.
  top.bvert_neighbours = build_csr(nB, [&](auto emit) {
    for (int f = 0; f < top.F.rows(); ++f)
      for (int k = 0; k < 3; ++k) emit(top.bindex[top.F(f, k)], top.bindex[top.F(f, (k + 1) % 3)]);
  });
  top.pins = component_pins(m.V, m.T);
  top.pinned.assign(top.nV, 0);
  for (int p : top.pins) top.pinned[p] = 1;
  return top;
}

/// Lower triangle (CSC) of the graph Laplacian with diag(v) = degree(v) + extra[v]. Entries in a
/// row or column of a `pinned` vertex become explicit zeros and its diagonal 1 (Dirichlet row).
Eigen::SparseMatrix<double> laplacian_lower(const Topology& top, const std::vector<double>& extra,
                                            const std::vector<char>& pinned) {
  const int n = top.nV;
  Eigen::SparseMatrix<double> A(n, n);
  std::vector<int> upper_start(n);
  long nnz = 0;
  for (int j = 0; j < n; ++j) {
    upper_start[j] =
        static_cast<int>(std::upper_bound(top.neighbours.begin(j), top.neighbours.end(j), j) - top.neighbours.begin(j));
    nnz += 1 + top.neighbours.size(j) - upper_start[j];
  }
  A.resizeNonZeros(nnz);
  int* outer = A.outerIndexPtr();
  int* inner = A.innerIndexPtr();
  double* val = A.valuePtr();
  long p = 0;
  for (int j = 0; j < n; ++j) {
    outer[j] = static_cast<int>(p);
    inner[p] = j;
    val[p++] = pinned[j] ? 1.0 : top.neighbours.size(j) + extra[j];
    for (const int* i = top.neighbours.begin(j) + upper_start[j]; i != top.neighbours.end(j); ++i) {
      inner[p] = *i;
      val[p++] = (pinned[j] || pinned[*i]) ? 0.0 : -1.0;
    }
  }
  outer[n] = static_cast<int>(p);
  return A;
}

Eigen::Matrix3d edge_matrix(const RowMatrixX3d& V, const RowMatrixX4i& T, int t) {
  Eigen::Matrix3d D;
  for (int k = 0; k < 3; ++k) D.col(k) = (V.row(T(t, k + 1)) - V.row(T(t, 0))).transpose();
  return D;
}

struct Reduction {
  double sum = 0, max = 0, volume = 0;
  long good = 0, inverted = 0;
};

/// Inverted tets, conformal distortion (relative to the input, through Dinv0) and volume.
Reduction tet_figures(const RowMatrixX3d& V, const RowMatrixX4i& T, const std::vector<Eigen::Matrix3d>& Dinv0) {
  auto body = [&](int t, Reduction& r) {
    const Eigen::Matrix3d D = edge_matrix(V, T, t);
    const double det = D.determinant();
    r.volume += det / 6.0;
    if (!(det > 0)) {
      ++r.inverted;
      return;
    }
    const Eigen::Matrix3d Fg = D * Dinv0[t];
    const double kappa = Fg.norm() * Fg.inverse().norm() / 3.0;
    r.sum += kappa;
    r.max = std::max(r.max, kappa);
    ++r.good;
  };
  return deterministic_reduce(static_cast<int>(T.rows()), Reduction{}, body, [](Reduction a, const Reduction& b) {
    a.sum += b.sum;
    a.max = std::max(a.max, b.max);
    a.volume += b.volume;
    a.good += b.good;
    a.inverted += b.inverted;
    return a;
  });
}

Eigen::Vector3d face_area_vector(const RowMatrixX3d& V, const RowMatrixX3i& F, int f) {
  const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
  return (b - a).cross(c - a);  // twice the area, along the outward normal
}

void check_params(const RotationDeformParams& p) {
  auto range = [](const std::string& name, double v, const std::string& r) {
    return ConfigError("rotation_deform: param `" + name + "` = " + std::to_string(v) + " is out of range " + r);
  };
  if (p.iterations < 1 || p.iterations > 50) throw range("iterations", p.iterations, "[1, 50]");
  if (!(p.anchor_weight > 0 && p.anchor_weight <= 1e6)) throw range("anchor_weight", p.anchor_weight, "(0, 1e6]");
  if (!(p.feature_angle >= 0 && p.feature_angle <= 180)) throw range("feature_angle", p.feature_angle, "[0, 180]");
  if (!(p.flatten >= 0 && p.flatten <= 1)) throw range("flatten", p.flatten, "[0, 1]");
  if (!(p.flatten_full_angle >= 0 && p.flatten_full_angle <= 90))
    throw range("flatten_full_angle", p.flatten_full_angle, "[0, 90]");
  if (!(p.flatten_max_angle > p.flatten_full_angle && p.flatten_max_angle <= 90))
    throw range("flatten_max_angle", p.flatten_max_angle, "(flatten_full_angle, 90]");
}

void check_mesh(const TetMesh& m) {
  const std::string who = m.source.empty() ? std::string("tet mesh") : m.source;
  if (m.T.rows() == 0 || m.V.rows() < 4)
    throw InvalidInput(who + ": empty tet mesh (" + std::to_string(m.V.rows()) + " vertices, " +
                       std::to_string(m.T.rows()) + " tets)");
  for (int t = 0; t < m.T.rows(); ++t)
    for (int k = 0; k < 4; ++k)
      if (m.T(t, k) < 0 || m.T(t, k) >= m.V.rows())
        throw InvalidInput(who + ": tet " + std::to_string(t) + " has vertex index " + std::to_string(m.T(t, k)) +
                           " out of range (" + std::to_string(m.V.rows()) + " vertices)");
  if (!m.V.allFinite()) throw InvalidInput(who + ": non-finite vertex position");
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Building blocks

Eigen::Vector4d coherent_quaternion(const Eigen::Matrix3d& R) {
  // §4.1: reorder and reflect the columns of R (R P, P a signed permutation with det +1) to
  // maximise the trace; then q_w = ½ sqrt(1 + trace) > 0 (the 24 candidates always include one
  // with trace > 1.9), which makes the quaternion coherent with all its neighbours.
  static const std::array<std::array<int, 3>, 6> perms = {
      {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {2, 1, 0}, {1, 0, 2}}};
  double best = -std::numeric_limits<double>::infinity();
  Eigen::Matrix3d M = R;
  for (int pi = 0; pi < 6; ++pi) {
    const int parity = pi < 3 ? 1 : -1;  // the first three are even permutations
    for (int s = 0; s < 8; ++s) {
      const int sx = (s & 1) ? -1 : 1, sy = (s & 2) ? -1 : 1, sz = (s & 4) ? -1 : 1;
      if (parity * sx * sy * sz != 1) continue;
      const int sign[3] = {sx, sy, sz};
      // (R P)_{:,j} = sign_j R_{:,perm_j}
      double tr = 0;
      for (int j = 0; j < 3; ++j) tr += sign[j] * R(j, perms[pi][j]);
      if (tr > best + 1e-15) {
        best = tr;
        for (int j = 0; j < 3; ++j) M.col(j) = sign[j] * R.col(perms[pi][j]);
      }
    }
  }
  const double w = 0.5 * std::sqrt(std::max(0.0, 1.0 + M.trace()));
  Eigen::Vector4d q((M(2, 1) - M(1, 2)) / (4 * w), (M(0, 2) - M(2, 0)) / (4 * w), (M(1, 0) - M(0, 1)) / (4 * w), w);
  return q.normalized();
}

Eigen::Matrix3d axis_aligning_rotation(const Eigen::Vector3d& n) {
  return axis_aligning_rotation(n, label_dir(closest_label(n)));
}

Eigen::Matrix3d axis_aligning_rotation(const Eigen::Vector3d& n, const Eigen::Vector3d& a) {
  // Rodrigues for the rotation about n x a by the angle between them; c = n.a > 0 (>= 1/sqrt(3) for the
  // closest axis).
  const Eigen::Vector3d v = n.cross(a);
  const double c = n.dot(a);
  Eigen::Matrix3d K;
  K << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return Eigen::Matrix3d::Identity() + K + K * K / (1.0 + c);
}

RowMatrixX3i boundary_faces(const RowMatrixX4i& T, int nV) { return boundary_faces_from(T, vertex_tet_csr(T, nV)); }

double axis_alignment(const RowMatrixX3d& V, const RowMatrixX3i& F, double angle_deg) {
  const double c = std::cos(angle_deg * kPi / 180.0);
  using Areas = std::pair<double, double>;  // (aligned area, total area)
  const Areas s = deterministic_reduce(
      static_cast<int>(F.rows()), Areas{0.0, 0.0},
      [&](int f, Areas& acc) {
        const Eigen::Vector3d n = face_area_vector(V, F, f);
        const double a = n.norm();
        acc.second += a;
        if (a > 0 && n.cwiseAbs().maxCoeff() >= c * a) acc.first += a;
      },
      [](const Areas& x, const Areas& y) {
        return Areas{x.first + y.first, x.second + y.second};
      });
  return s.second > 0 ? s.first / s.second : 0.0;
}

// ---------------------------------------------------------------------------------------------

namespace {

/// The buffers of one iteration, allocated once per run.
struct IterationBuffers {
  RowMatrixX3d face_n;                  ///< unit face normals (0 for degenerate faces)
  RowMatrixX3d face_a;                  ///< area vectors
  std::vector<Eigen::Vector4d> target;  ///< per boundary vertex its target quaternion
  std::vector<char> known, known_next, feature;
  Eigen::MatrixXd Bq, Bp;            ///< right-hand sides: quaternion Laplace, positions
  std::vector<Eigen::Matrix3d> rot;  ///< per vertex its rotation
  std::vector<int>
      blabel;  ///< direction label (polycube.h) closest to a non-feature boundary vertex's normal, -1 feature
  std::vector<double> bangle;  ///< degrees between the vertex normal and that direction

  IterationBuffers(const Topology& top, int n)
      : face_n(top.F.rows(), 3),
        face_a(top.F.rows(), 3),
        target(top.bverts.size()),
        known(top.bverts.size()),
        known_next(top.bverts.size()),
        feature(top.bverts.size()),
        Bq(Eigen::MatrixXd::Zero(n, 4)),
        Bp(n, 3),
        rot(size_t(n)),
        blabel(top.bverts.size(), -1),
        bangle(top.bverts.size(), 0.0) {}
};

/// Steps 1-3: boundary normals (area weighted) and features; per non-feature boundary vertex (§4.1) the
/// minimal axis-aligning rotation towards the closest direction, coherently oriented, and that
/// direction's label for the flattening. Returns the number of feature vertices.
int boundary_targets(const Topology& top, const RowMatrixX3d& V, double cos_feature, IterationBuffers& b) {
  const int nB = static_cast<int>(top.bverts.size());
  const Eigen::Vector4d identity(0, 0, 0, 1);
  parallel_range(static_cast<int>(top.F.rows()), [&](int f) {
    const Eigen::Vector3d a = face_area_vector(V, top.F, f);
    const double len = a.norm();
    b.face_a.row(f) = a.transpose();
    b.face_n.row(f) = len > 0 ? Eigen::RowVector3d(a.transpose() / len) : Eigen::RowVector3d::Zero();
  });
  parallel_range(nB, [&](int v) {
    Eigen::Vector3d nv = Eigen::Vector3d::Zero();
    bool is_feature = false;
    for (const int* f = top.bvert_faces.begin(v); f != top.bvert_faces.end(v); ++f) {
      nv += b.face_a.row(*f).transpose();
      if (b.face_n.row(*f).squaredNorm() == 0) continue;
      for (const int* g = f + 1; g != top.bvert_faces.end(v) && !is_feature; ++g)
        is_feature = b.face_n.row(*g).squaredNorm() > 0 && b.face_n.row(*f).dot(b.face_n.row(*g)) < cos_feature;
    }
    const double len = nv.norm();
    b.feature[v] = is_feature || !(len > 0);
    b.known[v] = !b.feature[v];
    b.blabel[v] = -1;
    b.target[v] = identity;
    if (!b.feature[v]) {
      const Eigen::Vector3d un = nv / len;
      b.blabel[v] = closest_label(un);
      b.bangle[v] = std::acos(std::min(1.0, std::abs(un[label_axis(b.blabel[v])]))) * 180.0 / kPi;
      b.target[v] = coherent_quaternion(axis_aligning_rotation(un, label_dir(b.blabel[v])));
    }
  });
  return static_cast<int>(std::count(b.feature.begin(), b.feature.end(), 1));
}

/// Feature vertices: target = normalised mean of the known targets of their surface neighbours, ring
/// by ring (right-hand side only, the matrix keeps its anchor rows).
void propagate_feature_targets(const Topology& top, IterationBuffers& b) {
  const int nB = static_cast<int>(top.bverts.size());
  for (bool progress = true; progress;) {
    progress = false;
    b.known_next = b.known;
    for (int v = 0; v < nB; ++v) {
      if (b.known[v]) continue;
      Eigen::Vector4d sum = Eigen::Vector4d::Zero();
      for (const int* o = top.bvert_neighbours.begin(v); o != top.bvert_neighbours.end(v); ++o)
        if (b.known[*o]) sum += b.target[*o];
      if (sum.squaredNorm() > 0) {
        b.target[v] = sum.normalized();
        b.known_next[v] = 1;
        progress = true;
      }
    }
    b.known.swap(b.known_next);
  }
}

/// Step 5: per vertex the rotation of its normalised quaternion; returns the smallest quaternion norm.
double vertex_rotations(const Eigen::MatrixXd& q, std::vector<Eigen::Matrix3d>& rot) {
  return deterministic_reduce(
      static_cast<int>(q.rows()), std::numeric_limits<double>::infinity(),
      [&](int v, double& min_norm) {
        min_norm = std::min(min_norm, q.row(v).norm());
        rot[v] = Eigen::Quaterniond(q(v, 3), q(v, 0), q(v, 1), q(v, 2)).normalized().toRotationMatrix();
      },
      [](double a, double b) { return std::min(a, b); });
}

/// Step 6, the right-hand side of §4.2 Eq. 1 (times N_i): L v = Σ_j ½(∇_i + ∇_j)(ṽ_i - ṽ_j), pinned
/// vertices stay.
void position_rhs(const Topology& top, const RowMatrixX3d& V, const RotationDeformParams& params, IterationBuffers& b) {
  const double full = params.flatten_full_angle, none = params.flatten_max_angle;
  parallel_range(top.nV, [&](int i) {
    const Eigen::Vector3d vi = V.row(i).transpose();
    if (top.pinned[i]) {
      b.Bp.row(i) = vi.transpose();
      return;
    }
    Eigen::Vector3d acc = Eigen::Vector3d::Zero(), pinned_sum = Eigen::Vector3d::Zero();
    const int bi = top.bindex[i];
    for (const int* j = top.neighbours.begin(i); j != top.neighbours.end(i); ++j) {
      const Eigen::Vector3d vj = V.row(*j).transpose();
      Eigen::Vector3d e = (b.rot[i] + b.rot[*j]) * (vi - vj);
      // Surface flattening (beyond the paper, see the header): a surface edge between two
      // non-feature vertices with the same closest axis loses the share β w of its component
      // along the axis, w = 1 up to flatten_full_angle, 0 from flatten_max_angle, linear between.
      // Edge (j, i) gets -e: rows i and j stay consistent.
      const int bj = bi >= 0 ? top.bindex[*j] : -1;
      if (params.flatten > 0 && bj >= 0 && b.blabel[bi] >= 0 && b.blabel[bj] == b.blabel[bi] &&
          std::find(top.bvert_neighbours.begin(bi), top.bvert_neighbours.end(bi), bj) != top.bvert_neighbours.end(bi)) {
        const double angle = std::max(b.bangle[bi], b.bangle[bj]);
        const double w = angle <= full ? 1.0 : angle >= none ? 0.0 : (none - angle) / (none - full);
        e[label_axis(b.blabel[bi])] *= 1.0 - params.flatten * w;
      }
      acc += e;
      if (top.pinned[*j]) pinned_sum += vj;
    }
    b.Bp.row(i) = (0.5 * acc + pinned_sum).transpose();
  });
}

}  // namespace

RotationDeformResult rotation_deform(const TetMesh& input, const RotationDeformParams& params,
                                     const IterationCallback& on_iteration) {
  check_params(params);
  check_mesh(input);
  const SolveMode mode = params.solve_mode;
  RotationDeformResult res;
  auto t_assemble = Clock::now();

  // --- Once per run: topology, both matrices, reference shapes for the distortion measure.
  const Topology top = build_topology(input);
  const int n = top.nV;
  const int nT = static_cast<int>(input.T.rows());
  const double w2 = params.anchor_weight * params.anchor_weight;
  std::vector<double> anchor_diag(n, 0.0);
  for (int v : top.bverts) anchor_diag[v] = w2;
  // §4.1 quaternion Laplace with soft anchors: (L + w² S); no pinned rows.
  const Eigen::SparseMatrix<double> Q = laplacian_lower(top, anchor_diag, std::vector<char>(n, 0));
  // §4.2 Eq. 1 times N_i: graph Laplacian with one Dirichlet vertex per component.
  const Eigen::SparseMatrix<double> P = laplacian_lower(top, std::vector<double>(n, 0.0), top.pinned);
  std::vector<Eigen::Matrix3d> Dinv0(nT);
  const double volume0 = deterministic_reduce(
      nT, 0.0,
      [&](int t, double& vol) {
        const Eigen::Matrix3d D = edge_matrix(input.V, input.T, t);
        vol += D.determinant() / 6.0;
        Dinv0[t] = D.inverse();
      },
      std::plus<double>());
  res.assemble_seconds = seconds_since(t_assemble);

  // Q and P share their pattern (P keeps explicit zeros in the pinned rows): one analysis, then the two
  // numeric factorizations side by side (each on its own CHOLMOD workspace; the same factors as one after
  // the other).
  CholmodFactorization quat_solver;
  quat_solver.analyse(Q);
  CholmodFactorization pos_solver = quat_solver.share_analysis();
  throw_if_interrupted();
  tbb::parallel_invoke([&] { quat_solver.factor(Q); }, [&] { pos_solver.factor(P); });

  res.boundary_vertices = static_cast<int>(top.bverts.size());
  res.boundary_faces = static_cast<int>(top.F.rows());
  res.components = static_cast<int>(top.pins.size());
  res.mesh = input;
  TetMesh& cur = res.mesh;
  res.input_alignment = axis_alignment(cur.V, top.F);

  const double cos_feature = std::cos(params.feature_angle * kPi / 180.0);
  IterationBuffers buf(top, n);
  for (int it = 1; it <= params.iterations; ++it) {
    throw_if_interrupted();  // safe point: nothing of this iteration computed yet
    auto t_it = Clock::now();
    RotationIterationStats st;
    st.feature_vertices = boundary_targets(top, cur.V, cos_feature, buf);  // 1-3
    propagate_feature_targets(top, buf);
    // 4. Laplace per quaternion component, soft anchors on every boundary vertex.
    for (size_t b = 0; b < top.bverts.size(); ++b) buf.Bq.row(top.bverts[b]) = w2 * buf.target[b].transpose();
    const Eigen::MatrixXd q = quat_solver.solve(buf.Bq, mode);
    throw_if_interrupted();
    st.min_quaternion_norm = vertex_rotations(q, buf.rot);  // 5
    if (!(st.min_quaternion_norm > 1e-12))
      throw SolverError("rotation_deform: degenerate quaternion (norm " + std::to_string(st.min_quaternion_norm) +
                        ") in iteration " + std::to_string(it));
    position_rhs(top, cur.V, params, buf);  // 6
    const Eigen::MatrixXd x = pos_solver.solve(buf.Bp, mode);
    cur.V = x;

    // Figures of this iteration.
    st.alignment = axis_alignment(cur.V, top.F);
    const Reduction r = tet_figures(cur.V, cur.T, Dinv0);
    st.inverted_tets = static_cast<int>(r.inverted);
    st.distortion = r.good ? r.sum / r.good : 0.0;
    st.distortion_max = r.max;
    st.volume_ratio = volume0 != 0 ? r.volume / volume0 : 0.0;
    st.seconds = seconds_since(t_it);
    res.iterations.push_back(st);
    if (on_iteration) on_iteration(it, cur, st);
  }
  res.factor_stats = quat_solver.stats();
  res.factor_stats += pos_solver.stats();
  return res;
}

}  // namespace polyhex
