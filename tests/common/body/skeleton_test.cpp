// Tests for common/src/body/skeleton.cpp: validity first, then the channel layout and ids.
#include "mocap/common/body/skeleton.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "mocap/common/util/error.hpp"
#include "raw_clip_builder.hpp"

namespace mocap {
namespace {

using test::RawClipBuilder;
using C = Channel;

TEST(SkeletonValidityTest, RejectsNonPositiveOrNonFiniteScale) {
  RawClipBuilder b;
  b.joint("Hips", -1, {0, 0, 0}, {});
  const RawClip clip = b.build();
  EXPECT_THROW(build_skeleton(clip, 0.0), InputError);
  EXPECT_THROW(build_skeleton(clip, -1.0), InputError);
  EXPECT_THROW(build_skeleton(clip, NAN), InputError);
  EXPECT_THROW(build_skeleton(clip, INFINITY), InputError);
}

TEST(SkeletonValidityTest, RejectsChildBeforeParent) {
  RawClip clip;
  clip.source = "x.bvh";
  clip.joints.resize(2);
  clip.joints[0].name = "A";
  clip.joints[0].parent = 1;
  clip.joints[1].name = "B";
  clip.joints[1].parent = -1;
  EXPECT_THROW(build_skeleton(clip, 1.0), InputError);
}

TEST(SkeletonValidityTest, RejectsFourRotationsAndRepeatedPositions) {
  {
    RawClipBuilder b;
    b.joint("Hips", -1, {0, 0, 0}, {C::Xrotation, C::Yrotation, C::Zrotation, C::Xrotation});
    EXPECT_THROW(build_skeleton(b.build(), 1.0), InputError);
  }
  {
    RawClipBuilder b;
    b.joint("Hips", -1, {0, 0, 0}, {C::Xposition, C::Xposition});
    try {
      build_skeleton(b.build(), 1.0);
      FAIL() << "expected an error";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("Hips"), std::string::npos);
    }
  }
}

TEST(SkeletonTest, ChannelMapFollowsFileOrder) {
  RawClipBuilder b;
  const int r =
      b.joint("Hips", -1, {0, 0, 0},
              {C::Zposition, C::Xposition, C::Yrotation, C::Yposition, C::Xrotation, C::Zrotation});
  b.joint("Leg", r, {0, -1, 0}, {C::Xrotation, C::Zrotation});
  const Skeleton s = build_skeleton(b.build(), 0.5);
  EXPECT_EQ(s.channel_count, 8u);
  EXPECT_EQ(s.channels[0].position_column, (std::array<int, 3>{1, 3, 0}));
  EXPECT_EQ(s.channels[0].rotation_count, 3);
  EXPECT_EQ(s.channels[0].rotation_column, (std::array<int, 3>{2, 4, 5}));
  EXPECT_EQ(s.channels[0].rotation_axis, (std::array<std::uint8_t, 3>{1, 0, 2}));
  EXPECT_EQ(s.channels[1].rotation_count, 2);
  EXPECT_EQ(s.channels[1].rotation_column[0], 6);
  EXPECT_FALSE(s.channels[1].has_position());
  EXPECT_TRUE(s.offsets_m[1].isApprox(Eigen::Vector3d(0, -0.5, 0)));
  EXPECT_EQ(s.find("Leg"), 1);
  EXPECT_EQ(s.find("Arm"), -1);
  EXPECT_EQ(s.children(0), std::vector<int>{1});
}

TEST(SkeletonTest, IdIsStableAndSeesOffsetsAndChannels) {
  auto make = [](double leg, Channel rot) {
    RawClipBuilder b;
    const int r = b.joint("Hips", -1, {0, 0, 0}, {C::Xposition, C::Yposition, C::Zposition});
    b.joint("Leg", r, {0, leg, 0}, {rot});
    return build_skeleton(b.build(), 1.0);
  };
  EXPECT_EQ(make(-1, C::Xrotation).id(), make(-1, C::Xrotation).id());
  EXPECT_NE(make(-1, C::Xrotation).id(), make(-1.01, C::Xrotation).id());
  EXPECT_NE(make(-1, C::Xrotation).id(), make(-1, C::Yrotation).id());
  Skeleton scaled = make(-1, C::Xrotation);
  scaled.translation_scales = {1.0, 1.0};
  const std::uint64_t unit_scales = scaled.id();
  scaled.translation_scales = {1.0, 1.2};
  EXPECT_NE(scaled.id(), unit_scales);
}

}  // namespace
}  // namespace mocap
