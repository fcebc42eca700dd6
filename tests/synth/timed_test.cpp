// Timed key poses through synthesize() (docs/queries.md "Timed key poses"):
// resampling refuses too few frames and keeps the ends; a held-out
// in-between passes each key pose at its time, writes round(T / dt) + 1
// frames at the clip's rate or at --fps, warps the partial motion within
// its range, fills a pair too short for a partial motion directly; --fps is
// refused for an untimed query, and so is the warp asked for by name (by
// default an untimed query is not warped); a warped pair takes, of its
// candidates, the one with the smallest warp (as each picked alone would
// give).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include "mocap/common/util/error.hpp"
#include "mocap/search/query.hpp"
#include "mocap/search/search.hpp"
#include "mocap/search/timing.hpp"
#include "mocap/synth/synth_job.hpp"
#include "motion_layout.hpp"
#include "synth_fixtures.hpp"
#include "test_support.hpp"

namespace {

namespace fs = std::filesystem;
using namespace mocap;

const Index* shared_index() {
  return test::built_index({"bandai-namco-1"});
}

const fs::path kWalk = "bandai-namco-1/data/dataset-1_walk_normal_001.bvh";

// A held-out query of frames `frames` of walk_normal_001 at `times`.
std::string timed_walk(const std::vector<std::size_t>& frames, const std::vector<double>& times) {
  const std::string file = fs::absolute(test::data_dir() / kWalk).string();
  std::string out = R"({"id": "ib", "top": 1, "frames": [)";
  for (std::size_t i = 0; i < frames.size(); ++i)
    out += std::string(i ? ", " : "") + R"({"bvh": ")" + file + R"(", "frame": )" +
           std::to_string(frames[i]) + R"(, "time_s": )" + std::to_string(times[i]) + "}";
  return out + R"(], "filter": {"exclude": ["dataset-1_walk_normal_001*"]}})";
}

struct Synthesised {
  SynthResult result;
  std::optional<SynthSkeleton> skeleton;
};

std::unique_ptr<Synthesised> synthesise(const Index& index, const std::string& text,
                                        const SynthOptions& options = {}) {
  const Query q = parse_query_text(text, "<test>", 0, fs::current_path(), "q");
  const QueryOutcome found = SearchEngine(index).run(q, SearchOptions{});
  if (found.error) {
    ADD_FAILURE() << *found.error;
    return nullptr;
  }
  auto out = std::make_unique<Synthesised>();
  out->result = synthesize(index, q, found.pairs, options, out->skeleton);
  return out;
}

// A timed query synthesised as mocap-synth does it with `options`: the query
// as the fill searches it (query_for_fill), its search, the motion; null
// (and a test failure) when the search fails.
struct FillRun {
  Query query;
  QueryOutcome found;
  SynthResult result;
  std::optional<SynthSkeleton> skeleton;
};

std::unique_ptr<FillRun> fill_run(const Index& index, const std::string& text,
                                  const SynthOptions& options) {
  auto run = std::make_unique<FillRun>();
  run->query =
      query_for_fill(parse_query_text(text, "<test>", 0, fs::current_path(), "q"), options);
  run->found = SearchEngine(index).run(run->query, SearchOptions{});
  if (run->found.error) {
    ADD_FAILURE() << *run->found.error;
    return nullptr;
  }
  run->result = synthesize(index, run->query, run->found.pairs, options, run->skeleton);
  return run;
}

// Frame f of the walk file as the index holds it.
SynthFrame walk_frame(const Index& index, std::size_t f) {
  return clip_frame(index, test::clip_named(index, kWalk.filename().string()), f);
}

// The output frame is the key pose: every joint's local rotation within
// 1e-4 rad (the root's position is placed: relative placement).
void expect_key_pose(const SynthFrame& out, const SynthFrame& key, const std::string& what) {
  for (std::size_t j = 0; j < key.local_rotations.size(); ++j)
    EXPECT_LT(out.local_rotations[j].angularDistance(key.local_rotations[j]), 1e-4)
        << what << " joint " << j;
}

}  // namespace

TEST(TimedKeyPoses, ResampleRefusesTooFewFramesAndKeepsTheEnds) {
  std::vector<SynthFrame> two(2);
  for (auto& f : two) f.local_rotations.assign(1, Eigen::Quaterniond::Identity());
  two[1].root_position_m = Eigen::Vector3d(1, 0, 0);
  EXPECT_THROW(synth_detail::resample_frames({two[0]}, 3), std::invalid_argument);
  EXPECT_THROW(synth_detail::resample_frames(two, 1), std::invalid_argument);
  const auto five = synth_detail::resample_frames(two, 5);
  ASSERT_EQ(five.size(), 5u);
  EXPECT_EQ(five.front().root_position_m, two[0].root_position_m);
  EXPECT_EQ(five.back().root_position_m, two[1].root_position_m);
  EXPECT_NEAR(five[1].root_position_m.x(), 0.25, 1e-12);
}

TEST(TimedKeyPoses, AHeldOutInBetweenPassesEachKeyPoseAtItsTime) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  const double dt =
      index->clips()[test::clip_named(*index, kWalk.filename().string())].frame_time_s;
  // A 30-frame gap (frames 100 and 131) at the file's rate, then at 60 fps;
  // transition, resampled partial motion, transition (not warped).
  const std::string q = timed_walk({100, 131}, {0.0, 31 * dt});
  SynthOptions unwarped;
  unwarped.warp_fill = false;
  auto s = synthesise(*index, q, unwarped);
  ASSERT_NE(s, nullptr);
  const SynthResult& r = s->result;
  ASSERT_EQ(r.frames.size(), 32u);
  EXPECT_DOUBLE_EQ(r.frame_time_s, dt);
  expect_key_pose(r.frames.front(), walk_frame(*index, 100), "first key");
  expect_key_pose(r.frames.back(), walk_frame(*index, 131), "second key");
  ASSERT_EQ(r.timing.size(), 1u);
  const PairTiming& t = r.timing[0];
  EXPECT_FALSE(t.direct);
  EXPECT_EQ(1 + t.in_frames + t.piece_frames + t.out_frames + 1, r.frames.size());
  EXPECT_GE(t.warp, kMinTimeWarp * 0.9);
  EXPECT_LE(t.warp, kMaxTimeWarp * 1.1);
  // The second key pose keeps its place relative to the first, as in the file.
  const Eigen::Vector3d moved =
      walk_frame(*index, 131).root_position_m - walk_frame(*index, 100).root_position_m;
  const Eigen::Vector3d out_moved =
      r.frames.back().root_position_m - r.frames.front().root_position_m;
  EXPECT_LT((moved - out_moved).norm(), 1e-3);

  SynthOptions at60 = unwarped;
  at60.fps = 60.0;
  auto s60 = synthesise(*index, q, at60);
  ASSERT_NE(s60, nullptr);
  EXPECT_EQ(s60->result.frames.size(), static_cast<std::size_t>(std::llround(31 * dt * 60.0)) + 1);
  expect_key_pose(s60->result.frames.back(), walk_frame(*index, 131), "second key at 60 fps");
}

TEST(TimedKeyPoses, APairTooShortForAPartialMotionIsFilledDirectly) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  const double dt =
      index->clips()[test::clip_named(*index, kWalk.filename().string())].frame_time_s;
  // Pairs of 6 frames (direct) and 40 frames.
  auto s = synthesise(*index, timed_walk({100, 106, 146}, {0.0, 6 * dt, 46 * dt}));
  ASSERT_NE(s, nullptr);
  const SynthResult& r = s->result;
  ASSERT_EQ(r.frames.size(), 47u);
  ASSERT_EQ(r.timing.size(), 2u);
  EXPECT_TRUE(r.timing[0].direct);
  EXPECT_EQ(r.timing[0].in_frames, 5u);
  EXPECT_FALSE(r.timing[1].direct);
  EXPECT_EQ(r.timing[1].key_frame, 6u);
  expect_key_pose(r.frames[6], walk_frame(*index, 106), "middle key");
  expect_key_pose(r.frames[46], walk_frame(*index, 146), "last key");
}

TEST(TimedKeyPoses, FpsNeedsATimedQuery) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  const std::string file = fs::absolute(test::data_dir() / kWalk).string();
  SynthOptions at60;
  at60.fps = 60.0;
  const std::string q = R"({"top": 1, "frames": [{"bvh": ")" + file +
                        R"(", "frame": 10}, {"bvh": ")" + file + R"(", "frame": 40}]})";
  EXPECT_THROW(synthesise(*index, q, at60), InputError);
}

TEST(TimedKeyPoses, WarpByNameNeedsATimedQuery) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  const std::string file = fs::absolute(test::data_dir() / kWalk).string();
  SynthOptions warp;
  warp.warp_required = true;
  const std::string text = R"({"top": 1, "frames": [{"bvh": ")" + file +
                           R"(", "frame": 10}, {"bvh": ")" + file + R"(", "frame": 40}]})";
  const Query q = parse_query_text(text, "<test>", 0, fs::current_path(), "q");
  EXPECT_THROW(query_for_fill(q, warp), InputError);
  EXPECT_THROW(synthesise(*index, text, warp), InputError);
  // By default (warp_fill, not asked for by name) an untimed query is not
  // warped: searched as given, synthesised without timing.
  EXPECT_TRUE(SynthOptions{}.warp_fill);
  EXPECT_EQ(query_for_fill(q, SynthOptions{}).transition_time_s, q.transition_time_s);
  auto s = synthesise(*index, text);
  ASSERT_NE(s, nullptr);
  EXPECT_TRUE(s->result.timing.empty());
}

TEST(TimedKeyPoses, AWarpedFillPassesEachKeyPoseAtItsTime) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  const double dt =
      index->clips()[test::clip_named(*index, kWalk.filename().string())].frame_time_s;
  SynthOptions warp;
  warp.warp_fill = true;
  // Pairs of 6 frames (direct: not warped) and 40 frames (warped); the
  // search ranks partial motions spanning the pair (query_for_fill).
  const Query q =
      query_for_fill(parse_query_text(timed_walk({100, 106, 146}, {0.0, 6 * dt, 46 * dt}), "<test>",
                                      0, fs::current_path(), "q"),
                     warp);
  EXPECT_LE(q.transition_time_s, kWarpTransitionS);
  const QueryOutcome found = SearchEngine(*index).run(q, SearchOptions{});
  ASSERT_FALSE(found.error);
  std::optional<SynthSkeleton> sk;
  const SynthResult r = synthesize(*index, q, found.pairs, warp, sk);
  ASSERT_EQ(r.frames.size(), 47u);
  ASSERT_EQ(r.timing.size(), 2u);
  EXPECT_TRUE(r.timing[0].direct);
  EXPECT_FALSE(r.timing[0].warped);
  EXPECT_TRUE(r.timing[1].warped);
  expect_key_pose(r.frames[6], walk_frame(*index, 106), "middle key");
  expect_key_pose(r.frames[46], walk_frame(*index, 146), "last key");
  // The transitions' measures are those of the frames in their place.
  for (const TransitionReport& t : r.transitions) EXPECT_GE(t.measures.work_energy_J, 0.0);
}

namespace {

// The choice among candidates against its brute reference: every candidate
// picked by its rank alone (the pair then warps that one, placed the same
// way); the chosen one has the least score (warp size + weight x W of the
// warped fill) of the first five that can be picked, and its motion is the
// picked run's, frame for frame (to 1e-5: the target skeleton's root offset
// comes from the first chosen clip's frame 0, the ranking's best before the
// choice, the picked one alone). `weight` 0 is the smallest warp alone.
void expect_least_score_taken(double weight) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  const double dt =
      index->clips()[test::clip_named(*index, kWalk.filename().string())].frame_time_s;
  std::string text = timed_walk({100, 140}, {0.0, 40 * dt});
  text.replace(text.find(R"("top": 1)"), 8, R"("top": 8)");
  SynthOptions warp;
  warp.warp_fill = true;
  warp.warp_candidates = 5;
  warp.warp_work_weight_m_per_J = weight;
  const auto run = fill_run(*index, text, warp);
  ASSERT_NE(run, nullptr);
  const Query& q = run->query;
  const QueryOutcome& found = run->found;
  const SynthResult& chosen = run->result;
  ASSERT_EQ(chosen.timing.size(), 1u);
  ASSERT_TRUE(chosen.timing[0].warped);
  EXPECT_EQ(chosen.timing[0].warp_candidates, 5u);
  double least = std::numeric_limits<double>::infinity();
  std::size_t picked = 0;
  const auto score = [&](const PairTiming& t) { return t.warp_size_m + weight * t.warp_work_J; };
  for (const SearchResult& m : found.pairs[0].results) {
    if (picked == 5) break;
    SynthOptions one = warp;
    one.picks = {Pick{1, m.rank}};
    std::optional<SynthSkeleton> sk1;
    SynthResult r;
    try {
      r = synthesize(*index, q, found.pairs, one, sk1);
    } catch (const InputError&) {
      continue;  // shorter than the minimum length: not a candidate
    }
    ++picked;
    EXPECT_EQ(r.timing[0].warp_candidates, 1u);
    EXPECT_GT(r.timing[0].warp_work_J, 0.0);
    least = std::min(least, score(r.timing[0]));
    if (m.rank != chosen.chosen[0].rank) continue;
    EXPECT_NEAR(r.timing[0].warp_work_J, chosen.timing[0].warp_work_J,
                1e-6 * chosen.timing[0].warp_work_J);
    ASSERT_EQ(r.frames.size(), chosen.frames.size());
    for (std::size_t i = 0; i < r.frames.size(); ++i) {
      EXPECT_LT((r.frames[i].root_position_m - chosen.frames[i].root_position_m).norm(), 1e-5) << i;
      for (std::size_t j = 0; j < r.frames[i].local_rotations.size(); ++j)
        EXPECT_LT(
            r.frames[i].local_rotations[j].angularDistance(chosen.frames[i].local_rotations[j]),
            1e-5)
            << i << " " << j;
    }
  }
  EXPECT_EQ(picked, 5u);
  EXPECT_NEAR(score(chosen.timing[0]), least, 1e-6);
  // One candidate: the ranking's best.
  warp.warp_candidates = 1;
  const SynthResult first = synthesize(*index, q, found.pairs, warp, run->skeleton);
  EXPECT_EQ(first.timing[0].warp_candidates, 1u);
  EXPECT_GE(score(first.timing[0]), score(chosen.timing[0]));
  // Here the choice matters: the ranking's best is not the least score.
  EXPECT_NE(first.chosen[0].rank, chosen.chosen[0].rank)
      << score(first.timing[0]) << " " << score(chosen.timing[0]);
}

TEST(TimedKeyPoses, AWarpedPairTakesTheCandidateWithTheSmallestWarpWithoutTheWorkWeight) {
  expect_least_score_taken(0.0);
}

TEST(TimedKeyPoses, AWarpedPairTakesTheCandidateWithTheLeastWarpAndWork) {
  expect_least_score_taken(SynthOptions{}.warp_work_weight_m_per_J);
}

TEST(TimedKeyPoses, RefusesAWorkWeightThatIsNotAFiniteNonNegativeNumber) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  const double dt =
      index->clips()[test::clip_named(*index, kWalk.filename().string())].frame_time_s;
  for (const double bad :
       {-1e-4, std::numeric_limits<double>::infinity(), std::numeric_limits<double>::quiet_NaN()}) {
    SynthOptions o;
    o.warp_work_weight_m_per_J = bad;
    try {
      (void)synthesise(*index, timed_walk({100, 140}, {0.0, 40 * dt}), o);
      ADD_FAILURE() << bad << " accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("--warp-work-weight"), std::string::npos) << e.what();
    }
  }
}

}  // namespace

namespace {

// The report pictures the partial motion a warped pair took, wherever it
// ranks: a held-out sideways walk whose better-ranked partial motions are
// takes of rigs the target skeleton cannot play (the pair takes rank 9).
TEST(TimedKeyPoses, TheReportPicturesThePartialMotionThePairTook) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  const std::string file =
      fs::absolute(test::data_dir() / "bandai-namco-1/data/dataset-1_walk-right_angry_001.bvh")
          .string();
  const std::string text = R"({"id": "side", "frames": [{"bvh": ")" + file +
                           R"(", "frame": 60, "time_s": 0}, {"bvh": ")" + file +
                           R"(", "frame": 91, "time_s": 1.0333323}],)" +
                           R"( "filter": {"exclude": ["dataset-1_walk-right_angry_001*"]}})";
  const SynthOptions options;
  const auto run = fill_run(*index, text, options);
  ASSERT_NE(run, nullptr);
  const SynthResult& r = run->result;
  ASSERT_EQ(r.chosen.size(), 1u);
  ASSERT_TRUE(r.timing[0].warped);
  const std::size_t taken = r.chosen[0].rank;
  EXPECT_GT(taken, 5u);  // beyond the ranks the report always draws
  const std::string html =
      synth_report_html(ClipSource(*index), run->query, run->found.pairs, r, options);
  const std::string id = "data-figure=\"filmstrip-pair1-rank" + std::to_string(taken) + "\"";
  EXPECT_NE(html.find(id), std::string::npos) << id;
  EXPECT_NE(html.find(", taken"), std::string::npos);
  // Ranks 1 to 5 are still drawn, and no other rank beyond them.
  EXPECT_NE(html.find("data-figure=\"filmstrip-pair1-rank1\""), std::string::npos);
  for (std::size_t k = 6; k < taken; ++k)
    EXPECT_EQ(html.find("data-figure=\"filmstrip-pair1-rank" + std::to_string(k) + "\""),
              std::string::npos)
        << k;
}

}  // namespace
