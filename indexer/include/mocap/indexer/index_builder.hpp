#pragma once
// `mocap-index build`: capture collections -> one HDF5 index (docs/index-format.md).
//
// The build is a TBB pipeline over the input files, sorted by path:
//   1. (parallel) stat, read and hash the file; reuse its clip from the
//      previous index when size, mtime and XXH64 are unchanged, else parse it
//      and compute its per-frame data (compute_clip_frame_data);
//   2. (serial, in path order) append the clip's rows to the index, or copy
//      the reused clip's rows from the previous index.
// At most 2 x jobs + 2 clips are in flight, so peak memory is bounded by the
// largest clips, not by the collection. HDF5 is touched by stage 2 only.
// Output is identical for any thread count (only the build_time_utc and
// build_tool root attributes differ between builds).
//
// Atomic: the index is written to ".NAME.tmp-PID" in the folder of `out`,
// closed, sealed (user block), re-opened and checked, fsync'ed and renamed
// over `out`. A build killed at any moment leaves the previous `out` as it
// was (and at worst a stale temporary file, removed by the next build).
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "mocap/common/body/body.hpp"
#include "mocap/common/dynamics/dynamics.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/common/io/raw_clip.hpp"
#include "mocap/common/io/units.hpp"
#include "mocap/indexer/asf_pairing.hpp"

namespace mocap {

// ---------------------------------------------------------------------------
// One clip's data (offline types)

/// A skeleton as indexed: the length-scaled runtime skeleton, the character's
/// body on it and its dynamics model.
struct IndexedSkeleton {
  Skeleton skeleton;
  Body body;
  DynamicsModel model;
  /// Per joint, the channel names in file order ("Xposition ... Yrotation").
  std::vector<std::string> channels;
  /// Joint whose origin is root_position_m: model.root(), or 0 when massless.
  int root_joint = 0;
  std::uint64_t id = 0;
};

/// All rows one clip adds to the index, frame-major, in the order of the
/// schema tables (index.hpp): frames[i] holds kFrameFields[i] for every frame
/// (frame_count x row_elements values; float64 fields in frames_f64[i]
/// instead; empty for the fields the index does not store,
/// kIndexDerivedFrameFields), clip_bounds[i] one row of
/// kClipBoundFields[i], blocks[b][i] the rows of kBlockFields[i] for block
/// size kIndexBlockSizes[b] (ceil(frame_count / size) rows).
struct ClipFrameData {
  std::size_t frame_count = 0;
  std::size_t joint_count = 0;
  std::size_t segment_count = 0;
  std::array<std::vector<float>, kFrameFieldCount> frames;
  std::array<std::vector<double>, kFrameFieldCount> frames_f64;
  std::array<std::vector<float>, kClipBoundFieldCount> clip_bounds;
  std::array<std::array<std::vector<float>, kBlockFieldCount>, kIndexBlockSizes.size()> blocks;
};

/// Builds the skeleton, body and dynamics model of a parsed clip for
/// `character` (its length scales applied), with `scale_m` metres per file unit.
IndexedSkeleton index_skeleton(const RawClip& clip, double scale_m, const Character& character,
                               const EnergyParams& params);

/// "Compute per-clip frame data": forward kinematics (stored as float32 local
/// rotations and joint positions), the dynamics of those stored rows
/// (index_frames.hpp clip_dynamics_from_rows, as a reader derives them), the
/// kd features (energy.hpp, transition time `transition_time_s` > 0) and,
/// where the schema stores them, the h scan values, the clip's own per-step
/// energy g as prefix sums (newton_euler.hpp), then the clip and block
/// bounds. This is the
/// one place that decides what a clip's rows contain: add a schema field in
/// index.hpp and fill it here. Requires clip.frame_count >= 1.
ClipFrameData compute_clip_frame_data(const RawClip& clip, const IndexedSkeleton& skel,
                                      double transition_time_s);

/// Clip and block bounds from the frame arrays, the clip's kd features `kd`
/// (frame_count x 3 S; schema 3 does not store them) and the raw rotation
/// channels (range of motion); called by compute_clip_frame_data.
/// std::invalid_argument when `kd` does not hold the clip's rows.
void compute_clip_bounds(const RawClip& clip, const IndexedSkeleton& skel,
                         std::span<const float> kd, ClipFrameData& data);

/// A character as canonical JSON (sorted keys): stored in the index and
/// compared to decide whether clips of a previous index can be reused.
std::string character_json(const Character& character);

// ---------------------------------------------------------------------------
// Labels

/// Labels of a clip: from the sidecar NAME.json next to NAME.bvh when present
/// (integer values are line numbers of cfg/<key>_label.txt, looked for in the
/// clip's folder, its parent and grandparent; the collection prefix such as
/// "dataset-1_" that also starts the clip's file name is dropped; strings are
/// taken as they are), else from a file name PREFIX_CONTENT_STYLE_TAKE
/// (Bandai Namco: content and style), else none.
struct ClipLabels {
  LabelSource source = LabelSource::none;
  /// key -> label, keys sorted.
  std::vector<std::pair<std::string, std::string>> labels;
};
ClipLabels resolve_clip_labels(const std::filesystem::path& bvh_path);

// ---------------------------------------------------------------------------
// The build

struct IndexBuildProgress {
  std::size_t files_done = 0;
  std::size_t files_total = 0;
  std::uint64_t frames_done = 0;
  std::uint64_t bytes_done = 0;
  double elapsed_s = 0.0;
  /// The file just finished.
  std::string current;
};

struct IndexBuildOptions {
  /// Folders (searched recursively), .bvh files, or list files (collection.hpp).
  std::vector<std::string> inputs;
  std::filesystem::path out;
  /// Worker threads; 0 = all cores.
  std::size_t jobs = 0;
  /// Fail (throw, previous index untouched) on the first bad file instead of skipping it.
  bool strict = false;
  /// Length unit of every file; nullopt = detect per clip (units.hpp).
  std::optional<LengthUnit> unit;
  /// Up axis of every file; nullopt = detect per clip (units.hpp). A Z-up
  /// clip is rotated to Y up before anything else.
  std::optional<UpAxis> up;
  /// Character file; nullopt = the default 70 kg male.
  std::optional<std::filesystem::path> character;
  /// T of the kd features, seconds (docs/energy.md; default 0.5).
  double transition_time_s = 0.5;
  /// AMC takes: their ASF (--asf; nullopt = the pairing rules, asf_pairing.hpp)
  /// and frame time (--amc-fps). Their unit is always the ASF's (--unit and the
  /// detection apply to BVH files); --up applies as to BVH files. A clip's
  /// content hash covers the AMC, its ASF and the frame time, so a changed ASF
  /// or --amc-fps re-parses the take on an incremental build.
  AmcReadOptions amc;
  /// 0 = no compression; 1..9 = shuffle + deflate on frame arrays.
  int deflate_level = 0;
  /// Ignore an existing index (parse everything).
  bool full = false;
  /// Replace `out` even when it is a regular file that is not an index
  /// (docs/cli.md "Output paths"; directories, devices and FIFOs are refused
  /// either way). A symbolic link at `out` is written through to its file.
  bool force = false;
  /// Written to the build_tool root attribute.
  std::string tool_version = "mocap-index";
  /// Called from the writing thread after every file (and once at the start).
  std::function<void(const IndexBuildProgress&)> progress;
};

/// Where a build's time went, in seconds. The worker stages (read, parse,
/// dynamics) are summed over worker threads, so they can exceed the wall time;
/// the others are serial sections (wall time). Zero for an up-to-date index.
struct IndexBuildStages {
  double plan_s = 0.0;      ///< collect inputs, stat, open the previous index (serial)
  double read_s = 0.0;      ///< read the files into memory (workers)
  double parse_s = 0.0;     ///< content hash, BVH parsing and unit detection (workers)
  double dynamics_s = 0.0;  ///< skeleton, per-frame dynamics, bounds, kd features (workers)
  double write_s = 0.0;     ///< the writer stage: HDF5 appends and reused-clip copies (serial)
  /// Clip tables, sealing (whole-file hash), check, fsync, rename (serial).
  double finalize_s = 0.0;
};

struct IndexBuildSummary {
  std::filesystem::path out;
  std::size_t clips = 0;
  std::uint64_t frames = 0;
  std::size_t skeletons = 0;
  std::size_t parsed_new = 0;
  std::size_t parsed_changed = 0;
  std::size_t reused = 0;
  /// Clips of the previous index whose files are gone (or now skipped).
  std::size_t removed = 0;
  std::vector<IndexSkippedFile> skipped;
  /// True when nothing changed and the existing index was kept as it is.
  bool up_to_date = false;
  /// Why clips of an existing index could not be reused ("" when they could).
  std::string previous_index_note;
  double seconds = 0.0;
  IndexBuildStages stages;
  std::uint64_t index_bytes = 0;
  std::uint64_t source_bytes = 0;
};

/// Builds (or incrementally rebuilds) the index. Throws InputError when no
/// file could be indexed, under `strict` on the first bad file, or when the
/// output cannot be written; the previous index is then untouched.
IndexBuildSummary build_index(const IndexBuildOptions& options);

}  // namespace mocap
