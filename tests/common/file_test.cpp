#include "mocap/file.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "mocap/error.hpp"
#include "test_support.hpp"

namespace mocap {
namespace {

namespace fs = std::filesystem;

void write(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
}

TEST(File, MissingFileIsAnError) {
  const fs::path missing = test::temp_dir("file-missing") / "nothing-here.bvh";
  std::string error;
  EXPECT_FALSE(stat_file(missing, error).has_value());
  EXPECT_FALSE(error.empty());
  try {
    (void)read_file_bytes(missing, 10);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("nothing-here.bvh"), std::string::npos) << e.what();
  }
  // A directory opens but cannot be read.
  EXPECT_THROW((void)read_file_bytes(test::temp_dir("file-dir"), 10), InputError);
}

TEST(File, StatGivesSizeAndModificationTime) {
  const fs::path path = test::temp_dir("file-stat") / "a.txt";
  write(path, "hello");
  std::string error;
  const auto st = stat_file(path, error);
  ASSERT_TRUE(st.has_value()) << error;
  EXPECT_EQ(st->size, 5u);
  // file_clock and the Unix epoch differ by a constant: compare a change.
  fs::last_write_time(path, fs::last_write_time(path) + std::chrono::seconds(3));
  const auto later = stat_file(path, error);
  ASSERT_TRUE(later.has_value());
  EXPECT_EQ(later->mtime_ns - st->mtime_ns, 3'000'000'000LL);
  EXPECT_EQ(later->size, st->size);
  EXPECT_FALSE(*later == *st);
}

TEST(File, ReadsTheWholeFileOrItsStart) {
  const fs::path dir = test::temp_dir("file-read");
  std::string bytes;
  for (int i = 0; i < 300000; ++i) bytes.push_back(static_cast<char>(i * 7 % 251));
  write(dir / "big.bin", bytes);
  EXPECT_EQ(read_file_bytes(dir / "big.bin", bytes.size()).view(), bytes);
  // Asking for more than there is gives what there is.
  EXPECT_EQ(read_file_bytes(dir / "big.bin", bytes.size() + 100).view(), bytes);
  const FileBytes start = read_file_bytes(dir / "big.bin", 1000);
  EXPECT_EQ(start.size(), 1000u);
  EXPECT_EQ(start.view(), std::string_view(bytes).substr(0, 1000));
  write(dir / "empty.bin", "");
  EXPECT_EQ(read_file_bytes(dir / "empty.bin", 0).size(), 0u);
  EXPECT_EQ(read_file_bytes(dir / "empty.bin", 64).size(), 0u);
}

}  // namespace
}  // namespace mocap
