// Rotating a Z-up clip to the engine's Y up (units.hpp: rotate_to_y_up,
// normalise_up_axis). Only the ROOTs change: their OFFSET, position and
// rotation channels are re-expressed in the Y-up frame; every other joint is
// relative to its parent and stays as it is.
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "mocap/common/io/units.hpp"

namespace mocap {

namespace {
constexpr double kDegToRad = std::numbers::pi / 180.0;

// (x, y, z) -> (x, z, -y): -90 degrees about X, +Z goes to +Y.
const Eigen::Matrix3d& z_up_to_y_up() {
  static const Eigen::Matrix3d r = (Eigen::Matrix3d() << 1, 0, 0, 0, 0, 1, 0, -1, 0).finished();
  return r;
}

Eigen::Vector3d unit_axis(int axis) {
  return Eigen::Vector3d::Unit(axis);
}

// The rotation axes a ROOT keeps: its own three in file order, ZXY otherwise.
std::array<int, 3> root_rotation_axes(const RawJoint& j) {
  std::array<int, 3> axes{};
  int n = 0;
  for (Channel c : j.channels)
    if (channel_is_rotation(c) && n < 3) axes[static_cast<std::size_t>(n++)] = channel_axis(c);
  if (n == 3) return axes;
  return {2, 0, 1};
}

Channel rotation_channel(int axis) {
  return axis == 0 ? Channel::Xrotation : axis == 1 ? Channel::Yrotation : Channel::Zrotation;
}

// The ROOT's new values (3 positions, 3 rotations in degrees) for one frame row.
std::array<double, 6> rotated_root_values(const RawJoint& j, const double* row,
                                          const std::array<int, 3>& axes) {
  Eigen::Vector3d t = j.offset;  // position channels replace the OFFSET's components
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  for (std::size_t k = 0; k < j.channels.size(); ++k) {
    const double v = row[j.first_column + k];
    const int axis = channel_axis(j.channels[k]);
    if (channel_is_rotation(j.channels[k]))
      r = r * Eigen::AngleAxisd(v * kDegToRad, unit_axis(axis)).toRotationMatrix();
    else
      t[axis] = v;
  }
  const Eigen::Vector3d t_up = z_up_to_y_up() * t;
  const Eigen::Vector3d e = (z_up_to_y_up() * r).eulerAngles(axes[0], axes[1], axes[2]);
  return {t_up.x(), t_up.y(), t_up.z(), e[0] / kDegToRad, e[1] / kDegToRad, e[2] / kDegToRad};
}
}  // namespace

RawClip rotate_to_y_up(const RawClip& clip, UpAxis up) {
  if (up == UpAxis::y) return clip;
  RawClip out = clip;
  std::vector<std::array<int, 3>> axes(clip.joints.size());
  std::size_t column = 0;
  for (std::size_t j = 0; j < clip.joints.size(); ++j) {
    RawJoint& o = out.joints[j];
    o.first_column = column;
    if (o.parent < 0) {
      axes[j] = root_rotation_axes(o);
      o.offset = z_up_to_y_up() * o.offset;
      o.channels = {Channel::Xposition, Channel::Yposition, Channel::Zposition};
      for (int a : axes[j]) o.channels.push_back(rotation_channel(a));
    }
    column += o.channels.size();
  }
  out.channel_count = column;
  out.values.assign(clip.frame_count * column, 0.0);
  for (std::size_t f = 0; f < clip.frame_count; ++f) {
    const double* row = clip.frame(f);
    double* dst = out.values.data() + f * column;
    for (std::size_t j = 0; j < clip.joints.size(); ++j) {
      const RawJoint& in = clip.joints[j];
      double* at = dst + out.joints[j].first_column;
      if (in.parent < 0) {
        const std::array<double, 6> v = rotated_root_values(in, row, axes[j]);
        std::copy(v.begin(), v.end(), at);
      } else {
        std::copy(row + in.first_column, row + in.first_column + in.channels.size(), at);
      }
    }
  }
  return out;
}

UpAxis normalise_up_axis(RawClip& clip, std::optional<UpAxis> declared) {
  const UpAxis up = declared ? *declared : detect_up_axis(clip);
  if (up == UpAxis::z) clip = rotate_to_y_up(clip, up);
  return up;
}

}  // namespace mocap
