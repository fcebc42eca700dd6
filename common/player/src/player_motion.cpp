// The player's motions (player.hpp): BVH text, root path box, foot
// contacts; the colours and the clip motions the scenes share.
#include <algorithm>
#include <cmath>

#include "mocap/common/io/bvh.hpp"
#include "mocap/player/player.hpp"

namespace mocap {
namespace {

constexpr const char* kRankColours[] = {"#3b6fb6", "#7b5ea7", "#4f8a8b", "#8c564b",
                                        "#5a6270", "#a0522d", "#2f4f7f", "#6b8e23"};

}  // namespace

const char* player_rank_colour(std::size_t rank) {
  constexpr std::size_t n = sizeof kRankColours / sizeof kRankColours[0];
  return kRankColours[(rank == 0 ? 0 : rank - 1) % n];
}

double player_end_s(const PlayerMotion& m) {
  return m.start_s + static_cast<double>(m.frames > 0 ? m.frames - 1 : 0) * m.frame_time_s;
}

PlayerMotion player_motion(const SynthSkeleton& sk, const std::vector<SynthFrame>& frames,
                           double frame_time_s) {
  PlayerMotion m;
  const Skeleton& s = sk.skeleton;
  m.bvh =
      write_bvh(to_export_layout(motion_bvh_clip(sk, frames, frame_time_s, "player motion")), 6);
  m.unit_m = s.unit_scale_m;
  m.ground_m = sk.model.params.ground_height_m;
  m.frame_time_s = frame_time_s;
  m.frames = frames.size();
  for (std::size_t j = 0; j < sk.joint_count(); ++j)
    if (sk.is_root_chain[j] && static_cast<int>(j) != sk.root_joint)
      m.hidden_joints.push_back(s.names[j]);
  if (!frames.empty()) {
    const Eigen::Vector3d& p0 = frames[0].root_position_m;
    m.box[0] = m.box[1] = p0.x();
    m.box[2] = m.box[3] = p0.z();
    for (const SynthFrame& f : frames) {
      m.box[0] = std::min(m.box[0], f.root_position_m.x());
      m.box[1] = std::max(m.box[1], f.root_position_m.x());
      m.box[2] = std::min(m.box[2], f.root_position_m.z());
      m.box[3] = std::max(m.box[3], f.root_position_m.z());
    }
  }
  // Foot states per frame (player.hpp kFootContact): height of the joint's
  // origin above the ground, horizontal speed by central differences.
  std::vector<WorldPose> world(frames.size());
  for (std::size_t f = 0; f < frames.size(); ++f) synth_world_pose(sk, frames[f], world[f]);
  const std::size_t n = frames.size();
  for (int jf : sk.foot_joints) {
    const auto j = static_cast<std::size_t>(jf);
    m.foot_joints.push_back(s.names[j]);
    std::string states(n, kFootAir);
    for (std::size_t f = 0; f < n; ++f) {
      const Eigen::Vector3d& p = world[f].positions_m[j];
      if (p.y() - m.ground_m >= kSkatingHeightM) continue;
      double speed = 0.0;
      if (n >= 2) {
        const std::size_t a = f == 0 ? 0 : f - 1, b = f + 1 == n ? f : f + 1;
        const Eigen::Vector3d d = world[b].positions_m[j] - world[a].positions_m[j];
        speed = std::hypot(d.x(), d.z()) / (static_cast<double>(b - a) * frame_time_s);
      }
      states[f] = speed > kSkatingSpeedMps ? kFootSkating : kFootContact;
    }
    m.contacts.push_back(std::move(states));
  }
  return m;
}

PlayerMotion player_clip_motion(const ClipSource& clips, std::size_t clip, std::size_t start,
                                std::size_t end) {
  const SynthSkeleton sk = make_synth_skeleton(clips, clips.skeleton_of(clip), clip);
  std::vector<SynthFrame> frames;
  for (std::size_t f = start; f <= end; ++f) frames.push_back(clip_frame(clips, clip, f));
  PlayerMotion m = player_motion(sk, frames, clips.clip(clip).frame_time_s);
  m.first_frame = start;
  return m;
}

PlayerMotion PlayerClipMotions::get(std::size_t clip, std::size_t start, std::size_t end) {
  const std::array<std::size_t, 3> key{clip, start, end};
  auto it = made_.find(key);
  if (it == made_.end())
    it = made_.emplace(key, player_clip_motion(clips_, clip, start, end)).first;
  return it->second;
}

}  // namespace mocap
