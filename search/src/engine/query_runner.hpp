#pragma once
// Internal to mocap_search: one query's run (SearchEngine::run). The runner
// holds the query frames resolved on every skeleton and what their pairs
// share (box-bound forms, per-frame bounds of partial frames, group and clip
// tile bounds, h values shared by neighbouring pairs); run_pair answers one
// pair {Q^h, Q^h+1}: candidate clips, groups of clips ordered by bound, a
// best-first seeding, then a (parallel) sweep of the groups with the clip
// scans (clip_scans.hpp). The answer does not depend on the order.
#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include "bounds/box_bounds.hpp"
#include "bounds/skeleton_tables.hpp"
#include "engine/search_engine_impl.hpp"
#include "mocap/search/query.hpp"
#include "mocap/search/search.hpp"
#include "query/resolved_frame.hpp"
#include "scan/clip_scans.hpp"
#include "scan/top_matches.hpp"

namespace mocap::search_detail {

// One pair's answer: its top matches (best first) and counters (time_ms unset).
struct PairRun {
  std::vector<ClipMatch> top;
  SearchStats stats;
};

class QueryRunner {
 public:
  // `skeletons`: the tables of the query's character (the engine's or a
  // query character's), one per index skeleton; all must outlive the runner.
  // `ceilings` (optional, one per pair): SearchEngine::run's.
  QueryRunner(const SearchEngine::Impl& engine, const Query& query, const SearchOptions& options,
              const std::vector<std::unique_ptr<SkeletonData>>& skeletons,
              const std::vector<double>* ceilings = nullptr);

  // The starting tau of pair h (+inf without ceilings, and for a pair with
  // named constraints, whose ranking is not by score alone).
  double ceiling(std::size_t h) const;

  // Whether a query frame of pair h has a named constraint (on any
  // skeleton; after prepare).
  bool named_constraints(std::size_t h) const;

  const Query& query() const { return q_; }

  // Joint names read as another body part than a rig carrying them names
  // (joint_name_warnings), over every frame and skeleton, each once.
  const std::vector<std::string>& warnings() const { return warnings_; }

  // The number of matches a pair keeps: the query's top unless set (the
  // deeper looks of a ranking by verdicts, SearchEngine::run).
  std::size_t top() const { return top_; }
  void set_top(std::size_t top) { top_ = top; }

  // Whether database frames that miss a named constraint of a query frame
  // score +inf (ResolvedFrame::require_met) in the following run_pair calls.
  void set_require_met(bool on);

  // Resolves every query frame on every skeleton, with what the engine
  // precomputes for them, and the per-frame bounds of partial frames (exact
  // and approx modes, world). Throws InputError for a query that does not
  // fit the index.
  void prepare();

  // The answer of pair h (query frames h, h + 1) in `mode` (approx falls back
  // to exact for pairs that are not two full frames, and in relative mode).
  PairRun run_pair(std::size_t h, SearchMode mode);

  // Each result's residuals (SearchResult::residuals_from / _to): the
  // named constraints of the pair's query frames measured on F^s and F^e.
  void add_residuals(PairResults& pair) const;

  // Each result's context energies (SearchResult::context_in_J / _out_J),
  // moved out of h_in_J and h_out_J; nothing for frames without context.
  void add_context_energies(PairResults& pair) const;

  // Each result's style term (SearchResult::style_J), moved out of h_in_J;
  // nothing for a query without "style".
  void add_style_energies(PairResults& pair) const;

 private:
  friend class PairSearch;

  // Query frame i's bounds on skeleton k over every group (group_bounds)
  // and over the clips of the groups opened so far (clip_tile_bounds),
  // computed once per query frame and shared by its two pairs, and by the
  // seeding and the sweep of a pair.
  struct FrameTiles {
    std::vector<float> groups;             // [group]
    std::vector<float> clips;              // [group][kLanes]
    std::vector<std::uint8_t> clips_done;  // [group]
  };

  // Whether pair h is placed relatively: a relative placement and a query
  // frame whose h depends on where it is placed (not joint rotations alone;
  // a pair of joint-rotation frames scores the same placed anywhere, and is
  // searched as in world mode, with its bounds).
  bool relative_pair(std::size_t h) const;
  // Whether every pair is placed relatively (no per-frame world bounds needed).
  bool all_relative() const;
  void prepare_caches();
  // A query with "style": style_rows_ from the options' style model
  // (InputError without one, or for a style the model lacks).
  void prepare_style();
  // Adds frame i's joint_name_warnings on skeleton k (and its file's, if any).
  void add_name_warnings(std::size_t k, std::size_t i, const QueryBvhFile* file);
  void compute_frame_bounds();
  FrameCache* cache_of(std::size_t k, std::size_t i);
  // Computes query frame i's group bounds on skeleton k if not done yet and
  // makes room for its clip tiles (one thread: before a pair's groups are
  // taken).
  const float* group_lbs(std::size_t k, std::size_t i);
  // Query frame i's bounds over the kLanes clips of group g of skeleton k
  // (after group_lbs(k, i); a group is opened by one thread at a time).
  const float* clip_lbs(std::size_t k, std::size_t i, std::size_t g);
  // Query frame i's per-frame lower bounds on skeleton k, or null.
  const double* frame_bounds_of(std::size_t k, std::size_t i) const;
  // Whether the clip passes the query's filter.
  bool passes(std::size_t clip) const;
  PairContext context(std::size_t k, std::size_t h, SearchMode mode);
  // Candidate clips (skeleton, row) of pair h for approx mode; nullopt = all.
  std::optional<std::vector<std::pair<std::size_t, std::size_t>>> approx_candidates(
      std::size_t h) const;

  const SearchEngine::Impl& engine_;
  const Query& q_;
  const SearchOptions& options_;
  const std::vector<std::unique_ptr<SkeletonData>>& skeletons_;
  const std::vector<double>* ceilings_ = nullptr;
  std::size_t top_;
  std::vector<std::string> warnings_;
  // resolved_[k][i]: query frame i on skeleton k; bounds_[k][i] its box-bound form.
  std::vector<std::vector<ResolvedFrame>> resolved_;
  // style_rows_[k][row]: the style term of the clip in row `row` of
  // skeleton k (weight x style distance, J); empty without "style".
  std::vector<std::vector<double>> style_rows_;
  std::vector<std::vector<BoundQuery>> bounds_;
  // cache_[k][i]: values of query frame i shared by pairs i-1 and i (world
  // mode, interior frames of queries with 3 or more frames); empty otherwise.
  std::vector<std::vector<FrameCache>> cache_;
  std::vector<std::vector<FrameTiles>> tiles_;
  // frame_lb_[k][i]: per skeleton frame lower bound of h(query frame i -> F)
  // for partial query frames (exact mode, world), computed once per query
  // frame and shared by its two pairs; empty otherwise.
  std::vector<std::vector<std::vector<double>>> frame_lb_;
  // body_[k][h]: pair h's query frames in body-frame coordinates on skeleton
  // k (relative placements; pair_body_frames); empty in world mode.
  std::vector<std::vector<std::array<ResolvedFrame, 2>>> body_;
  // relative_bounds_[k][h][side]: the bound forms of pair h's body-frame Q^h (side 0)
  // and Q^h+1 (side 1) when full frames under "relative": true (exact mode).
  std::vector<std::vector<std::array<std::optional<RelativeBoundQuery>, 2>>> relative_bounds_;
  // The same for root-only frames (either relative placement).
  std::vector<std::vector<std::array<std::optional<RootBoundQuery>, 2>>> root_bounds_;
};

}  // namespace mocap::search_detail
