#include "nodes/io/hexmesh_io.h"

#include <algorithm>

#include "runtime/errors.h"

namespace polyhex {

void write_hexmesh(const HexMesh& mesh, const std::filesystem::path& path, const std::string& format,
                   const CellData& cell_data) {
  write_cell_mesh(path, mesh.V, CellBlock{mesh.H.data(), mesh.H.rows(), 8}, kHexKind, format, cell_data);
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
