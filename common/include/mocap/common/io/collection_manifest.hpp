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
/// Most shards in one collection (mocap-index build --shards, and every reader).
inline constexpr std::size_t kMaxCollectionShards = 4096;

struct CollectionShard {
  /// As written in the manifest (relative to its folder, or absolute).
  std::string path;
  std::size_t clips = 0;
  std::uint64_t frames = 0;
  /// XXH64 of the shard file's bytes, 16 lower-case hex digits (the manifest
  /// may give them in either case).
  std::string xxh64;
};

struct CollectionManifest {
  std::vector<CollectionShard> shards;
};

/// True when `path` names a manifest rather than an index: its first
/// non-blank byte is '{' (an index starts with its binary user block).
bool is_collection_manifest(const std::filesystem::path& path);

/// Reads and checks a manifest (its size under --max-json-mib): format,
/// version, 1 to kMaxCollectionShards shards, every field present and of its
/// type (a path without NUL bytes; 16 hex digits in either case), each shard's
/// file listed once (links followed), clip counts whose sum fits 64 bits, and
/// a shard named STEM.shard-K-of-N.h5 (as build --shards names them) listed
/// K-th of N. Throws InputError(path, 0, "field: what was expected").
CollectionManifest read_collection_manifest(const std::filesystem::path& path);

/// The shard's file: its path resolved against the manifest's folder (the
/// folder of the file a symbolic link to the manifest leads to).
std::filesystem::path shard_file(const std::filesystem::path& manifest,
                                 const CollectionShard& shard);

/// "shard PATH: holds N clips, the manifest says M" (or the same of frames)
/// when a shard's index holds other counts than the manifest says; empty when
/// they agree. Every reader of a collection checks it (verify, info, search,
/// synthesis): the clips' numbering depends on the counts.
std::string shard_count_problem(const CollectionShard& shard, std::size_t clips,
                                std::uint64_t frames);

/// Problems of the shards on disk, one line each naming the shard: missing,
/// unreadable, or bytes that no longer hash to the manifest's xxh64. Empty
/// when every shard is as the manifest says.
std::vector<std::string> collection_shard_problems(const std::filesystem::path& manifest,
                                                   const CollectionManifest& m);

/// Writes the manifest atomically (atomic_file.hpp). Throws InputError.
void write_collection_manifest(const std::filesystem::path& path, const CollectionManifest& m);

}  // namespace mocap
