#include "mocap/file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "mocap/error.hpp"

namespace mocap {

std::optional<FileStat> stat_file(const std::filesystem::path& path, std::string& error) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    error = std::strerror(errno);
    return std::nullopt;
  }
  return FileStat{static_cast<std::uint64_t>(st.st_size),
                  static_cast<std::int64_t>(st.st_mtim.tv_sec) * 1000000000LL + st.st_mtim.tv_nsec};
}

FileBytes read_file_bytes(const std::filesystem::path& path, std::uint64_t max_bytes) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0)
    throw InputError(path.string(), 0,
                     std::string("cannot open file for reading: ") + std::strerror(errno));
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  FileBytes out;
  out.data_ = std::make_unique_for_overwrite<char[]>(static_cast<std::size_t>(max_bytes));
  std::size_t got = 0;
  while (got < max_bytes) {
    const ::ssize_t n =
        ::read(fd, out.data_.get() + got, static_cast<std::size_t>(max_bytes) - got);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0)
      throw InputError(path.string(), 0, std::string("cannot read file: ") + std::strerror(errno));
    if (n == 0) break;
    got += static_cast<std::size_t>(n);
  }
  out.size_ = got;
  return out;
}

}  // namespace mocap
