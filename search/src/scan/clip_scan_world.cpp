// The clip scans of world mode (clip_scans.hpp), and the
// running minimum that finds a clip's best pair (search.hpp).
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <span>
#include <stdexcept>
#include <utility>
#include <vector>

#include "scan/clip_scans.hpp"
#include "scan/frame_energy.hpp"
#include "scan/window_minima.hpp"

namespace mocap {

using search_detail::kInf;

using search_detail::better;

namespace {

void check_gaps(std::size_t min_gap, std::size_t max_gap) {
  if (min_gap < 1 || min_gap > max_gap)
    throw std::invalid_argument("best_partial_motion: need 1 <= min_gap <= max_gap");
}

}  // namespace

bool best_partial_motion(const double* a, const double* b, const double* prefix, std::size_t k,
                         double lambda, std::size_t min_gap, std::size_t max_gap, ClipBest& out) {
  check_gaps(min_gap, max_gap);
  if (k <= min_gap) return false;
  // v(s) = a(s) - lambda P[s] (+inf where a(s) is not finite); the starts of
  // end e are s in [e - max_gap, e - min_gap]: per e their least v, the
  // earliest s among equal values.
  auto v = [&](std::size_t s) { return std::isfinite(a[s]) ? a[s] - lambda * prefix[s] : kInf; };
  bool have = false;
  auto offer = [&](std::size_t e, double m, std::size_t s) {
    if (!std::isfinite(b[e]) || !std::isfinite(m)) return;
    const double score = (b[e] + lambda * prefix[e]) + m;
    if (score < out.score || !have) {  // strict: the earliest e wins ties
      out = {score, s, e};
      have = true;
    }
  };
  if (max_gap + 1 >= k) {  // no start leaves the window: a running minimum
    double m = kInf;
    std::size_t ms = 0;
    for (std::size_t e = min_gap; e < k; ++e) {
      const std::size_t s = e - min_gap;
      const double x = v(s);
      if (x < m) {  // strict: the earliest s wins ties
        m = x;
        ms = s;
      }
      offer(e, m, ms);
    }
    return have;
  }
  // Windows of w starts, van Herk / Gil-Werman (window_minima.hpp) with the
  // argmin: per run of w starts, the running minimum from its start (the
  // earliest s on ties) and to its end (likewise); a window joins the suffix
  // at its first start and the prefix at its last, the suffix winning ties.
  const std::size_t n = k - min_gap, w = max_gap - min_gap + 1;
  thread_local std::vector<double> prefix_v, suffix_v;
  thread_local std::vector<std::size_t> prefix_s, suffix_s;
  prefix_v.resize(n);
  suffix_v.resize(n);
  prefix_s.resize(n);
  suffix_s.resize(n);
  for (std::size_t r0 = 0; r0 < n; r0 += w) {
    const std::size_t r1 = std::min(n, r0 + w);
    double m = kInf;
    std::size_t ms = r0;
    for (std::size_t i = r0; i < r1; ++i) {
      const double x = v(i);
      suffix_v[i] = x;
      if (x < m) {
        m = x;
        ms = i;
      }
      prefix_v[i] = m;
      prefix_s[i] = ms;
    }
    m = kInf;
    ms = r1 - 1;
    for (std::size_t i = r1; i-- > r0;) {
      if (suffix_v[i] <= m) {
        m = suffix_v[i];
        ms = i;
      }
      suffix_v[i] = m;
      suffix_s[i] = ms;
    }
  }
  for (std::size_t e = min_gap; e < k; ++e) {
    const std::size_t last = e - min_gap;
    if (last + 1 < w) {  // the window is cut at frame 0: within the first run
      offer(e, prefix_v[last], prefix_s[last]);
      continue;
    }
    const std::size_t first = last + 1 - w;
    if (suffix_v[first] <= prefix_v[last])
      offer(e, suffix_v[first], suffix_s[first]);
    else
      offer(e, prefix_v[last], prefix_s[last]);
  }
  return have;
}

bool best_partial_motion_quadratic(const double* a, const double* b, const double* prefix,
                                   std::size_t k, double lambda, std::size_t min_gap,
                                   std::size_t max_gap, ClipBest& out) {
  check_gaps(min_gap, max_gap);
  bool have = false;
  for (std::size_t e = 1; e < k; ++e) {
    if (!std::isfinite(b[e])) continue;
    for (std::size_t s = 0; s < e; ++s) {
      if (!std::isfinite(a[s]) || e - s < min_gap || e - s > max_gap) continue;
      const double score = (b[e] + lambda * prefix[e]) + (a[s] - lambda * prefix[s]);
      if (better(score, e, s, out, have)) {
        out = {score, s, e};
        have = true;
      }
    }
  }
  return have;
}

}  // namespace mocap

namespace mocap::search_detail {

void scan_whole_chunk(const PairContext& pair, const ClipInfo& ci, const ResolvedFrame& q,
                      std::size_t bl, std::size_t f0, std::size_t f1, double* dst, double* cv,
                      std::uint8_t* cd, Scratch& scratch, ClipCounters& counters,
                      const BoundQuery* bound_query, const double* partner, double thr) {
  if (cd != nullptr && cd[f0]) {
    std::copy(cv + f0, cv + f1, dst + f0);
    return;
  }
  const SkeletonData& skeleton = *pair.skeleton;
  const SkeletonTables& tables = skeleton.tables;
  const std::size_t row = ci.block_start + bl;
  if (partner != nullptr && bound_query != nullptr && bound_query->kind == FrameKind::full &&
      std::isfinite(thr)) {
    float lb[kBlock];
    chain_sketch_bounds(bound_query->chain_sketch.data(),
                        tables.chain_sketch.data() + row * tables.chains * kSketchFields * kBlock,
                        tables.chains, lb);
    bool any = false;
    for (std::size_t f = f0; f < f1; ++f)
      any = any || !(safe(static_cast<double>(lb[f - f0]) + partner[f - f0]) > thr);
    if (!any) {
      std::fill(dst + f0, dst + f1, kInf);
      counters.pruned += f1 - f0;
      return;
    }
  }
  const HScanView tile = tables.tile(row, ci.frame_start + f0, f1 - f0);
  evaluate_h(q, skeleton, *pair.index, pair.t, ci.frame_start + f0, ci.frame_start + f1, dst + f0,
             scratch, std::nullopt, nullptr, &tile);
  counters.evaluated += f1 - f0;
  if (cd != nullptr) {
    std::copy(dst + f0, dst + f1, cv + f0);
    std::fill(cd + f0, cd + f1, std::uint8_t{1});
  }
}

namespace {

// The frames of the clip from the first to the last one a side needs (skip
// != 1), as [first, end).
std::pair<std::size_t, std::size_t> needed_span(const std::vector<std::uint8_t>& skip,
                                                std::size_t k) {
  std::size_t first = 0, end = k;
  while (first < k && skip[first] == 1) ++first;
  while (end > first && skip[end - 1] == 1) --end;
  return {first, end};
}

// How many of the clip's blocks hold a frame a side needs (skip == 0).
std::size_t blocks_needed(const std::vector<std::uint8_t>& skip, std::size_t k) {
  std::size_t count = 0;
  walk_blocks(
      0, k,
      [&](std::size_t, std::size_t f0, std::size_t f1) {
        return std::find(skip.begin() + static_cast<std::ptrdiff_t>(f0),
                         skip.begin() + static_cast<std::ptrdiff_t>(f1),
                         std::uint8_t{0}) != skip.begin() + static_cast<std::ptrdiff_t>(f1);
      },
      [&](std::size_t, std::size_t, std::size_t) { ++count; }, ignore_block);
  return count;
}

// World mode's per-frame lower bounds of a(s) and b(e) into scratch.la /
// scratch.lb (J): the box bound of the frame's block for a full or root-only
// query frame (0 for a partial one), raised to the partial frames' per-frame
// bounds where the pair has them.
void world_frame_bounds(const PairContext& pair, const ClipInfo& ci, Scratch& scratch) {
  const SkeletonTables& tables = pair.skeleton->tables;
  const std::size_t k = ci.frame_count;
  scratch.la.resize(k);
  scratch.lb.resize(k);
  const bool box_a = pair.qa->kind != FrameKind::partial,
             box_b = pair.qb->kind != FrameKind::partial;
  walk_blocks(
      0, k, every_block,
      [&](std::size_t bl, std::size_t f0, std::size_t f1) {
        const std::size_t row = ci.block_start + bl;
        const double xa =
            box_a ? static_cast<double>(block_box_bound(*pair.bound_a, tables, row)) : 0.0;
        const double xb =
            box_b ? static_cast<double>(block_box_bound(*pair.bound_b, tables, row)) : 0.0;
        for (std::size_t f = f0; f < f1; ++f) {
          scratch.la[f] = xa;
          scratch.lb[f] = xb;
        }
      },
      ignore_block);
  if (pair.frame_lb_a != nullptr)
    for (std::size_t f = 0; f < k; ++f)
      scratch.la[f] = std::max(scratch.la[f], pair.frame_lb_a[ci.frame_start + f]);
  if (pair.frame_lb_b != nullptr)
    for (std::size_t f = 0; f < k; ++f)
      scratch.lb[f] = std::max(scratch.lb[f], pair.frame_lb_b[ci.frame_start + f]);
}

// World mode's frame decisions from the bounds (world_frame_bounds): s is
// needed only if la(s) + min lb(e) over its ends e in [s + min, s + max] can
// reach tau; e only if lb(e) + min la(s) over its starts s in [e - max,
// e - min] can; a frame with no partner in the clip is not needed (skip_a,
// skip_b = 1). False (counted) when the bounds prune the whole clip.
bool decide_world_frames(const PairContext& pair, const ClipInfo& ci, const LengthFrames& len,
                         double tau, Scratch& scratch, ClipCounters& counters) {
  const std::size_t k = ci.frame_count;
  world_frame_bounds(pair, ci, scratch);
  if (k <= len.min) {
    counters.clip_pruned = true;
    counters.pruned += 2 * k;
    return false;
  }
  thread_local FixedWindowMinima windows;
  const std::size_t width = len.max - len.min + 1;
  double clip_lb = kInf;
  windows.build(0, k, width, [&](std::size_t f) { return scratch.lb[f]; });
  for (std::size_t f = 0; f + len.min < k; ++f) {
    const double x = scratch.la[f] + windows.window(static_cast<std::ptrdiff_t>(f + len.min));
    clip_lb = std::min(clip_lb, x);
    scratch.skip_a[f] = safe(x) > tau;
  }
  std::fill(scratch.skip_a.begin() + static_cast<std::ptrdiff_t>(k - len.min), scratch.skip_a.end(),
            std::uint8_t{1});
  if (safe(clip_lb) > tau) {
    counters.clip_pruned = true;
    counters.pruned += 2 * k;
    return false;
  }
  windows.build(0, k, width, [&](std::size_t f) { return scratch.la[f]; });
  std::fill(scratch.skip_b.begin(), scratch.skip_b.begin() + static_cast<std::ptrdiff_t>(len.min),
            std::uint8_t{1});
  for (std::size_t f = len.min; f < k; ++f)
    scratch.skip_b[f] =
        safe(scratch.lb[f] + windows.window(static_cast<std::ptrdiff_t>(f) -
                                            static_cast<std::ptrdiff_t>(len.max))) > tau;
  return true;
}

// The needed frames of one partial query frame q in the block frames [f0,
// f1) (`need` of them: skip == 0) into dst: copied where the query's other
// pair computed them (cv / cd: the shared frame cache from the clip's first
// frame, or null; such frames are marked skip = 2 for evaluate_h), the rest
// evaluated and cached.
void scan_partial_block(const PairContext& pair, const ClipInfo& ci, const ResolvedFrame& q,
                        std::size_t f0, std::size_t f1, std::size_t need,
                        std::vector<std::uint8_t>& skip, double* dst, double* cv, std::uint8_t* cd,
                        Scratch& scratch, ClipCounters& counters) {
  std::size_t fresh = need;
  if (cd != nullptr) {
    for (std::size_t f = f0; f < f1; ++f)
      if (skip[f] == 0 && cd[f]) {
        dst[f] = cv[f];
        skip[f] = 2;
        --fresh;
      }
  }
  if (fresh > 0)
    evaluate_h(q, *pair.skeleton, *pair.index, pair.t, ci.frame_start + f0, ci.frame_start + f1,
               dst + f0, scratch, std::nullopt, skip.data() + f0);
  if (cd != nullptr)
    for (std::size_t f = f0; f < f1; ++f)
      if (skip[f] == 0) {
        cv[f] = dst[f];
        cd[f] = 1;
      }
  counters.evaluated += fresh;
  counters.pruned += (f1 - f0) - need;
}

// One side of world mode: the frames of query frame q the side needs (skip
// == 0) into dst, block by block (a block with none is pruned). Full and
// root-only query frames are scanned in whole 16-frame chunks (the same
// chunks in every mode: bit-identical values); partial ones per frame.
void scan_world_side(const PairContext& pair, const ClipInfo& ci, const ResolvedFrame& q,
                     std::vector<std::uint8_t>& skip, double* dst, FrameCache* cache,
                     Scratch& scratch, ClipCounters& counters) {
  double* cv = cache ? cache->values.get() + ci.frame_start : nullptr;
  std::uint8_t* cd = cache ? cache->done.data() + ci.frame_start : nullptr;
  std::size_t need = 0;
  walk_blocks(
      0, ci.frame_count,
      [&](std::size_t, std::size_t f0, std::size_t f1) {
        need = 0;
        for (std::size_t f = f0; f < f1; ++f) need += skip[f] == 0;
        return need != 0;
      },
      [&](std::size_t bl, std::size_t f0, std::size_t f1) {
        if (q.kind == FrameKind::partial)
          scan_partial_block(pair, ci, q, f0, f1, need, skip, dst, cv, cd, scratch, counters);
        else
          scan_whole_chunk(pair, ci, q, bl, f0, f1, dst, cv, cd, scratch, counters);
      },
      [&](std::size_t, std::size_t f0, std::size_t f1) { counters.pruned += f1 - f0; });
}

}  // namespace

// World mode: per-frame lower bounds (block boxes, partial-frame bounds),
// a(s) and b(e) where they can matter, then the sliding-window minimum
// (best_partial_motion) over the pairs within the length limits.
bool eval_clip_world(const PairContext& pair, const ClipInfo& ci, double tau, Scratch& scratch,
                     ClipCounters& counters, ClipMatch& out) {
  const std::size_t k = ci.frame_count;
  scratch.a.assign(k, kInf);
  scratch.b.assign(k, kInf);
  scratch.skip_a.assign(k, 0);
  scratch.skip_b.assign(k, 0);
  const bool prune = pair.mode != SearchMode::brute;
  const LengthFrames len = length_frames(pair, pair.index->clips()[ci.clip].frame_time_s);
  if (prune && !decide_world_frames(pair, ci, len, tau, scratch, counters)) return false;
  auto side_a = [&] {
    scan_world_side(pair, ci, *pair.qa, scratch.skip_a, scratch.a.data(), pair.cache_a, scratch,
                    counters);
  };
  auto side_b = [&] {
    scan_world_side(pair, ci, *pair.qb, scratch.skip_b, scratch.b.data(), pair.cache_b, scratch,
                    counters);
  };
  if (!prune) {
    side_a();
    side_b();
  } else {
    // The side with fewer blocks to scan first; then the other side is
    // decided again with its true values in place of the bounds: a frame of
    // the first side that was not computed can be in no pair scoring <= tau,
    // so it counts as +inf (docs/search.md "Frame pruning").
    // The partners of s: e in [s + min, s + max]; of e: s in [e - max, e - min].
    thread_local FixedWindowMinima windows;
    const std::size_t width = len.max - len.min + 1;
    if (blocks_needed(scratch.skip_a, k) <= blocks_needed(scratch.skip_b, k)) {
      side_a();
      const auto [a0, a1] = needed_span(scratch.skip_a, k);
      windows.build(a0, a1, width, [&](std::size_t f) { return scratch.a[f]; });
      for (std::size_t f = len.min; f < k; ++f)
        if (scratch.skip_b[f] == 0)
          scratch.skip_b[f] =
              safe(scratch.lb[f] + windows.window(static_cast<std::ptrdiff_t>(f) -
                                                  static_cast<std::ptrdiff_t>(len.max))) > tau;
      side_b();
    } else {
      side_b();
      const auto [b0, b1] = needed_span(scratch.skip_b, k);
      windows.build(b0, b1, width, [&](std::size_t f) { return scratch.b[f]; });
      for (std::size_t f = 0; f + len.min < k; ++f)
        if (scratch.skip_a[f] == 0)
          scratch.skip_a[f] =
              safe(scratch.la[f] + windows.window(static_cast<std::ptrdiff_t>(f + len.min))) > tau;
      side_a();
    }
  }
  const std::span<const double> prefix = clip_prefix(*pair.index, *pair.skeleton, ci);
  ClipBest best;
  if (!best_partial_motion(scratch.a.data(), scratch.b.data(), prefix.data(), k, pair.lambda,
                           len.min, len.max, best))
    return false;
  out = {best.score,
         ci.clip,
         best.s,
         best.e,
         scratch.a[best.s],
         scratch.b[best.e],
         prefix[best.e] - prefix[best.s]};
  return true;
}

}  // namespace mocap::search_detail
