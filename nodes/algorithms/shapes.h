/// @file shapes.h
/// @brief Built-in closed test surfaces, so the default run and the unit tests need no file.
#pragma once

#include "nodes/artefacts/meshes.h"

#include <string>
#include <vector>

namespace polyhex {

struct ShapeParams {
  std::string name = "fandisk_like";  ///< one of shape_names()
  int resolution = 64;                ///< samples along the longest side (level-set voxels or parameter steps)
};

/// Names accepted by make_shape: sphere, torus, bumpy_torus, rod_with_holes, l_block, bent_pipe,
/// fandisk_like, box, and the exact solids with sharp edges (their creases are the solid's, not rounded by a
/// level set): sharp_l_block, chamfered_box, filleted_cylinder, stepped_ring. `resolution` sets their grid (cells of
/// about 1 / resolution).
std::vector<std::string> shape_names();

/// A closed, manifold, outward-oriented triangle surface of the named shape.
/// \throw InvalidInput for an unknown name (the message lists shape_names())
SurfaceMesh make_shape(const ShapeParams& p);

}  // namespace polyhex
