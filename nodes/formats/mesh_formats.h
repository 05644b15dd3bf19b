/// @file mesh_formats.h
/// @brief Cell-mesh file formats shared by the tet and hex readers/writers (and the VTK pieces the
/// surface writer uses): legacy VTK (ASCII and BINARY, classic `CELLS n size` layout, version 2.0
/// header, which HexaLab and hexcheck.py read), Medit `.mesh`, Gmsh `.msh` 2.2/4.1 ASCII.
///
/// One vertex order for every format: VTK's. Medit's hexahedron and tetrahedron orders and Gmsh's
/// (element types 4 and 5) are the same as VTK_TETRA / VTK_HEXAHEDRON, so cells are copied as they
/// are (checked against hexcheck.py, which reads Medit `Hexahedra` rows as VTK order).
#pragma once

#include "nodes/artefacts/meshes.h"

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace polyhex {

/// Per-cell arrays written as VTK CELL_DATA (e.g. `chart`, `axis` per triangle, `quality` per tet).
/// Every array holds one value per cell; names have no blanks.
struct CellData {
  std::vector<std::pair<std::string, std::vector<int>>> ints;
  std::vector<std::pair<std::string, std::vector<double>>> reals;
  bool empty() const { return ints.empty() && reals.empty(); }
};

/// Boundary faces written beside the cells, with the named groups they belong to (a hex mesh's boundary
/// groups, hexmesh_io.h). Each face is written once, however many groups hold it.
struct FaceGroups {
  RowMatrixX4i quads;  ///< #Q by 4 vertex indices, outward (counter-clockwise seen from outside)
  struct Group {
    std::string name;       ///< one word (BoundaryGroup::name)
    std::string family;     ///< "boundary", "chart", "patch", ...
    int id = 0;             ///< number within the family, >= 0
    std::vector<int> rows;  ///< rows of `quads`, sorted
  };
  std::vector<Group> groups;
  bool empty() const { return groups.empty(); }
  /// The families in the order they first appear in `groups`.
  std::vector<std::string> families() const;
  /// Per quad, the id of its group of `family`, -1 for a quad in none.
  std::vector<int> family_ids(const std::string& family) const;
};

/// Volume mesh output formats. Exodus II and Abaqus are written for hex meshes only (hexmesh_io.h).
enum class MeshFormat { VtkAscii, VtkBinary, Medit, Gmsh, Exodus, Abaqus };

/// The format of a volume mesh file: `format` is "auto" (by extension: .vtk -> VTK ASCII, .mesh ->
/// Medit, .msh -> Gmsh 4.1, and with `solver_formats` .e / .exo -> Exodus II, .inp -> Abaqus), "vtk",
/// "vtk_binary", "mesh", "msh", and with `solver_formats` "exodus", "abaqus".
/// \throw IOError naming the file for "auto" with another extension
/// \throw ConfigError for an unknown format name (lists the valid ones)
MeshFormat choose_mesh_format(const std::string& format, const std::filesystem::path& path,
                              bool solver_formats = false);

/// A block of cells: `rows` cells of `cols` vertex indices each, row-major, 0-based.
struct CellBlock {
  const int* data = nullptr;
  Eigen::Index rows = 0;
  int cols = 0;
};

/// Writes points and cells as a legacy VTK UNSTRUCTURED_GRID (version 2.0 header, classic CELLS),
/// ASCII or BINARY (big-endian), with optional CELL_DATA arrays. With face groups, their quads follow the
/// cells as VTK_QUAD (9) cells, and each family is an int CELL_DATA array of that name: a quad's group id
/// in the family, -1 on the volume cells and on quads in no group of it; cell_data arrays get -1 (ints)
/// or 0 (reals) on the quads.
/// \param V  #V by 3 positions
/// \pre every array of cell_data has cells.rows values
/// \throw IOError on a failed write, InvalidInput on a wrong cell_data size or name
void write_vtk_cells(const std::filesystem::path& path, const RowMatrixX3d& V, CellBlock cells, int vtk_type,
                     bool binary, const CellData& cell_data = {}, const FaceGroups& faces = {});
/// Writes Medit `.mesh` (MeshVersionFormatted 2, double precision) with one cell section
/// (`Tetrahedra`, `Hexahedra`), indices 1-based, reference 0. With face groups, their quads follow as
/// `Quadrilaterals`, each with one reference (a Medit face has one): its group id in the first family other
/// than "boundary" (the charts of a polyhex mesh), or in the first family if there is no other; -1 for a
/// quad in no group of it. \throw IOError
void write_medit_cells(const std::filesystem::path& path, const RowMatrixX3d& V, CellBlock cells,
                       const std::string& section, const FaceGroups& faces = {});
/// Writes Gmsh `.msh` 4.1 ASCII with one volume entity, node tags 1..#V, element tags 1..#cells. With face
/// groups: the volume is the physical group `volume` (dimension 3, tag 1), each group a physical group of
/// dimension 2 (tags 1.. in order) with its name in $PhysicalNames, and the quads (element type 3, tags
/// #cells+1..) sit on one surface entity per set of groups that hold the same quads, which carries those
/// groups' tags. (Gmsh keeps only elements of physical groups when it saves a mesh that has some, hence the
/// volume group.)
/// \throw IOError
void write_gmsh_cells(const std::filesystem::path& path, const RowMatrixX3d& V, CellBlock cells, int gmsh_type,
                      const FaceGroups& faces = {});

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

/// Writes a volume mesh in the format chosen by choose_mesh_format(format, path) (not Exodus or Abaqus). Cell data is
/// written by the VTK formats only (Medit and Gmsh files carry none); face groups by every format.
/// \pre cells.cols == kind.nodes
/// \throw IOError, ConfigError as choose_mesh_format and the writers
void write_cell_mesh(const std::filesystem::path& path, const RowMatrixX3d& V, CellBlock cells, const CellKind& kind,
                     const std::string& format, const CellData& cell_data = {}, const FaceGroups& faces = {});
/// Reads the cells of `kind` from .vtk, .mesh or .msh (by extension).
/// \throw IOError for another extension or malformed content
CellsRead read_cell_mesh(const std::filesystem::path& path, const CellKind& kind);

namespace io_detail {
/// Pieces of the legacy VTK writer, shared with the surface writer.
void append_vtk_header(std::string& out, const std::string& title, bool binary, const std::string& dataset);
void append_vtk_points(std::string& out, const RowMatrixX3d& V, bool binary);
/// \throw InvalidInput naming `file` when an array's name is not one word or it has not `cells` values
void check_array_name(const std::string& name, size_t size, Eigen::Index cells, const std::string& file);
/// \throw InvalidInput naming `file` when an array has the wrong size or a blank in its name
void append_vtk_cell_data(std::string& out, const CellData& data, Eigen::Index cells, bool binary,
                          const std::string& file);
/// Writes a whole buffer through write_file_atomic.
void write_buffer(const std::filesystem::path& path, const std::string& buffer, bool binary);
}  // namespace io_detail

}  // namespace polyhex
