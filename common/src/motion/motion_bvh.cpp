// A motion on a SynthSkeleton as BVH (motion_bvh_clip, skeleton_motion.hpp).
#include <algorithm>
#include <array>
#include <sstream>

#include "mocap/common/body/skeleton.hpp"
#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/motion/skeleton_motion.hpp"

namespace mocap {
namespace {

std::vector<Channel> parse_channels(const std::string& s) {
  std::vector<Channel> out;
  std::istringstream in(s);
  std::string w;
  static const char* names[] = {"Xposition", "Yposition", "Zposition",
                                "Xrotation", "Yrotation", "Zrotation"};
  while (in >> w)
    for (int k = 0; k < 6; ++k)
      if (w == names[k]) out.push_back(static_cast<Channel>(k));
  return out;
}

// Euler angles (degrees) of `q` on a joint's rotation channels: its axes in
// channel order, completed with the missing axes after them when it has fewer
// than 3 (the angles of those are 0 for a rotation the channels can hold).
Eigen::Vector3d channel_euler(const Eigen::Quaterniond& q, const JointChannelMap& cm) {
  if (cm.rotation_count == 3) return quaternion_to_euler(q, cm.rotation_axis);
  std::array<std::uint8_t, 3> axes{};
  std::size_t k = 0;
  for (; k < cm.rotation_count; ++k) axes[k] = cm.rotation_axis[k];
  for (std::uint8_t a = 0; a < 3; ++a)
    if (std::find(axes.begin(), axes.begin() + static_cast<std::ptrdiff_t>(k), a) ==
        axes.begin() + static_cast<std::ptrdiff_t>(k))
      axes[k++] = a;
  return quaternion_to_euler(q, axes);
}

}  // namespace

RawClip motion_bvh_clip(const SynthSkeleton& sk, const std::vector<SynthFrame>& frames,
                        double frame_time_s, const std::string& source,
                        std::span<const Eigen::Vector3d> local_translations_m) {
  const Skeleton& s = sk.skeleton;
  const double unit = s.unit_scale_m;
  RawClip raw;
  raw.source = source;
  raw.frame_time_s = frame_time_s;
  raw.frame_count = frames.size();
  const std::size_t n = s.joint_count();
  const bool per_frame = !local_translations_m.empty();
  if (per_frame && local_translations_m.size() != frames.size() * n)
    throw std::invalid_argument("motion_bvh_clip: " + std::to_string(local_translations_m.size()) +
                                " translations for " + std::to_string(frames.size()) +
                                " frames of " + std::to_string(n) + " joints");
  std::vector<std::vector<Channel>> chans(n);
  for (std::size_t j = 0; j < n; ++j) {
    RawJoint rj;
    rj.name = s.names[j];
    rj.parent = s.parents[j];
    // The rest OFFSET (scaled like the joint's translation): a joint with
    // position channels gets its translation from them (they replace it).
    const double scale = s.translation_scales.empty() ? 1.0 : s.translation_scales[j];
    rj.offset = s.offsets_m[j] * (s.parents[j] < 0 ? 1.0 : scale) / unit;
    chans[j] = parse_channels(j < sk.channels.size() ? sk.channels[j] : "");
    rj.channels = chans[j];
    rj.first_column = raw.channel_count;
    raw.channel_count += rj.channels.size();
    rj.has_end_site = s.has_end_site[j] != 0;
    rj.end_site = s.end_sites_m[j] / unit;
    raw.joints.push_back(std::move(rj));
  }
  raw.values.resize(raw.frame_count * raw.channel_count);
  WorldPose w;
  for (std::size_t f = 0; f < raw.frame_count; ++f) {
    const SynthFrame& fr = frames[f];
    if (!per_frame) synth_world_pose(sk, fr, w);
    double* row = raw.values.data() + f * raw.channel_count;
    for (std::size_t j = 0; j < n; ++j) {
      Eigen::Vector3d t = per_frame ? local_translations_m[f * n + j] : sk.local_translations_m[j];
      if (!per_frame && static_cast<int>(j) == sk.root_joint) {
        const int p = s.parents[j];
        t = p < 0 ? fr.root_position_m
                  : Eigen::Vector3d(
                        w.rotations[static_cast<std::size_t>(p)].conjugate() *
                        (fr.root_position_m - w.positions_m[static_cast<std::size_t>(p)]));
      }
      t /= unit;
      const auto& cm = s.channels[j];
      Eigen::Vector3d e = Eigen::Vector3d::Zero();
      if (cm.rotation_count > 0) e = channel_euler(fr.local_rotations[j], cm);
      std::size_t col = raw.joints[j].first_column, rot_k = 0;
      for (Channel c : chans[j]) {
        if (channel_is_rotation(c))
          row[col++] = rot_k < 3 ? e[static_cast<Eigen::Index>(rot_k++)] : 0.0;
        else
          row[col++] = t[channel_axis(c)];
      }
    }
  }
  return raw;
}

}  // namespace mocap
