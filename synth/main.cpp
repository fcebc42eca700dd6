// mocap-synth: query -> target motion (docs/synthesis.md).
//   mocap-synth --index INDEX.h5|COLLECTION.json --query Q.json|Q.jsonl [--id ID]
//               [--results R.jsonl]
//               [--pick PAIR:RANK ...] --out MOTION.bvh [--report REPORT.json] [--html REPORT.html]
//               [--transition astar|slerp|inertialize] [--max-states N] [--cost-threshold J]
//               [--refine N] [--refine-smoothing J] [--refine-polish S]
//               [--refine-polish-window W] [--refine-polish-segments]
//               [--refine-polish-smoothing J]
//               [--no-step-feet] [--threads N]
#include <tbb/global_control.h>
#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>

#include "mocap/common/atomic_file.hpp"
#include "mocap/common/error.hpp"
#include "mocap/common/file.hpp"
#include "mocap/common/input_limits_cli.hpp"
#include "mocap/common/output_path.hpp"
#include "mocap/search/collection_search.hpp"
#include "mocap/search/query.hpp"
#include "mocap/search/query_file.hpp"
#include "mocap/search/search.hpp"
#include "mocap/synth/clip_source.hpp"
#include "mocap/synth/player.hpp"
#include "mocap/synth/synth_job.hpp"
#include "refine_options.hpp"

int main(int argc, char** argv) {
  CLI::App app{
      "mocap-synth: synthesise the target motion of a query (A* supplementation, paper 2.4)"};
  std::string index_path, query_path, results_path, out_path, report_path, html_path,
      method = "astar";
  std::vector<std::string> picks;
  mocap::SynthOptions options;
  app.add_option("--index", index_path,
                 "index file or collection manifest (mocap-index build [--shards N])")
      ->required();
  app.add_option("--query", query_path,
                 "query file: one JSON query, or a JSONL batch (pick one with --id)")
      ->required();
  std::string query_id;
  app.add_option("--id", query_id,
                 "the id of the query to run in --query (required when it holds several)");
  app.add_option("--results", results_path,
                 "search results (mocap-search JSONL); without it the search runs here");
  app.add_option("--pick", picks,
                 "PAIR:RANK: take rank RANK for pair PAIR (1-based; default rank 1)");
  app.add_option("--out", out_path, "output BVH")->required();
  app.add_option("--report", report_path, "REPORT.json");
  app.add_option("--html", html_path, "REPORT.html (self-contained)");
  bool force = false;
  app.add_flag("--force", force,
               "Replace output files that hold something else (never a folder, device or FIFO; "
               "docs/cli.md \"Output paths\")");
  app.add_option("--transition", method, "astar | slerp | inertialize")->capture_default_str();
  app.add_option("--max-states", options.params.max_states, "T_n: most frames inserted per gap")
      ->capture_default_str();
  app.add_option("--cost-threshold", options.params.cost_threshold_J,
                 "T_c: stop when the step cost to the goal is below this (J)")
      ->capture_default_str();
  mocap::add_refine_options(app, options.params);
  double fps = 0.0;
  app.add_option("--fps", fps,
                 "output frame rate of a timed query (time_s on its frames; default: the first "
                 "BVH query frame's rate, else 30)")
      ->check(CLI::Range(0.001, 1000.0))
      // NaN passes Range (every comparison with it is false): refused as
      // every other value out of range.
      ->check(CLI::Validator(
          [](std::string& text) -> std::string {
            return std::isnan(std::strtod(text.c_str(), nullptr))
                       ? "Value " + text + " not in range [0.001 - 1000]"
                       : "";
          },
          "", "not NaN"));
  bool no_step = false;
  app.add_flag("--no-step-feet", no_step,
               "no stepping pass after the A* search (feet may glide; lowest g)");
  unsigned threads = 0;
  app.add_option("--threads", threads,
                 "worker threads: the gaps are supplemented in parallel (default: all cores); "
                 "the output does not depend on it");
  app.set_version_flag("--version", std::string("mocap-synth ") + MOCAP_VERSION);
  mocap::InputLimitFlags limits;
  mocap::add_input_limit_options(app, limits);
  CLI11_PARSE(app, argc, argv);
  options.params.step_feet = !no_step;
  if (fps > 0.0) options.fps = fps;
  std::optional<tbb::global_control> parallelism;
  if (threads > 0) parallelism.emplace(tbb::global_control::max_allowed_parallelism, threads);
  const auto t0 = std::chrono::steady_clock::now();
  try {
    mocap::apply_input_limits(limits);
    static const std::map<std::string, mocap::TransitionMethod> methods = {
        {"astar", mocap::TransitionMethod::astar},
        {"slerp", mocap::TransitionMethod::slerp},
        {"inertialize", mocap::TransitionMethod::inertialize}};
    if (!methods.count(method))
      throw mocap::InputError("--transition", 0,
                              "expected astar, slerp or inertialize, got \"" + method + "\"");
    options.method = methods.at(method);
    if (options.params.max_states < 1) throw mocap::InputError("--max-states", 0, "must be >= 1");
    mocap::check_supplement_options(options.params);
    for (const auto& p : picks) options.picks.push_back(mocap::parse_pick(p));
    // Output paths first (docs/cli.md "Output paths"): nothing is computed
    // for outputs that would be refused.
    mocap::check_outputs_and_inputs(
        {{"--out", out_path}, {"--report", report_path}, {"--html", html_path}},
        {{"--index", index_path}, {"--query", query_path}, {"--results", results_path}});
    const std::filesystem::path bvh_file =
        mocap::checked_output_path(out_path, mocap::OutputKind::bvh, force, "--out");
    const std::filesystem::path report_file =
        report_path.empty()
            ? std::filesystem::path()
            : mocap::checked_output_path(report_path, mocap::OutputKind::json, force, "--report");
    const std::filesystem::path html_file =
        html_path.empty()
            ? std::filesystem::path()
            : mocap::checked_output_path(html_path, mocap::OutputKind::html, force, "--html");

    // One query, or the one of a batch that --id names (the batch reader
    // mocap-search uses).
    const mocap::Query query =
        mocap::select_query(mocap::read_query_file(query_path), query_id, query_path);
    // An index file, or a collection manifest's shards numbered as one index
    // (a missing or changed shard is an error naming it, before any work).
    const mocap::ClipSource clips = mocap::ClipSource::open(index_path);

    std::vector<mocap::PairResults> ranked;
    double search_ms = 0.0;
    if (!results_path.empty()) {
      ranked = mocap::read_search_results(results_path, query.id, clips);
    } else {
      const auto ts = std::chrono::steady_clock::now();
      mocap::QueryOutcome outcome;
      if (clips.is_collection()) {
        // The collection search (each shard in turn, merged as one index)
        // over the shards the clip source has already checked and opened.
        std::vector<mocap::ShardSource> shards;
        std::size_t offset = 0;
        for (std::size_t k = 0; k < clips.index_count(); ++k) {
          shards.push_back({"", "", std::nullopt, offset, &clips.index(k)});
          offset += clips.index(k).clips().size();
        }
        std::vector<mocap::QueryOutcome> outcomes = mocap::search_shards(
            shards, {mocap::BatchEntry{query.id, query, ""}}, mocap::SearchOptions{});
        outcome = std::move(outcomes.front());
      } else {
        const mocap::SearchEngine engine(clips.index(0));
        outcome = engine.run(query, mocap::SearchOptions{});
      }
      if (outcome.error) throw mocap::InputError(query_path, 0, "search failed: " + *outcome.error);
      ranked = std::move(outcome.pairs);
      search_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - ts).count();
    }
    std::optional<mocap::SynthSkeleton> skeleton;
    const mocap::SynthResult result = mocap::synthesize(clips, query, ranked, options, skeleton);
    mocap::write_motion_bvh(result, bvh_file);
    const double total_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    if (!report_path.empty())
      mocap::write_file_atomically(
          report_file, mocap::synth_report_json(clips, query, query_path, ranked, result, options,
                                                search_ms, total_ms, out_path));
    if (!html_path.empty()) {
      // The 3D player needs the three.js copy (player.hpp): without it the
      // report keeps its printable views and says why.
      std::optional<mocap::PlayerLibrary> player;
      std::string missing;
      try {
        player = mocap::load_player_library(mocap::player_dir());
      } catch (const mocap::InputError& e) {
        missing = e.what();
        std::cerr << "mocap-synth: warning: the report has no 3D player: " << missing << "\n";
      }
      mocap::write_file_atomically(html_file,
                                   mocap::synth_report_html(clips, query, ranked, result, options,
                                                            player ? &*player : nullptr, missing));
    }
    std::size_t inserted = 0;
    for (const auto& t : result.transitions) inserted += t.measures.frames;
    std::cout << "motion: " << std::filesystem::absolute(out_path).string() << " ("
              << result.frames.size() << " frames, " << inserted << " supplementary, "
              << result.transitions.size() << " transitions by "
              << mocap::transition_method_name(options.method) << ")\n";
    if (!report_path.empty())
      std::cout << "report: " << std::filesystem::absolute(report_path).string() << "\n";
    if (!html_path.empty())
      std::cout << "html:   " << std::filesystem::absolute(html_path).string() << "\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "mocap-synth: " << e.what() << "\n";
    return 1;
  }
}
