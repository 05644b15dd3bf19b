/// @file pad.h
/// @brief Padding layer (paper §6 inset, [She07, Mar09]): every boundary quad is extruded into a hex,
/// which gives the optimization the freedom the hexes at PolyCube edges and corners lack on smooth parts.
#pragma once

#include "nodes/artefacts/meshes.h"
#include "runtime/stat_fields.h"

#include <array>
#include <vector>

namespace polyhex {

/// The params of pad_boundary. Their ranges are declared once, in the binding (pad_node.cpp), which checks
/// them and lists them in `polyhex nodes`.
struct PadParams {
  double thickness = 0.4;       ///< inward offset of the inner copies, fraction of the local hex edge
  int max_halvings = 10;        ///< halve a vertex's offset at most this often while a hex it touches is inverted
  bool remove_doublets = true;  ///< first remove hexes at boundary doublets (see remove_boundary_doublets)
  int peel_rounds = 0;          ///< first remove boundary hexes with corner scaled Jacobian <= peel_sj, this many times
  double peel_sj = 0.0;         ///< see peel_rounds
  bool repair_nonmanifold =
      true;  ///< first remove hexes at non-manifold boundary edges and vertices (remove_nonmanifold_boundary)
  bool selective = true;  ///< pad only where the lattice turns otherwise than the surface (select_padded_quads); the
                          ///< layer ends on convex creases
  double turn_tolerance = 30.0;  ///< degrees: a boundary edge whose lattice and surface turns differ by more needs
                                 ///< the layer on both sides (see select_padded_quads)
  bool split_parts = true;  ///< selective: parts of the layer that meet (on a convex crease) are padded in turn, each
                            ///< ending on the crease; false: all in one layer, sheared round such a crease (0.71).
                            ///< Off, femur's turned copy gets one layer where a second one re-covered most of the
                            ///< first (docs/orientation.md); not the default, the table's figures would move
};

struct PadStats {
  long hexes_added = 0;     ///< = boundary quads of the input
  long vertices_added = 0;  ///< = boundary vertices of the input
  long inverted = 0;        ///< hexes of the result with a corner scaled Jacobian <= 0
  long limited = 0;         ///< boundary vertices whose offset had to be reduced
  long doublets = 0;        ///< boundary doublet vertices found in the input (remove_doublets)
  long hexes_removed = 0;   ///< hexes removed to resolve them
  long peeled = 0;          ///< poor boundary hexes removed (peel_rounds)
  long nonmanifold_edges = 0, nonmanifold_vertices = 0;  ///< found in the input (repair_nonmanifold)
  long nonmanifold_removed = 0;                          ///< hexes removed to make the boundary manifold
  long nonmanifold_left = 0;  ///< non-manifold boundary edges + vertices of the result (0 unless the repair gave up)
  int layers = 0;             ///< layers added (selective padding adds them in turn, up to 4)
  long unpadded = 0;          ///< boundary quads of the result on hexes of the input (no layer over them)
  long layer_ends = 0;        ///< vertices where the layer ends on a crease: their inner copy lies on the surface
  double seconds = 0;

  /// Report names (runtime/stat_fields.h).
  static constexpr auto fields() {
    using S = PadStats;
    return std::make_tuple(
        stat("hexes_added", &S::hexes_added), stat("vertices_added", &S::vertices_added), stat("limited", &S::limited),
        stat("doublets", &S::doublets), stat("hexes_removed", &S::hexes_removed), stat("peeled", &S::peeled),
        stat("nonmanifold_edges", &S::nonmanifold_edges), stat("nonmanifold_vertices", &S::nonmanifold_vertices),
        stat("nonmanifold_removed", &S::nonmanifold_removed), stat("nonmanifold_left", &S::nonmanifold_left),
        stat("layers", &S::layers), stat("unpadded", &S::unpadded), stat("layer_ends", &S::layer_ends),
        stat("inverted", &S::inverted), stat("seconds", &S::seconds));
  }
};

/// The non-manifold places of a hex mesh's boundary (faces in one hex only).
struct BoundaryDefects {
  std::vector<std::array<int, 2>> edges;  ///< boundary edges not in exactly two boundary faces (sorted pairs)
  std::vector<int>
      vertices;  ///< boundary vertices whose boundary faces form more than one fan across their manifold edges
};

/// Finds the non-manifold boundary edges and vertices: where two sheets of hexes touch along an edge only
/// (four boundary faces on it) or at a vertex only. Lattice extraction makes them where the PolyCube map
/// folds; padding cannot extrude them (one inner copy for two sheets) and no vertex placement untangles
/// the layer hexes there.
BoundaryDefects find_boundary_defects(const HexMesh& mesh);

/// remove_nonmanifold_boundary's result.
struct NonmanifoldRepair {
  HexMesh mesh;       ///< the mesh without the removed hexes (a copy of the input if it has no defect)
  long edges = 0;     ///< non-manifold boundary edges found in the input
  long vertices = 0;  ///< non-manifold boundary vertices found in the input
  long removed = 0;   ///< hexes removed
};

/// peel_boundary_hexes's result.
struct Peeled {
  HexMesh mesh;      ///< the mesh without the peeled hexes (never empty)
  long removed = 0;  ///< hexes removed
};

/// remove_boundary_doublets's result.
struct DoubletRepair {
  HexMesh mesh;       ///< the mesh without the removed hexes (a copy of the input if it has no doublet)
  long doublets = 0;  ///< boundary doublet vertices found in the input
  long removed = 0;   ///< hexes removed
};

/// Removes hexes until the boundary is manifold: per non-manifold edge or vertex, the hex with a boundary
/// face on it that has the most boundary faces (then the lowest corner scaled Jacobian, then the lowest
/// index); repeated while defects remain, at most 20 rounds. Unused vertices are dropped.
/// \throw Interrupted after SIGINT/SIGTERM
NonmanifoldRepair remove_nonmanifold_boundary(const HexMesh& mesh);

/// Removes the hexes with a boundary face whose corner scaled Jacobian is <= max_sj, `rounds` times (each
/// round sees the new boundary). The layer that padding adds in their place starts from the surface and is
/// easier to untangle than a folded hex pressed against it.
/// A round that would remove every hex is skipped.
/// \throw Interrupted after SIGINT/SIGTERM
Peeled peel_boundary_hexes(const HexMesh& mesh, double max_sj, int rounds);

/// Removes hexes at boundary doublets. A doublet is a boundary vertex in only two boundary quads: they
/// share both of its boundary edges, so on a smooth surface both are flat (180 degrees) at it, and after
/// padding the two layer hexes on them share two faces and one of them is always inverted or flat there
/// (the determinants at the doublet have opposite signs). Per doublet, the incident hex with a boundary
/// face at it that has the most boundary faces (then the lowest corner scaled Jacobian, then the lowest
/// index) is removed; repeated while doublets remain (at most 5 rounds). When these removals together
/// would make a boundary edge non-manifold (that was not), each doublet in turn takes the first of its
/// candidates, in the same order, whose removal (with those taken so far) does not; a doublet with no
/// such candidate is left. Unused vertices are dropped.
/// \param mesh  conforming hex mesh
/// \throw Interrupted after SIGINT/SIGTERM
DoubletRepair remove_boundary_doublets(const HexMesh& mesh);

/// Which boundary quads get a layer hex (selective padding, after Cherchi et al. 2019, "Selective padding for
/// polycube-based hexahedral meshing"). The layer is there for the hexes at PolyCube edges, whose two boundary
/// faces meet at the lattice's right angle where the surface is smooth (or turns by another angle): flat hexes.
/// Where the surface turns as the lattice does (a part's convex or concave edge at about 90 degrees), the hexes
/// are good without it, and a layer across a convex edge caps them at 0.71 (0.58 at a corner).
/// Per boundary edge: the lattice turns by +90 (one hex on the edge: convex), 0 (two) or -90 degrees (three);
/// the surface by the signed angle between the two quads' normals. Both quads of an edge whose two turns differ
/// by more than `tolerance_deg` (or that is not manifold) are padded; then, until nothing changes, the layer
/// grows across every edge where it would end that is not convex within the tolerance of 90 degrees, and over
/// the unpadded quads of every vertex whose padded quads are not one fan between two such edges.
/// \param mesh  conforming hex mesh   \param Q  its boundary quads (hex_boundary_quads)
/// \return per quad of Q: 1 = padded
std::vector<char> select_padded_quads(const HexMesh& mesh,
                                      const Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor>& Q,
                                      double tolerance_deg);

/// Extrudes the boundary into one layer of hexes. Every boundary vertex v is duplicated: the inner copy
/// replaces v in the existing hexes and moves inward along the averaged inward normal of its boundary
/// quads by thickness x (mean length of its edges), halved while a hex it touches is inverted (never
/// below the original positions' validity); the outer copy stays (projected onto `surface` if given).
/// For each boundary quad (a, b, c, d), outward in its hex, the new hex is (a', b', c', d', a, b, c, d).
/// With p.selective only the quads of select_padded_quads get one; where the layer ends (on a convex crease),
/// the inner copy of a vertex moves away from the layer along the unpadded side's surface instead, and the
/// unpadded quads there take it: the layer hex's side face becomes a strip of the boundary.
/// \param mesh     conforming hex mesh, VTK_HEXAHEDRON order
/// \param surface  the input surface or null; if given, the outer vertices are projected onto it
/// With p.peel_rounds > 0 the poor boundary hexes are removed first (peel_boundary_hexes); with
/// p.repair_nonmanifold the hexes at non-manifold boundary edges and vertices are removed first
/// (remove_nonmanifold_boundary), then with p.remove_doublets those at boundary doublets
/// (remove_boundary_doublets).
/// \return the padded mesh: V = [kept input vertices, inner copies], hexes = [kept input hexes, layer]
/// \throw InvalidInput when the mesh fails check_hex_mesh or has no boundary
HexMesh pad_boundary(const HexMesh& mesh, const SurfaceMesh* surface, const PadParams& p = {},
                     PadStats* stats = nullptr);

}  // namespace polyhex
