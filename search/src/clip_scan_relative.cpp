// The clip scan of the relative placements (clip_scans.hpp).
#include <algorithm>
#include <cmath>
#include <span>

#include "clip_scans.hpp"
#include "frame_energy.hpp"
#include "relative_frames.hpp"
#include "window_minima.hpp"

namespace mocap::search_detail {

// a(s) with Q^h placed on F^s, b(s, e) with Q^h+1 placed by F^s's ground
// pose (relative_frames.hpp); O(K L) with L = max_length_s / frame time.
// Exact mode skips start frames whose a(s) plus the least bound of b over
// their window exceeds tau, and end frames whose bound (relative_bounds.hpp)
// does, tau lowered to the clip's best so far.
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
  // The clip's box bounds of both terms (their parts that hold wherever the
  // query frames are placed).
  if (prune && pair.in_bound != nullptr && pair.out_bound != nullptr &&
      safe(clip_relative_bound(*pair.in_bound, skeleton.tables, ci.row) +
           clip_relative_bound(*pair.out_bound, skeleton.tables, ci.row)) > tau) {
    counters.clip_pruned = true;
    counters.pruned += total;
    return false;
  }
  // a(s), or where Q^h is a full frame first its lower bound
  // (relative_bounds.hpp, Q^h placed on F^s).
  scratch.a.assign(k, kInf);
  const bool bounded_a = prune && pair.in_bound != nullptr;
  if (bounded_a) {
    relative_bound_frames(*pair.in_bound, skeleton.tables, ci.frame_start, k, scratch.in_frames);
    for (std::size_t s = 0; s < s_end; ++s)
      scratch.a[s] = relative_bound(*pair.in_bound, scratch.in_frames, s,
                                    place(s).apply(pair.in_bound->com_body));
  } else {
    for (std::size_t s = 0; s < s_end; ++s)
      evaluate_h(*pair.qa, skeleton, *pair.index, pair.t, ci.frame_start + s,
                 ci.frame_start + s + 1, scratch.a.data() + s, scratch, place(s));
    counters.evaluated += s_end;
  }
  // a_exact[s]: scratch.a[s] is a(s) itself, not its bound.
  scratch.a_exact.assign(k, bounded_a ? 0 : 1);
  const bool bounded = prune && pair.out_bound != nullptr;
  if (bounded) {
    // la[s]: the least placement-free bound of b over s's window [s + min, s + max].
    const RelativeBoundFrames& fr = scratch.out_frames;
    relative_bound_frames(*pair.out_bound, skeleton.tables, ci.frame_start, k, scratch.out_frames);
    thread_local FixedWindowMinima windows;
    windows.build(0, k, len.max - len.min + 1, [&](std::size_t e) { return fr.lower(e); });
    scratch.la.resize(s_end);
    for (std::size_t s = 0; s < s_end; ++s)
      scratch.la[s] = windows.window(static_cast<std::ptrdiff_t>(s + len.min));
  } else {
    scratch.la.assign(s_end, 0.0);
  }
  double min_lb = kInf;
  for (std::size_t s = 0; s < s_end; ++s) min_lb = std::min(min_lb, scratch.a[s] + scratch.la[s]);
  if (prune && safe(min_lb) > tau) {
    counters.clip_pruned = true;
    counters.pruned += total - (bounded_a ? 0 : s_end);
    return false;
  }
  const std::span<const double> prefix = clip_prefix(*pair.index, skeleton, ci);
  ClipBest best;
  bool have = false;
  scratch.b.resize(l);
  double best_out = 0.0;
  for (std::size_t s = 0; s < s_end; ++s) {
    const std::size_t e0 = s + len.min, e1 = std::min(k - 1, s + l);
    const double thr = have ? std::min(tau, best.score) : tau;
    if (prune && safe(scratch.a[s] + scratch.la[s]) > thr) {
      counters.pruned += e1 - e0 + 1 + (scratch.a_exact[s] ? 0 : 1);
      continue;
    }
    if (!scratch.a_exact[s]) {
      evaluate_h(*pair.qa, skeleton, *pair.index, pair.t, ci.frame_start + s,
                 ci.frame_start + s + 1, scratch.a.data() + s, scratch, place(s));
      scratch.a_exact[s] = 1;
      ++counters.evaluated;
      if (safe(scratch.a[s] + scratch.la[s]) > thr) {
        counters.pruned += e1 - e0 + 1;
        continue;
      }
    }
    const GroundPose at = place(s);
    std::size_t first = e1 + 1, last = e0;  // the frames to evaluate lie in [first, last]
    if (bounded) {
      const Eigen::Vector3d com = at.apply(pair.out_bound->com_body);
      const double base = scratch.a[s] - pair.lambda * prefix[s];
      for (std::size_t e = e0; e <= e1; ++e) {
        const double lb = base + pair.lambda * prefix[e] +
                          relative_bound(*pair.out_bound, scratch.out_frames, e, com);
        if (safe(lb) <= thr) {
          first = std::min(first, e);
          last = e;
        }
      }
      if (first > last) {
        counters.pruned += e1 - e0 + 1;
        continue;
      }
    } else {
      first = e0;
      last = e1;
    }
    evaluate_h(*pair.qb, skeleton, *pair.index, pair.t, ci.frame_start + first,
               ci.frame_start + last + 1, scratch.b.data(), scratch, at);
    counters.evaluated += last - first + 1;
    counters.pruned += (e1 - e0 + 1) - (last - first + 1);
    for (std::size_t e = first; e <= last; ++e) {
      const double b = scratch.b[e - first];
      const double score = (b + pair.lambda * prefix[e]) + (scratch.a[s] - pair.lambda * prefix[s]);
      if (better(score, e, s, best, have)) {
        best = {score, s, e};
        best_out = b;
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
         best_out,
         prefix[best.e] - prefix[best.s]};
  return true;
}

}  // namespace mocap::search_detail
