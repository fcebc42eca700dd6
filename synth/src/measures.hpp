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
/// step a -> b, counting a joint only when both ends are within contact
/// height of the ground and it moves no faster than the contact speed
/// (EnergyParams); dt in seconds.
double step_foot_sliding(const SynthSkeleton& sk, const WorldPose& a, const WorldPose& b,
                         double dt);

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
