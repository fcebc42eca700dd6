#pragma once
// Searching a sharded collection (docs/index-format.md "Collections") in one
// process: every shard answers the batch with its own engine, and the
// per-pair top-r lists are merged by the single index's ranking (score, then
// clip index, then e, then s), clip indices numbered as in one index of the
// same files. The results equal a single index's (docs/search.md
// "Collections").
#include <cstddef>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "mocap/common/io/collection_manifest.hpp"
#include "mocap/search/query_validation.hpp"
#include "mocap/search/search.hpp"

namespace mocap {

/// Merges the outcomes of the shards (shard k's clip c is clip
/// clip_offsets[k] + c): per query, the first shard's error if any shard
/// failed it; else per pair the best `top` results of all shards, ranked
/// again; stats summed; recall left out (approx mode measures it per shard).
std::vector<QueryOutcome> merge_shard_outcomes(
    const std::vector<std::vector<QueryOutcome>>& per_shard,
    const std::vector<std::size_t>& clip_offsets, const std::vector<BatchEntry>& batch);

/// One index to search as part of a collection: its file, the manifest's
/// name and clip count for it (checked when it is opened; nullopt: not
/// checked, a plain index), and the collection index of its first clip.
/// `open`: the index already opened by the caller (it must outlive the
/// search); the file is then neither opened nor checked again.
struct ShardSource {
  std::filesystem::path file;
  std::string name;
  std::optional<std::size_t> clips;
  std::size_t clip_offset = 0;
  const Index* open = nullptr;
  /// The manifest's entry (its counts checked against the shard's index:
  /// shard_count_problem); none for a single index.
  std::optional<CollectionShard> listed = std::nullopt;
};

/// The union of the shards' label values (add_label_values): from the
/// index when `open`, else from the file, opened for it and closed (its clip
/// count checked as search_shards checks it). Throws InputError as Index::open.
LabelValues shard_label_values(const std::vector<ShardSource>& shards);

/// How search_shards shares thresholds with searches elsewhere (other MPI
/// ranks). Optional members; the results do not depend on them.
struct ShardHooks {
  /// Per entry, per pair, the r-th best score found elsewhere (+inf: none),
  /// asked when the entry starts on a shard (shared_ceiling, distributed.hpp).
  std::function<std::vector<double>(std::size_t)> shared;
  /// Told, per entry and pair, an r-th best score found here (after each
  /// shard): a ceiling valid for the whole collection. From worker threads.
  std::function<void(std::size_t, const std::vector<double>&)> reached;
  /// BatchControl::first.
  std::size_t first = 0;
  /// The label values of the whole collection, when the shards given are
  /// only part of it (other ranks search the rest); null: the union of the
  /// given shards'. Query filters are checked against them (SearchEngine).
  const LabelValues* labels = nullptr;
};

/// Opens the shards one at a time, in the order given (which must be their
/// clip order), answers the batch on each (run_query_batch) pruning against
/// the r-th best of the shards before it, and merges. A query's filter is
/// checked against the label values of all the shards (or hooks.labels), so
/// that it names a label some shard holds: the shards not open yet are
/// opened first for their labels (a single shard is not). Throws InputError for
/// a shard that cannot be opened or whose clip count is not the manifest's.
/// `progress(done, total)` counts the queries of every shard.
std::vector<QueryOutcome> search_shards(
    const std::vector<ShardSource>& shards, const std::vector<BatchEntry>& batch,
    const SearchOptions& options, const ShardHooks& hooks = {},
    const std::function<void(std::size_t, std::size_t)>& progress = {});

/// The manifest's shards as sources, in manifest order (all of them, or
/// those listed in `which`).
std::vector<ShardSource> manifest_shards(const std::filesystem::path& manifest,
                                         const CollectionManifest& m,
                                         const std::vector<std::size_t>* which = nullptr);

/// Opens every shard of the manifest (InputError naming a missing or
/// changed shard, before any query runs) and runs the batch on each
/// (run_query_batch), then merges. `progress(done, total)` counts the
/// queries of every shard.
std::vector<QueryOutcome> run_collection_batch(
    const std::filesystem::path& manifest, const std::vector<BatchEntry>& batch,
    const SearchOptions& options,
    const std::function<void(std::size_t, std::size_t)>& progress = {});

}  // namespace mocap
