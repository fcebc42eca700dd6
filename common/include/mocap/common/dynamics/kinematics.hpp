#pragma once
// Local poses and forward kinematics (metres, Y up, unit quaternions).
//
// A clip's motion is stored as flat per-frame arrays (frame-major:
// element [f * J + j]). Forward kinematics walks joints in index order (parents
// first), so one pass per frame suffices; clip_forward_kinematics runs frames
// in parallel with TBB.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <span>
#include <vector>

#include "mocap/common/body/skeleton.hpp"
#include "mocap/common/io/raw_clip.hpp"

namespace mocap {

/// Quaternion of a rotation given as Euler angles in degrees, applied in the
/// order listed (intrinsic): axes {2,0,1} with degrees {a,b,c} = Rz(a)*Rx(b)*Ry(c).
Eigen::Quaterniond euler_to_quaternion(std::span<const std::uint8_t> axes,
                                       std::span<const double> degrees);
/// Inverse of euler_to_quaternion for 3 distinct axes (Tait-Bryan), degrees.
Eigen::Vector3d quaternion_to_euler(const Eigen::Quaterniond& q,
                                    const std::array<std::uint8_t, 3>& axes);

/// One frame's local transforms.
struct LocalPose {
  std::vector<Eigen::Vector3d> translations_m;  // per joint, relative to parent
  std::vector<Eigen::Quaterniond> rotations;    // per joint, relative to parent
};

/// World transforms of one frame.
struct WorldPose {
  std::vector<Eigen::Vector3d> positions_m;   // joint origins
  std::vector<Eigen::Quaterniond> rotations;  // joint frames (world from local)
};

/// Local pose of one frame row (file units and degrees) for `skel`.
void local_pose_from_row(const Skeleton& skel, const double* row, LocalPose& out);
/// World pose of a local pose.
void forward_kinematics(const Skeleton& skel, const LocalPose& local, WorldPose& out);
/// World positions of End Sites (one per joint; joints without an End Site get
/// their own origin).
void end_site_positions(const Skeleton& skel, const WorldPose& world,
                        std::vector<Eigen::Vector3d>& out);

/// A clip's whole motion, local and world, flat and frame-major. The world
/// arrays are empty when it holds local poses only (clip_locals_from_raw);
/// position() and rotation() then must not be called.
struct ClipMotion {
  Skeleton skeleton;
  double frame_time_s = 0.0;
  std::size_t frame_count = 0;
  std::vector<Eigen::Vector3d> local_translations_m;  // [f * J + j]
  std::vector<Eigen::Quaterniond> local_rotations;    // [f * J + j]
  std::vector<Eigen::Vector3d> world_positions_m;     // [f * J + j]
  std::vector<Eigen::Quaterniond> world_rotations;    // [f * J + j]

  std::size_t joint_count() const { return skeleton.joint_count(); }
  const Eigen::Vector3d& position(std::size_t f, std::size_t j) const {
    return world_positions_m[f * joint_count() + j];
  }
  const Eigen::Quaterniond& rotation(std::size_t f, std::size_t j) const {
    return world_rotations[f * joint_count() + j];
  }
};

/// Converts a raw clip (with `scale_m` metres per file unit) and runs forward
/// kinematics on all frames (TBB-parallel over frames when it pays).
ClipMotion clip_motion_from_raw(const RawClip& clip, double scale_m);

/// clip_motion_from_raw without the forward kinematics: the skeleton, frame
/// time and local poses (the same values); world_positions_m and
/// world_rotations are left empty. For readers that pose the frames on
/// another skeleton (the search's query frames).
ClipMotion clip_locals_from_raw(const RawClip& clip, double scale_m);

}  // namespace mocap
