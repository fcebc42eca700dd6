// mocap-synth: query -> target motion (docs/synthesis.md).
//   mocap-synth --index INDEX.h5|COLLECTION.json --query Q.json|Q.jsonl [--id ID]
//               [--results R.jsonl]
//               [--pick PAIR:RANK ...] --out MOTION.bvh|.glb|.npz [--report REPORT.json]
//               [--html REPORT.html]
//               [--transition astar|slerp|inertialize] [--max-states N] [--cost-threshold J]
//               [--refine N] [--refine-smoothing J] [--refine-polish S]
//               [--refine-polish-window W] [--refine-polish-segments]
//               [--refine-polish-smoothing J]
//               [--energy w|g] [--step-feet] [--threads N]
//   mocap-synth --index INDEX.h5|COLLECTION.json --queries BATCH.jsonl --out-dir DIR
//               [--results R.jsonl] [--reports] [--html-reports] [--summary PATH] [-q]
//               [the synthesis options above but --pick]
#include <tbb/global_control.h>
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <optional>

#include "mocap/common/io/motion_file.hpp"
#include "mocap/common/motion/clip_source.hpp"
#include "mocap/common/util/atomic_file.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/common/util/file.hpp"
#include "mocap/common/util/input_limits_cli.hpp"
#include "mocap/common/util/output_path.hpp"
#include "mocap/player/player.hpp"
#include "mocap/search/query.hpp"
#include "mocap/search/query_file.hpp"
#include "mocap/search/recognised_styles.hpp"
#include "mocap/search/search.hpp"
#include "mocap/synth/synth_batch.hpp"
#include "mocap/synth/synth_batch_folder.hpp"
#include "mocap/synth/synth_job.hpp"
#include "refine_options.hpp"

namespace {

// What the command line gives (add_synth_options); the job (run_synth) reads it.
struct SynthArgs {
  std::string index_path, query_path, results_path, out_path, report_path, html_path,
      method = "astar", energy = "w";
  std::vector<std::string> picks;
  mocap::SynthOptions options;
  std::string query_id;
  bool force = false;
  double fps = 0.0;
  bool step = false, no_step = false;
  bool warp = false, no_warp = false;
  unsigned threads = 0;
  mocap::InputLimitFlags limits;
  // A batch (--queries): its folder, summary and reports.
  std::string queries_path, out_dir, summary_path;
  bool reports = false, html_reports = false, quiet = false, allow_empty = false;
  std::string batch_format = "bvh";
  std::string style_model;
};

// The exit statuses of a batch (docs/cli.md "Exit status").
constexpr int kExitOk = 0;
constexpr int kExitSomeFailed = 1;
constexpr int kExitUsage = 2;

// The options of a batch (--queries), each needing it.
void add_batch_options(CLI::App& app, SynthArgs& a) {
  auto* queries =
      app.add_option("--queries", a.queries_path,
                     "a JSONL batch of queries, each synthesised to --out-dir (excludes "
                     "--query, --id, --out, --report, --html, --pick)");
  app.add_option("--out-dir", a.out_dir,
                 "with --queries: the folder of the motions (NAME.bvh per query: its id, "
                 "characters outside [A-Za-z0-9._-] as '_') and summary.jsonl")
      ->needs(queries);
  app.add_option("--format", a.batch_format,
                 "with --queries: the motions' format, bvh (default), glb (glTF binary) or npz "
                 "(NumPy arrays): NAME.bvh, NAME.glb or NAME.npz (docs/cli.md \"Motion formats\")")
      ->needs(queries);
  app.add_flag("--reports", a.reports, "with --queries: a REPORT.json per query (NAME.json)")
      ->needs(queries);
  app.add_flag("--html-reports", a.html_reports,
               "with --queries: an HTML report per query (NAME.html)")
      ->needs(queries);
  app.add_option("--summary", a.summary_path,
                 "with --queries: the summary's path (default: DIR/summary.jsonl)")
      ->needs(queries);
  app.add_flag("-q,--quiet", a.quiet, "with --queries: no progress on stderr")->needs(queries);
  app.add_flag("--allow-empty", a.allow_empty,
               "with --queries: accept a batch with no query (exit 0, an empty summary); "
               "without it an empty batch is an error (exit 2)")
      ->needs(queries);
}

// The CLI11 declaration of mocap-synth's options (in the order --help lists them).
void add_synth_options(CLI::App& app, SynthArgs& a) {
  app.add_option("--index", a.index_path,
                 "index file or collection manifest (mocap-index build [--shards N])")
      ->required();
  app.add_option("--query", a.query_path,
                 "query file: one JSON query, or a JSONL batch (pick one with --id)");
  app.add_option("--id", a.query_id,
                 "the id of the query to run in --query (required when it holds several)");
  app.add_option("--results", a.results_path,
                 "search results (mocap-search JSONL); without it the search runs here");
  app.add_option("--pick", a.picks,
                 "PAIR:RANK: take rank RANK for pair PAIR (1-based; default rank 1)");
  app.add_option("--out", a.out_path,
                 "output motion, by its extension: M.glb glTF 2.0 binary (metres, +Y up), M.npz "
                 "NumPy arrays (positions, rotations, names, parents, fps), any other name BVH");
  app.add_option("--report", a.report_path, "REPORT.json");
  app.add_option("--html", a.html_path, "REPORT.html (self-contained)");
  app.add_flag("--force", a.force,
               "Replace output files that hold something else (never a folder, device or FIFO; "
               "docs/cli.md \"Output paths\")");
  app.add_option("--transition", a.method, "astar | slerp | inertialize")->capture_default_str();
  app.add_option("--max-states", a.options.params.max_states, "T_n: most frames inserted per gap")
      ->capture_default_str();
  app.add_option("--cost-threshold", a.options.params.cost_threshold_J,
                 "T_c: stop when the step cost to the goal is below this (J)")
      ->capture_default_str();
  mocap::add_refine_options(app, a.options.params);
  app.add_option("--fps", a.fps,
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
  app.add_option("--energy", a.energy,
                 "the energy the A* search minimises: w (the work energy, default) or g (the "
                 "paper's, g_paper; docs/synthesis.md \"The search's energy\")")
      ->capture_default_str();
  auto* warp = app.add_flag("--warp", a.warp,
                            "timed key poses: play a partial motion's clip over the whole time "
                            "between them, bent onto both (the default for a timed query; with "
                            "--warp an untimed query is an error; docs/synthesis.md \"Warped "
                            "fills\")");
  app.add_flag("--no-warp", a.no_warp,
               "timed key poses: transition, resampled partial motion, transition")
      ->excludes(warp);
  app.add_option("--warp-candidates", a.options.warp_candidates,
                 "warped fills: choose among this many of each pair's ranked partial motions the "
                 "one with the smallest warp (1: the ranking's best)")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  app.add_option("--warp-work-weight", a.options.warp_work_weight_m_per_J,
                 "warped fills: the choice among candidates weighs the warp's size (m) plus this "
                 "many metres per joule of the warped fill's work energy W (0: the smallest warp "
                 "alone; docs/synthesis.md \"Warped fills\")")
      ->check(CLI::Range(0.0, 1e6))
      ->capture_default_str();
  auto* step = app.add_flag("--step-feet", a.step,
                            "the stepping pass after the A* search: no skating, at the price of "
                            "more work and faster joints (docs/synthesis.md \"Stepping\")");
  app.add_flag("--no-step-feet", a.no_step, "no stepping pass after the A* search (the default)")
      ->excludes(step);
  app.add_option("--style-model", a.style_model,
                 "a style model (mocap-index style-model): the search of a query asking for a "
                 "style (\"style\") uses it, and the report gives the recognised style of the "
                 "output and of every partial motion (\"styles\"; docs/style.md)");
  app.add_option("--style", a.options.style_transfer.style,
                 "turn the output toward this style of the --style-model model (style transfer, "
                 "docs/style.md \"Style transfer\"); a query's \"synth_style\" replaces it");
  app.add_option("--style-strength", a.options.style_transfer.strength,
                 "with --style: the multiple of the model's style offset applied (0 to 4)")
      ->capture_default_str();
  app.add_option("--threads", a.threads,
                 "worker threads: the gaps (with --queries, the queries too) are made in "
                 "parallel (default: all cores); the output does not depend on it");
  app.set_version_flag("--version", std::string("mocap-synth ") + MOCAP_VERSION);
  mocap::add_input_limit_options(app, a.limits);
  add_batch_options(app, a);
}

// --style-strength is 0 to 4; --style needs --style-model and one of its
// styles (named otherwise).
void check_style_transfer_options(const mocap::SynthOptions& o) {
  const double strength = o.style_transfer.strength;
  if (!(std::isfinite(strength) && strength >= 0.0 && strength <= 4.0))
    throw mocap::InputError("--style-strength", 0, "must be a number from 0 to 4");
  const std::string& style = o.style_transfer.style;
  if (style.empty()) return;
  if (!o.style_model)
    throw mocap::InputError("--style", 0,
                            "needs --style-model STYLE.json (a model of mocap-index style-model)");
  const std::vector<std::string>& styles = o.style_model->style.classes;
  if (std::find(styles.begin(), styles.end(), style) != styles.end()) return;
  std::string names;
  for (const std::string& s : styles) names += (names.empty() ? "" : ", ") + s;
  throw mocap::InputError("--style", 0,
                          "the style model has no style \"" + style + "\"; its styles: " + names);
}

// --transition, --max-states, the supplementation values, --pick and the
// flags, checked into a.options.
void check_synth_options(SynthArgs& a) {
  a.options.params.step_feet = a.step;
  a.options.warp_fill = !a.no_warp;
  a.options.warp_required = a.warp;
  if (a.fps > 0.0) a.options.fps = a.fps;
  static const std::map<std::string, mocap::TransitionMethod> methods = {
      {"astar", mocap::TransitionMethod::astar},
      {"slerp", mocap::TransitionMethod::slerp},
      {"inertialize", mocap::TransitionMethod::inertialize}};
  if (!methods.count(a.method))
    throw mocap::InputError("--transition", 0,
                            "expected astar, slerp or inertialize, got \"" + a.method + "\"");
  a.options.method = methods.at(a.method);
  if (a.energy != "g" && a.energy != "w")
    throw mocap::InputError("--energy", 0, "expected g or w, got \"" + a.energy + "\"");
  a.options.params.energy = a.energy == "w" ? mocap::SearchEnergy::work : mocap::SearchEnergy::g;
  if (a.options.params.max_states < 1) throw mocap::InputError("--max-states", 0, "must be >= 1");
  mocap::check_supplement_options(a.options.params);
  for (const auto& p : a.picks) a.options.picks.push_back(mocap::parse_pick(p));
  if (!a.style_model.empty())
    a.options.style_model =
        std::make_shared<const mocap::StyleModel>(mocap::read_style_model(a.style_model));
  check_style_transfer_options(a.options);
}

// The checked output files (empty: not asked for).
struct SynthOutputs {
  std::filesystem::path bvh, report, html;
};

// Output paths first (docs/cli.md "Output paths"): nothing is computed
// for outputs that would be refused.
SynthOutputs check_synth_outputs(const SynthArgs& a) {
  mocap::check_outputs_and_inputs(
      {{"--out", a.out_path}, {"--report", a.report_path}, {"--html", a.html_path}},
      {{"--index", a.index_path}, {"--query", a.query_path}, {"--results", a.results_path}});
  SynthOutputs out;
  out.bvh = mocap::checked_output_path(
      a.out_path, mocap::motion_output_kind(mocap::motion_format(a.out_path)), a.force, "--out");
  out.report =
      a.report_path.empty()
          ? std::filesystem::path()
          : mocap::checked_output_path(a.report_path, mocap::OutputKind::json, a.force, "--report");
  out.html = a.html_path.empty() ? std::filesystem::path()
                                 : mocap::checked_output_path(a.html_path, mocap::OutputKind::html,
                                                              a.force, "--html");
  return out;
}

// The search run here (no --results): the query over the index, or over a
// collection's shards; `search_ms` gets its time.
std::vector<mocap::PairResults> search_here(
    const mocap::ClipSource& clips, const mocap::Query& query, const std::string& query_path,
    const std::shared_ptr<const mocap::StyleModel>& style_model, double& search_ms) {
  const auto ts = std::chrono::steady_clock::now();
  mocap::QueryOutcome outcome;
  if (clips.is_collection()) {
    // The collection search (each shard in turn, merged as one index)
    // over the shards the clip source has already checked and opened.
    outcome = std::move(
        mocap::search_collection(clips, {mocap::BatchEntry{query.id, query, ""}}, style_model)
            .front());
  } else {
    const mocap::SearchEngine engine(clips.index(0));
    outcome = engine.run(query, mocap::synth_search_options(style_model));
  }
  if (outcome.error) throw mocap::InputError(query_path, 0, "search failed: " + *outcome.error);
  search_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - ts).count();
  return std::move(outcome.pairs);
}

// The HTML report. The 3D player needs the three.js copy (player.hpp):
// without it the report keeps its printable views and says why.
void write_synth_html(const std::filesystem::path& html_file, const mocap::ClipSource& clips,
                      const mocap::Query& query, const std::vector<mocap::PairResults>& ranked,
                      const mocap::SynthResult& result, const mocap::SynthOptions& options) {
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

// The lines naming what was written, then the feet and range notes.
void print_synth_summary(const SynthArgs& a, const mocap::SynthResult& result) {
  std::size_t inserted = 0;
  for (const auto& t : result.transitions) inserted += t.measures.frames;
  std::cout << "motion: " << std::filesystem::absolute(a.out_path).string() << " ("
            << result.frames.size() << " frames, " << inserted << " supplementary, "
            << result.transitions.size() << " transitions by "
            << mocap::transition_method_name(a.options.method) << ")\n";
  if (!a.report_path.empty())
    std::cout << "report: " << std::filesystem::absolute(a.report_path).string() << "\n";
  if (!a.html_path.empty())
    std::cout << "html:   " << std::filesystem::absolute(a.html_path).string() << "\n";
  std::cout << mocap::synth_report_text(result);
}

// The job: checks, the query and its ranked pairs (read or searched here),
// the synthesis, its files. Returns the exit code.
int run_synth(SynthArgs& a) {
  const auto t0 = std::chrono::steady_clock::now();
  try {
    mocap::apply_input_limits(a.limits);
    check_synth_options(a);
    const SynthOutputs files = check_synth_outputs(a);

    // One query, or the one of a batch that --id names (the batch reader
    // mocap-search uses).
    const mocap::Query query = mocap::query_for_fill(
        mocap::select_query(mocap::read_query_file(a.query_path), a.query_id, a.query_path),
        a.options);
    // An index file, or a collection manifest's shards numbered as one index
    // (a missing or changed shard is an error naming it, before any work).
    const mocap::ClipSource clips = mocap::ClipSource::open(a.index_path);

    std::vector<mocap::PairResults> ranked;
    double search_ms = 0.0;
    if (!a.results_path.empty())
      ranked = mocap::read_search_results(a.results_path, query.id, clips);
    else
      ranked = search_here(clips, query, a.query_path, a.options.style_model, search_ms);
    std::optional<mocap::SynthSkeleton> skeleton;
    const mocap::SynthResult result = mocap::synthesize(clips, query, ranked, a.options, skeleton);
    mocap::write_motion_file(result, files.bvh);
    const double total_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    if (!a.report_path.empty())
      mocap::write_file_atomically(
          files.report, mocap::synth_report_json(clips, query, a.query_path, ranked, result,
                                                 a.options, search_ms, total_ms, a.out_path));
    if (!a.html_path.empty()) write_synth_html(files.html, clips, query, ranked, result, a.options);
    print_synth_summary(a, result);
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "mocap-synth: " << e.what() << "\n";
    return 1;
  }
}

// --queries refuses the flags of one query, and needs --out-dir.
void check_batch_flags(const SynthArgs& a) {
  const std::pair<const char*, bool> single[] = {
      {"--query", !a.query_path.empty()}, {"--id", !a.query_id.empty()},
      {"--out", !a.out_path.empty()},     {"--report", !a.report_path.empty()},
      {"--html", !a.html_path.empty()},   {"--pick", !a.picks.empty()}};
  for (const auto& [flag, given] : single)
    if (given)
      throw mocap::InputError(
          "--queries", 0,
          std::string("excludes ") + flag + " (a batch writes each query's files to --out-dir)");
  if (a.out_dir.empty()) throw mocap::InputError("--queries", 0, "needs --out-dir DIR");
  if (a.batch_format != "bvh" && a.batch_format != "glb" && a.batch_format != "npz")
    throw mocap::InputError("--format", 0,
                            "expected bvh, glb or npz, got '" + a.batch_format + "'");
}

// "mocap-synth: N/M queries" on stderr, at most about once a second and
// once at the end (not with -q); called from worker threads.
class BatchProgress {
 public:
  BatchProgress(std::size_t total, bool quiet) : total_(total), quiet_(quiet) {}
  void tick() {
    const std::lock_guard<std::mutex> lock(mutex_);
    ++done_;
    const auto now = std::chrono::steady_clock::now();
    if (quiet_ || (done_ < total_ && now - last_ < std::chrono::seconds(1))) return;
    last_ = now;
    std::cerr << "mocap-synth: " << done_ << "/" << total_ << " queries\n";
  }

 private:
  std::mutex mutex_;
  std::size_t done_ = 0, total_;
  bool quiet_;
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

// The batch's queries, their ranked pairs (one search, or the results file
// read once), their synthesis and files; the errors in batch order. Returns
// the exit status.
int run_batch(SynthArgs& a) {
  mocap::apply_input_limits(a.limits);
  check_synth_options(a);
  check_batch_flags(a);
  std::vector<mocap::SynthBatchQuery> queries =
      mocap::synth_batch_queries(mocap::require_queries(mocap::read_query_batch(a.queries_path),
                                                        a.queries_path, a.allow_empty),
                                 a.options);
  const mocap::ClipSource clips = mocap::ClipSource::open(a.index_path);
  mocap::SynthBatchFolder folder(
      clips, a.options,
      {a.out_dir,
       a.summary_path,
       a.reports,
       a.html_reports,
       mocap::motion_format("x." + a.batch_format),
       a.force,
       a.queries_path,
       {{"--index", a.index_path}, {"--queries", a.queries_path}, {"--results", a.results_path}}});
  if (!a.results_path.empty())
    mocap::synth_batch_results_file(a.results_path, clips, queries);
  else
    mocap::search_synth_batch(clips, queries, nullptr, a.options.style_model);
  folder.name(queries);
  BatchProgress progress(queries.size(), a.quiet);
  mocap::run_synth_batch(clips, queries, a.options, [&](mocap::SynthBatchDone& done) {
    folder.write(done);
    progress.tick();
  });
  folder.finish();
  std::size_t failed = 0;
  for (std::size_t i = 0; i < queries.size(); ++i) {
    const auto& error = folder.errors()[i];
    if (!error) continue;
    ++failed;
    std::cerr << "mocap-synth: query " << queries[i].id << " (line " << queries[i].line
              << "): " << error->what() << "\n";
  }
  std::cout << "summary: " << std::filesystem::absolute(folder.summary_path()).string() << " ("
            << queries.size() - failed << " of " << queries.size() << " queries made)\n";
  return failed > 0 ? kExitSomeFailed : kExitOk;
}

// A batch that could not be done at all (usage, an unreadable batch, index
// or results file, a folder refused) exits 2.
int run_synth_batch_command(SynthArgs& a) {
  try {
    return run_batch(a);
  } catch (const std::exception& e) {
    std::cerr << "mocap-synth: " << e.what() << "\n";
    return kExitUsage;
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "mocap-synth: synthesise the target motion of a query (A* supplementation, paper 2.4)"};
  SynthArgs args;
  add_synth_options(app, args);
  CLI11_PARSE(app, argc, argv);
  if (args.queries_path.empty())
    for (const auto& [flag, value] :
         {std::pair{"--query", &args.query_path}, std::pair{"--out", &args.out_path}})
      if (value->empty()) return app.exit(CLI::RequiredError(flag));
  std::optional<tbb::global_control> parallelism;
  if (args.threads > 0)
    parallelism.emplace(tbb::global_control::max_allowed_parallelism, args.threads);
  return args.queries_path.empty() ? run_synth(args) : run_synth_batch_command(args);
}
