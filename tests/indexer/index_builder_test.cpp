// build_index: content round trip, determinism over thread counts, incremental
// rebuilds, bad files, labels, and the golden file of the current version.
#include <gtest/gtest.h>

#include <fstream>
#include <set>
#include <sstream>
#include <thread>

#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/hdf5.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/common/io/units.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/common/util/xxh64.hpp"
#include "mocap/indexer/index_builder.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;
using namespace mocap;

namespace {

fs::path golden_dir() {
  return fs::path(MOCAP_SOURCE_DIR) / "tests" / "data" / "index";
}
const char* kWalk = "golden_walk_normal_001.bvh";

/// A fresh temporary folder, removed when the test ends (indexes are large).
struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& tag) : path(test::temp_dir(tag)) {}
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  operator const fs::path&() const { return path; }
  fs::path operator/(const std::string& name) const { return path / name; }
};
const char* kJump = "golden_jump_happy_002.bvh";

IndexBuildSummary build(const std::vector<fs::path>& inputs, const fs::path& out,
                        std::size_t jobs = 2, bool strict = false, int deflate = 0) {
  IndexBuildOptions o;
  for (const auto& p : inputs) o.inputs.push_back(p.string());
  o.out = out;
  o.jobs = jobs;
  o.strict = strict;
  o.deflate_level = deflate;
  o.tool_version = "mocap-index test";
  return build_index(o);
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_text(const fs::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::binary);
  out << text;
}

/// Every array of every skeleton and every clip-table field except build
/// status must be equal (bit for bit).
void expect_same_content(const Index& a, const Index& b, bool compare_status = true) {
  ASSERT_EQ(a.clips().size(), b.clips().size());
  ASSERT_EQ(a.skeletons().size(), b.skeletons().size());
  EXPECT_EQ(a.label_keys(), b.label_keys());
  for (std::size_t c = 0; c < a.clips().size(); ++c) {
    const IndexClip &x = a.clips()[c], &y = b.clips()[c];
    EXPECT_EQ(x.path, y.path);
    EXPECT_EQ(x.content_hash, y.content_hash);
    EXPECT_EQ(x.skeleton, y.skeleton);
    EXPECT_EQ(x.frame_start, y.frame_start);
    EXPECT_EQ(x.frame_count, y.frame_count);
    EXPECT_EQ(x.labels, y.labels);
    if (compare_status) {
      EXPECT_EQ(x.status, y.status);
    }
  }
  for (std::uint32_t k = 0; k < a.skeletons().size(); ++k) {
    EXPECT_EQ(a.skeletons()[k].id, b.skeletons()[k].id);
    auto same = [&](const char* group, std::span<const IndexFieldSpec> table) {
      for (const auto& spec : table) {
        const IndexArray& x = a.array(k, group, spec.name);
        const IndexArray& y = b.array(k, group, spec.name);
        EXPECT_EQ(x.rows, y.rows) << group << "/" << spec.name;
        EXPECT_TRUE(x.f32 == y.f32 && x.f64 == y.f64) << group << "/" << spec.name;
      }
    };
    same("frames", kFrameFields);
    same("blocks16", kBlockFields);
    same("blocks64", kBlockFields);
    same("clip_bounds", kClipBoundFields);
  }
}

}  // namespace

TEST(IndexBuilder, RowsAreWhatComputeClipFrameDataGives) {
  const TempDir dir("index-rows");
  const auto s = build({golden_dir() / kWalk, golden_dir() / kJump}, dir / "i.h5");
  EXPECT_EQ(s.clips, 2u);
  EXPECT_EQ(s.frames, 7u);
  EXPECT_EQ(s.parsed_new, 2u);
  const Index index = Index::open(dir / "i.h5", {.verify_file_checksum = true});
  for (std::size_t c = 0; c < 2; ++c) {
    const IndexClip& clip = index.clips()[c];
    const RawClip raw = read_bvh_file(clip.path);
    const IndexedSkeleton skel = index_skeleton(raw, 0.01, Character{}, EnergyParams{});
    const ClipFrameData d = compute_clip_frame_data(raw, skel, 0.5);
    EXPECT_EQ(index.skeletons()[clip.skeleton].id, skel.id);
    for (std::size_t i = 0; i < kFrameFieldCount; ++i) {
      const IndexArray& a = index.array(clip.skeleton, "frames", kFrameFields[i].name);
      if (!frame_field_stored(kFrameFields[i].name, kIndexSchemaVersion)) {
        EXPECT_TRUE(d.frames[i].empty()) << kFrameFields[i].name;  // derived on load
        continue;
      }
      if (kFrameFields[i].dtype == IndexDType::f32) {
        const auto rows = a.rows_f32(clip.frame_start, clip.frame_count);
        EXPECT_TRUE(std::equal(rows.begin(), rows.end(), d.frames[i].begin(), d.frames[i].end()))
            << kFrameFields[i].name;
      } else {
        const std::vector<double> rows(
            a.f64.begin() + static_cast<std::ptrdiff_t>(clip.frame_start),
            a.f64.begin() + static_cast<std::ptrdiff_t>(clip.frame_start + clip.frame_count));
        EXPECT_EQ(rows, d.frames_f64[i]) << kFrameFields[i].name;
      }
    }
    for (std::size_t i = 0; i < kClipBoundFieldCount; ++i) {
      const auto row =
          index.array(clip.skeleton, "clip_bounds", kClipBoundFields[i].name).rows_f32(clip.row, 1);
      EXPECT_TRUE(
          std::equal(row.begin(), row.end(), d.clip_bounds[i].begin(), d.clip_bounds[i].end()))
          << kClipBoundFields[i].name;
    }
    const auto kdmin =
        index.array(clip.skeleton, "blocks64", "kd_min").rows_f32(clip.block64_start, 1);
    EXPECT_TRUE(
        std::equal(kdmin.begin(), kdmin.end(), d.blocks[1][2].begin(), d.blocks[1][2].end()));
  }
}

TEST(IndexBuilder, MatchesTheGoldenFileOfTheCurrentVersion) {
  // A change of what the writer stores must come with a new golden file (and
  // a schema version bump when old readers would misread it).
  const TempDir dir("index-golden");
  build({golden_dir() / kWalk, golden_dir() / kJump}, dir / "i.h5", 1, false, 9);
  const Index fresh = Index::open(dir / "i.h5");
  const Index golden = Index::open(golden_dir() / "index-v3.h5");
  ASSERT_EQ(fresh.clips().size(), golden.clips().size());
  for (std::size_t c = 0; c < fresh.clips().size(); ++c) {
    EXPECT_EQ(fs::path(fresh.clips()[c].path).filename(),
              fs::path(golden.clips()[c].path).filename());
    EXPECT_EQ(fresh.clips()[c].content_hash, golden.clips()[c].content_hash);
    EXPECT_EQ(fresh.clips()[c].labels, golden.clips()[c].labels);
  }
  for (std::size_t i = 0; i < kFrameFieldCount; ++i) {
    const IndexArray& x = fresh.array(0, "frames", kFrameFields[i].name);
    const IndexArray& y = golden.array(0, "frames", kFrameFields[i].name);
    ASSERT_EQ(x.f32.size(), y.f32.size()) << kFrameFields[i].name;
    ASSERT_EQ(x.f64.size(), y.f64.size()) << kFrameFields[i].name;
    // Kinematics must agree to float precision; dynamics to 1e-4 relative
    // (the body and energy models may be refined without a schema change).
    const bool kinematic =
        std::string_view(kFrameFields[i].name).find("rotation") != std::string_view::npos ||
        std::string_view(kFrameFields[i].name).find("position") != std::string_view::npos;
    for (std::size_t e = 0; e < x.f32.size(); ++e) {
      const double tol = kinematic ? 1e-6 : 1e-4 * (1.0 + std::abs(static_cast<double>(y.f32[e])));
      ASSERT_NEAR(x.f32[e], y.f32[e], tol) << kFrameFields[i].name << " element " << e;
    }
    for (std::size_t e = 0; e < x.f64.size(); ++e)
      ASSERT_NEAR(x.f64[e], y.f64[e], 1e-4 * (1.0 + std::abs(y.f64[e]))) << kFrameFields[i].name;
  }
}

// An index of an older schema is not reused: its clips are parsed again
// (nothing of a schema-1 or schema-2 file, which store arrays a newer one
// derives, is copied into a schema-3 one), and the note says why.
TEST(IndexBuilder, AnIndexOfAnOlderSchemaIsRebuiltNotReused) {
  const TempDir dir("index-old-schema");
  const fs::path out = dir / "i.h5";
  for (std::int64_t old = kIndexOldestSchemaVersion; old < kIndexSchemaVersion; ++old) {
    build({golden_dir() / kWalk, golden_dir() / kJump}, out);
    {
      h5::File f = h5::File::open(out, true);
      f.root().set_attribute("schema_version", old);
      f.close();
    }
    seal_index_file(out);
    const IndexBuildSummary s = build({golden_dir() / kWalk, golden_dir() / kJump}, out);
    EXPECT_EQ(s.reused, 0u) << old;
    EXPECT_EQ(s.parsed_new + s.parsed_changed, 2u) << old;
    EXPECT_NE(s.previous_index_note.find("index schema version " + std::to_string(old) +
                                         " (this build writes " +
                                         std::to_string(kIndexSchemaVersion) + ")"),
              std::string::npos)
        << s.previous_index_note;
    EXPECT_EQ(Index::open(out).info().schema_version, kIndexSchemaVersion);
  }
}

TEST(IndexBuilder, OutputDoesNotDependOnTheThreadCount) {
  const TempDir dir("index-threads");
  std::vector<fs::path> inputs;
  if (test::have_data()) {
    inputs = {test::data_dir() / "bandai-namco-1" / "data", test::data_dir() / "cmu"};
  } else {
    // Many small clips so that the pipeline really interleaves.
    const fs::path in = dir / "in";
    fs::create_directories(in);
    for (int i = 0; i < 40; ++i)
      fs::copy_file(golden_dir() / (i % 2 ? kWalk : kJump),
                    in / ("c" + std::to_string(100 + i) + "_x_y_1.bvh"));
    inputs = {in};
  }
  build(inputs, dir / "j1.h5", 1);
  build(inputs, dir / "j2.h5", 2);
  build(inputs, dir / "j4.h5", 4);
  const Index a = Index::open(dir / "j1.h5");
  const Index b = Index::open(dir / "j2.h5");
  const Index c = Index::open(dir / "j4.h5");
  expect_same_content(a, b);
  expect_same_content(a, c);
}

TEST(IndexBuilder, IncrementalRebuildReusesChangesAddsAndRemoves) {
  const TempDir dir("index-incremental");
  const fs::path in = dir / "in";
  fs::create_directories(in);
  const std::string walk = read_text(golden_dir() / kWalk);
  const std::string jump = read_text(golden_dir() / kJump);
  write_text(in / "a_walk_normal_001.bvh", walk);
  write_text(in / "b_walk_normal_002.bvh", walk);
  write_text(in / "c_jump_happy_003.bvh", jump);
  const fs::path out = dir / "i.h5";
  auto s = build({in}, out);
  EXPECT_EQ(s.parsed_new, 3u);
  EXPECT_FALSE(s.up_to_date);

  // Nothing changed: up to date, the file is not rewritten.
  const auto before = fs::last_write_time(out);
  s = build({in}, out);
  EXPECT_TRUE(s.up_to_date);
  EXPECT_EQ(s.reused, 3u);
  EXPECT_EQ(s.parsed_new + s.parsed_changed + s.removed, 0u);
  EXPECT_EQ(fs::last_write_time(out), before);

  // b modified (another frame value), c removed, d added, a untouched.
  std::string b2 = walk;
  b2.replace(b2.rfind("97"), 2, "98");
  write_text(in / "b_walk_normal_002.bvh", b2);
  fs::remove(in / "c_jump_happy_003.bvh");
  write_text(in / "d_jump_happy_004.bvh", jump);
  s = build({in}, out);
  EXPECT_FALSE(s.up_to_date);
  EXPECT_EQ(s.reused, 1u);
  EXPECT_EQ(s.parsed_changed, 1u);
  EXPECT_EQ(s.parsed_new, 1u);
  EXPECT_EQ(s.removed, 1u);
  EXPECT_EQ(s.clips, 3u);
  const Index inc = Index::open(out, {.verify_file_checksum = true});
  EXPECT_EQ(inc.clips()[0].status, ClipStatus::reused);
  EXPECT_EQ(inc.clips()[1].status, ClipStatus::parsed_changed);
  EXPECT_EQ(inc.clips()[2].status, ClipStatus::parsed_new);
  EXPECT_TRUE(verify_index(out).ok);

  // Same content as a full build (status aside).
  IndexBuildOptions o;
  o.inputs = {in.string()};
  o.out = dir / "full.h5";
  o.full = true;
  o.tool_version = "mocap-index test";
  build_index(o);
  const Index full = Index::open(dir / "full.h5");
  expect_same_content(inc, full, false);
  // The modified frame value shows: b's root is 1 cm higher in its last frame.
  EXPECT_NEAR(inc.clip_frames(1, "root_position_m")[3 * 3 + 1], 0.98f, 1e-6f);

  // A touched file (new mtime, same bytes) is parsed again, as changed.
  fs::last_write_time(in / "a_walk_normal_001.bvh",
                      fs::file_time_type::clock::now() + std::chrono::seconds(5));
  s = build({in}, out);
  EXPECT_EQ(s.parsed_changed, 1u);
  EXPECT_EQ(s.reused, 2u);
}

TEST(IndexBuilder, BadFilesAreSkippedOrFailUnderStrict) {
  const TempDir dir("index-bad");
  const fs::path in = dir / "in";
  fs::create_directories(in);
  fs::copy_file(golden_dir() / kWalk, in / kWalk);
  write_text(in / "empty.bvh", "");
  write_text(in / "malformed.bvh",
             "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 2 Xposition Wrotation\n}\n");
  const fs::path out = dir / "i.h5";
  auto s = build({in}, out);
  EXPECT_EQ(s.clips, 1u);
  ASSERT_EQ(s.skipped.size(), 2u);
  EXPECT_EQ(fs::path(s.skipped[0].path).filename(), "empty.bvh");
  EXPECT_EQ(s.skipped[0].reason, "empty file");
  EXPECT_EQ(fs::path(s.skipped[1].path).filename(), "malformed.bvh");
  EXPECT_NE(s.skipped[1].reason.find("line 5"), std::string::npos) << s.skipped[1].reason;
  const Index index = Index::open(out);
  ASSERT_EQ(index.skipped().size(), 2u);
  EXPECT_EQ(index.skipped()[1].reason, s.skipped[1].reason);

  // Unchanged bad files are not parsed again, and nothing else changed.
  s = build({in}, out);
  EXPECT_TRUE(s.up_to_date);
  EXPECT_EQ(s.skipped.size(), 2u);

  // --strict: the build fails and the previous index stays as it was.
  const std::string old_bytes = read_text(out);
  const auto old_hash = xxh64(old_bytes.data(), old_bytes.size());
  write_text(in / "another_walk_normal_009.bvh", read_text(golden_dir() / kWalk));
  EXPECT_THROW(build({in}, out, 2, true), InputError);
  const std::string now_bytes = read_text(out);
  EXPECT_EQ(xxh64(now_bytes.data(), now_bytes.size()), old_hash);
  for (const auto& e : fs::directory_iterator(dir))
    EXPECT_EQ(e.path().filename().string().find(".i.h5.tmp"), std::string::npos);

  // Nothing indexable at all is an error too.
  EXPECT_THROW(build({in / "empty.bvh"}, dir / "none.h5"), InputError);
  EXPECT_FALSE(fs::exists(dir / "none.h5"));
}

TEST(IndexBuilder, LabelsFromSidecarsCfgFilesAndFileNames) {
  const TempDir dir("index-labels");
  fs::create_directories(dir / "coll" / "cfg");
  fs::create_directories(dir / "coll" / "data");
  write_text(dir / "coll" / "cfg" / "content_label.txt", "coll-1_walk\ncoll-1_run\r\n");
  const fs::path clip = dir / "coll" / "data" / "coll-1_run_sad_001.bvh";
  fs::copy_file(golden_dir() / kWalk, clip);
  write_text(dir / "coll" / "data" / "coll-1_run_sad_001.json",
             R"({"content": 1, "style": "sad", "take": 7})");
  ClipLabels l = resolve_clip_labels(clip);
  EXPECT_EQ(l.source, LabelSource::sidecar_cfg);
  const std::vector<std::pair<std::string, std::string>> want{
      {"content", "run"}, {"style", "sad"}, {"take", "7"}};
  EXPECT_EQ(l.labels, want);

  // A sidecar whose numbers no cfg file reads (a partial copy of a
  // collection): the file name's labels for its keys, numbers for the rest.
  fs::create_directories(dir / "copy");
  const fs::path copy = dir / "copy" / "coll-1_run_sad_001.bvh";
  fs::copy_file(golden_dir() / kWalk, copy);
  write_text(dir / "copy" / "coll-1_run_sad_001.json", R"({"content": 1, "style": 4, "take": 7})");
  l = resolve_clip_labels(copy);
  EXPECT_EQ(l.source, LabelSource::sidecar);
  EXPECT_EQ(l.labels, want);

  l = resolve_clip_labels(golden_dir() / kWalk);
  EXPECT_EQ(l.source, LabelSource::file_name);
  EXPECT_EQ(l.labels, (std::vector<std::pair<std::string, std::string>>{{"content", "walk"},
                                                                        {"style", "normal"}}));
  l = resolve_clip_labels(golden_dir() / kJump);
  EXPECT_EQ(l.source, LabelSource::sidecar);
  l = resolve_clip_labels("/nowhere/131_01.bvh");
  EXPECT_EQ(l.source, LabelSource::none);
  EXPECT_TRUE(l.labels.empty());
}

TEST(IndexBuilder, RealDataSetOneAndCmu) {
  MOCAP_REQUIRE_DATA();
  const TempDir dir("index-real");
  const auto s =
      build({test::data_dir() / "bandai-namco-1" / "data", test::data_dir() / "cmu"}, dir / "i.h5");
  EXPECT_EQ(s.clips, 177u);
  EXPECT_TRUE(s.skipped.empty());
  const Index index = Index::open(dir / "i.h5");
  std::size_t cmu = 0;
  for (std::size_t c = 0; c < index.clips().size(); ++c) {
    const IndexClip& clip = index.clips()[c];
    const std::string name = fs::path(clip.path).stem().string();
    if (name.rfind("dataset-1_", 0) == 0) {
      // The sidecar resolved through cfg/*_label.txt says what the file name says.
      EXPECT_EQ(clip.label_source, LabelSource::sidecar_cfg) << name;
      const ClipLabels from_name = resolve_clip_labels(fs::path("/x") / (name + ".bvh"));
      ASSERT_EQ(from_name.labels.size(), 2u);
      EXPECT_EQ(index.label(c, "content"), from_name.labels[0].second) << name;
      EXPECT_EQ(index.label(c, "style"), from_name.labels[1].second) << name;
      EXPECT_EQ(clip.unit, "cm");
    } else {
      ++cmu;
      EXPECT_EQ(clip.unit, "cmu");
      EXPECT_EQ(clip.label_source, LabelSource::none);
    }
    // The root is the pelvis, not Bandai Namco's static joint_Root.
    const IndexSkeleton& sk = index.skeletons()[clip.skeleton];
    EXPECT_EQ(sk.skeleton.names[static_cast<std::size_t>(sk.root_joint)], "Hips");
  }
  EXPECT_EQ(cmu, 3u);
  EXPECT_TRUE(verify_index(dir / "i.h5").ok);
}
