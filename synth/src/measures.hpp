// Per-step and per-frame pieces of a transition's measures (private to
// synth/src): foot sliding, range violations and joint angular speed, summed
// by measure_transition (measures.cpp) and checked step by step by the A*
// search and the refinement.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <string>
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
  double speed_sum = 0.0, sliding_m = 0.0, slow_sliding_m = 0.0;
  void add(const SynthSkeleton& sk, const WorldPose& a, const WorldPose& b, double dt);
  double ratio() const { return steps ? static_cast<double>(skating_steps) / steps : 0.0; }
  double mean_speed() const { return joints ? speed_sum / static_cast<double>(joints) : 0.0; }
  double airborne_ratio() const {
    return steps ? static_cast<double>(airborne_steps) / static_cast<double>(steps) : 0.0;
  }
};

/// The contact-based sliding of one step (step_foot_sliding), metres, and
/// the part of it at contact speed: joints whose contact point moves
/// horizontally at most EnergyParams::contact_speed_mps (the energy model's
/// contacts slide that slowly; the rest is a foot swinging low).
struct StepSliding {
  double total_m = 0.0, slow_m = 0.0;
};
StepSliding step_foot_sliding_split(const SynthSkeleton& sk, const WorldPose& a, const WorldPose& b,
                                    double dt);

/// Steps of S_0 -> frames... -> S_G in which a foot skates (step_skating).
std::size_t skating_steps(const GapProblem& gap, const std::vector<SynthFrame>& frames);

/// The (frame, joint) pairs of `frames` outside the gap's range of motion,
/// named (RangeViolation; empty without a range): the pairs
/// frame_range_violations counts, in frame then joint order.
std::vector<RangeViolation> range_violation_list(const GapProblem& gap,
                                                 const std::vector<SynthFrame>& frames);

/// A foot segment's ground contact along a motion as the energy model sees
/// it (newton_euler.hpp: its lower contact point within contact_height_m of
/// the ground and moving slower than contact_speed_mps). The foot's contact
/// point is its joint origin (the ankle: the heel's contact), the toes'
/// their origin (the ball) or their bone tip (the toe tip), the lower.
struct FootContactRow {
  int joint = -1;
  std::string name;    // the skeleton's joint name
  std::string points;  // "joint origin" or "joint origin or bone tip"
  /// Per frame: 'c' in contact, 's' within contact height but faster than
  /// contact_speed_mps (sliding: no support), '.' higher.
  std::string states;
  /// The lowest height of its contact point above the ground over the
  /// frames, metres (above contact_height_m: never a contact).
  double lowest_m = 0.0;
  std::size_t contact_frames() const;
};
/// One row per SynthSkeleton::foot_joints entry, in that order; none for
/// fewer than two frames (rates need a neighbour). frame_time_s > 0.
std::vector<FootContactRow> foot_contact_rows(const SynthSkeleton& sk,
                                              const std::vector<SynthFrame>& frames,
                                              double frame_time_s);

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
