// Index frame arrays from a clip's dynamics, and the dynamics from an
// index's stored rows (index_frames.hpp).
#include "mocap/common/dynamics/index_frames.hpp"

#include <stdexcept>
#include <string>
#include <vector>

#include "mocap/common/dynamics/energy.hpp"

namespace mocap {
namespace {

/// Quaternion as (w, x, y, z) with w >= 0, as the index stores rotations.
void put_quaternion(const Eigen::Quaterniond& q, float* out) {
  const double s = q.w() < 0.0 ? -1.0 : 1.0;
  out[0] = static_cast<float>(s * q.w());
  out[1] = static_cast<float>(s * q.x());
  out[2] = static_cast<float>(s * q.y());
  out[3] = static_cast<float>(s * q.z());
}

void put_vec3s(const std::vector<Eigen::Vector3d>& v, float* out) {
  for (std::size_t i = 0; i < v.size(); ++i)
    for (int a = 0; a < 3; ++a)
      out[i * 3 + static_cast<std::size_t>(a)] = static_cast<float>(v[i][a]);
}

}  // namespace

ClipDynamics clip_dynamics_from_rows(const DynamicsModel& model, const StoredClipRows& rows) {
  const std::size_t J = model.parents.size(), K = rows.frame_count;
  if (K == 0) throw std::invalid_argument("clip_dynamics_from_rows: a clip without frames");
  if (rows.local_rotations.size() != K * J * 4 || rows.joint_positions_m.size() != K * J * 3)
    throw std::invalid_argument("clip_dynamics_from_rows: rows do not match the skeleton");
  std::vector<Eigen::Vector3d> positions(K * J);
  std::vector<Eigen::Quaterniond> world(K * J);
  for (std::size_t f = 0; f < K; ++f)
    for (std::size_t j = 0; j < J; ++j) {
      const std::size_t i = f * J + j;
      const float* q = &rows.local_rotations[i * 4];
      const float* x = &rows.joint_positions_m[i * 3];
      const Eigen::Quaterniond local = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized();
      const int p = model.parents[j];
      world[i] = p < 0 ? local : world[f * J + static_cast<std::size_t>(p)] * local;
      positions[i] = Eigen::Vector3d(x[0], x[1], x[2]);
    }
  ClipDynamics dyn;
  compute_clip_dynamics(model, K, rows.frame_time_s, positions.data(), world.data(), dyn);
  return dyn;
}

void stored_rows(std::span<const Eigen::Quaterniond> local,
                 std::span<const Eigen::Vector3d> positions, float* local_out,
                 float* positions_out) {
  if (local.size() != positions.size())
    throw std::invalid_argument("stored_rows: as many rotations as positions");
  for (std::size_t i = 0; i < local.size(); ++i) {
    put_quaternion(local[i], local_out + i * 4);
    for (int a = 0; a < 3; ++a)
      positions_out[i * 3 + static_cast<std::size_t>(a)] = static_cast<float>(positions[i][a]);
  }
}

ClipDynamics clip_dynamics_as_stored(const DynamicsModel& model, std::size_t frame_count,
                                     double frame_time_s, std::span<const Eigen::Quaterniond> local,
                                     std::span<const Eigen::Vector3d> positions) {
  const std::size_t J = model.parents.size();
  if (local.size() != frame_count * J || positions.size() != frame_count * J)
    throw std::invalid_argument("clip_dynamics_as_stored: rows do not match the skeleton");
  std::vector<float> lrot(local.size() * 4), jpos(positions.size() * 3);
  stored_rows(local, positions, lrot.data(), jpos.data());
  return clip_dynamics_from_rows(model, {lrot, jpos, frame_count, frame_time_s});
}

void derived_frame_rows(const DynamicsModel& model, const ClipDynamics& dyn, std::string_view field,
                        double transition_time_s, float* out) {
  const std::size_t K = dyn.frame_count, S = model.segments.size();
  if (field == "world_rotations") {
    for (std::size_t i = 0; i < dyn.rotations.size(); ++i)
      put_quaternion(dyn.rotations[i], out + i * 4);
  } else if (field == "segment_com_m") {
    put_vec3s(dyn.coms_m, out);
  } else if (field == "segment_com_velocity_mps") {
    put_vec3s(dyn.com_velocities_mps, out);
  } else if (field == "segment_angular_velocity_radps") {
    put_vec3s(dyn.angular_velocities_radps, out);
  } else if (field == "kd_features") {
    for (std::size_t f = 0; f < K; ++f)
      kd_feature(model, dyn.state(f), transition_time_s, out + f * 3 * S);
  } else if (field == "h_scan") {
    // energy.hpp's h scan values, one row per frame.
    constexpr std::size_t kF = HScanTable::kFields;
    static_assert(kF == 9, "index schema h_scan has 9 values per segment");
    for (std::size_t f = 0; f < K; ++f) h_scan_row(model, dyn.state(f), out + f * S * kF);
  } else {
    throw std::invalid_argument("derived_frame_rows: '" + std::string(field) +
                                "' is not a derived frame field");
  }
}

}  // namespace mocap
