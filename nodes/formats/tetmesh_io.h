/// @file tetmesh_io.h
/// @brief Reading tet meshes (Medit `.mesh`, legacy VTK ASCII/BINARY, Gmsh `.msh` 2.2/4.1 ASCII,
/// TetGen `.node/.ele`) and writing them (VTK ASCII/BINARY, Medit, Gmsh 4.1).
///
/// A read mesh is positively oriented ((v1-v0) x (v2-v0) . (v3-v0) > 0): inverted tets are
/// re-oriented by swapping two vertices, with a warning; degenerate tets are an error.
#pragma once

#include "nodes/artefacts/meshes.h"
#include "nodes/formats/mesh_formats.h"

#include <filesystem>
#include <string>
#include <vector>

namespace polyhex {

/// What read_tetmesh found and repaired.
struct TetReadReport {
  int vertices = 0;                   ///< vertices after dropping unused ones
  int tets = 0;                       ///< tetrahedra read
  int reoriented = 0;                 ///< inverted tets whose vertices 2 and 3 were swapped
  long boundary_faces = 0;            ///< faces used by one tet
  std::vector<std::string> warnings;  ///< repairs, ignored cell types and sections
};

/// Reads a tet mesh; the format follows the extension: .mesh, .vtk, .msh, or .node/.ele (TetGen,
/// either file given; 0- or 1-based as the first index of the .node file says).
/// \return positively oriented tets, no unused vertices; `source` = the path
/// \throw IOError naming the file (and line) for a missing file, an unknown extension, malformed or
///        truncated content, wrong counts, a non-finite coordinate, an index out of range, no tets
/// \throw InvalidInput naming the file and the tet index for a degenerate tet (repeated vertex, or
///        |volume| <= 1e-14 bbox_diag^3); naming the tets and the face for a face shared by more than 2
///        tets or by 2 tets on the same side of it (overlapping tets, which re-orienting cannot fix);
///        naming the place for a boundary that is not a closed manifold surface (two parts of the
///        solid touching at an edge or a vertex only)
TetMesh read_tetmesh(const std::filesystem::path& path, TetReadReport* report = nullptr);

/// The checks and repairs of read_tetmesh on a mesh in memory (name used in messages).
/// \pre indices in range, coordinates finite
/// \throw InvalidInput as read_tetmesh
void check_and_orient_tets(TetMesh& mesh, const std::string& name, TetReadReport& report);

/// Writes a tet mesh. `format`: "auto" (by extension .vtk/.mesh/.msh), "vtk", "vtk_binary", "mesh",
/// "msh". `cell_data` (one value per tet, e.g. quality) is written by the VTK formats only.
/// \throw IOError naming the file (unknown extension, failed write); ConfigError for a bad format
void write_tetmesh(const TetMesh& mesh, const std::filesystem::path& path, const std::string& format = "auto",
                   const CellData& cell_data = {});

}  // namespace polyhex
