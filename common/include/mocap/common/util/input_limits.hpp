#pragma once
// Input limits (docs/cli.md "Input limits"): the largest files and counts the
// tools accept. One set per process, set by the commands' flags
// (input_limits_cli.hpp) before any input is read and read-only afterwards.
#include <cstddef>
#include <cstdint>

namespace mocap {

struct InputLimits {
  /// Bytes of one BVH file (indexed, or a query frame's).
  std::uint64_t bvh_bytes = 8ull << 30;
  /// Bytes of a character file or a single query file (`--query`).
  std::uint64_t json_file_bytes = 16ull << 20;
  /// Bytes of a query batch (`--queries`) or a results file (`--results`).
  std::uint64_t batch_bytes = 4ull << 30;
  /// Query frames in one query.
  std::size_t query_frames = 256;
  /// Joints in one BVH file.
  std::size_t bvh_joints = 10000;
};

/// The limits in force (the defaults above until set_input_limits).
const InputLimits& input_limits();

/// Replaces the limits in force. Throws std::invalid_argument naming the
/// field when a limit is 0, or when query_frames < 2 (a query has at least
/// two frames). Not thread-safe: call it before any input is read.
void set_input_limits(const InputLimits& limits);

}  // namespace mocap
