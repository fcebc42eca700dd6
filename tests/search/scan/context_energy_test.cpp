// Context frames (docs/queries.md "Context frames"; search/src/scan/
// context_energy.hpp): invalid fields first, then on set 1: a key pose's own
// clip scores no context energy at its own frame and some one frame later;
// every result's context energy equals a reference computed from the
// index's segment COM and world rotation arrays; exact equals brute with
// context in relative and world placement, a middle key pose giving both
// sides.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "mocap/common/dynamics/dynamics.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/search/query.hpp"
#include "mocap/search/search.hpp"
#include "search_fixtures.hpp"
#include "test_support.hpp"

using namespace mocap;

namespace {

const std::filesystem::path& set1_index() {
  return test::set1_index("context-set1");
}

std::string walk_file() {
  return (test::data_dir() / "bandai-namco-1/data/dataset-1_walk_normal_001.bvh").string();
}

std::string frame(const std::string& file, int f, const std::string& extra) {
  return R"({"bvh": ")" + file + R"(", "frame": )" + std::to_string(f) + extra + "}";
}

// The reference: C(F) of docs/queries.md computed from the index's arrays
// (segment COMs, the root's world rotation) for query rows taken from the
// same arrays at clip frame `qa` of clip `qc` (a query frame of that clip;
// clip `c` of the same skeleton, on which the engine poses the file alike).
double reference_context(const Index& index, std::size_t qc, std::size_t qa, std::size_t c,
                         std::size_t f, std::size_t steps, bool before) {
  const IndexClip& qclip = index.clips()[qc];
  const IndexClip& clip = index.clips()[c];
  const DynamicsModel model = index.dynamics_model(clip.skeleton);
  const auto com = index.array(clip.skeleton, "frames", "segment_com_m").f32;
  const auto rot = index.array(clip.skeleton, "frames", "world_rotations").f32;
  const std::size_t nj = model.joint_count();
  const auto r = static_cast<std::size_t>(model.root());
  auto heading = [&](std::size_t g) {
    const float* q = rot.data() + (g * nj + r) * 4;
    return heading_rad(Eigen::Quaterniond(q[0], q[1], q[2], q[3]));
  };
  auto body_velocity = [&](std::size_t g_lo, std::size_t g_hi, int j, double psi, double dt) {
    const float* p0 = com.data() + (g_lo * nj + static_cast<std::size_t>(j)) * 3;
    const float* p1 = com.data() + (g_hi * nj + static_cast<std::size_t>(j)) * 3;
    const Eigen::Vector3d v = Eigen::Vector3f(p1[0], p1[1], p1[2]).cast<double>() -
                              Eigen::Vector3f(p0[0], p0[1], p0[2]).cast<double>();
    return Eigen::Vector3d(Eigen::AngleAxisd(-psi, Eigen::Vector3d::UnitY()) * v / dt);
  };
  const std::size_t ga = qclip.frame_start + qa, g = clip.frame_start + f;
  const double psi_q = heading(ga), psi_f = heading(g);
  const long long last = static_cast<long long>(clip.frame_count) - 1;
  double sum = 0.0;
  for (std::size_t j = 0; j < steps; ++j) {
    const auto jj = static_cast<long long>(j);
    const std::size_t q_lo = before ? ga - j - 1 : ga + j;
    long long lo = before ? static_cast<long long>(f) - jj - 1 : static_cast<long long>(f) + jj;
    lo = std::max(0LL, std::min(lo, last - 1));
    const std::size_t f_lo = clip.frame_start + static_cast<std::size_t>(lo);
    for (const int b : model.segments) {
      const Eigen::Vector3d u = body_velocity(q_lo, q_lo + 1, b, psi_q, qclip.frame_time_s);
      const Eigen::Vector3d v = body_velocity(f_lo, f_lo + 1, b, psi_f, clip.frame_time_s);
      sum += 0.5 * model.masses_kg[static_cast<std::size_t>(b)] * (u - v).squaredNorm();
    }
  }
  return sum / static_cast<double>(steps);
}

std::size_t clip_of(const Index& index, const std::string& path) {
  for (std::size_t c = 0; c < index.clips().size(); ++c)
    if (std::filesystem::path(index.clips()[c].path).filename() ==
        std::filesystem::path(path).filename())
      return c;
  return index.clips().size();
}

}  // namespace

TEST(ContextFrames, InvalidFieldsAreNamed) {
  const std::string w = "walk.bvh";
  const std::string two = frame(w, 20, "") + "]}";
  test::expect_parse_error(
      R"({"frames": [{"root_position": [0, null, 0], "context": {"before": 3}}, )" + two,
      "frames[0].context: only with a whole bvh or amc frame");
  test::expect_parse_error(R"({"frames": [)" +
                               frame(w, 10, R"(, "only": ["LeftArm"], "context": {"before": 3})") +
                               ", " + two,
                           "frames[0].context: only with a whole frame");
  // A whole-file key pose with a bad "context" value: the message.
  for (const auto& [context, message] : std::vector<std::pair<std::string, std::string>>{
           {R"({"before": -1})",
            "frames[0].context.before: expected a number of frames from 0 to 120"},
           {R"({"after": 121})",
            "frames[0].context.after: expected a number of frames from 0 to 120"},
           {R"({"before": 2.5})", "frames[0].context.before"},
           {R"({"befor": 2})", "did you mean \"before\"?"},
           {R"({"weight": 0})", "frames[0].context.weight: must be > 0"},
           {"3", "frames[0].context: expected an object"}})
    test::expect_parse_error(
        R"({"frames": [)" + frame(w, 10, R"(, "context": )" + context) + ", " + two, message);
  const Query q =
      test::parse(R"({"frames": [)" + frame(w, 10, R"(, "context": {"before": 4, "weight": 2})") +
                  ", " + frame(w, 20, R"(, "context": {"after": 3})") + "]}");
  EXPECT_EQ(q.frames[0].context_before, 4u);
  EXPECT_EQ(q.frames[0].context_after, 0u);
  EXPECT_EQ(q.frames[0].context_weight, 2.0);
  EXPECT_EQ(q.frames[1].context_after, 3u);
}

TEST(ContextFrames, FramesOutsideTheFileAreNamed) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(set1_index().empty()) << "could not build the set-1 index";
  const Index index = Index::open(set1_index());
  const SearchEngine engine(index);
  const std::string w = walk_file();
  const std::size_t own = clip_of(index, w);
  ASSERT_LT(own, index.clips().size());
  const int near_end = static_cast<int>(index.clips()[own].frame_count) - 3;
  for (const auto& [text, part] : std::vector<std::pair<std::string, std::string>>{
           {frame(w, 5, R"(, "context": {"before": 6})") + ", " + frame(w, 40, ""),
            "frames[0].context.before: 6 frames before frame 5"},
           {frame(w, 5, "") + ", " + frame(w, near_end, R"(, "context": {"after": 3})"),
            "frames[1].context.after: 3 frames after frame " + std::to_string(near_end) + " of " +
                w + ": the file has 2 after it"}}) {
    try {
      (void)engine.run(test::parse(R"({"frames": [)" + text + "]}"), SearchOptions{});
      ADD_FAILURE() << "no error for " << text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  }
}

TEST(ContextFrames, OwnClipScoresNothingAndResultsMatchTheReference) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(set1_index().empty()) << "could not build the set-1 index";
  const Index index = Index::open(set1_index());
  const SearchEngine engine(index);
  const std::string w = walk_file();
  const std::size_t own = clip_of(index, w);
  ASSERT_LT(own, index.clips().size());
  const std::size_t a = 60, b = 90, k = 8;
  for (const char* relative : {"true", "false"}) {
    const Query q = test::parse(
        std::string(R"({"id": "ctx", "top": 40, "relative": )") + relative + R"(, "frames": [)" +
        frame(w, static_cast<int>(a), R"(, "context": {"before": 8})") + ", " +
        frame(w, static_cast<int>(b), R"(, "context": {"after": 8})") + "]}");
    const QueryOutcome out = engine.run(q, SearchOptions{});
    ASSERT_FALSE(out.error);
    ASSERT_EQ(out.pairs.size(), 1u);
    const auto& results = out.pairs[0].results;
    ASSERT_FALSE(results.empty());
    std::size_t checked = 0;
    // The key poses' own clip from a to b: no h, no context (float COMs).
    EXPECT_EQ(results[0].clip_index, own) << relative;
    EXPECT_EQ(results[0].start_frame, a) << relative;
    EXPECT_EQ(results[0].end_frame, b) << relative;
    EXPECT_TRUE(results[0].context);
    EXPECT_LT(results[0].context_in_J, 1e-3) << relative;
    EXPECT_LT(results[0].context_out_J, 1e-3) << relative;
    for (const SearchResult& r : results) {
      EXPECT_NEAR(r.score_J, r.h_in_J + r.h_out_J + r.context_in_J + r.context_out_J,
                  1e-6 * std::max(1.0, r.score_J));
      if (index.clips()[r.clip_index].skeleton != index.clips()[own].skeleton) continue;
      ++checked;
      EXPECT_NEAR(r.context_in_J,
                  reference_context(index, own, a, r.clip_index, r.start_frame, k, true),
                  1e-4 * std::max(1.0, r.context_in_J))
          << relative << " rank " << r.rank;
      EXPECT_NEAR(r.context_out_J,
                  reference_context(index, own, b, r.clip_index, r.end_frame, k, false),
                  1e-4 * std::max(1.0, r.context_out_J))
          << relative << " rank " << r.rank;
    }
    EXPECT_GE(checked, 5u) << relative;
    // One frame later the walk moves otherwise than its context did.
    EXPECT_GT(reference_context(index, own, a, own, a + 4, k, true), 1.0);
  }
}

// Over set 1's walks and runs (the whole set takes brute 80 s under the
// sanitizers).
TEST(ContextFrames, ExactEqualsBruteWithContextOnBothSidesOfAMiddleKeyPose) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(set1_index().empty()) << "could not build the set-1 index";
  const Index index = Index::open(set1_index());
  const SearchEngine engine(index);
  const std::string w = walk_file();
  for (const char* relative : {"true", "false"}) {
    const Query q =
        test::parse(std::string(R"({"id": "ctx3", "relative": )") + relative + R"(, "frames": [)" +
                    frame(w, 50, R"(, "context": {"before": 10})") + ", " +
                    frame(w, 75, R"(, "context": {"before": 5, "after": 5, "weight": 3})") + ", " +
                    frame(w, 100, R"(, "context": {"after": 10})") +
                    R"(], "filter": {"exclude": ["dataset-1_walk_normal_001*"], )"
                    R"("content": ["walk", "run"]}})");
    SearchOptions exact, brute;
    brute.mode = SearchMode::brute;
    const QueryOutcome e = engine.run(q, exact);
    const QueryOutcome b = engine.run(q, brute);
    test::expect_same_results(e, b, std::string("relative ") + relative, 0.0);
    // The context changes the ranking: without it the first pair's best differs in score.
    const Query plain = test::parse(std::string(R"({"id": "plain3", "relative": )") + relative +
                                    R"(, "frames": [)" + frame(w, 50, "") + ", " +
                                    frame(w, 75, "") + ", " + frame(w, 100, "") +
                                    R"(], "filter": {"exclude": ["dataset-1_walk_normal_001*"], )"
                                    R"("content": ["walk", "run"]}})");
    const QueryOutcome p = engine.run(plain, exact);
    ASSERT_FALSE(p.error);
    for (std::size_t h = 0; h < 2; ++h) {
      ASSERT_FALSE(e.pairs[h].results.empty());
      const SearchResult& r = e.pairs[h].results[0];
      EXPECT_GT(r.context_in_J + r.context_out_J, 0.0) << relative << " pair " << h;
      EXPECT_GE(r.score_J, p.pairs[h].results[0].score_J) << relative << " pair " << h;
      EXPECT_FALSE(p.pairs[h].results[0].context);
    }
  }
}
