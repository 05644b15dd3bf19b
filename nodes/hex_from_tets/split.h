/// @file split.h
/// @brief The trivial all-hex baseline: every tet split into 4 hexes.
///
/// Each corner of a tet gets one hex spanned by the corner, the midpoints of its 3 edges, the
/// centres of its 3 faces and the tet centroid. All faces of these hexes are planar and every hex
/// has a positive Jacobian, but the mesh is all-irregular and far from what the PolyCube pipeline
/// produces: it is the baseline that the later stages must beat, not a result.
#pragma once

#include "nodes/artefacts/meshes.h"

namespace polyhex {

/// The split has no parameters; the struct exists for the node contract.
struct SplitParams {};

/// 4 hexes per tet. Vertex order of the output: the tet vertices (same indices), then one midpoint
/// per distinct edge, one centre per distinct face, one centroid per tet; shared edges and faces give
/// shared vertices, so the mesh is conforming when the tet mesh is. Hexes of tet t are rows
/// 4t .. 4t+3 (corner 0..3 of the tet), in VTK_HEXAHEDRON order with positive Jacobian.
/// \param tets  a tet mesh with positively oriented tets
/// \return #V' = #V + #edges + #faces + #T vertices, #H = 4 #T
/// \throw InvalidInput when there are no tets, an index is out of range, a coordinate is not finite or
///        a tet is not positively oriented (the message names the tet)
HexMesh split_tets_to_hexes(const TetMesh& tets);

}  // namespace polyhex
