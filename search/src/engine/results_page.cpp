// The player page of search results (mocap/search/results_page.hpp).
#include "mocap/search/results_page.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <string>

#include "mocap/common/util/error.hpp"

namespace mocap {
namespace {

std::string base_name(const std::string& path) {
  const auto s = path.find_last_of('/');
  return s == std::string::npos ? path : path.substr(s + 1);
}

std::string measure_text(double v, bool metres) {
  return metres ? fmt::format("{:.2f} m", v) : fmt::format("{:.0f}\u00b0", v);
}

// "meets the request", or "misses to NAME 73° > 20°, ..." (docs/queries.md
// "Residuals and verdicts"); "" for a result without named constraints.
std::string verdict_text(const SearchResult& r) {
  if (r.residuals_from.empty() && r.residuals_to.empty()) return "";
  std::string misses;
  for (const auto* side : {&r.residuals_from, &r.residuals_to}) {
    // By name: a results file read back holds them in that order.
    std::vector<ConstraintResidual> sorted = *side;
    std::sort(sorted.begin(), sorted.end(),
              [](const auto& a, const auto& b) { return a.name < b.name; });
    for (const ConstraintResidual& c : sorted)
      if (!c.met())
        misses += (misses.empty() ? "" : ", ") +
                  std::string(side == &r.residuals_from ? "from " : "to ") + c.name + " " +
                  measure_text(c.residual, c.metres) + " > " + measure_text(c.limit(), c.metres);
  }
  return misses.empty() ? "meets the request" : "misses " + misses;
}

std::string partial_label(std::size_t pair, const SearchResult& r, bool chosen) {
  const std::string verdict = verdict_text(r);
  return "pair " + std::to_string(pair) + " rank " + std::to_string(r.rank) +
         (chosen ? " (chosen)" : "") + ": " + base_name(r.clip) + " " +
         std::to_string(r.start_frame) + "-" + std::to_string(r.end_frame) +
         (verdict.empty() ? "" : " \u00b7 " + verdict);
}

// The badge after the tag: a tick for a result meeting every named
// constraint, a cross for one missing some; none without constraints.
std::string verdict_badge(const SearchResult& r) {
  if (r.residuals_from.empty() && r.residuals_to.empty()) return "";
  return r.met() ? " \u2713" : " \u2717";
}

}  // namespace

PlayerMotion result_player_motion(PlayerClipMotions& made, std::size_t pair, const SearchResult& r,
                                  bool chosen) {
  PlayerMotion m = made.get(r.clip_index, r.start_frame, r.end_frame);
  m.id = "p" + std::to_string(pair) + "r" + std::to_string(r.rank);
  m.tag = "p" + std::to_string(pair) + " r" + std::to_string(r.rank) + verdict_badge(r) +
          (chosen ? " \u2605" : "");
  m.label = partial_label(pair, r, chosen);
  m.group = "pair " + std::to_string(pair);
  m.colour = chosen ? kPlayerChosenColour : player_rank_colour(r.rank);
  m.chosen = chosen;
  return m;
}

PlayerScene results_player_scene(const ClipSource& clips, const std::string& query_id,
                                 const std::vector<PairResults>& pairs) {
  PlayerScene scene;
  scene.id = query_id;
  scene.title = "Search results: " + query_id;
  PlayerClipMotions made(clips);
  for (std::size_t h = 0; h < pairs.size(); ++h)
    for (const SearchResult& r : pairs[h].results) {
      PlayerMotion m = result_player_motion(made, h + 1, r, false);
      if (r.rank == 1) m.colour = kPlayerChosenColour;
      scene.duration_s = std::max(scene.duration_s, player_end_s(m));
      scene.motions.push_back(std::move(m));
    }
  return scene;
}

std::string results_player_page(const ClipSource& clips, const std::vector<ResultsLine>& lines,
                                const std::vector<std::string>& ids,
                                const std::string& results_name, const PlayerLibrary& library) {
  std::string known;
  for (const ResultsLine& l : lines) known += (known.empty() ? "" : ", ") + l.id;
  for (const std::string& id : ids)
    if (std::none_of(lines.begin(), lines.end(), [&](const ResultsLine& l) { return l.id == id; }))
      throw InputError(results_name, 0,
                       "no results for query \"" + id +
                           "\" (ids there: " + (known.empty() ? "none" : known) + ")");
  std::vector<PlayerScene> scenes;
  for (const ResultsLine& l : lines) {
    if (!l.error.empty()) continue;
    if (!ids.empty() && std::find(ids.begin(), ids.end(), l.id) == ids.end()) continue;
    scenes.push_back(results_player_scene(clips, l.id, l.pairs));
  }
  if (scenes.empty())
    throw InputError(
        results_name, 0,
        "no query with results to play (ids there: " + (known.empty() ? "none" : known) + ")");
  const std::string title =
      "Search results: " +
      (scenes.size() == 1 ? scenes[0].id : std::to_string(scenes.size()) + " queries");
  return player_page(title, scenes, library);
}

}  // namespace mocap
