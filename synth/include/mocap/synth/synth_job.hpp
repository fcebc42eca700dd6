#pragma once
// The synthesis job: query + chosen partial motions -> target motion
// (Q^1, M_c, R_1, M_c, Q^2, ..., Q^H), written as BVH, with a JSON and an
// HTML report (docs/synthesis.md "Assembly").
//
// Placement (docs/synthesis.md "Placement"): the output starts at the first
// query frame's own pose; partial motions and later query frames are placed
// by the search's rule (mocap/search/placement.hpp); query frames that give
// a root position stay there and each partial motion moves between them to
// absorb the transitions' travel; a query frame that is its partial motion's own
// frame is merged with it. BVH query frames carry their file's velocities
// into the transitions.
#include <cstddef>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "mocap/common/io/raw_clip.hpp"
#include "mocap/common/motion/clip_source.hpp"
#include "mocap/common/motion/style.hpp"
#include "mocap/search/query.hpp"
#include "mocap/search/results_file.hpp"
#include "mocap/search/search.hpp"
#include "mocap/synth/style_transfer.hpp"
#include "mocap/synth/synth.hpp"

namespace mocap {

/// A user's choice: pair h (1-based, joins Q^h and Q^h+1) takes rank r.
struct Pick {
  std::size_t pair = 0;
  std::size_t rank = 0;
};
/// "PAIR:RANK" -> Pick; InputError("--pick", 0, ...) otherwise.
Pick parse_pick(const std::string& text);

struct SynthOptions {
  TransitionMethod method = TransitionMethod::astar;
  SupplementParams params;
  std::vector<Pick> picks;
  /// Output frame rate of a timed query (frames per second, > 0); unset:
  /// the first BVH query frame's file rate, else 30. Refused for an untimed
  /// query.
  std::optional<double> fps;
  /// Timed key poses (docs/synthesis.md "Warped fills"): true (the
  /// default), each pair with a partial motion is filled by a partial
  /// motion's clip played over the whole time between the key poses and
  /// bent onto both (warp_fill), its contacts held; false, transition,
  /// resampled partial motion, transition. An untimed query is not warped.
  bool warp_fill = true;
  /// The warp asked for by name (mocap-synth --warp, Python warp=True): an
  /// untimed query is then an error.
  bool warp_required = false;
  /// With warp_fill: each warped pair chooses, among this many partial
  /// motions of its ranking (the best long enough first), the one whose
  /// warped fill scores least (docs/synthesis.md "Warped fills"): its
  /// warp's size plus warp_work_weight_m_per_J times its W
  /// (PairTiming::warp_size_m, warp_work_J); 1: the ranking's best. A pair
  /// whose rank the user picked takes it.
  std::size_t warp_candidates = 5;
  /// The choice's price of work, metres of warp per joule of the warped
  /// fill's W (finite, >= 0; 0: the smallest warp alone). 3e-4 makes
  /// 1,000 J weigh as 30 cm of warp.
  double warp_work_weight_m_per_J = 3e-4;
  /// With a style model (mocap-synth --style-model; docs/style.md): the
  /// recognised style of the output and of every chosen partial motion
  /// (SynthResult::styles).
  std::shared_ptr<const StyleModel> style_model;
  /// Style transfer (docs/style.md "Style transfer"; needs style_model):
  /// style_transfer.style names the style the output is turned toward
  /// (mocap-synth --style, Python style=); empty: none. A query's
  /// "synth_style" replaces it for that query. The transfer runs on the
  /// assembled motion (warped fills included), the chosen partial motions'
  /// content label (the first the model knows) giving the content.
  StyleTransferParams style_transfer;
};

/// The transition time a warped fill searches with (SynthOptions::warp_fill),
/// seconds: each pair's partial motion then spans the time between its key
/// poses but one frame at each end.
inline constexpr double kWarpTransitionS = 1.0 / 30.0;

/// The query as synthesis searches it: with options.warp_fill, a timed
/// query's transition time at most kWarpTransitionS (docs/synthesis.md
/// "Warped fills"); otherwise the query itself. Throws InputError("--warp")
/// for warp_required with an untimed query.
Query query_for_fill(const Query& query, const SynthOptions& options);

/// A pair of timed key poses in the output (docs/queries.md "Timed key poses").
struct PairTiming {
  std::size_t pair = 0;          // 1-based
  std::size_t key_frame = 0;     // output frame of Q^h: round(time_s / frame time)
  std::size_t in_frames = 0;     // transition frames into the partial motion
  std::size_t piece_frames = 0;  // the partial motion's frames, resampled
  std::size_t out_frames = 0;    // transition frames out of it
  /// Played over captured length of the partial motion (1: as captured).
  double warp = 1.0;
  /// No partial motion: one transition of in_frames from Q^h to Q^h+1.
  bool direct = false;
  /// The pair was filled by its warped clip (SynthOptions::warp_fill): its
  /// "transitions" hold the clip's own frames before and after the partial
  /// motion, bent like it.
  bool warped = false;
  /// A warped pair: its warp's size (metres; the mean joint displacement at
  /// both key poses before the displacement map), the W of its warped fill
  /// over the steps from key pose to key pose (joules; work_energy.hpp,
  /// the frames beside the pair as the rates' neighbours) and how many
  /// partial motions it chose among (SynthOptions::warp_candidates).
  double warp_size_m = 0.0;
  double warp_work_J = 0.0;
  std::size_t warp_candidates = 0;
};

/// One piece of the output motion.
struct MotionSegment {
  std::string kind;      // "query", "partial", "transition"
  std::size_t pair = 0;  // 1-based pair (query: the query frame number)
  std::size_t first_frame = 0;
  std::size_t frame_count = 0;
  /// A partial motion's own measures, as the output holds it (2 frames or
  /// more): measure_transition over its steps, its first and last frames as
  /// S_0 and S_G, the output's frames beside it as S_-1 and S_G+1. The
  /// capture beside which the transitions are judged.
  std::optional<TransitionMeasures> measures;
  /// A partial motion: clip frames the layout dropped from the chosen
  /// result's start and end (docs/synthesis.md "Placement": an untimed
  /// pair whose partial motion would overshoot); 0 otherwise.
  std::size_t trimmed_front = 0, trimmed_back = 0;
};

struct TransitionReport {
  std::size_t pair = 0;
  std::string side;  // "in" (Q^h -> F^s) or "out" (F^e -> Q^h+1)
  TransitionMethod method = TransitionMethod::astar;
  TransitionMeasures measures;
  /// The other methods on the same gap with the same number of frames.
  std::vector<std::pair<TransitionMethod, TransitionMeasures>> baselines;
  SupplementStats stats;
  double time_ms = 0.0;
};

struct SynthResult {
  const SynthSkeleton* skeleton = nullptr;
  std::vector<SynthFrame> frames;
  double frame_time_s = 0.0;
  std::vector<MotionSegment> segments;
  std::vector<SearchResult> chosen;  // per pair
  std::vector<TransitionReport> transitions;
  std::vector<double> step_energies_J;
  /// Sliding over the whole motion (measure_motion).
  MotionMeasures motion_measures;
  /// The whole motion measured as one transition from its first frame to
  /// its last (measure_transition; W, unsupported force, frames without
  /// contact, peak joint speed). Empty for a motion of one frame.
  std::optional<TransitionMeasures> whole_measures;
  std::vector<SynthFrame> query_frames;  // completed Q^h, as placed
  /// Per pair, for a timed query (empty otherwise).
  std::vector<PairTiming> timing;
  /// With SynthOptions::style_model: the style each is recognised as, the
  /// output first ("motion"; with a style transfer, then the output before
  /// it: "motion before transfer"), then each pair's partial motion ("partial
  /// H") of at least 4 frames; empty otherwise.
  struct RecognisedStyle {
    std::string of;
    std::string label;
    double p = 0.0;
  };
  std::vector<RecognisedStyle> styles;
  /// With a style asked for (SynthOptions::style_transfer, a query's
  /// "synth_style"): what the transfer did; "styles" then also holds the
  /// untransferred output's ("motion before transfer", after "motion").
  std::optional<StyleTransferReport> style_transfer;
  double synth_ms = 0.0;
};

/// Runs the job on the clips of `clips` (one index, or a collection's shards:
/// the same motion as one index of the same files). `ranked` are the search
/// results per pair (H - 1 of them). Throws InputError for picks out of
/// range, pairs without results, clips of a skeleton or frame rate other
/// than the target's (the first chosen clip's), query joints the skeleton
/// lacks. `skeleton_out` receives the target skeleton.
SynthResult synthesize(const ClipSource& clips, const Query& query,
                       const std::vector<PairResults>& ranked, const SynthOptions& options,
                       std::optional<SynthSkeleton>& skeleton_out);

/// The motion as BVH in the target skeleton, file units of the first clip:
/// the skeleton's own joints and channels, OFFSETs its rest offsets. The
/// pelvis (SynthSkeleton::root_joint) carries the root translation (position
/// channels, which replace its OFFSET, as Blender reads them) and rotation;
/// a static dummy root above it (Bandai Namco's joint_Root) keeps constant
/// channels. A file whose pelvis has position channels and a non-zero
/// OFFSET is not read right by loaders that add position channels to the
/// OFFSET (three.js BVHLoader): docs/synthesis.md "Output".
void write_motion_bvh(const SynthResult& result, const std::filesystem::path& path);
/// Writes the motion in the format `path`'s extension names: .glb (glTF 2.0
/// binary, metres, +Y up) and .npz (NumPy arrays) as write_motion_file
/// (mocap/common/io/motion_file.hpp) writes the BVH clip of write_motion_bvh
/// in the skeleton's unit; any other name BVH (write_motion_bvh).
void write_motion_file(const SynthResult& result, const std::filesystem::path& path);
/// REPORT.json text ("index": the index file or manifest of `clips`).
std::string synth_report_json(const ClipSource& clips, const Query& query,
                              const std::string& query_path, const std::vector<PairResults>& ranked,
                              const SynthResult& result, const SynthOptions& options,
                              double search_ms, double total_ms, const std::string& bvh_path);

/// What mocap-synth prints after the paths, lines ending in "\n": the feet
/// (foot sliding beside the skating ratio, with what each counts and its
/// thresholds; per foot segment, the frames in the energy model's contact)
/// and each transition's range violations by joint and channel (range,
/// worst value, how far outside). "" without a skeleton.
std::string synth_report_text(const SynthResult& result);

struct PlayerLibrary;  // mocap/player/player.hpp

/// REPORT.html text: one self-contained page (no network) with the 3D
/// player (player.hpp synth_player_scene; left out when `player` is null,
/// the page then says so and why: `player_missing`), and the printable
/// views in inline SVG: filmstrips of the query frames, the ranked partial
/// motions and the synthesised motion, the ranking table and the energy
/// curve. Each figure carries data-figure="..." (tests look for them).
std::string synth_report_html(const ClipSource& clips, const Query& query,
                              const std::vector<PairResults>& ranked, const SynthResult& result,
                              const SynthOptions& options, const PlayerLibrary* player = nullptr,
                              const std::string& player_missing = "");

}  // namespace mocap
