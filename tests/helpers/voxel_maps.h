// Shared fixtures of the hex_extract / pad / optimize tests: exact PolyCube maps of voxel shapes.
#pragma once

#include "nodes/artefacts/polycube_map.h"
#include "nodes/polycube_segment/polycube_segment.h"
#include "nodes/tetrahedralize/tetgen.h"
#include "tests/helpers/hex_fixtures.h"  // grid_hex_mesh
#include "tests/helpers/voxel_shapes.h"

#include <Eigen/Geometry>

#include <cmath>
#include <memory>
#include <random>

namespace polyhex::test {

/// The exact PolyCube map of a voxel shape: U = V (the shape is its own PolyCube), charts from
/// segment_polycube on the undeformed tets, h = voxel size / `per_voxel`.
inline PolyCubeMap identity_map(const std::vector<std::array<int, 3>>& voxels, int per_voxel, double tet_edge = 0.08) {
  SurfaceMesh s = voxel_surface(voxels, 1.0);
  TetgenParams tp;
  tp.edge_length = tet_edge;
  auto tets = std::make_shared<const TetMesh>(tetrahedralize(s, tp));
  // exact labels from the exact normals (the normal smoothing of segment_polycube may mislabel small
  // triangles next to an edge, which an exact test must not depend on)
  const RowMatrixX3i F = boundary_triangles(*tets);
  Eigen::VectorXi label(F.rows());
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = tets->V.row(F(f, 0)), b = tets->V.row(F(f, 1)), c = tets->V.row(F(f, 2));
    Eigen::Vector3d n = (b - a).cross(c - a);
    Eigen::Index axis;
    n.cwiseAbs().maxCoeff(&axis);
    label[f] = int(2 * axis + (n[axis] > 0 ? 0 : 1));
  }
  auto seg = std::make_shared<const PolyCubeSegmentation>(analyse_polycube_labels(tets->V, F, label));
  PolyCubeMap m;
  m.input = tets;
  m.segmentation = seg;
  m.U = tets->V;
  m.edge_length = 1.0 / per_voxel;
  m.chart_plane.resize(Eigen::Index(seg->charts.size()));
  for (Eigen::Index f = 0; f < seg->F.rows(); ++f) {
    const int c = seg->chart[f];
    m.chart_plane[c] = int(std::lround(tets->V(seg->F(f, 0), label_axis(seg->charts[size_t(c)].label)) * per_voxel));
  }
  return m;
}

}  // namespace polyhex::test
