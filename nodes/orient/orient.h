/// @file orient.h
/// @brief The frame in which the PolyCube is built (beyond the paper's limitation 2: "the results of our
/// method depend on the orientation of the model"): candidate frames from the surface, scored by how
/// well its normals line up with the axes, so that a turned copy of a model gets the model's own frame.
///
/// The score of a frame R is the axis-alignment energy of the area-weighted normals n_t,
///   E(R) = sum_t A_t (1 - sum_i (R n_t)_i^4) / (0.4 sum_t A_t),
/// 0 when every normal is on an axis, 1 on average for normals spread evenly over the sphere. The
/// candidates are the local minima of E reached by gradient descent on SO(3) from: the input frame, the
/// principal axes of the normals' second moments, frames of the dominant normal directions (pairs of
/// heavy, nearly orthogonal bins of a cube-map histogram) and a spread of rotations; plus the input
/// frame itself, unchanged. The input frame is always scored, and runs when it is as good as the best:
/// an axis-aligned part keeps its frame. As an option (flat_sigma_degrees), a minimum of a part with flat
/// faces is moved onto the frame of those faces: the energy's minimum is pulled off it by the normals on no
/// axis. See docs/orientation.md.
#pragma once

#include "nodes/artefacts/frames.h"
#include "nodes/artefacts/meshes.h"
#include "runtime/stat_fields.h"

namespace polyhex {

struct OrientParams {
  int max_frames = 3;  ///< frames that run as branches at most, the input frame included, [1, 8]
  double within =
      0.25;  ///< besides the lowest-energy frame, frames with energy up to (1 + within) x its energy run too, [0, 10]
  double distinct_degrees = 5;  ///< candidates closer than this (up to the cube's symmetries) are one, (0, 45]
  int histogram = 16;           ///< normals are binned on a cube map of 6 x histogram^2 cells, [2, 256]
  int spread_starts = 24;       ///< descents also start from this many rotations spread over SO(3), [0, 1000]
  /// A minimum is moved onto the nearby frame of the surface's flat faces: robust least squares of the
  /// normals' parts off their nearest axis, each weighted by its area times exp(-(its angle / sigma)^2),
  /// sigma from this down to 1/100 of it; 0 = off, [0, 20]. An option: 3 gives turned CAD parts their own
  /// frame exactly, but the results table's turned copies did not follow their originals better
  /// (docs/orientation.md, "Flat faces")
  double flat_sigma_degrees = 0;
  /// ... kept only when at least this share of the area is then within 0.1 degree of an axis (flat faces:
  /// 23-100 % on the shared CAD models, under 1 % on scans and organic models), [0, 1]
  double flat_min_area = 0.1;
};

/// What the search saw, for the report.
struct OrientStats {
  int starts = 0;           ///< descents run
  int bins = 0;             ///< non-empty normal bins
  double input_energy = 0;  ///< E of the input frame
  double best_energy = 0;   ///< lowest E found
  int branches = 0;         ///< frames that run (the input frame included)
  int flattened = 0;        ///< minima moved onto the frame of the flat faces

  /// Report names (runtime/stat_fields.h).
  static constexpr auto fields() {
    using S = OrientStats;
    return std::make_tuple(stat("starts", &S::starts), stat("bins", &S::bins), stat("input_energy", &S::input_energy),
                           stat("best_energy", &S::best_energy), stat("branches", &S::branches),
                           stat("flattened", &S::flattened));
  }
};

/// Axis-alignment energy E(R) of a surface's triangle normals (area-weighted; see the file comment).
/// \pre s has at least one triangle of positive area
double alignment_energy(const SurfaceMesh& s, const Eigen::Matrix3d& R);

/// The candidate frames of a surface, scored, and which run. candidates[0] is the input frame
/// (identity, or input_axes); the others follow by increasing energy, each canonical (the one of its 24
/// cube-equivalent rotations nearest the identity), no two within distinct_degrees. A minimum within
/// distinct_degrees of the input frame and less than 1e-4 lower in energy is the input frame (dropped:
/// an axis-aligned part runs in its own frame, bit for bit as without the search). Branch 1 goes to the
/// lowest energy (the input frame first among equals), branches 2.. to the next ones with energy up to
/// (1 + within) x the lowest plus 1e-4, up to max_frames. A minimum moved onto the flat faces' frame
/// lists `flat_faces` among its sources and is scored there. Deterministic.
/// With input_axes (the surface is in the canonical frame of placement.h, and *input_axes is the rotation
/// from it to the input's axes), the search itself runs as without (the same candidates for a turned copy),
/// and the input's axes run only where no minimum is within distinct_degrees of them and none is lower in
/// energy by 1e-4: a minimum near them runs in their place (an axis-aligned part and its turned copy run the
/// same frame), and they are not one of the frames nearly as good (a turned copy's axes would be another
/// rotation there).
/// \param s  surface, V #V by 3, F #F by 3 (its normals count, not its closedness)
/// \throw InvalidInput when s has no triangle of positive area or a coordinate is not finite
/// \throw ConfigError for params out of range
Frames orient_frames(const SurfaceMesh& s, const OrientParams& p, OrientStats* stats = nullptr,
                     const Eigen::Matrix3d* input_axes = nullptr);

/// The input-frame-only result (orient/input): one candidate, identity, branch 1.
Frames input_frame_only(const SurfaceMesh& s);

}  // namespace polyhex
