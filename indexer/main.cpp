// mocap-index: capture collections -> HDF5 index, and tools to look at files.
//
// Subcommands (docs/cli.md):
//   inspect FILE --frame N [--unit U] [--up A] [--character C.json] [--asf S.asf] [--amc-fps F]
//           [--json]
//   summary INPUT... [--unit U] [--up A] [--json]
//   build --out INDEX.h5 INPUT... [--jobs N] [--strict] [--unit U] [--up A] [--character C.json]
//         [--asf S.asf] [--amc-fps F] [--json]
//   convert IN --out OUT.bvh [--asf S.asf] [--amc-fps F] [--force]
//   verify INDEX.h5
//   info INDEX.h5 [--json]
// Exit status: 0 success; 1 some inputs were bad (reported, the rest done);
// 2 usage error or nothing could be done.
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <limits>
#include <map>

#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/collection_manifest.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/common/io/units.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/common/util/file.hpp"
#include "mocap/common/util/input_limits_cli.hpp"
#include "mocap/common/util/json_text.hpp"
#include "mocap/common/util/output_path.hpp"
#include "mocap/common/util/xxh64.hpp"
#include "mocap/indexer/asf_pairing.hpp"
#include "mocap/indexer/collection.hpp"
#include "mocap/indexer/index_builder.hpp"
#include "mocap/indexer/inspect.hpp"
#include "mocap/indexer/sharded_build.hpp"
#include "style_model_command.hpp"

namespace {

constexpr int kExitOk = 0;
constexpr int kExitSomeFailed = 1;
constexpr int kExitFatal = 2;

std::optional<mocap::LengthUnit> unit_option(const std::string& s) {
  if (s.empty() || s == "auto") return std::nullopt;
  auto u = mocap::parse_unit(s);
  if (!u)
    throw CLI::ValidationError("--unit",
                               "expected m, dm, cm, mm, inch, cmu or auto, got '" + s + "'");
  return u;
}

std::optional<mocap::UpAxis> up_option(const std::string& s) {
  if (s.empty() || s == "auto") return std::nullopt;
  auto a = mocap::parse_up_axis(s);
  if (!a) throw CLI::ValidationError("--up", "expected y, z or auto, got '" + s + "'");
  return a;
}

constexpr const char* kUpHelp =
    "Up axis of the files: y, z or auto (default: detected per file); a Z-up file is rotated "
    "to Y up, (x, y, z) -> (x, z, -y)";

// --asf and --amc-fps of inspect, build and convert.
struct AmcFlags {
  std::string asf;
  double fps = 120.0;
};

void add_amc_options(CLI::App& cmd, AmcFlags& flags) {
  cmd.add_option("--asf", flags.asf,
                 "ASF skeleton of the AMC files (default: paired by name, docs/asf-amc.md)");
  cmd.add_option("--amc-fps", flags.fps, "Frame rate of the AMC files (AMC has none; default 120)")
      ->check(CLI::PositiveNumber);
}

mocap::AmcReadOptions amc_options(const AmcFlags& flags) {
  mocap::AmcReadOptions o;
  if (!flags.asf.empty()) o.asf = flags.asf;
  if (!(flags.fps > 0.0) || !std::isfinite(flags.fps))
    throw CLI::ValidationError("--amc-fps", "expected a positive frame rate");
  o.frame_time_s = 1.0 / flags.fps;
  return o;
}

// convert: a BVH or AMC file -> BVH (the project's writer), under the output-path policy.
int run_convert(const std::string& in, const std::string& out, const AmcFlags& amc, bool force) {
  mocap::check_distinct_outputs({{"--out", out}, {"IN", in}});
  const std::filesystem::path target =
      mocap::checked_output_path(out, mocap::OutputKind::bvh, force, "--out");
  const mocap::CaptureFile file = mocap::read_capture_file(in, amc_options(amc));
  std::error_code ec;
  if (!target.parent_path().empty()) std::filesystem::create_directories(target.parent_path(), ec);
  mocap::write_bvh_file(file.clip, target);
  fmt::print("{}: {} frames, {} joints -> {}\n", in, file.clip.frame_count, file.clip.joints.size(),
             out);
  return kExitOk;
}

int run_inspect(const std::string& file, std::size_t frame, const std::string& unit,
                const std::string& up, const std::string& character, const AmcFlags& amc,
                bool json) {
  mocap::InspectOptions opt;
  opt.amc = amc_options(amc);
  opt.file = file;
  opt.frame = frame;
  opt.unit = unit_option(unit);
  opt.up = up_option(up);
  if (!character.empty()) opt.character = character;
  const nlohmann::json out = mocap::inspect_frame(opt);
  if (json) {
    std::cout << mocap::json_text(out) << '\n';
    return kExitOk;
  }
  fmt::print("{}  frame {} of {}  ({:.4f} s/frame, unit {} = {} m, body {:.1f} kg)\n",
             out["file"].get<std::string>(), frame, out["frames"].get<std::size_t>(),
             out["frame_time_s"].get<double>(), out["unit"].get<std::string>(),
             out["unit_scale_m"].get<double>(), out["total_mass_kg"].get<double>());
  fmt::print("{:<4} {:<20} {:>6}  {:>9} {:>9} {:>9}\n", "#", "joint", "parent", "x_m", "y_m",
             "z_m");
  int i = 0;
  for (const auto& j : out["joints"]) {
    const auto& p = j["position_m"];
    fmt::print("{:<4} {:<20} {:>6}  {:>9.4f} {:>9.4f} {:>9.4f}\n", i++,
               j["name"].get<std::string>(), j["parent"].get<int>(), p[0].get<double>(),
               p[1].get<double>(), p[2].get<double>());
  }
  fmt::print("\n{:<20} {:<13} {:<6} {:>8}\n", "segment", "class", "side", "mass_kg");
  for (const auto& s : out["segments"])
    fmt::print("{:<20} {:<13} {:<6} {:>8.3f}\n", s["joint"].get<std::string>(),
               s["class"].get<std::string>(), s["side"].get<std::string>(),
               s["mass_kg"].get<double>());
  return kExitOk;
}

int run_summary(const std::vector<std::string>& inputs, const std::string& unit,
                const std::string& up, bool json) {
  const mocap::Collection col = mocap::list_collection(inputs);
  for (const auto& p : col.problems) fmt::print(stderr, "mocap-index: {}: {}\n", p.input, p.reason);
  if (col.files.empty()) {
    fmt::print(stderr, "mocap-index: no BVH files found in the inputs\n");
    return kExitFatal;
  }
  std::vector<std::filesystem::path> files;
  files.reserve(col.files.size());
  for (const auto& e : col.files) files.push_back(e.path);
  const auto sums = mocap::summarize_files(files, unit_option(unit), up_option(up));

  std::size_t ok = 0, frames = 0, bytes = 0;
  double seconds = 0.0;
  for (const auto& s : sums) {
    if (!s.ok) continue;
    ++ok;
    frames += s.frames;
    bytes += s.bytes;
    seconds += static_cast<double>(s.frames) * s.frame_time_s;
  }
  const std::size_t failed = sums.size() - ok + col.problems.size();
  if (json) {
    nlohmann::json clips = nlohmann::json::array();
    for (const auto& s : sums) clips.push_back(mocap::to_json(s));
    nlohmann::json problems = nlohmann::json::array();
    for (const auto& p : col.problems)
      problems.push_back({{"input", p.input}, {"error", p.reason}});
    std::cout << mocap::json_text(nlohmann::json{{"clips", std::move(clips)},
                                                 {"input_problems", std::move(problems)},
                                                 {"total",
                                                  {{"clips", sums.size()},
                                                   {"ok", ok},
                                                   {"failed", failed},
                                                   {"frames", frames},
                                                   {"duration_s", seconds},
                                                   {"bytes", bytes}}}})
              << '\n';
  } else {
    fmt::print("{:<48} {:>7} {:>5} {:>8} {:>6} {:>5} {:>8} {:>8}\n", "clip", "frames", "fps", "sec",
               "joints", "unit", "height_m", "skel_m");
    for (const auto& s : sums) {
      const std::string name = std::filesystem::path(s.file).filename().string();
      if (!s.ok) {
        fmt::print("{:<48} ERROR {}\n", name, s.error);
        continue;
      }
      fmt::print("{:<48} {:>7} {:>5.0f} {:>8.2f} {:>6} {:>5} {:>8.3f} {:>8.3f}\n", name, s.frames,
                 1.0 / s.frame_time_s, static_cast<double>(s.frames) * s.frame_time_s, s.joints,
                 s.unit, s.height_m, s.skeleton_height_m);
    }
    fmt::print("\n{} clips ({} ok, {} failed), {} frames, {:.1f} s of motion, {:.1f} MB\n",
               sums.size(), ok, failed, frames, seconds, static_cast<double>(bytes) / 1e6);
  }
  return failed ? kExitSomeFailed : kExitOk;
}

// ---------------------------------------------------------------------------
// build / verify / info

std::string human_bytes(double b) {
  const char* units[] = {"B", "KB", "MB", "GB", "TB"};
  int u = 0;
  while (b >= 1000.0 && u < 4) {
    b /= 1000.0;
    ++u;
  }
  return u == 0 ? fmt::format("{:.0f} {}", b, units[u]) : fmt::format("{:.1f} {}", b, units[u]);
}

/// Progress on stderr: a redrawn bar on a terminal, a plain line every 10% otherwise.
class ProgressPrinter {
 public:
  ProgressPrinter() : tty_(::isatty(2) != 0) {}
  void operator()(const mocap::IndexBuildProgress& p) {
    if (p.files_total == 0) return;
    const double rate = p.elapsed_s > 0 ? static_cast<double>(p.frames_done) / p.elapsed_s : 0.0;
    const double frac = static_cast<double>(p.files_done) / static_cast<double>(p.files_total);
    const double eta = frac > 0 ? p.elapsed_s * (1.0 - frac) / frac : 0.0;
    if (tty_) {
      const auto now = std::chrono::steady_clock::now();
      if (p.files_done != p.files_total && p.files_done != 0 &&
          now - last_ < std::chrono::milliseconds(100))
        return;
      last_ = now;
      constexpr int kWidth = 30;
      const int filled = static_cast<int>(frac * kWidth);
      fmt::print(stderr, "\r[{}{}] {}/{} files  {} frames  {:.0f} frames/s  ETA {:.0f} s   ",
                 std::string(static_cast<std::size_t>(filled), '#'),
                 std::string(static_cast<std::size_t>(kWidth - filled), '.'), p.files_done,
                 p.files_total, p.frames_done, rate, eta);
      if (p.files_done == p.files_total) fmt::print(stderr, "\n");
    } else {
      const int decile = static_cast<int>(frac * 10.0);
      if (p.files_done != 0 && decile <= last_decile_) return;
      last_decile_ = decile;
      fmt::print(
          stderr,
          "mocap-index: {}/{} files, {} frames, {:.0f} frames/s, {:.1f} s elapsed, ETA {:.0f} s\n",
          p.files_done, p.files_total, p.frames_done, rate, p.elapsed_s, eta);
    }
  }

 private:
  bool tty_;
  int last_decile_ = -1;
  std::chrono::steady_clock::time_point last_{};
};

// The skipped files as JSON: [{"path", "reason"}].
nlohmann::json skipped_json(const std::vector<mocap::IndexSkippedFile>& skipped) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& k : skipped) out.push_back({{"path", k.path}, {"reason", k.reason}});
  return out;
}

// The summary of a sharded build: each shard's, then the collection's.
int report_sharded_build(const mocap::ShardedBuildSummary& s, bool json) {
  std::size_t clips = 0, skipped = 0;
  std::uint64_t frames = 0;
  nlohmann::json list = nlohmann::json::array();
  for (const auto& b : s.shards) {
    clips += b.clips;
    frames += b.frames;
    skipped += b.skipped.size();
    list.push_back({{"out", b.out.string()},
                    {"up_to_date", b.up_to_date},
                    {"clips", b.clips},
                    {"frames", b.frames},
                    {"new", b.parsed_new},
                    {"changed", b.parsed_changed},
                    {"reused", b.reused},
                    {"removed", b.removed},
                    {"skipped", skipped_json(b.skipped)},
                    {"seconds", b.seconds}});
  }
  if (json) {
    std::cout << mocap::json_text(nlohmann::json{{"out", s.manifest.string()},
                                                 {"clips", clips},
                                                 {"frames", frames},
                                                 {"shards", list}})
              << '\n';
  } else {
    for (const auto& b : s.shards) {
      fmt::print("{}: {}{} clips, {} frames\n", b.out.string(), b.up_to_date ? "up to date, " : "",
                 b.clips, b.frames);
      for (const auto& k : b.skipped) fmt::print("  skipped {}: {}\n", k.path, k.reason);
    }
    fmt::print("{}: {} shards, {} clips, {} frames, {} skipped\n", s.manifest.string(),
               s.shards.size(), clips, frames, skipped);
  }
  return skipped ? kExitSomeFailed : kExitOk;
}

int run_build(mocap::IndexBuildOptions opt, const std::string& unit, const std::string& up,
              const std::string& character, const AmcFlags& amc, std::size_t shards, bool json,
              bool quiet) {
  opt.amc = amc_options(amc);
  opt.unit = unit_option(unit);
  opt.up = up_option(up);
  if (!character.empty()) opt.character = character;
  opt.tool_version = std::string("mocap-index ") + MOCAP_VERSION;
  ProgressPrinter printer;
  if (!quiet) opt.progress = [&printer](const mocap::IndexBuildProgress& p) { printer(p); };
  if (shards > 0) return report_sharded_build(mocap::build_sharded(opt, shards), json);
  const mocap::IndexBuildSummary s = mocap::build_index(opt);
  const double fps = s.seconds > 0 ? static_cast<double>(s.frames) / s.seconds : 0.0;
  if (json) {
    const nlohmann::json skipped = skipped_json(s.skipped);
    std::cout << mocap::json_text(nlohmann::json{{"out", s.out.string()},
                                                 {"up_to_date", s.up_to_date},
                                                 {"clips", s.clips},
                                                 {"frames", s.frames},
                                                 {"skeletons", s.skeletons},
                                                 {"new", s.parsed_new},
                                                 {"changed", s.parsed_changed},
                                                 {"reused", s.reused},
                                                 {"removed", s.removed},
                                                 {"skipped", skipped},
                                                 {"previous_index_note", s.previous_index_note},
                                                 {"seconds", s.seconds},
                                                 {"stages",
                                                  {{"plan_s", s.stages.plan_s},
                                                   {"read_s", s.stages.read_s},
                                                   {"parse_s", s.stages.parse_s},
                                                   {"dynamics_s", s.stages.dynamics_s},
                                                   {"write_s", s.stages.write_s},
                                                   {"finalize_s", s.stages.finalize_s}}},
                                                 {"frames_per_s", fps},
                                                 {"index_bytes", s.index_bytes},
                                                 {"source_bytes", s.source_bytes}})
              << '\n';
  } else {
    if (!s.previous_index_note.empty()) fmt::print("note: {}\n", s.previous_index_note);
    fmt::print("{}: {}{} clips, {} frames, {} skeleton(s)\n", s.out.string(),
               s.up_to_date ? "up to date, " : "", s.clips, s.frames, s.skeletons);
    fmt::print("  new {}, changed {}, reused {}, removed {}, skipped {}\n", s.parsed_new,
               s.parsed_changed, s.reused, s.removed, s.skipped.size());
    for (const auto& k : s.skipped) fmt::print("  skipped {}: {}\n", k.path, k.reason);
    fmt::print("  {:.2f} s, {:.0f} frames/s, source {}, index {}\n", s.seconds, fps,
               human_bytes(static_cast<double>(s.source_bytes)),
               human_bytes(static_cast<double>(s.index_bytes)));
  }
  return s.skipped.empty() ? kExitOk : kExitSomeFailed;
}

// verify of a manifest: every shard present, unchanged and sound.
int run_verify_collection(const std::string& file, bool json) {
  const mocap::CollectionManifest m = mocap::read_collection_manifest(file);
  std::vector<std::string> problems = mocap::collection_shard_problems(file, m);
  std::size_t datasets = 0;
  if (problems.empty())
    for (const auto& sh : m.shards) {
      const mocap::IndexVerifyReport r = mocap::verify_index(mocap::shard_file(file, sh));
      datasets += r.datasets_checked;
      for (const auto& p : r.problems) problems.push_back("shard " + sh.path + ": " + p);
      if (!r.ok) continue;
      // The manifest's counts number the collection's clips: as every reader.
      const mocap::Index index = mocap::Index::open(mocap::shard_file(file, sh));
      if (std::string p = mocap::shard_count_problem(sh, index.clips().size(), index.frame_count());
          !p.empty())
        problems.push_back(std::move(p));
    }
  const bool ok = problems.empty();
  if (json) {
    std::cout << mocap::json_text(nlohmann::json{{"file", file},
                                                 {"ok", ok},
                                                 {"shards", m.shards.size()},
                                                 {"problems", problems},
                                                 {"datasets_checked", datasets}})
              << '\n';
  } else if (ok) {
    fmt::print("{}: ok ({} shards, {} datasets)\n", file, m.shards.size(), datasets);
  } else {
    for (const auto& p : problems) fmt::print(stderr, "mocap-index: {}: {}\n", file, p);
    fmt::print(stderr, "mocap-index: {}: verification FAILED ({} problem(s))\n", file,
               problems.size());
  }
  return ok ? kExitOk : kExitSomeFailed;
}

int run_verify(const std::string& file, bool json) {
  // A file that cannot be read at all is exit 2 (an InputError), not damage.
  (void)mocap::check_input_file(file, std::numeric_limits<std::uint64_t>::max());
  if (mocap::is_collection_manifest(file)) return run_verify_collection(file, json);
  const mocap::IndexVerifyReport r = mocap::verify_index(file);
  if (json) {
    std::cout << mocap::json_text(nlohmann::json{{"file", file},
                                                 {"ok", r.ok},
                                                 {"problems", r.problems},
                                                 {"datasets_checked", r.datasets_checked},
                                                 {"bytes", r.bytes}})
              << '\n';
  } else if (r.ok) {
    fmt::print("{}: ok ({} datasets, {}, schema version {})\n", file, r.datasets_checked,
               human_bytes(static_cast<double>(r.bytes)), mocap::kIndexSchemaVersion);
  } else {
    for (const auto& p : r.problems) fmt::print(stderr, "mocap-index: {}: {}\n", file, p);
    fmt::print(stderr, "mocap-index: {}: verification FAILED ({} problem(s))\n", file,
               r.problems.size());
  }
  return r.ok ? kExitOk : kExitSomeFailed;
}

// info of a manifest: its shards (a missing or changed one is an error) and totals.
int run_info_collection(const std::string& file, bool json) {
  const mocap::CollectionManifest m = mocap::read_collection_manifest(file);
  if (const auto problems = mocap::collection_shard_problems(file, m); !problems.empty())
    throw mocap::InputError(file, 0, problems.front());
  std::size_t clips = 0;
  std::uint64_t frames = 0;
  nlohmann::json list = nlohmann::json::array();
  for (const auto& sh : m.shards) {
    const mocap::Index index = mocap::Index::open(mocap::shard_file(file, sh));
    if (const std::string p =
            mocap::shard_count_problem(sh, index.clips().size(), index.frame_count());
        !p.empty())
      throw mocap::InputError(file, 0, p);
    clips += index.clips().size();
    frames += index.frame_count();
    list.push_back({{"path", sh.path},
                    {"clips", index.clips().size()},
                    {"frames", index.frame_count()},
                    {"skeletons", index.skeletons().size()},
                    {"xxh64", sh.xxh64}});
  }
  if (json) {
    std::cout << mocap::json_text(nlohmann::json{{"file", file},
                                                 {"format", mocap::kCollectionFormat},
                                                 {"version", mocap::kCollectionVersion},
                                                 {"clips", clips},
                                                 {"frames", frames},
                                                 {"shards", list}})
              << '\n';
  } else {
    fmt::print("{}: collection of {} shards, {} clips, {} frames\n", file, m.shards.size(), clips,
               frames);
    for (const auto& s : list)
      fmt::print("  {}: {} clips, {} frames\n", s["path"].get<std::string>(),
                 s["clips"].get<std::size_t>(), s["frames"].get<std::uint64_t>());
  }
  return kExitOk;
}

int run_info(const std::string& file, bool json) {
  if (mocap::is_collection_manifest(file)) return run_info_collection(file, json);
  const mocap::Index index = mocap::Index::open(file);
  const mocap::IndexInfo& in = index.info();
  std::error_code ec;
  const auto bytes = std::filesystem::file_size(file, ec);
  double seconds = 0.0;
  std::map<std::string, std::map<std::string, std::size_t>> hist;
  std::map<std::string, std::size_t> status_counts;
  for (std::size_t c = 0; c < index.clips().size(); ++c) {
    const auto& clip = index.clips()[c];
    seconds += static_cast<double>(clip.frame_count) * clip.frame_time_s;
    for (std::size_t k = 0; k < index.label_keys().size(); ++k)
      ++hist[index.label_keys()[k]][clip.labels[k].empty() ? "(none)" : clip.labels[k]];
    ++status_counts[mocap::clip_status_name(clip.status)];
  }
  nlohmann::json skel = nlohmann::json::array();
  for (std::size_t k = 0; k < index.skeletons().size(); ++k) {
    const auto& s = index.skeletons()[k];
    skel.push_back({{"index", k},
                    {"id", mocap::hex64(s.id)},
                    {"joints", s.skeleton.joint_count()},
                    {"segments", s.segments.size()},
                    {"root_joint", s.skeleton.names[static_cast<std::size_t>(s.root_joint)]},
                    {"clips", s.clips.size()},
                    {"frames", s.frame_count},
                    {"total_mass_kg", s.body.total_mass_kg}});
  }
  const nlohmann::json skipped = skipped_json(index.skipped());
  const nlohmann::json out{
      {"file", file},
      {"bytes", bytes},
      {"format", in.format},
      {"schema_version", in.schema_version},
      {"build_tool", in.build_tool},
      {"build_time_utc", in.build_time_utc},
      {"clips", index.clips().size()},
      {"frames", index.frame_count()},
      {"duration_s", seconds},
      {"skeletons", skel},
      {"labels", hist},
      {"status", status_counts},
      {"skipped", skipped},
      {"parameters",
       {{"character", nlohmann::json::parse(in.character_json, nullptr, false)},
        {"transition_time_s", in.transition_time_s},
        {"unit", in.unit_option},
        {"deflate_level", in.deflate_level},
        {"gravity_mps2", in.energy_params.gravity_mps2}}}};
  if (json) {
    std::cout << mocap::json_text(out) << '\n';
    return kExitOk;
  }
  fmt::print("{}  ({}, {} schema version {}, built {} by {})\n", file,
             human_bytes(static_cast<double>(bytes)), in.format, in.schema_version,
             in.build_time_utc, in.build_tool);
  fmt::print("{} clips, {} frames, {:.1f} s of motion, {} skeleton(s), {} skipped file(s)\n",
             index.clips().size(), index.frame_count(), seconds, index.skeletons().size(),
             index.skipped().size());
  fmt::print("character {} ({:.1f} kg), transition time {} s, unit {}, compression {}\n",
             in.character_name, in.character_total_mass_kg, in.transition_time_s, in.unit_option,
             in.deflate_level);
  for (const auto& s : skel)
    fmt::print("  skeleton {}: {} joints, {} segments, root {}, {} clips, {} frames\n",
               s["index"].get<std::size_t>(), s["joints"].get<std::size_t>(),
               s["segments"].get<std::size_t>(), s["root_joint"].get<std::string>(),
               s["clips"].get<std::size_t>(), s["frames"].get<std::uint64_t>());
  for (const auto& [key, counts] : hist) {
    fmt::print("label {}:", key);
    for (const auto& [label, n] : counts) fmt::print(" {}={}", label, n);
    fmt::print("\n");
  }
  for (const auto& k : index.skipped()) fmt::print("  skipped {}: {}\n", k.path, k.reason);
  return kExitOk;
}

// What each subcommand's command line gives (add_indexer_commands).
struct InspectArgs {
  std::string file, unit, up, character;
  std::size_t frame = 0;
  bool json = false;
  AmcFlags amc;
  mocap::InputLimitFlags limits;
};

struct SummaryArgs {
  std::vector<std::string> inputs;
  std::string unit, up;
  bool json = false;
  mocap::InputLimitFlags limits;
};

struct BuildArgs {
  mocap::IndexBuildOptions opt;
  std::string unit, up, character;
  bool json = false, quiet = false;
  AmcFlags amc;
  std::size_t shards = 0;
  mocap::InputLimitFlags limits;
};

struct ConvertArgs {
  std::string in, out;
  AmcFlags amc;
  bool force = false;
  mocap::InputLimitFlags limits;
};

// verify and info: one index file.
struct IndexFileArgs {
  std::string file;
  bool json = false;
};

struct IndexerArgs {
  InspectArgs inspect;
  SummaryArgs summary;
  BuildArgs build;
  ConvertArgs convert;
  IndexFileArgs verify, info;
  mocap::StyleModelArgs style_model;
};

// The subcommands (the one given is the one that tests true after parsing).
struct IndexerCommands {
  CLI::App *inspect, *summary, *build, *convert, *verify, *info, *style_model;
};

CLI::App* add_inspect_command(CLI::App& app, InspectArgs& a) {
  auto* inspect = app.add_subcommand(
      "inspect",
      "World-space joints and body segments of one frame of a BVH or AMC file (metres, Y up)");
  inspect->add_option("FILE", a.file, "BVH or AMC file")->required();
  inspect->add_option("--frame", a.frame, "Frame number, 0-based")->required();
  inspect->add_option("--unit", a.unit,
                      "Length unit of the file: m, dm, cm, mm, inch, cmu (0.056444 m) or auto "
                      "(default: detected from the skeleton height)");
  inspect->add_option("--up", a.up, kUpHelp);
  inspect->add_option("--character", a.character,
                      "Character JSON (docs/character.md); default 70 kg male");
  add_amc_options(*inspect, a.amc);
  inspect->add_flag("--json", a.json, "Print one JSON object (docs/cli.md)");
  return inspect;
}

CLI::App* add_summary_command(CLI::App& app, SummaryArgs& a) {
  auto* summary = app.add_subcommand(
      "summary", "Parse capture files and print one line per clip (frames, rate, unit, height)");
  summary->add_option("INPUT", a.inputs, "Folders (searched recursively), .bvh files or list files")
      ->required();
  summary->add_option("--unit", a.unit, "Length unit of the files (default: detected per file)");
  summary->add_option("--up", a.up, kUpHelp);
  summary->add_flag("--json", a.json, "Print one JSON object");
  return summary;
}

CLI::App* add_build_command(CLI::App& app, BuildArgs& a) {
  auto* build = app.add_subcommand("build",
                                   "Index capture collections into one HDF5 file "
                                   "(docs/index-format.md). When --out exists, clips whose "
                                   "size, mtime and content hash are unchanged are reused without "
                                   "parsing; the new index replaces the old "
                                   "one atomically once complete and verified. Bad files are "
                                   "reported and skipped (see --strict).");
  build
      ->add_option("INPUT", a.opt.inputs,
                   "Folders (searched recursively), .bvh or .amc files, or list files")
      ->required();
  build->add_option("--out,-o", a.opt.out, "Index file to write (HDF5)")->required();
  build->add_option("--jobs,-j", a.opt.jobs,
                    "Worker threads (default: all cores); output is identical for any value");
  build->add_flag("--strict", a.opt.strict,
                  "Fail (keeping the previous index) on the first bad file");
  build->add_option(
      "--unit", a.unit,
      "Length unit of the files: m, dm, cm, mm, inch, cmu or auto (default: detected per file)");
  build->add_option("--up", a.up, kUpHelp);
  build->add_option(
      "--character", a.character,
      "Character JSON the dynamics are computed for (docs/character.md); default 70 kg male");
  build->add_option("--transition-time", a.opt.transition_time_s,
                    "T of the kd features in seconds (default 0.5)");
  build
      ->add_option("--compress", a.opt.deflate_level,
                   "Deflate level 0-9 for the per-frame arrays (default 0: fastest; bounds are "
                   "always compressed)")
      ->check(CLI::Range(0, 9));
  build->add_flag("--full", a.opt.full, "Ignore an existing index: parse every file");
  build->add_flag("--force", a.opt.force,
                  "Replace --out even when it is a file that is not an index (never a folder, "
                  "device or FIFO; docs/cli.md \"Output paths\")");
  add_amc_options(*build, a.amc);
  build->add_flag("--json", a.json, "Print the summary as one JSON object");
  build->add_flag("--quiet,-q", a.quiet, "No progress output");
  build
      ->add_option("--shards", a.shards,
                   "Split the collection into N index files balanced by frames; --out is then "
                   "their manifest (COLLECTION.json; docs/index-format.md \"Collections\")")
      ->check(CLI::Range(std::size_t{1}, mocap::kMaxCollectionShards));
  return build;
}

CLI::App* add_convert_command(CLI::App& app, ConvertArgs& a) {
  auto* convert = app.add_subcommand(
      "convert", "Write a BVH or AMC file (with its ASF) as BVH (docs/cli.md \"convert\")");
  convert->add_option("IN", a.in, "BVH or AMC file")->required();
  convert->add_option("--out,-o", a.out, "BVH file to write")->required();
  add_amc_options(*convert, a.amc);
  convert->add_flag("--force", a.force,
                    "Replace --out even when it is a file that is not BVH (docs/cli.md \"Output "
                    "paths\")");
  return convert;
}

CLI::App* add_verify_command(CLI::App& app, IndexFileArgs& a) {
  auto* verify = app.add_subcommand("verify",
                                    "Check an index: user block and whole-file checksum "
                                    "(truncation, bit flips), format tag and schema "
                                    "version, every dataset's checksum, internal consistency. Exit "
                                    "0 when sound, 1 when damaged.");
  verify->add_option("INDEX", a.file, "Index file")->required();
  verify->add_flag("--json", a.json, "Print one JSON object");
  return verify;
}

CLI::App* add_info_command(CLI::App& app, IndexFileArgs& a) {
  auto* info = app.add_subcommand(
      "info", "Clips, frames, skeletons, label histogram and build parameters of an index");
  info->add_option("INDEX", a.file, "Index file")->required();
  info->add_flag("--json", a.json, "Print one JSON object");
  return info;
}

// The CLI11 declaration of every subcommand, in the order --help lists them.
IndexerCommands add_indexer_commands(CLI::App& app, IndexerArgs& a) {
  IndexerCommands c{};
  c.inspect = add_inspect_command(app, a.inspect);
  c.summary = add_summary_command(app, a.summary);
  c.build = add_build_command(app, a.build);
  c.convert = add_convert_command(app, a.convert);
  c.verify = add_verify_command(app, a.verify);
  c.info = add_info_command(app, a.info);
  c.style_model = mocap::add_style_model_command(app, a.style_model);
  // Input limits of the subcommands that read capture or character files.
  mocap::add_input_limit_options(*c.inspect, a.inspect.limits);
  mocap::add_input_limit_options(*c.summary, a.summary.limits);
  mocap::add_input_limit_options(*c.build, a.build.limits);
  mocap::add_input_limit_options(*c.convert, a.convert.limits);
  return c;
}

// The job: the subcommand given, run; its exit status (kExit*).
int run_indexer(const IndexerCommands& c, const IndexerArgs& a) {
  try {
    if (*c.inspect) mocap::apply_input_limits(a.inspect.limits);
    if (*c.summary) mocap::apply_input_limits(a.summary.limits);
    if (*c.build) mocap::apply_input_limits(a.build.limits);
    if (*c.convert) mocap::apply_input_limits(a.convert.limits);
    int rc = kExitFatal;
    if (*c.inspect) {
      const InspectArgs& i = a.inspect;
      rc = run_inspect(i.file, i.frame, i.unit, i.up, i.character, i.amc, i.json);
    }
    if (*c.summary)
      rc = run_summary(a.summary.inputs, a.summary.unit, a.summary.up, a.summary.json);
    if (*c.build) {
      const BuildArgs& b = a.build;
      rc = run_build(b.opt, b.unit, b.up, b.character, b.amc, b.shards, b.json, b.quiet);
    }
    if (*c.convert) rc = run_convert(a.convert.in, a.convert.out, a.convert.amc, a.convert.force);
    if (*c.verify) rc = run_verify(a.verify.file, a.verify.json);
    if (*c.info) rc = run_info(a.info.file, a.info.json);
    if (*c.style_model) rc = mocap::run_style_model(a.style_model);
    // What the command printed must have been written (a full disk, a
    // closed pipe, /dev/full): otherwise the run failed.
    std::cout.flush();
    if (!std::cout || std::fflush(stdout) != 0)
      throw mocap::InputError("<stdout>", 0, "cannot write the output");
    return rc;
  } catch (const CLI::ValidationError& e) {
    fmt::print(stderr, "mocap-index: error: {}\n", e.what());
    return kExitFatal;
  } catch (const mocap::InputError& e) {
    fmt::print(stderr, "mocap-index: error: {}\n", e.what());
    return kExitFatal;
  } catch (const std::exception& e) {
    fmt::print(stderr, "mocap-index: internal error: {}\n", e.what());
    return kExitFatal;
  }
  return kExitFatal;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "mocap-index: turn motion-capture collections into an index, and inspect BVH and AMC files"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string(MOCAP_VERSION));
  IndexerArgs args;
  const IndexerCommands commands = add_indexer_commands(app, args);
  CLI11_PARSE(app, argc, argv);
  return run_indexer(commands, args);
}
