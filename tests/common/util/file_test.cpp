// stat_file, read_file_bytes and hash_file (common/src/util/file.cpp) on real files.
#include "mocap/common/util/file.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <fstream>
#include <functional>
#include <string>

#include "mocap/common/util/error.hpp"
#include "mocap/common/util/xxh64.hpp"
#include "test_support.hpp"

namespace mocap {
namespace {

namespace fs = std::filesystem;

void write(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
}

TEST(File, InputsMustBeRegularFilesWithinTheirLimit) {
  const fs::path dir = test::temp_dir("file-inputs");
  EXPECT_THROW((void)check_input_file(dir / "missing.json", 10), InputError);
  EXPECT_THROW((void)check_input_file(dir, 10), InputError);
  ASSERT_EQ(mkfifo((dir / "fifo.bvh").c_str(), 0600), 0);
  try {
    (void)check_input_file(dir / "fifo.bvh", 10);
    FAIL() << "a FIFO accepted as input";
  } catch (const InputError& e) {
    EXPECT_NE(e.detail().find("not a regular file"), std::string::npos) << e.what();
  }
  EXPECT_THROW((void)check_input_file("/dev/zero", 10), InputError);
  write(dir / "eleven.txt", "01234567890");
  EXPECT_THROW((void)check_input_file(dir / "eleven.txt", 10), InputError);
  EXPECT_EQ(check_input_file(dir / "eleven.txt", 11).size, 11u);
}

TEST(File, MissingFileIsAnError) {
  const fs::path missing = test::temp_dir("file-missing") / "nothing-here.bvh";
  try {
    (void)stat_file(missing);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.source(), missing.string());
    EXPECT_EQ(e.detail(), "No such file or directory");  // the system's reason alone
  }
  for (const auto& read : {std::function<void()>([&] { (void)read_file_bytes(missing, 10); }),
                           std::function<void()>([&] { (void)hash_file(missing); })}) {
    try {
      read();
      FAIL() << "no error";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("nothing-here.bvh"), std::string::npos) << e.what();
    }
  }
  // A directory opens but cannot be read.
  EXPECT_THROW((void)read_file_bytes(test::temp_dir("file-dir"), 10), InputError);
  EXPECT_THROW((void)hash_file(test::temp_dir("file-dir")), InputError);
}

TEST(File, StatGivesSizeAndModificationTime) {
  const fs::path path = test::temp_dir("file-stat") / "a.txt";
  write(path, "hello");
  const FileStat st = stat_file(path);
  EXPECT_EQ(st.size, 5u);
  // file_clock and the Unix epoch differ by a constant: compare a change.
  fs::last_write_time(path, fs::last_write_time(path) + std::chrono::seconds(3));
  const FileStat later = stat_file(path);
  EXPECT_EQ(later.mtime_ns - st.mtime_ns, 3'000'000'000LL);
  EXPECT_EQ(later.size, st.size);
  EXPECT_FALSE(later == st);
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

TEST(File, ReservesTheFileNotTheLimit) {
  const fs::path dir = test::temp_dir("file-limit");
  write(dir / "small.json", "{\"id\": \"q\"}");
  // A limit of 1 PiB: allocating it would throw std::bad_alloc.
  const std::uint64_t huge = std::uint64_t{1} << 50;
  EXPECT_EQ(read_file_bytes(dir / "small.json", huge).view(), "{\"id\": \"q\"}");
  EXPECT_EQ(read_input_file(dir / "small.json", huge).view(), "{\"id\": \"q\"}");
  // read_input_file refuses a file over its limit, quoting the limit.
  try {
    (void)read_input_file(dir / "small.json", 5);
    FAIL() << "a 13-byte file read under a 5-byte limit";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("limit of 5 bytes"), std::string::npos) << e.what();
  }
  EXPECT_THROW((void)read_input_file(dir, huge), InputError);
}

TEST(File, HashIsTheXxh64OfTheBytesFromTheOffset) {
  const fs::path dir = test::temp_dir("file-hash");
  // Over 1 MiB: more than one read block.
  std::string bytes;
  for (int i = 0; i < 1'500'000; ++i) bytes.push_back(static_cast<char>(i * 13 % 253));
  write(dir / "big.bin", bytes);
  EXPECT_EQ(hash_file(dir / "big.bin"), xxh64(bytes.data(), bytes.size()));
  EXPECT_EQ(hash_file(dir / "big.bin", 512), xxh64(bytes.data() + 512, bytes.size() - 512));
  // At or past the end: the hash of no bytes.
  EXPECT_EQ(hash_file(dir / "big.bin", bytes.size()), xxh64(nullptr, 0));
  EXPECT_EQ(hash_file(dir / "big.bin", bytes.size() + 7), xxh64(nullptr, 0));
  write(dir / "empty.bin", "");
  EXPECT_EQ(hash_file(dir / "empty.bin"), xxh64(nullptr, 0));
}

}  // namespace
}  // namespace mocap
