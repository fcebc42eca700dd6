#pragma once
// `mocap-search energy`: h and g for the transition between two capture frames
// (docs/cli.md, docs/energy.md).
//
//   mocap-search energy --from FILE:FRAME --to FILE:FRAME [--transition-time S]
//                       [--character C.json] [--unit U] [--json]
//
// FRAME is 0-based. Each state is that frame with its clip velocities and
// accelerations (finite differences over its own clip, dynamics.hpp). Both
// files must have the same joint names and parents; the character's body is
// built on the --from file's skeleton (length scales applied) and used for
// both. --unit applies to both files (default: detected per file).
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "mocap/common/units.hpp"

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
};

/// Runs the command. Bad input (unreadable / malformed file, frame out of
/// range, different skeletons, bad character file, T <= 0) throws InputError.
EnergyReport run_energy_command(const EnergyCommandOptions& options);

/// {"h_J", "g_J", "terms": [{"name", "kind", "h_J", "g_J"}], "from": {"file", "frame"},
///  "to": {...}, "transition_time_s", "character", "total_mass_kg", "unit": {"from", "to"},
///  "contacts": {"from", "to"}, "residual": {"work_J", "impulse_J"}} on one line.
std::string energy_report_json(const EnergyReport& report);
/// Human-readable table.
std::string energy_report_text(const EnergyReport& report);

}  // namespace mocap
