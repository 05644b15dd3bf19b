#include "nodes/formats/tetmesh_io.h"

#include "nodes/formats/surface_io.h"
#include "nodes/formats/text_cursor.h"
#include "runtime/errors.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace polyhex {

using io_detail::TextCursor;

namespace {

std::string vertex_count(size_t nv) { return std::to_string(nv) + (nv == 1 ? " vertex" : " vertices"); }

// TetGen .node/.ele: `#` comments; .node: `n 3 nattr nbm` then `i x y z [attr...] [bm]`; .ele:
// `m 4|10 nattr` then `j a b c d [...]`. Indices start at the first index of the .node file.
CellsRead read_tetgen(const std::filesystem::path& given) {
  std::filesystem::path node_path = given, ele_path = given;
  node_path.replace_extension(".node");
  ele_path.replace_extension(".ele");
  CellsRead r;
  std::vector<std::string_view> w;
  std::string_view l;
  long long base = 0;
  {
    const std::string file = node_path.string();
    const std::string data = io_detail::load_file(node_path);
    TextCursor c(data, file, '#');
    if (!c.next_line(l)) throw IOError(file + ": empty file");
    io_detail::split_blanks(l, w);
    long long n, dim;
    if (w.size() < 2 || !io_detail::parse_int(w[0], n) || !io_detail::parse_int(w[1], dim) || n < 0)
      c.fail("expected `points dimension attributes boundary-markers`");
    if (dim != 3) c.fail("dimension " + std::to_string(dim) + " is not supported (expected 3)");
    std::vector<double> xyz;
    xyz.reserve(3 * c.reserve_hint(n, 8));
    for (long long i = 0; i < n; ++i) {
      if (!c.next_line(l))
        c.fail("truncated: the header announces " + vertex_count(size_t(n)) + ", the file ends after " +
               std::to_string(i));
      io_detail::split_blanks(l, w);
      long long idx;
      if (w.size() < 4 || !io_detail::parse_int(w[0], idx)) c.fail("expected `index x y z`");
      if (i == 0) {
        if (idx != 0 && idx != 1) c.fail("the first point index must be 0 or 1, got " + std::to_string(idx));
        base = idx;
      }
      if (idx != base + i)
        c.fail("point index " + std::to_string(idx) + ", expected " + std::to_string(base + i) + " (wrong counts?)");
      for (int k = 0; k < 3; ++k) {
        double x;
        if (!io_detail::parse_double(w[size_t(k + 1)], x))
          c.fail("expected a coordinate, got `" + std::string(w[size_t(k + 1)]) + "`");
        if (!std::isfinite(x)) c.fail("point " + std::to_string(idx) + " has a non-finite coordinate");
        xyz.push_back(x);
      }
    }
    if (c.next_line(l))
      c.fail("more data after the " + vertex_count(size_t(n)) + " the header announces (wrong counts?)");
    r.V = Eigen::Map<const RowMatrixX3d>(xyz.data(), Eigen::Index(n), 3);
  }
  const std::string file = ele_path.string();
  const std::string data = io_detail::load_file(ele_path);
  TextCursor c(data, file, '#');
  if (!c.next_line(l)) throw IOError(file + ": empty file");
  io_detail::split_blanks(l, w);
  long long m, per;
  if (w.size() < 2 || !io_detail::parse_int(w[0], m) || !io_detail::parse_int(w[1], per) || m < 0)
    c.fail("expected `tetrahedra nodes-per-tet attributes`");
  if (per != 4 && per != 10) c.fail(std::to_string(per) + " nodes per tet is not supported (expected 4 or 10)");
  const size_t nv = size_t(r.V.rows());
  r.cells.reserve(4 * c.reserve_hint(m, 10));
  for (long long t = 0; t < m; ++t) {
    if (!c.next_line(l))
      c.fail("truncated: the header announces " + std::to_string(m) + " tets, the file ends after " +
             std::to_string(t));
    io_detail::split_blanks(l, w);
    if ((long long)w.size() < 1 + per) c.fail("tet needs an index and " + std::to_string(per) + " vertex indices");
    for (int k = 0; k < 4; ++k) {
      long long v;
      if (!io_detail::parse_int(w[size_t(k + 1)], v))
        c.fail("expected a vertex index, got `" + std::string(w[size_t(k + 1)]) + "`");
      if (v - base < 0 || v - base >= (long long)nv)
        c.fail("tet " + std::to_string(t) + ": vertex index " + std::to_string(v) + " out of range (" +
               vertex_count(nv) + ", first index " + std::to_string(base) + ")");
      r.cells.push_back(int(v - base));
    }
  }
  if (c.next_line(l)) c.fail("more data after the " + std::to_string(m) + " tets the header announces (wrong counts?)");
  return r;
}

/// Faces shared by more than 2 tets or by two tets on the same side (overlapping tets) are errors;
/// the faces used once (the boundary) must form a closed manifold surface (no edge or vertex where
/// two parts of the solid only touch). \return the number of boundary faces
/// \pre every tet positively oriented
long check_tet_faces(const TetMesh& mesh, const std::string& name) {
  // Outward faces of a positive tet (v0 v1 v2 v3).
  static const int kFaces[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  struct Face {
    std::array<int, 3> key;  // sorted vertices
    int tet;
    bool even;  // the outward orientation is an even permutation of key
  };
  const Eigen::Index nt = mesh.T.rows();
  std::vector<Face> faces;
  faces.reserve(size_t(4 * nt));
  for (Eigen::Index t = 0; t < nt; ++t)
    for (const auto& f : kFaces) {
      std::array<int, 3> v{mesh.T(t, f[0]), mesh.T(t, f[1]), mesh.T(t, f[2])};
      // Rotate the smallest first; then the orientation is even iff the rest is increasing.
      while (v[0] > v[1] || v[0] > v[2]) v = {v[1], v[2], v[0]};
      const bool even = v[1] < v[2];
      if (!even) std::swap(v[1], v[2]);
      faces.push_back({v, int(t), even});
    }
  std::sort(faces.begin(), faces.end(),
            [](const Face& a, const Face& b) { return a.key != b.key ? a.key < b.key : a.tet < b.tet; });
  auto face_str = [&](const std::array<int, 3>& k) {
    return "(" + std::to_string(k[0]) + ", " + std::to_string(k[1]) + ", " + std::to_string(k[2]) + ")";
  };
  SurfaceMesh boundary;
  std::vector<int> bf;
  for (size_t i = 0; i < faces.size();) {
    size_t j = i;
    while (j < faces.size() && faces[j].key == faces[i].key) ++j;
    if (j - i > 2)
      throw InvalidInput(name + ": face " + face_str(faces[i].key) + " is shared by " + std::to_string(j - i) +
                         " tets (" + std::to_string(faces[i].tet) + ", " + std::to_string(faces[i + 1].tet) + ", " +
                         std::to_string(faces[i + 2].tet) + ", ...): the tets overlap");
    if (j - i == 2 && faces[i].even == faces[i + 1].even)
      throw InvalidInput(name + ": tets " + std::to_string(faces[i].tet) + " and " + std::to_string(faces[i + 1].tet) +
                         " lie on the same side of their shared face " + face_str(faces[i].key) +
                         ": the tets overlap (a folded or inverted region)");
    if (j - i == 1) {
      const auto& k = faces[i].key;
      if (faces[i].even)
        bf.insert(bf.end(), {k[0], k[1], k[2]});
      else
        bf.insert(bf.end(), {k[0], k[2], k[1]});
    }
    i = j;
  }
  boundary.V = mesh.V;
  boundary.F.resize(Eigen::Index(bf.size() / 3), 3);
  std::copy(bf.begin(), bf.end(), boundary.F.data());
  SurfaceReadReport ignored;
  try {
    check_and_repair_surface(boundary, name + ": boundary", ignored);
  } catch (const InvalidInput& e) {
    throw InvalidInput(std::string(e.what()) + " (the boundary faces of the tets must form a closed manifold surface)");
  }
  return long(boundary.F.rows());
}

}  // namespace

void check_and_orient_tets(TetMesh& mesh, const std::string& name, TetReadReport& report) {
  const Eigen::Index nt = mesh.T.rows();
  if (nt == 0) throw InvalidInput(name + ": no tetrahedra");
  const double diag = (mesh.V.colwise().maxCoeff() - mesh.V.colwise().minCoeff()).norm();
  const double eps = 1e-14 * diag * diag * diag;
  int reoriented = 0;
  for (Eigen::Index t = 0; t < nt; ++t) {
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b)
        if (mesh.T(t, a) == mesh.T(t, b))
          throw InvalidInput(name + ": tet " + std::to_string(t) + " is degenerate: repeated vertex index " +
                             std::to_string(mesh.T(t, a)));
    const Eigen::RowVector3d p0 = mesh.V.row(mesh.T(t, 0));
    const Eigen::Vector3d e1 = mesh.V.row(mesh.T(t, 1)) - p0, e2 = mesh.V.row(mesh.T(t, 2)) - p0,
                          e3 = mesh.V.row(mesh.T(t, 3)) - p0;
    const double vol = e1.cross(e2).dot(e3) / 6.0;
    if (std::abs(vol) <= eps)
      throw InvalidInput(name + ": tet " + std::to_string(t) + " is degenerate: volume " + std::to_string(vol) +
                         " (bounding-box diagonal " + std::to_string(diag) + ")");
    if (vol < 0) {
      std::swap(mesh.T(t, 2), mesh.T(t, 3));
      ++reoriented;
    }
  }
  if (reoriented > 0)
    report.warnings.push_back(name + ": re-oriented " + std::to_string(reoriented) + " inverted tets");
  report.reoriented = reoriented;
  report.boundary_faces = check_tet_faces(mesh, name);

  std::vector<int> map(size_t(mesh.V.rows()), -1);
  for (Eigen::Index i = 0; i < mesh.T.size(); ++i) map[size_t(mesh.T.data()[i])] = 0;
  int n = 0;
  for (auto& x : map)
    if (x == 0) x = n++;
  if (n < mesh.V.rows()) {
    report.warnings.push_back(name + ": dropped " + std::to_string(mesh.V.rows() - n) + " vertices used by no tet");
    RowMatrixX3d V(n, 3);
    for (size_t v = 0; v < map.size(); ++v)
      if (map[v] >= 0) V.row(map[v]) = mesh.V.row(Eigen::Index(v));
    mesh.V = std::move(V);
    for (Eigen::Index i = 0; i < mesh.T.size(); ++i) mesh.T.data()[i] = map[size_t(mesh.T.data()[i])];
  }
  report.vertices = int(mesh.V.rows());
  report.tets = int(nt);
}

TetMesh read_tetmesh(const std::filesystem::path& path, TetReadReport* report) {
  TetReadReport local;
  TetReadReport& r = report ? *report : local;
  r = TetReadReport{};
  const std::string ext = io_detail::lower_extension(path);
  CellsRead raw;
  if (ext == ".node" || ext == ".ele") {
    raw = read_tetgen(path);
  } else if (ext == ".vtk" || ext == ".mesh" || ext == ".msh") {
    raw = read_cell_mesh(path, kTetKind);
  } else {
    throw IOError(path.string() + ": unknown tet mesh extension `" + ext +
                  "` (expected .mesh, .vtk, .msh, .node or .ele)");
  }
  r.warnings = std::move(raw.warnings);
  TetMesh m;
  m.V = std::move(raw.V);
  m.T.resize(Eigen::Index(raw.cells.size() / 4), 4);
  std::copy(raw.cells.begin(), raw.cells.end(), m.T.data());
  m.source = path.string();
  check_and_orient_tets(m, path.string(), r);
  return m;
}

void write_tetmesh(const TetMesh& mesh, const std::filesystem::path& path, const std::string& format,
                   const CellData& cell_data) {
  write_cell_mesh(path, mesh.V, CellBlock{mesh.T.data(), mesh.T.rows(), 4}, kTetKind, format, cell_data);
}

}  // namespace polyhex
