/// @file rotations.h
/// @brief Rotations shared by the searches over orientations (reference_length, orient): a spread of
/// SO(3), small turns, and frames compared up to the symmetries of the cube.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace polyhex {

/// Rotation number i of a spread over SO(3): a Halton sequence (bases 2, 3, 5) mapped by Shoemake's
/// uniform quaternion. Deterministic; any prefix covers SO(3) about evenly.
Eigen::Matrix3d spread_rotation(unsigned i);

/// exp([w]x) R0: R0 turned by the rotation vector w (axis w / |w|, angle |w| rad).
Eigen::Matrix3d turn(const Eigen::Vector3d& w, const Eigen::Matrix3d& R0);

/// The frame R up to the 24 rotations of the cube (proper signed permutations P): the P R nearest to
/// the identity (largest trace; ties to the first in a fixed order). Frames whose rows span the same
/// axes give the same result, so a PolyCube built in either is the same PolyCube.
Eigen::Matrix3d canonical_frame(const Eigen::Matrix3d& R);

/// Angle in degrees between two frames up to the cube's rotations: the smallest rotation angle of
/// P A Bᵀ over the 24 P.
double frame_distance_degrees(const Eigen::Matrix3d& A, const Eigen::Matrix3d& B);

}  // namespace polyhex
