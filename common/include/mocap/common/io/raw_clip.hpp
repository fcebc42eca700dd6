#pragma once
// RawClip: a capture clip exactly as read from a file (offline type).
//
// It keeps the file's own units, channel order and Euler degrees; nothing is
// converted. parse_bvh() (bvh.hpp) makes one from BVH text and write_bvh()
// writes it back; build_skeleton() (skeleton.hpp) turns it into the runtime
// Skeleton in metres, clip_motion_from_raw() (kinematics.hpp) into local and
// world poses, and clip_locals_from_raw() into local poses only.
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace mocap {

/// One BVH channel. Positions are in the file's length unit, rotations in degrees.
enum class Channel : std::uint8_t {
  Xposition,
  Yposition,
  Zposition,
  Xrotation,
  Yrotation,
  Zrotation
};

/// "Xposition", ... as written in BVH.
const char* channel_name(Channel c);
/// 0, 1, 2 for X, Y, Z.
int channel_axis(Channel c);
bool channel_is_rotation(Channel c);

struct RawJoint {
  std::string name;
  /// Index of the parent in RawClip::joints, -1 for a ROOT. Always < own index.
  int parent = -1;
  /// OFFSET in file units, relative to the parent (rest translation).
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  /// Channels in file order (0, 3 or 6 of them, any order, any subset).
  std::vector<Channel> channels;
  /// Column of channels[0] within a frame row; frame rows list joints' channels
  /// in joint (depth-first file) order.
  std::size_t first_column = 0;
  /// True when the joint has an End Site; then end_site is its OFFSET (file units).
  bool has_end_site = false;
  Eigen::Vector3d end_site = Eigen::Vector3d::Zero();
};

struct RawClip {
  /// Where the clip came from (file path, or a name for in-memory text); used in messages.
  std::string source;
  /// Joints in depth-first file order: parent index < child index. Several
  /// ROOTs are allowed (each one starts a new tree).
  std::vector<RawJoint> joints;
  /// Seconds between frames, > 0, as read from "Frame Time:".
  double frame_time_s = 0.0;
  std::size_t frame_count = 0;
  /// Total channels over all joints = values per frame row.
  std::size_t channel_count = 0;
  /// frame_count x channel_count, row-major, file units and degrees.
  std::vector<double> values;

  /// Row of frame f (f < frame_count, unchecked): channel_count values.
  const double* frame(std::size_t f) const { return values.data() + f * channel_count; }
  /// Index of the first joint named exactly `name` (case-sensitive), -1 if absent.
  int find_joint(const std::string& name) const;
};

}  // namespace mocap
