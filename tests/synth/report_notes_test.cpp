// synth/src/report_notes.cpp: what the reports say about foot sliding,
// skating, foot contacts and range violations (docs/synthesis.md
// "Reports"). Invalid and empty inputs first, then hand-built violations
// and rows, then a captured walk as a motion.
#include <gtest/gtest.h>

#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "mocap/synth/synth_job.hpp"
#include "mocap/synth/synth_json.hpp"
#include "report_notes.hpp"
#include "report_views.hpp"
#include "synth_fixtures.hpp"
#include "test_support.hpp"

namespace {

using namespace mocap;
using namespace mocap::synth_detail;

RangeViolation violation(std::size_t frame, const std::string& joint, const std::string& channel,
                         double value_deg, double excess_deg) {
  RangeViolation v;
  v.frame = frame;
  v.joint = joint;
  v.channel = channel;
  v.min_deg = -10.0;
  v.max_deg = 20.0;
  v.value_deg = value_deg;
  v.excess_deg = excess_deg;
  return v;
}

// A captured walk as a synthesised motion of one partial segment.
struct WalkMotion {
  SynthSkeleton sk;
  SynthResult result;
};
std::unique_ptr<WalkMotion> captured_walk(const Index& index) {
  auto w = std::make_unique<WalkMotion>();
  const std::size_t clip = test::clip_named(index, "dataset-1_walk_normal_001.bvh");
  w->sk = make_synth_skeleton(index, index.clips()[clip].skeleton, clip);
  w->result.skeleton = &w->sk;
  w->result.frame_time_s = index.clips()[clip].frame_time_s;
  for (std::size_t f = 0; f < index.clips()[clip].frame_count; ++f)
    w->result.frames.push_back(clip_frame(index, clip, f));
  w->result.motion_measures = measure_motion(w->sk, w->result.frames, w->result.frame_time_s);
  return w;
}

}  // namespace

TEST(ReportNotes, EmptyInputsSayNothing) {
  EXPECT_TRUE(group_range_violations({}).empty());
  EXPECT_EQ(range_violation_summary({}), "");
  EXPECT_EQ(foot_contacts_text(EnergyParams{}, {}), "");
  EXPECT_EQ(foot_contacts_json({}), nlohmann::json::array());
  EXPECT_EQ(range_violation_list_json({}), nlohmann::json::array());
  EXPECT_EQ(synth_report_text(SynthResult{}), "") << "no skeleton";
}

TEST(ReportNotes, ViolationsAreGroupedByJointAndChannelTheWorstFirst) {
  const std::vector<RangeViolation> list{violation(0, "LowerLeg_L", "Xrotation", 25.0, 5.0),
                                         violation(1, "LowerLeg_L", "Xrotation", 32.0, 12.0),
                                         violation(1, "UpperArm_R", "Zrotation", -12.0, 2.0),
                                         violation(2, "LowerLeg_L", "Zrotation", 21.0, 1.0)};
  const auto groups = group_range_violations(list);
  ASSERT_EQ(groups.size(), 3u);
  EXPECT_EQ(groups[0].joint, "LowerLeg_L");
  EXPECT_EQ(groups[0].channel, "Xrotation");
  EXPECT_EQ(groups[0].frames, 2u);
  EXPECT_EQ(groups[0].worst_value_deg, 32.0);
  EXPECT_EQ(groups[0].worst_excess_deg, 12.0);
  EXPECT_EQ(groups[1].joint, "UpperArm_R");
  EXPECT_EQ(groups[2].channel, "Zrotation");
  EXPECT_EQ(range_violation_summary(list, 1),
            "LowerLeg_L Xrotation, range [-10.0, 20.0] deg: 2 frames, up to 32.0 (12.0 "
            "outside); and 2 more");
  const std::string all = range_violation_summary(list);
  EXPECT_NE(all.find("UpperArm_R Zrotation, range [-10.0, 20.0] deg: 1 frame, up to -12.0"),
            std::string::npos)
      << all;
  EXPECT_EQ(all.find("more"), std::string::npos) << all;
}

TEST(ReportNotes, TheMeasuresJsonKeepsTheCountAndNamesEachViolation) {
  TransitionMeasures m;
  m.range_violation_list = {violation(3, "Foot_L", "Yrotation", 24.5, 4.5)};
  m.range_violations = 1;
  const nlohmann::json j = measures_json(m);
  EXPECT_EQ(j.at("range_violations"), 1) << "the count stays (a contract)";
  ASSERT_EQ(j.at("range_violation_list").size(), 1u);
  const nlohmann::json& v = j.at("range_violation_list")[0];
  EXPECT_EQ(v.at("frame"), 3);
  EXPECT_EQ(v.at("joint"), "Foot_L");
  EXPECT_EQ(v.at("channel"), "Yrotation");
  EXPECT_EQ(v.at("min_deg"), -10.0);
  EXPECT_EQ(v.at("max_deg"), 20.0);
  EXPECT_EQ(v.at("value_deg"), 24.5);
  EXPECT_EQ(v.at("excess_deg"), 4.5);
  EXPECT_TRUE(j.contains("foot_sliding_slow_m"));
}

TEST(ReportNotes, TheSlidingNoteGivesBothNumbersAndTheirThresholds) {
  MotionMeasures m;
  m.foot_sliding_m = 4.14;
  m.foot_sliding_slow_m = 0.31;
  m.skating_ratio = 0.0;
  const std::string note = sliding_skating_note(EnergyParams{}, m);
  for (const char* part : {"foot sliding 4.14 m", "within 10 cm", "0.31 m at contact speed",
                           "0.8 m/s", "skating ratio 0.00", "below 5 cm", "faster than 0.5 m/s"})
    EXPECT_NE(note.find(part), std::string::npos) << part << " in: " << note;
}

TEST(ReportNotes, ARowThatNeverComesWithinTheBandSaysWhy) {
  FootContactRow row;
  row.lowest_m = 0.099;
  EXPECT_EQ(never_in_reach_note(EnergyParams{}, row), "");
  row.lowest_m = 0.1234;
  const std::string note = never_in_reach_note(EnergyParams{}, row);
  EXPECT_EQ(note.rfind("never within 10 cm (lowest 12.3 cm): ", 0), 0u) << note;
  EXPECT_NE(note.find("toes"), std::string::npos) << note;
}

TEST(ReportNotes, AWalksTextShowsEachFootSegmentsContacts) {
  if (!test::have_data()) GTEST_SKIP() << "no data";
  const Index* index = test::built_index({"bandai-namco-1"});
  ASSERT_NE(index, nullptr);
  const auto walk = captured_walk(*index);
  const std::string text = synth_report_text(walk->result);
  EXPECT_EQ(text.rfind("feet:   foot sliding ", 0), 0u) << text;
  for (const char* line : {"Foot_L (joint origin): in contact 0 of ", "never within 10 cm (lowest ",
                           "Toes_L (joint origin or bone tip): in contact ",
                           "Toes_R (joint origin or bone tip): in contact "})
    EXPECT_NE(text.find(line), std::string::npos) << line << " in:\n" << text;
  EXPECT_EQ(text.find("bone tip): in contact 0 of"), std::string::npos) << "toes touch:\n" << text;
  const nlohmann::json about = about_measures_json(walk->result);
  EXPECT_EQ(about.at("foot_sliding_m").at("contact_height_m"), 0.10);
  EXPECT_EQ(about.at("foot_skating_ratio").at("height_m"), 0.05);
  EXPECT_EQ(about.at("foot_skating_ratio").at("speed_mps"), 0.5);
  EXPECT_TRUE(about.at("sliding_and_skating").is_string());
}

TEST(ReportNotes, TheContactTimelineHasARowPerFootSegmentWithContacts) {
  if (!test::have_data()) GTEST_SKIP() << "no data";
  const Index* index = test::built_index({"bandai-namco-1"});
  ASSERT_NE(index, nullptr);
  const auto walk = captured_walk(*index);
  std::ostringstream o;
  contact_timeline(o, walk->result);
  const std::string svg = o.str();
  for (const char* row :
       {">Foot_L</text>", ">Foot_R</text>", ">Toes_L</text>", ">Toes_R</text>", ">skating</text>"})
    EXPECT_NE(svg.find(row), std::string::npos) << row;
  EXPECT_NE(svg.find("data-state=\"c\""), std::string::npos);
  EXPECT_NE(svg.find("data-note=\"never-in-reach\""), std::string::npos) << "the ankles' rows";
}

TEST(ReportNotes, StyleSummaryNamesEachStyleAndTheTransfer) {
  SynthResult r;
  EXPECT_EQ(style_summary_note(r), "") << "no style model: no paragraph";
  r.styles = {{"motion", "old", 0.372}, {"partial 1", "angry", 0.5}};
  EXPECT_EQ(style_summary_note(r), "output: old (p = 0.37); partial 1: angry (p = 0.50)");
  StyleTransferReport t;
  t.params.style = "tired";
  t.params.strength = 1.5;
  t.held_foot_frames = 41;
  t.max_root_drop_m = 0.0123;
  r.style_transfer = t;
  r.styles.insert(r.styles.begin() + 1, {"motion before transfer", "childish", 0.26});
  EXPECT_EQ(style_summary_note(r),
            "output: old (p = 0.37); partial 1: angry (p = 0.50); turned toward tired (strength "
            "1.50; before the transfer: childish, p = 0.26); 41 (leg, frame) pairs held where the "
            "untransferred feet are, the root moved at most 0.012 m");
}
