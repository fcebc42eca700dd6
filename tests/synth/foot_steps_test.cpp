// synth/src/foot_steps.cpp: the stepping pass (docs/synthesis.md
// "Stepping"). A bad gap is refused; a transition between walks that glides
// steps instead (no skating, each foot ending where S_G has it); a
// transition whose feet do not skate is left as the search made it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <vector>

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
