// The block-level clip scan of world mode (clip_scans.hpp): block bounds,
// then eval_clip_blocks.
#include <algorithm>
#include <cmath>
#include <span>

#include "clip_scans.hpp"

namespace mocap::search_detail {

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
  // PA / SB of the sketch bounds (a block pairs with itself and the
  // blocks after it); the box is needed where they do not exceed tau.
  // The needed rows are all requested (prefetched) before the first
  // box is computed, so their cache misses overlap.
  scratch.blk_pa.resize(nb);
  scratch.blk_need.resize(nb);
  double prefix = kInf, suffix = kInf;
  for (std::size_t bl = 0; bl < nb; ++bl)
    scratch.blk_pa[bl] = prefix = std::min(prefix, scratch.blk_a[bl]);
  for (std::size_t bl = nb; bl-- > 0;) {
    suffix = std::min(suffix, scratch.blk_b[bl]);
    const bool need_a = sketch_a && !(safe(scratch.blk_a[bl] + suffix) > tau);
    const bool need_b = sketch_b && !(safe(scratch.blk_b[bl] + scratch.blk_pa[bl]) > tau);
    scratch.blk_need[bl] = static_cast<std::uint8_t>(need_a | (need_b << 1));
    if (need_a || need_b) prefetch_block_box(tables, ci.block_start + bl);
  }
  for (std::size_t bl = 0; bl < nb; ++bl) {
    if (scratch.blk_need[bl] & 1) scratch.blk_a[bl] = std::max(scratch.blk_a[bl], box(qa, bl));
    if (scratch.blk_need[bl] & 2) scratch.blk_b[bl] = std::max(scratch.blk_b[bl], box(qb, bl));
  }
}

// World mode, exact, both query frames bounded by boxes only (full or
// root-only, no per-frame bounds): eval_clip_world's decisions taken per
// 16-frame block. lba / lbb are the box bounds of the clip's blocks (as
// double); every bound of a frame is its block's, so a block's frames differ
// only by which neighbours count as "s < e" (the first / last frame of a
// block). On top of those decisions the clip prunes against its own best
// pair so far (docs/search.md "The clip's own best"): a probe pair of blocks
// first while tau is infinite, and the second side's blocks in the order of
// their bounds. The chunks are eval_clip_world's 16-frame tiles (same
// values, same answer); fewer of them are scanned.
bool eval_clip_blocks(const PairContext& pair, const ClipInfo& ci, double tau, const double* lba,
                      const double* lbb, Scratch& scratch, ClipCounters& counters, ClipMatch& out) {
  const SkeletonData& skeleton = *pair.skeleton;
  const std::size_t k = ci.frame_count;
  const std::size_t nb = (k + kBlock - 1) / kBlock;
  auto first = [](std::size_t bl) { return bl * kBlock; };
  auto frames = [&](std::size_t bl) { return std::min(k, bl * kBlock + kBlock) - bl * kBlock; };
  // sb[b] = min_{g >= b} lbb[g] (sb[nb] = inf); pa[b + 1] = min_{g <= b} lba[g] (pa[0] = inf).
  std::vector<double>& sb = scratch.sb;
  std::vector<double>& pa = scratch.pa;
  sb.resize(nb + 1);
  pa.resize(nb + 1);
  sb[nb] = kInf;
  for (std::size_t bl = nb; bl-- > 0;) sb[bl] = std::min(sb[bl + 1], lbb[bl]);
  pa[0] = kInf;
  for (std::size_t bl = 0; bl < nb; ++bl) pa[bl + 1] = std::min(pa[bl], lba[bl]);
  // Frame s of block b needs a(s) if lba[b] + min_{e > s} lb(e) can reach tau:
  // sb[b] for all but the block's last frame, sb[b + 1] for it. Frame e
  // needs b(e) if lbb[b] + min_{s < e} la(s) can: pa[b + 1], or pa[b] for
  // the block's first frame.
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
  // block pair x <= y of least lba[x] + lbb[y] is scanned first; its best
  // pair s < e is a real score of this clip, so the clip's optimum is at most
  // that: it serves as the clip's tau (every decision below stays sound).
  if (!std::isfinite(tau) && k >= 2) {
    double least = kInf;
    std::size_t px = 0, py = 0;
    for (std::size_t x = 0; x < nb; ++x)
      for (std::size_t y = x; y < nb; ++y)
        if ((x != y || frames(x) >= 2) && lba[x] + lbb[y] < least) {
          least = lba[x] + lbb[y];
          px = x;
          py = y;
        }
    if (std::isfinite(least)) {
      scan_whole_chunk(pair, ci, *pair.qa, px, first(px), first(px) + frames(px), a,
                       cache_values(pair.cache_a), cache_done(pair.cache_a), scratch, counters);
      scan_whole_chunk(pair, ci, *pair.qb, py, first(py), first(py) + frames(py), b,
                       cache_values(pair.cache_b), cache_done(pair.cache_b), scratch, counters);
      scratch.done_a[px] = scratch.done_b[py] = 1;
      for (std::size_t s = first(px); s < first(px) + frames(px); ++s)
        for (std::size_t e = std::max(s + 1, first(py)); e < first(py) + frames(py); ++e)
          tau = std::min(tau, (b[e] + lp(e)) + (a[s] - lp(s)));
    }
  }
  double clip_lb = kInf;
  std::size_t count_a = 0, count_b = 0;
  for (std::size_t bl = 0; bl < nb; ++bl) {
    const double xa = lba[bl] + (frames(bl) >= 2 ? sb[bl] : sb[bl + 1]);
    clip_lb = std::min(clip_lb, xa);
    need_a[bl] = !(safe(xa) > tau);
    const double xb = lbb[bl] + (frames(bl) >= 2 ? pa[bl + 1] : pa[bl]);
    need_b[bl] = !(safe(xb) > tau);
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
  // A frame's partner bound (scan_whole_chunk): for a(s), the least lbb of
  // the blocks with a frame after s; for b(e), the least lba of the blocks
  // with a frame before e; on the second side, the first side's best partner.
  double partner[kBlock];
  auto side = [&](const ResolvedFrame& q, const std::vector<std::uint8_t>& need,
                  const std::vector<std::uint8_t>& done, double* dst, FrameCache* cache) {
    const bool is_a = &q == pair.qa;
    for (std::size_t bl = 0; bl < nb; ++bl) {
      const std::size_t f0 = first(bl), f1 = f0 + frames(bl);
      if (!need[bl]) {
        counters.pruned += f1 - f0;
      } else if (!done[bl]) {
        for (std::size_t f = f0; f < f1; ++f)
          partner[f - f0] =
              is_a ? (f + 1 == f1 ? sb[bl + 1] : sb[bl]) : (f == f0 ? pa[bl] : pa[bl + 1]);
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
  // f (min over s < f of a(s) - lambda P[s], or over e > f of b(e) + lambda P[e]).
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
  // The side with fewer blocks first; then the other side decided again with
  // its true values (+inf where not computed) in place of its bounds, for the
  // frames its bounds kept (docs/search.md "Frame pruning").
  std::vector<double>& key = scratch.key;
  key.resize(nb);
  if (count_a <= count_b) {
    side(*pair.qa, need_a, scratch.done_a, a, pair.cache_a);
    double pm = kInf;  // min_{s < first frame of the block} of the computed a(s)
    for (std::size_t bl = 0; bl < nb; ++bl) {
      const std::size_t f0 = first(bl), n = frames(bl);
      // min_{s < last frame of the block} of the computed a(s)
      double pm_last = pm;
      if (need_a[bl])
        for (std::size_t f = f0; f + 1 < f0 + n; ++f) pm_last = std::min(pm_last, a[f]);
      if (need_b[bl]) {
        const bool first_frame = !(safe(lbb[bl] + pa[bl]) > tau) && !(safe(lbb[bl] + pm) > tau);
        const bool rest =
            n >= 2 && !(safe(lbb[bl] + pa[bl + 1]) > tau) && !(safe(lbb[bl] + pm_last) > tau);
        need_b[bl] = first_frame || rest;
      }
      key[bl] = std::max(pa[bl + 1], pm_last);  // <= a(s) + lambda (P[e] - P[s]) for s < e in bl
      if (need_a[bl]) pm = std::min(pm_last, a[f0 + n - 1]);
    }
    // run[e] = min_{s < e} of the computed a(s) - lambda P[s]
    double m = kInf;
    for (std::size_t bl = 0; bl < nb; ++bl) {
      const std::size_t f0 = first(bl), f1 = f0 + frames(bl);
      for (std::size_t f = f0; f < f1; ++f) {
        scratch.run[f] = m;
        if (need_a[bl] && std::isfinite(a[f])) m = std::min(m, a[f] - lp(f));
      }
    }
    second_side(*pair.qb, need_b, scratch.done_b, lbb, key, b, pair.cache_b, 1.0);
  } else {
    side(*pair.qb, need_b, scratch.done_b, b, pair.cache_b);
    double sm = kInf;  // min_{e > last frame of the block} of the computed b(e)
    for (std::size_t bl = nb; bl-- > 0;) {
      const std::size_t f0 = first(bl), n = frames(bl);
      // min_{e > first frame of the block} of the computed b(e)
      double sm_first = sm;
      if (need_b[bl])
        for (std::size_t f = f0 + 1; f < f0 + n; ++f) sm_first = std::min(sm_first, b[f]);
      if (need_a[bl]) {
        const bool last = !(safe(lba[bl] + sb[bl + 1]) > tau) && !(safe(lba[bl] + sm) > tau);
        const bool rest =
            n >= 2 && !(safe(lba[bl] + sb[bl]) > tau) && !(safe(lba[bl] + sm_first) > tau);
        need_a[bl] = last || rest;
      }
      key[bl] = std::max(sb[bl], sm_first);  // <= b(e) + lambda (P[e] - P[s]) for e > s in bl
      if (need_b[bl]) sm = std::min(sm_first, b[f0]);
    }
    // run[s] = min_{e > s} of the computed b(e) + lambda P[e]
    double m = kInf;
    for (std::size_t bl = nb; bl-- > 0;) {
      const std::size_t f0 = first(bl), f1 = f0 + frames(bl);
      for (std::size_t f = f1; f-- > f0;) {
        scratch.run[f] = m;
        if (need_b[bl] && std::isfinite(b[f])) m = std::min(m, b[f] + lp(f));
      }
    }
    second_side(*pair.qa, need_a, scratch.done_a, lba, key, a, pair.cache_a, -1.0);
  }
  // Running minimum (best_partial_motion) over the computed values, +inf
  // elsewhere: blocks with neither side computed change nothing and are skipped.
  bool have = false;
  double run_min = kInf;
  std::size_t run_s = 0;
  ClipBest best;
  for (std::size_t bl = 0; bl < nb; ++bl) {
    if (!need_a[bl] && !need_b[bl]) continue;
    const std::size_t f0 = first(bl), f1 = f0 + frames(bl);
    for (std::size_t f = f0; f < f1; ++f) {
      // e = f with s < f, then s = f for the later e.
      if (need_b[bl] && f > 0 && std::isfinite(b[f]) && std::isfinite(run_min)) {
        const double score = (b[f] + lp(f)) + run_min;
        if (score < best.score || !have) {
          best = {score, run_s, f};
          have = true;
        }
      }
      if (need_a[bl] && std::isfinite(a[f])) {
        const double v = a[f] - lp(f);
        if (v < run_min) {
          run_min = v;
          run_s = f;
        }
      }
    }
  }
  if (!have) return false;
  out = {
      best.score, ci.clip, best.s, best.e, a[best.s], b[best.e], prefix[best.e] - prefix[best.s]};
  return true;
}

}  // namespace mocap::search_detail
