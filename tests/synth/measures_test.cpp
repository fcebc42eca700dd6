// synth/src/measures.cpp: the sliding measures (docs/synthesis.md
// "Measures"). A foot gliding fast on the ground is sliding and skating; a
// still pose is neither; a captured walk skates rarely. Range violations
// are named; the energy model's foot contacts show a walk's heels and toes.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "measures.hpp"
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

// range_violation_list: the pairs count_range_violations counts, named.
TEST(RangeViolationList, NoRangeNamesNothing) {
  if (!test::have_data()) GTEST_SKIP() << "no data";
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  auto g = test::make_gap(*index, "dataset-1_walk_normal_001.bvh", 20,
                          "dataset-1_walk_normal_001.bvh", 40);
  g->gap.range = nullptr;
  SynthFrame bent = g->gap.start;
  bent.local_rotations[1] = Eigen::Quaterniond(Eigen::AngleAxisd(3.0, Eigen::Vector3d::UnitX()));
  EXPECT_TRUE(synth_detail::range_violation_list(g->gap, {bent}).empty());
  EXPECT_TRUE(synth_detail::range_violation_list(g->gap, {}).empty());
}

TEST(RangeViolationList, NamesTheJointItsChannelRangeValueAndExcess) {
  if (!test::have_data()) GTEST_SKIP() << "no data";
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  auto g = test::make_gap(*index, "dataset-1_walk_normal_001.bvh", 20,
                          "dataset-1_walk_normal_001.bvh", 40);
  const SynthSkeleton& sk = g->sk;
  const int knee = sk.skeleton.find("LowerLeg_L");
  ASSERT_GE(knee, 0);
  const auto k = static_cast<std::size_t>(knee);
  SynthFrame bent = g->gap.start;  // the knee turned 170 degrees about its bone
  bent.local_rotations[k] =
      bent.local_rotations[k] *
      Eigen::Quaterniond(Eigen::AngleAxisd(170.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()));
  const std::vector<SynthFrame> frames{g->gap.start, bent, bent};
  const auto list = synth_detail::range_violation_list(g->gap, frames);
  EXPECT_EQ(list.size(), synth_detail::count_range_violations(g->gap, frames));
  std::size_t knee_hits = 0;
  for (const RangeViolation& v : list) {
    EXPECT_GE(v.frame, 1u) << "frame 0 is the capture's own pose";
    EXPECT_TRUE(v.channel == "Xrotation" || v.channel == "Yrotation" || v.channel == "Zrotation");
    EXPECT_LE(v.min_deg, v.max_deg);
    EXPECT_GT(v.excess_deg, 0.5) << "within_range's slack";
    const double outside =
        v.value_deg < v.min_deg ? v.min_deg - v.value_deg : v.value_deg - v.max_deg;
    EXPECT_NEAR(outside, v.excess_deg, 1e-9) << v.joint << " " << v.channel;
    if (v.joint == "LowerLeg_L") ++knee_hits;
  }
  EXPECT_EQ(knee_hits, 2u) << "the bent knee in frames 1 and 2";
}

// foot_contact_rows: the energy model's contacts, per foot segment.
TEST(FootContactRows, FewerThanTwoFramesGiveNoRows) {
  const SynthSkeleton sk{};
  EXPECT_TRUE(synth_detail::foot_contact_rows(sk, {}, 1.0 / 30).empty());
}

// Bandai Namco's ankle (the foot segment's only contact point: its bone tip
// is the toes' joint) never comes within 10 cm of the ground; the toes (the
// ball, or the toe tip) touch down and lift at every step.
TEST(FootContactRows, ACapturedWalksToesTouchAndItsAnklesStayAboveTheBand) {
  if (!test::have_data()) GTEST_SKIP() << "no data";
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  const std::size_t clip = clip_named(*index, "dataset-1_walk_normal_001.bvh");
  const SynthSkeleton sk = make_synth_skeleton(*index, index->clips()[clip].skeleton, clip);
  std::vector<SynthFrame> frames;
  for (std::size_t f = 0; f < index->clips()[clip].frame_count; ++f)
    frames.push_back(clip_frame(*index, clip, f));
  const auto rows = synth_detail::foot_contact_rows(sk, frames, index->clips()[clip].frame_time_s);
  ASSERT_EQ(rows.size(), sk.foot_joints.size());
  std::map<std::string, synth_detail::FootContactRow> by_name;
  for (const auto& r : rows) {
    EXPECT_EQ(r.states.size(), frames.size());
    EXPECT_EQ(r.states.find_first_not_of("cs."), std::string::npos);
    EXPECT_GE(r.lowest_m, 0.0) << r.name;
    by_name[r.name] = r;
  }
  const double band = sk.model.params.contact_height_m;
  for (const char* toes : {"Toes_L", "Toes_R"}) {
    ASSERT_TRUE(by_name.count(toes)) << toes;
    EXPECT_EQ(by_name[toes].points, "joint origin or bone tip");
    EXPECT_GT(by_name[toes].contact_frames(), frames.size() / 10) << toes << " touches";
    EXPECT_LT(by_name[toes].contact_frames(), frames.size()) << toes << " lifts";
    EXPECT_LE(by_name[toes].lowest_m, band);
  }
  for (const char* foot : {"Foot_L", "Foot_R"}) {
    ASSERT_TRUE(by_name.count(foot)) << foot;
    EXPECT_EQ(by_name[foot].points, "joint origin");
    EXPECT_EQ(by_name[foot].contact_frames(), 0u) << foot;
    EXPECT_GT(by_name[foot].lowest_m, band) << foot << ": the reason its row is blank";
  }
}

TEST(SlidingMeasures, SlidingAtContactSpeedIsPartOfTheSliding) {
  if (!test::have_data()) GTEST_SKIP() << "no data";
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  const std::size_t clip = clip_named(*index, "dataset-1_walk_normal_001.bvh");
  const SynthSkeleton sk = make_synth_skeleton(*index, index->clips()[clip].skeleton, clip);
  std::vector<SynthFrame> frames;
  for (std::size_t f = 0; f < index->clips()[clip].frame_count; ++f)
    frames.push_back(clip_frame(*index, clip, f));
  const MotionMeasures m = measure_motion(sk, frames, index->clips()[clip].frame_time_s);
  EXPECT_GT(m.foot_sliding_slow_m, 0.0);
  EXPECT_LT(m.foot_sliding_slow_m, m.foot_sliding_m) << "a walk's feet also swing low and fast";
}
