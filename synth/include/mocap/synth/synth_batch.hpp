#pragma once
// Batch synthesis (mocap-synth --queries, Python Index.synthesize_batch;
// docs/cli.md "mocap-synth", docs/python.md): the queries of a batch are
// prepared for filling (query_for_fill), searched together on one open index
// or collection (or read from one results file), then synthesised in
// parallel, each query handed to the caller as soon as it is done, so that
// no more motions are held than there are threads.
//
// A query that cannot be made (a line that does not parse, a search error,
// a synthesis error, an output the caller refuses) fails alone: it carries
// its InputError and the batch goes on. The motions do not depend on the
// thread count nor on the order queries finish in: each is the motion that
// synthesize() makes of its query alone (the same as mocap-synth --query
// Q.jsonl --id ID with the same options).
#include <cstddef>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "mocap/common/motion/clip_source.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/search/query.hpp"
#include "mocap/search/search.hpp"
#include "mocap/synth/synth_job.hpp"

namespace mocap {

/// One query of a batch, as synthesis takes it.
struct SynthBatchQuery {
  /// The query's id (its "id", else the batch's default id, "line N").
  std::string id;
  /// 1-based line of the batch file that holds it (0: not from a file).
  std::size_t line = 0;
  /// The query as synthesis searches it (query_for_fill); unset when the
  /// query failed before synthesis (its `error`).
  std::optional<Query> query;
  /// The ranked partial motions per pair (search_synth_batch or
  /// synth_batch_results_file), H - 1 of them.
  std::vector<PairResults> ranked;
  /// The query's share of the search: its own search time for an index
  /// file, the collection search's time over the batch's queries for a
  /// collection, 0 for results read from a file. Milliseconds.
  double search_ms = 0.0;
  /// Why the query cannot be made (first failure wins); unset: not failed.
  std::optional<InputError> error;
};

/// The batch's entries (read_query_batch, parse_batch_entry) as synthesis
/// queries, in the same order: each parsed query through
/// query_for_fill(options); an entry that failed to parse keeps its
/// InputError, and query_for_fill's InputError becomes its query's error.
/// Never throws InputError.
std::vector<SynthBatchQuery> synth_batch_queries(const std::vector<BatchEntry>& entries,
                                                 const SynthOptions& options);

/// The search options mocap-synth runs its own search with (no --results):
/// the defaults, and `style_model` (SynthOptions::style_model), which a
/// query asking for a style ("style"; docs/style.md) needs.
SearchOptions synth_search_options(const std::shared_ptr<const StyleModel>& style_model);

/// The collection search of `entries` over the shards `clips` (a
/// collection) has already checked and opened, numbered as one index
/// (search_shards with the default SearchOptions and `style_model`, which
/// queries asking for a style need): what mocap-synth runs for a collection
/// without --results, one query or a batch.
std::vector<QueryOutcome> search_collection(
    const ClipSource& clips, const std::vector<BatchEntry>& entries,
    const std::shared_ptr<const StyleModel>& style_model = nullptr);

/// Searches every query that has not failed, in one batch, with the default
/// SearchOptions and `style_model` (SynthOptions::style_model: a query's
/// "style" needs it; docs/style.md) (what mocap-synth runs without
/// --results): run_query_batch
/// on `engine` (or an engine built here on `clips`' index when null) for an
/// index file, search_shards over the already opened shards for a
/// collection. A query the search cannot answer fails with
/// InputError("<query ID>", 0, "search failed: ..."). Throws InputError as
/// the search does for a shard it cannot read.
void search_synth_batch(const ClipSource& clips, std::vector<SynthBatchQuery>& queries,
                        const SearchEngine* engine = nullptr,
                        const std::shared_ptr<const StyleModel>& style_model = nullptr);

/// The ranked pairs of every query that has not failed, from one
/// mocap-search results file read once (read_results_file; the first line
/// with the query's id). A query without a line, or whose line holds an
/// "error", fails (InputError(path, 0, ...)). Throws InputError when the
/// file cannot be read or a line's results do not fit `clips`.
void synth_batch_results_file(const std::filesystem::path& path, const ClipSource& clips,
                              std::vector<SynthBatchQuery>& queries);

/// A synthesised motion and the target skeleton it points at
/// (result.skeleton is &*skeleton): held by pointer, never copied.
struct SynthMotion {
  std::optional<SynthSkeleton> skeleton;
  SynthResult result;
};

/// What run_synth_batch hands over for one query.
struct SynthBatchDone {
  /// Position of the query in the batch (0-based).
  std::size_t index = 0;
  const SynthBatchQuery* query = nullptr;
  /// The motion (null when the query failed: `error`). The callback may keep
  /// it (std::move); otherwise it is freed when the callback returns.
  std::unique_ptr<SynthMotion> motion;
  /// Why the query failed: its earlier error, or synthesize's.
  std::optional<InputError> error;
  /// Milliseconds the synthesis took (0 for a query that failed before it).
  double synth_ms = 0.0;
};

/// Synthesises every query that has not failed (synthesize with `options`),
/// in parallel (TBB over queries, grain 1; each query's gaps in parallel
/// too), and calls done(item) once per query of the batch, failed ones
/// included: from worker threads, concurrently, as each query finishes (the
/// order is not the batch's), so `done` must be thread-safe. An exception
/// of synthesize becomes the query's error (an InputError as thrown, any
/// other as InputError("<query ID>", 0, what)); an exception thrown by
/// `done` ends the batch (rethrown here once the running queries are done).
void run_synth_batch(const ClipSource& clips, const std::vector<SynthBatchQuery>& queries,
                     const SynthOptions& options, const std::function<void(SynthBatchDone&)>& done);

}  // namespace mocap
