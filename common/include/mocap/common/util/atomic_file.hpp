#pragma once
// Replacing a file atomically: the new content is written to a temporary file
// ".NAME.tmp-PID" in the folder of the target NAME, made durable (fsync),
// renamed over the target, and the folder made durable. A process killed at
// any moment leaves the target as it was, and at worst a stale temporary file
// that the next replacement of the same target removes.
#include <cstdint>
#include <filesystem>
#include <string>

namespace mocap {

/// One replacement of `target`. The caller writes temporary_path() (nothing
/// is created there by this class), then commit()s; a replacement destroyed
/// without commit() removes the temporary file and leaves the target alone.
class AtomicFile {
 public:
  /// Creates the target's folder when it is missing and removes the stale
  /// temporaries of earlier replacements (remove_stale_temporaries). Throws
  /// InputError(folder, 0, reason) when the folder cannot be created.
  explicit AtomicFile(const std::filesystem::path& target);
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;
  ~AtomicFile();

  const std::filesystem::path& target() const { return target_; }
  /// ".NAME.tmp-PID" in the target's folder (PID: this process).
  const std::filesystem::path& temporary_path() const { return temporary_; }

  /// fsync(2)s the temporary file, renames it over the target and fsyncs the
  /// folder. Throws InputError(path, 0, reason) when a step fails (the
  /// temporary file is then removed by the destructor unless the rename
  /// happened). At most once.
  void commit();

 private:
  std::filesystem::path target_;
  std::filesystem::path temporary_;
  bool committed_ = false;
};

/// Starts the kernel writing a file's dirty pages to disk while the file is
/// still being written (sync_file_range(2), SYNC_FILE_RANGE_WRITE: no wait),
/// so that the fsync of AtomicFile::commit finds little left to write and
/// the disk works while the writer computes. Call kick() after each append;
/// it starts writeback once every `every_bytes` more bytes are in the file.
/// Best effort: a file that cannot be opened, or a failed call, only turns
/// it off (the fsync that follows reports real write errors).
class EarlyWriteback {
 public:
  explicit EarlyWriteback(const std::filesystem::path& path,
                          std::uint64_t every_bytes = std::uint64_t{32} << 20);
  EarlyWriteback(const EarlyWriteback&) = delete;
  EarlyWriteback& operator=(const EarlyWriteback&) = delete;
  ~EarlyWriteback();
  void kick();
  /// Bytes handed to writeback so far.
  std::uint64_t started_bytes() const { return started_; }

 private:
  int fd_ = -1;
  std::uint64_t every_ = 0;
  std::uint64_t started_ = 0;
};

/// An exclusive lock on the output `target` between processes: flock(2) on
/// ".NAME.lock" in the target's folder (created when missing, left there),
/// held while the object lives. Two builds to one index: the second fails at
/// once instead of racing the first. Throws InputError(target, 0, ...) when
/// another process (or another OutputLock) holds it, or the lock file cannot
/// be opened.
class OutputLock {
 public:
  explicit OutputLock(const std::filesystem::path& target);
  OutputLock(const OutputLock&) = delete;
  OutputLock& operator=(const OutputLock&) = delete;
  ~OutputLock();
  const std::filesystem::path& lock_path() const { return path_; }

 private:
  std::filesystem::path path_;
  int fd_ = -1;
};

/// Writes `text` to `path` through an AtomicFile: afterwards the path holds
/// the complete text or what it held before. Throws InputError(path, 0,
/// reason) when the folder cannot be created or a write or the commit fails.
void write_file_atomically(const std::filesystem::path& path, const std::string& text);

/// Removes the temporary files ".NAME.tmp-PID" of `target` left by processes
/// that no longer run (and by this process). Names with a non-numeric PID and
/// other files are left alone; errors while listing or removing are ignored
/// (a stale temporary file is only clutter).
void remove_stale_temporaries(const std::filesystem::path& target);

/// fsync(2) of a file, or of a folder (its entries: a rename in it) when
/// `folder`. A folder on a file system that cannot sync folders (EINVAL) is
/// accepted. Throws InputError(path, 0, reason) otherwise.
void sync_to_disk(const std::filesystem::path& path, bool folder);

}  // namespace mocap
