// Legs and two-bone inverse kinematics for foot planting (foot_planting.hpp).
#include "foot_planting.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace mocap::synth_detail {

std::vector<LegChain> leg_chains(const SynthSkeleton& sk) {
  std::vector<LegChain> legs;
  const auto is_foot = [&](int j) {
    return std::find(sk.foot_joints.begin(), sk.foot_joints.end(), j) != sk.foot_joints.end();
  };
  for (int j : sk.foot_joints) {
    const int knee = sk.skeleton.parents[static_cast<std::size_t>(j)];
    if (knee < 0 || is_foot(knee)) continue;
    const int hip = sk.skeleton.parents[static_cast<std::size_t>(knee)];
    if (hip < 0 || sk.is_root_chain[static_cast<std::size_t>(hip)] ||
        sk.is_root_chain[static_cast<std::size_t>(knee)])
      continue;
    LegChain leg{hip, knee, j, {}};
    for (int f : sk.foot_joints)
      for (int a = f; a >= 0; a = sk.skeleton.parents[static_cast<std::size_t>(a)])
        if (a == j) {
          leg.feet.push_back(f);
          break;
        }
    legs.push_back(std::move(leg));
  }
  return legs;
}

void aim_leg(const SynthSkeleton& sk, const LegChain& leg, const Eigen::Vector3d& target,
             const Eigen::Quaterniond& target_rotation, SynthFrame& f, WorldPose& w) {
  const auto hip = static_cast<std::size_t>(leg.hip), knee = static_cast<std::size_t>(leg.knee),
             ankle = static_cast<std::size_t>(leg.ankle);
  const Eigen::Quaterniond rh = Eigen::Quaterniond::FromTwoVectors(
      w.positions_m[ankle] - w.positions_m[hip], target - w.positions_m[hip]);
  f.local_rotations[hip] =
      (f.local_rotations[hip] * (w.rotations[hip].conjugate() * rh * w.rotations[hip]))
          .normalized();
  synth_world_pose(sk, f, w);
  f.local_rotations[ankle] = (w.rotations[knee].conjugate() * target_rotation).normalized();
}

bool plant_leg(const SynthSkeleton& sk, const RangeOfMotion* range, const LegChain& leg,
               const Eigen::Vector3d& target, const Eigen::Quaterniond& target_rotation,
               SynthFrame& f, WorldPose& w) {
  const auto hip = static_cast<std::size_t>(leg.hip), knee = static_cast<std::size_t>(leg.knee),
             ankle = static_cast<std::size_t>(leg.ankle);
  synth_world_pose(sk, f, w);
  const Eigen::Vector3d a = w.positions_m[hip], b = w.positions_m[knee], c = w.positions_m[ankle];
  const double lab = (b - a).norm(), lcb = (c - b).norm();
  if (lab < 1e-6 || lcb < 1e-6) return false;
  const Eigen::Vector3d bend = (a - b).cross(c - b);
  if (bend.norm() < 1e-9 * lab * lcb) return false;
  const double lat = std::clamp((target - a).norm(), std::abs(lab - lcb) + 1e-4, lab + lcb - 1e-4);
  const double angle0 =
      std::acos(std::clamp((a - b).normalized().dot((c - b).normalized()), -1.0, 1.0));
  const double angle1 =
      std::acos(std::clamp((lab * lab + lcb * lcb - lat * lat) / (2.0 * lab * lcb), -1.0, 1.0));
  const Eigen::Quaterniond rk(Eigen::AngleAxisd(angle1 - angle0, bend.normalized()));
  f.local_rotations[knee] =
      (f.local_rotations[knee] * (w.rotations[knee].conjugate() * rk * w.rotations[knee]))
          .normalized();
  synth_world_pose(sk, f, w);
  aim_leg(sk, leg, target, target_rotation, f, w);
  if (range)
    for (std::size_t j : {hip, knee, ankle})
      f.local_rotations[j] = clamp_to_range(sk, *range, static_cast<int>(j), f.local_rotations[j]);
  return true;
}

}  // namespace mocap::synth_detail
