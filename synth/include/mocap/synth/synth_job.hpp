#pragma once
// The synthesis job: query + chosen partial motions -> target motion
// (Q^1, M_c, R_1, M_c, Q^2, ..., Q^H), written as BVH, with a JSON and an
// HTML report (docs/synthesis.md "Assembly").
//
// Root placement: R_1 keeps its clip coordinates. R_h (h >= 2) keeps them too
// when Q^h gives a world root x and z (the search compared them in world
// coordinates); otherwise it is turned about the vertical to Q^h's heading
// (given) or R_h-1's last heading, and moved so that its first root lies
// (v_e + v_s) / 2 * T past R_h-1's last root (v_e, v_s: horizontal root
// velocities of R_h-1's end and R_h's start, T = the query's transition time).
// Query frames are completed from the neighbouring database frame (Q_F:
// Q^h from R_h's first frame, Q^H from R_H-1's last); an unspecified
// horizontal root position is taken v T / 2 before that frame (after it, for
// Q^H), so the character does not have to step back.
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "mocap/common/index.hpp"
#include "mocap/search/query.hpp"
#include "mocap/search/search.hpp"
#include "mocap/synth/synth.hpp"

namespace mocap {

/// Reads the search output (JSONL) and returns the pairs of the line whose
/// "id" is `query_id` (the results as SearchEngine::run gives them; their
/// labels are not read: synthesis does not use them). InputError (file:line)
/// for unreadable files, bad JSON, a missing id, an error line, or results
/// that do not fit `index` (unknown clip, frames out of range).
std::vector<PairResults> read_search_results(const std::filesystem::path& path,
                                             const std::string& query_id, const Index& index);

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
};

/// One piece of the output motion.
struct MotionSegment {
  std::string kind;      // "query", "partial", "transition"
  std::size_t pair = 0;  // 1-based pair (query: the query frame number)
  std::size_t first_frame = 0;
  std::size_t frame_count = 0;
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
  std::vector<SynthFrame> query_frames;  // completed Q^h, as placed
  double synth_ms = 0.0;
};

/// Runs the job. `ranked` are the search results per pair (H - 1 of them).
/// Throws InputError for picks out of range, pairs without results, clips of
/// a skeleton or frame rate other than the target's (the first chosen clip's),
/// query joints the skeleton lacks. `skeleton_out` receives the target skeleton.
SynthResult synthesize(const Index& index, const Query& query,
                       const std::vector<PairResults>& ranked, const SynthOptions& options,
                       std::optional<SynthSkeleton>& skeleton_out);

/// The motion as BVH in the target skeleton (file units of the first clip,
/// export layout that Blender and three.js load identically).
void write_motion_bvh(const SynthResult& result, const std::filesystem::path& path);

/// REPORT.json text.
std::string synth_report_json(const Index& index, const Query& query, const std::string& query_path,
                              const std::vector<PairResults>& ranked, const SynthResult& result,
                              const SynthOptions& options, double search_ms, double total_ms,
                              const std::string& bvh_path);

/// REPORT.html text: one self-contained page (inline SVG, no scripts, no
/// network) with filmstrips of the query frames, the ranked partial motions
/// and the synthesised motion, the ranking table and the energy curve. Each
/// figure carries data-figure="..." (tests look for them).
std::string synth_report_html(const Index& index, const Query& query,
                              const std::vector<PairResults>& ranked, const SynthResult& result,
                              const SynthOptions& options);

}  // namespace mocap
