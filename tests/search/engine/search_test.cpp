// Search: running minimum, query resolution errors, exact == brute on random
// queries over a set-1 index, threads 1 == 2, approx recall.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>

#include "mocap/common/io/hdf5.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/search/query.hpp"
#include "mocap/search/query_pose.hpp"
#include "mocap/search/search.hpp"
#include "search_fixtures.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;
using namespace mocap;

namespace {

using test::build_index_with_binary;
using test::build_set1_index;
using test::expect_same_results;
using test::golden_index;
using test::parse;

const fs::path& set1_index() {
  return test::set1_index("search-set1");
}

// A character that changes masses (total, sex, a class, a joint) and bone
// lengths (upper arms, thighs), written once per test run.
const fs::path& test_character() {
  static const fs::path path = [] {
    const fs::path p = test::temp_dir("search-character") / "char.json";
    std::ofstream(p)
        << R"({"version": 1, "name": "test-heavy-long", "total_mass_kg": 82, "sex": "female",
      "segments": {"upper_arm": {"mass_kg": 4.0, "length_scale": 1.15}, "thigh": {"length_scale": 0.9}},
      "joints": {"LeftHand": {"mass_kg": 1.5}}})";
    return p;
  }();
  return path;
}

// Number of random queries of the exact == brute test: MOCAP_SEARCH_TEST_QUERIES
// (default 220; sanitizer runs set fewer). The other random-query tests use
// a fifth of it (at least 10).
std::size_t random_query_count() {
  const char* v = std::getenv("MOCAP_SEARCH_TEST_QUERIES");
  if (v == nullptr || *v == '\0') return 220;
  const long n = std::strtol(v, nullptr, 10);
  return n > 0 ? static_cast<std::size_t>(n) : 220;
}
std::size_t small_query_count() {
  return std::max<std::size_t>(10, random_query_count() / 5);
}

// Helpers of the per-frame tests over a set-1 index (bounds, subtree kernel).
// `"bvh": PATH, "frame": K` of a random frame of a random clip.
std::string random_bvh_frame(const Index& index, std::mt19937& rng) {
  const auto& clips = index.clips();
  const std::size_t c = rng() % clips.size();
  return "\"bvh\": \"" + clips[c].path +
         "\", \"frame\": " + std::to_string(rng() % clips[c].frame_count);
}
// A random whole angle in degrees, -180..179.
std::string random_deg(std::mt19937& rng) {
  return std::to_string(static_cast<int>(rng() % 360) - 180);
}
// Test query i (world placement): query frame `frame`, then the origin;
// T = 0.25, 0.5, 1 s by i % 3.
Query frame_to_origin_query(const std::string& frame, std::size_t i) {
  const double t = i % 3 == 0 ? 0.25 : (i % 3 == 1 ? 0.5 : 1.0);
  return parse("{\"relative\": false, \"frames\": [" + frame +
               ", {\"root_position\": [0, null, 0]}], \"transition_time\": " + std::to_string(t) +
               "}");
}

// Joint-rotation query frame i (by i % 4) of the subtree tests: a forearm, a
// shoulder with `below` (a joint further down its arm), both upper legs, or
// the right arm of `bvh` (a "bvh"/"frame" pair); random Euler angles.
std::string joint_rotation_frame(std::size_t i, std::mt19937& rng, const std::string& bvh,
                                 const std::string& below) {
  auto euler = [&] {
    return "{\"euler_deg\": [" + random_deg(rng) + ", " + random_deg(rng) + ", " + random_deg(rng) +
           "], \"order\": \"ZXY\"}";
  };
  switch (i % 4) {
    case 0:
      return "{\"joints\": {\"RightForeArm\": " + euler() + "}}";
    case 1:
      return "{\"joints\": {\"LeftShoulder\": " + euler() + ", \"" + below + "\": " + euler() +
             "}}";
    case 2:
      return "{\"joints\": {\"LeftUpLeg\": " + euler() + ", \"RightUpLeg\": " + euler() + "}}";
    default:
      return "{" + bvh + ", \"only\": [\"RightUpperArm\", \"RightForeArm\"]}";
  }
}

}  // namespace

TEST(RunningMinimum, EqualsQuadraticReference) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 10.0);
  const double inf = std::numeric_limits<double>::infinity();
  for (int trial = 0; trial < 2000; ++trial) {
    const std::size_t k = 1 + rng() % 40;
    std::vector<double> a(k), b(k), p(k);
    double acc = 0.0;
    for (std::size_t i = 0; i < k; ++i) {
      a[i] = rng() % 7 == 0 ? inf : std::floor(u(rng));  // integers make ties common
      b[i] = rng() % 7 == 0 ? inf : std::floor(u(rng));
      p[i] = acc;
      acc += std::floor(u(rng));
    }
    const double lambda = trial % 3 == 0 ? 0.0 : 0.25 * (trial % 5);
    ClipBest x, y;
    // No length limits: 1 <= e - s <= k (tests/search/lengths_test.cpp draws limits).
    const bool hx = best_partial_motion(a.data(), b.data(), p.data(), k, lambda, 1, k, x);
    const bool hy = best_partial_motion_quadratic(a.data(), b.data(), p.data(), k, lambda, 1, k, y);
    ASSERT_EQ(hx, hy) << trial;
    if (!hx) continue;
    EXPECT_EQ(x.score, y.score) << trial;
    EXPECT_EQ(x.s, y.s) << trial;
    EXPECT_EQ(x.e, y.e) << trial;
    EXPECT_LT(x.s, x.e);
  }
}

TEST(QueryResolution, Errors) {
  const Index index = Index::open(golden_index());
  const SearchEngine engine(index);
  SearchOptions opt;
  opt.min_length_s = 0.05;  // the golden clips are 3 frames of 0.05 s
  // Unknown joint: the message lists the valid names.
  try {
    engine.run(
        parse(
            R"({"frames": [{"joints": {"Tail": {"quat": [1,0,0,0]}}}, {"root_position": [0, null, 0]}]})"),
        opt);
    FAIL() << "expected an error";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("frames[0].joints.Tail"), std::string::npos) << m;
    EXPECT_NE(m.find("unknown joint"), std::string::npos) << m;
    EXPECT_NE(m.find("Hips"), std::string::npos) << m;
  }
  // Bad BVH path.
  try {
    engine.run(
        parse(
            R"({"frames": [{"bvh": "no-such-file.bvh", "frame": 0}, {"root_position": [0, null, 0]}]})"),
        opt);
    FAIL() << "expected an error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no-such-file.bvh"), std::string::npos) << e.what();
  }
  // Frame out of range.
  try {
    engine.run(
        parse(
            R"({"frames": [{"bvh": "golden_walk_normal_001.bvh", "frame": 100000}, {"root_position": [0, null, 0]}]})"),
        opt);
    FAIL() << "expected an error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("out of range"), std::string::npos) << e.what();
  }
  // Aliases resolve: the CMU name RightUpLeg and the Bandai Namco name
  // UpperLeg_R mean the same joint (the golden skeleton has legs, no arms).
  const auto x = engine.run(
      parse(
          R"({"frames": [{"joints": {"RightUpLeg": {"euler_deg": [0,0,60], "order": "ZXY"}}}, {"root_position": [0, null, 0]}]})"),
      opt);
  const auto y = engine.run(
      parse(
          R"({"frames": [{"joints": {"UpperLeg_R": {"euler_deg": [0,0,60], "order": "ZXY"}}}, {"root_position": [0, null, 0]}]})"),
      opt);
  expect_same_results(x, y, "aliases");
  ASSERT_FALSE(x.pairs[0].results.empty());
}

// Query frames from indexed, unchanged files are read through a +-2 frame
// window of the file (QueryBvhCache::use_index, parse_bvh_window): the
// resolved pose is bit for bit the one from parsing the whole file, at the
// clip's ends too; a file the index does not hold is parsed whole.
TEST(QueryResolution, IndexedFileWindowEqualsWholeFileSet1) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(set1_index().empty());
  const Index index = Index::open(set1_index());
  QueryBvhCache windowed, whole;
  windowed.use_index(index);
  std::mt19937 rng(5);
  std::size_t compared = 0;
  for (int trial = 0; trial < 12; ++trial) {
    const IndexClip& clip = index.clips()[rng() % index.clips().size()];
    const std::size_t n = clip.frame_count;
    for (std::size_t frame : {std::size_t{0}, std::size_t{1}, n / 2, n - 2, n - 1}) {
      const Query q = parse("{\"frames\": [{\"bvh\": \"" + clip.path +
                            "\", \"frame\": " + std::to_string(frame) + "}, {\"bvh\": \"" +
                            clip.path + "\", \"frame\": " + std::to_string(frame) +
                            ", \"only\": [\"root_heading\", \"RightForeArm\"]}]}");
      const IndexSkeleton& sk = index.skeletons()[clip.skeleton];
      const DynamicsModel model = index.dynamics_model(clip.skeleton);
      const auto file = windowed.get_frames(clip.path, index.info().unit_option, frame, 2);
      EXPECT_EQ(file->file_frame_count, n);
      EXPECT_EQ(file->first_frame, frame >= 2 ? frame - 2 : 0);
      EXPECT_LE(file->motion.frame_count, 5u);
      for (std::size_t i = 0; i < 2; ++i) {
        const ResolvedQueryPose x =
            resolve_query_pose(q, i, sk, model, windowed, index.info().unit_option);
        const ResolvedQueryPose y =
            resolve_query_pose(q, i, sk, model, whole, index.info().unit_option);
        ASSERT_EQ(x.full, y.full);
        ASSERT_EQ(x.local_rotations.size(), y.local_rotations.size());
        for (std::size_t j = 0; j < x.local_rotations.size(); ++j)
          ASSERT_EQ(x.local_rotations[j].coeffs(), y.local_rotations[j].coeffs());
        ASSERT_EQ(x.given.joint_rotations.size(), y.given.joint_rotations.size());
        for (std::size_t j = 0; j < x.given.joint_rotations.size(); ++j)
          ASSERT_EQ(x.given.joint_rotations[j].second.coeffs(),
                    y.given.joint_rotations[j].second.coeffs());
        ASSERT_EQ(x.given.root_heading_rad, y.given.root_heading_rad);
        ASSERT_EQ(x.given.root_position_m, y.given.root_position_m);
        if (!x.full) continue;
        for (std::size_t j = 0; j < x.state.joint_positions_m.size(); ++j) {
          ASSERT_EQ(x.state.joint_positions_m[j], y.state.joint_positions_m[j])
              << clip.path << " " << frame;
          ASSERT_EQ(x.state.rotations[j].coeffs(), y.state.rotations[j].coeffs());
          ASSERT_EQ(x.state.coms_m[j], y.state.coms_m[j]);
          ASSERT_EQ(x.state.com_velocities_mps[j], y.state.com_velocities_mps[j]);
          ASSERT_EQ(x.state.com_accelerations_mps2[j], y.state.com_accelerations_mps2[j]);
          ASSERT_EQ(x.state.angular_velocities_radps[j], y.state.angular_velocities_radps[j]);
          ASSERT_EQ(x.state.angular_accelerations_radps2[j],
                    y.state.angular_accelerations_radps2[j]);
        }
        ++compared;
      }
    }
    // Past the end: the same error either way.
    const Query bad =
        parse("{\"frames\": [{\"bvh\": \"" + clip.path + "\", \"frame\": " + std::to_string(n) +
              "}, {\"root_position\": [0, null, 0]}]}");
    EXPECT_THROW((void)resolve_query_pose(bad, 0, index.skeletons()[clip.skeleton],
                                          index.dynamics_model(clip.skeleton), windowed,
                                          index.info().unit_option),
                 InputError);
  }
  EXPECT_GT(compared, 50u);
  // A file the index does not hold (a copy elsewhere) is parsed whole.
  const fs::path copy = test::temp_dir("search-window-copy") / "copy.bvh";
  fs::copy_file(index.clips()[0].path, copy, fs::copy_options::overwrite_existing);
  const auto c = windowed.get_frames(copy, index.info().unit_option, 5, 2);
  EXPECT_EQ(c->first_frame, 0u);
  EXPECT_EQ(c->motion.frame_count, index.clips()[0].frame_count);
  // Another spelling of an indexed path (not lexically normal) is the same
  // file: read through its window.
  const fs::path indexed(index.clips()[0].path);
  const auto o = windowed.get_frames(indexed.parent_path() / "." / indexed.filename(),
                                     index.info().unit_option, 5, 2);
  EXPECT_EQ(o->first_frame, 3u);
  EXPECT_EQ(o->motion.frame_count, 5u);
}

// A query frame's file fetched once (resolve_query_pose's `file` slot, as
// SearchEngine::run does across skeletons) resolves exactly as a fresh
// lookup; an unreadable file fails the same way and leaves the slot empty.
TEST(QueryResolution, FetchedFileReusedAcrossCallsSet1) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(set1_index().empty());
  const Index index = Index::open(set1_index());
  QueryBvhCache cache;
  cache.use_index(index);
  const IndexClip& clip = index.clips()[7];
  const IndexSkeleton& sk = index.skeletons()[clip.skeleton];
  const DynamicsModel model = index.dynamics_model(clip.skeleton);
  const std::string unit = index.info().unit_option;
  const Query q = parse("{\"frames\": [{\"bvh\": \"" + clip.path + "\", \"frame\": 3}, " +
                        "{\"bvh\": \"/nonexistent/x.bvh\", \"frame\": 0}]}");
  std::shared_ptr<const QueryBvhFile> slot;
  const ResolvedQueryPose fresh = resolve_query_pose(q, 0, sk, model, cache, unit);
  const ResolvedQueryPose first = resolve_query_pose(q, 0, sk, model, cache, unit, &slot);
  ASSERT_NE(slot, nullptr);
  const QueryBvhFile* fetched = slot.get();
  const ResolvedQueryPose again = resolve_query_pose(q, 0, sk, model, cache, unit, &slot);
  EXPECT_EQ(slot.get(), fetched);
  for (const ResolvedQueryPose* x : {&first, &again}) {
    ASSERT_TRUE(x->full);
    for (std::size_t j = 0; j < fresh.state.joint_positions_m.size(); ++j) {
      ASSERT_EQ(x->state.joint_positions_m[j], fresh.state.joint_positions_m[j]);
      ASSERT_EQ(x->state.com_velocities_mps[j], fresh.state.com_velocities_mps[j]);
      ASSERT_EQ(x->state.angular_accelerations_radps2[j],
                fresh.state.angular_accelerations_radps2[j]);
    }
  }
  std::shared_ptr<const QueryBvhFile> bad;
  EXPECT_THROW((void)resolve_query_pose(q, 1, sk, model, cache, unit, &bad), InputError);
  EXPECT_EQ(bad, nullptr);
}

// The verified bytes of an indexed file serve its other frames only while
// the file is unchanged: after an edit of the same size (and a new
// modification time) the next frame is read again, fails the index's hash
// and is parsed whole, with the edited value.
TEST(QueryResolution, ChangedIndexedFileIsReadAgain) {
  const fs::path dir = test::temp_dir("search-verified");
  fs::create_directories(dir / "clips");
  const fs::path file = dir / "clips" / "walk.bvh";
  fs::copy_file(fs::path(MOCAP_SOURCE_DIR) / "tests/data/index/golden_walk_normal_001.bvh", file);
  ASSERT_FALSE(build_index_with_binary(dir / "clips", dir / "i.h5", {}).empty());
  const Index index = Index::open(dir / "i.h5");
  const std::string unit = index.info().unit_option;
  const std::size_t n = index.clips()[0].frame_count;
  ASSERT_EQ(n, 4u);
  QueryBvhCache cache;
  cache.use_index(index);
  EXPECT_EQ(cache.get_frames(file, unit, 2, 1)->first_frame, 1u);
  const auto w3 = cache.get_frames(file, unit, 3, 1);  // from the verified bytes
  EXPECT_EQ(w3->first_frame, 2u);
  EXPECT_EQ(w3->motion.frame_count, 2u);
  // Edit the last frame's first digit (same size), with a later modification time.
  std::string text;
  {
    std::ifstream in(file, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    text = ss.str();
  }
  const std::size_t last_line = text.find_last_of('\n', text.size() - 2) + 1;
  const std::size_t digit = text.find_first_of("012345678", last_line);
  ASSERT_NE(digit, std::string::npos);
  ++text[digit];
  {
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out << text;
  }
  fs::last_write_time(file, fs::last_write_time(file) + std::chrono::seconds(10));
  const auto w4 = cache.get_frames(file, unit, 1, 1);  // a window would hold 3 frames
  EXPECT_EQ(w4->first_frame, 0u);
  EXPECT_EQ(w4->motion.frame_count, n);
  const QueryBvhFile whole = *QueryBvhCache().get(file, unit);
  ASSERT_EQ(whole.motion.frame_count, n);
  EXPECT_EQ(w4->motion.local_rotations, whole.motion.local_rotations);
  EXPECT_EQ(w4->motion.local_translations_m, whole.motion.local_translations_m);
}

TEST(Search, TinyIndexRankingIsSane) {
  // A query made of two frames of an indexed clip ranks that clip first with
  // those frames and score 0 (h(A, A) = 0).
  const Index index = Index::open(golden_index());
  const SearchEngine engine(index);
  for (SearchMode mode : {SearchMode::brute, SearchMode::exact}) {
    SearchOptions opt;
    opt.mode = mode;
    opt.min_length_s = 0.05;  // the golden clips are 3 frames of 0.05 s
    const auto r = engine.run(
        parse(
            R"({"relative": false, "frames": [{"bvh": "golden_walk_normal_001.bvh", "frame": 0}, {"bvh": "golden_walk_normal_001.bvh", "frame": 3}], "top": 2})"),
        opt);
    ASSERT_FALSE(r.error);
    ASSERT_FALSE(r.pairs[0].results.empty());
    const auto& best = r.pairs[0].results[0];
    EXPECT_NE(best.clip.find("golden_walk_normal_001.bvh"), std::string::npos);
    EXPECT_EQ(best.start_frame, 0u);
    EXPECT_EQ(best.end_frame, 3u);
    EXPECT_NEAR(best.score_J, 0.0, 1e-6);
    for (std::size_t i = 1; i < r.pairs[0].results.size(); ++i)
      EXPECT_GE(r.pairs[0].results[i].score_J, r.pairs[0].results[i - 1].score_J);
  }
}

namespace {

// Random queries over set 1: full frames, partial (root, ground plane +
// heading, joints, bvh "only"), world and relative, with and without filters.
std::vector<Query> random_queries(const Index& index, std::size_t count) {
  std::mt19937 rng(2024);
  const auto& clips = index.clips();
  auto frame_of = [&](std::size_t& c) {
    c = rng() % clips.size();
    return rng() % clips[c].frame_count;
  };
  std::vector<Query> out;
  const char* contents[] = {"walk", "run", "bow", "dash", "guide"};
  for (std::size_t i = 0; i < count; ++i) {
    const int kind = static_cast<int>(i % 10);
    std::string frames;
    const std::size_t nframes = 2 + (rng() % 4 == 0 ? 1 : 0);
    for (std::size_t f = 0; f < nframes; ++f) {
      std::size_t c = 0;
      const std::size_t fr = frame_of(c);
      std::string one;
      const double x = (rng() % 800) / 100.0 - 4.0, z = (rng() % 800) / 100.0 - 4.0;
      if (kind <= 3) {
        one = "{\"bvh\": \"" + clips[c].path + "\", \"frame\": " + std::to_string(fr) + "}";
      } else if (kind <= 5) {
        one = "{\"root_position\": [" + std::to_string(x) + ", " + (rng() % 2 ? "null" : "0.9") +
              ", " + std::to_string(z) + "]}";
      } else if (kind == 6) {
        one = "{\"root_position\": [" + std::to_string(x) + ", null, " + std::to_string(z) +
              "], \"root_heading_deg\": " + std::to_string(rng() % 360) + "}";
      } else if (kind == 7) {
        one = "{\"joints\": {\"RightForeArm\": {\"euler_deg\": [" + std::to_string(rng() % 90) +
              ", 0, 10], \"order\": \"ZXY\"}}}";
      } else {
        one = "{\"bvh\": \"" + clips[c].path + "\", \"frame\": " + std::to_string(fr) +
              ", \"only\": [\"root_position_xz\", \"LeftUpperArm\"]}";
      }
      frames += (f ? ", " : "") + one;
    }
    std::string extra;
    if (i % 3 == 0)
      extra +=
          ", \"filter\": {\"content\": [\"" + std::string(contents[rng() % 5]) + "\", \"walk\"]}";
    if (i % 7 == 0) extra += ", \"path_weight\": 0.01";
    if (i % 11 == 5 && kind != 6 && kind != 9)
      extra += ", \"relative\": true";
    else
      extra += ", \"relative\": false";
    extra += ", \"top\": " + std::to_string(1 + rng() % 8);
    out.push_back(parse("{\"id\": \"r" + std::to_string(i) + "\", \"frames\": [" + frames + "]" +
                        extra + "}"));
  }
  return out;
}

}  // namespace

TEST(Search, ExactEqualsBruteOnRandomQueriesSet1) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(set1_index().empty()) << "could not build the set-1 index";
  const Index index = Index::open(set1_index());
  const SearchEngine engine(index);
  const auto queries = random_queries(index, random_query_count());
  std::size_t relative = 0, pruned_somewhere = 0;
  SearchOptions exact, brute;
  exact.max_length_s = brute.max_length_s = 0.5;
  brute.mode = SearchMode::brute;
  for (const Query& q : queries) {
    const auto e = engine.run(q, exact);
    const auto b = engine.run(q, brute);
    expect_same_results(e, b, q.id);
    relative += q.relative();
    pruned_somewhere += e.stats.frames_pruned > 0;
    EXPECT_EQ(b.stats.frames_pruned, 0u);
    EXPECT_LE(e.stats.frames_evaluated, b.stats.frames_evaluated);
  }
  if (queries.size() >= 200) {
    EXPECT_GE(relative, 10u);
  }
  EXPECT_GE(pruned_somewhere, queries.size() / 2) << "exact mode should prune";
}

// A ceiling (a collection's other shards' r-th best score) keeps every
// result scoring below it, in order, and prunes more; brute ignores it, and
// so do pairs with named constraints (ranked by their verdicts too:
// docs/queries.md "Residuals and verdicts"), which give the same results.
TEST(Search, CeilingsKeepTheResultsBelowThemAndPruneMore) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(set1_index().empty()) << "could not build the set-1 index";
  const Index index = Index::open(set1_index());
  const SearchEngine engine(index);
  // 40 queries (fewer where MOCAP_SEARCH_TEST_QUERIES asks: the sanitizer run).
  const auto queries = random_queries(index, std::min<std::size_t>(40, random_query_count()));
  SearchOptions exact;
  std::size_t pruned_more = 0, i = 0;
  for (const Query& q : queries) {
    const auto free = engine.run(q, exact);
    std::vector<double> ceilings;
    for (const auto& p : free.pairs)  // the middle result's score
      ceilings.push_back(p.results.empty() ? std::numeric_limits<double>::infinity()
                                           : p.results[p.results.size() / 2].score_J);
    const auto capped = engine.run(q, exact, &ceilings);
    ASSERT_EQ(capped.pairs.size(), free.pairs.size());
    for (std::size_t h = 0; h < free.pairs.size(); ++h) {
      std::vector<const SearchResult*> below;
      for (const auto& r : capped.pairs[h].results)
        if (r.score_J < ceilings[h]) below.push_back(&r);
      std::size_t k = 0;
      for (const auto& r : free.pairs[h].results) {
        if (r.score_J >= ceilings[h]) break;
        ASSERT_LT(k, below.size()) << q.id;
        EXPECT_EQ(below[k]->clip_index, r.clip_index) << q.id;
        EXPECT_EQ(below[k]->start_frame, r.start_frame) << q.id;
        EXPECT_EQ(below[k]->end_frame, r.end_frame) << q.id;
        EXPECT_EQ(below[k]->score_J, r.score_J) << q.id;
        ++k;
      }
      EXPECT_EQ(k, below.size()) << q.id;
    }
    bool named = false;
    for (const auto& p : free.pairs)
      for (const auto& r : p.results)
        named = named || !r.residuals_from.empty() || !r.residuals_to.empty();
    if (named) {
      expect_same_results(capped, free, q.id);
    } else {
      EXPECT_LE(capped.stats.frames_evaluated, free.stats.frames_evaluated) << q.id;
      pruned_more += capped.stats.frames_evaluated < free.stats.frames_evaluated;
    }
    if (i++ % 5 == 0) {  // brute ignores ceilings (every fifth query: brute is slow)
      SearchOptions brute;
      brute.mode = SearchMode::brute;
      expect_same_results(engine.run(q, brute, &ceilings), engine.run(q, brute), q.id);
    }
  }
  EXPECT_GE(pruned_more, queries.size() / 4);
}

TEST(Search, ThreadsOneEqualsTwo) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(set1_index().empty());
  const Index index = Index::open(set1_index());
  const SearchEngine engine(index);
  const auto queries = random_queries(index, small_query_count());
  std::vector<BatchEntry> batch;
  for (const auto& q : queries) batch.push_back({q.id, q, ""});
  SearchOptions opt;
  opt.max_length_s = 0.5;
  std::vector<QueryOutcome> one, two;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    one = run_query_batch(engine, batch, opt);
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    two = run_query_batch(engine, batch, opt);
  }
  ASSERT_EQ(one.size(), two.size());
  for (std::size_t i = 0; i < one.size(); ++i) {
    expect_same_results(one[i], two[i], one[i].id);
    for (std::size_t p = 0; p < one[i].pairs.size(); ++p)
      for (std::size_t r = 0; r < one[i].pairs[p].results.size(); ++r)
        EXPECT_EQ(one[i].pairs[p].results[r].score_J, two[i].pairs[p].results[r].score_J);
  }
}

TEST(Search, ApproxRecallIsTheTopROverlapWithExact) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(set1_index().empty());
  const Index index = Index::open(set1_index());
  const SearchEngine engine(index);
  const auto queries = random_queries(index, small_query_count());
  SearchOptions approx, exact;
  approx.mode = SearchMode::approx;
  approx.approx_checks = 4;  // few checks: recall below 1 happens
  approx.approx_neighbours_per_result = 1;
  approx.max_length_s = exact.max_length_s = 0.5;
  for (const Query& q : queries) {
    const auto a = engine.run(q, approx);
    const auto e = engine.run(q, exact);
    ASSERT_TRUE(a.stats.recall.has_value());
    double sum = 0.0;
    for (std::size_t p = 0; p < a.pairs.size(); ++p) {
      std::set<std::size_t> ex;
      for (const auto& r : e.pairs[p].results) ex.insert(r.clip_index);
      std::size_t hit = 0;
      for (const auto& r : a.pairs[p].results) hit += ex.count(r.clip_index);
      sum += ex.empty() ? 1.0 : static_cast<double>(hit) / static_cast<double>(ex.size());
      // Scores in approx are true scores of the clips it returns: never better than exact's.
      if (!a.pairs[p].results.empty() && !e.pairs[p].results.empty()) {
        EXPECT_GE(a.pairs[p].results[0].score_J, e.pairs[p].results[0].score_J - 1e-9);
      }
    }
    EXPECT_NEAR(*a.stats.recall, sum / static_cast<double>(a.pairs.size()), 1e-12) << q.id;
    EXPECT_FALSE(e.stats.recall.has_value());
  }
}

// A batch prepares its engine before the first query (frame arrays, FLANN
// forests; SearchEngine::prepare): in exact mode the answers equal those of
// an engine that loads lazily in run() (random queries include partial
// frames, which read the frame arrays), preparing twice changes nothing, and
// a prepared approx batch answers every query with its recall. (Approx
// rankings are not compared across engines: FLANN's forests are random.)
TEST(Search, PreparedBatchEqualsLazyRuns) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(set1_index().empty());
  const Index index = Index::open(set1_index());
  const auto queries = random_queries(index, small_query_count());
  std::vector<BatchEntry> batch;
  for (const auto& q : queries) batch.push_back({q.id, q, ""});
  SearchOptions opt;
  opt.max_length_s = 0.5;
  const SearchEngine lazy(index), prepared(index);
  prepared.prepare(opt, true);
  const auto out = run_query_batch(prepared, batch, opt);
  ASSERT_EQ(out.size(), queries.size());
  for (std::size_t i = 0; i < queries.size(); ++i)
    expect_same_results(lazy.run(queries[i], opt), out[i], queries[i].id);
  SearchOptions approx = opt;
  approx.mode = SearchMode::approx;
  approx.approx_checks = 4;
  prepared.prepare(approx, true);
  const auto ap = run_query_batch(prepared, batch, approx);
  ASSERT_EQ(ap.size(), queries.size());
  for (const auto& o : ap) {
    ASSERT_FALSE(o.error.has_value()) << o.id << ": " << *o.error;
    ASSERT_TRUE(o.stats.recall.has_value()) << o.id;
    EXPECT_GE(*o.stats.recall, 0.0);
    EXPECT_LE(*o.stats.recall, 1.0);
  }
}

// Every lower bound exact mode uses is <= h, frame by frame, over a whole
// set-1 skeleton: full BVH frames (block boxes and whole-body sketches),
// root-only, heading (+ root position), joint rotations (one joint, a chain of
// two, random angles), BVH "only" with and without the root; several
// transition times. Also checks that the partial bounds are not trivially zero
// (they must prune), that the full-frame bounds are per frame, and that the
// chain sketches are tighter than the whole-body one.
TEST(Search, FrameLowerBoundsNeverExceedHSet1) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(set1_index().empty());
  const Index index = Index::open(set1_index());
  const SearchEngine engine(index);
  std::mt19937 rng(99);
  auto frame_json = [&] { return random_bvh_frame(index, rng); };
  auto deg = [&] { return random_deg(rng); };
  const std::size_t count = std::max<std::size_t>(12, random_query_count() / 10);
  double partial_lb_sum = 0.0, partial_h_sum = 0.0, full_lb_sum = 0.0, full_h_sum = 0.0;
  std::size_t checked = 0, full_frames = 0, sketch_misses = 0, chain_misses = 0;
  for (std::size_t i = 0; i < count; ++i) {
    std::string f;
    switch (i % 6) {
      case 0:
        f = "{" + frame_json() + "}";
        break;
      case 1:
        f = "{\"root_position\": [" + std::to_string((rng() % 600) / 100.0 - 3.0) + ", null, 0.5]}";
        break;
      case 2:
        f = "{\"root_position\": [0.3, null, -1.0], \"root_heading_deg\": " + deg() + "}";
        break;
      case 3:
        f = "{\"joints\": {\"RightForeArm\": {\"euler_deg\": [" + deg() + ", " + deg() +
            ", 10], \"order\": \"ZXY\"}}}";
        break;
      case 4:
        f = "{" + frame_json() + ", \"only\": [\"RightUpperArm\", \"RightForeArm\"]}";
        break;
      default:
        f = "{" + frame_json() + ", \"only\": [\"root_position_xz\", \"LeftUpperArm\"]}";
        break;
    }
    const Query q = frame_to_origin_query(f, i);
    for (std::size_t k = 0; k < index.skeletons().size(); ++k) {
      const FrameBounds bounds = engine.frame_bounds(q, 0, k);
      const std::vector<double>&lower = bounds.lower, &h = bounds.h, &sketch = bounds.sketch_lower,
            &chain = bounds.chain_lower;
      ASSERT_EQ(lower.size(), h.size());
      for (std::size_t g = 0; g < h.size(); ++g) {
        ASSERT_TRUE(std::isfinite(h[g])) << i << " frame " << g;
        // The engine compares with LB (1 - 1e-4) - 1e-3 J; the bound must hold with that slack.
        ASSERT_LE(lower[g] * (1.0 - 1e-4) - 1e-3, h[g])
            << "query " << i << " (" << f << ") frame " << g;
        ++checked;
        if (i % 6 >= 2) {
          partial_lb_sum += lower[g];
          partial_h_sum += h[g];
        } else if (i % 6 == 0) {
          full_lb_sum += lower[g];
          full_h_sum += h[g];
          sketch_misses += sketch[g] < 0.5 * h[g];
          chain_misses += chain[g] < 0.5 * h[g];
          ++full_frames;
        }
      }
    }
  }
  EXPECT_GT(checked, 100000u);
  // Not a vacuous bound: on average it recovers a real share of h.
  EXPECT_GT(partial_lb_sum, 0.2 * partial_h_sum);
  // Full frames: the whole-body sketches make the bound per frame (0.995 of h
  // on this data; the 16-frame block boxes alone: 0.83).
  EXPECT_GT(full_lb_sum, 0.9 * full_h_sum);
  // The chain sketches that filter the scans are per frame and tight: under
  // half of h on no full frame here, where the whole-body sketch alone is on
  // 0.5-4 % of them (depending on the queries drawn).
  EXPECT_GT(full_frames, 10000u);
  EXPECT_LT(chain_misses, full_frames / 100);
  EXPECT_LE(chain_misses, sketch_misses);
}

// Partial frames that give joint rotations only are evaluated by the
// engine's subtree kernel (forward kinematics of the given subtrees, the h-scan
// formula against the scan table): it equals partial_approximate_energy (the
// double reference on the converted frame arrays) to float precision of the
// stored data (the reference's rates are finite differences of the stored
// float joint positions: 1e-5 relative), on every frame of a set-1 index, for given joints at
// several depths (one forearm, a shoulder chain, both legs), BVH `only` frames and T = 0.25..1 s.
// Other partial frames keep the reference.
TEST(Search, SubtreeEnergyEqualsPartialEnergySet1) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(set1_index().empty());
  const Index index = Index::open(set1_index());
  const SearchEngine engine(index);
  std::mt19937 rng(7);
  double worst = 0.0, sum = 0.0;
  std::size_t checked = 0;
  for (std::size_t i = 0; i < 8; ++i) {
    const std::string bvh = random_bvh_frame(index, rng);  // drawn every time: same sequence
    const std::string f = joint_rotation_frame(i, rng, bvh, "LeftForeArm");
    const Query q = frame_to_origin_query(f, i);
    for (std::size_t k = 0; k < index.skeletons().size(); ++k) {
      const FrameBounds bounds = engine.frame_bounds(q, 0, k);
      const std::vector<double>&h = bounds.h, &engine_h = bounds.engine_h;
      ASSERT_EQ(engine_h.size(), h.size());
      for (std::size_t g = 0; g < h.size(); ++g) {
        const double err = std::abs(engine_h[g] - h[g]);
        ASSERT_LE(err, 1e-5 * h[g] + 1e-5) << "query " << i << " (" << f << ") frame " << g
                                           << ": engine " << engine_h[g] << ", reference " << h[g];
        worst = std::max(worst, err / (h[g] + 1e-3));
        sum += h[g];
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 100000u);
  EXPECT_GT(sum, 0.0);
  // The query's rotations differ from most frames: not a comparison of zeros.
  EXPECT_GT(sum / static_cast<double>(checked), 1.0);
  std::printf("subtree kernel vs reference: worst relative difference %.3g over %zu frames\n",
              worst, checked);
}

// The engine computes the per-frame bound of joint-rotation frames in float,
// vectorised over frames, from per-joint columns of the frame arrays
// (partial_bounds_columns); it equals the double reference
// (partial_frame_bounds_reference) to float rounding, on every frame of a
// set-1 index, for subtrees at several depths (a forearm, a shoulder chain
// with a given grandchild, both legs, a BVH arm), and transition times; and it
// is not the zero bound. The bound stays <= h: FrameLowerBoundsNeverExceedHSet1.
TEST(Search, PartialBoundColumnsEqualReferenceSet1) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(set1_index().empty());
  const Index index = Index::open(set1_index());
  const SearchEngine engine(index);
  std::mt19937 rng(21);
  double worst = 0.0, sum = 0.0;
  std::size_t checked = 0, positive = 0, differ = 0;
  for (std::size_t i = 0; i < 8; ++i) {
    const std::string bvh = random_bvh_frame(index, rng);
    const std::string f = joint_rotation_frame(i, rng, bvh, "LeftHand");
    Query q = frame_to_origin_query(f, i);
    q.transition_time_s = 0.25 + 0.25 * static_cast<double>(i % 4);
    for (std::size_t k = 0; k < index.skeletons().size(); ++k) {
      const FrameBounds bounds = engine.frame_bounds(q, 0, k);
      const std::vector<double>&lower = bounds.lower, &h = bounds.h,
            &partial = bounds.partial_lower, &reference = bounds.partial_reference;
      ASSERT_EQ(partial.size(), h.size());
      ASSERT_EQ(reference.size(), h.size());
      for (std::size_t g = 0; g < h.size(); ++g) {
        const double err = std::abs(partial[g] - reference[g]);
        ASSERT_LE(err, 1e-5 * reference[g] + 1e-5)
            << "query " << i << " (" << f << ") frame " << g << ": columns " << partial[g]
            << ", reference " << reference[g];
        ASSERT_GE(lower[g], partial[g]);  // the engine's bound includes it
        worst = std::max(worst, err / (reference[g] + 1e-3));
        sum += reference[g];
        positive += reference[g] > 1e-3;
        differ += partial[g] != reference[g];
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 100000u);
  EXPECT_GT(positive, checked / 2);
  // The float path is the one in use: its roundings differ from the double's.
  EXPECT_GT(differ, checked / 10);
  EXPECT_GT(sum, 0.0);
  std::printf(
      "partial bound, columns vs reference: worst relative difference %.3g over %zu frames\n",
      worst, checked);
}

// The engine's h scan tiles are derived from local_rotations (schema 3): a
// damaged local_rotations array is refused when the engine loads, with the
// dataset named, every time (nothing half-made is kept by the index).
TEST(Search, DamagedFrameArrayIsRefusedWhenTheEngineLoads) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(set1_index().empty());
  const fs::path copy = test::temp_dir("search-damaged") / "set1.h5";
  fs::copy_file(set1_index(), copy, fs::copy_options::overwrite_existing);
  {
    h5::File f = h5::File::open(copy, true);
    h5::Dataset d = f.root()
                        .open_group("skeletons")
                        .open_group("0")
                        .open_group("frames")
                        .open_dataset("local_rotations");
    std::vector<float> v = d.read_all<float>();
    v[v.size() / 3] = -v[v.size() / 3] + 0.5f;
    d.write_all<float>(v);
    f.close();
  }
  seal_index_file(copy);
  const Index index = Index::open(copy);
  for (int round = 0; round < 2; ++round) {
    const std::string e = test::input_error_message([&] { const SearchEngine engine(index); });
    EXPECT_NE(e.find("/skeletons/0/frames/local_rotations: checksum mismatch"), std::string::npos)
        << "round " << round << ": " << e;
  }
}

// A query character (tables recomputed from the stored poses) ranks and
// scores like an index built with that character: same clips and frames,
// scores equal to float rounding of the stored poses (ties within that
// tolerance may swap). Exact equals brute with the character, bit for bit.
TEST(Search, QueryCharacterEqualsIndexBuiltWithItSet1) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(set1_index().empty());
  const fs::path char_index = build_set1_index("search-set1-character", test_character());
  ASSERT_FALSE(char_index.empty()) << "could not build the set-1 index with the test character";
  const Index plain = Index::open(set1_index());
  const Index built = Index::open(char_index);
  ASSERT_EQ(plain.clips().size(), built.clips().size());
  const SearchEngine with_query_char(plain), with_index_char(built);
  const auto queries = random_queries(plain, small_query_count());
  SearchOptions exact, brute;
  exact.max_length_s = brute.max_length_s = 0.5;
  brute.mode = SearchMode::brute;
  std::size_t compared = 0;
  for (const Query& q0 : queries) {
    Query q = q0;
    q.character = test_character();
    const auto e = with_query_char.run(q, exact);
    const auto b = with_query_char.run(q, brute);
    expect_same_results(e, b, q.id + " (query character: exact vs brute)");
    for (std::size_t p = 0; p < e.pairs.size(); ++p)
      for (std::size_t r = 0; r < e.pairs[p].results.size(); ++r)
        EXPECT_EQ(e.pairs[p].results[r].score_J, b.pairs[p].results[r].score_J) << q.id;
    const auto ref = with_index_char.run(q0, exact);
    ASSERT_FALSE(ref.error) << *ref.error;
    ASSERT_EQ(e.pairs.size(), ref.pairs.size());
    for (std::size_t p = 0; p < e.pairs.size(); ++p) {
      const auto& x = e.pairs[p].results;
      const auto& y = ref.pairs[p].results;
      ASSERT_EQ(x.size(), y.size()) << q.id;
      for (std::size_t r = 0; r < x.size(); ++r) {
        const double tol = 1e-4 * std::max(1.0, std::abs(y[r].score_J));
        EXPECT_NEAR(x[r].score_J, y[r].score_J, tol) << q.id << " pair " << p << " rank " << r + 1;
        EXPECT_NEAR(x[r].path_cost_J, y[r].path_cost_J,
                    1e-4 * std::max(1.0, std::abs(y[r].path_cost_J)))
            << q.id;
        const bool same = x[r].clip_index == y[r].clip_index &&
                          x[r].start_frame == y[r].start_frame && x[r].end_frame == y[r].end_frame;
        if (!same) {
          // Only a near tie may swap: the other side has an entry with this score.
          bool tie = false;
          for (const auto& z : y)
            tie = tie || (z.clip_index == x[r].clip_index &&
                          std::abs(z.score_J - x[r].score_J) <= 2 * tol);
          tie =
              tie || (r + 1 == x.size());  // the last rank: a near tie with an entry just below it
          EXPECT_TRUE(tie) << q.id << " pair " << p << " rank " << r + 1 << ": clip "
                           << x[r].clip_index << " vs " << y[r].clip_index;
        }
        ++compared;
      }
    }
  }
  EXPECT_GT(compared, 50u);
}

// A character equal to the index's (the default, written out) uses the
// index's tables (identical results); an unreadable or invalid character
// file fails that query only.
TEST(Search, QueryCharacterErrorsAndDefault) {
  const Index index = Index::open(golden_index());
  const SearchEngine engine(index);
  const fs::path dir = test::temp_dir("search-character-errors");
  std::ofstream(dir / "bad-version.json") << R"({"version": 2})";
  std::ofstream(dir / "not-json.json") << "{ mass: heavy";
  const fs::path examples = fs::path(MOCAP_SOURCE_DIR) / "docs/examples";
  const std::string frames =
      R"("frames": [{"bvh": "golden_walk_normal_001.bvh", "frame": 0}, {"bvh": "golden_walk_normal_001.bvh", "frame": 3}])";
  std::vector<BatchEntry> batch;
  auto add = [&](const std::string& id, const std::string& character) {
    std::string text = "{\"id\": \"" + id + "\", \"relative\": false, " + frames;
    if (!character.empty()) text += ", \"character\": \"" + character + "\"";
    batch.push_back({id, parse(text + "}"), ""});
  };
  add("plain", "");
  add("default", (examples / "character-default.json").string());
  add("missing", (dir / "no-such-character.json").string());
  add("version", (dir / "bad-version.json").string());
  add("syntax", (dir / "not-json.json").string());
  add("heavy", (examples / "character-heavy-arms.json").string());
  SearchOptions opt;
  opt.min_length_s = 0.05;  // the golden clips are 3 frames of 0.05 s
  const auto out = run_query_batch(engine, batch, opt);
  ASSERT_EQ(out.size(), batch.size());
  ASSERT_FALSE(out[0].error) << *out[0].error;
  expect_same_results(out[0], out[1], "default character");
  for (std::size_t i : {2u, 3u, 4u}) {
    ASSERT_TRUE(out[i].error.has_value()) << out[i].id;
    EXPECT_NE(out[i].error->find("character"), std::string::npos) << *out[i].error;
  }
  EXPECT_NE(out[2].error->find("no-such-character.json"), std::string::npos) << *out[2].error;
  ASSERT_FALSE(out[5].error) << *out[5].error;
  // Heavier arms: the same frames of the same clip still score about 0
  // (h(A, A) = 0; the database side is recomputed from float32 poses);
  // brute agrees with exact.
  ASSERT_FALSE(out[5].pairs[0].results.empty());
  EXPECT_EQ(out[5].pairs[0].results[0].start_frame, 0u);
  EXPECT_EQ(out[5].pairs[0].results[0].end_frame, 3u);
  EXPECT_NEAR(out[5].pairs[0].results[0].score_J, 0.0, 1e-2);
  SearchOptions brute = opt;
  brute.mode = SearchMode::brute;
  expect_same_results(out[5], engine.run(*batch[5].query, brute), "heavy arms brute");
}

// Invalid search options are bad input (values a user gives: --min-length,
// --max-length, Python's keywords): validate_search_options, run() and
// run_query_batch throw InputError naming the flag and the value, the batch
// before any query runs.
TEST(Search, InvalidOptionsAreInputErrors) {
  const Index index = Index::open(golden_index());
  const SearchEngine engine(index);
  const Query q = parse(
      R"({"id": "q", "frames": [{"bvh": "golden_walk_normal_001.bvh", "frame": 0}, {"bvh": "golden_walk_normal_001.bvh", "frame": 3}]})");
  SearchOptions opt;
  EXPECT_NO_THROW(validate_search_options(opt));
  for (const double bad : {0.0, -1.0, std::numeric_limits<double>::quiet_NaN()}) {
    opt.max_length_s = bad;
    try {
      validate_search_options(opt);
      ADD_FAILURE() << "no error for " << bad;
    } catch (const InputError& e) {
      EXPECT_EQ(e.source(), "--max-length") << e.what();
      EXPECT_NE(std::string(e.what()).find("got"), std::string::npos) << e.what();
    }
    EXPECT_THROW((void)engine.run(q, opt), InputError) << bad;
    EXPECT_THROW((void)run_query_batch(engine, {{"q", q, ""}}, opt), InputError) << bad;
  }
  opt = SearchOptions{};
  opt.min_length_s = std::numeric_limits<double>::quiet_NaN();
  try {
    validate_search_options(opt);
    ADD_FAILURE() << "no error for a NaN --min-length";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "--min-length: must be a number of seconds > 0, got nan");
  }
  opt = SearchOptions{};
  opt.min_length_s = 5.0;
  opt.max_length_s = 4.0;
  EXPECT_THROW(validate_search_options(opt), InputError);
}

// SearchEngine::frame_bounds fills every field of FrameBounds, one value per
// frame of the skeleton: for a full frame the partial bounds are 0, the
// engine's h is h, and the bound holds; no such frame or skeleton: invalid_argument.
TEST(Search, FrameBoundsFillsEveryField) {
  const Index index = Index::open(golden_index());
  const SearchEngine engine(index);
  const Query q = parse(
      R"({"id": "q", "relative": false, "frames": [{"bvh": "golden_walk_normal_001.bvh", "frame": 0}, {"bvh": "golden_walk_normal_001.bvh", "frame": 3}]})");
  const FrameBounds b = engine.frame_bounds(q, 1, 0);
  const std::size_t n = index.skeletons()[0].frame_count;
  ASSERT_GT(n, 0u);
  for (const std::vector<double>* v : {&b.lower, &b.h, &b.engine_h, &b.sketch_lower, &b.chain_lower,
                                       &b.partial_lower, &b.partial_reference})
    ASSERT_EQ(v->size(), n);
  for (std::size_t g = 0; g < n; ++g) {
    EXPECT_EQ(b.engine_h[g], b.h[g]);
    EXPECT_EQ(b.partial_lower[g], 0.0);
    EXPECT_EQ(b.partial_reference[g], 0.0);
    EXPECT_LE(b.sketch_lower[g], b.lower[g]);
    EXPECT_LE(b.chain_lower[g], b.lower[g]);
    EXPECT_LE(b.lower[g] * (1.0 - 1e-4) - 1e-3, b.h[g]);
  }
  EXPECT_THROW((void)engine.frame_bounds(q, 2, 0), std::invalid_argument);
  EXPECT_THROW((void)engine.frame_bounds(q, 0, index.skeletons().size()), std::invalid_argument);
}

// A relative query leaves the thread's scratch with h arrays of different
// lengths (b holds one partial motion); a world query run after it on the same
// thread must size both again. It used to write past b: heap corruption that
// aborted mixed batches. The world results must equal a run on a fresh engine.
TEST(Search, WorldQueryAfterARelativeOneOnTheSameThread) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(set1_index().empty());
  const Index index = Index::open(set1_index());
  const auto& clips = index.clips();
  std::size_t longest = 0;
  for (std::size_t c = 0; c < clips.size(); ++c)
    if (clips[c].frame_count > clips[longest].frame_count) longest = c;
  const auto frame = [&](std::size_t c, std::size_t f) {
    return "{\"bvh\": \"" + clips[c].path + "\", \"frame\": " + std::to_string(f) + "}";
  };
  const std::size_t n = clips[longest].frame_count;
  const Query relative = parse("{\"id\": \"rel\", \"relative\": true, \"frames\": [" +
                               frame(longest, n / 5) + ", " + frame(longest, n / 5 + 30) + "]}");
  const Query world = parse("{\"id\": \"world\", \"relative\": false, \"frames\": [" +
                            frame(longest, n / 2) + ", " + frame(longest, n / 2 + 40) + "]}");
  tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  const SearchEngine fresh(index);
  const QueryOutcome alone = fresh.run(world, {});
  const SearchEngine shared(index);
  for (int round = 0; round < 3; ++round) {
    const QueryOutcome r = shared.run(relative, {});
    EXPECT_FALSE(r.pairs.empty());
    const QueryOutcome w = shared.run(world, {});
    expect_same_results(w, alone, "world after relative");
  }
}

// A query frame of a Z-up file is put Y up as the indexer put the clip: two
// frames of an indexed Z-up clip find that clip's own partial motion at h = 0
// (the indexed-file window is read through the whole file when it looks Z up).
TEST(Search, ZUpQueryFramesMatchTheirIndexedClip) {
  const fs::path source = test::data_dir() / "bvh-wild" / "pybvh_test1_mixedorders.bvh";
  if (!fs::exists(source)) GTEST_SKIP() << "no " << source;
  const fs::path dir = test::temp_dir("search-zup");
  fs::create_directories(dir / "clips");
  fs::copy_file(source, dir / "clips" / "zup.bvh");
  const fs::path index_path = build_index_with_binary(dir / "clips", dir / "zup.h5", {});
  ASSERT_FALSE(index_path.empty());
  const Index index = Index::open(index_path);
  const SearchEngine engine(index);
  const std::string file = (dir / "clips" / "zup.bvh").string();
  const Query q = parse("{\"relative\": false, \"top\": 1, \"frames\": [{\"bvh\": \"" + file +
                        "\", \"frame\": 5}, {\"bvh\": \"" + file + "\", \"frame\": 30}]}");
  const QueryOutcome r = engine.run(q, {});
  ASSERT_FALSE(r.error) << *r.error;
  ASSERT_EQ(r.pairs.size(), 1u);
  ASSERT_EQ(r.pairs[0].results.size(), 1u);
  EXPECT_EQ(r.pairs[0].results[0].start_frame, 5u);
  EXPECT_EQ(r.pairs[0].results[0].end_frame, 30u);
  EXPECT_EQ(r.pairs[0].results[0].score_J, 0.0);
}
