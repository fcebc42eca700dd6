#include "mocap/common/dynamics/kinematics.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <numbers>

namespace mocap {

namespace {
constexpr double kDegToRad = std::numbers::pi / 180.0;
constexpr double kRadToDeg = 180.0 / std::numbers::pi;

Eigen::Vector3d unit_axis(std::uint8_t a) {
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  v[a] = 1.0;
  return v;
}

// Local transform of joint j from a frame row (file units, degrees).
inline void local_transform(const Skeleton& skel, std::size_t j, const double* row,
                            Eigen::Vector3d& t, Eigen::Quaterniond& q) {
  const JointChannelMap& m = skel.channels[j];
  t = skel.offsets_m[j];
  for (int a = 0; a < 3; ++a)
    if (m.position_column[a] >= 0) t[a] = row[m.position_column[a]] * skel.unit_scale_m;
  if (!skel.translation_scales.empty()) t *= skel.translation_scales[j];
  q.setIdentity();
  for (int k = 0; k < m.rotation_count; ++k)
    q = q * Eigen::Quaterniond(Eigen::AngleAxisd(row[m.rotation_column[k]] * kDegToRad,
                                                 unit_axis(m.rotation_axis[k])));
}

// World transforms from local ones, parents first (parents[j] < j).
inline void fk_into(const Skeleton& skel, const Eigen::Vector3d* lt, const Eigen::Quaterniond* lq,
                    Eigen::Vector3d* wp, Eigen::Quaterniond* wq) {
  const std::size_t n = skel.joint_count();
  for (std::size_t j = 0; j < n; ++j) {
    const int p = skel.parents[j];
    if (p < 0) {
      wp[j] = lt[j];
      wq[j] = lq[j];
    } else {
      wp[j] = wp[p] + wq[p] * lt[j];
      wq[j] = wq[p] * lq[j];
    }
  }
}
}  // namespace

Eigen::Quaterniond euler_to_quaternion(std::span<const std::uint8_t> axes,
                                       std::span<const double> degrees) {
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  for (std::size_t k = 0; k < axes.size() && k < degrees.size(); ++k)
    q = q * Eigen::Quaterniond(Eigen::AngleAxisd(degrees[k] * kDegToRad, unit_axis(axes[k])));
  return q;
}

// R = R_i(a) R_j(b) R_k(c), (i, j, k) a permutation of the axes; s = +1 for an
// even (cyclic) permutation, -1 for an odd one. Then R(i,k) = s sin b,
// R(j,k) = -s sin a cos b, R(k,k) = cos a cos b, R(i,j) = -s cos b sin c,
// R(i,i) = cos b cos c. At gimbal lock (|cos b| ~ 0) c is set to 0.
Eigen::Vector3d quaternion_to_euler(const Eigen::Quaterniond& q,
                                    const std::array<std::uint8_t, 3>& axes) {
  const Eigen::Matrix3d r = q.normalized().toRotationMatrix();
  const int i = axes[0], j = axes[1], k = axes[2];
  const double s = ((j - i + 3) % 3 == 1) ? 1.0 : -1.0;
  const double sb = std::clamp(s * r(i, k), -1.0, 1.0);
  const double b = std::asin(sb);
  double a, c;
  if (std::abs(sb) < 1.0 - 1e-12) {
    a = std::atan2(-s * r(j, k), r(k, k));
    c = std::atan2(-s * r(i, j), r(i, i));
  } else {
    // cos b = 0: only a +/- c is determined; put it all in a.
    c = 0.0;
    a = std::atan2(s * r(k, j), r(j, j));
  }
  return {a * kRadToDeg, b * kRadToDeg, c * kRadToDeg};
}

void local_pose_from_row(const Skeleton& skel, const double* row, LocalPose& out) {
  const std::size_t n = skel.joint_count();
  out.translations_m.resize(n);
  out.rotations.resize(n);
  for (std::size_t j = 0; j < n; ++j)
    local_transform(skel, j, row, out.translations_m[j], out.rotations[j]);
}

void forward_kinematics(const Skeleton& skel, const LocalPose& local, WorldPose& out) {
  const std::size_t n = skel.joint_count();
  out.positions_m.resize(n);
  out.rotations.resize(n);
  fk_into(skel, local.translations_m.data(), local.rotations.data(), out.positions_m.data(),
          out.rotations.data());
}

void end_site_positions(const Skeleton& skel, const WorldPose& world,
                        std::vector<Eigen::Vector3d>& out) {
  const std::size_t n = skel.joint_count();
  out.resize(n);
  for (std::size_t j = 0; j < n; ++j)
    out[j] = skel.has_end_site[j]
                 ? Eigen::Vector3d(world.positions_m[j] + world.rotations[j] * skel.end_sites_m[j])
                 : world.positions_m[j];
}

namespace {

ClipMotion motion_from_raw(const RawClip& clip, double scale_m, bool world) {
  ClipMotion m;
  m.skeleton = build_skeleton(clip, scale_m);
  m.frame_time_s = clip.frame_time_s;
  m.frame_count = clip.frame_count;
  const std::size_t n = m.skeleton.joint_count();
  const std::size_t total = n * clip.frame_count;
  m.local_translations_m.resize(total);
  m.local_rotations.resize(total);
  if (world) {
    m.world_positions_m.resize(total);
    m.world_rotations.resize(total);
  }
  const Skeleton& skel = m.skeleton;
  auto body = [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t f = r.begin(); f != r.end(); ++f) {
      const double* row = clip.frame(f);
      const std::size_t base = f * n;
      for (std::size_t j = 0; j < n; ++j)
        local_transform(skel, j, row, m.local_translations_m[base + j],
                        m.local_rotations[base + j]);
      if (world)
        fk_into(skel, &m.local_translations_m[base], &m.local_rotations[base],
                &m.world_positions_m[base], &m.world_rotations[base]);
    }
  };
  // Small clips are cheaper serially than the task overhead.
  if (clip.frame_count * n < 8192)
    body(tbb::blocked_range<std::size_t>(0, clip.frame_count));
  else
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, clip.frame_count, 64), body);
  return m;
}

}  // namespace

ClipMotion clip_motion_from_raw(const RawClip& clip, double scale_m) {
  return motion_from_raw(clip, scale_m, true);
}

ClipMotion clip_locals_from_raw(const RawClip& clip, double scale_m) {
  return motion_from_raw(clip, scale_m, false);
}

}  // namespace mocap
