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

namespace {

// What the steps of eval_clip_blocks share: the clip's blocks, their bounds
// and partners, the values computed so far and the counters.
struct BlockScan {
  const PairContext& pair;
  const ClipInfo& ci;
  const double* lba;  // the blocks' bounds of a(s) and b(e) (J)
  const double* lbb;
  Scratch& scratch;
  ClipCounters& counters;
  BlockPartners bp;
  std::size_t k, nb;
  double* a = nullptr;  // a(s), b(e) of the clip's frames (J)
  double* b = nullptr;
  std::span<const double> prefix{};

  std::size_t first(std::size_t bl) const { return bl * kBlock; }
  std::size_t frames(std::size_t bl) const {
    return std::min(k, bl * kBlock + kBlock) - bl * kBlock;
  }
  // lambda P[f], without reading P when lambda = 0 (the same value: 0).
  double lp(std::size_t f) const { return pair.lambda != 0.0 ? pair.lambda * prefix[f] : 0.0; }
  double* cache_values(FrameCache* cache) const {
    return cache ? cache->values.get() + ci.frame_start : nullptr;
  }
  std::uint8_t* cache_done(FrameCache* cache) const {
    return cache ? cache->done.data() + ci.frame_start : nullptr;
  }
  // The clip as pruned by its bounds: nothing of it is evaluated.
  bool prune_clip() const {
    counters.clip_pruned = true;
    counters.pruned += 2 * k;
    return false;
  }
};

// Probe (only while fewer than r clips are scored, tau infinite): the block
// pair x <= y holding a pair s, e within the limits of least lba[x] + lbb[y]
// is scanned first; its best such pair is a real score of this clip, so the
// clip's optimum is at most that: it serves as the clip's tau (every
// decision after stays sound). Returns tau, lowered where the probe ran.
double probe_block_pair(BlockScan& c, double tau) {
  const std::size_t lo = c.bp.lo, hi = c.bp.hi;
  double least = kInf;
  std::size_t px = 0, py = 0;
  for (std::size_t x = 0; x < c.nb; ++x) {
    const std::size_t x_last = c.first(x) + c.frames(x) - 1;
    for (std::size_t y = x; y < c.nb && c.first(y) <= x_last + hi; ++y)
      if (c.first(y) + c.frames(y) - 1 >= c.first(x) + lo && c.lba[x] + c.lbb[y] < least) {
        least = c.lba[x] + c.lbb[y];
        px = x;
        py = y;
      }
  }
  if (!std::isfinite(least)) return tau;
  const PairContext& pair = c.pair;
  scan_whole_chunk(pair, c.ci, *pair.qa, px, c.first(px), c.first(px) + c.frames(px), c.a,
                   c.cache_values(pair.cache_a), c.cache_done(pair.cache_a), c.scratch, c.counters);
  scan_whole_chunk(pair, c.ci, *pair.qb, py, c.first(py), c.first(py) + c.frames(py), c.b,
                   c.cache_values(pair.cache_b), c.cache_done(pair.cache_b), c.scratch, c.counters);
  c.scratch.done_a[px] = c.scratch.done_b[py] = 1;
  for (std::size_t s = c.first(px); s < c.first(px) + c.frames(px); ++s)
    for (std::size_t e = std::max(s + lo, c.first(py));
         e < std::min(c.first(py) + c.frames(py), s + hi + 1); ++e)
      tau = std::min(tau, (c.b[e] + c.lp(e)) + (c.a[s] - c.lp(s)));
  return tau;
}

// The needed blocks of the first side (need[bl]) into dst, in the one block
// walk: chunks shared with the other pair copied, blocks the probe scanned
// kept; a frame's partner bound (scan_whole_chunk) is its block's sb for
// a(s), pa for b(e).
void scan_first_side(BlockScan& c, const ResolvedFrame& q, const std::vector<std::uint8_t>& need,
                     const std::vector<std::uint8_t>& done, double* dst, FrameCache* cache,
                     double tau) {
  const bool is_a = &q == c.pair.qa;
  double partner[kBlock];
  walk_blocks(
      0, c.k, [&](std::size_t bl, std::size_t, std::size_t) { return need[bl] != 0; },
      [&](std::size_t bl, std::size_t f0, std::size_t f1) {
        if (done[bl]) return;
        std::fill(partner, partner + (f1 - f0), is_a ? c.scratch.sb[bl] : c.scratch.pa[bl]);
        scan_whole_chunk(c.pair, c.ci, q, bl, f0, f1, dst, c.cache_values(cache),
                         c.cache_done(cache), c.scratch, c.counters,
                         is_a ? c.pair.bound_a : c.pair.bound_b, partner, tau);
      },
      [&](std::size_t, std::size_t f0, std::size_t f1) { c.counters.pruned += f1 - f0; });
}

// Scans the needed blocks of the second side in the order of key[bl] = its
// bound + a lower bound of the first side's best partner (least first), with
// u the clip's best score so far (tau at first): a block whose key exceeds u
// cannot hold a pair scoring <= u and is dropped (need = 0). partner(f): the
// computed first side's best partner of frame f within the limits
// (scratch.run: min over s in [f - max, f - min] of a(s) - lambda P[s], or
// over e in [f + min, f + max] of b(e) + lambda P[e]); sign: +1 for the b
// side, -1 for the a side.
void scan_second_side(BlockScan& c, const ResolvedFrame& q, std::vector<std::uint8_t>& need,
                      const std::vector<std::uint8_t>& done, const double* lbx, double* dst,
                      FrameCache* cache, double sign, double tau) {
  Scratch& scratch = c.scratch;
  const std::vector<double>& key_other = scratch.key;
  std::vector<std::size_t>& order = scratch.order;
  order.clear();
  for (std::size_t bl = 0; bl < c.nb; ++bl) {
    if (need[bl])
      order.push_back(bl);
    else
      c.counters.pruned += c.frames(bl);
  }
  std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
    const double kx = lbx[x] + key_other[x], ky = lbx[y] + key_other[y];
    return kx != ky ? kx < ky : x < y;
  });
  double partner[kBlock];
  double u = tau;
  for (const std::size_t bl : order) {
    const std::size_t f0 = c.first(bl), f1 = f0 + c.frames(bl);
    if (safe(lbx[bl] + key_other[bl]) > u) {
      need[bl] = 0;
      c.counters.pruned += f1 - f0;
      continue;
    }
    if (!done[bl]) {
      for (std::size_t f = f0; f < f1; ++f) partner[f - f0] = sign * c.lp(f) + scratch.run[f];
      scan_whole_chunk(c.pair, c.ci, q, bl, f0, f1, dst, c.cache_values(cache), c.cache_done(cache),
                       scratch, c.counters, &q == c.pair.qa ? c.pair.bound_a : c.pair.bound_b,
                       partner, u);
    }
    for (std::size_t f = f0; f < f1; ++f)
      if (std::isfinite(dst[f]) && std::isfinite(scratch.run[f]))
        u = std::min(u, (dst[f] + sign * c.lp(f)) + scratch.run[f]);
  }
}

// The frames of the first to the last block a side needs, as [first, end).
std::pair<std::size_t, std::size_t> needed_span(const BlockScan& c,
                                                const std::vector<std::uint8_t>& need) {
  std::size_t b0 = 0, b1 = c.nb;
  while (b0 < c.nb && !need[b0]) ++b0;
  while (b1 > b0 && !need[b1 - 1]) --b1;
  return {c.first(b0), b1 > b0 ? c.first(b1 - 1) + c.frames(b1 - 1) : c.first(b0)};
}

// The a side computed first: the b side's blocks decided again with the
// computed values (+inf where not computed) in place of their bounds
// (docs/search.md "Frame pruning"): run[e] = min over its starts s of the
// computed a(s) - lambda P[s], need_b and key per needed block.
void redecide_ends(BlockScan& c, double tau) {
  Scratch& scratch = c.scratch;
  const std::size_t lo = c.bp.lo, hi = c.bp.hi;
  thread_local FixedWindowMinima windows;
  const auto [a0, a1] = needed_span(c, scratch.need_a);
  windows.build(a0, a1, hi - lo + 1, [&](std::size_t s) {
    const double v = scratch.need_a[s / kBlock] ? c.a[s] : kInf;
    return std::isfinite(v) ? v - c.lp(s) : kInf;
  });
  walk_blocks(
      0, c.k, [&](std::size_t bl, std::size_t, std::size_t) { return scratch.need_b[bl] != 0; },
      [&](std::size_t bl, std::size_t f0, std::size_t f1) {
        // pm: the least a(s) + lambda (P[e] - P[s]) over the pairs with e in
        // the block (computed a), <= every such pair's score less b(e).
        double pm = kInf;
        for (std::size_t e = f0; e < f1; ++e) {
          scratch.run[e] =
              windows.window(static_cast<std::ptrdiff_t>(e) - static_cast<std::ptrdiff_t>(hi));
          if (e < lo) scratch.run[e] = kInf;
          pm = std::min(pm, c.lp(e) + scratch.run[e]);
        }
        scratch.need_b[bl] = !(safe(c.lbb[bl] + pm) > tau);
        scratch.key[bl] = std::max(scratch.pa[bl], pm);
      },
      ignore_block);
}

// redecide_ends the other way round (the b side computed first): run[s] =
// min over its ends e of the computed b(e) + lambda P[e].
void redecide_starts(BlockScan& c, double tau) {
  Scratch& scratch = c.scratch;
  const std::size_t lo = c.bp.lo, hi = c.bp.hi;
  thread_local FixedWindowMinima windows;
  const auto [b0, b1] = needed_span(c, scratch.need_b);
  windows.build(b0, b1, hi - lo + 1, [&](std::size_t e) {
    const double v = scratch.need_b[e / kBlock] ? c.b[e] : kInf;
    return std::isfinite(v) ? v + c.lp(e) : kInf;
  });
  walk_blocks(
      0, c.k, [&](std::size_t bl, std::size_t, std::size_t) { return scratch.need_a[bl] != 0; },
      [&](std::size_t bl, std::size_t f0, std::size_t f1) {
        // sm: the least b(e) + lambda (P[e] - P[s]) over the pairs with s in
        // the block (computed b), <= every such pair's score less a(s).
        double sm = kInf;
        for (std::size_t f = f0; f < f1; ++f) {
          scratch.run[f] = windows.window(static_cast<std::ptrdiff_t>(f + lo));
          sm = std::min(sm, scratch.run[f] - c.lp(f));
        }
        scratch.need_a[bl] = !(safe(c.lba[bl] + sm) > tau);
        scratch.key[bl] = std::max(scratch.sb[bl], sm);
      },
      ignore_block);
}

// The sliding-window minimum of best_partial_motion over the computed
// values, +inf elsewhere: only the blocks that need b(e) hold ends, and the
// starts enter the window from the blocks that need a(s). False when no
// pair has finite values.
bool best_block_pair(const BlockScan& c, ClipMatch& out) {
  const std::vector<std::uint8_t>& need_a = c.scratch.need_a;
  const std::size_t lo = c.bp.lo, hi = c.bp.hi;
  thread_local std::vector<WindowMin::Entry> storage;
  WindowMin window(storage, c.k);
  bool have = false;
  std::size_t next_s = 0;  // the starts below it have entered the window
  ClipBest best;
  auto visit_ends = [&](std::size_t, std::size_t f0, std::size_t f1) {
    for (std::size_t e = std::max(f0, lo); e < f1; ++e) {
      const std::size_t s_end = e - lo + 1;
      while (next_s < s_end) {
        const std::size_t block_end = std::min(s_end, (next_s / kBlock + 1) * kBlock);
        if (need_a[next_s / kBlock]) {
          for (; next_s < block_end; ++next_s)
            if (std::isfinite(c.a[next_s])) window.push(next_s, c.a[next_s] - c.lp(next_s));
        } else {
          next_s = block_end;
        }
      }
      if (e > hi) window.drop_before(e - hi);
      if (!std::isfinite(c.b[e]) || window.empty()) continue;
      const double score = (c.b[e] + c.lp(e)) + window.min();
      if (score < best.score || !have) {  // strict: the earliest e wins ties
        best = {score, window.argmin(), e};
        have = true;
      }
    }
  };
  walk_blocks(
      0, c.k, [&](std::size_t bl, std::size_t, std::size_t) { return c.scratch.need_b[bl] != 0; },
      visit_ends, ignore_block);
  if (!have) return false;
  out = {best.score,
         c.ci.clip,
         best.s,
         best.e,
         c.a[best.s],
         c.b[best.e],
         c.prefix[best.e] - c.prefix[best.s]};
  return true;
}

}  // namespace

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
  const std::size_t k = ci.frame_count;
  BlockScan c{pair,
              ci,
              lba,
              lbb,
              scratch,
              counters,
              block_partners(pair, ci),
              k,
              (k + kBlock - 1) / kBlock};
  const std::size_t nb = c.nb;
  if (k <= c.bp.lo) return c.prune_clip();  // no pair within the limits
  // sb[bl]: the least lbb of the blocks holding the ends of bl's starts;
  // pa[bl]: the least lba of the blocks holding the starts of bl's ends
  // (+inf when there are none).
  scratch.sb.resize(nb);
  scratch.pa.resize(nb);
  partner_block_minima(c.bp, nb, true, lbb, [&](std::size_t bl, double m) { scratch.sb[bl] = m; });
  partner_block_minima(c.bp, nb, false, lba, [&](std::size_t bl, double m) { scratch.pa[bl] = m; });
  scratch.need_a.assign(nb, 0);
  scratch.need_b.assign(nb, 0);
  scratch.done_a.assign(nb, 0);
  scratch.done_b.assign(nb, 0);
  // a and b are sized on their own: a relative scan leaves b shorter than a
  // (it holds one partial motion's h values, not the clip's).
  if (scratch.a.size() < k) scratch.a.resize(k);
  if (scratch.b.size() < k) scratch.b.resize(k);
  c.a = scratch.a.data();
  c.b = scratch.b.data();
  c.prefix = clip_prefix(*pair.index, *pair.skeleton, ci);
  if (!std::isfinite(tau)) tau = probe_block_pair(c, tau);
  // A start of block bl needs a(s) if lba[bl] + sb[bl] can reach tau; an end
  // needs b(e) if lbb[bl] + pa[bl] can.
  double clip_lb = kInf;
  std::size_t count_a = 0, count_b = 0;
  for (std::size_t bl = 0; bl < nb; ++bl) {
    const double xa = lba[bl] + scratch.sb[bl];
    clip_lb = std::min(clip_lb, xa);
    scratch.need_a[bl] = c.bp.has_ends(bl) && !(safe(xa) > tau);
    scratch.need_b[bl] = c.bp.has_starts(bl) && !(safe(lbb[bl] + scratch.pa[bl]) > tau);
    count_a += scratch.need_a[bl];
    count_b += scratch.need_b[bl];
  }
  if (safe(clip_lb) > tau) return c.prune_clip();
  // The side with fewer blocks first; then the other side decided again with
  // the true values (+inf where not computed) of its frames' partners in
  // place of their bounds (docs/search.md "Frame pruning"). Only the blocks
  // the second side needs read run and key.
  scratch.run.resize(k);
  scratch.key.resize(nb);
  if (count_a <= count_b) {
    scan_first_side(c, *pair.qa, scratch.need_a, scratch.done_a, c.a, pair.cache_a, tau);
    redecide_ends(c, tau);
    scan_second_side(c, *pair.qb, scratch.need_b, scratch.done_b, lbb, c.b, pair.cache_b, 1.0, tau);
  } else {
    scan_first_side(c, *pair.qb, scratch.need_b, scratch.done_b, c.b, pair.cache_b, tau);
    redecide_starts(c, tau);
    scan_second_side(c, *pair.qa, scratch.need_a, scratch.done_a, lba, c.a, pair.cache_a, -1.0,
                     tau);
  }
  return best_block_pair(c, out);
}

}  // namespace mocap::search_detail
