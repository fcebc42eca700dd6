// The baseline transitions A* is compared with: slerp (root linear, joints
// slerped) and inertialization (Bollo's quintic decay of the start offset
// toward the goal's own track); and the methods' names.
#include <algorithm>
#include <vector>

#include "mocap/synth/synth.hpp"
#include "transition_math.hpp"

namespace mocap {
namespace {

using synth_detail::local_log;
using synth_detail::quat_exp;

// Bollo's inertialization decay of a scalar offset x0 with rate v0 over t1, at t.
double inertialize_decay(double x0, double v0, double t1, double t) {
  if (x0 == 0.0 && v0 == 0.0) return 0.0;
  if (x0 > 0.0 ? v0 > 0.0 : v0 < 0.0) v0 = 0.0;  // never push the offset further out
  if (v0 != 0.0) t1 = std::min(t1, -5.0 * x0 / v0);
  if (t >= t1 || t1 <= 0.0) return 0.0;
  const double t12 = t1 * t1;
  const double a0 = (-8.0 * v0 * t1 - 20.0 * x0) / t12;
  const double A = -(a0 * t12 + 6.0 * v0 * t1 + 12.0 * x0) / (2.0 * t12 * t12 * t1);
  const double B = (3.0 * a0 * t12 + 16.0 * v0 * t1 + 30.0 * x0) / (2.0 * t12 * t12);
  const double C = -(3.0 * a0 * t12 + 12.0 * v0 * t1 + 20.0 * x0) / (2.0 * t12 * t1);
  const double t2 = t * t, t3 = t2 * t;
  return A * t3 * t2 + B * t2 * t2 + C * t3 + 0.5 * a0 * t2 + v0 * t + x0;
}
// The same along the offset's direction (its rate projected on it).
Eigen::Vector3d inertialize_decay(const Eigen::Vector3d& x0, const Eigen::Vector3d& v0, double t1,
                                  double t) {
  const double m = x0.norm();
  if (m < 1e-12) return Eigen::Vector3d::Zero();
  const Eigen::Vector3d dir = x0 / m;
  return dir * inertialize_decay(m, v0.dot(dir), t1, t);
}

}  // namespace

const char* transition_method_name(TransitionMethod m) {
  switch (m) {
    case TransitionMethod::astar:
      return "astar";
    case TransitionMethod::slerp:
      return "slerp";
    case TransitionMethod::inertialize:
      return "inertialize";
  }
  return "?";
}

std::vector<SynthFrame> slerp_transition(const GapProblem& gap, std::size_t frames) {
  synth_detail::check_gap(gap);
  std::vector<SynthFrame> out(frames);
  for (std::size_t i = 0; i < frames; ++i) {
    const double s = static_cast<double>(i + 1) / static_cast<double>(frames + 1);
    synth_detail::geodesic_frame(gap.start, gap.goal, s, out[i]);
  }
  return out;
}

std::vector<SynthFrame> inertialize_transition(const GapProblem& gap, std::size_t frames) {
  synth_detail::check_gap(gap);
  const double dt = gap.frame_time_s;
  const double t1 = static_cast<double>(frames + 1) * dt;
  const std::size_t n = gap.skeleton->joint_count();
  // Target track: the goal extrapolated backwards with its own rates.
  const Eigen::Vector3d vg = (gap.after.root_position_m - gap.goal.root_position_m) / dt;
  auto target_root = [&](double tau) {
    return Eigen::Vector3d(gap.goal.root_position_m - vg * tau);
  };
  std::vector<Eigen::Vector3d> wg(n);
  for (std::size_t j = 0; j < n; ++j)
    wg[j] = local_log(gap.goal.local_rotations[j], gap.after.local_rotations[j]) / dt;
  auto target_rot = [&](std::size_t j, double tau) {
    return Eigen::Quaterniond((gap.goal.local_rotations[j] * quat_exp(-wg[j] * tau)).normalized());
  };
  // Offsets at the start (value and rate).
  const Eigen::Vector3d px0 = gap.start.root_position_m - target_root(t1);
  const Eigen::Vector3d pxm = gap.before.root_position_m - target_root(t1 + dt);
  const Eigen::Vector3d pv0 = (px0 - pxm) / dt;
  std::vector<Eigen::Vector3d> rx0(n), rv0(n);
  for (std::size_t j = 0; j < n; ++j) {
    rx0[j] = local_log(target_rot(j, t1), gap.start.local_rotations[j]);
    const Eigen::Vector3d xm = local_log(target_rot(j, t1 + dt), gap.before.local_rotations[j]);
    rv0[j] = (rx0[j] - xm) / dt;
  }
  std::vector<SynthFrame> out(frames);
  for (std::size_t i = 0; i < frames; ++i) {
    const double t = static_cast<double>(i + 1) * dt, tau = t1 - t;
    SynthFrame& f = out[i];
    f.root_position_m = target_root(tau) + inertialize_decay(px0, pv0, t1, t);
    f.local_rotations.resize(n);
    for (std::size_t j = 0; j < n; ++j)
      f.local_rotations[j] =
          (target_rot(j, tau) * quat_exp(inertialize_decay(rx0[j], rv0[j], t1, t))).normalized();
  }
  return out;
}

}  // namespace mocap
