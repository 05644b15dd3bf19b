/// @file mesh_formats.h
/// @brief Cell-mesh file formats shared by the tet and hex readers/writers (and the VTK pieces the
/// surface writer uses): legacy VTK (ASCII and BINARY, classic `CELLS n size` layout, version 2.0
/// header, which HexaLab and hexcheck.py read), Medit `.mesh`, Gmsh `.msh` 2.2/4.1 ASCII.
///
/// One vertex order for every format: VTK's. Medit's hexahedron and tetrahedron orders and Gmsh's
/// (element types 4 and 5) are the same as VTK_TETRA / VTK_HEXAHEDRON, so cells are copied as they
/// are (checked against hexcheck.py, which reads Medit `Hexahedra` rows as VTK order).
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "nodes/artefacts/meshes.h"

namespace polyhex {

/// Per-cell arrays written as VTK CELL_DATA (e.g. `chart`, `axis` per triangle, `quality` per tet).
/// Every array holds one value per cell; names have no blanks.
struct CellData {
  std::vector<std::pair<std::string, std::vector<int>>> ints;
  std::vector<std::pair<std::string, std::vector<double>>> reals;
  bool empty() const { return ints.empty() && reals.empty(); }
};

/// Volume mesh output formats.
enum class MeshFormat { VtkAscii, VtkBinary, Medit, Gmsh };

/// The format of a volume mesh file: `format` is "auto" (by extension: .vtk -> VTK ASCII, .mesh ->
/// Medit, .msh -> Gmsh 4.1), "vtk", "vtk_binary", "mesh" or "msh".
/// \throw IOError naming the file for "auto" with another extension
/// \throw ConfigError for an unknown format name (lists the valid ones)
MeshFormat choose_mesh_format(const std::string& format, const std::filesystem::path& path);

/// A block of cells: `rows` cells of `cols` vertex indices each, row-major, 0-based.
struct CellBlock {
  const int* data = nullptr;
  Eigen::Index rows = 0;
  int cols = 0;
};

/// Writes points and cells as a legacy VTK UNSTRUCTURED_GRID (version 2.0 header, classic CELLS),
/// ASCII or BINARY (big-endian), with optional CELL_DATA arrays.
/// \param V  #V by 3 positions
/// \pre every array of cell_data has cells.rows values
/// \throw IOError on a failed write, InvalidInput on a wrong cell_data size or name
void write_vtk_cells(const std::filesystem::path& path, const RowMatrixX3d& V, CellBlock cells, int vtk_type,
                     bool binary, const CellData& cell_data = {});
/// Writes Medit `.mesh` (MeshVersionFormatted 2, double precision) with one cell section
/// (`Tetrahedra`, `Hexahedra`), indices 1-based, reference 0. \throw IOError
void write_medit_cells(const std::filesystem::path& path, const RowMatrixX3d& V, CellBlock cells,
                       const std::string& section);
/// Writes Gmsh `.msh` 4.1 ASCII with one volume entity, node tags 1..#V, element tags 1..#cells.
/// \throw IOError
void write_gmsh_cells(const std::filesystem::path& path, const RowMatrixX3d& V, CellBlock cells, int gmsh_type);

/// Cells read from a file.
struct CellsRead {
  RowMatrixX3d V;                     ///< #V by 3 positions
  std::vector<int> cells;             ///< #cells * nodes indices, 0-based, checked in range
  std::vector<std::string> warnings;  ///< ignored cell types, unknown sections
};

/// Reads legacy VTK UNSTRUCTURED_GRID (ASCII or BINARY, classic CELLS), keeping cells of `vtk_type`
/// with `nodes` vertices; other cell types are ignored with a warning.
/// \throw IOError naming the file (and line) for malformed, truncated or inconsistent content
CellsRead read_vtk_cells(const std::filesystem::path& path, int vtk_type, int nodes);
/// Reads Medit `.mesh` ASCII: `Vertices` and the cell section `section` (other sections skipped).
/// \throw IOError naming the file and line
CellsRead read_medit_cells(const std::filesystem::path& path, const std::string& section, int nodes);
/// Reads Gmsh `.msh` 2.2 or 4.1 ASCII, keeping elements of `gmsh_type`; others ignored with a warning.
/// \throw IOError naming the file and line
CellsRead read_gmsh_cells(const std::filesystem::path& path, int gmsh_type, int nodes);

/// The cell type of a volume mesh in every format.
struct CellKind {
  int vtk_type;               ///< VTK_TETRA 10, VTK_HEXAHEDRON 12
  const char* medit_section;  ///< "Tetrahedra", "Hexahedra"
  int gmsh_type;              ///< 4 (tetrahedron), 5 (hexahedron)
  int nodes;                  ///< 4, 8
};
inline constexpr CellKind kTetKind{10, "Tetrahedra", 4, 4};
inline constexpr CellKind kHexKind{12, "Hexahedra", 5, 8};

/// Writes a volume mesh in the format chosen by choose_mesh_format(format, path). Cell data is
/// written by the VTK formats only (Medit and Gmsh files carry none).
/// \pre cells.cols == kind.nodes
/// 	hrow IOError, ConfigError as choose_mesh_format and the writers
void write_cell_mesh(const std::filesystem::path& path, const RowMatrixX3d& V, CellBlock cells, const CellKind& kind,
                     const std::string& format, const CellData& cell_data = {});
/// Reads the cells of `kind` from .vtk, .mesh or .msh (by extension).
/// 	hrow IOError for another extension or malformed content
CellsRead read_cell_mesh(const std::filesystem::path& path, const CellKind& kind);

namespace io_detail {
/// Pieces of the legacy VTK writer, shared with the surface writer.
void append_vtk_header(std::string& out, const std::string& title, bool binary, const std::string& dataset);
void append_vtk_points(std::string& out, const RowMatrixX3d& V, bool binary);
/// \throw InvalidInput naming `file` when an array has the wrong size or a blank in its name
void append_vtk_cell_data(std::string& out, const CellData& data, Eigen::Index cells, bool binary,
                          const std::string& file);
/// Writes a whole buffer through write_file_atomic.
void write_buffer(const std::filesystem::path& path, const std::string& buffer, bool binary);
}  // namespace io_detail

}  // namespace polyhex
