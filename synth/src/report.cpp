// REPORT.json and REPORT.html of a synthesis (synth_job.hpp).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "mocap/common/util/json_text.hpp"
#include "mocap/synth/player_scene.hpp"
#include "mocap/synth/synth_job.hpp"
#include "mocap/synth/synth_json.hpp"
#include "report_notes.hpp"
#include "report_views.hpp"

namespace mocap {
namespace {

std::string base_name(const std::string& path) {
  const auto s = path.find_last_of('/');
  return s == std::string::npos ? path : path.substr(s + 1);
}

std::string esc(const std::string& s) {
  return html_escape(s);
}
std::string fmt(int digits, double v) {
  return synth_detail::fixed(digits, v);
}

// Per step: W and its unsupported part over the steps of some transitions
// or captured pieces, their frames without contact (over their states) and
// the largest peak joint speed.
struct PerStep {
  double w_J = 0.0, unsupported_J = 0.0, no_contact_states = 0.0, peak_radps = 0.0;
  double steps = 0.0, states = 0.0;
  void add(const TransitionMeasures& m) {
    const double n = static_cast<double>(m.frames + 1);
    w_J += m.work_energy_J;
    unsupported_J += m.unsupported_J;
    no_contact_states += m.no_contact_ratio * (n + 1.0);
    states += n + 1.0;
    steps += n;
    peak_radps = std::max(peak_radps, m.peak_angular_speed_radps);
  }
  nlohmann::json json() const {
    if (steps == 0.0) return nullptr;
    return {{"steps", steps},
            {"w_J", w_J / steps},
            {"unsupported_J", unsupported_J / steps},
            {"no_contact_ratio", no_contact_states / states},
            {"peak_angular_speed_radps", peak_radps}};
  }
};

// motion.per_step: the transitions beside the captured partial motions they
// join (docs/synthesis.md "Measures").
nlohmann::json per_step_json(const SynthResult& result) {
  PerStep transitions, captured;
  for (const TransitionReport& t : result.transitions) transitions.add(t.measures);
  for (const MotionSegment& s : result.segments)
    if (s.measures) captured.add(*s.measures);
  return {{"transitions", transitions.json()}, {"captured", captured.json()}};
}

// The transitions table: per transition its method, length, g, the slerp
// baseline's g and the foot and range measures; the whole motion's last.
void transitions_table(std::ostringstream& o, const SynthResult& result) {
  o << "<figure "
       "data-figure=\"transitions\"><figcaption>Transitions</figcaption><table><tr><th>pair</"
       "th><th>side</th>"
       "<th>method</th><th>frames</th><th>g (J)</th><th>slerp g (J)</th><th>foot sliding (m)</th>"
       "<th>skating ratio</th><th>skating speed (m/s)</th><th>airborne ratio</th>"
       "<th>range violations</th><th>peak ang. speed (rad/s)</th></tr>";
  for (const TransitionReport& t : result.transitions) {
    double slerp_g = std::nan("");
    for (const auto& [m, ms] : t.baselines)
      if (m == TransitionMethod::slerp) slerp_g = ms.energy_J;
    o << "<tr><td>" << t.pair << "</td><td>" << t.side << "</td><td>"
      << transition_method_name(t.method) << "</td><td>" << t.measures.frames << "</td><td>"
      << fmt(1, t.measures.energy_J) << "</td><td>"
      << (std::isnan(slerp_g) ? std::string("-") : fmt(1, slerp_g)) << "</td><td>"
      << fmt(3, t.measures.foot_sliding_m) << "</td><td>" << fmt(2, t.measures.skating_ratio)
      << "</td><td>" << fmt(2, t.measures.skating_speed_mps) << "</td><td>"
      << fmt(2, t.measures.airborne_ratio) << "</td><td title=\""
      << esc(synth_detail::range_violation_summary(t.measures.range_violation_list)) << "\">"
      << t.measures.range_violations << "</td><td>" << fmt(1, t.measures.peak_angular_speed_radps)
      << "</td></tr>";
  }
  const MotionMeasures& mm = result.motion_measures;
  o << "<tr><td colspan=\"6\">whole motion (" << result.frames.size() << " frames)</td><td>"
    << fmt(3, mm.foot_sliding_m) << "</td><td>" << fmt(2, mm.skating_ratio) << "</td><td>"
    << fmt(2, mm.skating_speed_mps) << "</td><td>" << fmt(2, mm.airborne_ratio)
    << "</td><td></td><td></td></tr>";
  o << "</table></figure>\n";
}

// Under the transitions table: what the foot sliding and the skating ratio
// count (and why both can hold), and each transition's range violations
// named by joint and channel (report_notes.hpp).
void measure_notes(std::ostringstream& o, const SynthResult& result) {
  o << "<div data-figure=\"measure-notes\"><p data-note=\"sliding-skating\">"
    << esc(synth_detail::sliding_skating_note(result.skeleton->model.params,
                                              result.motion_measures))
    << "</p>";
  bool any = false;
  for (const TransitionReport& t : result.transitions) {
    if (t.measures.range_violations == 0) continue;
    if (!any)
      o << "<p>Range violations: (inserted frame, joint) pairs outside the range of motion (the "
           "union of the captured channel ranges of the skeleton's clips, 0.5 deg slack), by "
           "joint and channel, the furthest outside first:</p><ul data-note=\"range\">";
    any = true;
    o << "<li>pair " << t.pair << " " << esc(t.side) << ": " << t.measures.range_violations << ": "
      << esc(synth_detail::range_violation_summary(t.measures.range_violation_list, 12)) << "</li>";
  }
  o << (any ? "</ul>" : "") << "</div>\n";
}

// motion.segments: kind, pair, frames, and for a partial motion of 2 frames
// or more its captured frames' skating and airborne ratios and measures.
nlohmann::json segments_json(const SynthResult& result) {
  nlohmann::json segs = nlohmann::json::array();
  for (const MotionSegment& s : result.segments) {
    nlohmann::json sj = {{"kind", s.kind},
                         {"pair", s.pair},
                         {"first_frame", s.first_frame},
                         {"frames", s.frame_count}};
    if (s.trimmed_front + s.trimmed_back > 0)
      sj["trimmed"] = {{"start", s.trimmed_front}, {"end", s.trimmed_back}};
    if (s.kind == "partial" && s.frame_count >= 2) {  // the captured frames' own measures
      const auto first = result.frames.begin() + static_cast<std::ptrdiff_t>(s.first_frame);
      const MotionMeasures m = measure_motion(
          *result.skeleton,
          std::vector<SynthFrame>(first, first + static_cast<std::ptrdiff_t>(s.frame_count)),
          result.frame_time_s);
      sj["foot_skating_ratio"] = m.skating_ratio;
      sj["airborne_ratio"] = m.airborne_ratio;
    }
    if (s.measures) sj["measures"] = measures_json(*s.measures);
    segs.push_back(std::move(sj));
  }
  return segs;
}

// The report's "style_transfer" (docs/style.md "Style transfer").
nlohmann::json style_transfer_json(const StyleTransferReport& t) {
  const StyleTransferParams& p = t.params;
  return {{"style", p.style},
          {"from_style", t.from_style},
          {"from_p", t.from_p},
          {"content", t.content},
          {"content_recognised", t.content_recognised},
          {"strength", p.strength},
          {"sd_ratio_limits", {p.min_sd_ratio, p.max_sd_ratio}},
          {"key_ease_s", p.key_ease_s},
          {"plant_height_m", p.plant_height_m},
          {"plant_ease_s", p.plant_ease_s},
          {"joints", t.joints},
          {"kept_joints", t.kept_joints},
          {"key_frames", t.key_frames},
          {"held_foot_frames", t.held_foot_frames},
          {"max_root_drop_m", t.max_root_drop_m},
          {"mean_offset_rad", t.mean_offset_rad},
          {"mean_sd_change", t.mean_sd_change}};
}

}  // namespace

std::string synth_report_json(const ClipSource& clips, const Query& query,
                              const std::string& query_path, const std::vector<PairResults>& ranked,
                              const SynthResult& result, const SynthOptions& options,
                              double search_ms, double total_ms, const std::string& bvh_path) {
  nlohmann::json j;
  j["query"] = {{"id", query.id},
                {"file", query_path},
                {"frames", query.frames.size()},
                {"transition_time_s", query.transition_time_s},
                {"relative", query.relative()},
                {"placement", placement_name(query.placement)}};
  j["index"] = clips.path().string();
  nlohmann::json chosen = nlohmann::json::array();
  for (std::size_t h = 0; h < result.chosen.size(); ++h) {
    const SearchResult& m = result.chosen[h];
    chosen.push_back({{"pair", h + 1},
                      {"from", ranked[h].from},
                      {"to", ranked[h].to},
                      {"rank", m.rank},
                      {"clip", m.clip},
                      {"clip_index", m.clip_index},
                      {"start_frame", m.start_frame},
                      {"end_frame", m.end_frame},
                      {"frames", m.end_frame - m.start_frame + 1},
                      {"score_J", m.score_J},
                      {"h_in_J", m.h_in_J},
                      {"h_out_J", m.h_out_J},
                      {"path_cost_J", m.path_cost_J}});
  }
  j["chosen"] = chosen;
  nlohmann::json trs = nlohmann::json::array();
  for (const TransitionReport& t : result.transitions) {
    nlohmann::json tj = {{"pair", t.pair},
                         {"side", t.side},
                         {"method", transition_method_name(t.method)},
                         {"time_ms", t.time_ms}};
    tj.update(measures_json(t.measures));
    if (t.method == TransitionMethod::astar)
      tj["search"] = {{"iterations", t.stats.iterations},
                      {"energy_evaluations", t.stats.energy_evaluations},
                      {"estimated_frames", t.stats.estimated_frames},
                      {"stop_reason", t.stats.stop_reason},
                      {"refine_steps", t.stats.refine_steps},
                      {"refine_gain_J", t.stats.refine_gain_J},
                      {"stepped", t.stats.stepped}};
    nlohmann::json bl = nlohmann::json::object();
    for (const auto& [m, ms] : t.baselines) bl[transition_method_name(m)] = measures_json(ms);
    tj["baselines_same_length"] = bl;
    trs.push_back(tj);
  }
  j["transitions"] = trs;
  if (!result.styles.empty()) {
    nlohmann::json styles = nlohmann::json::array();
    for (const auto& s : result.styles)
      styles.push_back({{"of", s.of}, {"label", s.label}, {"p", s.p}});
    j["styles"] = styles;
  }
  if (result.style_transfer) j["style_transfer"] = style_transfer_json(*result.style_transfer);
  const nlohmann::json segs = segments_json(result);
  double total = 0.0;
  for (double e : result.step_energies_J) total += e;
  j["motion"] = {{"bvh", bvh_path},
                 {"frames", result.frames.size()},
                 {"frame_time_s", result.frame_time_s},
                 {"skeleton", result.skeleton->index_skeleton},
                 {"segments", segs},
                 {"g_total_J", total},
                 {"g_paper_total_J", total},
                 {"foot_sliding_m", result.motion_measures.foot_sliding_m},
                 {"foot_sliding_slow_m", result.motion_measures.foot_sliding_slow_m},
                 {"foot_skating_ratio", result.motion_measures.skating_ratio},
                 {"skating_speed_mps", result.motion_measures.skating_speed_mps},
                 {"airborne_ratio", result.motion_measures.airborne_ratio},
                 {"step_energies_J", result.step_energies_J},
                 {"per_step", per_step_json(result)},
                 {"foot_contacts", synth_detail::foot_contacts_json(synth_detail::foot_contact_rows(
                                       *result.skeleton, result.frames, result.frame_time_s))}};
  if (result.whole_measures) {
    const TransitionMeasures& w = *result.whole_measures;
    j["motion"]["w_J"] = w.work_energy_J;
    j["motion"]["unsupported_J"] = w.unsupported_J;
    j["motion"]["no_contact_ratio"] = w.no_contact_ratio;
    j["motion"]["peak_angular_speed_radps"] = w.peak_angular_speed_radps;
  }
  if (!result.timing.empty()) {
    nlohmann::json pairs = nlohmann::json::array();
    for (const PairTiming& t : result.timing) {
      pairs.push_back({{"pair", t.pair},
                       {"key_frame", t.key_frame},
                       {"in_frames", t.in_frames},
                       {"partial_frames", t.piece_frames},
                       {"out_frames", t.out_frames},
                       {"warp", t.warp},
                       {"direct", t.direct},
                       {"warped", t.warped}});
      if (t.warped) {
        pairs.back()["warp_size_m"] = t.warp_size_m;
        pairs.back()["warp_work_J"] = t.warp_work_J;
        pairs.back()["warp_candidates"] = t.warp_candidates;
      }
    }
    j["timing"] = {{"fps", 1.0 / result.frame_time_s}, {"pairs", pairs}};
  }
  j["about_measures"] = synth_detail::about_measures_json(result);
  j["parameters"] = supplement_params_json(options.params);
  j["parameters"]["transition"] = transition_method_name(options.method);
  j["parameters"]["warp"] = options.warp_fill;
  j["parameters"]["warp_candidates"] = options.warp_candidates;
  j["parameters"]["warp_work_weight_m_per_J"] = options.warp_work_weight_m_per_J;
  j["timings_ms"] = {{"search", search_ms}, {"synthesis", result.synth_ms}, {"total", total_ms}};
  return json_text(j, 2) + "\n";
}

std::string synth_report_html(const ClipSource& clips, const Query& query,
                              const std::vector<PairResults>& ranked, const SynthResult& result,
                              const SynthOptions& options, const PlayerLibrary* player,
                              const std::string& player_missing) {
  const SynthSkeleton& sk = *result.skeleton;
  std::ostringstream o;
  o << "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>mocap-synth: "
    << esc(query.id)
    << "</title><style>body{font-family:sans-serif;margin:24px;background:#fff;color:#222}"
       "figure{margin:12px 0}figcaption{font-weight:bold;margin-bottom:4px}"
       "table{border-collapse:collapse}td,th{border:1px solid #bbb;padding:3px 8px;font-size:13px}"
       "th{background:#e8eef8}tr.chosen td{background:#fff3c4}</style></head><body "
       "data-report=\"mocap-synth\">\n";
  o << "<h1>Motion synthesis: " << esc(query.id) << "</h1>\n<p>" << query.frames.size()
    << " query frames, " << result.frames.size() << " output frames at "
    << fmt(1, 1.0 / result.frame_time_s) << " fps, transitions by "
    << transition_method_name(options.method) << ".</p>\n";
  if (const std::string styles = synth_detail::style_summary_note(result); !styles.empty())
    o << "<p data-figure=\"styles\"><b>Style</b> (recognised by the style model; "
         "docs/style.md): "
      << esc(styles) << "</p>\n";
  if (player)
    o << player_html({synth_player_scene(clips, query, ranked, result)}, *player);
  else
    o << "<p data-figure=\"player-missing\"><b>The 3D player is not in this report</b>: "
      << (player_missing.empty()
              ? std::string("scripts/setup installs its three.js copy into common/player/web "
                            "(MOCAP_PLAYER_DIR names another player folder).")
              : esc(player_missing))
      << "</p>\n";
  o << "<h2>Printable views</h2>\n";
  using synth_detail::filmstrip;
  filmstrip(o, "filmstrip-query", "Query frames (completed, Q_F)", sk, result.query_frames, 12,
            "#1f5fbf");
  // Ranked partial motions (the paper's figures 6 to 10): the first 5 and
  // the one the pair took, wherever it ranks (a warped pair's choice, or a
  // pair whose better ranks are of rigs the target skeleton cannot play).
  // Clips of other skeletons are drawn on their own skeleton.
  std::map<std::uint32_t, SynthSkeleton> others;
  for (std::size_t h = 0; h < ranked.size(); ++h)
    for (const SearchResult& m : ranked[h].results) {
      const bool taken = h < result.chosen.size() && m.rank == result.chosen[h].rank;
      if (m.rank > 5 && !taken) continue;
      const std::uint32_t k = clips.skeleton_of(m.clip_index);
      if (k != sk.index_skeleton && !others.count(k))
        others.emplace(k, make_synth_skeleton(clips, k, m.clip_index));
      const SynthSkeleton& own = k == sk.index_skeleton ? sk : others.at(k);
      std::vector<SynthFrame> fr;
      for (std::size_t f = m.start_frame; f <= m.end_frame; ++f)
        fr.push_back(clip_frame(clips, m.clip_index, f));
      filmstrip(o, "filmstrip-pair" + std::to_string(h + 1) + "-rank" + std::to_string(m.rank),
                "Pair " + std::to_string(h + 1) + ", rank " + std::to_string(m.rank) + ": " +
                    base_name(m.clip) + " frames " + std::to_string(m.start_frame) + "-" +
                    std::to_string(m.end_frame) + (taken ? ", taken" : ""),
                own, fr, 8, taken ? "#b8860b" : "#555", synth_detail::View::front, m.start_frame);
    }
  filmstrip(o, "filmstrip-motion", "Synthesised motion", sk, result.frames, 16, "#c0392b");
  filmstrip(o, "filmstrip-motion-side", "Synthesised motion", sk, result.frames, 16, "#c0392b",
            synth_detail::View::side);
  synth_detail::top_view(o, result);
  synth_detail::contact_timeline(o, result);
  // Ranking table.
  o << "<figure data-figure=\"ranking\"><figcaption>Ranking (score = h_in + h_out + lambda path "
       "cost, J)</figcaption>"
       "<table><tr><th>pair</th><th>rank</th><th>clip</th><th>frames</th><th>score (J)</th><th>h "
       "in</th><th>h out</th></tr>";
  for (std::size_t h = 0; h < ranked.size(); ++h)
    for (const SearchResult& m : ranked[h].results)
      o << "<tr" << (m.rank == result.chosen[h].rank ? " class=\"chosen\"" : "") << "><td>" << h + 1
        << "</td><td>" << m.rank << "</td><td>" << esc(base_name(m.clip)) << "</td><td>"
        << m.start_frame << "-" << m.end_frame << "</td><td>" << fmt(1, m.score_J) << "</td><td>"
        << fmt(1, m.h_in_J) << "</td><td>" << fmt(1, m.h_out_J) << "</td></tr>";
  o << "</table></figure>\n";
  transitions_table(o, result);
  measure_notes(o, result);
  synth_detail::energy_plot(o, result);
  o << "</body></html>\n";
  return o.str();
}

}  // namespace mocap
