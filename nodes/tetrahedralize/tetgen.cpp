/// @file tetgen.cpp
/// @brief TetGen 1.5 wrapper: flags, a crash-free driver, error translation, orientation, stats.
#include "nodes/tetrahedralize/tetgen.h"

#include "nodes/algorithms/reference_length.h"
#include "nodes/formats/surface_io.h"
#include "runtime/abort_guard.h"
#include "runtime/errors.h"
#include "runtime/stopwatch.h"

#include <Eigen/Geometry>
#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>
#include <tetgen.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <ctime>
#include <mutex>
#include <sstream>
#include <unistd.h>
#include <unordered_map>
#include <vector>

namespace polyhex {
namespace {

using Vec3 = Eigen::Vector3d;

constexpr double kVolumeFactor = 1.5;
constexpr double kTetsPerRegularVolume = 1.5;  // tets per volume of a regular tet of edge h (measured)
constexpr double kGrid = 68719476736.0;        // 2^36: normalized coordinates are rounded to multiples of 1 / kGrid
constexpr int kTurnedAttempts = 2;             // frames TetGen is tried in after a failed assertion

/// The k-th fixed frame TetGen is tried in after a failed assertion (k >= 1): a turn about an oblique axis.
Eigen::Matrix3d retry_turn(int k) {
  return Eigen::AngleAxisd(0.5 + 0.7 * k, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
}

std::string name_of(const SurfaceMesh& s) { return s.source.empty() ? std::string("surface") : s.source; }

void validate(const SurfaceMesh& s) {
  const std::string who = name_of(s);
  if (s.V.rows() < 4 || s.F.rows() < 4)
    throw InvalidInput(who + ": cannot tetrahedralize a surface with " + std::to_string(s.V.rows()) + " vertices and " +
                       std::to_string(s.F.rows()) + " triangles (a closed surface needs at least 4 of each)");
  if (!s.V.allFinite()) throw InvalidInput(who + ": vertex coordinates are not all finite");
  if (s.F.minCoeff() < 0 || s.F.maxCoeff() >= s.V.rows())
    throw InvalidInput(who + ": triangle vertex index out of range (" + std::to_string(s.V.rows()) + " vertices)");
  const double diag = (s.V.colwise().maxCoeff() - s.V.colwise().minCoeff()).norm();
  if (!std::isfinite(diag))
    throw InvalidInput(who + ": coordinates too large: the bounding-box diagonal overflows a double");
  if (!(diag > 0)) throw InvalidInput(who + ": all vertices are at one point (bounding-box diagonal 0)");
  // TetGen needs a closed, manifold surface: the reader's check (it may arrive unchecked, with defects).
  SurfaceMesh checked = s;
  SurfaceReadReport report;
  try {
    check_and_repair_surface(checked, who, report);
  } catch (const InvalidInput& e) {
    throw InvalidInput(std::string(e.what()) +
                       "; TetGen needs a closed, manifold surface: mesh it through a condition_surface node "
                       "(configs/default.json has one)");
  }
}

std::string short_number(double x) {
  std::ostringstream o;
  o.precision(3);
  o << x;
  return o.str();
}

/// Physical memory of the machine in bytes (0 when unknown).
double physical_memory() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
  return pages > 0 && page > 0 ? double(pages) * double(page) : 0.0;
}

/// Refuses a request whose estimated size exceeds max_tets or the machine's memory.
void check_size(const TetEstimate& e, const TetgenParams& p, const std::string& who) {
  const double memory = physical_memory();
  const bool too_many = e.tets > double(p.max_tets);
  const bool too_big = memory > 0 && e.bytes > memory;
  if (!too_many && !too_big) return;
  // The count scales as 1 / edge_length^3: the smallest edge_length within both limits.
  double limit = double(p.max_tets);
  if (memory > 0) limit = std::min(limit, memory / kTetgenBytesPerTet);
  const double min_edge = p.edge_length * std::cbrt(e.tets / limit);
  std::string why = too_many ? "more than max_tets = " + std::to_string(p.max_tets) : "";
  if (too_big)
    why += std::string(too_many ? ", and " : "") + "needing about " + short_number(e.bytes / 1e9) +
           " GB where the machine has " + short_number(memory / 1e9) + " GB";
  throw InvalidInput(who + ": refused: edge_length " + short_number(p.edge_length) + " (h = " + short_number(e.h) +
                     ") would give about " + short_number(e.tets) + " tets (enclosed volume " + short_number(e.volume) +
                     " / " + short_number(e.volume / e.tets) + " per tet), " + why +
                     "; use edge_length >= " + short_number(min_edge * 1.01) + " or raise max_tets");
}

/// A coordinate transform x -> (x - centre) / scale that puts the bounding box centre at the origin
/// and its diagonal at 1: TetGen's tolerances and our volume bound then see the same numbers at any
/// scale or offset.
struct Normalization {
  Eigen::RowVector3d centre;
  double scale = 1;
  explicit Normalization(const RowMatrixX3d& V)
      : centre(0.5 * (V.colwise().maxCoeff() + V.colwise().minCoeff())),
        scale((V.colwise().maxCoeff() - V.colwise().minCoeff()).norm()) {}
};

/// Hash of the exact bits of a point, to give input vertices their input coordinates back.
struct PointBits {
  std::uint64_t x, y, z;
  bool operator==(const PointBits& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct PointBitsHash {
  size_t operator()(const PointBits& p) const {
    return std::hash<std::uint64_t>()(p.x * 0x9E3779B97F4A7C15ull ^ (p.y + 0x632BE59BD9B4E019ull) ^ (p.z << 1));
  }
};
PointBits bits_of(const double* p) {
  PointBits b;
  std::memcpy(&b.x, p, 8);
  std::memcpy(&b.y, p + 1, 8);
  std::memcpy(&b.z, p + 2, 8);
  return b;
}

std::uint64_t edge_key(int a, int b) {
  if (a > b) std::swap(a, b);
  return (static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint32_t>(b);
}

std::string tetgen_error(int code, const std::string& who) {
  const std::string c = " (TetGen code " + std::to_string(code) + ")";
  switch (code) {
    case 1:
      return who + ": TetGen ran out of memory" + c + "; use a larger edge_length";
    case 2:
      return who + ": TetGen hit an internal error" + c +
             "; the surface is probably degenerate or nearly self-intersecting";
    case 3:
      return who + ": the surface intersects itself" + c + "; repair it before meshing";
    case 4:
      return who +
             ": the surface has a feature smaller than TetGen's tolerance (a vertex almost on a facet or two almost "
             "coincident vertices)" +
             c + "; remove tiny features before meshing";
    case 5:
      return who + ": two facets of the surface nearly touch or overlap" + c + "; repair it before meshing";
    default:
      return who + ": TetGen failed" + c;
  }
}

/// TetGen's robust predicates keep global state set up from each input's bounding box
/// (exactinit), so two runs must not overlap.
std::mutex& tetgen_mutex() {
  static std::mutex m;
  return m;
}

/// Runs TetGen's steps for a PLC (-p, optionally -Y) in the order of TetGen 1.5.0's own
/// tetrahedralize(tetgenbehavior*, ...), which we cannot call: when 1.5.0 fails, terminatetetgen()
/// frees the mesh and throws, and the destructor of the driver's local tetgenmesh frees it again
/// while unwinding, which crashes the process (double free; girl.off triggers it). Here the mesh
/// lives on the heap and after a failure only its storage is released, without the destructor:
/// terminatetetgen() has already freed its pools (freememory() leaves the pointers set, so the
/// destructor would free them again). The locals TetGen loses in the failing step are its own
/// (tools/lsan.supp).
/// \throw int TetGen's error code
void run_tetgen(tetgenbehavior& b, tetgenio& in, tetgenio& out) {
  auto* m = new tetgenmesh();
  try {
    m->b = &b;
    m->in = &in;
    m->addin = nullptr;
    m->initializepools();
    m->transfernodes();
    exactinit(b.verbose, b.noexact, b.nostaticfilter, m->xmax - m->xmin, m->ymax - m->ymin, m->zmax - m->zmin);
    clock_t tick = 0;  // TetGen's step timers, unused
    m->incrementaldelaunay(tick);
    m->meshsurface();
    if (b.nobisect)
      m->recoverboundary(tick);  // -Y: recover the input facets without splitting them
    else
      m->constraineddelaunay(tick);
    m->carveholes();  // remove the tets outside the surface
    if (b.nobisect) {
      if (m->subvertstack->objects > 0) m->suppresssteinerpoints();
      m->recoverdelaunay();
    }
    if (b.quality) m->delaunayrefinement();  // -q and -a
    if (b.optlevel > 0) m->optimizemesh();   // default -O2/7: flips and smoothing
    if (!b.nojettison && (m->dupverts > 0 || m->unuverts > 0)) m->jettisonnodes();
    out.firstnumber = in.firstnumber;
    out.mesh_dim = in.mesh_dim;
    m->outnodes(&out);
    if (m->tetrahedrons->items > 0) m->outelements(&out);
  } catch (int) {
    ::operator delete(static_cast<void*>(m));
    throw;
  }
  delete m;
}

double tet_volume6(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return (b - a).cross(c - a).dot(d - a);
}

}  // namespace

TetgenStats tet_stats(const TetMesh& mesh, double h) {
  TetgenStats s;
  s.tets = mesh.T.rows();
  s.vertices = mesh.V.rows();
  s.target_edge = h;
  if (mesh.T.rows() == 0) return s;
  auto P = [&](int i) -> Vec3 { return mesh.V.row(i).transpose(); };
  static const int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  // Per tet (in parallel; minima and maxima do not depend on the order): its edges (key, length) into six
  // slots, the smallest n_k.n_l (the smallest dihedral angle) and the largest circumradius over shortest edge.
  const size_t nt = size_t(mesh.T.rows());
  std::vector<std::pair<std::uint64_t, double>> edges(6 * nt);
  struct Extremes {
    double min_normal_dot = 2, max_radius_edge = 0;
  };
  const Extremes ex = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, nt, 4096), Extremes{},
      [&](const tbb::blocked_range<size_t>& r, Extremes x) {
        for (size_t t = r.begin(); t < r.end(); ++t) {
          const Eigen::Index ti = Eigen::Index(t);
          Vec3 p[4];
          for (int k = 0; k < 4; ++k) p[k] = P(mesh.T(ti, k));
          double shortest = INFINITY;
          for (int e = 0; e < 6; ++e) {
            const double len = (p[kEdges[e][0]] - p[kEdges[e][1]]).norm();
            shortest = std::min(shortest, len);
            edges[6 * t + size_t(e)] = {edge_key(mesh.T(ti, kEdges[e][0]), mesh.T(ti, kEdges[e][1])), len};
          }
          // Outward face normals: n[k] is the normal of the face opposite vertex k. The dihedral angle at
          // the edge shared by faces k and l is pi - angle(n[k], n[l]).
          Vec3 n[4];
          for (int k = 0; k < 4; ++k) {
            const Vec3 &a = p[(k + 1) % 4], &b = p[(k + 2) % 4], &c = p[(k + 3) % 4];
            Vec3 nk = (b - a).cross(c - a);
            if (nk.dot(p[k] - a) > 0) nk = -nk;
            n[k] = nk.normalized();
          }
          for (int k = 0; k < 4; ++k)
            for (int l = k + 1; l < 4; ++l) x.min_normal_dot = std::min(x.min_normal_dot, n[k].dot(n[l]));
          // Circumradius: |a|^2 (b x c) + |b|^2 (c x a) + |c|^2 (a x b) over 2 a.(b x c), a, b, c from p0.
          const Vec3 a = p[1] - p[0], b = p[2] - p[0], c = p[3] - p[0];
          const Vec3 num = a.squaredNorm() * b.cross(c) + b.squaredNorm() * c.cross(a) + c.squaredNorm() * a.cross(b);
          const double radius = num.norm() / std::abs(2 * a.dot(b.cross(c)));
          x.max_radius_edge = std::max(x.max_radius_edge, radius / shortest);
        }
        return x;
      },
      [](Extremes x, const Extremes& y) {
        x.min_normal_dot = std::min(x.min_normal_dot, y.min_normal_dot);
        x.max_radius_edge = std::max(x.max_radius_edge, y.max_radius_edge);
        return x;
      });
  s.max_radius_edge = ex.max_radius_edge;
  // smallest dihedral = pi - largest angle between outward normals = acos(-min n_k.n_l)
  s.min_dihedral_deg = std::acos(std::clamp(-ex.min_normal_dot, -1.0, 1.0)) * 180.0 / M_PI;
  // Each edge once: the copies of an edge (one per tet around it) have the same key and the same length, so
  // after sorting by key the first of each run stands for it, and the mean is summed in key order.
  tbb::parallel_sort(edges.begin(), edges.end());
  s.edge_min = INFINITY;
  double sum = 0;
  size_t unique = 0;
  for (size_t i = 0; i < edges.size(); ++i) {
    if (i > 0 && edges[i].first == edges[i - 1].first) continue;
    const double len = edges[i].second;
    s.edge_min = std::min(s.edge_min, len);
    s.edge_max = std::max(s.edge_max, len);
    sum += len;
    ++unique;
  }
  s.edge_min /= h;
  s.edge_max /= h;
  s.edge_mean = sum / static_cast<double>(unique) / h;
  return s;
}

TetEstimate estimate_tets(const SurfaceMesh& surface, double edge_length) {
  TetEstimate e;
  const Normalization n(surface.V);
  // Enclosed volume by the divergence theorem, in normalized coordinates (then scaled back).
  double vol = 0;
  for (Eigen::Index f = 0; f < surface.F.rows(); ++f) {
    const Vec3 a = (surface.V.row(surface.F(f, 0)) - n.centre) / n.scale,
               b = (surface.V.row(surface.F(f, 1)) - n.centre) / n.scale,
               c = (surface.V.row(surface.F(f, 2)) - n.centre) / n.scale;
    vol += a.dot(b.cross(c)) / 6.0;
  }
  // The target edge in normalized units (box diagonal 1): edge_length of the reference length.
  e.reference_length = reference_length(surface.V);
  const double h_unit = edge_length * (e.reference_length / n.scale);
  e.h = h_unit * n.scale;
  e.volume = std::abs(vol) * n.scale * n.scale * n.scale;
  // TetGen's tets come out smaller than its volume bound (1.5 regular tets): measured on a box, the
  // mean tet is the volume of a regular tet of edge h divided by 1.4-1.7.
  e.tets = kTetsPerRegularVolume * std::abs(vol) / (h_unit * h_unit * h_unit / (6.0 * std::sqrt(2.0)));
  e.bytes = e.tets * kTetgenBytesPerTet;
  return e;
}

TetMesh tetrahedralize(const SurfaceMesh& surface, const TetgenParams& p, TetgenStats* stats) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::string who = name_of(surface);
  validate(surface);
  if (!(p.edge_length > 0)) throw InvalidInput(who + ": edge_length must be positive");
  const TetEstimate estimate = estimate_tets(surface, p.edge_length);
  check_size(estimate, p, who);
  const Normalization norm(surface.V);
  const double h = estimate.h;                                                     // absolute target edge
  const double h_unit = p.edge_length * (estimate.reference_length / norm.scale);  // in normalized coordinates

  // TetGen's -a is an upper bound and the refined tets come out smaller, so the bound is 1.5 times
  // the volume of a regular tet of edge h (h^3 / (6 sqrt 2) ~ 0.118 h^3): measured, this puts the
  // mean interior edge at 0.95-1.0 h (sphere) and the mean edge of a box mesh at 0.93 h, where the
  // plain regular-tet bound gave 0.85 h and 0.78 h.
  const double max_volume = kVolumeFactor * h_unit * h_unit * h_unit / (6.0 * std::sqrt(2.0));
  std::ostringstream sw;
  sw.precision(17);
  sw << "pzQq" << p.radius_edge << "/" << p.min_dihedral << "a" << max_volume << (p.refine_surface ? "" : "Y");
  std::string switches = sw.str();

  // TetGen 1.5.0 as Debian builds it checks itself with assert(), and on some surfaces a check fails in
  // one frame and not in another (in-volume_twist in its canonical placement, nodes/orient/placement.h):
  // the failure is caught (runtime/abort_guard.h) and TetGen runs again on the surface turned about its
  // centre by a fixed rotation, the tets turned back (input vertices keep their exact coordinates).
  const RowMatrixX3d unit = (surface.V.rowwise() - norm.centre) / norm.scale;
  Eigen::Matrix3d turn = Eigen::Matrix3d::Identity();
  int aborted = 0;
  std::unordered_map<PointBits, int, PointBitsHash> input_point;
  tetgenio out;
  for (;; ++aborted) {
    if (aborted > 0) turn = retry_turn(aborted);
    // Normalized coordinates, rounded to multiples of 2^-36 (1.5e-11 of the diagonal): a model scaled by
    // 1e-9 normalizes to numbers a few ulps away from the unit model's, and the rounding makes them
    // (almost always) bit-identical, so TetGen takes the same decisions and gives the same tets.
    const RowMatrixX3d V =
        ((aborted == 0 ? unit : RowMatrixX3d(unit * turn.transpose())) * kGrid).array().round() / kGrid;
    const RowMatrixX3i& F = surface.F;
    input_point.clear();
    input_point.reserve(size_t(V.rows()));
    for (Eigen::Index i = 0; i < V.rows(); ++i) input_point.emplace(bits_of(V.data() + 3 * i), int(i));
    tetgenio in;
    in.firstnumber = 0;
    in.numberofpoints = static_cast<int>(V.rows());
    in.pointlist = new REAL[3 * V.rows()];
    std::copy(V.data(), V.data() + 3 * V.rows(), in.pointlist);  // row-major: x0 y0 z0 x1 ...
    in.numberoffacets = static_cast<int>(F.rows());
    in.facetlist = new tetgenio::facet[F.rows()];
    for (Eigen::Index i = 0; i < F.rows(); ++i) {
      tetgenio::facet& f = in.facetlist[i];
      tetgenio::init(&f);
      f.numberofpolygons = 1;
      f.polygonlist = new tetgenio::polygon[1];
      tetgenio::init(&f.polygonlist[0]);
      f.polygonlist[0].numberofvertices = 3;
      f.polygonlist[0].vertexlist = new int[3]{F(i, 0), F(i, 1), F(i, 2)};
    }
    out.deinitialize();
    out.initialize();
    bool finished = false;
    {
      std::lock_guard<std::mutex> lock(tetgen_mutex());
      try {
        tetgenbehavior b;
        if (!b.parse_commandline(switches.data())) throw InvalidInput(who + ": bad TetGen switches " + switches);
        finished = returns_without_abort([&] { run_tetgen(b, in, out); });
      } catch (int code) {
        throw InvalidInput(tetgen_error(code, who));
      }
    }
    if (finished) break;
    if (aborted == kTurnedAttempts)
      throw InvalidInput(who +
                         ": TetGen failed one of its internal checks (an assertion) in the input's frame and in " +
                         std::to_string(kTurnedAttempts) + " turned frames");
  }
  if (out.numberoftetrahedra <= 0 || out.numberofcorners != 4)
    throw InvalidInput(who + ": TetGen produced no tetrahedra; is the surface closed?");

  // Copy, orient every tet positively and drop unused points.
  TetMesh m;
  m.source = surface.source;
  std::vector<int> remap(out.numberofpoints, -1);
  int nv = 0;
  m.T.resize(out.numberoftetrahedra, 4);
  for (int t = 0; t < out.numberoftetrahedra; ++t)
    for (int k = 0; k < 4; ++k) {
      int v = out.tetrahedronlist[4 * t + k];
      if (remap[v] < 0) remap[v] = nv++;
      m.T(t, k) = remap[v];
    }
  m.V.resize(nv, 3);
  // Back to the input's coordinates; input vertices get their exact input coordinates.
  for (int i = 0; i < out.numberofpoints; ++i) {
    if (remap[i] < 0) continue;
    const double* q = out.pointlist + 3 * i;
    auto it = input_point.find(bits_of(q));
    if (it != input_point.end())
      m.V.row(remap[i]) = surface.V.row(it->second);
    else
      m.V.row(remap[i]) = (aborted == 0 ? Eigen::RowVector3d(q[0], q[1], q[2])
                                        : Eigen::RowVector3d(Eigen::RowVector3d(q[0], q[1], q[2]) * turn)) *
                              norm.scale +
                          norm.centre;
  }
  for (Eigen::Index t = 0; t < m.T.rows(); ++t) {
    Vec3 a = m.V.row(m.T(t, 0)), b = m.V.row(m.T(t, 1)), c = m.V.row(m.T(t, 2)), d = m.V.row(m.T(t, 3));
    if (tet_volume6(a, b, c, d) < 0) std::swap(m.T(t, 1), m.T(t, 2));
  }

  if (stats) {
    *stats = tet_stats(m, h);
    stats->estimated_tets = estimate.tets;
    stats->aborted_attempts = aborted;
    stats->seconds = seconds_since(t0);
  }
  return m;
}

}  // namespace polyhex
