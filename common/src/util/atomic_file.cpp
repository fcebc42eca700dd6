// Atomic file replacement: temporary file, stale temporaries, fsync, rename
// (mocap/common/util/atomic_file.hpp).
#include "mocap/common/util/atomic_file.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <string>
#include <system_error>

#include "mocap/common/util/error.hpp"

namespace mocap {

namespace fs = std::filesystem;

namespace {

std::string temporary_prefix(const fs::path& target) {
  return "." + target.filename().string() + ".tmp-";
}

}  // namespace

void remove_stale_temporaries(const fs::path& target) {
  const fs::path dir = target.parent_path().empty() ? fs::path(".") : target.parent_path();
  const std::string prefix = temporary_prefix(target);
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (name.rfind(prefix, 0) != 0) continue;
    const std::string pid_s = name.substr(prefix.size());
    if (pid_s.empty() ||
        !std::all_of(pid_s.begin(), pid_s.end(), [](unsigned char c) { return std::isdigit(c); }))
      continue;
    const pid_t pid = static_cast<pid_t>(std::stol(pid_s));
    if (pid == ::getpid() || (::kill(pid, 0) != 0 && errno == ESRCH)) fs::remove(e.path(), ec);
  }
}

void sync_to_disk(const fs::path& path, bool folder) {
  const int fd = ::open(path.c_str(), folder ? O_RDONLY | O_DIRECTORY : O_RDONLY);
  if (fd < 0)
    throw InputError(path.string(), 0, std::string("cannot open to sync: ") + std::strerror(errno));
  const int synced = ::fsync(fd);
  const int sync_errno = errno;
  ::close(fd);
  if (synced != 0 && !(folder && sync_errno == EINVAL))
    throw InputError(path.string(), 0, std::string("cannot sync: ") + std::strerror(sync_errno));
}

AtomicFile::AtomicFile(const fs::path& target) : target_(target) {
  const fs::path dir = target_.parent_path();
  std::error_code ec;
  if (!dir.empty() && !fs::create_directories(dir, ec) && ec)
    throw InputError(dir.string(), 0, "cannot create the folder: " + ec.message());
  remove_stale_temporaries(target_);
  temporary_ = dir / (temporary_prefix(target_) + std::to_string(::getpid()));
}

AtomicFile::~AtomicFile() {
  if (committed_) return;
  std::error_code ec;
  fs::remove(temporary_, ec);
}

void AtomicFile::commit() {
  sync_to_disk(temporary_, false);
  std::error_code ec;
  fs::rename(temporary_, target_, ec);
  if (ec) throw InputError(target_.string(), 0, "cannot replace the file: " + ec.message());
  committed_ = true;
  const fs::path dir = target_.parent_path();
  sync_to_disk(dir.empty() ? fs::path(".") : dir, true);
}

EarlyWriteback::EarlyWriteback(const fs::path& path, std::uint64_t every_bytes)
    : fd_(::open(path.c_str(), O_RDONLY | O_CLOEXEC)),
      every_(std::max<std::uint64_t>(every_bytes, 1)) {}

EarlyWriteback::~EarlyWriteback() {
  if (fd_ >= 0) ::close(fd_);
}

void EarlyWriteback::kick() {
  if (fd_ < 0) return;
  struct stat st {};
  if (::fstat(fd_, &st) != 0) return;
  const auto size = static_cast<std::uint64_t>(st.st_size);
  if (size < started_ + every_) return;
  if (::sync_file_range(fd_, static_cast<off64_t>(started_), static_cast<off64_t>(size - started_),
                        SYNC_FILE_RANGE_WRITE) != 0) {
    ::close(fd_);
    fd_ = -1;
    return;
  }
  started_ = size;
}

OutputLock::OutputLock(const fs::path& target) {
  const fs::path folder = target.parent_path().empty() ? fs::path(".") : target.parent_path();
  path_ = folder / ("." + target.filename().string() + ".lock");
  fd_ = ::open(path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0)
    throw InputError(target.string(), 0,
                     "cannot open the lock file " + path_.string() + ": " + std::strerror(errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    ::close(fd_);
    fd_ = -1;
    if (err == EWOULDBLOCK)
      throw InputError(target.string(), 0,
                       "another process is writing this file (it holds " + path_.string() +
                           "); wait for it to finish");
    throw InputError(target.string(), 0,
                     "cannot lock " + path_.string() + ": " + std::strerror(err));
  }
}

OutputLock::~OutputLock() {
  if (fd_ >= 0) ::close(fd_);  // releases the lock
}

void write_file_atomically(const std::filesystem::path& path, const std::string& text) {
  AtomicFile file(path);
  {
    std::ofstream out(file.temporary_path(), std::ios::binary);
    if (!out || !(out << text) || !out.flush()) throw InputError(path.string(), 0, "cannot write");
  }
  file.commit();
}

}  // namespace mocap
