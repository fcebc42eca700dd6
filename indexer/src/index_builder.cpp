// build_index: the orchestration of a build (index_builder.hpp): options,
// the plan (build_plan.hpp), the TBB pipeline that parses files in parallel
// and writes them in path order (index_writer.hpp), and the atomic replace.
#include "mocap/indexer/index_builder.hpp"

#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>
#include <set>
#include <thread>

#include "build_plan.hpp"
#include "index_writer.hpp"
#include "mocap/common/io/asf_amc.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/hdf5.hpp"
#include "mocap/common/util/atomic_file.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/common/util/file.hpp"
#include "mocap/common/util/input_limits.hpp"
#include "mocap/common/util/output_path.hpp"
#include "mocap/common/util/xxh64.hpp"
#include "mocap/indexer/collection.hpp"

namespace mocap {

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

std::int64_t ns_since(Clock::time_point t) {
  return static_cast<std::int64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - t).count());
}

/// Seconds since the build started; with MOCAP_INDEX_TRACE set, phase() prints them.
class BuildClock {
 public:
  double elapsed() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }
  void phase(const char* what) const {
    if (trace_) std::fprintf(stderr, "mocap-index: %.3f s %s\n", elapsed(), what);
  }

 private:
  Clock::time_point start_ = Clock::now();
  bool trace_ = std::getenv("MOCAP_INDEX_TRACE") != nullptr;
};

/// Worker-stage times, nanoseconds summed over threads.
struct WorkerTimes {
  std::atomic<std::int64_t> read_ns{0}, parse_ns{0}, dynamics_ns{0};
};

/// What the parallel stage hands to the writer.
struct ParsedFile {
  std::size_t file = 0;
  bool ok = false;
  std::string reason;  // when !ok
  IndexClip clip;
  std::unique_ptr<IndexedSkeleton> skeleton;
  ClipFrameData data;
};

std::string failure_reason(const InputError& e) {
  return e.line() > 0 ? "line " + std::to_string(e.line()) + ": " + e.detail() : e.detail();
}

IndexSkeleton to_table(const IndexedSkeleton& s) {
  IndexSkeleton t;
  t.id = s.id;
  t.skeleton = s.skeleton;
  t.channels = s.channels;
  t.body = s.body;
  t.root_joint = s.root_joint;
  t.segments = s.model.segments;
  return t;
}

/// An AMC take and its ASF (plan_file paired them): read, hashed together
/// (amc_content_hash) and converted; `scale_m` gets the ASF's metres per unit.
RawClip read_amc_take(const PlannedFile& f, const AmcReadOptions& amc, WorkerTimes& times,
                      Clock::time_point& t, std::uint64_t& content_hash,
                      std::optional<double>& scale_m) {
  // Both under --max-bvh-mib, as every reader of a motion file (input_limits.hpp).
  const FileBytes amc_text = read_input_file(f.path, input_limits().bvh_bytes);
  const FileBytes asf_text = read_input_file(f.asf, input_limits().bvh_bytes);
  times.read_ns += ns_since(t);
  t = Clock::now();
  content_hash = amc_content_hash(xxh64(amc_text.view().data(), amc_text.size()),
                                  xxh64(asf_text.view().data(), asf_text.size()), amc.frame_time_s);
  const AsfSkeleton skeleton = parse_asf(asf_text.view(), f.asf.string());
  const AmcMotion motion = parse_amc(amc_text.view(), f.path, skeleton);
  scale_m = skeleton.metres_per_unit();
  return asf_amc_to_raw_clip(skeleton, motion, amc.frame_time_s);
}

/// The parallel stage: read, hash, parse and compute the rows of a file to parse.
void parse_file(const PlannedFile& f, const IndexBuildOptions& opt, const Character& character,
                const EnergyParams& energy, WorkerTimes& times, ParsedFile& w) {
  if (!f.stat) {
    w.reason = "cannot stat: " + f.stat_error;
    return;
  }
  if (f.stat->size == 0) {
    w.reason = "empty file";
    return;
  }
  if (f.amc && f.asf.empty()) {
    w.reason = f.asf_error;
    return;
  }
  auto t = Clock::now();
  try {
    IndexClip& c = w.clip;
    RawClip raw;
    std::optional<double> asf_scale_m;
    if (f.amc) {
      raw = read_amc_take(f, opt.amc, times, t, c.content_hash, asf_scale_m);
    } else {
      const FileBytes text = read_input_file(f.path, input_limits().bvh_bytes);
      times.read_ns += ns_since(t);
      t = Clock::now();
      c.content_hash = xxh64(text.view().data(), text.size());
      raw = parse_bvh(text.view(), f.path);
    }
    if (raw.frame_count == 0) throw InputError(f.path, 0, "the clip has no frames");
    normalise_up_axis(raw, opt.up);
    const LengthUnit unit = opt.unit ? *opt.unit : detect_unit(raw);
    times.parse_ns += ns_since(t);
    t = Clock::now();
    c.unit = asf_scale_m ? kAsfUnitName : unit_name(unit);
    c.unit_scale_m = asf_scale_m ? *asf_scale_m : unit_scale_m(unit);
    c.frame_time_s = raw.frame_time_s;
    w.skeleton =
        std::make_unique<IndexedSkeleton>(index_skeleton(raw, c.unit_scale_m, character, energy));
    w.data = compute_clip_frame_data(raw, *w.skeleton, opt.transition_time_s);
    times.dynamics_ns += ns_since(t);
    w.ok = true;
  } catch (const InputError& e) {  // a bad file; a bug is not caught here
    w.reason = failure_reason(e);
  }
}

/// The serial stage's state: the clips and skipped files so far, in path order.
struct WriteStage {
  IndexWriter& writer;
  PreviousIndex* previous;
  const IndexBuildOptions& opt;
  const BuildClock& clock;
  IndexBuildSummary& sum;
  std::vector<IndexClip> clips;
  std::vector<ClipLabels> clip_labels;
  std::vector<IndexSkippedFile> skipped;
  IndexBuildProgress progress;
  /// The temporary index's early writeback (null: none).
  EarlyWriteback* writeback = nullptr;

  /// Writes one file's outcome (caller holds the HDF5 library lock). Throws
  /// under --strict for a bad file, and on HDF5 errors.
  void write(const PlannedFile& f, ParsedFile& w) {
    const FileStat stat = f.stat.value_or(FileStat{});
    if (f.plan == FilePlan::reuse) {
      IndexClip c = *f.old_clip;
      c.skeleton = writer.slot_for(previous->index().skeletons()[f.old_clip->skeleton]);
      c.status = ClipStatus::reused;
      c.label_source = f.labels.source;
      writer.copy(c, clips.size(), *previous, *f.old_clip);
      add_clip(std::move(c), f.labels);
      ++sum.reused;
    } else if (f.plan == FilePlan::still_bad) {
      if (opt.strict) throw InputError(f.path, 0, f.old_skip->reason);
      skipped.push_back({f.path, f.old_skip->reason, stat.size, stat.mtime_ns});
    } else if (!w.ok) {
      if (opt.strict) throw InputError(f.path, 0, w.reason);
      skipped.push_back({f.path, w.reason, stat.size, stat.mtime_ns});
    } else {
      IndexClip& c = w.clip;
      c.path = f.path;
      c.size_bytes = stat.size;
      c.mtime_ns = stat.mtime_ns;
      c.status = f.old_clip ? ClipStatus::parsed_changed : ClipStatus::parsed_new;
      c.label_source = f.labels.source;
      c.skeleton = writer.slot_for(to_table(*w.skeleton));
      writer.append(c, clips.size(), w.data);
      (f.old_clip ? sum.parsed_changed : sum.parsed_new) += 1;
      add_clip(std::move(c), f.labels);
    }
    ++progress.files_done;
    if (!clips.empty() && clips.back().path == f.path) {
      progress.frames_done += clips.back().frame_count;
      progress.bytes_done += clips.back().size_bytes;
    }
    progress.elapsed_s = clock.elapsed();
    progress.current = f.path;
    if (opt.progress) opt.progress(progress);
    if (writeback != nullptr) writeback->kick();
  }

  void add_clip(IndexClip clip, const ClipLabels& labels) {
    clips.push_back(std::move(clip));
    clip_labels.push_back(labels);
  }
};

/// The pipeline over `files`: parse_file in parallel (at most 2 x jobs + 2
/// files in flight), WriteStage::write in path order. The first error of the
/// writing stage is rethrown once the pipeline has drained.
void run_pipeline(std::vector<PlannedFile>& files, std::size_t jobs, tbb::task_arena& arena,
                  const Character& character, const EnergyParams& energy, WriteStage& stage,
                  WorkerTimes& times, std::int64_t& write_ns) {
  std::size_t next = 0;
  std::exception_ptr writer_failure;
  std::atomic<bool> writer_failed{false};
  arena.execute([&] {
    tbb::parallel_pipeline(
        2 * jobs + 2,
        tbb::make_filter<void, std::size_t>(tbb::filter_mode::serial_in_order,
                                            [&](tbb::flow_control& fc) -> std::size_t {
                                              if (writer_failed.load() || next >= files.size()) {
                                                fc.stop();
                                                return 0;
                                              }
                                              return next++;
                                            }) &
            tbb::make_filter<std::size_t, std::shared_ptr<ParsedFile>>(
                tbb::filter_mode::parallel,
                [&](std::size_t i) {
                  auto w = std::make_shared<ParsedFile>();
                  w->file = i;
                  if (files[i].plan == FilePlan::parse)
                    parse_file(files[i], stage.opt, character, energy, times, *w);
                  return w;
                }) &
            tbb::make_filter<std::shared_ptr<ParsedFile>, void>(
                tbb::filter_mode::serial_in_order, [&](std::shared_ptr<ParsedFile> w) {
                  // After a failure the remaining items only drain: an
                  // exception thrown out of a filter would cancel the pipeline
                  // and leak the items in flight (oneTBB does not destroy them).
                  if (writer_failure) return;
                  const auto t_write = Clock::now();
                  try {
                    std::lock_guard lib(h5::library_mutex());
                    stage.write(files[w->file], *w);
                  } catch (...) {
                    writer_failure = std::current_exception();
                    writer_failed.store(true);
                  }
                  write_ns += ns_since(t_write);
                }));
  });
  if (writer_failure) std::rethrow_exception(writer_failure);
}

/// Label keys: the union over clips, sorted; fills every clip's labels parallel to them.
std::vector<std::string> assign_labels(std::vector<IndexClip>& clips,
                                       const std::vector<ClipLabels>& clip_labels) {
  std::set<std::string> key_set;
  for (const auto& l : clip_labels)
    for (const auto& kv : l.labels) key_set.insert(kv.first);
  const std::vector<std::string> keys(key_set.begin(), key_set.end());
  for (std::size_t c = 0; c < clips.size(); ++c) {
    clips[c].labels.assign(keys.size(), std::string());
    for (const auto& [k, v] : clip_labels[c].labels)
      clips[c].labels[static_cast<std::size_t>(std::lower_bound(keys.begin(), keys.end(), k) -
                                               keys.begin())] = v;
  }
  return keys;
}

/// The root attributes this build writes, less the build time and counts.
IndexInfo build_info(const IndexBuildOptions& opt, const Character& character,
                     const EnergyParams& energy) {
  IndexInfo info;
  info.build_tool = opt.tool_version;
  info.character_json = character_json(character);
  info.character_name = character.name;
  info.character_total_mass_kg = character.total_mass_kg;
  info.transition_time_s = opt.transition_time_s;
  info.unit_option = opt.unit ? unit_name(*opt.unit) : "auto";
  info.deflate_level = opt.deflate_level;
  info.energy_params = energy;
  return info;
}

void check_options(const IndexBuildOptions& opt) {
  if (opt.out.empty()) throw InputError("<build>", 0, "no output file given");
  if (!(opt.transition_time_s > 0.0))
    throw InputError("<build>", 0, "transition time must be positive");
  if (opt.deflate_level < 0 || opt.deflate_level > 9)
    throw InputError("<build>", 0, "compression level must be 0..9");
  if (!(opt.amc.frame_time_s > 0.0) || !std::isfinite(opt.amc.frame_time_s))
    throw InputError("<build>", 0, "the AMC frame rate must be positive and finite");
}

/// The summary of a build that kept the previous index as it is.
void summarize_up_to_date(const Index& old, const fs::path& out, IndexBuildSummary& sum) {
  sum.up_to_date = true;
  sum.clips = old.clips().size();
  sum.frames = old.frame_count();
  sum.skeletons = old.skeletons().size();
  sum.reused = sum.clips;
  sum.skipped = old.skipped();
  for (const auto& c : old.clips()) sum.source_bytes += c.size_bytes;
  std::error_code ec;
  sum.index_bytes = fs::file_size(out, ec);
}

}  // namespace

IndexBuildSummary build_index(const IndexBuildOptions& opt) {
  const BuildClock clock;
  check_options(opt);
  const fs::path out =
      fs::absolute(checked_output_path(opt.out, OutputKind::index, opt.force, "--out"))
          .lexically_normal();
  // One build per index at a time: a second one fails here, before any work.
  std::error_code folder_ec;
  fs::create_directories(out.parent_path(), folder_ec);
  const OutputLock lock(out);
  const std::size_t jobs = opt.jobs ? opt.jobs : std::max(1u, std::thread::hardware_concurrency());
  const Character character = opt.character ? read_character_file(*opt.character) : Character{};
  const EnergyParams energy{};
  const IndexInfo info = build_info(opt, character, energy);

  const Collection col = list_collection(opt.inputs);
  std::vector<PlannedFile> files = list_planned_files(col);
  if (opt.strict && !col.problems.empty())
    throw InputError(col.problems.front().input, 0, col.problems.front().reason);
  {
    // The index never replaces a file the build reads, even with --force.
    std::vector<std::pair<std::string, fs::path>> inputs;
    for (const CollectionEntry& e : col.files) inputs.emplace_back("an input", e.path);
    if (opt.character) inputs.emplace_back("--character", *opt.character);
    check_outputs_and_inputs({{"--out", out}}, inputs);
  }

  IndexBuildSummary sum;
  sum.out = out;
  PreviousIndexChoice previous = choose_previous_index(out, info, opt.full);
  sum.previous_index_note = previous.note;
  std::unique_ptr<PreviousIndex>& prev = previous.index;
  // More threads than cores only adds contention (and a TBB warning).
  const std::size_t hw = std::max(1u, std::thread::hardware_concurrency());
  tbb::task_arena arena(static_cast<int>(std::min(jobs, hw)));
  plan_files(files, prev.get(), opt.amc, arena);
  clock.phase("planned");
  const double planned_at = clock.elapsed();
  if (prev && is_up_to_date(files, col, prev->index())) {
    // The index is kept; a killed build's ".NAME.tmp-PID" is still removed
    // (AtomicFile does it when the index is rewritten).
    remove_stale_temporaries(out);
    summarize_up_to_date(prev->index(), out, sum);
    sum.seconds = clock.elapsed();
    return sum;
  }

  AtomicFile target(out);
  std::unique_ptr<IndexWriter> writer;
  {
    std::lock_guard lib(h5::library_mutex());
    writer = std::make_unique<IndexWriter>(target.temporary_path(), opt.deflate_level);
  }
  // The disk writes the index while the pipeline computes: the final fsync
  // then finds little left (docs/performance.md "Storing less").
  EarlyWriteback writeback(target.temporary_path());
  WriteStage stage{*writer, prev.get(), opt, clock, sum, {}, {}, {}, {}, &writeback};
  for (const auto& p : col.problems) stage.skipped.push_back({p.input, p.reason, 0, 0});
  stage.progress.files_total = files.size();
  if (opt.progress) opt.progress(stage.progress);
  WorkerTimes times;
  std::int64_t write_ns = 0;
  run_pipeline(files, jobs, arena, character, energy, stage, times, write_ns);

  clock.phase("pipeline done");
  const double pipeline_done_at = clock.elapsed();
  sum.stages.plan_s = planned_at;
  sum.stages.read_s = 1e-9 * static_cast<double>(times.read_ns.load());
  sum.stages.parse_s = 1e-9 * static_cast<double>(times.parse_ns.load());
  sum.stages.dynamics_s = 1e-9 * static_cast<double>(times.dynamics_ns.load());
  sum.stages.write_s = 1e-9 * static_cast<double>(write_ns);
  std::vector<IndexClip>& clips = stage.clips;
  if (clips.empty()) {
    std::string why = "no clip could be indexed";
    if (!stage.skipped.empty())
      why += " (first problem: " + stage.skipped.front().path + ": " +
             stage.skipped.front().reason + ")";
    throw InputError(opt.inputs.empty() ? "<build>" : opt.inputs.front(), 0, why);
  }
  const std::vector<std::string> keys = assign_labels(clips, stage.clip_labels);
  {
    std::lock_guard lib(h5::library_mutex());
    sum.skeletons = writer->skeleton_count();
    writer->finish(clips, keys, stage.skipped, info);
    writer.reset();
  }
  std::set<std::string> now;
  for (const auto& c : clips) now.insert(c.path);
  if (prev)
    for (const auto& c : prev->index().clips())
      if (!now.count(c.path)) ++sum.removed;
  prev.reset();  // closes the previous index before it is replaced (takes the library lock itself)
  clock.phase("written");
  seal_index_file(target.temporary_path());
  clock.phase("sealed");
  // Checked before it replaces anything: user block, tag, version, tables.
  // (The whole-file hash was just computed from the file by seal_index_file.)
  Index::open(target.temporary_path());
  clock.phase("checked");
  target.commit();
  clock.phase("synced");

  sum.clips = clips.size();
  for (const auto& c : clips) {
    sum.frames += c.frame_count;
    sum.source_bytes += c.size_bytes;
  }
  sum.skipped = std::move(stage.skipped);
  std::error_code ec;
  sum.index_bytes = fs::file_size(out, ec);
  sum.seconds = clock.elapsed();
  sum.stages.finalize_s = sum.seconds - pipeline_done_at;
  return sum;
}

}  // namespace mocap
