// mocap-search export (export_command.hpp).
#include "export_command.hpp"

#include <algorithm>
#include <charconv>
#include <filesystem>
#include <iostream>
#include <string_view>

#include "mocap/common/io/motion_file.hpp"
#include "mocap/common/motion/clip_source.hpp"
#include "mocap/common/motion/export.hpp"
#include "mocap/common/motion/skeleton_motion.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/common/util/output_path.hpp"
#include "mocap/search/results_file.hpp"

namespace mocap {
namespace {

// A 1-based number given as `option`.
std::size_t positive(const std::string& text, const std::string& option, const char* what) {
  std::size_t v = 0;
  const auto r = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || r.ec != std::errc() || r.ptr != text.data() + text.size() || v == 0)
    throw InputError(
        option, 0, std::string("expected ") + what + " (an integer from 1), got \"" + text + "\"");
  return v;
}

void require(const std::string& value, const std::string& option, const std::string& why) {
  if (value.empty()) throw InputError(option, 0, "required " + why);
}

}  // namespace

CLI::App* add_export_command(CLI::App& app, ExportArgs& a) {
  CLI::App* cmd = app.add_subcommand(
      "export",
      "Write a partial motion of the index as BVH, glTF binary (.glb) or NumPy (.npz), by the "
      "extension of --out (the clip's skeleton, written as mocap-synth writes motions): --clip "
      "NAME --frames S-E, or the result of rank K of pair P of query Q in a results file "
      "(--results R.jsonl --id Q --pair P --rank K).");
  cmd->add_option("--index", a.index,
                  "Index file (mocap-index build), or a collection manifest (build --shards)");
  cmd->add_option("--clip", a.clip,
                  "The clip: its path as indexed (mocap-search results' \"clip\"), any other path "
                  "to the same file, or its file name");
  cmd->add_option("--frames", a.frames, "S-E: frames S to E of the clip, 0-based, inclusive");
  cmd->add_option("--results", a.results,
                  "Search results (mocap-search --out, JSON lines) over the same index");
  cmd->add_option("--id", a.id, "With --results: the query's \"id\"");
  cmd->add_option("--pair", a.pair,
                  "With --results: the pair, 1-based (pair P joins query frames P and P+1, as "
                  "mocap-synth --pick)");
  cmd->add_option("--rank", a.rank, "With --results: the result's rank (1: the best)");
  cmd->add_option("--out", a.out,
                  "The file to write (replaced atomically): M.glb glTF 2.0 binary (metres, +Y "
                  "up), M.npz NumPy arrays (positions, rotations, names, parents, fps), any "
                  "other name BVH (docs/cli.md \"Motion formats\")");
  cmd->add_flag("--force", a.force,
                "Replace --out even when it holds something else (never a folder, device or FIFO; "
                "docs/cli.md \"Output paths\")");
  return cmd;
}

int run_export(const ExportArgs& a) {
  require(a.index, "--index", "(an index file or a collection manifest)");
  const bool direct = !a.clip.empty() || !a.frames.empty();
  const bool listed = !a.results.empty() || !a.id.empty() || !a.pair.empty() || !a.rank.empty();
  if (direct == listed)
    throw InputError(direct ? "--results" : "export", 0,
                     direct ? "give either --clip NAME --frames S-E or --results R.jsonl --id Q "
                              "--pair P --rank K, not both"
                            : "give --clip NAME --frames S-E, or --results R.jsonl --id Q --pair "
                              "P --rank K");
  FrameRange range;
  std::size_t pair = 0, rank = 0;
  if (direct) {
    require(a.clip, "--clip", "with --frames (the clip's path as indexed, or its file name)");
    require(a.frames, "--frames", "with --clip (S-E: first and last frame, 0-based)");
    range = parse_frame_range(a.frames, "--frames");
  } else {
    require(a.results, "--results", "with --id, --pair and --rank (a mocap-search results file)");
    require(a.id, "--id", "with --results (the query's \"id\" in the results file)");
    require(a.pair, "--pair", "with --results (the pair, 1-based)");
    require(a.rank, "--rank", "with --results (the result's rank, 1 the best)");
    pair = positive(a.pair, "--pair", "a pair number");
    rank = positive(a.rank, "--rank", "a rank");
  }
  require(a.out, "--out", "(the motion file to write: .bvh, .glb or .npz)");
  // The output is checked before anything is read (docs/cli.md "Output paths").
  check_outputs_and_inputs({{"--out", a.out}}, {{"--index", a.index}, {"--results", a.results}});
  const std::filesystem::path out =
      checked_output_path(a.out, motion_output_kind(motion_format(a.out)), a.force, "--out");

  const ClipSource clips = ClipSource::open(a.index);
  std::size_t clip = 0;
  if (direct) {
    clip = find_clip(clips, a.clip);
  } else {
    const SearchResultsLine line = read_search_results_line(a.results, a.id, clips);
    if (pair > line.pairs.size())
      throw InputError(a.results, line.line,
                       "query \"" + a.id + "\": pair " + std::to_string(pair) +
                           " out of range (--pair; the query has " +
                           std::to_string(line.pairs.size()) + " pairs)");
    const auto& results = line.pairs[pair - 1].results;
    const auto it = std::find_if(results.begin(), results.end(),
                                 [&](const SearchResult& r) { return r.rank == rank; });
    if (it == results.end())
      throw InputError(a.results, line.line,
                       "query \"" + a.id + "\", pair " + std::to_string(pair) +
                           ": no result of rank " + std::to_string(rank) + " (--rank; " +
                           std::to_string(results.size()) + " results)");
    clip = it->clip_index;
    range = {it->start_frame, it->end_frame};
  }
  const RawClip motion = partial_motion_clip(clips, clip, range, direct ? "--frames" : a.results);
  write_motion_file(motion, clips.skeleton(clips.skeleton_of(clip)).skeleton.unit_scale_m, out);
  std::cout << "motion: " << std::filesystem::absolute(a.out).string() << " (" << motion.frame_count
            << " frames: " << clips.clip(clip).path << " frames " << range.first << "-"
            << range.last << ")\n";
  return 0;
}

}  // namespace mocap
