// common/src/util/output_path.cpp: the output-path policy (docs/cli.md "Output
// paths"). Refusals first, then what is written where.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "mocap/common/util/error.hpp"
#include "mocap/common/util/output_path.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;
using mocap::OutputKind;

namespace {
void write(const fs::path& p, const std::string& text) {
  std::ofstream(p, std::ios::binary) << text;
}
}  // namespace

TEST(OutputPath, RefusesWhatIsNotARegularFileOfItsKind) {
  const fs::path dir = mocap::test::temp_dir("output-path");
  EXPECT_THROW(mocap::checked_output_path("", OutputKind::bvh, false, "--out"), mocap::InputError);
  EXPECT_THROW(mocap::checked_output_path(dir, OutputKind::bvh, true, "--out"), mocap::InputError);
  ASSERT_EQ(mkfifo((dir / "fifo").c_str(), 0600), 0);
  EXPECT_THROW(mocap::checked_output_path(dir / "fifo", OutputKind::jsonl, true, "--out"),
               mocap::InputError);
  write(dir / "notes.jsonl", "{\"id\": 1}\n");
  try {
    mocap::checked_output_path(dir / "notes.jsonl", OutputKind::bvh, false, "--out");
    FAIL() << "a JSON lines file accepted as BVH output";
  } catch (const mocap::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--force"), std::string::npos) << e.what();
  }
  EXPECT_EQ(mocap::checked_output_path(dir / "notes.jsonl", OutputKind::bvh, true, "--out"),
            dir / "notes.jsonl");
  fs::create_symlink("loop-b", dir / "loop-a");
  fs::create_symlink("loop-a", dir / "loop-b");
  EXPECT_THROW(mocap::checked_output_path(dir / "loop-a", OutputKind::bvh, false, "--out"),
               mocap::InputError);
  EXPECT_THROW(
      mocap::check_distinct_outputs({{"--out", dir / "m.bvh"}, {"--report", dir / "m.bvh"}}),
      mocap::InputError);
  fs::create_symlink("m.bvh", dir / "alias.bvh");
  EXPECT_THROW(
      mocap::check_distinct_outputs({{"--out", dir / "m.bvh"}, {"--report", dir / "alias.bvh"}}),
      mocap::InputError);
  EXPECT_NO_THROW(mocap::check_distinct_outputs({{"--out", dir / "m.bvh"}, {"--report", ""}}));
}

TEST(OutputPath, NoOutputIsAFileReadNorAShardOfACollectionRead) {
  const fs::path dir = mocap::test::temp_dir("output-path-inputs");
  write(dir / "q.jsonl", "{}\n");
  write(dir / "col.shard-1-of-2.h5", "");
  write(dir / "col.shard-2-of-2.h5", "");
  const std::string shard = R"({"path": "col.shard-K-of-2.h5", "clips": 1, "frames": 2,
      "xxh64": "0123456789abcdef"})";
  auto with_k = [&](char k) {
    std::string s = shard;
    s[s.find('K')] = k;
    return s;
  };
  write(dir / "col.json", R"({"format": "mocap-collection", "version": 1, "shards": [)" +
                              with_k('1') + ", " + with_k('2') + "]}");
  const std::vector<std::pair<std::string, fs::path>> inputs{{"--index", dir / "col.json"},
                                                             {"--queries", dir / "q.jsonl"}};
  for (const fs::path& out : {dir / "col.json", dir / "q.jsonl", dir / "col.shard-2-of-2.h5"}) {
    try {
      mocap::check_outputs_and_inputs({{"--out", out}}, inputs);
      FAIL() << out << " accepted as an output";
    } catch (const mocap::InputError& e) {
      EXPECT_NE(std::string(e.what()).find("reads"), std::string::npos) << e.what();
    }
  }
  try {
    mocap::check_outputs_and_inputs({{"--out", dir / "col.shard-1-of-2.h5"}}, inputs);
    FAIL() << "a shard accepted as an output";
  } catch (const mocap::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("shard 1 of 2"), std::string::npos) << e.what();
  }
  // Through a link to a shard, from a path spelt another way.
  fs::create_symlink("col.shard-2-of-2.h5", dir / "alias.h5");
  EXPECT_THROW(mocap::check_outputs_and_inputs({{"--html", dir / "alias.h5"}}, inputs),
               mocap::InputError);
  EXPECT_THROW(
      mocap::check_outputs_and_inputs({{"--out", dir / "." / "col.shard-1-of-2.h5"}}, inputs),
      mocap::InputError);
  EXPECT_NO_THROW(
      mocap::check_outputs_and_inputs({{"--out", dir / "r.jsonl"}, {"--html", ""}}, inputs));
  // Outputs are still distinct from each other.
  EXPECT_THROW(mocap::check_outputs_and_inputs(
                   {{"--out", dir / "r.jsonl"}, {"--html", dir / "r.jsonl"}}, inputs),
               mocap::InputError);
}

TEST(OutputPath, AcceptsAbsentEmptyAndOwnKindAndWritesThroughLinks) {
  const fs::path dir = mocap::test::temp_dir("output-path-ok");
  EXPECT_EQ(mocap::checked_output_path(dir / "new" / "m.bvh", OutputKind::bvh, false, "--out"),
            dir / "new" / "m.bvh");
  write(dir / "empty.json", "");
  EXPECT_NO_THROW(mocap::checked_output_path(dir / "empty.json", OutputKind::json, false, "--out"));
  write(dir / "m.bvh", "  HIERARCHY\nROOT Hips\n");
  write(dir / "r.json", "\n[1]");
  write(dir / "r.html", "<!doctype HTML><html>");
  write(dir / "i.h5", std::string("MOCAP-INDEX-USER-BLOCK 1\n"));
  EXPECT_NO_THROW(mocap::checked_output_path(dir / "m.bvh", OutputKind::bvh, false, "--out"));
  EXPECT_NO_THROW(mocap::checked_output_path(dir / "r.json", OutputKind::json, false, "--out"));
  EXPECT_NO_THROW(mocap::checked_output_path(dir / "r.html", OutputKind::html, false, "--out"));
  EXPECT_NO_THROW(mocap::checked_output_path(dir / "i.h5", OutputKind::index, false, "--out"));
  EXPECT_THROW(mocap::checked_output_path(dir / "r.json", OutputKind::jsonl, false, "--out"),
               mocap::InputError);  // JSON lines start with an object
  EXPECT_TRUE(mocap::looks_like(OutputKind::index,
                                std::string(512, '\0') + std::string("\x89HDF\r\n\x1a\n", 8)));
  fs::create_symlink("m.bvh", dir / "link.bvh");
  fs::create_symlink("link.bvh", dir / "link2.bvh");
  EXPECT_EQ(mocap::checked_output_path(dir / "link2.bvh", OutputKind::bvh, false, "--out"),
            dir / "m.bvh");
  fs::create_symlink("gone.bvh", dir / "dangling.bvh");
  EXPECT_EQ(mocap::checked_output_path(dir / "dangling.bvh", OutputKind::bvh, false, "--out"),
            dir / "gone.bvh");
}
