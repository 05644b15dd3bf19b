#include "nodes/formats/solver_formats.h"

#include "nodes/artefacts/boundary_groups.h"
#include "nodes/formats/mesh_formats.h"
#include "nodes/formats/text_cursor.h"
#include "runtime/atomic_file.h"
#include "runtime/errors.h"

#include <exodusII.h>

#include <algorithm>
#include <mutex>
#include <string>
#include <vector>

namespace polyhex {
namespace {

/// The number (1..6) of the face in `table` (1-based node lists as the format's manual gives them) with the
/// same vertices as each of our local faces.
std::array<int, 6> face_numbers(const int (&table)[6][4]) {
  std::array<int, 6> out{};
  for (int f = 0; f < 6; ++f) {
    std::array<int, 4> ours;
    for (int k = 0; k < 4; ++k) ours[size_t(k)] = hex_topology::kFaces[f][k];
    std::sort(ours.begin(), ours.end());
    for (int s = 0; s < 6; ++s) {
      std::array<int, 4> theirs;
      for (int k = 0; k < 4; ++k) theirs[size_t(k)] = table[s][k] - 1;
      std::sort(theirs.begin(), theirs.end());
      if (theirs == ours) out[size_t(f)] = s + 1;
    }
  }
  return out;
}

constexpr int kExodusHexSides[6][4] = {{1, 2, 6, 5}, {2, 3, 7, 6}, {3, 4, 8, 7},
                                       {1, 5, 8, 4}, {1, 4, 3, 2}, {5, 6, 7, 8}};
constexpr int kAbaqusHexFaces[6][4] = {{1, 2, 3, 4}, {5, 8, 7, 6}, {1, 5, 6, 2},
                                       {2, 6, 7, 3}, {3, 7, 8, 4}, {4, 8, 5, 1}};

/// An open Exodus file, closed on every path out; each call checked.
class ExodusFile {
 public:
  ExodusFile(const std::filesystem::path& tmp, const std::filesystem::path& path) : path_(path) {
    int comp_ws = 8, io_ws = 8;
    id_ = ex_create(tmp.c_str(), EX_CLOBBER, &comp_ws, &io_ws);
    if (id_ < 0) fail("ex_create", id_);
  }
  ~ExodusFile() {
    if (id_ >= 0) ex_close(id_);
  }
  ExodusFile(const ExodusFile&) = delete;
  ExodusFile& operator=(const ExodusFile&) = delete;
  int id() const { return id_; }
  /// \throw IOError when an Exodus call returned a negative status
  void check(int status, const char* call) const {
    if (status < 0) fail(call, status);
  }
  void close() {
    const int status = ex_close(id_);
    id_ = -1;
    check(status, "ex_close");
  }

 private:
  [[noreturn]] void fail(const char* call, int status) const {
    const char* msg = nullptr;
    const char* func = nullptr;
    int code = 0;
    ex_get_err(&msg, &func, &code);
    throw IOError(path_.string() + ": Exodus II library: " + call + " failed (status " + std::to_string(status) +
                  (msg && *msg ? std::string(": ") + msg : std::string()) + "); no file written");
  }
  std::filesystem::path path_;
  int id_ = -1;
};

}  // namespace

std::array<int, 6> exodus_hex_sides() {
  static const std::array<int, 6> sides = face_numbers(kExodusHexSides);
  return sides;
}
std::array<int, 6> abaqus_hex_faces() {
  static const std::array<int, 6> faces = face_numbers(kAbaqusHexFaces);
  return faces;
}

void write_exodus_hex(const HexMesh& mesh, const std::filesystem::path& path) {
  const auto nv = mesh.V.rows(), nh = mesh.H.rows();
  const auto ng = int64_t(mesh.groups.size());
  // The Exodus library keeps global state (its list of open files, the last error), and two write_hex
  // nodes of one graph may run at once: one Exodus file at a time.
  static std::mutex exodus_mutex;
  const std::lock_guard<std::mutex> lock(exodus_mutex);
  write_file_atomic_by_name(path, [&](const std::filesystem::path& tmp) {
    ExodusFile f(tmp, path);
    const std::string title = "polyhex hex mesh" + (mesh.source.empty() ? std::string() : " of " + mesh.source);
    f.check(ex_put_init(f.id(), title.substr(0, MAX_LINE_LENGTH).c_str(), 3, nv, nh, 1, ng, ng), "ex_put_init");
    {
      std::vector<double> c[3];
      for (int k = 0; k < 3; ++k) {
        c[k].resize(size_t(nv));
        for (Eigen::Index v = 0; v < nv; ++v) c[k][size_t(v)] = mesh.V(v, k);
      }
      f.check(ex_put_coord(f.id(), c[0].data(), c[1].data(), c[2].data()), "ex_put_coord");
    }
    char cx[] = "x", cy[] = "y", cz[] = "z";
    char* coord_names[] = {cx, cy, cz};
    f.check(ex_put_coord_names(f.id(), coord_names), "ex_put_coord_names");
    f.check(ex_put_block(f.id(), EX_ELEM_BLOCK, 1, "HEX8", nh, 8, 0, 0, 0), "ex_put_block");
    std::vector<int> conn(size_t(nh) * 8);
    for (Eigen::Index h = 0; h < nh; ++h)
      for (int k = 0; k < 8; ++k) conn[size_t(h) * 8 + size_t(k)] = mesh.H(h, k) + 1;
    f.check(ex_put_conn(f.id(), EX_ELEM_BLOCK, 1, conn.data(), nullptr, nullptr), "ex_put_conn");
    f.check(ex_put_name(f.id(), EX_ELEM_BLOCK, 1, "volume"), "ex_put_name");
    const std::array<int, 6> side = exodus_hex_sides();
    for (int64_t g = 0; g < ng; ++g) {
      const BoundaryGroup& group = mesh.groups[size_t(g)];
      std::vector<int> elems, sides;
      for (const auto& [h, face] : group.faces) {
        elems.push_back(h + 1);
        sides.push_back(side[size_t(face)]);
      }
      f.check(ex_put_set_param(f.id(), EX_SIDE_SET, g + 1, int64_t(elems.size()), 0), "ex_put_set_param");
      f.check(ex_put_set(f.id(), EX_SIDE_SET, g + 1, elems.data(), sides.data()), "ex_put_set");
      f.check(ex_put_name(f.id(), EX_SIDE_SET, g + 1, group.name.c_str()), "ex_put_name");
      std::vector<int> nodes = group_vertices(mesh, group);
      for (int& v : nodes) ++v;
      f.check(ex_put_set_param(f.id(), EX_NODE_SET, g + 1, int64_t(nodes.size()), 0), "ex_put_set_param");
      f.check(ex_put_set(f.id(), EX_NODE_SET, g + 1, nodes.data(), nullptr), "ex_put_set");
      f.check(ex_put_name(f.id(), EX_NODE_SET, g + 1, group.name.c_str()), "ex_put_name");
    }
    f.close();
  });
}

void write_abaqus_hex(const HexMesh& mesh, const std::filesystem::path& path) {
  using io_detail::append_double;
  using io_detail::append_int;
  std::string out;
  out.reserve(size_t(mesh.V.rows()) * 70 + size_t(mesh.H.rows()) * 80 + 256);
  out += "*HEADING\npolyhex hex mesh" + (mesh.source.empty() ? std::string() : " of " + mesh.source) + "\n";
  out += "*NODE\n";
  for (Eigen::Index v = 0; v < mesh.V.rows(); ++v) {
    append_int(out, v + 1);
    for (int k = 0; k < 3; ++k) {
      out += ", ";
      append_double(out, mesh.V(v, k));
    }
    out += '\n';
  }
  out += "*ELEMENT, TYPE=C3D8, ELSET=volume\n";
  for (Eigen::Index h = 0; h < mesh.H.rows(); ++h) {
    append_int(out, h + 1);
    for (int k = 0; k < 8; ++k) {
      out += ", ";
      append_int(out, mesh.H(h, k) + 1);
    }
    out += '\n';
  }
  const std::array<int, 6> face = abaqus_hex_faces();
  for (const BoundaryGroup& g : mesh.groups) {
    out += "*NSET, NSET=" + g.name + "\n";
    const std::vector<int> nodes = group_vertices(mesh, g);
    for (size_t i = 0; i < nodes.size(); ++i) {  // at most 16 entries per data line
      append_int(out, nodes[i] + 1);
      out += (i % 16 == 15 || i + 1 == nodes.size()) ? "\n" : ", ";
    }
    out += "*SURFACE, NAME=" + g.name + ", TYPE=ELEMENT\n";
    for (const auto& [h, f] : g.faces) {
      append_int(out, h + 1);
      out += ", S" + std::to_string(face[size_t(f)]) + "\n";
    }
  }
  io_detail::write_buffer(path, out, false);
}

}  // namespace polyhex
