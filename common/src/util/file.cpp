// stat(2), whole-file reads and file hashes with POSIX calls (mocap/common/util/file.hpp).
#include "mocap/common/util/file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <string>
#include <vector>

#include "mocap/common/util/error.hpp"
#include "mocap/common/util/xxh64.hpp"

namespace mocap {

namespace {

/// A file descriptor open for reading, closed on destruction.
class ReadOnlyFile {
 public:
  explicit ReadOnlyFile(const std::filesystem::path& path)
      : path_(path), fd_(::open(path.c_str(), O_RDONLY | O_CLOEXEC)) {
    if (fd_ < 0)
      throw InputError(path.string(), 0,
                       std::string("cannot open file for reading: ") + std::strerror(errno));
  }
  ReadOnlyFile(const ReadOnlyFile&) = delete;
  ReadOnlyFile& operator=(const ReadOnlyFile&) = delete;
  ~ReadOnlyFile() { ::close(fd_); }

  /// Up to `bytes` bytes at `out` (fewer only at the end of the file; 0 there).
  std::size_t read(char* out, std::size_t bytes) {
    std::size_t got = 0;
    while (got < bytes) {
      const ::ssize_t n = ::read(fd_, out + got, bytes - got);
      if (n < 0 && errno == EINTR) continue;
      if (n < 0)
        throw InputError(path_.string(), 0,
                         std::string("cannot read file: ") + std::strerror(errno));
      if (n == 0) break;
      got += static_cast<std::size_t>(n);
    }
    return got;
  }

  /// fstat(2) of the open file: its size now.
  std::uint64_t size() {
    struct stat st {};
    if (::fstat(fd_, &st) != 0)
      throw InputError(path_.string(), 0, std::string("cannot stat file: ") + std::strerror(errno));
    return static_cast<std::uint64_t>(st.st_size);
  }

  void seek(std::uint64_t offset) {
    if (::lseek(fd_, static_cast<::off_t>(offset), SEEK_SET) < 0)
      throw InputError(path_.string(), 0,
                       std::string("cannot seek in file: ") + std::strerror(errno));
  }

 private:
  std::filesystem::path path_;
  int fd_;
};

}  // namespace

FileStat check_input_file(const std::filesystem::path& path, std::uint64_t max_bytes) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    throw InputError(path.string(), 0, std::string("cannot read: ") + std::strerror(errno));
  if (S_ISDIR(st.st_mode)) throw InputError(path.string(), 0, "is a folder, not a file");
  if (!S_ISREG(st.st_mode))
    throw InputError(path.string(), 0,
                     "not a regular file (a FIFO, a device or a socket): not read as input");
  const auto size = static_cast<std::uint64_t>(st.st_size);
  if (size > max_bytes)
    throw InputError(path.string(), 0,
                     std::to_string(size) + " bytes: larger than this input's limit of " +
                         std::to_string(max_bytes) + " bytes");
  return FileStat{size,
                  static_cast<std::int64_t>(st.st_mtim.tv_sec) * 1000000000LL + st.st_mtim.tv_nsec};
}

FileStat stat_file(const std::filesystem::path& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw InputError(path.string(), 0, std::strerror(errno));
  return FileStat{static_cast<std::uint64_t>(st.st_size),
                  static_cast<std::int64_t>(st.st_mtim.tv_sec) * 1000000000LL + st.st_mtim.tv_nsec};
}

FileBytes read_file_bytes(const std::filesystem::path& path, std::uint64_t max_bytes) {
  ReadOnlyFile file(path);
  // The buffer is the file's size (at most max_bytes), never the limit itself:
  // a 150-byte file under a 4 GiB limit takes 150 bytes.
  const std::uint64_t bytes = std::min(max_bytes, file.size());
  FileBytes out;
  out.data_ = std::make_unique_for_overwrite<char[]>(static_cast<std::size_t>(bytes));
  out.size_ = file.read(out.data_.get(), static_cast<std::size_t>(bytes));
  return out;
}

FileBytes read_input_file(const std::filesystem::path& path, std::uint64_t max_bytes) {
  const FileStat st = check_input_file(path, max_bytes);
  return read_file_bytes(path, st.size);
}

void for_each_line(std::string_view text,
                   const std::function<bool(std::string_view, std::size_t)>& line) {
  std::size_t n = 0;
  for (std::size_t at = 0; at < text.size();) {
    const std::size_t end = std::min(text.find('\n', at), text.size());
    if (!line(text.substr(at, end - at), ++n)) return;
    at = end + 1;
  }
}

std::uint64_t hash_file(const std::filesystem::path& path, std::uint64_t offset) {
  ReadOnlyFile file(path);
  file.seek(offset);
  Xxh64 h;
  std::vector<char> block(std::size_t{1} << 20);
  while (const std::size_t got = file.read(block.data(), block.size())) h.update(block.data(), got);
  return h.digest();
}

}  // namespace mocap
