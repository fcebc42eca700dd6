#pragma once
// The index's record tables and root attributes, described once: column
// tables that the writer (indexer/src/index_writer.cpp) and the reader
// (common/src/io/index_reader.cpp) both walk, in this order (the order datasets
// and attributes are created in the file). docs/index-format.md is their
// prose form.
//
//   /clips      one row per clip (IndexClip): kClipColumns, then
//               label_keys [K] (strings) and labels [C, K] (strings, "" = none)
//   /skipped    one row per file that was not indexed (IndexSkippedFile):
//               kSkippedColumns
//   /           root attributes (IndexInfo): kIndexAttributes
//
// Stored types follow from the member's C++ type: std::string -> variable-
// length UTF-8 string; std::uint64_t / std::int64_t / std::uint32_t ->
// little-endian integer of that width and sign; double -> float64;
// ClipStatus / LabelSource -> uint8 enumeration whose members are named by
// clip_status_name / label_source_name (index_enum_members). Root attributes:
// integers of any width are int64, std::vector<double> a float64 array, a
// fixed text (the units) a string the reader requires but does not interpret.
// Every dataset carries the attributes unit, description and checksum_xxh64
// (index.hpp).
#include <cstdint>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "mocap/common/dynamics/dynamics.hpp"
#include "mocap/common/io/index.hpp"

namespace mocap {

/// One dataset of a record table: one row per record, the record's `member`.
template <class Record>
struct IndexColumn {
  using Member = std::variant<std::string Record::*, std::uint64_t Record::*,
                              std::int64_t Record::*, std::uint32_t Record::*, double Record::*,
                              ClipStatus Record::*, LabelSource Record::*>;
  const char* name;
  /// SI unit stored in the `unit` attribute ("" for strings, enums, indices).
  const char* unit;
  const char* description;
  Member member;
};

/// /clips, one row per clip, sorted by path.
inline constexpr IndexColumn<IndexClip> kClipColumns[] = {
    {"path", "", "absolute path of the source file; clips are sorted by it", &IndexClip::path},
    {"size_bytes", "B", "source file size", &IndexClip::size_bytes},
    {"mtime_ns", "ns", "source file modification time since the Unix epoch", &IndexClip::mtime_ns},
    {"content_xxh64", "", "XXH64 (seed 0) of the source file's bytes", &IndexClip::content_hash},
    {"skeleton", "", "group /skeletons/<skeleton> holding the clip's rows", &IndexClip::skeleton},
    {"row", "", "row of the clip in its skeleton's clip_bounds arrays", &IndexClip::row},
    {"frame_start", "", "first row of the clip in its skeleton's frames arrays",
     &IndexClip::frame_start},
    {"frame_count", "", "number of frames (rows) of the clip", &IndexClip::frame_count},
    {"block16_start", "", "first row of the clip in blocks16 (ceil(frame_count / 16) rows)",
     &IndexClip::block16_start},
    {"block64_start", "", "first row of the clip in blocks64 (ceil(frame_count / 64) rows)",
     &IndexClip::block64_start},
    {"frame_time_s", "s", "seconds between frames (the file's Frame Time)",
     &IndexClip::frame_time_s},
    {"unit_scale_m", "m", "metres per file length unit", &IndexClip::unit_scale_m},
    {"unit", "", "file length unit, declared (--unit) or detected", &IndexClip::unit},
    {"status", "",
     "how this build obtained the clip: parsed (new file), parsed (changed file), reused from "
     "the previous index",
     &IndexClip::status},
    {"label_source", "",
     "where the labels came from: none, the file name, the NAME.json sidecar, the sidecar "
     "resolved via cfg/*_label.txt",
     &IndexClip::label_source},
};

/// /clips/label_keys and /clips/labels, after kClipColumns.
inline constexpr const char* kLabelKeysDescription = "label names, the columns of labels";
inline constexpr const char* kLabelsDescription = "label of each clip per key (\"\" = none)";

/// /skipped, one row per file that was not indexed.
inline constexpr IndexColumn<IndexSkippedFile> kSkippedColumns[] = {
    {"path", "", "files that were not indexed", &IndexSkippedFile::path},
    {"reason", "", "why (file:line: what was expected, or an I/O error)",
     &IndexSkippedFile::reason},
    {"size_bytes", "B", "file size when it was tried (0 for a missing input)",
     &IndexSkippedFile::size_bytes},
    {"mtime_ns", "ns", "modification time when it was tried, since the Unix epoch",
     &IndexSkippedFile::mtime_ns},
};

/// One root attribute: a member of IndexInfo, a member of its energy_params,
/// or a fixed text.
struct IndexAttribute {
  using Value =
      std::variant<const char*, std::string IndexInfo::*, double IndexInfo::*,
                   std::int64_t IndexInfo::*, std::uint64_t IndexInfo::*, int IndexInfo::*,
                   std::vector<double> IndexInfo::*, double EnergyParams::*>;
  const char* name;
  Value value;
};

/// The root attributes. format and schema_version come first: the reader
/// checks them before it reads anything else.
inline constexpr IndexAttribute kIndexAttributes[] = {
    {"format", &IndexInfo::format},
    {"schema_version", &IndexInfo::schema_version},
    {"description",
     "motion-capture index: clips, skeletons, per-frame kinematics and dynamics, bounds "
     "(docs/index-format.md)"},
    {"length_unit", "m"},
    {"time_unit", "s"},
    {"mass_unit", "kg"},
    {"energy_unit", "J"},
    {"angle_unit", "rad (quaternions are unitless; *_deg datasets are degrees)"},
    {"up_axis", "Y"},
    {"build_tool", &IndexInfo::build_tool},
    {"build_time_utc", &IndexInfo::build_time_utc},
    {"character", &IndexInfo::character_json},
    {"character_name", &IndexInfo::character_name},
    {"character_total_mass_kg", &IndexInfo::character_total_mass_kg},
    {"transition_time_s", &IndexInfo::transition_time_s},
    {"unit_option", &IndexInfo::unit_option},
    {"deflate_level", &IndexInfo::deflate_level},
    {"gravity_mps2", &EnergyParams::gravity_mps2},
    {"ground_height_m", &EnergyParams::ground_height_m},
    {"contact_height_m", &EnergyParams::contact_height_m},
    {"contact_speed_mps", &EnergyParams::contact_speed_mps},
    {"friction_coefficient", &EnergyParams::friction_coefficient},
    {"contact_patch_radius_m", &EnergyParams::contact_patch_radius_m},
    {"block_sizes", &IndexInfo::block_sizes},
    {"clip_count", &IndexInfo::clip_count},
    {"frame_count", &IndexInfo::frame_count},
    {"skeleton_count", &IndexInfo::skeleton_count},
    {"skipped_count", &IndexInfo::skipped_count},
};

/// (name, value) of every value of the enumeration: the members of its
/// stored uint8 enumeration type, values 0, 1, ...
std::vector<std::pair<std::string, int>> index_enum_members(ClipStatus);
std::vector<std::pair<std::string, int>> index_enum_members(LabelSource);

}  // namespace mocap
