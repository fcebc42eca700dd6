#pragma once
// Internal to mocap_search: the clip scans, the best partial motion of one
// clip for one query pair (docs/search.md):
//  - eval_clip_world: world mode, per-frame bounds (block boxes, partial
//    frames' per-frame bounds), a(s) and b(e) where they can matter, then
//    the running minimum (best_partial_motion); brute mode scans every frame;
//  - eval_clip_blocks: world mode, exact, both query frames bounded by boxes
//    only: the same decisions per 16-frame block, with the clip's own best
//    as a threshold (clip_block_bounds gives the blocks' bounds);
//  - eval_clip_relative (clip_scan_relative.cpp): relative placements, O(K L).
// Each returns false when the clip has no pair s < e that can score <= tau
// (its bounds prove it, or no pair has finite values), else its best match.
// Every mode that is exact gives the same match for a clip.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "bounds/box_bounds.hpp"
#include "bounds/relative_bounds.hpp"
#include "bounds/skeleton_tables.hpp"
#include "engine/scratch.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/search/search.hpp"
#include "query/resolved_frame.hpp"
#include "scan/top_matches.hpp"

namespace mocap::search_detail {

inline constexpr double kInf = std::numeric_limits<double>::infinity();

// h values of one query frame already computed for another pair of the same
// query (world mode: a(.) of Q^h+1 in pair h+1 equals b(.) in pair h, h being
// symmetric). Frames of a clip are written by the thread evaluating that
// clip; pairs run one after another.
struct FrameCache {
  std::unique_ptr<double[]> values;
  std::vector<std::uint8_t> done;  // per skeleton frame
};

// One query pair {Q^h, Q^h+1} on one skeleton: what every clip scan of the
// pair reads.
struct PairContext {
  const Index* index;
  const SkeletonData* skeleton;
  // Q^h and Q^h+1: world coordinates, or body-frame ones in the relative
  // placements (relative_frames.hpp).
  const ResolvedFrame* qa;
  const ResolvedFrame* qb;
  double t, lambda;  // transition time (s), path weight
  FramePlacement placement;
  SearchMode mode;                    // exact or brute (approx scans as exact)
  double min_length_s, max_length_s;  // the query's partial-motion length limits
  // Per skeleton frame lower bounds of a / b for partial query frames (world mode), or null.
  const double* frame_lb_a = nullptr;
  const double* frame_lb_b = nullptr;
  // Box-bound forms of qa / qb (world mode).
  const BoundQuery* bound_a = nullptr;
  const BoundQuery* bound_b = nullptr;
  // Values shared with the neighbouring pair (world mode), or null.
  FrameCache* cache_a = nullptr;
  FrameCache* cache_b = nullptr;
  // Relative placements, a full Q^h+1: what bounds b(s, e) (relative_bounds.hpp), or null.
  const RelativeBoundQuery* out_bound = nullptr;
  // The same for a full Q^h (a(s) is h(F^s -> Q^h placed at F^s)), or null.
  const RelativeBoundQuery* in_bound = nullptr;
  // Relative placements, a root-only Q^h / Q^h+1: what bounds a / b, or null.
  const RootBoundQuery* root_in = nullptr;
  const RootBoundQuery* root_out = nullptr;
};

// (score, e, s) lexicographic: true when the candidate beats the incumbent.
inline bool better(double score, std::size_t e, std::size_t s, const ClipBest& best, bool have) {
  if (!have) return true;
  if (score != best.score) return score < best.score;
  if (e != best.e) return e < best.e;
  return s < best.s;
}

// A partial motion's length limits in frames for a clip of frame time dt:
// min <= e - s <= max, 1 <= min <= max (SearchOptions::min_length_s).
struct LengthFrames {
  std::size_t min = 1, max = 1;
};
inline LengthFrames length_frames(const PairContext& pair, double dt) {
  auto frames = [dt](double seconds) {
    return std::max<std::size_t>(1, static_cast<std::size_t>(std::llround(seconds / dt)));
  };
  const std::size_t lo = frames(pair.min_length_s);
  return {lo, std::max(lo, frames(pair.max_length_s))};
}

// What a clip scan did: frames evaluated and pruned, and whether the whole
// clip was pruned by its bounds.
struct ClipCounters {
  std::uint64_t evaluated = 0, pruned = 0;
  bool clip_pruned = false;
};

// The one block walk of the clip scans: the clip frames [first, end) in the
// order of their blocks of B frames (block bl holds clip frames [bl B,
// bl B + B); the scans' 16-frame tiles, the relative scan's root blocks).
// Per block meeting the range, with [f0, f1) its frames in the range:
// open(bl, f0, f1) is the scan's bound of the block (true: some frame of it
// can matter), then visit(bl, f0, f1) goes through its frames, or
// closed(bl, f0, f1) takes the block as pruned. The callables are template
// arguments (inlined: no indirect call per block or frame). A coarser level
// nests one walk in another's visit.
template <std::size_t B = kBlock, class Open, class Visit, class Closed>
inline void walk_blocks(std::size_t first, std::size_t end, Open&& open, Visit&& visit,
                        Closed&& closed) {
  for (std::size_t bl = first / B; first < end && bl * B < end; ++bl) {
    const std::size_t f0 = std::max(first, bl * B), f1 = std::min(end, bl * B + B);
    if (open(bl, f0, f1))
      visit(bl, f0, f1);
    else
      closed(bl, f0, f1);
  }
}

// walk_blocks' bound for a walk that visits every block.
inline constexpr auto every_block = [](std::size_t, std::size_t, std::size_t) { return true; };
// walk_blocks' closed for a walk that counts nothing there.
inline constexpr auto ignore_block = [](std::size_t, std::size_t, std::size_t) {};

bool eval_clip_world(const PairContext& pair, const ClipInfo& ci, double tau, Scratch& scratch,
                     ClipCounters& counters, ClipMatch& out);

// The bounds of a clip's 16-frame blocks for both query frames of the pair
// (world mode) into scratch.blk_a / scratch.blk_b (as double): the box
// bounds; for a full query frame first the least whole-body sketch bound of
// the block's frames, raised to the box bound only where the sketches cannot
// rule the block out against tau (docs/search.md "Whole-body sketches": a
// block left at its sketch bound is not needed either way).
void clip_block_bounds(const PairContext& pair, const ClipInfo& ci, double tau, Scratch& scratch);

// lba / lbb: the clip's block bounds (clip_block_bounds).
bool eval_clip_blocks(const PairContext& pair, const ClipInfo& ci, double tau, const double* lba,
                      const double* lbb, Scratch& scratch, ClipCounters& counters, ClipMatch& out);

// A lower bound of a(s) + b(s, e) over every s, e of clip row `row` for a
// relative pair (the box bounds of full frames, the root boxes of root-only
// ones; 0 for a term of another kind), without touching its frames.
double relative_clip_bound(const PairContext& pair, std::size_t row);
// True when relative_clip_bound knows something of either term.
inline bool has_relative_clip_bound(const PairContext& pair) {
  return pair.in_bound != nullptr || pair.out_bound != nullptr || pair.root_in != nullptr ||
         pair.root_out != nullptr;
}

bool eval_clip_relative(const PairContext& pair, const ClipInfo& ci, double tau, Scratch& scratch,
                        ClipCounters& counters, ClipMatch& out);

// One whole 16-frame chunk [f0, f1) of a clip (its block bl) for a full or
// root-only query frame q into dst[f0, f1) (clip-relative frames): copied
// when the query's other pair computed it (cv / cd: the shared frame cache
// from the clip's first frame, null without one), else evaluated with the
// block's tile, counted and cached.
//
// With `partner` (a finite threshold `thr`; full query frames, `bound_query`
// its bound form), frame f of the chunk matters only if h(f) + partner[f - f0]
// can be <= thr, partner[i] being a lower bound of the best rest of a pair
// through frame f0 + i: the frames' chain-sketch bounds are computed first
// (2.2 KB on a 7-chain skeleton against the tile's 12 KB), and when no frame
// can matter by them the chunk is left at +inf, counted as pruned and not
// cached (docs/search.md "Chain sketches").
void scan_whole_chunk(const PairContext& pair, const ClipInfo& ci, const ResolvedFrame& q,
                      std::size_t bl, std::size_t f0, std::size_t f1, double* dst, double* cv,
                      std::uint8_t* cd, Scratch& scratch, ClipCounters& counters,
                      const BoundQuery* bound_query = nullptr, const double* partner = nullptr,
                      double thr = kInf);

}  // namespace mocap::search_detail
