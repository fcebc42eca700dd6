// RawClip helpers: BVH channel names and axes, joint lookup by name.
#include "mocap/common/io/raw_clip.hpp"

namespace mocap {

const char* channel_name(Channel c) {
  switch (c) {
    case Channel::Xposition:
      return "Xposition";
    case Channel::Yposition:
      return "Yposition";
    case Channel::Zposition:
      return "Zposition";
    case Channel::Xrotation:
      return "Xrotation";
    case Channel::Yrotation:
      return "Yrotation";
    case Channel::Zrotation:
      return "Zrotation";
  }
  return "?";
}

int channel_axis(Channel c) {
  switch (c) {
    case Channel::Xposition:
    case Channel::Xrotation:
      return 0;
    case Channel::Yposition:
    case Channel::Yrotation:
      return 1;
    case Channel::Zposition:
    case Channel::Zrotation:
      return 2;
  }
  return 0;
}

bool channel_is_rotation(Channel c) {
  return c == Channel::Xrotation || c == Channel::Yrotation || c == Channel::Zrotation;
}

int RawClip::find_joint(const std::string& name) const {
  for (std::size_t j = 0; j < joints.size(); ++j)
    if (joints[j].name == name) return static_cast<int>(j);
  return -1;
}

}  // namespace mocap
