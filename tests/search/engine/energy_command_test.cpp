// The `mocap-search energy` command logic: argument parsing, errors, and the
// report on real files.
#include "mocap/search/energy_command.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <utility>

#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/units.hpp"
#include "mocap/common/util/error.hpp"
#include "test_support.hpp"

namespace mocap {
namespace {

TEST(FrameSpec, ParsesFileAndZeroBasedFrame) {
  const FrameSpec a = parse_frame_spec("dir/clip.bvh:12", "--from");
  EXPECT_EQ(a.file, std::filesystem::path("dir/clip.bvh"));
  EXPECT_EQ(a.frame, 12u);
  // The last colon separates the frame (paths may contain colons).
  const FrameSpec b = parse_frame_spec("C:/data/x.bvh:0", "--to");
  EXPECT_EQ(b.file, std::filesystem::path("C:/data/x.bvh"));
  EXPECT_EQ(b.frame, 0u);
}

TEST(FrameSpec, RejectsMalformedSpecs) {
  for (const char* bad : {"clip.bvh", "clip.bvh:", ":3", "clip.bvh:-1", "clip.bvh:1.5",
                          "clip.bvh:abc", "clip.bvh: 2"}) {
    try {
      parse_frame_spec(bad, "--from");
      ADD_FAILURE() << bad;
    } catch (const InputError& e) {
      EXPECT_EQ(e.source(), "--from") << bad;
    }
  }
}

std::filesystem::path walk() {
  return test::data_dir() / "bandai-namco-1" / "data" / "dataset-1_walk_normal_001.bvh";
}

EnergyCommandOptions options(std::size_t from, std::size_t to) {
  EnergyCommandOptions o;
  o.from = {walk(), from};
  o.to = {walk(), to};
  return o;
}

// A Z-up file is read Y up, as the indexer reads it: its energies equal those
// of the same clip written Y up (rotate_to_y_up), to round-off.
TEST(EnergyCommand, ZUpFileEqualsItsYUpCopy) {
  const std::filesystem::path zup = test::data_dir() / "bvh-wild" / "pybvh_test1_mixedorders.bvh";
  if (!std::filesystem::exists(zup)) GTEST_SKIP() << "no " << zup;
  const RawClip raw = read_bvh_file(zup);
  ASSERT_EQ(detect_up_axis(raw), UpAxis::z);
  const std::filesystem::path yup = test::temp_dir("energy-zup") / "yup.bvh";
  write_bvh_file(rotate_to_y_up(raw, UpAxis::z), yup, 17);
  for (const auto& [from, to] : {std::pair<std::size_t, std::size_t>{0, 10}, {20, 21}}) {
    EnergyCommandOptions z, y;
    z.from = {zup, from};
    z.to = {zup, to};
    y.from = {yup, from};
    y.to = {yup, to};
    const EnergyReport rz = run_energy_command(z), ry = run_energy_command(y);
    EXPECT_EQ(rz.from_unit, ry.from_unit);
    EXPECT_NEAR(rz.h_J, ry.h_J, 1e-9 * (1.0 + ry.h_J)) << from << "->" << to;
    EXPECT_NEAR(rz.g_J, ry.g_J, 1e-9 * (1.0 + ry.g_J)) << from << "->" << to;
    EXPECT_GT(ry.g_J, 0.0);
  }
}

TEST(EnergyCommand, ReportOnARealClip) {
  MOCAP_REQUIRE_DATA();
  const EnergyReport r = run_energy_command(options(10, 25));
  EXPECT_GT(r.h_J, 0.0);
  EXPECT_GE(r.g_J, r.h_J);
  double h = 0.0, g = 0.0;
  int segments = 0, joints = 0;
  for (const auto& t : r.terms) {
    h += t.h_J;
    g += t.g_J;
    EXPECT_GE(t.g_J, t.h_J) << t.name;
    (t.is_joint ? joints : segments)++;
    EXPECT_NE(t.name, "joint_Root");
  }
  EXPECT_NEAR(h, r.h_J, 1e-9 * r.h_J);
  EXPECT_NEAR(g, r.g_J, 1e-9 * r.g_J);
  EXPECT_GT(segments, 10);
  EXPECT_EQ(segments, joints);  // Bandai Namco: every term joint is a segment
  EXPECT_EQ(r.from_unit, "cm");
  EXPECT_NEAR(r.total_mass_kg, 70.0, 1e-6);
  // JSON contract.
  const auto j = nlohmann::json::parse(energy_report_json(r));
  EXPECT_DOUBLE_EQ(j["h_J"].get<double>(), r.h_J);
  EXPECT_DOUBLE_EQ(j["g_J"].get<double>(), r.g_J);
  ASSERT_EQ(j["terms"].size(), r.terms.size());
  for (const auto& t : j["terms"]) {
    EXPECT_TRUE(t.contains("name") && t.contains("kind") && t.contains("h_J") && t.contains("g_J"));
    EXPECT_TRUE(t["kind"] == "segment" || t["kind"] == "joint");
  }
  EXPECT_NE(energy_report_text(r).find("Hips"), std::string::npos);
}

TEST(EnergyCommand, SameFrameHasZeroApproximateEnergyAndUnitsAgree) {
  MOCAP_REQUIRE_DATA();
  const EnergyReport same = run_energy_command(options(40, 40));
  EXPECT_EQ(same.h_J, 0.0);
  EXPECT_GE(same.g_J, 0.0);
  EnergyCommandOptions o = options(5, 60);
  const EnergyReport detected = run_energy_command(o);
  o.unit = LengthUnit::cm;
  const EnergyReport declared = run_energy_command(o);
  EXPECT_DOUBLE_EQ(detected.h_J, declared.h_J);
  EXPECT_DOUBLE_EQ(detected.g_J, declared.g_J);
  // The transition time matters: a slower transition costs less kinetic energy.
  o.transition_time_s = 2.0;
  EXPECT_LT(run_energy_command(o).h_J, declared.h_J);
}

TEST(EnergyCommand, CharacterWithHeavyArmsRaisesArmTerms) {
  MOCAP_REQUIRE_DATA();
  const auto dir = test::temp_dir("energy-command");
  const auto file = dir / "heavy.json";
  std::ofstream(file)
      << R"({"version": 1, "name": "heavy", "segments": {"upper_arm": {"mass_kg": 6.0}}})";
  EnergyCommandOptions o = options(10, 25);
  const EnergyReport base = run_energy_command(o);
  o.character = file;
  const EnergyReport heavy = run_energy_command(o);
  EXPECT_EQ(heavy.character, "heavy");
  for (std::size_t i = 0; i < base.terms.size(); ++i)
    if (base.terms[i].name == "UpperArm_L" && !base.terms[i].is_joint) {
      EXPECT_GT(heavy.terms[i].h_J, base.terms[i].h_J);
    }
}

// A --to frame of another rig (CMU onto Bandai Namco and back) is retargeted
// onto the --from skeleton and compared on the segments both share: h and g
// are the sums of those terms (g >= h term by term), which the report lists
// with the compared classes; the same rig keeps every term.
TEST(EnergyCommand, AnotherRigIsRetargetedAndComparedOnSharedSegments) {
  MOCAP_REQUIRE_DATA();
  const std::filesystem::path cmu = test::data_dir() / "cmu" / "131_01.bvh";
  EnergyCommandOptions o = options(100, 0);
  o.to = {cmu, 600};
  const EnergyReport r = run_energy_command(o);
  EXPECT_TRUE(r.cross_rig);
  EXPECT_EQ(r.to_unit, "cmu");
  // Onto Bandai Namco every class is compared (head, hands and toes are point
  // masses there, placed by the segments above them).
  EXPECT_EQ(r.compared_classes.size(), 21u);
  double h = 0.0, g = 0.0;
  for (const auto& t : r.terms) {
    h += t.h_J;
    g += t.g_J;
    EXPECT_GE(t.g_J, t.h_J) << t.name;
  }
  EXPECT_NEAR(h, r.h_J, 1e-9 * r.h_J);
  EXPECT_NEAR(g, r.g_J, 1e-9 * r.g_J);
  EXPECT_GT(r.h_J, 0.0);
  EXPECT_GE(r.g_J, r.h_J);
  const auto j = nlohmann::json::parse(energy_report_json(r));
  EXPECT_TRUE(j["cross_rig"].get<bool>());
  EXPECT_EQ(j["compared_classes"].size(), 21u);
  EXPECT_EQ(j["compared_classes"][0], "head");
  EXPECT_NE(energy_report_text(r).find("across rigs"), std::string::npos);
  // Bandai Namco onto CMU: CMU's head, hands and toes have bones whose
  // direction Bandai Namco does not give: not compared.
  EnergyCommandOptions back;
  back.from = {cmu, 600};
  back.to = {walk(), 100};
  const EnergyReport rb = run_energy_command(back);
  EXPECT_TRUE(rb.cross_rig);
  EXPECT_EQ(rb.compared_classes.size(), 16u);
  for (const auto& t : rb.terms)
    for (const char* not_compared : {"Head", "LeftWrist", "RightToe", "LHipJoint"})
      EXPECT_NE(t.name, not_compared);
  // The same rig: every term, no compared_classes.
  const EnergyReport same = run_energy_command(options(10, 25));
  EXPECT_FALSE(same.cross_rig);
  const auto js = nlohmann::json::parse(energy_report_json(same));
  EXPECT_FALSE(js["cross_rig"].get<bool>());
  EXPECT_FALSE(js.contains("compared_classes"));
}

TEST(EnergyCommand, BadInputsAreInputErrors) {
  MOCAP_REQUIRE_DATA();
  EXPECT_THROW(run_energy_command(options(0, 100000)), InputError);  // frame out of range
  // Another rig that cannot be retargeted: no joint is recognised as a pelvis.
  const auto odd = test::temp_dir("energy-command-rig") / "odd.bvh";
  std::ofstream(odd) << "HIERARCHY\nROOT a\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition "
                        "Zposition Zrotation Xrotation Yrotation\n  JOINT b\n  {\n    OFFSET 0 "
                        "10 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n    End Site\n    "
                        "{\n      OFFSET 0 10 0\n    }\n  }\n}\nMOTION\nFrames: 2\nFrame "
                        "Time: 0.0333333\n0 90 0 0 0 0 0 0 0\n0 90 0 0 0 0 0 0 0\n";
  EnergyCommandOptions o = options(0, 1);
  o.to.file = odd;
  try {
    run_energy_command(o);
    ADD_FAILURE() << "a skeleton without a pelvis was retargeted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.source(), odd.string());
    EXPECT_NE(std::string(e.what()).find("pelvis"), std::string::npos) << e.what();
  }
  o = options(0, 1);
  o.from.file = "/nonexistent/clip.bvh";
  EXPECT_THROW(run_energy_command(o), InputError);
  o = options(0, 1);
  o.transition_time_s = 0.0;
  EXPECT_THROW(run_energy_command(o), InputError);
  o = options(0, 1);
  o.character = "/nonexistent/character.json";
  EXPECT_THROW(run_energy_command(o), InputError);
  o = options(0, 1);
  o.work.unsupported_speed_mps = std::numeric_limits<double>::infinity();
  EXPECT_THROW(run_energy_command(o), InputError);
}

// --- energy --motion: a whole motion summed over its steps ---------------

MotionEnergyOptions motion_options(std::size_t first, std::size_t last) {
  MotionEnergyOptions o;
  o.file = walk();
  o.frames = std::make_pair(first, last);
  return o;
}

TEST(MotionEnergyCommand, BadInputsAreInputErrorsNamingTheSource) {
  MOCAP_REQUIRE_DATA();
  const auto expect_source = [](const MotionEnergyOptions& o, const std::string& source,
                                const char* says) {
    try {
      run_motion_energy_command(o);
      ADD_FAILURE() << "accepted: " << says;
    } catch (const InputError& e) {
      EXPECT_EQ(e.source(), source) << e.what();
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
    }
  };
  expect_source(motion_options(5, 5), "--frames", "S < E");
  expect_source(motion_options(9, 3), "--frames", "S < E");
  expect_source(motion_options(0, 100000), "--frames", "out of range");
  MotionEnergyOptions o = motion_options(0, 1);
  o.file = "/nonexistent/clip.bvh";
  EXPECT_THROW(run_motion_energy_command(o), InputError);
  o = motion_options(0, 1);
  o.character = "/nonexistent/character.json";
  EXPECT_THROW(run_motion_energy_command(o), InputError);
  o = motion_options(0, 1);
  o.work.unsupported_speed_mps = -1.0;
  expect_source(o, "--unsupported-speed", "finite speed");
  o.work.unsupported_speed_mps = std::nan("");
  expect_source(o, "--unsupported-speed", "finite speed");
  // A file of one frame holds no step.
  const auto one = test::temp_dir("motion-energy-one") / "one.bvh";
  std::ofstream(one) << "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition "
                        "Yposition Zposition Zrotation Xrotation Yrotation\n  End Site\n  {\n    "
                        "OFFSET 0 10 0\n  }\n}\nMOTION\nFrames: 1\nFrame Time: 0.0333333\n0 90 0 "
                        "0 0 0\n";
  o = MotionEnergyOptions{};
  o.file = one;
  expect_source(o, one.string(), "at least 2 frames");
}

// Each step's g equals the pair command's g between the same two frames at
// T = the frame time (the slow path: both frames' inverse dynamics redone),
// the parts add up to g, the terms to h and g, and the frames without
// contact and the peak speed are those of the frames asked for.
TEST(MotionEnergyCommand, StepsEqualThePairCommandAndPartsAddUp) {
  MOCAP_REQUIRE_DATA();
  const MotionEnergyReport r = run_motion_energy_command(motion_options(40, 52));
  ASSERT_EQ(r.step_g_J.size(), 12u);
  EXPECT_EQ(r.first_frame, 40u);
  EXPECT_EQ(r.last_frame, 52u);
  double sum = 0.0;
  for (std::size_t i = 0; i < r.step_g_J.size(); ++i) {
    EnergyCommandOptions pair = options(40 + i, 41 + i);
    pair.transition_time_s = r.frame_time_s;
    const EnergyReport p = run_energy_command(pair);
    EXPECT_NEAR(r.step_g_J[i], p.g_J, 1e-9 * (1.0 + p.g_J)) << "step " << i;
    sum += r.step_g_J[i];
  }
  EXPECT_NEAR(r.g_J, sum, 1e-9 * sum);
  const double parts = r.h_J + r.adjacent_work_J + r.contact_work_J + r.joint_work_J +
                       r.residual_work_J + r.residual_impulse_J;
  EXPECT_NEAR(parts, r.g_J, 1e-9 * r.g_J);
  double h = 0.0, g = 0.0;
  for (const EnergyTermReport& t : r.terms) {
    h += t.h_J;
    g += t.g_J;
  }
  EXPECT_NEAR(h, r.h_J, 1e-9 * r.h_J);
  EXPECT_NEAR(g, r.g_J, 1e-9 * r.g_J);
  EXPECT_GE(r.g_J, r.h_J);
  // Walking: some frame is on the ground, the knees swing at a few rad/s.
  EXPECT_LT(r.no_contact_frames, 13u);
  EXPECT_GT(r.peak_angular_speed_radps, 0.5);
  EXPECT_LT(r.peak_angular_speed_radps, 30.0);
  EXPECT_FALSE(r.peak_joint.empty());
  const nlohmann::json j = nlohmann::json::parse(motion_energy_report_json(r));
  EXPECT_EQ(j["motion"]["steps"], 12);
  EXPECT_EQ(j["step_g_J"].size(), 12u);
  EXPECT_DOUBLE_EQ(j["g_J"].get<double>(), r.g_J);
  EXPECT_DOUBLE_EQ(j["parts"]["residual_impulse_J"].get<double>(), r.residual_impulse_J);
}

// A part of a file gives the steps of the whole file's run over the same
// frames (the rates at its ends come from the frames beside it).
TEST(MotionEnergyCommand, FramesArePartOfTheWholeFile) {
  MOCAP_REQUIRE_DATA();
  MotionEnergyOptions whole;
  whole.file = walk();
  const MotionEnergyReport all = run_motion_energy_command(whole);
  const MotionEnergyReport part = run_motion_energy_command(motion_options(30, 45));
  ASSERT_GT(all.step_g_J.size(), 45u);
  for (std::size_t i = 0; i < part.step_g_J.size(); ++i)
    EXPECT_DOUBLE_EQ(part.step_g_J[i], all.step_g_J[30 + i]) << i;
}

}  // namespace
}  // namespace mocap
