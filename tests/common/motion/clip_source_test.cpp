// Tests for common/src/motion/clip_source.cpp: a collection's shards read as one
// index of the same files (clip and skeleton numbers, tables, frames, range
// of motion), and a missing, changed or miscounted shard refused by name.
#include "mocap/common/motion/clip_source.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <memory>
#include <string>

#include "mocap/common/io/collection_manifest.hpp"
#include "mocap/common/motion/skeleton_motion.hpp"
#include "mocap/common/util/error.hpp"
#include "test_support.hpp"

namespace mocap {
namespace {

namespace fs = std::filesystem;

// Four set-1 clips and the three CMU clips (another skeleton, 120 fps),
// indexed once as one index and once as a 2-shard collection: balanced by
// frames, the second shard holds only CMU clips, whose skeleton is its
// skeleton 0 and the collection's skeleton 1.
struct Built {
  fs::path dir;
  std::unique_ptr<Index> one;
};

std::string inputs() {
  std::string s;
  for (const char* name : {"dataset-1_bow_active_001.bvh", "dataset-1_dash_proud_001.bvh",
                           "dataset-1_walk_musical_001.bvh", "dataset-1_walk-left_happy_001.bvh"})
    s += " '" + (test::data_dir() / "bandai-namco-1" / "data" / name).string() + "'";
  return s + " '" + (test::data_dir() / "cmu").string() + "'";
}

const Built* built() {
  static std::unique_ptr<Built> b;
  static bool tried = false;
  if (tried) return b.get();
  tried = true;
  auto out = std::make_unique<Built>();
  out->dir = test::temp_dir("clip-source");
  const std::string tool = std::string(MOCAP_BINARY_DIR) + "/indexer/mocap-index build -q ";
  const std::string one =
      tool + "--out '" + (out->dir / "one.h5").string() + "'" + inputs() + " >/dev/null 2>&1";
  const std::string two = tool + "--shards 2 --out '" + (out->dir / "c2.json").string() + "'" +
                          inputs() + " >/dev/null 2>&1";
  if (std::system(one.c_str()) != 0 || std::system(two.c_str()) != 0) return nullptr;
  out->one = std::make_unique<Index>(Index::open(out->dir / "one.h5"));
  b = std::move(out);
  return b.get();
}

#define REQUIRE_BUILT(b)    \
  MOCAP_REQUIRE_DATA();     \
  const Built* b = built(); \
  ASSERT_NE(b, nullptr) << "mocap-index build failed";

// A copy of the collection (manifest and shards) in a fresh folder, to damage.
fs::path copy_collection(const Built& b, const std::string& tag) {
  const fs::path dir = test::temp_dir(tag);
  for (const auto& e : fs::directory_iterator(b.dir))
    if (e.path().filename().string().starts_with("c2"))
      fs::copy_file(e.path(), dir / e.path().filename());
  return dir / "c2.json";
}

std::string message_of(const fs::path& manifest) {
  try {
    (void)ClipSource::open(manifest);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(ClipSourceValidityTest, RefusesMissingChangedAndMiscountedShards) {
  REQUIRE_BUILT(b);
  {  // A missing shard: named.
    const fs::path m = copy_collection(*b, "clip-source-missing");
    fs::remove(m.parent_path() / "c2.shard-2-of-2.h5");
    const std::string e = message_of(m);
    EXPECT_NE(e.find("shard c2.shard-2-of-2.h5"), std::string::npos) << e;
  }
  {  // A changed shard: named, with what changed.
    const fs::path m = copy_collection(*b, "clip-source-changed");
    std::ofstream(m.parent_path() / "c2.shard-1-of-2.h5", std::ios::app) << 'x';
    const std::string e = message_of(m);
    EXPECT_NE(e.find("shard c2.shard-1-of-2.h5: changed since the manifest was written"),
              std::string::npos)
        << e;
  }
  {  // A manifest whose clip count is not the shard's (bytes as written).
    const fs::path m = copy_collection(*b, "clip-source-count");
    CollectionManifest man = read_collection_manifest(m);
    man.shards[0].clips += 1;
    write_collection_manifest(m, man);
    const std::string e = message_of(m);
    EXPECT_NE(e.find("shard c2.shard-1-of-2.h5: holds"), std::string::npos) << e;
    EXPECT_NE(e.find("the manifest says"), std::string::npos) << e;
  }
  {  // An index file that is not there.
    EXPECT_THROW((void)ClipSource::open(b->dir / "none.h5"), InputError);
  }
  {  // Clips past the end are a caller's error.
    const ClipSource s = ClipSource::open(b->dir / "c2.json");
    EXPECT_THROW((void)s.locate(s.clip_count()), std::out_of_range);
    EXPECT_THROW((void)s.skeleton_clips(static_cast<std::uint32_t>(s.skeleton_count())),
                 std::out_of_range);
  }
}

TEST(ClipSourceTest, OneIndexIsItsOwnSource) {
  REQUIRE_BUILT(b);
  const ClipSource s(*b->one);
  EXPECT_FALSE(s.is_collection());
  ASSERT_EQ(s.index_count(), 1u);
  ASSERT_EQ(s.clip_count(), b->one->clips().size());
  for (std::size_t c = 0; c < s.clip_count(); ++c) {
    EXPECT_EQ(s.locate(c).index, b->one.get());
    EXPECT_EQ(s.locate(c).clip, c);
    EXPECT_EQ(s.skeleton_of(c), b->one->clips()[c].skeleton);
  }
  const ClipSource opened = ClipSource::open(b->dir / "one.h5");
  EXPECT_FALSE(opened.is_collection());
  EXPECT_EQ(opened.clip_count(), s.clip_count());
}

TEST(ClipSourceTest, CollectionNumbersClipsAndSkeletonsAsOneIndex) {
  REQUIRE_BUILT(b);
  const Index& one = *b->one;
  const ClipSource s = ClipSource::open(b->dir / "c2.json");
  EXPECT_TRUE(s.is_collection());
  EXPECT_EQ(s.path(), b->dir / "c2.json");
  ASSERT_EQ(s.index_count(), 2u);
  ASSERT_EQ(s.clip_count(), one.clips().size());
  ASSERT_EQ(s.skeleton_count(), one.skeletons().size());
  ASSERT_GE(s.skeleton_count(), 2u);
  bool renumbered = false;  // a shard's own skeleton number is not the collection's
  for (std::size_t c = 0; c < s.clip_count(); ++c) {
    EXPECT_EQ(s.clip(c).path, one.clips()[c].path) << c;
    EXPECT_EQ(s.clip(c).frame_count, one.clips()[c].frame_count) << c;
    EXPECT_EQ(s.clip(c).frame_time_s, one.clips()[c].frame_time_s) << c;
    EXPECT_EQ(s.skeleton_of(c), one.clips()[c].skeleton) << c;
    const ClipSource::Location at = s.locate(c);
    EXPECT_EQ(at.index, &s.index(at.shard));
    renumbered = renumbered || at.index->clips()[at.clip].skeleton != s.skeleton_of(c);
  }
  EXPECT_TRUE(renumbered);
  EXPECT_GT(s.locate(s.clip_count() - 1).shard, s.locate(0).shard);
  for (std::uint32_t k = 0; k < s.skeleton_count(); ++k) {
    EXPECT_EQ(s.skeleton(k).id, one.skeletons()[k].id) << k;
    EXPECT_EQ(s.skeleton_clips(k), one.skeletons()[k].clips) << k;
  }
}

TEST(ClipSourceTest, SynthesisReadsTheCollectionAsOneIndex) {
  // The skeleton, the range of motion over every clip of it (across both
  // shards for the CMU skeleton) and the frames are the single index's, bit
  // for bit.
  REQUIRE_BUILT(b);
  const Index& one = *b->one;
  const ClipSource s = ClipSource::open(b->dir / "c2.json");
  for (std::uint32_t k = 0; k < s.skeleton_count(); ++k) {
    const std::size_t ref = s.skeleton_clips(k).back();
    const SynthSkeleton a = make_synth_skeleton(s, k, ref);
    const SynthSkeleton e = make_synth_skeleton(one, k, ref);
    EXPECT_EQ(a.index_skeleton, k);
    ASSERT_EQ(a.joint_count(), e.joint_count());
    for (std::size_t j = 0; j < a.joint_count(); ++j)
      EXPECT_EQ(a.local_translations_m[j], e.local_translations_m[j]) << k << " " << j;
    EXPECT_EQ(a.model.masses_kg, e.model.masses_kg);
    const RangeOfMotion ra = range_of_motion(s, a, s.skeleton_clips(k));
    const RangeOfMotion re = range_of_motion(one, e, one.skeletons()[k].clips);
    EXPECT_EQ(ra.min_deg, re.min_deg) << k;
    EXPECT_EQ(ra.max_deg, re.max_deg) << k;
    EXPECT_EQ(ra.has_range, re.has_range) << k;
    EXPECT_THROW((void)make_synth_skeleton(s, k == 0 ? 1 : 0, ref), std::invalid_argument);
  }
  for (std::size_t c : {std::size_t{0}, s.clip_count() - 1}) {
    const std::size_t last = s.clip(c).frame_count - 1;
    for (std::size_t f : {std::size_t{0}, last}) {
      const SynthFrame a = clip_frame(s, c, f), e = clip_frame(one, c, f);
      EXPECT_EQ(a.root_position_m, e.root_position_m);
      ASSERT_EQ(a.local_rotations.size(), e.local_rotations.size());
      for (std::size_t j = 0; j < a.local_rotations.size(); ++j)
        EXPECT_EQ(a.local_rotations[j].coeffs(), e.local_rotations[j].coeffs());
    }
  }
}

}  // namespace
}  // namespace mocap
