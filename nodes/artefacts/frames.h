/// @file frames.h
/// @brief The orientation search's result (nodes/orient): candidate frames in which to build the
/// PolyCube, scored, and which of them run as branches of the graph.
#pragma once

#include <Eigen/Core>

#include <string>
#include <vector>

namespace polyhex {

/// One frame: the rotation x -> R x from the input's coordinates into the frame's.
struct FrameCandidate {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  double energy = 0;   ///< axis-alignment energy of the surface normals in this frame (nodes/orient/orient.h)
  std::string source;  ///< where it came from: "input", "principal_axes", "normals", "spread" (joined by '+' when
                       ///< several agree)
  int branch = 0;      ///< the branch that builds the PolyCube in it (1-based, config `branches`), 0 = not run
};

/// The candidates: [0] is the input frame (R = identity), then the others by
/// increasing energy, no two within the search's distinct angle of each other (up to the cube's symmetries).
struct Frames {
  std::vector<FrameCandidate> candidates;

  /// The candidate that runs as branch k, or null.
  const FrameCandidate* of_branch(int k) const {
    for (const FrameCandidate& c : candidates)
      if (c.branch == k) return &c;
    return nullptr;
  }
};

template <class T>
struct ArtefactName;
template <>
struct ArtefactName<Frames> {
  static constexpr const char* value = "Frames";
};

}  // namespace polyhex
