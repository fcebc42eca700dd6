// The index reader against the golden files of the current schema version
// (tests/data/index/index-v3.h5) and of versions 2 and 1 (index-v2.h5,
// index-v1.h5), each built by `mocap-index build --compress 9` from the two
// hand-written clips next to them: the same contents from all three (the
// newer versions derive frame arrays the older ones stored), its refusal of
// other versions, and damaged copies.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <string>

#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/hdf5.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/common/io/index_tables.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/common/util/xxh64.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;
using namespace mocap;

namespace {

fs::path golden_dir() {
  return fs::path(MOCAP_SOURCE_DIR) / "tests" / "data" / "index";
}
fs::path golden() {
  return golden_dir() / "index-v3.h5";
}
fs::path golden_v2() {
  return golden_dir() / "index-v2.h5";
}
fs::path golden_v1() {
  return golden_dir() / "index-v1.h5";
}

/// Temporary copies of the golden file, removed when the test ends.
struct GoldenCopy {
  fs::path dir;
  fs::path file;
  explicit GoldenCopy(const std::string& tag)
      : dir(test::temp_dir("index-reader-" + tag)), file(dir / "copy.h5") {
    fs::copy_file(golden(), file);
  }
  ~GoldenCopy() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

void flip_byte(const fs::path& p, std::uint64_t offset) {
  std::fstream f(p, std::ios::in | std::ios::out | std::ios::binary);
  f.seekg(static_cast<std::streamoff>(offset));
  char c = 0;
  f.read(&c, 1);
  c = static_cast<char>(c ^ 0x10);
  f.seekp(static_cast<std::streamoff>(offset));
  f.write(&c, 1);
}

/// Adds `delta` to the middle value of skeleton 0's frame array `field` of
/// the index at `p`, then seals the file again: damage behind a valid user
/// block, which only the dataset's own checksum can catch.
void damage_frame_value(const fs::path& p, const std::string& field, float delta) {
  {
    h5::File f = h5::File::open(p, true);
    h5::Dataset d =
        f.root().open_group("skeletons").open_group("0").open_group("frames").open_dataset(field);
    std::vector<float> v = d.read_all<float>();
    v[v.size() / 2] += delta;
    d.write_all<float>(v);
    f.close();
  }
  seal_index_file(p);
}

}  // namespace

// What both golden files hold, read through Index (the frame arrays that
// version 2 derives included).
void expect_golden_contents(const fs::path& file, std::int64_t version) {
  ASSERT_TRUE(fs::exists(file)) << file;
  const Index index = Index::open(file, {.verify_file_checksum = true});
  EXPECT_EQ(index.info().format, kIndexFormat);
  EXPECT_EQ(index.info().schema_version, version);
  EXPECT_EQ(index.info().unit_option, "auto");
  EXPECT_DOUBLE_EQ(index.info().transition_time_s, 0.5);
  EXPECT_DOUBLE_EQ(index.info().character_total_mass_kg, 70.0);
  ASSERT_EQ(index.clips().size(), 2u);
  ASSERT_EQ(index.skeletons().size(), 1u);
  EXPECT_EQ(index.frame_count(), 7u);
  EXPECT_TRUE(index.skipped().empty());

  // Sorted by path: jump (3 frames at 20 fps, sidecar labels) then walk (4 frames, file-name
  // labels).
  const IndexClip& jump = index.clips()[0];
  const IndexClip& walk = index.clips()[1];
  EXPECT_EQ(fs::path(jump.path).filename(), "golden_jump_happy_002.bvh");
  EXPECT_EQ(fs::path(walk.path).filename(), "golden_walk_normal_001.bvh");
  EXPECT_EQ(jump.frame_count, 3u);
  EXPECT_EQ(walk.frame_count, 4u);
  EXPECT_EQ(jump.frame_start, 0u);
  EXPECT_EQ(walk.frame_start, 3u);
  EXPECT_DOUBLE_EQ(jump.frame_time_s, 0.05);
  EXPECT_EQ(jump.unit, "cm");
  EXPECT_DOUBLE_EQ(jump.unit_scale_m, 0.01);
  EXPECT_EQ(jump.label_source, LabelSource::sidecar);
  EXPECT_EQ(walk.label_source, LabelSource::file_name);
  EXPECT_EQ(index.label(0, "content"), "jump");
  EXPECT_EQ(index.label(0, "style"), "happy");
  EXPECT_EQ(index.label(1, "content"), "walk");
  EXPECT_EQ(index.label(1, "style"), "normal");
  EXPECT_EQ(index.label(1, "no-such-key"), "");

  const IndexSkeleton& s = index.skeletons()[0];
  ASSERT_EQ(s.skeleton.joint_count(), 10u);
  EXPECT_EQ(s.skeleton.names[0], "Hips");
  EXPECT_EQ(s.skeleton.parents[4], 0);  // LeftUpLeg under Hips
  EXPECT_EQ(s.channels[0], "Xposition Yposition Zposition Zrotation Xrotation Yrotation");
  EXPECT_EQ(s.skeleton.channel_count, 33u);
  EXPECT_EQ(s.root_joint, 0);
  EXPECT_NEAR(s.skeleton.offsets_m[1].y(), 0.20, 1e-12);
  EXPECT_NEAR(s.body.total_mass_kg, 70.0, 1e-6);
  EXPECT_EQ(s.clips, (std::vector<std::size_t>{0, 1}));
  EXPECT_EQ(index.dynamics_model(0).segments, s.segments);

  // Frame values by hand: walk frame 2 has its root at (0, 97, 6) cm.
  const auto root = index.clip_frames(1, "root_position_m");
  ASSERT_EQ(root.size(), 12u);
  EXPECT_NEAR(root[2 * 3 + 0], 0.0f, 1e-6f);
  EXPECT_NEAR(root[2 * 3 + 1], 0.97f, 1e-6f);
  EXPECT_NEAR(root[2 * 3 + 2], 0.06f, 1e-6f);
  // ... and its Hips local rotation is 10 degrees about Y (channels Z X Y = 0 0 10).
  const auto rot = index.clip_frames(1, "local_rotations");
  EXPECT_NEAR(rot[(2 * 10 + 0) * 4 + 0], std::cos(5.0 * M_PI / 180.0), 1e-6);
  EXPECT_NEAR(rot[(2 * 10 + 0) * 4 + 2], std::sin(5.0 * M_PI / 180.0), 1e-6);

  // Forward kinematics of the source file agrees with the stored joint positions.
  const RawClip raw = read_bvh_file(golden_dir() / "golden_walk_normal_001.bvh");
  const ClipMotion m = clip_motion_from_raw(raw, 0.01);
  const auto jpos = index.clip_frames(1, "joint_positions_m");
  for (std::size_t f = 0; f < 4; ++f)
    for (std::size_t j = 0; j < 10; ++j)
      for (int a = 0; a < 3; ++a)
        EXPECT_NEAR(jpos[(f * 10 + j) * 3 + static_cast<std::size_t>(a)], m.position(f, j)[a],
                    1e-6);

  // Bounds contain the frames; prefix sums start at 0 and never decrease.
  const IndexArray& bmin = index.array(0, "clip_bounds", "root_min_m");
  const IndexArray& bmax = index.array(0, "clip_bounds", "root_max_m");
  EXPECT_NEAR(bmin.f32[1 * 3 + 2], 0.0f, 1e-6f);
  EXPECT_NEAR(bmax.f32[1 * 3 + 2], 0.09f, 1e-6f);
  const IndexArray& chmin = index.array(0, "clip_bounds", "rotation_channel_min_deg");
  const IndexArray& chmax = index.array(0, "clip_bounds", "rotation_channel_max_deg");
  // walk, LeftUpLeg (joint 4) Xrotation (its 2nd channel) swings from -20 to 20 degrees.
  EXPECT_FLOAT_EQ(chmin.f32[(1 * 10 + 4) * 3 + 1], -20.0f);
  EXPECT_FLOAT_EQ(chmax.f32[(1 * 10 + 4) * 3 + 1], 20.0f);
  const auto prefix = index.clip_energy_prefix(0);
  ASSERT_EQ(prefix.size(), 3u);
  EXPECT_EQ(prefix[0], 0.0);
  EXPECT_GT(prefix[2], prefix[0]);                           // the jump costs energy
  EXPECT_EQ(index.array(0, "blocks16", "kd_min").rows, 2u);  // one block per clip

  const IndexVerifyReport r = verify_index(file);
  EXPECT_TRUE(r.ok) << (r.problems.empty() ? "" : r.problems.front());
  EXPECT_GT(r.datasets_checked, 36u);
}

TEST(IndexReader, GoldenFileOfTheCurrentVersion) {
  expect_golden_contents(golden(), kIndexSchemaVersion);
}

TEST(IndexReader, GoldenFileOfVersion2IsStillRead) {
  expect_golden_contents(golden_v2(), 2);
}

TEST(IndexReader, GoldenFileOfVersion1IsStillRead) {
  expect_golden_contents(golden_v1(), 1);
}

namespace {

/// The frame fields schema version `since` stopped storing.
std::vector<std::string_view> derived_since(std::int64_t since) {
  std::vector<std::string_view> out;
  for (const DerivedFrameField& d : kIndexDerivedFrameFields)
    if (d.since == since) out.push_back(d.name);
  return out;
}

/// Skeleton 0's `field` as `derived` derives it against `stored`'s stored
/// array: the same shape, every element within absolute + relative |stored|.
void expect_derived_near_stored(const Index& derived, const Index& stored, std::string_view field,
                                double relative, double absolute) {
  const IndexArray& x = derived.array(0, "frames", field);
  const IndexArray& y = stored.array(0, "frames", field);
  ASSERT_EQ(x.rows, y.rows) << field;
  ASSERT_EQ(x.f32.size(), y.f32.size()) << field;
  for (std::size_t e = 0; e < x.f32.size(); ++e)
    ASSERT_NEAR(x.f32[e], y.f32[e], absolute + relative * std::abs(static_cast<double>(y.f32[e])))
        << field << " element " << e;
}

/// The frame fields of `file`'s skeleton 0 that are not datasets in it.
std::vector<std::string_view> not_in_file(const fs::path& file) {
  h5::File f = h5::File::open(file);
  const h5::Group frames = f.root().open_group("skeletons").open_group("0").open_group("frames");
  std::vector<std::string_view> out;
  for (const IndexFieldSpec& spec : kFrameFields)
    if (!frames.exists(spec.name)) out.push_back(spec.name);
  return out;
}

}  // namespace

// Version 2 stores no world rotations, COMs or rates: what it derives
// equals what version 1 stored, to float precision (kinematics) and 1e-4
// relative (rates: finite differences of float positions), and the derived
// world rotations and COMs are the source file's forward kinematics (the
// slow reference).
TEST(IndexReader, Version2DerivesTheFrameArraysVersion1Stored) {
  const Index v2 = Index::open(golden_v2());
  const Index v1 = Index::open(golden_v1());
  for (std::string_view field : derived_since(2)) {
    EXPECT_FALSE(frame_field_stored(field, 2)) << field;
    EXPECT_TRUE(frame_field_stored(field, 1)) << field;
    const bool rate = field.find("velocity") != std::string_view::npos;
    expect_derived_near_stored(v2, v1, field, rate ? 1e-4 : 0.0, rate ? 1e-4 : 1e-6);
  }
  const RawClip raw = read_bvh_file(golden_dir() / "golden_walk_normal_001.bvh");
  const ClipMotion m = clip_motion_from_raw(raw, 0.01);
  const auto world = v2.clip_frames(1, "world_rotations");
  const auto com = v2.clip_frames(1, "segment_com_m");
  const DynamicsModel model = v2.dynamics_model(0);
  for (std::size_t f = 0; f < 4; ++f)
    for (std::size_t j = 0; j < 10; ++j) {
      const float* q = &world[(f * 10 + j) * 4];
      const Eigen::Quaterniond r(q[0], q[1], q[2], q[3]);
      EXPECT_LT(r.angularDistance(m.rotation(f, j)), 1e-6) << f << " " << j;
      const Eigen::Vector3d c = m.position(f, j) + m.rotation(f, j) * model.coms_local_m[j];
      for (int a = 0; a < 3; ++a)
        EXPECT_NEAR(com[(f * 10 + j) * 3 + static_cast<std::size_t>(a)], c[a], 1e-6)
            << f << " " << j;
    }
  // Not in the file: only derived.
  EXPECT_EQ(not_in_file(golden_v2()), derived_since(2));
}

// Version 3 stores no h scan or kd features either: what it derives equals
// what version 2 stored (which the build made from its double-precision
// dynamics) to float precision for positions and orientations, 1e-4
// relative for kinetic energies; the file holds exactly the stored fields.
TEST(IndexReader, Version3DerivesTheScanAndKdFeaturesVersion2Stored) {
  const Index v3 = Index::open(golden());
  const Index v2 = Index::open(golden_v2());
  ASSERT_EQ(derived_since(3), (std::vector<std::string_view>{"h_scan", "kd_features"}));
  for (std::string_view field : derived_since(3)) {
    EXPECT_FALSE(frame_field_stored(field, 3)) << field;
    EXPECT_TRUE(frame_field_stored(field, 2)) << field;
    expect_derived_near_stored(v3, v2, field, 1e-4, 1e-4);
  }
  std::vector<std::string_view> all = derived_since(2), three = derived_since(3);
  all.insert(all.end(), three.begin(), three.end());
  std::vector<std::string_view> missing = not_in_file(golden());
  std::sort(all.begin(), all.end());
  std::sort(missing.begin(), missing.end());
  EXPECT_EQ(missing, all);
}

// The build made the kd bounds from the same derivation a reader runs: every
// derived kd feature lies inside its clip's and its blocks' stored bounds
// (bit for bit, no tolerance).
TEST(IndexReader, Version3KdFeaturesLieInTheirStoredBounds) {
  const Index index = Index::open(golden());
  const IndexArray& kd = index.array(0, "frames", "kd_features");
  for (const IndexClip& clip : index.clips())
    for (std::uint64_t f = clip.frame_start; f < clip.frame_start + clip.frame_count; ++f) {
      const auto row = kd.rows_f32(f, 1);
      const auto lo = index.array(0, "clip_bounds", "kd_min").rows_f32(clip.row, 1);
      const auto hi = index.array(0, "clip_bounds", "kd_max").rows_f32(clip.row, 1);
      const std::uint64_t b = clip.block16_start + (f - clip.frame_start) / 16;
      const auto blo = index.array(0, "blocks16", "kd_min").rows_f32(b, 1);
      const auto bhi = index.array(0, "blocks16", "kd_max").rows_f32(b, 1);
      for (std::size_t e = 0; e < row.size(); ++e) {
        EXPECT_GE(row[e], lo[e]) << f << " " << e;
        EXPECT_LE(row[e], hi[e]) << f << " " << e;
        EXPECT_GE(row[e], blo[e]) << f << " " << e;
        EXPECT_LE(row[e], bhi[e]) << f << " " << e;
      }
    }
}

TEST(IndexReader, RefusesAnotherSchemaVersion) {
  const GoldenCopy copy("version");
  const fs::path& p = copy.file;
  {
    h5::File f = h5::File::open(p, true);
    f.root().set_attribute("schema_version", std::int64_t{kIndexSchemaVersion + 1});
    f.close();
  }
  seal_index_file(p);  // as a future writer would have sealed it
  const std::string msg = test::input_error_message([&] { Index::open(p); });
  EXPECT_NE(msg.find("unsupported index schema version " + std::to_string(kIndexSchemaVersion + 1) +
                     " (this build reads 1 to " + std::to_string(kIndexSchemaVersion) + ")"),
            std::string::npos)
      << msg;
  const IndexVerifyReport r = verify_index(p);
  EXPECT_FALSE(r.ok);
  ASSERT_FALSE(r.problems.empty());
  EXPECT_NE(r.problems.front().find("unsupported index schema version"), std::string::npos);
}

TEST(IndexReader, RefusesAnotherFormatTag) {
  const GoldenCopy copy("tag");
  const fs::path& p = copy.file;
  {
    h5::File f = h5::File::open(p, true);
    f.root().set_attribute("format", "something-else");
    f.close();
  }
  seal_index_file(p);
  EXPECT_NE(test::input_error_message([&] { Index::open(p); }).find("not a mocap index"),
            std::string::npos);
}

TEST(IndexReader, RefusesFilesThatAreNoIndex) {
  EXPECT_NE(test::input_error_message([&] {
              Index::open(golden_dir() / "golden_walk_normal_001.bvh");
            }).find("not a mocap index"),
            std::string::npos);
  EXPECT_NE(test::input_error_message([&] {
              Index::open(golden_dir() / "no-such.h5");
            }).find("no such index file"),
            std::string::npos);
  const IndexVerifyReport r = verify_index(golden_dir() / "golden_walk_normal_001.bvh");
  EXPECT_FALSE(r.ok);
}

TEST(IndexReader, TruncatedCopiesAreRefusedCleanly) {
  const GoldenCopy copy("truncated");
  const fs::path& p = copy.file;
  const auto size = fs::file_size(p);
  for (std::uint64_t keep :
       {size - 1, size / 2, std::uint64_t{600}, std::uint64_t{100}, std::uint64_t{0}}) {
    fs::resize_file(p, keep);
    const std::string msg = test::input_error_message([&] { Index::open(p); });
    EXPECT_FALSE(msg.empty()) << keep;
    const IndexVerifyReport r = verify_index(p);
    EXPECT_FALSE(r.ok) << keep;
    if (keep >= kIndexUserBlockBytes) {
      EXPECT_NE(msg.find("truncated"), std::string::npos) << msg;
    }
  }
}

TEST(IndexReader, BitFlipsAreFoundByVerify) {
  const GoldenCopy copy("flip-src");
  const fs::path& src = copy.file;
  const auto size = fs::file_size(src);
  // Flip one byte at many places (user block, HDF5 metadata, data): verify
  // reports damage every time and never crashes.
  for (std::uint64_t off = 3; off < size; off += size / 37) {
    const fs::path p = src.parent_path() / ("flip-" + std::to_string(off) + ".h5");
    fs::copy_file(src, p);
    flip_byte(p, off);
    const IndexVerifyReport r = verify_index(p);
    EXPECT_FALSE(r.ok) << "flip at " << off;
    EXPECT_FALSE(r.problems.empty());
  }
}

TEST(IndexReader, DatasetChecksumsCatchDamageBehindAValidUserBlock) {
  // Damage a dataset, then re-seal: the whole-file checksum passes, the
  // dataset's own checksum does not.
  const GoldenCopy copy("dataset");
  const fs::path& p = copy.file;
  {
    h5::File f = h5::File::open(p, true);
    h5::Dataset d = f.root().open_group("clips").open_dataset("frame_time_s");
    std::vector<double> v = d.read_all<double>();
    v[0] = 0.04;
    d.write_all<double>(v);
    f.close();
  }
  seal_index_file(p);
  const IndexVerifyReport r = verify_index(p);
  EXPECT_FALSE(r.ok);
  bool found = false;
  for (const auto& s : r.problems)
    found = found || s.find("/clips/frame_time_s: checksum mismatch") != std::string::npos;
  EXPECT_TRUE(found) << (r.problems.empty() ? "" : r.problems.front());
}

TEST(IndexReader, DerivedArraysCheckTheStoredArraysTheyComeFrom) {
  // Joint positions changed behind a valid user block: an array derived
  // from them (schema 3 stores no world rotations, COMs or h scan) is refused with
  // the stored array's checksum, not made from damaged data.
  const GoldenCopy copy("derived");
  const fs::path& p = copy.file;
  damage_frame_value(p, "joint_positions_m", 0.25f);
  const Index index = Index::open(p);
  for (const DerivedFrameField& d : kIndexDerivedFrameFields) {
    const std::string_view field = d.name;
    const std::string msg =
        test::input_error_message([&] { (void)index.array(0, "frames", field); });
    EXPECT_NE(msg.find("/skeletons/0/frames/joint_positions_m: checksum mismatch"),
              std::string::npos)
        << field << ": " << msg;
  }
  const std::string msg = test::input_error_message([&] {
    index.stream_rows(0, "frames", "segment_com_m", 2,
                      [](std::uint64_t, std::uint64_t, const float*) {});
  });
  EXPECT_NE(msg.find("joint_positions_m: checksum mismatch"), std::string::npos) << msg;
}

TEST(IndexReader, OpenChecksTheClipAndSkeletonTables) {
  // A changed clip label or segment mass behind a valid user block: the
  // search opens indexes with Index::open, which must refuse them (they
  // would change answers silently).
  for (const auto& [group, dataset] :
       {std::pair<std::string, std::string>{"clips", "frame_time_s"},
        std::pair<std::string, std::string>{"skeletons/0", "mass_kg"}}) {
    const GoldenCopy copy("open-" + dataset);
    {
      h5::File f = h5::File::open(copy.file, true);
      h5::Dataset d = group == "clips"
                          ? f.root().open_group("clips").open_dataset(dataset)
                          : f.root().open_group("skeletons").open_group("0").open_dataset(dataset);
      std::vector<double> v = d.read_all<double>();
      v[0] += 1.0;
      d.write_all<double>(v);
      f.close();
    }
    seal_index_file(copy.file);
    const std::string e = test::input_error_message([&] { (void)Index::open(copy.file); });
    EXPECT_NE(e.find(dataset + ": checksum mismatch"), std::string::npos) << e;
  }
}

// Index::arrays: several fields at once, the derived ones in one pass.
TEST(IndexReader, ArraysRefuseWhatArrayRefuses) {
  const Index index = Index::open(golden());
  const std::array<std::string_view, 2> bad{"world_rotations", "no_such_field"};
  EXPECT_NE(test::input_error_message([&] {
              (void)index.arrays(0, "frames", bad);
            }).find("unknown field"),
            std::string::npos);
  const std::array<std::string_view, 1> one{"kd_features"};
  EXPECT_NE(
      test::input_error_message([&] { (void)index.arrays(7, "frames", one); }).find("out of range"),
      std::string::npos);
  // Damaged sources: nothing is derived from them, and nothing is kept.
  const GoldenCopy copy("arrays");
  damage_frame_value(copy.file, "local_rotations", 0.5f);
  const Index damaged = Index::open(copy.file);
  const std::array<std::string_view, 2> derived{"world_rotations", "segment_com_m"};
  for (int attempt = 0; attempt < 2; ++attempt)
    EXPECT_NE(test::input_error_message([&] {
                (void)damaged.arrays(0, "frames", derived);
              }).find("local_rotations: checksum mismatch"),
              std::string::npos)
        << attempt;
}

TEST(IndexReader, ArraysEqualArrayFieldByField) {
  // Every frame field, derived and stored, twice (a repeated name), in one
  // call on one index and one array() at a time on another: the same values,
  // and the same shared arrays as array() then gives.
  std::vector<std::string_view> fields;
  for (const DerivedFrameField& d : kIndexDerivedFrameFields) fields.push_back(d.name);
  fields.push_back("local_rotations");
  fields.push_back("joint_positions_m");
  fields.push_back(kIndexDerivedFrameFields[0].name);
  const Index together = Index::open(golden());
  const Index alone = Index::open(golden());
  for (std::uint32_t k = 0; k < together.skeletons().size(); ++k) {
    const std::vector<const IndexArray*> a = together.arrays(k, "frames", fields);
    ASSERT_EQ(a.size(), fields.size());
    for (std::size_t i = 0; i < fields.size(); ++i) {
      const IndexArray& b = alone.array(k, "frames", fields[i]);
      EXPECT_EQ(a[i]->rows, b.rows) << fields[i];
      EXPECT_EQ(a[i]->f32, b.f32) << fields[i];
      EXPECT_EQ(a[i], &together.array(k, "frames", fields[i])) << fields[i];
    }
  }
}

TEST(IndexReader, ArrayErrorsNameTheProblem) {
  const Index index = Index::open(golden());
  EXPECT_NE(test::input_error_message([&] {
              index.array(0, "frames", "no_such_field");
            }).find("unknown field"),
            std::string::npos);
  EXPECT_NE(test::input_error_message([&] {
              index.array(0, "nonsense", "kd_min");
            }).find("unknown array group"),
            std::string::npos);
  EXPECT_NE(test::input_error_message([&] {
              index.array(7, "frames", "kd_features");
            }).find("out of range"),
            std::string::npos);
}

// Streaming the rows of an array (Index::stream_rows: the search engine
// builds its scan table from h_scan without keeping the array) gives the
// rows of array(), in order, for any block size, and names bad requests.
TEST(IndexReader, StreamedRowsEqualTheArray) {
  const Index index = Index::open(golden());
  for (std::uint32_t k = 0; k < index.skeletons().size(); ++k)
    for (const char* field : {"h_scan", "joint_positions_m", "root_position_m"}) {
      const IndexArray& a = index.array(k, "frames", field);
      ASSERT_GT(a.rows, 1u);
      // Stored arrays stream in blocks of at most `block` rows; derived ones
      // in whole clips (at least `block` rows, or the last clips).
      const bool stored = frame_field_stored(field, index.info().schema_version);
      std::set<std::uint64_t> clip_ends;
      for (std::size_t c : index.skeletons()[k].clips)
        clip_ends.insert(index.clips()[c].frame_start + index.clips()[c].frame_count);
      for (std::uint64_t block :
           {std::uint64_t{1}, std::uint64_t{7}, a.rows - 1, a.rows, a.rows + 5}) {
        std::vector<float> got;
        std::uint64_t next = 0;
        index.stream_rows(k, "frames", field, block,
                          [&](std::uint64_t first, std::uint64_t count, const float* v) {
                            EXPECT_EQ(first, next);
                            if (stored)
                              EXPECT_LE(count, block);
                            else
                              EXPECT_TRUE(clip_ends.contains(first + count));
                            next = first + count;
                            got.insert(got.end(), v, v + count * a.row_elements);
                          });
        EXPECT_EQ(next, a.rows) << field << " block " << block;
        EXPECT_EQ(got, a.f32) << field << " block " << block;
      }
    }
  auto none = [](std::uint64_t, std::uint64_t, const float*) {};
  EXPECT_NE(test::input_error_message([&] {
              index.stream_rows(0, "frames", "no_such_field", 8, none);
            }).find("unknown field"),
            std::string::npos);
  EXPECT_NE(test::input_error_message([&] {
              index.stream_rows(7, "frames", "h_scan", 8, none);
            }).find("out of range"),
            std::string::npos);
  EXPECT_NE(test::input_error_message([&] {
              index.stream_rows(0, "frames", "energy_prefix_J", 8, none);
            }).find("not a float array"),
            std::string::npos);
}

// A damaged array read by streaming fails its checksum after the last block,
// naming the dataset, like array() does.
TEST(IndexReader, StreamedRowsCatchDamage) {
  const GoldenCopy copy("stream");
  const fs::path& p = copy.file;
  damage_frame_value(p, "root_position_m", 1.0f);
  const Index index = Index::open(p);
  std::uint64_t rows = 0;
  const std::string e = test::input_error_message([&] {
    index.stream_rows(0, "frames", "root_position_m", 5,
                      [&](std::uint64_t, std::uint64_t count, const float*) { rows += count; });
  });
  EXPECT_EQ(rows, index.skeletons()[0].frame_count);  // every block was read first
  EXPECT_NE(e.find("/skeletons/0/frames/root_position_m: checksum mismatch"), std::string::npos)
      << e;
  EXPECT_NE(test::input_error_message([&] {
              index.array(0, "frames", "root_position_m");
            }).find("checksum mismatch"),
            std::string::npos);
}

TEST(IndexTables, DescribeTheGoldenFileExactly) {
  // The tables that writer and reader walk name exactly what the golden file
  // holds: /clips, /skipped and the root attributes, nothing more or less.
  std::lock_guard lock(h5::library_mutex());
  const h5::File f = h5::File::open(golden());
  std::vector<std::string> clips{"label_keys", "labels"};
  for (const auto& c : kClipColumns) clips.emplace_back(c.name);
  std::sort(clips.begin(), clips.end());
  EXPECT_EQ(f.root().open_group("clips").members(), clips);
  std::vector<std::string> skipped;
  for (const auto& c : kSkippedColumns) skipped.emplace_back(c.name);
  std::sort(skipped.begin(), skipped.end());
  EXPECT_EQ(f.root().open_group("skipped").members(), skipped);
  std::vector<std::string> attributes;
  for (const auto& a : kIndexAttributes) attributes.emplace_back(a.name);
  std::sort(attributes.begin(), attributes.end());
  EXPECT_EQ(f.root().attribute_names(), attributes);
  // Units and descriptions as the tables say.
  const h5::Dataset size = f.root().open_group("clips").open_dataset("size_bytes");
  EXPECT_EQ(size.string_attribute("unit"), "B");
  EXPECT_EQ(size.string_attribute("description"), kClipColumns[1].description);
  EXPECT_EQ(index_enum_members(ClipStatus{}),
            (std::vector<std::pair<std::string, int>>{{"new", 0}, {"changed", 1}, {"reused", 2}}));
  EXPECT_EQ(f.root().open_group("clips").open_dataset("label_source").enum_members(),
            index_enum_members(LabelSource{}));
}

TEST(IndexTables, RootAttributesReadBackIntoIndexInfo) {
  const Index index = Index::open(golden());
  const IndexInfo& info = index.info();
  EXPECT_EQ(info.block_sizes, (std::vector<double>{16, 64}));
  EXPECT_EQ(info.skeleton_count, index.skeletons().size());
  EXPECT_EQ(info.skipped_count, index.skipped().size());
  EXPECT_EQ(info.clip_count, index.clips().size());
  EXPECT_EQ(info.energy_params, EnergyParams{});
}
