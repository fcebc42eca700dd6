#pragma once
// The build plan: the input files in index order, which clips of the previous
// index are reused as they are, which bad files are still bad, and whether
// the previous index is up to date as a whole (index_builder.hpp describes
// the build).
#include <tbb/task_arena.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "index_writer.hpp"
#include "mocap/common/dynamics/dynamics.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/common/util/file.hpp"
#include "mocap/indexer/collection.hpp"
#include "mocap/indexer/index_builder.hpp"

namespace mocap {

/// What an index's clips depend on besides their files: a previous index
/// built with other parameters is not reused.
struct BuildParameters {
  std::string character_json;
  std::string unit_option;
  double transition_time_s = 0.0;
  EnergyParams energy;
  bool operator==(const BuildParameters&) const = default;
};
BuildParameters build_parameters(const IndexInfo& info);

/// The previous index when its clips can be reused (else null), and the
/// summary's note on why not ("" when there is no previous index or --full).
struct PreviousIndexChoice {
  std::unique_ptr<PreviousIndex> index;
  std::string note;
};
/// `info`: the root attributes this build writes (tool and parameters).
PreviousIndexChoice choose_previous_index(const std::filesystem::path& out, const IndexInfo& info,
                                          bool full);

enum class FilePlan : std::uint8_t {
  parse,      ///< parse the file (new, changed, or never indexed)
  reuse,      ///< copy its clip from the previous index (size, mtime and XXH64 unchanged)
  still_bad,  ///< skipped again for the previous reason (size and mtime unchanged)
};

/// One input file of the build.
struct PlannedFile {
  /// Absolute, lexically normal: the path stored in the index.
  std::string path;
  /// stat(2) of the file; when it failed, stat_error holds the system's reason.
  std::optional<FileStat> stat;
  std::string stat_error;
  FilePlan plan = FilePlan::parse;
  /// The previous index's clip / skipped file of this path, if any.
  const IndexClip* old_clip = nullptr;
  const IndexSkippedFile* old_skip = nullptr;
  ClipLabels labels;
  /// An AMC take: its ASF (empty when pairing failed: asf_error says why).
  bool amc = false;
  std::filesystem::path asf;
  std::string asf_error;
};

/// The content hash of an AMC take: XXH64 of the AMC's bytes, then of the
/// ASF's bytes and of the frame time's bits, each seeded with the hash so far.
std::uint64_t amc_content_hash(std::uint64_t amc_hash, std::uint64_t asf_hash, double frame_time_s);

/// The collection's files as PlannedFiles: absolute, deduplicated, sorted by path.
std::vector<PlannedFile> list_planned_files(const Collection& collection);

/// Stats every file and resolves its labels; with a previous index, plans
/// reuse (hashing the files whose size and mtime match) and still_bad.
/// Parallel over files in `arena`.
/// AMC takes are paired with their ASF (`amc`) first; one whose pairing failed
/// is still_bad only when it failed before for the same reason.
void plan_files(std::vector<PlannedFile>& files, const PreviousIndex* previous,
                const AmcReadOptions& amc, tbb::task_arena& arena);

/// True when the previous index is what this build would write: every file
/// reused, the same missing inputs, no clip removed, and the same labels
/// (they are re-read every build: a changed sidecar changes the index).
bool is_up_to_date(const std::vector<PlannedFile>& files, const Collection& collection,
                   const Index& previous);

}  // namespace mocap
