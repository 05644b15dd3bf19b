#include "nodes/formats/mesh_formats.h"

#include "nodes/formats/text_cursor.h"
#include "runtime/atomic_file.h"
#include "runtime/errors.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <type_traits>
#include <unordered_map>

namespace polyhex {

using io_detail::append_big_endian;
using io_detail::append_double;
using io_detail::append_int;
using io_detail::BinaryCursor;
using io_detail::TextCursor;

MeshFormat choose_mesh_format(const std::string& format, const std::filesystem::path& path, bool solver_formats) {
  if (format == "vtk") return MeshFormat::VtkAscii;
  if (format == "vtk_binary") return MeshFormat::VtkBinary;
  if (format == "mesh") return MeshFormat::Medit;
  if (format == "msh") return MeshFormat::Gmsh;
  if (solver_formats && format == "exodus") return MeshFormat::Exodus;
  if (solver_formats && format == "abaqus") return MeshFormat::Abaqus;
  if (format != "auto")
    throw ConfigError("unknown mesh format `" + format + "`; valid formats: auto, vtk, vtk_binary, mesh, msh" +
                      (solver_formats ? ", exodus, abaqus" : ""));
  const std::string ext = io_detail::lower_extension(path);
  if (ext == ".vtk") return MeshFormat::VtkAscii;
  if (ext == ".mesh") return MeshFormat::Medit;
  if (ext == ".msh") return MeshFormat::Gmsh;
  if (solver_formats && (ext == ".e" || ext == ".exo")) return MeshFormat::Exodus;
  if (solver_formats && ext == ".inp") return MeshFormat::Abaqus;
  throw IOError(path.string() + ": unknown extension `" + ext + "` (expected .vtk, .mesh" +
                (solver_formats ? ", .msh, .e, .exo or .inp)" : " or .msh)"));
}

std::vector<std::string> FaceGroups::families() const {
  std::vector<std::string> out;
  for (const Group& g : groups)
    if (std::find(out.begin(), out.end(), g.family) == out.end()) out.push_back(g.family);
  return out;
}

std::vector<int> FaceGroups::family_ids(const std::string& family) const {
  std::vector<int> id(size_t(quads.rows()), -1);
  for (const Group& g : groups)
    if (g.family == family)
      for (int r : g.rows) id[size_t(r)] = g.id;
  return id;
}

// ---------------------------------------------------------------------------------------------
// Writers

namespace io_detail {

void write_buffer(const std::filesystem::path& path, const std::string& buffer, bool binary) {
  write_file_atomic(
      path, [&](std::ostream& os) { os.write(buffer.data(), std::streamsize(buffer.size())); }, binary);
}

void append_vtk_header(std::string& out, const std::string& title, bool binary, const std::string& dataset) {
  out += "# vtk DataFile Version 2.0\n";
  out += title + "\n";
  out += binary ? "BINARY\n" : "ASCII\n";
  out += "DATASET " + dataset + "\n";
}

void append_vtk_points(std::string& out, const RowMatrixX3d& V, bool binary) {
  out += "POINTS " + std::to_string(V.rows()) + " double\n";
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    for (int k = 0; k < 3; ++k) {
      if (binary) {
        append_big_endian<double>(out, V(i, k));
      } else {
        if (k) out += ' ';
        append_double(out, V(i, k));
      }
    }
    if (!binary) out += '\n';
  }
  if (binary) out += '\n';
}

void check_array_name(const std::string& name, size_t size, Eigen::Index cells, const std::string& file) {
  if (name.empty() || name.find_first_of(" \t\n") != std::string::npos)
    throw InvalidInput(file + ": cell data name `" + name + "` must be one word");
  if (Eigen::Index(size) != cells)
    throw InvalidInput(file + ": cell data `" + name + "` has " + std::to_string(size) + " values for " +
                       std::to_string(cells) + " cells");
}

namespace {
template <class T>
void append_vtk_array(std::string& out, const std::string& name, const std::vector<T>& values, Eigen::Index cells,
                      bool binary, const std::string& file) {
  check_array_name(name, values.size(), cells, file);
  using Stored = std::conditional_t<std::is_same_v<T, int>, int32_t, double>;
  out += "SCALARS " + name + (std::is_same_v<T, int> ? " int" : " double") + " 1\nLOOKUP_TABLE default\n";
  for (T v : values) {
    if (binary) {
      append_big_endian<Stored>(out, Stored(v));
    } else {
      if constexpr (std::is_same_v<T, int>)
        append_int(out, v);
      else
        append_double(out, v);
      out += '\n';
    }
  }
  if (binary) out += '\n';
}
}  // namespace

void append_vtk_cell_data(std::string& out, const CellData& data, Eigen::Index cells, bool binary,
                          const std::string& file) {
  if (data.empty()) return;
  out += "CELL_DATA " + std::to_string(cells) + "\n";
  for (auto& [name, values] : data.ints) append_vtk_array(out, name, values, cells, binary, file);
  for (auto& [name, values] : data.reals) append_vtk_array(out, name, values, cells, binary, file);
}

}  // namespace io_detail

namespace {
// Appends one cell (`n` indices) to a legacy VTK CELLS block.
void append_vtk_cell(std::string& out, const int* row, int n, bool binary) {
  if (binary) {
    append_big_endian<int32_t>(out, n);
    for (int k = 0; k < n; ++k) append_big_endian<int32_t>(out, row[k]);
  } else {
    append_int(out, n);
    for (int k = 0; k < n; ++k) {
      out += ' ';
      append_int(out, row[k]);
    }
    out += '\n';
  }
}
}  // namespace

void write_vtk_cells(const std::filesystem::path& path, const RowMatrixX3d& V, CellBlock cells, int vtk_type,
                     bool binary, const CellData& cell_data, const FaceGroups& faces) {
  constexpr int kVtkQuad = 9;
  std::string out;
  const Eigen::Index nq = faces.empty() ? 0 : faces.quads.rows();
  out.reserve(size_t(V.rows()) * 60 + size_t(cells.rows) * (cells.cols + 2) * 8 + size_t(nq) * 48 + 256);
  io_detail::append_vtk_header(out, "polyhex mesh", binary, "UNSTRUCTURED_GRID");
  io_detail::append_vtk_points(out, V, binary);
  const Eigen::Index n = cells.rows;
  out += "CELLS " + std::to_string(n + nq) + " " + std::to_string(n * (cells.cols + 1) + nq * 5) + "\n";
  for (Eigen::Index c = 0; c < n; ++c) append_vtk_cell(out, cells.data + c * cells.cols, cells.cols, binary);
  for (Eigen::Index q = 0; q < nq; ++q) append_vtk_cell(out, faces.quads.row(q).data(), 4, binary);
  if (binary) out += '\n';
  out += "CELL_TYPES " + std::to_string(n + nq) + "\n";
  for (Eigen::Index c = 0; c < n + nq; ++c) {
    const int type = c < n ? vtk_type : kVtkQuad;
    if (binary) {
      append_big_endian<int32_t>(out, type);
    } else {
      append_int(out, type);
      out += '\n';
    }
  }
  if (binary) out += '\n';
  if (nq == 0) {
    io_detail::append_vtk_cell_data(out, cell_data, n, binary, path.string());
  } else {
    // Every array covers the volume cells and the quads.
    CellData all;
    for (auto [name, values] : cell_data.ints) {
      io_detail::check_array_name(name, values.size(), n, path.string());
      values.resize(size_t(n + nq), -1);
      all.ints.emplace_back(name, std::move(values));
    }
    for (auto [name, values] : cell_data.reals) {
      io_detail::check_array_name(name, values.size(), n, path.string());
      values.resize(size_t(n + nq), 0.0);
      all.reals.emplace_back(name, std::move(values));
    }
    for (const std::string& family : faces.families()) {
      std::vector<int> id(size_t(n), -1);
      const std::vector<int> quad_id = faces.family_ids(family);
      id.insert(id.end(), quad_id.begin(), quad_id.end());
      all.ints.emplace_back(family, std::move(id));
    }
    io_detail::append_vtk_cell_data(out, all, n + nq, binary, path.string());
  }
  io_detail::write_buffer(path, out, binary);
}

void write_medit_cells(const std::filesystem::path& path, const RowMatrixX3d& V, CellBlock cells,
                       const std::string& section, const FaceGroups& faces) {
  std::string out;
  out.reserve(size_t(V.rows()) * 60 + size_t(cells.rows) * (cells.cols + 1) * 8 + 256);
  out += "MeshVersionFormatted 2\n\nDimension 3\n\nVertices\n" + std::to_string(V.rows()) + "\n";
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    for (int k = 0; k < 3; ++k) {
      append_double(out, V(i, k));
      out += ' ';
    }
    out += "0\n";
  }
  out += "\n" + section + "\n" + std::to_string(cells.rows) + "\n";
  for (Eigen::Index c = 0; c < cells.rows; ++c) {
    const int* row = cells.data + c * cells.cols;
    for (int k = 0; k < cells.cols; ++k) {
      append_int(out, row[k] + 1);
      out += ' ';
    }
    out += "0\n";
  }
  if (!faces.empty()) {
    // One reference per face: the first family that is not the whole boundary, else the first.
    const std::vector<std::string> families = faces.families();
    std::string family = families.front();
    for (const std::string& f : families)
      if (f != "boundary") {
        family = f;
        break;
      }
    const std::vector<int> ref = faces.family_ids(family);
    out += "\nQuadrilaterals\n" + std::to_string(faces.quads.rows()) + "\n";
    for (Eigen::Index q = 0; q < faces.quads.rows(); ++q) {
      for (int k = 0; k < 4; ++k) {
        append_int(out, faces.quads(q, k) + 1);
        out += ' ';
      }
      append_int(out, ref[size_t(q)]);
      out += '\n';
    }
  }
  out += "\nEnd\n";
  io_detail::write_buffer(path, out, false);
}

namespace {
// " xmin ymin zmin xmax ymax zmax" of the vertices `ids` (all of V when null), for a Gmsh entity.
void append_gmsh_box(std::string& out, const RowMatrixX3d& V, const std::vector<int>* ids) {
  Eigen::Vector3d lo = Eigen::Vector3d::Zero(), hi = Eigen::Vector3d::Zero();
  if (ids && !ids->empty()) {
    lo = hi = V.row((*ids)[0]).transpose();
    for (int v : *ids) {
      lo = lo.cwiseMin(V.row(v).transpose());
      hi = hi.cwiseMax(V.row(v).transpose());
    }
  } else if (!ids && V.rows() > 0) {
    lo = V.colwise().minCoeff().transpose();
    hi = V.colwise().maxCoeff().transpose();
  }
  for (int k = 0; k < 3; ++k) {
    out += ' ';
    append_double(out, lo[k]);
  }
  for (int k = 0; k < 3; ++k) {
    out += ' ';
    append_double(out, hi[k]);
  }
}
}  // namespace

void write_gmsh_cells(const std::filesystem::path& path, const RowMatrixX3d& V, CellBlock cells, int gmsh_type,
                      const FaceGroups& faces) {
  constexpr int kGmshQuad = 3;
  const Eigen::Index nq = faces.empty() ? 0 : faces.quads.rows();
  // Surface entities: one per distinct set of groups holding a quad (quads in no group are left out).
  std::vector<std::vector<int>> groups_of(static_cast<size_t>(nq));
  for (size_t g = 0; g < faces.groups.size(); ++g)
    for (int r : faces.groups[g].rows) groups_of[size_t(r)].push_back(int(g) + 1);  // physical tags 1..
  std::map<std::vector<int>, std::vector<int>> entity_quads;                        // physical tags -> quad rows
  for (Eigen::Index q = 0; q < nq; ++q)
    if (!groups_of[size_t(q)].empty()) entity_quads[groups_of[size_t(q)]].push_back(int(q));
  long quads_written = 0;
  for (auto& [tags, rows] : entity_quads) quads_written += long(rows.size());

  std::string out;
  out.reserve(size_t(V.rows()) * 70 + size_t(cells.rows) * (cells.cols + 1) * 8 + size_t(nq) * 40 + 512);
  const std::string nv = std::to_string(V.rows()), nc = std::to_string(cells.rows);
  out += "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n";
  const bool groups = !faces.empty();
  if (groups) {
    out += "$PhysicalNames\n" + std::to_string(faces.groups.size() + 1) + "\n3 1 \"volume\"\n";
    for (size_t g = 0; g < faces.groups.size(); ++g)
      out += "2 " + std::to_string(g + 1) + " \"" + faces.groups[g].name + "\"\n";
    out += "$EndPhysicalNames\n";
  }
  // One volume entity (tag 1) holding every node and volume element: Gmsh needs the entity for its
  // blocks. Surface entities 1.. hold the quads.
  out += "$Entities\n0 0 " + std::to_string(entity_quads.size()) + " 1\n";
  int entity = 0;
  for (auto& [tags, rows] : entity_quads) {
    std::vector<int> ids;
    for (int r : rows)
      for (int k = 0; k < 4; ++k) ids.push_back(faces.quads(r, k));
    out += std::to_string(++entity);
    append_gmsh_box(out, V, &ids);
    out += " " + std::to_string(tags.size());
    for (int t : tags) out += " " + std::to_string(t);
    out += " 0\n";
  }
  out += "1";
  append_gmsh_box(out, V, nullptr);
  out += groups ? " 1 1 0\n$EndEntities\n" : " 0 0\n$EndEntities\n";
  out += "$Nodes\n1 " + nv + " 1 " + nv + "\n3 1 0 " + nv + "\n";
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    append_int(out, i + 1);
    out += '\n';
  }
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    for (int k = 0; k < 3; ++k) {
      if (k) out += ' ';
      append_double(out, V(i, k));
    }
    out += '\n';
  }
  const long total = long(cells.rows) + quads_written;
  out += "$EndNodes\n$Elements\n" + std::to_string(1 + entity_quads.size()) + " " + std::to_string(total) + " 1 " +
         std::to_string(total) + "\n3 1 " + std::to_string(gmsh_type) + " " + nc + "\n";
  for (Eigen::Index c = 0; c < cells.rows; ++c) {
    const int* row = cells.data + c * cells.cols;
    append_int(out, c + 1);
    for (int k = 0; k < cells.cols; ++k) {
      out += ' ';
      append_int(out, row[k] + 1);
    }
    out += '\n';
  }
  long tag = long(cells.rows);
  entity = 0;
  for (auto& [tags, rows] : entity_quads) {
    out += "2 " + std::to_string(++entity) + " " + std::to_string(kGmshQuad) + " " + std::to_string(rows.size()) + "\n";
    for (int r : rows) {
      append_int(out, ++tag);
      for (int k = 0; k < 4; ++k) {
        out += ' ';
        append_int(out, faces.quads(r, k) + 1);
      }
      out += '\n';
    }
  }
  out += "$EndElements\n";
  io_detail::write_buffer(path, out, false);
}

// ---------------------------------------------------------------------------------------------
// Readers

namespace {

RowMatrixX3d to_matrix(const std::vector<double>& xyz) {
  RowMatrixX3d V(Eigen::Index(xyz.size() / 3), 3);
  std::copy(xyz.begin(), xyz.end(), V.data());
  return V;
}

std::string plural(size_t n, const std::string& what) { return std::to_string(n) + " " + what + (n == 1 ? "" : "s"); }

// The values of a legacy VTK data block, ASCII or binary (big-endian).
struct VtkValues {
  TextCursor& text;
  bool binary;
  std::string file;

  template <class T, class Out>
  void read_binary(size_t n, std::vector<Out>& out, const char* what) {
    BinaryCursor b(text.text(), text.pos(), true, file);
    for (size_t i = 0; i < n; ++i) out.push_back(Out(b.get<T>(what)));
    text.seek(b.pos());
  }
  // Reads n values of VTK type `type` (float, double, int, ...) into out (as double).
  void read(const std::string& type, size_t n, std::vector<double>& out, const char* what) {
    out.clear();
    out.reserve(text.reserve_hint((long long)n, 2));
    if (!binary) {
      for (size_t i = 0; i < n; ++i) out.push_back(text.real(what));
      return;
    }
    if (type == "double")
      read_binary<double>(n, out, what);
    else if (type == "float")
      read_binary<float>(n, out, what);
    else if (type == "int" || type == "vtktypeint32")
      read_binary<int32_t>(n, out, what);
    else if (type == "unsigned_int")
      read_binary<uint32_t>(n, out, what);
    else if (type == "long" || type == "vtktypeint64")
      read_binary<int64_t>(n, out, what);
    else if (type == "short")
      read_binary<int16_t>(n, out, what);
    else if (type == "unsigned_short")
      read_binary<uint16_t>(n, out, what);
    else
      text.fail("unsupported binary data type `" + type + "` in " + what);
    for (size_t i = 0; i < n; ++i)
      if (!std::isfinite(out[i])) text.fail(std::string(what) + " " + std::to_string(i) + " is not finite");
  }
  void read_ints(size_t n, std::vector<long long>& out, const char* what) {
    out.clear();
    out.reserve(text.reserve_hint((long long)n, 2));
    if (!binary) {
      for (size_t i = 0; i < n; ++i) out.push_back(text.integer(what));
      return;
    }
    read_binary<int32_t>(n, out, what);
  }
};

long long count_field(TextCursor& c, const std::vector<std::string_view>& w, size_t i, const std::string& what) {
  long long n;
  if (w.size() <= i || !io_detail::parse_int(w[i], n) || n < 0) c.fail("expected " + what + " (a count)");
  // Every counted item takes at least a byte: a larger count is forged (and 3 n could overflow).
  if (static_cast<unsigned long long>(n) > c.remaining() + 1)
    c.fail(what + " " + std::to_string(n) + " is more than the " + std::to_string(c.remaining()) +
           " bytes left in the file");
  return n;
}

std::string vertex_count(size_t nv) { return std::to_string(nv) + (nv == 1 ? " vertex" : " vertices"); }

[[noreturn]] void index_error(const std::string& file, const std::string& what, long long v, size_t nv) {
  throw IOError(file + ": " + what + ": vertex index " + std::to_string(v) + " out of range (" + vertex_count(nv) +
                ")");
}

}  // namespace

CellsRead read_vtk_cells(const std::filesystem::path& path, int vtk_type, int nodes) {
  const std::string file = path.string();
  const std::string data = io_detail::load_file(path);
  TextCursor c(data, file);
  std::string_view l;
  if (!c.line(l) || l.rfind("# vtk DataFile Version", 0) != 0)
    throw IOError(file + ": not a legacy VTK file (the first line must be `# vtk DataFile Version x.y`)");
  if (!c.line(l)) c.fail("truncated: no title line");
  if (!c.next_line(l)) c.fail("truncated: expected ASCII or BINARY");
  bool binary;
  if (l == "ASCII")
    binary = false;
  else if (l == "BINARY")
    binary = true;
  else
    c.fail("expected ASCII or BINARY, got `" + std::string(l) + "`");
  std::vector<std::string_view> w;
  if (!c.next_line(l)) c.fail("truncated: expected DATASET UNSTRUCTURED_GRID");
  io_detail::split_blanks(l, w);
  if (w.size() != 2 || w[0] != "DATASET") c.fail("expected DATASET UNSTRUCTURED_GRID, got `" + std::string(l) + "`");
  if (w[1] != "UNSTRUCTURED_GRID")
    c.fail("DATASET " + std::string(w[1]) + " is not supported (expected UNSTRUCTURED_GRID)");

  VtkValues values{c, binary, file};
  std::vector<double> xyz;
  std::vector<long long> conn, types;
  bool have_points = false, have_cells = false, have_types = false;
  long long ncells = 0;
  while (c.next_line(l)) {
    io_detail::split_blanks(l, w);
    if (w[0] == "POINTS") {
      long long n = count_field(c, w, 1, "number of points");
      std::string type = w.size() > 2 ? std::string(w[2]) : "float";
      values.read(type, size_t(3 * n), xyz, "point coordinate");
      have_points = true;
    } else if (w[0] == "CELLS") {
      ncells = count_field(c, w, 1, "number of cells");
      long long size = count_field(c, w, 2, "CELLS size");
      size_t save = c.pos();
      std::string_view peek;
      if (c.next(peek) && peek == "OFFSETS")
        c.fail("VTK 5 OFFSETS/CONNECTIVITY cells are not supported; write legacy VTK (classic CELLS n size)");
      c.seek(save);
      values.read_ints(size_t(size), conn, "CELLS data");
      have_cells = true;
    } else if (w[0] == "CELL_TYPES") {
      long long n = count_field(c, w, 1, "number of cell types");
      if (have_cells && n != ncells)
        c.fail("CELL_TYPES lists " + std::to_string(n) + " cells but CELLS " + std::to_string(ncells) +
               " (wrong counts)");
      values.read_ints(size_t(n), types, "CELL_TYPES data");
      have_types = true;
    } else if (w[0] == "METADATA") {
      while (c.line(l) && !l.empty()) {
      }
    } else if (w[0] == "CELL_DATA" || w[0] == "POINT_DATA" || w[0] == "FIELD") {
      break;  // attribute data is not needed by the readers
    } else {
      c.fail("unexpected `" + std::string(w[0]) + "` (expected POINTS, CELLS or CELL_TYPES)");
    }
  }
  if (!have_points) throw IOError(file + ": no POINTS section");
  if (!have_cells) throw IOError(file + ": no CELLS section");
  if (!have_types) throw IOError(file + ": no CELL_TYPES section");
  if ((long long)types.size() != ncells)
    throw IOError(file + ": CELL_TYPES lists " + std::to_string(types.size()) + " cells but CELLS " +
                  std::to_string(ncells) + " (wrong counts)");

  CellsRead r;
  r.V = to_matrix(xyz);
  const size_t nv = size_t(r.V.rows());
  std::map<long long, size_t> ignored;
  r.cells.reserve(conn.size());
  size_t p = 0;
  for (long long i = 0; i < ncells; ++i) {
    if (p >= conn.size() || conn[p] < 0 || p + 1 + size_t(conn[p]) > conn.size())
      throw IOError(file + ": CELLS data ends inside cell " + std::to_string(i) + " (wrong CELLS size or counts)");
    const size_t k = size_t(conn[p]);
    if (types[size_t(i)] == vtk_type) {
      if (k != size_t(nodes))
        throw IOError(file + ": cell " + std::to_string(i) + " of type " + std::to_string(vtk_type) + " has " +
                      std::to_string(k) + " vertices, expected " + std::to_string(nodes));
      for (size_t j = 0; j < k; ++j) {
        long long v = conn[p + 1 + j];
        if (v < 0 || v >= (long long)nv) index_error(file, "cell " + std::to_string(i), v, nv);
        r.cells.push_back(int(v));
      }
    } else {
      ++ignored[types[size_t(i)]];
    }
    p += 1 + k;
  }
  if (p != conn.size())
    throw IOError(file + ": CELLS size is " + std::to_string(conn.size()) + " but the " + std::to_string(ncells) +
                  " cells use " + std::to_string(p) + " values (wrong counts)");
  for (auto& [type, n] : ignored)
    r.warnings.push_back(file + ": ignored " + plural(n, "cell") + " of VTK type " + std::to_string(type) +
                         " (only type " + std::to_string(vtk_type) + " is read)");
  return r;
}

CellsRead read_medit_cells(const std::filesystem::path& path, const std::string& section, int nodes) {
  const std::string file = path.string();
  const std::string data = io_detail::load_file(path);
  TextCursor c(data, file, '#');
  // Entries per element of the sections we skip (vertex indices + reference).
  static const std::map<std::string, int, std::less<>> skip = {{"Vertices", 4},
                                                               {"Edges", 3},
                                                               {"Triangles", 4},
                                                               {"Quadrilaterals", 5},
                                                               {"Tetrahedra", 5},
                                                               {"Hexahedra", 9},
                                                               {"Prisms", 7},
                                                               {"Pyramids", 6},
                                                               {"Corners", 1},
                                                               {"Ridges", 1},
                                                               {"RequiredVertices", 1},
                                                               {"RequiredEdges", 1},
                                                               {"RequiredTriangles", 1},
                                                               {"RequiredQuadrilaterals", 1},
                                                               {"Normals", 3},
                                                               {"Tangents", 3},
                                                               {"NormalAtVertices", 2},
                                                               {"TangentAtVertices", 2},
                                                               {"NormalAtTriangleVertices", 3},
                                                               {"TangentAtEdgeVertices", 3}};
  CellsRead r;
  std::vector<double> xyz;
  std::vector<long long> raw;  // 1-based indices, checked once the vertex count is known
  std::vector<int> cell_line;
  bool have_vertices = false, have_cells = false;
  std::string_view tok;
  bool pending = false;
  while (pending || c.next(tok)) {
    pending = false;
    double num;
    if (io_detail::parse_double(tok, num))
      c.fail("expected a section keyword, got `" + std::string(tok) + "` (wrong counts?)");
    const std::string key(tok);
    if (key == "End") break;
    if (key == "MeshVersionFormatted") {
      c.integer("MeshVersionFormatted value");
    } else if (key == "Dimension") {
      long long d = c.integer("dimension");
      if (d != 3) c.fail("Dimension " + std::to_string(d) + " is not supported (expected 3)");
    } else if (key == "Vertices") {
      long long n = c.integer("number of vertices");
      if (n < 0) c.fail("negative vertex count");
      xyz.clear();
      xyz.reserve(3 * c.reserve_hint(n, 8));
      for (long long i = 0; i < n; ++i) {
        for (int k = 0; k < 3; ++k) xyz.push_back(c.real("vertex coordinate"));
        c.integer("vertex reference");
      }
      have_vertices = true;
    } else if (key == section) {
      long long n = c.integer("number of " + section);
      if (n < 0) c.fail("negative " + section + " count");
      raw.clear();
      cell_line.clear();
      raw.reserve(c.reserve_hint(n, size_t(2 * (nodes + 1))) * size_t(nodes));
      cell_line.reserve(c.reserve_hint(n, size_t(2 * (nodes + 1))));
      const std::string index_what = section + " vertex index", ref_what = section + " reference";
      for (long long i = 0; i < n; ++i) {
        for (int k = 0; k < nodes; ++k) {
          raw.push_back(c.integer(index_what));
          if (k == 0) cell_line.push_back(c.line_no());
        }
        c.integer(ref_what);
      }
      have_cells = true;
    } else if (auto it = skip.find(key); it != skip.end()) {
      long long n = c.integer("number of " + key);
      const std::string what = key + " entry";
      for (long long i = 0; i < n; ++i)  // (not i < n * per-entry: a forged n would overflow)
        for (int k = 0; k < it->second; ++k) c.token(what);
    } else {
      // Unknown section: skip its numbers up to the next keyword.
      r.warnings.push_back(file + ": line " + std::to_string(c.line_no()) + ": ignored unknown section `" + key + "`");
      while (c.next(tok)) {
        if (!io_detail::parse_double(tok, num)) {
          pending = true;
          break;
        }
      }
    }
  }
  if (!have_vertices) throw IOError(file + ": no Vertices section");
  if (!have_cells) throw IOError(file + ": no " + section + " section");
  r.V = to_matrix(xyz);
  const size_t nv = size_t(r.V.rows());
  r.cells.resize(raw.size());
  for (size_t i = 0; i < raw.size(); ++i) {
    if (raw[i] < 1 || raw[i] > (long long)nv)
      throw IOError(file + ": line " + std::to_string(cell_line[i / nodes]) + ": " + section + " entry " +
                    std::to_string(i / nodes + 1) + ": vertex index " + std::to_string(raw[i]) + " out of range (" +
                    vertex_count(nv) + ", 1-based)");
    r.cells[i] = int(raw[i] - 1);
  }
  return r;
}

namespace {

/// read_gmsh_cells() as its sections: the format line, $Nodes, $Elements (2.2 or 4.1), others skipped.
class GmshReader {
 public:
  GmshReader(const std::string& data, const std::string& file, int gmsh_type, int nodes)
      : file_(file), c_(data, file), gmsh_type_(gmsh_type), nodes_(nodes) {}

  CellsRead read() {
    read_format();
    bool have_nodes = false, have_elements = false;
    while (c_.next_line(l_)) {
      if (l_.empty() || l_[0] != '$') c_.fail("expected a section such as $Nodes, got `" + std::string(l_) + "`");
      const std::string name(l_.substr(1));
      if (name == "Nodes") {
        v2_ ? read_nodes_v2() : read_nodes_v41();
        expect_end("$EndNodes");
        have_nodes = true;
      } else if (name == "Elements") {
        v2_ ? read_elements_v2() : read_elements_v41();
        expect_end("$EndElements");
        have_elements = true;
      } else {
        skip_section("$End" + name);
      }
    }
    if (!have_nodes) throw IOError(file_ + ": no $Nodes section");
    if (!have_elements) throw IOError(file_ + ": no $Elements section");
    return result();
  }

 private:
  void expect_line(const std::string& what) {
    if (!c_.next_line(l_)) c_.fail("truncated: unexpected end of file (expected " + what + ")");
    io_detail::split_blanks(l_, w_);
  }

  void expect_end(const std::string& end) {
    expect_line(end);
    if (l_ != end) c_.fail("expected " + end + ", got `" + std::string(l_) + "` (wrong counts?)");
  }

  void read_format() {
    expect_line("$MeshFormat");
    if (l_ != "$MeshFormat") c_.fail("not a Gmsh file (expected `$MeshFormat`, got `" + std::string(l_) + "`)");
    expect_line("version line");
    double version;
    long long filetype;
    if (w_.size() < 3 || !io_detail::parse_double(w_[0], version) || !io_detail::parse_int(w_[1], filetype))
      c_.fail("expected `version file-type data-size`");
    if (filetype != 0) c_.fail("binary .msh files are not supported (write ASCII)");
    v2_ = version >= 2.0 && version < 3.0;
    const bool v41 = version >= 4.1 && version < 5.0;
    if (!v2_ && !v41) c_.fail("Gmsh format version " + std::string(w_[0]) + " is not supported (use 2.2 or 4.1)");
    expect_line("$EndMeshFormat");
    if (l_ != "$EndMeshFormat") c_.fail("expected $EndMeshFormat");
  }

  void add_node(long long tag, std::string_view line_text) {
    io_detail::split_blanks(line_text, w_);
    if (w_.size() < 3) c_.fail("expected node coordinates x y z");
    double x[3];
    for (int k = 0; k < 3; ++k) {
      if (!io_detail::parse_double(w_[k], x[k]))
        c_.fail("expected a node coordinate, got `" + std::string(w_[k]) + "`");
      if (!std::isfinite(x[k])) c_.fail("node " + std::to_string(tag) + " has a non-finite coordinate");
    }
    if (!node_index_.emplace(tag, int(xyz_.size() / 3)).second)
      c_.fail("node tag " + std::to_string(tag) + " repeated");
    xyz_.insert(xyz_.end(), x, x + 3);
  }

  /// One element of `type` with node tags `tags[0..n)`: kept when of the type read, counted otherwise.
  void add_element(long long type, const std::string_view* tags, size_t n) {
    if (type != gmsh_type_) {
      ++ignored_[type];
      return;
    }
    if (n != size_t(nodes_))
      c_.fail("element of type " + std::to_string(type) + " has " + std::to_string(n) + " nodes, expected " +
              std::to_string(nodes_));
    for (size_t k = 0; k < n; ++k) {
      long long t;
      if (!io_detail::parse_int(tags[k], t)) c_.fail("expected a node tag, got `" + std::string(tags[k]) + "`");
      raw_.push_back(t);
    }
    raw_line_.push_back(c_.line_no());
  }

  void read_nodes_v2() {
    expect_line("number of nodes");
    long long n = count_field(c_, w_, 0, "number of nodes");
    for (long long i = 0; i < n; ++i) {
      expect_line("node");
      long long tag;
      if (!io_detail::parse_int(w_[0], tag)) c_.fail("expected a node tag, got `" + std::string(w_[0]) + "`");
      add_node(tag, l_.substr(size_t(w_[0].data() + w_[0].size() - l_.data())));
    }
  }

  void read_nodes_v41() {
    expect_line("$Nodes header");
    long long blocks = count_field(c_, w_, 0, "number of node blocks");
    for (long long b = 0; b < blocks; ++b) {
      expect_line("node block header");
      long long count = count_field(c_, w_, 3, "number of nodes in block");
      std::vector<long long> tags;
      tags.reserve(c_.reserve_hint(count, 2));
      for (long long k = 0; k < count; ++k) tags.push_back(c_.integer("node tag"));
      for (auto t : tags) {
        expect_line("node coordinates");
        add_node(t, l_);
      }
    }
  }

  void read_elements_v2() {
    expect_line("number of elements");
    long long n = count_field(c_, w_, 0, "number of elements");
    for (long long i = 0; i < n; ++i) {
      expect_line("element");
      long long type, ntags;
      if (w_.size() < 3 || !io_detail::parse_int(w_[1], type) || !io_detail::parse_int(w_[2], ntags) || ntags < 0 ||
          w_.size() < size_t(3 + ntags))
        c_.fail("expected `tag type ntags tags... nodes...`");
      add_element(type, w_.data() + 3 + ntags, w_.size() - size_t(3 + ntags));
    }
  }

  void read_elements_v41() {
    expect_line("$Elements header");
    long long blocks = count_field(c_, w_, 0, "number of element blocks");
    for (long long b = 0; b < blocks; ++b) {
      expect_line("element block header");
      long long type, count;
      if (w_.size() < 4 || !io_detail::parse_int(w_[2], type) || !io_detail::parse_int(w_[3], count) || count < 0)
        c_.fail("expected `entity-dim entity-tag element-type count`");
      for (long long i = 0; i < count; ++i) {
        expect_line("element");
        add_element(type, w_.data() + 1, w_.size() - 1);
      }
    }
  }

  void skip_section(const std::string& end) {
    while (c_.next_line(l_))
      if (l_ == end) return;
    c_.fail("truncated: no " + end);
  }

  CellsRead result() {
    CellsRead r;
    r.V = to_matrix(xyz_);
    r.cells.resize(raw_.size());
    for (size_t i = 0; i < raw_.size(); ++i) {
      auto it = node_index_.find(raw_[i]);
      if (it == node_index_.end())
        throw IOError(file_ + ": line " + std::to_string(raw_line_[i / size_t(nodes_)]) + ": element node tag " +
                      std::to_string(raw_[i]) + " is not a node (" + vertex_count(xyz_.size() / 3) + ")");
      r.cells[i] = it->second;
    }
    for (auto& [type, n] : ignored_)
      r.warnings.push_back(file_ + ": ignored " + plural(n, "element") + " of Gmsh type " + std::to_string(type) +
                           " (only type " + std::to_string(gmsh_type_) + " is read)");
    return r;
  }

  const std::string& file_;
  TextCursor c_;
  const int gmsh_type_, nodes_;
  bool v2_ = false;
  std::string_view l_;
  std::vector<std::string_view> w_;
  std::unordered_map<long long, int> node_index_;
  std::vector<double> xyz_;
  std::vector<long long> raw_;  ///< node tags of kept elements
  std::vector<int> raw_line_;   ///< line of each kept element
  std::map<long long, size_t> ignored_;
};

}  // namespace

CellsRead read_gmsh_cells(const std::filesystem::path& path, int gmsh_type, int nodes) {
  const std::string file = path.string();
  const std::string data = io_detail::load_file(path);
  return GmshReader(data, file, gmsh_type, nodes).read();
}

void write_cell_mesh(const std::filesystem::path& path, const RowMatrixX3d& V, CellBlock cells, const CellKind& kind,
                     const std::string& format, const CellData& cell_data, const FaceGroups& faces) {
  switch (choose_mesh_format(format, path)) {
    case MeshFormat::VtkAscii:
      return write_vtk_cells(path, V, cells, kind.vtk_type, false, cell_data, faces);
    case MeshFormat::VtkBinary:
      return write_vtk_cells(path, V, cells, kind.vtk_type, true, cell_data, faces);
    case MeshFormat::Medit:
      return write_medit_cells(path, V, cells, kind.medit_section, faces);
    case MeshFormat::Gmsh:
      return write_gmsh_cells(path, V, cells, kind.gmsh_type, faces);
    case MeshFormat::Exodus:
    case MeshFormat::Abaqus:
      break;  // not chosen without solver_formats
  }
}

CellsRead read_cell_mesh(const std::filesystem::path& path, const CellKind& kind) {
  const std::string ext = io_detail::lower_extension(path);
  if (ext == ".vtk") return read_vtk_cells(path, kind.vtk_type, kind.nodes);
  if (ext == ".mesh") return read_medit_cells(path, kind.medit_section, kind.nodes);
  if (ext == ".msh") return read_gmsh_cells(path, kind.gmsh_type, kind.nodes);
  throw IOError(path.string() + ": unknown extension `" + ext + "` (expected .vtk, .mesh or .msh)");
}

}  // namespace polyhex
