#pragma once
// Hand-built skeletons, bodies and states for the energy-model tests
// (dynamics_test, energy_test, newton_euler_test): no parser, no anthropometry.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "mocap/common/body/body.hpp"
#include "mocap/common/body/skeleton.hpp"
#include "mocap/common/dynamics/dynamics.hpp"

namespace mocap::test {

/// A skeleton from names, parents and offsets (metres); no channels needed by
/// the energy code.
inline Skeleton make_skeleton(const std::vector<std::string>& names,
                              const std::vector<int>& parents,
                              const std::vector<Eigen::Vector3d>& offsets) {
  Skeleton s;
  s.names = names;
  s.parents = parents;
  s.offsets_m = offsets;
  s.end_sites_m.assign(names.size(), Eigen::Vector3d::Zero());
  s.has_end_site.assign(names.size(), 0);
  s.channels.assign(names.size(), JointChannelMap{});
  return s;
}

/// A segment with the given mass, COM and tip (joint frame) and a diagonal
/// inertia about the COM.
inline Segment make_segment(int joint, double mass, const Eigen::Vector3d& com,
                            const Eigen::Vector3d& tip, const Eigen::Vector3d& principal_moments) {
  Segment s;
  s.joint = joint;
  s.mass_kg = mass;
  s.com_local_m = com;
  s.tip_local_m = tip;
  s.length_m = tip.norm();
  s.inertia_local_kgm2 = principal_moments.asDiagonal();
  return s;
}

/// A random rotation (uniform enough for tests).
inline Eigen::Quaterniond random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
  return q.normalized();
}

inline Eigen::Vector3d random_vector(std::mt19937& rng, double scale) {
  std::uniform_real_distribution<double> u(-scale, scale);
  return {u(rng), u(rng), u(rng)};
}

/// A small humanoid-like tree: a massless dummy root (like Bandai Namco's
/// joint_Root), a pelvis, a spine, a head, two arms of two links and two legs
/// of two links plus feet. Masses, COMs and (non-diagonal) inertias are
/// arbitrary but physical.
struct TestBody {
  Skeleton skeleton;
  Body body;
  DynamicsModel model;
};

inline TestBody make_test_body(const EnergyParams& params = {}) {
  TestBody t;
  const std::vector<std::string> names = {
      "joint_Root", "Hips",       "Spine",      "Head",   "UpperArm_L", "LowerArm_L", "UpperArm_R",
      "LowerArm_R", "UpperLeg_L", "LowerLeg_L", "Foot_L", "UpperLeg_R", "LowerLeg_R", "Foot_R"};
  const std::vector<int> parents = {-1, 0, 1, 2, 2, 4, 2, 6, 1, 8, 9, 1, 11, 12};
  const std::vector<Eigen::Vector3d> offsets = {
      {0, 0, 0},     {0, 0.95, 0},     {0, 0.1, 0},   {0, 0.45, 0},    {0.18, 0.4, 0},
      {0.3, 0, 0},   {-0.18, 0.4, 0},  {-0.3, 0, 0},  {0.1, -0.05, 0}, {0, -0.42, 0},
      {0, -0.42, 0}, {-0.1, -0.05, 0}, {0, -0.42, 0}, {0, -0.42, 0}};
  t.skeleton = make_skeleton(names, parents, offsets);
  t.body.segments.resize(names.size());
  for (std::size_t j = 0; j < names.size(); ++j) t.body.segments[j].joint = static_cast<int>(j);
  auto set = [&](int j, double m, Eigen::Vector3d com, Eigen::Vector3d tip, Eigen::Vector3d d,
                 double tilt) {
    Segment s = make_segment(j, m, com, tip, d);
    // Rotate the principal axes a little so that inertias are not diagonal.
    const Eigen::Matrix3d r =
        Eigen::AngleAxisd(tilt, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    s.inertia_local_kgm2 = r * s.inertia_local_kgm2 * r.transpose();
    t.body.segments[static_cast<std::size_t>(j)] = s;
  };
  set(1, 10.0, {0, 0.05, 0}, {0, 0.1, 0}, {0.08, 0.09, 0.07}, 0.1);
  set(2, 25.0, {0, 0.22, 0}, {0, 0.45, 0}, {0.4, 0.3, 0.35}, 0.2);
  set(3, 5.0, {0, 0.1, 0}, {0, 0.22, 0}, {0.03, 0.02, 0.03}, 0.3);
  set(4, 2.0, {0.15, 0, 0}, {0.3, 0, 0}, {0.002, 0.015, 0.015}, 0.05);
  set(5, 1.5, {0.14, 0, 0}, {0.3, 0, 0}, {0.001, 0.01, 0.01}, 0.4);
  set(6, 2.0, {-0.15, 0, 0}, {-0.3, 0, 0}, {0.002, 0.015, 0.015}, 0.05);
  set(7, 1.5, {-0.14, 0, 0}, {-0.3, 0, 0}, {0.001, 0.01, 0.01}, 0.4);
  set(8, 7.0, {0, -0.18, 0}, {0, -0.42, 0}, {0.1, 0.02, 0.1}, 0.15);
  set(9, 3.0, {0, -0.2, 0}, {0, -0.42, 0}, {0.04, 0.005, 0.04}, 0.25);
  set(10, 1.0, {0, -0.03, 0.05}, {0, -0.06, 0.12}, {0.004, 0.004, 0.001}, 0.1);
  set(11, 7.0, {0, -0.18, 0}, {0, -0.42, 0}, {0.1, 0.02, 0.1}, 0.15);
  set(12, 3.0, {0, -0.2, 0}, {0, -0.42, 0}, {0.04, 0.005, 0.04}, 0.25);
  set(13, 1.0, {0, -0.03, 0.05}, {0, -0.06, 0.12}, {0.004, 0.004, 0.001}, 0.1);
  for (const Segment& s : t.body.segments) t.body.total_mass_kg += s.mass_kg;
  t.model = build_dynamics_model(t.skeleton, t.body, params);
  return t;
}

/// World pose of local rotations (root translation given) by forward kinematics.
inline void pose_from_locals(const Skeleton& skel, const Eigen::Vector3d& root_translation,
                             const std::vector<Eigen::Quaterniond>& locals,
                             std::vector<Eigen::Vector3d>& x, std::vector<Eigen::Quaterniond>& r) {
  const std::size_t n = skel.joint_count();
  x.resize(n);
  r.resize(n);
  for (std::size_t j = 0; j < n; ++j) {
    const int p = skel.parents[j];
    if (p < 0) {
      x[j] = root_translation;
      r[j] = locals[j];
    } else {
      const auto pp = static_cast<std::size_t>(p);
      x[j] = x[pp] + r[pp] * skel.offsets_m[j];
      r[j] = r[pp] * locals[j];
    }
  }
}

/// The body standing still in its rest pose (every local rotation the
/// identity), the root moved by `move` (metres): a static state, feet on
/// the ground at move = 0.
inline BodyState standing_state(const TestBody& t,
                                const Eigen::Vector3d& move = Eigen::Vector3d::Zero()) {
  const std::size_t n = t.model.joint_count();
  std::vector<Eigen::Quaterniond> locals(n, Eigen::Quaterniond::Identity());
  std::vector<Eigen::Vector3d> x;
  std::vector<Eigen::Quaterniond> r;
  pose_from_locals(t.skeleton, move, locals, x, r);
  BodyState s;
  static_state(t.model, PoseView{x.data(), r.data()}, s);
  return s;
}

/// A random state on the model: random pose near the rest pose (root moved,
/// joints bent by up to `bend` rad), random rates of the given scales.
inline BodyState random_state(const TestBody& t, std::mt19937& rng, double bend = 0.8,
                              double speed = 1.0, double accel = 5.0) {
  const std::size_t n = t.skeleton.joint_count();
  std::vector<Eigen::Quaterniond> locals(n, Eigen::Quaterniond::Identity());
  std::uniform_real_distribution<double> u(-bend, bend);
  for (std::size_t j = 1; j < n; ++j)
    locals[j] = Eigen::Quaterniond(Eigen::AngleAxisd(u(rng), random_vector(rng, 1.0).normalized()));
  std::vector<Eigen::Vector3d> x;
  std::vector<Eigen::Quaterniond> r;
  pose_from_locals(t.skeleton, Eigen::Vector3d(u(rng), 0.0, u(rng)), locals, x, r);
  BodyState s;
  set_state_pose(t.model, PoseView{x.data(), r.data()}, s);
  for (std::size_t j = 0; j < n; ++j) {
    s.com_velocities_mps[j] = random_vector(rng, speed);
    s.angular_velocities_radps[j] = random_vector(rng, 3.0 * speed);
    s.com_accelerations_mps2[j] = random_vector(rng, accel);
    s.angular_accelerations_radps2[j] = random_vector(rng, 3.0 * accel);
  }
  return s;
}

/// Rigid motion of a whole state: p -> rot * p + shift, R -> rot R, rates rotated.
inline BodyState transform_state(const BodyState& s, const Eigen::Quaterniond& rot,
                                 const Eigen::Vector3d& shift) {
  BodyState o = s;
  for (std::size_t j = 0; j < s.coms_m.size(); ++j) {
    o.joint_positions_m[j] = rot * s.joint_positions_m[j] + shift;
    o.rotations[j] = rot * s.rotations[j];
    o.coms_m[j] = rot * s.coms_m[j] + shift;
    o.com_velocities_mps[j] = rot * s.com_velocities_mps[j];
    o.com_accelerations_mps2[j] = rot * s.com_accelerations_mps2[j];
    o.angular_velocities_radps[j] = rot * s.angular_velocities_radps[j];
    o.angular_accelerations_radps2[j] = rot * s.angular_accelerations_radps2[j];
  }
  return o;
}

}  // namespace mocap::test
