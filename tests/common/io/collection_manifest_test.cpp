// common/src/io/collection_manifest.cpp: what read_collection_manifest refuses
// (docs/cli.md "How a collection manifest is checked") and what it accepts.
#include "mocap/common/io/collection_manifest.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "mocap/common/util/error.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;

namespace {

std::string entry(const std::string& path, const std::string& clips = "2",
                  const std::string& xxh64 = "0123456789abcdef") {
  return R"({"path": ")" + path + R"(", "clips": )" + clips + R"(, "frames": 10, "xxh64": ")" +
         xxh64 + R"("})";
}

// Writes a manifest of `entries` to DIR/NAME.json and returns its path.
fs::path manifest(const fs::path& dir, const std::string& name,
                  const std::vector<std::string>& entries) {
  std::string list;
  for (const std::string& e : entries) list += (list.empty() ? "" : ", ") + e;
  const fs::path p = dir / (name + ".json");
  std::ofstream(p) << R"({"format": "mocap-collection", "version": 1, "shards": [)" << list << "]}";
  return p;
}

// The message of the InputError reading `path` throws ("" when none).
std::string refusal(const fs::path& path) {
  try {
    (void)mocap::read_collection_manifest(path);
  } catch (const mocap::InputError& e) {
    return e.what();
  }
  return "";
}

bool says(const std::string& message, const std::string& what) {
  return message.find(what) != std::string::npos;
}

}  // namespace

TEST(CollectionManifest, AcceptsAValidOneAndAnUpperCaseHash) {
  const fs::path dir = mocap::test::temp_dir("manifest-ok");
  const fs::path p = manifest(
      dir, "c", {entry("c.shard-1-of-2.h5"), entry("c.shard-2-of-2.h5", "3", "0123456789ABCDEF")});
  const mocap::CollectionManifest m = mocap::read_collection_manifest(p);
  ASSERT_EQ(m.shards.size(), 2u);
  EXPECT_EQ(m.shards[1].xxh64, "0123456789abcdef");
  EXPECT_EQ(m.shards[1].clips, 3u);
  // Shards under names of their own, in any order.
  EXPECT_EQ(refusal(manifest(dir, "own", {entry("b.h5"), entry("a.h5")})), "");
}

TEST(CollectionManifest, RefusesRepeatedReorderedAndMissingShards) {
  const fs::path dir = mocap::test::temp_dir("manifest-order");
  const std::string s1 = entry("c.shard-1-of-3.h5"), s2 = entry("c.shard-2-of-3.h5"),
                    s3 = entry("c.shard-3-of-3.h5");
  for (const auto& [name, entries] : std::vector<std::pair<std::string, std::vector<std::string>>>{
           {"twice", {s1, s1, s2, s3}}, {"reordered", {s2, s1, s3}}, {"dropped", {s1, s3}}})
    EXPECT_TRUE(says(refusal(manifest(dir, name, entries)), "reordered, repeated or missing"))
        << name;
  // A file listed twice under names of its own, or spelt two ways.
  EXPECT_TRUE(says(refusal(manifest(dir, "same", {entry("a.h5"), entry("a.h5")})), "again"));
  EXPECT_TRUE(says(refusal(manifest(dir, "spelt", {entry("a.h5"), entry("./a.h5")})), "again"));
}

TEST(CollectionManifest, RefusesBadFields) {
  const fs::path dir = mocap::test::temp_dir("manifest-fields");
  EXPECT_TRUE(says(refusal(manifest(dir, "nul", {entry("a\\u0000b.h5")})), "NUL"));
  EXPECT_TRUE(says(refusal(manifest(dir, "hex", {entry("a.h5", "1", "0123456789abcdeg")})),
                   "16 hex digits"));
  EXPECT_TRUE(says(
      refusal(manifest(dir, "sum", {entry("a.h5", "18446744073709551615"), entry("b.h5", "1")})),
      "2^64"));
  std::vector<std::string> many;
  for (std::size_t i = 0; i <= mocap::kMaxCollectionShards; ++i)
    many.push_back(entry("s" + std::to_string(i) + ".h5"));
  EXPECT_TRUE(says(refusal(manifest(dir, "many", many)), "more than the limit of 4096"));
}

TEST(CollectionManifest, ShardCountProblemNamesTheShardAndTheCounts) {
  mocap::CollectionShard s;
  s.path = "c.shard-1-of-2.h5";
  s.clips = 3;
  s.frames = 10;
  EXPECT_EQ(mocap::shard_count_problem(s, 3, 10), "");
  EXPECT_TRUE(says(mocap::shard_count_problem(s, 4, 10), "holds 4 clips, the manifest says 3"));
  EXPECT_TRUE(says(mocap::shard_count_problem(s, 3, 9), "holds 9 frames, the manifest says 10"));
}
