// Batch synthesis: the batch's queries, their search (or results file) and
// their synthesis in parallel (synth_batch.hpp).
#include "mocap/synth/synth_batch.hpp"

#include <tbb/parallel_for.h>

#include <chrono>
#include <exception>
#include <mutex>
#include <unordered_map>
#include <utility>

#include "mocap/search/collection_search.hpp"
#include "mocap/search/results_file.hpp"

namespace mocap {
namespace {

using Clock = std::chrono::steady_clock;

double ms_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

// The queries still to make, as a search batch, and where each came from.
struct PendingBatch {
  std::vector<BatchEntry> entries;
  std::vector<std::size_t> from;  // entries[k] is queries[from[k]]
};

PendingBatch pending_batch(const std::vector<SynthBatchQuery>& queries) {
  PendingBatch p;
  for (std::size_t i = 0; i < queries.size(); ++i) {
    if (queries[i].error || !queries[i].query) continue;
    p.entries.push_back(BatchEntry{queries[i].id, queries[i].query, ""});
    p.from.push_back(i);
  }
  return p;
}

// An index file: one engine for the batch, each query's own search time
// measured from its start to its answer.
std::vector<QueryOutcome> search_index(const ClipSource& clips,
                                       const std::vector<BatchEntry>& entries,
                                       const SearchEngine* engine, const SearchOptions& options,
                                       std::vector<double>& times_ms) {
  std::optional<SearchEngine> own;
  if (!engine) engine = &own.emplace(clips.index(0));
  std::vector<Clock::time_point> started(entries.size());
  times_ms.assign(entries.size(), 0.0);
  BatchControl control;
  control.ceilings = [&](std::size_t i) {
    started[i] = Clock::now();
    return std::vector<double>{};
  };
  control.answered = [&](std::size_t i, const QueryOutcome&) {
    times_ms[i] = ms_between(started[i], Clock::now());
  };
  return run_query_batch(*engine, entries, options, control, {});
}

}  // namespace

SearchOptions synth_search_options(const std::shared_ptr<const StyleModel>& style_model) {
  SearchOptions options;
  options.style_model = style_model;
  return options;
}

std::vector<QueryOutcome> search_collection(const ClipSource& clips,
                                            const std::vector<BatchEntry>& entries,
                                            const std::shared_ptr<const StyleModel>& style_model) {
  std::vector<ShardSource> shards;
  std::size_t offset = 0;
  for (std::size_t k = 0; k < clips.index_count(); ++k) {
    shards.push_back({"", "", std::nullopt, offset, &clips.index(k)});
    offset += clips.index(k).clips().size();
  }
  return search_shards(shards, entries, synth_search_options(style_model));
}

std::vector<SynthBatchQuery> synth_batch_queries(const std::vector<BatchEntry>& entries,
                                                 const SynthOptions& options) {
  std::vector<SynthBatchQuery> out(entries.size());
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const BatchEntry& e = entries[i];
    SynthBatchQuery& q = out[i];
    q.id = e.id;
    q.line = e.line;
    if (!e.query) {
      q.error = e.failure.value_or(InputError("<query " + e.id + ">", e.line, e.error));
      continue;
    }
    try {
      q.query = query_for_fill(*e.query, options);
    } catch (const InputError& err) {
      q.error = err;
    }
  }
  return out;
}

void search_synth_batch(const ClipSource& clips, std::vector<SynthBatchQuery>& queries,
                        const SearchEngine* engine,
                        const std::shared_ptr<const StyleModel>& style_model) {
  const PendingBatch pending = pending_batch(queries);
  if (pending.entries.empty()) return;
  const auto t0 = Clock::now();
  std::vector<double> times_ms;
  std::vector<QueryOutcome> outcomes =
      clips.is_collection() ? search_collection(clips, pending.entries, style_model)
                            : search_index(clips, pending.entries, engine,
                                           synth_search_options(style_model), times_ms);
  const double mean_ms = ms_between(t0, Clock::now()) / static_cast<double>(outcomes.size());
  for (std::size_t k = 0; k < outcomes.size(); ++k) {
    SynthBatchQuery& q = queries[pending.from[k]];
    q.search_ms = times_ms.empty() ? mean_ms : times_ms[k];
    if (outcomes[k].error)
      q.error = InputError("<query " + q.id + ">", 0, "search failed: " + *outcomes[k].error);
    else
      q.ranked = std::move(outcomes[k].pairs);
  }
}

void synth_batch_results_file(const std::filesystem::path& path, const ClipSource& clips,
                              std::vector<SynthBatchQuery>& queries) {
  std::vector<ResultsLine> lines = read_results_file(path, clips);
  std::unordered_map<std::string, std::size_t> first;  // id -> its first line
  for (std::size_t k = 0; k < lines.size(); ++k) first.emplace(lines[k].id, k);
  for (SynthBatchQuery& q : queries) {
    if (q.error || !q.query) continue;
    const auto at = first.find(q.id);
    if (at == first.end())
      q.error = InputError(path.string(), 0, "no results for query \"" + q.id + "\"");
    else if (!lines[at->second].error.empty())
      q.error = InputError(path.string(), 0,
                           "the search failed for this query: " + lines[at->second].error);
    else
      q.ranked = lines[at->second].pairs;  // a copy: ids may repeat in the batch
  }
}

void run_synth_batch(const ClipSource& clips, const std::vector<SynthBatchQuery>& queries,
                     const SynthOptions& options,
                     const std::function<void(SynthBatchDone&)>& done) {
  std::exception_ptr stop;
  std::mutex stop_mutex;
  // Grain 1: a query is seconds of work, and queries differ widely.
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, queries.size(), 1),
      [&](const tbb::blocked_range<std::size_t>& range) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          {
            const std::lock_guard<std::mutex> lock(stop_mutex);
            if (stop) return;
          }
          const SynthBatchQuery& q = queries[i];
          SynthBatchDone item;
          item.index = i;
          item.query = &q;
          item.error = q.error;
          if (!item.error) {
            const auto t0 = Clock::now();
            try {
              auto motion = std::make_unique<SynthMotion>();
              motion->result = synthesize(clips, *q.query, q.ranked, options, motion->skeleton);
              item.motion = std::move(motion);
            } catch (const InputError& e) {
              item.error = e;
            } catch (const std::exception& e) {
              item.error = InputError("<query " + q.id + ">", 0, e.what());
            }
            item.synth_ms = ms_between(t0, Clock::now());
          }
          try {
            done(item);
          } catch (...) {
            const std::lock_guard<std::mutex> lock(stop_mutex);
            if (!stop) stop = std::current_exception();
          }
        }
      },
      tbb::simple_partitioner());
  if (stop) std::rethrow_exception(stop);
}

}  // namespace mocap
