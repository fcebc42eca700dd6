#pragma once
// Sharded builds (docs/index-format.md "Collections"): one collection split
// into N ordinary index files balanced by frames, and the manifest that
// names them (mocap/common/io/collection_manifest.hpp).
#include <cstddef>
#include <filesystem>
#include <vector>

#include "mocap/indexer/index_builder.hpp"

namespace mocap {

struct ShardedBuildSummary {
  std::filesystem::path manifest;
  /// One per shard, in order (each shard's own build summary).
  std::vector<IndexBuildSummary> shards;
};

/// The shard files of a manifest at `manifest` with `count` shards:
/// "<stem>.shard-<k>-of-<count>.h5" beside it, k = 1 .. count.
std::vector<std::filesystem::path> shard_paths(const std::filesystem::path& manifest,
                                               std::size_t count);

/// Splits the files of `options.inputs` (sorted by path, as one index would
/// hold them) into `count` consecutive groups balanced by frames (a file's
/// MOTION header count; a file is never split), builds each group as an
/// ordinary index with `options` (incrementally over the shard's previous
/// file, like build_index), then writes the manifest `options.out`
/// atomically, last. Throws InputError for count 0, for fewer files than
/// shards, and as build_index does (the manifest then stays as it was).
ShardedBuildSummary build_sharded(const IndexBuildOptions& options, std::size_t count);

}  // namespace mocap
