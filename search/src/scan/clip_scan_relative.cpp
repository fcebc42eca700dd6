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

// What the steps of eval_clip_relative share: the clip, its length limits,
// which bounds prune its starts and ends, the root frames' caches, and the
// best pair so far.
struct RelativeScan {
  const PairContext& pair;
  const ClipInfo& ci;
  Scratch& scratch;
  ClipCounters& counters;
  const SkeletonData& skeleton;
  std::size_t k;
  LengthFrames len;
  std::size_t s_end;  // starts s < s_end
  bool prune;
  bool bounded_a = false;  // a(s) first bounded by in_bound / root_in
  bool root_a = false;
  bool bounded_b = false;  // b(s, e) first bounded by out_bound / root_out
  bool root_b = false;
  const double* headings = nullptr;  // and heading_cos_sin, 2 a frame
  const double* cos_sin = nullptr;
  const float* moments_in = nullptr;  // the turning frames' moments (turn_moments_of)
  const float* moments_out = nullptr;
  const float* kin = nullptr;  // the frames' kinetic energies (J)
  const float* kin_rot = nullptr;
  std::span<const double> prefix{};
  // The best pair so far and its b(s, e).
  ClipBest best{};
  bool have = false;
  double best_out = 0.0;

  GroundPose place(std::size_t f) const {
    return frame_placement(skeleton, pair.placement, ci.frame_start + f);
  }
  // Where a partial motion starting at f puts the query frame's root (world, m).
  Eigen::Vector3d placed(const RootBoundQuery& q, std::size_t f) const {
    return place_point(skeleton, pair.placement, ci.frame_start + f, q.root_body);
  }
  // cos and sin of where a partial motion starting at f turns a turning
  // frame (world).
  std::array<double, 2> placed_heading(const RootBoundQuery& q, std::size_t f) const {
    const double psi =
        q.heading_body + (pair.placement == FramePlacement::relative ? headings[f] : 0.0);
    return std::array<double, 2>{std::cos(psi), std::sin(psi)};
  }
  // Clip frame f's root position (m).
  Eigen::Vector3d root_at(std::size_t f) const {
    const float* r = skeleton.tables.root_positions.data() + ci.frame_start + f;
    const std::size_t st = skeleton.tables.frame_count;
    return Eigen::Vector3d(r[0], r[st], r[2 * st]);
  }
  // A root frame's bound at frame f with its root placed at p (world) and,
  // for a turning one (its moments), its heading's cos and sin psi.
  double root_frame_bound(const RootBoundQuery& q, const float* moments, std::size_t f,
                          const Eigen::Vector3d& p, const std::array<double, 2>& psi) const {
    return frame_root_bound(q, moments == nullptr ? nullptr : moments + 4 * f, kin[f], kin_rot[f],
                            root_at(f), cos_sin == nullptr ? nullptr : cos_sin + 2 * f, p, psi[0],
                            psi[1]);
  }
};

// The root frames' caches the root-only bounds read: headings, the turning
// frames' moments, the root blocks of a non-turning Q^h+1.
void prepare_root_frames(RelativeScan& c) {
  const PairContext& pair = c.pair;
  const bool turns = (c.root_a && pair.root_in->turns) || (c.root_b && pair.root_out->turns);
  if (!c.root_a && !c.root_b) return;
  ensure_frame_kinetic(c.skeleton);
  if (pair.placement == FramePlacement::relative || turns) {
    c.headings = frame_headings(c.skeleton).data() + c.ci.frame_start;
    c.cos_sin = c.skeleton.caches.heading_cos_sin.data() + 2 * c.ci.frame_start;
  }
  if (c.root_a && pair.root_in->turns)
    c.moments_in = turn_moments_of(*pair.root_in, c.skeleton) + 4 * c.ci.frame_start;
  if (c.root_b && pair.root_out->turns)
    c.moments_out = turn_moments_of(*pair.root_out, c.skeleton) + 4 * c.ci.frame_start;
  if (c.root_b && !pair.root_out->turns)
    c.scratch.root_blocks.build(c.skeleton, c.ci.frame_start, c.k);
}

// a(s) into scratch.a for every start, or where Q^h is a full frame (or
// root-only) first its lower bound (relative_bounds.hpp, Q^h placed on F^s);
// scratch.a_exact[s] says which are a(s) itself.
void start_values(RelativeScan& c) {
  const PairContext& pair = c.pair;
  Scratch& scratch = c.scratch;
  if (c.bounded_a) {
    relative_bound_frames(*pair.in_bound, c.skeleton.tables, c.ci.frame_start, c.k,
                          scratch.in_frames);
    for (std::size_t s = 0; s < c.s_end; ++s)
      scratch.a[s] = relative_bound(*pair.in_bound, scratch.in_frames, s,
                                    c.place(s).apply(pair.in_bound->com_body));
  } else if (c.root_a) {
    for (std::size_t s = 0; s < c.s_end; ++s)
      scratch.a[s] = c.root_frame_bound(*pair.root_in, c.moments_in, s, c.placed(*pair.root_in, s),
                                        c.placed_heading(*pair.root_in, s));
  } else {
    for (std::size_t s = 0; s < c.s_end; ++s)
      evaluate_h(*pair.qa, c.skeleton, *pair.index, pair.t, c.ci.frame_start + s,
                 c.ci.frame_start + s + 1, scratch.a.data() + s, scratch, c.place(s));
    c.counters.evaluated += c.s_end;
  }
  scratch.a_exact.assign(c.k, c.bounded_a || c.root_a ? 0 : 1);
}

// Root-only Q^h+1: per block of RootBlocks::kBlock start frames (the one
// block walk), the box of where their placements put Q^h+1's root against
// every block of end frames they reach; a start block none of whose end
// blocks can beat tau gets la = inf (its start frames are skipped). The
// path-cost term is left out (it is >= 0).
void root_block_pass(const RelativeScan& c, const RootBoundQuery& q, double tau) {
  constexpr std::size_t B = RootBlocks::kBlock;
  Scratch& scratch = c.scratch;
  const RootBlocks& blocks = scratch.root_blocks;
  const std::size_t last_e = blocks.x0.size() * B;                // past the clip's last block
  auto open = [&](std::size_t, std::size_t sa, std::size_t sb) {  // starts [sa, sb)
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(kInf), hi = -lo;
    double amin = kInf;
    for (std::size_t s = sa; s < sb; ++s) {
      const Eigen::Vector3d p = c.placed(q, s);
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
      amin = std::min(amin, scratch.a[s]);
    }
    const std::size_t e_lo = sa + c.len.min, e_hi = std::min(last_e - 1, sb - 1 + c.len.max);
    bool any = false;
    for (std::size_t j = e_lo / B; j <= e_hi / B && !any; ++j)
      any = safe(amin + blocks.bound_box(q, j, lo, hi)) <= tau;
    return any;
  };
  walk_blocks<B>(0, c.s_end, open, ignore_block, [&](std::size_t, std::size_t sa, std::size_t sb) {
    for (std::size_t s = sa; s < sb; ++s) scratch.la[s] = kInf;
  });
}

// scratch.la[s]: the least placement-free bound of b over s's window [s +
// min, s + max] (0 without one), then root_block_pass for a non-turning
// root-only Q^h+1.
void end_window_bounds(RelativeScan& c, double tau) {
  const PairContext& pair = c.pair;
  Scratch& scratch = c.scratch;
  auto window_minima = [&](const auto& lower) {
    thread_local FixedWindowMinima windows;
    windows.build(0, c.k, c.len.max - c.len.min + 1, lower);
    scratch.la.resize(c.s_end);
    for (std::size_t s = 0; s < c.s_end; ++s)
      scratch.la[s] = windows.window(static_cast<std::ptrdiff_t>(s + c.len.min));
  };
  if (c.bounded_b) {
    const RelativeBoundFrames& fr = scratch.out_frames;
    relative_bound_frames(*pair.out_bound, c.skeleton.tables, c.ci.frame_start, c.k,
                          scratch.out_frames);
    window_minima([&](std::size_t e) { return fr.lower(e); });
  } else if (c.root_b) {
    // The root bound with the x and z distances 0 (they depend on s).
    const RootBoundQuery& q = *pair.root_out;
    window_minima([&](std::size_t e) {
      return root_bound(q, c.kin[e], c.kin[e], c.kin_rot[e], 0.0,
                        q.root_body.y() - c.root_at(e).y(), 0.0);
    });
  } else {
    scratch.la.assign(c.s_end, 0.0);
  }
  if (c.root_b && !pair.root_out->turns) root_block_pass(c, *pair.root_out, tau);
}

// The end frames of start s in [e0, e1] that its bounds of b(s, e) (plus
// the path cost from s) leave at <= thr, as [first, last] (first > last:
// none): per frame (out_bound), or per block of end frames (the one block
// walk: the box of its roots against the placed query root, RootBlocks)
// then frame by frame, every block frame by frame for a turning frame; path
// costs only grow. All of them without a bound of b.
void end_frames_to_evaluate(const RelativeScan& c, std::size_t s, const GroundPose& at,
                            std::size_t e0, std::size_t e1, double thr, std::size_t& first,
                            std::size_t& last) {
  const PairContext& pair = c.pair;
  const double base = c.scratch.a[s] - pair.lambda * c.prefix[s];
  first = e1 + 1;
  last = e0;
  auto keep = [&](std::size_t e, double lb) {
    if (safe(base + pair.lambda * c.prefix[e] + lb) <= thr) {
      first = std::min(first, e);
      last = e;
    }
  };
  if (c.bounded_b) {
    const Eigen::Vector3d com = at.apply(pair.out_bound->com_body);
    for (std::size_t e = e0; e <= e1; ++e)
      keep(e, relative_bound(*pair.out_bound, c.scratch.out_frames, e, com));
  } else if (c.root_b) {
    const RootBoundQuery& q = *pair.root_out;
    const RootBlocks& blocks = c.scratch.root_blocks;
    const Eigen::Vector3d p = c.placed(q, s);
    const std::array<double, 2> psi =
        q.turns ? c.placed_heading(q, s) : std::array<double, 2>{1.0, 0.0};
    walk_blocks<RootBlocks::kBlock>(
        e0, e1 + 1,
        [&](std::size_t j, std::size_t f0, std::size_t) {
          return q.turns ||
                 !(safe(base + pair.lambda * c.prefix[f0] + blocks.bound(q, j, p)) > thr);
        },
        [&](std::size_t, std::size_t f0, std::size_t f1) {
          for (std::size_t e = f0; e < f1; ++e)
            keep(e, c.root_frame_bound(q, c.moments_out, e, p, psi));
        },
        ignore_block);
  } else {
    first = e0;
    last = e1;
  }
}

// b(s, e) for the end frames [first, last] of start s (Q^h+1 placed by
// F^s's ground pose `at`; a placement-free Q^h+1 once per end frame of the
// clip), each pair offered to the clip's best.
void evaluate_ends(RelativeScan& c, std::size_t s, const GroundPose& at, std::size_t first,
                   std::size_t last, bool b_free) {
  const PairContext& pair = c.pair;
  Scratch& scratch = c.scratch;
  const double* bv = scratch.b.data();  // bv[e - b0] = b(s, e)
  std::size_t b0 = first;
  if (b_free) {
    evaluate_free_frames(pair, c.ci, first, last, scratch);
    bv = scratch.b_free.data();
    b0 = 0;
  } else {
    evaluate_h(*pair.qb, c.skeleton, *pair.index, pair.t, c.ci.frame_start + first,
               c.ci.frame_start + last + 1, scratch.b.data(), scratch, at);
  }
  for (std::size_t e = first; e <= last; ++e) {
    const double b = bv[e - b0];
    const double score =
        (b + pair.lambda * c.prefix[e]) + (scratch.a[s] - pair.lambda * c.prefix[s]);
    if (better(score, e, s, c.best, c.have)) {
      c.best = {score, s, e};
      c.best_out = b;
      c.have = true;
    }
  }
}

// The pairs of start s: a(s) made exact where it was a bound, then the end
// frames its bounds leave, evaluated (counted); skipped (counted as pruned)
// where a(s) plus the least bound of b over its window exceeds the clip's
// threshold.
void scan_start(RelativeScan& c, std::size_t s, double tau, bool b_free) {
  const PairContext& pair = c.pair;
  Scratch& scratch = c.scratch;
  const std::size_t e0 = s + c.len.min, e1 = std::min(c.k - 1, s + c.len.max);
  const double thr = c.have ? std::min(tau, c.best.score) : tau;
  if (c.prune && safe(scratch.a[s] + scratch.la[s]) > thr) {
    c.counters.pruned += e1 - e0 + 1 + (scratch.a_exact[s] ? 0 : 1);
    return;
  }
  if (!scratch.a_exact[s]) {
    evaluate_h(*pair.qa, c.skeleton, *pair.index, pair.t, c.ci.frame_start + s,
               c.ci.frame_start + s + 1, scratch.a.data() + s, scratch, c.place(s));
    scratch.a_exact[s] = 1;
    ++c.counters.evaluated;
    if (safe(scratch.a[s] + scratch.la[s]) > thr) {
      c.counters.pruned += e1 - e0 + 1;
      return;
    }
  }
  const GroundPose at = c.place(s);
  std::size_t first = 0, last = 0;  // the frames to evaluate lie in [first, last]
  end_frames_to_evaluate(c, s, at, e0, e1, thr, first, last);
  if (first > last) {
    c.counters.pruned += e1 - e0 + 1;
    return;
  }
  evaluate_ends(c, s, at, first, last, b_free);
  c.counters.evaluated += last - first + 1;
  c.counters.pruned += (e1 - e0 + 1) - (last - first + 1);
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
  const LengthFrames len = length_frames(pair, pair.index->clips()[ci.clip].frame_time_s);
  if (k <= len.min) return false;
  RelativeScan c{
      pair, ci, scratch, counters, skeleton, k, len, k - len.min, pair.mode != SearchMode::brute};
  std::uint64_t total = 0;
  for (std::size_t s = 0; s < c.s_end; ++s)
    total += 1 + (std::min(k - 1, s + len.max) - (s + len.min) + 1);
  // The clip's box bounds of both terms (their parts that hold wherever the
  // query frames are placed).
  if (c.prune && has_relative_clip_bound(pair) && safe(relative_clip_bound(pair, ci.row)) > tau) {
    counters.clip_pruned = true;
    counters.pruned += total;
    return false;
  }
  scratch.a.assign(k, kInf);
  c.bounded_a = c.prune && pair.in_bound != nullptr;
  c.root_a = c.prune && !c.bounded_a && pair.root_in != nullptr;
  c.root_b = c.prune && pair.out_bound == nullptr && pair.root_out != nullptr;
  c.bounded_b = c.prune && pair.out_bound != nullptr;
  prepare_root_frames(c);
  c.kin = skeleton.caches.kinetic.data() + ci.frame_start;
  c.kin_rot = skeleton.caches.kinetic_rot.data() + ci.frame_start;
  start_values(c);
  end_window_bounds(c, tau);
  double min_lb = kInf;
  for (std::size_t s = 0; s < c.s_end; ++s) min_lb = std::min(min_lb, scratch.a[s] + scratch.la[s]);
  if (c.prune && safe(min_lb) > tau) {
    counters.clip_pruned = true;
    counters.pruned += total - (c.bounded_a || c.root_a ? 0 : c.s_end);
    return false;
  }
  c.prefix = clip_prefix(*pair.index, skeleton, ci);
  scratch.b.resize(len.max);
  // A Q^h+1 whose h does not depend on where it is placed (joint rotations,
  // body-frame constraints: placement_free) is evaluated once per end frame,
  // not once per (start, end) pair.
  const bool b_free = placement_free(*pair.qb);
  if (b_free) {
    scratch.b_free.resize(k);
    scratch.b_free_done.assign(k, 0);
  }
  for (std::size_t s = 0; s < c.s_end; ++s) scan_start(c, s, tau, b_free);
  if (!c.have) return false;
  out = {c.best.score,
         ci.clip,
         c.best.s,
         c.best.e,
         scratch.a[c.best.s],
         c.best_out,
         c.prefix[c.best.e] - c.prefix[c.best.s]};
  return true;
}

}  // namespace mocap::search_detail
