/// @file serialize.h
/// @brief Binary codecs of the artefact types (SurfaceMesh, TetMesh, HexMesh, PolyCubeSegmentation,
/// PolyCubeMap, Frames) for the artefact cache (graph/cache.h).
///
/// The payload is little-endian raw data, no padding: strings and arrays are a u64 count followed by
/// the elements; matrices are u64 rows followed by rows x cols elements in row-major order (doubles as
/// IEEE-754 bit patterns, so a round trip is exact). A PolyCubeMap holds its input TetMesh and
/// segmentation inline (a u8 presence flag, then the artefact). A HexMesh is followed by its boundary
/// groups (u64 count; per group name, family, i32 id, then its (hex, face) pairs as an array of i32
/// pairs). The codecs register themselves with `Registry::add_codec` at static initialisation;
/// `kCodecVersion` is their `ArtefactCodec::version`: bump it when a layout changes, older cache entries
/// are then ignored and recomputed.
#pragma once

#include "nodes/artefacts/frames.h"
#include "nodes/artefacts/meshes.h"
#include "nodes/artefacts/polycube.h"
#include "nodes/artefacts/polycube_map.h"

#include <cstdint>
#include <iosfwd>

namespace polyhex {

/// Format version of every payload below (ArtefactCodec::version).
constexpr std::uint32_t kCodecVersion = 7;

/// Writes the payload of one artefact. \throw IOError when the stream fails
void write_binary(std::ostream& out, const SurfaceMesh& m);
void write_binary(std::ostream& out, const TetMesh& m);
void write_binary(std::ostream& out, const HexMesh& m);
void write_binary(std::ostream& out, const PolyCubeSegmentation& s);
void write_binary(std::ostream& out, const PolyCubeMap& m);
void write_binary(std::ostream& out, const Frames& f);

/// Reads a payload written by write_binary of the same type.
/// \pre the stream holds exactly one payload of that type (trailing bytes are an error)
/// \throw IOError when the data is truncated, a count exceeds the bytes left, an index is out of range
///        or bytes are left over
SurfaceMesh read_surface_binary(std::istream& in);
TetMesh read_tetmesh_binary(std::istream& in);
HexMesh read_hexmesh_binary(std::istream& in);
PolyCubeSegmentation read_segmentation_binary(std::istream& in);
PolyCubeMap read_polycube_map_binary(std::istream& in);
Frames read_frames_binary(std::istream& in);

}  // namespace polyhex
