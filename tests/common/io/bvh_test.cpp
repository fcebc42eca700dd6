// Tests for the BVH reader, writer and export layout (common/src/bvh_*.cpp): validity first (one
// test per malformed input), then behaviour on tiny hand-written BVH, then round trips, then the
// export layout.
#include <gtest/gtest.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <stdexcept>
#include <string>

#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/units.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/common/util/input_limits.hpp"
#include "test_support.hpp"

namespace mocap {
namespace {

namespace fs = std::filesystem;

// Parses `text` and expects an InputError at `line` whose message contains `word`.
void expect_input_error(const std::string& text, std::size_t line, const std::string& word) {
  try {
    (void)parse_bvh(text, "test.bvh");
    ADD_FAILURE() << "expected InputError containing '" << word << "' at line " << line;
  } catch (const InputError& e) {
    EXPECT_EQ(e.source(), "test.bvh");
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_NE(std::string(e.what()).find("test.bvh:" + std::to_string(line) + ":"),
              std::string::npos)
        << e.what();
    EXPECT_NE(e.detail().find(word), std::string::npos)
        << "message: " << e.what() << "\nexpected word: " << word;
  }
}

// A two-joint skeleton with 6 + 3 channels; `motion` follows "MOTION\n".
std::string two_joints(const std::string& motion) {
  return "HIERARCHY\n"                                                                 // 1
         "ROOT Hips\n"                                                                 // 2
         "{\n"                                                                         // 3
         "  OFFSET 0 0 0\n"                                                            // 4
         "  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"  // 5
         "  JOINT Spine\n"                                                             // 6
         "  {\n"                                                                       // 7
         "    OFFSET 0 10 0\n"                                                         // 8
         "    CHANNELS 3 Zrotation Xrotation Yrotation\n"                              // 9
         "    End Site\n"                                                              // 10
         "    {\n"                                                                     // 11
         "      OFFSET 0 5 0\n"                                                        // 12
         "    }\n"                                                                     // 13
         "  }\n"                                                                       // 14
         "}\n"                                                                         // 15
         "MOTION\n" +                                                                  // 16
         motion;  // 17: Frames, 18: Frame Time, 19..: rows
}

// ---------------------------------------------------------------------------
// Validity: malformed input throws InputError naming the line and what was expected.
// ---------------------------------------------------------------------------

TEST(BvhValidity, EmptyFile) {
  expect_input_error("", 1, "empty");
  expect_input_error("\n  \r\n\t\n", 4, "empty");
}

TEST(BvhValidity, BinaryGarbage) {
  expect_input_error(std::string("\x7f"
                                 "ELF\x02\x01\x01\0\0\0",
                                 10),
                     1, "binary");
  expect_input_error(std::string("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHA\0NNELS 3\n", 50),
                     5, "binary");
  // Random bytes never crash and always end in InputError.
  std::mt19937 rng(7);
  for (int i = 0; i < 200; ++i) {
    std::string junk(64, '\0');
    for (char& c : junk) c = static_cast<char>(rng() & 0xff);
    EXPECT_THROW((void)parse_bvh(junk, "junk"), InputError);
  }
}

TEST(BvhValidity, NotAHierarchy) {
  expect_input_error("\n{\"json\": true}\n", 2, "HIERARCHY");
}

TEST(BvhValidity, TruncatedHierarchy) {
  const std::string full = two_joints("Frames: 1\nFrame Time: 0.1\n0 0 0 0 0 0 0 0 0\n");
  // Cut inside the Spine's OFFSET (line 8: "    OFFSET 0 10").
  const std::string cut = full.substr(0, full.find("10 0\n") + 2);
  expect_input_error(cut, 8, "truncated");
  // Cut after a complete JOINT block: the ROOT is never closed.
  const std::string cut2 = full.substr(0, full.find("  }\n}\n") + 4);
  expect_input_error(cut2, 15, "truncated");
  expect_input_error("HIERARCHY\n", 2, "ROOT");
}

TEST(BvhValidity, UnbalancedBraces) {
  std::string text = two_joints("Frames: 0\nFrame Time: 0.1\n");
  // An extra '}' after the ROOT's block.
  std::string extra = text;
  extra.insert(extra.find("MOTION"), "}\n");
  expect_input_error(extra, 16, "unbalanced");
  // The ROOT's '}' missing: MOTION arrives inside the ROOT.
  std::string missing = text;
  missing.erase(missing.find("  }\n}\n") + 4, 2);
  expect_input_error(missing, 15, "unbalanced");
  // A stray '{'.
  std::string stray = text;
  stray.insert(stray.find("    CHANNELS 3"), "{\n");
  expect_input_error(stray, 9, "unbalanced");
}

TEST(BvhValidity, UnknownChannelName) {
  std::string text = two_joints("Frames: 0\nFrame Time: 0.1\n");
  text.replace(text.find("CHANNELS 3 Zrotation") + 11, 9, "Wrotation");
  expect_input_error(text, 9, "unknown channel");
}

TEST(BvhValidity, ChannelCountDoesNotMatchNames) {
  std::string fewer = two_joints("Frames: 0\nFrame Time: 0.1\n");
  fewer.replace(fewer.find("CHANNELS 3"), 10, "CHANNELS 4");
  expect_input_error(fewer, 9, "does not match");
  std::string more = two_joints("Frames: 0\nFrame Time: 0.1\n");
  more.replace(more.find("CHANNELS 3"), 10, "CHANNELS 2");
  expect_input_error(more, 9, "does not match");
  std::string seven = two_joints("Frames: 0\nFrame Time: 0.1\n");
  seven.replace(seven.find("CHANNELS 3"), 10, "CHANNELS 7");
  expect_input_error(seven, 9, "0..6");
}

TEST(BvhValidity, DuplicateChannel) {
  std::string text = two_joints("Frames: 0\nFrame Time: 0.1\n");
  text.replace(text.find("CHANNELS 3 Zrotation") + 11, 29, "Zrotation Xrotation Zrotation");
  expect_input_error(text, 9, "duplicate");
}

TEST(BvhValidity, TooManyJoints) {
  std::string text =
      "HIERARCHY\nROOT R\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition Zposition\n";
  for (int i = 0; i < 10000; ++i) text += "JOINT J" + std::to_string(i) + "\n{\nOFFSET 0 1 0\n}\n";
  text += "}\nMOTION\nFrames: 0\nFrame Time: 0.1\n";
  // Joint 10,001 (the root is the first) opens on line 6 + 4 * 9999.
  expect_input_error(text, 6 + 4 * 9999, "more than 10000 joints");
  // The limit in force (--max-joints): 20 joints refuses the 21st, and a
  // limit above the count reads the file.
  mocap::InputLimits lower;
  lower.bvh_joints = 20;
  mocap::set_input_limits(lower);
  expect_input_error(text, 6 + 4 * 19, "more than 20 joints");
  mocap::InputLimits higher;
  higher.bvh_joints = 10001;
  mocap::set_input_limits(higher);
  EXPECT_EQ(parse_bvh(text, "many.bvh").joints.size(), 10001u);
  mocap::set_input_limits(mocap::InputLimits{});
}

TEST(InputLimits, RefusesLimitsThatWouldRefuseEverything) {
  for (auto set : {+[](mocap::InputLimits& l) { l.bvh_bytes = 0; },
                   +[](mocap::InputLimits& l) { l.json_file_bytes = 0; },
                   +[](mocap::InputLimits& l) { l.batch_bytes = 0; },
                   +[](mocap::InputLimits& l) { l.query_frames = 1; },
                   +[](mocap::InputLimits& l) { l.bvh_joints = 0; }}) {
    mocap::InputLimits l;
    set(l);
    EXPECT_THROW(mocap::set_input_limits(l), std::invalid_argument);
  }
  EXPECT_EQ(mocap::input_limits().bvh_joints, mocap::InputLimits{}.bvh_joints) << "left unchanged";
}

TEST(BvhValidity, DuplicateJointName) {
  std::string text = two_joints("Frames: 0\nFrame Time: 0.1\n");
  const std::string child = text.substr(text.find("JOINT ") + 6);
  const std::string child_name = child.substr(0, child.find('\n'));
  const std::string root = text.substr(text.find("ROOT ") + 5);
  text.replace(text.find("JOINT " + child_name), 6 + child_name.size(),
               "JOINT " + root.substr(0, root.find('\n')));
  expect_input_error(text, 6, "defined twice");
}

TEST(BvhValidity, NonNumericValue) {
  expect_input_error(
      two_joints("Frames: 2\nFrame Time: 0.1\n0 0 0 0 0 0 0 0 0\n0 0 0 0 abc 0 0 0 0\n"), 20,
      "number");
  expect_input_error(two_joints("Frames: 1\nFrame Time: 0.1\n0 0 0 0 0 0 0 1,5 0\n"), 19, "number");
  expect_input_error(two_joints("Frames: 1\nFrame Time: 0.1\n0 0 0 0 0 nan 0 0 0\n"), 19, "finite");
  std::string offset = two_joints("Frames: 0\nFrame Time: 0.1\n");
  offset.replace(offset.find("OFFSET 0 10 0"), 13, "OFFSET 0 1O 0");
  expect_input_error(offset, 8, "number");
}

TEST(BvhValidity, FiniteValuesOutOfRange) {
  // Finite but not motion capture: the dynamics would overflow or lose all
  // precision (an angle of 1e308 degrees, a frame time of 1e-300 s).
  expect_input_error(two_joints("Frames: 1\nFrame Time: 0.1\n0 0 0 0 0 1e308 0 0 0\n"), 19,
                     "out of range");
  expect_input_error(two_joints("Frames: 1\nFrame Time: 0.1\n1e30 0 0 0 0 0 0 0 0\n"), 19,
                     "out of range");
  expect_input_error(two_joints("Frames: 1\nFrame Time: 1e-300\n0 0 0 0 0 0 0 0 0\n"), 18,
                     "out of range");
  expect_input_error(two_joints("Frames: 1\nFrame Time: 1e300\n0 0 0 0 0 0 0 0 0\n"), 18,
                     "out of range");
  std::string offset = two_joints("Frames: 0\nFrame Time: 0.1\n");
  offset.replace(offset.find("OFFSET 0 10 0"), 13, "OFFSET 0 1e30 0");
  expect_input_error(offset, 8, "out of range");
}

TEST(BvhValidity, TooFewValuesOnFrameLine) {
  expect_input_error(
      two_joints(
          "Frames: 3\nFrame Time: 0.1\n0 0 0 0 0 0 0 0 0\n0 0 0 0 0 0 0 0\n0 0 0 0 0 0 0 0 0\n"),
      20, "too few");
}

TEST(BvhValidity, TooManyValuesOnFrameLine) {
  expect_input_error(
      two_joints("Frames: 2\nFrame Time: 0.1\n0 0 0 0 0 0 0 0 0 0\n0 0 0 0 0 0 0 0 0\n"), 19,
      "too many");
}

TEST(BvhValidity, FewerFramesThanDeclared) {
  expect_input_error(
      two_joints("Frames: 3\nFrame Time: 0.1\n0 0 0 0 0 0 0 0 0\n0 0 0 0 0 0 0 0 0\n"), 21,
      "fewer frame lines (2)");
}

TEST(BvhValidity, MoreFramesThanDeclared) {
  expect_input_error(
      two_joints("Frames: 1\nFrame Time: 0.1\n0 0 0 0 0 0 0 0 0\n\n0 0 0 0 0 0 0 0 0\n"), 21,
      "more frame lines");
}

TEST(BvhValidity, LyingFrameCountAllocatesNothingHuge) {
  // 10^15 frames x 9 channels would need 72 PB; the reader must stop at the text's end.
  expect_input_error(two_joints("Frames: 1000000000000000\nFrame Time: 0.1\n0 0 0 0 0 0 0 0 0\n"),
                     20, "fewer");
  expect_input_error(two_joints("Frames: 99999999999999999999999\nFrame Time: 0.1\n"), 17,
                     "frame count");
  expect_input_error(two_joints("Frames: -3\nFrame Time: 0.1\n"), 17, "frame count");
}

TEST(BvhValidity, NonPositiveFrameTime) {
  expect_input_error(two_joints("Frames: 0\nFrame Time: -0.1\n"), 18, "positive");
  expect_input_error(two_joints("Frames: 0\nFrame Time: 0\n"), 18, "positive");
  expect_input_error(two_joints("Frames: 0\nFrame Time: inf\n"), 18, "positive");
  expect_input_error(two_joints("Frames: 0\nFrame Time: fast\n"), 18, "number");
}

TEST(BvhValidity, MissingMotion) {
  std::string text = two_joints("");
  text.erase(text.find("MOTION"));
  expect_input_error(text, 16, "MOTION");
  expect_input_error(two_joints(""), 17, "Frames:");
  expect_input_error(two_joints("Frames: 0\n"), 18, "Frame Time:");
}

TEST(BvhValidity, MissingOffsetAndMisplacedKeywords) {
  std::string no_offset = two_joints("Frames: 0\nFrame Time: 0.1\n");
  no_offset.erase(no_offset.find("    OFFSET 0 10 0\n"), 18);
  expect_input_error(no_offset, 9, "OFFSET");
  std::string bad_end = two_joints("Frames: 0\nFrame Time: 0.1\n");
  bad_end.replace(bad_end.find("End Site"), 8, "End Zone");
  expect_input_error(bad_end, 10, "Site");
  std::string two_end = two_joints("Frames: 0\nFrame Time: 0.1\n");
  two_end.insert(two_end.find("  }\n}\n"), "    End Site\n    {\n      OFFSET 0 1 0\n    }\n");
  expect_input_error(two_end, 14, "second End Site");
  expect_input_error("HIERARCHY\nJOINT A\n", 2, "ROOT");
  expect_input_error("HIERARCHY\nROOT\n{\n", 2, "joint name");
}

// ---------------------------------------------------------------------------
// Behaviour on tiny hand-written BVH.
// ---------------------------------------------------------------------------

TEST(BvhParse, TwoJointsSixAndThreeChannels) {
  const RawClip clip = parse_bvh(two_joints("Frames: 2\nFrame Time: 0.0333333\n"
                                            "1 2 3 4 5 6 7 8 9\n"
                                            "-1 -2 -3 -4 -5 -6 -7 -8 -9\n"),
                                 "mem");
  EXPECT_EQ(clip.source, "mem");
  ASSERT_EQ(clip.joints.size(), 2u);
  EXPECT_EQ(clip.joints[0].name, "Hips");
  EXPECT_EQ(clip.joints[0].parent, -1);
  EXPECT_EQ(clip.joints[0].channels.size(), 6u);
  EXPECT_EQ(clip.joints[0].first_column, 0u);
  EXPECT_EQ(clip.joints[1].name, "Spine");
  EXPECT_EQ(clip.joints[1].parent, 0);
  EXPECT_EQ(clip.joints[1].first_column, 6u);
  EXPECT_EQ(clip.joints[1].channels,
            (std::vector<Channel>{Channel::Zrotation, Channel::Xrotation, Channel::Yrotation}));
  EXPECT_EQ(clip.joints[1].offset, Eigen::Vector3d(0, 10, 0));
  EXPECT_FALSE(clip.joints[0].has_end_site);
  EXPECT_TRUE(clip.joints[1].has_end_site);
  EXPECT_EQ(clip.joints[1].end_site, Eigen::Vector3d(0, 5, 0));
  EXPECT_EQ(clip.channel_count, 9u);
  EXPECT_EQ(clip.frame_count, 2u);
  EXPECT_DOUBLE_EQ(clip.frame_time_s, 0.0333333);
  ASSERT_EQ(clip.values.size(), 18u);
  EXPECT_EQ(clip.frame(0)[8], 9.0);
  EXPECT_EQ(clip.frame(1)[0], -1.0);
  EXPECT_EQ(clip.find_joint("Spine"), 1);
}

TEST(BvhParse, EveryEulerOrder) {
  const char* orders[6][3] = {{"X", "Y", "Z"}, {"X", "Z", "Y"}, {"Y", "X", "Z"},
                              {"Y", "Z", "X"}, {"Z", "X", "Y"}, {"Z", "Y", "X"}};
  for (const auto& o : orders) {
    const std::string text = std::string("HIERARCHY\nROOT R\n{\nOFFSET 0 0 0\nCHANNELS 3 ") + o[0] +
                             "rotation " + o[1] + "rotation " + o[2] +
                             "rotation\n}\nMOTION\nFrames: 1\nFrame Time: 0.01\n10 20 30\n";
    const RawClip clip = parse_bvh(text, "order");
    ASSERT_EQ(clip.joints[0].channels.size(), 3u);
    for (int k = 0; k < 3; ++k) {
      EXPECT_TRUE(channel_is_rotation(clip.joints[0].channels[static_cast<std::size_t>(k)]));
      EXPECT_EQ(channel_axis(clip.joints[0].channels[static_cast<std::size_t>(k)]), o[k][0] - 'X');
    }
    EXPECT_EQ(clip.frame(0)[1], 20.0);
  }
}

TEST(BvhParse, ChannelSubsetsAndZeroLengthJoints) {
  // Position-only root, a joint without CHANNELS, a 1-channel joint, zero-length joints.
  const std::string text =
      "HIERARCHY\nROOT Root\n{\n OFFSET 1 2 3\n CHANNELS 2 Zposition Xposition\n"
      " JOINT Fixed\n {\n  OFFSET 0 0 0\n"
      "  JOINT Hinge\n  {\n   OFFSET 0 0 0\n   CHANNELS 1 Yrotation\n   End Site\n   {\n    OFFSET "
      "0 0 0\n   }\n  }\n"
      " }\n}\nMOTION\nFrames: 1\nFrame Time: 0.5\n7 8 9\n";
  const RawClip clip = parse_bvh(text, "subset");
  ASSERT_EQ(clip.joints.size(), 3u);
  EXPECT_EQ(clip.channel_count, 3u);
  EXPECT_TRUE(clip.joints[1].channels.empty());
  EXPECT_EQ(clip.joints[1].first_column, 2u);
  EXPECT_EQ(clip.joints[2].first_column, 2u);
  EXPECT_EQ(clip.joints[2].parent, 1);
  EXPECT_EQ(clip.joints[2].offset, Eigen::Vector3d::Zero());
  EXPECT_TRUE(clip.joints[2].has_end_site);
  EXPECT_EQ(clip.frame(0)[2], 9.0);
}

TEST(BvhParse, CrlfTabsBlanksAndNumberForms) {
  const std::string text =
      "\xEF\xBB\xBFHIERARCHY\r\n\r\nROOT\tHip Joint \t\r\n{\r\n\t\tOFFSET\t+1.5  -.5\t1e-05 \r\n"
      "\tCHANNELS 6 Xposition Yposition Zposition Xrotation Yrotation Zrotation   \r\n"
      "\tEnd\r\n\tSite\r\n\t{\r\n\t\tOFFSET 0 1E+3 0\r\n\t}\r\n}\r\n"
      "MOTION\r\nFrames:\t2\r\nFrame   Time:\t  .0083333\r\n"
      "+1 .5 -.25 1e-05 1E+3 -2.5e+2\t\r\n\r\n"
      "\t0 -0 3.0 4 5 6 \r\n\r\n  \r\n";
  const RawClip clip = parse_bvh(text, "crlf");
  ASSERT_EQ(clip.joints.size(), 1u);
  EXPECT_EQ(clip.joints[0].name, "Hip Joint");
  EXPECT_EQ(clip.joints[0].offset, Eigen::Vector3d(1.5, -0.5, 1e-5));
  EXPECT_EQ(clip.joints[0].end_site, Eigen::Vector3d(0, 1000, 0));
  EXPECT_DOUBLE_EQ(clip.frame_time_s, 0.0083333);
  ASSERT_EQ(clip.frame_count, 2u);
  const std::vector<double> want{1, 0.5, -0.25, 1e-5, 1000, -250, 0, 0, 3, 4, 5, 6};
  EXPECT_EQ(clip.values, want);
  EXPECT_TRUE(std::signbit(clip.frame(1)[1]));
}

TEST(BvhParse, NumbersMatchFromChars) {
  // The reader's fast decimal path must give the same double as std::from_chars,
  // bit for bit, for every form: signs, leading/trailing dots, long mantissas
  // (fast path off), exponents inside and outside +-22.
  std::mt19937_64 rng(11);
  std::vector<std::string> numbers = {"0",
                                      "-0",
                                      "+0.0",
                                      ".5",
                                      "-.5",
                                      "5.",
                                      "+7",
                                      "1e-05",
                                      "1E+3",
                                      "-2.5e+2",
                                      "9007199254740993",
                                      "0.1",
                                      "1e22",
                                      "1e23",
                                      "123456789012345678901234567890",
                                      "4.9e-324",
                                      "1.7976931348623157e308",
                                      "0.000000000000000000000001234",
                                      "00012.50",
                                      "-1e-22",
                                      "3e-23"};
  for (int i = 0; i < 20000; ++i) {
    std::string s;
    if (rng() % 3 == 0) s += (rng() % 2) ? '-' : '+';
    const int int_digits = static_cast<int>(rng() % 10);
    const int frac_digits = static_cast<int>(rng() % 12);
    for (int d = 0; d < int_digits; ++d) s += static_cast<char>('0' + rng() % 10);
    if (frac_digits > 0 || int_digits == 0) {
      s += '.';
      for (int d = 0; d < std::max(frac_digits, 1); ++d) s += static_cast<char>('0' + rng() % 10);
    }
    if (rng() % 4 == 0)
      s += (rng() % 2 ? "e" : "E") + std::to_string(static_cast<int>(rng() % 61) - 30);
    numbers.push_back(s);
  }
  numbers.push_back("0.123456789012345678901234567890");
  numbers.push_back("1234567.8901234567890123");
  // Values beyond the reader's range (|v| > 1e7) are refused: checked on a
  // few of them, the rest compared with std::from_chars.
  auto value_of = [](const std::string& n) {
    double v = 0.0;
    std::from_chars(n.data() + (n[0] == '+' ? 1 : 0), n.data() + n.size(), v);
    return v;
  };
  const auto header = [](std::size_t frames) {
    return "HIERARCHY\nROOT R\n{\nOFFSET 0 0 0\nCHANNELS 1 Xposition\n}\nMOTION\nFrames: " +
           std::to_string(frames) + "\nFrame Time: 0.01\n";
  };
  std::size_t refused_checked = 0;
  for (const std::string& n : numbers) {
    if (std::abs(value_of(n)) > 1e7 && refused_checked++ < 20) {
      EXPECT_THROW(parse_bvh(header(1) + n + "\n", "big"), InputError) << n;
    }
  }
  numbers.erase(std::remove_if(numbers.begin(), numbers.end(),
                               [&](const std::string& n) { return std::abs(value_of(n)) > 1e7; }),
                numbers.end());
  std::string text = header(numbers.size());
  for (const std::string& n : numbers) text += n + "\n";
  const RawClip clip = parse_bvh(text, "numbers");
  ASSERT_EQ(clip.values.size(), numbers.size());
  std::size_t mismatches = 0;
  for (std::size_t i = 0; i < numbers.size(); ++i) {
    const std::string& n = numbers[i];
    const char* first = n.data() + (n[0] == '+' ? 1 : 0);
    double want = 0.0;
    std::from_chars(first, n.data() + n.size(), want);
    if (std::memcmp(&want, &clip.values[i], sizeof want) != 0 && mismatches++ < 5)
      ADD_FAILURE() << n << ": read " << clip.values[i] << ", from_chars " << want;
  }
  EXPECT_EQ(mismatches, 0u);
}

TEST(BvhParse, SeveralRoots) {
  const std::string text =
      "HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition Zposition\n"
      "JOINT A1\n{\nOFFSET 1 0 0\nCHANNELS 3 Zrotation Yrotation Xrotation\nEnd Site\n{\nOFFSET 1 "
      "0 0\n}\n}\n}\n"
      "ROOT B\n{\nOFFSET 5 0 0\nCHANNELS 3 Yrotation Xrotation Zrotation\n}\n"
      "MOTION\nFrames: 1\nFrame Time: 0.04\n1 2 3 4 5 6 7 8 9\n";
  const RawClip clip = parse_bvh(text, "roots");
  ASSERT_EQ(clip.joints.size(), 3u);
  EXPECT_EQ(clip.joints[0].parent, -1);
  EXPECT_EQ(clip.joints[1].parent, 0);
  EXPECT_EQ(clip.joints[2].parent, -1);
  EXPECT_EQ(clip.joints[2].name, "B");
  EXPECT_EQ(clip.joints[2].first_column, 6u);
  EXPECT_EQ(clip.channel_count, 9u);
  EXPECT_DOUBLE_EQ(clip.frame_time_s, 0.04);
}

TEST(BvhParse, NamedEndSitesReadLikeUnnamedOnes) {
  const std::string motion = "Frames: 1\nFrame Time: 0.1\n1 2 3 4 5 6 7 8 9\n";
  const RawClip plain = parse_bvh(two_joints(motion), "mem");
  for (const char* named :
       {"    End Site Head_end\n", "    End Site Head_end {\n", "    End Site  Spine end\t\r\n"}) {
    std::string text = two_joints(motion);
    std::string line = named;
    if (line.find('{') != std::string::npos) text.erase(text.find("    {\n      OFFSET 0 5"), 6);
    text.replace(text.find("    End Site\n"), 13, line);
    const RawClip clip = parse_bvh(text, "mem");
    ASSERT_EQ(clip.joints.size(), 2u) << named;
    EXPECT_TRUE(clip.joints[1].has_end_site) << named;
    EXPECT_EQ(clip.joints[1].end_site, plain.joints[1].end_site) << named;
    EXPECT_EQ(clip.values, plain.values) << named;
  }
  // A named End Site and a real defect later: the error names the defect.
  std::string both = two_joints(
      "Frames: 3\nFrame Time: 0.1\n0 0 0 0 0 0 0 0 0\n0 0 0 0 0 0 0 0\n0 0 0 0 0 0 0 0 0\n");
  both.replace(both.find("    End Site\n"), 13, "    End Site Head_end\n");
  expect_input_error(both, 20, "too few");
  std::string braced = two_joints("Frames: 0\nFrame Time: 0.1\n");
  braced.replace(braced.find("    End Site\n"), 13, "    End Site A}\n");
  expect_input_error(braced, 10, "End Site name");
}

TEST(BvhParse, ZeroFramesAndBraceOnNameLine) {
  const RawClip clip = parse_bvh(
      "HIERARCHY\nROOT R {\n OFFSET 0 0 0\n CHANNELS 3 Zrotation Xrotation Yrotation\n JOINT C {\n "
      " OFFSET 0 1 0\n }\n}\n"
      "MOTION\nFrames: 0\nFrame Time: 0.01\n",
      "zero");
  EXPECT_EQ(clip.joints.size(), 2u);
  EXPECT_EQ(clip.frame_count, 0u);
  EXPECT_TRUE(clip.values.empty());
}

TEST(BvhFile, ReadMissingFileNamesThePath) {
  const auto missing = test::temp_dir("bvh-missing") / "nope.bvh";
  try {
    (void)read_bvh_file(missing);
    ADD_FAILURE() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.source(), missing.string());
    EXPECT_NE(e.detail().find("cannot"), std::string::npos);
  }
}

// ---------------------------------------------------------------------------
// Round trips: parse -> write -> parse.
// ---------------------------------------------------------------------------

void expect_same_clip(const RawClip& a, const RawClip& b, double rel) {
  ASSERT_EQ(a.joints.size(), b.joints.size());
  for (std::size_t j = 0; j < a.joints.size(); ++j) {
    const RawJoint& x = a.joints[j];
    const RawJoint& y = b.joints[j];
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.parent, y.parent);
    EXPECT_EQ(x.channels, y.channels);
    EXPECT_EQ(x.first_column, y.first_column);
    EXPECT_EQ(x.has_end_site, y.has_end_site);
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(x.offset[k], y.offset[k], rel * std::abs(x.offset[k]));
      EXPECT_NEAR(x.end_site[k], y.end_site[k], rel * std::abs(x.end_site[k]));
    }
  }
  EXPECT_EQ(a.channel_count, b.channel_count);
  EXPECT_EQ(a.frame_count, b.frame_count);
  EXPECT_EQ(a.frame_time_s, b.frame_time_s);
  ASSERT_EQ(a.values.size(), b.values.size());
  std::size_t bad = 0;
  for (std::size_t i = 0; i < a.values.size(); ++i)
    if (!(std::abs(a.values[i] - b.values[i]) <= rel * std::abs(a.values[i]))) ++bad;
  EXPECT_EQ(bad, 0u) << "values differing by more than " << rel << " relative";
}

TEST(BvhRoundTrip, HandWritten) {
  const std::string texts[] = {
      two_joints("Frames: 2\nFrame Time: 0.0333333\n1 2 3 4 5 6 7 8 9\n-1.25 2e-7 -3 4 5 6 7 8 "
                 "123456.789\n"),
      "HIERARCHY\nROOT A\n{\nOFFSET 1 2 3\nCHANNELS 2 Zposition Xposition\nJOINT B\n{\nOFFSET 0 0 "
      "0\n}\n}\n"
      "ROOT C\n{\nOFFSET 0 0 0\nCHANNELS 1 Yrotation\nEnd Site\n{\nOFFSET 0 0 1\n}\n}\n"
      "MOTION\nFrames: 1\nFrame Time: .0083333\n+1 -.5 1e-05\n"};
  for (const std::string& text : texts) {
    const RawClip a = parse_bvh(text, "a");
    const std::string written = write_bvh(a);
    EXPECT_NE(written.find("\tOFFSET"), std::string::npos) << "tabs for indentation";
    const RawClip b = parse_bvh(written, "b");
    expect_same_clip(a, b, 1e-9);
    // Numbers with at most 9 significant digits come back exactly.
    EXPECT_EQ(a.values, b.values);
    EXPECT_EQ(write_bvh(b), written) << "writing is deterministic";
  }
}

TEST(BvhRoundTrip, PrecisionOfRandomValues) {
  RawClip clip = parse_bvh(two_joints("Frames: 0\nFrame Time: 0.01\n"), "rand");
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1000.0, 1000.0);
  clip.frame_count = 50;
  clip.values.resize(clip.frame_count * clip.channel_count);
  for (double& v : clip.values) v = u(rng) * std::pow(10.0, static_cast<int>(rng() % 9) - 4);
  // 17 significant digits: exact.
  EXPECT_EQ(parse_bvh(write_bvh(clip, 17), "p17").values, clip.values);
  // 9 digits: within half a unit in the 9th digit.
  expect_same_clip(clip, parse_bvh(write_bvh(clip, 9), "p9"), 5e-9);
  // 4 digits: visibly rounded, still within 5e-4.
  const RawClip p4 = parse_bvh(write_bvh(clip, 4), "p4");
  expect_same_clip(clip, p4, 5e-4);
  EXPECT_NE(p4.values, clip.values);
}

TEST(BvhRoundTrip, WriterRejectsBrokenClips) {
  RawClip clip = parse_bvh(two_joints("Frames: 1\nFrame Time: 0.01\n1 2 3 4 5 6 7 8 9\n"), "w");
  RawClip nan_value = clip;
  nan_value.values[3] = std::nan("");
  EXPECT_THROW((void)write_bvh(nan_value), InputError);
  RawClip short_values = clip;
  short_values.values.pop_back();
  EXPECT_THROW((void)write_bvh(short_values), std::invalid_argument);
  RawClip bad_parent = clip;
  bad_parent.joints[0].parent = 1;
  EXPECT_THROW((void)write_bvh(bad_parent), std::invalid_argument);
  RawClip bad_name = clip;
  bad_name.joints[1].name = "a\nb";
  EXPECT_THROW((void)write_bvh(bad_name), InputError);
}

TEST(BvhRoundTrip, WriteFileIsAtomicAndReadable) {
  const RawClip clip =
      parse_bvh(two_joints("Frames: 1\nFrame Time: 0.01\n1 2 3 4 5 6 7 8 9\n"), "f");
  const auto dir = test::temp_dir("bvh-write");
  const auto path = dir / "out.bvh";
  write_bvh_file(clip, path);
  write_bvh_file(clip, path);  // overwrite in place
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++files;
  EXPECT_EQ(files, 1u) << "no temporary file left behind";
  expect_same_clip(clip, read_bvh_file(path), 0.0);
  EXPECT_THROW(write_bvh_file(clip, dir / "no-such-dir" / "x.bvh"), InputError);
  std::filesystem::remove_all(dir);
}

TEST(BvhRoundTrip, RealFiles) {
  MOCAP_REQUIRE_DATA();
  std::vector<std::filesystem::path> files = {
      test::data_dir() / "bandai-namco-1" / "data" / "dataset-1_walk_normal_001.bvh",
      test::data_dir() / "cmu" / "131_01.bvh"};
  const auto bn2 = test::bandai_namco_2_dir();
  if (!bn2.empty()) {
    for (const auto& e : std::filesystem::directory_iterator(bn2))
      if (e.path().extension() == ".bvh") {
        files.push_back(e.path());
        break;
      }
  }
  for (const auto& path : files) {
    SCOPED_TRACE(path.string());
    const RawClip a = read_bvh_file(path);
    ASSERT_GT(a.frame_count, 0u);
    const RawClip b = parse_bvh(write_bvh(a), "written");
    expect_same_clip(a, b, 1e-9);
  }
}

// ---------------------------------------------------------------------------
// Export layout.
// ---------------------------------------------------------------------------

// Largest distance between world joint positions and End Sites of two clips
// over all frames, matching joints by name; joints listed in `skip` are ignored.
double max_world_difference_m(const RawClip& a, const RawClip& b, double scale_m,
                              const std::vector<std::string>& skip = {}) {
  const ClipMotion ma = clip_motion_from_raw(a, scale_m);
  const ClipMotion mb = clip_motion_from_raw(b, scale_m);
  EXPECT_EQ(ma.frame_count, mb.frame_count);
  double worst = 0.0;
  WorldPose wa, wb;
  std::vector<Eigen::Vector3d> ea, eb;
  for (std::size_t f = 0; f < std::min(ma.frame_count, mb.frame_count); ++f) {
    wa.positions_m.assign(
        ma.world_positions_m.begin() + static_cast<std::ptrdiff_t>(f * ma.joint_count()),
        ma.world_positions_m.begin() + static_cast<std::ptrdiff_t>((f + 1) * ma.joint_count()));
    wa.rotations.assign(
        ma.world_rotations.begin() + static_cast<std::ptrdiff_t>(f * ma.joint_count()),
        ma.world_rotations.begin() + static_cast<std::ptrdiff_t>((f + 1) * ma.joint_count()));
    wb.positions_m.assign(
        mb.world_positions_m.begin() + static_cast<std::ptrdiff_t>(f * mb.joint_count()),
        mb.world_positions_m.begin() + static_cast<std::ptrdiff_t>((f + 1) * mb.joint_count()));
    wb.rotations.assign(
        mb.world_rotations.begin() + static_cast<std::ptrdiff_t>(f * mb.joint_count()),
        mb.world_rotations.begin() + static_cast<std::ptrdiff_t>((f + 1) * mb.joint_count()));
    end_site_positions(ma.skeleton, wa, ea);
    end_site_positions(mb.skeleton, wb, eb);
    for (std::size_t j = 0; j < ma.joint_count(); ++j) {
      const std::string& name = ma.skeleton.names[j];
      if (std::find(skip.begin(), skip.end(), name) != skip.end()) continue;
      const int k = mb.skeleton.find(name);
      EXPECT_GE(k, 0) << name;
      if (k < 0) continue;
      const auto kk = static_cast<std::size_t>(k);
      worst = std::max(worst, (wa.positions_m[j] - wb.positions_m[kk]).norm());
      worst = std::max(worst, (ea[j] - eb[kk]).norm());
    }
  }
  return worst;
}

void expect_export_layout(const RawClip& e) {
  for (const RawJoint& j : e.joints) {
    if (j.parent < 0) {
      EXPECT_EQ(j.offset, Eigen::Vector3d::Zero()) << j.name;
      ASSERT_EQ(j.channels.size(), 6u) << j.name;
      EXPECT_EQ(j.channels[0], Channel::Xposition);
      EXPECT_EQ(j.channels[1], Channel::Yposition);
      EXPECT_EQ(j.channels[2], Channel::Zposition);
      for (std::size_t c = 3; c < 6; ++c) EXPECT_TRUE(channel_is_rotation(j.channels[c])) << j.name;
    } else {
      ASSERT_EQ(j.channels.size(), 3u) << j.name;
      for (Channel c : j.channels) EXPECT_TRUE(channel_is_rotation(c)) << j.name;
    }
  }
}

TEST(BvhExport, HandBuiltLayoutAndWorldPositions) {
  // Root with rotations only (its OFFSET becomes position values), a joint with
  // constant position channels and a 2-axis rotation, a joint with no channels.
  const std::string text =
      "HIERARCHY\nROOT R\n{\n OFFSET 1 2 3\n CHANNELS 3 Yrotation Xrotation Zrotation\n"
      " JOINT A\n {\n  OFFSET 0 5 0\n  CHANNELS 4 Xposition Yposition Zrotation Xrotation\n"
      "  JOINT B\n  {\n   OFFSET 0 4 0\n   End Site\n   {\n    OFFSET 1 1 1\n   }\n  }\n }\n}\n"
      "MOTION\nFrames: 3\nFrame Time: 0.1\n"
      "10 20 30 0.5 6 40 -30\n"
      "-15 25 -35 0.50002 6.00003 -20 70\n"
      "5 -5 90 0.49999 5.99998 170 10\n";
  const RawClip clip = parse_bvh(text, "hand");
  const RawClip e = to_export_layout(clip);
  expect_export_layout(e);
  EXPECT_EQ(e.joints[0].channels[3], Channel::Yrotation);  // own order kept
  EXPECT_EQ(e.joints[1].channels,
            (std::vector<Channel>{Channel::Zrotation, Channel::Xrotation, Channel::Yrotation}));
  EXPECT_EQ(e.joints[2].channels,
            (std::vector<Channel>{Channel::Zrotation, Channel::Xrotation, Channel::Yrotation}));
  EXPECT_NEAR(e.joints[1].offset.x(), 0.5, 1e-4);
  EXPECT_NEAR(e.joints[1].offset.y(), 6.0, 1e-4);
  EXPECT_EQ(e.joints[1].offset.z(), 0.0);
  EXPECT_EQ(e.frame(1)[0], 1.0);  // root OFFSET as position values
  EXPECT_EQ(e.frame(1)[2], 3.0);
  EXPECT_EQ(e.frame(2)[6], 170.0);
  EXPECT_EQ(e.frame(2)[8], 0.0);  // inserted zero-angle axis
  EXPECT_LT(max_world_difference_m(clip, e, 1.0), 1e-4);
  // The written export reads back as the same layout.
  const RawClip back = parse_bvh(write_bvh(e), "back");
  expect_export_layout(back);
  EXPECT_LT(max_world_difference_m(e, back, 1.0), 1e-9);
}

TEST(BvhExport, VaryingNonRootPositionsThrow) {
  // A's X position varies by 2 units and its parent R has two children: no way to fold it.
  const std::string text =
      "HIERARCHY\nROOT R\n{\n OFFSET 0 0 0\n CHANNELS 3 Zrotation Xrotation Yrotation\n"
      " JOINT A\n {\n  OFFSET 0 5 0\n  CHANNELS 3 Xposition Yposition Zposition\n }\n"
      " JOINT B\n {\n  OFFSET 0 5 0\n }\n}\n"
      "MOTION\nFrames: 2\nFrame Time: 0.1\n0 0 0 1 5 0\n0 0 0 3 5 0\n";
  const RawClip clip = parse_bvh(text, "vary");
  try {
    (void)to_export_layout(clip);
    ADD_FAILURE() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(e.detail().find("'A'"), std::string::npos) << e.what();
    EXPECT_NE(e.detail().find("vary"), std::string::npos) << e.what();
  }
  // Within a larger tolerance it folds.
  EXPECT_NO_THROW((void)to_export_layout(clip, 2.5));
}

TEST(BvhExport, BandaiNamcoLiftsHipsMotionToStaticRoot) {
  MOCAP_REQUIRE_DATA();
  const RawClip clip =
      read_bvh_file(test::data_dir() / "bandai-namco-1" / "data" / "dataset-1_walk_normal_001.bvh");
  const RawClip e = to_export_layout(clip);
  expect_export_layout(e);
  ASSERT_EQ(e.joints.size(), clip.joints.size());
  // Every joint below the static joint_Root keeps its world position; joint_Root
  // itself now carries the root motion (it has no geometry).
  const double exported_m = max_world_difference_m(clip, e, 0.01, {"joint_Root"});
  EXPECT_LT(exported_m, 1e-6);
  const RawClip back = parse_bvh(write_bvh(e), "back");
  const double written_m = max_world_difference_m(clip, back, 0.01, {"joint_Root"});
  EXPECT_LT(written_m, 1e-6);
  std::printf("  largest world position change: exported %.3g m, written and read back %.3g m\n",
              exported_m, written_m);
}

TEST(BvhExport, CmuKeepsAllWorldPositions) {
  MOCAP_REQUIRE_DATA();
  const RawClip clip = read_bvh_file(test::data_dir() / "cmu" / "131_02.bvh");
  const RawClip e = to_export_layout(clip);
  expect_export_layout(e);
  const double exported_m = max_world_difference_m(clip, e, unit_scale_m(LengthUnit::cmu));
  EXPECT_LT(exported_m, 1e-6);
  const RawClip back = parse_bvh(write_bvh(e), "back");
  const double written_m = max_world_difference_m(clip, back, unit_scale_m(LengthUnit::cmu));
  EXPECT_LT(written_m, 1e-6);
  std::printf("  largest world position change: exported %.3g m, written and read back %.3g m\n",
              exported_m, written_m);
}

// ---------------------------------------------------------------------------
// Windows: parse_bvh_window gives exactly parse_bvh's rows for the window.
// ---------------------------------------------------------------------------

void expect_window_equals_full(const std::string& text, const RawClip& full) {
  for (std::size_t first = 0; first <= full.frame_count + 1; ++first)
    for (std::size_t count :
         {std::size_t{0}, std::size_t{1}, std::size_t{5}, full.frame_count + 3}) {
      const BvhWindow w = parse_bvh_window(text, "w.bvh", first, count);
      EXPECT_EQ(w.file_frame_count, full.frame_count);
      EXPECT_EQ(w.first_frame, std::min(first, full.frame_count));
      const std::size_t expect =
          std::min(count, full.frame_count - std::min(first, full.frame_count));
      ASSERT_EQ(w.clip.frame_count, expect) << first << " " << count;
      ASSERT_EQ(w.clip.channel_count, full.channel_count);
      ASSERT_EQ(w.clip.values.size(), expect * full.channel_count);
      EXPECT_EQ(w.clip.frame_time_s, full.frame_time_s);
      ASSERT_EQ(w.clip.joints.size(), full.joints.size());
      for (std::size_t i = 0; i < w.clip.values.size(); ++i)
        ASSERT_EQ(w.clip.values[i], full.values[w.first_frame * full.channel_count + i])
            << "first " << first << " value " << i;
    }
}

TEST(BvhWindow, EqualsWholeParseWithBlankLines) {
  const std::string text = two_joints(
      "Frames: 4\nFrame Time: 0.1\n1 2 3 4 5 6 7 8 9\n\n  \n1.5 2 3 4 5 6 7 8 9.25\n"
      "\t-1 -2 -3 -4 -5 -6 -7 -8 -9\r\n\n1e-3 2 3 4 5 6 7 8 +9\n\n");
  expect_window_equals_full(text, parse_bvh(text, "w.bvh"));
  // Lines past the window are not read: a bad last line goes unnoticed.
  const std::string bad = two_joints(
      "Frames: 3\nFrame Time: 0.1\n1 2 3 4 5 6 7 8 9\n"
      "1 2 3 4 5 6 7 8 9\nnot numbers\n");
  EXPECT_EQ(parse_bvh_window(bad, "w.bvh", 0, 2).clip.frame_count, 2u);
  EXPECT_THROW((void)parse_bvh_window(bad, "w.bvh", 1, 2), InputError);
}

TEST(BvhWindow, EqualsWholeParseOnRealFiles) {
  MOCAP_REQUIRE_DATA();
  for (const auto& rel : {"bandai-namco-1/data/dataset-1_walk_normal_001.bvh", "cmu/131_02.bvh"}) {
    const fs::path path = test::data_dir() / rel;
    std::ifstream in(path, std::ios::binary);
    std::string text(static_cast<std::size_t>(fs::file_size(path)), '\0');
    in.read(text.data(), static_cast<std::streamsize>(text.size()));
    ASSERT_TRUE(in) << path;
    const RawClip full = parse_bvh(text, path.string());
    ASSERT_GT(full.frame_count, 10u);
    for (std::size_t first :
         {std::size_t{0}, std::size_t{3}, full.frame_count / 2, full.frame_count - 2}) {
      const BvhWindow w = parse_bvh_window(text, path.string(), first, 5);
      ASSERT_EQ(w.clip.frame_count, std::min<std::size_t>(5, full.frame_count - first));
      for (std::size_t i = 0; i < w.clip.values.size(); ++i)
        ASSERT_EQ(w.clip.values[i], full.values[first * full.channel_count + i]) << rel;
    }
  }
}

// ---------------------------------------------------------------------------
// Hierarchies: a text parsed after a known hierarchy gives exactly what a
// whole parse gives; heads() accepts only texts whose tokens are the same.
// ---------------------------------------------------------------------------

void expect_same_window(const BvhWindow& a, const BvhWindow& b) {
  EXPECT_EQ(a.first_frame, b.first_frame);
  EXPECT_EQ(a.file_frame_count, b.file_frame_count);
  EXPECT_EQ(a.clip.source, b.clip.source);
  expect_same_clip(a.clip, b.clip, 0.0);  // bit for bit
}

TEST(BvhHierarchy, HeadsOnlyTextsWithTheSameTokens) {
  const BvhHierarchy empty;
  EXPECT_FALSE(empty.heads(""));
  EXPECT_FALSE(empty.heads(two_joints("Frames: 0\nFrame Time: 0.1\n")));
  const std::string text = two_joints("Frames: 1\nFrame Time: 0.1\n1 2 3 4 5 6 7 8 9\n");
  BvhHierarchy h;
  (void)parse_bvh_window(text, "a.bvh", 0, 1, &h);
  ASSERT_EQ(h.prefix, text.substr(0, text.find("MOTION") + 6));
  EXPECT_EQ(h.motion_line, 16u);
  EXPECT_TRUE(h.clip.source.empty());
  EXPECT_EQ(h.clip.frame_count, 0u);
  EXPECT_TRUE(h.clip.values.empty());
  EXPECT_EQ(h.clip.channel_count, 9u);
  EXPECT_TRUE(h.heads(text));
  EXPECT_TRUE(h.heads(h.prefix));                 // MOTION at the very end
  EXPECT_TRUE(h.heads(h.prefix + " Frames: 0"));  // a blank after it
  EXPECT_FALSE(h.heads(h.prefix + "X\n"));        // another token: "MOTIONX"
  EXPECT_FALSE(h.heads(h.prefix.substr(0, 20)));  // shorter than the prefix
  std::string other = text;
  other[other.find("OFFSET 0 10 0") + 9] = '2';  // one byte of the hierarchy differs
  EXPECT_FALSE(h.heads(other));
  EXPECT_FALSE(h.heads("\xEF\xBB\xBF" + text));  // a byte order mark is part of the prefix
  EXPECT_THROW((void)parse_bvh_window(other, "b.bvh", h, 0, 1), std::invalid_argument);
}

TEST(BvhHierarchy, KnownHierarchyParsesAsTheWholeText) {
  const std::string a = two_joints(
      "Frames: 4\nFrame Time: 0.1\n1 2 3 4 5 6 7 8 9\n\n1.5 2 3 4 5 6 7 8 9.25\n"
      "-1 -2 -3 -4 -5 -6 -7 -8 -9\r\n1e-3 2 3 4 5 6 7 8 +9\n");
  const std::string b =
      two_joints("Frames:2\nFrame Time: 0.05\n9 8 7 6 5 4 3 2 1\n0 0 0 0 0 0 0 0 0\n");
  BvhHierarchy h;
  expect_same_window(parse_bvh_window(a, "a.bvh", 1, 2, &h), parse_bvh_window(a, "a.bvh", 1, 2));
  for (std::size_t first = 0; first <= 5; ++first)
    for (std::size_t count : {std::size_t{0}, std::size_t{1}, std::size_t{3}, std::size_t{9}}) {
      expect_same_window(parse_bvh_window(a, "a.bvh", h, first, count),
                         parse_bvh_window(a, "a.bvh", first, count));
      expect_same_window(parse_bvh_window(b, "b.bvh", h, first, count),
                         parse_bvh_window(b, "b.bvh", first, count));
    }
  // Errors after the hierarchy name the same file and line as a whole parse.
  const std::string bad =
      two_joints("Frames: 2\nFrame Time: 0.1\n1 2 3 4 5 6 7 8 9\n1 2 3 x 5 6 7 8 9\n");
  ASSERT_TRUE(h.heads(bad));
  std::string known_message, whole_message;
  try {
    (void)parse_bvh_window(bad, "bad.bvh", h, 0, 2);
  } catch (const InputError& e) {
    known_message = e.what();
  }
  try {
    (void)parse_bvh_window(bad, "bad.bvh", 0, 2);
  } catch (const InputError& e) {
    whole_message = e.what();
  }
  EXPECT_NE(known_message.find("bad.bvh:20"), std::string::npos) << known_message;
  EXPECT_EQ(known_message, whole_message);
}

TEST(BvhHierarchy, OneHierarchyServesOtherFilesOfTheSkeleton) {
  MOCAP_REQUIRE_DATA();
  const auto read = [](const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::string text(static_cast<std::size_t>(fs::file_size(path)), '\0');
    in.read(text.data(), static_cast<std::streamsize>(text.size()));
    return text;
  };
  // Set 1's 174 files have 5 distinct hierarchies: each file is read after
  // the one of an earlier file that heads it, when there is one.
  std::vector<BvhHierarchy> known;
  std::size_t reused = 0;
  for (const auto& entry : fs::directory_iterator(test::data_dir() / "bandai-namco-1" / "data")) {
    if (entry.path().extension() != ".bvh") continue;
    const std::string text = read(entry.path());
    const std::string name = entry.path().filename().string();
    const std::size_t first = 20;
    const BvhWindow whole = parse_bvh_window(text, name, first, 5);
    const auto h = std::find_if(known.begin(), known.end(),
                                [&](const BvhHierarchy& k) { return k.heads(text); });
    if (h == known.end()) {
      expect_same_window(parse_bvh_window(text, name, first, 5, &known.emplace_back()), whole);
      ASSERT_TRUE(known.back().heads(text)) << name;
    } else {
      expect_same_window(parse_bvh_window(text, name, *h, first, 5), whole);
      ++reused;
    }
  }
  EXPECT_EQ(known.size(), 5u);
  EXPECT_EQ(reused, 169u);
  for (const BvhHierarchy& h : known)
    EXPECT_FALSE(h.heads(read(test::data_dir() / "cmu" / "131_02.bvh")));
}

}  // namespace
}  // namespace mocap
