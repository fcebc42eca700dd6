// Body-frame constraints, weights and residuals in queries (docs/queries.md
// "Body-frame constraints", "Weights"): invalid queries first (parsing,
// then resolution on the set-1 skeleton), then on set 1: exact == brute for
// constrained and weighted queries in world and relative placement, the
// residuals equal to an independent measurement on the clip's BVH file, and
// a met constraint costing nothing.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/common/util/error.hpp"
#include "search_fixtures.hpp"

namespace fs = std::filesystem;
using namespace mocap;
using test::parse;

namespace {

const fs::path& index_path() {
  return test::set1_index("search-query-constraints-set1");
}

// The parse error, or the joint-value error parsing defers to resolution
// (reported there after the joint names: query_validation.hpp).
std::string error_of(const std::string& text) {
  try {
    const Query q = parse(text);
    for (const QueryFrameSpec& f : q.frames)
      if (f.joint_value_error) return f.joint_value_error->what();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(QueryConstraints, InvalidFieldsAreRefused) {
  const std::string up = "{\"root_position\": [0, null, 0]}";
  auto frame = [&](const std::string& f) { return "{\"frames\": [" + up + ", " + f + "]}"; };
  const std::pair<std::string, std::string> cases[] = {
      {frame("{\"angles\": {\"trunk_flex\": 40}}"), "unknown angle \"trunk_flex\""},
      {frame("{\"angles\": {\"left_knee_flexion\": 200}}"), "out of range"},
      {frame("{\"angles\": {\"left_knee_flexion\": -5}}"), "out of range"},
      {frame("{\"angles\": {\"trunk_flexion\": {\"tolerance_deg\": 5}}}"), "deg: required"},
      {frame("{\"angles\": {\"trunk_flexion\": {\"deg\": 5, \"tolerance_deg\": -1}}}"),
       "must be >= 0"},
      {frame("{\"angles\": {}}"), "expected a non-empty object"},
      {frame("{\"joints\": {\"RightArm\": {\"direction\": [0, 0, 0]}}}"), "must not be zero"},
      {frame("{\"joints\": {\"RightArm\": {\"direction\": [0, 1]}}}"), "expected [x, y, z]"},
      {frame("{\"joints\": {\"RightArm\": {\"direction\": [0, 1, 0], \"quat\": [1, 0, 0, 0]}}}"),
       "not both"},
      {frame("{\"joints\": {\"RightArm\": {\"quat\": [1, 0, 0, 0], \"tolerance_deg\": 3}}}"),
       "only with direction"},
      {frame("{\"joints\": {\"RightArm\": {\"quat\": [1, 0, 0, 0], \"weight\": 0}}}"),
       "weight: must be > 0"},
      {frame("{\"effectors\": {\"RightHand\": {\"tolerance_m\": 0.1}}}"), "position_m: required"},
      {frame("{\"effectors\": {\"RightHand\": {\"position_m\": [0, 1, 0], \"size\": 1}}}"),
       "unknown field"},
      {frame("{\"effectors\": {\"RightHand\": [0, 1, 0]}}"), "expected {\"position_m\""},
      {frame("{\"root_position\": [0, null, 0], \"weight\": -2}"), "weight: must be > 0"},
      {frame("{\"bvh\": \"a.bvh\", \"frame\": 1, \"effectors\": {\"RightHand\": "
             "{\"position_m\": [0, 1, 0]}}}"),
       "use \"only\""},
  };
  for (const auto& [text, want] : cases) {
    const std::string got = error_of(text);
    EXPECT_NE(got.find(want), std::string::npos) << text << "\n  got: " << got;
  }
  // A frame of constraints alone is a frame.
  EXPECT_EQ(error_of(frame("{\"angles\": {\"trunk_flexion\": 40}}")), "");
  const Query q =
      parse(frame("{\"effectors\": {\"LeftFoot\": {\"position_m\": [0.1, 0.3, 0.4], "
                  "\"tolerance_m\": 0.05, \"weight\": 3}}, \"weight\": 0.5}"));
  ASSERT_EQ(q.frames[1].effectors.size(), 1u);
  EXPECT_EQ(q.frames[1].effectors[0].tolerance_m, 0.05);
  EXPECT_EQ(q.frames[1].effectors[0].weight, 3.0);
  EXPECT_EQ(q.frames[1].weight, 0.5);
  EXPECT_TRUE(q.frames[1].constrained());
  EXPECT_FALSE(q.frames[0].constrained());
}

TEST(QueryConstraints, ResolutionErrorsNameTheEntry) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(index_path().empty()) << "could not build the set-1 index";
  const Index index = Index::open(index_path());
  const SearchEngine engine(index);
  auto error = [&](const std::string& second) -> std::string {
    const Query q =
        parse("{\"id\": \"e\", \"frames\": [{\"root_position\": [0, null, 0]}, " + second + "]}");
    try {
      engine.run(q, SearchOptions{});
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(error("{\"joints\": {\"Hips\": {\"direction\": [0, 1, 0]}}}").find("root_heading_deg"),
            std::string::npos);
  EXPECT_NE(error("{\"joints\": {\"Head\": {\"direction\": [0, 1, 0]}}}").find("0 child joints"),
            std::string::npos);
  EXPECT_NE(
      error("{\"effectors\": {\"Spine\": {\"position_m\": [0, 1, 0]}}}").find("two-bone chain"),
      std::string::npos);
  EXPECT_NE(error("{\"effectors\": {\"Rihgt\": {\"position_m\": [0, 1, 0]}}}")
                .find("unknown joint \"Rihgt\""),
            std::string::npos);
  const std::string both = error(
      "{\"angles\": {\"right_elbow_flexion\": 90}, \"effectors\": {\"RightHand\": "
      "{\"position_m\": [0, 1, 0]}}}");
  EXPECT_NE(both.find("\"right_elbow_flexion\" and \"RightHand\" both move"), std::string::npos)
      << both;
}

// Constrained, weighted queries: exact equals brute bit for bit in world
// and relative placement (the weighted frames' pairs are evaluated whole).
TEST(QueryConstraints, ExactEqualsBruteSet1) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(index_path().empty()) << "could not build the set-1 index";
  const Index index = Index::open(index_path());
  const SearchEngine engine(index);
  const std::string walk =
      (test::data_dir() / "bandai-namco-1/data/dataset-1_walk_normal_001.bvh").string();
  const std::string queries[] = {
      R"({"frames": [{"angles": {"trunk_flexion": 0}}, {"angles": {"trunk_flexion": {"deg": 50, "tolerance_deg": 5, "weight": 2}}}]})",
      R"({"relative": false, "frames": [{"root_position": [0, null, 0], "angles": {"left_elbow_flexion": 90}},
          {"joints": {"RightForeArm": {"euler_deg": [0, 0, 30], "order": "ZXY", "weight": 3}}, "weight": 2},
          {"effectors": {"LeftFoot": {"position_m": [0.1, 0.4, 0.3]}}, "weight": 0.5}]})",
      R"({"frames": [{"joints": {"RightArm": {"direction": [0, 1, 0]}, "LeftUpLeg": {"direction": [0, -1, 0.3]}}},
          {"angles": {"right_shoulder_elevation": 90, "left_knee_flexion": {"deg": 60, "tolerance_deg": 10}}}]})",
      R"({"frames": [{"bvh": ")" + walk + R"(", "frame": 40},
          {"bvh": ")" +
          walk +
          R"(", "frame": 70, "only": ["root_position_xz"], "effectors": {"RightHand": {"position_m": [-0.25, 1.29, 0.2], "tolerance_m": 0.05}}}],
          "filter": {"clips": ["*walk*", "*bye*"], "exclude": ["*walk_normal_001*"]}})",
  };
  SearchOptions exact, brute;
  brute.mode = SearchMode::brute;
  for (const std::string& text : queries) {
    Query q = parse(text);
    // Under the sanitizers (test_support.hpp) over the normal clips (20 of
    // 174) and placements up to 1.5 s: brute is O(K L) per clip.
    if (test::kSanitizerBuild) {
      q.filter.clips = {"*_normal_*"};
      q.max_length_s = 1.5;
    }
    const QueryOutcome e = engine.run(q, exact), b = engine.run(q, brute);
    test::expect_same_results(e, b, text, 0.0);
    ASSERT_FALSE(e.pairs.empty());
    EXPECT_FALSE(e.pairs[0].results.empty()) << text;
    for (std::size_t p = 0; p < e.pairs.size(); ++p)
      for (std::size_t r = 0; r < e.pairs[p].results.size(); ++r) {
        EXPECT_EQ(e.pairs[p].results[r].residuals_from, b.pairs[p].results[r].residuals_from);
        EXPECT_EQ(e.pairs[p].results[r].residuals_to, b.pairs[p].results[r].residuals_to);
      }
  }
}

// A result's residuals measured independently: the clip's BVH file read and
// posed here, the body frame from the pelvis's heading.
TEST(QueryConstraints, ResidualsMeasureTheResultFrames) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(index_path().empty()) << "could not build the set-1 index";
  const Index index = Index::open(index_path());
  const SearchEngine engine(index);
  const Eigen::Vector3d target(-0.3, 1.5, 0.2);
  const Query q = parse(R"({"frames": [{"angles": {"trunk_flexion": 20}},
      {"effectors": {"RightHand": {"position_m": [-0.3, 1.5, 0.2]}}}], "top": 4})");
  const QueryOutcome o = engine.run(q, SearchOptions{});
  ASSERT_FALSE(o.error) << *o.error;
  ASSERT_EQ(o.pairs[0].results.size(), 4u);
  for (const SearchResult& r : o.pairs[0].results) {
    ASSERT_EQ(r.residuals_from.size(), 1u);
    ASSERT_EQ(r.residuals_to.size(), 1u);
    EXPECT_EQ(r.residuals_from[0].name, "trunk_flexion");
    EXPECT_EQ(r.residuals_to[0].name, "RightHand");
    const IndexClip& c = index.clips()[r.clip_index];
    const ClipMotion m = clip_motion_from_raw(read_bvh_file(c.path), c.unit_scale_m);
    const int hips = m.skeleton.find("Hips"), hand = m.skeleton.find("Hand_R"),
              spine = m.skeleton.find("Spine"), neck = m.skeleton.find("Neck");
    ASSERT_TRUE(hips >= 0 && hand >= 0 && spine >= 0 && neck >= 0);
    auto at = [&](std::size_t f, int j) { return m.position(f, static_cast<std::size_t>(j)); };
    auto heading = [&](std::size_t f) {
      const Eigen::Quaterniond& h = m.rotation(f, static_cast<std::size_t>(hips));
      return 2.0 * std::atan2(h.y(), h.w());
    };
    // F^e: the hand's distance from the body-frame target.
    const std::size_t e = r.end_frame;
    const double psi = heading(e);
    const Eigen::Vector3d world = Eigen::AngleAxisd(psi, Eigen::Vector3d::UnitY()) * target +
                                  Eigen::Vector3d(at(e, hips).x(), 0.0, at(e, hips).z());
    EXPECT_NEAR(r.residuals_to[0].residual, (at(e, hand) - world).norm(), 2e-5) << c.path;
    // F^s: the trunk's forward lean from vertical against 20 degrees.
    const std::size_t s = r.start_frame;
    const Eigen::Vector3d t =
        Eigen::AngleAxisd(-heading(s), Eigen::Vector3d::UnitY()) * (at(s, neck) - at(s, spine));
    const double lean = std::atan2(t.z(), t.y()) * 180.0 / std::numbers::pi;
    EXPECT_NEAR(r.residuals_from[0].residual, std::abs(lean - 20.0), 5e-3) << c.path;
  }
}

// A frame that meets its constraints within tolerance costs nothing: a
// clip's own frame, its trunk lean and hand position stated loosely.
TEST(QueryConstraints, MetConstraintsCostNothing) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(index_path().empty()) << "could not build the set-1 index";
  const Index index = Index::open(index_path());
  const SearchEngine engine(index);
  const Query q =
      parse(R"({"frames": [{"angles": {"trunk_flexion": {"deg": 0, "tolerance_deg": 90}}},
      {"effectors": {"RightHand": {"position_m": [0, 1, 0], "tolerance_m": 3}}}], "top": 3})");
  const QueryOutcome o = engine.run(q, SearchOptions{});
  ASSERT_FALSE(o.error) << *o.error;
  for (const SearchResult& r : o.pairs[0].results) EXPECT_EQ(r.score_J, 0.0);
}

}  // namespace
