// mocap-search: queries against an index, and energy tools.
//
//   mocap-search --index INDEX.h5 (--queries Q.jsonl | --query Q.json) [--out R.jsonl]
//                [--mode exact|approx|brute] [--threads N] [--quiet] ...
//       answers a batch of queries (docs/queries.md, docs/search.md), one JSON
//       object per query per line, in input order (stdout without --out).
//   mpirun -np K mocap-search --index COLLECTION.json ... [--distribute auto|shards|queries]
//       the same batch spread over K MPI ranks (docs/search.md "Many machines:
//       MPI"); rank 0 writes the output, identical to one process's.
//   mocap-search energy --from FILE:FRAME --to FILE:FRAME [--transition-time S]
//                [--character C.json] [--unit U] [--json]
//   mocap-search energy --motion FILE.bvh [--frames S-E] [--character C.json] [--unit U]
//                [--unsupported-speed V] [--json]
//       a whole motion's energy, summed over its steps (energy_command.hpp).
//   mocap-search export --index I (--clip NAME --frames S-E | --results R.jsonl --id Q
//                --pair P --rank K) --out X.bvh [--force]
//       writes one partial motion as BVH (export_command.hpp).
//   mocap-search style --model STYLE.json FILE.bvh[:S-E] [--index I] [--content C] [--json]
//       the recognised style of a file or frames of it (style_command.hpp, docs/style.md).
//   mocap-search view --index INDEX.h5 --results R.jsonl --out R.html [--id Q ...]
//       the 3D player of a results file (also --html on a search;
//       mocap/player/player.hpp, docs/cli.md).
// Exit status (docs/cli.md): 0 success; 1 some queries failed (their lines
// carry "error"); 2 usage error or nothing could be done (the message names
// the file or the argument). CLI11 parse errors use CLI11's own codes.
#include <fmt/format.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "export_command.hpp"
#include "mocap/common/io/collection_manifest.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/common/io/units.hpp"
#include "mocap/common/motion/clip_source.hpp"
#include "mocap/common/motion/export.hpp"
#include "mocap/common/util/atomic_file.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/common/util/input_limits_cli.hpp"
#include "mocap/common/util/output_path.hpp"
#include "mocap/player/player.hpp"
#include "mocap/search/collection_search.hpp"
#include "mocap/search/distributed.hpp"
#include "mocap/search/energy_command.hpp"
#include "mocap/search/recognised_styles.hpp"
#include "mocap/search/results_file.hpp"
#include "mocap/search/results_page.hpp"
#include "mocap/search/search.hpp"
#include "style_command.hpp"
#ifdef MOCAP_HAVE_MPI
#include "mpi_search.hpp"
#endif

#ifndef MOCAP_VERSION
#define MOCAP_VERSION "dev"
#endif

namespace {

constexpr int kExitOk = 0;
constexpr int kExitSomeFailed = 1;
constexpr int kExitFatal = 2;

struct EnergyArgs {
  std::string from;
  std::string to;
  std::string motion;
  std::string frames;
  double transition_time_s = 0.5;
  double unsupported_speed_mps = mocap::WorkEnergyParams{}.unsupported_speed_mps;
  const CLI::Option* transition_time_option = nullptr;  // its count(): given on the command line
  std::string character;
  std::string unit = "auto";
  bool json = false;
};

struct SearchArgs {
  std::string index;
  std::string queries;
  std::string query;
  std::string out;
  std::string mode = "exact";
  unsigned threads = 0;
  bool quiet = false;
  double min_length_s = mocap::SearchOptions{}.min_length_s;
  double max_length_s = mocap::SearchOptions{}.max_length_s;
  int checks = 256;
  int trees = 4;
  bool no_recall = false;
  bool force = false;
  std::string distribute = "auto";
  std::string html;
  bool allow_empty = false;
  std::string style_model;
};

struct ViewArgs {
  std::string index;
  std::string results;
  std::string out;
  std::vector<std::string> ids;
  bool force = false;
};

// The MPI session when started by an MPI launcher (one rank of several), else null.
#ifdef MOCAP_HAVE_MPI
using MpiSession = mocap::mpi::Session;
#else
struct MpiSession {
  int rank() const { return 0; }
  int size() const { return 1; }
};
#endif

void add_search_options(CLI::App& app, SearchArgs& a) {
  app.add_option("--index", a.index,
                 "Index file (HDF5, mocap-index build), or a collection manifest (mocap-index "
                 "build --shards); opened once per batch");
  auto* qs = app.add_option("--queries", a.queries,
                            "Query batch: one JSON query per line (docs/queries.md)");
  auto* q1 = app.add_option("--query", a.query, "A single query (one JSON object in a file)");
  qs->excludes(q1);
  app.add_option("--style-model", a.style_model,
                 "A style model (mocap-index style-model): every result gets the style its "
                 "partial motion is recognised as (\"recognised_style\": {label, p}; "
                 "docs/style.md)");
  app.add_flag("--allow-empty", a.allow_empty,
               "Accept a --queries batch with no query (exit 0, nothing answered); without it "
               "an empty batch is an error (exit 2)");
  app.add_option("--out", a.out,
                 "Write the results here (JSON lines) instead of stdout; replaced atomically "
                 "once every query is answered");
  app.add_option("--html", a.html,
                 "Also write the 3D player of the results here (one self-contained HTML page; "
                 "docs/cli.md \"mocap-search view\")");
  app.add_flag("--force", a.force,
               "Replace --out even when it holds something else (never a folder, device or FIFO; "
               "docs/cli.md \"Output paths\")");
  app.add_option("--mode", a.mode,
                 "exact (default: identical to brute, pruned), approx (FLANN, with recall), brute")
      ->check(CLI::IsMember({"exact", "approx", "brute"}));
  app.add_option("--threads", a.threads,
                 "Worker threads (default: all cores); results do not depend on it");
  app.add_flag("-q,--quiet", a.quiet, "No progress output on stderr");
  app.add_option("--min-length", a.min_length_s,
                 "Shortest partial motion in seconds, for queries without min_length_s "
                 "(default 0.2)")
      ->check(CLI::PositiveNumber);
  app.add_option("--max-length", a.max_length_s,
                 "Longest partial motion in seconds, for queries without max_length_s "
                 "(default 4)")
      ->check(CLI::PositiveNumber);
  app.add_option("--checks", a.checks, "approx: kd-tree leaves visited per search (default 256)")
      ->check(CLI::PositiveNumber);
  app.add_option("--trees", a.trees, "approx: randomised kd-trees per skeleton (default 4)")
      ->check(CLI::PositiveNumber);
  app.add_flag("--no-recall", a.no_recall, "approx: do not run exact to measure recall");
  app.add_option("--distribute", a.distribute,
                 "Under mpirun: spread the shards of a collection over the ranks (shards), or the "
                 "queries over ranks that each open the whole index (queries); auto (default) "
                 "takes queries when every rank of a node can hold the whole collection in half "
                 "its memory. Without an MPI launcher the search runs in this one process.")
      ->check(CLI::IsMember({"auto", "shards", "queries"}));
}

void add_energy_command(CLI::App& app, EnergyArgs& args) {
  CLI::App* cmd = app.add_subcommand("energy",
                                     "Energy change of the transition between two capture frames "
                                     "(--from, --to), or of a whole motion summed over its steps "
                                     "(--motion): the approximate h (retrieval) and the full g "
                                     "(Newton-Euler with ground contact), in joules, with "
                                     "per-segment and per-joint terms (docs/energy.md).");
  cmd->add_option("--from", args.from,
                  "First state: FILE:FRAME (BVH file, 0-based frame; with its clip velocities)");
  cmd->add_option("--to", args.to, "Second state: FILE:FRAME (same skeleton as --from)");
  cmd->add_option("--motion", args.motion,
                  "A whole motion instead: the BVH file's steps, T = its frame time, summed "
                  "(with its residual, frames without contact and peak joint speed)");
  cmd->add_option("--frames", args.frames,
                  "With --motion: only the steps of frames S-E (0-based, inclusive)");
  args.transition_time_option =
      cmd->add_option("--transition-time", args.transition_time_s,
                      "Transition time T in seconds (0.001 to 60; --from/--to only)")
          ->default_val(0.5);
  cmd->add_option("--character", args.character,
                  "Character JSON file (docs/character.md); default body otherwise");
  cmd->add_option("--unit", args.unit,
                  "Length unit of both files: m, dm, cm, mm, inch, cmu or auto (detected per file)")
      ->default_val("auto");
  cmd->add_option("--unsupported-speed", args.unsupported_speed_mps,
                  "W's price of unsupported force, m/s: joules per newton-second of support no "
                  "contact gives (docs/energy.md \"W: the work energy\")")
      ->capture_default_str();
  cmd->add_flag("--json", args.json,
                "Print one JSON object: {h_J, g_J, terms: [{name, kind, h_J, g_J}], ...}");
}

void add_view_command(CLI::App& app, ViewArgs& args) {
  CLI::App* cmd = app.add_subcommand(
      "view",
      "The 3D player of a results file: every ranked partial motion of each pair plays side by "
      "side (one self-contained HTML page; scripts/view runs it).");
  cmd->add_option("--index", args.index,
                  "The index (or collection manifest) the results were searched in")
      ->required();
  cmd->add_option("--results", args.results, "Results file (JSON lines, mocap-search --out)")
      ->required();
  cmd->add_option("--out", args.out, "The HTML page to write")->required();
  cmd->add_option("--id", args.ids, "Only these queries (default: every line with results)");
  cmd->add_flag("--force", args.force,
                "Replace --out even when it holds something else (docs/cli.md \"Output paths\")");
}

int run_view(const ViewArgs& a) {
  mocap::check_outputs_and_inputs({{"--out", a.out}},
                                  {{"--index", a.index}, {"--results", a.results}});
  const std::filesystem::path out =
      mocap::checked_output_path(a.out, mocap::OutputKind::html, a.force, "--out");
  const mocap::PlayerLibrary player = mocap::load_player_library(mocap::player_dir());
  const mocap::ClipSource clips = mocap::ClipSource::open(a.index);
  const std::vector<mocap::ResultsLine> lines = mocap::read_results_file(a.results, clips);
  mocap::write_file_atomically(out,
                               mocap::results_player_page(clips, lines, a.ids, a.results, player));
  std::cout << "html: " << std::filesystem::absolute(out).string() << "\n";
  return kExitOk;
}

// --motion given: a whole motion's energy (run_motion_energy_command).
int run_motion_energy(const EnergyArgs& args, const std::optional<mocap::LengthUnit>& unit) {
  if (!args.from.empty() || !args.to.empty())
    throw mocap::InputError("--motion", 0, "give either --motion or --from and --to, not both");
  if (args.transition_time_option && args.transition_time_option->count() > 0)
    throw mocap::InputError("--transition-time", 0,
                            "not with --motion: its steps take the file's frame time");
  mocap::MotionEnergyOptions o;
  o.file = args.motion;
  if (!args.frames.empty()) {
    const mocap::FrameRange range = mocap::parse_frame_range(args.frames, "--frames");
    o.frames = std::make_pair(range.first, range.last);
  }
  o.character = args.character;
  o.unit = unit;
  o.work.unsupported_speed_mps = args.unsupported_speed_mps;
  const mocap::MotionEnergyReport r = mocap::run_motion_energy_command(o);
  std::cout << (args.json ? mocap::motion_energy_report_json(r) + "\n"
                          : mocap::motion_energy_report_text(r));
  return kExitOk;
}

int run_energy(const EnergyArgs& args) {
  std::optional<mocap::LengthUnit> unit;
  if (args.unit != "auto") {
    unit = mocap::parse_unit(args.unit);
    if (!unit)
      throw mocap::InputError("--unit", 0,
                              "expected m, dm, cm, mm, inch, cmu or auto, got '" + args.unit + "'");
  }
  if (!args.motion.empty()) return run_motion_energy(args, unit);
  if (!args.frames.empty()) throw mocap::InputError("--frames", 0, "only with --motion FILE.bvh");
  if (args.from.empty() || args.to.empty())
    throw mocap::InputError(args.from.empty() ? "--from" : "--to", 0,
                            "required: give --from FILE:FRAME and --to FILE:FRAME, or --motion "
                            "FILE.bvh");
  mocap::EnergyCommandOptions o;
  o.from = mocap::parse_frame_spec(args.from, "--from");
  o.to = mocap::parse_frame_spec(args.to, "--to");
  o.transition_time_s = args.transition_time_s;
  o.character = args.character;
  o.unit = unit;
  o.work.unsupported_speed_mps = args.unsupported_speed_mps;
  const mocap::EnergyReport r = mocap::run_energy_command(o);
  std::cout << (args.json ? mocap::energy_report_json(r) + "\n" : mocap::energy_report_text(r));
  return kExitOk;
}

// --index and one of --queries and --query given.
void check_search_inputs(const SearchArgs& a) {
  if (a.index.empty())
    throw mocap::InputError("--index", 0, "required (an index built by mocap-index build)");
  if (a.queries.empty() == a.query.empty())
    throw mocap::InputError("--queries", 0,
                            "give exactly one of --queries Q.jsonl or --query Q.json");
}

// The search options of the command line.
mocap::SearchOptions search_options(const SearchArgs& a) {
  mocap::SearchOptions opt;
  opt.mode = *mocap::parse_search_mode(a.mode);
  opt.min_length_s = a.min_length_s;
  opt.max_length_s = a.max_length_s;
  // NaN passes CLI11's PositiveNumber: named here by its flag.
  if (!std::isfinite(opt.min_length_s))
    throw mocap::InputError("--min-length", 0, "expected a finite number of seconds > 0");
  if (!std::isfinite(opt.max_length_s))
    throw mocap::InputError("--max-length", 0, "expected a finite number of seconds > 0");
  if (opt.min_length_s > opt.max_length_s)
    throw mocap::InputError("--min-length", 0, "must not exceed --max-length");
  opt.approx_checks = a.checks;
  opt.approx_trees = a.trees;
  opt.compute_recall = !a.no_recall;
  return opt;
}

// The batch and the checked, opened outputs of a search (prepare_search).
struct SearchInputs {
  std::optional<mocap::AtomicFile> out_file;
  std::filesystem::path html_file;
  std::optional<mocap::PlayerLibrary> player;
  std::vector<mocap::BatchEntry> batch;
  std::ofstream file;
};

// Rank 0 checks the outputs (and loads the player for --html); every rank
// reads the batch; the results file is opened.
void prepare_search(const SearchArgs& a, bool rank0, SearchInputs& in) {
  if ((!a.out.empty() || !a.html.empty()) && rank0) {
    mocap::check_outputs_and_inputs(
        {{"--out", a.out}, {"--html", a.html}},
        {{"--index", a.index}, {"--queries", a.queries.empty() ? a.query : a.queries}});
    if (!a.out.empty())
      in.out_file.emplace(
          mocap::checked_output_path(a.out, mocap::OutputKind::jsonl, a.force, "--out"));
    if (!a.html.empty()) {
      in.html_file = mocap::checked_output_path(a.html, mocap::OutputKind::html, a.force, "--html");
      in.player = mocap::load_player_library(mocap::player_dir());
    }
  }
  in.batch = a.queries.empty() ? mocap::read_single_query(a.query)
                               : mocap::require_queries(mocap::read_query_batch(a.queries),
                                                        a.queries, a.allow_empty);
  if (in.out_file) {
    // Checked here, created when the results are written: a run that ends
    // before (a rank killed under MPI) leaves no empty temporary file.
    in.file.open(in.out_file->temporary_path(), std::ios::binary);
    if (!in.file) throw mocap::InputError(a.out, 0, "cannot write the results file");
    in.file.close();
    std::error_code ec;
    std::filesystem::remove(in.out_file->temporary_path(), ec);
  }
}

// One progress report on stderr: a bar on a terminal, else a line per tenth.
void print_progress(std::size_t done, std::size_t total, bool tty, std::size_t& last_line) {
  if (tty) {
    const int width = 40;
    const int filled = static_cast<int>(width * done / total);
    fmt::print(stderr, "\r[{}{}] {}/{} queries", std::string(static_cast<std::size_t>(filled), '#'),
               std::string(static_cast<std::size_t>(width - filled), '.'), done, total);
    if (done == total) fmt::print(stderr, "\n");
  } else if (done * 10 / total != last_line || done == total) {
    last_line = done * 10 / total;
    fmt::print(stderr, "mocap-search: {}/{} queries\n", done, total);
  }
}

// The result lines to --out (committed) or stdout; the errors on stderr
// unless quiet. Returns the number of failed queries.
std::size_t write_search_results(const SearchArgs& a,
                                 const std::vector<mocap::QueryOutcome>& outcomes,
                                 SearchInputs& in) {
  if (in.out_file) {
    in.file.open(in.out_file->temporary_path(), std::ios::binary);
    if (!in.file) throw mocap::InputError(a.out, 0, "cannot write the results file");
  }
  std::ostream& os = a.out.empty() ? std::cout : in.file;
  std::size_t failed = 0;
  for (const auto& o : outcomes) {
    os << mocap::query_outcome_json(o) << '\n';
    if (!a.quiet)
      for (const std::string& w : o.warnings)
        fmt::print(stderr, "mocap-search: warning: query {}: {}\n", o.id, w);
    if (o.error) {
      ++failed;
      if (!a.quiet) fmt::print(stderr, "mocap-search: {}\n", *o.error);
    }
  }
  os.flush();
  if (!os) throw mocap::InputError(a.out.empty() ? "<stdout>" : a.out, 0, "write failed");
  if (in.out_file) {
    in.file.close();
    if (!in.file) throw mocap::InputError(a.out, 0, "write failed");
    in.out_file->commit();
  }
  return failed;
}

// The 3D player of the answered queries (mocap/player/player.hpp), for --html.
void write_search_player(const SearchArgs& a, const std::vector<mocap::QueryOutcome>& outcomes,
                         const std::optional<mocap::Index>& index, const SearchInputs& in) {
  std::vector<mocap::ResultsLine> lines;
  for (const auto& o : outcomes)
    lines.push_back(
        {o.id, o.error.value_or(""), o.error ? std::vector<mocap::PairResults>{} : o.pairs});
  const mocap::ClipSource clips =
      index ? mocap::ClipSource(*index) : mocap::ClipSource::open(a.index);
  mocap::write_file_atomically(in.html_file,
                               mocap::results_player_page(clips, lines, {}, "--html", *in.player));
}

int run_search(const SearchArgs& a, const MpiSession* mpi) {
  const bool rank0 = !mpi || mpi->rank() == 0;
  check_search_inputs(a);
  std::optional<tbb::global_control> threads;
  if (a.threads > 0) threads.emplace(tbb::global_control::max_allowed_parallelism, a.threads);
  mocap::SearchOptions opt = search_options(a);
  SearchInputs in;
  // Under MPI every rank reads the batch, rank 0 alone checks and opens the
  // output; any rank's failure ends every rank (mpi_search.hpp).
  const auto prepare = [&] { prepare_search(a, rank0, in); };
#ifdef MOCAP_HAVE_MPI
  if (mpi)
    mocap::mpi::on_every_rank(*mpi, prepare);
  else
#endif
    prepare();
  std::shared_ptr<const mocap::StyleModel> style_model;
  if (!a.style_model.empty())
    style_model = std::make_shared<const mocap::StyleModel>(mocap::read_style_model(a.style_model));
  opt.style_model = style_model;
  const auto t0 = std::chrono::steady_clock::now();
  const bool collection = mocap::is_collection_manifest(a.index);
  std::optional<mocap::Index> index;
  std::optional<mocap::SearchEngine> engine;
  if (!collection && !mpi) {
    index.emplace(mocap::Index::open(a.index));
    engine.emplace(*index);
  }
  const double load_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const bool tty = isatty(fileno(stderr)) != 0;
  std::size_t last_line = 0;
  auto progress = [&](std::size_t done, std::size_t total) {
    if (a.quiet || total < 2 || !rank0) return;
    print_progress(done, total, tty, last_line);
  };
  const auto t1 = std::chrono::steady_clock::now();
  // A collection manifest: every shard answers, the top-r lists merged
  // (docs/search.md "Collections").
  std::vector<mocap::QueryOutcome> outcomes;
  std::string where = "one process";
#ifdef MOCAP_HAVE_MPI
  if (mpi) {
    const auto r = mocap::mpi::run_distributed_batch(
        *mpi, a.index, in.batch, opt,
        a.distribute == "auto" ? std::nullopt : mocap::parse_distribution(a.distribute), progress);
    outcomes = r.outcomes;
    where = fmt::format("{} ranks, distributed by {}, peak memory per rank {:.0f}-{:.0f} MB",
                        mpi->size(), mocap::distribution_name(r.distribution), r.peak_rss_min_MB,
                        r.peak_rss_max_MB);
    if (!rank0) return kExitOk;
  } else
#endif
    outcomes = collection ? mocap::run_collection_batch(a.index, in.batch, opt, progress)
                          : mocap::run_query_batch(*engine, in.batch, opt, progress);
  if (style_model)
    mocap::add_recognised_styles(
        *style_model, index ? mocap::ClipSource(*index) : mocap::ClipSource::open(a.index),
        outcomes);
  const double run_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  const std::size_t failed = write_search_results(a, outcomes, in);
  if (in.player) write_search_player(a, outcomes, index, in);
  if (!a.quiet)
    fmt::print(stderr,
               "mocap-search: {} queries ({} failed), mode {}, {}, {}answered in {:.3f} s{}\n",
               outcomes.size(), failed, a.mode, where,
               engine ? fmt::format("index loaded in {:.2f} s, ", load_s) : "", run_s,
               engine ? "" : " (shards loaded meanwhile)");
  return failed > 0 ? kExitSomeFailed : kExitOk;
}

// Everything mocap-search's command line gives (add_command_line).
struct CommandLine {
  EnergyArgs energy;
  SearchArgs search;
  mocap::ExportArgs exporting;
  mocap::StyleArgs style;
  ViewArgs view;
  CLI::App* export_command = nullptr;
  CLI::App* style_command = nullptr;
  mocap::InputLimitFlags search_limits, energy_limits, view_limits, export_limits, style_limits;
};

// The CLI11 declaration of the search options and the subcommands.
void add_command_line(CLI::App& app, CommandLine& c) {
  app.set_version_flag("--version", MOCAP_VERSION);
  app.require_subcommand(0, 1);
  add_search_options(app, c.search);
  add_energy_command(app, c.energy);
  add_view_command(app, c.view);
  c.export_command = mocap::add_export_command(app, c.exporting);
  c.style_command = mocap::add_style_command(app, c.style);
  mocap::add_input_limit_options(app, c.search_limits);
  mocap::add_input_limit_options(*c.style_command, c.style_limits);
  mocap::add_input_limit_options(*app.get_subcommand("energy"), c.energy_limits);
  mocap::add_input_limit_options(*app.get_subcommand("view"), c.view_limits);
  mocap::add_input_limit_options(*c.export_command, c.export_limits);
}

// The job: the subcommand given (else the search), its exit status; only
// rank 0 reports errors.
int run_command(const CLI::App& app, const CommandLine& c, const MpiSession* session, bool rank0) {
  try {
    if (app.got_subcommand("view")) {
      mocap::apply_input_limits(c.view_limits);
      return run_view(c.view);
    }
    if (app.got_subcommand("energy")) {
      mocap::apply_input_limits(c.energy_limits);
      return run_energy(c.energy);
    }
    if (c.export_command->parsed()) {
      mocap::apply_input_limits(c.export_limits);
      return mocap::run_export(c.exporting);
    }
    if (c.style_command->parsed()) {
      mocap::apply_input_limits(c.style_limits);
      return mocap::run_style(c.style);
    }
    mocap::apply_input_limits(c.search_limits);
    return run_search(c.search, session);
  } catch (const mocap::InputError& e) {
    if (rank0) fmt::print(stderr, "mocap-search: {}\n", e.what());
    return kExitFatal;
#ifdef MOCAP_HAVE_MPI
  } catch (const mocap::mpi::RankFailure& e) {
    if (rank0) fmt::print(stderr, "mocap-search: {}\n", e.what());
    return kExitFatal;
#endif
  } catch (const std::exception& e) {
    if (rank0) fmt::print(stderr, "mocap-search: error: {}\n", e.what());
    return kExitFatal;
  }
}

}  // namespace

int main(int argc, char** argv) {
#ifdef MOCAP_HAVE_MPI
  // Under an MPI launcher every rank runs this command line; only rank 0 speaks.
  std::optional<mocap::mpi::Session> mpi;
  if (mocap::mpi::launched_by_mpi()) mpi.emplace(&argc, &argv);
  const MpiSession* session = mpi ? &*mpi : nullptr;
#else
  const MpiSession* session = nullptr;
#endif
  const bool rank0 = !session || session->rank() == 0;
  std::ostringstream silent;
  CLI::App app{"mocap-search: retrieval of partial motions by energy change, and energy tools"};
  CommandLine command_line;
  add_command_line(app, command_line);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return rank0 ? app.exit(e) : app.exit(e, silent, silent);
  }
  return run_command(app, command_line, session, rank0);
}
