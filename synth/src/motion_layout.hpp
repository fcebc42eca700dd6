// Where the pieces of the output motion go (private to synth/src): the query
// frames Q^h, completed, and the partial motions R_h, placed by the search's
// placement rule (mocap/search/placement.hpp) so that the output starts at
// the first query frame's own ground pose (docs/synthesis.md "Placement").
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "mocap/search/placement.hpp"
#include "mocap/search/query.hpp"
#include "mocap/search/query_pose.hpp"
#include "mocap/synth/synth.hpp"

namespace mocap::synth_detail {

/// A query frame as resolved on the target skeleton, with, for a BVH frame,
/// its file's previous and next frames (the same DOFs; the frame itself at
/// the file's ends): they carry its velocities into the transitions.
struct QueryFrameInput {
  ResolvedQueryPose pose;
  std::optional<ResolvedQueryPose> prev, next;
};

/// A completed query frame in output coordinates, with its neighbours (equal
/// to it for a hand-written frame: a pose at rest).
struct PlacedQueryFrame {
  SynthFrame before, frame, after;
};

struct MotionLayout {
  /// R_h in output coordinates (frames s..e of the chosen clip).
  std::vector<std::vector<SynthFrame>> pieces;
  /// Q^1..Q^H in output coordinates.
  std::vector<PlacedQueryFrame> queries;
  /// Per pair: Q^h is R_h's first frame (merged_in), R_h's last frame is
  /// Q^h+1 (merged_out), as one pose (same_pose): no transition there.
  std::vector<std::uint8_t> merged_in, merged_out;
  /// Per pair: frames dropped from the start and the end of R_h (untimed
  /// key poses whose partial motion would overshoot the transitions'
  /// travel); pieces[h] holds clip frames s + front .. e - back.
  std::vector<std::pair<std::size_t, std::size_t>> trimmed;
};

/// True when two frames are one pose: root within 0.1 mm, every joint's
/// local rotation within 1e-4 rad.
bool same_pose(const SynthFrame& a, const SynthFrame& b);

/// A pair of timed key poses in the output (docs/queries.md "Timed key
/// poses"): `in` and `out` transition frames around the partial motion, or
/// (`direct`) one transition of `in` frames from Q^h to Q^h+1.
struct TimedPair {
  std::size_t in = 0, out = 0;
  bool direct = false;
};

/// `frames` (at least 2) resampled to `count` frames (at least 2) spanning
/// the same motion: frame i at position i (frames - 1) / (count - 1), the
/// root interpolated linearly, each joint by slerp.
std::vector<SynthFrame> resample_frames(const std::vector<SynthFrame>& frames, std::size_t count);

/// Lays out the motion. `raw` holds R_h in clip coordinates (at least two
/// frames each), `query_frames` Q^1..Q^H (H = raw.size() + 1).
///  - The output's coordinates are Q^1's own (a BVH frame where it is in its
///    file; a hand-written one at its given root x/z and heading, else at the
///    origin facing +z).
///  - A pair whose first frame is anchored (FrameRoot::anchored) puts its
///    body frame where that frame is, and R_h there by
///    partial_motion_placement of F^s; an anchored Q^h+1 is placed by the
///    pair's body-frame move (pair_body_move). In world mode every move is
///    the identity: clips keep their coordinates.
///  - A pair whose first frame gives no root x/z or heading (joint rotations
///    only) continues from R_h-1 (continuation_placement: turned to R_h-1's
///    last heading, moved by the mean of the two root velocities over the
///    transition time `transition_time_s`).
///  - Query frames are completed from the neighbouring partial-motion frame
///    (Q^h from R_h's first, Q^H from R_H-1's last) in their own
///    coordinates; a frame that gives no root x/z is put v T / 2 before that
///    frame (after it for Q^H).
///  - Travel during the transitions: the search compares Q^h with F^s (and
///    F^e with Q^h+1) at one place, but a transition of about T seconds
///    lies between them. In a relative placement the query frames that give
///    root x/z stay where the query puts them (the output passes there), and
///    each partial motion moves horizontally by the mean of what its start
///    needs (Q^h plus the in-transition's travel: T times the mean of the
///    two horizontal root velocities; none when merged) and what its end
///    needs (Q^h+1 less the out-transition's), where its query frames give
///    root x/z; a piece whose two query frames give none moves as the
///    previous piece did, and a query frame without root x/z moves with the
///    piece it was completed from. A piece between two such frames whose run
///    overshoots what the transitions leave it first loses frames at its
///    ends (overshoot_trim; MotionLayout::trimmed). The character keeps
///    moving through the transitions, and the travel is absorbed instead of
///    added.
///  - Timed key poses (`timed`: one entry per pair): the query frames stay
///    where the query puts them (no travel shift, no merges), and each
///    partial motion that is not `direct` moves horizontally by the mean of
///    what its start needs (Q^h plus the in-transition's travel) and what its
///    end needs (Q^h+1 less the out-transition's travel), where the query
///    frames give root x/z.
MotionLayout lay_out_motion(const SynthSkeleton& sk, FramePlacement placement,
                            const std::vector<QueryFrameInput>& query_frames,
                            const std::vector<std::vector<SynthFrame>>& raw, double dt,
                            double transition_time_s,
                            const std::vector<TimedPair>* timed = nullptr);

}  // namespace mocap::synth_detail
