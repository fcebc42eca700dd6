// The clip scan of the relative placements (clip_scans.hpp).
#include <algorithm>
#include <array>
#include <cmath>
#include <span>

#include "query/relative_frames.hpp"
#include "scan/clip_scans.hpp"
#include "scan/frame_energy.hpp"
#include "scan/window_minima.hpp"

namespace mocap::search_detail {
namespace {

// Root-only Q^h+1: per block of kBlock start frames, the box of where their
// placements put Q^h+1's root against every block of end frames they reach;
// a start block none of whose end blocks can beat tau gets la = inf (its
// start frames are skipped). The path-cost term is left out (it is >= 0).
template <class Placed>
void root_block_pass(const RootBoundQuery& q, std::size_t s_end, const LengthFrames& len,
                     double tau, const Placed& placed, Scratch& scratch) {
  constexpr std::size_t B = RootBlocks::kBlock;
  const RootBlocks& blocks = scratch.root_blocks;
  const std::size_t last_e = blocks.x0.size() * B;  // past the clip's last block
  for (std::size_t sa = 0; sa < s_end; sa += B) {
    const std::size_t sb = std::min(s_end, sa + B);  // [sa, sb)
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(kInf), hi = -lo;
    double amin = kInf;
    for (std::size_t s = sa; s < sb; ++s) {
      const Eigen::Vector3d p = placed(q, s);
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
      amin = std::min(amin, scratch.a[s]);
    }
    const std::size_t e_lo = sa + len.min, e_hi = std::min(last_e - 1, sb - 1 + len.max);
    bool open = false;
    for (std::size_t j = e_lo / B; j <= e_hi / B && !open; ++j)
      open = safe(amin + blocks.bound_box(q, j, lo, hi)) <= tau;
    if (!open)
      for (std::size_t s = sa; s < sb; ++s) scratch.la[s] = kInf;
  }
}

// The root-only bound of a term over a whole clip (box = its clip_root_boxes
// row): Q^h ("in") lands at F^s plus its body offset d exactly; Q^h+1
// ("out") at F^s + d turned, at least |d| minus the clip's root extent
// from any F^e (per axis under "position"); for a frame that turns the body,
// its height alone (relative_bounds.hpp).
double clip_root_bound(const PairContext& pair, const RootBoundQuery& q,
                       const std::array<double, 9>& box, bool in) {
  const double dx = q.root_body.x(), dz = q.root_body.z();
  const double ex = in ? 0.0 : box[1] - box[0], ez = in ? 0.0 : box[5] - box[4];
  const double yq = q.root_body.y();
  const double dy = yq < box[2] ? box[2] - yq : (yq > box[3] ? yq - box[3] : 0.0);
  double gx = 0.0, gz = 0.0;
  if (q.turns) {
    // A turn moves the segments otherwise than the root: the height alone.
  } else if (pair.placement == FramePlacement::relative) {
    gx = std::max(0.0, std::hypot(dx, dz) - std::hypot(ex, ez));
  } else {
    gx = std::max(0.0, std::abs(dx) - ex);
    gz = std::max(0.0, std::abs(dz) - ez);
  }
  return root_bound(q, box[6], box[7], box[8], gx, dy, gz);
}

// b(e) of a placement-free Q^h+1 over the clip frames [first, last]: the
// runs of them not computed yet for this clip, into scratch.b_free (no
// placement: the frame's h does not depend on it).
void evaluate_free_frames(const PairContext& pair, const ClipInfo& ci, std::size_t first,
                          std::size_t last, Scratch& scratch) {
  for (std::size_t e = first; e <= last;) {
    if (scratch.b_free_done[e]) {
      ++e;
      continue;
    }
    std::size_t end = e;
    while (end <= last && !scratch.b_free_done[end]) scratch.b_free_done[end++] = 1;
    evaluate_h(*pair.qb, *pair.skeleton, *pair.index, pair.t, ci.frame_start + e,
               ci.frame_start + end, scratch.b_free.data() + e, scratch);
    e = end;
  }
}

}  // namespace

double relative_clip_bound(const PairContext& pair, std::size_t row) {
  const SkeletonData& skeleton = *pair.skeleton;
  const SkeletonTables& tables = skeleton.tables;
  if (pair.root_in != nullptr || pair.root_out != nullptr) ensure_frame_kinetic(skeleton);
  double a = 0.0, b = 0.0;
  if (pair.in_bound != nullptr)
    a = clip_relative_bound(*pair.in_bound, tables, row);
  else if (pair.root_in != nullptr)
    a = clip_root_bound(pair, *pair.root_in, skeleton.caches.clip_root_boxes[row], true);
  if (pair.out_bound != nullptr)
    b = clip_relative_bound(*pair.out_bound, tables, row);
  else if (pair.root_out != nullptr)
    b = clip_root_bound(pair, *pair.root_out, skeleton.caches.clip_root_boxes[row], false);
  return a + b;
}

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
  if (prune && has_relative_clip_bound(pair) && safe(relative_clip_bound(pair, ci.row)) > tau) {
    counters.clip_pruned = true;
    counters.pruned += total;
    return false;
  }
  // a(s), or where Q^h is a full frame first its lower bound
  // (relative_bounds.hpp, Q^h placed on F^s).
  scratch.a.assign(k, kInf);
  const bool bounded_a = prune && pair.in_bound != nullptr;
  const bool root_a = prune && !bounded_a && pair.root_in != nullptr;
  const bool root_b = prune && pair.out_bound == nullptr && pair.root_out != nullptr;
  const bool turns = (root_a && pair.root_in->turns) || (root_b && pair.root_out->turns);
  const double* headings = nullptr;  // and heading_cos_sin, 2 a frame
  const double* cos_sin = nullptr;
  const float* moments_in = nullptr;  // the turning frames' moments (turn_moments_of)
  const float* moments_out = nullptr;
  if (root_a || root_b) {
    ensure_frame_kinetic(skeleton);
    if (pair.placement == FramePlacement::relative || turns) {
      headings = frame_headings(skeleton).data() + ci.frame_start;
      cos_sin = skeleton.caches.heading_cos_sin.data() + 2 * ci.frame_start;
    }
    if (root_a && pair.root_in->turns)
      moments_in = turn_moments_of(*pair.root_in, skeleton) + 4 * ci.frame_start;
    if (root_b && pair.root_out->turns)
      moments_out = turn_moments_of(*pair.root_out, skeleton) + 4 * ci.frame_start;
    if (root_b && !pair.root_out->turns) scratch.root_blocks.build(skeleton, ci.frame_start, k);
  }
  auto placed = [&](const RootBoundQuery& q, std::size_t f) {
    return place_point(skeleton, pair.placement, ci.frame_start + f, q.root_body);
  };
  // cos and sin of where a partial motion starting at f turns a turning
  // frame (world).
  auto placed_heading = [&](const RootBoundQuery& q, std::size_t f) {
    const double psi =
        q.heading_body + (pair.placement == FramePlacement::relative ? headings[f] : 0.0);
    return std::array<double, 2>{std::cos(psi), std::sin(psi)};
  };
  const float* kin = skeleton.caches.kinetic.data() + ci.frame_start;
  const float* kin_rot = skeleton.caches.kinetic_rot.data() + ci.frame_start;
  auto root_at = [&](std::size_t f) {
    const float* r = skeleton.tables.root_positions.data() + ci.frame_start + f;
    const std::size_t st = skeleton.tables.frame_count;
    return Eigen::Vector3d(r[0], r[st], r[2 * st]);
  };
  // A root frame's bound at frame f with its root placed at p (world) and,
  // for a turning one (its moments), its heading's cos and sin psi.
  auto root_frame_bound = [&](const RootBoundQuery& q, const float* moments, std::size_t f,
                              const Eigen::Vector3d& p, const std::array<double, 2>& psi) {
    return frame_root_bound(q, moments == nullptr ? nullptr : moments + 4 * f, kin[f], kin_rot[f],
                            root_at(f), cos_sin == nullptr ? nullptr : cos_sin + 2 * f, p, psi[0],
                            psi[1]);
  };
  if (bounded_a) {
    relative_bound_frames(*pair.in_bound, skeleton.tables, ci.frame_start, k, scratch.in_frames);
    for (std::size_t s = 0; s < s_end; ++s)
      scratch.a[s] = relative_bound(*pair.in_bound, scratch.in_frames, s,
                                    place(s).apply(pair.in_bound->com_body));
  } else if (root_a) {
    for (std::size_t s = 0; s < s_end; ++s)
      scratch.a[s] = root_frame_bound(*pair.root_in, moments_in, s, placed(*pair.root_in, s),
                                      placed_heading(*pair.root_in, s));
  } else {
    for (std::size_t s = 0; s < s_end; ++s)
      evaluate_h(*pair.qa, skeleton, *pair.index, pair.t, ci.frame_start + s,
                 ci.frame_start + s + 1, scratch.a.data() + s, scratch, place(s));
    counters.evaluated += s_end;
  }
  // a_exact[s]: scratch.a[s] is a(s) itself, not its bound.
  const bool a_bounds = bounded_a || root_a;
  scratch.a_exact.assign(k, a_bounds ? 0 : 1);
  const bool bounded = prune && pair.out_bound != nullptr;
  // la[s]: the least placement-free bound `lower` of b over s's window
  // [s + min, s + max].
  auto window_minima = [&](const auto& lower) {
    thread_local FixedWindowMinima windows;
    windows.build(0, k, len.max - len.min + 1, lower);
    scratch.la.resize(s_end);
    for (std::size_t s = 0; s < s_end; ++s)
      scratch.la[s] = windows.window(static_cast<std::ptrdiff_t>(s + len.min));
  };
  if (bounded) {
    const RelativeBoundFrames& fr = scratch.out_frames;
    relative_bound_frames(*pair.out_bound, skeleton.tables, ci.frame_start, k, scratch.out_frames);
    window_minima([&](std::size_t e) { return fr.lower(e); });
  } else if (root_b) {
    // The root bound with the x and z distances 0 (they depend on s).
    const RootBoundQuery& q = *pair.root_out;
    window_minima([&](std::size_t e) {
      return root_bound(q, kin[e], kin[e], kin_rot[e], 0.0, q.root_body.y() - root_at(e).y(), 0.0);
    });
  } else {
    scratch.la.assign(s_end, 0.0);
  }
  if (root_b && !pair.root_out->turns)
    root_block_pass(*pair.root_out, s_end, len, tau, placed, scratch);
  double min_lb = kInf;
  for (std::size_t s = 0; s < s_end; ++s) min_lb = std::min(min_lb, scratch.a[s] + scratch.la[s]);
  if (prune && safe(min_lb) > tau) {
    counters.clip_pruned = true;
    counters.pruned += total - (a_bounds ? 0 : s_end);
    return false;
  }
  const std::span<const double> prefix = clip_prefix(*pair.index, skeleton, ci);
  ClipBest best;
  bool have = false;
  scratch.b.resize(l);
  // A Q^h+1 whose h does not depend on where it is placed (joint rotations,
  // body-frame constraints: placement_free) is evaluated once per end frame,
  // not once per (start, end) pair.
  const bool b_free = placement_free(*pair.qb);
  if (b_free) {
    scratch.b_free.resize(k);
    scratch.b_free_done.assign(k, 0);
  }
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
    } else if (root_b) {
      // Per block of end frames: the box of its roots against the placed
      // query root (relative_bounds.hpp RootBlocks), frame by frame for a
      // turning frame; path costs only grow.
      const RootBoundQuery& q = *pair.root_out;
      const RootBlocks& blocks = scratch.root_blocks;
      const Eigen::Vector3d p = placed(q, s);
      const std::array<double, 2> psi =
          q.turns ? placed_heading(q, s) : std::array<double, 2>{1.0, 0.0};
      const double base = scratch.a[s] - pair.lambda * prefix[s];
      constexpr std::size_t B = RootBlocks::kBlock;
      for (std::size_t j = e0 / B; j <= e1 / B; ++j) {
        const std::size_t lo = std::max(e0, j * B), hi = std::min(e1, j * B + B - 1);
        if (!q.turns && safe(base + pair.lambda * prefix[lo] + blocks.bound(q, j, p)) > thr)
          continue;
        for (std::size_t e = lo; e <= hi; ++e)  // then frame by frame
          if (safe(base + pair.lambda * prefix[e] + root_frame_bound(q, moments_out, e, p, psi)) <=
              thr) {
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
    const double* bv = scratch.b.data();  // bv[e - b0] = b(s, e)
    std::size_t b0 = first;
    if (b_free) {
      evaluate_free_frames(pair, ci, first, last, scratch);
      bv = scratch.b_free.data();
      b0 = 0;
    } else {
      evaluate_h(*pair.qb, skeleton, *pair.index, pair.t, ci.frame_start + first,
                 ci.frame_start + last + 1, scratch.b.data(), scratch, at);
    }
    counters.evaluated += last - first + 1;
    counters.pruned += (e1 - e0 + 1) - (last - first + 1);
    for (std::size_t e = first; e <= last; ++e) {
      const double b = bv[e - b0];
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
