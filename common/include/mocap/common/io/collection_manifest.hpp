#pragma once
// Sharded collections (docs/index-format.md "Collections"): a manifest, JSON,
// naming the ordinary index files (shards) that together hold a collection,
// in order:
//   {"format": "mocap-collection", "version": 1,
//    "shards": [{"path": "set.shard-1-of-2.h5", "clips": 87, "frames": 51234,
//                "xxh64": "<16 hex digits of the shard file>"}, ...]}
// Shard paths are relative to the manifest's folder. The clips of shard k
// follow those of shard k - 1: clip c of shard k is clip (clips of the
// shards before k) + c of the collection.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace mocap {

inline constexpr const char* kCollectionFormat = "mocap-collection";
inline constexpr int kCollectionVersion = 1;

struct CollectionShard {
  /// As written in the manifest (relative to its folder, or absolute).
  std::string path;
  std::size_t clips = 0;
  std::uint64_t frames = 0;
  /// XXH64 of the shard file's bytes, 16 lower-case hex digits.
  std::string xxh64;
};

struct CollectionManifest {
  std::vector<CollectionShard> shards;
};

/// True when `path` names a manifest rather than an index: its first
/// non-blank byte is '{' (an index starts with its binary user block).
bool is_collection_manifest(const std::filesystem::path& path);

/// Reads and checks a manifest: format, version, at least one shard, every
/// field present and of its type. Throws InputError(path, 0, "field: what
/// was expected").
CollectionManifest read_collection_manifest(const std::filesystem::path& path);

/// The shard's file: its path resolved against the manifest's folder.
std::filesystem::path shard_file(const std::filesystem::path& manifest,
                                 const CollectionShard& shard);

/// Problems of the shards on disk, one line each naming the shard: missing,
/// unreadable, or bytes that no longer hash to the manifest's xxh64. Empty
/// when every shard is as the manifest says.
std::vector<std::string> collection_shard_problems(const std::filesystem::path& manifest,
                                                   const CollectionManifest& m);

/// Writes the manifest atomically (atomic_file.hpp). Throws InputError.
void write_collection_manifest(const std::filesystem::path& path, const CollectionManifest& m);

}  // namespace mocap
