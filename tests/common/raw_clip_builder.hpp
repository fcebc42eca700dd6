#pragma once
// Builds small RawClips in code for tests that must not depend on the BVH parser,
// and changes a clip's length unit (in_metres).
#include <cstddef>
#include <initializer_list>
#include <string>
#include <vector>

#include "mocap/common/io/raw_clip.hpp"

namespace mocap::test {

class RawClipBuilder {
 public:
  explicit RawClipBuilder(std::string source = "<test>") { clip_.source = std::move(source); }

  /// Adds a joint; returns its index.
  int joint(const std::string& name, int parent, Eigen::Vector3d offset,
            std::initializer_list<Channel> channels) {
    RawJoint j;
    j.name = name;
    j.parent = parent;
    j.offset = offset;
    j.channels = channels;
    j.first_column = clip_.channel_count;
    clip_.channel_count += j.channels.size();
    clip_.joints.push_back(j);
    return static_cast<int>(clip_.joints.size() - 1);
  }
  RawClipBuilder& end_site(int j, Eigen::Vector3d offset) {
    clip_.joints[static_cast<std::size_t>(j)].has_end_site = true;
    clip_.joints[static_cast<std::size_t>(j)].end_site = offset;
    return *this;
  }
  /// Appends one frame row (must have channel_count values).
  RawClipBuilder& frame(std::vector<double> row) {
    clip_.values.insert(clip_.values.end(), row.begin(), row.end());
    ++clip_.frame_count;
    return *this;
  }
  RawClip build(double frame_time_s = 1.0 / 30.0) {
    clip_.frame_time_s = frame_time_s;
    return clip_;
  }

 private:
  RawClip clip_;
};

/// A copy of a clip written in centimetres with every length in metres
/// (offsets, end sites and position channels times 0.01): the same motion in
/// another unit.
inline RawClip in_metres(const RawClip& cm) {
  RawClip m = cm;
  for (RawJoint& j : m.joints) {
    j.offset *= 0.01;
    j.end_site *= 0.01;
    for (std::size_t c = 0; c < j.channels.size(); ++c)
      if (!channel_is_rotation(j.channels[c]))
        for (std::size_t f = 0; f < m.frame_count; ++f)
          m.values[f * m.channel_count + j.first_column + c] *= 0.01;
  }
  return m;
}

}  // namespace mocap::test
