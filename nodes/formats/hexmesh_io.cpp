#include "nodes/formats/hexmesh_io.h"

#include "nodes/artefacts/boundary_groups.h"
#include "nodes/formats/solver_formats.h"
#include "runtime/errors.h"

#include <algorithm>
#include <map>

namespace polyhex {

FaceGroups face_groups(const HexMesh& mesh) {
  FaceGroups out;
  std::map<std::array<int, 2>, int> row;  // (hex, face) -> row of out.quads
  for (const BoundaryGroup& g : mesh.groups)
    for (const auto& hf : g.faces) row.emplace(hf, 0);
  out.quads.resize(Eigen::Index(row.size()), 4);
  int r = 0;
  for (auto& [hf, i] : row) {
    i = r;
    const std::array<int, 4> q = hex_face_vertices(mesh, hf[0], hf[1]);
    for (int k = 0; k < 4; ++k) out.quads(r, k) = q[size_t(k)];
    ++r;
  }
  for (const BoundaryGroup& g : mesh.groups) {
    FaceGroups::Group fg{g.name, g.family, g.id, {}};
    for (const auto& hf : g.faces) fg.rows.push_back(row.at(hf));
    out.groups.push_back(std::move(fg));  // rows are sorted: faces and rows are both in (hex, face) order
  }
  return out;
}

void write_hexmesh(const HexMesh& mesh, const std::filesystem::path& path, const std::string& format,
                   const CellData& cell_data) {
  if (const std::string problem = boundary_groups_problem(mesh); !problem.empty())
    throw InvalidInput(path.string() + ": " + problem + "; no file written");
  switch (choose_mesh_format(format, path, true)) {
    case MeshFormat::Exodus:
      return write_exodus_hex(mesh, path);
    case MeshFormat::Abaqus:
      return write_abaqus_hex(mesh, path);
    default:
      return write_cell_mesh(path, mesh.V, CellBlock{mesh.H.data(), mesh.H.rows(), 8}, kHexKind, format, cell_data,
                             face_groups(mesh));
  }
}

HexMesh read_hexmesh(const std::filesystem::path& path, HexReadReport* report) {
  HexReadReport local;
  HexReadReport& r = report ? *report : local;
  r = HexReadReport{};
  CellsRead raw = read_cell_mesh(path, kHexKind);
  if (raw.cells.empty()) throw IOError(path.string() + ": no hexahedra");
  HexMesh m;
  m.V = std::move(raw.V);
  m.H.resize(Eigen::Index(raw.cells.size() / 8), 8);
  std::copy(raw.cells.begin(), raw.cells.end(), m.H.data());
  m.source = path.string();
  r.vertices = int(m.V.rows());
  r.hexes = int(m.H.rows());
  r.warnings = std::move(raw.warnings);
  return m;
}

}  // namespace polyhex
