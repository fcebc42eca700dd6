// The A* search of the paper's figure 4 over a planned length (private to
// synth/src; supplement_astar in supplement.cpp chooses the length and runs
// the refinement after it).
#pragma once

#include <cstddef>
#include <vector>

#include "mocap/synth/synth.hpp"

namespace mocap::synth_detail {

/// The search (synth.hpp, "astar") planned over `planned_frames` inserted
/// frames: at most params.max_states frames, stopping when g(S -> S_G) <
/// T_c or the planned length is used up. Adds its iterations and energy
/// evaluations to `stats` and sets estimated_frames and stop_reason there
/// (when given). The gap must have been checked (check_gap).
std::vector<SynthFrame> astar_search(const GapProblem& gap, const SupplementParams& params,
                                     std::size_t planned_frames, SupplementStats* stats);

}  // namespace mocap::synth_detail
