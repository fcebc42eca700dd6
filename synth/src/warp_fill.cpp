// Warped fills of timed key poses (warp_fill.hpp): the captured span, the
// displacement map onto both key poses, the contacts held, swinging feet
// lifted off the floor.
#include "warp_fill.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "foot_planting.hpp"

namespace mocap::synth_detail {
namespace {

SynthFrame blend(const SynthFrame& a, const SynthFrame& b, double t) {
  SynthFrame f = a;
  f.root_position_m = (1.0 - t) * a.root_position_m + t * b.root_position_m;
  for (std::size_t j = 0; j < f.local_rotations.size(); ++j)
    f.local_rotations[j] = a.local_rotations[j].slerp(t, b.local_rotations[j]).normalized();
  return f;
}

// Per leg and frame: its lowest foot joint on the ground (the skating rule's
// height) and slow (below the skating speed, from the neighbouring frames).
std::vector<std::vector<std::uint8_t>> leg_contacts(const SynthSkeleton& sk,
                                                    const std::vector<LegChain>& legs,
                                                    const std::vector<WorldPose>& w, double dt) {
  const double ground = sk.model.params.ground_height_m;
  const std::size_t n = w.size();
  std::vector<std::vector<std::uint8_t>> on(legs.size(), std::vector<std::uint8_t>(n, 0));
  for (std::size_t l = 0; l < legs.size(); ++l)
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t a = i > 0 ? i - 1 : i, b = i + 1 < n ? i + 1 : i;
      const double span = static_cast<double>(b - a) * dt;
      for (int f : legs[l].feet) {
        const Eigen::Vector3d& p = w[i].positions_m[static_cast<std::size_t>(f)];
        if (p.y() - ground >= kSkatingHeightM) continue;
        const Eigen::Vector3d d = w[b].positions_m[static_cast<std::size_t>(f)] -
                                  w[a].positions_m[static_cast<std::size_t>(f)];
        if (span <= 0.0 || std::hypot(d.x(), d.z()) / span < kSkatingSpeedMps) on[l][i] = 1;
      }
    }
  return on;
}

// The ankle's target (position, rotation) over contact [u, v] of frames 0..last.
struct AnkleHold {
  Eigen::Vector3d position;
  Eigen::Quaterniond rotation;
};
// Inside the gap the ankle keeps the captured height (the contact stays on
// the ground however the displacement moved the body) and the captured
// world rotation turned by the placement's heading change at that frame.
AnkleHold hold_at(const std::vector<WorldPose>& w, const std::vector<WorldPose>& wc, int ankle,
                  std::size_t u, std::size_t v, std::size_t last, std::size_t i) {
  const auto a = static_cast<std::size_t>(ankle);
  if (u == 0 && v == last) {  // standing through the gap: from key pose a's foot to b's
    const double t = static_cast<double>(i) / static_cast<double>(last);
    return {(1.0 - t) * w[0].positions_m[a] + t * w[last].positions_m[a],
            w[0].rotations[a].slerp(t, w[last].rotations[a])};
  }
  const std::size_t at = u == 0 ? 0 : v == last ? last : u;
  AnkleHold h{w[at].positions_m[a], w[at].rotations[a]};
  if (at != 0 && at != last) h.position.y() = wc[at].positions_m[a].y();
  return h;
}

}  // namespace

Placement placement_between(const SynthSkeleton& sk, const SynthFrame& clip,
                            const SynthFrame& placed) {
  Placement p;
  p.yaw_rad = root_heading(sk, placed) - root_heading(sk, clip);
  const Eigen::Vector3d turned =
      Eigen::AngleAxisd(p.yaw_rad, Eigen::Vector3d::UnitY()) * clip.root_position_m;
  p.translation_m = placed.root_position_m - turned;
  p.translation_m.y() = 0.0;
  return p;
}

Placement balanced_placement(const SynthSkeleton& sk, const std::vector<SynthFrame>& unplaced,
                             const SynthFrame& key_a, const SynthFrame& key_b) {
  if (unplaced.empty()) throw std::invalid_argument("balanced_placement: no frames");
  Placement p = placement_between(sk, unplaced.front(), key_a);
  Eigen::Vector3d miss =
      key_b.root_position_m - place_frame(sk, unplaced.back(), p).root_position_m;
  miss.y() = 0.0;
  p.translation_m += 0.5 * miss;
  return p;
}

double warp_size_m(const SynthSkeleton& sk, const SynthFrame& first, const SynthFrame& last,
                   const SynthFrame& key_a, const SynthFrame& key_b) {
  WorldPose c, k;
  double sum = 0.0;
  std::size_t count = 0;
  for (const auto& [frame, key] : {std::pair{&first, &key_a}, std::pair{&last, &key_b}}) {
    synth_world_pose(sk, *frame, c);
    synth_world_pose(sk, *key, k);
    for (std::size_t j = 0; j < c.positions_m.size(); ++j) {
      if (sk.is_root_chain[j] && static_cast<int>(j) != sk.root_joint) continue;
      sum += (c.positions_m[j] - k.positions_m[j]).norm();
      ++count;
    }
  }
  return count ? sum / static_cast<double>(count) : 0.0;
}

std::vector<SynthFrame> captured_span(const SynthSkeleton& sk, const WarpSource& src,
                                      std::size_t steps) {
  if (src.frame_count < 2) throw std::invalid_argument("warp_fill: a clip of fewer than 2 frames");
  const double last = static_cast<double>(src.frame_count - 1);
  std::vector<SynthFrame> out;
  out.reserve(steps + 1);
  for (std::size_t i = 0; i <= steps; ++i) {
    const double c = std::clamp(src.start + static_cast<double>(i) * src.step, 0.0, last);
    const auto f0 = static_cast<std::size_t>(std::floor(c));
    const std::size_t f1 = std::min(f0 + 1, src.frame_count - 1);
    const SynthFrame f = blend(src.frame(f0), src.frame(f1), c - static_cast<double>(f0));
    out.push_back(place_frame(sk, f, src.placement));
  }
  return out;
}

void displace_onto_keys(std::vector<SynthFrame>& frames, const SynthFrame& key_a,
                        const SynthFrame& key_b) {
  if (frames.size() < 2) throw std::invalid_argument("warp_fill: fewer than 2 frames");
  const SynthFrame& e0 = frames.front();
  const SynthFrame& e1 = frames.back();
  const Eigen::Vector3d d0 = key_a.root_position_m - e0.root_position_m;
  const Eigen::Vector3d d1 = key_b.root_position_m - e1.root_position_m;
  const std::size_t joints = e0.local_rotations.size();
  std::vector<Eigen::Quaterniond> o0(joints), o1(joints);
  for (std::size_t j = 0; j < joints; ++j) {
    o0[j] = key_a.local_rotations[j] * e0.local_rotations[j].conjugate();
    o1[j] = key_b.local_rotations[j] * e1.local_rotations[j].conjugate();
  }
  const double last = static_cast<double>(frames.size() - 1);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const double s = static_cast<double>(i) / last;
    SynthFrame& f = frames[i];
    f.root_position_m += (1.0 - s) * d0 + s * d1;
    for (std::size_t j = 0; j < joints; ++j)
      f.local_rotations[j] = (o0[j].slerp(s, o1[j]) * f.local_rotations[j]).normalized();
  }
  frames.front() = key_a;
  frames.back() = key_b;
}

void keep_foot_heights(const SynthSkeleton& sk, const RangeOfMotion* rom,
                       const std::vector<SynthFrame>& captured, std::vector<SynthFrame>& frames) {
  const std::size_t n = frames.size();
  if (n < 3 || captured.size() != n) return;
  const std::vector<LegChain> legs = leg_chains(sk);
  WorldPose c0, c1, k0, k1, wc, w;
  synth_world_pose(sk, captured.front(), c0);
  synth_world_pose(sk, captured.back(), c1);
  synth_world_pose(sk, frames.front(), k0);
  synth_world_pose(sk, frames.back(), k1);
  const double last = static_cast<double>(n - 1);
  for (std::size_t i = 1; i + 1 < n; ++i) {
    const double s = static_cast<double>(i) / last;
    synth_world_pose(sk, captured[i], wc);
    for (const LegChain& leg : legs) {
      const auto a = static_cast<std::size_t>(leg.ankle);
      synth_world_pose(sk, frames[i], w);
      Eigen::Vector3d target = w.positions_m[a];
      target.y() = wc.positions_m[a].y() +
                   (1.0 - s) * (k0.positions_m[a].y() - c0.positions_m[a].y()) +
                   s * (k1.positions_m[a].y() - c1.positions_m[a].y());
      plant_leg(sk, rom, leg, target, w.rotations[a], frames[i], w);
    }
  }
}

void hold_contacts(const SynthSkeleton& sk, const RangeOfMotion* rom,
                   const std::vector<SynthFrame>& captured, std::vector<SynthFrame>& frames,
                   double dt) {
  constexpr std::size_t kEase = 3;
  const std::size_t n = frames.size();
  if (n < 3 || captured.size() != n) return;
  const std::vector<LegChain> legs = leg_chains(sk);
  std::vector<WorldPose> wc(n), w(n);
  for (std::size_t i = 0; i < n; ++i) {
    synth_world_pose(sk, captured[i], wc[i]);
    synth_world_pose(sk, frames[i], w[i]);
  }
  const auto on = leg_contacts(sk, legs, wc, dt);
  WorldPose scratch;
  for (std::size_t l = 0; l < legs.size(); ++l) {
    const auto ankle = static_cast<std::size_t>(legs[l].ankle);
    for (std::size_t u = 0; u < n;) {
      if (!on[l][u]) {
        ++u;
        continue;
      }
      std::size_t v = u;
      while (v + 1 < n && on[l][v + 1]) ++v;
      // Frames u - kEase .. v + kEase: held fully inside [u, v], eased outside.
      const std::size_t from = u > kEase ? u - kEase : 0;
      const std::size_t to = std::min(n - 1, v + kEase);
      for (std::size_t i = std::max<std::size_t>(from, 1); i <= std::min(to, n - 2); ++i) {
        const AnkleHold h = hold_at(w, wc, legs[l].ankle, u, v, n - 1, std::clamp(i, u, v));
        const double out = i < u   ? static_cast<double>(u - i)
                           : i > v ? static_cast<double>(i - v)
                                   : 0.0;
        const double t = 1.0 - out / static_cast<double>(kEase + 1);
        synth_world_pose(sk, frames[i], scratch);
        const Eigen::Vector3d target = (1.0 - t) * scratch.positions_m[ankle] + t * h.position;
        const Eigen::Quaterniond rot = scratch.rotations[ankle].slerp(t, h.rotation);
        plant_leg(sk, rom, legs[l], target, rot, frames[i], scratch);
      }
      u = v + 1;
    }
  }
}

void lift_moving_feet(const SynthSkeleton& sk, const RangeOfMotion* rom,
                      std::vector<SynthFrame>& frames, double dt) {
  const std::size_t n = frames.size();
  if (n < 3 || dt <= 0.0) return;
  const double ground = sk.model.params.ground_height_m;
  const std::vector<LegChain> legs = leg_chains(sk);
  std::vector<WorldPose> w(n);
  for (std::size_t i = 0; i < n; ++i) synth_world_pose(sk, frames[i], w[i]);
  auto speed = [&](int f, std::size_t a, std::size_t b) {
    const Eigen::Vector3d d = w[b].positions_m[static_cast<std::size_t>(f)] -
                              w[a].positions_m[static_cast<std::size_t>(f)];
    return std::hypot(d.x(), d.z()) / dt;
  };
  WorldPose scratch;
  for (std::size_t i = 1; i + 1 < n; ++i)
    for (const LegChain& leg : legs) {
      double deficit = 0.0;
      for (int f : leg.feet) {
        if (std::max(speed(f, i - 1, i), speed(f, i, i + 1)) <= kSkatingSpeedMps) continue;
        const double y = w[i].positions_m[static_cast<std::size_t>(f)].y() - ground;
        deficit = std::max(deficit, kSkatingHeightM + kFootClearanceM - y);
      }
      if (deficit <= 0.0) continue;
      const auto a = static_cast<std::size_t>(leg.ankle);
      const Eigen::Vector3d target = w[i].positions_m[a] + Eigen::Vector3d(0.0, deficit, 0.0);
      plant_leg(sk, rom, leg, target, w[i].rotations[a], frames[i], scratch);
    }
}

std::vector<SynthFrame> warp_fill(const SynthSkeleton& sk, const RangeOfMotion* rom,
                                  const WarpSource& src, const SynthFrame& key_a,
                                  const SynthFrame& key_b, std::size_t steps, double dt) {
  if (steps < 1) throw std::invalid_argument("warp_fill: at least one step");
  const std::vector<SynthFrame> captured = captured_span(sk, src, steps);
  std::vector<SynthFrame> frames = captured;
  displace_onto_keys(frames, key_a, key_b);
  keep_foot_heights(sk, rom, captured, frames);
  hold_contacts(sk, rom, captured, frames, dt);
  lift_moving_feet(sk, rom, frames, dt);
  return frames;
}

}  // namespace mocap::synth_detail
