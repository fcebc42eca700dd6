// The cached sequence of a transition and its local updates (path_cache.hpp).
#include "mocap/synth/path_cache.hpp"

#include <algorithm>
#include <utility>

#include "measures.hpp"
#include "mocap/common/dynamics/energy.hpp"

namespace mocap {

void PathCache::DeltaScratch::reserve(std::size_t count) {
  if (w_changed.size() < count) w_changed.resize(count);
  if (s_changed.size() < count + 2) s_changed.resize(count + 2);
  if (id_changed.size() < count + 2) id_changed.resize(count + 2);
  if (steps_changed.size() < count + 3) steps_changed.resize(count + 3);
}

void PathCache::build_poses(const GapProblem& gap, const std::vector<SynthFrame>& frames) {
  const SynthSkeleton& sk = *gap.skeleton;
  L = frames.size() + 4;
  if (world.size() < L) world.resize(L);
  synth_world_pose(sk, gap.before, world[0]);
  synth_world_pose(sk, gap.start, world[1]);
  for (std::size_t i = 0; i < frames.size(); ++i) synth_world_pose(sk, frames[i], world[2 + i]);
  synth_world_pose(sk, gap.goal, world[L - 2]);
  synth_world_pose(sk, gap.after, world[L - 1]);
}

void PathCache::build_states(const GapProblem& gap, const std::vector<SynthFrame>& frames) {
  build_poses(gap, frames);
  if (states.size() < L) states.resize(L);
  if (ids.size() < L) ids.resize(L);
  for (std::size_t k = 1; k + 1 < L; ++k) {
    state_at(gap, k, 0, 0, nullptr, states[k]);
    inverse_dynamics(gap.skeleton->model, states[k].view(), ids[k]);
  }
}

double PathCache::build(const GapProblem& gap, const std::vector<SynthFrame>& frames) {
  const SynthSkeleton& sk = *gap.skeleton;
  build_states(gap, frames);
  steps.assign(L, 0.0);
  ws.smoothing_J = smoothing_J;
  double g = 0.0;
  for (std::size_t k = 1; k + 2 < L; ++k) {
    steps[k] = full_energy(sk.model, states[k].view(), states[k + 1].view(), gap.frame_time_s,
                           ids[k], ids[k + 1], ws);
    g += steps[k];
  }
  return g;
}

double PathCache::foot_sliding(const GapProblem& gap) const {
  return foot_sliding_with(gap, 0, 0, nullptr);
}

double PathCache::foot_sliding_with(const GapProblem& gap, std::size_t first, std::size_t count,
                                    const WorldPose* changed) const {
  const auto pose = [&](std::size_t q) -> const WorldPose& {
    return q >= first && q < first + count ? changed[q - first] : world[q];
  };
  double sum = 0.0;
  for (std::size_t k = 1; k + 2 < L; ++k)
    sum += synth_detail::step_foot_sliding(*gap.skeleton, pose(k), pose(k + 1), gap.frame_time_s);
  return sum;
}

double PathCache::delta(const GapProblem& gap, std::size_t i, std::size_t count,
                        const SynthFrame* changed, DeltaScratch& sc) const {
  sc.reserve(count);
  sc.ws.smoothing_J = smoothing_J;
  const SynthSkeleton& sk = *gap.skeleton;
  const std::size_t s0 = i + 2, s1 = s0 + count - 1;  // sequence indices of the frames
  for (std::size_t q = 0; q < count; ++q) synth_world_pose(sk, changed[q], sc.w_changed[q]);
  for (std::size_t d = 0; d < count + 2; ++d) {
    state_at(gap, s0 - 1 + d, s0, count, sc.w_changed.data(), sc.s_changed[d]);
    inverse_dynamics(sk.model, sc.s_changed[d].view(), sc.id_changed[d]);
  }
  const auto changed_state = [&](std::size_t k) { return k + 1 >= s0 && k <= s1 + 1; };
  const std::size_t k0 = std::max<std::size_t>(1, s0 - 2), k1 = std::min(L - 3, s1 + 1);
  double before = 0.0, after = 0.0;
  for (std::size_t k = k0; k <= k1; ++k) {
    before += steps[k];
    const BodyState& a = changed_state(k) ? sc.s_changed[k + 1 - s0] : states[k];
    const BodyState& b = changed_state(k + 1) ? sc.s_changed[k + 2 - s0] : states[k + 1];
    const NewtonEulerData& ia = changed_state(k) ? sc.id_changed[k + 1 - s0] : ids[k];
    const NewtonEulerData& ib = changed_state(k + 1) ? sc.id_changed[k + 2 - s0] : ids[k + 1];
    sc.steps_changed[k - k0] =
        full_energy(sk.model, a.view(), b.view(), gap.frame_time_s, ia, ib, sc.ws);
    after += sc.steps_changed[k - k0];
  }
  return after - before;
}

void PathCache::apply(std::size_t i, std::size_t count, DeltaScratch& sc) {
  const std::size_t s0 = i + 2, s1 = s0 + count - 1;
  for (std::size_t q = 0; q < count; ++q) std::swap(world[s0 + q], sc.w_changed[q]);
  for (std::size_t d = 0; d < count + 2; ++d) {
    std::swap(states[s0 - 1 + d], sc.s_changed[d]);
    std::swap(ids[s0 - 1 + d], sc.id_changed[d]);
  }
  const std::size_t k0 = std::max<std::size_t>(1, s0 - 2), k1 = std::min(L - 3, s1 + 1);
  for (std::size_t k = k0; k <= k1; ++k) steps[k] = sc.steps_changed[k - k0];
}

void PathCache::state_at(const GapProblem& gap, std::size_t k, std::size_t first, std::size_t count,
                         const WorldPose* changed, BodyState& out) const {
  const auto pose = [&](std::size_t q) {
    return pose_view(q >= first && q < first + count ? changed[q - first] : world[q]);
  };
  const PoseView p = pose(k - 1), c = pose(k), x = pose(k + 1);
  sequence_state(gap.skeleton->model, &p, c, &x, gap.frame_time_s, out);
}

}  // namespace mocap
