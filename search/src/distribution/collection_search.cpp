// Searching a sharded collection (collection_search.hpp).
#include "mocap/search/collection_search.hpp"

#include <algorithm>
#include <limits>

#include "engine/ranking.hpp"
#include "mocap/common/io/collection_manifest.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/search/distributed.hpp"

namespace mocap {

namespace {
constexpr double kNoCeiling = std::numeric_limits<double>::infinity();

void check_shard_clips(const ShardSource& s, const Index& index) {
  if (s.listed)
    if (const std::string p =
            shard_count_problem(*s.listed, index.clips().size(), index.frame_count());
        !p.empty())
      throw InputError(s.file.string(), 0, p);
  if (s.clips && index.clips().size() != *s.clips)
    throw InputError(s.file.string(), 0,
                     "shard " + s.name + ": holds " + std::to_string(index.clips().size()) +
                         " clips, the manifest says " + std::to_string(*s.clips));
}
}  // namespace

LabelValues shard_label_values(const std::vector<ShardSource>& shards) {
  LabelValues out;
  for (const ShardSource& s : shards) {
    if (s.open) {
      add_label_values(out, *s.open);
      continue;
    }
    const Index index = Index::open(s.file);
    check_shard_clips(s, index);
    add_label_values(out, index);
  }
  return out;
}

std::vector<QueryOutcome> merge_shard_outcomes(
    const std::vector<std::vector<QueryOutcome>>& per_shard,
    const std::vector<std::size_t>& clip_offsets, const std::vector<BatchEntry>& batch) {
  std::vector<QueryOutcome> out;
  for (std::size_t q = 0; q < batch.size(); ++q) {
    QueryOutcome merged;
    merged.id = per_shard.front()[q].id;
    for (const auto& shard : per_shard)
      for (const std::string& w : shard[q].warnings)
        if (std::find(merged.warnings.begin(), merged.warnings.end(), w) == merged.warnings.end())
          merged.warnings.push_back(w);
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
      // Each shard's results are its best under the query's ranking
      // (ranking.hpp), a total order on results: the best of their union
      // are the collection's.
      search_detail::rank_results(all, batch[q].query ? batch[q].query->met : MetPolicy::any, top);
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

std::vector<ShardSource> manifest_shards(const std::filesystem::path& manifest,
                                         const CollectionManifest& m,
                                         const std::vector<std::size_t>* which) {
  std::vector<ShardSource> out;
  std::size_t offset = 0;
  for (std::size_t k = 0; k < m.shards.size(); ++k) {
    const CollectionShard& s = m.shards[k];
    if (!which || std::find(which->begin(), which->end(), k) != which->end())
      out.push_back({shard_file(manifest, s), s.path, s.clips, offset, nullptr, s});
    offset += s.clips;
  }
  return out;
}

std::vector<QueryOutcome> search_shards(
    const std::vector<ShardSource>& shards, const std::vector<BatchEntry>& batch,
    const SearchOptions& options, const ShardHooks& hooks,
    const std::function<void(std::size_t, std::size_t)>& progress) {
  // The shards searched so far, merged (their clip indices the collection's).
  std::vector<QueryOutcome> merged;
  // Per query and pair, the r-th best score of the shards searched so far:
  // a later shard's clips rank after theirs at equal scores, so it need not
  // find results at or above it (SearchEngine::run's ceilings).
  std::vector<std::vector<double>> own(batch.size());
  std::size_t done_before = 0;
  // The labels query filters may name: every shard's (a single one's are its own).
  std::optional<LabelValues> labels;
  if (hooks.labels)
    labels = *hooks.labels;
  else if (shards.size() > 1)
    labels = shard_label_values(shards);
  for (const ShardSource& s : shards) {
    std::optional<Index> opened;
    const Index& index = s.open ? *s.open : opened.emplace(Index::open(s.file));
    check_shard_clips(s, index);
    const SearchEngine engine = labels ? SearchEngine(index, *labels) : SearchEngine(index);
    BatchControl control;
    control.first = hooks.first;
    control.ceilings = [&](std::size_t i) {
      std::vector<double> c = own[i];
      if (hooks.shared) {
        const std::vector<double> elsewhere = hooks.shared(i);
        c.resize(std::max(c.size(), elsewhere.size()), kNoCeiling);
        for (std::size_t h = 0; h < elsewhere.size(); ++h)
          c[h] = shared_ceiling(c[h], elsewhere[h]);
      }
      return c;
    };
    if (hooks.reached)
      control.answered = [&](std::size_t i, const QueryOutcome& o) {
        std::vector<double> r = rth_best_scores(o, batch[i].query ? batch[i].query->top : 0);
        for (std::size_t h = 0; h < r.size() && h < own[i].size(); ++h)
          r[h] = std::min(r[h], own[i][h]);
        hooks.reached(i, r);
      };
    std::function<void(std::size_t, std::size_t)> shard_progress;
    // In queries, not queries x shards: each shard answers every query.
    if (progress)
      shard_progress = [&](std::size_t done, std::size_t) {
        progress((done_before + done) / shards.size(), batch.size());
      };
    std::vector<QueryOutcome> shard =
        run_query_batch(engine, batch, options, control, shard_progress);
    merged = merged.empty() ? merge_shard_outcomes({std::move(shard)}, {s.clip_offset}, batch)
                            : merge_shard_outcomes({std::move(merged), std::move(shard)},
                                                   {0, s.clip_offset}, batch);
    done_before += batch.size();
    for (std::size_t q = 0; q < batch.size(); ++q)
      own[q] = rth_best_scores(merged[q], batch[q].query ? batch[q].query->top : 0);
  }
  return merged;
}

std::vector<QueryOutcome> run_collection_batch(
    const std::filesystem::path& manifest, const std::vector<BatchEntry>& batch,
    const SearchOptions& options, const std::function<void(std::size_t, std::size_t)>& progress) {
  const CollectionManifest m = read_collection_manifest(manifest);
  if (const auto problems = collection_shard_problems(manifest, m); !problems.empty())
    throw InputError(manifest.string(), 0, problems.front());
  return search_shards(manifest_shards(manifest, m), batch, options, {}, progress);
}

}  // namespace mocap
