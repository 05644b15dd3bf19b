// Turned copies of test inputs: fixed rotations from a seed, applied to surfaces. Header-only.
#pragma once

#include "nodes/artefacts/meshes.h"

#include <Eigen/Geometry>

#include <random>

namespace polyhex::test {

/// A rotation drawn uniformly from SO(3) by a seeded generator (the same seed, the same rotation).
inline Eigen::Matrix3d seeded_rotation(unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::Quaterniond q(g(rng), g(rng), g(rng), g(rng));
  return q.normalized().toRotationMatrix();
}

/// `s` with every vertex x replaced by R x.
inline SurfaceMesh rotated(const SurfaceMesh& s, const Eigen::Matrix3d& R) {
  SurfaceMesh r = s;
  r.V = s.V * R.transpose();
  return r;
}

/// `s` turned by R about the origin, then moved by t: every vertex x replaced by R x + t.
inline SurfaceMesh moved(const SurfaceMesh& s, const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  SurfaceMesh m = rotated(s, R);
  m.V.rowwise() += t.transpose();
  return m;
}

}  // namespace polyhex::test
