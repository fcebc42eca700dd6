// synth/src/warp_fill.cpp: warped fills of timed key poses (docs/synthesis.md
// "Warped fills"). Bad input is refused; the captured span is the clip where
// its time map hits whole frames; the placement between a clip frame and its
// placed copy is the one that placed it; the balanced placement shares the
// miss of the last key pose between both ends; the warp size is the mean
// joint distance at both ends; the displacement map meets both key
// poses exactly and moves the middle by the mean of the two offsets; a real
// walk bent onto key poses 40-57 cm away keeps its low feet as still as the
// capture does, where the displacement alone drags them; a walk lowered
// into the floor has its swinging feet lifted off it, no foot joint moved
// horizontally, the end frames untouched.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include "measures.hpp"
#include "mocap/synth/synth.hpp"
#include "synth_fixtures.hpp"
#include "test_support.hpp"
#include "warp_fill.hpp"

namespace {

using namespace mocap;
using namespace mocap::synth_detail;

const Index* shared_index() {
  return test::built_index({"bandai-namco-1"});
}

// A walk of set 1 as a warp source, placed by `p`.
struct Walk {
  const Index* index = nullptr;
  std::size_t clip = 0;
  SynthSkeleton sk;
  RangeOfMotion rom;
  WarpSource src;
};
std::unique_ptr<Walk> walk(const Index& index, double start, Placement p = {}) {
  auto w = std::make_unique<Walk>();
  w->index = &index;
  w->clip = test::clip_named(index, "dataset-1_walk_normal_001.bvh");
  w->sk = make_synth_skeleton(index, index.clips()[w->clip].skeleton, w->clip);
  w->rom = range_of_motion(index, w->sk, index.skeletons()[index.clips()[w->clip].skeleton].clips);
  w->src.frame = [&index, c = w->clip](std::size_t f) { return clip_frame(index, c, f); };
  w->src.frame_count = index.clips()[w->clip].frame_count;
  w->src.start = start;
  w->src.step = 1.0;
  w->src.placement = p;
  return w;
}

// Metres the foot joints move horizontally while below the skating height
// (low_foot_speed over every step): what a planted foot should not do.
double low_foot_travel(const SynthSkeleton& sk, const std::vector<SynthFrame>& frames, double dt) {
  std::vector<WorldPose> w(frames.size());
  for (std::size_t i = 0; i < frames.size(); ++i) synth_world_pose(sk, frames[i], w[i]);
  double d = 0.0;
  for (std::size_t i = 0; i + 1 < frames.size(); ++i)
    for (int j : sk.foot_joints) {
      const auto ju = static_cast<std::size_t>(j);
      d += dt * low_foot_speed(w[i].positions_m[ju], w[i + 1].positions_m[ju], dt,
                               sk.model.params.ground_height_m);
    }
  return d;
}

double largest_joint_angle(const SynthFrame& a, const SynthFrame& b) {
  double worst = 0.0;
  for (std::size_t j = 0; j < a.local_rotations.size(); ++j)
    worst = std::max(worst, a.local_rotations[j].angularDistance(b.local_rotations[j]));
  return worst;
}

TEST(WarpFill, RejectsInvalidInputs) {
  std::vector<SynthFrame> one(1);
  EXPECT_THROW(displace_onto_keys(one, SynthFrame{}, SynthFrame{}), std::invalid_argument);
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  auto w = walk(*index, 10.0);
  const SynthFrame a = clip_frame(*index, w->clip, 10), b = clip_frame(*index, w->clip, 40);
  EXPECT_THROW(warp_fill(w->sk, &w->rom, w->src, a, b, 0, 1.0 / 30.0), std::invalid_argument);
  WarpSource short_clip = w->src;
  short_clip.frame_count = 1;
  EXPECT_THROW(captured_span(w->sk, short_clip, 5), std::invalid_argument);
  EXPECT_THROW(balanced_placement(w->sk, {}, a, b), std::invalid_argument);
}

TEST(WarpFill, CapturedSpanIsTheClipAtWholeFramesAndClampsAtItsEnds) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  auto w = walk(*index, 20.0);
  const auto span = captured_span(w->sk, w->src, 10);
  ASSERT_EQ(span.size(), 11u);
  for (std::size_t i = 0; i <= 10; ++i) {
    const SynthFrame c = clip_frame(*index, w->clip, 20 + i);
    EXPECT_LT((span[i].root_position_m - c.root_position_m).norm(), 1e-12) << i;
    EXPECT_LT(largest_joint_angle(span[i], c), 1e-9) << i;
  }
  w->src.start = -3.0;  // before the clip: its first frame
  const auto early = captured_span(w->sk, w->src, 4);
  const SynthFrame first = clip_frame(*index, w->clip, 0);
  for (std::size_t i = 0; i <= 3; ++i)
    EXPECT_LT((early[i].root_position_m - first.root_position_m).norm(), 1e-12) << i;
}

TEST(WarpFill, PlacementBetweenIsTheOneThatPlacedTheFrame) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  auto w = walk(*index, 0.0);
  const SynthFrame f = clip_frame(*index, w->clip, 50);
  const Placement p{0.7, Eigen::Vector3d(1.5, 0.0, -2.0)};
  const Placement q = placement_between(w->sk, f, place_frame(w->sk, f, p));
  EXPECT_NEAR(std::remainder(q.yaw_rad - p.yaw_rad, 2.0 * M_PI), 0.0, 1e-9);
  EXPECT_LT((q.translation_m - p.translation_m).norm(), 1e-9);
}

TEST(WarpFill, BalancedPlacementSharesTheMissOfTheLastKeyBetweenBothEnds) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  auto w = walk(*index, 40.0);
  const std::size_t steps = 20;
  const auto span = captured_span(w->sk, w->src, steps);
  // The span's own ends, turned and moved; the last 30 cm further on.
  const Placement p{0.9, Eigen::Vector3d(2.0, 0.0, -1.0)};
  const SynthFrame ka = place_frame(w->sk, span.front(), p);
  SynthFrame kb = place_frame(w->sk, span.back(), p);
  kb.root_position_m += Eigen::Vector3d(0.3, 0.0, 0.0);
  WarpSource placed = w->src;
  placed.placement = balanced_placement(w->sk, span, ka, kb);
  const auto at = captured_span(w->sk, placed, steps);
  const Eigen::Vector3d half(0.15, 0.0, 0.0);
  EXPECT_LT((at.front().root_position_m - half - ka.root_position_m).norm(), 1e-9);
  EXPECT_LT((at.back().root_position_m + half - kb.root_position_m).norm(), 1e-9);
  EXPECT_NEAR(std::remainder(root_heading(w->sk, at.front()) - root_heading(w->sk, ka), 2 * M_PI),
              0.0, 1e-9);
}

TEST(WarpFill, WarpSizeIsTheMeanJointDistanceAtBothEnds) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  auto w = walk(*index, 40.0);
  const auto span = captured_span(w->sk, w->src, 20);
  EXPECT_LT(warp_size_m(w->sk, span.front(), span.back(), span.front(), span.back()), 1e-12);
  // Every joint 30 cm off at the last key pose, none at the first: 15 cm.
  const SynthFrame kb =
      place_frame(w->sk, span.back(), Placement{0.0, Eigen::Vector3d(0.0, 0.0, 0.3)});
  EXPECT_NEAR(warp_size_m(w->sk, span.front(), span.back(), span.front(), kb), 0.15, 1e-9);
  // A posture change at the first key pose adds the joints' displacement.
  SynthFrame ka = span.front();
  ka.local_rotations[1] =
      ka.local_rotations[1] * Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitX()));
  EXPECT_GT(warp_size_m(w->sk, span.front(), span.back(), ka, kb), 0.15 + 1e-3);
}

TEST(WarpFill, DisplacementMeetsBothKeysAndMovesTheMiddleByTheMeanOffset) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  auto w = walk(*index, 30.0);
  const auto span = captured_span(w->sk, w->src, 20);
  // Key poses of another part of the take, 25 cm aside.
  const Placement aside{0.0, Eigen::Vector3d(0.25, 0.0, 0.0)};
  const SynthFrame ka = place_frame(w->sk, clip_frame(*index, w->clip, 32), aside);
  const SynthFrame kb = place_frame(w->sk, clip_frame(*index, w->clip, 48), aside);
  std::vector<SynthFrame> bent = span;
  displace_onto_keys(bent, ka, kb);
  EXPECT_EQ(bent.front().root_position_m, ka.root_position_m);
  EXPECT_EQ(bent.back().root_position_m, kb.root_position_m);
  EXPECT_LT(largest_joint_angle(bent.front(), ka), 1e-12);
  EXPECT_LT(largest_joint_angle(bent.back(), kb), 1e-12);
  const Eigen::Vector3d mean = 0.5 * (ka.root_position_m - span.front().root_position_m +
                                      kb.root_position_m - span.back().root_position_m);
  EXPECT_LT((bent[10].root_position_m - span[10].root_position_m - mean).norm(), 1e-9);
}

TEST(WarpFill, AWalkBentOntoKeyPosesKeepsItsFeetPlanted) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  auto w = walk(*index, 60.0);
  const double dt = index->clips()[w->clip].frame_time_s;
  const std::size_t steps = 30;
  const auto span = captured_span(w->sk, w->src, steps);
  // The key poses: the span's own ends, the first 40 cm to one side and the
  // last 40 cm to the other and 40 cm further on, as another take's key
  // poses could be.
  const SynthFrame ka =
      place_frame(w->sk, span.front(), Placement{0.0, Eigen::Vector3d(0.4, 0.0, 0.0)});
  const SynthFrame kb =
      place_frame(w->sk, span.back(), Placement{0.0, Eigen::Vector3d(-0.4, 0.0, 0.4)});
  const auto fill = warp_fill(w->sk, &w->rom, w->src, ka, kb, steps, dt);
  ASSERT_EQ(fill.size(), steps + 1);
  EXPECT_LT(largest_joint_angle(fill.front(), ka), 1e-12);
  EXPECT_LT(largest_joint_angle(fill.back(), kb), 1e-12);
  EXPECT_EQ(fill.back().root_position_m, kb.root_position_m);
  std::vector<SynthFrame> dragged = span;
  displace_onto_keys(dragged, ka, kb);
  const double own = low_foot_travel(w->sk, span, dt);
  const double drag = low_foot_travel(w->sk, dragged, dt);
  const double held = low_foot_travel(w->sk, fill, dt);
  EXPECT_GT(drag, own + 0.2) << "the displacement alone drags the planted feet";
  // Measured: 0.02 m captured, 0.78 m dragged, 0.002 m held.
  EXPECT_LT(held, own + 0.05) << own << " " << drag << " " << held;
}

// Steps of `frames` in which a foot joint skates (step_skating).
std::size_t skating_steps(const SynthSkeleton& sk, const std::vector<SynthFrame>& frames,
                          double dt) {
  std::vector<WorldPose> w(frames.size());
  for (std::size_t i = 0; i < frames.size(); ++i) synth_world_pose(sk, frames[i], w[i]);
  std::size_t n = 0;
  for (std::size_t i = 0; i + 1 < frames.size(); ++i)
    n += step_skating(sk, w[i], w[i + 1], dt).joints > 0 ? 1 : 0;
  return n;
}

TEST(WarpFill, LiftMovingFeetLeavesTooShortSpansAlone) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  auto w = walk(*index, 60.0);
  std::vector<SynthFrame> two = captured_span(w->sk, w->src, 1);
  for (SynthFrame& f : two) f.root_position_m.y() -= 0.1;
  const std::vector<SynthFrame> before = two;
  lift_moving_feet(w->sk, &w->rom, two, 1.0 / 30.0);
  ASSERT_EQ(two.size(), before.size());
  for (std::size_t i = 0; i < two.size(); ++i)
    EXPECT_EQ(two[i].root_position_m, before[i].root_position_m);
  std::vector<SynthFrame> empty;
  lift_moving_feet(w->sk, &w->rom, empty, 1.0 / 30.0);
  EXPECT_TRUE(empty.empty());
}

TEST(WarpFill, AWalkLoweredIntoTheFloorHasItsSwingingFeetLifted) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  auto w = walk(*index, 60.0);
  const double dt = index->clips()[w->clip].frame_time_s;
  std::vector<SynthFrame> frames = captured_span(w->sk, w->src, 30);
  // The body 4 cm lower between the ends: swinging toes skim the floor.
  for (std::size_t i = 1; i + 1 < frames.size(); ++i) frames[i].root_position_m.y() -= 0.04;
  const std::vector<SynthFrame> lowered = frames;
  ASSERT_GT(skating_steps(w->sk, lowered, dt), 3u);
  lift_moving_feet(w->sk, &w->rom, frames, dt);
  EXPECT_EQ(skating_steps(w->sk, frames, dt), 0u);
  EXPECT_LT(largest_joint_angle(frames.front(), lowered.front()), 1e-15);
  EXPECT_LT(largest_joint_angle(frames.back(), lowered.back()), 1e-15);
  // Only heights change: every foot joint where it was across the floor.
  WorldPose a, b;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    synth_world_pose(w->sk, lowered[i], a);
    synth_world_pose(w->sk, frames[i], b);
    EXPECT_EQ(frames[i].root_position_m, lowered[i].root_position_m);
    for (int j : w->sk.foot_joints) {
      const Eigen::Vector3d d =
          b.positions_m[static_cast<std::size_t>(j)] - a.positions_m[static_cast<std::size_t>(j)];
      EXPECT_LT(std::hypot(d.x(), d.z()), 1e-6) << "frame " << i << " joint " << j;
      EXPECT_GE(d.y(), -1e-9) << "frame " << i << " joint " << j;
    }
  }
}

}  // namespace
