/// @file surface_io.h
/// @brief Reading and checking closed triangle surfaces (OBJ, OFF, STL ASCII/binary, PLY
/// ASCII/binary), built-in shapes by name, and writing surfaces (OBJ, OFF, VTK polydata).
///
/// The checks follow what the tet mesher and the PolyCube stages need (paper §3: the input is a
/// closed, manifold, outward-oriented triangle mesh): every undirected edge in exactly 2 triangles,
/// the link of every vertex a single cycle, consistent and outward orientation, no degenerate faces.
/// Only safe repairs are made (welding exactly duplicate vertices, dropping unused ones, orienting
/// faces); each is reported as a warning.
#pragma once

#include "nodes/artefacts/meshes.h"
#include "nodes/formats/mesh_formats.h"

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace polyhex {

/// What read_surface found and repaired.
struct SurfaceReadReport {
  int vertices = 0;                   ///< vertices after repairs
  int faces = 0;                      ///< triangles (polygons are fan-triangulated)
  int welded = 0;                     ///< vertices removed by welding exactly duplicate positions
  int flipped = 0;                    ///< triangles whose orientation differs from the file's
  int components = 0;                 ///< connected components (through shared edges)
  int genus = 0;                      ///< total genus from the Euler characteristic: (2 components - (V - E + F)) / 2
  std::vector<std::string> warnings;  ///< one line per repair
  /// With keep_defects: the check that failed (the message read_surface would throw), else empty.
  std::vector<std::string> defects;
};

/// Reads a closed triangle surface; the format follows the extension (.obj .off .stl .ply).
/// A path `shape:NAME` builds the built-in shape `make_shape(ShapeParams{NAME})` instead.
/// \param report when not null, receives counts and the repair warnings
/// \param keep_defects instead of throwing InvalidInput for an open, non-manifold, non-orientable or
///        degenerate surface, return its triangles as read, with exactly duplicate vertices welded
///        and unused ones dropped, and the check's message in report->defects (for the surface
///        conditioning, condition_surface.h). Malformed files still throw IOError.
/// \return the surface, outward oriented, no unused or duplicate vertices; `source` = the path
/// \throw IOError naming the file (and the line or face) for a missing/unreadable file, an unknown
///        extension, a truncated file, wrong counts, a non-finite coordinate or an index out of range
/// \throw InvalidInput naming the file (and a face) for an open, non-manifold, non-orientable
///        surface or a degenerate (repeated-index or zero-area) face
SurfaceMesh read_surface(const std::filesystem::path& path, SurfaceReadReport* report = nullptr,
                         bool keep_defects = false);

/// Checks and repairs a surface in memory (what read_surface does after parsing).
/// \param name used in messages (a file name)
/// \param face_line when not empty, the file line of every face, for messages
/// \param always_weld weld exactly duplicate vertices even when the surface is closed without it
/// \pre every index of F is in [0, V.rows()), every coordinate finite
/// \throw InvalidInput as read_surface
void check_and_repair_surface(SurfaceMesh& mesh, const std::string& name, SurfaceReadReport& report,
                              const std::vector<int>& face_line = {}, bool always_weld = false);

/// Writes a surface; the format follows the extension: .obj, .off, or .vtk (legacy ASCII
/// polydata, with `cell_data` as CELL_DATA; OBJ and OFF carry no cell data).
/// \pre every array of cell_data has F.rows() values
/// \throw IOError for an unknown extension or a failed write; InvalidInput for a wrong array size
void write_surface(const SurfaceMesh& mesh, const std::filesystem::path& path, const CellData& cell_data = {});

}  // namespace polyhex
