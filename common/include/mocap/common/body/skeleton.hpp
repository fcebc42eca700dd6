#pragma once
// Skeleton: the runtime description of a joint tree (immutable after build).
//
// Flat arrays indexed by joint, parent index < child index, metres. Each
// joint's local transform is  T(translation) * R(rotation)  where
//  - translation = the position channels when present (they REPLACE the
//    OFFSET: Bandai Namco's Hips OFFSET is a rest translation that the channels
//    already contain; missing axes take the OFFSET's component), else OFFSET;
//  - rotation = product of the joint's rotation channels in file order,
//    intrinsic: "Zrotation Xrotation Yrotation" gives Rz * Rx * Ry.
// World: X_j = X_parent(j) * T_j * R_j.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "mocap/common/io/raw_clip.hpp"
#include "mocap/common/io/units.hpp"

namespace mocap {

/// Where a joint's channels are in a frame row (column indices, -1 = absent).
struct JointChannelMap {
  /// Columns of X/Y/Z position channels (by axis, not by file order).
  std::array<int, 3> position_column{-1, -1, -1};
  /// Rotation channels in file order: column and axis (0=X, 1=Y, 2=Z).
  std::array<int, 3> rotation_column{-1, -1, -1};
  std::array<std::uint8_t, 3> rotation_axis{0, 0, 0};
  std::uint8_t rotation_count = 0;
  bool has_position() const {
    return position_column[0] >= 0 || position_column[1] >= 0 || position_column[2] >= 0;
  }
};

struct Skeleton {
  std::vector<std::string> names;
  /// Parent joint index, -1 for roots; parents[j] < j.
  std::vector<int> parents;
  /// Rest translation from the parent (OFFSET), metres.
  std::vector<Eigen::Vector3d> offsets_m;
  /// End Site offset in the joint's frame, metres (zero when has_end_site is 0).
  std::vector<Eigen::Vector3d> end_sites_m;
  std::vector<std::uint8_t> has_end_site;
  std::vector<JointChannelMap> channels;
  /// Multiplier on each joint's local translation (OFFSET or position channels),
  /// set by a character's length scales (body.hpp: apply_length_scales). Empty
  /// means 1 for every joint. Roots are never scaled.
  std::vector<double> translation_scales;
  /// Values per frame row.
  std::size_t channel_count = 0;
  /// Metres per file unit used to build it.
  double unit_scale_m = 1.0;

  std::size_t joint_count() const { return names.size(); }
  /// Index by exact name, -1 if absent.
  int find(const std::string& name) const;
  /// Children of joint j, in index order.
  std::vector<int> children(int j) const;
  /// 64-bit FNV-1a over names, parents, offsets (rounded to 1e-6 m), channel
  /// layouts and translation scales (when set): equal ids mean interchangeable
  /// skeletons.
  std::uint64_t id() const;
};

/// Builds the runtime skeleton; `scale_m` = metres per file unit.
Skeleton build_skeleton(const RawClip& clip, double scale_m);

}  // namespace mocap
