/// @file hexmesh_io.h
/// @brief Writing and reading all-hex meshes: legacy VTK ASCII 2.0 / BINARY (cell type 12, classic
/// CELLS, as HexaLab and ../shared/tools/hexcheck.py read), Medit `.mesh` (`Hexahedra`), Gmsh
/// `.msh` 4.1 (element type 5), and for writing Exodus II and Abaqus `.inp` (solver_formats.h). Every
/// one of them lists hex vertices in VTK_HEXAHEDRON order, so rows are written as they are.
///
/// A mesh's boundary groups are written by every format: Exodus side sets + node sets, Abaqus *SURFACE +
/// *NSET, Gmsh physical groups (quads on surface entities, the hexes in the physical group `volume`),
/// VTK quad cells with one int cell array per group family, Medit Quadrilaterals with one reference
/// (mesh_formats.h says which).
#pragma once

#include "nodes/artefacts/meshes.h"
#include "nodes/formats/mesh_formats.h"

#include <filesystem>
#include <string>
#include <vector>

namespace polyhex {

/// The boundary faces of a mesh's groups, each once, with the groups as rows of them (for the writers of
/// mesh_formats.h). Rows are in (hex, face) order. \pre boundary_groups_problem(mesh) is empty
FaceGroups face_groups(const HexMesh& mesh);

/// Writes a hex mesh with its boundary groups. `format`: "auto" (by extension .vtk -> VTK ASCII, .mesh,
/// .msh, .e / .exo -> Exodus II, .inp -> Abaqus), "vtk", "vtk_binary", "mesh", "msh", "exodus", "abaqus".
/// `cell_data` (one value per hex) is written by the VTK formats only.
/// \throw IOError naming the file (unknown extension, failed write); ConfigError for a bad format;
///        InvalidInput naming the file when the groups are inconsistent (boundary_groups_problem); in every
///        case no file is written
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
