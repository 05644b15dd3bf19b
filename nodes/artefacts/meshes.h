/// @file meshes.h
/// @brief The mesh artefacts that flow between nodes: SurfaceMesh, TetMesh, HexMesh.
///
/// Artefacts are plain data (Eigen matrices, one row per element) and pass between nodes as
/// `std::shared_ptr<const T>`: no node changes another node's output.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>  // cross products everywhere meshes are used
#include <string>
#include <vector>

namespace polyhex {

using RowMatrixX3d = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using RowMatrixX3i = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;
using RowMatrixX4i = Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor>;
using RowMatrixX8i = Eigen::Matrix<int, Eigen::Dynamic, 8, Eigen::RowMajor>;

/// A closed, oriented triangle surface.
struct SurfaceMesh {
  RowMatrixX3d V;   ///< #V by 3 vertex positions
  RowMatrixX3i F;   ///< #F by 3 triangles, counter-clockwise seen from outside (outward normals)
  std::string source;  ///< file it was read from, or "shapes:<name>"
};

/// A tetrahedral mesh. Every tet is positively oriented:
/// (v1-v0) x (v2-v0) . (v3-v0) > 0.
struct TetMesh {
  RowMatrixX3d V;   ///< #V by 3 vertex positions
  RowMatrixX4i T;   ///< #T by 4 tetrahedra
  std::string source;
};

/// An all-hex mesh. One vertex order everywhere, VTK_HEXAHEDRON: bottom face 0-1-2-3, top face
/// 4-5-6-7 above it (4 over 0), (p1-p0) x (p3-p0) . (p4-p0) > 0 for a valid hex.
struct HexMesh {
  RowMatrixX3d V;   ///< #V by 3 vertex positions
  RowMatrixX8i H;   ///< #H by 8 hexahedra, VTK_HEXAHEDRON order
  std::string source;
};

}  // namespace polyhex
