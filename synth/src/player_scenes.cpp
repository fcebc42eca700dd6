// The player's motions and scenes (player.hpp): BVH text, root path box,
// foot contacts, and the layout of a synthesis or of one query's results.
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <optional>

#include "measures.hpp"
#include "mocap/common/bvh.hpp"
#include "mocap/common/error.hpp"
#include "mocap/synth/player.hpp"

namespace mocap {
namespace {

std::string base_name(const std::string& path) {
  const auto s = path.find_last_of('/');
  return s == std::string::npos ? path : path.substr(s + 1);
}

// Colours: the synthesised motion as in the filmstrips, the chosen partial
// motion gold, the other ranks from a palette that avoids the feet's green
// and magenta.
constexpr const char* kSynthColour = "#c0392b";
constexpr const char* kChosenColour = "#b8860b";
constexpr const char* kQueryColour = "#1f5fbf";
constexpr const char* kRankColours[] = {"#3b6fb6", "#7b5ea7", "#4f8a8b", "#8c564b",
                                        "#5a6270", "#a0522d", "#2f4f7f", "#6b8e23"};

const char* rank_colour(std::size_t rank) {
  constexpr std::size_t n = sizeof kRankColours / sizeof kRankColours[0];
  return kRankColours[(rank == 0 ? 0 : rank - 1) % n];
}

}  // namespace

PlayerMotion player_motion(const SynthSkeleton& sk, const std::vector<SynthFrame>& frames,
                           double frame_time_s) {
  PlayerMotion m;
  const Skeleton& s = sk.skeleton;
  m.bvh =
      write_bvh(to_export_layout(motion_bvh_clip(sk, frames, frame_time_s, "player motion")), 6);
  m.unit_m = s.unit_scale_m;
  m.ground_m = sk.model.params.ground_height_m;
  m.frame_time_s = frame_time_s;
  m.frames = frames.size();
  for (std::size_t j = 0; j < sk.joint_count(); ++j)
    if (sk.is_root_chain[j] && static_cast<int>(j) != sk.root_joint)
      m.hidden_joints.push_back(s.names[j]);
  if (!frames.empty()) {
    const Eigen::Vector3d& p0 = frames[0].root_position_m;
    m.box[0] = m.box[1] = p0.x();
    m.box[2] = m.box[3] = p0.z();
    for (const SynthFrame& f : frames) {
      m.box[0] = std::min(m.box[0], f.root_position_m.x());
      m.box[1] = std::max(m.box[1], f.root_position_m.x());
      m.box[2] = std::min(m.box[2], f.root_position_m.z());
      m.box[3] = std::max(m.box[3], f.root_position_m.z());
    }
  }
  // Foot states per frame (player.hpp kFootContact): height of the joint's
  // origin above the ground, horizontal speed by central differences.
  std::vector<WorldPose> world(frames.size());
  for (std::size_t f = 0; f < frames.size(); ++f) synth_world_pose(sk, frames[f], world[f]);
  const std::size_t n = frames.size();
  for (int jf : sk.foot_joints) {
    const auto j = static_cast<std::size_t>(jf);
    m.foot_joints.push_back(s.names[j]);
    std::string states(n, kFootAir);
    for (std::size_t f = 0; f < n; ++f) {
      const Eigen::Vector3d& p = world[f].positions_m[j];
      if (p.y() - m.ground_m >= synth_detail::kSkatingHeightM) continue;
      double speed = 0.0;
      if (n >= 2) {
        const std::size_t a = f == 0 ? 0 : f - 1, b = f + 1 == n ? f : f + 1;
        const Eigen::Vector3d d = world[b].positions_m[j] - world[a].positions_m[j];
        speed = std::hypot(d.x(), d.z()) / (static_cast<double>(b - a) * frame_time_s);
      }
      states[f] = speed > synth_detail::kSkatingSpeedMps ? kFootSkating : kFootContact;
    }
    m.contacts.push_back(std::move(states));
  }
  return m;
}

PlayerMotion player_clip_motion(const ClipSource& clips, std::size_t clip, std::size_t start,
                                std::size_t end) {
  const SynthSkeleton sk = make_synth_skeleton(clips, clips.skeleton_of(clip), clip);
  std::vector<SynthFrame> frames;
  for (std::size_t f = start; f <= end; ++f) frames.push_back(clip_frame(clips, clip, f));
  PlayerMotion m = player_motion(sk, frames, clips.clip(clip).frame_time_s);
  m.first_frame = start;
  return m;
}

namespace {

std::string partial_label(std::size_t pair, const SearchResult& r, bool chosen) {
  return "pair " + std::to_string(pair) + " rank " + std::to_string(r.rank) +
         (chosen ? " (chosen)" : "") + ": " + base_name(r.clip) + " " +
         std::to_string(r.start_frame) + "-" + std::to_string(r.end_frame);
}

// The motion of result r (clip frames start..end), reusing the motion of a
// result already made for the same frames of the same clip.
PlayerMotion result_motion(const ClipSource& clips, const SearchResult& r,
                           std::map<std::array<std::size_t, 3>, PlayerMotion>& made) {
  const std::array<std::size_t, 3> key{r.clip_index, r.start_frame, r.end_frame};
  auto it = made.find(key);
  if (it == made.end())
    it = made.emplace(key, player_clip_motion(clips, r.clip_index, r.start_frame, r.end_frame))
             .first;
  return it->second;
}

double end_time(const PlayerMotion& m) {
  return m.start_s + static_cast<double>(m.frames > 0 ? m.frames - 1 : 0) * m.frame_time_s;
}

}  // namespace

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
  motion.colour = kSynthColour;
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
    q.colour = kQueryColour;
    scene.motions.push_back(std::move(q));
  }
  std::map<std::array<std::size_t, 3>, PlayerMotion> made;
  for (std::size_t h = 0; h < ranked.size(); ++h)
    for (const SearchResult& r : ranked[h].results) {
      const bool chosen = h < result.chosen.size() && r.rank == result.chosen[h].rank;
      if (r.rank > max_rank && !chosen) continue;
      PlayerMotion m = result_motion(clips, r, made);
      m.id = "p" + std::to_string(h + 1) + "r" + std::to_string(r.rank);
      m.tag =
          "p" + std::to_string(h + 1) + " r" + std::to_string(r.rank) + (chosen ? " \u2605" : "");
      m.label = partial_label(h + 1, r, chosen);
      m.group = "pair " + std::to_string(h + 1);
      m.colour = chosen ? kChosenColour : rank_colour(r.rank);
      m.chosen = chosen;
      const auto it = pair_start.find(h + 1);
      m.start_s = it == pair_start.end() ? 0.0 : it->second;
      scene.motions.push_back(std::move(m));
    }
  for (const PlayerMotion& m : scene.motions)
    scene.duration_s = std::max(scene.duration_s, end_time(m));
  return scene;
}

PlayerScene results_player_scene(const ClipSource& clips, const std::string& query_id,
                                 const std::vector<PairResults>& pairs) {
  PlayerScene scene;
  scene.id = query_id;
  scene.title = "Search results: " + query_id;
  std::map<std::array<std::size_t, 3>, PlayerMotion> made;
  for (std::size_t h = 0; h < pairs.size(); ++h)
    for (const SearchResult& r : pairs[h].results) {
      PlayerMotion m = result_motion(clips, r, made);
      m.id = "p" + std::to_string(h + 1) + "r" + std::to_string(r.rank);
      m.tag = "p" + std::to_string(h + 1) + " r" + std::to_string(r.rank);
      m.label = partial_label(h + 1, r, false);
      m.group = "pair " + std::to_string(h + 1);
      m.colour = r.rank == 1 ? kChosenColour : rank_colour(r.rank);
      scene.duration_s = std::max(scene.duration_s, end_time(m));
      scene.motions.push_back(std::move(m));
    }
  return scene;
}

}  // namespace mocap

namespace mocap {

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
