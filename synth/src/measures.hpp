// Per-step and per-frame pieces of a transition's measures (private to
// synth/src): foot sliding, range violations and joint angular speed, summed
// by measure_transition (measures.cpp) and checked step by step by the A*
// search and the refinement.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "mocap/synth/synth.hpp"

namespace mocap::synth_detail {

/// Lowest contact point of foot joint j in world pose `w`, metres: the
/// joint's origin, or its bone tip when the model lets the tip touch and it
/// is lower.
Eigen::Vector3d contact_point(const SynthSkeleton& sk, const WorldPose& w, int j);

/// Horizontal displacement (m) of the foot joints' contact points over the
/// step a -> b, counting a joint when both ends are within contact height of
/// the ground (EnergyParams::contact_height_m), however fast it moves; dt in
/// seconds (unused: kept for the step's signature).
double step_foot_sliding(const SynthSkeleton& sk, const WorldPose& a, const WorldPose& b,
                         double dt);

/// The foot-skating test of one step (docs/synthesis.md "Measures"): foot
/// and toe joint origins below kSkatingHeightM above the ground in both
/// frames while moving horizontally faster than kSkatingSpeedMps.
/// (kSkatingHeightM, kSkatingSpeedMps: mocap/common/motion/skeleton_motion.hpp)
struct StepSkating {
  std::size_t joints = 0;  // joints that skate in this step
  double speed_sum = 0.0;  // their horizontal speeds summed, m/s
  bool airborne = false;   // every foot joint at or above kSkatingHeightM in both frames
};
StepSkating step_skating(const SynthSkeleton& sk, const WorldPose& a, const WorldPose& b,
                         double dt);

/// Skating over consecutive steps: steps that skate, steps, joints and their
/// speeds, and the contact-based sliding (step_foot_sliding) summed.
struct SkatingTally {
  std::size_t skating_steps = 0, steps = 0, joints = 0, airborne_steps = 0;
  double speed_sum = 0.0, sliding_m = 0.0;
  void add(const SynthSkeleton& sk, const WorldPose& a, const WorldPose& b, double dt);
  double ratio() const { return steps ? static_cast<double>(skating_steps) / steps : 0.0; }
  double mean_speed() const { return joints ? speed_sum / static_cast<double>(joints) : 0.0; }
  double airborne_ratio() const {
    return steps ? static_cast<double>(airborne_steps) / static_cast<double>(steps) : 0.0;
  }
};

/// Steps of S_0 -> frames... -> S_G in which a foot skates (step_skating).
std::size_t skating_steps(const GapProblem& gap, const std::vector<SynthFrame>& frames);

/// Joints of frame `f` outside the gap's range of motion (0 without a range).
std::size_t frame_range_violations(const GapProblem& gap, const SynthFrame& f);
/// The same summed over `frames`.
std::size_t count_range_violations(const GapProblem& gap, const std::vector<SynthFrame>& frames);

/// Largest local joint angular speed of the step a -> b (the dummies above
/// the root excepted), rad/s.
double step_peak_angular_speed(const GapProblem& gap, const SynthFrame& a, const SynthFrame& b);
/// That peak over S_0 -> frames... -> S_G (measure_transition's).
double peak_angular_speed(const GapProblem& gap, const std::vector<SynthFrame>& frames);

}  // namespace mocap::synth_detail
