#include "nodes/artefacts/serialize.h"

#include "graph/node.h"
#include "nodes/artefacts/boundary_groups.h"

#include <istream>
#include <limits>
#include <ostream>
#include <type_traits>

namespace polyhex {
namespace {

static_assert(sizeof(double) == 8 && sizeof(int) == 4, "the cache payload assumes 64-bit doubles and 32-bit ints");

// --- writing -----------------------------------------------------------------------------------

class Writer {
 public:
  explicit Writer(std::ostream& out) : out_(out) {}
  template <class T>
  void pod(const T& v) {
    static_assert(std::is_arithmetic_v<T>, "plain numbers only");
    raw(&v, sizeof(T));
  }
  void count(size_t n) { pod(std::uint64_t(n)); }
  void flag(bool b) { pod(std::uint8_t(b ? 1 : 0)); }
  void str(const std::string& s) {
    count(s.size());
    raw(s.data(), s.size());
  }
  template <class T>
  void vec(const std::vector<T>& v) {
    count(v.size());
    if constexpr (std::is_same_v<T, std::string>) {
      for (auto& s : v) str(s);
    } else {
      raw(v.data(), v.size() * sizeof(T));
    }
  }
  /// Matrices and vectors with a fixed column count: rows, then the row-major data.
  template <class M>
  void matrix(const M& m) {
    count(size_t(m.rows()));
    if constexpr (M::IsRowMajor || M::ColsAtCompileTime == 1) {
      raw(m.data(), size_t(m.size()) * sizeof(typename M::Scalar));
    } else {
      for (Eigen::Index r = 0; r < m.rows(); ++r)
        for (Eigen::Index c = 0; c < m.cols(); ++c) pod(m(r, c));
    }
  }

 private:
  void raw(const void* p, size_t n) {
    out_.write(static_cast<const char*>(p), std::streamsize(n));
    if (!out_) throw IOError("artefact cache: write failed");
  }
  std::ostream& out_;
};

// --- reading -----------------------------------------------------------------------------------

class Reader {
 public:
  Reader(std::istream& in, const char* what) : in_(in), what_(what) {
    auto here = in_.tellg();
    in_.seekg(0, std::ios::end);
    auto end = in_.tellg();
    in_.seekg(here);
    if (here < 0 || end < here) fail("stream is not seekable");
    left_ = std::uint64_t(end - here);
  }
  [[noreturn]] void fail(const std::string& msg) const {
    throw IOError(std::string("artefact cache: ") + what_ + " payload: " + msg);
  }
  template <class T>
  T pod() {
    T v{};
    raw(&v, sizeof(T));
    return v;
  }
  /// A count of elements of `elem_bytes` each, checked against the bytes left.
  size_t count(size_t elem_bytes) {
    auto n = pod<std::uint64_t>();
    if (elem_bytes > 0 && n > left_ / elem_bytes)
      fail("count " + std::to_string(n) + " exceeds the " + std::to_string(left_) + " bytes left");
    return size_t(n);
  }
  bool flag() {
    auto b = pod<std::uint8_t>();
    if (b > 1) fail("flag byte " + std::to_string(b) + " is not 0 or 1");
    return b == 1;
  }
  std::string str() {
    std::string s(count(1), '\0');
    raw(s.data(), s.size());
    return s;
  }
  template <class T>
  std::vector<T> vec() {
    if constexpr (std::is_same_v<T, std::string>) {
      std::vector<std::string> v(count(8));
      for (auto& s : v) s = str();
      return v;
    } else {
      std::vector<T> v(count(sizeof(T)));
      raw(v.data(), v.size() * sizeof(T));
      return v;
    }
  }
  template <class M>
  M matrix() {
    const Eigen::Index cols = M::ColsAtCompileTime == Eigen::Dynamic ? 1 : M::ColsAtCompileTime;
    const size_t rows = count(size_t(cols) * sizeof(typename M::Scalar));
    M m(Eigen::Index(rows), cols);
    static_assert(M::IsRowMajor || M::ColsAtCompileTime == 1, "row-major matrices or vectors");
    raw(m.data(), size_t(m.size()) * sizeof(typename M::Scalar));
    return m;
  }
  void finish() const {
    if (left_ != 0) fail(std::to_string(left_) + " bytes left over");
  }
  /// Every entry of `idx` in [0, n).
  template <class M>
  void check_index(const M& idx, Eigen::Index n, const char* name) const {
    if (idx.size() == 0) return;
    if (idx.minCoeff() < 0 || idx.maxCoeff() >= n)
      fail(std::string(name) + " index out of range [0, " + std::to_string(n) + ")");
  }

 private:
  void raw(void* p, size_t n) {
    if (n > left_) fail("truncated");
    in_.read(static_cast<char*>(p), std::streamsize(n));
    if (!in_) fail("read failed");
    left_ -= n;
  }
  std::istream& in_;
  const char* what_;
  std::uint64_t left_ = 0;
};

// The three mesh types share a layout: source, V, elements.
template <class M, class Cells>
void write_mesh(Writer& w, const M& m, const Cells& cells) {
  w.str(m.source);
  w.matrix(m.V);
  w.matrix(cells);
}
template <class M, class Cells>
M read_mesh(Reader& r, Cells M::*cells) {
  M m;
  m.source = r.str();
  m.V = r.matrix<RowMatrixX3d>();
  m.*cells = r.matrix<Cells>();
  r.check_index(m.*cells, m.V.rows(), "vertex");
  return m;
}

// A HexMesh: the mesh layout, then its boundary groups (name, family, id, (hex, face) pairs).
void write_hex(Writer& w, const HexMesh& m) {
  write_mesh(w, m, m.H);
  w.count(m.groups.size());
  for (const BoundaryGroup& g : m.groups) {
    w.str(g.name);
    w.str(g.family);
    w.pod(std::int32_t(g.id));
    w.vec(g.faces);
  }
}

HexMesh read_hex(Reader& r) {
  HexMesh m = read_mesh(r, &HexMesh::H);
  m.groups.resize(r.count(28));  // smallest group record: 8 + 8 + 4 + 8 bytes
  for (BoundaryGroup& g : m.groups) {
    g.name = r.str();
    g.family = r.str();
    g.id = r.pod<std::int32_t>();
    g.faces = r.vec<std::array<int, 2>>();
  }
  if (const std::string problem = boundary_groups_problem(m); !problem.empty()) r.fail(problem);
  return m;
}

void write_segmentation(Writer& w, const PolyCubeSegmentation& s) {
  w.matrix(s.F);
  w.matrix(s.chart);
  w.matrix(s.label);
  w.count(s.charts.size());
  for (auto& c : s.charts) {
    w.pod(std::int32_t(c.label));
    w.pod(std::int32_t(c.triangles));
    w.pod(c.area);
    w.vec(c.neighbours);
    w.flag(c.separating);
  }
  w.count(s.edges.size());
  for (auto& e : s.edges) {
    w.pod(std::int32_t(e.chart_a));
    w.pod(std::int32_t(e.chart_b));
    w.vec(e.vertices);
    w.flag(e.closed);
  }
  w.count(s.corners.size());
  for (auto& c : s.corners) {
    w.pod(std::int32_t(c.vertex));
    w.pod(std::int32_t(c.valence));
    w.vec(c.charts);
  }
  for (int v : {s.splits_multi_orientation, s.splits_wedge, s.splits_ramp, s.splits_order_cycle, s.order_cycles,
                s.splits_island, s.repaired_corners, s.removed_small, s.removed_narrow, s.smoothing_iterations})
    w.pod(std::int32_t(v));
  w.flag(s.valid);
  w.vec(s.problems);
  w.vec(s.failing_charts);
  w.vec(s.warnings);
  w.str(s.source);
}

PolyCubeSegmentation read_segmentation(Reader& r) {
  PolyCubeSegmentation s;
  s.F = r.matrix<RowMatrixX3i>();
  s.chart = r.matrix<Eigen::VectorXi>();
  s.label = r.matrix<Eigen::VectorXi>();
  if (s.chart.size() != s.F.rows() || s.label.size() != s.F.rows())
    r.fail("chart/label sizes differ from the " + std::to_string(s.F.rows()) + " triangles");
  r.check_index(s.F, std::numeric_limits<int>::max(), "vertex");
  r.check_index(s.label, 6, "label");
  s.charts.resize(r.count(21));  // smallest chart record: 4 + 4 + 8 + 8 + 1 bytes
  for (auto& c : s.charts) {
    c.label = r.pod<std::int32_t>();
    c.triangles = r.pod<std::int32_t>();
    c.area = r.pod<double>();
    c.neighbours = r.vec<int>();
    c.separating = r.flag();
  }
  r.check_index(s.chart, Eigen::Index(s.charts.size()), "chart");
  s.edges.resize(r.count(17));
  for (auto& e : s.edges) {
    e.chart_a = r.pod<std::int32_t>();
    e.chart_b = r.pod<std::int32_t>();
    e.vertices = r.vec<int>();
    e.closed = r.flag();
  }
  s.corners.resize(r.count(16));
  for (auto& c : s.corners) {
    c.vertex = r.pod<std::int32_t>();
    c.valence = r.pod<std::int32_t>();
    c.charts = r.vec<int>();
  }
  for (int* v : {&s.splits_multi_orientation, &s.splits_wedge, &s.splits_ramp, &s.splits_order_cycle, &s.order_cycles,
                 &s.splits_island, &s.repaired_corners, &s.removed_small, &s.removed_narrow, &s.smoothing_iterations})
    *v = r.pod<std::int32_t>();
  s.valid = r.flag();
  s.problems = r.vec<std::string>();
  s.failing_charts = r.vec<int>();
  s.warnings = r.vec<std::string>();
  s.source = r.str();
  return s;
}

void write_map(Writer& w, const PolyCubeMap& m) {
  w.flag(m.input != nullptr);
  if (m.input) write_mesh(w, *m.input, m.input->T);
  w.flag(m.segmentation != nullptr);
  if (m.segmentation) write_segmentation(w, *m.segmentation);
  w.matrix(m.U);
  w.pod(m.edge_length);
  w.matrix(m.chart_plane);
}

PolyCubeMap read_map(Reader& r) {
  PolyCubeMap m;
  if (r.flag()) m.input = std::make_shared<const TetMesh>(read_mesh(r, &TetMesh::T));
  if (r.flag()) m.segmentation = std::make_shared<const PolyCubeSegmentation>(read_segmentation(r));
  m.U = r.matrix<RowMatrixX3d>();
  m.edge_length = r.pod<double>();
  m.chart_plane = r.matrix<Eigen::VectorXi>();
  if (m.input && m.U.rows() != m.input->V.rows())
    r.fail("U has " + std::to_string(m.U.rows()) + " rows for " + std::to_string(m.input->V.rows()) + " vertices");
  if (m.segmentation && m.chart_plane.size() != Eigen::Index(m.segmentation->charts.size()))
    r.fail("chart_plane has " + std::to_string(m.chart_plane.size()) + " entries for " +
           std::to_string(m.segmentation->charts.size()) + " charts");
  return m;
}

// Reads one whole payload with `read` and checks nothing is left over.
template <class F>
auto read_all(std::istream& in, const char* what, F read) {
  Reader r(in, what);
  auto v = read(r);
  r.finish();
  return v;
}

template <class T>
void add_codec(void (*write)(std::ostream&, const T&), T (*read)(std::istream&)) {
  ArtefactCodec c;
  c.version = kCodecVersion;
  c.write = [write](const Artefact& a, std::ostream& out) { write(out, *a.as<T>()); };
  c.read = [read](std::istream& in) { return make_artefact(read(in)); };
  Registry::instance().add_codec(artefact_name<T>(), std::move(c));
}

const bool registered_codecs = [] {
  add_codec<SurfaceMesh>(&write_binary, &read_surface_binary);
  add_codec<TetMesh>(&write_binary, &read_tetmesh_binary);
  add_codec<HexMesh>(&write_binary, &read_hexmesh_binary);
  add_codec<PolyCubeSegmentation>(&write_binary, &read_segmentation_binary);
  add_codec<PolyCubeMap>(&write_binary, &read_polycube_map_binary);
  add_codec<Frames>(&write_binary, &read_frames_binary);
  return true;
}();

}  // namespace

void write_binary(std::ostream& out, const SurfaceMesh& m) {
  Writer w(out);
  write_mesh(w, m, m.F);
}
void write_binary(std::ostream& out, const TetMesh& m) {
  Writer w(out);
  write_mesh(w, m, m.T);
}
void write_binary(std::ostream& out, const HexMesh& m) {
  Writer w(out);
  write_hex(w, m);
}
void write_binary(std::ostream& out, const PolyCubeSegmentation& s) {
  Writer w(out);
  write_segmentation(w, s);
}
void write_binary(std::ostream& out, const PolyCubeMap& m) {
  Writer w(out);
  write_map(w, m);
}

SurfaceMesh read_surface_binary(std::istream& in) {
  return read_all(in, "SurfaceMesh", [](Reader& r) { return read_mesh(r, &SurfaceMesh::F); });
}
TetMesh read_tetmesh_binary(std::istream& in) {
  return read_all(in, "TetMesh", [](Reader& r) { return read_mesh(r, &TetMesh::T); });
}
HexMesh read_hexmesh_binary(std::istream& in) { return read_all(in, "HexMesh", read_hex); }
PolyCubeSegmentation read_segmentation_binary(std::istream& in) {
  return read_all(in, "PolyCubeSegmentation", read_segmentation);
}
PolyCubeMap read_polycube_map_binary(std::istream& in) { return read_all(in, "PolyCubeMap", read_map); }
// Frames: u64 count, then per candidate R (9 doubles, row-major), centre (3 doubles), grid, energy, source,
// i32 branch.
void write_binary(std::ostream& out, const Frames& f) {
  Writer w(out);
  w.count(f.candidates.size());
  for (const FrameCandidate& c : f.candidates) {
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 3; ++k) w.pod(c.R(r, k));
    for (int k = 0; k < 3; ++k) w.pod(c.centre[k]);
    w.pod(c.grid);
    w.pod(c.energy);
    w.str(c.source);
    w.pod(std::int32_t(c.branch));
  }
}
Frames read_frames_binary(std::istream& in) {
  return read_all(in, "Frames", [](Reader& r) {
    Frames f;
    f.candidates.resize(r.count(9 * 8 + 3 * 8 + 8 + 8 + 8 + 4));
    for (FrameCandidate& c : f.candidates) {
      for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) c.R(i, k) = r.pod<double>();
      for (int k = 0; k < 3; ++k) c.centre[k] = r.pod<double>();
      c.grid = r.pod<double>();
      if (!(c.grid >= 0)) r.fail("negative grid");
      c.energy = r.pod<double>();
      c.source = r.str();
      c.branch = r.pod<std::int32_t>();
      if (c.branch < 0) r.fail("negative branch");
    }
    return f;
  });
}

}  // namespace polyhex
