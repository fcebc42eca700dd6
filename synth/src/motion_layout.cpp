// Placement of the query frames and partial motions in the output
// (motion_layout.hpp).
#include "motion_layout.hpp"

#include <algorithm>
#include <stdexcept>

namespace mocap::synth_detail {
namespace {

GroundPose frame_ground_pose(const SynthSkeleton& sk, const SynthFrame& f) {
  GroundPose g;
  g.heading_rad = root_heading(sk, f);
  g.position_m = Eigen::Vector2d(f.root_position_m.x(), f.root_position_m.z());
  return g;
}

Placement placement_of(const GroundPose& g) {
  Placement p;
  p.yaw_rad = g.heading_rad;
  p.translation_m = Eigen::Vector3d(g.position_m.x(), 0.0, g.position_m.y());
  return p;
}

GroundPose ground_pose_of_placement(const Placement& p) {
  GroundPose g;
  g.heading_rad = p.yaw_rad;
  g.position_m = Eigen::Vector2d(p.translation_m.x(), p.translation_m.z());
  return g;
}

// `base` with the DOFs `q` gives (all in the frame's own coordinates).
SynthFrame complete(const SynthSkeleton& sk, const PartialPoseSpec& q, SynthFrame base) {
  for (const auto& [j, rot] : q.joint_rotations)
    base.local_rotations[static_cast<std::size_t>(j)] = rot.normalized();
  if (q.root_heading_rad) {
    const Eigen::Vector3d keep = base.root_position_m;
    Placement turn;
    turn.yaw_rad = *q.root_heading_rad - root_heading(sk, base);
    base = place_frame(sk, base, turn);
    base.root_position_m = keep;
  }
  for (std::size_t k = 0; k < 3; ++k)
    if (q.root_position_m[k])
      base.root_position_m[static_cast<Eigen::Index>(k)] = *q.root_position_m[k];
  return base;
}

// The partial motions placed; `out_pose` receives the output ground pose of
// every anchored query frame.
std::vector<std::vector<SynthFrame>> place_pieces(
    const SynthSkeleton& sk, FramePlacement placement, const std::vector<FrameRoot>& roots,
    const std::vector<std::vector<SynthFrame>>& raw, double dt, double transition_time_s,
    std::vector<std::optional<GroundPose>>& out_pose) {
  const std::size_t H = roots.size();
  out_pose = std::vector<std::optional<GroundPose>>(H);
  if (roots.front().anchored()) out_pose.front() = roots.front().ground_pose();
  std::vector<std::vector<SynthFrame>> pieces(H - 1);
  for (std::size_t h = 0; h + 1 < H; ++h) {
    const std::vector<SynthFrame>& r = raw[h];
    const GroundPose to_clip =
        partial_motion_placement(placement, frame_ground_pose(sk, r.front()));
    GroundPose body;  // the pair's body frame -> output
    if (roots[h].anchored()) {
      body = out_pose[h].value_or(GroundPose{}) * roots[h].ground_pose().inverse() *
             pair_body_move(placement, roots[h], roots[h]).inverse();
    } else if (h > 0) {
      const auto& prev = pieces[h - 1];
      const Eigen::Vector3d ve = horizontal_root_velocity(prev[prev.size() - 2], prev.back(), dt);
      const Eigen::Vector3d vs = horizontal_root_velocity(r[0], r[1], dt);
      body = ground_pose_of_placement(
                 continuation_placement(sk, prev.back(), ve, r[0], vs, transition_time_s)) *
             to_clip;
    }
    const Placement clip_to_out = placement_of(body * to_clip.inverse());
    for (const SynthFrame& f : r) pieces[h].push_back(place_frame(sk, f, clip_to_out));
    if (roots[h + 1].anchored())
      out_pose[h + 1] =
          body * pair_body_move(placement, roots[h], roots[h + 1]) * roots[h + 1].ground_pose();
  }
  return pieces;
}

// Horizontal root velocity of placed query frame h from its neighbours, m/s
// (0 for a frame at rest).
Eigen::Vector3d query_velocity(const MotionLayout& out,
                               const std::vector<QueryFrameInput>& query_frames, std::size_t h,
                               double dt) {
  const int steps = (query_frames[h].prev ? 1 : 0) + (query_frames[h].next ? 1 : 0);
  if (steps == 0) return Eigen::Vector3d::Zero();
  return horizontal_root_velocity(out.queries[h].before, out.queries[h].after, steps * dt);
}

// Query frame h gives its root's ground position under this placement (in
// world mode clips keep their coordinates: nothing moves).
bool gives_root_xz(FramePlacement placement, const std::vector<QueryFrameInput>& query_frames,
                   std::size_t h) {
  if (placement == FramePlacement::world) return false;
  const auto& p = query_frames[h].pose.given.root_position_m;
  return p[0].has_value() && p[2].has_value();
}

void translate(SynthFrame& f, const Eigen::Vector3d& d) {
  f.root_position_m += d;
}

// The frames to drop from the start and the end of piece `pc` (n >= 3) so
// that its root run shrinks by about `excess` metres (horizontal, along the
// run; <= 0: none): frames alternately from both ends (from one end when
// the other is merged), while at least half of the piece, and 3 frames,
// remain.
std::pair<std::size_t, std::size_t> overshoot_trim(const std::vector<SynthFrame>& pc, double excess,
                                                   bool keep_front, bool keep_back) {
  const std::size_t n = pc.size();
  Eigen::Vector3d run = pc[n - 1].root_position_m - pc[0].root_position_m;
  run.y() = 0.0;
  if (!(excess > 0.0) || run.norm() < 1e-6 || (keep_front && keep_back)) return {0, 0};
  const Eigen::Vector3d u = run.normalized();
  std::size_t front = 0, back = 0;
  double removed = 0.0;
  while (removed < excess && n - front - back > std::max<std::size_t>(3, n / 2)) {
    const bool from_front = keep_back || (!keep_front && front <= back);
    const std::size_t a = from_front ? front : n - 2 - back;
    removed += (pc[a + 1].root_position_m - pc[a].root_position_m).dot(u);
    (from_front ? front : back) += 1;
  }
  return {front, back};
}

// Untimed key poses: the query frames that give their root x/z stay where
// the query puts them; each partial motion moves horizontally between its
// two query frames, by the mean of what its start needs (Q^h plus the
// in-transition's travel, none when merged) and what its end needs, after
// dropping end frames of a piece whose run would overshoot the transitions'
// travel (motion_layout.hpp); sets the merge flags.
void add_travel(FramePlacement placement, const std::vector<QueryFrameInput>& query_frames,
                double dt, double transition_time_s, MotionLayout& out) {
  const std::size_t pairs = out.pieces.size();
  out.merged_in.assign(pairs, 0);
  out.merged_out.assign(pairs, 0);
  out.trimmed.assign(pairs, {0, 0});
  auto gives_xz = [&](std::size_t h) { return gives_root_xz(placement, query_frames, h); };
  auto velocity = [&](std::size_t h) { return query_velocity(out, query_frames, h, dt); };
  auto move_query = [&](std::size_t h, const Eigen::Vector3d& d) {
    PlacedQueryFrame& q = out.queries[h];
    for (SynthFrame* f : {&q.before, &q.frame, &q.after}) translate(*f, d);
  };
  // What the start and the end of piece h need to move by (absent: that
  // query frame gives no root x/z).
  auto needs_of = [&](std::size_t h) {
    const auto& pc = out.pieces[h];
    const std::size_t n = pc.size();
    const Eigen::Vector3d v_s = horizontal_root_velocity(pc[0], pc[1], dt);
    const Eigen::Vector3d v_e = horizontal_root_velocity(pc[n - 2], pc[n - 1], dt);
    const double in_time = out.merged_in[h] ? 0.0 : transition_time_s;
    const double out_time = out.merged_out[h] ? 0.0 : transition_time_s;
    std::pair<std::optional<Eigen::Vector3d>, std::optional<Eigen::Vector3d>> needs;
    if (gives_xz(h))
      needs.first = out.queries[h].frame.root_position_m + 0.5 * in_time * (velocity(h) + v_s) -
                    pc[0].root_position_m;
    if (gives_xz(h + 1))
      needs.second = out.queries[h + 1].frame.root_position_m -
                     0.5 * out_time * (v_e + velocity(h + 1)) - pc[n - 1].root_position_m;
    return needs;
  };
  Eigen::Vector3d carried = Eigen::Vector3d::Zero();  // the previous piece's move
  for (std::size_t h = 0; h < pairs; ++h) {
    auto& pc = out.pieces[h];
    // Unmoved relations decide the merges (the search's placement).
    out.merged_in[h] = same_pose(out.queries[h].frame, pc[0]) && pc.size() >= 3;
    out.merged_out[h] = same_pose(pc.back(), out.queries[h + 1].frame) &&
                        pc.size() >= 3 + static_cast<std::size_t>(out.merged_in[h]);
    auto needs = needs_of(h);
    if (needs.first && needs.second && pc.size() >= 3) {
      // The run past what the two transitions leave it, along the run.
      Eigen::Vector3d run = pc.back().root_position_m - pc.front().root_position_m;
      run.y() = 0.0;
      const double excess =
          run.norm() < 1e-6 ? 0.0 : (*needs.first - *needs.second).dot(run.normalized());
      const auto [front, back] =
          overshoot_trim(pc, excess, out.merged_in[h] != 0, out.merged_out[h] != 0);
      if (front + back > 0) {
        pc.erase(pc.end() - static_cast<std::ptrdiff_t>(back), pc.end());
        pc.erase(pc.begin(), pc.begin() + static_cast<std::ptrdiff_t>(front));
        out.trimmed[h] = {front, back};
        needs = needs_of(h);
      }
    }
    Eigen::Vector3d shift = Eigen::Vector3d::Zero();
    if (needs.first && needs.second)
      shift = 0.5 * (*needs.first + *needs.second);
    else if (needs.first || needs.second)
      shift = needs.first ? *needs.first : *needs.second;
    else  // continues the previous piece (continuation_placement)
      shift = carried;
    shift.y() = 0.0;
    for (SynthFrame& f : pc) translate(f, shift);
    // Query frames without root x/z were completed from this piece.
    if (!gives_xz(h)) move_query(h, shift);
    if (h + 1 == pairs && !gives_xz(h + 1)) move_query(h + 1, shift);
    carried = shift;
  }
}

// Timed key poses: each partial motion moved between its two query frames
// (motion_layout.hpp); the query frames stay.
void add_timed_travel(FramePlacement placement, const std::vector<QueryFrameInput>& query_frames,
                      const std::vector<TimedPair>& timed, double dt, MotionLayout& out) {
  const std::size_t pairs = out.pieces.size();
  out.trimmed.assign(pairs, {0, 0});
  out.merged_in.assign(pairs, 0);
  out.merged_out.assign(pairs, 0);
  auto gives_xz = [&](std::size_t h) { return gives_root_xz(placement, query_frames, h); };
  auto velocity = [&](std::size_t h) { return query_velocity(out, query_frames, h, dt); };
  for (std::size_t h = 0; h < pairs; ++h) {
    if (timed[h].direct) continue;
    auto& pc = out.pieces[h];
    const std::size_t n = pc.size();
    const Eigen::Vector3d v_s = horizontal_root_velocity(pc[0], pc[1], dt);
    const Eigen::Vector3d v_e = horizontal_root_velocity(pc[n - 2], pc[n - 1], dt);
    std::vector<Eigen::Vector3d> needs;
    if (gives_xz(h))
      needs.push_back(out.queries[h].frame.root_position_m +
                      0.5 * static_cast<double>(timed[h].in + 1) * dt * (velocity(h) + v_s) -
                      pc[0].root_position_m);
    if (gives_xz(h + 1))
      needs.push_back(out.queries[h + 1].frame.root_position_m -
                      0.5 * static_cast<double>(timed[h].out + 1) * dt * (v_e + velocity(h + 1)) -
                      pc[n - 1].root_position_m);
    if (needs.empty()) continue;
    Eigen::Vector3d shift = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3d& d : needs) shift += d / static_cast<double>(needs.size());
    shift.y() = 0.0;
    for (SynthFrame& f : pc) translate(f, shift);
  }
}

}  // namespace

std::vector<SynthFrame> resample_frames(const std::vector<SynthFrame>& frames, std::size_t count) {
  if (frames.size() < 2 || count < 2)
    throw std::invalid_argument("resample_frames: at least 2 frames in and out");
  std::vector<SynthFrame> out(count);
  const double scale = static_cast<double>(frames.size() - 1) / static_cast<double>(count - 1);
  for (std::size_t i = 0; i < count; ++i) {
    const double u = static_cast<double>(i) * scale;
    const auto k = std::min(frames.size() - 2, static_cast<std::size_t>(u));
    const double t = u - static_cast<double>(k);
    const SynthFrame& a = frames[k];
    const SynthFrame& b = frames[k + 1];
    SynthFrame& f = out[i];
    f.root_position_m = (1.0 - t) * a.root_position_m + t * b.root_position_m;
    f.local_rotations.resize(a.local_rotations.size());
    for (std::size_t j = 0; j < a.local_rotations.size(); ++j)
      f.local_rotations[j] = a.local_rotations[j].slerp(t, b.local_rotations[j]).normalized();
  }
  return out;
}

bool same_pose(const SynthFrame& a, const SynthFrame& b) {
  if ((a.root_position_m - b.root_position_m).norm() > 1e-4) return false;
  for (std::size_t j = 0; j < a.local_rotations.size(); ++j)
    if (a.local_rotations[j].angularDistance(b.local_rotations[j]) > 1e-4) return false;
  return true;
}

MotionLayout lay_out_motion(const SynthSkeleton& sk, FramePlacement placement,
                            const std::vector<QueryFrameInput>& query_frames,
                            const std::vector<std::vector<SynthFrame>>& raw, double dt,
                            double transition_time_s, const std::vector<TimedPair>* timed) {
  const std::size_t H = query_frames.size();
  if (H < 2 || raw.size() + 1 != H)
    throw std::invalid_argument("lay_out_motion: expected H >= 2 query frames and H - 1 pieces");
  for (const auto& r : raw)
    if (r.size() < 2) throw std::invalid_argument("lay_out_motion: a piece of fewer than 2 frames");
  if (timed && timed->size() != raw.size())
    throw std::invalid_argument("lay_out_motion: expected one timing per pair");
  std::vector<FrameRoot> roots;
  for (const QueryFrameInput& q : query_frames) roots.push_back(frame_root(q.pose));
  std::vector<std::optional<GroundPose>> out_pose;
  MotionLayout out;
  out.pieces = place_pieces(sk, placement, roots, raw, dt, transition_time_s, out_pose);
  for (std::size_t h = 0; h < H; ++h) {
    // The neighbouring partial-motion frame, moved v T / 2 away from it when
    // the frame gives no root x/z.
    const bool first = h + 1 < H;
    const auto& pc = out.pieces[first ? h : h - 1];
    SynthFrame base = first ? pc[0] : pc.back();
    const PartialPoseSpec& given = query_frames[h].pose.given;
    if (!(given.root_position_m[0] && given.root_position_m[2])) {
      const Eigen::Vector3d v = first ? horizontal_root_velocity(pc[0], pc[1], dt)
                                      : horizontal_root_velocity(pc[pc.size() - 2], pc.back(), dt);
      base.root_position_m += (first ? -0.5 : 0.5) * transition_time_s * v;
    }
    // Own coordinates -> output.
    const GroundPose own_to_out =
        out_pose[h] ? out_pose[h].value_or(GroundPose{}) * roots[h].ground_pose().inverse()
                    : GroundPose{};
    const Placement to_out = placement_of(own_to_out);
    const SynthFrame own_base = place_frame(sk, base, placement_of(own_to_out.inverse()));
    // Body-frame constraints are solved on the frame they complete.
    WorldPose base_world;
    if (query_frames[h].pose.solve) synth_world_pose(sk, own_base, base_world);
    auto placed = [&](const ResolvedQueryPose& pose) {
      PartialPoseSpec spec = pose.given;
      if (pose.solve) {
        PoseConstraintScratch scratch;
        std::vector<Eigen::Quaterniond> locals;
        solve_given(pose, sk.model, base_world.positions_m.data(), base_world.rotations.data(),
                    scratch, locals, spec);
      }
      return place_frame(sk, complete(sk, spec, own_base), to_out);
    };
    PlacedQueryFrame p;
    p.frame = placed(query_frames[h].pose);
    p.before = query_frames[h].prev ? placed(*query_frames[h].prev) : p.frame;
    p.after = query_frames[h].next ? placed(*query_frames[h].next) : p.frame;
    out.queries.push_back(std::move(p));
  }
  if (timed)
    add_timed_travel(placement, query_frames, *timed, dt, out);
  else
    add_travel(placement, query_frames, dt, transition_time_s, out);
  return out;
}

}  // namespace mocap::synth_detail
