#pragma once
// Motions on a clip's skeleton: the frames synthesis, export and the 3D
// player work with. A SynthSkeleton is the view of an index skeleton that
// these need (fixed translations, channels, the dynamics model, the pelvis,
// the feet, the range of motion); a SynthFrame is one pose on it (the
// pelvis's world position and every joint's local rotation). Frames are read
// from the index (clip_frame), posed (synth_world_pose), placed rigidly
// about the vertical (place_frame) and written as BVH (motion_bvh_clip).
//
// Units: metres, seconds, radians (degrees where a name says _deg).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "mocap/common/body/body.hpp"
#include "mocap/common/body/joint_classes.hpp"
#include "mocap/common/body/skeleton.hpp"
#include "mocap/common/dynamics/dynamics.hpp"
#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/common/io/raw_clip.hpp"
#include "mocap/common/motion/clip_source.hpp"

namespace mocap {

/// One frame of a motion on a SynthSkeleton: the world position of the root
/// joint (the pelvis, metres) and every joint's local rotation (unit, from its
/// parent). Translations of the other joints are the skeleton's (fixed).
struct SynthFrame {
  Eigen::Vector3d root_position_m = Eigen::Vector3d::Zero();
  std::vector<Eigen::Quaterniond> local_rotations;
};

/// Range of motion: per joint, per rotation channel (the joint's channel
/// order), degrees. has_range[j] = 0: not limited (the root joint and its
/// ancestors; joints without rotation channels).
struct RangeOfMotion {
  std::vector<std::array<double, 3>> min_deg;
  std::vector<std::array<double, 3>> max_deg;
  std::vector<std::uint8_t> has_range;
};

/// The target skeleton with everything synthesis needs (immutable).
struct SynthSkeleton {
  /// The skeleton's number in the index, or in the ClipSource it was made
  /// from (a collection's numbers are one index's: clip_source.hpp).
  std::uint32_t index_skeleton = 0;
  Skeleton skeleton;
  /// Per joint "Xposition ... Yrotation" as in the source files.
  std::vector<std::string> channels;
  DynamicsModel model;
  /// The joint whose world position SynthFrame::root_position_m is (pelvis).
  int root_joint = 0;
  /// Fixed local translation of every joint, metres (the root joint's is
  /// replaced per frame by its world position).
  std::vector<Eigen::Vector3d> local_translations_m;
  /// 1 for the root joint and its ancestors (orientation free, not limited).
  std::vector<std::uint8_t> is_root_chain;
  /// Foot and toe joints (segments whose contact counts as foot contact).
  std::vector<int> foot_joints;
  /// Segment class / side per joint (joint_classes.hpp classify_joints).
  std::vector<std::pair<SegmentClass, Side>> classes;

  std::size_t joint_count() const { return skeleton.joint_count(); }
};

/// Builds the synthesis view of index skeleton k. Translations of joints with
/// position channels come from frame 0 of clip `reference_clip` (a clip of
/// that skeleton); the others are the skeleton's OFFSETs.
SynthSkeleton make_synth_skeleton(const Index& index, std::uint32_t skeleton,
                                  std::size_t reference_clip);
/// The same for skeleton k and a reference clip of a clip source (its numbers).
SynthSkeleton make_synth_skeleton(const ClipSource& clips, std::uint32_t skeleton,
                                  std::size_t reference_clip);

/// Union of the clips' rotation_channel_min/max_deg (clips of the skeleton:
/// std::invalid_argument otherwise). With a ClipSource, clip and skeleton
/// numbers are the source's; a collection's clips are read from their shards.
RangeOfMotion range_of_motion(const Index& index, const SynthSkeleton& sk,
                              const std::vector<std::size_t>& clips);
RangeOfMotion range_of_motion(const ClipSource& source, const SynthSkeleton& sk,
                              const std::vector<std::size_t>& clips);

/// Frame f (0-based, within the clip) of an index clip
/// (std::invalid_argument for f out of range).
SynthFrame clip_frame(const Index& index, std::size_t clip, std::size_t f);
/// The same for clip `clip` of a clip source (read from its own index).
SynthFrame clip_frame(const ClipSource& clips, std::size_t clip, std::size_t f);

/// World pose of a frame (joint origins, world rotations), reusing `out`.
void synth_world_pose(const SynthSkeleton& sk, const SynthFrame& frame, WorldPose& out);

/// True when every channel of joint j's rotation is inside the range (either
/// Euler solution, angles modulo 360, `slack_deg` tolerance).
bool within_range(const SynthSkeleton& sk, const RangeOfMotion& rom, int j,
                  const Eigen::Quaterniond& local, double slack_deg = 0.5);
/// The rotation with its Euler angles clamped channel-wise to the range (the
/// rotation itself when within range).
Eigen::Quaterniond clamp_to_range(const SynthSkeleton& sk, const RangeOfMotion& rom, int j,
                                  const Eigen::Quaterniond& local);

/// Rigid placement about the vertical: p' = R_y(yaw) p + t (t horizontal).
struct Placement {
  double yaw_rad = 0.0;
  Eigen::Vector3d translation_m = Eigen::Vector3d::Zero();
};
/// The frame moved rigidly (root position and the root chain's top rotation).
SynthFrame place_frame(const SynthSkeleton& sk, const SynthFrame& frame, const Placement& p);
/// Heading of the root joint's world rotation (dynamics.hpp heading_rad), radians.
double root_heading(const SynthSkeleton& sk, const SynthFrame& frame);

/// The foot contact rule of the measures' skating test and of the player's
/// contact timeline (docs/synthesis.md "Measures"): a foot or toe joint
/// origin below kSkatingHeightM above the ground is on it; moving
/// horizontally faster than kSkatingSpeedMps there, it skates.
inline constexpr double kSkatingHeightM = 0.05;
inline constexpr double kSkatingSpeedMps = 0.5;

/// The horizontal speed (m/s), over a step of dt seconds, of a foot joint
/// origin that is below kSkatingHeightM above the ground (height ground_m)
/// in both frames `a` and `b`; 0 when it is not. It skates when this exceeds
/// kSkatingSpeedMps.
inline double low_foot_speed(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double dt,
                             double ground_m) {
  if (a.y() - ground_m >= kSkatingHeightM || b.y() - ground_m >= kSkatingHeightM) return 0.0;
  return std::hypot(b.x() - a.x(), b.z() - a.z()) / dt;
}

/// The joints whose contact counts as foot contact: foot and toe segments
/// (classify_joints) that carry mass in `model` (SynthSkeleton::foot_joints).
std::vector<int> foot_joints(const std::vector<std::pair<SegmentClass, Side>>& classes,
                             const DynamicsModel& model);

/// The BVH clip of `frames` on `sk` (a synthesised motion's: write_motion_bvh,
/// mocap/synth/synth_job.hpp; or a clip's own: export.hpp): frame_count = frames.size(), the
/// frame time given, `source` for messages; write_bvh gives its text.
/// Rotation channels hold each joint's local rotation as Euler angles in
/// the channels' order (a joint with fewer than 3 keeps the angles of its
/// own axes: exact for the rotations they can express). Position channels
/// hold `sk`'s fixed translations and the root joint's from
/// SynthFrame::root_position_m, or, when `local_translations_m` is given
/// (frames.size() x joints, [f * J + j], metres; std::invalid_argument for
/// another size), every joint's translation of that frame (a clip whose
/// joints above the pelvis move, as Bandai Namco's joint_Root in a few takes).
RawClip motion_bvh_clip(const SynthSkeleton& sk, const std::vector<SynthFrame>& frames,
                        double frame_time_s, const std::string& source,
                        std::span<const Eigen::Vector3d> local_translations_m = {});

}  // namespace mocap
