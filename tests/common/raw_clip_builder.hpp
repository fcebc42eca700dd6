#pragma once
// Builds small RawClips in code for tests that must not depend on the BVH parser.
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

}  // namespace mocap::test
