// Tests for common/src/motion/export.cpp: clip names refused with
// what was expected, and a clip's partial motion written so that the file's
// own forward kinematics (the BVH reader's, the slow reference) gives the
// index's joint positions of those frames, from one index and from a
// collection of the same files alike.
#include "mocap/common/motion/export.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/util/error.hpp"
#include "test_support.hpp"

namespace mocap {
namespace {

namespace fs = std::filesystem;

// Set-1 clips (among them the four takes whose joint_Root, above the
// pelvis, moves) and the three CMU takes (another skeleton, other units),
// once as one index and once as a 2-shard collection; a small BVH indexed
// from two folders (two clips of one file name); and that BVH with joints of
// one and two rotation channels.
struct Built {
  fs::path dir;
  std::unique_ptr<ClipSource> one;
  std::unique_ptr<ClipSource> collection;
  std::unique_ptr<ClipSource> twins;
  std::unique_ptr<ClipSource> subsets;
};

// `clip` with only the channels `keep` of joint `name` (the others dropped
// from the hierarchy and from every frame).
RawClip keep_channels(const RawClip& clip, const std::string& name,
                      const std::vector<Channel>& keep) {
  RawClip out = clip;
  out.channel_count = 0;
  std::vector<std::size_t> columns;
  for (std::size_t j = 0; j < clip.joints.size(); ++j) {
    RawJoint& rj = out.joints[j];
    rj.channels.clear();
    rj.first_column = out.channel_count;
    for (std::size_t k = 0; k < clip.joints[j].channels.size(); ++k) {
      const Channel c = clip.joints[j].channels[k];
      if (rj.name == name && std::find(keep.begin(), keep.end(), c) == keep.end()) continue;
      rj.channels.push_back(c);
      columns.push_back(clip.joints[j].first_column + k);
    }
    out.channel_count += rj.channels.size();
  }
  out.values.clear();
  for (std::size_t f = 0; f < clip.frame_count; ++f)
    for (std::size_t col : columns) out.values.push_back(clip.frame(f)[col]);
  return out;
}

const Built* built() {
  static std::unique_ptr<Built> b;
  static bool tried = false;
  if (tried) return b.get();
  tried = true;
  auto out = std::make_unique<Built>();
  out->dir = test::temp_dir("export");
  std::string inputs;
  for (const char* name : {"dataset-1_bow_active_001.bvh", "dataset-1_walk_normal_001.bvh",
                           "dataset-1_dash_normal_001.bvh", "dataset-1_run_normal_001.bvh",
                           "dataset-1_walk-back_normal_001.bvh", "dataset-1_walk_normal_002.bvh"})
    inputs += " '" + (test::data_dir() / "bandai-namco-1" / "data" / name).string() + "'";
  inputs += " '" + (test::data_dir() / "cmu").string() + "'";
  const fs::path golden =
      fs::path(MOCAP_SOURCE_DIR) / "tests/data/index/golden_walk_normal_001.bvh";
  for (const char* twin : {"a", "b"}) {
    fs::create_directories(out->dir / twin);
    fs::copy_file(golden, out->dir / twin / golden.filename());
  }
  RawClip subsets = read_bvh_file(golden);
  subsets = keep_channels(subsets, "LeftLeg", {Channel::Xrotation});
  subsets = keep_channels(subsets, "RightLeg", {Channel::Zrotation, Channel::Xrotation});
  write_bvh_file(subsets, out->dir / "subsets.bvh");
  const std::string tool = std::string(MOCAP_BINARY_DIR) + "/indexer/mocap-index build -q --out '";
  const std::string quiet = " >/dev/null 2>&1";
  for (const std::string& cmd :
       {tool + (out->dir / "one.h5").string() + "'" + inputs + quiet,
        std::string(MOCAP_BINARY_DIR) + "/indexer/mocap-index build -q --shards 2 --out '" +
            (out->dir / "c2.json").string() + "'" + inputs + quiet,
        tool + (out->dir / "twins.h5").string() + "' '" + (out->dir / "a").string() + "' '" +
            (out->dir / "b").string() + "'" + quiet,
        tool + (out->dir / "subsets.h5").string() + "' '" + (out->dir / "subsets.bvh").string() +
            "'" + quiet})
    if (std::system(cmd.c_str()) != 0) return nullptr;
  out->one = std::make_unique<ClipSource>(ClipSource::open(out->dir / "one.h5"));
  out->collection = std::make_unique<ClipSource>(ClipSource::open(out->dir / "c2.json"));
  out->twins = std::make_unique<ClipSource>(ClipSource::open(out->dir / "twins.h5"));
  out->subsets = std::make_unique<ClipSource>(ClipSource::open(out->dir / "subsets.h5"));
  b = std::move(out);
  return b.get();
}

#define REQUIRE_BUILT(b)    \
  MOCAP_REQUIRE_DATA();     \
  const Built* b = built(); \
  ASSERT_NE(b, nullptr) << "mocap-index build failed";

TEST(FindClipTest, RefusesUnknownAndAmbiguousNames) {
  REQUIRE_BUILT(b);
  const ClipSource& s = *b->one;
  // A near miss: the close names listed, and the index named.
  std::string e =
      test::input_error_message([&] { (void)find_clip(s, "dataset-1_walk_normal_01.bvh"); });
  EXPECT_NE(e.find(b->dir.string() + "/one.h5: no clip \"dataset-1_walk_normal_01.bvh\""),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("close names: dataset-1_walk_normal_001.bvh"), std::string::npos) << e;
  // Part of a name: the clips containing it.
  e = test::input_error_message([&] { (void)find_clip(s, "131_0"); });
  EXPECT_NE(e.find("131_01.bvh"), std::string::npos) << e;
  EXPECT_EQ(e.find("dataset-1"), std::string::npos) << e;
  e = test::input_error_message(
      [&] { (void)find_clip(s, "zzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzz"); });
  EXPECT_NE(e.find("no clip has a close name"), std::string::npos) << e;
  // One file name twice: the paths listed; the full path chooses.
  const ClipSource& t = *b->twins;
  ASSERT_EQ(t.clip_count(), 2u);
  e = test::input_error_message([&] { (void)find_clip(t, "golden_walk_normal_001.bvh"); });
  EXPECT_NE(e.find("2 clips are named \"golden_walk_normal_001.bvh\": give the full path"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find(t.clip(0).path), std::string::npos) << e;
  EXPECT_NE(e.find(t.clip(1).path), std::string::npos) << e;
  EXPECT_EQ(find_clip(t, t.clip(1).path), 1u);
}

TEST(FindClipTest, TakesTheStoredPathARelativePathOrTheFileName) {
  REQUIRE_BUILT(b);
  for (const ClipSource* s : {b->one.get(), b->collection.get()})
    for (std::size_t c = 0; c < s->clip_count(); ++c) {
      const fs::path p = s->clip(c).path;
      EXPECT_EQ(find_clip(*s, p.string()), c);
      EXPECT_EQ(find_clip(*s, p.filename().string()), c);
      EXPECT_EQ(find_clip(*s, fs::relative(p).string()), c) << fs::relative(p);
    }
}

// The same file by another route: its real path (the data folder may be
// reached through a symbolic link), a symbolic link to its folder, a path
// through "..": found, and among two clips of one file name the one whose
// file it is. The stored path stays what the index holds.
TEST(FindClipTest, TakesAnyPathToTheSameFile) {
  REQUIRE_BUILT(b);
  const fs::path scratch = test::temp_dir("find-clip-routes");
  const ClipSource& s = *b->one;
  for (std::size_t c = 0; c < s.clip_count(); ++c) {
    const fs::path p = s.clip(c).path;
    EXPECT_EQ(find_clip(s, fs::canonical(p).string()), c) << fs::canonical(p);
    const fs::path link = scratch / ("link" + std::to_string(c));
    fs::create_directory_symlink(fs::canonical(p.parent_path()), link);
    EXPECT_EQ(find_clip(s, (link / p.filename()).string()), c) << link;
    fs::create_directories(scratch / "sub");
    const fs::path up = scratch / "sub" / ".." / link.filename() / p.filename();
    EXPECT_EQ(find_clip(s, up.string()), c) << up;
  }
  const ClipSource& t = *b->twins;
  for (std::size_t c = 0; c < t.clip_count(); ++c) {
    const fs::path p = t.clip(c).path;
    const fs::path link = scratch / ("twin" + std::to_string(c));
    fs::create_directory_symlink(p.parent_path(), link);
    EXPECT_EQ(find_clip(t, (link / p.filename()).string()), c) << link;
  }
  // A path to a file that is not indexed, of an indexed file's name.
  fs::create_directories(scratch / "other");
  fs::copy_file(t.clip(0).path, scratch / "other" / fs::path(t.clip(0).path).filename());
  const std::string e = test::input_error_message(
      [&] { (void)find_clip(t, (scratch / "other" / "golden_walk_normal_001.bvh").string()); });
  EXPECT_NE(e.find("no clip \""), std::string::npos) << e;
}

// World positions of every joint of the exported file's frames (its own
// reader and forward kinematics) against the index's joint_positions_m.
void expect_index_positions(const ClipSource& s, std::size_t c, FrameRange r) {
  const RawClip raw = partial_motion_clip(s, c, r, "--frames");
  ASSERT_EQ(raw.frame_count, r.last - r.first + 1);
  EXPECT_EQ(raw.frame_time_s, s.clip(c).frame_time_s);
  const RawClip read = parse_bvh(write_bvh(raw), "exported");
  const ClipMotion m = clip_motion_from_raw(read, s.clip(c).unit_scale_m);
  const std::size_t n = m.skeleton.joint_count();
  const auto positions = s.clip_frames(c, "joint_positions_m");
  ASSERT_EQ(positions.size(), s.clip(c).frame_count * n * 3);
  double worst = 0.0;
  for (std::size_t f = 0; f < raw.frame_count; ++f)
    for (std::size_t j = 0; j < n; ++j) {
      const float* p = positions.data() + ((r.first + f) * n + j) * 3;
      const Eigen::Vector3d want(p[0], p[1], p[2]);
      worst = std::max(worst, (m.position(f, j) - want).norm());
    }
  EXPECT_LT(worst, 1e-5) << s.clip(c).path << " frames " << r.first << "-" << r.last;
}

TEST(PartialMotionTest, TheFileGivesTheIndexJointPositions) {
  REQUIRE_BUILT(b);
  const ClipSource& s = *b->one;
  for (std::size_t c = 0; c < s.clip_count(); ++c) {
    const std::size_t last = s.clip(c).frame_count - 1;
    expect_index_positions(s, c, {0, last});             // the whole clip
    expect_index_positions(s, c, {last / 3, last / 2});  // a partial motion
    expect_index_positions(s, c, {last, last});          // one frame
  }
}

TEST(PartialMotionTest, JointsWithOneOrTwoRotationChannelsKeepTheirAngles) {
  REQUIRE_BUILT(b);
  const ClipSource& s = *b->subsets;
  ASSERT_EQ(s.clip_count(), 1u);
  const std::size_t last = s.clip(0).frame_count - 1;
  expect_index_positions(s, 0, {0, last});
  const RawClip read = parse_bvh(write_bvh(partial_motion_clip(s, 0, {0, last}, "--frames")), "x");
  EXPECT_EQ(read.joints[static_cast<std::size_t>(read.find_joint("LeftLeg"))].channels,
            std::vector<Channel>{Channel::Xrotation});
  EXPECT_EQ(read.joints[static_cast<std::size_t>(read.find_joint("RightLeg"))].channels,
            (std::vector<Channel>{Channel::Zrotation, Channel::Xrotation}));
  // The knees bend: the angles are written, not zeros.
  double bend = 0.0;
  const std::size_t col =
      read.joints[static_cast<std::size_t>(read.find_joint("LeftLeg"))].first_column;
  for (std::size_t f = 0; f < read.frame_count; ++f)
    bend = std::max(bend, std::abs(read.frame(f)[col]));
  EXPECT_GT(bend, 1.0);
}

TEST(PartialMotionTest, ACollectionWritesWhatOneIndexWrites) {
  REQUIRE_BUILT(b);
  ASSERT_EQ(b->collection->clip_count(), b->one->clip_count());
  for (std::size_t c = 0; c < b->one->clip_count(); ++c) {
    const std::size_t n = b->one->clip(c).frame_count;
    const FrameRange r{n / 4, n - 1 - n / 4};
    EXPECT_EQ(write_bvh(partial_motion_clip(*b->collection, c, r, "--frames")),
              write_bvh(partial_motion_clip(*b->one, c, r, "--frames")))
        << b->one->clip(c).path;
  }
}

TEST(PartialMotionTest, RefusesFramesPastTheEnd) {
  REQUIRE_BUILT(b);
  const ClipSource& s = *b->one;
  const std::size_t n = s.clip(0).frame_count;
  const std::string e = test::input_error_message([&] {
    (void)partial_motion_clip(s, 0, {n - 2, n}, "--frames");
  });
  EXPECT_NE(e.find("--frames: frames " + std::to_string(n - 2) + "-" + std::to_string(n) +
                   " out of range for \"" + s.clip(0).path + "\" (" + std::to_string(n) +
                   " frames: 0-" + std::to_string(n - 1) + ")"),
            std::string::npos)
      << e;
  EXPECT_THROW((void)partial_motion_clip(s, s.clip_count(), {0, 1}, "--frames"), std::out_of_range);
  EXPECT_THROW((void)partial_motion_clip(s, 0, {3, 2}, "--frames"), std::invalid_argument);
}

}  // namespace
}  // namespace mocap
