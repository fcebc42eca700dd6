// The synthesis view of an index skeleton: fixed translations, frames from
// the index, forward kinematics, range of motion, rigid placement.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/motion/skeleton_motion.hpp"
#include "mocap/common/util/error.hpp"

namespace mocap {
namespace {

Eigen::Quaterniond quat_at(std::span<const float> v, std::size_t i) {
  return Eigen::Quaterniond(v[4 * i], v[4 * i + 1], v[4 * i + 2], v[4 * i + 3]).normalized();
}
Eigen::Vector3d vec_at(std::span<const float> v, std::size_t i) {
  return {v[3 * i], v[3 * i + 1], v[3 * i + 2]};
}

// World rotation of the parent of the root joint (its ancestors keep their
// frame's local rotations), identity when the root joint is a tree root.
Eigen::Quaterniond root_parent_rotation(const SynthSkeleton& sk, const SynthFrame& frame) {
  Eigen::Quaterniond w = Eigen::Quaterniond::Identity();
  std::vector<int> chain;
  for (int p = sk.skeleton.parents[static_cast<std::size_t>(sk.root_joint)]; p >= 0;
       p = sk.skeleton.parents[static_cast<std::size_t>(p)])
    chain.push_back(p);
  for (auto it = chain.rbegin(); it != chain.rend(); ++it)
    w = w * frame.local_rotations[static_cast<std::size_t>(*it)];
  return w;
}

bool channel_fits(double v, double lo, double hi, double slack) {
  for (int k = -1; k <= 1; ++k) {
    const double x = v + 360.0 * k;
    if (x >= lo - slack && x <= hi + slack) return true;
  }
  return false;
}

}  // namespace

SynthSkeleton make_synth_skeleton(const Index& index, std::uint32_t skeleton,
                                  std::size_t reference_clip) {
  return make_synth_skeleton(ClipSource(index), skeleton, reference_clip);
}

// The skeleton's table comes from the first index holding it (in a
// collection: the table one index of the same files stores, written from
// the first clip of that skeleton), the translations from the reference
// clip's own index.
SynthSkeleton make_synth_skeleton(const ClipSource& clips, std::uint32_t skeleton,
                                  std::size_t reference_clip) {
  if (skeleton >= clips.skeleton_count())
    throw std::invalid_argument("make_synth_skeleton: skeleton " + std::to_string(skeleton) +
                                " out of range");
  if (reference_clip >= clips.clip_count() || clips.skeleton_of(reference_clip) != skeleton)
    throw std::invalid_argument("make_synth_skeleton: reference clip not of skeleton " +
                                std::to_string(skeleton));
  const IndexSkeleton& isk = clips.skeleton(skeleton);
  SynthSkeleton sk;
  sk.index_skeleton = skeleton;
  sk.skeleton = isk.skeleton;
  sk.channels = isk.channels;
  sk.model = clips.dynamics_model(skeleton);
  sk.root_joint = isk.root_joint;
  const std::size_t n = sk.skeleton.joint_count();
  const auto positions = clips.clip_frames(reference_clip, "joint_positions_m");
  const auto rotations = clips.clip_frames(reference_clip, "world_rotations");
  sk.local_translations_m.resize(n);
  for (std::size_t j = 0; j < n; ++j) {
    const int p = sk.skeleton.parents[j];
    if (sk.skeleton.channels[j].has_position()) {
      const Eigen::Vector3d x = vec_at(positions, j);
      sk.local_translations_m[j] =
          p < 0 ? x
                : Eigen::Vector3d(quat_at(rotations, static_cast<std::size_t>(p)).conjugate() *
                                  (x - vec_at(positions, static_cast<std::size_t>(p))));
    } else {
      const double s =
          sk.skeleton.translation_scales.empty() ? 1.0 : sk.skeleton.translation_scales[j];
      sk.local_translations_m[j] = sk.skeleton.offsets_m[j] * s;
    }
  }
  sk.is_root_chain.assign(n, 0);
  for (int j = sk.root_joint; j >= 0; j = sk.skeleton.parents[static_cast<std::size_t>(j)])
    sk.is_root_chain[static_cast<std::size_t>(j)] = 1;
  sk.classes = classify_joints(sk.skeleton);
  sk.foot_joints = foot_joints(sk.classes, sk.model);
  return sk;
}

std::vector<int> foot_joints(const std::vector<std::pair<SegmentClass, Side>>& classes,
                             const DynamicsModel& model) {
  std::vector<int> out;
  for (std::size_t j = 0; j < classes.size(); ++j) {
    const SegmentClass c = classes[j].first;
    if ((c == SegmentClass::foot || c == SegmentClass::toes) && model.masses_kg[j] > 0.0)
      out.push_back(static_cast<int>(j));
  }
  return out;
}

RangeOfMotion range_of_motion(const Index& index, const SynthSkeleton& sk,
                              const std::vector<std::size_t>& clips) {
  return range_of_motion(ClipSource(index), sk, clips);
}

// Each clip's row from its own index (min and max do not depend on the
// order: a collection gives one index's range).
RangeOfMotion range_of_motion(const ClipSource& source, const SynthSkeleton& sk,
                              const std::vector<std::size_t>& clips) {
  const std::size_t n = sk.joint_count();
  RangeOfMotion rom;
  rom.min_deg.assign(n, {0.0, 0.0, 0.0});
  rom.max_deg.assign(n, {0.0, 0.0, 0.0});
  rom.has_range.assign(n, 0);
  bool first = true;
  for (std::size_t c : clips) {
    if (c >= source.clip_count() || source.skeleton_of(c) != sk.index_skeleton)
      throw std::invalid_argument("range_of_motion: clip " + std::to_string(c) +
                                  " is not of the target skeleton");
    const auto row_lo = source.clip_bounds_row(c, "rotation_channel_min_deg");
    const auto row_hi = source.clip_bounds_row(c, "rotation_channel_max_deg");
    for (std::size_t j = 0; j < n; ++j)
      for (std::size_t k = 0; k < 3; ++k) {
        const double a = row_lo[3 * j + k], b = row_hi[3 * j + k];
        rom.min_deg[j][k] = first ? a : std::min(rom.min_deg[j][k], a);
        rom.max_deg[j][k] = first ? b : std::max(rom.max_deg[j][k], b);
      }
    first = false;
  }
  if (!first)
    for (std::size_t j = 0; j < n; ++j)
      rom.has_range[j] = !sk.is_root_chain[j] && sk.skeleton.channels[j].rotation_count == 3;
  return rom;
}

SynthFrame clip_frame(const ClipSource& clips, std::size_t clip, std::size_t f) {
  const ClipSource::Location at = clips.locate(clip);
  return clip_frame(*at.index, at.clip, f);
}

SynthFrame clip_frame(const Index& index, std::size_t clip, std::size_t f) {
  const IndexClip& c = index.clips().at(clip);
  if (f >= c.frame_count)
    throw std::invalid_argument("clip_frame: frame " + std::to_string(f) + " out of range");
  const std::size_t n = index.skeletons()[c.skeleton].skeleton.joint_count();
  const auto root = index.clip_frames(clip, "root_position_m");
  const auto local = index.clip_frames(clip, "local_rotations");
  SynthFrame out;
  out.root_position_m = vec_at(root, f);
  out.local_rotations.resize(n);
  for (std::size_t j = 0; j < n; ++j) out.local_rotations[j] = quat_at(local, f * n + j);
  return out;
}

void synth_world_pose(const SynthSkeleton& sk, const SynthFrame& frame, WorldPose& out) {
  const std::size_t n = sk.joint_count();
  out.positions_m.resize(n);
  out.rotations.resize(n);
  for (std::size_t j = 0; j < n; ++j) {
    const int p = sk.skeleton.parents[j];
    const Eigen::Quaterniond& q = frame.local_rotations[j];
    if (p < 0) {
      out.rotations[j] = q;
      out.positions_m[j] = sk.local_translations_m[j];
    } else {
      const auto pp = static_cast<std::size_t>(p);
      out.rotations[j] = out.rotations[pp] * q;
      out.positions_m[j] = out.positions_m[pp] + out.rotations[pp] * sk.local_translations_m[j];
    }
    if (static_cast<int>(j) == sk.root_joint) out.positions_m[j] = frame.root_position_m;
  }
}

bool within_range(const SynthSkeleton& sk, const RangeOfMotion& rom, int j,
                  const Eigen::Quaterniond& local, double slack_deg) {
  const auto ju = static_cast<std::size_t>(j);
  if (!rom.has_range[ju]) return true;
  const auto& ch = sk.skeleton.channels[ju];
  const Eigen::Vector3d e = quaternion_to_euler(local, ch.rotation_axis);
  const Eigen::Vector3d alt(e[0] + 180.0, 180.0 - e[1], e[2] + 180.0);
  for (const Eigen::Vector3d* v : {&e, &alt}) {
    bool ok = true;
    for (int k = 0; k < 3 && ok; ++k)
      ok = channel_fits((*v)[k], rom.min_deg[ju][static_cast<std::size_t>(k)],
                        rom.max_deg[ju][static_cast<std::size_t>(k)], slack_deg);
    if (ok) return true;
  }
  return false;
}

Eigen::Quaterniond clamp_to_range(const SynthSkeleton& sk, const RangeOfMotion& rom, int j,
                                  const Eigen::Quaterniond& local) {
  if (within_range(sk, rom, j, local, 0.0)) return local;
  const auto ju = static_cast<std::size_t>(j);
  const auto& ch = sk.skeleton.channels[ju];
  const Eigen::Vector3d e = quaternion_to_euler(local, ch.rotation_axis);
  double deg[3];
  for (std::size_t k = 0; k < 3; ++k) {
    const double lo = rom.min_deg[ju][k], hi = rom.max_deg[ju][k];
    double best = e[static_cast<Eigen::Index>(k)], best_d = 1e300;
    for (int w = -1; w <= 1; ++w) {
      const double x = e[static_cast<Eigen::Index>(k)] + 360.0 * w;
      const double c = std::clamp(x, lo, hi);
      if (std::abs(c - x) < best_d) {
        best_d = std::abs(c - x);
        best = c;
      }
    }
    deg[k] = best;
  }
  const std::uint8_t axes[3] = {ch.rotation_axis[0], ch.rotation_axis[1], ch.rotation_axis[2]};
  return euler_to_quaternion(axes, deg).normalized();
}

SynthFrame place_frame(const SynthSkeleton& sk, const SynthFrame& frame, const Placement& p) {
  SynthFrame out = frame;
  const Eigen::Quaterniond ry(Eigen::AngleAxisd(p.yaw_rad, Eigen::Vector3d::UnitY()));
  out.root_position_m = ry * frame.root_position_m + p.translation_m;
  const Eigen::Quaterniond wp = root_parent_rotation(sk, frame);
  auto& q = out.local_rotations[static_cast<std::size_t>(sk.root_joint)];
  q = (wp.conjugate() * ry * wp * q).normalized();
  return out;
}

double root_heading(const SynthSkeleton& sk, const SynthFrame& frame) {
  return heading_rad(root_parent_rotation(sk, frame) *
                     frame.local_rotations[static_cast<std::size_t>(sk.root_joint)]);
}

}  // namespace mocap

namespace mocap {

Eigen::Vector3d horizontal_root_velocity(const SynthFrame& a, const SynthFrame& b, double dt) {
  Eigen::Vector3d v = (b.root_position_m - a.root_position_m) / dt;
  v.y() = 0.0;
  return v;
}

Placement continuation_placement(const SynthSkeleton& sk, const SynthFrame& end,
                                 const Eigen::Vector3d& v_end, const SynthFrame& first,
                                 const Eigen::Vector3d& v_first, double travel_time_s,
                                 const double* heading) {
  Placement p;
  const double target = heading ? *heading : root_heading(sk, end);
  p.yaw_rad = target - root_heading(sk, first);
  const Eigen::Quaterniond ry(Eigen::AngleAxisd(p.yaw_rad, Eigen::Vector3d::UnitY()));
  const Eigen::Vector3d vf = ry * v_first;
  Eigen::Vector3d dest = end.root_position_m + 0.5 * (v_end + vf) * travel_time_s;
  const Eigen::Vector3d turned = ry * first.root_position_m;
  p.translation_m = dest - turned;
  p.translation_m.y() = 0.0;
  return p;
}

}  // namespace mocap
