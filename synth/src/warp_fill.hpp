// Warped fills of timed key poses (private to synth/src; docs/synthesis.md
// "Warped fills"): the chosen partial motion's clip, played over the whole
// time between two key poses, bent onto both by a displacement map (motion
// warping, Witkin & Popovic 1995) with its foot contacts held in place.
#pragma once

#include <cstddef>
#include <functional>
#include <vector>

#include "mocap/synth/synth.hpp"

namespace mocap::synth_detail {

/// Where the captured motion comes from and how it maps onto the output.
struct WarpSource {
  /// Frame f (0-based) of the clip, on the target skeleton, clip coordinates.
  std::function<SynthFrame(std::size_t)> frame;
  /// The clip's frame count (>= 2).
  std::size_t frame_count = 0;
  /// Output step i (0: key pose a) plays clip position start + i * step
  /// (fractional clip frames; clamped to the clip).
  double start = 0.0;
  double step = 1.0;
  /// Clip coordinates -> output coordinates.
  Placement placement;
};

/// The clip's frames at output steps 0..steps, placed (root linear, joints
/// slerp between captured frames).
std::vector<SynthFrame> captured_span(const SynthSkeleton& sk, const WarpSource& src,
                                      std::size_t steps);

/// The displacement map: `frames` (at least 2) bent so that the first is
/// `key_a` and the last `key_b`: the root moved by the offsets at both ends
/// blended linearly in time, every joint's local rotation turned by the
/// offset rotations at both ends slerped likewise.
void displace_onto_keys(std::vector<SynthFrame>& frames, const SynthFrame& key_a,
                        const SynthFrame& key_b);

/// Foot heights kept: every leg's ankle (in frames 1 .. n-2) at the height
/// it has in `captured`, plus the difference at the ends blended linearly
/// (so that the key poses' own heights are met), its horizontal position
/// and rotation as in `frames` (two-bone inverse kinematics): the joint
/// rotations' displacement would otherwise lower a swinging foot to the
/// ground or push a planted one into it.
void keep_foot_heights(const SynthSkeleton& sk, const RangeOfMotion* rom,
                       const std::vector<SynthFrame>& captured, std::vector<SynthFrame>& frames);

/// Foot contacts held: a leg whose lowest foot joint is on the ground in
/// `captured` (within 5 cm, slower than 0.5 m/s: the skating rule's
/// thresholds) keeps its ankle, in `frames`, where it is at the contact's
/// middle frame (at the first or last frame where the contact includes it,
/// those being the key poses), by two-bone inverse kinematics, eased in and
/// out over 3 frames. The first and last frames are not changed.
void hold_contacts(const SynthSkeleton& sk, const RangeOfMotion* rom,
                   const std::vector<SynthFrame>& captured, std::vector<SynthFrame>& frames,
                   double dt);

/// Margin above kSkatingHeightM to which lift_moving_feet raises a foot (m).
inline constexpr double kFootClearanceM = 0.005;

/// Swinging feet off the ground: in frames 1 .. n-2 of `frames` (dt s
/// apart), a leg with a foot joint that moves horizontally faster than
/// kSkatingSpeedMps (from the frame before or to the frame after) while
/// below kSkatingHeightM + kFootClearanceM above the ground has its ankle
/// raised by the largest such shortfall (two-bone inverse kinematics, the
/// ankle's world rotation kept, so no foot joint moves horizontally). A foot
/// that moves is off the ground, as in the capture; the displacement map and
/// the contacts' easing otherwise leave swinging toes skimming the floor.
/// The first and last frames are not changed; fewer than 3 frames, none.
void lift_moving_feet(const SynthSkeleton& sk, const RangeOfMotion* rom,
                      std::vector<SynthFrame>& frames, double dt);

/// The passes above in order (captured_span, displace_onto_keys,
/// keep_foot_heights, hold_contacts, lift_moving_feet): steps + 1 frames
/// from key_a to key_b (both included, exactly).
std::vector<SynthFrame> warp_fill(const SynthSkeleton& sk, const RangeOfMotion* rom,
                                  const WarpSource& src, const SynthFrame& key_a,
                                  const SynthFrame& key_b, std::size_t steps, double dt);

/// The placement (yaw, horizontal translation) that takes clip frame
/// `clip` onto the placed frame `placed` (root heading and horizontal root
/// position).
Placement placement_between(const SynthSkeleton& sk, const SynthFrame& clip,
                            const SynthFrame& placed);

/// The placement a candidate is judged and warped with (docs/synthesis.md
/// "Warped fills", choice among candidates), from its captured span
/// unplaced (captured_span with an identity placement): the span's first
/// frame turned to key_a's root heading and put on its horizontal root
/// position, then moved horizontally by half of what its last frame misses
/// of key_b's root position (the mismatch shared by both ends). Throws
/// std::invalid_argument for an empty span.
Placement balanced_placement(const SynthSkeleton& sk, const std::vector<SynthFrame>& unplaced,
                             const SynthFrame& key_a, const SynthFrame& key_b);

/// The warp's size, metres: the mean distance between the joints' world
/// positions in a captured span's first and last frames (`first`, `last`,
/// placed) and in key_a and key_b, over both ends and over the root joint
/// and the joints below it (the root's ancestors do not move with the
/// body); what the displacement map moves the joints by at the ends, 0 for
/// a span that meets both key poses.
double warp_size_m(const SynthSkeleton& sk, const SynthFrame& first, const SynthFrame& last,
                   const SynthFrame& key_a, const SynthFrame& key_b);

}  // namespace mocap::synth_detail
