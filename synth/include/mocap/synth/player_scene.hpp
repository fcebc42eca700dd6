#pragma once
// The synthesis's scene of the 3D player (mocap/player/player.hpp): what
// REPORT.html plays (docs/synthesis.md "3D player").
#include <cstddef>
#include <vector>

#include "mocap/common/motion/clip_source.hpp"
#include "mocap/player/player.hpp"
#include "mocap/search/query.hpp"
#include "mocap/search/search.hpp"
#include "mocap/synth/synth_job.hpp"

namespace mocap {

/// The synthesis's scene: the synthesised motion (group "synthesised"), the
/// query frames on it, and the top `max_rank` partial motions of each pair
/// (group "pair h"; the chosen one marked), each starting when its pair's
/// partial motion starts in the output. Marks: query frames, transitions,
/// partial motions.
PlayerScene synth_player_scene(const ClipSource& clips, const Query& query,
                               const std::vector<PairResults>& ranked, const SynthResult& result,
                               std::size_t max_rank = 5);

}  // namespace mocap
