// Supplementation of a gap by A* (supplement_astar): the planned length
// (estimate_transition_frames, choose_transition_frames), the search
// (astar.cpp) and the optional refinement (refine.cpp) under the limits of
// the slerp transition of the same length. docs/synthesis.md documents the
// method and every choice.
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "astar.hpp"
#include "foot_steps.hpp"
#include "measures.hpp"
#include "mocap/synth/path_cache.hpp"
#include "mocap/synth/refine.hpp"
#include "mocap/synth/synth.hpp"
#include "transition_math.hpp"

namespace mocap {

std::size_t estimate_transition_frames(const GapProblem& gap, const SupplementParams& params) {
  synth_detail::check_gap(gap);
  double angle = 0.0;
  const std::size_t n = gap.skeleton->joint_count();
  for (std::size_t j = 0; j < n; ++j)
    angle = std::max(
        angle,
        synth_detail::local_log(gap.start.local_rotations[j], gap.goal.local_rotations[j]).norm());
  const double dist = (gap.goal.root_position_m - gap.start.root_position_m).norm();
  const double t = std::max(
      {angle / params.ref_angular_speed_radps, dist / params.ref_speed_mps, params.min_duration_s});
  const auto frames = static_cast<std::size_t>(std::ceil(t / gap.frame_time_s));
  return std::clamp<std::size_t>(frames, 1, std::max<std::size_t>(1, params.max_states));
}

std::size_t choose_transition_frames(const GapProblem& gap, const SupplementParams& params) {
  const std::size_t estimate = estimate_transition_frames(gap, params);
  if (!params.choose_length) return estimate;
  const std::size_t cap = std::max<std::size_t>(1, params.max_states);
  const std::size_t hi = std::min(cap, 2 * estimate + 2);
  // Coarse grid (steps growing by ~20%), then every length between the
  // best grid point's neighbours; ties go to the shorter length.
  std::vector<std::size_t> grid{1};
  for (std::size_t m = 2; m < hi; m = std::max(m + 1, m + m / 5)) grid.push_back(m);
  if (hi > 1) grid.push_back(hi);
  PathCache sc;
  std::vector<double> energy(hi + 1, -1.0);
  auto eval = [&](std::size_t m) {
    if (energy[m] < 0.0) energy[m] = sc.build(gap, slerp_transition(gap, m));
    return energy[m];
  };
  std::size_t best = grid[0];
  std::size_t at = 0;
  for (std::size_t i = 0; i < grid.size(); ++i)
    if (eval(grid[i]) < eval(best)) {
      best = grid[i];
      at = i;
    }
  const std::size_t lo2 = at > 0 ? grid[at - 1] + 1 : 1;
  const std::size_t hi2 = at + 1 < grid.size() ? grid[at + 1] - 1 : hi;
  for (std::size_t m = lo2; m <= hi2; ++m)
    if (eval(m) < eval(best)) best = m;
  return best;
}

std::vector<SynthFrame> supplement_astar(const GapProblem& gap, const SupplementParams& params,
                                         SupplementStats* stats) {
  synth_detail::check_gap(gap);
  if (!(params.cost_threshold_J >= 0.0)) throw std::invalid_argument("cost threshold must be >= 0");
  SupplementStats local;
  SupplementStats& st = stats ? *stats : local;
  st = SupplementStats{};
  std::vector<SynthFrame> frames;
  if (params.fixed_frames > 0) {  // the length is given: run to the horizon
    SupplementParams fixed = params;
    fixed.cost_threshold_J = 0.0;
    fixed.max_states = std::max(params.max_states, params.fixed_frames);
    frames = synth_detail::astar_search(gap, fixed, params.fixed_frames, &st);
  } else {
    frames = synth_detail::astar_search(gap, params, choose_transition_frames(gap, params), &st);
  }
  if (params.step_feet) {
    // Only where the feet skate, and kept where it skates less.
    const std::size_t skating = synth_detail::skating_steps(gap, frames);
    if (skating > 0) {
      std::vector<SynthFrame> stepped = frames;
      synth_detail::step_feet(gap, stepped, synth_detail::stepping_params(gap));
      if (synth_detail::skating_steps(gap, stepped) < skating) {
        frames = std::move(stepped);
        st.stepped = true;
      }
    }
  }
  if (params.refine.iterations > 0 || params.refine.polish_sweeps > 0) {
    // Feet may slide as much as the slerp transition of the same length's
    // (the search's own bound; after the stepping pass: as much as its
    // path), not more; no joint may turn faster than in that slerp, the
    // path or the captured steps at either end.
    PathCache slerp_path;
    const std::vector<SynthFrame> slerp = slerp_transition(gap, frames.size());
    slerp_path.build_poses(gap, slerp);
    RefineOptions ro = params.refine;
    ro.foot_sliding_limit_m = st.stepped ? 0.0 : slerp_path.foot_sliding(gap);
    ro.angular_speed_limit_radps = synth_detail::peak_angular_speed(gap, slerp);
    const RefineResult r = refine_transition(gap, frames, ro);
    st.refine_steps = r.steps;
    st.refine_gain_J = r.energy_before_J - r.energy_after_J;
  }
  return frames;
}

}  // namespace mocap
