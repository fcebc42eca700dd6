// Tests for common/src/io/units.cpp: unit names, scales and detection by skeleton height.
#include "mocap/common/io/units.hpp"

#include <gtest/gtest.h>

#include "mocap/common/io/bvh.hpp"
#include "raw_clip_builder.hpp"

namespace mocap {
namespace {

using C = Channel;

TEST(UnitsTest, ParseRejectsUnknownNames) {
  EXPECT_FALSE(parse_unit(""));
  EXPECT_FALSE(parse_unit("metre"));
  EXPECT_FALSE(parse_unit("c m"));
  EXPECT_EQ(parse_unit("CM"), LengthUnit::cm);
  EXPECT_EQ(parse_unit("cmu"), LengthUnit::cmu);
  EXPECT_EQ(parse_unit("inch"), LengthUnit::inch);
  EXPECT_EQ(parse_unit("DM"), LengthUnit::dm);
}

TEST(UnitsTest, Scales) {
  EXPECT_DOUBLE_EQ(unit_scale_m(LengthUnit::m), 1.0);
  EXPECT_DOUBLE_EQ(unit_scale_m(LengthUnit::cm), 0.01);
  EXPECT_DOUBLE_EQ(unit_scale_m(LengthUnit::mm), 0.001);
  EXPECT_DOUBLE_EQ(unit_scale_m(LengthUnit::inch), 0.0254);
  EXPECT_DOUBLE_EQ(unit_scale_m(LengthUnit::cmu), 0.056444);
  EXPECT_DOUBLE_EQ(unit_scale_m(LengthUnit::dm), 0.1);
}

// A stick figure `height_m` tall, written in `unit`, lying flat in its rest
// pose (like Bandai Namco's X-along-the-bone rest pose) and stood up by the
// root rotation in the frame.
RawClip figure(double height_m, LengthUnit unit) {
  const double k = 1.0 / unit_scale_m(unit);
  test::RawClipBuilder b;
  const int hips =
      b.joint("Hips", -1, {0, 0, 0},
              {C::Xposition, C::Yposition, C::Zposition, C::Zrotation, C::Xrotation, C::Yrotation});
  const int head = b.joint("Head", hips, {0.45 * height_m * k, 0, 0}, {});
  b.end_site(head, {0.05 * height_m * k, 0, 0});
  b.joint("Foot", hips, {-0.5 * height_m * k, 0, 0}, {});
  b.frame({0, 0.5 * height_m * k, 0, 90, 0, 0});  // Rz(90): +X becomes +Y
  b.frame({0, 0.5 * height_m * k, 0, 90, 0, 0});
  return b.build();
}

TEST(UnitsTest, StandingHeightUsesPosedFramesNotTheRestPose) {
  EXPECT_NEAR(standing_height_file_units(figure(1.7, LengthUnit::cm)), 170.0, 1e-9);
}

TEST(UnitsTest, DetectsEveryUnitForAdultsAndChildren) {
  for (LengthUnit u : {LengthUnit::m, LengthUnit::dm, LengthUnit::cm, LengthUnit::mm,
                       LengthUnit::inch, LengthUnit::cmu})
    for (double h : {1.2, 1.3, 1.5, 1.7, 1.95}) {
      if (u == LengthUnit::inch && h < 1.4)
        continue;  // inch vs cm: 2.54x apart, children ambiguous
      if (u == LengthUnit::cmu && h < 1.28)
        continue;  // cmu vs dm: 1.77x apart, a 1.2 m child in cmu reads as 2.1 m in dm
      EXPECT_EQ(detect_unit(figure(h, u)), u) << unit_name(u) << " " << h;
    }
}

// MakeHuman writes decimetres: its 1.66 m default figure is 16.6 units tall.
TEST(UnitsTest, DecimetreFigureIsDm) {
  const RawClip clip = parse_bvh(
      "HIERARCHY\nROOT Hips\n{\n OFFSET 0 9.1 0\n"
      " CHANNELS 6 Xposition Yposition Zposition Xrotation Yrotation Zrotation\n"
      " JOINT Neck\n {\n  OFFSET 0 5.4 0\n  CHANNELS 3 Xrotation Yrotation Zrotation\n"
      "  End Site Head_end\n  {\n   OFFSET 0 2.1 0\n  }\n }\n"
      " JOINT UpLeg_L\n {\n  OFFSET 0.9 -0.6 0\n  CHANNELS 3 Xrotation Yrotation Zrotation\n"
      "  JOINT Foot_L\n  {\n   OFFSET 0 -8.2 0\n   CHANNELS 3 Xrotation Yrotation Zrotation\n"
      "   End Site\n   {\n    OFFSET 0 -0.3 0.8\n   }\n  }\n }\n}\n"
      "MOTION\nFrames: 2\nFrame Time: 0.04\n"
      "0 9.1 0 0 0 0 0 0 0 0 0 0 0 0 0\n"
      "1 9.0 2 5 10 0 -10 0 5 -20 0 0 15 0 0\n",
      "makehuman-like.bvh");
  EXPECT_NEAR(standing_height_file_units(clip, 1), 16.6, 1e-9);
  EXPECT_EQ(detect_unit(clip), LengthUnit::dm);
}

TEST(UnitsTest, EmptyClipIsMetres) {
  test::RawClipBuilder b;
  b.joint("Hips", -1, {0, 0, 0}, {});
  EXPECT_EQ(detect_unit(b.build()), LengthUnit::m);
  EXPECT_EQ(standing_height_file_units(b.build()), 0.0);
}

}  // namespace
}  // namespace mocap
