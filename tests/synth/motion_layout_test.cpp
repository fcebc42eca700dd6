// synth/src/motion_layout.cpp through synthesize(): where the output motion
// goes. A relative query of two frames of an indexed clip reproduces that
// clip; held-out queries start at the first query frame's world pose and keep
// moving; the pelvis carries the translation in the written BVH.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "mocap/common/io/bvh.hpp"
#include "mocap/search/query.hpp"
#include "mocap/search/search.hpp"
#include "mocap/synth/synth_job.hpp"
#include "synth_fixtures.hpp"
#include "test_support.hpp"

namespace {

namespace fs = std::filesystem;
using namespace mocap;

const Index* shared_index() {
  return test::built_index({"bandai-namco-1", "cmu"});
}

fs::path data_file(const std::string& rel) {
  return fs::absolute(test::data_dir() / rel);
}

std::string frames_json(const fs::path& bvh, std::size_t a, std::size_t b) {
  return R"("frames": [{"bvh": ")" + bvh.string() + R"(", "frame": )" + std::to_string(a) +
         R"(}, {"bvh": ")" + bvh.string() + R"(", "frame": )" + std::to_string(b) + "}]";
}

struct Synthesised {
  SynthResult result;
  std::optional<SynthSkeleton> skeleton;
};

std::unique_ptr<Synthesised> synthesise(const Index& index, const std::string& text) {
  const Query q = parse_query_text(text, "<test>", 0, fs::current_path(), "q");
  const SearchEngine engine(index);
  const QueryOutcome found = engine.run(q, SearchOptions{});
  if (found.error) {
    ADD_FAILURE() << *found.error;
    return nullptr;
  }
  auto out = std::make_unique<Synthesised>();
  out->result = synthesize(index, q, found.pairs, SynthOptions{}, out->skeleton);
  out->result.skeleton = &*out->skeleton;
  return out;
}

Eigen::Vector3d clip_root(const Index& index, std::size_t clip, std::size_t f) {
  const IndexClip& c = index.clips()[clip];
  const IndexArray& roots = index.array(c.skeleton, "frames", "root_position_m");
  const std::size_t g = c.frame_start + f;
  return {roots.f32[3 * g], roots.f32[3 * g + 1], roots.f32[3 * g + 2]};
}

using test::clip_named;

// The held-out walk query (frames 10 and 40 of walk_normal_001, the clip
// excluded) with `placement` ("relative" JSON value), synthesised.
std::unique_ptr<Synthesised> held_out_walk(const Index& index, const std::string& placement) {
  const fs::path file = data_file("bandai-namco-1/data/dataset-1_walk_normal_001.bvh");
  return synthesise(index, "{" + frames_json(file, 10, 40) + R"(, "top": 1, "relative": )" +
                               placement +
                               R"(, "filter": {"exclude": ["dataset-1_walk_normal_001.bvh"]}})");
}

bool identical(const SynthFrame& a, const SynthFrame& b) {
  if (a.root_position_m != b.root_position_m) return false;
  for (std::size_t j = 0; j < a.local_rotations.size(); ++j)
    if (!a.local_rotations[j].coeffs().isApprox(b.local_rotations[j].coeffs(), 0.0)) return false;
  return true;
}

}  // namespace

TEST(MotionLayout, RelativeQueryOfOneClipReproducesItsRootPath) {
  // The clip itself ranks first at h = 0: the output is its frames a..b
  // where they are in the file (set 1 and CMU).
  if (!test::have_data()) GTEST_SKIP() << "no data";
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  for (const auto& [rel, a, b] : {std::tuple<std::string, std::size_t, std::size_t>{
                                      "bandai-namco-1/data/dataset-1_walk_normal_001.bvh", 10, 40},
                                  {"cmu/131_02.bvh", 30, 90}}) {
    const fs::path file = data_file(rel);
    const auto s = synthesise(*index, "{" + frames_json(file, a, b) + R"(, "top": 1})");
    ASSERT_TRUE(s);
    const std::size_t clip = clip_named(*index, file.filename().string());
    ASSERT_EQ(s->result.frames.size(), b - a + 1) << rel;
    double worst = 0.0;
    for (std::size_t k = 0; k < s->result.frames.size(); ++k)
      worst = std::max(
          worst, (s->result.frames[k].root_position_m - clip_root(*index, clip, a + k)).norm());
    EXPECT_LT(worst, 0.01) << rel;
  }
}

TEST(MotionLayout, HeldOutQueryStartsAtItsFirstFrameAndKeepsMoving) {
  // The query's clip excluded: the output starts at the first query frame's
  // world root, no two consecutive frames are one pose (the query frames'
  // velocities carry into the transitions), and the root keeps moving
  // forward at walking speed (no step back, no standing still), also where
  // the second key pose, kept where the query puts it, leaves the
  // transitions less travel than the partial motion's run would.
  if (!test::have_data()) GTEST_SKIP() << "no data";
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  const fs::path file = data_file("bandai-namco-1/data/dataset-1_walk_normal_001.bvh");
  const auto s = held_out_walk(*index, "true");
  ASSERT_TRUE(s);
  const auto& fr = s->result.frames;
  const std::size_t clip = clip_named(*index, file.filename().string());
  EXPECT_LT((fr.front().root_position_m - clip_root(*index, clip, 10)).norm(), 1e-5);
  const double dt = s->result.frame_time_s;
  Eigen::Vector3d ahead = clip_root(*index, clip, 40) - clip_root(*index, clip, 10);
  ahead.y() = 0.0;
  ahead.normalize();
  double slowest = 1e9;
  for (std::size_t k = 1; k < fr.size(); ++k) {
    EXPECT_FALSE(identical(fr[k - 1], fr[k])) << "frames " << k - 1 << " and " << k;
    Eigen::Vector3d v = (fr[k].root_position_m - fr[k - 1].root_position_m) / dt;
    v.y() = 0.0;
    slowest = std::min(slowest, v.dot(ahead));
  }
  // At walking speed throughout (0.87 m/s at the slowest; -0.35, a step
  // back, when the partial motion was moved whole into the transitions).
  EXPECT_GT(slowest, 0.5) << "slowest forward root speed, m/s";
}

TEST(MotionLayout, PelvisCarriesTheTranslationUnderAStaticDummyRoot) {
  if (!test::have_data()) GTEST_SKIP() << "no data";
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  const fs::path file = data_file("bandai-namco-1/data/dataset-1_walk_normal_001.bvh");
  const auto s = held_out_walk(*index, "true");
  ASSERT_TRUE(s);
  const fs::path out = test::temp_dir("motion-layout-bvh") / "out.bvh";
  write_motion_bvh(s->result, out);
  const RawClip written = read_bvh_file(out);
  const RawClip source = read_bvh_file(file);
  ASSERT_EQ(written.joints.size(), source.joints.size());
  ASSERT_EQ(written.joints[0].name, "joint_Root");
  ASSERT_EQ(written.joints[1].name, "Hips");
  for (std::size_t j = 0; j < written.joints.size(); ++j)
    EXPECT_LT((written.joints[j].offset - source.joints[j].offset).norm(), 1e-4)
        << written.joints[j].name << ": the OFFSET is the rest offset";
  const RawJoint& dummy = written.joints[0];
  for (std::size_t f = 1; f < written.frame_count; ++f)
    for (std::size_t c = 0; c < dummy.channels.size(); ++c)
      EXPECT_EQ(written.frame(f)[dummy.first_column + c], written.frame(0)[dummy.first_column + c])
          << "joint_Root channel " << c << " frame " << f;
  // Hips: position channels first (as in the source), in centimetres.
  const RawJoint& hips = written.joints[1];
  for (std::size_t f = 0; f < written.frame_count; f += 7)
    for (int a = 0; a < 3; ++a)
      EXPECT_NEAR(written.frame(f)[hips.first_column + static_cast<std::size_t>(a)] / 100.0,
                  s->result.frames[f].root_position_m[a], 1e-5);
}

TEST(MotionLayout, PartialMotionsArePlacedByTheSearchRule) {
  // The held-out walk's best match faces another way in its clip. Relative:
  // the partial motion is turned to the first query frame's heading (the
  // search put F^s's ground pose on Q^1's); "position": it keeps its clip's
  // heading; false: it keeps its clip's coordinates. Every placement starts
  // at the query frame's own pose.
  if (!test::have_data()) GTEST_SKIP() << "no data";
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  const fs::path file = data_file("bandai-namco-1/data/dataset-1_walk_normal_001.bvh");
  const std::size_t query_clip = clip_named(*index, file.filename().string());
  for (const char* placement : {"true", "\"position\"", "false"}) {
    const auto s = held_out_walk(*index, placement);
    ASSERT_TRUE(s);
    const SynthResult& r = s->result;
    const SynthSkeleton& sk = *r.skeleton;
    const SearchResult& m = r.chosen[0];
    std::size_t first = 0, trimmed = 0;  // the partial motion's first frame, as kept
    for (const MotionSegment& seg : r.segments)
      if (seg.kind == "partial") first = seg.first_frame, trimmed = seg.trimmed_front;
    const SynthFrame& placed = r.frames[first];
    const SynthFrame clip = clip_frame(*index, m.clip_index, m.start_frame + trimmed);
    const SynthFrame q1 = clip_frame(*index, query_clip, 10);
    EXPECT_LT((r.frames[0].root_position_m - q1.root_position_m).norm(), 1e-5) << placement;
    EXPECT_NEAR(std::remainder(root_heading(sk, r.frames[0]) - root_heading(sk, q1), 2 * M_PI), 0.0,
                1e-6)
        << placement;
    // Relative: F^s turned onto Q^1's heading (the kept first frame turns
    // with it).
    const double turn =
        root_heading(sk, clip) - root_heading(sk, clip_frame(*index, m.clip_index, m.start_frame));
    const double want =
        std::string(placement) == "true" ? root_heading(sk, q1) + turn : root_heading(sk, clip);
    EXPECT_NEAR(std::remainder(root_heading(sk, placed) - want, 2 * M_PI), 0.0, 1e-6)
        << placement << ": " << m.clip;
    if (std::string(placement) == "false") {
      EXPECT_LT((placed.root_position_m - clip.root_position_m).norm(), 1e-9);
    }
  }
}

namespace {

// The output frame of query frame `number` (1-based), or none when merged.
std::optional<std::size_t> query_output_frame(const SynthResult& r, std::size_t number) {
  for (const MotionSegment& seg : r.segments)
    if (seg.kind == "query" && seg.pair == number) return seg.first_frame;
  return std::nullopt;
}

double ground_distance(Eigen::Vector3d a, Eigen::Vector3d b) {
  a.y() = b.y() = 0.0;
  return (a - b).norm();
}

}  // namespace

TEST(MotionLayout, UntimedKeyPosesAreWhereTheQueryPutsThem) {
  // The transitions' travel is absorbed, not added: an untimed query frame
  // that gives its root position is where the output passes, within 1 cm,
  // as a timed one is. Hand-written: a walk frame, 2 m ahead, then an arm
  // up (the output passed 2.64 m ahead when the travel was added); BVH:
  // three held-out frames of one walk, each at its place in the file (1.66
  // and 3.10 m away when the travel was added).
  if (!test::have_data()) GTEST_SKIP() << "no data";
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  const fs::path file = data_file("bandai-namco-1/data/dataset-1_walk_normal_001.bvh");
  const std::size_t walk = clip_named(*index, file.filename().string());
  const auto written =
      synthesise(*index, R"({"frames": [{"bvh": ")" + file.string() + R"(", "frame": 20},
                             {"root_position": [0, null, 2.0]},
                             {"joints": {"RightArm": {"direction": [0, 1, 0]}}}], "top": 3})");
  ASSERT_TRUE(written);
  const auto at = query_output_frame(written->result, 2);
  ASSERT_TRUE(at.has_value());
  EXPECT_NEAR(ground_distance(written->result.frames[*at].root_position_m,
                              written->result.frames[0].root_position_m),
              2.0, 0.01);
  // A heading change too: 1.5 m ahead and turned 90 degrees left, within 1 degree.
  const auto turned =
      synthesise(*index, R"({"frames": [{"bvh": ")" + file.string() + R"(", "frame": 20},
                             {"root_position": [0, null, 1.5], "root_heading_deg": 90}], "top": 3})");
  ASSERT_TRUE(turned);
  const auto turned_at = query_output_frame(turned->result, 2);
  ASSERT_TRUE(turned_at.has_value());
  const SynthSkeleton& tsk = *turned->result.skeleton;
  EXPECT_NEAR(ground_distance(turned->result.frames[*turned_at].root_position_m,
                              turned->result.frames[0].root_position_m),
              1.5, 0.01);
  EXPECT_NEAR(std::remainder(root_heading(tsk, turned->result.frames[*turned_at]) -
                                 root_heading(tsk, turned->result.frames[0]) - M_PI / 2,
                             2 * M_PI),
              0.0, M_PI / 180);
  const auto held_out =
      synthesise(*index, R"({"frames": [{"bvh": ")" + file.string() + R"(", "frame": 10},
                                        {"bvh": ")" +
                             file.string() + R"(", "frame": 45},
                                        {"bvh": ")" +
                             file.string() + R"(", "frame": 80}],
                             "top": 3, "filter": {"exclude": ["dataset-1_walk_normal_001.bvh"]}})");
  ASSERT_TRUE(held_out);
  for (const auto& [number, frame] : {std::pair<std::size_t, std::size_t>{2, 45}, {3, 80}}) {
    const auto out = query_output_frame(held_out->result, number);
    ASSERT_TRUE(out.has_value()) << "query frame " << number;
    EXPECT_LT(ground_distance(held_out->result.frames[*out].root_position_m,
                              clip_root(*index, walk, frame)),
              0.01)
        << "query frame " << number;
  }
}
