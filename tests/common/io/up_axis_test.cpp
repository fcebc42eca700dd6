// Tests for the up axis (common/src/io/units.cpp: detect_up_axis; common/src/io/up_axis.cpp:
// rotate_to_y_up, normalise_up_axis) on small hand-written Z-up BVH files.
#include <gtest/gtest.h>

#include <string>

#include "mocap/common/body/skeleton.hpp"
#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/units.hpp"

namespace mocap {
namespace {

// A 170 cm figure standing along +Z (feet at Z = 0, head top at Z = 170),
// three frames: rest, walked and turned about Z, leaning. Root rotation order ZYX.
const char* kZUpFigure =
    "HIERARCHY\n"
    "ROOT Hips\n{\n OFFSET 0 0 90\n"
    " CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\n"
    " JOINT Spine\n {\n  OFFSET 0 0 20\n  CHANNELS 3 Zrotation Yrotation Xrotation\n"
    "  JOINT Head\n  {\n   OFFSET 0 0 50\n   CHANNELS 3 Zrotation Yrotation Xrotation\n"
    "   End Site Head_end\n   {\n    OFFSET 0 0 10\n   }\n  }\n }\n"
    " JOINT LeftLeg\n {\n  OFFSET 10 0 -5\n  CHANNELS 3 Zrotation Yrotation Xrotation\n"
    "  JOINT LeftFoot\n  {\n   OFFSET 0 0 -80\n   CHANNELS 3 Zrotation Yrotation Xrotation\n"
    "   End Site\n   {\n    OFFSET 0 5 -5\n   }\n  }\n }\n"
    " JOINT RightLeg\n {\n  OFFSET -10 0 -5\n  CHANNELS 3 Zrotation Yrotation Xrotation\n"
    "  JOINT RightFoot\n  {\n   OFFSET 0 0 -80\n   CHANNELS 3 Zrotation Yrotation Xrotation\n"
    "   End Site\n   {\n    OFFSET 0 5 -5\n   }\n  }\n }\n}\n"
    "MOTION\nFrames: 3\nFrame Time: 0.04\n"
    "0 0 90 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0\n"
    "35 -20 89 30 0 0 0 5 0 0 0 0 0 0 20 0 0 -10 0 0 -15 0 0 5\n"
    "70 -40 88 60 4 -7 10 10 3 -5 0 0 0 0 -20 0 0 25 0 0 10 0 0 0\n";

// Godot-VR-like: a ROOT with CHANNELS 0 and three tracked children along Z.
const char* kZUpTrackers =
    "HIERARCHY\n"
    "ROOT origin\n{\n OFFSET 0 0 0\n CHANNELS 0\n"
    " JOINT head\n {\n  OFFSET 0 0 1.6\n"
    "  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
    "  End Site\n  {\n   OFFSET 0 0 0.1\n  }\n }\n"
    " JOINT foot\n {\n  OFFSET 0 0 0\n"
    "  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
    "  End Site\n  {\n   OFFSET 0 0.1 0\n  }\n }\n}\n"
    "MOTION\nFrames: 2\nFrame Time: 0.1\n"
    "0 0 1.6 0 0 0 0.1 0 0.05 0 0 0\n"
    "0.2 0.3 1.55 20 10 -5 0.3 0.1 0.0 45 0 0\n";

// World joint origins and End Sites of every frame, file units.
std::vector<Eigen::Vector3d> world_points(const RawClip& clip) {
  const Skeleton skel = build_skeleton(clip, 1.0);
  std::vector<Eigen::Vector3d> out;
  LocalPose local;
  WorldPose world;
  std::vector<Eigen::Vector3d> ends;
  for (std::size_t f = 0; f < clip.frame_count; ++f) {
    local_pose_from_row(skel, clip.frame(f), local);
    forward_kinematics(skel, local, world);
    end_site_positions(skel, world, ends);
    out.insert(out.end(), world.positions_m.begin(), world.positions_m.end());
    out.insert(out.end(), ends.begin(), ends.end());
  }
  return out;
}

// (x, y, z) -> (x, z, -y).
Eigen::Vector3d to_y_up(const Eigen::Vector3d& p) {
  return {p.x(), p.z(), -p.y()};
}

void expect_rotated(const RawClip& z_up, const RawClip& y_up, double tol) {
  const std::vector<Eigen::Vector3d> a = world_points(z_up), b = world_points(y_up);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i)
    EXPECT_LT((to_y_up(a[i]) - b[i]).norm(), tol) << "point " << i;
}

TEST(UnitsUpAxis, ParseNames) {
  EXPECT_EQ(parse_up_axis("y"), UpAxis::y);
  EXPECT_EQ(parse_up_axis("Z"), UpAxis::z);
  EXPECT_FALSE(parse_up_axis("x"));
  EXPECT_FALSE(parse_up_axis("zz"));
  EXPECT_FALSE(parse_up_axis(""));
  EXPECT_STREQ(up_axis_name(UpAxis::z), "z");
}

TEST(UnitsUpAxis, ZUpFigureIsDetectedAndRotatedToYUp) {
  const RawClip clip = parse_bvh(kZUpFigure, "zup.bvh");
  EXPECT_EQ(detect_up_axis(clip), UpAxis::z);
  const RawClip up = rotate_to_y_up(clip, UpAxis::z);
  expect_rotated(clip, up, 1e-9);
  // The root keeps its rotation order after the three position channels.
  ASSERT_EQ(up.joints[0].channels.size(), 6u);
  EXPECT_EQ(up.joints[0].channels[3], Channel::Zrotation);
  EXPECT_EQ(up.joints[0].channels[5], Channel::Xrotation);
  EXPECT_EQ(up.joints[1].channels, clip.joints[1].channels);
  // Measured along the figure's own vertical: 170 cm standing, cm detected.
  EXPECT_EQ(detect_up_axis(up), UpAxis::y);
  EXPECT_NEAR(standing_height_file_units(up, 1), 170.0, 1e-9);
  EXPECT_EQ(detect_unit(up), LengthUnit::cm);
}

TEST(UnitsUpAxis, RootWithoutChannelsGetsSix) {
  const RawClip clip = parse_bvh(kZUpTrackers, "trackers.bvh");
  const RawClip up = rotate_to_y_up(clip, UpAxis::z);
  ASSERT_EQ(up.joints[0].channels.size(), 6u);
  EXPECT_EQ(up.channel_count, clip.channel_count + 6);
  EXPECT_EQ(up.joints[1].first_column, 6u);
  expect_rotated(clip, up, 1e-12);
}

TEST(UnitsUpAxis, DeclaredAxisWinsAndYIsUntouched) {
  RawClip clip = parse_bvh(kZUpFigure, "zup.bvh");
  const RawClip original = clip;
  EXPECT_EQ(normalise_up_axis(clip, UpAxis::y), UpAxis::y);
  EXPECT_EQ(clip.values, original.values);
  EXPECT_EQ(normalise_up_axis(clip, std::nullopt), UpAxis::z);
  expect_rotated(original, clip, 1e-9);
  RawClip y_up = clip;
  EXPECT_EQ(normalise_up_axis(y_up, std::nullopt), UpAxis::y);
  EXPECT_EQ(y_up.values, clip.values);
}

}  // namespace
}  // namespace mocap
