// Tests for indexer/src/asf_pairing.cpp: which ASF an AMC take is read with.
#include "mocap/indexer/asf_pairing.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "mocap/common/util/error.hpp"
#include "test_support.hpp"

namespace mocap {
namespace {

namespace fs = std::filesystem;

// --- invalid inputs --------------------------------------------------------

TEST(AsfPairingValidityTest, EmptyAmcPathIsAnError) {
  const AsfPairing p = pair_asf_by_name("", std::nullopt, {"a.asf"});
  EXPECT_TRUE(p.asf.empty());
  EXPECT_NE(p.error.find("not an AMC file name"), std::string::npos);
}

TEST(AsfPairingValidityTest, NonAmcExtensionIsAnError) {
  const AsfPairing p = pair_asf_by_name("d/take.bvh", std::nullopt, {"take.asf"});
  EXPECT_TRUE(p.asf.empty());
  EXPECT_FALSE(p.error.empty());
}

TEST(AsfPairingValidityTest, NoAsfInTheFolderIsAnError) {
  const AsfPairing p = pair_asf_by_name("d/take.amc", std::nullopt, {});
  EXPECT_TRUE(p.asf.empty());
  EXPECT_NE(p.error.find("no ASF skeleton"), std::string::npos);
  EXPECT_NE(p.error.find("0 .asf file(s)"), std::string::npos);
}

TEST(AsfPairingValidityTest, NoRuleMatchesAmongSeveralAsfs) {
  const AsfPairing p = pair_asf_by_name("d/walk.amc", std::nullopt, {"run.asf", "jump.asf"});
  EXPECT_TRUE(p.asf.empty());
  EXPECT_NE(p.error.find("2 .asf file(s)"), std::string::npos);
}

TEST(AsfPairingValidityTest, EmptyAsfOptionIsAnError) {
  const AsfPairing p = pair_asf_by_name("d/take.amc", fs::path(), {"take.asf"});
  EXPECT_TRUE(p.asf.empty());
  EXPECT_FALSE(p.error.empty());
}

TEST(AsfPairingValidityTest, MissingAsfOptionFileIsAnError) {
  const fs::path dir = test::temp_dir("asf_pairing_missing");
  std::ofstream(dir / "take.amc") << "1\n";
  const AsfPairing p = pair_asf(dir / "take.amc", dir / "absent.asf");
  EXPECT_TRUE(p.asf.empty());
  EXPECT_NE(p.error.find("absent.asf"), std::string::npos);
}

TEST(AsfPairingValidityTest, ReadingAnUnpairedAmcThrowsNamingTheFile) {
  const fs::path dir = test::temp_dir("asf_pairing_unpaired");
  std::ofstream(dir / "take.amc") << "1\n";
  try {
    read_capture_file(dir / "take.amc", {});
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("take.amc"), std::string::npos);
  }
}

// --- the rules, in order ---------------------------------------------------

TEST(AsfPairingTest, AsfOptionWinsOverTheFolder) {
  const AsfPairing p = pair_asf_by_name("d/take.amc", fs::path("other/s.asf"), {"take.asf"});
  EXPECT_EQ(p.asf, fs::path("other/s.asf"));
  EXPECT_TRUE(p.error.empty());
}

TEST(AsfPairingTest, TheFoldersOnlyAsf) {
  EXPECT_EQ(pair_asf_by_name("d/walk.amc", std::nullopt, {"skel.asf"}).asf, fs::path("d/skel.asf"));
  // Names that are not .asf do not count.
  EXPECT_EQ(pair_asf_by_name("d/walk.amc", std::nullopt, {"skel.ASF", "notes.txt"}).asf,
            fs::path("d/skel.ASF"));
}

TEST(AsfPairingTest, SubjectAsfForCmuTakeNames) {
  EXPECT_EQ(pair_asf_by_name("d/02_01.amc", std::nullopt, {"01.asf", "02.asf", "02_01.asf"}).asf,
            fs::path("d/02.asf"));
}

TEST(AsfPairingTest, SameStem) {
  EXPECT_EQ(pair_asf_by_name("d/walk.AMC", std::nullopt, {"run.asf", "walk.asf"}).asf,
            fs::path("d/walk.asf"));
  // A stem without '_' or with it at an end goes to the same-name rule.
  EXPECT_EQ(pair_asf_by_name("d/_x.amc", std::nullopt, {"a.asf", "_x.asf"}).asf,
            fs::path("d/_x.asf"));
}

TEST(AsfPairingTest, LongestPrefixIsTheLastRule) {
  const std::vector<std::string> names{"backflip.asf", "charleston.asf", "char.asf", "zombie.asf"};
  EXPECT_EQ(pair_asf_by_name("d/charleston1.amc", std::nullopt, names).asf,
            fs::path("d/charleston.asf"));
  // The same stem comes before a prefix.
  EXPECT_EQ(pair_asf_by_name("d/char.amc", std::nullopt, names).asf, fs::path("d/char.asf"));
  // Names compare case-sensitively.
  EXPECT_TRUE(pair_asf_by_name("d/Charleston1.amc", std::nullopt, names).asf.empty());
}

TEST(AsfPairingTest, OnTheFileSystem) {
  const fs::path dir = test::temp_dir("asf_pairing_fs");
  for (const char* n : {"a.asf", "ab.asf", "abc1.amc"}) std::ofstream(dir / n) << "x\n";
  fs::create_directories(dir / "z.asf");  // a folder is not an ASF
  EXPECT_EQ(pair_asf(dir / "abc1.amc", std::nullopt).asf, dir / "ab.asf");
}

}  // namespace
}  // namespace mocap
