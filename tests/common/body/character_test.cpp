// Tests of character.cpp and segment_class.cpp: character files (invalid
// input first, one test per kind of error, then every field), the equality of
// characters, and the segment classes' names and predicates.
#include "mocap/common/body/character.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "mocap/common/util/error.hpp"
#include "test_support.hpp"

namespace mocap {
namespace {

std::filesystem::path source_dir() {
  return MOCAP_SOURCE_DIR;
}

// ---------------------------------------------------------------------------
// Character JSON: invalid input first, one test per kind of error.

/// Parses `text`, expects an InputError whose message starts with `field: `.
void expect_field_error(const std::string& text, const std::string& field) {
  try {
    (void)parse_character_json(text, "<char>");
    ADD_FAILURE() << "no error for " << text;
  } catch (const InputError& e) {
    EXPECT_EQ(e.source(), "<char>");
    EXPECT_EQ(e.line(), 0u);
    EXPECT_EQ(e.detail().rfind(field + ": ", 0), 0u)
        << "message '" << e.detail() << "' does not name " << field;
  }
}

TEST(CharacterJson, RejectsMalformedJson) {
  try {
    (void)parse_character_json("{\"total_mass_kg\": 70,", "<char>");
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(e.detail().find("invalid JSON"), std::string::npos) << e.detail();
    EXPECT_EQ(e.source(), "<char>");
  }
}

TEST(CharacterJson, RejectsNonObjectDocument) {
  expect_field_error("[1, 2]", "<document>");
}

TEST(CharacterJson, RejectsUnknownTopLevelKey) {
  expect_field_error(R"({"weight_kg": 70})", "weight_kg");
}

TEST(CharacterJson, RejectsWrongTypes) {
  expect_field_error(R"({"total_mass_kg": "70"})", "total_mass_kg");
  expect_field_error(R"({"total_mass_kg": true})", "total_mass_kg");
  expect_field_error(R"({"name": 3})", "name");
  expect_field_error(R"({"name": ""})", "name");
  expect_field_error(R"({"segments": []})", "segments");
  expect_field_error(R"({"segments": {"upper_arm": 3}})", "segments.upper_arm");
  expect_field_error(R"({"segments": {"hand": {"length_scale": false}}})",
                     "segments.hand.length_scale");
  expect_field_error(R"({"joints": {"LeftArm": [1]}})", "joints.LeftArm");
  expect_field_error(R"({"joints": {"LeftArm": {"mass_kg": null}}})", "joints.LeftArm.mass_kg");
}

TEST(CharacterJson, RejectsNonPositiveMassesAndScales) {
  expect_field_error(R"({"total_mass_kg": 0})", "total_mass_kg");
  expect_field_error(R"({"total_mass_kg": -70})", "total_mass_kg");
  expect_field_error(R"({"segments": {"upper_arm": {"mass_kg": -3}}})",
                     "segments.upper_arm.mass_kg");
  expect_field_error(R"({"segments": {"thigh": {"mass_scale": 0}}})", "segments.thigh.mass_scale");
  expect_field_error(R"({"segments": {"shank": {"length_scale": -1.1}}})",
                     "segments.shank.length_scale");
  expect_field_error(R"({"joints": {"LeftArm": {"length_scale": 0}}})",
                     "joints.LeftArm.length_scale");
  expect_field_error(R"({"joints": {"Head": {"mass_kg": -0.5}}})", "joints.Head.mass_kg");
}

TEST(CharacterJson, RejectsInfiniteNumbers) {
  // JSON has no NaN or Infinity literal; an overflowing number is the way in.
  expect_field_error(R"({"segments": {"upper_arm": {"mass_kg": 1e999}}})",
                     "segments.upper_arm.mass_kg");
  expect_field_error(R"({"total_mass_kg": -1e999})", "total_mass_kg");
}

TEST(CharacterJson, RejectsFiniteNumbersOutOfRange) {
  expect_field_error(R"({"total_mass_kg": 1e300})", "total_mass_kg");
  expect_field_error(R"({"segments": {"thigh": {"mass_scale": 1e6}}})",
                     "segments.thigh.mass_scale");
  expect_field_error(R"({"joints": {"LeftArm": {"length_scale": 1000}}})",
                     "joints.LeftArm.length_scale");
}

TEST(CharacterJson, RejectsBadSex) {
  expect_field_error(R"({"sex": "robot"})", "sex");
  expect_field_error(R"({"sex": 1})", "sex");
}

TEST(CharacterJson, RejectsUnknownClasses) {
  expect_field_error(R"({"segments": {"wing": {"mass_kg": 1}}})", "segments.wing");
  expect_field_error(R"({"segments": {"none": {"mass_kg": 1}}})", "segments.none");
  expect_field_error(R"({"segments": {"Upper_Arm": {"mass_kg": 1}}})", "segments.Upper_Arm");
}

TEST(CharacterJson, RejectsUnknownEntryKeys) {
  expect_field_error(R"({"segments": {"upper_arm": {"mass": 3}}})", "segments.upper_arm.mass");
  expect_field_error(R"({"joints": {"LeftArm": {"mass_scale": 2}}})", "joints.LeftArm.mass_scale");
}

TEST(CharacterJson, RejectsMassAndScaleTogether) {
  expect_field_error(R"({"segments": {"upper_arm": {"mass_kg": 3, "mass_scale": 2}}})",
                     "segments.upper_arm");
}

TEST(CharacterJson, RejectsEmptyJointName) {
  expect_field_error(R"({"joints": {"": {"mass_kg": 1}}})", "joints");
}

TEST(CharacterJson, RejectsUnsupportedVersion) {
  expect_field_error(R"({"version": 2})", "version");
  expect_field_error(R"({"version": "1"})", "version");
}

TEST(CharacterJson, MissingFileNamesThePath) {
  const auto path = test::temp_dir("character") / "absent.json";
  try {
    (void)read_character_file(path);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.source(), path.string());
  }
}

TEST(CharacterJson, ParsesEveryField) {
  const Character ch = parse_character_json(R"({
    "version": 1, "name": "tall", "total_mass_kg": 82.5, "sex": "female",
    "segments": {"upper_arm": {"mass_kg": 3.0, "length_scale": 1.1},
                 "thigh": {"mass_scale": 1.5}},
    "joints": {"LeftArm": {"mass_kg": 2.5, "length_scale": 1.2}}})",
                                            "<char>");
  EXPECT_EQ(ch.name, "tall");
  EXPECT_EQ(ch.total_mass_kg, 82.5);
  EXPECT_EQ(ch.sex, Sex::female);
  EXPECT_EQ(ch.class_mass_kg.at(SegmentClass::upper_arm), 3.0);
  EXPECT_EQ(ch.class_length_scale.at(SegmentClass::upper_arm), 1.1);
  EXPECT_EQ(ch.class_mass_scale.at(SegmentClass::thigh), 1.5);
  EXPECT_EQ(ch.class_mass_kg.count(SegmentClass::thigh), 0u);
  EXPECT_EQ(ch.joint_mass_kg.at("LeftArm"), 2.5);
  EXPECT_EQ(ch.joint_length_scale.at("LeftArm"), 1.2);
}

TEST(CharacterJson, EmptyObjectIsTheDefault) {
  const Character ch = parse_character_json("{}", "<char>");
  EXPECT_EQ(ch.name, "default");
  EXPECT_EQ(ch.total_mass_kg, 70.0);
  EXPECT_EQ(ch.sex, Sex::male);
}

TEST(CharacterJson, ExampleFilesParse) {
  const Character def = read_character_file(source_dir() / "docs/examples/character-default.json");
  EXPECT_EQ(def.total_mass_kg, 70.0);
  EXPECT_TRUE(def.class_mass_kg.empty());
  const Character heavy =
      read_character_file(source_dir() / "docs/examples/character-heavy-arms.json");
  ASSERT_EQ(heavy.class_mass_kg.count(SegmentClass::upper_arm), 1u);
  // Above the table's 2.71 % of 70 kg.
  EXPECT_GT(heavy.class_mass_kg.at(SegmentClass::upper_arm), 2.71 / 100.0 * 70.0);
}

TEST(SegmentClassNames, RoundTrip) {
  for (SegmentClass c :
       {SegmentClass::none, SegmentClass::head, SegmentClass::neck, SegmentClass::upper_trunk,
        SegmentClass::middle_trunk, SegmentClass::lower_trunk, SegmentClass::clavicle,
        SegmentClass::upper_arm, SegmentClass::forearm, SegmentClass::hand, SegmentClass::thigh,
        SegmentClass::shank, SegmentClass::foot, SegmentClass::toes})
    EXPECT_EQ(parse_segment_class(segment_class_name(c)), c);
  EXPECT_FALSE(parse_segment_class("arm").has_value());
  EXPECT_STREQ(side_name(Side::left), "left");
  EXPECT_STREQ(side_name(Side::center), "center");
}

TEST(SegmentClassNames, SidedAndTrunkClasses) {
  int sided = 0, trunk = 0;
  for (SegmentClass c : kMassiveClasses) {
    sided += is_sided(c) ? 1 : 0;
    trunk += is_trunk(c) ? 1 : 0;
    EXPECT_FALSE(is_sided(c) && is_trunk(c)) << segment_class_name(c);
  }
  EXPECT_EQ(sided, 8);
  EXPECT_EQ(trunk, 3);
  EXPECT_FALSE(is_sided(SegmentClass::none));
  EXPECT_FALSE(is_trunk(SegmentClass::none));
  EXPECT_TRUE(is_sided(SegmentClass::toes));
  EXPECT_TRUE(is_trunk(SegmentClass::lower_trunk));
  EXPECT_FALSE(is_sided(SegmentClass::neck));
}

TEST(CharacterEquality, BodySettingsIgnoreTheName) {
  Character a =
      parse_character_json(R"({"name": "a", "segments": {"hand": {"mass_kg": 1.0}}})", "<a>");
  Character b =
      parse_character_json(R"({"name": "b", "segments": {"hand": {"mass_kg": 1.0}}})", "<b>");
  EXPECT_FALSE(a == b);
  EXPECT_TRUE(static_cast<const BodySettings&>(a) == static_cast<const BodySettings&>(b));
  b.name = "a";
  EXPECT_TRUE(a == b);
  b.joint_length_scale["LeftArm"] = 1.1;
  EXPECT_FALSE(static_cast<const BodySettings&>(a) == static_cast<const BodySettings&>(b));
  EXPECT_TRUE(Character{} == parse_character_json("{}", "<default>"));
}

}  // namespace
}  // namespace mocap
