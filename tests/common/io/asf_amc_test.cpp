// Tests for the ASF/AMC reader (common/src/io/asf_amc.cpp): validity first (one block per malformed
// input), then a hand-built two-bone skeleton whose world positions are computed by hand, then
// the real CMU files, then (when tests/cli/crosscheck_asf_amc.sh provides one) an independent
// reference of world positions.
#include <gtest/gtest.h>

#include <charconv>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/io/asf_amc.hpp"
#include "mocap/common/util/error.hpp"
#include "test_support.hpp"

namespace mocap {
namespace {

namespace fs = std::filesystem;

// Line numbers below refer to these texts.
const std::string kAsf =
    "# two bones\n"                // 1
    ":version 1.10\n"              // 2
    ":name test\n"                 // 3
    ":units\n"                     // 4
    "  mass 1.0\n"                 // 5
    "  length 1.0\n"               // 6
    "  angle deg\n"                // 7
    ":root\n"                      // 8
    "  order TX TY TZ RX RY RZ\n"  // 9
    "  axis XYZ\n"                 // 10
    "  position 0 0 0\n"           // 11
    "  orientation 0 0 0\n"        // 12
    ":bonedata\n"                  // 13
    "  begin\n"                    // 14
    "    id 1\n"                   // 15
    "    name a\n"                 // 16
    "    direction 0 1 0\n"        // 17
    "    length 2\n"               // 18
    "    axis 0 0 90 XYZ\n"        // 19
    "    dof rx\n"                 // 20
    "    limits (-90 90)\n"        // 21
    "  end\n"                      // 22
    "  begin\n"                    // 23
    "    id 2\n"                   // 24
    "    name b\n"                 // 25
    "    direction 1 0 0\n"        // 26
    "    length 1\n"               // 27
    "    axis 0 0 0 XYZ\n"         // 28
    "    dof rz\n"                 // 29
    "    limits (-inf inf)\n"      // 30
    "  end\n"                      // 31
    ":hierarchy\n"                 // 32
    "  begin\n"                    // 33
    "    root a\n"                 // 34
    "    a b\n"                    // 35
    "  end\n";                     // 36

const std::string kAmc =
    "# take\n"             // 1
    ":FULLY-SPECIFIED\n"   // 2
    ":DEGREES\n"           // 3
    "1\n"                  // 4
    "root 1 2 3 0 0 0\n"   // 5
    "a 90\n"               // 6
    "b 0\n"                // 7
    "2\n"                  // 8
    "root 0 0 0 0 0 90\n"  // 9
    "a 0\n"                // 10
    "b 90\n";              // 11

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

template <typename Parse>
void expect_input_error(Parse parse, const std::string& source, std::size_t line,
                        const std::string& word) {
  try {
    parse();
    ADD_FAILURE() << "expected InputError containing '" << word << "' at line " << line;
  } catch (const InputError& e) {
    EXPECT_EQ(e.source(), source);
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_NE(e.detail().find(word), std::string::npos) << e.what();
  }
}

void expect_asf_error(const std::string& text, std::size_t line, const std::string& word) {
  expect_input_error([&] { (void)parse_asf(text, "t.asf"); }, "t.asf", line, word);
}

void expect_amc_error(const std::string& text, std::size_t line, const std::string& word) {
  const AsfSkeleton s = parse_asf(kAsf, "t.asf");
  expect_input_error([&] { (void)parse_amc(text, "t.amc", s); }, "t.amc", line, word);
}

TEST(AsfAmcValidity, MissingHierarchy) {
  expect_asf_error(kAsf.substr(0, kAsf.find(":hierarchy")), 31, "missing section :hierarchy");
}

TEST(AsfAmcValidity, MissingRootAndBonedata) {
  expect_asf_error(replaced(kAsf, ":root\n", ":units\n"), 8, "section ':units' appears twice");
  const std::string no_root =
      kAsf.substr(0, kAsf.find(":root")) + kAsf.substr(kAsf.find(":bonedata"));
  expect_asf_error(no_root, 31, "missing section :root");
}

TEST(AsfAmcValidity, CycleInHierarchy) {
  expect_asf_error(replaced(kAsf, "    root a\n    a b\n", "    b a\n    a b\n"), 34, "cycle");
  expect_asf_error(replaced(kAsf, "    a b\n", "    a b root\n"), 35, "cycle");
}

TEST(AsfAmcValidity, BoneDefinedTwice) {
  expect_asf_error(replaced(kAsf, "name b\n", "name a\n"), 23, "defined twice");
}

TEST(AsfAmcValidity, HierarchyBoneNeverDefined) {
  expect_asf_error(replaced(kAsf, "    a b\n", "    a c\n"), 35, "not defined in :bonedata");
  expect_asf_error(replaced(kAsf, "    a b\n", "    c b\n"), 35, "not defined in :bonedata");
}

TEST(AsfAmcValidity, BoneNotConnectedOrTwoParents) {
  expect_asf_error(replaced(kAsf, "    a b\n", ""), 23, "not connected to the root");
  expect_asf_error(replaced(kAsf, "    a b\n", "    a b\n    root b\n"), 36, "second parent");
}

TEST(AsfAmcValidity, MalformedAsfNumbersAndKeywords) {
  expect_asf_error(replaced(kAsf, "length 2\n", "length 2x\n"), 18, "expected a number");
  expect_asf_error(replaced(kAsf, "direction 0 1 0", "direction 0 1"), 17, "3 numbers");
  expect_asf_error(replaced(kAsf, "axis 0 0 90 XYZ", "axis 0 0 90 XYX"), 19, "rotation order");
  expect_asf_error(replaced(kAsf, "dof rx\n", "dof rx tx\n"), 20, "bone translations");
  expect_asf_error(replaced(kAsf, "limits (-90 90)", "limits (-90 90"), 21, "limit pair");
  expect_asf_error(replaced(kAsf, "dof rz\n", "dof rz rx\n"), 23, "limits for 2 dofs");
  expect_asf_error(replaced(kAsf, "    id 2\n", "    bogus 2\n"), 24, "expected id, name");
  expect_asf_error(replaced(kAsf, "  end\n:hierarchy", ":hierarchy"), 31, "expected 'end'");
  expect_asf_error(replaced(kAsf, ":name test", ":nom test"), 3, "expected a section");
}

// Found by tests/fuzz/asf_fuzz: norm() squared the components, so a direction of 1e200 became
// a zero one (of a bone of length 2, which must be an error) and 1e-170 an error.
TEST(AsfAmcValidity, HugeOrTinyDirectionIsNormalised) {
  for (const char* d : {"direction 1e200 0 0", "direction 1e-170 0 0"}) {
    const AsfSkeleton s = parse_asf(replaced(kAsf, "direction 0 1 0", d), "t.asf");
    EXPECT_NEAR(s.bones[0].direction.x(), 1.0, 1e-15) << d;
    EXPECT_EQ(s.bones[0].direction.y(), 0.0) << d;
  }
  expect_asf_error(replaced(kAsf, "direction 0 1 0", "direction 0 0 0"), 14, "zero direction");
}

TEST(AsfAmcValidity, UnknownBoneInAmc) {
  expect_amc_error(replaced(kAmc, "b 90\n", "c 90\n"), 11, "not in the skeleton");
}

TEST(AsfAmcValidity, DofCountMismatch) {
  expect_amc_error(replaced(kAmc, "a 90\n", "a 90 1\n"), 6, "expected 1 values, found 2");
  expect_amc_error(replaced(kAmc, "root 1 2 3 0 0 0", "root 1 2 3 0 0"), 5, "expected 6 values");
}

TEST(AsfAmcValidity, FramesNotConsecutive) {
  expect_amc_error(replaced(kAmc, "\n2\n", "\n3\n"), 8, "expected frame number 2");
}

TEST(AsfAmcValidity, AsfDoesNotFitAmc) {
  // A CMU take's lines against the two-bone skeleton.
  expect_amc_error(":FULLY-SPECIFIED\n:DEGREES\n1\nroot 0 0 0 0 0 0\nlowerback 1 2 3\n", 5,
                   "an ASF that does not fit");
}

TEST(AsfAmcValidity, MalformedAmc) {
  expect_amc_error(replaced(kAmc, "a 90\n", "a 9o\n"), 6, "expected a number");
  expect_amc_error(":DEGREES\nroot 0 0 0 0 0 0\n", 2, "expected a frame number");
  expect_amc_error(replaced(kAmc, "b 0\n", "b 0\nb 0\n"), 8, "appears twice");
  expect_amc_error(replaced(kAmc, "\n2\n", "\n:DEGREES\n"), 8, "expected a bone line");
}

TEST(AsfAmcSkeleton, KeepsFieldsAndLimits) {
  const AsfSkeleton s = parse_asf(kAsf, "t.asf");
  EXPECT_EQ(s.version, "1.10");
  EXPECT_EQ(s.name, "test");
  ASSERT_EQ(s.bones.size(), 2u);
  EXPECT_EQ(s.bones[0].name, "a");
  EXPECT_EQ(s.bones[0].parent, -1);
  EXPECT_EQ(s.bones[1].parent, 0);
  ASSERT_EQ(s.bones[0].limits.size(), 1u);
  EXPECT_EQ(s.bones[0].limits[0].lo, -90.0);
  EXPECT_EQ(s.bones[0].limits[0].hi, 90.0);
  EXPECT_TRUE(std::isinf(s.bones[1].limits[0].lo));
  EXPECT_EQ(s.root_children, std::vector<int>{0});
  EXPECT_NEAR(parse_asf(replaced(kAsf, "length 1.0", "length 0.45"), "t").metres_per_unit(),
              0.0564444, 1e-7);
  // Radians: axis angles and limits converted to degrees.
  const AsfSkeleton r = parse_asf(
      replaced(replaced(kAsf, "angle deg", "angle rad"), "axis 0 0 90 XYZ", "axis 0 0 1 XYZ"), "t");
  EXPECT_NEAR(r.bones[0].axis_deg.z(), 57.29577951308232, 1e-12);
  EXPECT_NEAR(r.bones[0].limits[0].hi, 90.0 * 57.29577951308232, 1e-9);
}

// World positions computed by hand (asf_amc.hpp conventions):
// frame 1: root at (1,2,3); a's L = Rz(90) Rx(90) Rz(-90) = Ry(90); a's end (= b's origin) is
// (1,2,3) + Ry(90)(0,2,0) = (1,4,3); b's end is (1,4,3) + Ry(90)(1,0,0) = (1,4,2).
// frame 2: root Rz(90) at 0; b's origin Rz(90)(0,2,0) = (-2,0,0); b turns by Rz(90) more, so its
// end is (-2,0,0) + Rz(180)(1,0,0) = (-3,0,0).
TEST(AsfAmcConversion, TwoBoneWorldPositionsByHand) {
  const AsfSkeleton s = parse_asf(kAsf, "t.asf");
  const AmcMotion m = parse_amc(kAmc, "t.amc", s);
  EXPECT_EQ(m.frame_count, 2u);
  EXPECT_EQ(m.first_frame_number, 1);
  const RawClip clip = asf_amc_to_raw_clip(s, m, 0.5);
  EXPECT_EQ(clip.frame_time_s, 0.5);
  ASSERT_EQ(clip.joints.size(), 3u);
  EXPECT_EQ(clip.joints[0].name, "root");
  EXPECT_EQ(clip.joints[1].name, "a");
  EXPECT_EQ(clip.joints[2].name, "b");
  EXPECT_TRUE((clip.joints[2].offset - Eigen::Vector3d(0, 2, 0)).norm() < 1e-15);
  EXPECT_TRUE(clip.joints[2].has_end_site);
  const ClipMotion motion = clip_motion_from_raw(clip, 1.0);
  WorldPose w;
  std::vector<Eigen::Vector3d> ends;
  const Eigen::Vector3d expected[2][4] = {{{1, 2, 3}, {1, 2, 3}, {1, 4, 3}, {1, 4, 2}},
                                          {{0, 0, 0}, {0, 0, 0}, {-2, 0, 0}, {-3, 0, 0}}};
  for (std::size_t f = 0; f < 2; ++f) {
    w.positions_m.assign(motion.world_positions_m.begin() + static_cast<long>(f * 3),
                         motion.world_positions_m.begin() + static_cast<long>(f * 3 + 3));
    w.rotations.assign(motion.world_rotations.begin() + static_cast<long>(f * 3),
                       motion.world_rotations.begin() + static_cast<long>(f * 3 + 3));
    end_site_positions(motion.skeleton, w, ends);
    for (std::size_t j = 0; j < 3; ++j)
      EXPECT_LT((w.positions_m[j] - expected[f][j]).norm(), 1e-12) << f << " " << j;
    EXPECT_LT((ends[2] - expected[f][3]).norm(), 1e-12) << f;
  }
}

// parse_amc tries the bone that followed last time first; any order must give the same values.
// The conversion reuses the angles of a bone whose values repeat the previous frame's.
TEST(AsfAmcConversion, BoneOrderAndRepeatedValues) {
  const AsfSkeleton s = parse_asf(kAsf, "t.asf");
  const AmcMotion m = parse_amc(kAmc, "t.amc", s);
  const AmcMotion reordered =
      parse_amc(replaced(kAmc, "root 0 0 0 0 0 90\na 0\nb 90\n", "b 90\na 0\nroot 0 0 0 0 0 90\n"),
                "t.amc", s);
  EXPECT_EQ(reordered.values, m.values);
  expect_amc_error(replaced(kAmc, "a 0\nb 90\n", "b 90\nc 0\n"), 11, "not in the skeleton");
  const AmcMotion repeated = parse_amc(replaced(kAmc, "a 0\n", "a 90\n"), "t.amc", s);
  const RawClip clip = asf_amc_to_raw_clip(s, repeated);
  const std::size_t a = clip.joints[static_cast<std::size_t>(clip.find_joint("a"))].first_column;
  for (std::size_t k = 0; k < 3; ++k)
    EXPECT_EQ(clip.values[clip.channel_count + a + k], clip.values[a + k]) << k;
  EXPECT_NE(clip.values[0], clip.values[clip.channel_count]);  // the root did move
}

TEST(AsfAmcConversion, AbsentBoneRestsAndRadians) {
  const AsfSkeleton s = parse_asf(kAsf, "t.asf");
  const AmcMotion m = parse_amc(replaced(kAmc, "b 0\n", ""), "t.amc", s);
  EXPECT_EQ(m.frame(0)[m.bone_columns[1]], 0.0);
  const AmcMotion r = parse_amc(replaced(kAmc, ":DEGREES", ":RADIANS"), "t.amc", s);
  EXPECT_NEAR(r.frame(0)[m.bone_columns[0]], 90.0 * 57.29577951308232, 1e-9);
  EXPECT_EQ(r.frame(0)[0], 1.0);  // translations are not angles
}

// Pairs of the real files: charleston1/2 use charleston.asf, X.amc uses X.asf.
struct Take {
  const char* asf;
  const char* amc;
};
constexpr Take kTakes[] = {{"backflip", "backflip"},      {"charleston", "charleston1"},
                           {"charleston", "charleston2"}, {"lambada", "lambada"},
                           {"pirouette", "pirouette"},    {"zombie", "zombie"}};

long last_frame_number(const fs::path& amc) {
  std::ifstream in(amc);
  std::string line;
  long last = 0;
  while (std::getline(in, line)) {
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
    long v = 0;
    const auto [p, ec] = std::from_chars(line.data(), line.data() + line.size(), v);
    if (ec == std::errc() && p == line.data() + line.size() && !line.empty()) last = v;
  }
  return last;
}

TEST(AsfAmcRealData, AllTakesParse) {
  const fs::path dir = test::data_dir() / "cmu-asf-amc";
  if (!fs::exists(dir)) GTEST_SKIP() << "no data at " << dir;
  for (const Take& t : kTakes) {
    const fs::path amc = dir / (std::string(t.amc) + ".amc");
    const AsfSkeleton s = read_asf_file(dir / (std::string(t.asf) + ".asf"));
    EXPECT_EQ(s.bones.size(), 30u) << t.asf;
    EXPECT_NEAR(s.metres_per_unit(), 0.056444, 1e-6);
    const AmcMotion m = read_amc_file(amc, s);
    EXPECT_EQ(m.first_frame_number, 1) << t.amc;
    EXPECT_EQ(static_cast<long>(m.frame_count), last_frame_number(amc)) << t.amc;
    const RawClip clip = asf_amc_to_raw_clip(s, m);
    EXPECT_EQ(clip.joints.size(), 31u);
    EXPECT_EQ(clip.frame_count, m.frame_count);
    const ClipMotion motion = clip_motion_from_raw(clip, s.metres_per_unit());
    // A standing adult: the head is 1 to 2.2 m above the lowest foot in frame 0.
    const int head = clip.find_joint("head");
    ASSERT_GE(head, 0);
    double lowest = 1e9;
    for (std::size_t j = 0; j < clip.joints.size(); ++j)
      lowest = std::min(lowest, motion.position(0, j).y());
    EXPECT_GT(motion.position(0, static_cast<std::size_t>(head)).y() - lowest, 1.0) << t.amc;
    EXPECT_LT(motion.position(0, static_cast<std::size_t>(head)).y() - lowest, 2.2) << t.amc;
  }
}

// MOCAP_ASF_AMC_REFERENCE names a JSON file written by tests/crosscheck/asf_amc_fk.py:
// [{"asf": path, "amc": path, "frame": 1-based number, "positions_m": {name: [x, y, z]}}, ...]
// with world positions of joints (bone starts) and of bone ends ("name/end") for leaves.
TEST(AsfAmcCrosscheck, MatchesIndependentReference) {
  const char* path = std::getenv("MOCAP_ASF_AMC_REFERENCE");
  if (path == nullptr) GTEST_SKIP() << "MOCAP_ASF_AMC_REFERENCE not set (crosscheck_asf_amc.sh)";
  std::ifstream in(path);
  ASSERT_TRUE(in) << path;
  const nlohmann::json cases = nlohmann::json::parse(in);
  ASSERT_FALSE(cases.empty());
  std::size_t compared = 0;
  for (const auto& c : cases) {
    const AsfSkeleton s = read_asf_file(c.at("asf").get<std::string>());
    const RawClip clip = asf_amc_to_raw_clip(s, read_amc_file(c.at("amc").get<std::string>(), s));
    const ClipMotion motion = clip_motion_from_raw(clip, s.metres_per_unit());
    const auto f = c.at("frame").get<std::size_t>() - 1;
    ASSERT_LT(f, motion.frame_count);
    const std::size_t n = clip.joints.size();
    WorldPose w;
    w.positions_m.assign(motion.world_positions_m.begin() + static_cast<long>(f * n),
                         motion.world_positions_m.begin() + static_cast<long>(f * n + n));
    w.rotations.assign(motion.world_rotations.begin() + static_cast<long>(f * n),
                       motion.world_rotations.begin() + static_cast<long>(f * n + n));
    std::vector<Eigen::Vector3d> ends;
    end_site_positions(motion.skeleton, w, ends);
    for (const auto& [name, xyz] : c.at("positions_m").items()) {
      const bool end = name.size() > 4 && name.ends_with("/end");
      const int j = clip.find_joint(end ? name.substr(0, name.size() - 4) : name);
      ASSERT_GE(j, 0) << name;
      const Eigen::Vector3d ref(xyz[0].get<double>(), xyz[1].get<double>(), xyz[2].get<double>());
      const Eigen::Vector3d got =
          end ? ends[static_cast<std::size_t>(j)] : w.positions_m[static_cast<std::size_t>(j)];
      EXPECT_LT((got - ref).norm(), 1e-4) << c.at("amc") << " frame " << f + 1 << " " << name;
      ++compared;
    }
  }
  EXPECT_GT(compared, 0u);
}

}  // namespace
}  // namespace mocap
