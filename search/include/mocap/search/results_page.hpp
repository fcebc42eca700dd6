#pragma once
// The 3D player of search results (mocap-search --html and view; the player
// itself: mocap/player/player.hpp): one scene per query, every ranked
// partial motion of each pair side by side.
#include <cstddef>
#include <string>
#include <vector>

#include "mocap/common/motion/clip_source.hpp"
#include "mocap/player/player.hpp"
#include "mocap/search/results_file.hpp"
#include "mocap/search/search.hpp"

namespace mocap {

/// Ranked partial motion r of pair `pair` (1-based) as a player motion:
/// id "pPrR", tag "pP rR" (a star when chosen), label "pair P rank R
/// (chosen): FILE S-E", group "pair P", the chosen colour or the rank's.
/// Frames are made once per clip range in `made`.
PlayerMotion result_player_motion(PlayerClipMotions& made, std::size_t pair, const SearchResult& r,
                                  bool chosen);

/// One query's search results: every ranked partial motion of each pair
/// (group "pair h", ranks side by side), all starting at 0.
PlayerScene results_player_scene(const ClipSource& clips, const std::string& query_id,
                                 const std::vector<PairResults>& pairs);

/// The player page of search results: one scene per line with results
/// (results_player_scene), in order, keeping only the ids in `ids` when it
/// is not empty (an id the lines lack throws InputError(results_name, 0,
/// ...) listing the ids there). Lines with an error are left out;
/// InputError(results_name, 0, ...) when no line is left.
std::string results_player_page(const ClipSource& clips, const std::vector<ResultsLine>& lines,
                                const std::vector<std::string>& ids,
                                const std::string& results_name, const PlayerLibrary& library);

}  // namespace mocap
