// The clip scan of the relative placements (clip_scans.hpp).
#include <algorithm>
#include <cmath>
#include <deque>
#include <span>

#include "clip_scans.hpp"
#include "frame_energy.hpp"
#include "relative_frames.hpp"

namespace mocap::search_detail {

namespace {

// The least of lower[e] over each window [s + lo, min(k - 1, s + hi)], s < s_end.
void window_minima(const OutBoundFrames& fr, std::size_t k, std::size_t s_end, LengthFrames len,
                   std::vector<double>& out) {
  out.assign(s_end, kInf);
  std::deque<std::size_t> window;  // frames of increasing lower(), in frame order
  std::size_t next = 0;            // next frame to enter
  for (std::size_t s = 0; s < s_end; ++s) {
    const std::size_t e0 = s + len.min, e1 = std::min(k - 1, s + len.max);
    for (next = std::max(next, e0); next <= e1; ++next) {
      while (!window.empty() && fr.lower(window.back()) >= fr.lower(next)) window.pop_back();
      window.push_back(next);
    }
    while (!window.empty() && window.front() < e0) window.pop_front();
    if (!window.empty()) out[s] = fr.lower(window.front());
  }
}

}  // namespace

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
      safe(clip_out_bound(*pair.in_bound, skeleton.tables, ci.row) +
           clip_out_bound(*pair.out_bound, skeleton.tables, ci.row)) > tau) {
    counters.clip_pruned = true;
    counters.pruned += total;
    return false;
  }
  // a(s), or where Q^h is a full frame first its lower bound (the b bound's
  // form, relative_bounds.hpp, with Q^h placed on F^s).
  scratch.a.assign(k, kInf);
  const bool bounded_a = prune && pair.in_bound != nullptr;
  if (bounded_a) {
    out_bound_frames(*pair.in_bound, skeleton.tables, ci.frame_start, k, scratch.in_frames);
    for (std::size_t s = 0; s < s_end; ++s)
      scratch.a[s] =
          out_bound(*pair.in_bound, scratch.in_frames, s, place(s).apply(pair.in_bound->com_body));
  } else {
    for (std::size_t s = 0; s < s_end; ++s)
      evaluate_h(*pair.qa, skeleton, *pair.index, pair.t, ci.frame_start + s,
                 ci.frame_start + s + 1, scratch.a.data() + s, scratch, place(s));
    counters.evaluated += s_end;
  }
  // a_known[s]: a(s) itself, not its bound.
  scratch.skip_a.assign(k, bounded_a ? 0 : 1);
  const bool bounded = prune && pair.out_bound != nullptr;
  if (bounded) {
    out_bound_frames(*pair.out_bound, skeleton.tables, ci.frame_start, k, scratch.out_frames);
    window_minima(scratch.out_frames, k, s_end, len, scratch.la);
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
  scratch.need_e.resize(l + 1);
  double best_out = 0.0;
  for (std::size_t s = 0; s < s_end; ++s) {
    const std::size_t e0 = s + len.min, e1 = std::min(k - 1, s + l);
    const double thr = have ? std::min(tau, best.score) : tau;
    if (prune && safe(scratch.a[s] + scratch.la[s]) > thr) {
      counters.pruned += e1 - e0 + 1 + (scratch.skip_a[s] ? 0 : 1);
      continue;
    }
    if (!scratch.skip_a[s]) {
      evaluate_h(*pair.qa, skeleton, *pair.index, pair.t, ci.frame_start + s,
                 ci.frame_start + s + 1, scratch.a.data() + s, scratch, place(s));
      scratch.skip_a[s] = 1;
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
        const double lb =
            base + pair.lambda * prefix[e] + out_bound(*pair.out_bound, scratch.out_frames, e, com);
        const bool need = safe(lb) <= thr;
        scratch.need_e[e - e0] = need;
        if (need) {
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
      std::fill(scratch.need_e.begin(), scratch.need_e.begin() + (e1 - e0 + 1), 1);
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
