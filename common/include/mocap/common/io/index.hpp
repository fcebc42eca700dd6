#pragma once
// The HDF5 index: schema (shared by writer and reader) and the runtime reader.
//
// Written by `mocap-index build` (indexer/, offline), read by search and synth
// through `Index` (immutable; metadata loaded at open, per-frame arrays
// loaded once per dataset on first use). The full schema, with every group,
// dataset, dtype, shape, unit, chunking and the version policy, is
// docs/index-format.md; this header is its code form, with the record tables
// and root attributes in mocap/common/io/index_tables.hpp.
//
// Layout in short (C clips sorted by path, S skeletons, per skeleton k:
// N_k frames, J_k joints, C_k clips, B16_k / B64_k blocks):
//   /                      attributes: format "mocap-index", schema_version,
//                          units, build tool and time, character, parameters
//   /clips/*               one row per clip (path, size, mtime, hash, skeleton,
//                          frame range, frame time, labels, status)
//   /skeletons/<k>/*       skeleton table (names, parents, offsets, channels,
//                          segment classes, masses, COMs, inertias)
//   /skeletons/<k>/frames/*       [N_k, ...] per-frame arrays, float32
//   /skeletons/<k>/blocks16/*     [B16_k, ...] bounds per 16-frame block
//   /skeletons/<k>/blocks64/*     [B64_k, ...] bounds per 64-frame block
//   /skeletons/<k>/clip_bounds/*  [C_k, ...] bounds per clip
//   /skipped/*             files that were not indexed: path, reason, size, mtime
// A clip's frames are rows [frame_start, frame_start + frame_count) of its
// skeleton's frame arrays; its blocks start at block16_start / block64_start
// (block b covers frames [16 b, 16 b + 16) of the clip, the last one fewer);
// its clip_bounds row is `row`.
//
// Integrity: a 512-byte user block in front of the HDF5 data holds the file
// length and the XXH64 of everything after it (so truncation and bit flips are
// caught before HDF5 reads anything), and every dataset carries the XXH64 of
// its values in attribute `checksum_xxh64`.
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "mocap/common/body/body.hpp"
#include "mocap/common/body/skeleton.hpp"
#include "mocap/common/dynamics/dynamics.hpp"

namespace mocap {

// ---------------------------------------------------------------------------
// Schema

inline constexpr const char* kIndexFormat = "mocap-index";
/// Bumped on any change a reader of the previous version would misread.
/// 2: world rotations, segment COMs and rates are no longer stored;
/// 3: nor h_scan and kd_features (kIndexDerivedFrameFields).
inline constexpr std::int64_t kIndexSchemaVersion = 3;
/// The oldest schema this build reads (docs/index-format.md "Versions").
inline constexpr std::int64_t kIndexOldestSchemaVersion = 1;
/// Size of the user block in front of the HDF5 data.
inline constexpr std::size_t kIndexUserBlockBytes = 512;
/// Frames per block for the per-block bounds.
inline constexpr std::array<std::size_t, 2> kIndexBlockSizes = {16, 64};

enum class IndexDType : std::uint8_t { f32, f64 };

/// Shape of one row of an array, given the skeleton's joint count J and
/// segment count S (joints with mass, DynamicsModel::segments).
enum class RowShape : std::uint8_t {
  scalar,     // []
  vec3,       // [3]
  joints3,    // [J, 3]
  joints4,    // [J, 4]
  segments3,  // [S, 3]
  segments9,  // [S, 9]
};
std::size_t row_elements(RowShape s, std::size_t joints, std::size_t segments);
/// Dimensions after the row dimension.
std::vector<std::size_t> row_dims(RowShape s, std::size_t joints, std::size_t segments);

struct IndexFieldSpec {
  const char* name;
  IndexDType dtype;
  RowShape shape;
  /// SI unit string stored in the dataset's `unit` attribute ("m", "m/s", "1").
  const char* unit;
  const char* description;
};

/// /skeletons/<k>/frames/*: one row per frame. World frame, Y up. Rates are
/// DynamicsModel finite differences (dynamics.hpp: central, one-sided at a
/// clip's ends, zero for a 1-frame clip). Not stored because they follow
/// exactly from what is: a joint's local translation R_parent^T (x_j -
/// x_parent); accelerations (c_{f+1} - 2 c_f + c_{f-1}) / dt^2 and the same
/// for rotations (compute_clip_dynamics on a clip's rows).
inline constexpr IndexFieldSpec kFrameFields[] = {
    {"root_position_m", IndexDType::f32, RowShape::vec3, "m",
     "world position of the root joint (the pelvis: skeleton attribute root_joint)"},
    {"local_rotations", IndexDType::f32, RowShape::joints4, "1",
     "joint rotation relative to its parent, unit quaternion (w, x, y, z), w >= 0"},
    {"world_rotations", IndexDType::f32, RowShape::joints4, "1",
     "joint frame in world (world from joint), unit quaternion (w, x, y, z), w >= 0"},
    {"joint_positions_m", IndexDType::f32, RowShape::joints3, "m", "joint origin in world"},
    {"segment_com_m", IndexDType::f32, RowShape::joints3, "m",
     "centre of mass of the joint's segment in world, x_j + R_j c_j (the joint origin for massless "
     "joints)"},
    {"segment_com_velocity_mps", IndexDType::f32, RowShape::joints3, "m/s", "segment COM velocity"},
    {"segment_angular_velocity_radps", IndexDType::f32, RowShape::joints3, "rad/s",
     "angular velocity of the joint frame, world vector"},
    {"h_scan", IndexDType::f32, RowShape::segments9, "mixed",
     "per segment (skeleton dataset segments) the 9 values of energy.hpp HScanTable: COM x y z "
     "(m), "
     "1/2 m |v|^2 (J), orientation in principal axes q = R P (w x y z), 1/2 w^T I w (J)"},
    {"kd_features", IndexDType::f32, RowShape::segments3, "sqrt(J)",
     "energy.hpp kd_feature: sqrt(m_b / 2) / T * c_b per segment, T = root attribute "
     "transition_time_s; "
     "squared distances lower-bound h for static queries"},
    {"energy_prefix_J", IndexDType::f64, RowShape::scalar, "J",
     "the clip's own per-step full energy g(F^i -> F^i+1) (newton_euler.hpp clip_step_energies, T "
     "= frame time) "
     "as prefix sums restarting at 0 on each clip's first frame: cost of F^s..F^e = P[e] - P[s]"},
};
inline constexpr std::size_t kFrameFieldCount = sizeof(kFrameFields) / sizeof(kFrameFields[0]);

/// /skeletons/<k>/blocks16/* and blocks64/*: one row per block of frames.
inline constexpr IndexFieldSpec kBlockFields[] = {
    {"root_min_m", IndexDType::f32, RowShape::vec3, "m",
     "per-axis minimum of root_position_m over the block"},
    {"root_max_m", IndexDType::f32, RowShape::vec3, "m",
     "per-axis maximum of root_position_m over the block"},
    {"kd_min", IndexDType::f32, RowShape::segments3, "sqrt(J)",
     "per-element minimum of kd_features over the block"},
    {"kd_max", IndexDType::f32, RowShape::segments3, "sqrt(J)",
     "per-element maximum of kd_features over the block"},
};
inline constexpr std::size_t kBlockFieldCount = sizeof(kBlockFields) / sizeof(kBlockFields[0]);

/// /skeletons/<k>/clip_bounds/*: one row per clip of the skeleton.
inline constexpr IndexFieldSpec kClipBoundFields[] = {
    {"root_min_m", IndexDType::f32, RowShape::vec3, "m",
     "root position bounding box, minimum corner"},
    {"root_max_m", IndexDType::f32, RowShape::vec3, "m",
     "root position bounding box, maximum corner"},
    {"kd_min", IndexDType::f32, RowShape::segments3, "sqrt(J)",
     "per-element minimum of kd_features over the clip"},
    {"kd_max", IndexDType::f32, RowShape::segments3, "sqrt(J)",
     "per-element maximum of kd_features over the clip"},
    {"local_rotation_min", IndexDType::f32, RowShape::joints4, "1",
     "per-component minimum of local_rotations (w, x, y, z) over the clip"},
    {"local_rotation_max", IndexDType::f32, RowShape::joints4, "1",
     "per-component maximum of local_rotations (w, x, y, z) over the clip"},
    {"rotation_channel_min_deg", IndexDType::f32, RowShape::joints3, "deg",
     "range of motion: minimum of each rotation channel as written in the file, in the joint's "
     "channel order "
     "(skeleton dataset channels); 0 for absent channels"},
    {"rotation_channel_max_deg", IndexDType::f32, RowShape::joints3, "deg",
     "range of motion: maximum of each rotation channel, as rotation_channel_min_deg"},
};
inline constexpr std::size_t kClipBoundFieldCount =
    sizeof(kClipBoundFields) / sizeof(kClipBoundFields[0]);

/// A frame field an index no longer stores from schema version `since` on:
/// Index::array derives it on first use from local_rotations and
/// joint_positions_m (dynamics/index_frames.hpp). From schema 3 the build
/// derives its h_scan, kd_features, bounds and energy prefix sums from the
/// same stored rows with the same code, so what a reader derives is bit for
/// bit what the bounds were made from. Older schemas store the field.
struct DerivedFrameField {
  std::string_view name;
  std::int64_t since = 0;
};
inline constexpr DerivedFrameField kIndexDerivedFrameFields[] = {
    {"world_rotations", 2},
    {"segment_com_m", 2},
    {"segment_com_velocity_mps", 2},
    {"segment_angular_velocity_radps", 2},
    {"h_scan", 3},
    {"kd_features", 3}};
/// Whether an index of `schema_version` stores frame field `name`.
bool frame_field_stored(std::string_view name, std::int64_t schema_version);

/// Index of a field by name in one of the tables above, -1 if absent.
int find_field(std::span<const IndexFieldSpec> table, std::string_view name);

/// How this build obtained a clip.
enum class ClipStatus : std::uint8_t { parsed_new = 0, parsed_changed = 1, reused = 2 };
/// Where a clip's labels came from.
enum class LabelSource : std::uint8_t { none = 0, file_name = 1, sidecar = 2, sidecar_cfg = 3 };
const char* clip_status_name(ClipStatus s);
const char* label_source_name(LabelSource s);

// ---------------------------------------------------------------------------
// Runtime records

struct IndexClip {
  /// Absolute path of the source file at build time.
  std::string path;
  std::uint64_t size_bytes = 0;
  /// Modification time, nanoseconds since the Unix epoch.
  std::int64_t mtime_ns = 0;
  /// XXH64 of the file's bytes.
  std::uint64_t content_hash = 0;
  std::uint32_t skeleton = 0;
  /// Row in the skeleton's clip_bounds arrays.
  std::uint64_t row = 0;
  /// Rows [frame_start, frame_start + frame_count) of the skeleton's frame arrays.
  std::uint64_t frame_start = 0;
  std::uint64_t frame_count = 0;
  std::uint64_t block16_start = 0;
  std::uint64_t block64_start = 0;
  double frame_time_s = 0.0;
  /// Metres per file unit used; `unit` is its name (units.hpp).
  double unit_scale_m = 1.0;
  std::string unit;
  ClipStatus status = ClipStatus::parsed_new;
  LabelSource label_source = LabelSource::none;
  /// Parallel to Index::label_keys(); "" = no label for that key.
  std::vector<std::string> labels;
};

struct IndexSkeleton {
  /// Skeleton::id() of the skeleton as indexed (length scales applied).
  std::uint64_t id = 0;
  /// Rebuilt runtime skeleton (metres, channel maps, translation scales).
  Skeleton skeleton;
  /// Per joint: "Xposition Yposition Zposition Zrotation Xrotation Yrotation" as in the file.
  std::vector<std::string> channels;
  /// Body of the index's character on this skeleton (masses, COMs, inertias).
  Body body;
  /// The root joint whose position is root_position_m (the pelvis).
  int root_joint = 0;
  /// Joints with mass (DynamicsModel::segments): the S rows of segment arrays.
  std::vector<int> segments;
  std::uint64_t frame_count = 0;
  std::uint64_t block16_count = 0;
  std::uint64_t block64_count = 0;
  /// Clip indices (into Index::clips()) in row order.
  std::vector<std::size_t> clips;
};

/// A file that was not indexed (/skipped, one row each).
struct IndexSkippedFile {
  std::string path;
  /// "line N: what was expected", "empty file", an I/O error, or why an input is missing.
  std::string reason;
  /// Size and modification time (ns since the Unix epoch) when it was tried;
  /// 0 for a missing input. An incremental build does not parse an unchanged
  /// bad file again.
  std::uint64_t size_bytes = 0;
  std::int64_t mtime_ns = 0;
};

/// The root attributes (index_tables.hpp kIndexAttributes lists them with
/// the fixed texts between them). The writer fills one and writes it; the
/// reader reads it back. Defaults: the current format tag, schema version and
/// block sizes.
struct IndexInfo {
  std::string format = kIndexFormat;
  std::int64_t schema_version = kIndexSchemaVersion;
  /// "mocap-index VERSION": a previous index built by another tool is not reused.
  std::string build_tool;
  /// ISO 8601 UTC, e.g. "2026-11-22T07:29:07Z".
  std::string build_time_utc;
  /// The character as canonical JSON (sorted keys), its name and total mass.
  std::string character_json;
  std::string character_name;
  double character_total_mass_kg = 0.0;
  /// T of the kd features, seconds.
  double transition_time_s = 0.0;
  /// --unit given at build time ("auto" = detected per clip).
  std::string unit_option;
  /// Compression level of the frame arrays (0 = none, 1..9 deflate).
  int deflate_level = 0;
  /// Constants of the energy model the dynamics were computed with.
  EnergyParams energy_params;
  /// Frames per block of blocks16 / blocks64 (kIndexBlockSizes).
  std::vector<double> block_sizes = {static_cast<double>(kIndexBlockSizes[0]),
                                     static_cast<double>(kIndexBlockSizes[1])};
  std::uint64_t clip_count = 0;
  std::uint64_t frame_count = 0;
  std::uint64_t skeleton_count = 0;
  std::uint64_t skipped_count = 0;
};

/// A loaded array: rows x row_elements values, one of f32 / f64 filled.
struct IndexArray {
  std::uint64_t rows = 0;
  std::uint64_t row_elements = 0;
  std::vector<float> f32;
  std::vector<double> f64;
  /// Rows [first, first + count) as float (f32 arrays only).
  std::span<const float> rows_f32(std::uint64_t first, std::uint64_t count) const {
    return std::span<const float>(f32).subspan(first * row_elements, count * row_elements);
  }
};

struct IndexOpenOptions {
  /// Hash the whole file against the user block (reads every byte; `verify` does it).
  bool verify_file_checksum = false;
};

/// The runtime index. Immutable after open; array loads are thread-safe.
class Index {
 public:
  /// Opens and validates: user block (length), format tag, schema version
  /// ("unsupported index schema version N (this build reads M)"), then the
  /// clip, skeleton and skipped tables and their mutual consistency. Throws
  /// InputError naming the file and the dataset.
  static Index open(const std::filesystem::path& path, const IndexOpenOptions& options = {});

  Index(Index&&) noexcept;
  Index& operator=(Index&&) noexcept;
  ~Index();

  const std::filesystem::path& path() const;
  const IndexInfo& info() const;
  const std::vector<IndexClip>& clips() const;
  const std::vector<std::string>& label_keys() const;
  /// Label `key` of clip `c`, "" when absent.
  std::string label(std::size_t c, std::string_view key) const;
  const std::vector<IndexSkeleton>& skeletons() const;
  const std::vector<IndexSkippedFile>& skipped() const;
  /// Total frames over all skeletons.
  std::uint64_t frame_count() const;

  /// One array of skeleton `k`: group is "frames", "blocks16", "blocks64" or
  /// "clip_bounds", field a name from the matching table. Loaded on first use
  /// (validated against its checksum), then shared.
  const IndexArray& array(std::uint32_t skeleton, std::string_view group,
                          std::string_view field) const;
  /// Several arrays of skeleton `k`'s group, as array() gives each, in the
  /// order of `fields`. The frame fields the index does not store
  /// (frame_field_stored) that are not loaded yet are derived together, in
  /// one pass over the stored rows (each clip's dynamics computed once for
  /// all of them), where array() derives one field a pass.
  std::vector<const IndexArray*> arrays(std::uint32_t skeleton, std::string_view group,
                                        std::span<const std::string_view> fields) const;
  /// The rows of a float array (group and field as for array()) read in
  /// blocks of `rows_per_block` rows, in order: fn(first_row, row_count,
  /// values) with row_count x row_elements values, valid during the call.
  /// Nothing is kept; after the last block the rows' checksum is compared
  /// (InputError on a mismatch: a consumer keeps nothing it read until the
  /// call returns). Thread-safe; the HDF5 library is not locked during fn.
  void stream_rows(std::uint32_t skeleton, std::string_view group, std::string_view field,
                   std::uint64_t rows_per_block,
                   const std::function<void(std::uint64_t, std::uint64_t, const float*)>& fn) const;
  /// A clip's rows of a frame field (f32 fields).
  std::span<const float> clip_frames(std::size_t clip, std::string_view field) const;
  /// A clip's energy prefix sums P (frame_count values, P[0] = 0, joules):
  /// the clip's own energy for its frames s..e is P[e] - P[s].
  std::span<const double> clip_energy_prefix(std::size_t clip) const;
  /// The dynamics model of skeleton k for the index's character (rebuilt
  /// from the stored skeleton, body and energy parameters).
  DynamicsModel dynamics_model(std::uint32_t skeleton) const;

 private:
  /// stream_rows of a frame field the index does not store
  /// (frame_field_stored): whole clips at a time (at least rows_per_block
  /// rows, but for the last), derived from their stored local rotations and
  /// joint positions as those are read (index_frames.hpp); nothing is kept,
  /// and the stored arrays' checksums are compared after the last block.
  void stream_derived_rows(
      std::uint32_t skeleton, std::string_view field, std::uint64_t rows_per_block,
      const std::function<void(std::uint64_t, std::uint64_t, const float*)>& fn) const;
  /// The same for several fields at once: fn(first_row, row_count, rows)
  /// with rows[i] holding field i's row_count rows.
  void stream_derived_rows(std::uint32_t skeleton, std::span<const std::string_view> fields,
                           std::uint64_t rows_per_block,
                           const std::function<void(std::uint64_t, std::uint64_t,
                                                    std::span<const float* const>)>& fn) const;
  /// Derives the frame fields among `fields` that the index does not store
  /// and that are not loaded yet, in one pass, and keeps them (array()'s
  /// cache; a thread that derived one first keeps its copy).
  void derive_arrays(std::uint32_t skeleton, std::span<const std::string_view> fields) const;

  struct Impl;
  explicit Index(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// ---------------------------------------------------------------------------
// Integrity and verification

/// Writes the user block of a finished index file (length + XXH64 of the
/// bytes after the user block). Throws InputError on I/O errors.
void seal_index_file(const std::filesystem::path& path);
/// Checks the user block: magic, length (truncation), and when `hash` the
/// XXH64 of the content. Throws InputError with a clear reason.
void check_index_file(const std::filesystem::path& path, bool hash);

struct IndexVerifyReport {
  bool ok = false;
  /// Human-readable findings, one per problem (empty when ok).
  std::vector<std::string> problems;
  std::uint64_t datasets_checked = 0;
  std::uint64_t bytes = 0;
};
/// Everything `mocap-index verify` checks: user block and file checksum,
/// format tag and version, every expected dataset with its dtype and shape,
/// internal consistency (ranges, counts, finite values, unit quaternions,
/// bounds containing their frames), and every dataset's checksum. Never
/// throws for a damaged file: damage is reported in `problems`.
IndexVerifyReport verify_index(const std::filesystem::path& path);

}  // namespace mocap
