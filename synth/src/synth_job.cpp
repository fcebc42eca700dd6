// The synthesis job: results in, assembly, BVH out (synth_job.hpp).
#include "mocap/synth/synth_job.hpp"
#include "mocap/common/util/json_text.hpp"

#include <tbb/parallel_for.h>
#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>
#include <sstream>
#include <tuple>
#include <utility>

#include "foot_steps.hpp"
#include "mocap/common/body/retarget.hpp"
#include "mocap/common/body/skeleton.hpp"
#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/motion_file.hpp"
#include "mocap/common/io/units.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/common/util/file.hpp"
#include "mocap/common/util/input_limits.hpp"
#include "mocap/search/query_pose.hpp"
#include "mocap/search/timing.hpp"
#include "motion_layout.hpp"
#include "warp_fill.hpp"

namespace mocap {
namespace {

std::string base_name(const std::string& path) {
  const auto s = path.find_last_of('/');
  return s == std::string::npos ? path : path.substr(s + 1);
}

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// Query frame i on the target skeleton: the DOFs it gives (the search
// library's resolver, mocap/search/query_pose.hpp), and for a BVH frame its
// file's previous and next frames (the frame itself at the file's ends);
// errors naming the query file.
synth_detail::QueryFrameInput resolve_query_frame(const Query& q, std::size_t i,
                                                  const ClipSource& clips, const SynthSkeleton& sk,
                                                  QueryBvhCache& cache, const std::string& source,
                                                  const TypicalPoseFn& typical_pose) {
  const IndexSkeleton& isk = clips.skeleton(sk.index_skeleton);
  synth_detail::QueryFrameInput out;
  try {
    out.pose = resolve_query_pose(q, i, isk, sk.model, cache, "auto", nullptr, typical_pose);
  } catch (const InputError& e) {
    throw InputError(source, 0, e.detail());
  }
  if (!out.pose.from_bvh) return out;
  auto neighbour = [&](std::size_t frame) -> std::optional<ResolvedQueryPose> {
    Query qn = q;
    qn.frames[i].bvh_frame = frame;
    try {
      return resolve_query_pose(qn, i, isk, sk.model, cache, "auto", nullptr, typical_pose);
    } catch (const InputError&) {
      return std::nullopt;  // past the file's end: the frame itself
    }
  };
  const std::size_t f = q.frames[i].bvh_frame;
  if (f > 0) out.prev = neighbour(f - 1);
  out.next = neighbour(f + 1);
  return out;
}

// Whether partial motion `m` lasts the query's minimum length (at least
// one frame).
bool long_enough(const ClipSource& clips, const Query& query, const SearchResult& m) {
  const double min_s = query.min_length_s.value_or(SearchOptions{}.min_length_s);
  const double dt = clips.clip(m.clip_index).frame_time_s;
  const auto frames = std::max<std::size_t>(1, static_cast<std::size_t>(std::llround(min_s / dt)));
  return m.end_frame - m.start_frame >= frames;
}

// The chosen result of each pair: its best-ranked partial motion at least
// the query's minimum length long (min_length_s, else the search's default:
// results files of other settings may hold shorter ones), unless picked.
// InputError ("--pick") for a pick of a pair out of range, of a rank the
// pair lacks or of a partial motion shorter than the minimum; InputError
// (`source`) for a pair with no result long enough.
std::vector<SearchResult> chosen_results(const ClipSource& clips, const Query& query,
                                         const std::vector<PairResults>& ranked,
                                         const std::vector<Pick>& picks,
                                         const std::string& source) {
  const std::size_t pairs = ranked.size();
  const double min_s = query.min_length_s.value_or(SearchOptions{}.min_length_s);
  auto long_enough = [&](const SearchResult& m) { return mocap::long_enough(clips, query, m); };
  std::vector<std::size_t> rank(pairs, 0);  // 0: the best long enough
  for (const Pick& p : picks) {
    if (p.pair > pairs)
      throw InputError("--pick", 0,
                       "pair " + std::to_string(p.pair) + " out of range (the query has " +
                           std::to_string(pairs) + " pairs)");
    rank[p.pair - 1] = p.rank;
  }
  std::vector<SearchResult> chosen;
  for (std::size_t h = 0; h < pairs; ++h) {
    const auto& rs = ranked[h].results;
    if (rank[h] == 0) {
      auto it = std::find_if(rs.begin(), rs.end(), long_enough);
      if (it == rs.end())
        throw InputError(source, 0,
                         "pair " + std::to_string(h + 1) + " has no partial motion of at least " +
                             std::to_string(min_s) + " s among its " + std::to_string(rs.size()) +
                             " results");
      chosen.push_back(*it);
      continue;
    }
    auto it = std::find_if(rs.begin(), rs.end(),
                           [&](const SearchResult& m) { return m.rank == rank[h]; });
    if (it == rs.end())
      throw InputError("--pick", 0,
                       "pair " + std::to_string(h + 1) + " has no result of rank " +
                           std::to_string(rank[h]) + " (" + std::to_string(rs.size()) +
                           " results)");
    if (!long_enough(*it))
      throw InputError("--pick", 0,
                       "pair " + std::to_string(h + 1) + ", rank " + std::to_string(rank[h]) +
                           ": the partial motion is shorter than the minimum length (" +
                           std::to_string(min_s) + " s)");
    chosen.push_back(*it);
  }
  return chosen;
}

// Frames of the chosen clips on the target skeleton (the first chosen
// clip's): clips of another skeleton are mapped joint by joint (same name,
// else the same canonical body part). The constructor throws InputError
// (`source`) for a clip of another frame rate, or of a skeleton with no
// counterpart for a target joint that rotates.
class TargetPieces {
 public:
  TargetPieces(const ClipSource& clips, const std::vector<SearchResult>& chosen,
               const std::string& source)
      : clips_(clips),
        c0_(clips.clip(chosen[0].clip_index)),
        k0_(clips.skeleton_of(chosen[0].clip_index)),
        target_(clips.skeleton(k0_).skeleton) {
    for (const SearchResult& m : chosen) {
      const IndexClip& c = clips.clip(m.clip_index);
      const std::uint32_t k = clips.skeleton_of(m.clip_index);
      if (std::abs(c.frame_time_s - c0_.frame_time_s) > 1e-9)
        throw InputError(source, 0,
                         "clip \"" + base_name(c.path) + "\" has frame time " +
                             std::to_string(c.frame_time_s) + " s, the target (\"" +
                             base_name(c0_.path) + "\") " + std::to_string(c0_.frame_time_s) +
                             " s: pick clips of one frame rate");
      if (k == k0_ || joint_maps_.count(k)) continue;
      const Skeleton& other = clips.skeleton(k).skeleton;
      std::vector<int> map(target_.joint_count(), -1);
      std::string missing;
      for (std::size_t j = 0; j < target_.joint_count(); ++j) {
        int o = other.find(target_.names[j]);
        if (o < 0) o = find_joint_by_alias(other, target_.names[j]);
        map[j] = o;
        if (o < 0 && target_.channels[j].rotation_count > 0)
          missing += (missing.empty() ? "" : ", ") + target_.names[j];
      }
      if (!missing.empty())
        throw InputError(source, 0,
                         "clip \"" + base_name(c.path) + "\" uses skeleton " + std::to_string(k) +
                             ", which cannot be mapped to the target skeleton " +
                             std::to_string(k0_) + " (from \"" + base_name(c0_.path) +
                             "\"): no joint for " + missing);
      joint_maps_[k] = std::move(map);
    }
  }

  std::size_t frame_count(std::size_t clip) const { return clips_.clip(clip).frame_count; }
  // Whether frame() gives the clip's frames on the target skeleton: a clip
  // of the target's frame rate, of its skeleton or of one already mapped.
  bool takes(std::size_t clip) const {
    const std::uint32_t k = clips_.skeleton_of(clip);
    return std::abs(clips_.clip(clip).frame_time_s - c0_.frame_time_s) <= 1e-9 &&
           (k == k0_ || joint_maps_.count(k) > 0);
  }
  // Frame f of a chosen clip, on the target skeleton (joints without a
  // counterpart: identity).
  SynthFrame frame(std::size_t clip, std::size_t f) const {
    SynthFrame fr = clip_frame(clips_, clip, f);
    const std::uint32_t k = clips_.skeleton_of(clip);
    const auto it = joint_maps_.find(k);
    if (k == k0_ || it == joint_maps_.end()) return fr;
    SynthFrame mapped;
    mapped.root_position_m = fr.root_position_m;
    mapped.local_rotations.assign(target_.joint_count(), Eigen::Quaterniond::Identity());
    for (std::size_t j = 0; j < target_.joint_count(); ++j)
      if (it->second[j] >= 0)
        mapped.local_rotations[j] = fr.local_rotations[static_cast<std::size_t>(it->second[j])];
    return mapped;
  }

 private:
  const ClipSource& clips_;
  const IndexClip& c0_;
  const std::uint32_t k0_;  // the target skeleton (source number)
  const Skeleton& target_;
  std::map<std::uint32_t, std::vector<int>> joint_maps_;
};

// One gap to supplement and, once done, its transition and report. A
// merged gap (its ends are one pose: a query frame that is the partial
// motion's own frame) gets no transition; the duplicate frame is dropped
// (the partial motion's) and `gap` is the step that then joins them.
struct GapTask {
  std::size_t pair;
  const char* side;
  GapProblem gap;
  bool merged = false;
  TransitionReport report;
  std::vector<SynthFrame> frames;
  /// Timed key poses: exactly `fixed_frames` frames (possibly 0).
  bool fixed = false;
  std::size_t fixed_frames = 0;
};

// Per pair: the swing of the chosen partial motion's gait (gait_swing_s over
// its clip's frames from a second before the partial motion to a second
// after it, in the clip's time), which times the stepping around it.
std::vector<double> gait_swings(const ClipSource& clips, const SynthSkeleton& sk,
                                const TargetPieces& source,
                                const std::vector<SearchResult>& chosen) {
  std::vector<double> swings;
  for (const SearchResult& r : chosen) {
    const IndexClip& c = clips.clip(r.clip_index);
    const auto second = static_cast<std::size_t>(std::llround(1.0 / c.frame_time_s));
    const std::size_t first = r.start_frame > second ? r.start_frame - second : 0;
    const std::size_t last =
        std::min<std::size_t>(r.end_frame + second, static_cast<std::size_t>(c.frame_count) - 1);
    std::vector<SynthFrame> frames;
    for (std::size_t f = first; f <= last; ++f) frames.push_back(source.frame(r.clip_index, f));
    swings.push_back(synth_detail::gait_swing_s(sk, frames, c.frame_time_s));
  }
  return swings;
}

// The gaps, two per pair in order: into each partial motion from its query
// frame ("in") and out of it to the next ("out"). Query frames bring their
// neighbours (their velocities) to both.
std::vector<GapTask> gap_tasks(const SynthSkeleton& sk, const RangeOfMotion& rom,
                               const synth_detail::MotionLayout& layout,
                               const std::vector<double>& gait_swings, double dt) {
  std::vector<GapTask> tasks;
  for (std::size_t h = 0; h < layout.pieces.size(); ++h) {
    const synth_detail::PlacedQueryFrame& q = layout.queries[h];
    const synth_detail::PlacedQueryFrame& qn = layout.queries[h + 1];
    const auto& pc = layout.pieces[h];
    const std::size_t n = pc.size();
    // The partial motion's gait times the stepping on both of its sides.
    const double swing_s = gait_swings[h];
    GapTask in{h + 1, "in", GapProblem{&sk, &rom, q.before, q.frame, pc[0], pc[1], dt, swing_s},
               false, {},   {}};
    if (layout.merged_in[h]) {
      in.merged = true;
      in.gap.goal = pc[1];
      in.gap.after = pc[2];
    }
    GapTask out{
        h + 1, "out", GapProblem{&sk, &rom, pc[n - 2], pc[n - 1], qn.frame, qn.after, dt, swing_s},
        false, {},    {}};
    if (layout.merged_out[h]) {
      out.merged = true;
      out.gap.before = pc[n - 3];
      out.gap.start = pc[n - 2];
    }
    tasks.push_back(std::move(in));
    tasks.push_back(std::move(out));
  }
  return tasks;
}

// The gaps of a timed query: per pair "in" and "out" of the given lengths,
// or one "direct" gap from Q^h to Q^h+1 (then the pair's "out" slot is an
// empty merged task, so that tasks stay two per pair).
std::vector<GapTask> timed_gap_tasks(const SynthSkeleton& sk, const RangeOfMotion& rom,
                                     const synth_detail::MotionLayout& layout,
                                     const std::vector<double>& gait_swings,
                                     const std::vector<synth_detail::TimedPair>& timed, double dt) {
  std::vector<GapTask> tasks = gap_tasks(sk, rom, layout, gait_swings, dt);
  for (std::size_t h = 0; h < timed.size(); ++h) {
    GapTask& in = tasks[2 * h];
    GapTask& out = tasks[2 * h + 1];
    in.fixed = out.fixed = true;
    in.fixed_frames = timed[h].in;
    out.fixed_frames = timed[h].out;
    if (!timed[h].direct) continue;
    const synth_detail::PlacedQueryFrame& qn = layout.queries[h + 1];
    in.side = "direct";
    in.gap.goal = qn.frame;
    in.gap.after = qn.after;
    out.merged = true;
    out.fixed = false;
  }
  return tasks;
}

// Supplements one gap by options.method and measures it, with the other
// baselines at the same length.
void supplement_gap(GapTask& t, const SynthOptions& options) {
  TransitionReport& tr = t.report;
  tr.pair = t.pair;
  tr.side = t.side;
  tr.method = options.method;
  if (t.merged) {
    tr.measures = measure_transition(t.gap, {});
    return;
  }
  const auto ts = std::chrono::steady_clock::now();
  // Baselines get the length A* would plan with (choose_transition_frames),
  // so --transition slerp|inertialize compare like with like; a timed gap
  // has its length given.
  const std::size_t frames = t.fixed ? t.fixed_frames
                             : options.method == TransitionMethod::astar
                                 ? 0
                                 : choose_transition_frames(t.gap, options.params);
  SupplementParams params = options.params;
  if (t.fixed) params.fixed_frames = frames;
  switch (options.method) {
    case TransitionMethod::astar:
      if (!t.fixed || frames > 0) t.frames = supplement_astar(t.gap, params, &tr.stats);
      break;
    case TransitionMethod::slerp:
      t.frames = slerp_transition(t.gap, frames);
      break;
    case TransitionMethod::inertialize:
      t.frames = inertialize_transition(t.gap, frames);
      break;
  }
  tr.time_ms = ms_since(ts);
  tr.measures = measure_transition(t.gap, t.frames);
  for (TransitionMethod other :
       {TransitionMethod::astar, TransitionMethod::slerp, TransitionMethod::inertialize}) {
    if (other == options.method || other == TransitionMethod::astar) continue;
    const auto bf = other == TransitionMethod::slerp
                        ? slerp_transition(t.gap, t.frames.size())
                        : inertialize_transition(t.gap, t.frames.size());
    tr.baselines.emplace_back(other, measure_transition(t.gap, bf));
  }
}

// The motion Q^1, transition, R_1, transition, Q^2, ..., Q^H into
// res.frames and res.segments; the tasks' reports into res.transitions.
void assemble(SynthResult& res, const std::vector<std::vector<SynthFrame>>& pieces,
              std::vector<GapTask>& tasks) {
  auto add_segment = [&](const std::string& kind, std::size_t pair,
                         const std::vector<SynthFrame>& fs) {
    res.segments.push_back({kind, pair, res.frames.size(), fs.size(), std::nullopt});
    res.frames.insert(res.frames.end(), fs.begin(), fs.end());
  };
  const std::size_t H = pieces.size() + 1;
  for (std::size_t h = 0; h + 1 < H; ++h) {
    add_segment("query", h + 1, {res.query_frames[h]});
    if (std::string(tasks[2 * h].side) == "direct") {  // timed: no partial motion
      add_segment("transition", h + 1, tasks[2 * h].frames);
      res.transitions.push_back(std::move(tasks[2 * h].report));
      continue;
    }
    for (std::size_t side = 0; side < 2; ++side) {
      GapTask& t = tasks[2 * h + side];
      if (side == 1) {
        const auto& pc = pieces[h];
        const auto first = pc.begin() + (tasks[2 * h].merged ? 1 : 0);
        const auto last = pc.end() - (t.merged ? 1 : 0);
        add_segment("partial", h + 1, std::vector<SynthFrame>(first, last));
      }
      add_segment("transition", h + 1, t.frames);
      res.transitions.push_back(std::move(t.report));
    }
  }
  add_segment("query", H, {res.query_frames.back()});
}

// measure_transition over output frames first .. first + count - 1 (count >= 2),
// the frames beside them (where there are any) as S_-1 and S_G+1.
TransitionMeasures measure_span(const SynthResult& res, const RangeOfMotion& rom, std::size_t first,
                                std::size_t count) {
  const std::vector<SynthFrame>& f = res.frames;
  const std::size_t last = first + count - 1;
  const GapProblem gap{res.skeleton,    &rom,    f[first > 0 ? first - 1 : 0],
                       f[first],        f[last], f[std::min(last + 1, f.size() - 1)],
                       res.frame_time_s};
  return measure_transition(
      gap, std::vector<SynthFrame>(f.begin() + static_cast<std::ptrdiff_t>(first + 1),
                                   f.begin() + static_cast<std::ptrdiff_t>(last)));
}

// The captured pieces' own measures and the whole motion's (the report's
// reference for the transitions).
void measure_pieces(SynthResult& res, const RangeOfMotion& rom) {
  for (MotionSegment& s : res.segments)
    if (s.kind == "partial" && s.frame_count >= 2)
      s.measures = measure_span(res, rom, s.first_frame, s.frame_count);
  if (res.frames.size() >= 2) res.whole_measures = measure_span(res, rom, 0, res.frames.size());
}

// The partial motions a warped pair chooses among
// (SynthOptions::warp_candidates): the chosen one first, then the
// ranking's next results that are long enough and whose clips the target
// skeleton takes, `k` in all; only the chosen one where the user picked
// the pair's rank.
std::vector<SearchResult> warp_candidates(const ClipSource& clips, const Query& query,
                                          const PairResults& ranked, const SearchResult& chosen,
                                          bool picked, const TargetPieces& source, std::size_t k) {
  std::vector<SearchResult> out{chosen};
  if (picked) return out;
  for (const SearchResult& m : ranked.results) {
    if (out.size() >= k) break;
    if (m.rank == chosen.rank || !long_enough(clips, query, m) || !source.takes(m.clip_index))
      continue;
    out.push_back(m);
  }
  return out;
}

// The clip of partial motion `c` played over pair `t`'s whole time: its
// time map (the partial motion over piece_frames output frames) extended to
// both key poses; placed where placement_between puts it.
synth_detail::WarpSource warp_source(const TargetPieces& source, const SearchResult& c,
                                     const PairTiming& t) {
  synth_detail::WarpSource src;
  src.frame = [&source, clip = c.clip_index](std::size_t f) { return source.frame(clip, f); };
  src.frame_count = source.frame_count(c.clip_index);
  src.step =
      static_cast<double>(c.end_frame - c.start_frame) / static_cast<double>(t.piece_frames - 1);
  src.start = static_cast<double>(c.start_frame) - static_cast<double>(t.in_frames + 1) * src.step;
  return src;
}

// SynthOptions::style_model: the output's style, the untransferred
// output's (`before`, with a style transfer) and each chosen partial
// motion's (SynthResult::styles; too short or another rig: left out).
void recognise_styles(const ClipSource& clips, const StyleModel& model,
                      const std::optional<StylePrediction>& before, SynthResult& res) {
  const auto add = [&](const std::string& of, const StyleMotion& m, const std::string& content) {
    if (const auto p = recognise_motion_style(model, m, content))
      res.styles.push_back({of, p->style, p->probability});
  };
  add("motion", synth_style_motion(*res.skeleton, res.frames, res.frame_time_s), "");
  if (before) res.styles.push_back({"motion before transfer", before->style, before->probability});
  for (std::size_t h = 0; h < res.chosen.size(); ++h) {
    const SearchResult& r = res.chosen[h];
    const ClipSource::Location at = clips.locate(r.clip_index);
    add("partial " + std::to_string(h + 1),
        index_style_motion(*at.index, at.clip, r.start_frame, r.end_frame),
        at.index->label(at.clip, "content"));
  }
}

// The transitions' measures: of the frames now in their place.
void remeasure_transitions(SynthResult& res, const RangeOfMotion& rom) {
  std::size_t k = 0;
  for (const MotionSegment& seg : res.segments) {
    if (seg.kind != "transition") continue;
    TransitionReport& tr = res.transitions[k++];
    tr.measures = measure_span(res, rom, seg.first_frame - 1, seg.frame_count + 2);
  }
}

// The style asked of this query: its "synth_style", else the options'
// (empty: none).
std::string asked_synth_style(const Query& query, const SynthOptions& options) {
  return query.synth_style.value_or(options.style_transfer.style);
}

// Style transfer (style_transfer.hpp) of the assembled motion toward the
// asked style, its key frames the query frames' and its content the first
// chosen partial motion's label the model knows; returns the untransferred
// output's recognised style (for SynthResult::styles). Errors of a style
// asked by the query name the query and its field.
std::optional<StylePrediction> transfer_output_style(SynthResult& res, const ClipSource& clips,
                                                     const Query& query,
                                                     const SynthOptions& options,
                                                     const RangeOfMotion& rom,
                                                     const std::string& src) {
  StyleTransferParams params = options.style_transfer;
  params.style = asked_synth_style(query, options);
  const std::string field = query.synth_style ? "synth_style" : "--style";
  if (!options.style_model)
    throw InputError(query.synth_style ? src : "--style", 0,
                     (query.synth_style ? "synth_style: " : std::string()) +
                         "needs a style model (mocap-synth --style-model STYLE.json, Python "
                         "style_model=; mocap-index style-model writes one)");
  const StyleModel& model = *options.style_model;
  std::string content;
  for (const SearchResult& r : res.chosen) {
    const ClipSource::Location at = clips.locate(r.clip_index);
    const std::string label = at.index->label(at.clip, "content");
    if (std::find(model.content.classes.begin(), model.content.classes.end(), label) !=
        model.content.classes.end()) {
      content = label;
      break;
    }
  }
  std::vector<std::size_t> keys;
  for (const MotionSegment& seg : res.segments)
    if (seg.kind == "query") keys.push_back(seg.first_frame);
  const std::optional<StylePrediction> before = recognise_motion_style(
      model, synth_style_motion(*res.skeleton, res.frames, res.frame_time_s), "");
  try {
    res.style_transfer = transfer_style(*res.skeleton, &rom, model, params, keys, content,
                                        res.frames, res.frame_time_s);
  } catch (const InputError& e) {
    if (!query.synth_style || e.source() != "--style") throw;
    throw InputError(src, 0, field + ": " + e.detail());
  }
  remeasure_transitions(res, rom);
  return before;
}

// Output frames a..b with their swinging feet lifted off the ground
// (synth_detail::lift_moving_feet); a and b are not changed.
void lift_pair_feet(SynthResult& res, const RangeOfMotion& rom, std::size_t a, std::size_t b) {
  if (b < a + 2 || b >= res.frames.size()) return;
  const auto first = res.frames.begin() + static_cast<std::ptrdiff_t>(a);
  std::vector<SynthFrame> span(first, res.frames.begin() + static_cast<std::ptrdiff_t>(b + 1));
  synth_detail::lift_moving_feet(*res.skeleton, &rom, span, res.frame_time_s);
  std::copy(span.begin() + 1, span.end() - 1, first + 1);
}

// A warped pair's fill from one candidate (`src`, placed here by
// balanced_placement) and what the choice among candidates weighs: the
// warp's size and the fill's W from key pose a to key pose b (the output
// frames beside them as the rates' neighbours).
struct WarpedCandidate {
  synth_detail::WarpSource source;
  std::vector<SynthFrame> fill;
  double size_m = 0.0;
  double work_J = 0.0;
};

WarpedCandidate warp_candidate(const SynthResult& res, const RangeOfMotion& rom,
                               synth_detail::WarpSource src, std::size_t a, std::size_t b) {
  const SynthSkeleton& sk = *res.skeleton;
  const std::vector<SynthFrame>& f = res.frames;
  const std::vector<SynthFrame> unplaced = synth_detail::captured_span(sk, src, b - a);
  src.placement = synth_detail::balanced_placement(sk, unplaced, f[a], f[b]);
  WarpedCandidate c;
  c.size_m = synth_detail::warp_size_m(sk, place_frame(sk, unplaced.front(), src.placement),
                                       place_frame(sk, unplaced.back(), src.placement), f[a], f[b]);
  c.fill = synth_detail::warp_fill(sk, &rom, src, f[a], f[b], b - a, res.frame_time_s);
  const GapProblem gap{
      res.skeleton,    &rom, f[a > 0 ? a - 1 : 0], f[a], f[b], f[std::min(b + 1, f.size() - 1)],
      res.frame_time_s};
  c.work_J = measure_transition(gap, std::vector<SynthFrame>(c.fill.begin() + 1, c.fill.end() - 1))
                 .work_energy_J;
  c.source = std::move(src);
  return c;
}

// SynthOptions::warp_fill: each timed pair with a partial motion is filled
// by a clip played over the whole pair (warp_source) and bent onto both key
// poses (warp_fill.hpp): of the pair's candidates (warp_candidates), the
// one whose warp_size_m + warp_work_weight_m_per_J x warp_work_J is least
// (warp_candidate; the first of equals).
// The pair's chosen partial motion becomes that one. A pair too short for a
// partial motion keeps its A* frames with their swinging feet lifted
// (lift_pair_feet). The transitions' measures are those of the frames now
// in their place.
void warp_timed_pairs(SynthResult& res, const RangeOfMotion& rom, const TargetPieces& source,
                      const ClipSource& clips, const Query& query,
                      const std::vector<PairResults>& ranked, const SynthOptions& options) {
  if (!(std::isfinite(options.warp_work_weight_m_per_J) && options.warp_work_weight_m_per_J >= 0.0))
    throw InputError("--warp-work-weight", 0, "must be a finite number of metres per joule >= 0");
  for (std::size_t h = 0; h < res.timing.size(); ++h) {
    PairTiming& t = res.timing[h];
    const std::size_t a = t.key_frame;
    const std::size_t b =
        h + 1 < res.timing.size() ? res.timing[h + 1].key_frame : res.frames.size() - 1;
    if (t.direct || t.piece_frames < 2) {  // too short for a partial motion: A* frames
      lift_pair_feet(res, rom, a, b);
      continue;
    }
    const bool picked = std::any_of(options.picks.begin(), options.picks.end(),
                                    [&](const Pick& p) { return p.pair == h + 1; });
    const std::vector<SearchResult> candidates =
        warp_candidates(clips, query, ranked[h], res.chosen[h], picked, source,
                        std::max<std::size_t>(1, options.warp_candidates));
    std::optional<WarpedCandidate> best;
    const SearchResult* taken = nullptr;
    const double weight = options.warp_work_weight_m_per_J;
    for (const SearchResult& c : candidates) {
      WarpedCandidate w = warp_candidate(res, rom, warp_source(source, c, t), a, b);
      if (best && w.size_m + weight * w.work_J >= best->size_m + weight * best->work_J) continue;
      best = std::move(w);
      taken = &c;
    }
    t.warp_size_m = best->size_m;
    t.warp_work_J = best->work_J;
    // The played-over-captured factor of the partial motion taken.
    t.warp *= static_cast<double>(res.chosen[h].end_frame - res.chosen[h].start_frame) /
              static_cast<double>(taken->end_frame - taken->start_frame);
    res.chosen[h] = *taken;
    const std::vector<SynthFrame>& fill = best->fill;
    std::copy(fill.begin() + 1, fill.end() - 1,
              res.frames.begin() + static_cast<std::ptrdiff_t>(a + 1));
    t.warped = true;
    t.warp_candidates = candidates.size();
  }
  // The transitions' measures: of the frames now in their place (every
  // pair was warped or had its feet lifted).
  remeasure_transitions(res, rom);
}

}  // namespace

void write_motion_bvh(const SynthResult& result, const std::filesystem::path& path) {
  write_bvh_file(
      motion_bvh_clip(*result.skeleton, result.frames, result.frame_time_s, path.string()), path);
}

void write_motion_file(const SynthResult& result, const std::filesystem::path& path) {
  if (motion_format(path) == MotionFormat::bvh) return write_motion_bvh(result, path);
  write_motion_file(
      motion_bvh_clip(*result.skeleton, result.frames, result.frame_time_s, path.string()),
      result.skeleton->skeleton.unit_scale_m, path);
}

Pick parse_pick(const std::string& text) {
  const auto colon = text.find(':');
  Pick p;
  auto num = [&](std::string_view s, std::size_t& v) {
    const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
    return r.ec == std::errc() && r.ptr == s.data() + s.size() && v >= 1;
  };
  if (colon == std::string::npos || !num(std::string_view(text).substr(0, colon), p.pair) ||
      !num(std::string_view(text).substr(colon + 1), p.rank))
    throw InputError("--pick", 0, "expected PAIR:RANK with 1-based integers, got \"" + text + "\"");
  return p;
}

// The output frame time of a timed query: 1 / --fps, else the first BVH
// query frame's file rate, else 1/30 s.
double output_frame_time(const Query& query, const SynthOptions& options, QueryBvhCache& cache,
                         const std::string& source) {
  if (options.fps) {
    if (!(*options.fps > 0.0 && *options.fps <= 1000.0))
      throw InputError("--fps", 0, "must be in (0, 1000] frames per second");
    return 1.0 / *options.fps;
  }
  // The unit option resolve_query_frame read the file with: the cached file.
  for (const QueryFrameSpec& f : query.frames)
    if (f.bvh) try {
        return f.asf ? 1.0 / f.amc_fps : cache.get(*f.bvh, "auto")->motion.frame_time_s;
      } catch (const InputError& e) {
        throw InputError(source, 0, e.what());
      }
  return 1.0 / 30.0;
}

// The frames of each pair of a timed query at output frame time `dt`
// (docs/queries.md "Timed key poses"): Q^h at round(time_s / dt), the
// time between shared by timed_pair_window; each partial motion (captured
// at `clip_dt`) resampled in `raw` to its played frames. Fills `timing`.
std::vector<synth_detail::TimedPair> time_pairs(const Query& query, double dt, double clip_dt,
                                                std::vector<std::vector<SynthFrame>>& raw,
                                                std::vector<PairTiming>& timing) {
  const double min_s = query.min_length_s.value_or(SearchOptions{}.min_length_s);
  std::vector<synth_detail::TimedPair> out;
  auto key = [&](std::size_t h) {
    return static_cast<std::size_t>(std::llround(*query.frames[h].time_s / dt));
  };
  for (std::size_t h = 0; h < raw.size(); ++h) {
    const std::size_t a = key(h), b = key(h + 1);
    const std::size_t steps = b > a ? b - a : 1;  // output steps from Q^h to Q^h+1
    const TimedPairWindow w = timed_pair_window(
        *query.frames[h + 1].time_s - *query.frames[h].time_s, query.transition_time_s, min_s);
    synth_detail::TimedPair p;
    // The partial motion plays over round(played_s / dt) steps; the rest is
    // shared by the two transitions (a transition of n frames spans n + 1
    // steps), each at least one step.
    const auto played = static_cast<std::size_t>(std::llround(w.played_s / dt));
    PairTiming t;
    t.pair = h + 1;
    t.key_frame = a;
    if (w.direct || played < 1 || played + 2 > steps) {
      p.direct = true;
      p.in = steps - 1;
    } else {
      const std::size_t rest = steps - played;
      p.in = rest / 2 - 1;
      p.out = rest - rest / 2 - 1;
      t.warp =
          static_cast<double>(played) * dt / (static_cast<double>(raw[h].size() - 1) * clip_dt);
      raw[h] = synth_detail::resample_frames(raw[h], played + 1);
      t.piece_frames = played + 1;
    }
    t.in_frames = p.in;
    t.out_frames = p.out;
    t.direct = p.direct;
    timing.push_back(t);
    out.push_back(p);
  }
  return out;
}

Query query_for_fill(const Query& query, const SynthOptions& options) {
  if (!options.warp_fill) return query;
  if (!query.timed()) {
    if (options.warp_required)
      throw InputError("--warp", 0, "needs a timed query (time_s on every query frame)");
    return query;
  }
  Query q = query;
  q.transition_time_s = std::min(q.transition_time_s, kWarpTransitionS);
  return q;
}

SynthResult synthesize(const ClipSource& clips, const Query& query,
                       const std::vector<PairResults>& ranked, const SynthOptions& options,
                       std::optional<SynthSkeleton>& skeleton_out) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::string src = "<query " + query.id + ">";
  const std::size_t H = query.frames.size();
  if (H < 2) throw InputError(src, 0, "frames: a query needs at least 2 frames");
  if (ranked.size() != H - 1)
    throw InputError(src, 0,
                     "the search results have " + std::to_string(ranked.size()) +
                         " pairs, the query " + std::to_string(H - 1));
  SynthResult res;
  res.chosen = chosen_results(clips, query, ranked, options.picks, src);
  // Target skeleton: the first chosen clip's.
  const std::size_t first_clip = res.chosen[0].clip_index;
  const std::uint32_t target = clips.skeleton_of(first_clip);
  const TargetPieces source(clips, res.chosen, src);
  skeleton_out.emplace(make_synth_skeleton(clips, target, first_clip));
  const SynthSkeleton& sk = *skeleton_out;
  res.skeleton = &sk;
  const double dt = clips.clip(first_clip).frame_time_s;
  res.frame_time_s = dt;
  // Range of motion: union over every clip of the target skeleton in the
  // index (every shard of a collection).
  const RangeOfMotion rom = range_of_motion(clips, sk, clips.skeleton_clips(target));
  std::vector<synth_detail::QueryFrameInput> qf;
  QueryBvhCache bvh_cache;
  // The target skeleton's typical pose (over its first clip's index), for
  // query frames of other rigs: read when one comes.
  std::optional<std::vector<Eigen::Quaterniond>> typical;
  const TypicalPoseFn typical_pose = [&]() -> const std::vector<Eigen::Quaterniond>* {
    if (!typical) {
      const std::size_t c = clips.skeleton_clips(sk.index_skeleton).at(0);
      typical = typical_local_rotations(*clips.locate(c).index, clips.clip(c).skeleton);
    }
    return &*typical;
  };
  for (std::size_t i = 0; i < H; ++i)
    qf.push_back(resolve_query_frame(query, i, clips, sk, bvh_cache, src, typical_pose));
  std::vector<std::vector<SynthFrame>> raw(H - 1);
  for (std::size_t h = 0; h + 1 < H; ++h)
    for (std::size_t f = res.chosen[h].start_frame; f <= res.chosen[h].end_frame; ++f)
      raw[h].push_back(source.frame(res.chosen[h].clip_index, f));
  std::vector<synth_detail::TimedPair> timed;
  if (query.timed()) {
    res.frame_time_s = output_frame_time(query, options, bvh_cache, src);
    timed = time_pairs(query, res.frame_time_s, dt, raw, res.timing);
  } else if (options.fps) {
    throw InputError("--fps", 0, "needs a timed query (time_s on every query frame)");
  } else if (options.warp_fill && options.warp_required) {
    throw InputError("--warp", 0, "needs a timed query (time_s on every query frame)");
  }
  const double out_dt = res.frame_time_s;
  const synth_detail::MotionLayout layout =
      synth_detail::lay_out_motion(sk, query.placement, qf, raw, out_dt, query.transition_time_s,
                                   timed.empty() ? nullptr : &timed);
  for (const auto& q : layout.queries) res.query_frames.push_back(q.frame);
  const std::vector<double> swings = gait_swings(clips, sk, source, res.chosen);
  std::vector<GapTask> tasks = timed.empty()
                                   ? gap_tasks(sk, rom, layout, swings, dt)
                                   : timed_gap_tasks(sk, rom, layout, swings, timed, out_dt);
  // Each gap is supplemented as its own task (independent: the result does
  // not depend on the thread count).
  tbb::parallel_for(std::size_t{0}, tasks.size(),
                    [&](std::size_t i) { supplement_gap(tasks[i], options); });
  assemble(res, layout.pieces, tasks);
  for (MotionSegment& seg : res.segments)
    if (seg.kind == "partial")
      std::tie(seg.trimmed_front, seg.trimmed_back) = layout.trimmed[seg.pair - 1];
  if (!timed.empty() && options.warp_fill)
    warp_timed_pairs(res, rom, source, clips, query, ranked, options);
  if (!timed.empty()) {
    const std::size_t last = res.timing.empty() ? 0 : res.timing.back().key_frame;
    const std::size_t want =
        static_cast<std::size_t>(std::llround(*query.frames.back().time_s / out_dt)) + 1;
    if (res.frames.size() != want || last >= want)
      throw std::logic_error("timed synthesis: " + std::to_string(res.frames.size()) +
                             " frames, expected " + std::to_string(want));
  }
  std::optional<StylePrediction> before;
  if (!asked_synth_style(query, options).empty())
    before = transfer_output_style(res, clips, query, options, rom, src);
  res.step_energies_J = motion_step_energies(sk, res.frames, out_dt);
  res.motion_measures = measure_motion(sk, res.frames, out_dt);
  measure_pieces(res, rom);
  if (options.style_model) recognise_styles(clips, *options.style_model, before, res);
  res.synth_ms = ms_since(t0);
  return res;
}

}  // namespace mocap
