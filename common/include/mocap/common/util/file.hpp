#pragma once
// Source files as the tools read them: one stat(2) for size and modification
// time, whole-file reads into a buffer that is not zero-filled first (the
// search reads a query frame's BVH file: docs/search.md "Query frames from
// indexed files"), and the XXH64 of a file's bytes read in bounded memory
// (content hashes of the indexer, the index's whole-file checksum).
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string_view>

namespace mocap {

/// What stat(2) says of a file (links followed).
struct FileStat {
  std::uint64_t size = 0;
  /// Modification time, nanoseconds since the Unix epoch.
  std::int64_t mtime_ns = 0;
  bool operator==(const FileStat&) const = default;
};

/// stat(2) of `path`. Throws InputError(path, 0, reason) when it fails, the
/// reason being the system's alone (e.g. "No such file or directory") so that
/// callers can say what they were doing.
FileStat stat_file(const std::filesystem::path& path);

/// stat_file of an input that must be a regular file (links followed) of at
/// most `max_bytes` (the limits in force: input_limits.hpp): a FIFO or a device would block or
/// never end, a folder cannot be read. Throws InputError(path, 0, reason) naming what it is.
FileStat check_input_file(const std::filesystem::path& path, std::uint64_t max_bytes);

/// Bytes read from a file; immutable once read.
class FileBytes {
 public:
  std::string_view view() const { return {data_.get(), size_}; }
  std::size_t size() const { return size_; }

 private:
  friend FileBytes read_file_bytes(const std::filesystem::path& path, std::uint64_t max_bytes);
  std::unique_ptr<char[]> data_;
  std::size_t size_ = 0;
};

/// The first `max_bytes` bytes of the file, or all of it when it is shorter.
/// Allocates what the file holds (at most max_bytes), never max_bytes itself.
/// Throws InputError(path, 0, reason) when it cannot be opened or read.
FileBytes read_file_bytes(const std::filesystem::path& path, std::uint64_t max_bytes);

/// The whole of an input bounded by a limit (input_limits.hpp): check_input_file
/// (a regular file of at most `max_bytes`, else InputError naming the limit),
/// then read_file_bytes of its size. The one reader of a bounded input file.
FileBytes read_input_file(const std::filesystem::path& path, std::uint64_t max_bytes);

/// Calls `line(text, n)` for each line of `text` in order (split at '\n',
/// which is not part of the line; a last line without one included; n
/// 1-based) until it returns false: the lines std::getline would read.
void for_each_line(std::string_view text,
                   const std::function<bool(std::string_view, std::size_t)>& line);

/// XXH64 (seed 0, mocap/common/util/xxh64.hpp) of the file's bytes from `offset` to its
/// end (none when offset is at or past the end), read in 1 MiB blocks.
/// Throws InputError(path, 0, reason) when it cannot be opened or read.
std::uint64_t hash_file(const std::filesystem::path& path, std::uint64_t offset = 0);

}  // namespace mocap
