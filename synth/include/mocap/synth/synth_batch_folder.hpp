#pragma once
// The files of a batch synthesis in one folder (mocap-synth --queries
// --out-dir DIR; docs/cli.md "mocap-synth"): per query DIR/NAME.bvh (or
// .glb, .npz: --format, docs/cli.md "Motion formats"), and
// with reports DIR/NAME.json and DIR/NAME.html; at the end the summary,
// one JSON line per query in batch order.
//
// Every file follows the output-path policy (mocap/common/util/output_path.hpp:
// a file of another kind is replaced only with `force`; a folder, a device,
// a file the command reads never) and is written atomically. A query whose
// name is taken or whose path is refused fails alone; the folder and the
// summary path are checked before any work.
//
// Summary line (keys in this order):
//   {"id", "line", "bvh" (BVH batches), "motion" (the motion file, any
//    format), "report" (with reports), "html" (with HTML
//    reports), "frames", "duration_s" ((frames - 1) x frame time, seconds),
//    "measures": {"w_J", "unsupported_J", "no_contact_ratio",
//    "peak_angular_speed_radps" (the whole motion as one transition,
//    SynthResult::whole_measures), "foot_skating_ratio"
//    (SynthResult::motion_measures)}, "time_ms" (the query's synthesis and
//    its files, milliseconds)}
// or, for a query that failed, {"id", "line", "error"} (the InputError's
// text: source:line: what).
#include <cstddef>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "mocap/common/io/motion_file.hpp"
#include "mocap/common/motion/clip_source.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/synth/synth_batch.hpp"
#include "mocap/synth/synth_job.hpp"

namespace mocap {

struct PlayerLibrary;  // mocap/player/player.hpp

/// The name of a query's files (without extension): `id` with every byte
/// outside [A-Za-z0-9._-] replaced by '_'; "query-LINE" when that leaves
/// an empty name, "." or "..".
std::string synth_batch_file_name(const std::string& id, std::size_t line);

struct SynthBatchFolderOptions {
  /// The folder (--out-dir): created with its parents when missing.
  std::filesystem::path dir;
  /// The summary (--summary); empty: DIR/summary.jsonl.
  std::filesystem::path summary;
  /// Write DIR/NAME.json (synth_report_json) and DIR/NAME.html
  /// (synth_report_html, with the 3D player when its three.js copy is found).
  bool reports = false;
  bool html_reports = false;
  /// The motions' format (--format): NAME.bvh, NAME.glb or NAME.npz.
  MotionFormat format = MotionFormat::bvh;
  /// Replace files of another kind (output_path.hpp).
  bool force = false;
  /// The batch file, as the reports' query.file names it.
  std::string batch_path;
  /// The files the command reads, (option, path): no output may be one of
  /// them (check_outputs_and_inputs).
  std::vector<std::pair<std::string, std::filesystem::path>> inputs;
};

/// One batch's folder. Construct, name() the queries, then write() each
/// query as run_synth_batch hands it over (from any thread), then finish().
class SynthBatchFolder {
 public:
  /// Checks the folder and the summary path, before any work: InputError
  /// ("--out-dir") when DIR is not a folder (a file, a device) or cannot be
  /// created; InputError ("--summary") for a summary path the policy
  /// refuses. With html_reports, loads the 3D player once (a warning on
  /// stderr when it is missing; the reports then say why).
  SynthBatchFolder(const ClipSource& clips, const SynthOptions& options,
                   SynthBatchFolderOptions folder);
  ~SynthBatchFolder();
  SynthBatchFolder(const SynthBatchFolder&) = delete;
  SynthBatchFolder& operator=(const SynthBatchFolder&) = delete;

  /// Gives each query that has not failed its name (in batch order) and
  /// checks its outputs: a name an earlier query took, or an output path
  /// the policy refuses, becomes the query's error. Call once, before the
  /// run.
  void name(std::vector<SynthBatchQuery>& queries);

  /// Writes one query's files and keeps its summary line. A file that cannot
  /// be written fails the query. Thread-safe for distinct queries.
  void write(const SynthBatchDone& done);

  /// Writes the summary (atomically; InputError when it cannot be written).
  void finish();

  const std::filesystem::path& summary_path() const { return summary_; }
  /// Per query of the batch, its error (unset: made); complete after the run.
  const std::vector<std::optional<InputError>>& errors() const { return errors_; }

 private:
  struct QueryFiles {
    std::filesystem::path bvh, report, html;              // as named (DIR/NAME.*)
    std::filesystem::path bvh_out, report_out, html_out;  // checked (links followed)
  };
  void check_query_files(QueryFiles& files) const;
  std::string made_line(const SynthBatchDone& done, const QueryFiles& files, double time_ms) const;

  const ClipSource& clips_;
  const SynthOptions& options_;
  SynthBatchFolderOptions folder_;
  std::filesystem::path summary_;
  std::unique_ptr<PlayerLibrary> player_;  // null: missing (player_missing_)
  std::string player_missing_;
  std::vector<QueryFiles> files_;
  std::vector<std::string> lines_;
  std::vector<std::optional<InputError>> errors_;
  std::mutex mutex_;
};

}  // namespace mocap
