// Tests for indexer/src/collection.cpp: inputs -> sorted, de-duplicated BVH files.
#include "mocap/indexer/collection.hpp"

#include <gtest/gtest.h>

#include <sys/stat.h>

#include <fstream>

#include "test_support.hpp"

namespace mocap {
namespace {

namespace fs = std::filesystem;

void touch(const fs::path& p) {
  fs::create_directories(p.parent_path());
  std::ofstream(p) << "x";
}

TEST(CollectionValidityTest, MissingInputsAreReportedNotThrown) {
  const Collection c = list_collection({"/nonexistent/folder", "/nonexistent/file.bvh"});
  EXPECT_TRUE(c.files.empty());
  ASSERT_EQ(c.problems.size(), 2u);
  EXPECT_EQ(c.problems[0].input, "/nonexistent/folder");
}

TEST(CollectionValidityTest, ListFileWithMissingEntries) {
  const fs::path dir = test::temp_dir("collection");
  touch(dir / "a.bvh");
  std::ofstream(dir / "list.txt") << "# comment\n\na.bvh\n  missing.bvh  \r\n";
  const Collection c = list_collection({(dir / "list.txt").string()});
  ASSERT_EQ(c.files.size(), 1u);
  EXPECT_EQ(c.files[0].path, dir / "a.bvh");
  ASSERT_EQ(c.problems.size(), 1u);
  EXPECT_NE(c.problems[0].input.find("missing.bvh"), std::string::npos);
  EXPECT_NE(c.problems[0].reason.find("list.txt"), std::string::npos);
  fs::remove_all(dir);
}

TEST(CollectionValidityTest, LinkLoopsFifosAndDanglingLinks) {
  // Two links back up the tree end neither in a hang nor in the same file
  // listed many times; a FIFO or a dangling link named .bvh is reported.
  const fs::path dir = test::temp_dir("collection-links");
  touch(dir / "a" / "walk.bvh");
  fs::create_directory_symlink("..", dir / "a" / "up");
  fs::create_directory_symlink("../a", dir / "a" / "again");
  ASSERT_EQ(mkfifo((dir / "a" / "fifo.bvh").c_str(), 0600), 0);
  fs::create_symlink("nowhere.bvh", dir / "a" / "dangling.bvh");
  const Collection c = list_collection({dir.string(), (dir / "a").string()});
  ASSERT_EQ(c.files.size(), 1u);
  EXPECT_EQ(c.files[0].path.filename(), "walk.bvh");
  ASSERT_EQ(c.problems.size(), 2u);
  for (const auto& p : c.problems)
    EXPECT_NE(p.reason.find("not a regular file"), std::string::npos) << p.input;
}

TEST(CollectionTest, FoldersRecursiveSortedDeduplicatedHiddenSkipped) {
  const fs::path dir = test::temp_dir("collection");
  touch(dir / "b" / "z.BVH");
  touch(dir / "a" / "deep" / "y.bvh");
  touch(dir / "a" / "notes.txt");
  touch(dir / ".hidden" / "x.bvh");
  touch(dir / "c.bvh");
  const Collection c =
      list_collection({dir.string(), (dir / "c.bvh").string(), (dir / "b").string()});
  EXPECT_TRUE(c.problems.empty());
  std::vector<fs::path> got;
  for (const auto& e : c.files) got.push_back(e.path);
  EXPECT_EQ(got, (std::vector<fs::path>{dir / "a" / "deep" / "y.bvh", dir / "b" / "z.BVH",
                                        dir / "c.bvh"}));
  fs::remove_all(dir);
}

TEST(CollectionTest, AmcTakesAreClipsAsfSkeletonsAreNot) {
  const fs::path dir = test::temp_dir("collection_amc");
  for (const char* n : {"a.bvh", "s.asf", "s1.AMC", "sub/02_01.amc", "sub/02.ASF"}) touch(dir / n);
  std::ofstream(dir / "list.txt") << "s.asf\ns1.AMC\n";
  const Collection folder = list_collection({dir.string(), (dir / "s.asf").string()});
  EXPECT_TRUE(folder.problems.empty());
  ASSERT_EQ(folder.files.size(), 3u);
  EXPECT_EQ(folder.files[0].path, dir / "a.bvh");
  EXPECT_EQ(folder.files[1].path, dir / "s1.AMC");
  EXPECT_EQ(folder.files[2].path, dir / "sub/02_01.amc");
  const Collection list = list_collection({(dir / "list.txt").string()});
  EXPECT_TRUE(list.problems.empty());
  ASSERT_EQ(list.files.size(), 1u);
  EXPECT_EQ(list.files[0].path, dir / "s1.AMC");
}

TEST(CollectionTest, RealDataSet1HasAllClips) {
  MOCAP_REQUIRE_DATA();
  const Collection c = list_collection({(test::data_dir() / "bandai-namco-1").string()});
  EXPECT_TRUE(c.problems.empty());
  EXPECT_EQ(c.files.size(), 174u);
}

}  // namespace
}  // namespace mocap
