// Tests for common/src/motion/style.cpp (docs/style.md): bad input refused
// by name; the features do not depend on where the motion faces nor on the
// length unit; an indexed clip and its file give the same features; a
// model reads back from its JSON to the same predictions; its calibrated
// temperature gives held-out takes' true styles more probability; on set 1,
// leave one take out, the style of at least 7 takes in 10 is named (15
// styles; measured 0.80, as the experiment's script in
// docs/experiments/2026-12-06-style-recognition.py).
#include "mocap/common/motion/style.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "mocap/common/io/bvh.hpp"
#include "mocap/common/util/error.hpp"
#include "test_support.hpp"

namespace mocap {
namespace {

namespace fs = std::filesystem;

// Set 1, indexed once per test binary.
const Index* set1() {
  static const std::unique_ptr<Index> index = [] {
    const fs::path out =
        test::build_index_with_binary(test::data_dir() / "bandai-namco-1" / "data",
                                      test::temp_dir("style-index") / "set1.h5", {});
    return out.empty() ? nullptr : std::make_unique<Index>(Index::open(out));
  }();
  return index.get();
}

fs::path set1_file(const std::string& name) {
  return test::data_dir() / "bandai-namco-1" / "data" / name;
}

std::size_t clip_named(const Index& index, const std::string& name) {
  for (std::size_t c = 0; c < index.clips().size(); ++c)
    if (index.clips()[c].path.ends_with("/" + name)) return c;
  ADD_FAILURE() << "no clip " << name;
  return 0;
}

TEST(Style, BadInputIsRefusedByName) {
  MOCAP_REQUIRE_DATA();
  RawClip clip = read_bvh_file(set1_file("dataset-1_walk_normal_001.bvh"));
  EXPECT_THROW(raw_style_motion(clip, 10, 9), InputError);
  EXPECT_THROW(raw_style_motion(clip, 0, clip.frame_count), InputError);
  const StyleMotion three = raw_style_motion(clip, 0, 2);
  EXPECT_THROW(style_features(three, style_joints(three)), InputError);
  const StyleMotion m = raw_style_motion(clip, 0, 40);
  try {
    style_features(m, {"Hips", "Tail"});
    FAIL() << "a joint the motion lacks";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("\"Tail\""), std::string::npos) << e.what();
  }
  const std::vector<std::string> joints = style_joints(m);
  StyleSample a{style_features(m, joints), "walk", "normal", 0};
  EXPECT_THROW(train_style_model({a, a}, joints), InputError) << "one style";
  StyleSample b = a;
  b.style = "old";
  EXPECT_THROW(train_style_model({a, b}, joints, 0.0), InputError) << "shrinkage 0";
  b.features.pop_back();
  EXPECT_THROW(train_style_model({a, b}, joints), InputError) << "features of another length";
  EXPECT_THROW(style_model_from_json(nlohmann::json::object(), "m.json"), InputError);
  EXPECT_THROW(style_model_from_json({{"format", "mocap-style-model"}, {"version", 2}}, "m.json"),
               InputError);
}

TEST(Style, FeaturesIgnoreHeadingPlaceAndLengthUnit) {
  MOCAP_REQUIRE_DATA();
  const RawClip clip = read_bvh_file(set1_file("dataset-1_walk_normal_001.bvh"));
  const StyleMotion m = raw_style_motion(clip, 0, clip.frame_count - 1);
  const std::vector<std::string> joints = style_joints(m);
  ASSERT_EQ(joints.front(), "Hips");  // joint_Root above it carries no motion
  ASSERT_EQ(joints.size(), 21u);
  const std::vector<double> f = style_features(m, joints);
  ASSERT_EQ(f.size(), 21 * kStyleJointFeatures + kStyleMotionFeatures);
  // The whole motion turned by 70 degrees about +Y, moved, and in metres.
  StyleMotion t = m;
  const Eigen::AngleAxisd turn(1.2217, Eigen::Vector3d::UnitY());
  for (std::size_t i = 0; i < t.frame_count; ++i) {
    t.pelvis_rotations[i] = Eigen::Quaterniond(turn) * t.pelvis_rotations[i];
    t.pelvis_positions[i] = 0.01 * (turn * t.pelvis_positions[i]) + Eigen::Vector3d(3, 0, -2);
  }
  const std::vector<double> g = style_features(t, joints);
  for (std::size_t i = 0; i < f.size(); ++i) EXPECT_NEAR(g[i], f[i], 1e-9) << "feature " << i;
}

TEST(Style, AnIndexedClipAndItsFileGiveTheSameFeatures) {
  MOCAP_REQUIRE_DATA();
  const Index* index = set1();
  ASSERT_NE(index, nullptr);
  for (const char* name : {"dataset-1_walk_normal_001.bvh", "dataset-1_bow_old_001.bvh"}) {
    const std::size_t c = clip_named(*index, name);
    const RawClip clip = read_bvh_file(set1_file(name));
    const StyleMotion a = index_style_motion(*index, c, 5, 60);
    const StyleMotion b = raw_style_motion(clip, 5, 60);
    const std::vector<std::string> joints = style_joints(a);
    ASSERT_EQ(joints, style_joints(b));
    const std::vector<double> fa = style_features(a, joints), fb = style_features(b, joints);
    // The index holds float32 rotations and metres; the file, doubles in cm.
    for (std::size_t i = 0; i < fa.size(); ++i)
      EXPECT_NEAR(fa[i], fb[i], 2e-3 * (1.0 + std::abs(fb[i]))) << name << " feature " << i;
  }
}

TEST(Style, ModelReadsBackAndNamesStylesOfHeldOutTakes) {
  MOCAP_REQUIRE_DATA();
  const Index* index = set1();
  ASSERT_NE(index, nullptr);
  std::vector<std::string> joints;
  const std::vector<StyleSample> samples = index_style_samples(*index, joints);
  EXPECT_EQ(samples.size(), 174u);
  const StyleModel m = train_style_model(samples, joints);
  EXPECT_EQ(m.style.classes.size(), 15u);
  const StyleModel back =
      style_model_from_json(nlohmann::json::parse(style_model_json(m).dump()), "<round trip>");
  for (std::size_t i = 0; i < samples.size(); i += 17) {
    const StylePrediction p = recognise_style(m, samples[i].features);
    const StylePrediction q = recognise_style(back, samples[i].features);
    EXPECT_EQ(p.style, q.style);
    EXPECT_EQ(p.content, q.content);
    double total = 0.0;
    for (std::size_t k = 0; k < p.probabilities.size(); ++k) {
      EXPECT_NEAR(p.probabilities[k].second, q.probabilities[k].second, 1e-9);
      total += p.probabilities[k].second;
    }
    EXPECT_NEAR(total, 1.0, 1e-12);
  }
  EXPECT_THROW(recognise_style(m, samples[0].features, "no-such-content"), InputError);
  // Calibration: held-out takes (those of fold 0 of 5, a model learned
  // without them) get more probability on their true style at the
  // calibrated temperature than at the discriminant's own.
  const double t = calibrate_style_temperature(samples, joints);
  EXPECT_GT(t, 1.0) << "a discriminant in 192 dimensions is overconfident";
  std::vector<StyleSample> train, held;
  for (std::size_t i = 0; i < samples.size(); ++i)
    (i % 5 == 0 ? held : train).push_back(samples[i]);
  StyleModel raw = train_style_model(train, joints), cal = raw;
  cal.temperature = t;
  double log_raw = 0.0, log_cal = 0.0;
  for (const StyleSample& s : held) {
    const auto truth = [&](const StylePrediction& p) {
      for (const auto& [style, prob] : p.probabilities)
        if (style == s.style) return std::log(std::max(prob, 1e-300));
      return 0.0;
    };
    log_raw += truth(recognise_style(raw, s.features, s.content));
    log_cal += truth(recognise_style(cal, s.features, s.content));
  }
  EXPECT_GT(log_cal, log_raw);
  const StyleEvaluation e = evaluate_style(samples, joints, 0);
  EXPECT_EQ(e.takes + e.alone, samples.size());
  EXPECT_GE(e.accuracy(), 0.7) << e.right << " of " << e.takes;
}

}  // namespace
}  // namespace mocap
