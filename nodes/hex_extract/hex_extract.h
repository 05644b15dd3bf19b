/// @file hex_extract.h
/// @brief Hex mesh generation from a PolyCube map (paper §6): hex vertices at the integer points of the
/// PolyCube lattice, hex centroids at the half-integer points, both mapped back to the input by
/// barycentric coordinates, hexes formed by a search within the model's volume.
///
/// Work is in lattice units P = U / h (h = map.edge_length), so chart planes are integer planes.
///
/// Vertices are generated in the order PolyCube corners, edges, facets, volume (§6):
///  - corners: the corner's mesh vertex (all three coordinates on chart planes);
///  - edges: integer points along each PolyCube edge chain (two coordinates fixed on the two charts'
///    planes), mapped by linear interpolation along the chain segment;
///  - facets: integer points inside each chart's boundary triangles, located in 2D in the chart's plane,
///    mapped by the triangle's barycentric coordinates, so they lie exactly on the input surface;
///  - volume: integer points inside the tets of the PolyCube map ("rasterised": every tet visits the
///    lattice points of its bounding box, a uniform grid of cell 1), mapped by barycentric coordinates.
/// The map is not bijective: at concave PolyCube edges tets invert and overlap (Fig. 9). Candidates of
/// one lattice point are clustered by mapped position (within `duplicate_distance` h). A cluster whose
/// degree (number of positive minus inverted containing simplices) is <= 0 lies outside the PolyCube
/// and conflicts with its structure; so does a volume point whose lattice neighbour across a facet
/// (the neighbour on the inner side of a facet vertex's chart) says it is outside. Such candidates are
/// dropped (dropped_conflict). A candidate whose lattice point is already taken by a vertex mapped within
/// `duplicate_distance` h is dropped (dropped_duplicate); a far-away one is another sheet and is kept.
/// Containment tests use a fixed tiny perturbation of the lattice point (simulation of simplicity), so a
/// point on a shared face is inside exactly one simplex of each sheet.
///
/// Hex centroids are generated in the same way in the volume; each centroid keeps the tet holding it.
/// The hex is formed by a breadth-first search over face-adjacent tets from that tet, restricted to tets
/// whose lattice bounding box meets the hex's unit cube grown by `search_margin` (folded
/// tets at concave edges need the margin to stay face-connected): the 8 vertices are the ones with the cube's
/// corner coordinates whose anchor simplex was reached (not across a gap). Output in VTK_HEXAHEDRON order,
/// positive in the lattice.
#pragma once

#include "nodes/artefacts/meshes.h"
#include "nodes/artefacts/polycube_map.h"
#include "runtime/stat_fields.h"

namespace polyhex {

/// A tet of a sound map spans a few hex edges (a box of at most a few hundred lattice points); one whose
/// box holds more comes from a map that exploded there (distortion 1e11 was seen on a badly turned
/// part) and would take hours to rasterise: it is skipped and counted (HexExtractStats::exploded_tets).
constexpr double kMaxLatticePointsPerTet = 1e5;

struct HexExtractParams {
  double duplicate_distance =
      5.0;  ///< in hex edges: same lattice point and mapped this close = duplicate (§6: five), [0.5, 100]
  double search_margin =
      0.5;  ///< lattice units: the hex search visits tets meeting its unit cube grown by this, [1e-3, 2]
  double perturbation = 1e-7;  ///< lattice units: fixed offset of points for containment tests (breaks ties), [0, 1e-3]
};

struct HexExtractStats {
  long hexes = 0;
  long vertices = 0;                                                                     ///< vertices used by the hexes
  long corner_vertices = 0, edge_vertices = 0, facet_vertices = 0, volume_vertices = 0;  ///< kept, per kind
  long dropped_conflict = 0;   ///< candidates outside the PolyCube structure (degree <= 0, wrong side of a facet)
  long dropped_duplicate = 0;  ///< candidates whose lattice point was taken by a vertex within duplicate_distance
  long exploded_tets =
      0;  ///< tets of the map whose lattice box holds more than kMaxLatticePointsPerTet points: not rasterised
  long unused_vertices = 0;  ///< kept vertices no hex uses (removed from the output)
  long centroids = 0;        ///< hex centroids generated
  long unlocated = 0;        ///< hex corners not found by the search (their hex is left out)
  long hexes_skipped = 0;    ///< centroids without a complete hex
  long duplicate_hexes = 0;  ///< hexes formed twice from overlapping centroids (one kept)
  long inverted = 0;         ///< hexes with a corner scaled Jacobian <= 0 (before padding / optimization)
  double seconds = 0;

  /// Report names (runtime/stat_fields.h).
  static constexpr auto fields() {
    using S = HexExtractStats;
    return std::make_tuple(
        stat("hexes", &S::hexes), stat("vertices", &S::vertices), stat("corner_vertices", &S::corner_vertices),
        stat("edge_vertices", &S::edge_vertices), stat("facet_vertices", &S::facet_vertices),
        stat("volume_vertices", &S::volume_vertices), stat("dropped_conflict", &S::dropped_conflict),
        stat("dropped_duplicate", &S::dropped_duplicate), stat("exploded_tets", &S::exploded_tets),
        stat("unused_vertices", &S::unused_vertices), stat("centroids", &S::centroids),
        stat("unlocated", &S::unlocated), stat("hexes_skipped", &S::hexes_skipped),
        stat("duplicate_hexes", &S::duplicate_hexes), stat("inverted", &S::inverted), stat("seconds", &S::seconds));
  }
};

/// Extracts the all-hex mesh of a PolyCube map (§6).
/// \param map  PolyCube map: input tets, segmentation, U (#V by 3), edge_length h > 0, chart_plane (#charts)
/// \return hex mesh in the input's space; V #V by 3, H #H by 8 VTK_HEXAHEDRON order
/// \throw InvalidInput when the map is inconsistent (sizes, missing input or segmentation, h <= 0, a chart
///        plane that does not match its vertices) or no hex could be formed; Interrupted after
///        SIGINT/SIGTERM (runtime/cancel.h), checked between the phases and inside the long loops
HexMesh extract_hexes(const PolyCubeMap& map, const HexExtractParams& p = {}, HexExtractStats* stats = nullptr);

}  // namespace polyhex
