// synth/src/measures.cpp: the sliding measures (docs/synthesis.md
// "Measures"). A foot gliding fast on the ground is sliding and skating; a
// still pose is neither; a captured walk skates rarely.
#include <gtest/gtest.h>

#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "mocap/synth/synth.hpp"
#include "synth_fixtures.hpp"
#include "test_support.hpp"

namespace {

using namespace mocap;

const Index* shared_index() {
  return test::built_index({"bandai-namco-1"});
}
using test::clip_named;

}  // namespace

TEST(SlidingMeasures, FewerThanTwoFramesMeasureNothing) {
  const SynthSkeleton sk{};
  const MotionMeasures m = measure_motion(sk, {}, 1.0 / 30);
  EXPECT_EQ(m.skating_ratio, 0.0);
  EXPECT_EQ(m.foot_sliding_m, 0.0);
}

TEST(SlidingMeasures, AGlideOnTheGroundSkatesAndSlidesAStillPoseDoesNot) {
  if (!test::have_data()) GTEST_SKIP() << "no data";
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  const std::size_t clip = clip_named(*index, "dataset-1_bow_normal_001.bvh");
  const SynthSkeleton sk = make_synth_skeleton(*index, index->clips()[clip].skeleton, clip);
  const SynthFrame stand = clip_frame(*index, clip, 0);
  const double dt = index->clips()[clip].frame_time_s;
  std::vector<SynthFrame> still(12, stand), glide;
  for (std::size_t k = 0; k < 12; ++k) {
    SynthFrame f = stand;
    f.root_position_m.z() += 0.04 * static_cast<double>(k);  // 1.2 m/s at 30 fps
    glide.push_back(f);
  }
  const MotionMeasures s = measure_motion(sk, still, dt);
  EXPECT_EQ(s.skating_ratio, 0.0);
  EXPECT_EQ(s.foot_sliding_m, 0.0);
  const MotionMeasures g = measure_motion(sk, glide, dt);
  EXPECT_EQ(g.skating_ratio, 1.0) << "the toes stay on the ground while the body moves";
  EXPECT_NEAR(g.skating_speed_mps, 0.04 / dt, 1e-6);
  // Every foot joint within contact height slides 0.44 m (fast, yet counted).
  EXPECT_GE(g.foot_sliding_m, 11 * 0.04 - 1e-9);
}

TEST(SlidingMeasures, CapturedWalksSkateRarely) {
  if (!test::have_data()) GTEST_SKIP() << "no data";
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  for (const char* name : {"dataset-1_walk_normal_001.bvh", "dataset-1_run_normal_001.bvh"}) {
    const std::size_t clip = clip_named(*index, name);
    const SynthSkeleton sk = make_synth_skeleton(*index, index->clips()[clip].skeleton, clip);
    std::vector<SynthFrame> frames;
    for (std::size_t f = 0; f < index->clips()[clip].frame_count; ++f)
      frames.push_back(clip_frame(*index, clip, f));
    const MotionMeasures m = measure_motion(sk, frames, index->clips()[clip].frame_time_s);
    EXPECT_LT(m.skating_ratio, 0.1) << name;
  }
}
