// synth/src/foot_steps.cpp: the stepping pass (docs/synthesis.md
// "Stepping"). A bad gap is refused; a transition between walks that glides
// steps instead (no skating, each foot ending where S_G has it); a
// transition whose feet do not skate is left as the search made it; the
// gait's own swing (gait_swing_s) is measured from a clip and times the
// plan's swings (plan_steps), whose planted feet stay put.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <vector>

#include "foot_steps.hpp"
#include "mocap/synth/synth.hpp"
#include "synth_fixtures.hpp"
#include "test_support.hpp"

namespace {

using namespace mocap;

const Index* shared_index() {
  return test::built_index({"bandai-namco-1"});
}

// Horizontal distance of every foot joint between the last inserted frame
// and S_G, the largest.
double largest_foot_gap_to_goal(const GapProblem& gap, const std::vector<SynthFrame>& frames) {
  WorldPose a, b;
  synth_world_pose(*gap.skeleton, frames.back(), a);
  synth_world_pose(*gap.skeleton, gap.goal, b);
  double d = 0.0;
  for (int j : gap.skeleton->foot_joints) {
    const auto ju = static_cast<std::size_t>(j);
    d = std::max(d, std::hypot(a.positions_m[ju].x() - b.positions_m[ju].x(),
                               a.positions_m[ju].z() - b.positions_m[ju].z()));
  }
  return d;
}

}  // namespace

TEST(FootSteps, RefusesABadGap) {
  GapProblem gap;  // no skeleton, no frame time
  std::vector<SynthFrame> frames(3);
  EXPECT_THROW(step_transition_feet(gap, frames), std::invalid_argument);
}

TEST(FootSteps, NoFramesNothingToStep) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  auto g = test::make_gap(*index, "dataset-1_walk_normal_001.bvh", 20,
                          "dataset-1_walk_angry_001.bvh", 30);
  std::vector<SynthFrame> none;
  step_transition_feet(g->gap, none);
  EXPECT_TRUE(none.empty());
}

TEST(FootSteps, AGlidingWalkTransitionStepsAndEndsOnTheGoalsFeet) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  for (const auto& [x, y] :
       {std::pair{"dataset-1_walk_normal_001.bvh", "dataset-1_walk_angry_001.bvh"},
        std::pair{"dataset-1_walk_active_001.bvh", "dataset-1_walk_active_002.bvh"}}) {
    auto g = test::make_gap(*index, x, 30, y, 40);
    const std::size_t n = choose_transition_frames(g->gap, SupplementParams{});
    std::vector<SynthFrame> frames = slerp_transition(g->gap, n);
    const TransitionMeasures glide = measure_transition(g->gap, frames);
    ASSERT_GT(glide.skating_ratio, 0.3) << x << ": the slerp glides";
    step_transition_feet(g->gap, frames);
    ASSERT_EQ(frames.size(), n);
    const TransitionMeasures stepped = measure_transition(g->gap, frames);
    EXPECT_LE(stepped.skating_ratio, std::min(0.1, glide.skating_ratio / 4)) << x;
    // Each foot is close to where S_G has it one frame before S_G.
    EXPECT_LT(largest_foot_gap_to_goal(g->gap, frames), 0.15) << x;
    // The stepping pass only turns the legs: the root stays on the path.
    const std::vector<SynthFrame> slerp = slerp_transition(g->gap, n);
    for (std::size_t i = 0; i < n; ++i)
      EXPECT_EQ(frames[i].root_position_m, slerp[i].root_position_m) << x << " frame " << i;
  }
}

namespace {

// A* on g (whose legs glide where the clips move) on a gap from frame a of
// clip x to frame b of clip y, with and without the stepping pass.
struct WithAndWithout {
  std::unique_ptr<test::RealGap> g;
  std::vector<SynthFrame> stepped, plain;
  SupplementStats stepped_stats, plain_stats;
};
std::unique_ptr<WithAndWithout> astar_both_ways(const Index& index, const char* x, std::size_t a,
                                                const char* y, std::size_t b) {
  auto w = std::make_unique<WithAndWithout>();
  w->g = test::make_gap(index, x, a, y, b);
  SupplementParams p;
  p.energy = SearchEnergy::g;
  p.step_feet = true;
  w->stepped = supplement_astar(w->g->gap, p, &w->stepped_stats);
  p.step_feet = false;
  w->plain = supplement_astar(w->g->gap, p, &w->plain_stats);
  return w;
}

}  // namespace

TEST(FootSteps, AStarOnAWalkGapNoLongerSkates) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  const auto w = astar_both_ways(*index, "dataset-1_walk_normal_001.bvh", 30,
                                 "dataset-1_walk_angry_001.bvh", 40);
  EXPECT_TRUE(w->stepped_stats.stepped);
  EXPECT_LE(measure_transition(w->g->gap, w->stepped).skating_ratio, 0.05);
  EXPECT_FALSE(w->plain_stats.stepped);
  EXPECT_GT(measure_transition(w->g->gap, w->plain).skating_ratio, 0.2)
      << "without steps the feet glide";
}

TEST(FootSteps, ATransitionThatDoesNotSkateIsLeftAsTheSearchMadeIt) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  const auto w = astar_both_ways(*index, "dataset-1_bow_normal_001.bvh", 20,
                                 "dataset-1_bow_normal_001.bvh", 24);
  ASSERT_EQ(measure_transition(w->g->gap, w->stepped).skating_ratio, 0.0);
  EXPECT_FALSE(w->stepped_stats.stepped);
  ASSERT_EQ(w->stepped.size(), w->plain.size());
  for (std::size_t i = 0; i < w->stepped.size(); ++i)
    for (std::size_t j = 0; j < w->stepped[i].local_rotations.size(); ++j)
      EXPECT_EQ(w->stepped[i].local_rotations[j].coeffs(), w->plain[i].local_rotations[j].coeffs());
}

namespace {

// Frames first .. first + count - 1 of clip `name` in its own skeleton
// (count 0: to the clip's end).
std::vector<SynthFrame> clip_frames(const Index& index, const std::string& name, std::size_t first,
                                    std::size_t count) {
  const std::size_t c = test::clip_named(index, name);
  if (count == 0) count = index.clips()[c].frame_count - first;
  std::vector<SynthFrame> f;
  for (std::size_t i = first; i < first + count; ++i) f.push_back(clip_frame(index, c, i));
  return f;
}

}  // namespace

TEST(FootSteps, GaitSwingOfNothingOrOfAStandingClipIsUnknown) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  auto g = test::make_gap(*index, "dataset-1_bow_normal_001.bvh", 20,
                          "dataset-1_bow_normal_001.bvh", 24);
  const double dt = g->gap.frame_time_s;
  EXPECT_EQ(synth_detail::gait_swing_s(g->sk, {}, dt), 0.0);
  EXPECT_EQ(synth_detail::gait_swing_s(
                g->sk, clip_frames(*index, "dataset-1_bow_normal_001.bvh", 10, 2), dt),
            0.0);
  // A bow keeps both feet down: no swing to measure.
  EXPECT_EQ(synth_detail::gait_swing_s(
                g->sk, clip_frames(*index, "dataset-1_bow_normal_001.bvh", 0, 60), dt),
            0.0);
  EXPECT_EQ(synth_detail::stepping_params(g->gap).swing_s, synth_detail::SteppingParams{}.swing_s);
}

TEST(FootSteps, GaitSwingOfAWalkIsItsOwnAndTimesThePlansSwings) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  auto g = test::make_gap(*index, "dataset-1_walk_normal_001.bvh", 30,
                          "dataset-1_walk_angry_001.bvh", 40);
  const double dt = g->gap.frame_time_s;
  const double walk = synth_detail::gait_swing_s(
      g->sk, clip_frames(*index, "dataset-1_walk_normal_001.bvh", 0, 90), dt);
  // A walk's swing, and a run's: 0.3 to 0.65 s.
  const double running = synth_detail::gait_swing_s(
      g->sk, clip_frames(*index, "dataset-1_run_normal_001.bvh", 0, 0), dt);
  for (const double swing : {walk, running}) {
    EXPECT_GT(swing, 0.3);
    EXPECT_LT(swing, 0.65);
  }
  // The plan's swings last the gait's swing: a swing that starts and ends
  // inside the transition is in the air round(swing / dt) - 1 frames (it
  // has landed in its last).
  const std::size_t n = 40;
  const std::vector<SynthFrame> slerp = slerp_transition(g->gap, n);
  for (const double swing_s : {0.2, 0.3}) {
    g->gap.gait_swing_s = swing_s;
    const synth_detail::SteppingParams p = synth_detail::stepping_params(g->gap);
    ASSERT_EQ(p.swing_s, swing_s);
    const auto plan = synth_detail::plan_steps(g->gap, slerp, p);
    ASSERT_EQ(plan.size(), n);
    const auto expected = static_cast<std::size_t>(std::round(swing_s / dt)) - 1;
    std::size_t whole = 0;
    for (std::size_t l = 0; l < plan[0].size(); ++l) {
      std::size_t i = 0;
      while (i < n && plan[i][l].swinging) ++i;  // a swing under way at S_0
      while (i < n) {
        std::size_t run = 0;
        const std::size_t first = i;
        while (i < n && plan[i][l].swinging) ++run, ++i;
        if (run > 0 && i < n && first > 0) {
          EXPECT_EQ(run, expected) << swing_s << " s, leg " << l << " from frame " << first;
          ++whole;
        }
        // A planted foot stays where it is (or settles onto S_G's foot,
        // within settle_m of it).
        const std::size_t down = i;
        while (i < n && !plan[i][l].swinging) ++i;
        for (std::size_t k = down + 1; k < i; ++k)
          EXPECT_LE((plan[k][l].position - plan[down][l].position).norm(), p.settle_m + 1e-9)
              << swing_s << " s, leg " << l << " frame " << k;
      }
    }
    EXPECT_GT(whole, 0U) << swing_s << " s: the walk gap steps";
  }
}
