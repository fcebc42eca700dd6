#pragma once
// XXH64 (Yann Collet's 64-bit xxHash): the hash behind every checksum of the
// index (source-file content hashes, per-dataset checksums, the whole-file
// checksum in the user block) and the query cache's check that a file is the
// one the index holds.
//
// Values equal the reference implementation's (`xxhsum -H1` for seed 0) on
// little-endian hosts (x86-64, aarch64), the only ones the project builds for.
#include <cstddef>
#include <cstdint>
#include <string>

namespace mocap {

/// Streaming XXH64: update() any number of times (any split of the bytes gives
/// the same digest), digest() at any point (it does not change the state).
/// Several GB/s.
class Xxh64 {
 public:
  explicit Xxh64(std::uint64_t seed = 0);
  /// Adds `bytes` bytes at `data` (nullptr allowed when bytes is 0).
  void update(const void* data, std::size_t bytes);
  /// The hash of everything added so far.
  std::uint64_t digest() const;

 private:
  std::uint64_t lanes_[4];
  std::uint64_t seed_;
  std::uint64_t total_ = 0;
  unsigned char buffer_[32];
  std::size_t buffered_ = 0;
};

/// XXH64 of `bytes` bytes at `data` in one call.
std::uint64_t xxh64(const void* data, std::size_t bytes, std::uint64_t seed = 0);

/// 16 lowercase hex digits, most significant first (the form the index stores).
std::string hex64(std::uint64_t v);

}  // namespace mocap
