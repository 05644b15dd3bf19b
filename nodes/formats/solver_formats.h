/// @file solver_formats.h
/// @brief Hex-mesh writers for solvers: Exodus II (through the Exodus library, on netCDF) and Abaqus
/// `.inp`. Both list an 8-node hex's vertices in our VTK_HEXAHEDRON order (Exodus HEX8, Abaqus C3D8:
/// bottom 1-2-3-4, top 5-6-7-8 above it), so connectivity is written as it is; only the face (side)
/// numbers differ, converted by the tables below.
#pragma once

#include "nodes/artefacts/meshes.h"

#include <array>
#include <filesystem>

namespace polyhex {

/// Exodus II side number (1..6) of each local face of hex_topology::kFaces: the Exodus HEX sides are
/// 1: nodes 1 2 6 5, 2: 2 3 7 6, 3: 3 4 8 7, 4: 1 5 8 4, 5: 1 4 3 2, 6: 5 6 7 8.
std::array<int, 6> exodus_hex_sides();
/// Abaqus C3D8 face number (S1..S6 -> 1..6) of each local face of hex_topology::kFaces: the C3D8 faces are
/// 1: nodes 1 2 3 4, 2: 5 8 7 6, 3: 1 5 6 2, 4: 2 6 7 3, 5: 3 7 8 4, 6: 4 8 5 1.
std::array<int, 6> abaqus_hex_faces();

/// Writes Exodus II: one element block `volume` (id 1, HEX8) with every hex; per boundary group (in order,
/// ids 1..) a side set of its faces and a node set of their vertices, both named after the group; coordinate
/// names x, y, z; double precision. Written under a temporary name in the same folder, then renamed.
/// Calls from several threads are serialised (the Exodus library is not thread-safe).
/// \pre the groups pass boundary_groups_problem (write_hexmesh checks)
/// \throw IOError naming the file and the Exodus call that failed, or as write_file_atomic_by_name
void write_exodus_hex(const HexMesh& mesh, const std::filesystem::path& path);

/// Writes Abaqus `.inp`: *NODE (1..#V), *ELEMENT TYPE=C3D8 ELSET=volume (1..#H); per boundary group a
/// *NSET of its faces' vertices and a *SURFACE (TYPE=ELEMENT, lines `element, S<face>`), both named after
/// the group. Written atomically.
/// \pre as write_exodus_hex   \throw IOError
void write_abaqus_hex(const HexMesh& mesh, const std::filesystem::path& path);

}  // namespace polyhex
