#include "mocap/common/body/skeleton.hpp"

#include <cmath>
#include <cstring>

#include "mocap/common/util/error.hpp"

namespace mocap {

int Skeleton::find(const std::string& name) const {
  for (std::size_t j = 0; j < names.size(); ++j)
    if (names[j] == name) return static_cast<int>(j);
  return -1;
}

std::vector<int> Skeleton::children(int j) const {
  std::vector<int> out;
  for (std::size_t c = static_cast<std::size_t>(j) + 1; c < parents.size(); ++c)
    if (parents[c] == j) out.push_back(static_cast<int>(c));
  return out;
}

namespace {
struct Fnv1a {
  std::uint64_t h = 1469598103934665603ull;
  void bytes(const void* p, std::size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    for (std::size_t i = 0; i < n; ++i) {
      h ^= b[i];
      h *= 1099511628211ull;
    }
  }
  void i64(std::int64_t v) { bytes(&v, sizeof v); }
};
}  // namespace

std::uint64_t Skeleton::id() const {
  Fnv1a f;
  f.i64(static_cast<std::int64_t>(names.size()));
  for (std::size_t j = 0; j < names.size(); ++j) {
    f.bytes(names[j].data(), names[j].size());
    f.i64(parents[j]);
    for (int a = 0; a < 3; ++a) f.i64(std::llround(offsets_m[j][a] * 1e6));
    for (int a = 0; a < 3; ++a) f.i64(std::llround(end_sites_m[j][a] * 1e6));
    f.i64(has_end_site[j]);
    const auto& c = channels[j];
    for (int a = 0; a < 3; ++a) f.i64(c.position_column[a]);
    for (int a = 0; a < 3; ++a) f.i64(c.rotation_column[a] * 4 + c.rotation_axis[a]);
    f.i64(c.rotation_count);
    if (!translation_scales.empty()) f.i64(std::llround(translation_scales[j] * 1e6));
  }
  return f.h;
}

Skeleton build_skeleton(const RawClip& clip, double scale_m) {
  if (!(scale_m > 0.0) || !std::isfinite(scale_m))
    throw InputError(clip.source, 0, "length unit scale must be a positive number of metres");
  Skeleton s;
  const std::size_t n = clip.joints.size();
  s.names.reserve(n);
  s.parents.reserve(n);
  s.offsets_m.reserve(n);
  s.end_sites_m.reserve(n);
  s.has_end_site.reserve(n);
  s.channels.reserve(n);
  for (std::size_t j = 0; j < n; ++j) {
    const RawJoint& rj = clip.joints[j];
    if (rj.parent >= static_cast<int>(j))
      throw InputError(clip.source, 0, "joint '" + rj.name + "' comes before its parent");
    s.names.push_back(rj.name);
    s.parents.push_back(rj.parent);
    s.offsets_m.push_back(rj.offset * scale_m);
    s.end_sites_m.push_back(rj.has_end_site ? Eigen::Vector3d(rj.end_site * scale_m)
                                            : Eigen::Vector3d::Zero());
    s.has_end_site.push_back(rj.has_end_site ? 1 : 0);
    JointChannelMap m;
    for (std::size_t c = 0; c < rj.channels.size(); ++c) {
      const int col = static_cast<int>(rj.first_column + c);
      const Channel ch = rj.channels[c];
      const int axis = channel_axis(ch);
      if (channel_is_rotation(ch)) {
        if (m.rotation_count >= 3)
          throw InputError(clip.source, 0,
                           "joint '" + rj.name + "' has more than 3 rotation channels");
        m.rotation_column[m.rotation_count] = col;
        m.rotation_axis[m.rotation_count] = static_cast<std::uint8_t>(axis);
        ++m.rotation_count;
      } else {
        if (m.position_column[axis] >= 0)
          throw InputError(clip.source, 0, "joint '" + rj.name + "' repeats a position channel");
        m.position_column[axis] = col;
      }
    }
    s.channels.push_back(m);
  }
  s.channel_count = clip.channel_count;
  s.unit_scale_m = scale_m;
  return s;
}

}  // namespace mocap
