/// @file hexmesh_io.h
/// @brief Writing and reading all-hex meshes: legacy VTK ASCII 2.0 / BINARY (cell type 12, classic
/// CELLS, as HexaLab and ../shared/tools/hexcheck.py read), Medit `.mesh` (`Hexahedra`), Gmsh
/// `.msh` 4.1 (element type 5). Medit and Gmsh list hex vertices in VTK_HEXAHEDRON order, so
/// rows are written as they are.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "nodes/artefacts/meshes.h"
#include "nodes/io/mesh_formats.h"

namespace polyhex {

/// Writes a hex mesh. `format`: "auto" (by extension .vtk -> VTK ASCII, .mesh, .msh), "vtk",
/// "vtk_binary", "mesh", "msh". `cell_data` (one value per hex) is written by the VTK formats only.
/// \throw IOError naming the file (unknown extension, failed write); ConfigError for a bad format
void write_hexmesh(const HexMesh& mesh, const std::filesystem::path& path, const std::string& format = "auto",
                   const CellData& cell_data = {});

/// What read_hexmesh found.
struct HexReadReport {
  int vertices = 0;
  int hexes = 0;
  std::vector<std::string> warnings;  ///< ignored cell types and sections
};

/// Reads a hex mesh from Medit `.mesh` (Hexahedra), legacy VTK `.vtk` (ASCII or BINARY, cell type
/// 12) or Gmsh `.msh` (type 5). Hexes are not checked for inversion (that is the quality node's job).
/// \throw IOError naming the file (and line) for a missing file, unknown extension, malformed or
///        truncated content, an index out of range, no hexes
HexMesh read_hexmesh(const std::filesystem::path& path, HexReadReport* report = nullptr);

}  // namespace polyhex
