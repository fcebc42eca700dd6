// Tests for common/src/dynamics/kinematics.cpp: Euler conversions, local poses, forward kinematics.
#include "mocap/common/dynamics/kinematics.hpp"

#include <gtest/gtest.h>

#include <array>
#include <numbers>
#include <random>

#include "raw_clip_builder.hpp"

namespace mocap {
namespace {

using test::RawClipBuilder;
using C = Channel;

Eigen::Matrix3d axis_matrix(int axis, double deg) {
  return Eigen::AngleAxisd(deg * std::numbers::pi / 180.0, Eigen::Vector3d::Unit(axis))
      .toRotationMatrix();
}

const std::array<std::array<std::uint8_t, 3>, 6> kOrders = {
    {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}}};

TEST(EulerTest, QuaternionIsProductInListedOrderForAllSixOrders) {
  const std::array<double, 3> deg{30.0, -50.0, 70.0};
  for (const auto& order : kOrders) {
    const Eigen::Quaterniond q = euler_to_quaternion(order, deg);
    const Eigen::Matrix3d expect = axis_matrix(order[0], deg[0]) * axis_matrix(order[1], deg[1]) *
                                   axis_matrix(order[2], deg[2]);
    EXPECT_TRUE(q.toRotationMatrix().isApprox(expect, 1e-12));
  }
}

TEST(EulerTest, RoundTripAllOrdersRandomAngles) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> any(-179.0, 179.0), mid(-89.0, 89.0);
  for (const auto& order : kOrders) {
    for (int i = 0; i < 500; ++i) {
      const std::array<double, 3> deg{any(rng), mid(rng), any(rng)};
      const Eigen::Quaterniond q = euler_to_quaternion(order, deg);
      const Eigen::Vector3d back = quaternion_to_euler(q, order);
      EXPECT_NEAR(back[0], deg[0], 1e-7);
      EXPECT_NEAR(back[1], deg[1], 1e-7);
      EXPECT_NEAR(back[2], deg[2], 1e-7);
    }
  }
}

TEST(EulerTest, GimbalLockStillGivesTheSameRotation) {
  for (const auto& order : kOrders) {
    const std::array<double, 3> deg{25.0, 90.0, 40.0};
    const Eigen::Quaterniond q = euler_to_quaternion(order, deg);
    const Eigen::Vector3d back = quaternion_to_euler(q, order);
    const Eigen::Quaterniond q2 =
        euler_to_quaternion(order, std::array<double, 3>{back[0], back[1], back[2]});
    EXPECT_NEAR(std::abs(q.dot(q2)), 1.0, 1e-9);
  }
}

RawClip chain_clip() {
  RawClipBuilder b;
  const int root =
      b.joint("Hips", -1, {0, 0, 0},
              {C::Xposition, C::Yposition, C::Zposition, C::Zrotation, C::Xrotation, C::Yrotation});
  const int child = b.joint("Spine", root, {1, 0, 0}, {C::Zrotation, C::Xrotation, C::Yrotation});
  b.end_site(child, {0, 2, 0});
  // Root at (1,2,3) turned +90 deg about Y; the child bends +90 deg about Z.
  b.frame({1, 2, 3, 0, 0, 90, 90, 0, 0});
  return b.build();
}

TEST(ForwardKinematicsTest, TwoJointChainByHand) {
  const RawClip clip = chain_clip();
  const Skeleton skel = build_skeleton(clip, 1.0);
  LocalPose local;
  WorldPose world;
  local_pose_from_row(skel, clip.frame(0), local);
  forward_kinematics(skel, local, world);
  // Ry(90) maps +X to -Z: child at (1, 2, 3 - 1).
  EXPECT_TRUE(world.positions_m[0].isApprox(Eigen::Vector3d(1, 2, 3)));
  EXPECT_TRUE(world.positions_m[1].isApprox(Eigen::Vector3d(1, 2, 2), 1e-12));
  // End Site (0,2,0) in the child frame: Rz(90) maps +Y to -X, then Ry(90) maps -X to +Z.
  std::vector<Eigen::Vector3d> ends;
  end_site_positions(skel, world, ends);
  EXPECT_TRUE(ends[1].isApprox(Eigen::Vector3d(1, 2, 4), 1e-12));
  EXPECT_TRUE(ends[0].isApprox(world.positions_m[0]));  // no End Site: its own origin
}

TEST(ForwardKinematicsTest, PositionChannelsReplaceTheOffset) {
  RawClipBuilder b;
  const int root = b.joint("joint_Root", -1, {0, 0, 0}, {});
  b.joint("Hips", root, {0.8, 94.0, -452.0}, {C::Xposition, C::Yposition, C::Zposition});
  b.frame({10, 90, 20});
  const RawClip clip = b.build();
  const Skeleton skel = build_skeleton(clip, 0.01);
  LocalPose local;
  WorldPose world;
  local_pose_from_row(skel, clip.frame(0), local);
  forward_kinematics(skel, local, world);
  EXPECT_TRUE(world.positions_m[1].isApprox(Eigen::Vector3d(0.10, 0.90, 0.20), 1e-12));
}

TEST(ForwardKinematicsTest, MissingPositionAxesKeepTheOffset) {
  RawClipBuilder b;
  b.joint("Hips", -1, {5, 6, 7}, {C::Yposition});
  b.frame({100});
  const RawClip clip = b.build();
  const Skeleton skel = build_skeleton(clip, 1.0);
  LocalPose local;
  local_pose_from_row(skel, clip.frame(0), local);
  EXPECT_TRUE(local.translations_m[0].isApprox(Eigen::Vector3d(5, 100, 7)));
}

TEST(ForwardKinematicsTest, SeveralRootsAreIndependentTrees) {
  RawClipBuilder b;
  const int a = b.joint("A", -1, {0, 0, 0}, {C::Xposition, C::Yposition, C::Zposition});
  b.joint("A1", a, {1, 0, 0}, {});
  const int c = b.joint("B", -1, {0, 0, 0}, {C::Xposition, C::Yposition, C::Zposition});
  b.joint("B1", c, {0, 1, 0}, {});
  b.frame({1, 1, 1, -1, -1, -1});
  const RawClip clip = b.build();
  const ClipMotion m = clip_motion_from_raw(clip, 1.0);
  EXPECT_TRUE(m.position(0, 1).isApprox(Eigen::Vector3d(2, 1, 1)));
  EXPECT_TRUE(m.position(0, 3).isApprox(Eigen::Vector3d(-1, 0, -1)));
}

TEST(ForwardKinematicsTest, TranslationScalesLengthenBones) {
  const RawClip clip = chain_clip();
  Skeleton skel = build_skeleton(clip, 1.0);
  skel.translation_scales = {1.0, 2.0};
  LocalPose local;
  WorldPose world;
  local_pose_from_row(skel, clip.frame(0), local);
  forward_kinematics(skel, local, world);
  EXPECT_TRUE(world.positions_m[1].isApprox(Eigen::Vector3d(1, 2, 1), 1e-12));
}

// The batched, TBB-parallel clip path equals the one-frame reference.
TEST(ForwardKinematicsTest, ClipMotionEqualsPerFrameReference) {
  RawClipBuilder b;
  int parent =
      b.joint("Hips", -1, {0, 0, 0},
              {C::Xposition, C::Yposition, C::Zposition, C::Yrotation, C::Xrotation, C::Zrotation});
  for (int j = 1; j < 20; ++j)
    parent = b.joint("J" + std::to_string(j), j % 4 == 0 ? 0 : parent, {0.1 * j, 0.2, -0.05},
                     {C::Zrotation, C::Yrotation, C::Xrotation});
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> deg(-180.0, 180.0);
  const std::size_t channels = 6 + 19 * 3;
  for (int f = 0; f < 2000; ++f) {
    std::vector<double> row(channels);
    for (double& v : row) v = deg(rng);
    b.frame(row);
  }
  const RawClip clip = b.build();
  const ClipMotion m = clip_motion_from_raw(clip, 0.01);
  ASSERT_EQ(m.frame_count, 2000u);
  LocalPose local;
  WorldPose world;
  for (std::size_t f = 0; f < m.frame_count; f += 97) {
    local_pose_from_row(m.skeleton, clip.frame(f), local);
    forward_kinematics(m.skeleton, local, world);
    for (std::size_t j = 0; j < m.joint_count(); ++j) {
      EXPECT_EQ(m.position(f, j), world.positions_m[j]);
      EXPECT_EQ(m.rotation(f, j).coeffs(), world.rotations[j].coeffs());
    }
  }
  // Without the forward kinematics: the same skeleton and local poses, no world poses.
  const ClipMotion l = clip_locals_from_raw(clip, 0.01);
  EXPECT_EQ(l.frame_count, m.frame_count);
  EXPECT_EQ(l.frame_time_s, m.frame_time_s);
  EXPECT_EQ(l.skeleton.names, m.skeleton.names);
  EXPECT_EQ(l.skeleton.parents, m.skeleton.parents);
  ASSERT_EQ(l.local_rotations.size(), m.local_rotations.size());
  ASSERT_EQ(l.local_translations_m.size(), m.local_translations_m.size());
  for (std::size_t i = 0; i < l.local_rotations.size(); ++i) {
    ASSERT_EQ(l.local_rotations[i].coeffs(), m.local_rotations[i].coeffs());
    ASSERT_EQ(l.local_translations_m[i], m.local_translations_m[i]);
  }
  EXPECT_TRUE(l.world_positions_m.empty());
  EXPECT_TRUE(l.world_rotations.empty());
}

}  // namespace
}  // namespace mocap
