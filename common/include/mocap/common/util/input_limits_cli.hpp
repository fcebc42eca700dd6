#pragma once
// The input-limit flags of every command (docs/cli.md "Input limits"):
// header-only, for the commands' main files, which link CLI11.
//   add_input_limit_options(app_or_subcommand, flags);  // before parsing
//   apply_input_limits(flags);                          // after parsing
#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>

#include "mocap/common/util/input_limits.hpp"

namespace mocap {

/// The flags' values: sizes in MiB, counts as they are.
struct InputLimitFlags {
  std::uint64_t bvh_mib = InputLimits{}.bvh_bytes >> 20;
  std::uint64_t json_mib = InputLimits{}.json_file_bytes >> 20;
  std::uint64_t batch_mib = InputLimits{}.batch_bytes >> 20;
  std::size_t query_frames = InputLimits{}.query_frames;
  std::size_t joints = InputLimits{}.bvh_joints;
};

/// Adds --max-bvh-mib, --max-json-mib, --max-batch-mib, --max-query-frames
/// and --max-joints to `app` (a command or a subcommand), in the group
/// "Input limits".
inline void add_input_limit_options(CLI::App& app, InputLimitFlags& f) {
  constexpr std::uint64_t kMaxMib = std::uint64_t{1} << 24;  // 16 TiB
  const std::string group = "Input limits (docs/cli.md)";
  app.add_option("--max-bvh-mib", f.bvh_mib, "Largest BVH file read, MiB")
      ->check(CLI::Range(std::uint64_t{1}, kMaxMib))
      ->capture_default_str()
      ->group(group);
  app.add_option("--max-json-mib", f.json_mib, "Largest character or single query file, MiB")
      ->check(CLI::Range(std::uint64_t{1}, kMaxMib))
      ->capture_default_str()
      ->group(group);
  app.add_option("--max-batch-mib", f.batch_mib, "Largest query batch or results file, MiB")
      ->check(CLI::Range(std::uint64_t{1}, kMaxMib))
      ->capture_default_str()
      ->group(group);
  app.add_option("--max-query-frames", f.query_frames, "Most query frames in one query")
      ->check(CLI::Range(std::size_t{2}, std::size_t{1} << 20))
      ->capture_default_str()
      ->group(group);
  app.add_option("--max-joints", f.joints, "Most joints in one BVH file")
      ->check(CLI::Range(std::size_t{1}, std::size_t{1} << 24))
      ->capture_default_str()
      ->group(group);
}

/// Puts the flags' limits in force (set_input_limits).
inline void apply_input_limits(const InputLimitFlags& f) {
  InputLimits l;
  l.bvh_bytes = f.bvh_mib << 20;
  l.json_file_bytes = f.json_mib << 20;
  l.batch_bytes = f.batch_mib << 20;
  l.query_frames = f.query_frames;
  l.bvh_joints = f.joints;
  set_input_limits(l);
}

}  // namespace mocap
