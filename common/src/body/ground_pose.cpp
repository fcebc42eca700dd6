// Ground placement (ground_pose.hpp).
#include "mocap/common/body/ground_pose.hpp"

#include <cmath>

namespace mocap {

Eigen::Quaterniond GroundPose::rotation() const {
  return Eigen::Quaterniond(Eigen::AngleAxisd(heading_rad, Eigen::Vector3d::UnitY()));
}

Eigen::Vector3d GroundPose::turn(const Eigen::Vector3d& v) const {
  const double c = std::cos(heading_rad), s = std::sin(heading_rad);
  return {c * v.x() + s * v.z(), v.y(), -s * v.x() + c * v.z()};
}

Eigen::Vector3d GroundPose::apply(const Eigen::Vector3d& p) const {
  Eigen::Vector3d out = turn(p);
  out.x() += position_m.x();
  out.z() += position_m.y();
  return out;
}

GroundPose GroundPose::inverse() const {
  GroundPose inv;
  inv.heading_rad = -heading_rad;
  const Eigen::Vector3d back = inv.turn(Eigen::Vector3d(position_m.x(), 0.0, position_m.y()));
  inv.position_m = Eigen::Vector2d(-back.x(), -back.z());
  return inv;
}

GroundPose operator*(const GroundPose& a, const GroundPose& b) {
  GroundPose out;
  out.heading_rad = a.heading_rad + b.heading_rad;
  const Eigen::Vector3d o = a.apply(Eigen::Vector3d(b.position_m.x(), 0.0, b.position_m.y()));
  out.position_m = Eigen::Vector2d(o.x(), o.z());
  return out;
}

GroundPose ground_pose_of(const Eigen::Vector3d& root_position_m,
                          const Eigen::Quaterniond& root_rotation) {
  GroundPose g;
  g.heading_rad = heading_rad(root_rotation);
  g.position_m = Eigen::Vector2d(root_position_m.x(), root_position_m.z());
  return g;
}

void place_state(const GroundPose& g, BodyState& state) {
  const Eigen::Quaterniond r = g.rotation();
  for (auto& p : state.joint_positions_m) p = g.apply(p);
  for (auto& c : state.coms_m) c = g.apply(c);
  for (auto& q : state.rotations) q = (r * q).normalized();
  for (auto* vs : {&state.com_velocities_mps, &state.com_accelerations_mps2,
                   &state.angular_velocities_radps, &state.angular_accelerations_radps2})
    for (auto& v : *vs) v = g.turn(v);
}

}  // namespace mocap
