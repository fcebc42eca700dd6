// A motion in the format its output path names, and the .npz of a motion
// (motion_file.hpp).
#include "mocap/common/io/motion_file.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <stdexcept>

#include "io/bvh_text.hpp"
#include "io/motion_poses.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/npz.hpp"
#include "mocap/common/util/atomic_file.hpp"
#include "mocap/common/util/error.hpp"

namespace mocap {

MotionFormat motion_format(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".glb") return MotionFormat::glb;
  if (ext == ".npz") return MotionFormat::npz;
  return MotionFormat::bvh;
}

const char* motion_format_name(MotionFormat format) {
  return output_kind_name(motion_output_kind(format));
}

OutputKind motion_output_kind(MotionFormat format) {
  switch (format) {
    case MotionFormat::glb:
      return OutputKind::glb;
    case MotionFormat::npz:
      return OutputKind::npz;
    case MotionFormat::bvh:
      break;
  }
  return OutputKind::bvh;
}

namespace detail {

ClipMotion checked_motion(const RawClip& clip, double scale_m) {
  if (!(scale_m > 0.0) || !std::isfinite(scale_m))
    throw std::invalid_argument("motion file: " + clip.source + ": scale " +
                                std::to_string(scale_m) + " m per unit");
  check_clip(clip);
  if (clip.frame_count == 0)
    throw InputError(clip.source, 0, "the motion has no frames: nothing to write");
  const auto bad = std::find_if(clip.values.begin(), clip.values.end(),
                                [](double v) { return !std::isfinite(v); });
  if (bad != clip.values.end())
    throw InputError(clip.source, 0,
                     "non-finite value at frame " +
                         std::to_string(static_cast<std::size_t>(bad - clip.values.begin()) /
                                        clip.channel_count));
  return clip_motion_from_raw(clip, scale_m);
}

}  // namespace detail

std::string motion_npz(const RawClip& clip, double scale_m) {
  const ClipMotion m = detail::checked_motion(clip, scale_m);
  const std::size_t frames = m.frame_count, joints = m.joint_count();
  std::vector<double> positions, rotations, translations;
  positions.reserve(frames * joints * 3);
  translations.reserve(frames * joints * 3);
  rotations.reserve(frames * joints * 4);
  for (std::size_t k = 0; k < frames * joints; ++k) {
    const Eigen::Quaterniond& q = m.local_rotations[k];
    positions.insert(positions.end(), m.world_positions_m[k].data(),
                     m.world_positions_m[k].data() + 3);
    translations.insert(translations.end(), m.local_translations_m[k].data(),
                        m.local_translations_m[k].data() + 3);
    rotations.insert(rotations.end(), {q.x(), q.y(), q.z(), q.w()});
  }
  std::vector<std::int32_t> parents(m.skeleton.parents.begin(), m.skeleton.parents.end());
  const std::vector<std::pair<std::string, NpyArray>> arrays = {
      {"positions", npy_float64({frames, joints, 3}, positions)},
      {"rotations", npy_float64({frames, joints, 4}, rotations)},
      {"translations", npy_float64({frames, joints, 3}, translations)},
      {"names", npy_strings(m.skeleton.names)},
      {"parents", npy_int32(parents)},
      {"fps", npy_float64({}, {1.0 / clip.frame_time_s})}};
  std::vector<std::pair<std::string, std::string>> members;
  for (const auto& [name, array] : arrays) members.emplace_back(name + ".npy", npy_bytes(array));
  return zip_stored(members, clip.source);
}

void write_motion_file(const RawClip& clip, double scale_m, const std::filesystem::path& path) {
  switch (motion_format(path)) {
    case MotionFormat::bvh:
      write_bvh_file(clip, path);
      return;
    case MotionFormat::glb:
      write_file_atomically(path, motion_glb(clip, scale_m));
      return;
    case MotionFormat::npz:
      write_file_atomically(path, motion_npz(clip, scale_m));
      return;
  }
}

}  // namespace mocap
