/// @file frames.h
/// @brief The orientation search's result (nodes/orient): candidate frames in which to build the
/// PolyCube, scored, and which of them run as branches of the graph.
#pragma once

#include <Eigen/Core>

#include <string>
#include <vector>

namespace polyhex {

/// A rigid change of coordinates, x -> R (x - centre) (R a rotation): the frame a mesh is built in, against
/// the frame of the mesh it came from.
struct RigidFrame {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();

  bool is_identity() const { return R == Eigen::Matrix3d::Identity() && centre == Eigen::Vector3d::Zero(); }
  /// Every row x of V (#V by 3) replaced by R (x - centre).
  template <class M>
  M apply(const M& V) const {
    return (V.rowwise() - centre.transpose()) * R.transpose();
  }
  /// The way back: y -> Rᵀ y + centre.
  RigidFrame inverse() const { return RigidFrame{R.transpose(), -(R * centre)}; }
  /// This frame, then `next` (given in this frame's coordinates): x -> next.R (R (x - centre) - next.centre).
  RigidFrame then(const RigidFrame& next) const { return RigidFrame{next.R * R, centre + R.transpose() * next.centre}; }
};

/// One frame: x -> R (x - centre) from the coordinates of the mesh the search saw into the frame's (an
/// orientation search's candidates turn about the origin: centre 0).
struct FrameCandidate {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  /// > 0: positions in this frame are rounded to multiples of it (the canonical frame, nodes/orient/placement.h:
  /// two copies of a shape then get the same bits); 0: not rounded
  double grid = 0;
  double energy = 0;   ///< axis-alignment energy of the surface normals in this frame (nodes/orient/orient.h)
  std::string source;  ///< where it came from: "input", "principal_axes", "normals", "spread" (joined by '+' when
                       ///< several agree)
  int branch = 0;      ///< the branch that builds the PolyCube in it (1-based, config `branches`), 0 = not run

  RigidFrame frame() const { return RigidFrame{R, centre}; }
  /// Positions V (#V by 3) in this frame: R (x - centre), rounded to multiples of grid if it is > 0 (exactly:
  /// grid is a power of 2).
  template <class M>
  M place(const M& V) const {
    M out = frame().apply(V);
    if (grid > 0) out = ((out / grid).array().round() * grid).matrix();
    return out;
  }
};

/// The candidates: [0] is the input frame (R = identity, or the input's axes when the search ran on a
/// canonical placement), then the others by
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
