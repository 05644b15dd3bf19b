/// @file hex_topology.h
/// @brief Local topology of a VTK_HEXAHEDRON (bottom face 0-1-2-3, top face 4-5-6-7 above it), shared by
/// every stage that walks a hex's corners, faces or edges (quality, padding, optimization). The tables
/// are those of ../shared/tools/hexcheck.py, so our figures and the independent checker's agree.
#pragma once

namespace polyhex::hex_topology {

/// Corner o with its three edge neighbours (b, c, d), ordered so that det[b-o, c-o, d-o] > 0 for a valid hex.
/// kCorners[j] is also the set of corners whose frames use corner j (edge neighbours are mutual): a move of
/// corner j alone leaves the other 4 corner frames, and every per-corner figure of them, as they were.
inline constexpr int kCorners[8][4] = {{0, 1, 3, 4}, {1, 2, 0, 5}, {2, 3, 1, 6}, {3, 0, 2, 7},
                                       {4, 7, 5, 0}, {5, 4, 6, 1}, {6, 5, 7, 2}, {7, 6, 4, 3}};
/// The 6 faces, each ordered to face outward for a valid hex.
inline constexpr int kFaces[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                     {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
/// The 12 edges.
inline constexpr int kEdges[12][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6},
                                      {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};

}  // namespace polyhex::hex_topology
