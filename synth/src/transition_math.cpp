// Rotation exp / log, gap checks, the geodesic frame and the Hermite step
// (transition_math.hpp).
#include "transition_math.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "mocap/common/dynamics/dynamics.hpp"

namespace mocap::synth_detail {
namespace {

// One step of the cubic Hermite path from (x0, v0) to (x1, v1) over duration T, at time t.
template <class V>
V hermite(const V& x0, const V& v0, const V& x1, const V& v1, double T, double t) {
  const double s = t / T, s2 = s * s, s3 = s2 * s;
  return (2 * s3 - 3 * s2 + 1) * x0 + (s3 - 2 * s2 + s) * T * v0 + (-2 * s3 + 3 * s2) * x1 +
         (s3 - s2) * T * v1;
}

}  // namespace

Eigen::Quaterniond quat_exp(const Eigen::Vector3d& v) {
  const double a = v.norm();
  if (a < 1e-12) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(Eigen::AngleAxisd(a, v / a));
}

Eigen::Vector3d local_log(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return rotation_vector((a.conjugate() * b).normalized());
}

void check_gap(const GapProblem& gap) {
  if (gap.skeleton == nullptr) throw std::invalid_argument("gap: no skeleton");
  if (!(gap.frame_time_s > 0.0) || !std::isfinite(gap.frame_time_s))
    throw std::invalid_argument("gap: frame time must be > 0");
  const std::size_t n = gap.skeleton->joint_count();
  for (const SynthFrame* f : {&gap.before, &gap.start, &gap.goal, &gap.after})
    if (f->local_rotations.size() != n)
      throw std::invalid_argument("gap: frame has " + std::to_string(f->local_rotations.size()) +
                                  " joint rotations, the skeleton " + std::to_string(n));
  if (gap.range != nullptr && gap.range->has_range.size() != n)
    throw std::invalid_argument("gap: range of motion does not fit the skeleton");
}

void geodesic_frame(const SynthFrame& from, const SynthFrame& to, double s, SynthFrame& out) {
  out.root_position_m = (1.0 - s) * from.root_position_m + s * to.root_position_m;
  const std::size_t n = from.local_rotations.size();
  out.local_rotations.resize(n);
  for (std::size_t j = 0; j < n; ++j)
    out.local_rotations[j] = from.local_rotations[j].slerp(s, to.local_rotations[j]).normalized();
}

SynthFrame geodesic_step(const GapProblem& gap, const SynthFrame& cur, std::size_t remaining) {
  SynthFrame out;
  geodesic_frame(cur, gap.goal, 1.0 / static_cast<double>(remaining), out);
  return out;
}

SynthFrame hermite_step(const GapProblem& gap, const SynthFrame& prev, const SynthFrame& cur,
                        std::size_t remaining) {
  const double dt = gap.frame_time_s, T = static_cast<double>(remaining) * dt;
  SynthFrame out;
  const Eigen::Vector3d v0 = (cur.root_position_m - prev.root_position_m) / dt;
  const Eigen::Vector3d v1 = (gap.after.root_position_m - gap.goal.root_position_m) / dt;
  out.root_position_m = hermite(cur.root_position_m, v0, gap.goal.root_position_m, v1, T, dt);
  const std::size_t n = cur.local_rotations.size();
  out.local_rotations.resize(n);
  for (std::size_t j = 0; j < n; ++j) {
    const Eigen::Quaterniond& qg = gap.goal.local_rotations[j];
    const Eigen::Vector3d x0 = local_log(qg, cur.local_rotations[j]);
    const Eigen::Vector3d xp = local_log(qg, prev.local_rotations[j]);
    const Eigen::Vector3d w0 = (x0 - xp) / dt;
    const Eigen::Vector3d w1 = local_log(qg, gap.after.local_rotations[j]) / dt;
    const Eigen::Vector3d x = hermite(x0, w0, Eigen::Vector3d::Zero().eval(), w1, T, dt);
    out.local_rotations[j] = (qg * quat_exp(x)).normalized();
  }
  return out;
}

}  // namespace mocap::synth_detail
