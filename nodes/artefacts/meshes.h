/// @file meshes.h
/// @brief The mesh artefacts that flow between nodes: SurfaceMesh, TetMesh, HexMesh.
///
/// Artefacts are plain data (Eigen matrices, one row per element) and pass between nodes as
/// `std::shared_ptr<const T>`: no node changes another node's output.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>  // cross products everywhere meshes are used

#include <array>
#include <string>
#include <vector>

namespace polyhex {

using RowMatrixX3d = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using RowMatrixX3i = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;
using RowMatrixX4i = Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor>;
using RowMatrixX8i = Eigen::Matrix<int, Eigen::Dynamic, 8, Eigen::RowMajor>;

/// A closed, oriented triangle surface.
struct SurfaceMesh {
  RowMatrixX3d V;      ///< #V by 3 vertex positions
  RowMatrixX3i F;      ///< #F by 3 triangles, counter-clockwise seen from outside (outward normals)
  std::string source;  ///< file it was read from, or "shapes:<name>"
};

/// A tetrahedral mesh. Every tet is positively oriented:
/// (v1-v0) x (v2-v0) . (v3-v0) > 0.
struct TetMesh {
  RowMatrixX3d V;  ///< #V by 3 vertex positions
  RowMatrixX4i T;  ///< #T by 4 tetrahedra
  std::string source;
};

/// A named set of boundary faces of a hex mesh, to put boundary conditions on: a side set and the node
/// set of its faces' vertices in Exodus II, a surface and a node set in Abaqus, a physical group in Gmsh.
/// Groups of one family do not overlap (a face is in at most one chart), groups of different families do.
struct BoundaryGroup {
  std::string name;    ///< unique in the mesh, letters, digits and '_', starting with a letter (every format's rule),
                       ///< e.g. "chart_3"
  std::string family;  ///< what the group stands for: "boundary", "chart", "patch"; formats with one reference per face
                       ///< (Medit) or one array per family (VTK) use it
  int id = 0;          ///< number of the group within its family (the chart id, the patch id; 0 for "boundary"), >= 0
  std::vector<std::array<int, 2>>
      faces;  ///< (hex, local face 0..5 of hex_topology::kFaces), sorted, each a boundary face
};

/// An all-hex mesh. One vertex order everywhere, VTK_HEXAHEDRON: bottom face 0-1-2-3, top face
/// 4-5-6-7 above it (4 over 0), (p1-p0) x (p3-p0) . (p4-p0) > 0 for a valid hex.
struct HexMesh {
  RowMatrixX3d V;  ///< #V by 3 vertex positions
  RowMatrixX8i H;  ///< #H by 8 hexahedra, VTK_HEXAHEDRON order
  std::string source;
  /// Optional boundary groups (the boundary_groups node); they refer to H, so a node that changes H
  /// drops them (a default-constructed or copied-then-rebuilt mesh has none).
  std::vector<BoundaryGroup> groups;
};

}  // namespace polyhex
