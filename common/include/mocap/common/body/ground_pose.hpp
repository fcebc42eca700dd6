#pragma once
// Placement on the ground: a turn about the vertical (+Y) and a horizontal
// move, the transforms under which the energies h and g do not change (they
// see only differences of positions, relative rotations, speeds and heights).
// Relative query placement (docs/queries.md "Placement") and synthesis put
// query frames and partial motions where they belong through these.
//
// A GroundPose maps body-frame coordinates to world ones:
//   p_world = R_y(heading) p_body + (x, 0, z).
// The body frame of a character pose is its root's ground pose
// (ground_pose_of): origin under the root (pelvis), +z forward (the facing
// direction: heading 0 faces world +z), +x to the character's left, +y up.
// Units: metres, radians.
#include <Eigen/Core>
#include <Eigen/Geometry>

#include "mocap/common/dynamics/dynamics.hpp"

namespace mocap {

struct GroundPose {
  /// Turn about +Y, radians (heading_rad's convention).
  double heading_rad = 0.0;
  /// World x and z of the body frame's origin, metres.
  Eigen::Vector2d position_m = Eigen::Vector2d::Zero();

  /// R_y(heading_rad).
  Eigen::Quaterniond rotation() const;
  /// A direction (velocity, angular velocity) from body to world: R v.
  Eigen::Vector3d turn(const Eigen::Vector3d& v) const;
  /// A point from body to world: R p + (x, 0, z).
  Eigen::Vector3d apply(const Eigen::Vector3d& p) const;
  /// The pose that maps world back to body.
  GroundPose inverse() const;
};

/// (a * b)(p) = a(b(p)): b first, then a.
GroundPose operator*(const GroundPose& a, const GroundPose& b);

/// The body frame of a pose whose root (pelvis) is at `root_position_m` with
/// world rotation `root_rotation`: heading heading_rad(root_rotation), origin
/// the root's x and z.
GroundPose ground_pose_of(const Eigen::Vector3d& root_position_m,
                          const Eigen::Quaterniond& root_rotation);

/// Moves a state by `g`: joint origins and COMs as points, rotations
/// (R' = R_y R), velocities, accelerations and angular rates as directions.
void place_state(const GroundPose& g, BodyState& state);

}  // namespace mocap
