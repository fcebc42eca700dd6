// Foot planting for the A* proposals (private to synth/src): the legs of a
// skeleton and two-bone inverse kinematics that keeps a foot in place.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "mocap/synth/synth.hpp"

namespace mocap::synth_detail {

/// A leg: hip, knee and ankle joints (the ankle a foot joint whose parent is
/// not one, neither the knee nor the hip in the root chain) and the foot
/// joints it carries (the ankle, the toes).
struct LegChain {
  int hip = -1, knee = -1, ankle = -1;
  std::vector<int> feet;
};

/// The skeleton's legs, in the order of SynthSkeleton::foot_joints.
std::vector<LegChain> leg_chains(const SynthSkeleton& sk);

/// The last steps of plant_leg, once the knee is bent: the hip turns the
/// hip-ankle line onto `target` (world, metres), then the ankle takes the
/// world rotation `target_rotation`. `w` must be `f`'s world pose on entry
/// (it is scratch after).
void aim_leg(const SynthSkeleton& sk, const LegChain& leg, const Eigen::Vector3d& target,
             const Eigen::Quaterniond& target_rotation, SynthFrame& f, WorldPose& w);

/// Turns the leg so that its ankle lies at `target` (world, metres) with the
/// world rotation `target_rotation` (two-bone inverse kinematics: the knee
/// angle gives the hip-ankle distance, clamped to the reachable range; the
/// hip turns the hip-ankle line onto the target; the ankle takes the
/// rotation), each of the three joints then clamped to `range` (none: not
/// clamped). `w` is scratch. False, `f` partly changed, when the leg is
/// straight (no knee plane) or degenerate (a bone under 1 micrometre).
bool plant_leg(const SynthSkeleton& sk, const RangeOfMotion* range, const LegChain& leg,
               const Eigen::Vector3d& target, const Eigen::Quaterniond& target_rotation,
               SynthFrame& f, WorldPose& w);

}  // namespace mocap::synth_detail
