/// @file polycube_vtk.h
/// @brief The PolyCube structure's labelled surface as VTK (--save-all and `save_surface` of the
/// segmentation; the map's saver).
#pragma once

#include "nodes/artefacts/polycube.h"

#include <filesystem>

namespace polyhex {

/// Writes the labelled surface as legacy VTK polydata with cell data `chart`, `axis` (0..2) and
/// `label` (0..5 = +X,-X,+Y,-Y,+Z,-Z) (write_surface, atomic).
/// \param V  #V by 3 positions the triangles index (e.g. the deformed tet mesh's V)
/// \pre path ends in .vtk   \throw IOError when the file cannot be written
void write_polycube_vtk(const std::filesystem::path& path, const RowMatrixX3d& V, const PolyCubeSegmentation& s);

}  // namespace polyhex
