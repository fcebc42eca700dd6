#pragma once
// Retrieval of partial motions (paper section 2.3; docs/search.md).
//
// A SearchEngine is built once from an opened Index and answers queries
// (query.hpp) concurrently: `run` is const and thread-safe; every call uses
// its own scratch. For each consecutive pair of query frames {Q^h, Q^h+1}
// and each clip F^1..F^K it finds the partial motion F^s..F^e (s < e, within
// the length limits) that
// minimises
//
//   score = h(Q^h -> F^s) + h(F^e -> Q^h+1) + lambda * (P[e] - P[s])      (joules)
//
// (h: energy.hpp approximate energy for the query's character, by default
// the index's, with the query's transition time; P: the clip's own energy prefix sums; lambda:
// Query::path_weight), ranks clips by that score and keeps the `top` best.
// Ties are broken by clip index, then end frame, then start frame, so the
// answer is a function of the query and the index only: it is the same in
// every mode that is exact (brute, exact) and for any number of threads.
//
// Modes:
//  - brute: every frame of every clip (the reference);
//  - exact (default): the same answer, skipping groups of clips, clips and
//    16-frame blocks whose lower bounds (docs/search.md proves them) cannot
//    beat the current r-th best score;
//  - approx: FLANN randomised kd-trees over the per-frame kd features pick
//    candidate clips (bounded checks); only those are scored. Queries without
//    a full query frame on both sides of a pair fall back to exact. The
//    recall of the top r against exact is computed per query (exact is run
//    too, which doubles the cost; SearchOptions::compute_recall).
//
// Relative placements (Query::placement, docs/queries.md "Placement"): the
// pair's query frames are put in the body frame of Q^h and placed with F^s's
// root ground pose (its heading too under "relative": true), so
// h(F^e -> Q^h+1) depends on s and a clip costs O(K L) with
// L = max_length_s / frame time; exact mode bounds both terms by what does
// not depend on placement (docs/search.md "Relative placements").
// Every placement keeps min_length_s <= e - s <= max_length_s (in frames).
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "mocap/common/io/index.hpp"
#include "mocap/common/motion/style.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/search/query.hpp"
#include "mocap/search/query_validation.hpp"

namespace mocap {

enum class SearchMode : std::uint8_t { exact, approx, brute };
const char* search_mode_name(SearchMode m);
/// "exact", "approx", "brute"; nullopt otherwise.
std::optional<SearchMode> parse_search_mode(const std::string& s);

struct SearchOptions {
  SearchMode mode = SearchMode::exact;
  /// approx: randomised kd-trees per skeleton (FLANN KDTreeIndexParams).
  int approx_trees = 4;
  /// approx: leaves visited per kd-tree search (FLANN SearchParams checks).
  int approx_checks = 256;
  /// approx: nearest frames asked for per query frame, per kept result
  /// (k = approx_neighbours_per_result * top); their clips are the candidates.
  int approx_neighbours_per_result = 32;
  /// approx: also run exact and report recall (top-r overlap) per query.
  bool compute_recall = true;
  /// Shortest and longest partial motion, seconds, in every placement:
  /// round(min_length_s / frame time) <= e - s <= round(max_length_s / frame
  /// time), the lower limit at least 1 frame (so s < e). A query's own
  /// min_length_s / max_length_s replace them. 0 < min_length_s <= max_length_s.
  double min_length_s = 0.2;
  double max_length_s = 4.0;
  /// Parallelise over clips inside one query (TBB); results do not depend on it.
  bool parallel_clips = true;
  /// The style model queries with a "style" need (docs/style.md "Asking for
  /// a style"); null: such a query fails.
  std::shared_ptr<const StyleModel> style_model;
};

/// Checks the options' ranges (0 < min_length_s <= max_length_s): values a
/// user gives, so an invalid one throws InputError naming where it came from
/// (`min_name`, `max_name`: the command line's flags, or Python's keywords)
/// and the value. SearchEngine::run and run_query_batch call it.
void validate_search_options(const SearchOptions& options,
                             const std::string& min_name = "--min-length",
                             const std::string& max_name = "--max-length");

/// A result's frame measured against one named constraint of its query
/// frame (docs/queries.md "Residuals and verdicts").
struct ConstraintResidual {
  std::string name;  // as the query wrote it
  /// How far the frame is from the target (constraint_residual): metres for
  /// effectors, degrees for directions, angles and joint rotations.
  double residual = 0.0;
  /// The query's tolerance, in the residual's unit (0 when none was given).
  double tolerance = 0.0;
  bool metres = false;  // an effector (metres); otherwise degrees
  /// The limit the verdict uses: the tolerance, but at least the verdict's
  /// floor (kMetFloorM, kMetFloorDeg), so that "exactly" allows round-off.
  double limit() const;
  /// residual <= limit().
  bool met() const { return residual <= limit(); }
  bool operator==(const ConstraintResidual&) const = default;
};
/// The verdict's floors: a constraint given without a tolerance is met
/// within 1 cm (effectors) or 1 degree (the others).
inline constexpr double kMetFloorM = 0.01;
inline constexpr double kMetFloorDeg = 1.0;

/// One ranked partial motion. Frames are 0-based within the clip.
struct SearchResult {
  std::size_t rank = 0;        // 1-based
  std::size_t clip_index = 0;  // into Index::clips()
  std::string clip;            // the clip's path as indexed
  /// (key, label) for every index label key with a non-empty label.
  std::vector<std::pair<std::string, std::string>> labels;
  std::size_t start_frame = 0;  // s
  std::size_t end_frame = 0;    // e > s
  double score_J = 0.0;         // h_in + h_out + lambda * path_cost (as computed)
  double h_in_J = 0.0;          // h(Q^h -> F^s)
  double h_out_J = 0.0;         // h(F^e -> Q^h+1)
  double path_cost_J = 0.0;     // P[e] - P[s], the clip's own energy (lambda not applied)
  /// The context energies in score_J (docs/queries.md "Context frames"),
  /// weighted: Q^h's frames before it against F^s and before, Q^h+1's after
  /// it against F^e and after; 0 without context. h_in_J and h_out_J do not
  /// include them.
  double context_in_J = 0.0;
  double context_out_J = 0.0;
  /// A frame of the pair gives context (the JSON then has both fields).
  bool context = false;
  /// The style the partial motion is recognised as, and its probability
  /// (mocap-search --style-model; docs/style.md); empty: not asked, or the
  /// motion could not be read as the model's (fewer than 4 frames, another rig).
  std::string recognised_style;
  double recognised_style_p = 0.0;
  /// The query's style term in score_J (weight x the clip's style distance,
  /// docs/style.md "Asking for a style"), with `style` set; h_in_J does not
  /// include it.
  double style_J = 0.0;
  bool style = false;
  /// How far F^s misses each named constraint of Q^h (residuals_from) and
  /// F^e each of Q^h+1 (residuals_to), by name: metres for effectors,
  /// degrees for joint rotations, directions and angles
  /// (constraint_residual), with the tolerance and verdict. Empty for
  /// frames without named constraints.
  std::vector<ConstraintResidual> residuals_from, residuals_to;
  /// Every named constraint of both frames met (true without any).
  bool met() const;
  /// The sum over both frames of residual / limit(): how far the result is
  /// from the request in units of what it accepts; 0 without constraints.
  /// Results of equal score rank by it (docs/queries.md "Ranking").
  double misfit() const;
};

struct PairResults {
  std::size_t from = 0;               // query frame index h (0-based)
  std::size_t to = 0;                 // h + 1
  std::vector<SearchResult> results;  // best first, at most Query::top
};

struct SearchStats {
  /// Clips that passed the filter (summed over pairs).
  std::uint64_t clips = 0;
  /// Of those, clips skipped by a bound (never scored in full).
  std::uint64_t clips_pruned = 0;
  /// h evaluations (query frame x database frame).
  std::uint64_t frames_evaluated = 0;
  /// Frame evaluations skipped by bounds (2 per frame per pair in world mode).
  std::uint64_t frames_pruned = 0;
  double time_ms = 0.0;
  /// approx with compute_recall: |top-r approx  intersect  top-r exact| / r,
  /// averaged over pairs, clips compared by index.
  std::optional<double> recall;
};

/// One answered (or failed) query.
struct QueryOutcome {
  std::string id;
  std::vector<PairResults> pairs;
  SearchStats stats;
  /// Set when the query could not be answered; pairs is then empty.
  std::optional<std::string> error;
  /// What the query may not mean as written (joint_name_warnings:
  /// "frames[i].joints.NAME: read as ..."), each once; the JSON line's
  /// "warnings" when not empty.
  std::vector<std::string> warnings;
};

/// SearchEngine::frame_bounds: per frame F of one skeleton (index order of
/// its frames), for one query frame Q^i, in joules.
struct FrameBounds {
  /// The lower bound of h(Q^i -> F) that exact mode uses: the greatest of its
  /// group's and clip's box and sketch-range bounds, 16-frame block boxes,
  /// whole-body and chain sketches of full frames, per-frame bounds of partial
  /// frames (docs/search.md).
  std::vector<double> lower;
  /// h itself, the reference: the h scan for full and root-only frames,
  /// partial_approximate_energy for partial ones.
  std::vector<double> h;
  /// The values the search ranks by (every mode): equal to `h` except for
  /// partial frames giving joint rotations only, which the engine evaluates
  /// with its own subtree kernel (docs/search.md "Joint-rotation frames").
  std::vector<double> engine_h;
  /// Full frames: the per-frame whole-body sketch bound alone, and the chain
  /// sketch bound alone, that the scans use as a filter (docs/search.md
  /// "Chain sketches"); 0 for other frames.
  std::vector<double> sketch_lower, chain_lower;
  /// Partial frames: the per-frame partial bound alone as the engine computes
  /// it (for joint-rotation frames in float from per-joint columns;
  /// docs/search.md "Partial queries"), and as the double reference computes
  /// it; 0 for other frames.
  std::vector<double> partial_lower, partial_reference;
  /// Root-only frames, frames giving the root heading and no joint
  /// rotations, and frames giving root position components and joint
  /// rotations: the per-frame root bound of relative placements
  /// (docs/search.md "Root-only frames", "Turning frames"), for the frame
  /// placed as written; 0 for other frames.
  std::vector<double> root_lower;
};

/// The engine: per-skeleton tables (h scan table transposed from the index,
/// the same in 16-frame tiles, kd features, box bounds per group of clips,
/// clip and 16-frame block, computed from the scan table) built once; FLANN
/// trees built on the first approx query of a skeleton. A query naming a
/// character other than the index's gets tables recomputed for it, built once
/// per engine and character (at most 4 kept) and shared by the queries that
/// name it. Holds a reference to `index`, which must outlive it.
class SearchEngine {
 public:
  explicit SearchEngine(const Index& index);
  /// The same, checking the label values of query filters against
  /// `filter_labels` (messages: "the collection has: ...") instead of the
  /// index's own: the engine of one shard of a collection, whose queries may
  /// name labels that only other shards' clips carry (collection_search.hpp).
  SearchEngine(const Index& index, LabelValues filter_labels);
  SearchEngine(SearchEngine&&) noexcept;
  ~SearchEngine();

  const Index& index() const;

  /// Answers one query. Throws InputError for a query that does not fit the
  /// index (a filter label value no clip carries: check_filter_labels;
  /// unknown joint: the message lists the valid names; unreadable BVH; frame
  /// out of range; an unreadable or invalid character file; order:
  /// query_validation.hpp), and
  /// for invalid options (validate_search_options).
  QueryOutcome run(const Query& query, const SearchOptions& options) const;
  /// The same with, per pair, a score `ceilings[h]` the results need not
  /// reach (exact mode only; brute and approx ignore it): the other shards
  /// of a collection already hold `top` results that rank before any of
  /// this index's scoring that much or more (collection_search.hpp). The
  /// search prunes against it from the start; a pair may then return fewer
  /// than `top` results, and some at or above the ceiling.
  QueryOutcome run(const Query& query, const SearchOptions& options,
                   const std::vector<double>* ceilings) const;

  /// Loads up front what queries will need and run() would otherwise load on
  /// first use (shared by all later queries): with `whole_body_frames`, the
  /// per-frame arrays that partial frames moving the whole body read (a
  /// heading, a root position with joint rotations); in approx mode, the FLANN
  /// forests. A batch calls it before its first query, so that each query's
  /// stats.time_ms is the query alone. (Frames giving joint rotations alone
  /// read per-joint columns of those arrays, streamed from the index the first
  /// time a query needs a joint: that query's time includes it, about 0.1 s on
  /// set 2.) Thread-safe; idempotent.
  void prepare(const SearchOptions& options, bool whole_body_frames) const;

  /// Diagnostics and tests: the bounds exact mode uses for query frame `i` of
  /// `query` (world mode) on skeleton `k`, and h itself, for every frame of the
  /// skeleton (FrameBounds). Throws std::invalid_argument when there is no such
  /// skeleton or frame, InputError as run() for a frame that does not fit.
  FrameBounds frame_bounds(const Query& query, std::size_t i, std::size_t k) const;

  /// Internal tables (search/src/engine/search_engine_impl.hpp).
  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

/// One line of a batch: a parsed query, or why the line could not be parsed.
struct BatchEntry {
  std::string id;
  std::optional<Query> query;
  /// Without a query: the InputError's message (source:line: what), and the
  /// error itself (rethrown where one query was asked for: read_query_file).
  std::string error;
  std::optional<InputError> failure = std::nullopt;
  /// The 1-based line of the batch file that holds it (0: not a file's line).
  std::size_t line = 0;
};

/// Reads a JSONL batch: one query per non-blank line (default id "line N",
/// N 1-based); lines that fail to parse become entries with `error`. Lines
/// that are invalid JSON alone but make one JSON object together (a query
/// written over several lines) each get an error naming those lines and the
/// fix (one query per line, or --query).
/// Throws InputError when the file cannot be read at all.
std::vector<BatchEntry> read_query_batch(const std::filesystem::path& path);
/// The --queries batch `entries` read from `path`, refused when it holds no
/// query (an empty file, or blank lines only): InputError(path, 0, ...)
/// naming the fix, unless `allow_empty` (mocap-search and mocap-synth
/// --allow-empty).
std::vector<BatchEntry> require_queries(std::vector<BatchEntry> entries,
                                        const std::filesystem::path& path, bool allow_empty);
/// Reads one query from a JSON file (default id: the file stem).
std::vector<BatchEntry> read_single_query(const std::filesystem::path& path);

/// How a caller that shares pruning thresholds with other searches of the
/// same batch (the shards of a collection, other MPI ranks) steers
/// run_query_batch. The outcomes are the same whatever it does: a ceiling
/// only lets exact mode skip what cannot be among the merged top r.
struct BatchControl {
  /// Asked when entry i starts: its per-pair ceilings (SearchEngine::run;
  /// an empty vector: none). Called from worker threads, concurrently.
  std::function<std::vector<double>(std::size_t)> ceilings;
  /// Told once entry i is answered (or failed). Called from worker threads,
  /// concurrently.
  std::function<void(std::size_t, const QueryOutcome&)> answered;
  /// The entry the batch starts from, wrapping around: ranks that start
  /// from different entries find each other's thresholds for the entries
  /// they reach last. Order only: outcomes stay in input order.
  std::size_t first = 0;
};

/// Runs a batch in parallel (TBB over queries, and over clips inside each);
/// outcomes are in input order. A query that fails (InputError or another
/// exception) gets its `error` and the batch goes on; invalid options throw
/// std::invalid_argument before any query runs. `progress(done, total)` (optional) is called
/// from worker threads after each query, serialised.
/// `ceilings` (optional): per batch entry, SearchEngine::run's per-pair ceilings.
std::vector<QueryOutcome> run_query_batch(
    const SearchEngine& engine, const std::vector<BatchEntry>& batch, const SearchOptions& options,
    const std::function<void(std::size_t, std::size_t)>& progress = {},
    const std::vector<std::vector<double>>* ceilings = nullptr);
/// The same, steered by `control`.
std::vector<QueryOutcome> run_query_batch(
    const SearchEngine& engine, const std::vector<BatchEntry>& batch, const SearchOptions& options,
    const BatchControl& control, const std::function<void(std::size_t, std::size_t)>& progress);

/// The contract line: {"id", "pairs": [...], "stats": {...}} or {"id", "error"}.
std::string query_outcome_json(const QueryOutcome& outcome);

// ---------------------------------------------------------------------------
// Building blocks (exposed for tests and the benchmark)

/// Best pair of one clip by a sliding-window minimum (world mode):
///   score(e) = (b(e) + lambda P[e]) + min_{e - max_gap <= s <= e - min_gap} (a(s) - lambda P[s]),
/// over frames whose a / b are finite (+inf = excluded), so that
/// min_gap <= e - s <= max_gap (frames: the search passes the length limits
/// of SearchOptions / Query, round(seconds / frame time)). Ties: smallest score, then
/// smallest e, then smallest s. Returns false when no pair within the limits
/// has both values finite. O(K). Throws std::invalid_argument unless
/// 1 <= min_gap <= max_gap.
struct ClipBest {
  double score = 0.0;
  std::size_t s = 0, e = 0;
};
bool best_partial_motion(const double* a, const double* b, const double* prefix, std::size_t k,
                         double lambda, std::size_t min_gap, std::size_t max_gap, ClipBest& out);
/// The O(K^2) reference of best_partial_motion (same arithmetic, same ties).
bool best_partial_motion_quadratic(const double* a, const double* b, const double* prefix,
                                   std::size_t k, double lambda, std::size_t min_gap,
                                   std::size_t max_gap, ClipBest& out);

}  // namespace mocap
