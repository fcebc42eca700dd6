// BVH export layout: a clip rearranged into the form that Blender and
// three.js load identically (to_export_layout, bvh.hpp).
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "io/bvh_text.hpp"
#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/util/error.hpp"

namespace mocap {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// A joint's translation in its parent's frame at one frame row: position
// channels replace the OFFSET's components (skeleton.hpp), file units.
Eigen::Vector3d joint_translation(const RawJoint& j, const double* row) {
  Eigen::Vector3d t = j.offset;
  for (std::size_t c = 0; c < j.channels.size(); ++c)
    if (!channel_is_rotation(j.channels[c]))
      t[channel_axis(j.channels[c])] = row[j.first_column + c];
  return t;
}

Eigen::Quaterniond joint_rotation(const RawJoint& j, const double* row) {
  std::array<std::uint8_t, 3> axes{};
  std::array<double, 3> degrees{};
  std::size_t k = 0;
  for (std::size_t c = 0; c < j.channels.size() && k < 3; ++c)
    if (channel_is_rotation(j.channels[c])) {
      axes[k] = static_cast<std::uint8_t>(channel_axis(j.channels[c]));
      degrees[k] = row[j.first_column + c];
      ++k;
    }
  return euler_to_quaternion(std::span<const std::uint8_t>(axes.data(), k),
                             std::span<const double>(degrees.data(), k));
}

// Which non-root joints have position channels that vary by more than tolerance.
std::vector<std::uint8_t> varying_positions(const RawClip& clip, double tolerance) {
  const std::size_t n = clip.joints.size();
  const std::size_t frames = clip.frame_count;
  std::vector<std::uint8_t> varies(n, 0);
  for (std::size_t j = 0; j < n; ++j) {
    const RawJoint& rj = clip.joints[j];
    if (rj.parent < 0) continue;
    for (std::size_t c = 0; c < rj.channels.size(); ++c) {
      if (channel_is_rotation(rj.channels[c])) continue;
      double lo = kInf, hi = -kInf;
      for (std::size_t f = 0; f < frames; ++f) {
        const double v = clip.frame(f)[rj.first_column + c];
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
      if (frames > 0 && hi - lo > tolerance) varies[j] = 1;
    }
  }
  return varies;
}

// A varying joint can be "lifted": when the path from its root down to its
// parent is a bare chain (each joint there has exactly this one child and no
// End Site; the joints between have constant positions), moving the root by
//   d(f) = R_world(parent)(f) * (t(f) - t(0))
// and giving the joint the constant translation t(0) keeps the world
// positions of the joint and its whole subtree; only the chain above moves
// with the root. This is Bandai Namco's static joint_Root above a moving Hips.
// Returns per root the lifted joint, -1 none; throws for a varying joint
// that cannot be lifted.
std::vector<int> lifted_joints(const RawClip& clip, const std::vector<std::uint8_t>& varies,
                               double tolerance) {
  const std::size_t n = clip.joints.size();
  std::vector<std::size_t> child_count(n, 0);
  for (const RawJoint& j : clip.joints)
    if (j.parent >= 0) ++child_count[static_cast<std::size_t>(j.parent)];
  std::vector<int> lifted(n, -1);
  for (std::size_t j = 0; j < n; ++j) {
    if (!varies[j]) continue;
    const RawJoint& rj = clip.joints[j];
    bool chain = true;
    int root = rj.parent;
    for (int a = rj.parent; a >= 0; a = clip.joints[static_cast<std::size_t>(a)].parent) {
      const auto ai = static_cast<std::size_t>(a);
      if (child_count[ai] != 1 || clip.joints[ai].has_end_site ||
          (varies[ai] && clip.joints[ai].parent >= 0))
        chain = false;
      root = a;
    }
    const auto ri = static_cast<std::size_t>(root);
    if (!chain || lifted[ri] >= 0)
      throw InputError(clip.source, 0,
                       "joint '" + rj.name + "' has position channels that vary by more than " +
                           std::to_string(tolerance) +
                           " file units; expected constant positions on non-root joints");
    lifted[ri] = static_cast<int>(j);
  }
  return lifted;
}

// A joint's output rotation channels and their source columns (-1: constant
// zero angle): its own in their order, then the missing axes; ZXY zeros for
// a joint without any.
void export_rotations(const RawClip& clip, const RawJoint& rj, std::vector<Channel>& rotations,
                      std::vector<int>& rotation_columns) {
  std::array<bool, 3> have_axis{false, false, false};
  for (std::size_t c = 0; c < rj.channels.size(); ++c) {
    const Channel ch = rj.channels[c];
    if (!channel_is_rotation(ch)) continue;
    const int axis = channel_axis(ch);
    if (have_axis[static_cast<std::size_t>(axis)])
      throw InputError(
          clip.source, 0,
          "joint '" + rj.name + "' repeats the rotation channel " + std::string(channel_name(ch)));
    have_axis[static_cast<std::size_t>(axis)] = true;
    rotations.push_back(ch);
    rotation_columns.push_back(static_cast<int>(rj.first_column + c));
  }
  if (rotations.empty()) {
    rotations = {Channel::Zrotation, Channel::Xrotation, Channel::Yrotation};
    rotation_columns = {-1, -1, -1};
  } else {
    // Zero-angle rotations are the identity wherever they go: append them.
    constexpr Channel kAxisRotation[3] = {Channel::Xrotation, Channel::Yrotation,
                                          Channel::Zrotation};
    for (std::size_t a = 0; a < 3; ++a)
      if (!have_axis[a]) {
        rotations.push_back(kAxisRotation[a]);
        rotation_columns.push_back(-1);
      }
  }
}

// A non-root joint's constant OFFSET: its position channels' first value
// when it varies (a lifted joint), else the middle of their range.
Eigen::Vector3d export_offset(const RawClip& clip, const RawJoint& rj, bool varies) {
  const std::size_t frames = clip.frame_count;
  Eigen::Vector3d offset = rj.offset;
  for (std::size_t c = 0; c < rj.channels.size(); ++c) {
    if (channel_is_rotation(rj.channels[c]) || frames == 0) continue;
    const std::size_t col = rj.first_column + c;
    double lo = kInf, hi = -kInf;
    for (std::size_t f = 0; f < frames; ++f) {
      lo = std::min(lo, clip.frame(f)[col]);
      hi = std::max(hi, clip.frame(f)[col]);
    }
    offset[channel_axis(rj.channels[c])] = varies ? clip.frame(0)[col] : 0.5 * (lo + hi);
  }
  return offset;
}

// The output joints and channel layout of `out` (no values yet). Returns
// the source columns of each output channel (-1: constant zero angle, or a
// root position filled per frame).
std::vector<std::vector<int>> export_joints(const RawClip& clip,
                                            const std::vector<std::uint8_t>& varies, RawClip& out) {
  const std::size_t n = clip.joints.size();
  out.joints.resize(n);
  std::vector<std::vector<int>> source_columns(n);
  std::size_t column = 0;
  for (std::size_t j = 0; j < n; ++j) {
    const RawJoint& rj = clip.joints[j];
    RawJoint& oj = out.joints[j];
    oj = rj;  // name, parent and End Site as they are; the rest is rebuilt below
    oj.channels.clear();
    oj.first_column = column;
    std::vector<int>& src = source_columns[j];
    std::vector<Channel> rotations;
    std::vector<int> rotation_columns;
    export_rotations(clip, rj, rotations, rotation_columns);
    if (rj.parent < 0) {
      oj.offset = Eigen::Vector3d::Zero();
      oj.channels = {Channel::Xposition, Channel::Yposition, Channel::Zposition};
      src = {-1, -1, -1};  // filled per frame below
    } else {
      oj.offset = export_offset(clip, rj, varies[j] != 0);
    }
    oj.channels.insert(oj.channels.end(), rotations.begin(), rotations.end());
    src.insert(src.end(), rotation_columns.begin(), rotation_columns.end());
    column += oj.channels.size();
  }
  out.channel_count = column;
  return source_columns;
}

// Root joint j's position at source row `row`, moved by its lifted joint's
// displacement when it has one (lifted: that joint, -1 none).
Eigen::Vector3d export_root_position(const RawClip& clip, std::size_t j, int lifted,
                                     const double* row) {
  Eigen::Vector3d p = joint_translation(clip.joints[j], row);
  if (lifted < 0) return p;
  // Rotation of the lifted joint's parent in the root's parent (world) frame.
  const auto lj = static_cast<std::size_t>(lifted);
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  std::vector<std::size_t> path;
  for (int a = clip.joints[lj].parent; a >= 0; a = clip.joints[static_cast<std::size_t>(a)].parent)
    path.push_back(static_cast<std::size_t>(a));
  for (auto it = path.rbegin(); it != path.rend(); ++it)
    q = q * joint_rotation(clip.joints[*it], row);
  const RawJoint& lifted_joint = clip.joints[lj];
  p += q * (joint_translation(lifted_joint, row) - joint_translation(lifted_joint, clip.frame(0)));
  return p;
}

}  // namespace

RawClip to_export_layout(const RawClip& clip, double tolerance) {
  detail::check_clip(clip);
  const std::size_t n = clip.joints.size();
  const std::size_t frames = clip.frame_count;
  const std::vector<std::uint8_t> varies = varying_positions(clip, tolerance);
  const std::vector<int> lifted = lifted_joints(clip, varies, tolerance);

  RawClip out;
  out.source = clip.source;
  out.frame_time_s = clip.frame_time_s;
  out.frame_count = frames;
  const std::vector<std::vector<int>> source_columns = export_joints(clip, varies, out);
  const std::size_t column = out.channel_count;
  out.values.assign(frames * column, 0.0);

  for (std::size_t f = 0; f < frames; ++f) {
    const double* row = clip.frame(f);
    double* orow = out.values.data() + f * column;
    for (std::size_t j = 0; j < n; ++j) {
      const RawJoint& oj = out.joints[j];
      const std::vector<int>& src = source_columns[j];
      for (std::size_t c = 0; c < src.size(); ++c)
        if (src[c] >= 0) orow[oj.first_column + c] = row[static_cast<std::size_t>(src[c])];
      if (oj.parent >= 0) continue;
      const Eigen::Vector3d p = export_root_position(clip, j, lifted[j], row);
      for (int a = 0; a < 3; ++a) orow[oj.first_column + static_cast<std::size_t>(a)] = p[a];
    }
  }
  return out;
}

}  // namespace mocap
