/// @file placement.h
/// @brief The frame the whole pipeline works in (beyond the paper's limitation 2, with the orientation
/// search of orient.h): the input's own coordinates, or a canonical frame fixed by the shape itself, so
/// that a turned or moved copy of a surface is meshed bit for bit as the surface is.
///
/// Every stage from the tet mesh on depends on the last bits of its input (TetGen's Steiner points, the
/// chart levels, the optimizer's moves): two copies of one shape in two frames give two different meshes,
/// and the minimum scaled Jacobian, a one-hex figure, comes out apart (docs/orientation.md). In the
/// canonical frame the copies are made equal before anything is computed:
///   - centre c: the mean of the vertices; radius r: the largest distance of a vertex from c;
///   - first axis e1: towards the first vertex (in the file's order) at least 0.9 r from c;
///   - second axis e2: towards the first vertex at least half as far from the line (c, e1) as the farthest
///     one, made orthogonal to e1; e3 = e1 x e2;
///   - positions R (x - c), R the rows e1, e2, e3, rounded to multiples of the grid, 2^(floor(log2 r) -
///     grid_bits).
/// A rigid motion of the input moves c, e1, e2 with it (the vertices chosen by index are the same), so the
/// canonical positions of two copies differ only by rounding, far below the grid: rounded, they are the
/// same numbers (unless one of the 3 #V coordinates lies within rounding of a grid step's middle, about
/// #V 2^(grid_bits - 50) as likely: 1.5 % for a million vertices at 24 bits). The axes are anchored on
/// vertices rather than principal axes, which a symmetric shape leaves undetermined. The orientation search
/// then runs in this frame, on the canonical surface: its candidates are the same for both copies. The
/// mesh is carried back to the input's frame at the end (unframe_hexes).
///
/// What it costs: the input's own frame is no longer where TetGen runs, so on a model the mesh is another
/// draw of the same method (its minimum moves as it does with any upstream change), and the input's axes run
/// only as the search's best frame (orient_frames' input_axes): a scan's upright pose, often a good frame
/// that no minimum of the alignment energy is near, is not tried.
#pragma once

#include "nodes/artefacts/frames.h"
#include "nodes/artefacts/meshes.h"
#include "runtime/stat_fields.h"

namespace polyhex {

/// Which frame the pipeline works in.
enum class PlacementFrame { input, canonical };

struct PlacementParams {
  PlacementFrame frame = PlacementFrame::input;  ///< input: the input's coordinates, unchanged; canonical: see above
  int grid_bits = 24;  ///< canonical positions are rounded to 2^-grid_bits of the radius (a power of 2), [8, 40]
};

/// What the canonical frame was anchored on, for the report (-1 / 0 for the input frame).
struct PlacementStats {
  int first_anchor = -1, second_anchor = -1;  ///< the vertices e1 and e2 point to
  double radius = 0;                          ///< r
  double grid = 0;                            ///< the rounding step, input units

  static constexpr auto fields() {
    using S = PlacementStats;
    return std::make_tuple(stat("first_anchor", &S::first_anchor), stat("second_anchor", &S::second_anchor),
                           stat("radius", &S::radius), stat("grid", &S::grid));
  }
};

/// One frame, branch 1, source "input" (identity) or "canonical" (R, centre and grid as above).
/// \pre s.V has finite coordinates
/// \throw InvalidInput when a coordinate is not finite, or (canonical) when the vertices are all on one line
/// \throw ConfigError for grid_bits out of range
Frames placement_frame(const SurfaceMesh& s, const PlacementParams& p, PlacementStats* stats = nullptr);

}  // namespace polyhex
