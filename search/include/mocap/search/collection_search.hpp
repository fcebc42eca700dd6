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
#include <vector>

#include "mocap/search/search.hpp"

namespace mocap {

/// Merges the outcomes of the shards (shard k's clip c is clip
/// clip_offsets[k] + c): per query, the first shard's error if any shard
/// failed it; else per pair the best `top` results of all shards, ranked
/// again; stats summed; recall left out (approx mode measures it per shard).
std::vector<QueryOutcome> merge_shard_outcomes(
    const std::vector<std::vector<QueryOutcome>>& per_shard,
    const std::vector<std::size_t>& clip_offsets, const std::vector<BatchEntry>& batch);

/// Opens every shard of the manifest (InputError naming a missing or
/// changed shard, before any query runs) and runs the batch on each
/// (run_query_batch), then merges. `progress(done, total)` counts the
/// queries of every shard.
std::vector<QueryOutcome> run_collection_batch(
    const std::filesystem::path& manifest, const std::vector<BatchEntry>& batch,
    const SearchOptions& options,
    const std::function<void(std::size_t, std::size_t)>& progress = {});

}  // namespace mocap
