// The stepping pass of the A* supplementation (private to synth/src): feet
// on the ground stay planted, a foot that must move is lifted and set down
// ahead (one foot in the air at a time where the transition allows), and
// each foot ends where S_G has it, so that a transition between moving clips
// steps instead of gliding. docs/synthesis.md "Stepping" describes the rule.
#pragma once

#include <cstddef>
#include <vector>

#include "foot_planting.hpp"
#include "mocap/synth/synth.hpp"

namespace mocap::synth_detail {

/// Tuning of the stepping pass (lengths in metres, times in seconds).
struct SteppingParams {
  /// A leg is planted at S_0 (at S_G) when its lowest foot joint is below
  /// this height above the ground and its ankle moves slower than
  /// plant_speed_mps horizontally over the captured step S_-1 -> S_0
  /// (S_G -> S_G+1).
  double plant_height_m = 0.10;
  double plant_speed_mps = 0.5;
  /// A planted foot closer than this to where S_G has it slides there
  /// over the last frames instead of stepping.
  double settle_m = 0.05;
  /// The leg reaches at most this fraction of its length (hip to knee to
  /// ankle): a planted foot further from the hip than that is lifted even
  /// while another foot is in the air.
  double reach_fraction = 0.98;
  /// A planted foot is lifted, when no other foot is in the air, once its
  /// horizontal distance from the hip exceeds this fraction of the reach.
  double release_fraction = 0.8;
  /// Longest swing; shorter when the transition must fit more swings.
  double swing_s = 0.40;
  /// Height the ankle is lifted by at a swing's middle, above the straight
  /// line between lift-off and landing.
  double lift_m = 0.07;
};

/// The stepping parameters for `gap`: the defaults, with the swing lasting
/// the gait's own swing (GapProblem::gait_swing_s) where it is known.
SteppingParams stepping_params(const GapProblem& gap);

/// Where a leg's ankle goes in one frame of a stepping plan: its position
/// (world, metres) and world rotation; `swinging`: the foot is in the air.
struct AnkleTarget {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  bool swinging = false;
};

/// The stepping plan over the inserted `frames` of `gap`: for frame i
/// (0-based, as `frames`) and leg l (leg_chains order), plan[i][l] is where
/// step_feet puts that leg's ankle (the rule below). Empty when the
/// skeleton has no legs or `frames` is empty.
std::vector<std::vector<AnkleTarget>> plan_steps(const GapProblem& gap,
                                                 const std::vector<SynthFrame>& frames,
                                                 const SteppingParams& params);

/// The median swing of a motion's legs, seconds: per leg, the runs of
/// frames in which none of its foot joints (ankle, toes) is on the ground
/// (lower than params.plant_height_m and moving slower than
/// params.plant_speed_mps horizontally), counting only runs with ground
/// contact on both sides; 0 when there is none (a motion that does not
/// step, or fewer than 3 frames). `frames` are consecutive frames
/// frame_time_s apart.
double gait_swing_s(const SynthSkeleton& sk, const std::vector<SynthFrame>& frames,
                    double frame_time_s, const SteppingParams& params = {});

/// Steps of the feet over the inserted `frames` of `gap` (changed in
/// place: the hip, knee and ankle rotations of each leg, by two-bone
/// inverse kinematics, then clamped to the gap's range of motion), leg by
/// leg (leg_chains), frame by frame:
/// - A leg is planted at S_0 (at S_G) when its lowest foot joint is below
///   plant_height_m and its ankle moves slower than plant_speed_mps over
///   the captured step beside it; else it is in the air there.
/// - A planted foot stays where it is (the last few centimetres onto S_G's
///   foot when it is within settle_m of it). It is lifted when the leg
///   cannot reach it (reach_fraction of the leg's length, and no nearer
///   than the pose's own foot), or, while no other foot is in the air, when
///   it lies further from the hip horizontally than release_fraction of
///   the reach and 10 cm further than the pose's own foot; and for its
///   final swing onto S_G's foot once the frames left are fewer than a
///   swing for each leg still away from S_G (forced in the last two).
/// - A swing lasts swing_s (stepping_params: the gait's own swing where
///   known; at most an equal share of the transition per
///   leg, at least 3 frames; half that for a foot already in the air at
///   S_0), eases from lift-off to landing (smoothstep), is lifted by lift_m
///   at its middle, and slerps the ankle's rotation. A final swing (or one
///   that would land within half a swing of S_G) lands on S_G's foot; any
///   other below the hip, ahead by half the hip's travel over the swing,
///   with the lowest foot joint 2 cm above the ground.
/// Nothing changes when the skeleton has no legs. The gap must have been
/// checked (check_gap).
void step_feet(const GapProblem& gap, std::vector<SynthFrame>& frames,
               const SteppingParams& params = {});

}  // namespace mocap::synth_detail
