// Tests for search/src/query/query.cpp: the query language. Invalid queries first
// (each error names the field path; "synth_style" too, the style mocap-synth
// transfers to), then what valid ones mean.
#include "mocap/search/query.hpp"

#include <gtest/gtest.h>

#include <numbers>

#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/util/error.hpp"

namespace mocap {
namespace {

Query parse(const std::string& text) {
  return parse_query_text(text, "q.jsonl", 7, "/data/queries", "<line 7>");
}

// Expects an InputError whose message holds "q.jsonl:7: " and `field`.
void expect_error(const std::string& text, const std::string& field) {
  try {
    parse(text);
    FAIL() << "accepted: " << text;
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("q.jsonl:7: "), std::string::npos) << msg;
    EXPECT_NE(msg.find(field), std::string::npos) << "expected '" << field << "' in: " << msg;
  }
}

const char* kTwo =
    R"("frames": [{"root_position": [0, null, 0]}, {"root_position": [0, null, 3]}])";

TEST(QueryValidityTest, SyntaxAndShape) {
  expect_error("", "invalid JSON");
  expect_error("{\"frames\": [", "invalid JSON");
  expect_error("[1, 2]", "query: expected a JSON object");
  expect_error("{}", "frames: required");
  expect_error(R"({"frames": 3})", "frames: expected a list");
  expect_error(R"({"frames": [{"root_position": [0, 0, 0]}]})", "at least 2 query frames");
  expect_error(std::string("{") + kTwo + R"(, "colour": 1})", "colour: unknown field");
}

TEST(QueryValidityTest, FrameFields) {
  expect_error(R"({"frames": [{}, {"root_position": [0,0,0]}]})", "frames[0]: gives nothing");
  expect_error(R"({"frames": [{"root_position": [0,0]}, {"root_position": [0,0,0]}]})",
               "frames[0].root_position: expected [x, y, z]");
  expect_error(R"({"frames": [{"root_position": [0,"a",0]}, {"root_position": [0,0,0]}]})",
               "frames[0].root_position[1]: expected a number");
  // Out-of-range numbers are refused by the JSON reader itself.
  expect_error(R"({"frames": [{"root_position": [0,0,0]}, {"root_position": [0,0,1e999]}]})",
               "invalid JSON: [json.exception.out_of_range.406] number overflow");
  expect_error(R"({"frames": [{"root_position": [0,0,0]}, {"pose": 1}]})",
               "frames[1].pose: unknown field");
  expect_error(R"({"frames": [{"root_position": [0,0,0]}, {"root_heading_deg": "north"}]})",
               "frames[1].root_heading_deg: expected a number");
}

TEST(QueryValidityTest, KeyPoseTimes) {
  const std::string a = R"({"root_position": [0,0,0])", b = R"({"root_position": [0,0,1])";
  auto two = [&](const std::string& ta, const std::string& tb) {
    return R"({"frames": [)" + a + ta + "}, " + b + tb + "}]}";
  };
  // Both or neither; the first at 0; increasing by at least a millisecond.
  expect_error(two(R"(, "time_s": 0)", ""), "frames[1].time_s: give time_s on every");
  expect_error(two("", R"(, "time_s": 1)"), "frames[1].time_s: give time_s on every");
  expect_error(two(R"(, "time_s": 0.5)", R"(, "time_s": 1)"),
               "frames[0].time_s: the first key pose is at 0");
  expect_error(two(R"(, "time_s": 0)", R"(, "time_s": 0)"), "frames[1].time_s: must exceed");
  expect_error(two(R"(, "time_s": 0)", R"(, "time_s": 0.0005)"), "frames[1].time_s: must exceed");
  expect_error(two(R"(, "time_s": 0)", R"(, "time_s": -1)"), "frames[1].time_s: must be >= 0");
  expect_error(two(R"(, "time_s": 0)", R"(, "time_s": "1s")"),
               "frames[1].time_s: expected a number");
  expect_error(two(R"(, "time_s": 0)", R"(, "time_s": 1e5)"), "frames[1].time_s");
  expect_error(R"({"frames": [{"time_s": 0}, {"root_position": [0,0,1], "time_s": 1}]})",
               "frames[0]: gives nothing");
  const Query q = parse(two(R"(, "time_s": 0)", R"(, "time_s": 1.2)"));
  EXPECT_TRUE(q.timed());
  EXPECT_EQ(*q.frames[1].time_s, 1.2);
  EXPECT_FALSE(parse(two("", "")).timed());
}

// An invalid joint value parses: its error waits in the frame's
// joint_value_error (reported at resolution, after the joint names), naming
// the query file, line and field; the joint is kept with no rotation.
void expect_deferred(const std::string& text, std::size_t frame, const std::string& field) {
  const Query q = parse(text);
  const QueryFrameSpec& f = q.frames.at(frame);
  ASSERT_TRUE(f.joint_value_error.has_value()) << "no deferred error: " << text;
  const std::string msg = f.joint_value_error->what();
  EXPECT_NE(msg.find("q.jsonl:7: "), std::string::npos) << msg;
  EXPECT_NE(msg.find(field), std::string::npos) << "expected '" << field << "' in: " << msg;
  ASSERT_FALSE(f.joints.empty());
  EXPECT_TRUE(f.joints.front().rotation.isApprox(Eigen::Quaterniond::Identity()));
}

TEST(QueryValidityTest, JointRotations) {
  const std::string pre = R"({"frames": [{"root_position": [0,0,0]}, {"joints": {"RightArm": )";
  expect_error(R"({"frames": [{"root_position": [0,0,0]}, {"joints": []}]})",
               "frames[1].joints: expected an object");
  expect_error(R"({"frames": [{"root_position": [0,0,0]}, {"joints": {"": {"quat": [1,0,0,0]}}}]})",
               "frames[1].joints: empty joint name");
  expect_deferred(pre + R"({"euler_deg": [1, 2, 3], "order": "ZZY"}}}]})", 1,
                  "frames[1].joints.RightArm.order: expected 3 distinct");
  expect_deferred(pre + R"({"euler_deg": [1, 2, 3]}}}]})", 1, "frames[1].joints.RightArm.order");
  expect_deferred(pre + R"({"euler_deg": [1, 2], "order": "ZXY"}}}]})", 1,
                  "frames[1].joints.RightArm.euler_deg: expected 3");
  expect_deferred(pre + R"({"quat": [0, 0, 0, 0]}}}]})", 1,
                  "frames[1].joints.RightArm.quat: must not be zero");
  expect_deferred(pre + R"({"quat": [1, 0, 0, 0], "euler_deg": [1, 2, 3]}}}]})", 1,
                  "exactly one of");
  expect_deferred(pre + R"({"quat": [1, 0, 0, 0], "order": "XYZ"}}}]})", 1,
                  "RightArm.order: only with euler_deg");
  expect_deferred(pre + R"(42}}]})", 1, "frames[1].joints.RightArm: expected");
  // The first invalid value of a frame is kept; the valid ones keep theirs.
  const Query q = parse(
      R"({"frames": [{"joints": {"A": {"quat": [0, 1, 0, 0]}, "B": {"euler_deg": [1, 2, 3]},
                                 "C": {"quat": [0, 0, 0, 0]}}}, {"root_position": [0,0,0]}]})");
  ASSERT_TRUE(q.frames[0].joint_value_error);
  EXPECT_NE(std::string(q.frames[0].joint_value_error->what()).find("joints.B.order"),
            std::string::npos);
  ASSERT_EQ(q.frames[0].joints.size(), 3u);
  EXPECT_TRUE(q.frames[0].joints[0].rotation.isApprox(Eigen::Quaterniond(0, 1, 0, 0)));
  EXPECT_FALSE(q.frames[1].joint_value_error);
  // An error outside the joints' values is still thrown while parsing.
  expect_error(pre + R"({"euler_deg": [1, 2, 3]}}, "frame": 2}]})", "frames[1].frame: only with");
}

TEST(QueryValidityTest, BvhFrames) {
  const std::string pre = R"({"frames": [{"root_position": [0,0,0]}, )";
  expect_error(pre + R"({"bvh": "a.bvh"}]})", "frames[1].frame: required");
  expect_error(pre + R"({"bvh": "a.bvh", "frame": -1}]})",
               "frames[1].frame: expected a non-negative integer");
  expect_error(pre + R"({"bvh": "a.bvh", "frame": 1.5}]})", "frames[1].frame");
  expect_error(pre + R"({"bvh": "", "frame": 1}]})", "frames[1].bvh: expected a BVH file path");
  expect_error(pre + R"({"bvh": "a.bvh", "frame": 1, "only": []}]})",
               "frames[1].only: must not be empty");
  expect_error(pre + R"({"frame": 1}]})", "frames[1].frame: only with bvh");
  expect_error(pre + R"({"bvh": "a.bvh", "frame": 1, "root_position": [0,0,0]}]})", "use \"only\"");
}

TEST(QueryValidityTest, AmcFrames) {
  const std::string pre = R"({"frames": [{"root_position": [0,0,0]}, )";
  expect_error(pre + R"({"amc": "a.amc", "frame": 1}]})", "frames[1].asf: required with amc");
  expect_error(pre + R"({"amc": "a.amc", "asf": "", "frame": 1}]})", "frames[1].asf: required");
  expect_error(pre + R"({"amc": "", "asf": "a.asf", "frame": 1}]})",
               "frames[1].amc: expected an AMC file path");
  expect_error(pre + R"({"amc": "a.amc", "asf": "a.asf"}]})", "frames[1].frame: required with amc");
  expect_error(pre + R"({"amc": "a.amc", "bvh": "a.bvh", "asf": "a.asf", "frame": 1}]})",
               "frames[1]: give bvh or amc, not both");
  expect_error(pre + R"({"bvh": "a.bvh", "asf": "a.asf", "frame": 1}]})",
               "frames[1].asf: only with amc");
  expect_error(pre + R"({"bvh": "a.bvh", "amc_fps": 60, "frame": 1}]})",
               "frames[1].amc_fps: only with amc");
  expect_error(pre + R"({"amc": "a.amc", "asf": "a.asf", "amc_fps": 0, "frame": 1}]})",
               "frames[1].amc_fps: must be > 0");
  expect_error(pre + R"({"amc": "a.amc", "asf": "a.asf", "frame": 1, "joints": {}}]})",
               "use \"only\"");
  // A valid one: the AMC path in `bvh`, its skeleton in `asf`, the rate.
  const Query q =
      parse(pre + R"({"amc": "/d/t.amc", "asf": "/d/t.asf", "amc_fps": 60, "frame": 4}]})");
  ASSERT_EQ(q.frames.size(), 2u);
  EXPECT_EQ(q.frames[1].bvh, std::filesystem::path("/d/t.amc"));
  EXPECT_EQ(q.frames[1].asf, std::filesystem::path("/d/t.asf"));
  EXPECT_EQ(q.frames[1].amc_fps, 60.0);
  EXPECT_EQ(q.frames[1].bvh_frame, 4u);
  EXPECT_FALSE(parse(pre + R"({"bvh": "/d/t.bvh", "frame": 4}]})").frames[1].asf);
}

TEST(QueryValidityTest, Options) {
  const std::string pre = std::string("{") + kTwo;
  expect_error(pre + R"(, "transition_time": 0})", "transition_time: must be 0.001 to 60");
  expect_error(pre + R"(, "transition_time": 1e-300})", "transition_time: must be 0.001 to 60");
  std::string many = R"({"frames": [)";
  for (int i = 0; i < 257; ++i) many += std::string(i ? ", " : "") + R"({"root_heading_deg": 0})";
  expect_error(many + "]}", "frames: at most 256 query frames");
  expect_error(pre + R"(, "transition_time": 1e300})", "transition_time: out of range");
  expect_error(pre + R"(, "path_weight": 1e300})", "path_weight: out of range");
  expect_error(pre + R"(, "max_length_s": 1e9})", "max_length_s: out of range");
  expect_error(R"({"frames": [{"root_position": [1e30, null, 0]}, {"root_heading_deg": 0}]})",
               "frames[0].root_position[0]: out of range");
  expect_error(R"({"frames": [{"root_heading_deg": 1e308}, {"root_heading_deg": 0}]})",
               "frames[0].root_heading_deg: out of range");
  expect_error(pre + R"(, "top": 0})", "top: expected an integer >= 1");
  expect_error(pre + R"(, "top": 2.5})", "top: expected an integer >= 1, got the number 2.5");
  expect_error(pre + R"(, "top": "5"})", "top: expected an integer >= 1, got string");
  expect_error(pre + R"(, "top": -3})", "top: expected an integer >= 1, got -3");
  // A misspelt field: the nearest valid name within 2 edits, any case.
  expect_error(pre + R"(, "Top": 5})", "Top: unknown field (did you mean \"top\"? expected one of");
  expect_error(pre + R"(, "relatve": true})", "relatve: unknown field (did you mean \"relative\"?");
  expect_error(pre + R"(, "filter": {"styel": ["x"]}})",
               "filter.styel: unknown field (did you mean \"style\"?");
  expect_error(pre + R"(, "zzzzzz": 1})", "zzzzzz: unknown field (expected one of");
  // What was given, named.
  expect_error(pre + R"(, "filter": [1]})", "filter: expected an object, got array");
  expect_error(pre + R"(, "filter": {"style": ["a", 3]}})",
               "filter.style[1]: expected a string, got number");
  expect_error(pre + R"(, "path_weight": -1})", "path_weight: must be >= 0");
  expect_error(pre + R"(, "relative": "yes"})", "relative: expected true, false or \"position\"");
  expect_error(pre + R"(, "filter": {"genre": ["x"]}})", "filter.genre: unknown field");
  expect_error(pre + R"(, "filter": {"content": [1]}})", "filter.content[0]: expected a string");
  expect_error(pre + R"(, "id": [1]})", "id: expected a string or an integer, got array");
  expect_error(pre + R"(, "character": ""})", "character: expected");
}

TEST(QueryValidityTest, SynthStyle) {
  const std::string pre = std::string("{") + kTwo;
  expect_error(pre + R"(, "synth_style": 3})", "synth_style: expected a style name");
  expect_error(pre + R"(, "synth_style": ""})", "synth_style: expected a style name");
  expect_error(pre + R"(, "synth_style": ["old"]})", "synth_style: expected a style name");
  EXPECT_FALSE(parse(pre + "}").synth_style);
  EXPECT_EQ(parse(pre + R"(, "synth_style": "old"})").synth_style, "old");
}

TEST(QueryTest, DefaultsAndPartialRootPositions) {
  const Query q = parse(std::string("{") + kTwo + "}");
  EXPECT_EQ(q.id, "<line 7>");
  EXPECT_EQ(q.frames.size(), 2u);
  EXPECT_EQ(q.placement, FramePlacement::relative);
  EXPECT_DOUBLE_EQ(q.transition_time_s, 0.5);
  EXPECT_EQ(q.top, 10u);
  EXPECT_DOUBLE_EQ(q.path_weight, 0.0);
  EXPECT_TRUE(q.filter.empty());
  EXPECT_FALSE(q.character);
  EXPECT_EQ(q.frames[1].root_position_m[0], 0.0);
  EXPECT_FALSE(q.frames[1].root_position_m[1]);
  EXPECT_EQ(q.frames[1].root_position_m[2], 3.0);
}

TEST(QueryTest, TheIssueExample) {
  const Query q = parse(R"({"id": "walk-then-reach",
    "frames": [
      {"root_position": [0, null, 0]},
      {"root_position": [0, null, 3.0]},
      {"joints": {"RightArm": {"euler_deg": [-50, 60, -45], "order": "ZXY"}}},
      {"bvh": "path/to/file.bvh", "frame": 42},
      {"bvh": "/abs/file.bvh", "frame": 42, "only": ["root_position", "LeftArm"]}],
    "relative": false, "character": "char.json", "transition_time": 0.5, "top": 10,
    "path_weight": 0.0,
    "filter": {"content": ["walk"], "style": ["tired"], "clips": ["*walk*"],
               "exclude": ["dataset-2_walk_normal_001*"]}})");
  EXPECT_EQ(q.id, "walk-then-reach");
  ASSERT_EQ(q.frames.size(), 5u);
  ASSERT_EQ(q.frames[2].joints.size(), 1u);
  EXPECT_EQ(q.frames[2].joints[0].name, "RightArm");
  const std::array<std::uint8_t, 3> zxy{2, 0, 1};
  const Eigen::Quaterniond expect = euler_to_quaternion(zxy, std::array<double, 3>{-50, 60, -45});
  EXPECT_NEAR(std::abs(q.frames[2].joints[0].rotation.dot(expect)), 1.0, 1e-12);
  EXPECT_EQ(*q.frames[3].bvh, std::filesystem::path("/data/queries/path/to/file.bvh"));
  EXPECT_EQ(q.frames[3].bvh_frame, 42u);
  EXPECT_TRUE(q.frames[3].only.empty());
  EXPECT_EQ(*q.frames[4].bvh, std::filesystem::path("/abs/file.bvh"));
  EXPECT_EQ(q.frames[4].only, (std::vector<std::string>{"root_position", "LeftArm"}));
  EXPECT_EQ(*q.character, std::filesystem::path("/data/queries/char.json"));
  EXPECT_TRUE(q.filter.accepts("dataset-2_walk_tired_003.bvh", "walk", "tired"));
  EXPECT_FALSE(q.filter.accepts("dataset-2_walk_tired_003.bvh", "walk", "happy"));
  EXPECT_FALSE(q.filter.accepts("dataset-2_walk_tired_003.bvh", "run", "tired"));
  EXPECT_FALSE(q.filter.accepts("dataset-2_walk_normal_001.bvh", "walk", "tired"));
  EXPECT_FALSE(q.filter.accepts("dataset-2_run_tired_001.bvh", "walk", "tired"));
}

TEST(QueryTest, QuaternionsAreNormalised) {
  const Query q = parse(R"({"frames": [{"root_position": [0,0,0]},
    {"joints": {"Head": {"quat": [2, 0, 0, 0]}}, "root_heading_deg": 90}]})");
  EXPECT_NEAR(q.frames[1].joints[0].rotation.w(), 1.0, 1e-15);
  EXPECT_EQ(q.frames[1].root_heading_deg, 90.0);
}

TEST(QueryTest, EulerOrders) {
  EXPECT_EQ(parse_euler_order("zxy"), (std::array<std::uint8_t, 3>{2, 0, 1}));
  EXPECT_FALSE(parse_euler_order("XY"));
  EXPECT_FALSE(parse_euler_order("XYW"));
  EXPECT_FALSE(parse_euler_order("XXY"));
}

}  // namespace
}  // namespace mocap
