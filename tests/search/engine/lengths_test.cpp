// Length limits of a partial motion in world placement (SearchOptions /
// Query min_length_s, max_length_s): the sliding-window minimum equals its
// quadratic reference under random limits; on a set-1 index exact equals
// brute under non-default limits, every result keeps the limits, and the
// ranking equals one computed here from the per-frame h values of
// SearchEngine::frame_bounds.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "mocap/common/io/index.hpp"
#include "mocap/search/query.hpp"
#include "mocap/search/search.hpp"
#include "mocap/search/timing.hpp"
#include "search_fixtures.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;
using namespace mocap;

namespace {

using test::parse;

const fs::path& set1_index() {
  return test::set1_index("lengths-set1");
}

// A partial motion's length limits in frames, as the search turns seconds
// into them: round(seconds / frame time), the lower at least 1, the upper at
// least the lower.
std::pair<std::size_t, std::size_t> limit_frames(double min_s, double max_s, double dt) {
  auto frames = [dt](double seconds) {
    return std::max<std::size_t>(1, static_cast<std::size_t>(std::llround(seconds / dt)));
  };
  const std::size_t lo = frames(min_s);
  return {lo, std::max(lo, frames(max_s))};
}

// Random world-placement queries over set 1 (full BVH frames, root-only,
// root and heading, joint rotations, BVH "only"), two or three frames, some
// with a path weight or a content filter, some with their own length limits
// (min_length_s 0.1-0.6 s, max_length_s 0.5-2.5 s).
std::vector<Query> random_world_queries(const Index& index, std::size_t count, unsigned seed) {
  std::mt19937 rng(seed);
  const auto& clips = index.clips();
  std::vector<Query> out;
  for (std::size_t i = 0; i < count; ++i) {
    const int kind = static_cast<int>(i % 6);
    std::string frames;
    const std::size_t nframes = 2 + (rng() % 4 == 0 ? 1 : 0);
    for (std::size_t f = 0; f < nframes; ++f) {
      const std::size_t c = rng() % clips.size();
      const std::string bvh = "\"bvh\": \"" + clips[c].path +
                              "\", \"frame\": " + std::to_string(rng() % clips[c].frame_count);
      const std::string x = std::to_string((rng() % 800) / 100.0 - 4.0),
                        z = std::to_string((rng() % 800) / 100.0 - 4.0);
      std::string one;
      switch (kind) {
        case 0:
        case 1:
          one = "{" + bvh + "}";
          break;
        case 2:
          one = "{\"root_position\": [" + x + ", " + (rng() % 2 ? "null" : "0.9") + ", " + z + "]}";
          break;
        case 3:
          one = "{\"root_position\": [" + x + ", null, " + z +
                "], \"root_heading_deg\": " + std::to_string(rng() % 360) + "}";
          break;
        case 4:
          one = "{\"joints\": {\"RightForeArm\": {\"euler_deg\": [" + std::to_string(rng() % 90) +
                ", 0, 10], \"order\": \"ZXY\"}}}";
          break;
        default:
          one = "{" + bvh + ", \"only\": [\"root_position_xz\", \"LeftUpperArm\"]}";
          break;
      }
      frames += (f ? ", " : "") + one;
    }
    std::string extra = ", \"top\": " + std::to_string(1 + rng() % 8);
    if (i % 5 == 2) extra += ", \"path_weight\": 0.01";
    if (i % 7 == 3) extra += ", \"filter\": {\"content\": [\"walk\", \"run\"]}";
    if (i % 4 == 1) extra += ", \"min_length_s\": " + std::to_string(0.1 + 0.1 * (rng() % 6));
    if (i % 4 == 2) extra += ", \"max_length_s\": " + std::to_string(0.5 + 0.5 * (rng() % 5));
    out.push_back(parse("{\"id\": \"w" + std::to_string(i) +
                        "\", \"relative\": false, \"frames\": [" + frames + "]" + extra + "}"));
  }
  return out;
}

}  // namespace

// The sliding-window minimum gives the quadratic loop's pair under random
// limits (ties common: integer values), and the pair keeps the limits.
TEST(LengthLimits, SlidingMinimumEqualsQuadraticReference) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 10.0);
  const double inf = std::numeric_limits<double>::infinity();
  std::size_t found = 0, at_min = 0, at_max = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    const std::size_t k = 1 + rng() % 60;
    std::vector<double> a(k), b(k), p(k);
    double acc = 0.0;
    for (std::size_t i = 0; i < k; ++i) {
      a[i] = rng() % 7 == 0 ? inf : std::floor(u(rng));
      b[i] = rng() % 7 == 0 ? inf : std::floor(u(rng));
      p[i] = acc;
      acc += std::floor(u(rng));
    }
    const double lambda = trial % 3 == 0 ? 0.0 : 0.25 * (trial % 5);
    const std::size_t min_gap = 1 + rng() % 8;
    const std::size_t max_gap = min_gap + rng() % (trial % 4 == 0 ? 80 : 12);
    ClipBest x, y;
    const bool hx =
        best_partial_motion(a.data(), b.data(), p.data(), k, lambda, min_gap, max_gap, x);
    const bool hy =
        best_partial_motion_quadratic(a.data(), b.data(), p.data(), k, lambda, min_gap, max_gap, y);
    ASSERT_EQ(hx, hy) << trial;
    if (!hx) continue;
    ++found;
    EXPECT_EQ(x.score, y.score) << trial;
    EXPECT_EQ(x.s, y.s) << trial;
    EXPECT_EQ(x.e, y.e) << trial;
    EXPECT_GE(x.e - x.s, min_gap) << trial;
    EXPECT_LE(x.e - x.s, max_gap) << trial;
    at_min += x.e - x.s == min_gap;
    at_max += x.e - x.s == max_gap;
  }
  EXPECT_GT(found, 2000u);
  // The limits bind: some best pairs sit on them.
  EXPECT_GT(at_min, 50u);
  EXPECT_GT(at_max, 50u);
}

TEST(LengthLimits, InvalidGapsAreCallerErrors) {
  const std::vector<double> a(4, 1.0), b(4, 1.0), p(4, 0.0);
  ClipBest out;
  for (const auto& [lo, hi] : {std::pair<std::size_t, std::size_t>{0, 3}, {3, 2}}) {
    EXPECT_THROW(best_partial_motion(a.data(), b.data(), p.data(), 4, 0.0, lo, hi, out),
                 std::invalid_argument);
    EXPECT_THROW(best_partial_motion_quadratic(a.data(), b.data(), p.data(), 4, 0.0, lo, hi, out),
                 std::invalid_argument);
  }
  // A clip shorter than the lower limit has no pair.
  EXPECT_FALSE(best_partial_motion(a.data(), b.data(), p.data(), 4, 0.0, 4, 6, out));
  ASSERT_TRUE(best_partial_motion(a.data(), b.data(), p.data(), 4, 0.0, 3, 6, out));
  EXPECT_EQ(out.s, 0u);
  EXPECT_EQ(out.e, 3u);
}

// World placement on set 1 with limits other than the defaults (in the
// options and in some queries): exact equals brute bit for bit, every
// result keeps its query's limits, some sit on them, and exact prunes.
TEST(LengthLimits, WorldExactEqualsBruteSet1) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(set1_index().empty()) << "could not build the set-1 index";
  const Index index = Index::open(set1_index());
  const SearchEngine engine(index);
  // 120 queries (30 under the sanitizers: test_support.hpp).
  const std::size_t count = test::kSanitizerBuild ? 30 : 120;
  const auto queries = random_world_queries(index, count, 31);
  // Option limits by query: short and tight, long, one-frame minimum.
  const std::tuple<double, double> option_limits[] = {{0.3, 0.8}, {0.5, 3.0}, {0.03, 0.4}};
  std::size_t results = 0, at_limit = 0, pruned_somewhere = 0;
  for (std::size_t i = 0; i < queries.size(); ++i) {
    const Query& q = queries[i];
    SearchOptions exact, brute;
    std::tie(exact.min_length_s, exact.max_length_s) = option_limits[i % 3];
    if (q.max_length_s) exact.min_length_s = std::min(exact.min_length_s, *q.max_length_s);
    if (q.min_length_s) exact.max_length_s = std::max(exact.max_length_s, *q.min_length_s);
    brute.min_length_s = exact.min_length_s;
    brute.max_length_s = exact.max_length_s;
    brute.mode = SearchMode::brute;
    const auto e = engine.run(q, exact);
    const auto b = engine.run(q, brute);
    test::expect_same_results(e, b, q.id, 0.0);  // scores equal
    pruned_somewhere += e.stats.frames_pruned > 0;
    EXPECT_EQ(b.stats.frames_pruned, 0u);
    EXPECT_LE(e.stats.frames_evaluated, b.stats.frames_evaluated) << q.id;
    const double min_s = q.min_length_s.value_or(exact.min_length_s);
    const double max_s = q.max_length_s.value_or(exact.max_length_s);
    for (const auto& pair : e.pairs)
      for (const auto& r : pair.results) {
        const auto [lo, hi] = limit_frames(min_s, max_s, index.clips()[r.clip_index].frame_time_s);
        ASSERT_GT(r.end_frame, r.start_frame) << q.id;
        EXPECT_GE(r.end_frame - r.start_frame, lo) << q.id;
        EXPECT_LE(r.end_frame - r.start_frame, hi) << q.id;
        at_limit += r.end_frame - r.start_frame == lo || r.end_frame - r.start_frame == hi;
        ++results;
      }
  }
  EXPECT_GT(results, count * 5 / 2);
  EXPECT_GT(at_limit, results / 10) << "the limits should bind";
  EXPECT_GE(pruned_somewhere, queries.size() / 2) << "exact mode should prune";
}

// Two-frame world queries without a path weight: the ranking (best pair per
// clip within the limits, by score, clip, e, s) computed here from the
// engine's per-frame h values (frame_bounds) and the quadratic reference
// equals exact's and brute's.
TEST(LengthLimits, WorldRankingEqualsPerFrameReferenceSet1) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(set1_index().empty()) << "could not build the set-1 index";
  const Index index = Index::open(set1_index());
  const SearchEngine engine(index);
  const auto& clips = index.clips();
  std::mt19937 rng(5);
  for (std::size_t i = 0; i < 12; ++i) {
    auto bvh = [&] {
      const std::size_t c = rng() % clips.size();
      return "{\"bvh\": \"" + clips[c].path +
             "\", \"frame\": " + std::to_string(rng() % clips[c].frame_count) + "}";
    };
    const std::string root = "{\"root_position\": [" + std::to_string(0.5 * (i % 5)) + ", null, " +
                             std::to_string(-0.3 * (i % 4)) + "]}";
    const std::string first = bvh();
    const std::string second = i % 3 == 2 ? root : bvh();
    const double min_s = 0.1 * static_cast<double>(1 + i % 5),
                 max_s = min_s + 0.4 * static_cast<double>(i % 4);
    const Query q =
        parse("{\"id\": \"f" + std::to_string(i) + "\", \"relative\": false, \"top\": 6, " +
              "\"min_length_s\": " + std::to_string(min_s) + ", \"max_length_s\": " +
              std::to_string(max_s) + ", \"frames\": [" + first + ", " + second + "]}");
    // Reference: per clip, the quadratic loop over frame_bounds' engine_h.
    struct Ref {
      double score;
      std::size_t clip, s, e;
    };
    std::vector<Ref> refs;
    for (std::size_t k = 0; k < index.skeletons().size(); ++k) {
      const FrameBounds fa = engine.frame_bounds(q, 0, k), fb = engine.frame_bounds(q, 1, k);
      for (std::size_t c = 0; c < clips.size(); ++c) {
        if (clips[c].skeleton != k) continue;
        const std::size_t n = clips[c].frame_count, g = clips[c].frame_start;
        const auto [lo, hi] = limit_frames(*q.min_length_s, *q.max_length_s, clips[c].frame_time_s);
        const std::vector<double> zero(n, 0.0);
        ClipBest best;
        if (best_partial_motion_quadratic(fa.engine_h.data() + g, fb.engine_h.data() + g,
                                          zero.data(), n, 0.0, lo, hi, best))
          refs.push_back({best.score, c, best.s, best.e});
      }
    }
    std::sort(refs.begin(), refs.end(), [](const Ref& x, const Ref& y) {
      return std::tie(x.score, x.clip, x.e, x.s) < std::tie(y.score, y.clip, y.e, y.s);
    });
    ASSERT_GE(refs.size(), q.top);
    for (const SearchMode mode : {SearchMode::exact, SearchMode::brute}) {
      SearchOptions opt;
      opt.mode = mode;
      const QueryOutcome out = engine.run(q, opt);
      ASSERT_FALSE(out.error) << *out.error;
      ASSERT_EQ(out.pairs.size(), 1u);
      const auto& results = out.pairs[0].results;
      ASSERT_EQ(results.size(), q.top) << q.id;
      for (std::size_t r = 0; r < results.size(); ++r) {
        EXPECT_EQ(results[r].clip_index, refs[r].clip) << q.id << " rank " << r + 1;
        EXPECT_EQ(results[r].start_frame, refs[r].s) << q.id << " rank " << r + 1;
        EXPECT_EQ(results[r].end_frame, refs[r].e) << q.id << " rank " << r + 1;
        EXPECT_NEAR(results[r].score_J, refs[r].score, 1e-9 * std::max(1.0, refs[r].score))
            << q.id << " rank " << r + 1;
      }
    }
  }
}

// Timed key poses (docs/queries.md "Timed key poses"): each pair ranks
// partial motions whose captured length fits the time between its key poses
// (timed_pair_window), in relative and world placement, exact equal to
// brute; a pair too short for any partial motion ranks the minimum length.
TEST(LengthLimits, TimedPairsRankPartialMotionsThatFitTheirInterval) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(set1_index().empty()) << "could not build the set-1 index";
  const Index index = Index::open(set1_index());
  const SearchEngine engine(index);
  const std::string walk =
      (test::data_dir() / "bandai-namco-1/data/dataset-1_walk_normal_001.bvh").string();
  const double times[] = {0.0, 0.2, 1.2, 3.2};  // intervals 0.2 s (direct), 1 s, 2 s
  for (const char* relative : {"true", "false"}) {
    std::string frames;
    for (std::size_t i = 0; i < 4; ++i)
      frames += std::string(i ? ", " : "") + R"({"bvh": ")" + walk + R"(", "frame": )" +
                std::to_string(40 + 30 * i) + R"(, "time_s": )" + std::to_string(times[i]) + "}";
    const Query q =
        parse(R"({"id": "timed", "relative": )" + std::string(relative) + R"(, "frames": [)" +
              frames + R"(], "filter": {"exclude": ["dataset-1_walk_normal_001*"]}})");
    ASSERT_TRUE(q.timed());
    SearchOptions exact, brute;
    brute.mode = SearchMode::brute;
    const auto e = engine.run(q, exact);
    const auto b = engine.run(q, brute);
    test::expect_same_results(e, b, q.id, 0.0);
    ASSERT_EQ(e.pairs.size(), 3u);
    for (std::size_t h = 0; h < 3; ++h) {
      const TimedPairWindow w =
          timed_pair_window(times[h + 1] - times[h], q.transition_time_s, exact.min_length_s);
      EXPECT_EQ(w.direct, h == 0);
      ASSERT_FALSE(e.pairs[h].results.empty()) << relative << " pair " << h;
      for (const auto& r : e.pairs[h].results) {
        const auto [lo, hi] =
            limit_frames(w.min_length_s, w.max_length_s, index.clips()[r.clip_index].frame_time_s);
        EXPECT_GE(r.end_frame - r.start_frame, lo) << relative << " pair " << h;
        EXPECT_LE(r.end_frame - r.start_frame, hi) << relative << " pair " << h;
      }
    }
  }
}
