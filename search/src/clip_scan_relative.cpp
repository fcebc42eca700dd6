// The clip scan of the relative placements (clip_scans.hpp).
#include <algorithm>
#include <cmath>
#include <span>

#include "clip_scans.hpp"
#include "frame_energy.hpp"
#include "relative_frames.hpp"

namespace mocap::search_detail {

// Relative mode: a(s) with Q^h placed on F^s, b(s, e) with Q^h+1 placed
// relative to F^s; O(K L) with L = max_length_s / frame time.
bool eval_clip_relative(const PairContext& pair, const ClipInfo& ci, double tau, Scratch& scratch,
                        ClipCounters& counters, ClipMatch& out) {
  const SkeletonData& skeleton = *pair.skeleton;
  const std::size_t k = ci.frame_count;
  const double dt = pair.index->clips()[ci.clip].frame_time_s;
  const LengthFrames len = length_frames(pair, dt);
  if (k <= len.min) return false;
  const std::size_t l = len.max;
  const std::size_t s_end = k - len.min;  // s < s_end
  const bool prune = pair.mode != SearchMode::brute;
  auto place = [&](std::size_t f) {
    return frame_placement(skeleton, pair.placement, ci.frame_start + f);
  };
  std::uint64_t total = 0;
  for (std::size_t s = 0; s < s_end; ++s) total += 1 + (std::min(k - 1, s + l) - (s + len.min) + 1);
  scratch.a.assign(k, kInf);
  double min_a = kInf;
  for (std::size_t s = 0; s < s_end; ++s) {
    evaluate_h(*pair.qa, skeleton, *pair.index, pair.t, ci.frame_start + s, ci.frame_start + s + 1,
               scratch.a.data() + s, scratch, place(s));
    min_a = std::min(min_a, scratch.a[s]);
  }
  counters.evaluated += s_end;
  if (prune && safe(min_a) > tau) {
    counters.clip_pruned = true;
    counters.pruned += total - s_end;
    return false;
  }
  const std::span<const double> prefix = clip_prefix(*pair.index, skeleton, ci);
  ClipBest best;
  bool have = false;
  scratch.b.resize(l);
  for (std::size_t s = 0; s < s_end; ++s) {
    const std::size_t e0 = s + len.min, e1 = std::min(k - 1, s + l);
    if (prune && safe(scratch.a[s]) > tau) {
      counters.pruned += e1 - e0 + 1;
      continue;
    }
    evaluate_h(*pair.qb, skeleton, *pair.index, pair.t, ci.frame_start + e0,
               ci.frame_start + e1 + 1, scratch.b.data(), scratch, place(s));
    counters.evaluated += e1 - e0 + 1;
    for (std::size_t e = e0; e <= e1; ++e) {
      const double score =
          (scratch.b[e - e0] + pair.lambda * prefix[e]) + (scratch.a[s] - pair.lambda * prefix[s]);
      if (better(score, e, s, best, have)) {
        best = {score, s, e};
        out.h_out = scratch.b[e - e0];
        have = true;
      }
    }
  }
  if (!have) return false;
  out = {best.score,
         ci.clip,
         best.s,
         best.e,
         scratch.a[best.s],
         out.h_out,
         prefix[best.e] - prefix[best.s]};
  return true;
}

}  // namespace mocap::search_detail
