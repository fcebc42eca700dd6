#pragma once
// `mocap-search energy`: h and g for the transition between two capture frames
// (docs/cli.md, docs/energy.md).
//
//   mocap-search energy --from FILE:FRAME --to FILE:FRAME [--transition-time S]
//                       [--character C.json] [--unit U] [--json]
//
// FRAME is 0-based. Each state is that frame with its clip velocities and
// accelerations (finite differences over its own clip, dynamics.hpp). The
// character's body is built on the --from file's skeleton (length scales
// applied) and used for both. When the --to file is another rig
// (retarget.hpp same_rig), its clip is retargeted onto the --from skeleton
// (every frame, so its rates are the retargeted motion's; the --from clip's
// frames give the rig's typical pose, typical_local_rotations) and h and g sum
// only the terms of the segments both rigs share (RetargetMap::compared), as
// the search compares a query frame of another rig with database frames.
// --unit applies to both files (default: detected per file).
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "mocap/common/io/units.hpp"

namespace mocap {

/// "FILE:FRAME" split at the last ':'; throws InputError("<option>", 0, ...) when
/// the frame is not a non-negative integer or the file part is empty.
struct FrameSpec {
  std::filesystem::path file;
  std::size_t frame = 0;
};
FrameSpec parse_frame_spec(const std::string& text, const std::string& option);

struct EnergyCommandOptions {
  FrameSpec from;
  FrameSpec to;
  /// T of the transition, seconds (> 0).
  double transition_time_s = 0.5;
  /// Character file (docs/character.md); empty = default character.
  std::filesystem::path character;
  /// nullopt = detect per file (units.hpp).
  std::optional<LengthUnit> unit;
};

struct EnergyTermReport {
  std::string name;
  bool is_joint = false;  // "joint" vs "segment"
  double h_J = 0.0;
  double g_J = 0.0;
};

struct EnergyReport {
  double h_J = 0.0;
  double g_J = 0.0;
  std::vector<EnergyTermReport> terms;
  // Context (also printed).
  FrameSpec from;
  FrameSpec to;
  double transition_time_s = 0.0;
  std::string character;
  std::string from_unit;
  std::string to_unit;
  double total_mass_kg = 0.0;
  std::size_t from_contacts = 0;
  std::size_t to_contacts = 0;
  double residual_work_J = 0.0;
  double residual_impulse_J = 0.0;
  /// The --to file is another rig, retargeted onto the --from skeleton: h_J,
  /// g_J and `terms` cover only the compared segments, whose classes
  /// compared_classes names (retarget.hpp class_key_name).
  bool cross_rig = false;
  std::vector<std::string> compared_classes;
};

/// Runs the command. Bad input (unreadable / malformed file, frame out of
/// range, a --to skeleton of another rig that cannot be retargeted (no
/// pelvis), bad character file, T <= 0) throws InputError.
EnergyReport run_energy_command(const EnergyCommandOptions& options);

/// {"h_J", "g_J", "terms": [{"name", "kind", "h_J", "g_J"}], "from": {"file", "frame"},
///  "to": {...}, "transition_time_s", "character", "total_mass_kg", "unit": {"from", "to"},
///  "contacts": {"from", "to"}, "residual": {"work_J", "impulse_J"}, "cross_rig",
///  "compared_classes" (only when cross_rig)} on one line.
std::string energy_report_json(const EnergyReport& report);
/// Human-readable table.
std::string energy_report_text(const EnergyReport& report);

}  // namespace mocap
