// compute_clip_frame_data: what one clip contributes to the index.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <stdexcept>

#include "mocap/common/dynamics/energy.hpp"
#include "mocap/common/dynamics/index_frames.hpp"
#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/dynamics/newton_euler.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/indexer/index_builder.hpp"

namespace mocap {

namespace {

std::size_t field_index(std::span<const IndexFieldSpec> table, const char* name) {
  const int i = find_field(table, name);
  if (i < 0) throw std::logic_error(std::string("index schema lacks field ") + name);
  return static_cast<std::size_t>(i);
}

inline void put_vec3(const Eigen::Vector3d& v, float* out) {
  out[0] = static_cast<float>(v.x());
  out[1] = static_cast<float>(v.y());
  out[2] = static_cast<float>(v.z());
}

/// Per-element min and max of rows [first, first + count) of a row-major array.
void min_max_rows(std::span<const float> values, std::size_t row_elements, std::size_t first,
                  std::size_t count, float* lo, float* hi) {
  std::fill(lo, lo + row_elements, std::numeric_limits<float>::infinity());
  std::fill(hi, hi + row_elements, -std::numeric_limits<float>::infinity());
  for (std::size_t r = first; r < first + count; ++r) {
    const float* row = values.data() + r * row_elements;
    for (std::size_t e = 0; e < row_elements; ++e) {
      lo[e] = std::min(lo[e], row[e]);
      hi[e] = std::max(hi[e], row[e]);
    }
  }
}

}  // namespace

IndexedSkeleton index_skeleton(const RawClip& clip, double scale_m, const Character& character,
                               const EnergyParams& params) {
  IndexedSkeleton s;
  s.skeleton = apply_length_scales(build_skeleton(clip, scale_m), character);
  s.body = build_body(s.skeleton, character);
  s.model = build_dynamics_model(s.skeleton, s.body, params);
  if (s.model.segments.empty())
    throw InputError(clip.source, 0,
                     "no joint of the skeleton carries mass (no body segment recognised)");
  s.channels.reserve(clip.joints.size());
  for (const RawJoint& j : clip.joints) {
    std::string c;
    for (Channel ch : j.channels) {
      if (!c.empty()) c += ' ';
      c += channel_name(ch);
    }
    s.channels.push_back(std::move(c));
  }
  s.root_joint = std::max(0, s.model.root());
  s.id = s.skeleton.id();
  return s;
}

ClipFrameData compute_clip_frame_data(const RawClip& clip, const IndexedSkeleton& skel,
                                      double transition_time_s) {
  const Skeleton& sk = skel.skeleton;
  const DynamicsModel& model = skel.model;
  const std::size_t K = clip.frame_count;
  const std::size_t J = sk.joint_count();
  const std::size_t S = model.segments.size();
  if (K == 0) throw InputError(clip.source, 0, "the clip has no frames");
  if (clip.channel_count != sk.channel_count)
    throw std::invalid_argument(clip.source +
                                ": the skeleton is not the clip's (channel counts differ)");
  if (kd_feature_dimension(model) != 3 * S)
    throw std::logic_error("kd feature dimension is not 3 x segments");

  // Forward kinematics, parallel over frames (each frame is independent, so
  // the result does not depend on the split).
  std::vector<Eigen::Vector3d> positions(K * J);
  std::vector<Eigen::Quaterniond> local(K * J);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, K, 256),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      LocalPose lp;
                      WorldPose wp;
                      for (std::size_t f = r.begin(); f != r.end(); ++f) {
                        local_pose_from_row(sk, clip.frame(f), lp);
                        forward_kinematics(sk, lp, wp);
                        std::copy(wp.positions_m.begin(), wp.positions_m.end(),
                                  positions.begin() + static_cast<std::ptrdiff_t>(f * J));
                        std::copy(lp.rotations.begin(), lp.rotations.end(),
                                  local.begin() + static_cast<std::ptrdiff_t>(f * J));
                      }
                    });

  ClipFrameData d;
  d.frame_count = K;
  d.joint_count = J;
  d.segment_count = S;
  // The fields the index stores; the others (kIndexDerivedFrameFields) a
  // reader derives from the local rotations and joint positions.
  for (std::size_t i = 0; i < kFrameFieldCount; ++i) {
    if (!frame_field_stored(kFrameFields[i].name, kIndexSchemaVersion)) continue;
    if (kFrameFields[i].dtype == IndexDType::f32)
      d.frames[i].resize(K * row_elements(kFrameFields[i].shape, J, S));
    else
      d.frames_f64[i].resize(K * row_elements(kFrameFields[i].shape, J, S));
  }
  auto frame = [&](const char* name) -> std::vector<float>& {
    return d.frames[field_index(kFrameFields, name)];
  };
  std::vector<float>& root = frame("root_position_m");
  std::vector<float>& lrot = frame("local_rotations");
  std::vector<float>& jpos = frame("joint_positions_m");

  const auto rj = static_cast<std::size_t>(skel.root_joint);
  for (std::size_t f = 0; f < K; ++f) put_vec3(positions[f * J + rj], &root[f * 3]);
  stored_rows(local, positions, lrot.data(), jpos.data());
  // The dynamics from the stored float rows, as a reader derives them
  // (index_frames.hpp): the kd features, their bounds and the h scan a
  // reader derives are then bit for bit these.
  const ClipDynamics dyn = clip_dynamics_from_rows(model, {lrot, jpos, K, clip.frame_time_s});
  std::vector<float> kd(K * 3 * S);
  derived_frame_rows(model, dyn, "kd_features", transition_time_s, kd.data());
  if (frame_field_stored("h_scan", kIndexSchemaVersion))
    derived_frame_rows(model, dyn, "h_scan", transition_time_s, frame("h_scan").data());

  // The clip's own energy: g per step, as prefix sums from 0.
  std::vector<double> prefix = energy_prefix_sums(clip_step_energies(model, dyn));
  if (prefix.size() != K)
    throw std::logic_error("energy_prefix_sums: expected one value per frame");
  d.frames_f64[field_index(kFrameFields, "energy_prefix_J")] = std::move(prefix);

  compute_clip_bounds(clip, skel, kd, d);
  if (frame_field_stored("kd_features", kIndexSchemaVersion)) frame("kd_features") = std::move(kd);
  return d;
}

void compute_clip_bounds(const RawClip& clip, const IndexedSkeleton& skel,
                         std::span<const float> kd, ClipFrameData& d) {
  const std::size_t K = d.frame_count, J = d.joint_count, S = d.segment_count;
  if (kd.size() != K * 3 * S)
    throw std::invalid_argument("compute_clip_bounds: kd features do not match the clip");
  const auto& root = d.frames[field_index(kFrameFields, "root_position_m")];
  const auto& lrot = d.frames[field_index(kFrameFields, "local_rotations")];

  for (std::size_t i = 0; i < kClipBoundFieldCount; ++i)
    d.clip_bounds[i].assign(row_elements(kClipBoundFields[i].shape, J, S), 0.0f);
  auto bound = [&](const char* name) {
    return d.clip_bounds[field_index(kClipBoundFields, name)].data();
  };
  min_max_rows(root, 3, 0, K, bound("root_min_m"), bound("root_max_m"));
  min_max_rows(kd, 3 * S, 0, K, bound("kd_min"), bound("kd_max"));
  min_max_rows(lrot, 4 * J, 0, K, bound("local_rotation_min"), bound("local_rotation_max"));

  // Range of motion: the rotation channels as written (degrees), channel order.
  float* rmin = bound("rotation_channel_min_deg");
  float* rmax = bound("rotation_channel_max_deg");
  for (std::size_t j = 0; j < J; ++j) {
    const JointChannelMap& m = skel.skeleton.channels[j];
    for (std::size_t c = 0; c < m.rotation_count; ++c) {
      const auto col = static_cast<std::size_t>(m.rotation_column[c]);
      double lo = std::numeric_limits<double>::infinity(), hi = -lo;
      for (std::size_t f = 0; f < K; ++f) {
        const double v = clip.frame(f)[col];
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
      rmin[j * 3 + c] = static_cast<float>(lo);
      rmax[j * 3 + c] = static_cast<float>(hi);
    }
  }

  for (std::size_t b = 0; b < kIndexBlockSizes.size(); ++b) {
    const std::size_t bs = kIndexBlockSizes[b];
    const std::size_t blocks = (K + bs - 1) / bs;
    auto& out = d.blocks[b];
    for (std::size_t i = 0; i < kBlockFieldCount; ++i)
      out[i].assign(blocks * row_elements(kBlockFields[i].shape, J, S), 0.0f);
    auto col = [&](const char* name) { return out[field_index(kBlockFields, name)].data(); };
    for (std::size_t k = 0; k < blocks; ++k) {
      const std::size_t first = k * bs, count = std::min(bs, K - first);
      min_max_rows(root, 3, first, count, col("root_min_m") + k * 3, col("root_max_m") + k * 3);
      min_max_rows(kd, 3 * S, first, count, col("kd_min") + k * 3 * S, col("kd_max") + k * 3 * S);
    }
  }
}

}  // namespace mocap
