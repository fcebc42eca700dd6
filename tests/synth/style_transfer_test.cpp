// Tests for synth/src/style_transfer.cpp and its use in synthesize()
// (docs/style.md "Style transfer"): bad input refused by name (a style the
// model lacks, named with the model's styles; bad parameters; a motion too
// short; a model of another rig; a style without a model; a query's
// "synth_style" that is no string or no style of the model); then on set 1,
// a timed fill of a normal walk's key poses, the database's old walks left
// out, turned toward "old": the model gives "old" more probability than
// before, the key frames are the untransferred motion's bit for bit, the
// feet skate no more than the untransferred motion's + 0.01, the report
// carries the transfer and the style before it, and the motion does not
// depend on the thread count.
#include "mocap/synth/style_transfer.hpp"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cstring>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "mocap/common/util/error.hpp"
#include "mocap/search/query.hpp"
#include "mocap/search/search.hpp"
#include "mocap/synth/synth_job.hpp"
#include "synth_fixtures.hpp"
#include "test_support.hpp"

namespace {

namespace fs = std::filesystem;
using namespace mocap;

const Index* set1() {
  return test::built_index({"bandai-namco-1"});
}

// The style model of set 1's labelled clips (mocap-index style-model's).
std::shared_ptr<const StyleModel> set1_model() {
  static std::shared_ptr<const StyleModel> model = [] {
    std::vector<std::string> joints;
    const std::vector<StyleSample> samples = index_style_samples(*set1(), joints);
    return std::make_shared<const StyleModel>(learn_style_model(samples, joints));
  }();
  return model;
}

const fs::path kWalk = "bandai-namco-1/data/dataset-1_walk_normal_001.bvh";

// Key poses of walk_normal_001 at frames 100, 140, 180 (their own times),
// the take itself and every old walk left out of the search.
std::string old_walk_query(const std::string& extra = "") {
  const std::string file = fs::absolute(test::data_dir() / kWalk).string();
  std::string out = R"({"id": "to-old", "top": 3, "frames": [)";
  for (int i = 0; i < 3; ++i)
    out += std::string(i ? ", " : "") + R"({"bvh": ")" + file + R"(", "frame": )" +
           std::to_string(100 + 40 * i) + R"(, "time_s": )" + std::to_string(40 * i / 30.0) + "}";
  return out +
         R"(], "filter": {"exclude": ["dataset-1_walk_normal_001*", "dataset-1_walk_old_*"]})" +
         extra + "}";
}

struct Synthesised {
  Query query;
  QueryOutcome found;
  SynthResult result;
  std::optional<SynthSkeleton> skeleton;
};

// The query as mocap-synth runs it (query_for_fill, its search, synthesize).
std::unique_ptr<Synthesised> run(const std::string& text, const SynthOptions& options) {
  auto r = std::make_unique<Synthesised>();
  r->query = query_for_fill(parse_query_text(text, "<test>", 0, fs::current_path(), "q"), options);
  r->found = SearchEngine(*set1()).run(r->query, SearchOptions{});
  if (r->found.error) {
    ADD_FAILURE() << *r->found.error;
    return nullptr;
  }
  r->result = synthesize(*set1(), r->query, r->found.pairs, options, r->skeleton);
  return r;
}

double probability_of(const StyleModel& model, const SynthResult& r, const std::string& style) {
  const auto p = recognise_motion_style(
      model, synth_style_motion(*r.skeleton, r.frames, r.frame_time_s), "walk");
  if (!p) return -1.0;
  for (const auto& [s, prob] : p->probabilities)
    if (s == style) return prob;
  return -1.0;
}

// The error's source and detail of `f()` (a test failure when none).
template <class F>
std::pair<std::string, std::string> input_error_of(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return {e.source(), e.detail()};
  }
  ADD_FAILURE() << "no InputError";
  return {};
}

}  // namespace

TEST(StyleTransfer, RefusesBadInputByName) {
  MOCAP_REQUIRE_DATA();
  ASSERT_NE(set1(), nullptr);
  const auto model = set1_model();
  SynthOptions plain;
  const auto base = run(old_walk_query(), plain);
  ASSERT_NE(base, nullptr);
  const SynthSkeleton& sk = *base->skeleton;
  std::vector<SynthFrame> frames = base->result.frames;
  const double dt = base->result.frame_time_s;
  StyleTransferParams p;
  p.style = "elderly";
  auto [source, detail] =
      input_error_of([&] { transfer_style(sk, nullptr, *model, p, {0}, "walk", frames, dt); });
  EXPECT_EQ(source, "--style");
  EXPECT_NE(detail.find("no style \"elderly\"; its styles: active, angry"), std::string::npos)
      << detail;
  p.style = "old";
  p.strength = 5.0;
  EXPECT_EQ(
      input_error_of([&] { transfer_style(sk, nullptr, *model, p, {0}, "", frames, dt); }).first,
      "--style-strength");
  p.strength = 1.0;
  p.min_sd_ratio = 1.5;
  EXPECT_EQ(
      input_error_of([&] { transfer_style(sk, nullptr, *model, p, {0}, "", frames, dt); }).first,
      "--style");
  p.min_sd_ratio = 0.5;
  std::vector<SynthFrame> three(frames.begin(), frames.begin() + 3);
  std::tie(source, detail) =
      input_error_of([&] { transfer_style(sk, nullptr, *model, p, {0}, "", three, dt); });
  EXPECT_EQ(source, "--style-model");
  EXPECT_NE(detail.find("at least 4"), std::string::npos) << detail;
  StyleModel other = *model;
  other.joints.back() = "Tail";
  std::tie(source, detail) =
      input_error_of([&] { transfer_style(sk, nullptr, other, p, {0}, "", frames, dt); });
  EXPECT_EQ(source, "--style-model");
  EXPECT_NE(detail.find("\"Tail\""), std::string::npos) << detail;
  EXPECT_EQ(frames.size(), base->result.frames.size()) << "a refused transfer changes nothing";
  // Through synthesize: a style without a model; a query's style the
  // model lacks, named with the query's field.
  SynthOptions no_model;
  no_model.style_transfer.style = "old";
  EXPECT_EQ(input_error_of([&] {
              synthesize(*set1(), base->query, base->found.pairs, no_model, base->skeleton);
            }).first,
            "--style");
  SynthOptions with_model;
  with_model.style_model = model;
  Query asked = base->query;
  asked.synth_style = "elderly";
  std::tie(source, detail) = input_error_of(
      [&] { synthesize(*set1(), asked, base->found.pairs, with_model, base->skeleton); });
  EXPECT_EQ(source, "<query to-old>");
  EXPECT_NE(detail.find("synth_style: the style model has no style \"elderly\""), std::string::npos)
      << detail;
  for (const char* bad : {R"(, "synth_style": 3)", R"(, "synth_style": "")"}) {
    std::tie(source, detail) = input_error_of(
        [&] { parse_query_text(old_walk_query(bad), "<test>", 0, fs::current_path(), "q"); });
    EXPECT_NE(detail.find("synth_style"), std::string::npos) << detail;
  }
}

TEST(StyleTransfer, TurnsAWalkTowardOldWithKeyPosesAndFeetKept) {
  MOCAP_REQUIRE_DATA();
  ASSERT_NE(set1(), nullptr);
  const auto model = set1_model();
  SynthOptions plain;
  plain.style_model = model;
  const auto before = run(old_walk_query(), plain);
  ASSERT_NE(before, nullptr);
  const auto after = run(old_walk_query(R"(, "synth_style": "old")"), plain);
  ASSERT_NE(after, nullptr);
  const SynthResult& a = after->result;
  const SynthResult& b = before->result;
  ASSERT_EQ(a.frames.size(), b.frames.size());
  ASSERT_TRUE(a.style_transfer);
  EXPECT_EQ(a.style_transfer->params.style, "old");
  EXPECT_EQ(a.style_transfer->content, "walk");
  EXPECT_FALSE(a.style_transfer->content_recognised);
  EXPECT_GT(a.style_transfer->held_foot_frames, 0u);
  const double p_before = probability_of(*model, b, "old"),
               p_after = probability_of(*model, a, "old");
  EXPECT_GT(p_after, p_before) << "old: " << p_before << " -> " << p_after;
  // The report's styles: the output's, then the untransferred output's (as
  // the plain run recognises it).
  ASSERT_GE(a.styles.size(), 2u);
  EXPECT_EQ(a.styles[0].of, "motion");
  EXPECT_EQ(a.styles[1].of, "motion before transfer");
  EXPECT_EQ(a.styles[1].label, b.styles[0].label);
  EXPECT_DOUBLE_EQ(a.styles[1].p, b.styles[0].p);
  // Key poses: the key frames are the untransferred motion's, bit for bit;
  // the frames between them changed.
  std::size_t keys = 0;
  for (const MotionSegment& s : a.segments) {
    if (s.kind != "query") continue;
    ++keys;
    const SynthFrame& x = a.frames[s.first_frame];
    const SynthFrame& y = b.frames[s.first_frame];
    EXPECT_EQ(x.root_position_m, y.root_position_m) << s.first_frame;
    for (std::size_t j = 0; j < x.local_rotations.size(); ++j)
      EXPECT_EQ(x.local_rotations[j].coeffs(), y.local_rotations[j].coeffs()) << j;
  }
  EXPECT_EQ(keys, 3u);
  EXPECT_EQ(a.style_transfer->key_frames, 3u);
  EXPECT_GT(a.frames[20].local_rotations[a.skeleton->root_joint].angularDistance(
                b.frames[20].local_rotations[b.skeleton->root_joint]) +
                a.frames[60].local_rotations[a.skeleton->root_joint].angularDistance(
                    b.frames[60].local_rotations[b.skeleton->root_joint]),
            0.0);
  // Feet: no more skating than the untransferred motion's + 0.01.
  EXPECT_LE(a.motion_measures.skating_ratio, b.motion_measures.skating_ratio + 0.01)
      << b.motion_measures.skating_ratio;
  // The report: the transfer's parameters and the styles.
  const nlohmann::json report = nlohmann::json::parse(synth_report_json(
      *set1(), after->query, "q.json", after->found.pairs, a, plain, 0.0, 0.0, "m.bvh"));
  ASSERT_TRUE(report.contains("style_transfer"));
  EXPECT_EQ(report["style_transfer"]["style"], "old");
  EXPECT_EQ(report["style_transfer"]["from_style"], a.style_transfer->from_style);
  EXPECT_EQ(report["styles"][1]["of"], "motion before transfer");
}

TEST(StyleTransfer, TheMotionDoesNotDependOnTheThreadCount) {
  MOCAP_REQUIRE_DATA();
  ASSERT_NE(set1(), nullptr);
  SynthOptions options;
  options.style_model = set1_model();
  options.style_transfer.style = "tired";
  const auto many = run(old_walk_query(), options);
  ASSERT_NE(many, nullptr);
  std::unique_ptr<Synthesised> one;
  {
    const tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
    one = run(old_walk_query(), options);
  }
  ASSERT_NE(one, nullptr);
  ASSERT_TRUE(many->result.style_transfer);
  ASSERT_EQ(one->result.frames.size(), many->result.frames.size());
  for (std::size_t i = 0; i < one->result.frames.size(); ++i) {
    const SynthFrame& x = one->result.frames[i];
    const SynthFrame& y = many->result.frames[i];
    EXPECT_EQ(x.root_position_m, y.root_position_m) << i;
    for (std::size_t j = 0; j < x.local_rotations.size(); ++j)
      EXPECT_EQ(x.local_rotations[j].coeffs(), y.local_rotations[j].coeffs()) << i << " " << j;
  }
}

TEST(StyleTransfer, StrengthZeroLeavesTheMotionAsItWas) {
  MOCAP_REQUIRE_DATA();
  ASSERT_NE(set1(), nullptr);
  SynthOptions plain;
  const auto base = run(old_walk_query(), plain);
  ASSERT_NE(base, nullptr);
  std::vector<SynthFrame> frames = base->result.frames;
  StyleTransferParams p;
  p.style = "old";
  p.strength = 0.0;
  const StyleTransferReport r = transfer_style(*base->skeleton, nullptr, *set1_model(), p, {0},
                                               "walk", frames, base->result.frame_time_s);
  EXPECT_EQ(r.mean_offset_rad, 0.0);
  EXPECT_GT(r.held_foot_frames, 0u);  // the held legs' IK ran, and changed nothing
  double turned = 0.0, moved = 0.0;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    moved = std::max(moved,
                     (frames[i].root_position_m - base->result.frames[i].root_position_m).norm());
    for (std::size_t j = 0; j < frames[i].local_rotations.size(); ++j)
      turned = std::max(turned, frames[i].local_rotations[j].angularDistance(
                                    base->result.frames[i].local_rotations[j]));
  }
  EXPECT_LT(moved, 1e-9);
  EXPECT_LT(turned, 1e-6);
}
