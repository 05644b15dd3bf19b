/// @file boundary_groups.h
/// @brief Named boundary groups of the final hex mesh (beyond the paper), for a solver's boundary
/// conditions: the whole boundary, one group per PolyCube chart, one per patch of the input surface
/// bounded by its sharp edges.
///
/// The hex mesh's boundary lies on the input surface (§6 projects it there; padding and optimization keep
/// it there), but no stage keeps which chart a boundary quad came from: padding re-creates the boundary
/// and optimization moves it. So each boundary quad is given the chart of the boundary triangle of the
/// segmented tet mesh nearest to its centroid (the tet mesh's rest positions, which are the input
/// surface's), and the patch of the nearest input-surface triangle. A quad lies within a fraction of a hex
/// edge of its surface, and a chart or patch is many hex edges wide, so only quads across a chart border
/// can go either way.
#pragma once

#include "nodes/algorithms/features.h"
#include "nodes/artefacts/meshes.h"
#include "nodes/artefacts/polycube_map.h"
#include "runtime/stat_fields.h"

namespace polyhex {

struct BoundaryGroupsParams {
  bool charts = true;  ///< one group `chart_<id>` per PolyCube chart (needs a map with its segmentation)
  double feature_angle = kFeatureAngle;  ///< one group `patch_<id>` per surface patch bounded by edges sharper than
                                         ///< this (degrees, [1, 179]; 0 = no patch groups; needs the surface)
};

struct BoundaryGroupsStats {
  long boundary_faces = 0;  ///< faces of the `boundary` group
  int chart_groups = 0;     ///< charts holding at least one boundary face
  int patch_groups = 0;     ///< surface patches holding at least one boundary face
  int surface_patches = 0;  ///< patches of the surface at feature_angle
  long facing_away = 0;     ///< boundary faces whose nearest chart or patch triangle faces the other way (thin walls)
  double seconds = 0;

  /// Report names (runtime/stat_fields.h).
  static constexpr auto fields() {
    using S = BoundaryGroupsStats;
    return std::make_tuple(stat("boundary_faces", &S::boundary_faces), stat("chart_groups", &S::chart_groups),
                           stat("patch_groups", &S::patch_groups), stat("surface_patches", &S::surface_patches),
                           stat("faces_facing_away", &S::facing_away), stat("seconds", &S::seconds));
  }
};

/// The mesh with its boundary groups, in this order: `boundary` (family "boundary", every boundary face),
/// `chart_<c>` (family "chart", id c, the segmentation's chart ids) for every chart that holds a face, then
/// `patch_<k>` (family "patch", id k, features.h surface_patches) for every patch that holds a face. Groups
/// the mesh had before are replaced.
/// \param mesh     conforming hex mesh whose boundary lies on the surface
/// \param map      the PolyCube map the mesh was extracted from (its input tets and segmentation), or null
/// \param surface  the input surface, or null
/// \pre mesh passes check_hex_mesh
/// \throw InvalidInput when the mesh has no hex or no boundary face, a coordinate is not finite, p.charts is
///        set and the map is null, has no input or segmentation or its sizes disagree, p.feature_angle > 0
///        and the surface is null or empty, or p.feature_angle is outside {0} and [1, 179]
HexMesh add_boundary_groups(const HexMesh& mesh, const PolyCubeMap* map, const SurfaceMesh* surface,
                            const BoundaryGroupsParams& p = {}, BoundaryGroupsStats* stats = nullptr);

}  // namespace polyhex
