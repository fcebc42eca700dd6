// DynamicsModel, states and per-frame finite-difference dynamics on hand-built data.
#include "mocap/common/dynamics/dynamics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "energy_fixtures.hpp"
#include "mocap/common/util/error.hpp"

namespace mocap {
namespace {

using test::make_test_body;

// ---------------------------------------------------------------- validity

TEST(DynamicsModel, RejectsBodyOfWrongSize) {
  auto t = make_test_body();
  t.body.segments.pop_back();
  EXPECT_THROW(build_dynamics_model(t.skeleton, t.body), InputError);
}

TEST(DynamicsModel, RejectsNegativeOrNonFiniteMass) {
  auto t = make_test_body();
  t.body.segments[3].mass_kg = -1.0;
  EXPECT_THROW(build_dynamics_model(t.skeleton, t.body), InputError);
  t.body.segments[3].mass_kg = std::nan("");
  EXPECT_THROW(build_dynamics_model(t.skeleton, t.body), InputError);
}

TEST(DynamicsModel, RejectsIndefiniteInertiaAndBadParameters) {
  auto t = make_test_body();
  t.body.segments[4].inertia_local_kgm2(0, 0) = -1.0;
  EXPECT_THROW(build_dynamics_model(t.skeleton, t.body), InputError);
  auto u = make_test_body();
  EnergyParams p;
  p.friction_coefficient = -0.5;
  EXPECT_THROW(build_dynamics_model(u.skeleton, u.body, p), InputError);
}

TEST(DynamicsModel, SegmentListsFollowTheTree) {
  const auto t = make_test_body();
  const DynamicsModel& m = t.model;
  EXPECT_EQ(m.joint_count(), 14u);
  EXPECT_EQ(m.segments.size(), 13u);  // all but the dummy root
  ASSERT_EQ(m.body_roots.size(), 1u);
  EXPECT_EQ(m.root(), 1);  // Hips, not joint_Root
  EXPECT_FALSE(m.is_term_joint[0]);
  for (int j = 1; j < 14; ++j) EXPECT_TRUE(m.is_term_joint[static_cast<std::size_t>(j)]) << j;
  double total = 0.0;
  for (const Segment& s : t.body.segments) total += s.mass_kg;
  EXPECT_DOUBLE_EQ(m.total_mass_kg, total);
  // Principal decomposition reproduces the inertia.
  for (int j : m.segments) {
    const auto jj = static_cast<std::size_t>(j);
    const Eigen::Matrix3d p = m.principal_frames[jj].toRotationMatrix();
    const Eigen::Matrix3d back = p * m.principal_moments_kgm2[jj].asDiagonal() * p.transpose();
    EXPECT_LT((back - m.inertias_local_kgm2[jj]).norm(), 1e-12) << j;
  }
}

TEST(DynamicsModel, MasslessJointBetweenSegmentsIsATermJoint) {
  // root(massive) -> mid(massless, zero length) -> leaf(massive): mid transmits.
  const Skeleton s = test::make_skeleton({"a", "mid", "leaf", "tip"}, {-1, 0, 1, 2},
                                         {{0, 1, 0}, {0, 0.3, 0}, {0, 0, 0}, {0, 0.2, 0}});
  Body b;
  b.segments = {test::make_segment(0, 2.0, {0, 0.15, 0}, {0, 0.3, 0}, {0.01, 0.001, 0.01}),
                test::make_segment(1, 0.0, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}),
                test::make_segment(2, 1.0, {0, 0.1, 0}, {0, 0.2, 0}, {0.005, 0.001, 0.005}),
                test::make_segment(3, 0.0, {0, 0, 0}, {0, 0, 0}, {0, 0, 0})};
  const DynamicsModel m = build_dynamics_model(s, b);
  EXPECT_EQ(m.segments, (std::vector<int>{0, 2}));
  EXPECT_EQ(m.term_joints, (std::vector<int>{0, 1, 2}));  // "tip" carries nothing below
  EXPECT_EQ(m.body_roots, (std::vector<int>{0}));
}

// ---------------------------------------------------------------- utilities

TEST(RotationVector, AngleAxisRoundTripAndShortWay) {
  const Eigen::Vector3d axis = Eigen::Vector3d(1, -2, 0.5).normalized();
  for (double angle : {0.0, 1e-12, 1e-6, 0.3, 2.0, 3.1}) {
    const Eigen::Quaterniond q(Eigen::AngleAxisd(angle, axis));
    EXPECT_LT((rotation_vector(q) - angle * axis).norm(), 1e-12) << angle;
    // -q is the same rotation.
    Eigen::Quaterniond nq = q;
    nq.coeffs() = -nq.coeffs();
    EXPECT_LT((rotation_vector(nq) - angle * axis).norm(), 1e-12) << angle;
  }
  // An angle beyond pi comes back the short way.
  const Eigen::Quaterniond q(Eigen::AngleAxisd(1.5 * std::numbers::pi, axis));
  EXPECT_LT((rotation_vector(q) + 0.5 * std::numbers::pi * axis).norm(), 1e-12);
}

TEST(Heading, TwistAboutVerticalIgnoresTilt) {
  for (double psi : {-3.0, -1.0, 0.0, 0.5, 2.5}) {
    const Eigen::Quaterniond tilt(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitX()));
    const Eigen::Quaterniond q =
        Eigen::Quaterniond(Eigen::AngleAxisd(psi, Eigen::Vector3d::UnitY())) * tilt;
    EXPECT_NEAR(heading_rad(q), psi, 1e-12);
  }
}

// ---------------------------------------------------------------- states

TEST(BodyState, StaticStateHasComsAndZeroRates) {
  const auto t = make_test_body();
  std::mt19937 rng(1);
  const BodyState moving = test::random_state(t, rng);
  BodyState s;
  static_state(t.model, PoseView{moving.joint_positions_m.data(), moving.rotations.data()}, s);
  for (std::size_t j = 0; j < t.model.joint_count(); ++j) {
    EXPECT_LT((s.coms_m[j] -
               (moving.joint_positions_m[j] + moving.rotations[j] * t.model.coms_local_m[j]))
                  .norm(),
              1e-15);
    EXPECT_EQ(s.com_velocities_mps[j], Eigen::Vector3d::Zero());
    EXPECT_EQ(s.angular_accelerations_radps2[j], Eigen::Vector3d::Zero());
  }
}

// A clip with analytic motion: root translation c(t) = c0 + v0 t + a0 t^2 / 2,
// every joint rotating about a fixed world axis by theta(t) = w0 t + al t^2 / 2.
struct AnalyticClip {
  std::vector<Eigen::Vector3d> x;
  std::vector<Eigen::Quaterniond> r;
};

AnalyticClip analytic_clip(const test::TestBody& t, std::size_t frames, double dt,
                           const Eigen::Vector3d& v0, const Eigen::Vector3d& a0,
                           const Eigen::Vector3d& axis, double w0, double al) {
  const std::size_t n = t.model.joint_count();
  AnalyticClip c;
  c.x.resize(frames * n);
  c.r.resize(frames * n);
  std::vector<Eigen::Quaterniond> locals(n, Eigen::Quaterniond::Identity());
  for (std::size_t f = 0; f < frames; ++f) {
    const double time = static_cast<double>(f) * dt;
    const double theta = w0 * time + 0.5 * al * time * time;
    // The whole body turns rigidly about `axis` through the root and translates.
    const Eigen::Quaterniond turn(Eigen::AngleAxisd(theta, axis));
    std::vector<Eigen::Vector3d> x;
    std::vector<Eigen::Quaterniond> r;
    test::pose_from_locals(t.skeleton, Eigen::Vector3d::Zero(), locals, x, r);
    const Eigen::Vector3d shift =
        Eigen::Vector3d(0.2, 0.1, -0.3) + v0 * time + 0.5 * a0 * time * time;
    for (std::size_t j = 0; j < n; ++j) {
      c.x[f * n + j] = turn * x[j] + shift;
      c.r[f * n + j] = turn * r[j];
    }
  }
  return c;
}

TEST(ClipDynamics, ExactForUniformlyAcceleratedTranslationAndRotation) {
  const auto t = make_test_body();
  const std::size_t frames = 9, n = t.model.joint_count();
  const double dt = 1.0 / 30.0;
  const Eigen::Vector3d v0(0.5, -0.2, 1.0), a0(0.3, 2.0, -1.0);
  const Eigen::Vector3d axis = Eigen::Vector3d(0.2, 1.0, 0.1).normalized();
  const double w0 = 0.7, al = 1.3;
  const AnalyticClip c = analytic_clip(t, frames, dt, v0, a0, axis, w0, al);
  ClipDynamics d;
  compute_clip_dynamics(t.model, frames, dt, c.x.data(), c.r.data(), d);
  ASSERT_EQ(d.frame_count, frames);
  ASSERT_EQ(d.joint_count, n);
  for (std::size_t f = 1; f + 1 < frames; ++f) {
    const double time = static_cast<double>(f) * dt;
    const double w = w0 + al * time;
    for (std::size_t j = 0; j < n; ++j) {
      const StateView s = d.state(f);
      // COM of a rigidly turning + translating body: v = v_shift + w x (c - pivot)...
      // checked through the angular rates, which are exact for a fixed axis:
      EXPECT_LT((s.angular_velocities_radps[j] - w * axis).norm(), 1e-9) << f << " " << j;
      EXPECT_LT((s.angular_accelerations_radps2[j] - al * axis).norm(), 1e-7) << f << " " << j;
    }
  }
  // Pure translation (no turn): COM rates are exact for a quadratic path.
  const AnalyticClip tr = analytic_clip(t, frames, dt, v0, a0, axis, 0.0, 0.0);
  compute_clip_dynamics(t.model, frames, dt, tr.x.data(), tr.r.data(), d);
  for (std::size_t f = 1; f + 1 < frames; ++f) {
    const double time = static_cast<double>(f) * dt;
    for (std::size_t j = 0; j < n; ++j) {
      EXPECT_LT((d.state(f).com_velocities_mps[j] - (v0 + a0 * time)).norm(), 1e-10);
      EXPECT_LT((d.state(f).com_accelerations_mps2[j] - a0).norm(), 1e-7);
      EXPECT_LT(d.state(f).angular_velocities_radps[j].norm(), 1e-12);
    }
  }
  // Ends: one-sided velocity (the first / last half-step rate), neighbour's acceleration.
  for (std::size_t j = 0; j < n; ++j) {
    EXPECT_LT((d.state(0).com_velocities_mps[j] - (v0 + 0.5 * a0 * dt)).norm(), 1e-10);
    const double tl = static_cast<double>(frames - 1) * dt;
    EXPECT_LT((d.state(frames - 1).com_velocities_mps[j] - (v0 + a0 * (tl - 0.5 * dt))).norm(),
              1e-10);
    EXPECT_LT((d.state(0).com_accelerations_mps2[j] - a0).norm(), 1e-7);
    EXPECT_LT((d.state(frames - 1).com_accelerations_mps2[j] - a0).norm(), 1e-7);
  }
}

TEST(ClipDynamics, RigidTurnGivesConsistentComVelocity) {
  // For a rigid turn about a fixed axis through the moving shift point, the
  // COM velocity is v_shift + w x (c - shift_point) to second order in dt.
  const auto t = make_test_body();
  const std::size_t frames = 5, n = t.model.joint_count();
  const double dt = 1.0 / 240.0;
  const Eigen::Vector3d v0(0.5, 0.0, 1.0), axis = Eigen::Vector3d::UnitY();
  const double w0 = 2.0;
  const AnalyticClip c = analytic_clip(t, frames, dt, v0, Eigen::Vector3d::Zero(), axis, w0, 0.0);
  ClipDynamics d;
  compute_clip_dynamics(t.model, frames, dt, c.x.data(), c.r.data(), d);
  const std::size_t f = 2;
  const double time = static_cast<double>(f) * dt;
  const Eigen::Vector3d pivot = Eigen::Vector3d(0.2, 0.1, -0.3) + v0 * time;
  for (std::size_t j = 0; j < n; ++j) {
    const Eigen::Vector3d expect = v0 + (w0 * axis).cross(d.state(f).coms_m[j] - pivot);
    EXPECT_LT((d.state(f).com_velocities_mps[j] - expect).norm(), 1e-4 * (1.0 + expect.norm()))
        << j;
  }
}

TEST(ClipDynamics, ShortClips) {
  const auto t = make_test_body();
  const std::size_t n = t.model.joint_count();
  const AnalyticClip c = analytic_clip(t, 2, 0.1, Eigen::Vector3d(1, 0, 0), Eigen::Vector3d::Zero(),
                                       Eigen::Vector3d::UnitY(), 1.0, 0.0);
  ClipDynamics d;
  compute_clip_dynamics(t.model, 1, 0.1, c.x.data(), c.r.data(), d);
  for (std::size_t j = 0; j < n; ++j) {
    EXPECT_EQ(d.state(0).com_velocities_mps[j], Eigen::Vector3d::Zero());
    EXPECT_EQ(d.state(0).angular_velocities_radps[j], Eigen::Vector3d::Zero());
  }
  compute_clip_dynamics(t.model, 2, 0.1, c.x.data(), c.r.data(), d);
  for (std::size_t f = 0; f < 2; ++f)
    for (std::size_t j = 0; j < n; ++j) {
      EXPECT_LT((d.state(f).angular_velocities_radps[j] - Eigen::Vector3d::UnitY()).norm(), 1e-12);
      EXPECT_EQ(d.state(f).com_accelerations_mps2[j], Eigen::Vector3d::Zero());
      EXPECT_LT(
          (d.state(f).com_velocities_mps[j] - (d.state(1).coms_m[j] - d.state(0).coms_m[j]) / 0.1)
              .norm(),
          1e-12);
    }
}

TEST(ClipDynamics, SequenceStateMatchesClipInside) {
  const auto t = make_test_body();
  const std::size_t frames = 6, n = t.model.joint_count();
  const double dt = 1.0 / 30.0;
  // Non-rigid motion: random local rotations drifting.
  std::mt19937 rng(7);
  std::vector<Eigen::Vector3d> xs(frames * n);
  std::vector<Eigen::Quaterniond> rs(frames * n);
  std::vector<Eigen::Vector3d> axes(n);
  for (auto& a : axes) a = test::random_vector(rng, 1.0).normalized();
  for (std::size_t f = 0; f < frames; ++f) {
    std::vector<Eigen::Quaterniond> locals(n);
    for (std::size_t j = 0; j < n; ++j)
      locals[j] = Eigen::Quaterniond(
          Eigen::AngleAxisd(0.1 * static_cast<double>(f * (j + 1)) * 0.2, axes[j]));
    std::vector<Eigen::Vector3d> x;
    std::vector<Eigen::Quaterniond> r;
    test::pose_from_locals(t.skeleton, Eigen::Vector3d(0.05 * static_cast<double>(f), 0, 0), locals,
                           x, r);
    std::copy(x.begin(), x.end(), xs.begin() + static_cast<std::ptrdiff_t>(f * n));
    std::copy(r.begin(), r.end(), rs.begin() + static_cast<std::ptrdiff_t>(f * n));
  }
  ClipDynamics d;
  compute_clip_dynamics(t.model, frames, dt, xs.data(), rs.data(), d);
  auto pose = [&](std::size_t f) { return PoseView{&xs[f * n], &rs[f * n]}; };
  BodyState s;
  const PoseView p2 = pose(2), p3 = pose(3), p4 = pose(4);
  sequence_state(t.model, &p2, p3, &p4, dt, s);
  for (std::size_t j = 0; j < n; ++j) {
    EXPECT_LT((s.com_velocities_mps[j] - d.state(3).com_velocities_mps[j]).norm(), 1e-12);
    EXPECT_LT((s.com_accelerations_mps2[j] - d.state(3).com_accelerations_mps2[j]).norm(), 1e-9);
    EXPECT_LT((s.angular_velocities_radps[j] - d.state(3).angular_velocities_radps[j]).norm(),
              1e-12);
    EXPECT_LT(
        (s.angular_accelerations_radps2[j] - d.state(3).angular_accelerations_radps2[j]).norm(),
        1e-9);
  }
  // One neighbour: one-sided velocity, zero acceleration.
  sequence_state(t.model, nullptr, pose(0), &p2, 2.0 * dt, s);
  for (std::size_t j = 0; j < n; ++j) {
    EXPECT_LT((s.com_velocities_mps[j] - (d.state(2).coms_m[j] - d.state(0).coms_m[j]) / (2.0 * dt))
                  .norm(),
              1e-12);
    EXPECT_EQ(s.com_accelerations_mps2[j], Eigen::Vector3d::Zero());
  }
}

TEST(ClipDynamics, RejectsClipOfOtherSkeleton) {
  const auto t = make_test_body();
  ClipMotion m;
  m.skeleton = test::make_skeleton({"a"}, {-1}, {{0, 0, 0}});
  m.frame_count = 1;
  m.frame_time_s = 0.1;
  m.world_positions_m.assign(1, Eigen::Vector3d::Zero());
  m.world_rotations.assign(1, Eigen::Quaterniond::Identity());
  EXPECT_THROW(compute_clip_dynamics(t.model, m), InputError);
}

}  // namespace
}  // namespace mocap
