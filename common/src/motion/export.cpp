// A clip's partial motion as synthesis writes motions (export.hpp).
#include "mocap/common/motion/export.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <stdexcept>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "mocap/common/motion/skeleton_motion.hpp"
#include "mocap/common/util/edit_distance.hpp"
#include "mocap/common/util/error.hpp"

namespace mocap {
namespace {

std::string file_name(const std::string& path) {
  const auto s = path.find_last_of('/');
  return s == std::string::npos ? path : path.substr(s + 1);
}

// "a, b, c" of at most five close file names (distinct, closest first).
std::string close_names(const ClipSource& clips, const std::string& name) {
  const std::string want = ascii_lower(file_name(name));
  const std::size_t limit = std::max<std::size_t>(3, want.size() / 3);
  std::vector<std::pair<std::size_t, std::string>> near;
  for (std::size_t c = 0; c < clips.clip_count(); ++c) {
    const std::string have = file_name(clips.clip(c).path);
    const std::string key = ascii_lower(have);
    const std::size_t d = key.find(want) != std::string::npos || want.find(key) != std::string::npos
                              ? 0
                              : edit_distance(want, key);
    if (d <= limit) near.emplace_back(d, have);
  }
  std::sort(near.begin(), near.end());
  near.erase(std::unique(near.begin(), near.end()), near.end());
  std::string out;
  for (std::size_t i = 0; i < near.size() && i < 5; ++i) out += (i ? ", " : "") + near[i].second;
  return out;
}

// Clips whose stored file is the file `name` names (compared by identity,
// so any route to it counts), among those with `name`'s file name: a stat
// per candidate, not per clip. None when `name` names no existing file.
std::vector<std::size_t> same_files(const ClipSource& clips, const std::string& name) {
  std::vector<std::size_t> found;
  std::error_code ec;
  if (!std::filesystem::exists(name, ec)) return found;
  const std::string want = file_name(name);
  for (std::size_t c = 0; c < clips.clip_count(); ++c) {
    const std::string& p = clips.clip(c).path;
    if (file_name(p) != want) continue;
    ec.clear();
    if (std::filesystem::equivalent(p, name, ec) && !ec) found.push_back(c);
  }
  return found;
}

}  // namespace

std::size_t find_clip(const ClipSource& clips, const std::string& name) {
  // A full path: as stored, or relative to the working folder.
  std::vector<std::string> paths{name};
  if (name.find('/') != std::string::npos) {
    std::error_code ec;
    const auto absolute = std::filesystem::absolute(name, ec);
    if (!ec) paths.push_back(absolute.lexically_normal().string());
  }
  std::vector<std::size_t> by_path, by_name;
  for (std::size_t c = 0; c < clips.clip_count(); ++c) {
    const std::string& p = clips.clip(c).path;
    if (std::find(paths.begin(), paths.end(), p) != paths.end()) by_path.push_back(c);
    if (file_name(p) == name) by_name.push_back(c);
  }
  // The same file reached by another route (a symbolic link in the stored
  // path or in `name`, ".."): the clips of that file name whose stored file
  // is the one `name` names.
  if (by_path.empty() && name.find('/') != std::string::npos) by_path = same_files(clips, name);
  const std::vector<std::size_t>& found = by_path.empty() ? by_name : by_path;
  if (found.size() == 1) return found.front();
  if (found.empty()) {
    const std::string near = close_names(clips, name);
    throw InputError(clips.path().string(), 0,
                     "no clip \"" + name + "\" among its " + std::to_string(clips.clip_count()) +
                         " clips; " +
                         (near.empty() ? "no clip has a close name" : "close names: " + near));
  }
  std::string list;
  for (std::size_t i = 0; i < found.size() && i < 5; ++i)
    list += (i ? ", " : "") + clips.clip(found[i]).path;
  throw InputError(clips.path().string(), 0,
                   std::to_string(found.size()) + " clips are named \"" + name +
                       "\": give the full path (" + list + (found.size() > 5 ? ", ..." : "") + ")");
}

RawClip partial_motion_clip(const ClipSource& clips, std::size_t clip, FrameRange range,
                            const std::string& option) {
  const IndexClip& c = clips.clip(clip);
  if (range.first > range.last)
    throw std::invalid_argument("partial_motion_clip: first frame after last frame");
  if (range.last >= c.frame_count)
    throw InputError(option, 0,
                     "frames " + std::to_string(range.first) + "-" + std::to_string(range.last) +
                         " out of range for \"" + c.path + "\" (" + std::to_string(c.frame_count) +
                         " frames" +
                         (c.frame_count ? ": 0-" + std::to_string(c.frame_count - 1) : "") + ")");
  // The clip's own skeleton; each frame's local rotations, and every
  // joint's translation from the frame's joint origins (the root joint's,
  // and those of joints above it that move: export.hpp).
  const SynthSkeleton sk = make_synth_skeleton(clips, clips.skeleton_of(clip), clip);
  const std::size_t n = sk.joint_count();
  const auto positions = clips.clip_frames(clip, "joint_positions_m");
  const auto rotations = clips.clip_frames(clip, "world_rotations");
  auto position = [&](std::size_t f, std::size_t j) {
    const float* p = positions.data() + (f * n + j) * 3;
    return Eigen::Vector3d(p[0], p[1], p[2]);
  };
  auto rotation = [&](std::size_t f, std::size_t j) {
    const float* q = rotations.data() + (f * n + j) * 4;
    return Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized();
  };
  std::vector<SynthFrame> frames;
  std::vector<Eigen::Vector3d> translations;
  frames.reserve(range.last - range.first + 1);
  translations.reserve(frames.capacity() * n);
  for (std::size_t f = range.first; f <= range.last; ++f) {
    frames.push_back(clip_frame(clips, clip, f));
    for (std::size_t j = 0; j < n; ++j) {
      const int p = sk.skeleton.parents[j];
      const auto pj = static_cast<std::size_t>(p);
      translations.push_back(p < 0 ? position(f, j)
                                   : Eigen::Vector3d(rotation(f, pj).conjugate() *
                                                     (position(f, j) - position(f, pj))));
    }
  }
  return motion_bvh_clip(
      sk, frames, c.frame_time_s,
      c.path + " frames " + std::to_string(range.first) + "-" + std::to_string(range.last),
      translations);
}

}  // namespace mocap
