#pragma once
// `mocap-index inspect` and `mocap-index summary`: look at capture files
// without building an index.
#include <cstddef>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "mocap/common/io/units.hpp"
#include "mocap/indexer/asf_pairing.hpp"

namespace mocap {

struct InspectOptions {
  std::filesystem::path file;
  std::size_t frame = 0;                           // 0-based
  std::optional<LengthUnit> unit;                  // nullopt: detect_unit()
  std::optional<UpAxis> up;                        // nullopt: detect_up_axis()
  std::optional<std::filesystem::path> character;  // nullopt: default 70 kg male
  /// An AMC file's ASF and frame time; its unit is the ASF's ("asf", `unit`
  /// is not used), its up axis as for BVH.
  AmcReadOptions amc;
};

/// One frame of a BVH file, or of an AMC file (with its ASF, asf_pairing.hpp), in world space
/// (metres, Y up), the contract of docs/cli.md:
/// {"file", "frames", "frame_time_s", "unit", "unit_scale_m", "up", "total_mass_kg",
///  "joints": [{"name", "parent", "position_m"}],
///  "segments": [{"joint", "joint_index", "class", "side", "mass_kg", "com_m"}]}.
/// "up" is the file's up axis ("y" or "z", declared or detected); a Z-up file
/// is rotated to Y up (units.hpp: rotate_to_y_up). Segments are the joints with mass (class none is
/// not a segment). The character's length scales are applied before forward kinematics. Throws
/// InputError for a bad file, frame or character.
nlohmann::json inspect_frame(const InspectOptions& opt);

/// Per-clip facts for the summary (one line each).
struct ClipSummary {
  std::string file;
  bool ok = false;
  std::string error;  // when !ok: "file:line: what was expected"
  std::size_t frames = 0;
  std::size_t joints = 0;
  double frame_time_s = 0.0;
  std::string unit;  // declared or detected
  double unit_scale_m = 0.0;
  double height_m = 0.0;           // standing height (units.hpp)
  double skeleton_height_m = 0.0;  // skeleton height (units.hpp; what detect_unit uses)
  std::size_t bytes = 0;
};

/// Parses every file (TBB-parallel, results in input order); a Z-up file
/// (declared or detected) is rotated to Y up before its heights are measured.
std::vector<ClipSummary> summarize_files(const std::vector<std::filesystem::path>& files,
                                         std::optional<LengthUnit> unit,
                                         std::optional<UpAxis> up = std::nullopt);

nlohmann::json to_json(const ClipSummary& s);

}  // namespace mocap
