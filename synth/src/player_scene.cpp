// The synthesis's scene of the 3D player (mocap/synth/player_scene.hpp).
#include "mocap/synth/player_scene.hpp"

#include <algorithm>
#include <map>

#include "mocap/search/results_page.hpp"

namespace mocap {

PlayerScene synth_player_scene(const ClipSource& clips, const Query& query,
                               const std::vector<PairResults>& ranked, const SynthResult& result,
                               std::size_t max_rank) {
  const SynthSkeleton& sk = *result.skeleton;
  const double dt = result.frame_time_s;
  PlayerScene scene;
  scene.id = query.id;
  scene.title = "Synthesis: " + query.id;
  PlayerMotion motion = player_motion(sk, result.frames, dt);
  motion.id = "motion";
  motion.tag = "synthesised";
  motion.label = "synthesised (" + std::to_string(result.frames.size()) + " frames)";
  motion.group = "synthesised";
  motion.colour = kPlayerSynthColour;
  scene.motions.push_back(std::move(motion));
  // Marks, and when each pair's partial motion starts in the output.
  std::map<std::size_t, double> pair_start;
  for (const MotionSegment& s : result.segments) {
    if (s.frame_count == 0) continue;
    const double a = static_cast<double>(s.first_frame) * dt;
    const double b = static_cast<double>(s.first_frame + s.frame_count - 1) * dt;
    if (s.kind == "query") {
      scene.marks.push_back({"query", "Q" + std::to_string(s.pair), a, a});
      pair_start.emplace(s.pair, a);  // a direct pair: its query frame
    } else if (s.kind == "transition") {
      scene.marks.push_back({"transition", "pair " + std::to_string(s.pair), a, b});
    } else {
      scene.marks.push_back({"partial", "pair " + std::to_string(s.pair), a, b});
      pair_start[s.pair] = a;
    }
  }
  // The completed query frames, on the synthesised motion.
  for (std::size_t h = 0; h < result.query_frames.size(); ++h) {
    PlayerMotion q = player_motion(sk, {result.query_frames[h]}, dt);
    q.id = "query" + std::to_string(h + 1);
    q.tag = "Q" + std::to_string(h + 1);
    q.label = "query frame " + std::to_string(h + 1) + " (completed, on the synthesised motion)";
    q.attach = "motion";
    q.colour = kPlayerQueryColour;
    scene.motions.push_back(std::move(q));
  }
  PlayerClipMotions made(clips);
  for (std::size_t h = 0; h < ranked.size(); ++h)
    for (const SearchResult& r : ranked[h].results) {
      const bool chosen = h < result.chosen.size() && r.rank == result.chosen[h].rank;
      if (r.rank > max_rank && !chosen) continue;
      PlayerMotion m = result_player_motion(made, h + 1, r, chosen);
      const auto it = pair_start.find(h + 1);
      m.start_s = it == pair_start.end() ? 0.0 : it->second;
      scene.motions.push_back(std::move(m));
    }
  for (const PlayerMotion& m : scene.motions)
    scene.duration_s = std::max(scene.duration_s, player_end_s(m));
  return scene;
}

}  // namespace mocap
