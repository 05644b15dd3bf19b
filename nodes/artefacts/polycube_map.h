/// @file polycube_map.h
/// @brief The PolyCube map (paper §5.2): the input tet mesh and, for each of its vertices, a position in
/// the PolyCube domain whose boundary is the PolyCube (every chart on an axis-aligned plane at an integer
/// multiple of the hex edge length).
#pragma once

#include "nodes/artefacts/meshes.h"
#include "nodes/artefacts/polycube.h"

#include <Eigen/Core>

#include <memory>

namespace polyhex {

struct PolyCubeMap {
  std::shared_ptr<const TetMesh> input;                      ///< the input tet mesh (rest positions)
  std::shared_ptr<const PolyCubeSegmentation> segmentation;  ///< charts of the input's boundary
  RowMatrixX3d U;                                            ///< #V by 3 PolyCube positions, same units as the input
  double edge_length = 0;       ///< absolute hex edge length h; chart planes sit at integer multiples of h
  Eigen::VectorXi chart_plane;  ///< #charts integer k: chart c lies on the plane x_axis(c) = k h
};

template <class T>
struct ArtefactName;
template <>
struct ArtefactName<PolyCubeMap> {
  static constexpr const char* value = "PolyCubeMap";
};

}  // namespace polyhex
