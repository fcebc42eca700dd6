// Searching a sharded collection (collection_search.hpp).
#include "mocap/search/collection_search.hpp"

#include <algorithm>
#include <limits>

#include "mocap/common/collection_manifest.hpp"
#include "mocap/common/error.hpp"
#include "mocap/common/index.hpp"

namespace mocap {

std::vector<QueryOutcome> merge_shard_outcomes(
    const std::vector<std::vector<QueryOutcome>>& per_shard,
    const std::vector<std::size_t>& clip_offsets, const std::vector<BatchEntry>& batch) {
  std::vector<QueryOutcome> out;
  for (std::size_t q = 0; q < batch.size(); ++q) {
    QueryOutcome merged;
    merged.id = per_shard.front()[q].id;
    for (const auto& shard : per_shard)
      if (shard[q].error) {
        merged.error = shard[q].error;
        break;
      }
    if (merged.error) {
      out.push_back(std::move(merged));
      continue;
    }
    const std::size_t top = batch[q].query ? batch[q].query->top : 0;
    merged.pairs = per_shard.front()[q].pairs;
    for (std::size_t h = 0; h < merged.pairs.size(); ++h) {
      std::vector<SearchResult>& all = merged.pairs[h].results;
      all.clear();
      for (std::size_t k = 0; k < per_shard.size(); ++k)
        for (SearchResult r : per_shard[k][q].pairs[h].results) {
          r.clip_index += clip_offsets[k];
          all.push_back(std::move(r));
        }
      std::sort(all.begin(), all.end(), [](const SearchResult& x, const SearchResult& y) {
        if (x.score_J != y.score_J) return x.score_J < y.score_J;
        if (x.clip_index != y.clip_index) return x.clip_index < y.clip_index;
        if (x.end_frame != y.end_frame) return x.end_frame < y.end_frame;
        return x.start_frame < y.start_frame;
      });
      if (all.size() > top) all.resize(top);
      for (std::size_t i = 0; i < all.size(); ++i) all[i].rank = i + 1;
    }
    for (const auto& shard : per_shard) {
      const SearchStats& s = shard[q].stats;
      merged.stats.clips += s.clips;
      merged.stats.clips_pruned += s.clips_pruned;
      merged.stats.frames_evaluated += s.frames_evaluated;
      merged.stats.frames_pruned += s.frames_pruned;
      merged.stats.time_ms += s.time_ms;
    }
    out.push_back(std::move(merged));
  }
  return out;
}

std::vector<QueryOutcome> run_collection_batch(
    const std::filesystem::path& manifest, const std::vector<BatchEntry>& batch,
    const SearchOptions& options, const std::function<void(std::size_t, std::size_t)>& progress) {
  const CollectionManifest m = read_collection_manifest(manifest);
  if (const auto problems = collection_shard_problems(manifest, m); !problems.empty())
    throw InputError(manifest.string(), 0, problems.front());
  // The shards searched so far, merged (their clip indices the collection's).
  std::vector<QueryOutcome> merged;
  // Per query and pair, the r-th best score of the shards searched so far:
  // a later shard's clips rank after theirs at equal scores, so it need not
  // find results at or above it (SearchEngine::run's ceilings).
  std::vector<std::vector<double>> ceilings(batch.size());
  std::size_t offset = 0, done_before = 0;
  const std::size_t total = batch.size() * m.shards.size();
  for (const CollectionShard& s : m.shards) {
    const Index index = Index::open(shard_file(manifest, s));
    if (index.clips().size() != s.clips)
      throw InputError(manifest.string(), 0,
                       "shard " + s.path + ": holds " + std::to_string(index.clips().size()) +
                           " clips, the manifest says " + std::to_string(s.clips));
    const SearchEngine engine(index);
    std::function<void(std::size_t, std::size_t)> shard_progress;
    if (progress)
      shard_progress = [&](std::size_t done, std::size_t) { progress(done_before + done, total); };
    std::vector<QueryOutcome> shard =
        run_query_batch(engine, batch, options, shard_progress, &ceilings);
    merged = merged.empty()
                 ? merge_shard_outcomes({std::move(shard)}, {offset}, batch)
                 : merge_shard_outcomes({std::move(merged), std::move(shard)}, {0, offset}, batch);
    offset += s.clips;
    done_before += batch.size();
    for (std::size_t q = 0; q < batch.size(); ++q) {
      ceilings[q].assign(merged[q].pairs.size(), std::numeric_limits<double>::infinity());
      const std::size_t top = batch[q].query ? batch[q].query->top : 0;
      for (std::size_t h = 0; h < merged[q].pairs.size(); ++h)
        if (top > 0 && merged[q].pairs[h].results.size() >= top)
          ceilings[q][h] = merged[q].pairs[h].results[top - 1].score_J;
    }
  }
  return merged;
}

}  // namespace mocap
