#pragma once
// Replacing a file atomically: the new content is written to a temporary file
// ".NAME.tmp-PID" in the folder of the target NAME, made durable (fsync),
// renamed over the target, and the folder made durable. A process killed at
// any moment leaves the target as it was, and at worst a stale temporary file
// that the next replacement of the same target removes.
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
