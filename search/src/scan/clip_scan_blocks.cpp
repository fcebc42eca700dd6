// The block-level clip scan of world mode (clip_scans.hpp): block bounds,
// then eval_clip_blocks.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <span>
#include <utility>

#include "scan/clip_scans.hpp"
#include "scan/window_minima.hpp"

namespace mocap::search_detail {

namespace {

// The partners of the frames of a 16-frame block [f0, f1) of a clip of k
// frames under the length limits lo <= e - s <= hi: the ends e of its starts
// lie in [f0 + lo, f1 - 1 + hi], the starts s of its ends in [f0 - hi,
// f1 - 1 - lo], both cut to the clip; as half-open frame ranges, whose ends
// never decrease with the block.
struct BlockPartners {
  std::size_t k, lo, hi;
  std::size_t f0(std::size_t bl) const { return bl * kBlock; }
  std::size_t f1(std::size_t bl) const { return std::min(k, bl * kBlock + kBlock); }
  std::size_t ends_first(std::size_t bl) const { return std::min(k, f0(bl) + lo); }
  std::size_t ends_end(std::size_t bl) const { return std::min(k, f1(bl) + hi); }
  std::size_t starts_first(std::size_t bl) const { return f0(bl) > hi ? f0(bl) - hi : 0; }
  std::size_t starts_end(std::size_t bl) const { return f1(bl) > lo ? f1(bl) - lo : 0; }
  bool has_ends(std::size_t bl) const { return ends_first(bl) < ends_end(bl); }
  bool has_starts(std::size_t bl) const { return starts_first(bl) < starts_end(bl); }
};

// emit(bl, m) for every block, m = the least x[g] over the blocks g holding
// the block's partners: the ends of its starts (`ends`) or the starts of its
// ends; +inf when it has none. For a whole block those are the blocks
// [bl + lo / 16, bl + ceil(hi / 16)] and [bl - ceil(hi / 16), bl - lo / 16],
// windows of one width at fixed offsets (for the clip's last, shorter block
// they hold its partners' blocks and maybe one more: a lower bound still).
template <class Emit>
void partner_block_minima(const BlockPartners& bp, std::size_t nb, bool ends, const double* x,
                          Emit emit) {
  thread_local FixedWindowMinima windows;
  const auto lo_blocks = static_cast<std::ptrdiff_t>(bp.lo / kBlock);
  const auto hi_blocks = static_cast<std::ptrdiff_t>((bp.hi + kBlock - 1) / kBlock);
  windows.build(0, nb, static_cast<std::size_t>(hi_blocks - lo_blocks + 1),
                [&](std::size_t g) { return x[g]; });
  for (std::size_t bl = 0; bl < nb; ++bl) {
    const auto b = static_cast<std::ptrdiff_t>(bl);
    const bool has = ends ? bp.has_ends(bl) : bp.has_starts(bl);
    emit(bl, has ? windows.window(ends ? b + lo_blocks : b - hi_blocks) : kInf);
  }
}

BlockPartners block_partners(const PairContext& pair, const ClipInfo& ci) {
  const LengthFrames len = length_frames(pair, pair.index->clips()[ci.clip].frame_time_s);
  return {ci.frame_count, len.min, len.max};
}

}  // namespace

void clip_block_bounds(const PairContext& pair, const ClipInfo& ci, double tau, Scratch& scratch) {
  const SkeletonTables& tables = pair.skeleton->tables;
  const std::size_t nb = (ci.frame_count + kBlock - 1) / kBlock;
  const BoundQuery& qa = *pair.bound_a;
  const BoundQuery& qb = *pair.bound_b;
  const bool sketch_a = qa.kind == FrameKind::full, sketch_b = qb.kind == FrameKind::full;
  auto box = [&](const BoundQuery& bound_query, std::size_t bl) {
    return static_cast<double>(block_box_bound(bound_query, tables, ci.block_start + bl));
  };
  scratch.blk_a.resize(nb);
  scratch.blk_b.resize(nb);
  for (std::size_t bl = 0; bl < nb; ++bl) {
    float xa = 0.0f, xb = 0.0f;
    if (sketch_a || sketch_b)
      sketch_block_bounds(qa.sketch.data(), qb.sketch.data(),
                          tables.sketch.data() + (ci.block_start + bl) * kSketchFields * kBlock, xa,
                          xb);
    scratch.blk_a[bl] = sketch_a ? static_cast<double>(xa) : box(qa, bl);
    scratch.blk_b[bl] = sketch_b ? static_cast<double>(xb) : box(qb, bl);
  }
  if (!sketch_a && !sketch_b) return;
  // The least sketch bound of the blocks a block's frames pair with (within
  // the length limits); the box is needed where the sum does not exceed tau.
  // The needed rows are all requested (prefetched) before the first box is
  // computed, so their cache misses overlap.
  const BlockPartners bp = block_partners(pair, ci);
  scratch.blk_need.assign(nb, 0);
  if (sketch_a)
    partner_block_minima(bp, nb, true, scratch.blk_b.data(), [&](std::size_t bl, double m) {
      if (!(safe(scratch.blk_a[bl] + m) > tau)) scratch.blk_need[bl] |= 1;
    });
  if (sketch_b)
    partner_block_minima(bp, nb, false, scratch.blk_a.data(), [&](std::size_t bl, double m) {
      if (!(safe(scratch.blk_b[bl] + m) > tau)) scratch.blk_need[bl] |= 2;
    });
  for (std::size_t bl = 0; bl < nb; ++bl)
    if (scratch.blk_need[bl] != 0) prefetch_block_box(tables, ci.block_start + bl);
  for (std::size_t bl = 0; bl < nb; ++bl) {
    if (scratch.blk_need[bl] & 1) scratch.blk_a[bl] = std::max(scratch.blk_a[bl], box(qa, bl));
    if (scratch.blk_need[bl] & 2) scratch.blk_b[bl] = std::max(scratch.blk_b[bl], box(qb, bl));
  }
}

// World mode, exact, both query frames bounded by boxes only (full or
// root-only, no per-frame bounds): eval_clip_world's decisions taken per
// 16-frame block. lba / lbb are the box bounds of the clip's blocks (as
// double); every bound of a frame is its block's, and a block's frames are
// given the partners of all its frames (the blocks holding them within the
// length limits: BlockPartners), a bound no tighter than eval_clip_world's
// per frame. On top of those decisions the clip prunes against its own best
// pair so far (docs/search.md "The clip's own best"): a probe pair of blocks
// first while tau is infinite, and the second side's blocks in the order of
// their bounds. The chunks are eval_clip_world's 16-frame tiles (same
// values, same answer); fewer of them are scanned.
bool eval_clip_blocks(const PairContext& pair, const ClipInfo& ci, double tau, const double* lba,
                      const double* lbb, Scratch& scratch, ClipCounters& counters, ClipMatch& out) {
  const SkeletonData& skeleton = *pair.skeleton;
  const std::size_t k = ci.frame_count;
  const std::size_t nb = (k + kBlock - 1) / kBlock;
  const BlockPartners bp = block_partners(pair, ci);
  const std::size_t lo = bp.lo, hi = bp.hi;
  if (k <= lo) {  // no pair within the limits
    counters.clip_pruned = true;
    counters.pruned += 2 * k;
    return false;
  }
  auto first = [](std::size_t bl) { return bl * kBlock; };
  auto frames = [&](std::size_t bl) { return std::min(k, bl * kBlock + kBlock) - bl * kBlock; };
  // sb[bl]: the least lbb of the blocks holding the ends of bl's starts;
  // pa[bl]: the least lba of the blocks holding the starts of bl's ends
  // (+inf when there are none).
  std::vector<double>& sb = scratch.sb;
  std::vector<double>& pa = scratch.pa;
  sb.resize(nb);
  pa.resize(nb);
  partner_block_minima(bp, nb, true, lbb, [&](std::size_t bl, double m) { sb[bl] = m; });
  partner_block_minima(bp, nb, false, lba, [&](std::size_t bl, double m) { pa[bl] = m; });
  // A start of block bl needs a(s) if lba[bl] + sb[bl] can reach tau; an end
  // needs b(e) if lbb[bl] + pa[bl] can.
  std::vector<std::uint8_t>& need_a = scratch.need_a;
  std::vector<std::uint8_t>& need_b = scratch.need_b;
  need_a.assign(nb, 0);
  need_b.assign(nb, 0);
  scratch.done_a.assign(nb, 0);
  scratch.done_b.assign(nb, 0);
  // a and b are sized on their own: a relative scan leaves b shorter than a
  // (it holds one partial motion's h values, not the clip's).
  if (scratch.a.size() < k) scratch.a.resize(k);
  if (scratch.b.size() < k) scratch.b.resize(k);
  double* a = scratch.a.data();
  double* b = scratch.b.data();
  const std::span<const double> prefix = clip_prefix(*pair.index, skeleton, ci);
  const double lambda = pair.lambda;
  // lambda P[f], without reading P when lambda = 0 (the same value: 0).
  auto lp = [&](std::size_t f) { return lambda != 0.0 ? lambda * prefix[f] : 0.0; };
  auto cache_values = [&](FrameCache* cache) {
    return cache ? cache->values.get() + ci.frame_start : nullptr;
  };
  auto cache_done = [&](FrameCache* cache) {
    return cache ? cache->done.data() + ci.frame_start : nullptr;
  };
  // Probe (only while fewer than r clips are scored, tau infinite): the
  // block pair x <= y holding a pair s, e within the limits of least
  // lba[x] + lbb[y] is scanned first; its best such pair is a real score of
  // this clip, so the clip's optimum is at most that: it serves as the
  // clip's tau (every decision below stays sound).
  if (!std::isfinite(tau)) {
    double least = kInf;
    std::size_t px = 0, py = 0;
    for (std::size_t x = 0; x < nb; ++x) {
      const std::size_t x_last = first(x) + frames(x) - 1;
      for (std::size_t y = x; y < nb && first(y) <= x_last + hi; ++y)
        if (first(y) + frames(y) - 1 >= first(x) + lo && lba[x] + lbb[y] < least) {
          least = lba[x] + lbb[y];
          px = x;
          py = y;
        }
    }
    if (std::isfinite(least)) {
      scan_whole_chunk(pair, ci, *pair.qa, px, first(px), first(px) + frames(px), a,
                       cache_values(pair.cache_a), cache_done(pair.cache_a), scratch, counters);
      scan_whole_chunk(pair, ci, *pair.qb, py, first(py), first(py) + frames(py), b,
                       cache_values(pair.cache_b), cache_done(pair.cache_b), scratch, counters);
      scratch.done_a[px] = scratch.done_b[py] = 1;
      for (std::size_t s = first(px); s < first(px) + frames(px); ++s)
        for (std::size_t e = std::max(s + lo, first(py));
             e < std::min(first(py) + frames(py), s + hi + 1); ++e)
          tau = std::min(tau, (b[e] + lp(e)) + (a[s] - lp(s)));
    }
  }
  double clip_lb = kInf;
  std::size_t count_a = 0, count_b = 0;
  for (std::size_t bl = 0; bl < nb; ++bl) {
    const double xa = lba[bl] + sb[bl];
    clip_lb = std::min(clip_lb, xa);
    need_a[bl] = bp.has_ends(bl) && !(safe(xa) > tau);
    need_b[bl] = bp.has_starts(bl) && !(safe(lbb[bl] + pa[bl]) > tau);
    count_a += need_a[bl];
    count_b += need_b[bl];
  }
  if (safe(clip_lb) > tau) {
    counters.clip_pruned = true;
    counters.pruned += 2 * k;
    return false;
  }
  // Scans the needed blocks of the first side (chunks shared with the other
  // pair: copied; blocks the probe scanned: kept).
  // A frame's partner bound (scan_whole_chunk): its block's sb for a(s), pa
  // for b(e); on the second side, the first side's best partner.
  double partner[kBlock];
  auto side = [&](const ResolvedFrame& q, const std::vector<std::uint8_t>& need,
                  const std::vector<std::uint8_t>& done, double* dst, FrameCache* cache) {
    const bool is_a = &q == pair.qa;
    for (std::size_t bl = 0; bl < nb; ++bl) {
      const std::size_t f0 = first(bl), f1 = f0 + frames(bl);
      if (!need[bl]) {
        counters.pruned += f1 - f0;
      } else if (!done[bl]) {
        std::fill(partner, partner + (f1 - f0), is_a ? sb[bl] : pa[bl]);
        scan_whole_chunk(pair, ci, q, bl, f0, f1, dst, cache_values(cache), cache_done(cache),
                         scratch, counters, is_a ? pair.bound_a : pair.bound_b, partner, tau);
      }
    }
  };
  // Scans the needed blocks of the second side in the order of key[bl] =
  // its bound + a lower bound of the first side's best partner (least
  // first), with u the clip's best score so far (tau at first): a block
  // whose key exceeds u cannot hold a pair scoring <= u and is dropped
  // (need = 0). partner(f): the computed first side's best partner of frame
  // f within the limits (min over s in [f - max, f - min] of a(s) - lambda
  // P[s], or over e in [f + min, f + max] of b(e) + lambda P[e]).
  auto second_side = [&](const ResolvedFrame& q, std::vector<std::uint8_t>& need,
                         const std::vector<std::uint8_t>& done, const double* lbx,
                         const std::vector<double>& key_other, double* dst, FrameCache* cache,
                         double sign) {
    std::vector<std::size_t>& order = scratch.order;
    order.clear();
    for (std::size_t bl = 0; bl < nb; ++bl) {
      if (need[bl])
        order.push_back(bl);
      else
        counters.pruned += frames(bl);
    }
    std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
      const double kx = lbx[x] + key_other[x], ky = lbx[y] + key_other[y];
      return kx != ky ? kx < ky : x < y;
    });
    double u = tau;
    for (const std::size_t bl : order) {
      const std::size_t f0 = first(bl), f1 = f0 + frames(bl);
      if (safe(lbx[bl] + key_other[bl]) > u) {
        need[bl] = 0;
        counters.pruned += f1 - f0;
        continue;
      }
      if (!done[bl]) {
        for (std::size_t f = f0; f < f1; ++f) partner[f - f0] = sign * lp(f) + scratch.run[f];
        scan_whole_chunk(pair, ci, q, bl, f0, f1, dst, cache_values(cache), cache_done(cache),
                         scratch, counters, &q == pair.qa ? pair.bound_a : pair.bound_b, partner,
                         u);
      }
      for (std::size_t f = f0; f < f1; ++f)
        if (std::isfinite(dst[f]) && std::isfinite(scratch.run[f]))
          u = std::min(u, (dst[f] + sign * lp(f)) + scratch.run[f]);
    }
  };
  scratch.run.resize(k);
  // The computed values of a side: +inf in the blocks it does not need.
  auto a_of = [&](std::size_t s) { return need_a[s / kBlock] ? a[s] : kInf; };
  auto b_of = [&](std::size_t e) { return need_b[e / kBlock] ? b[e] : kInf; };
  // The partners of s: e in [s + min, s + max]; of e: s in [e - max, e - min].
  thread_local FixedWindowMinima windows;
  const std::size_t width = hi - lo + 1;
  // The frames of the first to the last block a side needs.
  auto needed_span = [&](const std::vector<std::uint8_t>& need) {
    std::size_t b0 = 0, b1 = nb;
    while (b0 < nb && !need[b0]) ++b0;
    while (b1 > b0 && !need[b1 - 1]) --b1;
    return std::pair<std::size_t, std::size_t>(
        first(b0), b1 > b0 ? first(b1 - 1) + frames(b1 - 1) : first(b0));
  };
  // The side with fewer blocks first; then the other side decided again with
  // the true values (+inf where not computed) of its frames' partners in
  // place of their bounds (docs/search.md "Frame pruning"). Only the blocks
  // the second side needs read run and key.
  std::vector<double>& key = scratch.key;
  key.resize(nb);
  if (count_a <= count_b) {
    side(*pair.qa, need_a, scratch.done_a, a, pair.cache_a);
    // run[e] = min over its starts s of the computed a(s) - lambda P[s]
    const auto [a0, a1] = needed_span(need_a);
    windows.build(a0, a1, width, [&](std::size_t s) {
      const double v = a_of(s);
      return std::isfinite(v) ? v - lp(s) : kInf;
    });
    for (std::size_t bl = 0; bl < nb; ++bl) {
      if (!need_b[bl]) continue;
      // pm: the least a(s) + lambda (P[e] - P[s]) over the pairs with e in
      // the block (computed a), <= every such pair's score less b(e).
      double pm = kInf;
      for (std::size_t e = first(bl); e < first(bl) + frames(bl); ++e) {
        scratch.run[e] =
            windows.window(static_cast<std::ptrdiff_t>(e) - static_cast<std::ptrdiff_t>(hi));
        if (e < lo) scratch.run[e] = kInf;
        pm = std::min(pm, lp(e) + scratch.run[e]);
      }
      need_b[bl] = !(safe(lbb[bl] + pm) > tau);
      key[bl] = std::max(pa[bl], pm);
    }
    second_side(*pair.qb, need_b, scratch.done_b, lbb, key, b, pair.cache_b, 1.0);
  } else {
    side(*pair.qb, need_b, scratch.done_b, b, pair.cache_b);
    // run[s] = min over its ends e of the computed b(e) + lambda P[e]
    const auto [b0, b1] = needed_span(need_b);
    windows.build(b0, b1, width, [&](std::size_t e) {
      const double v = b_of(e);
      return std::isfinite(v) ? v + lp(e) : kInf;
    });
    for (std::size_t bl = 0; bl < nb; ++bl) {
      if (!need_a[bl]) continue;
      // sm: the least b(e) + lambda (P[e] - P[s]) over the pairs with s in
      // the block (computed b), <= every such pair's score less a(s).
      double sm = kInf;
      for (std::size_t f = first(bl); f < first(bl) + frames(bl); ++f) {
        scratch.run[f] = windows.window(static_cast<std::ptrdiff_t>(f + lo));
        sm = std::min(sm, scratch.run[f] - lp(f));
      }
      need_a[bl] = !(safe(lba[bl] + sm) > tau);
      key[bl] = std::max(sb[bl], sm);
    }
    second_side(*pair.qa, need_a, scratch.done_a, lba, key, a, pair.cache_a, -1.0);
  }
  // The sliding-window minimum of best_partial_motion over the computed
  // values, +inf elsewhere: only the blocks that need b(e) hold ends, and
  // the starts enter the window from the blocks that need a(s).
  thread_local std::vector<WindowMin::Entry> storage;
  WindowMin window(storage, k);
  bool have = false;
  std::size_t next_s = 0;  // the starts below it have entered the window
  ClipBest best;
  for (std::size_t bl = 0; bl < nb; ++bl) {
    if (!need_b[bl]) continue;
    for (std::size_t e = std::max(first(bl), lo); e < first(bl) + frames(bl); ++e) {
      const std::size_t s_end = e - lo + 1;
      while (next_s < s_end) {
        const std::size_t block_end = std::min(s_end, (next_s / kBlock + 1) * kBlock);
        if (need_a[next_s / kBlock]) {
          for (; next_s < block_end; ++next_s)
            if (std::isfinite(a[next_s])) window.push(next_s, a[next_s] - lp(next_s));
        } else {
          next_s = block_end;
        }
      }
      if (e > hi) window.drop_before(e - hi);
      if (!std::isfinite(b[e]) || window.empty()) continue;
      const double score = (b[e] + lp(e)) + window.min();
      if (score < best.score || !have) {  // strict: the earliest e wins ties
        best = {score, window.argmin(), e};
        have = true;
      }
    }
  }
  if (!have) return false;
  out = {
      best.score, ci.clip, best.s, best.e, a[best.s], b[best.e], prefix[best.e] - prefix[best.s]};
  return true;
}

}  // namespace mocap::search_detail
